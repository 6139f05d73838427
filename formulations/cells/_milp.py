"""The candidate-site MILP for drone-cell placement, with exact reductions and lazy cuts.

Model (over a candidate set, see ``_core.candidate_sites``)::

    max  sum_j y_j
    s.t. y_j <= sum_{c covers j} x_c          (coverage, eq. 4.9)
         sum_c x_c <= m
         x_c + x_d <= 1   if |c - d| < 2 R_d  (4.8, written as cliques, see below)
         connectivity cuts (below)             (backhaul with relays, 4.7-4.8)
         x, y binary

Every candidate already satisfies |c - G_h| >= R_g + R_d (4.7) and the bounds, so
those constraints are enforced by the candidate filter.

Size engineering (thesis scale has ~5 000 candidates, ~10^6 pairs closer than 2 R_d
and ~3*10^6 pairs within r2, far too many to write out):

1. **Incumbent pruning (exact).** Any solution containing site c covers at most
   |S(c)| + B_{m-1} users, where B_{m-1} is the optimum of the *unconstrained*
   maximum coverage by m-1 discs (a relaxation: it drops non-overlap and backhaul,
   and by disjointness-free union bound |S(X)| <= |S(c)| + |S(X - c)|). If that is
   <= the value z of a known feasible solution, no solution containing c is better
   than z, so c is dropped unless it belongs to that incumbent (which is kept).
   The optimum of the reduced model is therefore the optimum of the full
   candidate model (either z, attained by the kept incumbent, or a better value
   reached only by unpruned sites).
2. **Non-overlap as cliques.** Points in one half-open square of side
   (2 R_d - TOL) / sqrt(2) are pairwise closer than 2 R_d - TOL (they overlap), so each square gives an
   at-most-one constraint; four grids shifted by half a square cover most
   conflicting pairs. Conflicting pairs that share no square are written as
   pairs when few, and otherwise added lazily (a clique around the midpoint of a
   violated pair: all sites within (d + 2 R_d - TOL)/4 of it are pairwise < 2 R_d - TOL apart).
3. **Connectivity by lazily added cuts (exact).** A site c that is not within r1
   of a GBS needs a chosen neighbour within r2: ``x_c <= sum_{d in N(c)} x_d``
   (written up front for every non-direct site). That alone admits chosen groups
   that only link to each other; for such a component C found in a solution we add,
   for W = the non-direct sites within distance delta of C (delta in {0, R_d}):
   ``x_e <= sum_{d in N(W) - W} x_d`` for every e in W (through one auxiliary
   binary): a chosen site in W reaches a GBS only through a chosen site outside W
   adjacent to W. Each cut is valid for every connected placement, and the loop
   stops only when the solution is connected, so the final optimum is exact.
   Every model in the loop is a relaxation of the candidate problem, so its bound
   is a valid upper bound of the candidate problem at any time.
"""

from __future__ import annotations

import dataclasses
import math
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from ortools.sat.python import cp_model
from scipy.spatial import cKDTree

from droneplan.formulations.cells._core import (
    TOL,
    Candidates,
    as_positions,
    candidate_sites,
    coverage_lists,
    evaluate,
    merge_points,
    pair_intersections,
)
from droneplan.scenarios.cells import CellProblem
from droneplan.solvers.cpsat import solve_cpsat
from droneplan.solvers.mip import new_mip, solve_mip
from droneplan.solvers.result import SolveResult, Status
from droneplan.solvers.validation import check_instance, check_time_limit

BACKENDS = ("cp-sat", "highs", "scip")
"""Backend names ``solve_milp(backend=...)`` accepts (CP-SAT, and HiGHS/SCIP through OR-Tools)."""


# --------------------------------------------------------------------------- relaxation bound
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


def coverage_upper_bound(problem: CellProblem, n_discs: int | None = None, *, backend: str = "highs",
                         time_limit: float | None = None) -> SolveResult:
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

    backend: linear backend name ("highs", "cp-sat", "scip").
    time_limit: wall-clock limit of the bound's solve (s), None: none.
    """
    check_instance("problem", problem, CellProblem)
    time_limit = check_time_limit(time_limit)
    m = problem.n_cells if n_discs is None else int(n_discs)
    t0 = time.perf_counter()
    t = problem.targets
    if m <= 0 or len(t) == 0:
        return SolveResult(Status.OPTIMAL, objective=0.0, bound=0.0, backend=backend, solve_time=0.0,
                           message="continuous relaxation bound (trivial)")
    pts = merge_points(np.concatenate([t, pair_intersections(t, problem.R_d)], axis=0))
    sets = _maximal_sets(coverage_lists(pts, t, problem.R_d))
    if len(sets) <= m:
        v = float(len(np.unique(np.concatenate(sets))))
        return SolveResult(Status.OPTIMAL, objective=v, bound=v, backend="enumeration",
                           solve_time=time.perf_counter() - t0, message="continuous relaxation bound")
    users = np.unique(np.concatenate(sets))
    tried = []
    res = None
    for be in dict.fromkeys((backend, "cp-sat")):  # the requested backend, then CP-SAT as the fallback
        left = None if time_limit is None else max(time_limit - (time.perf_counter() - t0), 0.01)
        res = _max_coverage_model(sets, users, m, be, left)
        tried.append(f"{be}: {res.status.name}" + (f" ({res.backend_status})" if res.backend_status else ""))
        if res.status in (Status.OPTIMAL, Status.FEASIBLE, Status.NO_SOLUTION) and res.bound is not None:
            break
    assert res is not None
    desc = (f"continuous relaxation bound: max coverage by {m} discs over {len(sets)} maximal candidate sets, "
            f"no overlap/backhaul constraints")
    if res.bound is None or res.status not in (Status.OPTIMAL, Status.FEASIBLE, Status.NO_SOLUTION):
        # never a silent stand-in (such as the user count): the caller sees None and why
        return dataclasses.replace(res, bound=None, objective=None, x=None, solve_time=time.perf_counter() - t0,
                                   message=f"{desc}: not computed, no backend returned a bound ({'; '.join(tried)})",
                                   info={**res.info, "tried": tried})
    if len(tried) > 1:
        desc += f"; computed by {res.backend} after {'; '.join(tried[:-1])}"
    return dataclasses.replace(res, bound=math.floor(res.bound + 1e-6), x=None, solve_time=time.perf_counter() - t0,
                               message=desc, info={**res.info, "tried": tried})


def _max_coverage_model(sets: list[np.ndarray], users: np.ndarray, m: int, backend: str,
                        time_limit: float | None) -> SolveResult:
    """Maximum coverage of ``users`` by ``m`` of ``sets`` on ``backend``; never raises on a solver failure."""
    if backend == "cp-sat":
        mdl = cp_model.CpModel()
        x = [mdl.new_bool_var(f"x{k}") for k in range(len(sets))]
        y = {int(u): mdl.new_bool_var(f"y{u}") for u in users}
        cov: dict[int, list] = {}
        for k, s in enumerate(sets):
            for u in s:
                cov.setdefault(int(u), []).append(x[k])
        for u, xs in cov.items():
            mdl.add(y[u] <= sum(xs))
        mdl.add(sum(x) <= m)
        mdl.maximize(sum(y.values()))
        return solve_cpsat(mdl, variables=x, time_limit=time_limit, workers=2)
    s = new_mip(backend)
    x = [s.BoolVar(f"x{k}") for k in range(len(sets))]
    y = {int(u): s.NumVar(0, 1, f"y{u}") for u in users}
    cov = {}
    for k, st in enumerate(sets):
        for u in st:
            cov.setdefault(int(u), []).append(x[k])
    for u, xs in cov.items():
        s.Add(y[u] <= sum(xs))
    s.Add(sum(x) <= m)
    s.Maximize(sum(y.values()))
    return solve_mip(s, variables=x, time_limit=time_limit, threads=1)


# --------------------------------------------------------------------------- greedy incumbent
def greedy_placement(problem: CellProblem, cand: Candidates) -> np.ndarray:
    """A feasible placement built greedily over the candidates (primal heuristic used
    for pruning): repeatedly add the site covering most new users among those that
    keep the placement feasible (no overlap, linked to a GBS or a placed site).

    problem: the CellProblem (users, GBSs, m, radii in metres).
    cand: the Candidates of ``problem`` (candidate_sites).
    """
    check_instance("problem", problem, CellProblem)
    pts = cand.points
    if len(pts) == 0:
        return np.zeros((0, 2))
    n = len(problem.targets)
    member = np.zeros((len(pts), max(n, 1)), dtype=bool)
    for i, c in enumerate(cand.cover):
        member[i, c] = True
    covered = np.zeros(member.shape[1], dtype=bool)
    ok = np.ones(len(pts), dtype=bool)
    linked = cand.direct.copy()
    chosen: list[int] = []
    for _ in range(problem.n_cells):
        gain = (member & ~covered).sum(1)
        score = np.where(ok & linked, gain, -1)
        i = int(np.argmax(score))
        if score[i] <= 0:
            break
        chosen.append(i)
        covered |= member[i]
        d = np.hypot(*(pts - pts[i]).T)
        ok &= d >= 2 * problem.R_d - TOL
        linked |= d <= problem.r2 + TOL
    return pts[chosen]


# --------------------------------------------------------------------------- model
@dataclass
class CellModel:
    """A built candidate model (the output of :func:`build_milp`)."""

    problem: CellProblem
    """The instance."""
    backend: str
    """"cp-sat", "highs" or "scip"."""
    points: np.ndarray
    """(c, 2) candidate sites kept in the model (m)."""
    cover: list
    """cover[i]: active-user indices covered by site i."""
    direct: np.ndarray
    """(c,) bool, site within r1 of a GBS."""
    model: Any
    """cp_model.CpModel or pywraplp.Solver."""
    x: list
    """Site variables, one per row of ``points``."""
    y: dict
    """User coverage variables keyed by active-user index."""
    stats: dict = field(default_factory=dict)
    """Sizes: candidates, pruned, cliques, pairs, cuts."""


class _Lin:
    """Tiny builder facade over CP-SAT and pywraplp (same constraints in both)."""

    def __init__(self, backend: str):
        self.backend = backend
        self.m = cp_model.CpModel() if backend == "cp-sat" else new_mip(backend)

    def bool(self, name: str):
        return self.m.new_bool_var(name) if self.backend == "cp-sat" else self.m.BoolVar(name)

    def cont01(self, name: str):
        return self.m.new_bool_var(name) if self.backend == "cp-sat" else self.m.NumVar(0.0, 1.0, name)

    def le(self, lhs, rhs) -> None:
        if self.backend == "cp-sat":
            self.m.add(lhs <= rhs)
        else:
            self.m.Add(lhs <= rhs)

    def at_most_one(self, xs) -> None:
        if len(xs) < 2:
            return
        if self.backend == "cp-sat":
            self.m.add_at_most_one(xs)
        else:
            self.m.Add(sum(xs) <= 1)

    def maximize(self, expr) -> None:
        if self.backend == "cp-sat":
            self.m.maximize(expr)
        else:
            self.m.Maximize(expr)


def _grid_cliques(points: np.ndarray, R_d: float) -> list[np.ndarray]:
    side = (2 * R_d - TOL) / math.sqrt(2)  # same half-open square => distance < 2 R_d - TOL
    out = []
    for sx, sy in ((0, 0), (0.5, 0), (0, 0.5), (0.5, 0.5)):
        key = np.floor(points / side - np.array([sx, sy])).astype(np.int64)
        _, inv = np.unique(key, axis=0, return_inverse=True)
        inv = inv.ravel()
        order = np.argsort(inv, kind="stable")
        bounds = np.flatnonzero(np.diff(inv[order])) + 1
        for grp in np.split(order, bounds):
            if len(grp) > 1:
                out.append(np.sort(grp))
    return out


def _uncovered_pairs(points: np.ndarray, R_d: float, cliques: list[np.ndarray]) -> np.ndarray:
    if len(points) < 2:
        return np.zeros((0, 2), dtype=np.int64)
    pairs = cKDTree(points).query_pairs(2 * R_d - 2 * TOL, output_type="ndarray")
    if len(pairs) == 0:
        return pairs.reshape(0, 2)
    d = np.hypot(*(points[pairs[:, 0]] - points[pairs[:, 1]]).T)
    pairs = pairs[d < 2 * R_d - TOL]
    side = (2 * R_d - TOL) / math.sqrt(2)  # same half-open square => distance < 2 R_d - TOL
    covered = np.zeros(len(pairs), dtype=bool)
    for sx, sy in ((0, 0), (0.5, 0), (0, 0.5), (0.5, 0.5)):
        key = np.floor(points / side - np.array([sx, sy])).astype(np.int64)
        covered |= np.all(key[pairs[:, 0]] == key[pairs[:, 1]], axis=1)
    return pairs[~covered]


def reduce_candidates(problem: CellProblem, cand: Candidates, incumbent_value: float, incumbent_sites: np.ndarray,
                      bound_m_minus_1: float) -> np.ndarray:
    """Indices of candidates kept by the exact incumbent pruning (see module docstring, item 1)."""
    size = np.array([len(c) for c in cand.cover])
    keep = size + bound_m_minus_1 > incumbent_value + 1e-9
    if len(incumbent_sites):
        d = np.hypot(cand.points[:, None, 0] - incumbent_sites[None, :, 0],
                     cand.points[:, None, 1] - incumbent_sites[None, :, 1])
        keep |= np.any(d <= 1e-3, axis=1)
    return np.flatnonzero(keep)


def build_milp(problem: CellProblem, *, backend: str = "cp-sat", candidates: Candidates | None = None,
               keep: np.ndarray | None = None, cuts: list | None = None,
               pair_limit: int = 200_000) -> CellModel:
    """Build the candidate model (module docstring) without solving it.

    backend: "cp-sat" (default), "highs" or "scip".
    candidates: a candidate set (default :func:`candidate_sites(problem)`).
    keep: indices of candidates to keep (default all), e.g. from :func:`reduce_candidates`.
    cuts: lazily found cuts to include: ("clique", idx) or ("conn", W_idx, boundary_idx),
        indices into the full candidate set; restricted to the kept candidates (dropped
        sites are fixed at 0, so a restricted cut stays valid).
    pair_limit: write conflicting pairs not covered by the grid cliques explicitly when
        there are at most this many; otherwise they are left to lazy clique cuts.
    """
    check_instance("problem", problem, CellProblem)
    if backend not in BACKENDS:
        raise ValueError(f"backend must be one of {BACKENDS}, got {backend!r}")
    cand = candidate_sites(problem) if candidates is None else candidates
    idx = np.arange(len(cand.points)) if keep is None else np.asarray(keep, dtype=np.int64)
    pts = cand.points[idx]
    cover = [cand.cover[i] for i in idx]
    direct = cand.direct[idx]
    lin = _Lin(backend)
    x = [lin.bool(f"x{i}") for i in range(len(pts))]
    by_user: dict[int, list] = {}
    for i, c in enumerate(cover):
        for u in c:
            by_user.setdefault(int(u), []).append(x[i])
    y = {u: lin.cont01(f"y{u}") for u in sorted(by_user)}
    for u, xs in by_user.items():
        lin.le(y[u], sum(xs))
    if x:
        lin.le(sum(x), problem.n_cells)
    cliques = _grid_cliques(pts, problem.R_d) if len(pts) else []
    for q in cliques:
        lin.at_most_one([x[i] for i in q])
    extra = _uncovered_pairs(pts, problem.R_d, cliques)
    n_pairs = 0
    if len(extra) <= pair_limit:
        for a, b in extra:
            lin.at_most_one([x[a], x[b]])
        n_pairs = len(extra)
    # every non-direct site needs a chosen, non-overlapping neighbour within r2
    n_nbr = 0
    if len(pts):
        tree = cKDTree(pts)
        for i in np.flatnonzero(~direct):
            nb = [j for j in tree.query_ball_point(pts[i], problem.r2 + TOL)
                  if math.dist(pts[i], pts[j]) >= 2 * problem.R_d - TOL]  # a linked site may not overlap
            lin.le(x[i], sum(x[j] for j in nb) if nb else 0)
            n_nbr += 1
    n_cuts = 0
    local = np.full(len(cand.points), -1, dtype=np.int64)
    local[idx] = np.arange(len(idx))
    for cut in cuts or ():
        if cut[0] == "clique":
            q = local[cut[1]]
            lin.at_most_one([x[i] for i in q[q >= 0]])
        else:
            w, bnd = local[cut[1]], local[cut[2]]
            w, bnd = w[w >= 0], bnd[bnd >= 0]
            if len(w) == 0:
                continue
            b = lin.bool(f"cut{n_cuts}")
            lin.le(b, sum(x[j] for j in bnd) if len(bnd) else 0)
            for e in w:
                lin.le(x[e], b)
        n_cuts += 1
    if y:
        lin.maximize(sum(y.values()))
    stats = {"candidates": len(cand.points), "kept": len(pts), "users": len(y), "grid_cliques": len(cliques),
             "extra_pairs": n_pairs, "pairs_deferred": len(extra) if len(extra) > pair_limit else 0,
             "neighbour_rows": n_nbr, "lazy_cuts": n_cuts}
    return CellModel(problem=problem, backend=backend, points=pts, cover=cover, direct=direct, model=lin.m,
                     x=x, y=y, stats=stats)


# --------------------------------------------------------------------------- solve
def _components_without_gbs(problem: CellProblem, pos: np.ndarray) -> list[np.ndarray]:
    """Connected groups (by r2 links) of placed sites none of which is within r1 of a GBS."""
    k = len(pos)
    d = np.hypot(pos[:, None, 0] - pos[None, :, 0], pos[:, None, 1] - pos[None, :, 1])
    adj = d <= problem.r2 + TOL
    seen = np.zeros(k, dtype=bool)
    dg = np.hypot(pos[:, None, 0] - problem.gbs[None, :, 0], pos[:, None, 1] - problem.gbs[None, :, 1])
    direct = np.any(dg <= problem.r1 + TOL, axis=1)
    out = []
    for s in range(k):
        if seen[s]:
            continue
        comp = {s}
        stack = [s]
        while stack:
            i = stack.pop()
            for j in np.flatnonzero(adj[i]):
                if j not in comp:
                    comp.add(int(j))
                    stack.append(int(j))
        seen[list(comp)] = True
        c = np.array(sorted(comp))
        if not direct[c].any():
            out.append(c)
    return out


def _feasible_subset(problem: CellProblem, pos: np.ndarray) -> np.ndarray:
    """A feasible placement made of some of the sites ``pos`` ((k, 2) m): sites outside
    ``bounds`` or inside a GBS keep-out disc (4.7) are dropped first (no other site can
    repair them), then one of each overlapping pair (4.8) at a time, then the sites
    without a backhaul path. Every pass removes at least one site, so this ends."""
    pos = np.asarray(pos, dtype=float).reshape(-1, 2)
    if len(pos):
        dg = np.hypot(pos[:, None, 0] - problem.gbs[None, :, 0], pos[:, None, 1] - problem.gbs[None, :, 1])
        ok = np.all(dg >= problem.R_g + problem.R_d - TOL, axis=1)
        if problem.bounds is not None:
            xmin, xmax, ymin, ymax = problem.bounds
            ok &= (pos[:, 0] >= xmin - TOL) & (pos[:, 0] <= xmax + TOL)
            ok &= (pos[:, 1] >= ymin - TOL) & (pos[:, 1] <= ymax + TOL)
        pos = pos[ok]
    while len(pos):
        ev = evaluate(problem, pos)
        if ev.feasible:
            return pos
        d = np.hypot(pos[:, None, 0] - pos[None, :, 0], pos[:, None, 1] - pos[None, :, 1])
        np.fill_diagonal(d, np.inf)
        bad = np.flatnonzero(np.any(d < 2 * problem.R_d - TOL, axis=1))
        if len(bad):
            pos = np.delete(pos, bad[-1], axis=0)
        elif not ev.connected.all():
            pos = pos[ev.connected]
        else:  # more sites than n_cells: drop the last; the next pass re-checks connectivity
            pos = pos[:-1]
    return pos


# With 1-2 workers CP-SAT's default portfolio runs no LP-based subsolver, so its bound
# on this covering model stalls far above the optimum (m=4 thesis instance: bound 222 vs
# optimum 61 after 120 s). An LP-relaxation worker plus the core-based worker close it.
CPSAT_PARAMETERS = {"subsolvers": ["max_lp", "core"]}


def solve_milp(problem: CellProblem, *, backend: str = "cp-sat", time_limit: float | None = None,
               warm_start=None, workers: int = 2, max_rounds: int = 200) -> SolveResult:
    """Solve the candidate-site model with exact backhaul connectivity (lazy cuts).

    backend: "cp-sat" (default), "highs" or "scip".
    time_limit: wall-clock limit (s) for the whole call, candidate generation and model
        building included; when it is reached the best plan and bound found so far are
        returned (FEASIBLE). None: no limit.
    warm_start: drone-cell positions ((k, 2) m, e.g. the GA's). They are added to the
        candidate set (so the result is never worse than a feasible warm start); their
        feasible part (sites outside bounds, in a GBS cell, overlapping or without
        backhaul dropped) becomes the incumbent and the backend's hint when it covers at
        least as many users as the built-in greedy start. ``info["warm_start"]`` says
        whether it was used and why not (``used``, ``value``, ``greedy_value``, ``reason``).
    workers: CP-SAT workers / MIP threads.

    Returns a SolveResult: ``x`` positions (k, 2) with k <= m, ``objective`` covered
    users, ``bound`` an upper bound valid for the *candidate* problem (all user
    points, pairwise R_d-circle intersections, R_d circles met with the r1 and
    R_g + R_d circles and the area edges, and the warm start); ``info`` holds
    ``continuous_bound`` (valid for the continuous problem: max coverage by m discs
    without overlap/backhaul constraints; None, with the reason in ``message``, when no
    backend could compute it), ``global_optimal`` (objective equals the
    continuous bound), ``rounds``, ``model_stats``. ``message`` says which bound is which.

    max_rounds: maximum lazy-cut rounds (count); reaching it ends the solve without a proof of optimality.
    """
    if not isinstance(problem, CellProblem):
        raise TypeError(f"problem must be a CellProblem, got {type(problem).__name__}")
    if backend not in BACKENDS:
        raise ValueError(f"backend must be one of {BACKENDS}, got {backend!r}")
    time_limit = check_time_limit(time_limit)
    t0 = time.perf_counter()
    warm = None if warm_start is None else as_positions(problem, warm_start)

    def left() -> float | None:
        return None if time_limit is None else max(time_limit - (time.perf_counter() - t0), 0.01)

    def expired() -> bool:
        return time_limit is not None and time.perf_counter() - t0 >= time_limit

    n_active = float(len(problem.targets))
    info: dict[str, Any] = {}
    # candidates and the greedy incumbent first (fast), so a short time limit still returns a plan
    cand = candidate_sites(problem, extra=warm)
    inc = greedy_placement(problem, cand)
    inc_val = evaluate(problem, inc).covered
    warm_used = False
    if warm is not None:  # the warm start (its feasible part) replaces greedy when at least as good
        w = _feasible_subset(problem, warm)
        wv = evaluate(problem, w).covered
        dropped = len(warm) - len(w)
        why = (f"{dropped} of {len(warm)} given sites dropped to make it feasible (outside bounds, in a GBS cell, "
               f"overlapping, without backhaul or beyond n_cells); " if dropped else "")
        if len(w) and wv >= inc_val:
            greedy_val = int(inc_val)
            inc, inc_val, warm_used = w, wv, True
            info["warm_start"] = {"given": len(warm), "used": True, "value": wv, "greedy_value": greedy_val,
                                  "reason": why + f"its feasible part ({wv} users) is the incumbent and the hint"}
        else:
            info["warm_start"] = {"given": len(warm), "used": False, "value": wv, "greedy_value": int(inc_val),
                                  "reason": why + (f"not used as incumbent: its feasible part covers {wv} users, "
                                                   f"the built-in greedy start {inc_val}; its sites stay in the "
                                                   "candidate set")}
    relax = coverage_upper_bound(problem, problem.n_cells, time_limit=left())
    cont_bound = None if relax.bound is None else float(relax.bound)
    # internal bound for pruning and stopping: the relaxation's, or the trivial user count
    # when it could not be computed (never reported as the continuous bound)
    ub = n_active if cont_bound is None else cont_bound
    info.update({"continuous_bound": cont_bound, "relaxation_time": relax.solve_time,
                 "relaxation_message": relax.message})
    bound_note = ("" if cont_bound is not None else
                  f"; continuous-problem bound not available ({relax.message})")
    if len(cand.points) == 0 or cont_bound == 0:
        return SolveResult(Status.OPTIMAL, objective=0.0, bound=0.0, x=np.zeros((0, 2)), backend=backend,
                           solve_time=time.perf_counter() - t0, warm_started=False,
                           message="no user can be covered by a feasible drone-cell: optimum 0 (no sites)",
                           info={**info, "global_optimal": True, "rounds": 0,
                                 "model_stats": {"candidates": len(cand.points)}})

    def early(status: Status, bound: float | None, msg: str) -> SolveResult:
        return SolveResult(status, objective=float(inc_val), bound=bound, x=inc, backend=backend,
                           solve_time=time.perf_counter() - t0, warm_started=warm_used, message=msg + bound_note,
                           info={**info, "global_optimal": cont_bound is not None and inc_val >= cont_bound,
                                 "rounds": 0, "model_stats": {}})

    if inc_val >= ub:
        return early(Status.OPTIMAL, ub, "bound valid for the continuous problem (max coverage by m discs without "
                                         "overlap/backhaul) and attained: globally optimal")
    if expired():
        return early(Status.FEASIBLE, cont_bound, "time limit reached before the model was built; the plan is the "
                                                  "greedy or warm start")
    relax_prev = coverage_upper_bound(problem, problem.n_cells - 1, time_limit=left())
    b_prev = n_active if relax_prev.bound is None else float(relax_prev.bound)
    tree = cKDTree(cand.points)
    cuts: list = []
    state = {"inc": inc, "inc_val": inc_val, "rounds": 0, "raw": "", "stats": {}}

    def cut_loop(keep: np.ndarray) -> tuple[str, float]:
        """Solve the model restricted to ``keep`` exactly with lazy cuts.
        Returns ("optimal", value) or ("stopped", bound of the restricted problem)."""
        rbound = math.inf
        while state["rounds"] < max_rounds:
            if expired():
                return "stopped", rbound
            state["rounds"] += 1
            mdl = build_milp(problem, backend=backend, candidates=cand, keep=keep, cuts=cuts)
            if expired():  # building can be long: the limit covers it
                return "stopped", rbound
            state["stats"] = mdl.stats
            pk = mdl.points
            hint_idx = set()
            for p in state["inc"]:
                j = np.flatnonzero(np.hypot(*(pk - p).T) <= 1e-3)
                if len(j):
                    hint_idx.add(int(j[0]))
            if backend == "cp-sat":
                hint = {v: int(i in hint_idx) for i, v in enumerate(mdl.x)}
                res = solve_cpsat(mdl.model, variables=mdl.x, time_limit=left(), workers=workers, hint=hint,
                                  parameters=CPSAT_PARAMETERS if workers <= 2 else None)
            else:
                hint = {v: float(i in hint_idx) for i, v in enumerate(mdl.x)}
                res = solve_mip(mdl.model, variables=mdl.x, time_limit=left(), warm_start=hint, threads=workers)
            state["raw"] = res.backend_status
            if res.bound is not None:
                rbound = min(rbound, math.floor(res.bound + 1e-6))
            if not res.has_solution:
                return "stopped", rbound
            chosen = np.flatnonzero(np.asarray(res.x) > 0.5)
            pos = pk[chosen]
            ev = evaluate(problem, pos)
            cand_pos = pos if ev.feasible else _feasible_subset(problem, pos)
            cv = evaluate(problem, cand_pos).covered
            if cv > state["inc_val"]:
                state["inc"], state["inc_val"] = cand_pos, cv
            if res.status is not Status.OPTIMAL:
                return "stopped", rbound
            if ev.feasible:
                return "optimal", float(ev.covered)
            g = keep[chosen]  # global indices of the chosen sites
            d = np.hypot(pos[:, None, 0] - pos[None, :, 0], pos[:, None, 1] - pos[None, :, 1])
            for a, b in zip(*np.nonzero(np.triu(d < 2 * problem.R_d - TOL, 1))):
                mid = (pos[a] + pos[b]) / 2
                # d/2 < rho and 2 rho < 2 R_d - TOL: the ball holds both sites and is a clique
                rho = (d[a, b] + 2 * problem.R_d - TOL) / 4
                cuts.append(("clique", np.array(sorted(tree.query_ball_point(mid, rho)), dtype=np.int64)))
            for comp in _components_without_gbs(problem, pos):
                for delta in (0.0, problem.R_d):
                    w: set = set()
                    for i in comp:
                        w.update(tree.query_ball_point(pos[i], delta + TOL))
                    w_arr = np.array(sorted(j for j in w if not cand.direct[j]), dtype=np.int64)
                    nb: set = set()
                    for e in w_arr:
                        nb.update(tree.query_ball_point(cand.points[e], problem.r2 + TOL))
                    bnd = np.array(sorted(nb - set(w_arr.tolist())), dtype=np.int64)
                    cuts.append(("conn", w_arr, bnd))
            if time_limit is not None and time.perf_counter() - t0 >= time_limit:
                return "stopped", rbound
        return "stopped", rbound

    # Descending target scheme (exact): any solution worth more than g uses only sites
    # with |S(c)| + B_{m-1} > g. Solve on those; an optimum z_r > g is the optimum of the
    # full candidate problem, otherwise z_r is a new incumbent and g is lowered, ending
    # with g = incumbent value (the plain pruning of item 1).
    size = np.array([len(c) for c in cand.cover])
    best_bound = ub
    status = Status.FEASIBLE
    g = state["inc_val"] + 0.5 * (ub - state["inc_val"])
    while True:
        g = max(g, state["inc_val"])
        final = g <= state["inc_val"]
        keep = reduce_candidates(problem, cand, g, state["inc"], b_prev)
        outcome, val = cut_loop(keep)
        if outcome == "optimal" and (val > g or final):
            status = Status.OPTIMAL
            best_bound = min(best_bound, max(val, state["inc_val"]))
            break
        if outcome == "stopped":
            if final:
                best_bound = min(best_bound, val)
            else:
                # restricted to sites of value > g: solutions worth more than g are bounded by
                # val; others are bounded by g
                best_bound = min(best_bound, max(val, math.floor(g)))
            break
        g = state["inc_val"] + 0.5 * (g - state["inc_val"]) if g - state["inc_val"] > 2 else state["inc_val"]
    inc, rounds, raw, last_stats = state["inc"], state["rounds"], state["raw"], state["stats"]
    obj = float(evaluate(problem, inc).covered)
    if obj >= best_bound:
        status = Status.OPTIMAL
    glob = cont_bound is not None and obj >= cont_bound
    msg = (f"bound {best_bound:g} valid for the candidate problem (the candidate sites described in the "
           f"docstring); " + (f"continuous-problem upper bound {cont_bound:g} (max coverage by m discs without "
                              f"overlap/backhaul)" if cont_bound is not None else bound_note[2:])
           + ("; attained: globally optimal" if glob else ""))
    if status is not Status.OPTIMAL:
        msg += f"; stopped after {rounds} cut rounds (time limit or round limit) before proving optimality"
    return SolveResult(status, objective=obj, bound=float(best_bound), x=inc, backend=backend, backend_status=raw,
                       message=msg, solve_time=time.perf_counter() - t0, iterations=rounds,
                       warm_started=warm_used,
                       info={**info, "global_optimal": glob, "rounds": rounds, "model_stats": last_stats})
