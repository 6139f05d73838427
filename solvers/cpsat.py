"""Adapter for OR-Tools CP-SAT: solve a built ``cp_model.CpModel`` into a SolveResult."""

from __future__ import annotations

import time
from typing import Any, Mapping, Sequence

import numpy as np
from ortools.sat.python import cp_model

from droneplan.solvers.result import SolveResult, Status, map_status
from droneplan.solvers.validation import check_time_limit

BACKEND = "cp-sat"

# CP-SAT's native statuses; FEASIBLE means a solution without a proof of optimality.
STATUS_MAP: dict[int, Status] = {
    cp_model.OPTIMAL: Status.OPTIMAL,
    cp_model.FEASIBLE: Status.FEASIBLE,
    cp_model.INFEASIBLE: Status.INFEASIBLE,
    cp_model.UNKNOWN: Status.NO_SOLUTION,
    cp_model.MODEL_INVALID: Status.ERROR,
}


def solve_cpsat(
    model: cp_model.CpModel,
    *,
    variables: Sequence[Any] = (),
    time_limit: float | None = None,
    workers: int | None = None,
    hint: Mapping[Any, int] | None = None,
    seed: int | None = None,
    log: bool = False,
    parameters: Mapping[str, Any] | None = None,
) -> SolveResult:
    """Solve a CP-SAT model.

    model: the model, as a builder left it (objective optional).
    variables: integer/Boolean variables whose solution values form ``x`` (in order).
    time_limit: wall-clock limit in seconds (None: no limit).
    workers: number of search workers (None: CP-SAT's default, all cores).
    hint: a starting assignment {variable: value}; handed to CP-SAT as solution hints.
    seed: CP-SAT's random seed.
    log: print CP-SAT's search log.
    parameters: further CP-SAT parameters by their SatParameters field name, e.g.
        ``{"subsolvers": ["max_lp", "core"]}`` (a list sets a repeated field).

    Returns a SolveResult: ``x`` is an int64 array of the values of ``variables``
    (None without a solution), ``objective`` the objective value and ``bound`` CP-SAT's
    best objective bound (both None for a model without objective or solution).
    """
    if not isinstance(model, cp_model.CpModel):
        raise TypeError(f"model must be a cp_model.CpModel, got {type(model).__name__}")
    check_time_limit(time_limit)
    if workers is not None and (not isinstance(workers, int) or workers < 1):
        raise ValueError(f"workers must be a positive int, got {workers!r}")
    model.clear_hints()
    if hint:
        for var, value in hint.items():
            model.add_hint(var, int(value))
    solver = cp_model.CpSolver()
    params = solver.parameters
    if time_limit is not None:
        params.max_time_in_seconds = float(time_limit)
    if workers is not None:
        params.num_workers = workers
    if seed is not None:
        params.random_seed = int(seed)
    params.log_search_progress = bool(log)
    for name, value in (parameters or {}).items():
        if not hasattr(params, name):
            raise ValueError(f"unknown CP-SAT parameter {name!r}")
        if isinstance(value, (list, tuple)):
            field = getattr(params, name)
            field.clear()
            field.extend(value)
        else:
            try:
                setattr(params, name, value)
            except (TypeError, ValueError) as exc:
                raise ValueError(f"CP-SAT parameter {name}={value!r}: {exc}") from exc

    t0 = time.perf_counter()
    try:
        code = solver.solve(model)
    except Exception as exc:  # the backend failed: report, never a result that looks valid
        return SolveResult(Status.ERROR, backend=BACKEND, backend_status="exception",
                           message=f"CP-SAT raised {exc!r}", solve_time=time.perf_counter() - t0,
                           warm_started=bool(hint))
    elapsed = time.perf_counter() - t0
    status = map_status(code, STATUS_MAP)
    has_objective = model.has_objective()
    objective = bound = None
    x = None
    if status.has_solution:
        x = np.array([solver.value(v) for v in variables], dtype=np.int64)
        if has_objective:
            objective = float(solver.objective_value)
            bound = float(solver.best_objective_bound)
    message = ""
    if status is Status.ERROR:
        message = f"CP-SAT: {solver.status_name(code)}; model validation: {model.validate() or 'ok'}"
    elif status is Status.NO_SOLUTION:
        message = "CP-SAT stopped (time limit) before finding a solution"
    return SolveResult(
        status=status,
        objective=objective,
        bound=bound,
        x=x,
        backend=BACKEND,
        backend_status=solver.status_name(code),
        message=message,
        solve_time=elapsed,
        iterations=int(solver.num_branches),
        warm_started=bool(hint),
        info={"num_branches": int(solver.num_branches), "num_conflicts": int(solver.num_conflicts),
              "wall_time": float(solver.wall_time)},
    )
