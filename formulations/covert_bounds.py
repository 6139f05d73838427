"""Proven references for covert observation (thesis ch. 3) as convex programs (Clarabel SOCPs).

Per instant. With u_j the unit vector from target A_j to the reference point R, the
bearing change (3.6) at A_j satisfies beta_j(D) <= theta  <=>  u_j . (D - A_j) >=
cos(theta) |D - A_j|: for theta < 90 deg a second-order cone with apex A_j around the axis
towards R. So {D : max_j beta_j(D) <= theta} is convex and contains R. When R lies
outside the observation ball |D - F| <= L_u (Table 3.2: |R - F| = 272 m > 200 m), any
such D inside the ball joins R by a segment that crosses the sphere, and the whole segment
stays in the convex set: the minimum over the sphere equals the minimum over the ball,
a quasiconvex program. With c = cos(theta) we solve the slack form

    s(c) = max_{|D - F| <= L_u}  min_j  u_j . (D - A_j) - c |D - A_j|

(an SOCP, laid out once per shape for Clarabel), which is convex and decreasing in c; the
optimum is the root c* of s, beta* = arccos(c*). Newton's method on s from the feasible side
(s > 0) increases c monotonically to c* (s is convex, so each tangent root stays below c*),
with ds/dc = -sum_j lambda_j |D - A_j| from the duals lambda of the slack rows. A final solve
at c* + delta with s < 0 certifies the lower bound arccos(c* + delta).

Whole mission. A drone that starts at D_s at t = 0, flies at |v| <= V_max, is on the
sphere from t_a to t_f and back at D_s at the end T is, at each instant, inside the convex
set  |D - D_s| <= V_max min(t, T - t)  and  |D - F| <= L_u + V_max max(t_a - t, 0, t - t_f)
(and on the sphere for t_a <= t <= t_f, relaxed to the ball as above). The minimum of
max_j beta_j over that convex set (same slack program with the extra balls) at every
control instant, maximised over the instants, is a lower bound on beta_max for any such
controller, whatever it knows about the targets.

As cvxpy models. :func:`build_instant_slack` writes the slack SOCP at one c for given targets
(and extra balls), and :func:`build_mission_slack` the one of the whole-mission bound at one
instant; both are parametrised (DPP), so a model compiles once and is re-solved with new data
through :meth:`SlackModel.set_data` and ``model.c.value``. :func:`solve_slack` solves one with
any cvxpy solver. ``backend="cvxpy"`` runs :func:`instant_minmax_bearing`,
:func:`mission_lower_bound` and :func:`mission_front` on these models instead of the direct
Clarabel layout (the default, which is faster: ``droneplan bench covert`` measures both).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray
from scipy import sparse

from droneplan.core.validation import (
    MAX_COORDINATE,
    check_array,
    check_bool,
    check_in_range,
    check_instance,
    check_nonneg,
    check_positive,
    check_size,
    check_work,
    require_set,
)
from droneplan.solvers.result import SolveResult, Status

if TYPE_CHECKING:
    import cvxpy as cp

__all__ = [
    "BACKENDS",
    "InstantMinmaxProgram",
    "MissionBound",
    "SlackModel",
    "build_instant_slack",
    "build_mission_slack",
    "instant_minmax_bearing",
    "mission_front",
    "mission_lower_bound",
    "solve_slack",
]

BACKENDS = ("clarabel", "cvxpy")
"""How the per-instant programs are solved: the direct Clarabel layout, or the cvxpy models."""

_C_WIDTH = 1e-9  # the search stops when the bracket on cos(theta*) is this narrow
_DELTA_C = 1e-6  # certification: first step in cos(theta) above the bracket (about 1e-5 rad in theta)
_S_TOL = 1e-7  # certified infeasible when s < -_S_TOL (scaled: 20 um at L_u = 200 m), 10x solver tolerance


_Eval = tuple[float, float, NDArray[np.float64]]
"""One solve of the slack SOCP at a given c: (s(c), ds/dc, y)."""


def _directions(params: Any, targets: np.ndarray, L: float) -> tuple[np.ndarray, np.ndarray]:
    """(u, q) of the slack programs: u the unit directions from each target to the reference
    point R, q the targets' offsets from F in units of L (m); ValueError for a target at R."""
    u = params.R_arr - targets
    nu = np.linalg.norm(u, axis=1, keepdims=True)
    if np.any(nu < 1e-9):
        raise ValueError("targets: a target coincides with the reference point R")
    return u / nu, (targets - params.F_arr) / L


class InstantMinmaxProgram:
    """The slack SOCP  max s  s.t.  u_j.(y - q_j) - c t_j >= s,  |y - q_j| <= t_j,  |y| <= 1,
    |y - p_i| <= r_i  (extra balls),  in units scaled by L_u around F (y = (D - F) / L_u),
    laid out once for ``n_targets`` targets and ``n_balls`` extra balls in Clarabel's conic
    form (min q.x  s.t.  A x + z = b, z in the cones; x = (y, t, s)) and re-solved with new
    data (targets, c, balls) by filling the few entries of A and b that change; the solver is
    built on the first solve and updated in place after (the sparsity pattern never changes).
    """

    last_accurate: bool = False
    """Whether the last solve ended Solved (not AlmostSolved)."""

    def __init__(self, n_targets: int, n_balls: int = 0):
        if isinstance(n_targets, bool) or not isinstance(n_targets, (int, np.integer)) or n_targets < 1:
            raise ValueError(f"n_targets must be an int >= 1, got {n_targets!r}")
        if isinstance(n_balls, bool) or not isinstance(n_balls, (int, np.integer)) or n_balls < 0:
            raise ValueError(f"n_balls must be an int >= 0, got {n_balls!r}")
        import clarabel

        n, nb = int(n_targets), int(n_balls)
        self.n_targets, self.n_balls = n, nb
        self._clarabel = clarabel
        self._settings = clarabel.DefaultSettings()
        self._settings.verbose = False
        nx = n + 4  # y (3), t (n), s
        rows = n + 4 * (1 + n + nb)  # slack rows, then one 4-row cone per ball (unit, targets, extras)
        self._A = np.zeros((rows, nx))
        self._b = np.zeros(rows)
        self._A[:n, nx - 1] = 1.0  # slack rows:  -u_j.y + c t_j + s + z_j = -u_j.q_j,  z_j >= 0
        for k in range(1 + n + nb):  # cone k:  (rhs - A x) = (radius, y - centre)
            r0 = n + 4 * k
            self._A[r0 + 1 : r0 + 4, :3] = -np.eye(3)
            if 1 <= k <= n:
                self._A[r0, 3 + k - 1] = -1.0  # the radius of target j's cone is t_j
        self._b[n] = 1.0  # |y| <= 1
        self._q = np.zeros(nx)
        self._q[nx - 1] = -1.0  # maximise s
        self._P = sparse.csc_matrix((nx, nx))
        self._diag = (np.arange(n), 3 + np.arange(n))
        mask = self._A != 0.0
        mask[:n, : 3 + n] = True  # -u_j and c: filled in per instance and per solve
        self._csc = sparse.csc_matrix(mask.astype(float))  # the fixed pattern; its data is refilled
        self._nz = (self._csc.indices, np.repeat(np.arange(nx), np.diff(self._csc.indptr)))
        self._cones = [clarabel.NonnegativeConeT(n)] + [clarabel.SecondOrderConeT(4)] * (1 + n + nb)
        self._solver: Any = None

    def set_instance(self, params: Any, targets: Any, balls: Any = None, radius: float | None = None) -> None:
        """Fill in the data: targets (n, 3) m, balls (n_balls, 4) rows (centre (3) m, radius m),
        radius (m) of the ball around F (default params.L_u); params gives F, R and L_u."""
        F = params.F_arr
        L = params.L_u if radius is None else float(radius)
        n = self.n_targets
        u, q = _directions(params, np.asarray(targets, float).reshape(-1, 3), L)
        self._A[:n, :3] = -u
        self._b[:n] = -np.sum(u * q, axis=1)
        cones = self._b[n:].reshape(-1, 4)  # a view: writes go to self._b
        cones[1 : 1 + n, 1:] = -q
        if self.n_balls:
            B = np.asarray(balls, float).reshape(self.n_balls, 4)
            cones[1 + n :, 0] = np.maximum(B[:, 3], 0.0) / L
            cones[1 + n :, 1:] = -(B[:, :3] - F) / L

    def _s(self, c: float) -> _Eval | None:
        """(s(c), ds/dc, y) or None when the solver failed; s = -inf when the balls do not meet."""
        self._A[self._diag] = c
        self._csc.data[:] = self._A[self._nz]
        if self._solver is None:
            self._solver = self._clarabel.DefaultSolver(
                self._P, self._q, self._csc, self._b, self._cones, self._settings
            )
        else:  # the same pattern: new values in place of the solver's copies (no warm start in an IPM)
            self._solver.update(A=self._csc, b=self._b)
        sol = self._solver.solve()
        status = str(sol.status)
        self.last_accurate = status == "Solved"
        if status == "PrimalInfeasible":
            return -math.inf, 0.0, np.full(3, np.nan)
        if status not in ("Solved", "AlmostSolved"):
            return None
        x, lam = np.asarray(sol.x, float), np.asarray(sol.z, float)[: self.n_targets]
        # d(-s*)/dc = sum_j lam_j t_j: the derivative of the optimum in the entries c of A
        return float(x[-1]), -float(lam @ x[3:-1]), x[:3].copy()

    def solve(  # noqa: C901
        self,
        params: Any,
        targets: Any,
        *,
        balls: Any = None,
        c_start: float | None = None,
        radius: float | None = None,
    ) -> tuple[float | None, float | None, NDArray[np.float64] | None, int, str]:
        """(cos of the certified lower bound, cos of the best feasible angle, its point D (m), solves, note).

        targets: (n, 3) m; balls: (n_balls, 4) rows (centre (3) m, radius m); c_start: a cos(theta)
        believed to be below the root (e.g. the previous instant's, minus a margin); radius: the
        radius (m) of the ball around F (default params.L_u, the observation ball).
        The first two are None when theta* >= 90 deg (the cones are no longer convex).
        """
        F = params.F_arr
        L = params.L_u if radius is None else float(radius)
        self.set_instance(params, targets, balls, radius)
        solves = 0

        def ev(c: float) -> _Eval | None:
            nonlocal solves
            solves += 1
            return self._s(c)

        # bracket [lo, hi] with s(lo) > 0 >= s(hi); s is decreasing in c (each row is), but
        # neither convex nor concave in general, so the search takes Newton steps from the
        # known ends of the bracket (closest to the root first) and bisects when both leave it
        lo, hi = 0.0, 1.0
        f_lo: _Eval | None = None
        f_hi: _Eval | None = None
        hi_accurate = False
        c = float(c_start) if c_start is not None and 0.0 < c_start < 1.0 else 0.0
        while solves < 60:
            r = ev(c)
            if r is None:
                return None, None, None, solves, "solver failure"
            if r[0] > 0:
                lo, f_lo = c, r
            else:
                hi, f_hi, hi_accurate = c, r, self.last_accurate
            if f_lo is None and lo == 0.0 and c == 0.0:
                return (
                    None,
                    None,
                    None,
                    solves,
                    ("min-max bearing >= 90 deg (or the balls do not meet): not convex"),
                )
            if f_lo is not None and (hi - lo <= _C_WIDTH or f_lo[0] <= 0.1 * _S_TOL):
                break
            if f_hi is None and hi == 1.0 and c == 1.0:  # s(1) > 0: every cone met at theta = 0
                return 1.0, 1.0, F + L * self._point(f_lo), solves, ""
            ends = [(c0, r0) for c0, r0 in ((lo, f_lo), (hi, f_hi)) if r0 is not None]
            cands = [
                c0 - r0[0] / r0[1]
                for c0, r0 in sorted(ends, key=lambda e: abs(e[1][0]))
                if r0[1] < 0 and math.isfinite(r0[0])
            ]
            c_next = next((x for x in cands if lo < x < hi), None)
            if c_next is not None:
                c = c_next
            else:
                c = 0.0 if f_lo is None else 1.0 if f_hi is None else 0.5 * (lo + hi)
        if f_lo is None:
            return None, None, None, solves, "no feasible angle found"
        # certify: the first c above lo, in steps growing from _DELTA_C, with s clearly negative
        step = _DELTA_C
        while True:
            c_cert = min(lo + step, 1.0)
            if c_cert >= hi and f_hi is not None and f_hi[0] < -_S_TOL and hi_accurate:
                c_cert = hi
                break
            r = ev(c_cert)
            if r is None:
                return None, lo, F + L * self._point(f_lo), solves, "solver failure at the certification step"
            if (r[0] < -_S_TOL and self.last_accurate) or c_cert >= 1.0:
                break
            step *= 10
        return c_cert, lo, F + L * self._point(f_lo), solves, ""

    def _point(self, r: _Eval | None) -> NDArray[np.float64]:
        return require_set(r, "_point is called once a feasible angle (s > 0) was found")[2]


def _cvxpy_status(status: str | None) -> Status:
    """The Status of a cvxpy problem status: only a solve the solver proved optimal is OPTIMAL."""
    return {
        "optimal": Status.OPTIMAL,
        "optimal_inaccurate": Status.FEASIBLE,
        "infeasible": Status.INFEASIBLE,
        "unbounded": Status.UNBOUNDED,
        "infeasible_inaccurate": Status.NO_SOLUTION,
        "unbounded_inaccurate": Status.NO_SOLUTION,
        "user_limit": Status.NO_SOLUTION,
    }.get(str(status), Status.ERROR)


@dataclass(frozen=True, eq=False)
class SlackModel:
    """The slack SOCP of the module docstring as a parametrised (DPP) cvxpy problem.

    maximise s  s.t.  u_j.(y - q_j) - c t_j >= s,  |y - q_j| <= t_j,  |y| <= 1,  |y - p_i| <= r_i,
    in units scaled by the radius L of the ball around F: y = (D - F) / L (D in m), q_j =
    (A_j - F) / L for the targets A_j (m), (p_i, r_i) = (centre - F, radius) / L for the extra
    balls. ``s`` and ``t`` are in units of L; ``c`` is cos(theta) (dimensionless). The data are
    cvxpy Parameters, so the problem is compiled on its first solve and re-solved with new data
    after :meth:`set_data` or a new ``c.value``. ``print(model.problem)`` shows it; a user adds
    constraints with ``cp.Problem(model.problem.objective, model.problem.constraints + [...])``
    (``D`` gives the position in metres) and solves with any cvxpy solver, or with
    :func:`solve_slack`. The optimum s(c) is positive when some D of the set sees every target
    within the angle arccos(c), and its root in c is cos of the min-max bearing change.
    """

    problem: cp.Problem
    """The cvxpy problem (maximise s)."""
    y: cp.Variable
    """(3,) position scaled around F: (D - F) / L (dimensionless)."""
    t: cp.Variable
    """(n_targets,) scaled distances |y - q_j| (units of L)."""
    s: cp.Variable
    """The slack (units of L)."""
    D: cp.Expression
    """(3,) position F + L y (m)."""
    c: cp.Parameter
    """cos(theta), dimensionless, in [-1, 1]."""
    rows: cp.Constraint
    """The slack rows u_j.(y - q_j) - c t_j >= s; their duals give ds/dc = -sum_j lambda_j t_j."""
    data: dict[str, cp.Parameter]
    """The other Parameters: u (n, 3) unit vectors A_j -> R, uq (n,) u_j.q_j, q (n, 3), centre (3,)
    = F (m), scale (L, m), and with extra balls ball_centre (n_balls, 3) and ball_radius (n_balls,)."""
    n_targets: int
    n_balls: int

    def set_data(self, params: Any, targets: Any, *, balls: Any = None, radius: float | None = None) -> None:
        """Fill in the data: targets (n_targets, 3) m, balls (n_balls, 4) rows (centre (3) m, radius
        m), radius (m) of the ball around F (default params.L_u); params gives F, R and L_u (m)."""
        F = params.F_arr
        L = check_positive("radius", params.L_u if radius is None else radius)
        A = check_array("targets", np.asarray(targets, float).reshape(-1, 3), shape=(self.n_targets, 3))
        u, q = _directions(params, A, L)
        d = self.data
        d["u"].value, d["q"].value, d["uq"].value = u, q, np.sum(u * q, axis=1)
        d["centre"].value, d["scale"].value = np.asarray(F, float), L
        if self.n_balls:
            if balls is None:
                raise ValueError(f"balls: {self.n_balls} rows (centre (3) m, radius m) needed")
            B = check_array("balls", np.asarray(balls, float).reshape(-1, 4), shape=(self.n_balls, 4))
            d["ball_centre"].value = (B[:, :3] - F) / L
            d["ball_radius"].value = np.maximum(B[:, 3], 0.0) / L


def _slack_model(n_targets: int, n_balls: int) -> SlackModel:
    """The parametrised slack SOCP for n_targets targets and n_balls extra balls (data unset)."""
    import cvxpy as cp

    n, nb = n_targets, n_balls
    y, t, s = cp.Variable(3, name="y"), cp.Variable(n, name="t"), cp.Variable(name="s")
    c = cp.Parameter(name="c")
    d = {
        "u": cp.Parameter((n, 3), name="u"),
        "uq": cp.Parameter(n, name="uq"),
        "q": cp.Parameter((n, 3), name="q"),
        "centre": cp.Parameter(3, name="F"),
        "scale": cp.Parameter(pos=True, name="L"),
    }
    Y = np.ones((n, 1)) @ cp.reshape(y, (1, 3), order="C")
    rows = d["u"] @ y - d["uq"] - c * t >= s
    cons = [rows, cp.SOC(t, Y - d["q"], axis=1), cp.SOC(cp.Constant(1.0), y)]
    if nb:
        d["ball_centre"] = cp.Parameter((nb, 3), name="ball_centre")
        d["ball_radius"] = cp.Parameter(nb, nonneg=True, name="ball_radius")
        Yb = np.ones((nb, 1)) @ cp.reshape(y, (1, 3), order="C")
        cons.append(cp.SOC(d["ball_radius"], Yb - d["ball_centre"], axis=1))
    problem = cp.Problem(cp.Maximize(s), cons)
    D = d["centre"] + d["scale"] * y
    return SlackModel(problem, y, t, s, D, c, rows, d, n, nb)


def build_instant_slack(
    params: Any, targets: Any, c: float, *, balls: Any = None, radius: float | None = None
) -> SlackModel:
    """The per-instant slack SOCP at c = cos(theta) as a cvxpy model (see :class:`SlackModel`).

    params: CovertParams (F, R, L_u in m); targets: (n, 3) positions (m), n >= 1; c: cos(theta)
    in [-1, 1]; balls: optional (n_balls, 4) rows (centre (3) m, radius m) the position must also
    lie in; radius: radius (m) of the ball around F (default params.L_u, the observation ball).
    The model keeps its shape (n targets, n_balls balls): re-solve it with other data of that
    shape through ``model.set_data(...)`` and ``model.c.value = ...`` without recompiling.
    """
    A = check_array("targets", np.asarray(targets, dtype=float).reshape(-1, 3), min_rows=1)
    _check_targets_work(A.shape[0])
    c = check_in_range("c", c, -1.0, 1.0)
    nb = 0 if balls is None else check_array("balls", np.asarray(balls, float).reshape(-1, 4)).shape[0]
    model = _slack_model(A.shape[0], nb)
    model.set_data(params, A, balls=balls, radius=radius)
    model.c.value = c
    return model


def build_mission_slack(
    scenario: Any,
    t: float,
    t_a: float,
    c: float,
    *,
    t_f: float | None = None,
    retreat: bool = True,
    t_end: float | None = None,
    sphere_tol: float = 1.0,
) -> SlackModel:
    """The slack SOCP of the whole-mission bound at instant t (s) and c = cos(theta), as a cvxpy model.

    The targets are those observable at t; the position is restricted to the set a drone of
    the class of :func:`mission_lower_bound` (arrival t_a (s), departure t_f (s), ``retreat``,
    ``t_end`` (s), ``sphere_tol`` (m): same meanings and defaults) can occupy at t: a ball
    around F of radius L_u + sphere_tol + V_max x (time off the sphere) (m) and the balls around
    D_s of what is reachable from the start and, with ``retreat``, of what still gets home.
    The root in c of the optimum s(c) is cos of that instant's bound. Raises ValueError when no
    target is observable at t.
    """
    from droneplan.scenarios.covert import CovertScenario

    check_instance("scenario", scenario, CovertScenario)
    t = check_nonneg("t", t)
    t_a = check_in_range("t_a", t_a, 0.0, MAX_COORDINATE)
    retreat = check_bool("retreat", retreat)
    sphere_tol = check_nonneg("sphere_tol", sphere_tol)
    p = scenario.params
    T = p.duration if t_end is None else check_positive("t_end", t_end)
    back = (np.linalg.norm(p.D_s_arr - p.F_arr) - p.L_u) / p.V_max
    tf = (T - back) if t_f is None else check_nonneg("t_f", t_f)
    if not tf >= t_a:
        raise ValueError(f"t_f must be >= t_a, got t_f={tf:.6g} and t_a={t_a:.6g}")
    tt = np.array([t])
    m = np.asarray(scenario.observable_at(tt))[0]
    if not m.any():
        raise ValueError(f"t: no target is observable at t={t:.6g} s")
    A = np.asarray(scenario.targets_at(tt))[0][m]
    radius, balls = _instant_balls(p, t, t_a, tf, T, retreat, sphere_tol)
    return build_instant_slack(p, A, c, balls=np.array(balls), radius=radius)


def solve_slack(model: SlackModel, *, solver: str | None = "CLARABEL", **solver_options: Any) -> SolveResult:
    """Solve a :class:`SlackModel` (or its data as they stand) with a cvxpy solver.

    solver: a cvxpy solver name (default CLARABEL; None lets cvxpy choose); solver_options go to
    ``problem.solve``. Returns objective = s (units of L), x = D (3,) (m), info["ds_dc"] = ds/dc
    from the duals of the slack rows (None when the solver gives no duals), info["y"] = the
    scaled position; ``bound`` is None. Status: OPTIMAL only when
    the solver reports ``optimal``; ``optimal_inaccurate`` is FEASIBLE, ``infeasible`` (the balls
    do not meet) INFEASIBLE, an inaccurate infeasibility NO_SOLUTION, a solver failure ERROR.
    """
    import cvxpy as cp

    check_instance("model", model, SlackModel)
    backend = "cvxpy" if solver is None else f"cvxpy-{str(solver).lower()}"
    t0 = time.perf_counter()
    try:
        model.problem.solve(solver=solver, **solver_options)
    except cp.error.SolverError as exc:
        return SolveResult(
            Status.ERROR, backend=backend, solve_time=time.perf_counter() - t0, message=str(exc)
        )
    el = time.perf_counter() - t0
    status = _cvxpy_status(model.problem.status)
    if not status.has_solution:
        return SolveResult(
            status,
            backend=backend,
            backend_status=str(model.problem.status),
            solve_time=el,
            message="slack SOCP: no solution",
        )
    lam, tv = model.rows.dual_value, model.t.value
    ds_dc = None if lam is None else -float(np.asarray(lam, float).reshape(-1) @ np.asarray(tv, float))
    return SolveResult(
        status,
        objective=float(np.asarray(model.s.value, float)),
        x=np.asarray(model.D.value, float),
        backend=backend,
        backend_status=str(model.problem.status),
        solve_time=el,
        message="slack SOCP at c = cos(theta): objective s in units of the ball radius L",
        info={"ds_dc": ds_dc, "y": np.asarray(model.y.value, float)},
    )


class _CvxpyProgram(InstantMinmaxProgram):
    """:class:`InstantMinmaxProgram` with each slack solve done on a :class:`SlackModel` (cvxpy,
    Clarabel underneath), compiled once and re-solved with new parameter values."""

    def __init__(self, n_targets: int, n_balls: int = 0):
        if isinstance(n_targets, bool) or not isinstance(n_targets, (int, np.integer)) or n_targets < 1:
            raise ValueError(f"n_targets must be an int >= 1, got {n_targets!r}")
        if isinstance(n_balls, bool) or not isinstance(n_balls, (int, np.integer)) or n_balls < 0:
            raise ValueError(f"n_balls must be an int >= 0, got {n_balls!r}")
        self.n_targets, self.n_balls = int(n_targets), int(n_balls)
        self.model = _slack_model(self.n_targets, self.n_balls)

    def set_instance(self, params: Any, targets: Any, balls: Any = None, radius: float | None = None) -> None:
        self.model.set_data(params, targets, balls=balls, radius=radius)

    def _s(self, c: float) -> _Eval | None:
        import cvxpy as cp

        m = self.model
        m.c.value = c
        try:
            m.problem.solve(solver=cp.CLARABEL)
        except cp.error.SolverError:
            self.last_accurate = False
            return None
        status = _cvxpy_status(m.problem.status)
        self.last_accurate = status is Status.OPTIMAL
        if status is Status.INFEASIBLE:
            return -math.inf, 0.0, np.full(3, np.nan)
        if not status.has_solution:
            return None
        lam = np.asarray(m.rows.dual_value, float).reshape(-1)
        return (
            float(np.asarray(m.s.value, float)),
            -float(lam @ np.asarray(m.t.value, float)),
            np.asarray(m.y.value, float).copy(),
        )


_PROGRAMS: dict[tuple[int, int, str], InstantMinmaxProgram] = {}


def _program(n: int, n_balls: int, backend: str = "clarabel") -> InstantMinmaxProgram:
    key = (n, n_balls, backend)
    if key not in _PROGRAMS:
        _PROGRAMS[key] = (_CvxpyProgram if backend == "cvxpy" else InstantMinmaxProgram)(n, n_balls)
    return _PROGRAMS[key]


def _check_backend(backend: Any) -> str:
    if backend not in BACKENDS:
        raise ValueError(f"backend must be one of {BACKENDS}, got {backend!r}")
    return str(backend)


def _to_sphere(params: Any, D: NDArray[np.float64]) -> NDArray[np.float64]:
    """The point where the segment from D (inside the ball) to R (outside) crosses the sphere."""
    F, L, R = params.F_arr, params.L_u, params.R_arr
    d = R - D
    a, b, c = d @ d, 2 * d @ (D - F), (D - F) @ (D - F) - L * L
    tau = (-b + math.sqrt(max(b * b - 4 * a * c, 0.0))) / (2 * a)
    P = D + min(max(tau, 0.0), 1.0) * d
    return F + L * (P - F) / np.linalg.norm(P - F)


def _check_targets_work(n_targets: int) -> None:
    """Refuse up front a convex program over more targets than the evaluations budget allows.

    Building and solving the program of :func:`instant_minmax_bearing` grows about as the square
    of the number of targets n (some tens of milliseconds at n = 50, seconds at n = 200), so the
    work counted is the n (n + 1) / 2 target pairs (at most about 450 targets under the default
    budget; raise it with ``core.validation.work_limits(evaluations=...)``)."""
    check_work("targets (target pairs of the convex program)", n_targets * (n_targets + 1) / 2, "evaluations")


def instant_minmax_bearing(
    params: Any, targets: Any, *, c_start: float | None = None, backend: str = "clarabel"
) -> SolveResult:
    """Exact min over the observation sphere of max_j beta_j (rad) for fixed targets, by the convex program.

    targets: (n, 3) positions (m), n >= 1. Returns OPTIMAL with objective = max_j beta_j at
    the returned point x (3,) of the sphere (m) and bound = a certified lower bound (rad):
    no point of the sphere does better; both agree to about 1e-5 rad (up to 1e-4 rad for optima
    within a degree of 0). Returns ERROR (no numbers) when the program does not apply: R
    inside the observation ball, or an optimum of 90 deg or more (then the cones are not convex; use
    the branch and bound).
    c_start: cos of an angle believed to be below the optimum (speeds up a sequence of instants).
    backend: "clarabel" (default: the program laid out directly for Clarabel) or "cvxpy" (the
    :class:`SlackModel` of :func:`build_instant_slack`, solved by Clarabel through cvxpy; the same
    optimum, slower); the result's ``backend`` names it.
    """
    from droneplan.scenarios.covert import bearing_changes

    t0 = time.perf_counter()
    backend = _check_backend(backend)
    A = check_array("targets", np.asarray(targets, dtype=float).reshape(-1, 3), min_rows=1)
    _check_targets_work(A.shape[0])
    if np.linalg.norm(params.R_arr - params.F_arr) <= params.L_u:
        return SolveResult(
            Status.ERROR,
            backend=backend,
            solve_time=time.perf_counter() - t0,
            message="R lies inside the observation ball: the convex reformulation does not apply",
        )
    c_lo, c_best, D, solves, note = _program(A.shape[0], 0, backend).solve(params, A, c_start=c_start)
    el = time.perf_counter() - t0
    if c_lo is None or D is None:
        return SolveResult(
            Status.ERROR,
            backend=backend,
            solve_time=el,
            iterations=solves,
            message=f"convex per-instant program not applicable: {note}",
        )
    P = _to_sphere(params, D)
    val = float(bearing_changes(P, A, params.R_arr).max())
    bound = min(math.acos(min(c_lo, 1.0)), val)
    return SolveResult(
        Status.OPTIMAL,
        objective=val,
        bound=bound,
        x=P,
        backend=backend,
        solve_time=el,
        iterations=solves,
        message=f"exact convex per-instant optimum (SOCP slack form, Newton on cos theta, "
        f"{solves} solves); bound = certified lower bound on min over the sphere of "
        f"max_j beta_j (rad)",
        info={"cos_theta": c_best},
    )


@dataclass(frozen=True)
class MissionBound:
    """Lower bound on the mission's beta_max for every controller of the class described in
    :func:`mission_lower_bound`.

    t: (K,) instants (s); per_instant: (K,) certified lower bounds (rad) of min max_j beta_j over
    the set reachable at t (NaN where no target is observable or the program does not apply);
    value: max over the instants (rad), the bound; t_a, t_f: the class's arrival and departure
    times (s).
    """

    t: NDArray[np.float64]
    per_instant: NDArray[np.float64]
    value: float
    t_a: float
    t_f: float

    @property
    def argmax(self) -> float:
        """Instant (s) where the bound is attained."""
        return float(self.t[int(np.nanargmax(self.per_instant))])


def _instant_balls(
    p: Any, t: float, t_a: float, t_f: float, t_end: float, retreat: bool, sphere_tol: float
) -> tuple[float, list[NDArray[np.float64]]]:
    """(radius around F, extra balls) of the set a drone of the class can occupy at time t."""
    balls = [np.r_[p.D_s_arr, p.V_max * t]]
    if retreat:
        balls.append(np.r_[p.D_s_arr, p.V_max * max(t_end - t, 0.0)])
    radius = p.L_u + sphere_tol
    if t < t_a:
        radius += p.V_max * (t_a - t)
    elif t > t_f:
        radius += p.V_max * (t - t_f)
    return radius, balls


def mission_lower_bound(
    scenario: Any,
    t_a: float,
    t_f: float | None = None,
    *,
    times: Any = None,
    retreat: bool = True,
    t_end: float | None = None,
    sphere_tol: float = 1.0,
    backend: str = "clarabel",
) -> MissionBound:
    """Lower bound on beta_max (rad) on ``scenario`` for any controller that leaves D_s at t = 0 at
    speed <= V_max, is on the observation sphere (within ``sphere_tol`` m) from ``t_a`` (s) to
    ``t_f`` (s; default: the latest time from which D_s is still reachable by t_end) and, with
    ``retreat``, is back at D_s by ``t_end`` (s; default params.duration).

    At every instant of ``times`` (default: every control period params.dt) the drone lies in
    the convex set described in the module docstring; the certified minimum of max_j beta_j
    over the observable targets on that set bounds what any such controller records at that
    instant, so their maximum bounds beta_max (the recorded maximum over the run). Instants
    where the program does not apply (optimum >= 90 deg, or an empty set: the class cannot
    reach the sphere by t_a) are NaN and left out. backend: as in :func:`instant_minmax_bearing`
    (the cvxpy model of an instant is :func:`build_mission_slack`).
    """
    t_a = check_in_range("t_a", t_a, 0.0, MAX_COORDINATE)
    return mission_front(
        scenario,
        [t_a],
        t_f,
        times=times,
        retreat=retreat,
        t_end=t_end,
        sphere_tol=sphere_tol,
        backend=backend,
    )[0]


def mission_front(  # noqa: C901, PLR0915
    scenario: Any,
    arrival_times: Any,
    t_f: float | None = None,
    *,
    times: Any = None,
    retreat: bool = True,
    t_end: float | None = None,
    sphere_tol: float = 1.0,
    backend: str = "clarabel",
) -> list[MissionBound]:
    """:func:`mission_lower_bound` for several arrival times (s), sharing the instants after arrival.

    scenario: the targets' paths and the parameters (no obstacles); arrival_times: the t_a (s) of
    each class; t_f, times, retreat, t_end, sphere_tol, backend: as in :func:`mission_lower_bound`.
    Every instant is one convex program per arrival time at worst: more than the solves budget
    (``core.validation.work_limits``) of instants times arrival times is refused up front.
    Returns one :class:`MissionBound` per arrival time. The bound is non-increasing in the
    arrival time (a later deadline admits more controllers): the stealth-versus-arrival-time
    front of the best any controller could do.
    """
    from droneplan.scenarios.covert import CovertScenario

    check_instance("scenario", scenario, CovertScenario)
    retreat = check_bool("retreat", retreat)
    sphere_tol = check_nonneg("sphere_tol", sphere_tol)
    backend = _check_backend(backend)
    if t_end is not None:
        t_end = check_positive("t_end", t_end)
    if t_f is not None:
        t_f = check_nonneg("t_f", t_f)
    if times is not None:
        times = check_array("times", times, shape=(None,), min_rows=1)
    arrival_times = check_array("arrival_times", arrival_times, ndim=None)
    arrival_times = np.atleast_1d(arrival_times)
    p = scenario.params
    if getattr(scenario, "obstacles", ()):
        raise ValueError(
            "scenario has obstacles: which targets are visible depends on the drone position, "
            "and the bound assumes the visible set is the same for every position"
        )
    arr = np.atleast_1d(np.asarray(arrival_times, float))
    if arr.size == 0 or not np.all(np.isfinite(arr)) or np.any(arr < 0):
        raise ValueError(f"arrival_times must be finite and >= 0, got {arrival_times!r}")
    if not (math.isfinite(sphere_tol) and sphere_tol >= 0):
        raise ValueError(f"sphere_tol must be finite and >= 0, got {sphere_tol}")
    T = p.duration if t_end is None else float(t_end)
    if not (math.isfinite(T) and T > 0):
        raise ValueError(f"t_end must be finite and > 0, got {t_end}")
    back = (np.linalg.norm(p.D_s_arr - p.F_arr) - p.L_u) / p.V_max  # shortest way home from the sphere
    tf = (T - back) if t_f is None else float(t_f)
    if not (math.isfinite(tf) and tf >= arr.max()):
        src = "t_f" if t_f is not None else f"t_f (t_end minus {back:.3g} s, the shortest way home)"
        raise ValueError(
            f"{src} must be finite and >= every arrival time (t_a / arrival_times, latest "
            f"{arr.max():.6g} s), got t_f={tf:.6g}"
        )
    n_times = math.floor(T / p.dt) + 1 if times is None else len(times)
    what = "t_end / params.dt (instants)" if times is None else "times"
    check_size(what, n_times)
    # one program per instant after the earliest arrival, and per arrival time before it
    check_work(f"{what} x arrival_times", n_times * (1 + arr.size), "solves")
    _check_targets_work(len(scenario.paths))
    tt = np.arange(0.0, T + 1e-9, p.dt) if times is None else np.asarray(times, float)
    A_all = scenario.targets_at(tt)
    obs = scenario.observable_at(tt)

    def run(mask_t: NDArray[np.bool_], t_a: float) -> NDArray[np.float64]:
        out = np.full(tt.shape, np.nan)
        c_prev = None
        for k in np.nonzero(mask_t)[0]:
            m = obs[k]
            if not m.any():
                continue
            radius, balls = _instant_balls(p, float(tt[k]), t_a, tf, T, retreat, sphere_tol)
            res = _mission_instant(p, A_all[k][m], balls, radius, c_prev, backend)
            if res is not None:
                out[k] = res[0]
                c_prev = max(res[1] - 1e-3, 0.0)
        return out

    after = run(tt >= arr.min(), float(arr.min()))  # instants on or after the earliest arrival
    fronts = []
    for t_a in arr:
        vals = np.where(tt >= t_a, after, np.nan)
        before = run(tt < t_a, float(t_a))
        vals = np.where(tt < t_a, before, vals)
        val = float(np.nanmax(vals)) if np.isfinite(vals).any() else math.nan
        fronts.append(MissionBound(tt, vals, val, float(t_a), tf))
    return fronts


def _mission_instant(
    p: Any,
    A: NDArray[np.float64],
    balls: list[NDArray[np.float64]],
    radius_F: float,
    c_start: float | None,
    backend: str = "clarabel",
) -> tuple[float, float] | None:
    """Certified min max beta over {|D - F| <= radius_F} ∩ balls, as (bound rad, cos) or None."""
    extra = list(balls)
    prog = _program(A.shape[0], len(extra), backend)
    try:
        c_lo, c_best, _, _, _ = prog.solve(p, A, balls=np.array(extra), c_start=c_start, radius=radius_F)
    except ValueError:
        return None
    if c_lo is None:
        return None
    c_best = require_set(c_best, "a certified bound comes with the best feasible angle")
    return math.acos(min(c_lo, 1.0)), c_best
