"""Adapters for LP/MILP through OR-Tools' linear-solver wrapper (pywraplp): HiGHS and SCIP.

Both offer the "linear" capability (:class:`PywraplpLinearModel`). The older entry
points stay: a builder may ask :func:`new_mip` for an empty pywraplp model, add
variables and constraints to it and hand it to :func:`solve_mip`.

Another solver that pywraplp drives (Gurobi, CPLEX, Xpress, CBC ...) is a subclass of
:class:`PywraplpAdapter` with its ``name``, pywraplp ``solver_id`` and ``takes_hint``,
in its own file, plus one line in ``registry._BUILTIN``.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any, ClassVar

import numpy as np
from ortools.linear_solver import pywraplp

from droneplan.core.validation import check_time_limit
from droneplan.solvers.base import BackendAdapter, LinearBackend, NativeReadout, run_native
from droneplan.solvers.linear import LinearModel
from droneplan.solvers.result import SolveResult, Status

__all__ = [
    "STATUS_MAP",
    "PywraplpAdapter",
    "HighsAdapter",
    "ScipAdapter",
    "PywraplpLinearModel",
    "new_mip",
    "solve_mip",
]

STATUS_MAP: dict[Any, Status] = {
    pywraplp.Solver.OPTIMAL: Status.OPTIMAL,
    pywraplp.Solver.FEASIBLE: Status.FEASIBLE,
    pywraplp.Solver.INFEASIBLE: Status.INFEASIBLE,
    pywraplp.Solver.UNBOUNDED: Status.UNBOUNDED,
    pywraplp.Solver.ABNORMAL: Status.ERROR,
    pywraplp.Solver.MODEL_INVALID: Status.ERROR,
    pywraplp.Solver.NOT_SOLVED: Status.NO_SOLUTION,
}

_UNKNOWN_STATUS = 99  # MPSOLVER_UNKNOWN_STATUS in linear_solver.h

_STATUS_NAME = {
    pywraplp.Solver.OPTIMAL: "OPTIMAL",
    pywraplp.Solver.FEASIBLE: "FEASIBLE",
    pywraplp.Solver.INFEASIBLE: "INFEASIBLE",
    pywraplp.Solver.UNBOUNDED: "UNBOUNDED",
    pywraplp.Solver.ABNORMAL: "ABNORMAL",
    pywraplp.Solver.MODEL_INVALID: "MODEL_INVALID",
    pywraplp.Solver.NOT_SOLVED: "NOT_SOLVED",
}


_AVAILABLE: dict[str, bool] = {}  # pywraplp solver id -> can be created here


class PywraplpAdapter(BackendAdapter, LinearBackend):
    """A MIP solver reached through pywraplp; subclasses set the three class attributes."""

    solver_id: ClassVar[str]
    """pywraplp's name for the solver ("HIGHS", "SCIP", "GUROBI" ...)."""
    takes_hint: ClassVar[bool] = False
    """Whether pywraplp forwards a start solution (SetHint) to this solver."""
    quiet_parameters: ClassVar[str] = ""
    """Solver-specific parameter text that silences the solver (pywraplp's SuppressOutput
    does not silence every solver's banner)."""
    status_map = STATUS_MAP

    def status_name(self, code: Any) -> str:
        return _STATUS_NAME.get(code, str(code))

    def is_available(self) -> bool:
        if self.solver_id not in _AVAILABLE:
            _AVAILABLE[self.solver_id] = pywraplp.Solver.CreateSolver(self.solver_id) is not None
        return _AVAILABLE[self.solver_id]

    def new_native(self) -> pywraplp.Solver:
        """An empty pywraplp model of this solver."""
        solver = pywraplp.Solver.CreateSolver(self.solver_id)
        if solver is None:  # pragma: no cover - depends on the ortools build and licences
            raise RuntimeError(f"OR-Tools cannot create the {self.name} solver in this installation")
        solver._droneplan_backend = self.name
        return solver

    def new_model(self) -> PywraplpLinearModel:
        return PywraplpLinearModel(self)

    def solve_native(  # noqa: C901
        self,
        solver: pywraplp.Solver,
        *,
        variables: Sequence[Any] = (),
        time_limit: float | None = None,
        warm_start: Mapping[Any, float] | None = None,
        threads: int | None = None,
        relative_gap: float | None = None,
        verbose: bool = False,
    ) -> SolveResult:
        """Solve a pywraplp model of this solver (see :func:`solve_mip`)."""
        check_time_limit(time_limit)
        if threads is not None and (isinstance(threads, bool) or not isinstance(threads, int) or threads < 1):
            raise ValueError(f"threads must be a positive int, got {threads!r}")
        if relative_gap is not None and not (0 <= relative_gap < 1):
            raise ValueError(f"relative_gap must be in [0, 1), got {relative_gap}")
        if time_limit is not None:
            solver.SetTimeLimit(max(1, round(time_limit * 1000)))
        if threads is not None:
            solver.SetNumThreads(threads)
        if verbose:
            solver.EnableOutput()
        else:
            solver.SuppressOutput()
            if self.quiet_parameters:
                # pywraplp reports False for HiGHS options even when it applies them
                solver.SetSolverSpecificParametersAsString(self.quiet_parameters)
        warm_used = False
        if warm_start and self.takes_hint:
            solver.SetHint(list(warm_start.keys()), [float(v) for v in warm_start.values()])
            warm_used = True
        params = pywraplp.MPSolverParameters()
        if relative_gap is not None:
            params.SetDoubleParam(pywraplp.MPSolverParameters.RELATIVE_MIP_GAP, relative_gap)
        name = self.name

        def read(code: Any, _payload: Any, status: Status, elapsed: float) -> NativeReadout:
            limit_hit = time_limit is not None and elapsed >= 0.9 * time_limit
            if code == _UNKNOWN_STATUS and limit_hit:
                # HiGHS under pywraplp reports MPSOLVER_UNKNOWN_STATUS when it stops at the time
                # limit and exposes no incumbent; any other unknown code stays ERROR.
                status = Status.NO_SOLUTION
            objective = bound = x = None
            if status.has_solution:
                x = np.array([v.solution_value() for v in variables], dtype=float)
                objective = float(solver.Objective().Value())
                is_mip = any(v.integer() for v in solver.variables())
                bound = (
                    float(solver.Objective().BestBound())
                    if is_mip
                    else (objective if status is Status.OPTIMAL else None)
                )
            message = ""
            if warm_start and not warm_used:
                message = (
                    f"warm start not passed: the {name} backend of pywraplp does not take a start solution"
                )
            if status is Status.NO_SOLUTION:
                message = (
                    message + "; " if message else ""
                ) + "stopped at the limit without a usable solution"
            elif status is Status.ERROR:
                message = (
                    message + "; " if message else ""
                ) + f"{name} returned status {self.status_name(code)}"
            return NativeReadout(
                objective=objective,
                bound=bound,
                x=x,
                message=message,
                status=status,
                iterations=int(solver.nodes()) if status.has_solution else None,
            )

        return run_native(self, lambda: (solver.Solve(params), None), read, warm_started=warm_used)


class HighsAdapter(PywraplpAdapter):
    """HiGHS (branch and cut, dual simplex) through pywraplp. Takes no start solution:
    with ortools 9.15, SetHint followed by Solve crashes the process under HiGHS."""

    name = "highs"
    solver_id = "HIGHS"
    takes_hint = False
    quiet_parameters = "output_flag=false"
    description = "HiGHS MILP/LP through OR-Tools pywraplp"


class ScipAdapter(PywraplpAdapter):
    """SCIP (branch and cut) through pywraplp; takes a start solution."""

    name = "scip"
    solver_id = "SCIP"
    takes_hint = True
    description = "SCIP MILP through OR-Tools pywraplp"


class PywraplpLinearModel(LinearModel):
    """LinearModel on a pywraplp solver (``unit_var`` is continuous in [0, 1])."""

    def __init__(self, adapter: PywraplpAdapter) -> None:
        self._adapter = adapter
        self.backend = adapter.name
        self._solver = adapter.new_native()

    @property
    def takes_hint(self) -> bool:
        return self._adapter.takes_hint

    @property
    def native(self) -> pywraplp.Solver:
        return self._solver

    def bool_var(self, name: str = "") -> Any:
        return self._solver.BoolVar(name)

    def int_var(self, lb: int, ub: int, name: str = "") -> Any:
        return self._solver.IntVar(int(lb), int(ub), name)

    def unit_var(self, name: str = "") -> Any:
        return self._solver.NumVar(0.0, 1.0, name)

    def add(self, constraint: Any) -> None:
        self._solver.Add(constraint)

    def sum(self, terms: Any) -> Any:
        return self._solver.Sum(list(terms))

    def maximize(self, expr: Any) -> None:
        self._solver.Maximize(expr)

    def minimize(self, expr: Any) -> None:
        self._solver.Minimize(expr)

    def solve(
        self,
        *,
        variables: Sequence[Any] = (),
        time_limit: float | None = None,
        workers: int | None = None,
        hint: Mapping[Any, float] | None = None,
        verbose: bool = False,
        options: Mapping[str, Any] | None = None,
    ) -> SolveResult:
        """Solve; ``options`` may hold ``relative_gap`` (stop below this relative MIP gap)."""
        opts = dict(options or {})
        relative_gap = opts.pop("relative_gap", None)
        if opts:
            raise ValueError(f"unknown {self.backend} options {sorted(opts)}; known: ['relative_gap']")
        return self._adapter.solve_native(
            self._solver,
            variables=variables,
            time_limit=time_limit,
            warm_start=hint,
            threads=workers,
            relative_gap=relative_gap,
            verbose=verbose,
        )


def new_mip(backend: str = "highs") -> pywraplp.Solver:
    """An empty pywraplp model for ``backend`` (a registered pywraplp backend: "highs", "scip")."""
    from droneplan.solvers.registry import available_backends, get_backend

    mip = [n for n in available_backends("linear") if isinstance(get_backend(n), PywraplpAdapter)]
    if not isinstance(backend, str) or backend.lower() not in mip:
        raise ValueError(f"unknown MIP backend {backend!r}; choose from {mip}")
    adapter = get_backend(backend, kind="linear")
    return adapter.new_native()


def solve_mip(
    solver: pywraplp.Solver,
    *,
    variables: Sequence[Any] = (),
    time_limit: float | None = None,
    warm_start: Mapping[Any, float] | None = None,
    threads: int | None = None,
    relative_gap: float | None = None,
    verbose: bool = False,
) -> SolveResult:
    """Solve a model built in a :func:`new_mip` container.

    variables: variables whose solution values form ``x`` (float array, in order).
    time_limit: wall-clock limit in seconds (None: no limit).
    warm_start: a start solution {variable: value}; passed to backends that accept one
        (SCIP); ``warm_started`` says whether it was used.
    threads: solver threads (None: backend default).
    relative_gap: stop when the relative MIP gap is below this (None: backend default).
    verbose: let the solver print its log (default quiet).

    ``objective`` is the model's objective, ``bound`` the backend's best bound (the
    objective itself for a pure LP solved to optimality).
    """
    from droneplan.solvers.registry import get_backend

    if not isinstance(solver, pywraplp.Solver):
        raise TypeError(f"solver must be a pywraplp.Solver from new_mip, got {type(solver).__name__}")
    name = getattr(solver, "_droneplan_backend", None)
    if name is None:
        raise ValueError("solve_mip needs a model created by new_mip(backend)")
    adapter: PywraplpAdapter = get_backend(name, kind="linear")
    return adapter.solve_native(
        solver,
        variables=variables,
        time_limit=time_limit,
        warm_start=warm_start,
        threads=threads,
        relative_gap=relative_gap,
        verbose=verbose,
    )
