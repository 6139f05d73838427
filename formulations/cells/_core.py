"""CellProblem evaluation and the candidate-site geometry (thesis ch. 4)."""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.spatial import cKDTree

from droneplan.core.validation import check_array, check_instance, check_typed_array
from droneplan.scenarios.cells import CellProblem

TOL = 1e-6
"""Absolute geometric tolerance (m): a user at distance <= R_d + TOL is covered, a
separation >= 2 R_d - TOL does not overlap, a link of length <= r + TOL exists.
Candidate points built as circle intersections sit on circles up to rounding error,
so every test in this package uses the same tolerance."""


@dataclass(frozen=True)
class Evaluation:
    """Outcome of :func:`evaluate`."""

    covered: int
    """Number of active users (not served by a GBS) within R_d of some drone-cell."""
    feasible: bool
    """True when every constraint of (4.7)-(4.8) and backhaul connectivity holds."""
    violations: tuple[str, ...]
    """Human-readable description of each violated constraint (empty when feasible)."""
    connected: np.ndarray
    """(k,) bool: drone-cell i reaches a GBS through backhaul links (relays allowed)."""
    covered_mask: np.ndarray
    """(n,) bool over ``problem.users``: user covered by a drone-cell (inactive users False)."""
    value: float = float("nan")
    """The objective: the covered weight (``covered`` without weights), or with a capacity
    the most weight the drone-cells can serve (a user served once, by one drone-cell within
    R_d, at most ``capacity`` users a drone-cell)."""


def as_positions(problem: CellProblem, positions, name: str = "positions") -> np.ndarray:
    """Validate and return drone-cell positions as a float (k, w) array, w = 2 (x, y) or, with
    altitude levels, 3 (x, y, h) (``problem.plan_width``; one point (w,) or an empty array is
    accepted too); errors name the parameter ``name`` of the public entry."""
    check_instance("problem", problem, CellProblem)
    width = problem.plan_width
    p = check_array(name, positions)
    if p.size == 0:
        p = p.reshape(0, width)
    if p.ndim == 1 and p.shape[0] == width:
        p = p.reshape(1, width)
    return check_array(name, p, shape=(None, width))


def site_radii(problem: CellProblem, positions: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(k,) coverage radius (m) of each drone-cell of ``positions`` ((k, plan_width) m) and (k,)
    bool whether it flies at one of the problem's altitude levels (to ``TOL``): R_d and True
    everywhere without levels; R(h) of its level with them (0 off the levels)."""
    k = len(positions)
    if problem.altitudes is None or problem.level_radii is None:
        return np.full(k, problem.R_d), np.ones(k, dtype=bool)
    gap = np.abs(positions[:, 2:3] - np.asarray(problem.altitudes)[None, :])
    on_level = np.any(gap <= TOL, axis=1)
    radius = np.where(on_level, problem.level_radii[np.argmin(gap, axis=1)] if k else 0.0, 0.0)
    return radius, on_level


def link_distances(problem: CellProblem, positions: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Backhaul link lengths (m) of drone-cells at ``positions``: (k, g) to the GBSs and (k, k)
    between drone-cells; in 3-D with altitude levels (a GBS at height 0), on the ground without."""
    to_gbs = pairwise_distances(positions, problem.gbs)
    between = pairwise_distances(positions, positions)
    if positions.shape[1] == 3:
        h = positions[:, 2]
        to_gbs = np.hypot(to_gbs, h[:, None])
        between = np.hypot(between, h[:, None] - h[None, :])
    return to_gbs, between


def pairwise_distances(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(len(a), len(b)) Euclidean distances (m) between the points ``a`` ((p, 2) m) and ``b``
    ((q, 2) m): the one distance helper of the cells package."""
    return np.hypot(a[:, None, 0] - b[None, :, 0], a[:, None, 1] - b[None, :, 1])


def _as_mask(name: str, value, k: int) -> np.ndarray:
    """``value`` as a (k,) bool array; TypeError unless its dtype is bool, ValueError on another shape."""
    arr = check_typed_array(name, value, "b", "a bool array")
    if arr.shape != (k,):
        raise ValueError(f"{name} must have shape ({k},) (one flag per drone-cell), got {arr.shape}")
    return arr


def connected_mask(
    problem: CellProblem, positions: np.ndarray, usable: np.ndarray | None = None
) -> np.ndarray:
    """(k,) bool: which drone-cells reach a GBS through links <= r1 (to a GBS) / <= r2
    (between drone-cells), relaying only through drone-cells flagged ``usable``.

    problem: the CellProblem (users, GBSs, m, radii in metres).
    positions: (k, 2) drone-cell positions (m); (k, 3) (x, y, h) with altitude levels, whose
        links are measured in 3-D.
    usable: (k,) bool, drone-cells allowed to relay (default: all); a bool array with one
        entry per drone-cell (ints and other dtypes are refused).
    """
    check_instance("problem", problem, CellProblem)
    positions = as_positions(problem, positions)
    k = len(positions)
    usable = np.ones(k, dtype=bool) if usable is None else _as_mask("usable", usable, k)
    if k == 0:
        return np.zeros(0, dtype=bool)
    to_gbs, between = link_distances(problem, positions)
    direct = np.any(to_gbs <= problem.r1 + TOL, axis=1) & usable
    adj = (between <= problem.r2 + TOL) & usable[:, None] & usable[None, :]
    reach = direct.copy()
    for _ in range(k):
        new = reach | np.any(adj & reach[None, :], axis=1)
        if np.array_equal(new, reach):
            break
        reach = new
    return reach


def evaluate(problem: CellProblem, positions) -> Evaluation:
    """Covered users and feasibility of drone-cells at ``positions`` ((k, 2) m, k <= m allowed;
    (k, 3) (x, y, h) with altitude levels, see :class:`CellProblem`, each with its radius R(h)).

    Feasible (eqs. 4.7-4.8 with relays): |D_i - G_h| >= R_g + R_d for all i, h;
    |D_i - D_h| >= 2 R_d for i != h; every drone-cell reaches some GBS through
    backhaul links (drone-GBS <= r1, drone-drone <= r2); at most ``n_cells`` drone-cells;
    inside ``bounds`` when given. ``covered`` counts active users within R_d of any
    drone-cell whether or not the placement is feasible.

    problem: the CellProblem (users, GBSs, m, radii in metres).
    """
    if not isinstance(problem, CellProblem):
        raise TypeError(f"problem must be a CellProblem, got {type(problem).__name__}")
    pos = as_positions(problem, positions)
    k = len(pos)
    v: list[str] = []
    if k > problem.n_cells:
        v.append(f"{k} drone-cells placed but n_cells = {problem.n_cells}")
    if problem.bounds is not None and k:
        xmin, xmax, ymin, ymax = problem.bounds
        out = (
            (pos[:, 0] < xmin - TOL)
            | (pos[:, 0] > xmax + TOL)
            | (pos[:, 1] < ymin - TOL)
            | (pos[:, 1] > ymax + TOL)
        )
        v += [f"drone-cell {i} outside bounds" for i in np.flatnonzero(out)]
    radius, on_level = site_radii(problem, pos)
    if k:
        v += _level_violations(problem, pos, on_level)
        v += _overlap_violations(problem, pos, radius)
        v += [f"drone-cell {i} lies in no-fly zone {z}" for i, z in in_no_fly(problem, pos)]
    conn = connected_mask(problem, pos)
    v += [f"drone-cell {i} has no backhaul path to a GBS" for i in np.flatnonzero(~conn)]
    mask = np.zeros(len(problem.users), dtype=bool)
    within = np.zeros((len(problem.users), k), dtype=bool)
    if k and len(problem.users):
        within = (pairwise_distances(problem.users, pos) <= radius[None, :] + TOL) & problem.active[:, None]
        mask = np.any(within, axis=1)
    weights = np.ones(len(problem.users)) if problem.weights is None else problem.weights
    if problem.capacity is None:
        value = float(weights[mask].sum())
    else:
        value = served_weight(within, weights, problem.capacity)
    return Evaluation(
        covered=int(mask.sum()),
        feasible=not v,
        violations=tuple(v),
        connected=conn,
        covered_mask=mask,
        value=value,
    )


def _level_violations(problem: CellProblem, pos: np.ndarray, on_level: np.ndarray) -> list[str]:
    """A drone-cell off the altitude levels (3-D plans only)."""
    return [
        f"drone-cell {i} flies at {pos[i, 2]:g} m, not at an altitude level {problem.altitudes}"
        for i in np.flatnonzero(~on_level)
    ]


def _overlap_violations(problem: CellProblem, pos: np.ndarray, radius: np.ndarray) -> list[str]:
    """(4.7) GBS keep-out and (4.8) non-overlap, on the ground, with each drone-cell's radius."""
    v = []
    flat = problem.altitudes is None
    dg = pairwise_distances(pos, problem.gbs)
    for i, h in zip(*np.nonzero(dg < problem.R_g + radius[:, None] - TOL), strict=True):
        what = "R_g + R_d" if flat else f"R_g + R(h) = {problem.R_g + radius[i]:g}"
        v.append(f"drone-cell {i} overlaps GBS {h} cell: distance {dg[i, h]:.3f} < {what} (4.7)")
    dd = pairwise_distances(pos, pos)
    reach = radius[:, None] + radius[None, :]
    for i, h in zip(*np.nonzero(np.triu(dd < reach - TOL, 1)), strict=True):
        what = "2 R_d" if flat else f"R(h_i) + R(h_j) = {reach[i, h]:g}"
        v.append(f"drone-cells {i} and {h} overlap: distance {dd[i, h]:.3f} < {what} (4.8)")
    return v


def in_no_fly(problem: CellProblem, points: np.ndarray) -> list[tuple[int, int]]:
    """(point index, zone index) of every point of ``points`` ((k, 2) m) inside a no-fly zone
    of ``problem`` or within ``TOL / 2`` of its edge."""
    if not problem.no_fly or not len(points):
        return []
    import shapely

    found = []
    for z, zone in enumerate(problem.no_fly):
        near = shapely.dwithin(zone, shapely.points(points[:, :2]), TOL / 2)
        found += [(int(i), z) for i in np.flatnonzero(near)]
    return sorted(found)


def served_weight(within: np.ndarray, weights: np.ndarray, capacity: int) -> float:
    """The most weight drone-cells serve when each user is served at most once, by a drone-cell
    it lies within (``within``: (n, k) bool), and each drone-cell serves at most ``capacity``
    users: a maximum-weight b-matching. Its LP is a transportation problem (totally unimodular),
    so the LP optimum is the integer one."""
    users, _ = served_pairs(within, weights, capacity)
    return float(np.asarray(weights, float)[users].sum())


def served_pairs(within: np.ndarray, weights: np.ndarray, capacity: int) -> tuple[np.ndarray, np.ndarray]:
    """(users, drone-cells) of a maximum-weight b-matching of :func:`served_weight`: user
    ``users[i]`` served by drone-cell ``cells[i]``."""
    from scipy.optimize import linprog
    from scipy.sparse import coo_matrix

    users, cells = np.nonzero(within & (np.asarray(weights)[:, None] > 0))
    if not len(users):
        return users, cells
    n_arcs = len(users)
    arc = np.arange(n_arcs)
    user_ids, user_row = np.unique(users, return_inverse=True)
    cell_ids, cell_row = np.unique(cells, return_inverse=True)
    rows = np.concatenate([user_row, len(user_ids) + cell_row])
    a_ub = coo_matrix((np.ones(2 * n_arcs), (rows, np.concatenate([arc, arc]))))
    b_ub = np.concatenate([np.ones(len(user_ids)), np.full(len(cell_ids), float(capacity))])
    res = linprog(
        -np.asarray(weights, float)[users], A_ub=a_ub.tocsr(), b_ub=b_ub, bounds=(0, 1), method="highs"
    )
    if res.status != 0:
        raise RuntimeError(f"the b-matching LP of the served weight failed: {res.message}")
    chosen = res.x > 0.5  # an integral vertex (total unimodularity)
    return users[chosen], cells[chosen]


# --------------------------------------------------------------------------- geometry
def circle_intersections(
    c1: np.ndarray, r1: np.ndarray | float, c2: np.ndarray, r2: np.ndarray | float
) -> np.ndarray:
    """Intersection points of circles (c1[i], r1) and (c2[i], r2), vectorised over i.

    Returns an (2q, 2) array holding both points of every pair that intersects
    (tangent pairs give a repeated point; concentric or disjoint pairs give none).
    """
    c1 = np.asarray(c1, float).reshape(-1, 2)
    c2 = np.asarray(c2, float).reshape(-1, 2)
    r1 = np.broadcast_to(np.asarray(r1, float), (len(c1),))
    r2 = np.broadcast_to(np.asarray(r2, float), (len(c1),))
    d_vec = c2 - c1
    d = np.hypot(d_vec[:, 0], d_vec[:, 1])
    ok = (d > 0) & (d <= r1 + r2) & (d >= np.abs(r1 - r2))
    c1, c2, r1, r2, d_vec, d = c1[ok], c2[ok], r1[ok], r2[ok], d_vec[ok], d[ok]
    a = (r1**2 - r2**2 + d**2) / (2 * d)
    h = np.sqrt(np.maximum(r1**2 - a**2, 0.0))
    u = d_vec / d[:, None]
    base = c1 + a[:, None] * u
    perp = np.column_stack([-u[:, 1], u[:, 0]])
    return np.concatenate([base + h[:, None] * perp, base - h[:, None] * perp], axis=0)


def merge_points(points: np.ndarray, resolution: float = 1e-3) -> np.ndarray:
    """Points with duplicates (equal after rounding to ``resolution`` m) merged, order kept."""
    if len(points) == 0:
        return points.reshape(0, 2)
    key = np.round(points / resolution).astype(np.int64)
    _, idx = np.unique(key, axis=0, return_index=True)
    return points[np.sort(idx)]


def pair_intersections(users: np.ndarray, R_d: float) -> np.ndarray:
    """Intersection points of the radius-R_d circles around every pair of users < 2 R_d apart."""
    if len(users) < 2:
        return np.zeros((0, 2))
    pairs = cKDTree(users).query_pairs(2 * R_d, output_type="ndarray")
    if len(pairs) == 0:
        return np.zeros((0, 2))
    return circle_intersections(users[pairs[:, 0]], R_d, users[pairs[:, 1]], R_d)


def coverage_lists(points: np.ndarray, users: np.ndarray, R_d: float) -> list[np.ndarray]:
    """For every point, the sorted indices of ``users`` within R_d + TOL of it."""
    if len(points) == 0:
        return []
    if len(users) == 0:
        return [np.zeros(0, dtype=np.int64) for _ in points]
    tree = cKDTree(users)
    return [np.asarray(sorted(ix), dtype=np.int64) for ix in tree.query_ball_point(points, R_d + TOL)]


@dataclass(frozen=True)
class Candidates:
    """Candidate drone-cell sites of a :class:`CellProblem` (all feasible one at a time)."""

    points: np.ndarray
    """(c, 2) candidate positions (m)."""
    cover: list
    """cover[i]: indices into ``problem.targets`` (active users) covered by site i."""
    direct: np.ndarray
    """(c,) bool: site within r1 of some GBS (a direct backhaul link)."""
    n_generated: int
    """Number of distinct points generated before the feasibility filter."""
    heights: np.ndarray | None = None
    """(c,) altitude (m) of each site with altitude levels; None at one altitude."""
    radius: np.ndarray | None = None
    """(c,) coverage radius (m) of each site with altitude levels; None: R_d everywhere."""

    def subset(self, idx: np.ndarray) -> Candidates:
        """The sites ``idx`` (indices into these candidates, in that order) as candidates."""
        return Candidates(
            points=self.points[idx],
            cover=[self.cover[i] for i in np.asarray(idx).tolist()],
            direct=self.direct[idx],
            n_generated=self.n_generated,
            heights=None if self.heights is None else self.heights[idx],
            radius=None if self.radius is None else self.radius[idx],
        )

    def plan(self, idx: Any) -> np.ndarray:
        """The plan of the sites ``idx``: (k, 2) positions (m), or (k, 3) (x, y, h) with levels."""
        if self.heights is None:
            return self.points[idx].reshape(-1, 2)
        return np.column_stack([self.points[idx], self.heights[idx]]).reshape(-1, 3)


def raw_candidate_points(problem: CellProblem) -> np.ndarray:
    """Every active user location, the intersection points of the radius-R_d circles
    around pairs of active users, and the points where those circles meet each GBS's
    r1 circle and (R_g + R_d) circle, the edges of ``bounds`` and the edges of the no-fly
    zones (duplicates merged)."""
    return raw_points_for_radius(problem, problem.R_d, problem.r1)


def raw_points_for_radius(problem: CellProblem, R: float, direct_reach: float) -> np.ndarray:
    """:func:`raw_candidate_points` for drone-cells of coverage radius ``R`` (m) whose direct
    backhaul reaches ``direct_reach`` (m, on the ground; skipped when <= 0) around each GBS."""
    t = problem.targets
    parts = [t, pair_intersections(t, R)]
    if len(t):
        for g in problem.gbs:
            parts.extend(
                circle_intersections(t, R, np.broadcast_to(g, t.shape), rad)
                for rad in (direct_reach, problem.R_g + R)
                if rad > 0
            )
        if problem.bounds is not None:
            xmin, xmax, ymin, ymax = problem.bounds
            for axis, val in ((0, xmin), (0, xmax), (1, ymin), (1, ymax)):
                off = t[:, axis] - val
                ok = np.abs(off) <= R
                h = np.sqrt(np.maximum(R**2 - off[ok] ** 2, 0.0))
                for s in (1.0, -1.0):
                    q = t[ok].copy()
                    q[:, axis] = val
                    q[:, 1 - axis] += s * h
                    parts.append(q)
        parts += _no_fly_edge_points(t, R, problem.no_fly)
    return merge_points(np.concatenate(parts, axis=0))


_EIGHTHS = np.arange(8) * np.pi / 4


def _no_fly_edge_points(targets: np.ndarray, R: float, zones: tuple) -> list[np.ndarray]:
    """Where the radius-R circles around ``targets`` cross the edges of the no-fly ``zones``,
    each moved ``TOL`` off the edge to both sides (the side inside the zone is then filtered
    out; the other covers the same users, coverage being tested to R + TOL): a site pushed
    against a zone stops on such a point, as it stops on the area edges. The zones' corners,
    moved ``TOL`` in eight directions, are candidates too."""
    parts = []
    for zone in zones:
        rings = [zone.exterior, *zone.interiors]
        for ring in rings:
            xy = np.asarray(ring.coords)
            ring_offsets = TOL * np.stack([np.cos(_EIGHTHS), np.sin(_EIGHTHS)], axis=1)
            parts.append((xy[:-1, None, :] + ring_offsets[None, :, :]).reshape(-1, 2))  # the corners
            for a, b in itertools.pairwise(xy):
                seg = b - a
                length = float(np.hypot(*seg))
                if length == 0.0:
                    continue
                unit = seg / length
                normal = np.array([-unit[1], unit[0]])
                along = (targets - a) @ unit  # foot of each user on the edge's line
                off = (targets - a) @ normal
                ok = np.abs(off) <= R
                h = np.sqrt(np.maximum(R**2 - off[ok] ** 2, 0.0))
                for sign in (1.0, -1.0):
                    s = along[ok] + sign * h
                    on = (s >= 0) & (s <= length)
                    base = a + s[on, None] * unit
                    parts += [base + TOL * normal, base - TOL * normal]
    return parts


def site_feasible(problem: CellProblem, points: np.ndarray, R: float | None = None) -> np.ndarray:
    """(c,) bool: a single drone-cell of coverage radius ``R`` (m, default R_d) may sit at each
    point: inside ``bounds``, outside the no-fly zones, at least R_g + R from every GBS (4.7)
    and within r1 + (m - 1) r2 of some GBS (the farthest a chain of m drone-cells can reach)."""
    if len(points) == 0:
        return np.zeros(0, dtype=bool)
    R = problem.R_d if R is None else R
    dg = pairwise_distances(points, problem.gbs)
    ok = np.all(dg >= problem.R_g + R - TOL, axis=1)
    ok &= np.any(dg <= problem.r1 + (problem.n_cells - 1) * problem.r2 + TOL, axis=1)
    if problem.bounds is not None:
        xmin, xmax, ymin, ymax = problem.bounds
        ok &= (points[:, 0] >= xmin - TOL) & (points[:, 0] <= xmax + TOL)
        ok &= (points[:, 1] >= ymin - TOL) & (points[:, 1] <= ymax + TOL)
    for i, _ in in_no_fly(problem, points):
        ok[i] = False
    return ok


def candidate_sites(problem: CellProblem, extra=None) -> Candidates:
    """The candidate set of :func:`raw_candidate_points` plus ``extra`` positions
    ((q, 2) m, e.g. a heuristic's placement), restricted to feasible single sites. With altitude
    levels, the same construction at each level with its radius R(h) (``extra`` then (q, 3),
    each point added at its own level), sites tagged with ``heights`` and ``radius``.

    problem: the CellProblem (users, GBSs, m, radii in metres).
    """
    check_instance("problem", problem, CellProblem)
    if problem.altitudes is not None:
        return _level_candidates(problem, extra)
    pts = raw_candidate_points(problem)
    if extra is not None:
        ex = as_positions(problem, extra, "extra")
        pts = merge_points(np.concatenate([ex, pts], axis=0)) if len(pts) else merge_points(ex)
    n_gen = len(pts)
    pts = pts[site_feasible(problem, pts)]
    cover = coverage_lists(pts, problem.targets, problem.R_d)
    direct = (
        np.any(pairwise_distances(pts, problem.gbs) <= problem.r1 + TOL, axis=1)
        if len(pts)
        else np.zeros(0, bool)
    )
    return Candidates(points=pts, cover=cover, direct=direct, n_generated=n_gen)


def _level_candidates(problem: CellProblem, extra=None) -> Candidates:
    """:func:`candidate_sites` with altitude levels: each level's sites with its radius R(h);
    a site is direct when its 3-D distance to a GBS (at height 0) is within r1."""
    if problem.altitudes is None or problem.level_radii is None:
        raise ValueError("problem has no altitude levels")
    ex = None if extra is None else as_positions(problem, extra, "extra")
    parts, n_gen = [], 0
    for h, R in zip(problem.altitudes, problem.level_radii.tolist(), strict=True):
        reach = math.sqrt(max(problem.r1**2 - h**2, 0.0))
        pts = raw_points_for_radius(problem, R, reach)
        if ex is not None and len(ex):
            mine = ex[np.abs(ex[:, 2] - h) <= TOL, :2]
            pts = merge_points(np.concatenate([mine, pts], axis=0)) if len(pts) else merge_points(mine)
        n_gen += len(pts)
        parts.append((pts[site_feasible(problem, pts, R)], h, R))
    pts = np.concatenate([p for p, _, _ in parts]).reshape(-1, 2)
    heights = np.concatenate([np.full(len(p), h) for p, h, _ in parts])
    radius = np.concatenate([np.full(len(p), R) for p, _, R in parts])
    cover = [c for p, _, R in parts for c in coverage_lists(p, problem.targets, R)]
    to_gbs = (
        np.hypot(pairwise_distances(pts, problem.gbs), heights[:, None]) if len(pts) else np.zeros((0, 1))
    )
    direct = np.any(to_gbs <= problem.r1 + TOL, axis=1)
    return Candidates(
        points=pts, cover=cover, direct=direct, n_generated=n_gen, heights=heights, radius=radius
    )
