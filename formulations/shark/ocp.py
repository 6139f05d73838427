"""Time-optimal interception as an optimal control problem (CasADi / IPOPT).

Decision: final time T (s), operator nodes O_0..O_N (m) and piecewise-constant
velocities U_0..U_{N-1} (m/s) on the uniform grid t_k = k T / N.

    minimise   T  (+ 1e-6 * sum_k h |U_k|^2 to make the controls unique)
    s.t.       O_{k+1} = O_k + h U_k,  h = T/N                     (integrator, eq. 5.4)
               |U_k,xy| <= VoMxy,  |U_k,z| <= VoMz,  lmin <= z_o <= le
               |S(t0 + t) - (O(t) - l_j e_z)| >= eps_o + margin  (j = 1, 2; the field
                   never touches the shark: at the nodes 1..N-1 and the interval midpoints,
                   the last midpoint with margin 0)
               O_N,xy = S_xy(T) + eps'(T) u(T),  eps' = eps*(1 + gamma)   (frontal, eq. 5.8/5.9)
               O_N,z  = z_o*(z_s(T))                                       (exact optimal altitude)

u is the shark's horizontal heading. The shark's path S is either known (a
`SharkTrajectory`, offline: the physical limit for that path) or predicted at
constant horizontal velocity and constant depth from its current state (online).
Being nonconvex (the field must pass on one side of the shark), the problem is solved
from several starting plans (e.g. the virtual-shark rollouts on both sides of the path)
and the best local optimum is kept.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, ClassVar

import casadi as ca
import numpy as np
from numpy.typing import NDArray

from droneplan.core.validation import (
    MAX_COORDINATE,
    check_array,
    check_in_range,
    check_instance,
    check_int,
    check_positive,
    check_size,
    check_work,
    require_set,
)
from droneplan.scenarios.shark import THESIS_TABLE_5_1, SharkParams, SharkTrajectory
from droneplan.solvers.registry import available_backends, get_backend
from droneplan.solvers.result import SolveResult

__all__ = [
    "InterceptionPlan",
    "InterceptionOCP",
    "build_interception_nlp",
    "solve_interception",
    "casadi_optimal_altitude",
]

_REG = 1e-6


@dataclass(frozen=True)
class InterceptionPlan:
    """An operator plan: node times t (N+1,) s, positions operator (N+1,3) m, velocities (N,3) m/s.

    T: interception time (s, relative to the plan's start); side: +1 if the operator ends on
    the left of the shark's path side it came from, -1 right, 0 unknown; origin: where the
    plan comes from when it is used as a starting plan ("crude" for the formulation's own
    guesses, "virtual-shark" for the thesis heuristic's rollout, "" unknown).
    """

    t: NDArray[np.float64]
    operator: NDArray[np.float64]
    velocity: NDArray[np.float64]
    """(N, 3) piecewise-constant operator velocities (m/s), one per interval."""
    T: float
    side: int = 0
    origin: str = ""

    def position(self, t) -> NDArray[np.float64]:
        """Planned position (m) at time(s) t (s), clamped to [0, T]."""
        t = np.clip(np.asarray(t, float), 0.0, self.T)
        return np.stack([np.interp(t, self.t, self.operator[:, i]) for i in range(3)], axis=-1)

    @classmethod
    def from_samples(cls, t, operator, side: int = 0, origin: str = "") -> InterceptionPlan:
        """A plan from sampled positions (e.g. a closed-loop rollout up to its interception time)."""
        t = np.asarray(t, float)
        op = np.asarray(operator, float)
        if len(t) < 2 or op.shape != (len(t), 3):
            raise ValueError("from_samples needs >= 2 times and (len(t), 3) positions")
        vel = np.diff(op, axis=0) / np.diff(t)[:, None]
        return cls(t - t[0], op, vel, float(t[-1] - t[0]), side, origin)

    def resample(self, N: int) -> InterceptionPlan:
        """The same plan on N uniform intervals."""
        tt = np.linspace(0.0, self.T, N + 1)
        op = self.position(tt)
        vel = np.diff(op, axis=0) / max(self.T / N, 1e-9)
        return InterceptionPlan(tt, op, vel, self.T, self.side, self.origin)


def casadi_optimal_altitude(z_s, params: SharkParams):
    """Symbolic twin of `optimal_altitude`: (z_o*, eps*) as CasADi expressions of z_s.

    eps* is floored at 1e-3 m (the square root is kept differentiable).
    """
    z1 = ca.fmin(ca.fmax(z_s + params.l1, params.lmin), params.le)
    z2 = ca.fmin(ca.fmax(z_s + params.l2, params.lmin), params.le)
    e1 = params.eps_o**2 - (z1 - z_s - params.l1) ** 2
    e2 = params.eps_o**2 - (z2 - z_s - params.l2) ** 2
    zo = ca.if_else(e1 >= e2, z1, z2)
    eps = ca.sqrt(ca.fmax(ca.fmax(e1, e2), 1e-6))
    return zo, eps


_PathFunction = Callable[[Any, Any], Any]
"""f(t, p) -> a CasADi expression, for symbolic time t and parameter vector p."""


def _path_functions(path: SharkTrajectory | None) -> tuple[_PathFunction, _PathFunction, int, Any]:
    """(S(t, p), V(t, p), n_p, symbol class): shark position (3) and horizontal velocity (2)
    as CasADi functions, the parameter count and the CasADi symbol class (SX or MX)."""
    if path is None:  # constant-velocity prediction, p = [S0 (3), V0 (2)]

        def S_line(t: Any, p: Any) -> Any:
            return ca.vertcat(p[0] + p[3] * t, p[1] + p[4] * t, p[2])

        def V_line(t: Any, p: Any) -> Any:
            return ca.vertcat(p[3], p[4])

        return S_line, V_line, 5, ca.SX
    grid = [np.asarray(path.t, float)]
    fx = [ca.interpolant(f"s{i}", "bspline", grid, path.pos[:, i]) for i in range(3)]
    fv = [ca.interpolant(f"v{i}", "bspline", grid, path.vel[:, i]) for i in range(2)]

    def S_path(t: Any, p: Any) -> Any:  # p = [t0]
        return ca.vertcat(*[f(p[0] + t) for f in fx])

    def V_path(t: Any, p: Any) -> Any:
        return ca.vertcat(*[f(p[0] + t) for f in fv])

    return S_path, V_path, 1, ca.MX


def build_interception_nlp(
    params: SharkParams = THESIS_TABLE_5_1,
    *,
    N: int = 40,
    path: SharkTrajectory | None = None,
    margin: float = 0.05,
) -> dict:
    """Build (only) the NLP of the interception OCP; returns {"nlp", "N", "n_p", "kind"}.

    x = [T, O_0..O_N (3 each), U_0..U_{N-1} (3 each)]; p = [t0] (known path) or
    [S0 (3), V0 (2)] (constant-velocity prediction). g layout: dynamics (3N), horizontal
    speed (N), clearance (2(N-1) nodes + 2N midpoints), terminal (3).

    params: problem parameters, SharkParams (default: THESIS_TABLE_5_1).
    margin: clearance added to eps_o in the no-touch constraints (m).
    N: control intervals (>= 2; at most 1000 under the default evaluations budget of
    ``core.validation.work_limits``).
    """
    check_instance("params", params, SharkParams)
    check_instance("path", path, SharkTrajectory, optional=True)
    check_int("N", N, min_value=2)
    # building and solving grow faster than N (N = 10^4: 7 s to build, N = 3000: 25 s to solve)
    check_work("N (OCP intervals, 100 evaluations each)", 100 * N, "evaluations")
    check_in_range("margin", margin, 0.0, MAX_COORDINATE)
    S, V, n_p, Sym = _path_functions(path)
    T = Sym.sym("T")
    O = Sym.sym("O", 3, N + 1)
    U = Sym.sym("U", 3, N)
    p = Sym.sym("p", n_p)
    h = T / N
    dyn = ca.vec(O[:, 1:] - O[:, :-1] - h * U)
    spd = ca.sum1(U[:2, :] ** 2).T
    lift = ca.DM([0, 0, 1])
    clear: list[Any] = []
    rmin2 = (params.eps_o + margin) ** 2
    for k in range(1, N):
        Sk = S(k * h, p)
        clear.extend(ca.sumsqr(Sk - (O[:, k] - lj * lift)) - rmin2 for lj in (params.l1, params.l2))
    for k in range(N):
        Sk = S((k + 0.5) * h, p)
        Om = 0.5 * (O[:, k] + O[:, k + 1])
        r2 = rmin2 if k < N - 1 else params.eps_o**2
        clear.extend(ca.sumsqr(Sk - (Om - lj * lift)) - r2 for lj in (params.l1, params.l2))
    ST = S(T, p)
    VT = V(T, p)
    u = VT / ca.sqrt(ca.sumsqr(VT) + 1e-6)
    zo, eps = casadi_optimal_altitude(ca.fmin(ST[2], 0), params)
    term = ca.vertcat(O[:2, N] - ST[:2] - eps * (1 + params.gamma) * u, O[2, N] - zo)
    x = ca.vertcat(T, ca.vec(O), ca.vec(U))
    f = T + _REG * h * ca.sumsqr(U)
    g = ca.vertcat(dyn, spd, ca.vertcat(*clear), term)
    return {
        "nlp": {"x": x, "f": f, "g": g, "p": p},
        "N": N,
        "n_p": n_p,
        "kind": "constant-velocity" if path is None else "known-path",
        "n_dyn": 3 * N,
        "n_spd": N,
        "n_clear": len(clear),
    }


class InterceptionOCP:
    """The interception OCP built once (IPOPT instance reused across solves).

    params: problem parameters; N: intervals; path: known shark path (None: constant-velocity
    prediction); margin: clearance margin (m) to the balls; t_max: upper bound on T (s);
    time_limit: wall-clock limit per solve (s); max_iter: iteration limit.
    backend: a registered "nlp" backend that solves to a local optimum ("ipopt").
    """

    BACKEND_OPTIONS: ClassVar[dict[str, dict[str, float]]] = {"ipopt": {"tol": 1e-6, "acceptable_tol": 1e-4}}
    """Backend options by backend name (``max_iter`` is added from the argument)."""

    def __init__(
        self,
        params: SharkParams = THESIS_TABLE_5_1,
        *,
        N: int = 40,
        path: SharkTrajectory | None = None,
        margin: float = 0.05,
        t_max: float = 30.0,
        time_limit: float | None = None,
        max_iter: int = 300,
        backend: str = "ipopt",
    ):
        check_instance("params", params, SharkParams)
        check_positive("t_max", t_max)
        # default_guesses scans the horizon every 0.25 s
        check_size("t_max", t_max / 0.25)
        check_int("max_iter", max_iter, min_value=1)
        self.params, self.N, self.path, self.t_max = params, N, path, t_max
        built = build_interception_nlp(params, N=N, path=path, margin=margin)
        self.layout = built
        self.kind = built["kind"]
        adapter = get_backend(backend, kind="nlp")
        if not adapter.solves_to_local_optimum:
            raise ValueError(
                f"backend {backend!r} does not solve to a local optimum; the interception OCP needs "
                f"one of {[b for b in available_backends('nlp') if get_backend(b).solves_to_local_optimum]}"
            )
        self._reuses_duals = adapter.reuses_duals
        self.solver = adapter.create_nlp(
            built["nlp"],
            time_limit=time_limit,
            options={"max_iter": max_iter, **self.BACKEND_OPTIONS.get(adapter.name, {})},
        )
        nd, ns, nc = built["n_dyn"], built["n_spd"], built["n_clear"]
        self._lbg = np.r_[np.zeros(nd), np.full(ns, -np.inf), np.zeros(nc), np.zeros(3)]
        self._ubg = np.r_[np.zeros(nd), np.full(ns, params.VoMxy**2), np.full(nc, np.inf), np.zeros(3)]

    def _bounds(self, operator0, t0):
        p, N = self.params, self.N
        lbO = np.tile([-np.inf, -np.inf, p.lmin], (N + 1, 1))
        ubO = np.tile([np.inf, np.inf, p.le], (N + 1, 1))
        lbO[0] = ubO[0] = operator0
        lbU = np.tile([-p.VoMxy, -p.VoMxy, -p.VoMz], (N, 1))
        ubU = -lbU
        t_hi = self.t_max if self.path is None else max(min(self.t_max, self.path.duration - t0), 0.2)
        lbx = np.r_[0.05, lbO.ravel(), lbU.ravel()]  # column-major vec of 3xK = row-major of Kx3
        ubx = np.r_[t_hi, ubO.ravel(), ubU.ravel()]
        return lbx, ubx

    def vector(self, plan: InterceptionPlan) -> NDArray[np.float64]:
        """The decision vector of a plan (resampled to N intervals)."""
        r = plan.resample(self.N)
        vel = np.clip(
            r.velocity,
            [-self.params.VoMxy] * 2 + [-self.params.VoMz],
            [self.params.VoMxy] * 2 + [self.params.VoMz],
        )
        return np.r_[r.T, r.operator.ravel(), vel.ravel()]

    def plan(self, x, side: int = 0) -> InterceptionPlan:
        """The plan encoded by decision vector x."""
        N = self.N
        T = float(x[0])
        O = np.asarray(x[1 : 1 + 3 * (N + 1)]).reshape(N + 1, 3)
        U = np.asarray(x[1 + 3 * (N + 1) :]).reshape(N, 3)
        return InterceptionPlan(np.linspace(0, T, N + 1), O, U, T, side)

    def shark_at(self, t, *, t0: float = 0.0, shark_state=None):
        """Shark position (3,) at plan time t under this OCP's path model."""
        if self.path is None:
            S0, V0 = shark_state
            return np.array([S0[0] + V0[0] * t, S0[1] + V0[1] * t, S0[2]])
        return self.path.at(t0 + t)[0]

    def default_guesses(self, operator0, *, t0: float = 0.0, shark_state=None) -> list[InterceptionPlan]:
        """Two crude starting plans, one per side of the path: via a point beside the shark, then
        to the goal."""
        p = self.params
        O0 = np.asarray(operator0, float)
        out = []
        for side in (1, -1):
            T0 = None
            for Tc in np.arange(0.5, self.t_max, 0.25):
                goal = self.shark_at(Tc, t0=t0, shark_state=shark_state)
                if np.linalg.norm(goal[:2] - O0[:2]) + 3 * p.eps_o <= 0.8 * p.VoMxy * Tc:
                    T0 = Tc
                    break
            T0 = T0 or self.t_max / 2
            Sm = self.shark_at(0.5 * T0, t0=t0, shark_state=shark_state)
            Sm2 = self.shark_at(0.5 * T0 + 0.1, t0=t0, shark_state=shark_state)
            uh = (Sm2 - Sm)[:2]
            uh = uh / (np.linalg.norm(uh) + 1e-9)
            pl = side * np.array([-uh[1], uh[0]])
            W = np.r_[Sm[:2] + 2 * p.eps_o * (uh + pl), p.le]
            ST = self.shark_at(T0, t0=t0, shark_state=shark_state)
            ST2 = self.shark_at(T0 + 0.1, t0=t0, shark_state=shark_state)
            uT = (ST2 - ST)[:2] / (np.linalg.norm((ST2 - ST)[:2]) + 1e-9)
            G = np.r_[ST[:2] + p.eps_o * (1 + p.gamma) * uT, p.lmin]
            out.append(InterceptionPlan.from_samples([0.0, 0.5 * T0, T0], [O0, W, G], side, "crude"))
        return out

    def solve(
        self,
        operator0,
        *,
        t0: float = 0.0,
        shark_state=None,
        guess: InterceptionPlan | None = None,
        warm_start: SolveResult | None = None,
        time_limit: float | None = None,
    ) -> SolveResult:
        """Solve from a starting plan (or a previous result's primal/duals); x of the result is a plan."""
        O0 = np.asarray(operator0, float)
        if O0.shape != (3,) or not np.all(np.isfinite(O0)):
            raise ValueError("operator0 must be a finite (3,) position")
        if self.path is None:
            if shark_state is None:
                raise ValueError("a constant-velocity OCP needs shark_state=(position (3,), velocity (>=2,))")
            S0 = np.asarray(shark_state[0], float)
            V0 = np.asarray(shark_state[1], float)[:2]
            if not (np.all(np.isfinite(S0)) and np.all(np.isfinite(V0))):
                raise ValueError("shark_state must be finite")
            par = np.r_[S0, V0]
        else:
            if not math.isfinite(t0) or t0 < 0:
                raise ValueError("t0 must be finite and >= 0")
            par = np.array([t0])
        lbx, ubx = self._bounds(O0, t0)
        if guess is not None:
            x0 = self.vector(guess)
        elif (
            warm_start is not None and warm_start.has_solution and isinstance(warm_start.x, InterceptionPlan)
        ):
            x0 = self.vector(warm_start.x)
        else:  # also a solved warm_start without a plan (x0 was None: np.clip raised TypeError)
            x0 = self.vector(self.default_guesses(O0, t0=t0, shark_state=shark_state)[0])
        x0 = np.clip(x0, lbx, ubx)
        ws = None
        if self._reuses_duals and warm_start is not None and warm_start.has_solution:
            ws = dataclasses.replace(warm_start, x=x0)
        res = self.solver.solve(
            x0=x0, lbx=lbx, ubx=ubx, lbg=self._lbg, ubg=self._ubg, p=par, warm_start=ws, time_limit=time_limit
        )
        side = guess.side if guess is not None else 0
        if res.x is None:
            return dataclasses.replace(res, message=f"interception OCP ({self.kind}): {res.message}")
        plan = self.plan(res.x, side)
        return dataclasses.replace(
            res,
            x=plan,
            objective=plan.T,
            message=f"interception OCP ({self.kind}, N={self.N}): T={plan.T:.3f} s; "
            f"local optimum ({res.backend}), no bound",
            info={**res.info, "x_vector": res.x},
        )


def _shark_state(shark: Any) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The (position (3,) m, velocity (>= 2,) m/s) pair of a constant-velocity shark, checked."""
    if not isinstance(shark, (tuple, list)):
        raise TypeError(
            f"shark must be a SharkTrajectory or (position (3,), velocity (>=2,)), got {shark!r:.60}"
        )
    if len(shark) != 2:
        raise ValueError(
            f"shark must be a SharkTrajectory or (position (3,), velocity (>=2,)), got {len(shark)} items"
        )
    position = check_array("shark position", shark[0], shape=(3,))
    velocity = check_array("shark velocity", shark[1], ndim=1)
    if len(velocity) < 2:
        raise ValueError(f"shark velocity must hold at least (vx, vy), got {len(velocity)} entries")
    return position, velocity


def _check_plans(warm_starts: Any) -> list[InterceptionPlan]:
    """``warm_starts`` as a list of InterceptionPlan (TypeError naming it otherwise)."""
    if isinstance(warm_starts, (str, bytes)) or not hasattr(warm_starts, "__iter__"):
        raise TypeError(
            f"warm_starts must be a sequence of InterceptionPlan, got {type(warm_starts).__name__}"
        )
    plans = list(warm_starts)
    for i, plan in enumerate(plans):
        check_instance(f"warm_starts[{i}]", plan, InterceptionPlan)
    return plans


def solve_interception(
    shark,
    operator0,
    params: SharkParams = THESIS_TABLE_5_1,
    *,
    N: int = 50,
    warm_starts=(),
    t0: float = 0.0,
    margin: float = 0.05,
    t_max: float = 30.0,
    time_limit: float | None = None,
) -> SolveResult:
    """Time-optimal interception: build the OCP, solve from every starting plan, keep the best.

    shark: a `SharkTrajectory` (path known: offline optimum) or (position (3,), velocity (>=2,))
        for the constant-velocity prediction (online).
    operator0: operator position (3,) in m at t0 (s, time on the known path); a shark already
        inside the field at t0 is refused (ValueError): there is nothing to intercept.
    warm_starts: starting plans (`InterceptionPlan`, e.g. virtual-shark rollouts on both
        sides of the path); when empty, two crude plans (one per side) are used.
    Returns the best result: objective = T in s, status FEASIBLE (a local optimum of the OCP,
    ``info["local_optimum"]`` True when IPOPT converged; never OPTIMAL, since only the bound is
    proven), x = `InterceptionPlan`, bound = the proven lower bound on T of
    `formulations.shark.bound.interception_time_bound` (None, with the reason in ``message``,
    if it could not be computed). info["tried"] lists (origin, side, status, T) of every start,
    info["start_won"] the origin of the start the best result came from; ``warm_started`` is
    True only when that start was a heuristic's plan (not one of the formulation's crude
    guesses). Status FEASIBLE/NO_SOLUTION etc. if no start converged.

    params: problem parameters, SharkParams (default: THESIS_TABLE_5_1).
    N: number of control intervals (count).
    margin: clearance added to eps_o in the no-touch constraints (m).
    t_max: upper bound on the interception time T (s).
    time_limit: wall-clock limit per IPOPT solve (s), None: none.
    """
    from droneplan.formulations.shark.bound import interception_time_bound
    from droneplan.scenarios.shark import inside_field

    check_instance("params", params, SharkParams)
    O0 = operator0 = check_array("operator0", operator0, shape=(3,))
    t0 = check_in_range("t0", t0, 0.0, MAX_COORDINATE)
    if isinstance(shark, SharkTrajectory):
        if not t0 < shark.duration:
            raise ValueError(f"t0 must be in [0, {shark.duration}) s (the path's horizon), got {t0}")
        S_now = shark.at(t0)[0]
        ocp = InterceptionOCP(params, N=N, path=shark, margin=margin, t_max=t_max, time_limit=time_limit)
        state = None
    else:
        S_now, velocity = _shark_state(shark)
        ocp = InterceptionOCP(params, N=N, path=None, margin=margin, t_max=t_max, time_limit=time_limit)
        state = (S_now, velocity)
    clearance = float(inside_field(S_now, O0, params))
    if clearance <= 0:
        raise ValueError(
            f"shark is already inside the field at t0 (clearance {clearance:.3f} m <= 0): "
            "operator0 must start with the shark outside both balls"
        )
    starts = _check_plans(warm_starts) or ocp.default_guesses(O0, t0=t0, shark_state=state)
    best: SolveResult | None = None
    best_start: InterceptionPlan | None = None
    best_T = math.inf  # best.objective
    tried = []
    for g in starts:
        r = ocp.solve(O0, t0=t0, shark_state=state, guess=g)
        tried.append((g.origin, g.side, r.status.name, None if r.x is None else r.objective))
        if not r.has_solution:
            continue
        t_int = require_set(r.objective, "a solved OCP reports its T")
        # at a tie, a converged local optimum beats a point IPOPT returned at a limit
        if (
            best is None
            or t_int < best_T - 1e-9
            or (not best.converged and r.converged and t_int <= best_T + 1e-6)
        ):
            best, best_start, best_T = r, g, t_int
    try:
        lb = interception_time_bound(shark, O0, params, t0=t0, t_max=t_max)
        bound = lb.bound
        bound_msg = lb.message
    except Exception as exc:  # noqa: BLE001  # a bound that could not be computed is None, never a number
        bound, bound_msg = None, f"no bound: {type(exc).__name__}: {exc}"
    if best is None:
        last = r
        return dataclasses.replace(
            last,
            bound=bound,
            info={**last.info, "tried": tried, "start_won": None},
            message=f"no start converged: {tried}; {bound_msg}",
        )
    if bound is not None and best_T < bound - 1e-6:  # cannot happen unless a constraint is violated
        bound_msg += f"; WARNING: OCP T={best_T:.6f} s is below it (constraint violation?)"
    won = require_set(best_start, "the start of the best OCP is set with it").origin or "unknown"
    return dataclasses.replace(
        best,
        bound=bound,
        warm_started=won not in ("crude", "unknown"),
        info={**best.info, "tried": tried, "start_won": won, "bound_message": bound_msg},
        message=best.message.replace(f"({best.backend}), no bound", f"({best.backend})")
        + f"; best of {len(starts)} starts (side {best.x.side}, from the {won} start); bound: {bound_msg}",
    )
