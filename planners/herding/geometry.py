"""Hull geometry for herding: convex hull, extended hull (Definition 6.3.1), arc lengths,
minimum enclosing circle. Vectorised with numpy; degenerate herds never raise."""

from __future__ import annotations

import bisect
import math
from dataclasses import dataclass

import numpy as np
from scipy.spatial import ConvexHull, QhullError

try:  # scipy's qhull wrapper behind ConvexHull (see _qhull_2d)
    from scipy.spatial._qhull import _Qhull as _QHULL
except ImportError:  # pragma: no cover - another scipy layout: ConvexHull alone
    _QHULL = None

from droneplan.core.validation import check_array, check_positive, check_real

__all__ = [
    "convex_hull",
    "HullTracker",
    "MITRE_LIMIT",
    "extended_hull_vertices",
    "ExtendedHull",
    "min_enclosing_circle",
]


def convex_hull(points: np.ndarray) -> np.ndarray:
    """Counter-clockwise convex-hull vertices of (n, 2) points, m.

    Degenerate input gives 1 vertex (all points coincide) or 2 (all collinear:
    the two extreme points); a hull thinner than 1e-9 of its extent counts as collinear.
    """
    return _convex_hull(check_array("points", points, shape=(None, 2), min_rows=1))


def _qhull_2d(pts: np.ndarray) -> tuple[np.ndarray, float, float]:
    """``ConvexHull(pts)``'s (vertices, volume, area) of (n, 2) points: ccw vertex indices, the
    enclosed area (m^2) and the perimeter (m). QhullError on flat input, as ConvexHull.

    ConvexHull also builds the facet, neighbour and equation arrays, which cost as much as the
    hull itself on the herders' hundred-odd points; this runs the same qhull calls (mode "i",
    option "Qt", triangulated, the 2-D extremes in order) on scipy's qhull wrapper and reads only
    these three, so the result is ConvexHull's. Should that wrapper change, ConvexHull is used.
    """
    lean = None if _QHULL is None else _lean_qhull_2d(pts)
    if lean is not None:
        return lean
    hull = ConvexHull(pts)
    return hull.vertices, float(hull.volume), float(hull.area)


def _lean_qhull_2d(pts: np.ndarray) -> tuple[np.ndarray, float, float] | None:
    """:func:`_qhull_2d` on scipy's qhull wrapper; None when that wrapper takes other arguments
    (another scipy)."""
    try:
        q = _QHULL(b"i", pts, None, required_options=b"Qt")
    except (TypeError, AttributeError):
        return None
    try:
        q.triangulate()
        vertices = q.get_extremes_2d()
        volume, area = q.volume_area()
    finally:
        q.close()
    return vertices, float(volume), float(area)


def _convex_hull(pts: np.ndarray) -> np.ndarray:
    """:func:`convex_hull` of checked points (HullTracker's rebuild)."""
    if pts.shape[0] >= 3:
        try:
            cand = _hull_candidates(pts)
            vertices, volume, area = _qhull_2d(pts if cand is None else pts[cand])
            if volume > 1e-9 * area * area:  # 2-D: volume = area, area = perimeter
                return pts[vertices if cand is None else cand[vertices]]
        except QhullError:
            pass  # Qhull rejects flat input: collinear or coincident points are handled below
    c = pts.mean(axis=0)
    extent = float(np.max(np.abs(pts - c))) if pts.shape[0] > 1 else 0.0
    if extent <= 1e-12:
        return pts[:1].copy()
    # collinear: extremes along the principal direction
    _, _, vt = np.linalg.svd(pts - c, full_matrices=False)
    proj = (pts - c) @ vt[0]
    return pts[[int(np.argmin(proj)), int(np.argmax(proj))]]


_PREFILTER_MIN = 1500
"""Herds of at least this many animals are prefiltered before qhull (below, qhull alone is faster)."""


def _octagon(pts: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The octagon of the extreme points of (n, 2) ``pts`` along x, y, x + y and x - y: the
    indices of its corners (8,), ccw (min x, min x+y, min y, max x-y, max x, max x+y, max y,
    min x-y), the corners (8, 2) and the edge vectors from each corner to the next (8, 2), m."""
    x, y = pts[:, 0], pts[:, 1]
    s, d = x + y, x - y
    ext = np.array(
        [x.argmin(), s.argmin(), y.argmin(), d.argmax(), x.argmax(), s.argmax(), y.argmax(), d.argmin()]
    )
    corner = pts[ext]
    return ext, corner, np.roll(corner, -1, axis=0) - corner


def _hull_candidates(pts: np.ndarray) -> np.ndarray | None:
    """Indices (ascending) of the points that can be hull vertices, or None to keep them all.

    The Akl-Toussaint throw-away: the extreme points along x, y, x + y and x - y span an
    octagon inside the hull; a point strictly inside it (by more than a rounding margin) is
    no hull vertex. qhull then runs on the few hundred points left instead of the whole herd
    and returns the same vertices in the same order (the input order of the survivors is kept).
    """
    n = pts.shape[0]
    if n < _PREFILTER_MIN:
        return None
    x, y = pts[:, 0], pts[:, 1]
    ext, corner, edge = _octagon(pts)
    scale = float(np.max(np.abs(corner - corner.mean(axis=0)))) + 1.0
    keep = np.zeros(n, dtype=bool)
    for (ax, ay), (ex, ey) in zip(corner.tolist(), edge.tolist(), strict=True):
        # cross((e), (p - a)) > 0: strictly left of the ccw edge, inside; keep the rest (and a margin)
        if ex == 0.0 and ey == 0.0:  # two extremes coincide: no edge
            continue
        margin = 1e-9 * scale * (abs(ex) + abs(ey))
        keep |= ex * (y - ay) - ey * (x - ax) <= margin
    keep[ext] = True
    cand = np.flatnonzero(keep)
    return None if cand.size == n else cand


class HullTracker:
    """:func:`convex_hull` of a herd observed again and again, moving a little each time.

    Calling it with each new herd gives exactly ``convex_hull(points)`` (the same vertices in
    the same order), most calls from qhull on a few candidate animals instead of the whole
    herd. The candidates are the animals within ``margin`` (m) of the hull boundary when it was
    last built on the whole herd. While no animal has moved more than ``margin / 2`` in all
    since then (the sum of the largest move of each call, measured, not assumed), no other
    animal can be a vertex: it was deeper than ``margin`` in the old hull, moved less than
    margin / 2, and the hull shrank by less than margin / 2 (the hull of points that each moved
    at most D contains the old hull shrunk by D). Then it rebuilds. For a herd large enough
    for :func:`convex_hull`'s own prefilter (1500 or more) the rebuild measures the depth only
    of the animals near the prefilter's octagon (which lies inside the hull, so an animal deep
    inside the octagon is deeper still inside the hull). Herds of fewer than 64 animals and
    degenerate hulls always take :func:`convex_hull` directly.

    margin: depth of the candidate band, m (> 0).
    """

    def __init__(self, margin: float = 20.0) -> None:
        self.margin = check_positive("margin", margin)
        self._prev: np.ndarray | None = None
        self._cand: np.ndarray | None = None
        self._moved = 0.0

    def __call__(self, points: np.ndarray) -> np.ndarray:
        """Counter-clockwise convex-hull vertices of (n, 2) points, m (as :func:`convex_hull`)."""
        return self._track(check_array("points", points, shape=(None, 2), min_rows=1))

    def _track(self, pts: np.ndarray) -> np.ndarray:
        """:meth:`__call__` of checked points (the herders' own, checked where they enter)."""
        prev, cand = self._prev, self._cand
        if prev is not None and cand is not None and prev.shape == pts.shape:
            d = pts - prev
            dx, dy = d[:, 0], d[:, 1]
            self._moved += math.sqrt(float(np.max(dx * dx + dy * dy)))
            if self._moved < 0.45 * self.margin:  # margin / 2, less a safety for rounding
                self._prev = pts
                try:
                    vertices, volume, area = _qhull_2d(pts[cand])
                    if volume > 1e-9 * area * area:
                        return pts[cand[vertices]]
                except QhullError:
                    pass  # degenerate: the whole herd below
        return self._rebuild(pts)

    def _rebuild(self, pts: np.ndarray) -> np.ndarray:
        V = _convex_hull(pts)
        self._prev, self._moved, self._cand = pts, 0.0, None
        if V.shape[0] >= 3 and pts.shape[0] >= _TRACK_MIN:
            # a large herd: first the animals within margin of the prefilter's octagon (inside
            # the hull, so the depth there is no larger), then the exact depth of those only
            near = _octagon_band(pts, self.margin) if pts.shape[0] >= _PREFILTER_MIN else None
            sub = pts if near is None else pts[near]
            e = V[np.arange(1, V.shape[0] + 1) % V.shape[0]] - V
            normal = np.column_stack([e[:, 1], -e[:, 0]]) / np.linalg.norm(e, axis=1)[:, None]  # outward
            # depth of each animal inside the hull: its least distance to an edge's line
            depth = np.min(np.sum(normal * V, axis=1)[None, :] - sub @ normal.T, axis=1)
            band = np.flatnonzero(depth < self.margin)
            self._cand = band if near is None else near[band]
        return V


def _octagon_band(pts: np.ndarray, margin: float) -> np.ndarray:
    """Indices (ascending) of the points less than ``margin`` (m) inside the octagon of the
    extreme points along x, y, x + y and x - y, or outside it (a superset of the points within
    ``margin`` of the hull boundary: the octagon lies inside the hull)."""
    x, y = pts[:, 0], pts[:, 1]
    _, corner, edge = _octagon(pts)
    keep = np.zeros(pts.shape[0], dtype=bool)
    for (ax, ay), (ex, ey) in zip(corner.tolist(), edge.tolist(), strict=True):
        length = math.hypot(ex, ey)
        if length == 0.0:  # two extremes coincide: no edge
            continue
        # distance inside the ccw edge's line (cross product / length), with a rounding allowance
        keep |= ex * (y - ay) - ey * (x - ax) < (margin * (1 + 1e-9) + 1e-9) * length
    return np.flatnonzero(keep)


_POINT_AT_SCALAR_MAX = 12
"""Up to this many arc positions (one per drone), :meth:`ExtendedHull.point_at` works in plain
Python floats (faster than a dozen numpy calls on a few values)."""

_TRACK_MIN = 64
"""Herds of at least this many animals are tracked by :class:`HullTracker` (smaller ones: qhull
on all)."""


MITRE_LIMIT = 2.0
"""Largest distance of an extended-hull vertex from its animal, in units of d_s (a corner
sharper than 60 degrees is cut there; 2 * d_s = 60 m stays within Table 6.2's R_b = 100 m)."""


def extended_hull_vertices(
    hull: np.ndarray, d_s: float, *, mitre_limit: float = MITRE_LIMIT
) -> tuple[np.ndarray, np.ndarray]:
    """Extended hull (Definition 6.3.1): the hull offset outward by ``d_s`` with mitred corners.

    hull: (h, 2) ccw convex-hull vertices, m; d_s: offset, m (> 0).
    Returns (E, P): E (n_e, 2) ccw extended-hull vertices and P (n_e, 2) the animal
    (hull vertex) each one corresponds to. For h >= 3, ``E_i = P_i + d_s (n_{i-1} +
    n_i) / (1 + n_{i-1}.n_i)`` with n_i the outward unit normal of edge P_i P_{i+1}:
    the intersection of the two offset edge lines, so n_e = h and every edge is
    parallel to its hull edge at distance d_s (the same polygon as shapely's mitre
    buffer with an unlimited mitre) -- except at corners sharper than the mitre limit:
    there the mitre would run off far beyond the herd (a thin, nearly collinear herd has
    hairpin corners whose mitre is hundreds of metres long, and drones sent there bark at
    nothing), so E_i is put on the corner's outward bisector at
    ``mitre_limit * d_s`` from P_i (our rule; the thesis does not cover it). mitre_limit >= 1
    (inf: the unlimited mitre of Definition 6.3.1). Degenerate hulls (our rule, which the thesis
    does not cover): a point becomes the square of half-side d_s around it (its four
    corners correspond to the point), a segment the rectangle d_s around it with
    square caps (corners correspond to the nearer end).
    """
    d_s, mitre_limit = _check_offset(d_s, mitre_limit)
    return _extended_hull_vertices(check_array("hull", hull, shape=(None, 2), min_rows=1), d_s, mitre_limit)


def _check_offset(d_s: float, mitre_limit: float) -> tuple[float, float]:
    d_s = check_positive("d_s", d_s)
    mitre_limit = check_real("mitre_limit", mitre_limit, finite=False)
    if not mitre_limit >= 1:
        raise ValueError(f"mitre_limit must be >= 1, got {mitre_limit}")
    return d_s, mitre_limit


def _extended_hull_vertices(P: np.ndarray, d_s: float, mitre_limit: float) -> tuple[np.ndarray, np.ndarray]:
    """:func:`extended_hull_vertices` of a checked (h, 2) float hull ``P`` and checked offsets."""
    h = P.shape[0]
    if h == 1:
        corners = np.array([[1.0, -1.0], [1.0, 1.0], [-1.0, 1.0], [-1.0, -1.0]])
        return P[0] + d_s * corners, np.repeat(P, 4, axis=0)
    if h == 2:
        u = P[1] - P[0]
        u = u / np.linalg.norm(u)
        nrm = np.array([-u[1], u[0]])
        E = np.array(
            [P[0] - d_s * (u + nrm), P[1] + d_s * (u - nrm), P[1] + d_s * (u + nrm), P[0] + d_s * (nrm - u)]
        )
        return E, P[[0, 1, 1, 0]]
    nxt = np.arange(1, h + 1) % h  # index of the next vertex; np.roll by index, one gather each
    prv = np.arange(-1, h - 1) % h
    # per coordinate: the same values as the row norms and dot products, without numpy's
    # reductions over the short last axis
    e = P[nxt] - P
    ex, ey = e[:, 0], e[:, 1]
    length = np.sqrt(ex * ex + ey * ey)
    hx, hy = ex / length, ey / length  # unit edge directions
    # outward unit normals n_i = (hy, -hx); n_{i-1} . n_i = hx_prev hx + hy_prev hy
    dot = hy[prv] * hy + hx[prv] * hx
    # outward bisector (incoming minus outgoing edge direction: defined at hairpins too)
    bx, by = hx[prv] - hx, hy[prv] - hy
    blen = np.sqrt(bx * bx + by * by)
    cos_half = np.sqrt(np.minimum(np.maximum((1.0 + dot) / 2.0, 0.0), 1.0))  # np.clip's values, faster
    # mitre length d_s / cos(half the turn); capped at mitre_limit * d_s (our rule for sharp
    # corners of thin herds, where the mitre runs off beyond any barking range)
    reach = d_s * np.minimum(1.0 / np.maximum(cos_half, 1e-12), mitre_limit)
    E = np.empty_like(P)
    E[:, 0] = P[:, 0] + reach * (bx / blen)
    E[:, 1] = P[:, 1] + reach * (by / blen)
    return E, P.copy()


def _edges(E: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Edge vectors E_{i+1} - E_i (n_e, 2), their squared lengths and lengths of a closed polygon."""
    AB = E[np.arange(1, E.shape[0] + 1) % E.shape[0]] - E
    x, y = AB[:, 0], AB[:, 1]
    L2 = x * x + y * y
    return AB, L2, np.sqrt(L2)


@dataclass
class ExtendedHull:
    """A closed ccw polygon with arc-length parametrisation (m)."""

    vertices: np.ndarray
    """(n_e, 2) ccw vertices E_i, m."""
    animals: np.ndarray
    """(n_e, 2) hull vertex (animal) each E_i corresponds to, m."""
    cum: np.ndarray
    """(n_e + 1,) arc length of each vertex from E_0; cum[-1] = perimeter, m."""

    @classmethod
    def from_points(
        cls, animals: np.ndarray, d_s: float, *, mitre_limit: float = MITRE_LIMIT
    ) -> ExtendedHull:
        """Extended hull of a herd (n, 2) at offset d_s (m).

        mitre_limit: see :func:`extended_hull_vertices`.
        """
        d_s, mitre_limit = _check_offset(d_s, mitre_limit)
        E, P = _extended_hull_vertices(convex_hull(animals), d_s, mitre_limit)  # convex_hull checks the herd
        return cls.from_vertices(E, P)

    @classmethod
    def from_hull(cls, hull: np.ndarray, d_s: float, *, mitre_limit: float = MITRE_LIMIT) -> ExtendedHull:
        """Extended hull of a herd from its hull.

        hull: (h, 2) ccw hull vertices of the herd, m (as :func:`convex_hull` or
        :class:`HullTracker` return them); d_s: offset, m (> 0); mitre_limit: see
        :func:`extended_hull_vertices`.
        """
        d_s, mitre_limit = _check_offset(d_s, mitre_limit)
        return cls._from_checked_hull(
            check_array("hull", hull, shape=(None, 2), min_rows=1), d_s, mitre_limit
        )

    @classmethod
    def _from_checked_hull(
        cls, hull: np.ndarray, d_s: float, mitre_limit: float = MITRE_LIMIT
    ) -> ExtendedHull:
        """:meth:`from_hull` of a hull, offset and mitre limit already checked (the herders': the
        tracker's hull, HerdingParams.d_s)."""
        return cls.from_vertices(*_extended_hull_vertices(hull, d_s, mitre_limit))

    @classmethod
    def from_vertices(cls, E: np.ndarray, P: np.ndarray | None = None) -> ExtendedHull:
        """The polygon through vertices ``E`` (n_e, 2), m, in ccw order; ``P`` (n_e, 2) the animal
        each one corresponds to, m (default: the vertices themselves)."""
        E = np.asarray(E, dtype=float)
        _, _, seg = _edges(E)
        cum = np.zeros(E.shape[0] + 1)
        np.cumsum(seg, out=cum[1:])
        return cls(E, E.copy() if P is None else np.asarray(P, dtype=float), cum)

    def __post_init__(self) -> None:
        self._AB, self._L2, self._L = _edges(self.vertices)
        self._last_project: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray] | None = None
        self._lists: tuple[list[float], ...] | None = None  # plain-float copies for _point_at_scalar

    @property
    def perimeter(self) -> float:
        return float(self.cum[-1])

    @property
    def vertex_s(self) -> np.ndarray:
        """(n_e,) arc positions of the vertices, m."""
        return self.cum[:-1]

    def point_at(self, s) -> np.ndarray:
        """Points at arc positions ``s`` (any shape, taken mod perimeter), shape (..., 2)."""
        s = np.asarray(s, dtype=float)
        if s.ndim == 1 and s.size <= _POINT_AT_SCALAR_MAX and bool(np.isfinite(s).all()):
            return self._point_at_scalar(s.tolist())
        s = np.mod(s, self.perimeter)
        i = np.clip(np.searchsorted(self.cum, s, side="right") - 1, 0, len(self.vertices) - 1)
        L = self._L[i]
        t = np.divide(s - self.cum[i], L, out=np.zeros_like(s), where=L > 0)
        return self.vertices[i] + t[..., None] * self._AB[i]

    def _point_at_scalar(self, s: list[float]) -> np.ndarray:
        """:meth:`point_at` of a few finite arc positions in Python floats (the same operations,
        the same values to the last bit: Python's float % rounds as np.mod, bisect_right finds
        searchsorted's side="right")."""
        if self._lists is None:
            self._lists = (
                self.cum.tolist(),
                self._L.tolist(),
                self.vertices[:, 0].tolist(),
                self.vertices[:, 1].tolist(),
                self._AB[:, 0].tolist(),
                self._AB[:, 1].tolist(),
            )
        cum, Ls, vx, vy, ex, ey = self._lists
        M, last = cum[-1], len(vx) - 1
        out = []
        for si in s:
            sm = si % M
            i = min(max(bisect.bisect_right(cum, sm) - 1, 0), last)
            t = (sm - cum[i]) / Ls[i] if Ls[i] > 0 else 0.0
            out.append((vx[i] + t * ex[i], vy[i] + t * ey[i]))
        return np.array(out, dtype=float).reshape(len(s), 2)

    def project(self, q: np.ndarray):
        """Closest points on the polygon to points q (k, 2) (Remark 6.4.2, eq. 6.11).

        Returns (s, closest, edge): arc positions (k,), closest points (k, 2) and
        the index i of the closest edge E_i E_{i+1} (k,).
        """
        q = np.atleast_2d(np.asarray(q, dtype=float))
        last = self._last_project
        if last is not None and last[0].shape == q.shape and np.array_equal(last[0], q):
            return last[1].copy(), last[2].copy(), last[3].copy()
        A, AB, L2 = self.vertices, self._AB, self._L2
        # per coordinate (query x edge): the same values as the row dot products, without
        # numpy's reductions over the short last axis
        qx, qy = q[:, 0, None], q[:, 1, None]
        ax, ay, ex, ey = A[:, 0], A[:, 1], AB[:, 0], AB[:, 1]
        t = ((qx - ax) * ex + (qy - ay) * ey) / np.maximum(L2, 1e-300)
        t = np.minimum(np.maximum(t, 0.0), 1.0)  # np.clip's values (a zero may lose its sign), faster
        cx, cy = ax + t * ex, ay + t * ey  # the closest point of each edge
        dx, dy = qx - cx, qy - cy
        i = np.argmin(dx * dx + dy * dy, axis=1)
        k = np.arange(q.shape[0])
        s: np.ndarray = np.mod(self.cum[i] + t[k, i] * self._L[i], self.perimeter)
        close = np.column_stack([cx[k, i], cy[k, i]])
        self._last_project = (q.copy(), s.copy(), close.copy(), i.copy())
        return s, close, i

    def ray_s(self, origin: np.ndarray, angle: float) -> float:
        """Arc position where the ray from ``origin`` (inside) at ``angle`` (rad) leaves the polygon."""
        o = np.asarray(origin, dtype=float)
        u = np.array([math.cos(angle), math.sin(angle)])
        A = self.vertices
        AB = np.roll(A, -1, axis=0) - A
        den = u[0] * AB[:, 1] - u[1] * AB[:, 0]
        rel = A - o
        with np.errstate(divide="ignore", invalid="ignore"):
            lam = (rel[:, 0] * AB[:, 1] - rel[:, 1] * AB[:, 0]) / den
            mu = (rel[:, 0] * u[1] - rel[:, 1] * u[0]) / den
        ok = np.isfinite(lam) & (lam >= 0) & (mu >= -1e-12) & (mu <= 1 + 1e-12)
        if not ok.any():
            return float(self.project(o + u)[0][0])
        i = int(np.flatnonzero(ok)[np.argmin(lam[ok])])
        return float(
            np.mod(self.cum[i] + np.clip(mu[i], 0, 1) * (self.cum[i + 1] - self.cum[i]), self.perimeter)
        )


def min_enclosing_circle(points: np.ndarray) -> tuple[np.ndarray, float]:
    """Smallest circle containing the points (n, 2): (centre, radius), m.

    Welzl's randomised incremental algorithm (expected O(n)); apply it to the hull
    vertices for speed. Deterministic order (no shuffling) keeps it reproducible.
    The three nested loops ("the first point outside the current circle") scan the
    points with one vectorised distance test per scan; points the test cannot place
    safely inside are re-tested with the scalar test, so the result is the same as
    the point-by-point loops to the last bit.
    """
    return _min_enclosing_circle(check_array("points", points, shape=(None, 2), min_rows=1))


_Circle = tuple[np.ndarray, float]


def _norm(v: np.ndarray) -> float:
    """Bit-identical to np.linalg.norm of a 1-D float vector."""
    return math.sqrt(v.dot(v))


def _circ2(a: np.ndarray, b: np.ndarray) -> _Circle:
    c = (a + b) / 2
    return c, _norm(a - c)


def _circ3(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> _Circle:
    ax, ay = a
    bx, by = b
    cx, cy = c
    d = 2 * (ax * (by - cy) + bx * (cy - ay) + cx * (ay - by))
    if abs(d) < 1e-12:  # collinear: the widest pair
        return max((_circ2(a, b), _circ2(a, c), _circ2(b, c)), key=lambda t: t[1])
    na, nb, nc = ax * ax + ay * ay, bx * bx + by * by, cx * cx + cy * cy
    ux = (na * (by - cy) + nb * (cy - ay) + nc * (ay - by)) / d
    uy = (na * (cx - bx) + nb * (ax - cx) + nc * (bx - ax)) / d
    u = np.array([ux, uy])
    return u, _norm(a - u)


def _inside(circle: _Circle, p: np.ndarray) -> bool:
    return _norm(p - circle[0]) <= circle[1] * (1 + 1e-12) + 1e-9


_SCALAR_SCAN = 32
"""The first points of a scan tested one at a time, the rest by one vectorised test (on the
herders' hulls of a few dozen vertices, a scan mostly stops or ends within these)."""


def _first_outside(arr: np.ndarray, P: list[np.ndarray], circle: _Circle, lo: int, hi: int) -> int:
    """Smallest index in [lo, hi) of a point (rows of arr, P the same rows) not ``_inside`` circle
    (hi if none)."""
    centre = circle[0]
    bound = circle[1] * (1 + 1e-12) + 1e-9  # _inside's test, its bound computed once
    head = min(hi, lo + _SCALAR_SCAN)  # short scans (the common case on ordered hulls): scalar
    for q in range(lo, head):
        v = P[q] - centre
        if not math.sqrt(v.dot(v)) <= bound:  # not _inside(circle, P[q])
            return q
    if head >= hi:
        return hi
    rel = arr[head:hi] - centre
    rx, ry = rel[:, 0], rel[:, 1]
    # surely inside, whatever the rounding of the scalar norm (a few ulps); NaN is not
    sure = np.sqrt(rx * rx + ry * ry) <= bound * (1 - 1e-13)
    if sure.all():
        return hi
    for off in np.flatnonzero(~sure).tolist():
        v = P[head + off] - centre
        if not math.sqrt(v.dot(v)) <= bound:
            return head + off
    return hi


def _min_enclosing_circle(arr: np.ndarray) -> tuple[np.ndarray, float]:
    """:func:`min_enclosing_circle` of checked points (the herders' hull vertices)."""
    P = list(arr)
    n = len(P)
    c: _Circle = (P[0], 0.0)
    i = _first_outside(arr, P, c, 1, n)
    while i < n:
        c = (P[i], 0.0)
        j = _first_outside(arr, P, c, 0, i)
        while j < i:
            c = _circ2(P[i], P[j])
            k = _first_outside(arr, P, c, 0, j)
            while k < j:
                c = _circ3(P[i], P[j], P[k])
                k = _first_outside(arr, P, c, k + 1, j)
            j = _first_outside(arr, P, c, j + 1, i)
        i = _first_outside(arr, P, c, i + 1, n)
    return np.asarray(c[0], dtype=float), float(c[1])
