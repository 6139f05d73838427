"""The min-max bearing-change MPC of covert observation (thesis ch. 3, objective (3.7)).

Over a horizon of N intervals (the first of length ``params.dt``, the others of
length ``settings.step``) the model chooses heading-rate commands u_k and speeds v_k
for the drone model (3.2)-(3.5) to

    minimise  tau + w_stage * mean_k tau_k + w_smooth * sum_k |Delta command|^2
    s.t.      sin^2 beta_jk <= tau_k^2 cos^2 beta_jk,  tau_k <= tau,  tau_k >= 0
              (epigraph of max_{j,k} tan beta_jk, smooth form)
              D_{k+1}, h_{k+1} = exact rotation step of (D_k, h_k) under (u_k, v_k)
              h_k . u_k = 0,  |u_k|^2 <= U_max^2,  -V_max <= v_k <= V_max        (3.4)-(3.5)
              lo_k <= |D_{k+1} - F| <= hi_k,  |D_{k+1} - D_s| <= home_k   (phase constraints)
              |(D_k - F) . h_k| <= L_u sin 5deg on the sphere from the second node on (heading ~tangent)

where cos beta_jk = c_jk . (A_jk - D_k) / |A_jk - D_k| and sin beta_jk = |c_jk x (A_jk -
D_k)| / |A_jk - D_k|, with c_jk the unit vector from R to the predicted target position
A_jk (3.6). For beta <= 90 deg the constraint says tan beta_jk <= tau_k, so minimising tau
minimises the maximum bearing change (tan is increasing), with polynomial (smooth)
constraints. We first used the epigraph of the minimum cosine: it is smooth too, but
flat near beta = 0 (1 - cos beta ~ beta^2/2), so IPOPT stopped ~1.5 deg short of the
camouflage line; tan beta ~ beta is not flat there. The dynamics are the plant's exact
zero-order-hold rotation (:func:`scenarios.covert.rotate_heading`), written with power
series of theta^2 = |u|^2 Delta^2 so that they are smooth at u = 0; on the first interval
they are the plant's step exactly.

Two ways to solve it:
- backend "ipopt": IPOPT (warm-started from the shifted previous solution, with its duals);
- backend "osqp": sequential QPs on OSQP (:class:`solvers.sqp.SqpSolver`, real-time
  iteration: one QP per control step linearised at the shifted previous solution, with
  a proximal term; the QP matrices keep one sparsity pattern and are updated in place).
Both are looked up in the backend registry.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, replace
from typing import Any

import casadi as ca
import numpy as np
from numpy.typing import NDArray

from droneplan.core.validation import (
    check_array,
    check_in_range,
    check_instance,
    check_int,
    check_nonneg,
    check_positive,
    check_size,
    check_work,
)
from droneplan.scenarios.covert import CovertParams
from droneplan.solvers.base import NlpSolver
from droneplan.solvers.registry import get_backend
from droneplan.solvers.result import SolveResult, Status
from droneplan.solvers.sqp import SqpStructure

__all__ = [
    "MPCSettings",
    "MPCData",
    "MPCPlan",
    "BearingMPC",
    "build_bearing_mpc",
    "solve_bearing_mpc",
    "RecedingBearingMPC",
    "cos_bearing_symbolic",
    "sphere_minmax_bearing",
    "sphere_minmax_bearing_bnb",
]

_SERIES_TERMS = 20  # accurate to 1e-15 for theta = |u| Delta <= 6 rad
TANGENT_TOL_DEG = 5.0  # on the sphere, nodes 2..N keep the heading within this angle of the tangent plane
TAU_PROX, H_PROX = 1e2, 1e-2  # SQP proximal weights of the cosines and headings (relative to prox)


@dataclass(frozen=True)
class MPCSettings:
    """Settings of the bearing MPC."""

    horizon: int = 8
    """Number of intervals N."""
    step: float = 0.5
    """Length of intervals 2..N (s)."""
    replan_every: int = 5
    """The first interval lasts replan_every control periods (s = replan_every * params.dt): the
    controller re-solves every replan_every periods and in between holds the planned constant-rate
    turn and speed, which the plant then follows exactly."""
    stage_weight: float = 0.2
    """Weight (dimensionless) of the mean per-node minimum cosine (keeps near-term nodes optimised when the
    worst node of the horizon is out of reach)."""
    smooth_weight: float = 1e-3
    """Weight (dimensionless) of the squared command changes, normalised by U_max^2 and V_max^2."""
    max_iter: int = 80
    """IPOPT iteration limit per warm-started solve (count)."""
    cold_max_iter: int = 400
    """IPOPT iteration limit of a solve without duals to reuse (the first step; count)."""
    time_limit: float | None = None
    """Wall-clock limit per solve (s), None: none."""
    prox: float = 0.1
    """SQP proximal weight on the step (dimensionless; per variable, scaled to the variable's range)."""
    sqp_iters: int = 1
    """QPs per control step in the SQP variant (count; 1: real-time iteration)."""

    def __post_init__(self) -> None:
        for name in ("horizon", "replan_every", "max_iter", "cold_max_iter", "sqp_iters"):
            check_int(name, getattr(self, name), min_value=1, max_value=1_000_000)
        for name in ("step", "prox"):
            check_positive(name, getattr(self, name))
        for name in ("stage_weight", "smooth_weight"):
            check_nonneg(name, getattr(self, name))


@dataclass(frozen=True)
class MPCData:
    """The numbers of one MPC instance (one control step)."""

    D0: NDArray[np.float64]
    """Current drone position (3,) (m)."""
    h0: NDArray[np.float64]
    """Current unit heading (3,)."""
    targets: NDArray[np.float64]
    """(N, n, 3) predicted target positions at the horizon nodes 1..N (m)."""
    mask: NDArray[np.bool_]
    """(n,) bool: target counted in the objective (observable)."""
    sphere_lo: NDArray[np.float64]
    """(N,) lower bounds on |D_k - F| (m)."""
    sphere_hi: NDArray[np.float64]
    """(N,) upper bounds on |D_k - F| (m)."""
    home_hi: NDArray[np.float64]
    """(N,) upper bounds on |D_k - D_s| (m) (inf: none)."""
    tangent: NDArray[np.bool_] | None = None
    """(N,) bool: heading at node k must be (nearly, TANGENT_TOL_DEG) tangent to the sphere,
    (D_k - F) . h_k ~ 0 (implied by keeping |D - F| constant in continuous time while moving);
    None: nowhere."""


@dataclass(frozen=True)
class MPCPlan:
    """A solution of the MPC: commands and predicted states on the horizon."""

    times: NDArray[np.float64]
    """(N+1,) node times from now (s)."""
    u: NDArray[np.float64]
    """(N, 3) heading-rate commands (rad/s)."""
    v: NDArray[np.float64]
    """(N,) speeds (m/s)."""
    D: NDArray[np.float64]
    """(N+1, 3) predicted positions (m), D[0] the current one."""
    h: NDArray[np.float64]
    """(N+1, 3) predicted headings."""
    tau: float
    """Epigraph value: maximum over the horizon of tan(predicted bearing change)."""

    @property
    def beta_max(self) -> float:
        """Predicted maximum bearing change over the horizon (rad) = arctan(tau)."""
        return float(math.atan(max(0.0, self.tau)))


def _series(theta2: Any, offset: int, terms: int = _SERIES_TERMS) -> Any:
    """sum_k (-1)^k theta2^k / (2k + offset)!  (offset 0: cos, 1: sin(x)/x, 2: (1-cos x)/x^2)."""
    out = 0
    term_pow = 1
    for k in range(terms):
        out = out + ((-1) ** k) * term_pow / math.factorial(2 * k + offset)
        term_pow = term_pow * theta2
    return out


def cos_bearing_symbolic(D: Any, A: Any, R: NDArray[np.float64], eps: float = 1e-6) -> Any:
    """CasADi expression of cos beta (3.6) for drone D and target A (3-vectors): the twin of
    :func:`scenarios.covert.bearing_changes` (beta = arccos of this)."""
    c = A - R
    c = c / ca.sqrt(ca.dot(c, c))
    a = A - D
    return ca.dot(c, a) / ca.sqrt(ca.dot(a, a) + eps)


@dataclass
class BearingMPC:
    """The symbolic model: decision vector, constraints, parameters and their layout."""

    params: CovertParams
    """The problem parameters the model was built for (Table 3.2)."""
    settings: MPCSettings
    """The MPC settings the model was built with."""
    n_targets: int
    """Number of targets in the model (count)."""
    nlp: dict[str, Any]
    """{"x", "f", "g", "p"} CasADi SX expressions."""
    durations: NDArray[np.float64]
    """(N,) interval lengths (s)."""
    idx: dict[str, Any]
    """Index arrays into x: "u" (N,3), "v" (N,), "D" (N,3), "h" (N,3), "tau_k" (N,), "tau" ()."""
    gidx: dict[str, NDArray[np.intp]]
    """Index arrays into g: "dyn", "orth", "unorm", "sphere", "home", "epi" (N,n), "link", "tangent"."""

    @property
    def n_x(self) -> int:
        return int(self.nlp["x"].numel())

    @property
    def n_g(self) -> int:
        return int(self.nlp["g"].numel())

    def pack_params(self, data: MPCData) -> NDArray[np.float64]:
        """The parameter vector p of ``data``; masked-out targets get a harmless position (F)."""
        A = np.array(data.targets, dtype=float).reshape(self.settings.horizon, self.n_targets, 3)
        mask = np.asarray(data.mask, bool)
        A[:, ~mask, :] = self.params.F_arr
        if not np.isfinite(A).all():
            raise ValueError("predicted positions of observable targets must be finite")
        return np.concatenate([np.asarray(data.D0, float), np.asarray(data.h0, float), A.ravel()])

    def bounds(
        self, data: MPCData
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """(lbx, ubx, lbg, ubg) for ``data``."""
        p, N = self.params, self.settings.horizon
        lbx = np.full(self.n_x, -np.inf)
        ubx = np.full(self.n_x, np.inf)
        lbx[self.idx["u"]] = -p.U_max
        ubx[self.idx["u"]] = p.U_max
        lbx[self.idx["v"]] = -p.V_max
        ubx[self.idx["v"]] = p.V_max
        for name in ("tau_k", "tau"):  # tangents of bearing changes: >= 0
            lbx[self.idx[name]] = 0.0
        lbg = np.zeros(self.n_g)
        ubg = np.zeros(self.n_g)
        gi = self.gidx
        lbg[gi["unorm"]] = -np.inf
        ubg[gi["unorm"]] = p.U_max**2
        lbg[gi["sphere"]] = np.asarray(data.sphere_lo, float)
        ubg[gi["sphere"]] = np.asarray(data.sphere_hi, float)
        lbg[gi["home"]] = -np.inf
        ubg[gi["home"]] = np.asarray(data.home_hi, float)
        mask = np.asarray(data.mask, bool)
        lbg[gi["epi"]] = -np.inf
        ubg[gi["epi"]] = np.where(mask[None, :], 0.0, np.inf) * np.ones((N, 1))
        ubg[gi["link"]] = np.inf
        tan = np.zeros(N, bool) if data.tangent is None else np.asarray(data.tangent, bool)
        band = self.params.L_u * math.sin(math.radians(TANGENT_TOL_DEG))
        lbg[gi["tangent"]] = np.where(tan, -band, -np.inf)
        ubg[gi["tangent"]] = np.where(tan, band, np.inf)
        return lbx, ubx, lbg, ubg

    def unpack(self, x: NDArray[np.float64], data: MPCData) -> MPCPlan:
        """The plan held in the decision vector ``x``."""
        x = np.asarray(x, float)
        D = np.vstack([data.D0, x[self.idx["D"]]])
        h = np.vstack([data.h0, x[self.idx["h"]]])
        return MPCPlan(
            times=np.concatenate([[0.0], np.cumsum(self.durations)]),
            u=x[self.idx["u"]],
            v=x[self.idx["v"]],
            D=D,
            h=h,
            tau=float(x[self.idx["tau"]]),
        )

    def pack(
        self,
        plan_u: NDArray[np.float64],
        plan_v: NDArray[np.float64],
        D: NDArray[np.float64],
        h: NDArray[np.float64],
        tau_k: NDArray[np.float64] | None = None,
    ) -> NDArray[np.float64]:
        """A decision vector from commands (N,3),(N,) and node states D, h (N,3) (nodes 1..N)."""
        x = np.zeros(self.n_x)
        x[self.idx["u"]] = plan_u
        x[self.idx["v"]] = plan_v
        x[self.idx["D"]] = D
        x[self.idx["h"]] = h
        tk = np.zeros(self.settings.horizon) if tau_k is None else tau_k
        x[self.idx["tau_k"]] = tk
        x[self.idx["tau"]] = float(np.max(tk))
        return x


def build_bearing_mpc(  # noqa: PLR0915
    params: CovertParams, n_targets: int, settings: MPCSettings | None = None
) -> BearingMPC:
    """Build the symbolic min-max bearing MPC for ``n_targets`` targets (no solving).

    params: problem parameters, CovertParams (Table 3.2).
    settings: MPCSettings (default: MPCSettings()).
    """
    check_instance("params", params, CovertParams)
    check_instance("settings", settings, MPCSettings, optional=True)
    st = settings if settings is not None else MPCSettings()
    n = check_int("n_targets", n_targets, min_value=0)
    N = st.horizon
    # the symbolic graph holds some tens of nodes per target and horizon step, and building it
    # takes about a millisecond per node (horizon 1000 with 2 targets: 5 s)
    check_size("n_targets x horizon", 64.0 * (N + 1) * (n + 1))
    check_work(
        "n_targets x settings.horizon (symbolic MPC, 50 evaluations each)",
        50.0 * (N + 1) * (n + 1),
        "evaluations",
    )
    durations = np.array([params.dt * st.replan_every] + [st.step] * (N - 1))
    if params.U_max * durations.max() > 6.0:
        raise ValueError(
            f"U_max * step must be <= 6 rad for the series dynamics, got {params.U_max * durations.max()}"
        )
    F, Ds, R = params.F_arr, params.D_s_arr, params.R_arr
    per = 10  # u(3) v D(3) h(3)
    nx = per * N + N + 1
    x = ca.SX.sym("x", nx)
    pv = ca.SX.sym("p", 6 + N * n * 3)
    D_prev, h_prev = pv[0:3], pv[3:6]
    idx: dict[str, Any] = {  # index arrays, and the int index of tau
        "u": np.zeros((N, 3), int),
        "v": np.zeros(N, int),
        "D": np.zeros((N, 3), int),
        "h": np.zeros((N, 3), int),
    }
    g_dyn, g_orth, g_un, g_sph, g_home, g_epi, g_link, g_tan = [], [], [], [], [], [], [], []
    tau_k = x[per * N : per * N + N]
    tau = x[per * N + N]
    idx["tau_k"] = np.arange(per * N, per * N + N)
    idx["tau"] = per * N + N
    smooth: Any = 0  # a CasADi expression once a second node exists
    u_last: Any = None
    v_last: Any = None
    for k in range(N):
        b = per * k
        idx["u"][k] = np.arange(b, b + 3)
        idx["v"][k] = b + 3
        idx["D"][k] = np.arange(b + 4, b + 7)
        idx["h"][k] = np.arange(b + 7, b + 10)
        u, v, Dn, hn = x[b : b + 3], x[b + 3], x[b + 4 : b + 7], x[b + 7 : b + 10]
        dt = float(durations[k])
        th2 = ca.dot(u, u) * dt * dt
        c0, s1, c2 = _series(th2, 0), _series(th2, 1), _series(th2, 2)
        g_dyn.append(Dn - (D_prev + v * (dt * s1 * h_prev + dt * dt * c2 * u)))
        g_dyn.append(hn - (c0 * h_prev + dt * s1 * u))
        g_orth.append(ca.dot(h_prev, u))
        g_un.append(ca.dot(u, u))
        g_sph.append(ca.sqrt(ca.dot(Dn - F, Dn - F) + 1e-9))
        g_home.append(ca.sqrt(ca.dot(Dn - Ds, Dn - Ds) + 1e-9))
        g_tan.append(ca.dot(Dn - F, hn))
        for j in range(n):
            o = 6 + (k * n + j) * 3
            A = pv[o : o + 3]
            c = A - R
            c = c / ca.sqrt(ca.dot(c, c))
            a = A - Dn
            na2 = ca.dot(a, a) + 1e-6
            cr = ca.cross(c, a)
            g_epi.append((ca.dot(cr, cr) - tau_k[k] ** 2 * ca.dot(c, a) ** 2) / na2)
        g_link.append(tau - tau_k[k])
        if u_last is not None:
            smooth = (
                smooth
                + ca.dot(u - u_last, u - u_last) / params.U_max**2
                + (v - v_last) ** 2 / params.V_max**2
            )
        u_last, v_last = u, v
        D_prev, h_prev = Dn, hn
    f = tau + st.stage_weight * ca.sum1(tau_k) / N + st.smooth_weight * smooth
    groups = [
        ("dyn", g_dyn),
        ("orth", g_orth),
        ("unorm", g_un),
        ("sphere", g_sph),
        ("home", g_home),
        ("epi", g_epi),
        ("link", g_link),
        ("tangent", g_tan),
    ]
    gs: list[Any] = []
    gidx: dict[str, NDArray[np.intp]] = {}
    off = 0
    for name, items in groups:
        expr = ca.vertcat(*items) if items else ca.SX(0, 1)
        m = int(expr.numel())
        gidx[name] = np.arange(off, off + m, dtype=np.intp)
        off += m
        gs.append(expr)
    gidx["epi"] = gidx["epi"].reshape(N, n)
    nlp = {"x": x, "f": f, "g": ca.vertcat(*gs), "p": pv}
    return BearingMPC(params, st, n, nlp, durations, idx, gidx)


def rollout_guess(
    model: BearingMPC, data: MPCData, u: NDArray[np.float64], v: NDArray[np.float64]
) -> NDArray[np.float64]:
    """A decision vector consistent with the dynamics for commands u (N,3), v (N,).

    Each u_k is first made admissible (orthogonal to the node's heading, |u| <= U_max).
    """
    from droneplan.scenarios.covert import rotate_heading

    p = model.params
    D, h = np.asarray(data.D0, float), np.asarray(data.h0, float)
    us, vs, Ds, hs = [], [], [], []
    for k, dt in enumerate(model.durations):
        uk = np.asarray(u[k], float)
        uk = uk - (uk @ h) * h
        nu = np.linalg.norm(uk)
        if nu > p.U_max:
            uk *= p.U_max / nu
        vk = float(np.clip(v[k], -p.V_max, p.V_max))
        h_new, integral = rotate_heading(h, uk, float(dt))
        D = D + vk * integral
        h = h_new
        us.append(uk)
        vs.append(vk)
        Ds.append(D)
        hs.append(h)
    x = model.pack(np.array(us), np.array(vs), np.array(Ds), np.array(hs))
    tk = _node_max_tan(model, data, np.array(Ds))
    x[model.idx["tau_k"]] = tk
    x[model.idx["tau"]] = tk.max()
    return x


def _node_max_tan(model: BearingMPC, data: MPCData, D: NDArray[np.float64]) -> NDArray[np.float64]:
    mask = np.asarray(data.mask, bool)
    if not mask.any():
        return np.zeros(len(D))
    A = np.asarray(data.targets)[:, mask, :]
    c = A - model.params.R_arr
    c /= np.linalg.norm(c, axis=-1, keepdims=True)
    a = A - D[:, None, :]
    cos = np.sum(c * a, axis=-1)
    sin = np.linalg.norm(np.cross(c, a), axis=-1)
    tan = sin / np.maximum(np.abs(cos), 1e-9)
    return np.minimum(tan, 1e3).max(axis=1)


def _result_with_plan(model: BearingMPC, data: MPCData, res: SolveResult, how: str) -> SolveResult:
    if not res.has_solution:
        return res
    plan = model.unpack(res.x, data)
    f = res.objective
    return replace(
        res,
        x=plan,
        objective=plan.beta_max,
        bound=None,
        message=f"{how}; objective = predicted max bearing change over the horizon (rad), "
        f"local solution (no bound). {res.message}",
        info={**res.info, "z": np.asarray(res.x, float), "f": f},
    )


def solve_bearing_mpc(
    params: CovertParams,
    data: MPCData,
    settings: MPCSettings | None = None,
    *,
    x0: NDArray[np.float64] | None = None,
) -> SolveResult:
    """Build the MPC for ``data`` and solve it once with IPOPT (x = :class:`MPCPlan`).

    x0: starting decision vector (default: straight flight at V_max / 2 rolled out).

    params: problem parameters, CovertParams (Table 3.2).
    settings: MPCSettings (default: MPCSettings()).
    """
    model = build_bearing_mpc(params, np.asarray(data.mask).size, settings)
    solver = RecedingBearingMPC(model, backend="ipopt")
    return solver.solve(data, x0=x0)


class RecedingBearingMPC:
    """A built model and its solver adapter, re-solved every control step.

    backend: a registered "nlp" backend: "ipopt" (IpoptSolver, warm-started with the
    previous duals) or "osqp" (sequential QPs on OSQP, :class:`solvers.sqp.SqpSolver`,
    with the QP matrices updated in place). The options each one gets are in
    :meth:`backend_options`.
    """

    soft_weight = 1e2
    """SQP only: quadratic penalty weight on the slack of the linearised sphere, home and
    tangent rows (objective units per m^2); a quadratic (not L1) penalty keeps the QP
    strongly convex, which OSQP needs to converge in few iterations."""

    def __init__(self, model: BearingMPC, backend: str = "ipopt"):
        self._adapter = get_backend(backend, kind="nlp")
        self.model = model
        self.backend = backend
        self.local_optimum = self._adapter.solves_to_local_optimum
        """True when a solve ends at a local optimum (a restart from elsewhere may find a better one)."""
        self._solvers: dict[bool, NlpSolver] = {}

    @staticmethod
    def backend_options(settings: MPCSettings, *, warm: bool) -> dict[str, dict[str, Any]]:
        """Options per backend name for a solve with (``warm``) or without a previous solution."""
        return {
            "ipopt": {
                "max_iter": settings.max_iter if warm else settings.cold_max_iter,
                "tol": 1e-5,
                "acceptable_tol": 1e-3,
                "acceptable_iter": 5,
            },
            "osqp": {
                "iterations": settings.sqp_iters,
                "qp_settings": {
                    "eps_abs": 1e-3,
                    "eps_rel": 1e-3,
                    "polishing": False,
                    "scaling": 25,
                    "max_iter": 4000,
                    "check_termination": 10,
                    "eps_prim_inf": 1e-9,
                    "eps_dual_inf": 1e-9,
                },
            },
        }

    def _structure(self) -> SqpStructure:
        """Proximal weights scaled to each variable's range, and the soft rows (sphere, home,
        tangent: one free slack each, so every linearised QP is feasible)."""
        model = self.model
        prox = np.ones(model.n_x)
        prox[model.idx["u"].ravel()] = 1.0 / model.params.U_max**2
        prox[model.idx["v"]] = 1.0 / model.params.V_max**2
        prox[model.idx["D"].ravel()] = 1e-2
        prox[model.idx["tau_k"]] = TAU_PROX
        prox[model.idx["tau"]] = TAU_PROX
        prox[model.idx["h"].ravel()] = H_PROX
        soft = np.concatenate([model.gidx["sphere"], model.gidx["home"], model.gidx["tangent"]])
        return SqpStructure(prox=model.settings.prox * prox, soft_rows=soft, soft_weight=self.soft_weight)

    def _solver(self, warm: bool) -> NlpSolver:
        if warm not in self._solvers:
            st = self.model.settings
            options = self.backend_options(st, warm=warm).get(self._adapter.name, {})
            self._solvers[warm] = self._adapter.create_nlp(
                self.model.nlp, options=options, structure=self._structure(), time_limit=st.time_limit
            )
        return self._solvers[warm]

    def solve(
        self,
        data: MPCData,
        *,
        x0: NDArray[np.float64] | None = None,
        warm: SolveResult | None = None,
        start: str | None = None,
    ) -> SolveResult:
        """Solve for ``data`` from the starting vector ``x0`` (duals of ``warm`` reused when the
        backend takes them).

        start: what x0 is (e.g. "sliding-rollout", "shifted-plan"), recorded in info["start"].
        Returns a SolveResult whose x is an :class:`MPCPlan` (info["z"]: the raw vector);
        ``warm_started`` is True when a supplied x0 was handed to the solver, info["start"] says
        which start it was ("straight-flight" when none was given) and info["duals_reused"]
        whether the backend also started from ``warm``'s multipliers.
        """
        label = start if start is not None else ("given" if x0 is not None else "straight-flight")
        res = self._solve(data, x0=x0, warm=warm)
        return replace(
            res,
            warm_started=x0 is not None,
            info={**res.info, "start": label, "duals_reused": bool(res.warm_started)},
        )

    def _solve(
        self, data: MPCData, *, x0: NDArray[np.float64] | None = None, warm: SolveResult | None = None
    ) -> SolveResult:
        m = self.model
        p = m.pack_params(data)
        lbx, ubx, lbg, ubg = m.bounds(data)
        if x0 is None:  # straight flight at half speed (v = 0 is a stationary point of the dynamics)
            N = m.settings.horizon
            x0 = rollout_guess(m, data, np.zeros((N, 3)), np.full(N, 0.5 * m.params.V_max))
        ws = warm if (self._adapter.reuses_duals and warm is not None and warm.has_solution) else None

        def project(z: NDArray[np.float64]) -> NDArray[np.float64]:
            # onto the plant: admissible commands, states re-simulated exactly
            return rollout_guess(m, data, z[m.idx["u"]], z[m.idx["v"]])

        res = self._solver(ws is not None).solve(
            x0=x0, lbx=lbx, ubx=ubx, lbg=lbg, ubg=ubg, p=p, warm_start=ws, project=project
        )
        return _result_with_plan(m, data, res, res.backend)


# --------------------------------------------------------------------------- instantaneous oracle
def sphere_minmax_bearing(params: CovertParams, targets: Any, *, c_start: float | None = None) -> SolveResult:
    """Exact min over the observation sphere of max_j beta_j (rad) for fixed targets, with a certified bound.

    The convex program of :func:`formulations.covert_bounds.instant_minmax_bearing` (an SOCP
    per angle, Clarabel; no grid, no tolerance to choose): objective = max_j beta_j at the
    returned point x (3,) of the sphere (m), bound = a certified lower bound (rad), equal to
    about 1e-5 rad (1e-4 rad near 0). Where that program does not apply (R inside the
    observation ball, or an optimum of 90 deg or more), the branch and bound
    :func:`sphere_minmax_bearing_bnb` answers instead (``backend`` says which).
    params: the problem (F, L_u, R; CovertParams); targets: (n, 3) positions (m), n >= 1,
    none on the sphere, coordinates at most 1e15 m in magnitude (``MAX_COORDINATE``: farther
    targets would overflow the distances). c_start: cos of an angle believed below the optimum (e.g. the
    previous instant's optimum minus a margin), to save solves along a sequence of instants.
    """
    from droneplan.formulations.covert_bounds import instant_minmax_bearing

    check_instance("params", params, CovertParams)
    targets = check_array("targets", targets, shape=(None, 3), min_rows=1)
    if c_start is not None:
        c_start = check_in_range("c_start", c_start, -1.0, 1.0)
    res = instant_minmax_bearing(params, targets, c_start=c_start)
    if res.has_solution:
        return res
    bnb = sphere_minmax_bearing_bnb(params, targets)
    return replace(bnb, message=f"{res.message}; fell back to: {bnb.message}")


def sphere_minmax_bearing_bnb(
    params: CovertParams, targets: Any, *, tol: float = math.radians(0.05), max_cells: int = 400_000
) -> SolveResult:
    """Global min over the observation sphere of max_j beta_j for fixed targets, with a proven bound
    (branch and bound; the test oracle of :func:`sphere_minmax_bearing`).

    Branch and bound on a latitude-longitude partition of the sphere |D - F| = L_u: a cell
    with centre C and covering radius rho (every point of the cell is within rho of C)
    satisfies max_j beta_j(D) >= max_j beta_j(C) - rho * max_j 1 / (|C - A_j| - rho), because
    |grad_D beta_j| <= 1 / |D - A_j| (the angle at A_j subtended by a displacement of D).
    Cells whose lower bound is not below the best value found minus ``tol`` are discarded; the
    others are split in four until the gap is below ``tol`` (rad) or ``max_cells`` cells were
    evaluated. Returns objective = best value found (rad; x = that point (3,)), bound = a
    proven lower bound (rad): no point of the sphere has a smaller maximum bearing change.
    targets: (n, 3) positions (m), n >= 1, none on the sphere, each coordinate at most
    ``MAX_COORDINATE`` (1e15 m) in magnitude.

    params: problem parameters, CovertParams (F, R, L_u in metres).
    tol: optimality gap (rad) > 0 at which a cell is no longer split.
    max_cells: cells evaluated at most (count >= 1; 8 array elements per cell and 2 per cell and
    target, within the element budget of ``core.validation.work_limits``: at the default max_cells,
    up to 62 targets).
    """
    check_instance("params", params, CovertParams)
    A = check_array("targets", targets, shape=(None, 3), min_rows=1)
    tol = check_positive("tol", tol)
    max_cells = check_int("max_cells", max_cells, min_value=1)
    check_work("max_cells", 8 * max_cells, "elements")  # 4 bounds and 3 coordinates per cell
    # every evaluated cell computes a bearing change per target (300 targets x 3e5 cells: 26 s)
    check_work(
        "max_cells x targets (bearing evaluations, 2 elements each)", 2.0 * max_cells * len(A), "elements"
    )
    from droneplan.scenarios.covert import bearing_changes

    t0 = time.perf_counter()
    F, L, R = params.F_arr, params.L_u, params.R_arr
    # cells: (theta0, theta1, phi0, phi1), theta polar angle from +z in [0, pi]
    nt, npf = 36, 72
    th = np.linspace(0.0, math.pi, nt + 1)
    ph = np.linspace(-math.pi, math.pi, npf + 1)
    T0, P0 = np.meshgrid(th[:-1], ph[:-1], indexing="ij")
    cells = np.column_stack([T0.ravel(), (T0 + th[1]).ravel(), P0.ravel(), (P0 + ph[1] - ph[0]).ravel()])
    best, best_pt, evaluated = math.inf, None, 0
    lower = -math.inf
    while cells.size:
        tc = 0.5 * (cells[:, 0] + cells[:, 1])
        pc = 0.5 * (cells[:, 2] + cells[:, 3])
        C = F + L * np.column_stack([np.sin(tc) * np.cos(pc), np.sin(tc) * np.sin(pc), np.cos(tc)])
        # covering radius: half a meridian arc plus half the widest parallel arc (a path within the cell)
        smax = np.where(
            (cells[:, 0] <= math.pi / 2) & (cells[:, 1] >= math.pi / 2),
            1.0,
            np.maximum(np.sin(cells[:, 0]), np.sin(cells[:, 1])),
        )
        dth = cells[:, 1] - cells[:, 0]
        dph = cells[:, 3] - cells[:, 2]
        rho = 0.5 * L * (dth + smax * dph)
        vals = bearing_changes(C, np.broadcast_to(A, (len(C), *A.shape)), R).max(axis=1)
        dist = np.linalg.norm(C[:, None, :] - A[None], axis=-1).min(axis=1)
        lip_ok = dist > rho
        lb = np.where(lip_ok, vals - rho / np.where(lip_ok, dist - rho, 1.0), -math.inf)
        lb = np.maximum(lb, 0.0)
        evaluated += len(C)
        i = int(np.argmin(vals))
        if vals[i] < best:
            best, best_pt = float(vals[i]), C[i]
        keep = lb < best - tol
        if not keep.any():
            break
        if evaluated + 4 * int(keep.sum()) > max_cells:
            lower = float(lb[keep].min())
            break
        k = cells[keep]
        tm = 0.5 * (k[:, 0] + k[:, 1])
        pm = 0.5 * (k[:, 2] + k[:, 3])
        cells = np.vstack(
            [
                np.column_stack([k[:, 0], tm, k[:, 2], pm]),
                np.column_stack([k[:, 0], tm, pm, k[:, 3]]),
                np.column_stack([tm, k[:, 1], k[:, 2], pm]),
                np.column_stack([tm, k[:, 1], pm, k[:, 3]]),
            ]
        )
    # a discarded cell had lb >= (best at that time) - tol >= best - tol; if the cell budget
    # stopped the search, the cells still open have lb >= lower
    bound = max(0.0, min(best - tol, lower) if math.isfinite(lower) else best - tol)
    status = Status.OPTIMAL if best - bound <= tol + 1e-12 else Status.FEASIBLE
    return SolveResult(
        status,
        objective=best,
        bound=bound,
        x=best_pt,
        backend="sphere-bnb",
        message=f"branch and bound on the sphere, {evaluated} cells; bound = proven "
        f"lower bound on min max beta over the sphere (rad)",
        solve_time=time.perf_counter() - t0,
        iterations=evaluated,
    )
