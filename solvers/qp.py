"""Adapter for convex QPs ``min 1/2 x'Px + q'x s.t. l <= Ax <= u`` through OSQP.

The solver is set up once; :meth:`OsqpSolver.update` changes the vectors (and the
values of P and A on a fixed sparsity pattern) between solves, and a previous
result can be handed back as a primal/dual warm start, which is what a
sequential-QP / real-time-iteration controller needs.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from droneplan.core.validation import check_time_limit
from droneplan.solvers.base import BackendAdapter, NativeReadout, NlpBackend, QpBackend, run_native
from droneplan.solvers.result import SolveResult, Status

__all__ = ["BACKEND", "STATUS_MAP", "OsqpSolver", "OsqpAdapter", "osqp_inf"]

BACKEND = "osqp"

# OSQP's status strings (identical in osqp 0.6 and 1.x), lower-cased.
STATUS_MAP: dict[Any, Status] = {
    "solved": Status.OPTIMAL,
    "solved inaccurate": Status.FEASIBLE,
    "primal infeasible": Status.INFEASIBLE,
    "primal infeasible inaccurate": Status.INFEASIBLE,
    "dual infeasible": Status.UNBOUNDED,
    "dual infeasible inaccurate": Status.UNBOUNDED,
    "maximum iterations reached": Status.NO_SOLUTION,
    "run time limit reached": Status.NO_SOLUTION,
    "problem non convex": Status.ERROR,
    "interrupted": Status.ERROR,
    "unsolved": Status.ERROR,
}

_DEFAULT_SETTINGS = {"verbose": False, "eps_abs": 1e-6, "eps_rel": 1e-6, "polishing": True, "max_iter": 10000}


class OsqpSolver:
    """A QP set up once in OSQP and re-solved after updates.

    P: (n, n) symmetric positive semidefinite cost matrix (only its upper triangle is used).
    q: (n,) linear cost.
    A: (m, n) constraint matrix; l, u: (m,) bounds (±inf allowed).
    settings: OSQP settings overriding ours (eps_abs=eps_rel=1e-6, polishing on).
    time_limit: wall-clock limit per solve in seconds (None: none).
    verbose: let OSQP print its log (default quiet; ``settings["verbose"]`` also works).
    """

    def __init__(
        self,
        P: Any,
        q: Any,
        A: Any,
        l: Any,
        u: Any,
        *,
        settings: Mapping[str, Any] | None = None,
        time_limit: float | None = None,
        verbose: bool = False,
    ):
        import osqp
        import scipy.sparse as sp

        check_time_limit(time_limit)
        P = sp.csc_matrix(P, dtype=float)
        A = sp.csc_matrix(A, dtype=float)
        n = P.shape[0]
        if P.shape != (n, n):
            raise ValueError(f"P must be square, got shape {P.shape}")
        if A.shape[1] != n:
            raise ValueError(f"A has {A.shape[1]} columns, P has {n}")
        self.n, self.m = n, A.shape[0]
        q = self._vec("q", q, n, allow_inf=False)
        l = self._vec("l", l, self.m)
        u = self._vec("u", u, self.m)
        if np.any(l > u):
            raise ValueError("l must be <= u elementwise")
        opts = dict(_DEFAULT_SETTINGS, verbose=bool(verbose))
        # osqp 1.x renamed "polish" to "polishing"; accept either spelling from callers.
        if settings:
            opts.update(settings)
            if "polish" in settings:
                opts["polishing"] = opts.pop("polish")
        if time_limit is not None:
            opts["time_limit"] = float(time_limit)
        self._P_upper = sp.triu(P, format="csc")
        self._A = A
        self._solver = osqp.OSQP()
        self._solver.setup(P=self._P_upper, q=q, A=A, l=l, u=u, **opts)

    @staticmethod
    def _vec(name: str, value: Any, n: int, allow_inf: bool = True) -> np.ndarray:
        arr = np.asarray(value, dtype=float).ravel()
        if arr.size != n:
            raise ValueError(f"{name} has {arr.size} entries, expected {n}")
        if np.isnan(arr).any() or (not allow_inf and np.isinf(arr).any()):
            raise ValueError(f"{name} must be finite" if not allow_inf else f"{name} contains NaN")
        return np.asarray(np.clip(arr, -osqp_inf(), osqp_inf()), dtype=float)

    def update(self, *, q: Any = None, l: Any = None, u: Any = None, Px: Any = None, Ax: Any = None) -> None:
        """Change vectors, or the nonzero values of P's upper triangle / A (same pattern)."""
        kwargs: dict[str, Any] = {}
        if q is not None:
            kwargs["q"] = self._vec("q", q, self.n, allow_inf=False)
        if l is not None:
            kwargs["l"] = self._vec("l", l, self.m)
        if u is not None:
            kwargs["u"] = self._vec("u", u, self.m)
        if Px is not None:
            kwargs["Px"] = self._vec("Px", Px, self._P_upper.nnz, allow_inf=False)
        if Ax is not None:
            kwargs["Ax"] = self._vec("Ax", Ax, self._A.nnz, allow_inf=False)
        if kwargs:
            self._solver.update(**kwargs)

    def solve(self, *, warm_start: SolveResult | tuple[Any, Any] | None = None) -> SolveResult:
        """Solve; ``warm_start`` is a previous result of a solver of the same size or (x, y).

        Returns ``x`` = primal, ``objective`` = 1/2 x'Px + q'x, ``bound`` = the objective
        when solved (OSQP's duality gap is within its tolerance), ``info["y"]`` = duals.
        """
        warm_used = False
        if warm_start is not None:
            if isinstance(warm_start, SolveResult):
                xw, yw = (warm_start.x, warm_start.info.get("y")) if warm_start.has_solution else (None, None)
            elif isinstance(warm_start, tuple) and len(warm_start) == 2:
                xw, yw = warm_start
            else:
                raise TypeError("warm_start must be a SolveResult or a tuple (x, y)")
            if xw is not None:
                xw = self._vec("warm_start x", xw, self.n, allow_inf=False)
                yw = None if yw is None else self._vec("warm_start y", yw, self.m, allow_inf=False)
                if yw is None:
                    self._solver.warm_start(x=xw)
                else:
                    self._solver.warm_start(x=xw, y=yw)
                warm_used = True

        def call() -> tuple[str, Any]:
            try:
                res = self._solver.solve(raise_error=False)
            except TypeError:  # osqp < 1.0 has no raise_error argument
                res = self._solver.solve()
            return str(res.info.status).lower(), res

        def read(_code: Any, res: Any, status: Status, _elapsed: float) -> NativeReadout:
            has = status.has_solution and res.x is not None and np.isfinite(res.x).all()
            if status.has_solution and not has:
                status = Status.ERROR
            objective = float(res.info.obj_val) if has else None
            return NativeReadout(
                status=status,
                objective=objective,
                bound=objective if status is Status.OPTIMAL else None,
                x=np.asarray(res.x, dtype=float).copy() if has else None,
                backend_status=str(res.info.status),
                message="" if has else f"OSQP: {res.info.status}",
                iterations=int(res.info.iter),
                info={"y": np.asarray(res.y, dtype=float).copy() if res.y is not None else None},
            )

        return run_native(_ADAPTER, call, read, warm_started=warm_used)


class OsqpAdapter(BackendAdapter, QpBackend, NlpBackend):
    """OSQP (ADMM for convex QPs); as an NLP backend, sequential QPs (:mod:`~droneplan.solvers.sqp`)."""

    name = BACKEND
    status_map = STATUS_MAP
    description = "OSQP: convex QPs by ADMM, warm start with primal and duals"
    requires = ("osqp", "scipy")

    def create_qp(
        self,
        P: Any,
        q: Any,
        A: Any,
        l: Any,
        u: Any,
        *,
        settings: Mapping[str, Any] | None = None,
        time_limit: float | None = None,
        verbose: bool = False,
    ) -> OsqpSolver:
        """An :class:`OsqpSolver` (see its docstring)."""
        return OsqpSolver(P, q, A, l, u, settings=settings, time_limit=time_limit, verbose=verbose)

    def create_nlp(
        self,
        nlp: Mapping[str, Any],
        *,
        options: Mapping[str, Any] | None = None,
        structure: Any = None,
        time_limit: float | None = None,
        verbose: bool = False,
    ) -> Any:
        """A :class:`~droneplan.solvers.sqp.SqpSolver` on OSQP.

        options: ``iterations`` (QPs per solve, default 1: real-time iteration) and
            ``qp_settings`` (OSQP settings). time_limit: per QP (s).
        structure: a :class:`~droneplan.solvers.sqp.SqpStructure` (proximal weights, soft rows).
        """
        from droneplan.solvers.sqp import SqpSolver, SqpStructure

        opts = dict(options or {})
        iterations = opts.pop("iterations", 1)
        qp_settings = opts.pop("qp_settings", None)
        if opts:
            raise ValueError(f"unknown osqp NLP options {sorted(opts)}; known: ['iterations', 'qp_settings']")
        if structure is not None and not isinstance(structure, SqpStructure):
            raise TypeError(f"structure must be an SqpStructure, got {type(structure).__name__}")
        return SqpSolver(
            nlp,
            qp_backend=self,
            iterations=iterations,
            structure=structure,
            qp_settings=qp_settings,
            time_limit=time_limit,
            verbose=verbose,
        )


_ADAPTER = OsqpAdapter()


def osqp_inf() -> float:
    """The magnitude OSQP treats as infinite (1e30 in osqp 0.6 and 1.x)."""
    return 1e30
