"""Collision-free allocation of steering points to barking drones (thesis §6.4.3).

The drones and the steering points live on the extended hull, a closed curve of
perimeter ``M``; positions are arc lengths in ``[0, M)`` (increasing = the
thesis's counter-clockwise / "right flying on the z axis"). An allocation sends
drone ``j`` to steering point ``target[j]`` in direction ``direction[j]``
(+1 increasing arc length, -1 decreasing). The thesis's problem (6.21)-(6.23):

    minimise   max_j gamma_j                                   (6.21)
    subject to 0 < z*_n - z*_1 < M                             (6.22)
               z*_j < z*_{j+1},  j = 1..n-1                    (6.23)

where drones are relabelled counter-clockwise from drone 1 (``z_1 = 0``), ``z'_j``
is the steering point of drone j on the z axis, ``z*_j`` its unwrapped
destination (6.19) and ``gamma_j = |z*_j - z_j|`` its travel (6.20). For n = 1
(6.22) would read ``0 < 0``; the order constraints are vacuous for one drone and
we drop them (a single drone cannot collide).

Two exact methods are provided and must agree:

* ``method="cp-sat"``: the explicit assignment model of (6.21)-(6.23) (Booleans
  for drone x steering point x direction, as in the thesis's (S', Sigma)) solved
  by CP-SAT, see :func:`build_allocation_model`;
* ``method="exact"``: an O(n^2) combinatorial algorithm, see :func:`_exact`.

Structure theorem (proof of the exact algorithm)
------------------------------------------------
Let drones be sorted so ``0 = z_1 < ... < z_n < M`` and let ``t_0 < ... < t_{n-1}``
be the steering points' z coordinates in ``[0, M)`` (distinct; equal steering
points make the problem infeasible because destinations must differ by (6.23)
and by less than M by (6.22)).

1. *A feasible allocation is a cyclic shift.* By (6.23) and (6.22) the
   destinations satisfy ``z*_1 < z*_2 < ... < z*_n < z*_1 + M``: they lie in one
   half-open window of length M, so their residues ``z*_j mod M`` are distinct
   and, read from ``z*_1 mod M`` upwards (wrapping at M), appear in index order.
   The residues are exactly the steering points ``t``. Hence if ``z*_1 mod M =
   t_r``, drone j (0-based) must go to ``t_{(j + r) mod n}``: the assignment is
   the cyclic shift ``r``.
2. *The wraps are determined by the shift and one integer.* Write
   ``z*_j = t_{(j+r) mod n} + k_j M``. Inside the window ``[z*_1, z*_1 + M)`` the
   values ``t_r, ..., t_{n-1}`` come first and ``t_0, ..., t_{r-1}`` after the
   wrap, so ``k_j = k_1 + [j + r >= n]``.
3. *k_1 has two candidates.* (6.19) gives ``z*_j in (z_j - M, z_j + M)`` (one
   direction, less than one lap). With ``z_1 = 0`` and ``t in [0, M)`` this
   leaves ``k_1 in {-1, 0}``.
4. *The direction is implied.* ``k_j`` must be one of the two values (6.19)
   allows for drone j (``sigma=0``: 0 if ``z' <= z`` else -1; ``sigma=1``: 0 if
   ``z' >= z`` else +1); the direction is the sign of ``z*_j - z_j`` (either when
   they are equal; we report +1).

So the feasible set is contained in the 2n candidates (r, k_1); each is checked
against (6.19), (6.22), (6.23) in O(n), and the one of least maximum travel is
optimal: O(n^2) time (vectorised as a 2n x n array). Conversely every candidate
passing the checks is a feasible point of (6.21)-(6.23), so the minimum over the
candidates equals the optimum. The hypothesis tests compare it with the CP-SAT
model and with Algorithm 3 (``planners.herding.allocate_bruteforce``).

Fewer steering points than drones
---------------------------------
When the hull has fewer vertices than there are drones (``len(steer_s) <
len(drone_s)``), :func:`pad_steering_points` adds points by repeatedly splitting
the longest arc gap between consecutive steering points at its midpoint (ties:
the lowest gap start), so every drone still gets a distinct destination spread
over the hull. The padded positions are returned in ``Allocation.points`` and
target indices ``>= len(steer_s)`` refer to them. More steering points than
drones is a ValueError (the caller chooses which n steering points to use).
"""

from __future__ import annotations

import os
import time
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
from ortools.sat.python import cp_model

from droneplan.core.deprecation import renamed_keywords
from droneplan.core.validation import check_array, check_instance, check_int, check_nonneg, check_positive
from droneplan.solvers.registry import available_backends, get_backend
from droneplan.solvers.result import SolveResult, Status

__all__ = [
    "METHODS",
    "solve_checked_exact",
    "Allocation",
    "validate_allocation_input",
    "pad_steering_points",
    "z_coordinates",
    "allowed_wraps",
    "check_allocation",
    "AllocationModel",
    "build_allocation_model",
    "solve_allocation",
    "write_allocation_model",
]

METHODS = ("exact", "cp-sat")


@dataclass(frozen=True)
class Allocation:
    """Which drone goes to which steering point, in which direction (Definition 6.4.1)."""

    target: np.ndarray
    """(n,) int: index of the steering point of drone j (input order of ``drone_s``)."""
    direction: np.ndarray
    """(n,) int: +1 (increasing arc length) or -1 (decreasing) for drone j."""
    travel: np.ndarray
    """(n,) float, m: distance drone j flies along the hull, gamma_j of (6.20)."""
    points: np.ndarray
    """(n,) float, m: arc positions of the steering points ``target`` indexes (input + padding)."""

    @property
    def destination(self) -> np.ndarray:
        """(n,) float, m: arc position each drone flies to, ``points[target]``."""
        return self.points[self.target]


# --------------------------------------------------------------------------- validation
def _as_positions(name: str, values, perimeter: float) -> np.ndarray:
    arr = check_array(name, values, ndim=1)
    if np.any(arr < 0) or np.any(arr >= perimeter):
        raise ValueError(f"{name} must lie in [0, perimeter) = [0, {perimeter})")
    return arr


def validate_allocation_input(drone_s, steer_s, perimeter) -> tuple[np.ndarray, np.ndarray, float]:
    """Check the inputs of an allocation problem; returns (drone_s, steer_s, perimeter) as floats.

    Raises ValueError for a non-positive or non-finite perimeter, no drones, no
    steering points, more steering points than drones, or positions outside
    ``[0, perimeter)`` or non-finite.
    """
    perimeter = check_positive("perimeter", perimeter)
    d = _as_positions("drone_s", drone_s, perimeter)
    s = _as_positions("steer_s", steer_s, perimeter)
    if d.size < 1:
        raise ValueError("drone_s must hold at least one drone (n_drones >= 1)")
    if s.size < 1:
        raise ValueError("steer_s must hold at least one steering point")
    if s.size > d.size:
        raise ValueError(
            f"mismatched lengths: {s.size} steering points for {d.size} drones "
            "(need len(steer_s) <= len(drone_s))"
        )
    return d, s, perimeter


MAX_PADDED_POINTS = 100_000
"""The most points :func:`pad_steering_points` pads to (its loop is quadratic in them)."""


def pad_steering_points(steer_s, n: int, perimeter: float) -> np.ndarray:
    """Extend ``steer_s`` to ``n`` points by splitting the longest arc gap at its midpoint.

    The documented rule for hulls with fewer vertices than drones (see module
    docstring): the padding an allocation method's ``target`` indexes into when there are fewer
    steering points than drones. steer_s: (m,) arc positions in [0, perimeter), m >= 1; n: the
    number of points wanted (the drones); perimeter: the hull's perimeter M (m). Returns the
    input points followed by the added ones (m).
    """
    perimeter = check_positive("perimeter", perimeter)
    steer = check_array("steer_s", steer_s, shape=(None,), min_rows=1)
    if np.any((steer < 0) | (steer >= perimeter)):
        raise ValueError(f"steer_s must lie in [0, perimeter) = [0, {perimeter}) (arc positions, m)")
    n = check_int("n", n, min_value=0, max_value=MAX_PADDED_POINTS)
    pts = [float(v) for v in steer]
    while len(pts) < n:
        order = sorted(pts)
        gaps = [(order[(i + 1) % len(order)] - order[i]) % perimeter or perimeter for i in range(len(order))]
        i = int(np.argmax(gaps))
        pts.append((order[i] + gaps[i] / 2.0) % perimeter)
    return np.asarray(pts, dtype=float)


def z_coordinates(drone_s: np.ndarray, steer_s: np.ndarray, perimeter: float):
    """The thesis's z axis: drones relabelled ccw from the first one at z = 0.

    Returns ``(order, z, zp)``: ``order`` the drone indices sorted by arc position
    (stable), ``z`` their z coordinates (``z[0] = 0``) and ``zp`` the steering
    points' z coordinates (input order), all in ``[0, M)``.
    """
    order = np.argsort(drone_s, kind="stable")
    origin = drone_s[order[0]]
    z = drone_s[order] - origin
    zp = np.mod(steer_s - origin, perimeter)
    zp[zp >= perimeter] = 0.0  # guard against fmod rounding up to M
    return order, z, zp


def allowed_wraps(z: np.ndarray, zp: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(6.17)-(6.19): the wrap k (z* = z' + k M) for left (sigma=0) and right (sigma=1) flying."""
    k_left = np.where(zp > z, -1, 0)
    k_right = np.where(zp < z, 1, 0)
    return k_left, k_right


def check_allocation(drone_s, steer_s, perimeter, allocation: Allocation, *, tol: float = 1e-9) -> float:
    """Verify an allocation against (6.19)-(6.23); return its max travel (m).

    Independent of how the allocation was found: recomputes each destination from
    the target and direction, the travel, and the order constraints on the z* axis.
    Raises ValueError naming the violated condition (an explicit check, kept under ``python -O``).

    drone_s, steer_s: drone and steering-point arc positions on the extended hull (m), in [0, perimeter).
    perimeter: extended-hull perimeter M (m).
    tol: tolerance of the order checks, relative to max(1, perimeter) (finite, >= 0).
    """
    drone_s, steer_s, perimeter = validate_allocation_input(drone_s, steer_s, perimeter)
    check_instance("allocation", allocation, Allocation)
    tol = check_nonneg("tol", tol)
    d = np.asarray(drone_s, dtype=float)
    pts = np.asarray(allocation.points, dtype=float)
    n, M = d.size, float(perimeter)
    tgt = np.asarray(allocation.target)
    if tgt.shape != (n,) or sorted(tgt.tolist()) != list(range(n)):
        raise ValueError("allocation violates: every steering point gets exactly one drone")
    if np.shape(allocation.direction) != (n,) or np.shape(allocation.travel) != (n,):
        raise ValueError(f"allocation violates: direction and travel have one entry per drone ({n})")
    if not np.all(np.isin(allocation.direction, (-1, 1))):
        raise ValueError("allocation violates: every direction is +1 or -1")
    order, z, zp_all = z_coordinates(d, pts, M)
    zstar = np.empty(n)
    for rank, j in enumerate(order):
        zj, zpj = z[rank], zp_all[tgt[j]]
        zs = zpj + (M if zpj < zj else 0.0) if allocation.direction[j] > 0 else zpj - (M if zpj > zj else 0.0)
        zstar[rank] = zs
        if not abs(abs(zs - zj) - allocation.travel[j]) <= tol * max(1.0, M):
            raise ValueError(
                f"allocation violates (6.20): travel of drone {j} does not match its destination"
            )
    if n > 1:
        if not np.all(np.diff(zstar) > 0):
            raise ValueError("allocation violates (6.23): destinations do not keep the drones' cyclic order")
        if not zstar[-1] < zstar[0] + M:
            raise ValueError("allocation violates (6.22): destinations span a whole perimeter or more")
    return float(np.max(allocation.travel))


# --------------------------------------------------------------------------- exact O(n^2)
_SCALAR_MAX = 12
"""Allocations of up to this many drones run the O(n^2) algorithm in plain Python floats (the
same operations in the same order as the numpy version, so the same result to the last bit;
for a handful of drones the numpy calls cost more than the arithmetic)."""


def _exact(d: np.ndarray, s: np.ndarray, M: float):
    """The O(n^2) algorithm of the module docstring; returns (Allocation, max travel) or None."""
    if d.size <= _SCALAR_MAX:
        return _exact_scalar(d, s, M)
    return _exact_numpy(d, s, M)


def _exact_scalar(d: np.ndarray, s: np.ndarray, M: float):
    """:func:`_exact` for a few drones, one shift and wrap at a time in Python floats."""
    n = d.size
    ds, ss = d.tolist(), s.tolist()
    order = sorted(range(n), key=ds.__getitem__)  # stable, as argsort(kind="stable")
    origin = ds[order[0]]
    z = [ds[i] - origin for i in order]
    zp = [(v - origin) % M for v in ss]  # Python's float % rounds as np.mod
    zp = [0.0 if v >= M else v for v in zp]
    sidx = sorted(range(n), key=zp.__getitem__)
    t = [zp[i] for i in sidx]
    if any(t[i + 1] - t[i] <= 0 for i in range(n - 1)):
        return None  # coincident steering points: (6.22)-(6.23) cannot both hold
    best = None
    for k1 in (-1, 0):
        for r in range(n):
            row = _shift_row(z, t, M, n, r, k1)
            if row is not None and (best is None or row[0] < best[0]):
                best = (row[0], r, row[1], row[2])
    if best is None:
        return None
    worst, r, zstar, travel = best
    target = np.empty(n, dtype=int)
    direction = np.empty(n, dtype=int)
    tr = np.empty(n)
    target[order] = [sidx[(j + r) % n] for j in range(n)]
    direction[order] = [1 if zs >= zj else -1 for zs, zj in zip(zstar, z, strict=True)]
    tr[order] = travel
    return Allocation(target, direction, tr, s.copy()), worst


def _shift_row(z: list[float], t: list[float], M: float, n: int, r: int, k1: int):
    """Drone j (ccw from the first) to sorted steering point (j + r) mod n with wrap k1 (+1 past
    the end): (max travel, z*, travel), or None when (6.19), (6.22) or (6.23) fails."""
    zstar = []
    for j in range(n):
        jr = j + r
        k, tz = (k1 + 1, t[jr - n]) if jr >= n else (k1, t[jr])
        zj = z[j]
        # (6.19): a target ahead may wrap back (k = -1), one behind forward (k = +1), else k = 0
        if tz > zj:
            if k != -1 and k != 0:
                return None
        elif tz < zj:
            if k != 0 and k != 1:
                return None
        elif k != 0:
            return None
        zstar.append(tz + k * M)
    prev = zstar[0]
    for zs in zstar[1:]:  # (6.23): strictly increasing ...
        if not zs - prev > 0:
            return None
        prev = zs
    if n > 1 and not prev < zstar[0] + M:  # ... (6.22): within one lap
        return None
    travel = [abs(zs - zj) for zs, zj in zip(zstar, z, strict=True)]
    return max(travel), zstar, travel


def _exact_numpy(d: np.ndarray, s: np.ndarray, M: float):
    """:func:`_exact` vectorised over the shifts (many drones)."""
    n = d.size
    order, z, zp = z_coordinates(d, s, M)
    sidx = np.argsort(zp, kind="stable")
    t = zp[sidx]
    if n > 1 and np.any(np.diff(t) <= 0):
        return None  # coincident steering points: (6.22)-(6.23) cannot both hold
    j = np.arange(n)
    r = np.arange(n)[:, None]  # shift
    pos = (j[None, :] + r) % n  # (n, n): sorted-steering index of sorted drone j
    wrap = (j[None, :] + r >= n).astype(int)
    best = None
    for k1 in (-1, 0):
        k = k1 + wrap  # (n, n)
        tz = t[pos]
        zstar = tz + k * M
        k_left, k_right = allowed_wraps(z[None, :], tz)
        ok = (k == k_left) | (k == k_right)
        if n > 1:
            ok_rows = (
                ok.all(axis=1) & np.all(np.diff(zstar, axis=1) > 0, axis=1) & (zstar[:, -1] < zstar[:, 0] + M)
            )
        else:
            ok_rows = ok.all(axis=1)
        if not ok_rows.any():
            continue
        travel = np.abs(zstar - z[None, :])
        worst = np.where(ok_rows, travel.max(axis=1), np.inf)
        rr = int(np.argmin(worst))
        if best is None or worst[rr] < best[0]:
            best = (worst[rr], rr, k[rr], zstar[rr], travel[rr])
    if best is None:
        return None
    worst, rr, _, zstar, travel = best
    target = np.empty(n, dtype=int)
    direction = np.empty(n, dtype=int)
    tr = np.empty(n)
    target[order] = sidx[pos[rr]]
    direction[order] = np.where(zstar >= z, 1, -1)
    tr[order] = travel
    return Allocation(target, direction, tr, s.copy()), float(worst)


# --------------------------------------------------------------------------- CP-SAT model
@dataclass
class AllocationModel:
    """A built CP-SAT model of (6.21)-(6.23) and the data to decode its solution."""

    model: cp_model.CpModel
    """The CP-SAT model (objective: rank of the maximum travel)."""
    choices: list
    """Per decision variable: (drone index, steering index, direction +-1, z*, travel)."""
    variables: list
    """Boolean x[j, i, sigma], aligned with ``choices``."""
    travel_values: np.ndarray
    """Sorted distinct travel values (m); the objective variable is an index into it."""
    points: np.ndarray
    """Arc positions of the steering points (after padding), m."""


def build_allocation_model(drone_s, steer_s, perimeter) -> AllocationModel:  # noqa: C901
    """Build the explicit assignment model of (6.21)-(6.23) (does not solve).

    Variables: Boolean ``x[j,i,sigma]`` = drone j flies to steering point i in
    direction sigma (thesis (S', Sigma)); z*_j and gamma_j follow from (6.19),
    (6.20) as constants of the chosen (i, sigma). Constraints: each drone one
    choice, each steering point one drone, (6.23) ``z*_j < z*_{j+1}``, (6.22)
    ``z*_n < z*_1 + M``; objective ``min T`` with ``T >= gamma_j``.

    Exactness without rounding: CP-SAT needs integer coefficients, so every
    destination value and every ``destination + M`` is replaced by its rank in
    one sorted list of all of them, and every travel by its rank among the
    travels. Comparisons between ranks are the comparisons between the real
    numbers, so the integer model has exactly the feasible set and the argmin of
    the real one; the objective rank is mapped back to metres.

    drone_s, steer_s: drone and steering-point arc positions on the extended hull (m), in [0, perimeter).
    perimeter: extended-hull perimeter M (m).
    """
    d, s, M = validate_allocation_input(drone_s, steer_s, perimeter)
    n = d.size
    pts = pad_steering_points(s, n, M)
    order, z, zp = z_coordinates(d, pts, M)
    k_left, k_right = allowed_wraps(z[:, None], zp[None, :])  # (n drones sorted, n points)
    choices = []
    for rank in range(n):
        for i in range(n):
            for sigma, k in ((-1, k_left[rank, i]), (1, k_right[rank, i])):
                if sigma == -1 and k_left[rank, i] == 0 and k_right[rank, i] == 0:
                    continue  # z' == z: both directions give the same destination; keep sigma=+1 only
                zs = zp[i] + k * M
                choices.append((rank, i, sigma, zs, abs(zs - z[rank])))
    zs_all = np.array([c[3] for c in choices])
    grid = np.unique(np.concatenate([zs_all, zs_all + M]))
    zrank = np.searchsorted(grid, zs_all)
    zrank_plus = np.searchsorted(grid, zs_all + M)
    travel_values = np.unique(np.array([c[4] for c in choices]))
    trank = np.searchsorted(travel_values, np.array([c[4] for c in choices]))

    model = cp_model.CpModel()
    way = {1: "inc", -1: "dec"}  # the direction of arc positions; LP files take no sign in a name
    x = [model.new_bool_var(f"drone{order[c[0]]}_point{c[1]}_{way[c[2]]}") for c in choices]
    by_drone: list[list[int]] = [[] for _ in range(n)]
    by_point: list[list[int]] = [[] for _ in range(n)]
    for idx, c in enumerate(choices):
        by_drone[c[0]].append(idx)
        by_point[c[1]].append(idx)
    for lst in by_drone:
        model.add_exactly_one(x[i] for i in lst)
    for lst in by_point:
        model.add_exactly_one(x[i] for i in lst)
    zr = [sum(int(zrank[i]) * x[i] for i in lst) for lst in by_drone]
    for rank in range(n - 1):  # (6.23)
        model.add(zr[rank] + 1 <= zr[rank + 1])
    if n > 1:  # (6.22): z*_n < z*_1 + M
        first_plus = sum(int(zrank_plus[i]) * x[i] for i in by_drone[0])
        model.add(zr[n - 1] + 1 <= first_plus)
    T = model.new_int_var(0, len(travel_values) - 1, "max_travel_rank")
    for lst in by_drone:  # (6.21)
        model.add(sum(int(trank[i]) * x[i] for i in lst) <= T)
    model.minimize(T)
    # report choices in the caller's drone indexing
    choices = [(int(order[c[0]]), c[1], c[2], c[3], c[4]) for c in choices]
    return AllocationModel(model, choices, x, travel_values, pts)


def write_allocation_model(drone_s, steer_s, perimeter: float, path: str | os.PathLike[str]) -> Path:
    """Write the assignment model of (6.21)-(6.23) (:func:`build_allocation_model`) as an MPS or
    LP file that any MIP solver reads.

    drone_s, steer_s: drone and steering-point arc positions on the extended hull (m), in
    [0, perimeter); perimeter: the extended-hull perimeter M (m). path: the file, ``.mps`` (free
    MPS) or ``.lp`` (CPLEX LP), in an existing writable folder (written through a temporary file).

    Variables: ``drone{j}_point{i}_inc`` / ``_dec`` (0-1: drone j, in the caller's order, flies
    to steering point i, padded as :func:`pad_steering_points` pads them, in direction +1, that
    of increasing arc position, or -1) and ``max_travel_rank``, the minimised objective:
    the rank of the largest travel among the sorted distinct travels (rank k means
    ``build_allocation_model(...).travel_values[k]`` metres; ranks keep the model integral and
    exact). Returns the path (a ``pathlib.Path``).
    """
    from droneplan.solvers.model_files import check_model_path, write_cp_model

    target = check_model_path(path)
    return write_cp_model(build_allocation_model(drone_s, steer_s, perimeter).model, target)


def _decode(am: AllocationModel, values: np.ndarray, n: int) -> Allocation:
    target = np.full(n, -1, dtype=int)
    direction = np.zeros(n, dtype=int)
    travel = np.zeros(n)
    for c, v in zip(am.choices, values, strict=True):  # one value per model variable
        if v:
            target[c[0]], direction[c[0]], travel[c[0]] = c[1], c[2], c[4]
    return Allocation(target, direction, travel, am.points)


def _hint(am: AllocationModel, hint: Allocation) -> dict:
    chosen = {(j, int(hint.target[j]), int(hint.direction[j])) for j in range(len(hint.target))}
    out = {}
    for c, var in zip(am.choices, am.variables, strict=True):
        key = (c[0], c[1], c[2])
        # sigma=-1 for z'==z was merged into sigma=+1
        out[var] = int(key in chosen or (c[2] == 1 and (c[0], c[1], -1) in chosen and c[4] == 0.0))
    return out


# --------------------------------------------------------------------------- public solve
def solve_checked_exact(d: np.ndarray, s: np.ndarray, M: float) -> SolveResult:
    """:func:`solve_allocation` with ``engine="exact"`` on inputs already as
    :func:`validate_allocation_input` returns them (float arrays, 1 <= len(s) <= len(d), every
    position in [0, M), M > 0): the herders' own, whose arc positions hold that by construction,
    so the check is not repeated at each re-allocation. d, s: drone and steering-point arc
    positions, m; M: perimeter, m."""
    n = d.size
    t0 = time.perf_counter()
    pts = pad_steering_points(s, n, M)
    out = _exact(d, pts, M)
    elapsed = time.perf_counter() - t0
    msg = f"steering points padded from {s.size} to {n}" if s.size < n else ""
    if out is None:
        return SolveResult(
            Status.INFEASIBLE,
            backend="exact-cyclic-shift",
            backend_status="infeasible",
            message=("coincident steering points; " + msg).strip("; "),
            solve_time=elapsed,
        )
    alloc, worst = out
    return SolveResult(
        Status.OPTIMAL,
        objective=worst,
        bound=worst,
        x=alloc,
        backend="exact-cyclic-shift",
        backend_status="optimal",
        message=msg,
        solve_time=elapsed,
        iterations=2 * n,
    )


@renamed_keywords(method="engine", hint="warm_start")
def solve_allocation(
    drone_s,
    steer_s,
    perimeter: float,
    *,
    engine: str = "exact",
    time_limit: float | None = None,
    workers: int = 1,
    warm_start: Allocation | None = None,
) -> SolveResult:
    """Optimal collision-free allocation of steering points (6.21)-(6.23).

    drone_s: (n,) drone arc positions on the extended hull, m, in [0, perimeter), any order.
    steer_s: (m,) steering-point arc positions, m, in [0, perimeter), 1 <= m <= n;
        m < n is padded by :func:`pad_steering_points`.
    perimeter: extended-hull perimeter M, m (> 0).
    engine: "exact" (O(n^2) combinatorial algorithm) or "cp-sat" (explicit model, solved by
        that registered "cp" backend).
    time_limit, workers, warm_start: CP-SAT only (seconds; search workers; an Allocation handed
        to CP-SAT as its hint). ``method`` and ``hint`` are the deprecated names of ``engine`` and
        ``warm_start``.

    Returns a SolveResult with ``x`` an :class:`Allocation`, ``objective`` the
    maximum travel (m), ``bound`` a proven lower bound (= objective when OPTIMAL).
    Coincident steering points make the problem INFEASIBLE (a returned status).
    """
    if engine != "exact" and (not isinstance(engine, str) or engine not in available_backends("cp")):
        raise ValueError(f"engine must be 'exact' or a cp backend {available_backends('cp')}, got {engine!r}")
    workers = check_int("workers", workers, min_value=1)
    d, s, M = validate_allocation_input(drone_s, steer_s, perimeter)
    if engine == "exact":
        return solve_checked_exact(d, s, M)
    n = d.size
    padded = s.size < n
    am = build_allocation_model(d, s, M)
    res = get_backend(engine, kind="cp").solve_cp(
        am.model,
        variables=am.variables,
        time_limit=time_limit,
        workers=workers,
        hint=_hint(am, warm_start) if warm_start is not None else None,
    )
    if not res.has_solution:
        return res
    alloc = _decode(am, res.x, n)
    obj = float(am.travel_values[round(res.objective)])
    b = int(np.ceil(res.bound - 1e-9))
    bound = float(am.travel_values[min(max(b, 0), len(am.travel_values) - 1)])
    msg = "objective/bound mapped back from travel ranks (exact, no rounding)"
    if padded:
        msg += f"; steering points padded from {s.size} to {n}"
    return replace(res, x=alloc, objective=obj, bound=bound, message=msg)
