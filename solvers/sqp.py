"""Sequential quadratic programming over a QP backend (real-time iteration when ``iterations=1``).

For an NLP ``min f(x, p) s.t. lbg <= g(x, p) <= ubg, lbx <= x <= ubx`` (CasADi
expressions) each iteration solves, at the current iterate z, the QP in the step d
(and one free slack s_r per *soft* constraint row r)::

    min  1/2 d'(H + diag(prox)) d + grad f(z)'d + 1/2 soft_weight |s|^2
    s.t. lbg - g(z) <= J(z) d + E s <= ubg - g(z),   lbx - z <= d <= ubx - z

and moves to z + d, then maps the iterate through the caller's ``project`` (e.g.
re-simulating states from the commands so the iterate obeys the dynamics exactly).
H is the Hessian of f alone, computed once: exact for an objective quadratic in x
whose Hessian does not depend on p (checked when the solver is built); constraint
curvature is left out (a Gauss-Newton-like model), and the proximal term keeps the
QP strongly convex. The QP keeps one sparsity pattern: after the first iteration
only its vectors and the values of J change, and each QP is warm-started with the
previous QP's duals.

There is no line search or merit function: the proximal weights are the only
globalisation, so too small a ``prox`` can make the iterates cycle on curved
constraints (the unit tests show both cases). Soft rows make every QP feasible;
the result reports the remaining constraint violation of the final iterate. The
result's status is FEASIBLE when every QP was solved (a local method proves no global
optimality, so never OPTIMAL) and the QP's status otherwise. ``info["local_optimum"]``
is True when the iterate is a KKT point: the last QP was solved to OSQP's tolerance with
a step of at most ``KKT_STEP_TOL`` (relative to the iterate) and the final constraint
violation is at most ``KKT_VIOLATION_TOL``. A zero step means the gradient of f is
balanced by the QP's multipliers on the constraints linearised at the iterate, which
is the first-order optimality condition of the NLP there; a real-time iteration that
stops after one step far from such a point leaves it False.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, replace
from typing import Any

import casadi as ca
import numpy as np
import scipy.sparse as sp

from droneplan.core.validation import check_time_limit, require_set
from droneplan.solvers.base import QpBackend
from droneplan.solvers.result import SolveResult, Status

__all__ = ["SqpStructure", "SqpSolver", "KKT_STEP_TOL", "KKT_VIOLATION_TOL"]

KKT_STEP_TOL = 1e-6
"""Largest last step, as a fraction of max(1, |iterate|_inf), for the iterate to count as a KKT point."""
KKT_VIOLATION_TOL = 1e-6
"""Largest constraint violation (constraint units) for the iterate to count as a KKT point."""


@dataclass(frozen=True)
class SqpStructure:
    """What a formulation tells a linearising NLP method about its problem (all optional)."""

    prox: Any = None
    """(n_x,) proximal weights (objective units per unit of x squared) added to the QP's
    diagonal; default 0 (then H must be positive definite on its own for OSQP to do well)."""
    soft_rows: Any = None
    """Indices of constraint rows made soft by one free slack each (quadratic penalty)."""
    soft_weight: float = 1e2
    """Penalty weight of the slacks (objective units per constraint unit squared)."""


class SqpSolver:
    """An NLP solved by sequential QPs on a QP backend (see the module docstring).

    nlp: dict with CasADi SX expressions ``x``, ``f`` and optional ``g``, ``p``.
    qp_backend: the QP backend's adapter, e.g. ``get_backend("osqp", kind="qp")``.
    iterations: QPs per solve (1: real-time iteration).
    structure: :class:`SqpStructure` (proximal weights, soft rows).
    qp_settings: settings of the QP backend (its own names).
    time_limit: wall-clock limit per QP (s), None: none.
    verbose: let the QP backend print.
    name: the ``backend`` reported in results.
    """

    def __init__(
        self,
        nlp: Mapping[str, Any],
        *,
        qp_backend: QpBackend,
        iterations: int = 1,
        structure: SqpStructure | None = None,
        qp_settings: Mapping[str, Any] | None = None,
        time_limit: float | None = None,
        verbose: bool = False,
        name: str = "osqp-sqp",
    ):
        if not isinstance(nlp, Mapping) or "x" not in nlp or "f" not in nlp:
            raise ValueError("nlp must be a mapping with at least 'x' and 'f' CasADi expressions")
        if isinstance(iterations, bool) or not isinstance(iterations, int) or iterations < 1:
            raise ValueError(f"iterations must be an int >= 1, got {iterations!r}")
        check_time_limit(time_limit)
        if not isinstance(qp_backend, QpBackend):
            raise TypeError(
                f"qp_backend must be a QP backend adapter (get_backend(name, kind='qp')), got {qp_backend!r}"
            )
        self._qp_adapter = qp_backend
        st = structure or SqpStructure()
        x = nlp["x"]
        pv = nlp.get("p", ca.SX(0, 1))
        g = nlp.get("g", ca.SX(0, 1))
        f = nlp["f"]
        nx, ng = int(x.numel()), int(g.numel())
        self.n_x, self.n_g, self.n_p = nx, ng, int(pv.numel())
        self.iterations = iterations
        self.name = name
        self._qp_settings = dict(qp_settings or {})
        self._time_limit = time_limit
        self._verbose = verbose
        soft = (
            np.zeros(0, dtype=np.int64) if st.soft_rows is None else np.asarray(st.soft_rows, dtype=np.int64)
        )
        if soft.size and (soft.min() < 0 or soft.max() >= ng):
            raise ValueError(f"soft_rows must index the {ng} constraint rows")
        ns = soft.size
        prox = np.zeros(nx) if st.prox is None else np.asarray(st.prox, dtype=float).ravel()
        if prox.size != nx or not np.all(np.isfinite(prox)) or np.any(prox < 0):
            raise ValueError(f"prox must be {nx} finite weights >= 0")
        if not (math.isfinite(st.soft_weight) and st.soft_weight > 0):
            raise ValueError(f"soft_weight must be > 0, got {st.soft_weight}")
        Hexpr = ca.hessian(f, x)[0]
        if ca.depends_on(Hexpr, ca.vertcat(x, pv)):
            raise ValueError("SqpSolver needs an objective quadratic in x with a Hessian independent of p")
        E = np.zeros((ng, ns))
        E[soft, np.arange(ns)] = 1.0
        top = ca.horzcat(ca.jacobian(g, x), ca.SX(ca.DM(E)))
        A_expr = ca.vertcat(top, ca.SX.eye(nx + ns))
        self._gA = ca.Function("gA", [x, pv], [g, A_expr, g])
        self._sparsity = A_expr.sparsity()
        self._grad = ca.Function("grad", [x, pv], [ca.gradient(f, x)])
        self._f = ca.Function("f", [x, pv], [f])
        H0 = ca.Function("H", [x, pv], [Hexpr])(np.zeros(nx), np.zeros(self.n_p))
        H = np.asarray(ca.DM(H0).full())  # constant: checked above
        Pfull = np.zeros((nx + ns, nx + ns))
        Pfull[:nx, :nx] = H + np.diag(prox)
        Pfull[nx:, nx:] = np.eye(ns) * st.soft_weight
        self._P = sp.csc_matrix(Pfull)
        self._nq = nx + ns
        self._ns = ns
        self._qp: Any = None
        self._last: SolveResult | None = None

    def _vec(self, name: str, value: Any, n: int, default: float) -> np.ndarray:
        if value is None:
            return np.full(n, default)
        arr = np.asarray(value, dtype=float).ravel()
        if arr.size == 1 and n != 1:
            return np.full(n, float(arr[0]))
        if arr.size != n:
            raise ValueError(f"{name} has {arr.size} entries, expected {n}")
        if np.isnan(arr).any():
            raise ValueError(f"{name} contains NaN")
        return arr

    def _step(
        self, z: np.ndarray, p: np.ndarray, lbx: np.ndarray, ubx: np.ndarray, lbg: np.ndarray, ubg: np.ndarray
    ) -> SolveResult:
        nx, ng, ns = self.n_x, self.n_g, self._ns
        gd, Aval, _ = self._gA(z, p)
        gd = np.asarray(gd, float).ravel()
        colind, row = self._sparsity.get_ccs()
        Adata = np.asarray(ca.DM(Aval).nonzeros(), float)
        q = np.concatenate([np.asarray(self._grad(z, p), float).ravel(), np.zeros(ns)])
        l = np.concatenate([lbg - gd, lbx - z, np.full(ns, -np.inf)])
        u = np.concatenate([ubg - gd, ubx - z, np.full(ns, np.inf)])
        l = np.where(np.isfinite(l), l, -1e30)
        u = np.where(np.isfinite(u), u, 1e30)
        if self._qp is None:
            A = sp.csc_matrix((Adata, np.asarray(row), np.asarray(colind)), shape=(ng + nx + ns, self._nq))
            self._qp = self._qp_adapter.create_qp(
                self._P,
                q,
                A,
                l,
                u,
                settings=self._qp_settings,
                time_limit=self._time_limit,
                verbose=self._verbose,
            )
            res: SolveResult = self._qp.solve()
        else:
            self._qp.update(q=q, l=l, u=u, Ax=Adata)
            y = None if self._last is None else self._last.info.get("y")
            res = self._qp.solve(warm_start=(np.zeros(self._nq), y) if y is not None else None)
        if res.has_solution:
            res = replace(res, x=res.x[:nx], info={**res.info, "slack": float(res.x[nx:].sum())})
        return res

    def solve(
        self,
        *,
        x0: Any = None,
        lbx: Any = None,
        ubx: Any = None,
        lbg: Any = None,
        ubg: Any = None,
        p: Any = None,
        warm_start: SolveResult | None = None,
        time_limit: float | None = None,
        project: Callable[[np.ndarray], np.ndarray] | None = None,
    ) -> SolveResult:
        """Run ``iterations`` SQP steps from ``x0`` (default zeros).

        project: maps an iterate to the point the next linearisation uses; applied to x0 and
            after every step (default: identity).
        warm_start: unused (the QP duals of the previous solve are reused automatically).
        time_limit: per-QP limit is fixed at construction; passing one here raises.
        Returns x = final iterate, objective = f there (no bound: a local method proves
        none), status FEASIBLE (never OPTIMAL), info = {"violation", "y", "local_optimum",
        "last_step"} (constraint violation, last QP duals, whether the iterate is a KKT point
        (module docstring), the last step's inf-norm relative to max(1, |iterate|_inf)).
        """
        if time_limit is not None:
            raise ValueError("SqpSolver takes its time_limit at construction")
        if self.n_p and p is None:
            raise ValueError(f"this NLP has {self.n_p} parameters: pass p")
        pvec = self._vec("p", p, self.n_p, 0.0)
        lbx_, ubx_ = self._vec("lbx", lbx, self.n_x, -np.inf), self._vec("ubx", ubx, self.n_x, np.inf)
        lbg_, ubg_ = self._vec("lbg", lbg, self.n_g, -np.inf), self._vec("ubg", ubg, self.n_g, np.inf)
        proj = project if project is not None else (lambda z: z)
        t0 = time.perf_counter()
        z = proj(self._vec("x0", x0, self.n_x, 0.0))
        res = None
        iters = 0
        step = math.inf
        for _ in range(self.iterations):
            res = self._step(z, pvec, lbx_, ubx_, lbg_, ubg_)
            iters += res.iterations or 0
            if not res.has_solution:
                break
            self._last = res
            step = float(np.max(np.abs(res.x), initial=0.0)) / max(1.0, float(np.max(np.abs(z), initial=0.0)))
            z = proj(z + res.x)
        elapsed = time.perf_counter() - t0
        res = require_set(res, "iterations >= 1 solves at least one QP")
        if not res.has_solution:
            return replace(
                res, solve_time=elapsed, backend=self.name, message=f"SQP: QP failed ({res.backend_status})"
            )
        gval = np.asarray(self._gA(z, pvec)[2], float).ravel()
        viol = float(
            max(
                np.max(np.maximum(lbg_ - gval, 0), initial=0.0),
                np.max(np.maximum(gval - ubg_, 0), initial=0.0),
            )
        )
        local = res.status is Status.OPTIMAL and step <= KKT_STEP_TOL and viol <= KKT_VIOLATION_TOL
        return SolveResult(
            Status.FEASIBLE,
            objective=float(self._f(z, pvec)),
            x=z,
            backend=self.name,
            backend_status=res.backend_status,
            message=f"{self.iterations} QP(s) linearised at the warm start "
            f"(real-time iteration); constraint violation of the iterate {viol:.2e}",
            solve_time=elapsed,
            iterations=iters,
            warm_started=x0 is not None,
            info={"violation": viol, "y": res.info.get("y"), "local_optimum": local, "last_step": step},
        )
