"""A proven lower bound on the interception time for a known shark path (relaxation of the OCP).

The interception OCP (`formulations.shark.ocp`) ends at time T with the operator at the
frontal-contact point

    G(T) = (S_xy(T) + eps*(z_s(T)) (1 + gamma) u(T),  z_o*(z_s(T)))

(u the shark's horizontal heading, z_o*, eps* the exact optimal altitude). Dropping every
path constraint (the field never touching the shark before T, the altitude band) leaves the
relaxation: the earliest T at which an operator flying at |v_xy| <= VoMxy, |v_z| <= VoMz
from O_0 can be at G(T), i.e.

    f(T) = max(|G_xy(T) - O_0,xy| - VoMxy T,  |G_z(T) - O_0,z| - VoMz T) <= slack.

For fixed T that is a convex feasibility problem whose only variable is the final
position, so it is decided in closed form (the reachable set is a cylinder). Feasibility is
*not* monotone in T (G moves with the shark's turns and depth changes, possibly faster
than the operator), so a bisection over T could step over the first feasible T; the
search instead scans T upwards by f(T) / L with L a Lipschitz constant of f
(:func:`solvers.search.first_root_lipschitz`), which never skips a root. Every T below
the returned bound is infeasible for the relaxation, hence for the OCP and for any
controller that reaches G(T) at speed limits.

``slack`` (m, default gamma) accepts an operator within slack of G(T) on each axis: the
virtual-shark interceptor declares capture within gamma of S2 = G, so with that slack the
same number bounds its capture time too. Where eps* = 0 (shark out of reach) the OCP aims
1e-3 m ahead while the virtual shark aims eps_o ahead; the horizontal slack then also
covers the offset eps_o (1 + gamma).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence

import casadi as ca
import numpy as np
from numpy.typing import ArrayLike, NDArray

from droneplan.core.validation import (
    MAX_COORDINATE,
    check_array,
    check_in_range,
    check_instance,
    check_nonneg,
    check_real,
    check_size,
    current_limit,
)
from droneplan.scenarios.shark import THESIS_TABLE_5_1, SharkParams, SharkTrajectory
from droneplan.solvers.result import SolveResult, Status
from droneplan.solvers.search import first_root_lipschitz

__all__ = ["frontal_point", "interception_time_bound"]

_LIP_OVERSAMPLE = 20  # derivative of G sampled at dt / 20 ...
_LIP_MARGIN = 1.5  # ... and inflated by 50% for the Lipschitz constant (G is a C2 cubic B-spline)


def _eps_zo(z_s: NDArray[np.float64], params: SharkParams) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The OCP's terminal altitude and radius (numeric twin of `casadi_optimal_altitude`)."""
    z = np.minimum(z_s, 0.0)
    z1 = np.clip(z + params.l1, params.lmin, params.le)
    z2 = np.clip(z + params.l2, params.lmin, params.le)
    e1 = params.eps_o**2 - (z1 - z - params.l1) ** 2
    e2 = params.eps_o**2 - (z2 - z - params.l2) ** 2
    zo = np.where(e1 >= e2, z1, z2)
    eps = np.sqrt(np.maximum(np.maximum(e1, e2), 1e-6))
    reach = np.maximum(e1, e2) > 0
    return zo, np.where(reach, eps, 0.0)


def _shark_model(
    shark: SharkTrajectory | Sequence[ArrayLike], t0: float
) -> Callable[[ArrayLike], tuple[NDArray[np.float64], NDArray[np.float64]]]:
    """(S(t) (K,3), V(t) (K,2)) for plan times t (K,), as the OCP sees the path."""
    if isinstance(shark, SharkTrajectory):
        grid = [np.asarray(shark.t, float)]
        fs = [ca.interpolant(f"bs{i}", "bspline", grid, shark.pos[:, i]) for i in range(3)]
        fv = [ca.interpolant(f"bv{i}", "bspline", grid, shark.vel[:, i]) for i in range(2)]

        def path_model(t: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
            tt = ca.DM(np.atleast_1d(np.asarray(t, float) + t0)).T
            S = np.column_stack([np.asarray(f(tt)).ravel() for f in fs])
            V = np.column_stack([np.asarray(f(tt)).ravel() for f in fv])
            return S, V

        return path_model
    S0 = np.asarray(shark[0], float)
    V0 = np.asarray(shark[1], float)[:2]

    def line_model(t: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        tt = np.atleast_1d(np.asarray(t, float))
        S = np.column_stack([S0[0] + V0[0] * tt, S0[1] + V0[1] * tt, np.full(tt.shape, S0[2])])
        return S, np.tile(V0, (tt.size, 1))

    return line_model


def frontal_point(shark, t, params: SharkParams = THESIS_TABLE_5_1, *, t0: float = 0.0):
    """The OCP's terminal point G(t) (K,3) in m and eps*(t) (K,) for plan times t (s, from t0).

    shark: a `SharkTrajectory` (its B-spline interpolant, as in the OCP) or (position, velocity).
    """
    S, V = _shark_model(shark, t0)(t)
    u = V / np.sqrt(np.sum(V**2, axis=1, keepdims=True) + 1e-6)
    zo, eps = _eps_zo(S[:, 2], params)
    off = np.where(eps > 0, eps, 1e-3)[:, None] * (1 + params.gamma) * u
    return np.column_stack([S[:, :2] + off, zo]), eps


def interception_time_bound(
    shark,
    operator0,
    params: SharkParams = THESIS_TABLE_5_1,
    *,
    t0: float = 0.0,
    t_max: float = 30.0,
    slack: float | None = None,
    resolution: float = 1e-5,
) -> SolveResult:
    """Proven lower bound (s) on the interception time T of the OCP from ``operator0`` at t0.

    shark: a `SharkTrajectory` (known path) or (position (3,), velocity (>=2,)) for the
    constant-velocity prediction; operator0: (3,) m; t_max: latest T considered (s; a known
    path also ends at its last sample); slack: accepted distance (m) to the frontal point on
    each axis (None: params.gamma, so the bound also holds for the virtual-shark capture time);
    resolution: the search stops within about this many seconds of the relaxation's optimum
    (>= 1e-12 s and >= the float64 spacing of t_max: T cannot be resolved more finely).
    t0: time (s) of the shark's path at which the operator starts, 0 <= t0 <= 1e15.
    The Lipschitz constant is estimated on a grid of t_max / 0.005 s samples, refused up front
    beyond the array-element budget (``core.validation.work_limits``); the scan takes at most
    the evaluations budget of steps.
    Returns status OPTIMAL with objective = bound = the bound (s), or INFEASIBLE with bound
    None when no T <= t_max is reachable even in the relaxation.
    """
    start = time.perf_counter()
    check_instance("params", params, SharkParams)
    O0 = check_array("operator0", operator0, shape=(3,))
    t_max = check_in_range("t_max", t_max, 0.0, MAX_COORDINATE, lo_open=True)
    t0 = check_in_range("t0", t0, 0.0, MAX_COORDINATE)
    sl = params.gamma if slack is None else check_nonneg("slack", slack)
    finest = max(1e-12, 4 * math.ulp(t_max + t0))
    resolution = check_real("resolution", resolution)
    if not resolution >= finest:
        raise ValueError(
            f"resolution must be >= {finest:.3g} s (1e-12 s, or the float64 spacing at t0 + t_max = "
            f"{t_max + t0:.3g} s: lower t0 or t_max for a finer resolution), got {resolution}"
        )
    if not isinstance(shark, SharkTrajectory):
        if not isinstance(shark, (tuple, list)) or len(shark) != 2:
            raise TypeError("shark must be a SharkTrajectory or (position (3,), velocity (>=2,))")
        shark = (
            check_array("shark position", shark[0], shape=(3,)),
            check_array("shark velocity", np.asarray(shark[1], float).ravel()[:2], shape=(2,)),
        )
    hi = t_max if not isinstance(shark, SharkTrajectory) else max(min(t_max, shark.duration - t0), 0.0)
    lo = 0.0
    # Lipschitz constant of f: VoM + |dG/dt|, the latter from G sampled finely over [lo, hi]
    dt = (shark.dt if isinstance(shark, SharkTrajectory) else 0.1) / _LIP_OVERSAMPLE
    check_size("t_max", 6 * ((hi - lo) / dt + 2))  # G and its derivative on the grid, 3 columns each
    grid = np.arange(lo, hi + dt, dt)
    G, _ = frontal_point(shark, grid, params, t0=t0)
    dG = np.diff(G, axis=0) / dt
    L_xy = float(np.max(np.linalg.norm(dG[:, :2], axis=1))) if len(dG) else 0.0
    L_z = float(np.max(np.abs(dG[:, 2]))) if len(dG) else 0.0
    L = max(L_xy + params.VoMxy, L_z + params.VoMz) * _LIP_MARGIN
    far = params.eps_o * (1 + params.gamma)

    def f(T: float) -> float:
        g, e = frontal_point(shark, [T], params, t0=t0)
        extra = far if e[0] <= 0 else 0.0
        fxy = float(np.hypot(*(g[0, :2] - O0[:2]))) - params.VoMxy * T - sl - extra
        fz = abs(float(g[0, 2] - O0[2])) - params.VoMz * T - sl
        return max(fxy, fz)

    root = first_root_lipschitz(
        f, lo, hi, L, resolution=resolution, max_evaluations=current_limit("evaluations")
    )
    el = time.perf_counter() - start
    what = (
        f"relaxation of the interception OCP (no path constraints: earliest T at which the operator at "
        f"VoMxy={params.VoMxy:.2f}, VoMz={params.VoMz:.2f} m/s can be within {sl:.3g} m of the frontal "
        f"point), Lipschitz scan over T (L={L:.1f} m/s, {root.evaluations} evaluations)"
    )
    if root.lower is None:
        return SolveResult(
            Status.INFEASIBLE,
            bound=None,
            backend="lipschitz-scan",
            solve_time=el,
            iterations=root.evaluations,
            message=f"no T <= {hi:.2f} s reachable even in the {what}; no bound",
        )
    return SolveResult(
        Status.OPTIMAL,
        objective=root.lower,
        bound=root.lower,
        backend="lipschitz-scan",
        solve_time=el,
        iterations=root.evaluations,
        message=f"proven lower bound on the interception time (s) from the {what}",
        info={"lipschitz": L, "slack": sl},
    )
