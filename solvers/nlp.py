"""Adapter for nonlinear programs through CasADi's IPOPT interface.

The NLP is symbolic (CasADi SX/MX) and is turned into a solver once, when the
:class:`IpoptSolver` is created; each :meth:`IpoptSolver.solve` then only passes
numbers (bounds, parameters, starting point), which is what a receding-horizon
controller needs.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

import numpy as np

from droneplan.core.validation import check_time_limit, require_set
from droneplan.solvers.base import BackendAdapter, NativeReadout, NlpBackend, run_native
from droneplan.solvers.result import SolveResult, Status

if TYPE_CHECKING:
    import casadi as ca

__all__ = ["BACKEND", "STATUS_MAP", "IpoptSolver", "IpoptAdapter"]

BACKEND = "ipopt"

# IPOPT return_status strings (IpReturnCodes). IPOPT proves no global optimality, so no
# code maps to OPTIMAL: "Solve_Succeeded" is a local optimum (a KKT point within IPOPT's
# tolerance), FEASIBLE with info["local_optimum"] True. Statuses that stop at a point whose
# quality is unknown are mapped to FEASIBLE here and demoted to NO_SOLUTION by
# IpoptSolver.solve when that point violates the constraints.
_LOCAL_OPTIMUM_CODE = "Solve_Succeeded"
"""The one IPOPT code that means a KKT point within the requested tolerance."""

STATUS_MAP: dict[Any, Status] = {
    _LOCAL_OPTIMUM_CODE: Status.FEASIBLE,
    "Solved_To_Acceptable_Level": Status.FEASIBLE,
    "Feasible_Point_Found": Status.FEASIBLE,
    "Maximum_Iterations_Exceeded": Status.FEASIBLE,
    "Maximum_CpuTime_Exceeded": Status.FEASIBLE,
    "Maximum_WallTime_Exceeded": Status.FEASIBLE,
    "Search_Direction_Becomes_Too_Small": Status.FEASIBLE,
    "User_Requested_Stop": Status.FEASIBLE,
    "Infeasible_Problem_Detected": Status.INFEASIBLE,
    "Diverging_Iterates": Status.UNBOUNDED,
    "Restoration_Failed": Status.NO_SOLUTION,
    "Error_In_Step_Computation": Status.ERROR,
    "Not_Enough_Degrees_Of_Freedom": Status.ERROR,
    "Invalid_Problem_Definition": Status.ERROR,
    "Invalid_Option": Status.ERROR,
    "Invalid_Number_Detected": Status.ERROR,
    "Unrecoverable_Exception": Status.ERROR,
    "NonIpopt_Exception_Thrown": Status.ERROR,
    "Insufficient_Memory": Status.ERROR,
    "Internal_Error": Status.ERROR,
}

_LIMIT_STATUSES = {
    "Maximum_Iterations_Exceeded",
    "Maximum_CpuTime_Exceeded",
    "Maximum_WallTime_Exceeded",
    "Search_Direction_Becomes_Too_Small",
    "User_Requested_Stop",
    "Restoration_Failed",
}


class IpoptSolver:
    """An NLP ``min f(x, p) s.t. lbg <= g(x, p) <= ubg, lbx <= x <= ubx`` solved by IPOPT.

    nlp: dict with CasADi expressions ``x`` (decision vector), ``f`` (scalar
        objective), optional ``g`` (constraints) and ``p`` (parameters).
    options: extra IPOPT options (``{"max_iter": 200}``; keys without the
        ``ipopt.`` prefix); printing is off unless ``print_level`` is given.
    time_limit: default wall-clock limit per solve, in seconds (None: none).
    feasibility_tol: maximum constraint violation for a point returned at a limit
        to count as FEASIBLE (otherwise NO_SOLUTION).
    verbose: let IPOPT print its banner and iteration log (default quiet).
    """

    def __init__(
        self,
        nlp: Mapping[str, Any],
        *,
        options: Mapping[str, Any] | None = None,
        time_limit: float | None = None,
        feasibility_tol: float = 1e-6,
        verbose: bool = False,
    ):
        if not isinstance(nlp, Mapping) or "x" not in nlp or "f" not in nlp:
            raise ValueError("nlp must be a mapping with at least 'x' and 'f' CasADi expressions")
        unknown = set(nlp) - {"x", "f", "g", "p"}
        if unknown:
            raise ValueError(f"nlp has unknown keys {sorted(unknown)}; allowed: x, f, g, p")
        check_time_limit(time_limit)
        if feasibility_tol <= 0:
            raise ValueError(f"feasibility_tol must be > 0, got {feasibility_tol}")
        self._nlp = dict(nlp)
        self.n_x = int(nlp["x"].numel())
        self.n_g = int(nlp["g"].numel()) if "g" in nlp else 0
        self.n_p = int(nlp["p"].numel()) if "p" in nlp else 0
        self.time_limit = time_limit
        self.feasibility_tol = feasibility_tol
        self._options = dict(options or {})
        self.verbose = bool(verbose)
        self._solvers: dict[tuple[bool, float | None], ca.Function] = {}

    def _solver(self, warm: bool, time_limit: float | None) -> ca.Function:
        import casadi as ca

        key = (warm, time_limit)
        if key not in self._solvers:
            # quiet unless asked: sb=yes drops IPOPT's banner, print_time=False CasADi's timing table
            ipopt = {} if self.verbose else {"print_level": 0, "sb": "yes"}
            ipopt.update(self._options)
            if time_limit is not None:
                ipopt["max_wall_time"] = float(time_limit)
            if warm:
                ipopt.update(
                    {
                        "warm_start_init_point": "yes",
                        "warm_start_bound_push": 1e-6,
                        "warm_start_mult_bound_push": 1e-6,
                        "mu_init": 1e-4,
                    }
                )
            opts: dict[str, Any] = {"ipopt": ipopt, "print_time": self.verbose, "error_on_fail": False}
            self._solvers[key] = ca.nlpsol("droneplan_ipopt", "ipopt", self._nlp, opts)
        return self._solvers[key]

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

    def solve(  # noqa: C901
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
        project: Any = None,
    ) -> SolveResult:
        """Solve from ``x0`` (or from ``warm_start``'s primal and duals).

        Bounds default to ±inf; ``p`` is required when the NLP has parameters.
        ``warm_start``: a previous SolveResult of this solver (its ``x`` and its
        ``info["lam_x"]``, ``info["lam_g"]``); used only when it had a solution.
        ``project`` is ignored (IPOPT iterates internally; see NlpSolver).
        Returns ``x`` = primal (np.ndarray), ``objective`` = f at x, ``bound`` = None
        (a local solve proves no bound), ``info`` = {"lam_x", "lam_g", "g", "violation",
        "x_last", "local_optimum"}. Status is never OPTIMAL: a converged solve
        ("Solve_Succeeded", a KKT point) is FEASIBLE with ``info["local_optimum"]`` True;
        every other stop has it False.
        """
        limit = self.time_limit if time_limit is None else time_limit
        check_time_limit(limit)
        if warm_start is not None and not isinstance(warm_start, SolveResult):
            raise TypeError(f"warm_start must be a SolveResult, got {type(warm_start).__name__}")
        use_warm = warm_start is not None and warm_start.has_solution and "lam_x" in warm_start.info
        if use_warm:
            x0 = require_set(warm_start, "use_warm implies a warm start").x if x0 is None else x0
        args: dict[str, Any] = {
            "x0": self._vec("x0", x0, self.n_x, 0.0),
            "lbx": self._vec("lbx", lbx, self.n_x, -np.inf),
            "ubx": self._vec("ubx", ubx, self.n_x, np.inf),
        }
        if self.n_g:
            args["lbg"] = self._vec("lbg", lbg, self.n_g, -np.inf)
            args["ubg"] = self._vec("ubg", ubg, self.n_g, np.inf)
        if self.n_p:
            if p is None:
                raise ValueError(f"this NLP has {self.n_p} parameters: pass p")
            args["p"] = self._vec("p", p, self.n_p, 0.0)
        elif p is not None:
            raise ValueError("this NLP has no parameters, but p was given")
        if use_warm:
            warm_start = require_set(warm_start, "use_warm implies a warm start")
            args["lam_x0"] = self._vec("lam_x0", warm_start.info["lam_x"], self.n_x, 0.0)
            if self.n_g:
                args["lam_g0"] = self._vec("lam_g0", warm_start.info["lam_g"], self.n_g, 0.0)

        solver = self._solver(use_warm, limit)

        def call() -> tuple[str, Any]:
            sol = solver(**args)
            return str(solver.stats().get("return_status", "unknown")), sol

        def read(code: Any, sol: Any, status: Status, _elapsed: float) -> NativeReadout:
            stats = solver.stats()
            x = np.asarray(sol["x"], dtype=float).ravel()
            g = np.asarray(sol["g"], dtype=float).ravel() if self.n_g else np.zeros(0)
            violation = self._violation(x, g, args)
            local = code == _LOCAL_OPTIMUM_CODE
            message = "local optimum (KKT point); no global bound" if local else ""
            if code in _LIMIT_STATUSES or (status is Status.FEASIBLE and not local):
                # a point returned at a limit counts only if it satisfies the constraints
                if violation <= self.feasibility_tol and np.isfinite(x).all():
                    status = Status.FEASIBLE
                    message = f"IPOPT stopped with {code}; point feasible (violation {violation:.2e})"
                else:
                    status = Status.NO_SOLUTION
                    message = f"IPOPT stopped with {code}; point infeasible (violation {violation:.2e})"
            if status is Status.ERROR and code not in STATUS_MAP:
                message = f"unknown IPOPT status {code!r}"
            has = status.has_solution
            return NativeReadout(
                status=status,
                objective=float(sol["f"]) if has else None,
                x=x if has else None,
                message=message,
                iterations=int(stats.get("iter_count", 0)),
                info={
                    "lam_x": np.asarray(sol["lam_x"], dtype=float).ravel(),
                    "lam_g": np.asarray(sol["lam_g"], dtype=float).ravel(),
                    "g": g,
                    "violation": violation,
                    "x_last": x,
                    "local_optimum": local,
                },
            )

        return run_native(_ADAPTER, call, read, warm_started=use_warm)

    @staticmethod
    def _violation(x: np.ndarray, g: np.ndarray, args: Mapping[str, np.ndarray]) -> float:
        parts = [np.maximum(args["lbx"] - x, 0), np.maximum(x - args["ubx"], 0)]
        if g.size:
            parts += [np.maximum(args["lbg"] - g, 0), np.maximum(g - args["ubg"], 0)]
        finite = [np.nan_to_num(p, nan=np.inf) for p in parts]
        return float(max((p.max() if p.size else 0.0) for p in finite))


class IpoptAdapter(BackendAdapter, NlpBackend):
    """IPOPT (interior point, local) through CasADi's nlpsol."""

    name = BACKEND
    status_map = STATUS_MAP
    description = "IPOPT through CasADi: local NLP solutions, warm start with duals"
    reuses_duals = True
    solves_to_local_optimum = True
    requires = ("casadi",)

    def create_nlp(
        self,
        nlp: Mapping[str, Any],
        *,
        options: Mapping[str, Any] | None = None,
        structure: Any = None,
        time_limit: float | None = None,
        verbose: bool = False,
    ) -> IpoptSolver:
        """An :class:`IpoptSolver`; ``options`` are IPOPT options, plus ``feasibility_tol``
        (see IpoptSolver). ``structure`` is not needed by IPOPT and ignored."""
        opts = dict(options or {})
        feasibility_tol = opts.pop("feasibility_tol", 1e-6)
        return IpoptSolver(
            nlp, options=opts, time_limit=time_limit, feasibility_tol=feasibility_tol, verbose=verbose
        )


_ADAPTER = IpoptAdapter()
