"""The public exact solves of the candidate problem: one entry, two engines.

:func:`solve_exact` prepares candidates, the incumbent (greedy and warm start) and the
continuous bound once (``_prepare.prepare``) and hands them to either engine:

- ``engine="bnb"``: the combinatorial branch and bound of ``_bnb`` (no model);
- ``engine="milp"``: the candidate model of ``_milp`` on a linear backend.

:func:`branch_and_bound` and :func:`solve_milp` are ``solve_exact`` with the engine fixed.
Both engines solve the same candidate problem, so on a proven instance they agree on the
optimum value (the tests check both against brute force).
"""

from __future__ import annotations

import warnings
from typing import Any

from droneplan.core.validation import check_bool, check_int
from droneplan.formulations.cells._bnb import search
from droneplan.formulations.cells._core import evaluate
from droneplan.formulations.cells._milp import CONNECTIVITY, solve_model
from droneplan.formulations.cells._prepare import Prepared, prepare
from droneplan.scenarios.cells import CellProblem
from droneplan.solvers.registry import get_backend
from droneplan.solvers.result import SolveResult, Status

ENGINES = ("bnb", "milp")
"""Exact engines of :func:`solve_exact`: the combinatorial branch and bound or the model."""


def _check_common(
    problem: CellProblem,
    engine: str,
    backend: str,
    connectivity: str,
    workers: int,
    max_rounds: int,
    user_cliques: bool,
) -> None:
    """The argument checks shared by the entries (each error names its parameter; the
    warm start is checked by ``prepare`` under its own name)."""
    if not isinstance(problem, CellProblem):
        raise TypeError(f"problem must be a CellProblem, got {type(problem).__name__}")
    if engine not in ENGINES:
        raise ValueError(f"engine must be one of {ENGINES}, got {engine!r}")
    get_backend(backend, kind="linear")  # an unknown or unavailable backend raises ValueError here
    if connectivity not in CONNECTIVITY:
        raise ValueError(f"connectivity must be one of {CONNECTIVITY}, got {connectivity!r}")
    check_int("workers", workers, min_value=1)
    check_int("max_rounds", max_rounds, min_value=0)
    check_bool("user_cliques", user_cliques)


def _early_exit(prep: Prepared, backend: str, engine: str) -> SolveResult | None:
    """The result when no search is needed (nothing to cover, the incumbent attains the
    bound, or no time is left), else None."""
    if len(prep.cand.points) == 0 or prep.cont_bound == 0:
        return prep.result(
            Status.OPTIMAL,
            objective=0.0,
            bound=0.0,
            x=prep.inc[:0].reshape(0, 2),
            backend=backend,
            message="no user can be covered by a feasible drone-cell: optimum 0 (no sites)",
            engine=engine,
            model_stats={"candidates": len(prep.cand.points)},
        )
    note = (
        ""
        if prep.cont_bound is not None
        else f"; continuous-problem bound not available ({prep.info['relaxation_message']})"
    )
    if prep.inc_val >= prep.ub:
        return prep.result(
            Status.OPTIMAL,
            objective=prep.inc_val,
            bound=prep.ub,
            x=prep.inc,
            backend=backend,
            message="bound valid for the continuous problem (max coverage by m discs without "
            "overlap/backhaul) and attained: globally optimal" + note,
            engine=engine,
        )
    if prep.expired():
        return prep.result(
            Status.FEASIBLE,
            objective=prep.inc_val,
            bound=prep.cont_bound,
            x=prep.inc,
            backend=backend,
            message="time limit reached before the search started; the plan is the greedy or warm start"
            + note,
            engine=engine,
        )
    return None


def _polish(prep: Prepared, *, greedy: bool = True) -> None:
    """Improve the starts with the primal heuristics of ``_bnb`` (1-swap local search and the
    exchange search; no elimination, no main search) and make the best the incumbent.

    The starts are the greedy placement (unless ``greedy`` is False) and the warm start's
    feasible part, each polished on its own within a share of at most a quarter of the time
    left (``_POLISH_MAX_S`` in all); on a tie the warm start's line wins. ``info["incumbent"]``
    and ``info["warm_start"]`` record the values. Exactness does not depend on it: a
    placement only becomes the incumbent after ``evaluate`` confirms it, and the engine then
    proves or improves on its value alone. The model's pruning and objective cut get
    stronger with a better incumbent: Table 4.2 m = 4 seed 3, CP-SAT, 120 s: from greedy
    (55) not proven (bound 66); from 64 proven."""
    starts = [("greedy", prep.greedy, prep.greedy_val)] if greedy else []
    if prep.warm is not None and len(prep.warm):
        starts.append(("warm_start", prep.warm, prep.warm_val))
    if not starts:
        return
    left = prep.left()
    budget = (_POLISH_MAX_S if left is None else min(_POLISH_MAX_S, 0.25 * left)) / len(starts)
    polished: dict[str, int] = {}
    for name, pos, val in starts:
        bb = search(
            prep.problem, prep.cand, pos, val, upper=prep.ub, time_limit=budget, workers=1, main=False
        )
        ev = evaluate(prep.problem, bb.positions)
        if ev.feasible and ev.covered > val:
            pos, val = bb.positions, int(ev.covered)
        polished[name] = val
        if val > prep.inc_val or (name == "warm_start" and val >= prep.inc_val):
            prep.inc, prep.inc_val, prep.warm_used = pos, val, name == "warm_start"
    prep.info["incumbent"] = {
        "greedy": prep.greedy_val,
        **({"greedy_polished": polished["greedy"]} if "greedy" in polished else {}),
        "value": int(prep.inc_val),
        "from": "warm_start" if prep.warm_used else "greedy",
    }
    if "warm_start" in polished:
        ws = prep.info["warm_start"]
        ws["polished_value"] = polished["warm_start"]
        ws["used"] = prep.warm_used
        head = ws["reason"].split("; its feasible part")[0].split("not used as incumbent")[0]
        part = f"its feasible part ({ws['value']} users), polished to {polished['warm_start']}, "
        rival = f"greedy start polished to {prep.inc_val}" if greedy else f"greedy start ({prep.inc_val})"
        ws["reason"] = (
            head
            + part
            + (
                "is the incumbent"
                if prep.warm_used
                else f"lost to the {rival}; its sites stay in the candidate set"
            )
        )


_POLISH_MAX_S = 30.0
"""Seconds at most for ``_polish``."""


def _solve_bnb(prep: Prepared, workers: int) -> SolveResult:
    """The combinatorial branch and bound (``_bnb.search``) from the prepared incumbent."""
    problem = prep.problem
    bb = search(
        problem,
        prep.cand,
        prep.inc,
        int(prep.inc_val),
        upper=prep.ub,
        time_limit=prep.left(),
        workers=workers,
    )
    obj = float(evaluate(problem, bb.positions).covered)
    bnd = float(max(min(bb.bound, prep.ub), obj))
    proven = bb.proven or obj >= bnd
    msg = prep.bound_text(bnd, "the exact combinatorial branch and bound (engine 'bnb')")
    if not proven:
        msg += f"; time limit reached after {bb.nodes} search nodes, optimality not proven"
    return prep.result(
        Status.OPTIMAL if proven else Status.FEASIBLE,
        objective=obj,
        bound=obj if proven else bnd,
        x=bb.positions,
        backend="bnb",
        message=msg,
        engine="bnb",
        iterations=bb.nodes,
        model_stats={
            "engine": "bnb",
            "candidates": len(prep.cand.points),
            "pruned_sites": int(prep.info.get("pruned_sites", 0)),
            "nodes": bb.nodes,
            "eliminated": bb.eliminated,
            "dominated": bb.dominated,
            "elimination_time": bb.elimination_time,
        },
    )


def solve_exact(
    problem: CellProblem,
    *,
    engine: str = "bnb",
    backend: str = "cp-sat",
    time_limit: float | None = None,
    warm_start=None,
    workers: int = 2,
    connectivity: str = "hops",
    max_rounds: int = 200,
    user_cliques: bool = True,
) -> SolveResult:
    """Solve the candidate problem exactly with either engine (module docstring).

    problem: the CellProblem (users, GBSs, m, radii in metres).
    engine: "bnb" (default): the combinatorial branch and bound (no model; ``backend``,
        ``connectivity``, ``max_rounds`` and ``user_cliques`` unused); "milp": the candidate
        model on ``backend``.
    backend: linear backend of the model and of the continuous bound's solve: "cp-sat"
        (default), "highs" or "scip".
    time_limit: wall-clock limit (s) for the whole call, candidate generation and model
        building included; when it is reached the best plan and bound found so far are
        returned (FEASIBLE). None: no limit.
    warm_start: drone-cell positions ((k, 2) m, e.g. the GA's). They are added to the
        candidate set (so the result is never worse than a feasible warm start). Their
        feasible part (sites outside bounds, in a GBS cell, overlapping or without
        backhaul dropped) is always polished by the primal heuristics, beside the greedy
        start; the better line (the warm start's on a tie) becomes the incumbent, the
        model's hint (CP-SAT's hint; HiGHS's start solution through highspy's
        ``setSolution``; the incumbent's value is also the model's objective cut) and the
        search's start. ``info["warm_start"]``
        says what happened (``used``, ``value``, ``polished_value``, ``greedy_value``,
        ``reason``), ``info["incumbent"]`` which line won and its value.
    workers: for engine "milp", CP-SAT workers / MIP threads; for "bnb", processes that
        share the search on thesis-scale instances (forked; 1: this process alone).
    connectivity: "hops" (default) or "lazy", the model's exact backhaul formulation (hop
        levels measured faster: Table 4.2 m = 4 seed 3, CP-SAT, 1 worker, from the optimum
        as incumbent: proven in 78 s, lazy cuts still at bound 66 after 120 s).
    max_rounds: at most this many model solves, an int >= 0 (engine "milp"; then FEASIBLE
        with the bound found so far).
    user_cliques: add the per-user at-most-one rows to the model (engine "milp").

    Returns a SolveResult: ``x`` positions (k, 2) with k <= m, ``objective`` covered
    users, ``bound`` an upper bound valid for the *candidate* problem (all user
    points, pairwise R_d-circle intersections, R_d circles met with the r1 and
    R_g + R_d circles and the area edges, and the warm start); ``backend`` "bnb" or the
    model's backend; ``info`` holds ``engine``, ``continuous_bound`` (valid for the
    continuous problem: max coverage by m discs without overlap/backhaul constraints;
    None, with the reason in ``message``, when no backend could compute it),
    ``global_optimal`` (objective equals the continuous bound), ``rounds`` (model solves),
    ``model_stats``. ``message`` says which bound is which and which engine gave it.
    """
    _check_common(problem, engine, backend, connectivity, workers, max_rounds, user_cliques)
    prep = prepare(problem, warm_start=warm_start, time_limit=time_limit)
    done = _early_exit(prep, "bnb" if engine == "bnb" else backend, engine)
    if done is not None:
        return done
    if engine == "bnb":
        # the search polishes its incumbent itself; a warm start is polished here too, so it
        # is always tried, and the better of the two lines starts the search. The sites that
        # cannot beat the incumbent go first (``Prepared.prune_candidates``), and again once
        # the polish has raised it.
        prep.prune_candidates()
        _polish(prep, greedy=False)
        prep.prune_candidates()
        return _solve_bnb(prep, workers)
    _polish(prep)
    done = _early_exit(prep, backend, engine)
    if done is not None:
        return done
    return solve_model(
        prep,
        backend=backend,
        workers=workers,
        connectivity=connectivity,
        max_rounds=max_rounds,
        user_cliques=user_cliques,
    )


def branch_and_bound(
    problem: CellProblem, *, time_limit: float | None = None, warm_start=None, workers: int = 2
) -> SolveResult:
    """The exact combinatorial branch and bound over the candidate sites:
    ``solve_exact(problem, engine="bnb", ...)``.

    problem: the CellProblem (users, GBSs, m, radii in metres).
    time_limit: wall-clock limit (s) for the whole call, None: none.
    warm_start: drone-cell positions ((k, 2) m) handed in as a start (``solve_exact``).
    workers: processes that share the search (forked; 1: this process alone).
    """
    return solve_exact(problem, engine="bnb", time_limit=time_limit, warm_start=warm_start, workers=workers)


def solve_milp(
    problem: CellProblem,
    *,
    backend: str = "cp-sat",
    time_limit: float | None = None,
    warm_start=None,
    workers: int = 2,
    connectivity: str = "hops",
    max_rounds: int = 200,
    user_cliques: bool = True,
    engine: str = "milp",
) -> SolveResult:
    """The candidate MILP on a linear backend: ``solve_exact(problem, engine="milp", ...)``.

    problem: the CellProblem (users, GBSs, m, radii in metres).
    backend: "cp-sat" (default), "highs" or "scip".
    time_limit: wall-clock limit (s) for the whole call, None: none.
    warm_start: drone-cell positions ((k, 2) m) handed in as a start (``solve_exact``).
    workers: CP-SAT workers / MIP threads.
    connectivity: "hops" (default) or "lazy", the exact backhaul formulation.
    max_rounds: at most this many model solves.
    user_cliques: add the per-user at-most-one rows.
    engine: "milp" (default). "bnb" is still accepted for callers written when it was the
        default (a DeprecationWarning); use :func:`solve_exact` or :func:`branch_and_bound`.
    """
    if engine == "bnb":
        warnings.warn(
            "solve_milp(engine='bnb') runs no MILP; call solve_exact(engine='bnb') or branch_and_bound",
            DeprecationWarning,
            stacklevel=2,
        )
    kw: dict[str, Any] = {
        "connectivity": connectivity,
        "max_rounds": max_rounds,
        "user_cliques": user_cliques,
    }
    return solve_exact(
        problem,
        engine=engine,
        backend=backend,
        time_limit=time_limit,
        warm_start=warm_start,
        workers=workers,
        **kw,
    )
