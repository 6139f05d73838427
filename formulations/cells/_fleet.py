"""The smallest fleet: the fewest drone-cells that cover a given share of the users' weight."""

from __future__ import annotations

import math
import time
from dataclasses import replace

import numpy as np

from droneplan.core.validation import check_in_range, check_instance, check_int, check_time_limit
from droneplan.formulations.cells._core import evaluate
from droneplan.formulations.cells._exact import solve_exact
from droneplan.formulations.cells._milp import CellModel, build_milp
from droneplan.formulations.cells._open import MAX_WORKERS, _checked, _empty_plan, _with_total_time
from droneplan.scenarios.cells import CellProblem
from droneplan.solvers.result import SolveResult, Status

__all__ = ["min_fleet"]


def min_fleet(
    problem: CellProblem,
    *,
    coverage: float = 1.0,
    time_limit: float | None = None,
    backend: str | None = None,
    workers: int | None = None,
) -> SolveResult:
    """The fewest drone-cells (at most ``problem.n_cells``) that cover at least ``coverage`` of
    the active users' weight (served weight, with a capacity), with backhaul and every other
    constraint of the problem: the candidate model with the objective row
    ``covered weight >= coverage * total`` and the objective ``min sum_c x_c``.

    problem: the CellProblem (its variants apply). coverage: the share in (0, 1] (1: everyone).
    time_limit: wall-clock limit (s), None: none. backend: "cp-sat", "highs" or "scip"; None:
    CP-SAT when every weight is an integer, HiGHS otherwise (CP-SAT rows take integers only).
    workers: backend threads, 1..``MAX_WORKERS`` (None: the backend's default).

    Returns a SolveResult: ``objective`` the number of drone-cells, ``bound`` a proven lower
    bound on it, ``x`` the plan ((k, 2) m); OPTIMAL when proven. When even ``n_cells``
    drone-cells cannot reach the share: INFEASIBLE, with ``info["best_share"]`` the largest
    share ``n_cells`` drone-cells reach (``info["best_share_proven"]`` whether that is proven
    within the time left).
    """
    check_instance("problem", problem, CellProblem)
    share = check_in_range("coverage", coverage, 0.0, 1.0, lo_open=True)
    limit = check_time_limit(time_limit)
    if workers is not None:
        workers = check_int("workers", workers, min_value=1, max_value=MAX_WORKERS)
    t0 = time.perf_counter()
    weights = problem.target_weights
    total = float(weights.sum())
    integral = bool(np.all(np.mod(weights, 1.0) == 0))
    backend = backend if backend is not None else ("cp-sat" if integral else "highs")
    need = share * total
    need = math.ceil(need - 1e-9) if integral else need
    model = build_milp(problem, backend=backend, deadline=None if limit is None else t0 + limit)
    if model is None:  # only the deadline stops this build
        return SolveResult(
            Status.NO_SOLUTION,
            backend=backend,
            message="the time limit was reached while the model was built",
            solve_time=time.perf_counter() - t0,
            info={"engine": "milp"},
        )
    if need <= 0:
        return _with_total_time(_fleet_result(model, _empty_plan(model, t0), need, total), t0)
    model.add(model.objective >= need)
    model.model.minimize(model.sum(model.x))
    raw = model.model.solve(variables=model.x, time_limit=limit, workers=workers)
    result = _fleet_result(model, _checked(model, raw, t0), need, total)
    if result.status is Status.INFEASIBLE:
        left = None if limit is None else max(limit - (time.perf_counter() - t0), 1.0)
        best = solve_exact(problem, backend=backend, time_limit=left)
        value = 0.0 if best.objective is None else float(best.objective)
        info = {
            **result.info,
            "best_share": value / total,
            "best_share_proven": best.status is Status.OPTIMAL,
        }
        result = replace(
            result,
            info=info,
            message=f"{problem.n_cells} drone-cells reach at most {value / total:.1%} of the weight "
            f"({'proven' if info['best_share_proven'] else 'best found'}), short of {share:.1%}",
        )
    return _with_total_time(result, t0)


def _fleet_result(model: CellModel, result: SolveResult, need: float, total: float) -> SolveResult:
    """A fleet-size result: the count of the plan as the objective, the share in ``info``."""
    info = {**result.info, "required_weight": need, "total_weight": total}
    if not result.has_solution:
        return replace(result, info=info)
    ev = info.get("evaluation") or evaluate(model.problem, result.x)
    info["covered_share"] = ev.value / total if total else 1.0
    count = float(len(result.x))
    bound = count if result.status is Status.OPTIMAL else result.bound
    message = (
        f"fleet of {len(result.x)} covering {info['covered_share']:.1%} of the weight; " + result.message
    )
    return replace(result, objective=count, bound=bound, info=info, message=message)
