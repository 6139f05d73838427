"""The open candidate model: solve a :class:`CellModel` as the user left it, and the engine of the
model's variants (weights, no-fly zones, capacity).

``build_milp(problem)`` writes the candidate model of the thesis problem and of its variants
(see ``_milp``): the variants change the candidate set (no-fly zones remove sites and add the
points where the users' R_d circles cross a zone's edge), the objective weights (the covered
weight) or the objective itself (with a capacity, the served weight of a 0-1 assignment of
users to chosen sites). The user adds rows and objective terms over the named variables;
:func:`solve_model` solves the model once, with no reduction that assumes the objective (the
incumbent pruning, light-site, dominance and LP-fixing rows of the thesis engine are not
written), so its proof covers whatever the user added.
"""

from __future__ import annotations

import os
import time
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from droneplan.core.validation import check_bool, check_instance, check_int, check_time_limit
from droneplan.formulations.cells._core import as_positions, evaluate, served_pairs
from droneplan.formulations.cells._milp import FEW_WORKER_OPTIONS, CellModel, build_milp
from droneplan.formulations.cells._model import capacity_bound
from droneplan.formulations.cells._prepare import greedy_placement
from droneplan.scenarios.cells import CellProblem
from droneplan.solvers.result import SolveResult, Status

__all__ = ["solve_model", "solve_variant", "write_model", "BNB_VARIANTS"]

BNB_VARIANTS: tuple[str, ...] = ()
"""Variants whose instances the branch and bound solves: none (its coverage bounds count users,
its pruning assumes every site may be placed with any number of users). The MILP solves all."""


MAX_WORKERS = 1024
"""Most backend threads / CP-SAT workers ``solve_model`` accepts."""


def solve_model(
    model: CellModel,
    *,
    time_limit: float | None = None,
    workers: int | None = None,
    verbose: bool = False,
    warm_start: Any = None,
) -> SolveResult:
    """Solve a :class:`CellModel` from :func:`build_milp`, with the rows and objective terms the
    user added, and re-check its plan.

    model: the built model (solved as it stands; it may be solved again after more rows).
    time_limit: wall-clock limit (s), None: none. workers: backend threads / CP-SAT workers,
    1..``MAX_WORKERS`` (None: one; with one or two, CP-SAT runs its LP-based workers,
    ``FEW_WORKER_OPTIONS``, without which its bound on these models stays at the user count).
    verbose: print the backend's log. warm_start: a plan ((k, 2) or (k, 3) m) whose drone-cells
    are model sites, handed to the backend as a start (CP-SAT's hint; ``warm_started`` says
    whether it was used).

    Returns a SolveResult: ``x`` the chosen sites ((k, 2) m), ``objective`` the model's
    objective value (covered or served weight plus the user's terms), ``bound`` the backend's
    proven bound on it; OPTIMAL when the backend proved it, INFEASIBLE when the rows admit no
    plan (e.g. a user row no placement meets). ``info["evaluation"]`` is droneplan's
    :func:`evaluate` of the plan (covered users, ``value``, violations); a plan that breaks the
    problem's constraints is an ERROR result naming them. ``info["engine"]`` is "milp".
    """
    check_instance("model", model, CellModel)
    limit = check_time_limit(time_limit)
    if workers is not None:
        workers = check_int("workers", workers, min_value=1, max_value=MAX_WORKERS)
    verbose = check_bool("verbose", verbose)
    t0 = time.perf_counter()
    if not model.x:
        return _empty_plan(model, t0)
    hint = None if warm_start is None else _site_hint(model, warm_start)
    raw = model.model.solve(
        variables=model.x,
        time_limit=limit,
        workers=workers,
        verbose=verbose,
        hint=hint,
        options=FEW_WORKER_OPTIONS.get(model.backend) if (workers or 1) <= 2 else None,
    )
    return replace(_checked(model, raw, t0), warm_started=raw.warm_started)


def _site_hint(model: CellModel, plan: Any) -> dict:
    """{site variable: 0 or 1} choosing the model sites of ``plan``; ValueError naming a drone-cell
    that is no model site."""
    positions = as_positions(model.problem, plan, "warm_start")
    sites = model.plan(np.ones(len(model.points), dtype=bool))
    chosen = set()
    for p in positions:
        gap = np.abs(sites - p).max(axis=1) if len(sites) else np.zeros(0)
        if not len(gap) or gap.min() > 1e-6:
            raise ValueError(f"warm_start: the drone-cell at {p.tolist()} is no site of the model")
        chosen.add(int(np.argmin(gap)))
    hint = {var: int(i in chosen) for i, var in enumerate(model.x)}
    if model.serve:  # a capacity: the plan's best assignment too, so the start is complete
        site_of = sorted(chosen)
        column = {c: k for k, c in enumerate(site_of)}
        within = np.zeros((len(model.problem.targets), len(site_of)), dtype=bool)
        for u, c in model.serve:
            if c in column:
                within[u, column[c]] = True
        users, cells = served_pairs(within, model.problem.target_weights, int(model.problem.capacity or 0))
        served = {(int(u), site_of[int(k)]) for u, k in zip(users, cells, strict=True)}
        hint.update({var: int(key in served) for key, var in model.serve.items()})
    return hint


def _checked(model: CellModel, raw: SolveResult, t0: float) -> SolveResult:
    """The backend's result with the chosen sites as the plan, checked by ``evaluate``."""
    info: dict[str, Any] = {
        "engine": "milp",
        "model_stats": dict(model.stats),
        "variants": model.problem.variants,
    }
    if not raw.has_solution:
        return SolveResult(
            raw.status,
            bound=raw.bound,
            backend=model.backend,
            backend_status=raw.backend_status,
            message=raw.message or f"the candidate model on {model.backend}: {raw.status.value}",
            solve_time=time.perf_counter() - t0,
            info=info,
        )
    chosen = np.asarray(raw.x, dtype=float) > 0.5
    plan = model.plan(chosen)
    ev = evaluate(model.problem, plan)
    info["evaluation"] = ev
    status, message = raw.status, f"the candidate model on {model.backend} (engine 'milp')"
    if not ev.feasible:
        status = Status.ERROR
        message += "; its plan breaks the problem's constraints: " + "; ".join(ev.violations[:3])
    elif status is Status.OPTIMAL:
        message += ": proven optimal over the candidate sites"
    else:
        message += f": stopped ({raw.backend_status or raw.status.value}), optimality not proven"
    return SolveResult(
        status,
        objective=None if raw.objective is None else float(raw.objective),
        bound=None if raw.bound is None else float(raw.bound),
        x=plan,
        backend=model.backend,
        backend_status=raw.backend_status,
        message=message,
        solve_time=time.perf_counter() - t0,
        iterations=raw.iterations,
        info=info,
    )


def _empty_plan(model: CellModel, t0: float) -> SolveResult:
    """No candidate site is left (every one forbidden, or no user to cover): the empty plan,
    optimal (a user row on an empty model is checked by the backend as any other)."""
    plan = model.plan(np.zeros(len(model.points), dtype=bool))
    raw = model.model.solve(variables=[], time_limit=None)
    if not raw.has_solution:
        return _checked(model, raw, t0)
    ev = evaluate(model.problem, plan)
    return SolveResult(
        Status.OPTIMAL,
        objective=0.0 if raw.objective is None else float(raw.objective),
        bound=0.0 if raw.objective is None else float(raw.objective),
        x=plan,
        backend=model.backend,
        backend_status=raw.backend_status,
        message="no candidate site can be placed: the empty plan is optimal",
        solve_time=time.perf_counter() - t0,
        info={"engine": "milp", "evaluation": ev, "variants": model.problem.variants},
    )


def solve_variant(
    problem: CellProblem, *, backend: str, time_limit: float | None, workers: int | None
) -> SolveResult:
    """The exact solve of a variant instance (``solve_exact``'s MILP path for it): the whole
    candidate model, built and solved once within ``time_limit`` (s), from the greedy placement
    as the backend's start."""
    t0 = time.perf_counter()
    model = build_milp(problem, backend=backend, deadline=None if time_limit is None else t0 + time_limit)
    start = greedy_placement(problem)  # a start only: the model proves the bound
    left = None if time_limit is None else time_limit - (time.perf_counter() - t0)
    if model is None or (left is not None and left <= 0.0):
        why = "the time limit was reached while the model was built"
        return _start_only(problem, start, backend, None, why, t0)
    result = solve_model(model, time_limit=left, workers=workers, warm_start=start)
    if result.x is None and result.status is Status.NO_SOLUTION:
        why = f"the backend found no plan in time ({result.backend_status or result.status.value})"
        return _start_only(problem, start, model.backend, result.bound, why, t0)
    ev = result.info.get("evaluation")
    if ev is not None and ev.feasible and result.objective is not None:
        # at a stop short of the optimum the model may not credit every user the plan covers
        result = replace(result, objective=max(float(result.objective), float(ev.value)))
    return _with_total_time(result, t0)


def _start_only(
    problem: CellProblem, start: np.ndarray, backend: str, bound: float | None, why: str, t0: float
) -> SolveResult:
    """The greedy ``start`` with the backend's ``bound`` (None: none), when the model gave no
    plan: ``why``. With a capacity the bound is at most :func:`capacity_bound`, and a start that
    meets it is OPTIMAL (otherwise FEASIBLE)."""
    ev = evaluate(problem, start)
    if problem.capacity is not None:
        bound = capacity_bound(problem) if bound is None else min(float(bound), capacity_bound(problem))
    proven = bound is not None and ev.value >= bound - 1e-9 * max(1.0, abs(bound))
    return SolveResult(
        Status.OPTIMAL if proven else Status.FEASIBLE,
        objective=float(ev.value),
        bound=bound,
        x=np.asarray(start, dtype=float),
        backend=backend,
        message=f"{why}: the greedy plan"
        + ("" if bound is None else f", bound {bound:g}")
        + (", which it meets" if proven else ""),
        solve_time=time.perf_counter() - t0,
        info={"engine": "milp", "evaluation": ev, "variants": problem.variants},
    )


def _with_total_time(result: SolveResult, t0: float) -> SolveResult:
    """``result`` with its solve time measured from ``t0`` (a ``time.perf_counter()`` value)."""
    return replace(result, solve_time=time.perf_counter() - t0)


def write_model(
    problem_or_model: CellProblem | CellModel, path: str | os.PathLike[str], *, backend: str = "cp-sat"
) -> Path:
    """Write the candidate model as an MPS or LP file that any MIP solver reads.

    problem_or_model: a :class:`CellProblem` (its candidate model is built with
    :func:`build_milp` on ``backend``; variants included) or a :class:`CellModel` with the
    user's own rows and objective terms, written as it stands. path: the file, ``.mps`` (free
    MPS) or ``.lp`` (CPLEX LP); its folder must exist and be writable; it is written through a
    temporary file, so a failure leaves no partial file. backend: the linear backend the model is
    built on when given a problem ("cp-sat", "highs" or "scip").

    Variables are named by what they are: ``site{i}`` (candidate site i chosen, 0-1; its position
    is ``build_milp(problem).points[i]``), ``covered{u}`` (active user u covered; users covered by
    the same sites share one), ``serve{u}_{i}`` (with a capacity: user u served by site i),
    ``hop{i}_{l}`` (site i is l hops from a ground station, l >= 2), ``hop_le{i}_{l}`` and
    ``square_any{l}_{q}`` (auxiliary hop-row indicators), ``cut{k}`` (a connectivity cut's
    indicator). The objective is maximised: covered users (or the variant's weight).

    Returns the path (a ``pathlib.Path``). An empty model (no candidate site) is refused.
    """
    from droneplan.solvers.model_files import check_model_path

    target = check_model_path(path)
    if isinstance(problem_or_model, CellProblem):
        model = build_milp(problem_or_model, backend=backend)
        if model is None:
            raise ValueError("the candidate model could not be built for this problem")
    else:
        model = check_instance("problem_or_model", problem_or_model, CellModel)
    if not model.x:
        raise ValueError("problem_or_model: the model has no candidate site to write")
    return model.model.write(target)
