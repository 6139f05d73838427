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

import os
import time
import warnings
from collections.abc import Callable
from typing import Any

import numpy as np

from droneplan.core.validation import check_bool, check_instance, check_int, check_time_limit
from droneplan.formulations.cells._bnb import (
    BranchAndBoundSearch,
    _can_fork,
    _Timeout,
    relation_bytes,
    relations_fit,
    search,
)
from droneplan.formulations.cells._core import evaluate
from droneplan.formulations.cells._milp import CONNECTIVITY, refuse_before_polish, solve_prepared
from droneplan.formulations.cells._open import BNB_VARIANTS, solve_variant
from droneplan.formulations.cells._portfolio import ModelPeer, solve_portfolio
from droneplan.formulations.cells._prepare import Prepared, _near_any, dropped_sites_text, prepare
from droneplan.scenarios.cells import CellProblem
from droneplan.solvers.registry import get_backend
from droneplan.solvers.result import SolveResult, Status

ENGINES = ("bnb", "milp")
"""Exact engines of :func:`solve_exact`: the combinatorial branch and bound or the model."""

ENGINE_CHOICES = ("auto", *ENGINES)
"""What ``solve_exact(engine=...)`` accepts: ``"auto"`` (the default) runs both engines as a
portfolio on two cores or more, else ``ONE_CORE_ENGINE``."""

ONE_CORE_ENGINE = "bnb"
"""The engine ``engine="auto"`` runs when one worker is all it has. Measured (Table 4.2 m = 4
seeds 0-9, one worker each, time limit 300 s, load 6.4-7.6): both engines prove every seed; the
branch and bound takes 58.2 CPU-s in all against the MILP's 115.0, and no more than the MILP on
any seed (seed 8: 0.15 both), so a single core goes to it."""

DEFAULT_WORKERS: dict[str, int] = {"bnb": 2, "milp": 1, "auto": 2}
"""Workers of :func:`solve_exact` per engine when ``workers`` is None: the branch and bound's
forked processes, the model's CP-SAT workers (or MIP threads). A second CP-SAT worker slowed the
model's proof on a 2-core machine and did not speed it up (Table 4.2, CP-SAT, wall s with 1 / 2
workers, load 1-2): m = 6 seed 14 203 / 494 (494 with the subsolvers of
``_milp.FEW_WORKER_OPTIONS``, 484 and 463 with pseudo_costs or no_lp in place of max_lp, 464
with default_lp alone; at load 3, 2 workers left it open at 88 / 99 after 600 s), seed 3 87.0 /
87.8, seed 5 43.6 / 43.6, a Thomas-process m = 6 instance 344 / 350, m = 4 seed 5 14.5 / 13.8."""


def _engine_for(problem: CellProblem, engine: str | None) -> str:
    """The engine that runs: ``engine``, or for None the branch and bound on the thesis model and
    the MILP on a variant; ValueError when the branch and bound is asked for a variant it cannot
    solve."""
    check_instance("problem", problem, CellProblem)
    unsupported = [v for v in problem.variants if v not in BNB_VARIANTS]
    if engine is None or (engine == "auto" and unsupported):
        return "milp" if unsupported else "auto"
    if engine == "bnb" and unsupported:
        raise ValueError(
            f"engine 'bnb' cannot solve an instance with {', '.join(unsupported)}: use engine='milp'"
        )
    return engine


def _check_common(
    problem: CellProblem,
    engine: str,
    backend: str,
    connectivity: str,
    workers: int | None,
    max_rounds: int,
    user_cliques: bool,
) -> None:
    """The argument checks shared by the entries (each error names its parameter; the
    warm start is checked by ``prepare`` under its own name)."""
    if not isinstance(problem, CellProblem):
        raise TypeError(f"problem must be a CellProblem, got {type(problem).__name__}")
    if engine not in ENGINE_CHOICES:
        raise ValueError(f"engine must be one of {ENGINE_CHOICES}, got {engine!r}")
    get_backend(backend, kind="linear")  # an unknown or unavailable backend raises ValueError here
    if connectivity not in CONNECTIVITY:
        raise ValueError(f"connectivity must be one of {CONNECTIVITY}, got {connectivity!r}")
    if workers is not None:
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
    (55) not proven (bound 66); from 64 proven. The exchange search takes out sets of
    ``POLISH_EXCHANGE_SIZES`` sites (the main search of the branch and bound only 1 or 2).

    The heuristics hold the search's site relations (``relation_bytes``); when those would
    take more than ``POLISH_MEMORY_SHARE`` of the machine's memory the starts are used as they
    are (``info["incumbent"]["polish"]`` says so), so that the model's size check, or the
    branch and bound's own memory check, answers first."""
    starts = [("greedy", prep.greedy, prep.greedy_val)] if greedy else []
    if prep.warm is not None and len(prep.warm):
        starts.append(("warm_start", prep.warm, prep.warm_val))
    if not starts:
        return
    left = prep.left()
    budget = (_POLISH_MAX_S if left is None else min(_POLISH_MAX_S, 0.25 * left)) / len(starts)
    n_sites = len(prep.cand.points)
    skip = not relations_fit(n_sites, POLISH_MEMORY_SHARE)
    polished: dict[str, int] = {}
    for name, pos, val in starts:
        if not skip:
            bb = search(
                prep.problem,
                prep.cand,
                pos,
                val,
                upper=prep.ub,
                time_limit=budget,
                workers=1,
                main=False,
                exchange_sizes=polish_exchange_sizes(prep.problem.n_cells),
            )
            prep.polish_stopped |= not bb.built
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
        "polish": (
            f"skipped: the site relations would take {relation_bytes(n_sites) / 2**30:.1f} GiB, over "
            f"{POLISH_MEMORY_SHARE:.0%} of this machine's memory"
            if skip
            else "stopped: its share of the time limit passed while the site relations were built"
            if prep.polish_stopped
            else "run"
        ),
    }
    if "warm_start" in polished:
        ws = prep.info["warm_start"]
        ws["polished_value"] = polished["warm_start"]
        ws["used"] = prep.warm_used
        head = dropped_sites_text(ws["given"], len(starts[-1][1]))  # the warm start is the last start
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

POLISH_EXCHANGE_SIZES = (1, 2, 3)
"""Sizes of the site sets that ``_polish``'s exchange search takes out of a start (m >= 4;
below, ``polish_exchange_sizes``). Sets of 3 reach placements that differ from the start in
three sites, where 1-swaps and sets of 2 stop at a local optimum; each exchange stays an
exact search below the rest of the start, bounded by the polish's time share. Measured on
Table 4.2 in the CHANGELOG: they reach the optimum on five of the library's hard entries,
change no value on m = 4-8 seeds 0-9, and take seconds."""


def polish_exchange_sizes(n_cells: int) -> tuple[int, ...]:
    """The exchange sizes of ``_polish`` for m = ``n_cells``: ``POLISH_EXCHANGE_SIZES`` below m,
    and at least 1 and 2 (at m <= 3 a set of 3 would be the whole search)."""
    return tuple(k for k in POLISH_EXCHANGE_SIZES if k < n_cells or k <= 2)


POLISH_MEMORY_SHARE = 0.25
"""``_polish`` runs only when the search's site relations take at most this share of the
machine's memory: at Table 4.2 density x8 (250,211 sites) they would take 14.6 GiB of 23.5, before
the model's own size check (half the memory) could answer."""


ELIMINATION_SHARE = 0.5
"""Share of the time left that ``_eliminate_for_model`` may take (a site elimination cut
short still drops the sites it has cleared)."""

ELIMINATION_MAX_SITES = 20_000
"""``_eliminate_for_model`` is skipped above this many sites (after the pruning of
``Prepared.prune_candidates``): the search's site relations take n^2 / 8 bytes each."""


def _eliminate_for_model(prep: Prepared) -> None:
    """Drop from ``prep.cand`` the sites that the branch and bound's root elimination clears
    (``_bnb`` items 9, 10 and 13), before the model is built (engine "milp" with
    ``bnb_elimination``). ``info["elimination"]`` records what it did.

    Exactness. Let z be the incumbent value and A the sites left alive. Items 9-10 clear a
    site only when no placement holding it beats z (each probe's bound is valid given the
    sites cleared before it, so an elimination stopped at its time limit is valid too);
    item 13 clears a site c only when an alive site d can replace it in every placement of
    alive sites without losing coverage or feasibility. So when some placement beats z, a
    placement of A at least as good exists. The incumbent's sites are added back (a
    superset of A keeps that, and the model's hint and objective cut ``>= z`` stay
    satisfiable). Every placement of the kept sites is a candidate placement, so the
    candidate optimum is max(z, the model's optimum) <= max(z, the model's bound): the
    model over the kept sites proves the same optimum and reports a valid bound (its bound
    is never below its incumbent z). When a probe finds a better placement, it becomes the
    incumbent before the sites are dropped (the elimination used its value)."""
    prep.prune_candidates()  # item 1's rule first: the search's relations grow with n^2
    cand = prep.cand
    n = len(cand.points)
    if n == 0 or prep.problem.n_cells < 3 or n > ELIMINATION_MAX_SITES or prep.expired():
        prep.info["elimination"] = {"run": False, "sites": n}
        return
    t_start = time.perf_counter()
    left = prep.left()
    limit = None if left is None else (t_start - prep.t0) + ELIMINATION_SHARE * left
    try:
        bb = BranchAndBoundSearch(
            prep.problem, cand, int(prep.inc_val), upper=prep.ub, time_limit=limit, t0=prep.t0
        )
    except _Timeout:  # its share of the time passed while the site relations were built
        prep.info["elimination"] = {"run": False, "sites": n, "reason": "time limit"}
        return
    alive = np.ones(bb.n, dtype=bool)
    complete, dominated = True, 0
    try:
        bb.eliminate_sites(alive)
        dominated = bb.drop_dominated(alive)
    except _Timeout:
        complete = False
    if bb.best_val > prep.inc_val:  # a probe found a better placement: it must be the incumbent
        ev = evaluate(prep.problem, bb.pts[bb.best]) if bb.best is not None else None
        if ev is None or not ev.feasible or ev.covered < bb.best_val:
            prep.info["elimination"] = {"run": False, "sites": n, "reason": "unconfirmed incumbent"}
            return
        prep.inc, prep.inc_val, prep.warm_used = bb.pts[bb.best], int(ev.covered), False
        prep.info.setdefault("incumbent", {})["value"] = prep.inc_val
    keep = np.zeros(n, dtype=bool)
    keep[bb.order[alive]] = True
    if len(prep.inc):
        keep |= _near_any(cand.points, np.asarray(prep.inc, dtype=float).reshape(-1, 2))
    idx = np.flatnonzero(keep)
    prep.cand = cand.subset(idx)
    prep.info["elimination"] = {
        "run": True,
        "complete": complete,
        "sites": n,
        "kept": len(idx),
        "dominated": dominated,
        "time": time.perf_counter() - t_start,
    }


def _solve_bnb(prep: Prepared, workers: int, peer: ModelPeer | None = None) -> SolveResult:
    """The combinatorial branch and bound (``_bnb.search``) from the prepared incumbent; beside
    the model (``peer``, ``_portfolio``) it prunes against the model's incumbents too, and its
    placement is the better of its own and the model's."""
    problem = prep.problem
    bb = search(
        problem,
        prep.cand,
        prep.inc,
        int(prep.inc_val),
        upper=prep.ub,
        time_limit=prep.left(),
        workers=workers,
        on_incumbent=None if prep.report is None else prep.offer_report,
        peer=peer,
    )
    positions = bb.positions if peer is None else peer.better(bb.positions)
    prep.offer_report(positions)
    obj = float(evaluate(problem, positions).covered)
    bnd = float(max(min(bb.bound, prep.ub), obj))
    # proven: nothing beats bb.value, the value searched against (the model's, beside it)
    proven = (bb.proven and obj >= bb.value) or obj >= bnd
    msg = prep.bound_text(bnd, "the exact combinatorial branch and bound (engine 'bnb')")
    if not proven:
        msg += f"; time limit reached after {bb.nodes} search nodes, optimality not proven"
    return prep.result(
        Status.OPTIMAL if proven else Status.FEASIBLE,
        objective=obj,
        bound=obj if proven else bnd,
        x=positions,
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


def available_cores() -> int:
    """Cores this process may run on (its CPU affinity; ``os.cpu_count()`` where unknown)."""
    try:
        return len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        return os.cpu_count() or 1


def _run_bnb(prep: Prepared, workers: int, peer: ModelPeer | None = None) -> SolveResult:
    """The branch and bound from the preparation: the search polishes its incumbent itself; a
    warm start is polished here too, so it is always tried, and the better of the two lines
    starts the search. The sites that cannot beat the incumbent go first
    (``Prepared.prune_candidates``), and again once the polish has raised it."""
    prep.prune_candidates()
    _polish(prep, greedy=False)
    prep.offer_report(prep.inc)
    prep.prune_candidates()
    return _solve_bnb(prep, workers, peer)


def _run_model(
    prep: Prepared,
    backend: str,
    workers: int,
    connectivity: str,
    max_rounds: int,
    user_cliques: bool,
    bnb_elimination: bool,
) -> SolveResult:
    """The candidate model from the preparation, after the polish (and the branch and bound's
    root elimination when ``bnb_elimination``); a model too large even from the best incumbent
    the polish could reach is refused before it (``_milp.refuse_before_polish``)."""
    refuse_before_polish(prep, backend=backend, connectivity=connectivity, max_rounds=max_rounds)
    _polish(prep)
    if bnb_elimination:
        _eliminate_for_model(prep)
    prep.offer_report(prep.inc)
    done = _early_exit(prep, backend, "milp")
    if done is not None:
        return done
    return solve_prepared(
        prep,
        backend=backend,
        workers=workers,
        connectivity=connectivity,
        max_rounds=max_rounds,
        user_cliques=user_cliques,
    )


def _solve_portfolio(
    prep: Prepared, workers: int, backend: str, connectivity: str, max_rounds: int, user_cliques: bool
) -> SolveResult:
    """Both engines side by side (``_portfolio``): the model on one worker in a child, the
    branch and bound with the other ``workers - 1`` here."""

    def run_model(p: Prepared) -> SolveResult:
        return _run_model(p, backend, 1, connectivity, max_rounds, user_cliques, False)

    return solve_portfolio(
        prep, run_model=run_model, run_search=lambda p, peer: _run_bnb(p, max(1, workers - 1), peer)
    )


def solve_exact(
    problem: CellProblem,
    *,
    engine: str | None = None,
    backend: str = "cp-sat",
    time_limit: float | None = None,
    warm_start=None,
    workers: int | None = None,
    connectivity: str = "hops",
    max_rounds: int = 200,
    user_cliques: bool = True,
    bnb_elimination: bool = False,
    report: Callable[..., Any] | None = None,
) -> SolveResult:
    """Solve the candidate problem exactly with either engine (module docstring).

    problem: the CellProblem (users, GBSs, m, radii in metres).
    engine: "bnb": the combinatorial branch and bound (no model; ``backend``,
        ``connectivity``, ``max_rounds`` and ``user_cliques`` unused); "milp": the candidate
        model on ``backend``; "auto" or None (default): on the thesis model with ``workers`` >= 2
        and two cores, both side by side (``_portfolio``: the model on one worker in a forked
        child, its incumbents pruning the branch and bound, which gets the other workers; the
        first proof ends both; ``info["portfolio"]`` says which engine proved it, with each
        one's status, bound and wall time), with one worker ``ONE_CORE_ENGINE`` (the branch
        and bound, measured faster alone); on an instance with variants (weights, no-fly zones,
        capacity), which only the MILP solves, the whole candidate model solved once
        (``_open.solve_variant``; the warm start, the rounds and the thesis model's reductions
        are not used). ``info["engine"]`` says which ran ("auto" for the portfolio).
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
        share the search on thesis-scale instances (forked; 1: this process alone); for "auto",
        processes in all (the model's one and the branch and bound's others). None (default):
        per engine, ``DEFAULT_WORKERS`` (2 for "bnb" and "auto", 1 for "milp": a second CP-SAT
        worker slowed the model's proofs measured on 2 cores).
    connectivity: "hops" (default) or "lazy", the model's exact backhaul formulation (hop
        levels measured faster: Table 4.2 m = 4 seed 3, CP-SAT, 1 worker, from the optimum
        as incumbent: proven in 78 s, lazy cuts still at bound 66 after 120 s).
    max_rounds: at most this many model solves, an int >= 0 (engine "milp"; then FEASIBLE
        with the bound found so far).
    user_cliques: add the per-user at-most-one rows to the model (engine "milp").
    bnb_elimination: engine "milp": True first drops the sites that the branch and bound's
        root site elimination clears (``_eliminate_for_model``; the model's proof then rests
        on those rules too). False (default): the model is pruned by its own rules only, so
        its proof uses nothing from the branch and bound (the polished start is only a
        start, checked by ``evaluate``), as cross-certification of the two engines needs.
        Measured (Table 4.2, CP-SAT, 1 worker, CPU s without / with): m = 4 seeds 0-9 52.4 /
        41.9 in all (seed 5 19.7 / 14.1, seeds 2, 3, 6 slower); m = 6 seed 5 67.1 / 76.9;
        m = 6 seed 1 open at 66 / 75 after 600 s either way (4 188 of 4 387 sites kept).
    report: called as ``report(positions, bound=b)`` with each placement better than the last
        one reported, as the engine finds it (an anytime trace): the start (greedy or warm
        start), its polish, the model's solutions as the backend finds them (CP-SAT), the
        branch and bound's incumbents (in this process; those of forked workers with the
        result). ``positions`` is (k, 2) m, feasible; ``b`` is the continuous-problem bound,
        valid throughout (the proven bound is the result's). A variant reports its final plan
        only, with the result's bound.

    Returns a SolveResult: ``x`` positions (k, 2) with k <= m, ``objective`` covered
    users, ``bound`` an upper bound valid for the *candidate* problem (all user
    points, pairwise R_d-circle intersections, R_d circles met with the r1 and
    R_g + R_d circles and the area edges, and the warm start); ``backend`` "bnb" or the
    model's backend; ``info`` holds ``engine``, ``continuous_bound`` (valid for the
    continuous problem: max coverage by m discs without overlap/backhaul constraints;
    None, with the reason in ``message``, when no backend could compute it),
    ``global_optimal`` (objective equals the continuous bound), ``rounds`` (model solves),
    ``model_stats``. ``message`` says which bound is which and which engine gave it.

    Raises ValueError (engine "milp", hop levels) when the model's hop rows are projected past
    half this machine's memory at 128 bytes a term (``_milp.model_term_cap``), naming the terms
    asked for: before the polish when even the best incumbent it could reach (the continuous
    bound) leaves too large a model, else after the polish (which may raise the incumbent and
    so prune the model) and before the model, or the LP of its site fixing, is built.
    """
    engine = _engine_for(problem, engine)
    _check_common(problem, engine, backend, connectivity, workers, max_rounds, user_cliques)
    check_bool("bnb_elimination", bnb_elimination)
    workers = DEFAULT_WORKERS[engine] if workers is None else workers
    if report is not None and not callable(report):
        raise TypeError(f"report must be callable or None, got {type(report).__name__}")
    if problem.variants:
        limit = check_time_limit(time_limit)
        result = solve_variant(problem, backend=backend, time_limit=limit, workers=workers)
        if report is not None and result.has_solution:
            report(np.asarray(result.x, dtype=float), bound=result.bound)
        return result
    prep = prepare(problem, warm_start=warm_start, time_limit=time_limit)
    if report is not None:
        prep.report = report
        prep.offer_report(prep.inc)
    done = _early_exit(prep, "bnb" if engine == "bnb" else backend, engine)
    if done is not None:
        return done
    if engine == "auto":
        if workers >= 2 and available_cores() >= 2 and _can_fork():
            return _solve_portfolio(prep, workers, backend, connectivity, max_rounds, user_cliques)
        engine = ONE_CORE_ENGINE
    if engine == "bnb":
        return _run_bnb(prep, workers)
    return _run_model(prep, backend, workers, connectivity, max_rounds, user_cliques, bnb_elimination)


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
    workers: int | None = None,
    connectivity: str = "hops",
    max_rounds: int = 200,
    user_cliques: bool = True,
    bnb_elimination: bool = False,
    engine: str = "milp",
) -> SolveResult:
    """The candidate MILP on a linear backend: ``solve_exact(problem, engine="milp", ...)``.

    problem: the CellProblem (users, GBSs, m, radii in metres).
    backend: "cp-sat" (default), "highs" or "scip".
    time_limit: wall-clock limit (s) for the whole call, None: none.
    warm_start: drone-cell positions ((k, 2) m) handed in as a start (``solve_exact``).
    workers: CP-SAT workers / MIP threads; None (default): 1 (``DEFAULT_WORKERS``).
    connectivity: "hops" (default) or "lazy", the exact backhaul formulation.
    max_rounds: at most this many model solves.
    user_cliques: add the per-user at-most-one rows.
    bnb_elimination: True: drop the sites the branch and bound's root elimination clears
        first (``solve_exact``; default False: the model's proof uses nothing from it).
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
        "bnb_elimination": bnb_elimination,
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
