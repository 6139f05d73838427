"""Steering-point allocation baselines: Algorithm 3 (brute force) and a collision-blind bottleneck.

Both return a :class:`~solvers.result.SolveResult` whose ``x`` is a
:class:`formulations.herding.Allocation`, like ``formulations.herding.solve_allocation``.
"""

from __future__ import annotations

import itertools
import math
import time

import numpy as np
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import maximum_bipartite_matching

from droneplan.core.validation import check_int
from droneplan.formulations.herding import (
    Allocation,
    allowed_wraps,
    pad_steering_points,
    validate_allocation_input,
    z_coordinates,
)
from droneplan.solvers.result import SolveResult, Status

__all__ = ["allocate_bruteforce", "crosses", "allocate_collision_blind"]

_CHUNK = 720  # permutations evaluated per vectorised block


def allocate_bruteforce(drone_s, steer_s, perimeter: float, *, max_drones: int = 9) -> SolveResult:
    """Algorithm 3 of the thesis: search all n!·2^n allocations (S', Sigma).

    drone_s, steer_s, perimeter: as in ``formulations.herding.solve_allocation`` (m).
    max_drones: refuse larger n (the search is n!·2^n); ValueError beyond it.

    For every permutation of the steering points and every direction vector,
    computes lambda^L, lambda^R (6.17)-(6.18), z* (6.19), gamma (6.20), keeps the
    allocations satisfying (6.22)-(6.23) (vacuous for n = 1) and returns one of
    least maximum travel (6.21). Vectorised over direction vectors and blocks of
    permutations. ``objective`` = max travel (m), ``bound`` = objective (exhaustive).
    """
    max_drones = check_int("max_drones", max_drones, min_value=1)
    d, s, M = validate_allocation_input(drone_s, steer_s, perimeter)
    n = d.size
    if n > max_drones:
        raise ValueError(f"n_drones = {n} exceeds max_drones = {max_drones} (the search is n!*2^n)")
    t0 = time.perf_counter()
    pts = pad_steering_points(s, n, M)
    order, z, zp = z_coordinates(d, pts, M)
    # sigma[c, j] in {0 (left), 1 (right)} for every direction vector c
    sigma = np.array(list(itertools.product((0, 1), repeat=n)), dtype=np.int8)  # (2^n, n)
    best_val, best = math.inf, None
    perms_iter = itertools.permutations(range(n))
    while True:
        block = list(itertools.islice(perms_iter, _CHUNK))
        if not block:
            break
        perm = np.array(block, dtype=int)  # (P, n): steering point of z-ordered drone j
        zpr = zp[perm][:, None, :]  # (P, 1, n): z'_j
        zz = z[None, None, :]
        lam_l = (zpr > zz) & (sigma[None] == 0)  # (6.17)
        lam_r = (zpr < zz) & (sigma[None] == 1)  # (6.18)
        zstar = np.where(sigma[None] == 0, zpr - lam_l * M, zpr + lam_r * M)  # (6.19)
        gamma = np.where(sigma[None] == 0, zz - zstar, zstar - zz)  # (6.20)
        if n > 1:
            ok = np.all(np.diff(zstar, axis=2) > 0, axis=2)  # (6.23)
            span = zstar[..., -1] - zstar[..., 0]
            ok &= (span > 0) & (zstar[..., -1] < zstar[..., 0] + M)  # (6.22)
        else:
            ok = np.ones(zstar.shape[:2], dtype=bool)
        worst = np.where(ok, gamma.max(axis=2), np.inf)
        p, c = np.unravel_index(int(np.argmin(worst)), worst.shape)
        if worst[p, c] < best_val:
            best_val = float(worst[p, c])
            best = (perm[p], sigma[c], gamma[p, c])
    elapsed = time.perf_counter() - t0
    n_alloc = math.factorial(n) * 2**n
    if best is None:
        return SolveResult(
            Status.INFEASIBLE,
            backend="bruteforce-alg3",
            backend_status="infeasible",
            message="no allocation satisfies (6.22)-(6.23) (coincident steering points)",
            solve_time=elapsed,
            iterations=n_alloc,
        )
    perm, sig, gam = best
    target = np.empty(n, dtype=int)
    direction = np.empty(n, dtype=int)
    travel = np.empty(n)
    target[order] = perm
    direction[order] = np.where(sig == 1, 1, -1)
    travel[order] = gam
    return SolveResult(
        Status.OPTIMAL,
        objective=best_val,
        bound=best_val,
        x=Allocation(target, direction, travel, pts),
        backend="bruteforce-alg3",
        backend_status="optimal",
        message=f"searched {n_alloc} allocations",
        solve_time=elapsed,
        iterations=n_alloc,
    )


def crosses(drone_s, perimeter: float, allocation: Allocation) -> bool:
    """True when an allocation violates (6.22)-(6.23), i.e. two drones would pass each other."""
    d = np.asarray(drone_s, dtype=float)
    n, M = d.size, float(perimeter)
    if n == 1:
        return False
    if n <= _SCALAR_MAX:
        return _crosses_scalar(d.tolist(), M, allocation)
    order, z, zp = z_coordinates(d, np.asarray(allocation.points, dtype=float), M)
    tz = zp[np.asarray(allocation.target)[order]]
    dirs = np.asarray(allocation.direction)[order]
    k_left, k_right = allowed_wraps(z, tz)
    zstar = tz + np.where(dirs > 0, k_right, k_left) * M
    return not (np.all(np.diff(zstar) > 0) and zstar[-1] < zstar[0] + M)


_SCALAR_MAX = 12
"""Up to this many drones, :func:`crosses` runs in plain Python floats (the same operations as
the numpy version, the same answer; for a handful of drones numpy's calls cost more)."""


def _crosses_scalar(d: list[float], M: float, allocation: Allocation) -> bool:
    """:func:`crosses` of a few drones (n >= 2), one drone at a time."""
    n = len(d)
    pts = np.asarray(allocation.points, dtype=float).tolist()
    target = np.asarray(allocation.target).tolist()
    direction = np.asarray(allocation.direction).tolist()
    order = sorted(range(n), key=d.__getitem__)  # stable, as z_coordinates' argsort
    origin = d[order[0]]
    zstar = []
    for j in order:
        z = d[j] - origin
        tz = (pts[target[j]] - origin) % M  # Python's float % rounds as np.mod
        tz = 0.0 if tz >= M else tz
        k = (1 if tz < z else 0) if direction[j] > 0 else (-1 if tz > z else 0)
        zstar.append(tz + k * M)
    ordered = all(zstar[i + 1] - zstar[i] > 0 for i in range(n - 1))
    return not (ordered and zstar[-1] < zstar[0] + M)


def allocate_collision_blind(drone_s, steer_s, perimeter: float) -> SolveResult:
    """Bottleneck assignment ignoring the order constraints (the collision-blind baseline).

    Each drone flies the shorter way round to its steering point (travel =
    circular distance, m); the assignment minimising the maximum travel is found
    by bisection over the sorted distances with a bipartite perfect-matching test.
    It is a relaxation of (6.21)-(6.23), so its objective is a lower bound on the
    collision-free optimum; ``info["crosses"]`` says whether its drones would pass
    each other (violating (6.22)-(6.23)).

    drone_s, steer_s: drone and steering-point arc positions on the extended hull (m), in [0, perimeter).
    perimeter: extended-hull perimeter M (m).
    """
    d, s, M = validate_allocation_input(drone_s, steer_s, perimeter)
    t0 = time.perf_counter()
    n = d.size
    pts = pad_steering_points(s, n, M)
    fwd = np.mod(pts[None, :] - d[:, None], M)  # distance flying in + direction
    bwd = np.mod(d[:, None] - pts[None, :], M)
    dist = np.minimum(fwd, bwd)
    values = np.unique(dist)
    lo, hi = 0, len(values) - 1
    match = None
    while lo < hi:  # smallest threshold admitting a perfect matching
        mid = (lo + hi) // 2
        m = maximum_bipartite_matching(csr_matrix(dist <= values[mid]), perm_type="column")
        if np.all(m >= 0):
            hi, match = mid, m
        else:
            lo = mid + 1
    if match is None or not np.all(dist[np.arange(n), match] <= values[lo]):
        match = maximum_bipartite_matching(csr_matrix(dist <= values[lo]), perm_type="column")
    target = match.astype(int)
    rows = np.arange(n)
    direction = np.where(fwd[rows, target] <= bwd[rows, target], 1, -1)
    travel = dist[rows, target]
    alloc = Allocation(target, direction, travel, pts)
    return SolveResult(
        Status.OPTIMAL,
        objective=float(travel.max()),
        bound=float(travel.max()),
        x=alloc,
        backend="bottleneck-collision-blind",
        backend_status="optimal",
        message="optimal for the relaxation without (6.22)-(6.23)",
        solve_time=time.perf_counter() - t0,
        info={"crosses": crosses(d, M, alloc)},
    )
