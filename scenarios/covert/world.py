"""Covert observation world: Table 3.2 parameters, terrain, target paths, thesis cases."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from droneplan.core.validation import (
    check_array,
    check_in_range,
    check_int,
    check_positive,
    check_real,
    resolve_seed,
)

__all__ = [
    "ZONE",
    "HABITAT",
    "V_T_MIN",
    "CovertParams",
    "THESIS_TABLE_3_2",
    "Terrain",
    "TargetPath",
    "Occlusion",
    "Obstacle",
    "FIG_3_13_OBSTACLE",
    "CovertScenario",
    "CASE1_TERRAIN",
    "thesis_case",
    "random_case",
    "LAYOUTS",
    "two_target_layout",
]

ZONE = 200.0
"""Side of the square zone the targets move in (m), thesis §3.5."""
HABITAT = (80.0, 195.0)
"""Random targets stay in [HABITAT[0], HABITAT[1]]^2 (m): the habitat part of the zone near F."""


V_T_MIN = 0.01
"""Slowest target speed (m/s) :func:`thesis_case` accepts: the 240 m paths then take 24,000 s
(6.7 hours, 240,000 control steps of 0.1 s); slower targets make periods no study simulates."""


# --------------------------------------------------------------------------- parameters
@dataclass(frozen=True)
class CovertParams:
    """Parameters of the covert-observation problem (defaults: thesis Table 3.2)."""

    V_max: float = 10.0
    """Maximum drone speed |v| (m/s)."""
    U_max: float = 5.0
    """Maximum |u|, the heading turn rate (rad/s; Table 3.2 prints m/s^2, a unit slip: |h| = 1)."""
    F: tuple[float, float, float] = (200.0, 200.0, 0.0)
    """Farthest point of the habitat, centre of the observation sphere (m)."""
    R: tuple[float, float, float] = (10.0, 10.0, 40.0)
    """Reference point of the camouflage constraint lines (m)."""
    D_s: tuple[float, float, float] = (20.0, 20.0, 38.0)
    """Start and end of the drone's path (m); must lie outside the observation sphere."""
    L_u: float = 200.0
    """Maximum useful observing distance, radius of the observation sphere (m)."""
    V_T: float = 2.0
    """Maximum target speed (m/s)."""
    duration: float = 120.0
    """Simulation period: the drone must be back at D_s around this time (s)."""
    dt: float = 0.1
    """Control period and simulation step (s); not given in the thesis."""

    def __post_init__(self) -> None:
        for name in ("V_max", "U_max", "L_u", "V_T", "duration", "dt"):
            check_positive(name, getattr(self, name))
        for name in ("F", "R", "D_s"):
            vec = check_array(name, getattr(self, name), shape=(3,))
            object.__setattr__(self, name, tuple(float(x) for x in vec))
        if self.dt > self.duration:
            raise ValueError(f"dt must be <= duration, got dt={self.dt}, duration={self.duration}")
        if np.linalg.norm(np.subtract(self.D_s, self.F)) <= self.L_u:
            raise ValueError(
                f"D_s must lie outside the observation sphere: |D_s - F| = "
                f"{np.linalg.norm(np.subtract(self.D_s, self.F)):.3f} m <= L_u = {self.L_u} m"
            )
        if self.U_max * self.dt > math.pi:
            raise ValueError(
                f"U_max * dt must be <= pi (one step turns at most half a turn), got {self.U_max * self.dt}"
            )

    @property
    def F_arr(self) -> NDArray[np.float64]:
        """F as a numpy array (m)."""
        return np.asarray(self.F)

    @property
    def R_arr(self) -> NDArray[np.float64]:
        """R as a numpy array (m)."""
        return np.asarray(self.R)

    @property
    def D_s_arr(self) -> NDArray[np.float64]:
        """D_s as a numpy array (m)."""
        return np.asarray(self.D_s)


THESIS_TABLE_3_2 = CovertParams()
"""Table 3.2 of the thesis (plus the control period dt = 0.1 s, which the thesis does not state)."""


# --------------------------------------------------------------------------- terrain
@dataclass(frozen=True)
class Terrain:
    """Smooth hills: z(x, y) = sum_i height_i * exp(-((x-x_i)^2 + (y-y_i)^2) / (2 sigma_i^2)).

    hills: (k, 4) rows (x_i m, y_i m, height_i m, sigma_i m); empty means flat ground z = 0.
    """

    hills: tuple[tuple[float, float, float, float], ...] = ()
    """Hill centres, heights and widths (m)."""

    def __post_init__(self) -> None:
        arr = check_array("hills", self.hills, shape=(None, 4))
        if (arr[:, 3] <= 0).any():
            raise ValueError("hills: every sigma must be > 0")
        object.__setattr__(self, "hills", tuple(tuple(float(v) for v in row) for row in arr))

    def height(self, x: Any, y: Any) -> NDArray[np.float64]:
        """Ground height (m) at planar coordinates x, y (m), vectorised (broadcast)."""
        x = np.asarray(x, dtype=float)
        y = np.asarray(y, dtype=float)
        z = np.zeros(np.broadcast(x, y).shape)
        for hx, hy, hh, hs in self.hills:
            z = z + hh * np.exp(-((x - hx) ** 2 + (y - hy) ** 2) / (2.0 * hs * hs))
        return z


# --------------------------------------------------------------------------- targets
@dataclass(frozen=True)
class TargetPath:
    """A target walking along a planar curve draped on the terrain at constant 3D speed.

    points: (m, 3) densely sampled positions on the ground (m), in walking order.
    """

    points: NDArray[np.float64] = field(repr=False)
    """(m, 3) samples of the path on the terrain (m)."""
    _s: NDArray[np.float64] = field(init=False, repr=False, compare=False)
    """(m,) arc length (m) at each sample, set from ``points``."""

    def __post_init__(self) -> None:
        pts = check_array("points", self.points, shape=(None, 3), min_rows=2)
        seg = np.linalg.norm(np.diff(pts, axis=0), axis=1)
        keep = np.concatenate([[True], seg > 1e-12])
        pts = pts[keep]
        if pts.shape[0] < 2:
            raise ValueError("points must not all coincide")
        object.__setattr__(self, "points", pts)
        object.__setattr__(
            self, "_s", np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(pts, axis=0), axis=1))])
        )

    @property
    def length(self) -> float:
        """Length of the path (m)."""
        return float(self._s[-1])

    def at(self, s: Any) -> NDArray[np.float64]:
        """Positions (..., 3) at arc lengths s (m), clipped to [0, length] (the target then stands)."""
        s = np.clip(np.asarray(s, dtype=float), 0.0, self.length)
        out = np.empty((*s.shape, 3))
        for c in range(3):
            out[..., c] = np.interp(s, self._s, self.points[:, c])
        return out


def _drape(xy: NDArray[np.float64], terrain: Terrain) -> NDArray[np.float64]:
    return np.column_stack([xy[:, 0], xy[:, 1], terrain.height(xy[:, 0], xy[:, 1])])


@dataclass(frozen=True)
class Occlusion:
    """Target ``target`` is unobservable (no line of sight) for start <= t < end (s)."""

    target: int
    """Index of the occluded target."""
    start: float
    """Start of the occlusion (s)."""
    end: float = math.inf
    """End of the occlusion (s); inf: until the end of the run."""

    def __post_init__(self) -> None:
        check_int("target", self.target, min_value=0)
        check_real("start", self.start)
        if check_real("end", self.end, finite=False) <= self.start:
            raise ValueError(f"end must be > start, got start={self.start}, end={self.end}")


@dataclass(frozen=True)
class Obstacle:
    """A vertical prism that blocks line of sight: a convex footprint polygon (m) from the
    ground up to ``height`` (m, absolute z of its flat top), e.g. a stand of trees or a rock.

    A target is hidden from the drone when the segment between them passes through the
    prism: some point of it lies over the footprint below the top.
    """

    footprint: tuple[tuple[float, float], ...]
    """Vertices (x, y) of the convex footprint (m), in either orientation."""
    height: float
    """Absolute height of the top (m)."""

    def __post_init__(self) -> None:
        pts = check_array("footprint", self.footprint, shape=(None, 2))
        if pts.shape[0] < 3:
            raise ValueError(f"footprint must have >= 3 (x, y) vertices, got {pts.shape[0]}")
        object.__setattr__(self, "height", check_real("height", self.height))
        poly = self.polygon
        if not poly.is_valid or poly.area <= 0 or abs(poly.convex_hull.area - poly.area) > 1e-9 * poly.area:
            raise ValueError("footprint must be a convex polygon with positive area")
        object.__setattr__(self, "footprint", tuple(tuple(float(v) for v in row) for row in pts))

    @property
    def polygon(self):
        """The footprint as a shapely Polygon."""
        from shapely.geometry import Polygon

        return Polygon(np.asarray(self.footprint, dtype=float))

    def _halfplanes(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """(normals (m, 2), offsets (m,)): the footprint is {p : normals @ p <= offsets}."""
        pts = np.asarray(self.polygon.exterior.coords)[:-1]
        if self.polygon.exterior.is_ccw is False:
            pts = pts[::-1]
        e = np.roll(pts, -1, axis=0) - pts
        nrm = np.column_stack([e[:, 1], -e[:, 0]])  # outward for a counter-clockwise ring
        return nrm, np.sum(nrm * pts, axis=1)

    def blocks(self, drone: Any, targets: Any) -> NDArray[np.bool_]:
        """Whether the prism blocks each segment drone -> target, vectorised (numpy).

        drone: (..., 3) m; targets: (..., 3) m (broadcast). Clips each segment's ground
        projection to the footprint's half-planes (Cyrus-Beck) and tests the height on the
        clipped part, whose lowest point is one of its ends (z is linear along the segment).
        """
        D = np.asarray(drone, dtype=float)
        A = np.asarray(targets, dtype=float)
        D, A = np.broadcast_arrays(D, A)
        nrm, off = self._halfplanes()
        d = A[..., :2] - D[..., :2]
        num = off - D[..., :2] @ nrm.T  # (..., m): constraint  (nrm . d) s <= num
        den = d @ nrm.T
        lo = np.zeros(D.shape[:-1])
        hi = np.ones(D.shape[:-1])
        with np.errstate(divide="ignore", invalid="ignore"):
            ratio = num / den
        enter = np.where(den < 0, ratio, -np.inf).max(axis=-1)
        leave = np.where(den > 0, ratio, np.inf).min(axis=-1)
        outside_parallel = np.any((den == 0) & (num < 0), axis=-1)
        lo = np.maximum(lo, enter)
        hi = np.minimum(hi, leave)
        hit = (lo <= hi) & ~outside_parallel
        z_lo = D[..., 2] + lo * (A[..., 2] - D[..., 2])
        z_hi = D[..., 2] + hi * (A[..., 2] - D[..., 2])
        return hit & (np.minimum(z_lo, z_hi) < self.height)

    def blocks_shapely(self, drone: Any, target: Any) -> bool:
        """The same test for one segment with shapely (the reference for :meth:`blocks`)."""
        from shapely.geometry import LineString

        D = np.asarray(drone, dtype=float)
        A = np.asarray(target, dtype=float)
        if np.allclose(D[:2], A[:2]):
            from shapely.geometry import Point

            inside = self.polygon.intersects(Point(D[:2]))
            return bool(inside and min(D[2], A[2]) < self.height)
        seg = LineString([D[:2], A[:2]])
        part = seg.intersection(self.polygon)
        if part.is_empty:
            return False
        import shapely

        L2 = float(np.sum((A[:2] - D[:2]) ** 2))
        for x, y in shapely.get_coordinates(part):  # ends of the part over the footprint
            s = float(np.dot([x - D[0], y - D[1]], A[:2] - D[:2]) / L2)
            if D[2] + s * (A[2] - D[2]) < self.height:
                return True
        return False


FIG_3_13_OBSTACLE = Obstacle(((63.51, 142.91), (62.09, 141.49), (17.54, 186.04), (18.96, 187.46)), 2.0)
"""Our Fig. 3.13 obstacle: a 2 m high, 2 m thick hedge along the last 60 m of target 2's straight path
in case 1, from its 180 m mark (62.8, 142.2), reached at t = 90 s at V_T = 2 m/s, to 3 m past its end,
so target 2 walks into it at t = 90 s (the thesis only says target 2 is blocked by an obstacle from
t = 90 s). Target 1's S-shaped path crosses the hedge early on, so it is hidden too while it
crosses (about t = 9-13 s in the sliding-mode run)."""


@dataclass(frozen=True)
class CovertScenario:
    """One observation run: parameters, terrain, target paths and occlusions."""

    params: CovertParams
    """Problem parameters (Table 3.2 by default)."""
    terrain: Terrain
    """Ground the targets walk on."""
    paths: tuple[TargetPath, ...]
    """One path per target; targets walk them at speed params.V_T from t = 0."""
    occlusions: tuple[Occlusion, ...] = ()
    """Intervals where a target cannot be seen by the drone."""
    name: str = ""
    """Human-readable label."""
    seed: int | None = None
    """Seed the scenario was generated from (None: deterministic layout)."""
    targets_stop: bool = False
    """Allow target paths shorter than the mission (``params.V_T * params.duration``): such a
    target stands still at its path's end once it gets there. False (default): a short
    path is refused, so a path cut short by mistake does not silently stop a target."""
    obstacles: tuple[Obstacle, ...] = ()
    """Prisms that block the line of sight between the drone and a target."""

    def __post_init__(self) -> None:  # noqa: C901
        obstacles = tuple(self.obstacles)
        for j, ob in enumerate(obstacles):
            if not isinstance(ob, Obstacle):
                raise TypeError(f"obstacles[{j}] must be an Obstacle, got {type(ob).__name__}")
        object.__setattr__(self, "obstacles", obstacles)
        if not isinstance(self.params, CovertParams):
            raise TypeError(f"params must be CovertParams, got {type(self.params).__name__}")
        if not isinstance(self.terrain, Terrain):
            raise TypeError(f"terrain must be a Terrain, got {type(self.terrain).__name__}")
        paths = tuple(self.paths)
        for j, path in enumerate(paths):
            if not isinstance(path, TargetPath):
                raise TypeError(f"paths[{j}] must be a TargetPath, got {type(path).__name__}")
        object.__setattr__(self, "paths", paths)
        occlusions = tuple(self.occlusions)
        for j, occ in enumerate(occlusions):
            if not isinstance(occ, Occlusion):
                raise TypeError(f"occlusions[{j}] must be an Occlusion, got {type(occ).__name__}")
        object.__setattr__(self, "occlusions", occlusions)
        if not isinstance(self.targets_stop, (bool, np.bool_)):
            raise TypeError(f"targets_stop must be a bool, got {type(self.targets_stop).__name__}")
        mission = self.params.V_T * self.params.duration
        for j, path in enumerate(paths):  # (shorter by less than one step's walk does not count)
            if not self.targets_stop and path.length < mission - self.params.V_T * self.params.dt:
                raise ValueError(
                    f"paths[{j}] is {path.length:.3f} m long, shorter than the mission's V_T * duration = "
                    f"{mission:.3f} m (the target would stop); pass targets_stop=True to allow it"
                )
        R = self.params.R_arr
        for occ in self.occlusions:
            if occ.target >= len(self.paths):
                raise ValueError(f"occlusion target {occ.target} out of range (n = {len(self.paths)})")
        for j, p in enumerate(self.paths):
            if np.min(np.linalg.norm(p.points - R, axis=1)) < 1e-6:
                raise ValueError(
                    f"target {j} passes through the reference point R (bearing change undefined)"
                )

    @property
    def n_targets(self) -> int:
        """Number of targets."""
        return len(self.paths)

    def targets_at(self, t: Any) -> NDArray[np.float64]:
        """True target positions at time(s) t (s): shape t.shape + (n, 3) (m)."""
        t = np.asarray(t, dtype=float)
        if not self.paths:
            return np.zeros((*t.shape, 0, 3))
        return np.stack([p.at(self.params.V_T * t) for p in self.paths], axis=-2)

    def observable_at(self, t: Any, drone: Any = None) -> NDArray[np.bool_]:
        """Boolean mask t.shape + (n,): target has line of sight to the drone at t.

        drone: drone position(s) t.shape + (3,) (m); needed when the scenario has obstacles
        (line of sight against each obstacle prism), ignored otherwise. Scripted occlusion
        windows apply in both cases.
        """
        t = np.asarray(t, dtype=float)
        mask = np.ones((*t.shape, self.n_targets), dtype=bool)
        for occ in self.occlusions:
            mask[..., occ.target] &= ~((t >= occ.start) & (t < occ.end))
        if self.obstacles and self.n_targets:
            if drone is None:
                raise ValueError(
                    "drone is required: with obstacles, line of sight depends on the drone position"
                )
            D = np.asarray(drone, dtype=float)
            if D.shape != (*t.shape, 3) or not np.isfinite(D).all():
                raise ValueError(f"drone must be a finite array of shape {(*t.shape, 3)}, got {D.shape}")
            A = self.targets_at(t)
            for ob in self.obstacles:
                mask &= ~ob.blocks(D[..., None, :], A)
        return mask


def _s_path(
    terrain: Terrain, length: float, m: int = 2000, start=(30.0, 150.0), end=(150.0, 125.0)
) -> TargetPath:
    """Target 1 of case 1: an S-shaped walk from ``start`` (default (30, 150)) that ends at ``end``
    (default (150, 125), the top of the hill), so its second half climbs the hill (thesis Fig. 3.9c);
    the S amplitude is set (bisection) so that the 3D length is ``length``."""
    u = np.linspace(0.0, 1.0, m)
    x0, y0 = (float(v) for v in start)
    x1, y1 = (float(v) for v in end)

    def build(amp: float) -> NDArray[np.float64]:
        return np.column_stack([x0 + (x1 - x0) * u, y0 + (y1 - y0) * u + amp * np.sin(2.0 * math.pi * u)])

    lo, hi = 0.0, 100.0
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        if TargetPath(_drape(build(mid), terrain)).length < length:
            lo = mid
        else:
            hi = mid
    return _scale_to_length(build(hi), terrain, length)


def _straight_path(terrain: Terrain, length: float, start, end, m: int = 2000) -> TargetPath:
    u = np.linspace(0.0, 1.0, m)[:, None]
    xy = (1 - u) * np.asarray(start, float) + u * np.asarray(end, float)
    return _scale_to_length(xy, terrain, length)


def _scale_to_length(xy: NDArray[np.float64], terrain: Terrain, length: float) -> TargetPath:
    """Drape a planar curve and cut (or extend linearly) it to 3D length ``length``."""
    path = TargetPath(_drape(xy, terrain))
    if path.length >= length:
        # cut at arc length ``length``, keeping the vertices (resampling would cut corners
        # and leave the path shorter than the mission, so the target would stop early)
        keep = path.points[path._s < length]
        return TargetPath(np.vstack([keep, path.at(length)[None, :]]))
    # extend along the last direction on the ground: that of the last segment of non-zero length
    # (a curve may end in repeated points), along x when the curve is a single point
    steps = np.diff(xy, axis=0)
    norms = np.linalg.norm(steps, axis=1)
    moving = np.flatnonzero(norms > 0)
    d = steps[moving[-1]] / norms[moving[-1]] if len(moving) else np.array([1.0, 0.0])
    extra = max(length - path.length, 1e-6 * max(length, 1.0))  # a rounding-size shortfall extends too
    ext = xy[-1] + np.outer(np.linspace(0.0, 1.5 * extra, 200)[1:], d)
    return _scale_to_length(np.vstack([xy, ext]), terrain, length)


LAYOUTS = ("ours", "figures")
"""The case 1 layouts of :func:`thesis_case`: ``"ours"`` (the original one, built from the text of
§3.5) and ``"figures"`` (reconstructed from what Figs 3.9 and 3.11 and their text state)."""


def two_target_layout(
    *,
    centre_dist_m: float = 85.0,
    centre_angle_deg: float = 0.0,
    heading_deg: float = 0.0,
    crossing_deg: float = 60.0,
    closest_m: float = 20.0,
    s_amplitude_m: float = 15.0,
    hill_m: float = 25.0,
    params: CovertParams | None = None,
) -> CovertScenario:
    """Two targets that approach each other, pass closest at mid-mission and drift apart.

    Target 1 walks an S (one full sine period of lateral amplitude ``s_amplitude_m`` about its
    line) and climbs, in its second half, a hill of ``hill_m`` centred at 85 % of its line (sigma
    25 m); target 2 walks straight. Each walks V_T * duration metres at V_T (the ground distance
    of their lines; the S and the hill make target 1's walk a little longer, so it stops before
    its end is reached: ``targets_stop``).

    centre_dist_m: the pair's midpoint at mid-mission lies this far from F (m, >= 0) in the
        direction of D_s, turned by centre_angle_deg (deg, [-90, 90], counter-clockwise seen
        from above) about F's vertical.
    heading_deg: the pair's mean walking direction, deg in [-90, 90]: 0 walks across the line of
        sight from D_s to F (clockwise about F seen from above), 90 straight away from D_s.
    crossing_deg: angle between the two walking directions, deg in [0, 180] (0: parallel).
    closest_m: distance between the two lines at mid-mission, m (>= 0).
    s_amplitude_m: lateral amplitude of target 1's S, m (>= 0; 0: straight).
    hill_m: height of target 1's hill, m (>= 0; 0: flat ground).
    params: Table 3.2 by default (its V_T, duration, F and D_s set the walk).
    """
    p = params if params is not None else THESIS_TABLE_3_2
    if not isinstance(p, CovertParams):
        raise TypeError(f"params must be CovertParams or None, got {type(params).__name__}")
    ang = {}
    for name, v, lo, hi in (
        ("centre_angle_deg", centre_angle_deg, -90.0, 90.0),
        ("heading_deg", heading_deg, -90.0, 90.0),
        ("crossing_deg", crossing_deg, 0.0, 180.0),
    ):
        x = check_real(name, v)
        if not lo <= x <= hi:
            raise ValueError(f"{name} must be in [{lo}, {hi}], got {x}")
        ang[name] = math.radians(x)
    size = {}
    for name, v in (
        ("centre_dist_m", centre_dist_m),
        ("closest_m", closest_m),
        ("s_amplitude_m", s_amplitude_m),
        ("hill_m", hill_m),
    ):
        size[name] = check_real(name, v)
        if size[name] < 0:
            raise ValueError(f"{name} must be >= 0, got {size[name]}")
    F, D_s = p.F_arr[:2], p.D_s_arr[:2]
    towards = math.atan2(D_s[1] - F[1], D_s[0] - F[0]) + ang["centre_angle_deg"]
    centre = F + size["centre_dist_m"] * np.array([math.cos(towards), math.sin(towards)])
    across = towards - math.pi / 2  # clockwise about F, seen from above
    mean = across - ang["heading_deg"]  # positive: turned away from D_s (across - 90 deg points away)
    half = p.V_T * p.duration / 2
    normal = np.array([-math.sin(mean), math.cos(mean)])
    u = np.linspace(-1.0, 1.0, 2401)[:, None]
    xy = []
    for j, sign in enumerate((-1.0, 1.0)):
        th = mean + sign * ang["crossing_deg"] / 2
        d = np.array([math.cos(th), math.sin(th)])
        line = centre + sign * size["closest_m"] / 2 * normal + u * half * d
        if j == 0 and size["s_amplitude_m"] > 0:
            line = line + size["s_amplitude_m"] * np.sin(math.pi * (u + 1.0)) * np.array([-d[1], d[0]])
        xy.append(line)
    top = xy[0][int(0.85 * (len(u) - 1))]
    hill = size["hill_m"]
    terrain = Terrain(((float(top[0]), float(top[1]), hill, 25.0),) if hill > 0 else ())
    paths = tuple(TargetPath(_drape(c, terrain)) for c in xy)
    return CovertScenario(p, terrain, paths, name="two targets", targets_stop=True)


CASE1_TERRAIN = Terrain(((150.0, 125.0, 25.0, 22.0), (60.0, 60.0, 6.0, 30.0), (110.0, 175.0, 5.0, 25.0)))
"""Case 1 ground: a 25 m hill that target 1 climbs, and two low swells (m)."""


FIGURES_CASE1 = {
    "centre_dist_m": 49.0,
    "centre_angle_deg": 18.1,
    "heading_deg": 86.1,
    "crossing_deg": 21.3,
    "closest_m": 0.4,
    "s_amplitude_m": 11.6,
    "hill_m": 14.0,
}
"""Case 1 reconstructed from Figs 3.9 and 3.11 and their text: the :func:`two_target_layout` keywords
(m, deg). Target 1 walks an S and climbs a 14 m hill in its second half, target 2 walks straight;
they pass closest (0.4 m apart) at mid-mission 49 m from F and both walk away from D_s, so they
move away from the drone after t_a. Chosen among 160 random layouts of that form as the one that
meets every statement of §3.5 on case 1 checked by ``studies.thesis.fidelity_covert.figure_checks``
(closest in mid-mission; target 1 climbing in its second half with the height difference
growing; both farther from the drone at t_f than at t_a; the sliding-mode run's beta_m falling
after t_a and rising, more slowly, after 60 s; its t_a = 7.4 s +- 0.5 s and t_f = 113.2 s +- 1 s)
and whose hover beta_max is nearest the thesis's 21.8 deg (the benchmark's value; the
sliding-mode margin was not used to choose it). One statement it does not meet: walking 240 m away
from D_s, the targets leave the 200 m zone beyond F (we found no layout with a straight 240 m
walk inside the zone that meets the others)."""


def _check_case_options(case: Any, occlusion: Any, layout: Any) -> bool | str:
    """The checked ``occlusion`` of :func:`thesis_case` (numpy bools as bools), after checking
    ``case``, ``occlusion`` and ``layout`` together."""
    if isinstance(occlusion, np.bool_):
        occlusion = bool(occlusion)
    if not isinstance(occlusion, (bool, str)):
        raise TypeError(
            f"occlusion must be a bool or 'obstacle' / 'scripted', got {type(occlusion).__name__}"
        )
    if occlusion not in (False, True, "obstacle", "scripted"):
        raise ValueError(f"occlusion must be False, True, 'obstacle' or 'scripted', got {occlusion!r}")
    if isinstance(case, (bool, np.bool_)) or case not in (1, 2):
        raise ValueError(f"case must be 1 or 2, got {case!r}")
    if not isinstance(layout, str):
        raise TypeError(f"layout must be a str, one of {LAYOUTS}, got {type(layout).__name__}")
    if layout not in LAYOUTS:
        raise ValueError(f"layout must be one of {LAYOUTS}, got {layout!r}")
    if layout != "ours" and (case != 1 or occlusion):
        raise ValueError(f"layout {layout!r} is defined for case 1 without occlusion only")
    return occlusion


def thesis_case(
    case: int,
    seed: int | np.random.Generator | None = 0,
    *,
    V_T: float | None = None,
    occlusion: bool | str = False,
    params: CovertParams | None = None,
    layout: str = "ours",
) -> CovertScenario:
    """The thesis simulation cases (§3.5) over uneven terrain, with Table 3.2 parameters.

    case 1: two targets, target 1 on an S-shaped path whose second half climbs a hill,
        target 2 on a straight path; they approach each other in the first half and
        drift apart in the second (Fig. 3.9). The layout is fixed (``seed`` unused).
    layout: case 1's layout, one of :data:`LAYOUTS`. ``"ours"`` (default): the original layout, built
        from the text of §3.5 (target 2 crosses the zone along its anti-diagonal, target 1 walks its S
        from (30, 150) to the top of a 25 m hill at (150, 125), over two low swells). It meets every
        statement of Figs 3.9 and 3.11 but one: target 2 walks towards the drone's side of the zone
        before it walks away, while §3.5 says the targets move away from the drone after t_a.
        ``"figures"``: :data:`FIGURES_CASE1`, reconstructed so that it also meets that statement, at
        the price of another (see there). Case 2 has one layout (``"ours"``).
    case 2: ten targets on random curvy paths over random smooth hills drawn from ``seed``.
    V_T: target speed (m/s); the paths stay the same, so the period shrinks to
        120 s * 2 / V_T (Fig. 3.12 uses V_T = 5 m/s). It must lie in [:data:`V_T_MIN`,
        ``params.V_max``]: targets faster than the drone cannot be kept in view, and targets
        slower than 1 cm/s would stretch the period beyond 6.7 hours.
    occlusion: case 1 only (Fig. 3.13): "obstacle" (or True) puts FIG_3_13_OBSTACLE in the scene,
        so target 2 is hidden whenever the line of sight crosses it (from t = 90 s * 2 / V_T on,
        where the target walks into it); "scripted" hides target 2 by a time window from then on.
    params: override the Table 3.2 parameters (V_T and duration are set here).
    """
    base = params if params is not None else THESIS_TABLE_3_2
    if not isinstance(base, CovertParams):
        raise TypeError(f"params must be CovertParams or None, got {type(params).__name__}")
    if seed is not None and not isinstance(seed, np.random.Generator):
        check_int("seed", seed, min_value=0)  # checked for case 1 too, where it is unused
    speed = base.V_T if V_T is None else check_in_range("V_T", V_T, V_T_MIN, base.V_max)
    occlusion = _check_case_options(case, occlusion, layout)
    path_len = THESIS_TABLE_3_2.V_T * THESIS_TABLE_3_2.duration  # 240 m walked in the thesis period
    duration = path_len / speed
    from dataclasses import replace

    p = replace(base, V_T=speed, duration=duration)
    if case == 1 and layout == "figures":
        sc = two_target_layout(**FIGURES_CASE1, params=p)
        return replace(sc, name="case 1 (figures layout)")
    if case == 1:
        terrain = CASE1_TERRAIN
        paths = (_s_path(terrain, path_len), _straight_path(terrain, path_len, (190.0, 15.0), (20.0, 185.0)))
        occ = (Occlusion(1, 90.0 * 2.0 / speed),) if occlusion == "scripted" else ()
        obstacles = (FIG_3_13_OBSTACLE,) if occlusion in (True, "obstacle") else ()
        label = {False: "", True: " (obstacle)", "obstacle": " (obstacle)", "scripted": " (occlusion window)"}
        return CovertScenario(
            p, terrain, paths, occ, name="case 1" + label[occlusion], seed=None, obstacles=obstacles
        )
    if case == 2:
        if occlusion:
            raise ValueError("occlusion is defined for case 1 only (Fig. 3.13)")
        rng, used = resolve_seed(seed)
        sc = random_case(10, rng, params=p)
        return CovertScenario(sc.params, sc.terrain, sc.paths, (), name="case 2", seed=used)
    raise ValueError(f"case must be 1 or 2, got {case!r}")


def random_case(
    n_targets: int,
    seed: int | np.random.Generator | None = None,
    *,
    params: CovertParams | None = None,
    n_hills: int = 4,
) -> CovertScenario:
    """Random targets on curvy paths over random smooth hills (the family of case 2).

    n_targets: number of targets (>= 1).
    Targets start in a 60 m x 60 m patch centred at (140, 140) (the habitat side of
    the zone, towards F), walk with a smoothly varying heading (Ornstein-Uhlenbeck
    turn rate) and turn back at the border of [LO, 195]^2 (LO = 80 m); each walks
    params.V_T * params.duration metres.

    seed: int, numpy Generator or None (fresh entropy).
    n_hills: number of Gaussian hills of the terrain (count).
    """
    n_targets = check_int("n_targets", n_targets, min_value=1, max_value=10_000)
    n_hills = check_int("n_hills", n_hills, min_value=0, max_value=10_000)
    p = params if params is not None else THESIS_TABLE_3_2
    if not isinstance(p, CovertParams):
        raise TypeError(f"params must be CovertParams or None, got {type(params).__name__}")
    rng, used = resolve_seed(seed)
    hills = np.column_stack(
        [
            rng.uniform(30.0, 190.0, n_hills),
            rng.uniform(30.0, 190.0, n_hills),
            rng.uniform(5.0, 25.0, n_hills),
            rng.uniform(15.0, 35.0, n_hills),
        ]
    )
    terrain = Terrain(tuple(map(tuple, hills)))
    length = p.V_T * p.duration
    ds = 0.5
    m = math.ceil(length / ds) + 1
    paths = []
    centre = np.array([140.0, 140.0])
    lo, hi = HABITAT
    for _ in range(n_targets):
        pos = centre + rng.uniform(-30.0, 30.0, 2)
        heading = rng.uniform(0.0, 2.0 * math.pi)
        kappa = 0.0
        xy = np.empty((m, 2))
        for i in range(m):
            xy[i] = pos
            kappa += -0.05 * kappa * ds + 0.02 * math.sqrt(ds) * rng.standard_normal()
            heading += kappa * ds
            step = ds * np.array([math.cos(heading), math.sin(heading)])
            nxt = pos + step
            if not (lo <= nxt[0] <= hi and lo <= nxt[1] <= hi):
                heading += math.pi / 2.0
                kappa = 0.0
                nxt = np.clip(pos + ds * np.array([math.cos(heading), math.sin(heading)]), lo, hi)
            pos = nxt
        paths.append(_scale_to_length(xy, terrain, length))
    return CovertScenario(p, terrain, tuple(paths), (), name=f"random {n_targets} targets", seed=used)
