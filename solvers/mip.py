"""Adapters for LP/MILP through OR-Tools' linear-solver wrapper (pywraplp): HiGHS and SCIP.

Both offer the "linear" capability (:class:`PywraplpLinearModel`). A builder that writes
pywraplp directly takes an empty model from :func:`droneplan.solvers.mip_models.new_mip` and
solves it with :func:`~droneplan.solvers.mip_models.solve_mip`.

Another solver that pywraplp drives (CPLEX, Xpress, CBC ...) is a subclass of
:class:`PywraplpAdapter` with its ``name``, pywraplp ``solver_id`` and ``takes_hint``,
in its own file, plus its registration (see :mod:`~droneplan.solvers.registry`).
"""

from __future__ import annotations

import dataclasses
import math
import os
import time
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np

from droneplan.core.validation import check_time_limit
from droneplan.solvers.base import BackendAdapter, LinearBackend, NativeReadout, run_native
from droneplan.solvers.linear import LinearModel
from droneplan.solvers.result import SolveResult, Status

if TYPE_CHECKING:
    from ortools.linear_solver import pywraplp

__all__ = [
    "STATUS_MAP",
    "PywraplpAdapter",
    "HighsAdapter",
    "ScipAdapter",
    "PywraplpLinearModel",
]

# pywraplp's ResultStatus codes (linear_solver.h), written as numbers so that this module loads
# without OR-Tools; a test holds them against pywraplp.Solver's constants.
STATUS_MAP: dict[Any, Status] = {
    0: Status.OPTIMAL,  # pywraplp.Solver.OPTIMAL
    1: Status.FEASIBLE,  # pywraplp.Solver.FEASIBLE
    2: Status.INFEASIBLE,  # pywraplp.Solver.INFEASIBLE
    3: Status.UNBOUNDED,  # pywraplp.Solver.UNBOUNDED
    4: Status.ERROR,  # pywraplp.Solver.ABNORMAL
    5: Status.ERROR,  # pywraplp.Solver.MODEL_INVALID
    6: Status.NO_SOLUTION,  # pywraplp.Solver.NOT_SOLVED
}

_UNKNOWN_STATUS = 99  # MPSOLVER_UNKNOWN_STATUS in linear_solver.h

_STATUS_NAME = {
    0: "OPTIMAL",
    1: "FEASIBLE",
    2: "INFEASIBLE",
    3: "UNBOUNDED",
    4: "ABNORMAL",
    5: "MODEL_INVALID",
    6: "NOT_SOLVED",
}


_AVAILABLE: dict[str, bool] = {}  # pywraplp solver id -> can be created here


_HIGHS_STATUS: dict[Any, Status] = {
    "kOptimal": Status.OPTIMAL,
    "kModelEmpty": Status.OPTIMAL,
    "kInfeasible": Status.INFEASIBLE,
    "kUnbounded": Status.UNBOUNDED,
    "kUnboundedOrInfeasible": Status.UNBOUNDED,
    **dict.fromkeys(
        (
            "kTimeLimit",
            "kIterationLimit",
            "kSolutionLimit",
            "kInterrupt",
            "kHighsInterrupt",
            "kObjectiveBound",
            "kObjectiveTarget",
            "kMemoryLimit",
        ),
        Status.NO_SOLUTION,  # FEASIBLE when HiGHS holds a feasible point (``_highs_readout``)
    ),
}
"""HiGHS model statuses (``HighsModelStatus`` names); others are ERROR."""


def _check_settings(time_limit: float | None, threads: int | None, relative_gap: float | None) -> None:
    """The argument checks of ``solve_native`` (each error names its parameter)."""
    check_time_limit(time_limit)
    if threads is not None and (isinstance(threads, bool) or not isinstance(threads, int) or threads < 1):
        raise ValueError(f"threads must be a positive int, got {threads!r}")
    if relative_gap is not None and not (0 <= relative_gap < 1):
        raise ValueError(f"relative_gap must be in [0, 1), got {relative_gap}")


def _highs_model(solver: pywraplp.Solver) -> Any:
    """A highspy.Highs holding the linear model of the pywraplp ``solver`` (its MPModelProto:
    same variable order, bounds, integrality, rows and objective)."""
    import highspy  # type: ignore[import-untyped]
    from ortools.linear_solver import linear_solver_pb2

    proto = linear_solver_pb2.MPModelProto()
    solver.ExportModelToProto(proto)
    if len(proto.general_constraint) or proto.HasField("quadratic_objective"):
        raise ValueError("the HiGHS adapter takes linear models only (no general or quadratic terms)")
    lp = highspy.HighsLp()
    lp.num_col_ = len(proto.variable)
    lp.num_row_ = len(proto.constraint)
    lp.col_cost_ = np.array([v.objective_coefficient for v in proto.variable], dtype=float)
    lp.col_lower_ = np.array([v.lower_bound for v in proto.variable], dtype=float)
    lp.col_upper_ = np.array([v.upper_bound for v in proto.variable], dtype=float)
    lp.row_lower_ = np.array([c.lower_bound for c in proto.constraint], dtype=float)
    lp.row_upper_ = np.array([c.upper_bound for c in proto.constraint], dtype=float)
    lp.sense_ = highspy.ObjSense.kMaximize if proto.maximize else highspy.ObjSense.kMinimize
    lp.offset_ = float(proto.objective_offset)
    if any(v.is_integer for v in proto.variable):
        kinds = (highspy.HighsVarType.kContinuous, highspy.HighsVarType.kInteger)
        lp.integrality_ = [kinds[bool(v.is_integer)] for v in proto.variable]
    lp.a_matrix_.format_ = highspy.MatrixFormat.kRowwise
    lp.a_matrix_.num_col_ = lp.num_col_
    lp.a_matrix_.num_row_ = lp.num_row_
    lp.a_matrix_.start_ = np.cumsum([0] + [len(c.var_index) for c in proto.constraint]).astype(np.int32)
    lp.a_matrix_.index_ = np.array([i for c in proto.constraint for i in c.var_index], dtype=np.int32)
    lp.a_matrix_.value_ = np.array([a for c in proto.constraint for a in c.coefficient], dtype=float)
    lp.col_names_ = [v.name or f"v{i}" for i, v in enumerate(proto.variable)]
    lp.row_names_ = [c.name or f"r{i}" for i, c in enumerate(proto.constraint)]
    highs = highspy.Highs()
    highs.setOptionValue("output_flag", False)
    highs.passModel(lp)
    return highs


def _mip_presolve_is_unsafe(highs: Any) -> bool:
    """True for a MIP on HiGHS 1.14.x, whose MIP presolve (singleton-column stuffing with
    integer columns) can return a suboptimal point with status optimal; fixed in HiGHS 1.15.0
    (ERGO-Code/HiGHS pull request 2961). On a 10-user maximum-coverage model with one disc it
    reported 3 where a set of 4 users exists. The pin highspy < 1.15 keeps OR-Tools importable,
    so MIPs on 1.14 run with presolve off."""
    integrality = highs.getLp().integrality_
    is_mip = integrality is not None and any(int(k) != 0 for k in integrality)
    return is_mip and (highs.versionMajor(), highs.versionMinor()) == (1, 14)


def _highs_start(highs: Any, warm_start: Mapping[Any, float]) -> bool:
    """Hand the start solution {pywraplp variable: value} to ``highs`` (highspy's sparse
    ``setSolution``, columns in the pywraplp order); True when HiGHS accepted it."""
    import highspy

    idx = np.array([v.index() for v in warm_start], dtype=np.int32)
    val = np.array([float(x) for x in warm_start.values()], dtype=float)
    return bool(highs.setSolution(len(idx), idx, val) == highspy.HighsStatus.kOk)


def _highs_readout(
    highs: Any,
    code: str,
    status: Status,
    variables: Sequence[Any],
    warm_start: bool,
    name: str,
    presolve_off: bool = False,
) -> NativeReadout:
    """The solution of a HiGHS run: at a limit, its incumbent (FEASIBLE) when it has one."""
    info = highs.getInfo()
    is_mip = highs.getLp().integrality_ is not None and len(highs.getLp().integrality_) > 0
    has_point = info.primal_solution_status == 2  # kSolutionStatusFeasible
    if status is Status.NO_SOLUTION and has_point:
        status = Status.FEASIBLE
    objective = x = None
    if status.has_solution:
        col = np.asarray(highs.getSolution().col_value, dtype=float)
        x = np.array([col[v.index()] for v in variables], dtype=float)
        objective = float(info.objective_function_value)
    bound = float(info.mip_dual_bound) if is_mip else (objective if status is Status.OPTIMAL else None)
    if bound is not None and not math.isfinite(bound):
        bound = None
    notes = []
    if warm_start:
        notes.append(f"warm start not passed: the {name} backend does not take a start solution")
    if status is Status.NO_SOLUTION:
        notes.append(f"stopped at the limit ({code}) without a feasible solution")
    elif status is Status.FEASIBLE:
        notes.append(f"stopped at the limit ({code}); the incumbent is not proven optimal")
    elif status is Status.ERROR:
        notes.append(f"{name} returned status {code}")
    if presolve_off:
        notes.append("MIP presolve off (HiGHS 1.14 presolve can return a suboptimal point as optimal)")
    return NativeReadout(
        objective=objective,
        bound=bound,
        x=x,
        message="; ".join(notes),
        status=status,
        iterations=int(info.mip_node_count) if is_mip and status.has_solution else None,
        info={"presolve": "off"} if presolve_off else {},
    )


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
    requires: ClassVar[tuple[str, ...]] = ("ortools",)

    def status_name(self, code: Any) -> str:
        return _STATUS_NAME.get(code, str(code))

    def is_available(self) -> bool:
        if not self.requires_installed():
            return False
        from ortools.linear_solver import pywraplp

        if self.solver_id not in _AVAILABLE:
            _AVAILABLE[self.solver_id] = pywraplp.Solver.CreateSolver(self.solver_id) is not None
        return _AVAILABLE[self.solver_id]

    def new_native(self) -> pywraplp.Solver:
        """An empty pywraplp model of this solver."""
        from ortools.linear_solver import pywraplp

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
        from ortools.linear_solver import pywraplp

        _check_settings(time_limit, threads, relative_gap)
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
    """HiGHS (branch and cut, dual simplex). Models are built with pywraplp and solved by
    highspy, handed over as their MPModelProto: pywraplp's HiGHS interface reports
    MPSOLVER_UNKNOWN_STATUS at the time limit and drops HiGHS's incumbent, while highspy
    returns it (FEASIBLE, with HiGHS's bound). Takes a start solution, handed to highspy's
    ``setSolution`` (sparse: the variables given; HiGHS completes a partial one when it can),
    never to pywraplp (with ortools 9.15, SetHint followed by Solve crashes the process
    under HiGHS). MIPs on HiGHS 1.14 run with presolve off (``_mip_presolve_is_unsafe``);
    the result's ``info["presolve"]`` and message say so."""

    name = "highs"
    solver_id = "HIGHS"
    takes_hint = True
    quiet_parameters = "output_flag=false"
    description = "HiGHS MILP/LP (models built with OR-Tools pywraplp, solved by highspy)"
    status_map = _HIGHS_STATUS
    requires = ("ortools", "highspy")

    def status_name(self, code: Any) -> str:
        return str(code)

    def solve_native(
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
        """Solve a pywraplp model with HiGHS (see :func:`solve_mip`); ``time_limit`` (s) covers
        the hand-over of the model too. At a limit the incumbent, if HiGHS has one, comes back
        with status FEASIBLE, else NO_SOLUTION; ``bound`` is HiGHS's dual bound in both cases.
        ``threads`` is checked and otherwise unused (HiGHS's branch and cut runs on one thread)."""
        t0 = time.perf_counter()
        _check_settings(time_limit, threads, relative_gap)
        options: dict[str, Any] = {"output_flag": bool(verbose)}
        if relative_gap is not None:
            options["mip_rel_gap"] = float(relative_gap)

        passed = [False]
        presolve_off = [False]

        def call() -> tuple[str, Any]:
            highs = _highs_model(solver)
            if time_limit is not None:
                options["time_limit"] = max(time_limit - (time.perf_counter() - t0), 1e-3)
            if _mip_presolve_is_unsafe(highs):
                options["presolve"] = "off"
                presolve_off[0] = True
            for key, value in options.items():
                highs.setOptionValue(key, value)
            if warm_start:
                passed[0] = _highs_start(highs, warm_start)
            highs.run()
            return highs.getModelStatus().name, highs

        def read(code: Any, highs: Any, status: Status, _elapsed: float) -> NativeReadout:
            unused = bool(warm_start) and not passed[0]
            return _highs_readout(highs, code, status, variables, unused, self.name, presolve_off[0])

        out = run_native(self, call, read, warm_started=False)
        return dataclasses.replace(out, warm_started=passed[0]) if passed[0] else out


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

    def write(self, path: str | os.PathLike[str]) -> Path:
        """Write the model as free MPS or CPLEX LP (through HiGHS, :func:`_highs_model`)."""
        from droneplan.solvers.model_files import write_highs

        return write_highs(_highs_model(self._solver), path)

    def solve(
        self,
        *,
        variables: Sequence[Any] = (),
        time_limit: float | None = None,
        workers: int | None = None,
        hint: Mapping[Any, float] | None = None,
        verbose: bool = False,
        options: Mapping[str, Any] | None = None,
        on_solution: Callable[[np.ndarray, float | None, float | None], Any] | None = None,
    ) -> SolveResult:
        """Solve; ``options`` may hold ``relative_gap`` (stop below this relative MIP gap).
        pywraplp reports no solution while it runs: ``on_solution`` gets the final one."""
        opts = dict(options or {})
        relative_gap = opts.pop("relative_gap", None)
        if opts:
            raise ValueError(f"unknown {self.backend} options {sorted(opts)}; known: ['relative_gap']")
        result = self._adapter.solve_native(
            self._solver,
            variables=variables,
            time_limit=time_limit,
            warm_start=hint,
            threads=workers,
            relative_gap=relative_gap,
            verbose=verbose,
        )
        if on_solution is not None and result.has_solution:
            on_solution(np.asarray(result.x), result.objective, result.bound)
        return result
