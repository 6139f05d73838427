"""Adapter for LP/MILP through OR-Tools' linear-solver wrapper (pywraplp), HiGHS or SCIP.

A builder asks :func:`new_mip` for an empty model of the chosen backend, adds
variables and constraints to it, and hands it to :func:`solve_mip`.
"""

from __future__ import annotations

import time
from typing import Any, Mapping, Sequence

import numpy as np
from ortools.linear_solver import pywraplp

from droneplan.solvers.result import SolveResult, Status, map_status
from droneplan.solvers.validation import check_time_limit

BACKENDS: dict[str, str] = {"highs": "HIGHS", "scip": "SCIP"}
"""Our backend names -> pywraplp solver ids."""

# Backends through which pywraplp forwards a start solution. HiGHS is left out on
# purpose: with ortools 9.15, SetHint followed by Solve crashes the process under HiGHS.
_TAKES_HINT = frozenset({"scip"})

STATUS_MAP: dict[int, Status] = {
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


def new_mip(backend: str = "highs") -> pywraplp.Solver:
    """An empty LP/MILP model for ``backend`` ("highs" or "scip") for a builder to fill."""
    if not isinstance(backend, str) or backend.lower() not in BACKENDS:
        raise ValueError(f"unknown MIP backend {backend!r}; choose from {sorted(BACKENDS)}")
    solver = pywraplp.Solver.CreateSolver(BACKENDS[backend.lower()])
    if solver is None:  # pragma: no cover - depends on the ortools build
        raise RuntimeError(f"OR-Tools was built without the {backend} backend")
    solver._droneplan_backend = backend.lower()
    return solver


def _backend_of(solver: pywraplp.Solver) -> str:
    name = getattr(solver, "_droneplan_backend", None)
    if name is None:
        raise ValueError("solve_mip needs a model created by new_mip(backend)")
    return name


def solve_mip(
    solver: pywraplp.Solver,
    *,
    variables: Sequence[Any] = (),
    time_limit: float | None = None,
    warm_start: Mapping[Any, float] | None = None,
    threads: int | None = None,
    relative_gap: float | None = None,
) -> SolveResult:
    """Solve a model built in a :func:`new_mip` container.

    variables: variables whose solution values form ``x`` (float array, in order).
    time_limit: wall-clock limit in seconds (None: no limit).
    warm_start: a start solution {variable: value}; passed to backends that accept one
        (SCIP); ``warm_started`` says whether it was used.
    threads: solver threads (None: backend default).
    relative_gap: stop when the relative MIP gap is below this (None: backend default).

    ``objective`` is the model's objective, ``bound`` the backend's best bound (the
    objective itself for a pure LP solved to optimality).
    """
    if not isinstance(solver, pywraplp.Solver):
        raise TypeError(f"solver must be a pywraplp.Solver from new_mip, got {type(solver).__name__}")
    backend = _backend_of(solver)
    check_time_limit(time_limit)
    if threads is not None and (not isinstance(threads, int) or threads < 1):
        raise ValueError(f"threads must be a positive int, got {threads!r}")
    if relative_gap is not None and not (0 <= relative_gap < 1):
        raise ValueError(f"relative_gap must be in [0, 1), got {relative_gap}")

    if time_limit is not None:
        solver.SetTimeLimit(max(1, int(round(time_limit * 1000))))
    if threads is not None:
        solver.SetNumThreads(threads)
    warm_used = False
    if warm_start:
        if backend in _TAKES_HINT:
            solver.SetHint(list(warm_start.keys()), [float(v) for v in warm_start.values()])
            warm_used = True
    params = pywraplp.MPSolverParameters()
    if relative_gap is not None:
        params.SetDoubleParam(pywraplp.MPSolverParameters.RELATIVE_MIP_GAP, relative_gap)

    t0 = time.perf_counter()
    try:
        code = solver.Solve(params)
    except Exception as exc:
        return SolveResult(Status.ERROR, backend=backend, backend_status="exception",
                           message=f"{backend} raised {exc!r}", solve_time=time.perf_counter() - t0,
                           warm_started=warm_used)
    elapsed = time.perf_counter() - t0
    status = map_status(code, STATUS_MAP)
    limit_hit = time_limit is not None and elapsed >= 0.9 * time_limit
    if code == _UNKNOWN_STATUS and limit_hit:
        # HiGHS under pywraplp reports MPSOLVER_UNKNOWN_STATUS when it stops at the time
        # limit and exposes no incumbent; any other unknown code stays ERROR.
        status = Status.NO_SOLUTION
    objective = bound = None
    x = None
    if status.has_solution:
        x = np.array([v.solution_value() for v in variables], dtype=float)
        objective = float(solver.Objective().Value())
        is_mip = any(v.integer() for v in solver.variables())
        bound = float(solver.Objective().BestBound()) if is_mip else (
            objective if status is Status.OPTIMAL else None)
    message = ""
    if warm_start and not warm_used:
        message = f"warm start not passed: the {backend} backend of pywraplp does not take a start solution"
    if status is Status.NO_SOLUTION:
        message = (message + "; " if message else "") + "stopped at the limit without a usable solution"
    elif status is Status.ERROR:
        message = (message + "; " if message else "") + f"{backend} returned status {_STATUS_NAME.get(code, code)}"
    return SolveResult(
        status=status,
        objective=objective,
        bound=bound,
        x=x,
        backend=backend,
        backend_status=_STATUS_NAME.get(code, str(code)),
        message=message,
        solve_time=elapsed,
        iterations=int(solver.nodes()) if status.has_solution else None,
        warm_started=warm_used,
    )
