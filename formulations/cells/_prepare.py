"""What both exact engines start from, computed once: candidates, incumbent, bounds.

:func:`prepare` builds the candidate sites (with a warm start's sites added), the greedy
incumbent, the warm start's feasible part and the continuous relaxation bound;
:class:`Prepared` holds them with the clock of the call and builds every
:class:`SolveResult` of :func:`droneplan.formulations.cells.solve_exact` in one place.
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from droneplan.core.validation import check_instance, check_int, check_time_limit, require_set
from droneplan.formulations.cells._core import (
    TOL,
    Candidates,
    as_positions,
    candidate_sites,
    coverage_lists,
    evaluate,
    in_no_fly,
    merge_points,
    pair_intersections,
    pairwise_distances,
)
from droneplan.scenarios.cells import CellProblem
from droneplan.solvers.registry import get_backend
from droneplan.solvers.result import SolveResult, Status


def _maximal_sets(cover: list[np.ndarray]) -> list[np.ndarray]:
    """Coverage sets with duplicates and subsets of other sets removed (largest first).

    Exact for maximum coverage: replacing a disc by one covering a superset never
    lowers the union."""
    seen: dict[frozenset, None] = {}
    for c in cover:
        if len(c):
            seen.setdefault(frozenset(c.tolist()), None)
    kept: list[frozenset] = []
    by_user: dict[int, list[int]] = {}
    for s in sorted(seen, key=len, reverse=True):
        u0 = min(s, key=lambda u: len(by_user.get(u, ())))
        if any(s <= kept[k] for k in by_user.get(u0, ())):
            continue
        by_user_k = len(kept)
        kept.append(s)
        for u in s:
            by_user.setdefault(u, []).append(by_user_k)
    return [np.array(sorted(s), dtype=np.int64) for s in kept]


def coverage_upper_bound(
    problem: CellProblem,
    n_discs: int | None = None,
    *,
    backend: str = "highs",
    time_limit: float | None = None,
) -> SolveResult:
    """Maximum number of active users that ``n_discs`` radius-R_d discs can cover with
    non-overlap, GBS clearance and backhaul all dropped: an upper bound of the
    *continuous* placement problem.

    Exactness of the finite model: for any disc centre p with covered set S, the
    convex set A = intersection of the discs B(u, R_d), u in S, contains p; if A has
    a vertex it is an intersection point of two user circles, and if it has none all
    those discs coincide and the user point itself covers S. So user points plus
    pairwise intersection points attain every maximal covered set.

    Returns a SolveResult (objective = bound when proven optimal; ``bound`` is valid
    for the continuous problem in any case).

    On HiGHS (1.14: MIP presolve off, the adapter's guard against a presolve that returned
    suboptimal points as optimal) it took 0.06-0.11 CPU-s on Table 4.2 instances (m = 4, 6,
    8) and 1.1-1.2 CPU-s at density x 4 (1.8 with presolve on); CP-SAT had not proven the
    m = 4 seed 0 bound after 120 s (86 CPU-s), so HiGHS is the default.

    n_discs: number of discs (count >= 0; default the problem's m).
    backend: linear backend name ("highs", "cp-sat", "scip").
    time_limit: wall-clock limit of the bound's solve (s), None: none.
    """
    check_instance("problem", problem, CellProblem)
    time_limit = check_time_limit(time_limit)
    m = problem.n_cells if n_discs is None else check_int("n_discs", n_discs, min_value=0)
    t0 = time.perf_counter()
    t = problem.targets
    if m <= 0 or len(t) == 0:
        return SolveResult(
            Status.OPTIMAL,
            objective=0.0,
            bound=0.0,
            backend=backend,
            solve_time=0.0,
            message="continuous relaxation bound (trivial)",
        )
    pts = merge_points(np.concatenate([t, pair_intersections(t, problem.R_d)], axis=0))
    sets = _maximal_sets(coverage_lists(pts, t, problem.R_d))
    if len(sets) <= m:
        v = float(len(np.unique(np.concatenate(sets))))
        return SolveResult(
            Status.OPTIMAL,
            objective=v,
            bound=v,
            backend="enumeration",
            solve_time=time.perf_counter() - t0,
            message="continuous relaxation bound",
        )
    users = np.unique(np.concatenate(sets))
    tried = []
    res = None
    for be in dict.fromkeys((backend, "cp-sat")):  # the requested backend, then CP-SAT as the fallback
        left = None if time_limit is None else max(time_limit - (time.perf_counter() - t0), 0.01)
        res = _max_coverage_model(sets, users, m, be, left)
        tried.append(f"{be}: {res.status.name}" + (f" ({res.backend_status})" if res.backend_status else ""))
        if res.status in (Status.OPTIMAL, Status.FEASIBLE, Status.NO_SOLUTION) and res.bound is not None:
            break
    res = require_set(res, "the relaxation's result (the loop runs at least once)")
    desc = (
        f"continuous relaxation bound: max coverage by {m} discs over {len(sets)} maximal candidate sets, "
        f"no overlap/backhaul constraints"
    )
    if res.bound is None or res.status not in (Status.OPTIMAL, Status.FEASIBLE, Status.NO_SOLUTION):
        # never a silent stand-in (such as the user count): the caller sees None and why
        return dataclasses.replace(
            res,
            bound=None,
            objective=None,
            x=None,
            solve_time=time.perf_counter() - t0,
            message=f"{desc}: not computed, no backend returned a bound ({'; '.join(tried)})",
            info={**res.info, "tried": tried},
        )
    if len(tried) > 1:
        desc += f"; computed by {res.backend} after {'; '.join(tried[:-1])}"
    return dataclasses.replace(
        res,
        bound=math.floor(res.bound + 1e-6),
        x=None,
        solve_time=time.perf_counter() - t0,
        message=desc,
        info={**res.info, "tried": tried},
    )


def _max_coverage_model(
    sets: list[np.ndarray], users: np.ndarray, m: int, backend: str, time_limit: float | None
) -> SolveResult:
    """Maximum coverage of ``users`` by ``m`` of ``sets`` on ``backend``; never raises on a solver failure."""
    lin = get_backend(backend, kind="linear").new_model()
    x = [lin.bool_var(f"x{k}") for k in range(len(sets))]
    y = {int(u): lin.unit_var(f"y{u}") for u in users}
    cov: dict[int, list] = {}
    for k, st in enumerate(sets):
        for u in st:
            cov.setdefault(int(u), []).append(x[k])
    for u, xs in cov.items():
        lin.add_implies_any(y[u], xs)
    lin.add(lin.sum(x) <= m)
    lin.maximize(lin.sum(y.values()))
    return lin.solve(variables=x, time_limit=time_limit, workers=1)


def greedy_placement(problem: CellProblem, cand: Candidates | None = None) -> np.ndarray:
    """A feasible placement built greedily over the candidates (primal heuristic used
    for pruning): repeatedly add the site covering most new users among those that
    keep the placement feasible (no overlap, linked to a GBS or a placed site).

    Variants: with ``weights`` "most" is the most new weight; with a ``capacity`` C a site
    gains (and serves) the C heaviest users it covers that no placed site serves yet; no-fly
    zones hold no candidate.

    problem: the CellProblem (users, GBSs, m, radii in metres).
    cand: the Candidates of ``problem`` (default: ``candidate_sites(problem)``).
    """
    check_instance("problem", problem, CellProblem)
    if cand is None:
        cand = candidate_sites(problem)
    pts = cand.points
    if len(pts) == 0:
        return cand.plan(np.zeros(0, dtype=np.int64))
    radius = np.full(len(pts), problem.R_d) if cand.radius is None else cand.radius
    heights = np.zeros(len(pts)) if cand.heights is None else cand.heights
    n = len(problem.targets)
    member = np.zeros((len(pts), max(n, 1)), dtype=bool)
    for i, c in enumerate(cand.cover):
        member[i, c] = True
    weight = np.zeros(member.shape[1])
    weight[:n] = problem.target_weights
    covered = np.zeros(member.shape[1], dtype=bool)
    ok = np.ones(len(pts), dtype=bool)
    linked = cand.direct.copy()
    chosen: list[int] = []
    for _ in range(problem.n_cells):
        new = np.where(member & ~covered, weight, 0.0)
        if problem.capacity is not None and problem.capacity < new.shape[1]:
            new = -np.partition(-new, problem.capacity - 1, axis=1)[:, : problem.capacity]
        score = np.where(ok & linked, new.sum(1), -1.0)
        i = int(np.argmax(score))
        if score[i] <= 0:
            break
        chosen.append(i)
        served = np.flatnonzero(member[i] & ~covered)
        if problem.capacity is not None:
            served = served[np.argsort(-weight[served], kind="stable")[: problem.capacity]]
        covered[served] = True
        d = np.hypot(*(pts - pts[i]).T)
        ok &= d >= radius + radius[i] - TOL
        linked |= np.hypot(d, heights - heights[i]) <= problem.r2 + TOL
    return cand.plan(np.asarray(chosen, dtype=np.int64))


def _feasible_subset(problem: CellProblem, pos: np.ndarray) -> np.ndarray:
    """A feasible placement made of some of the sites ``pos`` ((k, 2) m): sites outside
    ``bounds`` or inside a GBS keep-out disc (4.7) are dropped first (no other site can
    repair them), then one of each overlapping pair (4.8) at a time, then the sites
    without a backhaul path. Every pass removes at least one site, so this ends."""
    pos = np.asarray(pos, dtype=float).reshape(-1, 2)
    if len(pos):
        dg = pairwise_distances(pos, problem.gbs)
        ok = np.all(dg >= problem.R_g + problem.R_d - TOL, axis=1)
        if problem.bounds is not None:
            xmin, xmax, ymin, ymax = problem.bounds
            ok &= (pos[:, 0] >= xmin - TOL) & (pos[:, 0] <= xmax + TOL)
            ok &= (pos[:, 1] >= ymin - TOL) & (pos[:, 1] <= ymax + TOL)
        ok[[i for i, _ in in_no_fly(problem, pos)]] = False
        pos = pos[ok]
    while len(pos):
        ev = evaluate(problem, pos)
        if ev.feasible:
            return pos
        d = pairwise_distances(pos, pos)
        np.fill_diagonal(d, np.inf)
        bad = np.flatnonzero(np.any(d < 2 * problem.R_d - TOL, axis=1))
        if len(bad):
            pos = np.delete(pos, bad[-1], axis=0)
        elif not ev.connected.all():
            pos = pos[ev.connected]
        else:  # more sites than n_cells: drop the last; the next pass re-checks connectivity
            pos = pos[:-1]
    return pos


@dataclass
class Prepared:
    """Candidates, incumbent and bounds of one call, with its clock (``prepare``)."""

    problem: CellProblem
    """The instance."""
    cand: Candidates
    """Candidate sites (the warm start's sites included)."""
    inc: np.ndarray
    """(k, 2) the incumbent placement (m): greedy or the warm start's feasible part."""
    inc_val: int
    """Users the incumbent covers."""
    warm_used: bool
    """True when the warm start is the incumbent."""
    warm: np.ndarray | None
    """The warm start's feasible part ((k, 2) m), None without a warm start."""
    warm_val: int
    """Users the warm start's feasible part covers (0 without a warm start)."""
    greedy: np.ndarray
    """(k, 2) the greedy placement (m)."""
    greedy_val: int
    """Users it covers."""
    cont_bound: float | None
    """Continuous-problem bound (max coverage by m discs), None when not computed."""
    ub: float
    """Bound used for pruning: ``cont_bound`` or, when unknown, the active-user count."""
    relax_time: float
    """Seconds the continuous bound took."""
    info: dict[str, Any]
    """``info`` entries shared by every result (warm start, continuous bound)."""
    t0: float
    """``time.perf_counter()`` at the start of the call."""
    time_limit: float | None
    """Seconds for the whole call, None: none."""
    polish_stopped: bool = False
    """True when the time limit passed before the polish (``_exact._polish``) could start a
    heuristic, so a longer limit may still raise the incumbent."""
    _b_prev: float | None = None
    """:meth:`bound_m_minus_1` once computed."""
    _relax_prev: SolveResult | None = None
    """:meth:`relaxation_m_minus_1` once computed."""
    report: Callable[..., Any] | None = None
    """Called as ``report(positions, bound=...)`` with each better placement the engines find
    (``solve_exact(report=...)``); the bound is ``ub``, valid for the continuous problem."""
    reported_val: int = -1
    """Users covered by the last placement reported."""

    def offer_report(self, positions: np.ndarray) -> None:
        """Report ``positions`` when they are feasible and cover more users than the last report
        (nothing else changes: the engines keep their own incumbents)."""
        if self.report is None:
            return
        ev = evaluate(self.problem, positions)
        if ev.feasible and int(ev.covered) > self.reported_val:
            self.reported_val = int(ev.covered)
            self.report(np.array(positions, dtype=float).reshape(-1, 2), bound=float(self.ub))

    def bound_m_minus_1(self) -> float:
        """An upper bound on the users any m - 1 drone-cells cover: the continuous bound of
        m - 1 discs (``coverage_upper_bound``), computed on first use; ``ub`` (a bound for m,
        so also for m - 1) when less time is left than the first relaxation took or no
        backend returned a bound."""
        if self._b_prev is None:
            m = self.problem.n_cells
            time_left = self.left()
            if m <= 1:
                self._b_prev = 0.0
            elif time_left is not None and time_left < self.relax_time:
                self._b_prev = self.ub
            else:
                relax = self.relaxation_m_minus_1()
                self._b_prev = self.ub if relax.bound is None else min(float(relax.bound), self.ub)
        return self._b_prev

    def relaxation_m_minus_1(self) -> SolveResult:
        """The continuous relaxation of m - 1 discs (``coverage_upper_bound``, within the time
        left), computed once and shared by the engines' B_{m-1} bounds."""
        if self._relax_prev is None:
            self._relax_prev = coverage_upper_bound(
                self.problem, self.problem.n_cells - 1, time_limit=self.left()
            )
        return self._relax_prev

    def prune_candidates(self) -> int:
        """Drop the candidate sites that no placement better than the incumbent can hold;
        returns how many were dropped (also added up in ``info["pruned_sites"]``).

        Exact: a placement holding site c covers at most |S(c)| users through c and at most
        B_{m-1} (:meth:`bound_m_minus_1`) through its other m - 1 sites or fewer, so when
        |S(c)| + B_{m-1} <= the incumbent value no placement holding c, as a covering site
        or as a relay, beats the incumbent. The incumbent's and the warm start's sites are
        kept, so the incumbent stays a placement of the reduced set. Done before the
        search builds its site relations (packed bit rows, n^2 / 8 bytes each): at Table 4.2
        density x 4 most of the 64k sites lie in the background, where a disc holds few
        users, and go here."""
        cand = self.cand
        n = len(cand.points)
        if n == 0:
            return 0
        w = np.fromiter((len(c) for c in cand.cover), dtype=np.int64, count=n)
        keep = w + self.bound_m_minus_1() > self.inc_val + 1e-9
        for sites in (self.inc, self.warm):
            if sites is not None and len(sites):
                keep |= _near_any(cand.points, np.asarray(sites, dtype=float).reshape(-1, 2))
        dropped = int(n - keep.sum())
        if dropped:
            idx = np.flatnonzero(keep)
            self.cand = cand.subset(idx)
        self.info["pruned_sites"] = int(self.info.get("pruned_sites", 0)) + dropped
        self.info["bound_m_minus_1"] = self._b_prev
        return dropped

    def left(self) -> float | None:
        """Seconds left of the time limit (at least 0.01), None without a limit."""
        if self.time_limit is None:
            return None
        return max(self.time_limit - (time.perf_counter() - self.t0), 0.01)

    def expired(self) -> bool:
        """True once the time limit has passed."""
        return self.time_limit is not None and time.perf_counter() - self.t0 >= self.time_limit

    def bound_text(self, bound: float, engine: str) -> str:
        """The message part that says which bound is which (``bound`` from ``engine``)."""
        if self.cont_bound is not None:
            cont = (
                f"continuous-problem upper bound {self.cont_bound:g} (max coverage by m discs without "
                "overlap/backhaul)"
            )
        else:
            cont = f"continuous-problem bound not available ({self.info['relaxation_message']})"
        return (
            f"bound {bound:g} valid for the candidate problem (the candidate sites described in the "
            f"docstring), from {engine}; {cont}"
        )

    def result(
        self,
        status: Status,
        *,
        objective: float,
        bound: float | None,
        x: np.ndarray,
        backend: str,
        message: str,
        engine: str,
        iterations: int | None = None,
        backend_status: str = "",
        rounds: int = 0,
        model_stats: dict[str, Any] | None = None,
    ) -> SolveResult:
        """The SolveResult of the call (every exit builds it here)."""
        glob = self.cont_bound is not None and objective >= self.cont_bound
        if glob and "globally optimal" not in message:
            message += "; attained: globally optimal"
        return SolveResult(
            status,
            objective=float(objective),
            bound=None if bound is None else float(bound),
            x=x,
            backend=backend,
            backend_status=backend_status,
            message=message,
            solve_time=time.perf_counter() - self.t0,
            iterations=iterations,
            warm_started=self.warm_used,
            info={
                **self.info,
                "engine": engine,
                "global_optimal": glob,
                "rounds": rounds,
                "model_stats": {} if model_stats is None else model_stats,
            },
        )


def _near_any(points: np.ndarray, sites: np.ndarray) -> np.ndarray:
    """(len(points),) bool: the points within 1e-3 m of one of ``sites`` ((k, 2) m, k small)."""
    near = np.zeros(len(points), dtype=bool)
    for s in sites:
        near |= np.hypot(*(points - s).T) <= 1e-3
    return near


def dropped_sites_text(given: int, kept: int) -> str:
    """The start of ``info["warm_start"]["reason"]``: how many of the ``given`` sites of a warm
    start were dropped to keep a feasible part of ``kept`` sites ("" when none were)."""
    dropped = given - kept
    if not dropped:
        return ""
    return (
        f"{dropped} of {given} given sites dropped to make it feasible (outside bounds, "
        "in a GBS cell, overlapping, without backhaul or beyond n_cells); "
    )


def _warm_start_info(
    warm: np.ndarray, part: np.ndarray, value: int, greedy_value: int, used: bool
) -> dict[str, Any]:
    """``info["warm_start"]``: what happened to a given plan ``warm`` (feasible part ``part``)."""
    why = dropped_sites_text(len(warm), len(part))
    if used:
        why += f"its feasible part ({value} users) is the incumbent and the hint"
    else:
        why += (
            f"not used as incumbent: its feasible part covers {value} users, "
            f"the built-in greedy start {greedy_value}; its sites stay in the "
            "candidate set"
        )
    return {"given": len(warm), "used": used, "value": value, "greedy_value": greedy_value, "reason": why}


def prepare(problem: CellProblem, *, warm_start=None, time_limit: float | None = None) -> Prepared:
    """Candidates, greedy incumbent, the warm start's fate and the continuous bound.

    problem: the CellProblem (users, GBSs, m, radii in metres).
    warm_start: drone-cell positions ((k, 2) m) or None; added to the candidate set, its
        feasible part becomes the incumbent when it covers at least as many users as greedy.
    time_limit: seconds for the whole call (the clock starts here), None: none.
    """
    check_instance("problem", problem, CellProblem)
    time_limit = check_time_limit(time_limit)
    t0 = time.perf_counter()
    warm = None if warm_start is None else as_positions(problem, warm_start, "warm_start")
    info: dict[str, Any] = {}
    # candidates and the greedy incumbent first (fast), so a short time limit still returns a plan
    cand = candidate_sites(problem, extra=warm)
    inc = greedy = greedy_placement(problem, cand)
    inc_val = greedy_val = int(evaluate(problem, inc).covered)
    warm_used = False
    part = None
    wv = 0
    if warm is not None:  # the warm start (its feasible part) replaces greedy when at least as good
        part = _feasible_subset(problem, warm)
        wv = int(evaluate(problem, part).covered)
        warm_used = bool(len(part)) and wv >= inc_val
        info["warm_start"] = _warm_start_info(warm, part, wv, inc_val, warm_used)
        if warm_used:
            inc, inc_val = part, wv
    left = None if time_limit is None else max(time_limit - (time.perf_counter() - t0), 0.01)
    relax = coverage_upper_bound(problem, problem.n_cells, time_limit=left)
    cont_bound = None if relax.bound is None else float(relax.bound)
    info.update(
        {
            "continuous_bound": cont_bound,
            "relaxation_time": relax.solve_time,
            "relaxation_message": relax.message,
        }
    )
    return Prepared(
        problem=problem,
        cand=cand,
        inc=inc,
        inc_val=inc_val,
        warm_used=warm_used,
        warm=part,
        warm_val=wv,
        greedy=greedy,
        greedy_val=greedy_val,
        cont_bound=cont_bound,
        # internal bound for pruning and stopping: the relaxation's, or the trivial user count
        # when it could not be computed (never reported as the continuous bound)
        ub=float(len(problem.targets)) if cont_bound is None else cont_bound,
        relax_time=relax.solve_time,
        info=info,
        t0=t0,
        time_limit=time_limit,
    )
