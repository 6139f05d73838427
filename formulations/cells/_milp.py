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
        res = solve_cpsat(mdl, variables=x, time_limit=time_limit, workers=2)
    else:
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
        res = solve_mip(s, variables=x, time_limit=time_limit, threads=1)
    bound = res.bound if res.bound is not None else float(len(users))
    return dataclasses.replace(res, bound=math.floor(bound + 1e-6), x=None, solve_time=time.perf_counter() - t0,
                               message=f"continuous relaxation bound: max coverage by {m} discs over "
                                       f"{len(sets)} maximal candidate sets, no overlap/backhaul constraints")


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
    """Drop sites until the placement is feasible (overlaps first, then disconnected)."""
    pos = pos.copy()
    while len(pos):
        ev = evaluate(problem, pos)
        if ev.feasible:
            return pos
        d = np.hypot(pos[:, None, 0] - pos[None, :, 0], pos[:, None, 1] - pos[None, :, 1])
        np.fill_diagonal(d, np.inf)
        bad = np.flatnonzero(np.any(d < 2 * problem.R_d - TOL, axis=1))
        if len(bad):
            pos = np.delete(pos, bad[-1], axis=0)
        else:
            pos = pos[ev.connected]
    return pos


# With 1-2 workers CP-SAT's default portfolio runs no LP-based subsolver, so its bound
# on this covering model stalls far above the optimum (m=4 thesis instance: bound 222 vs
# optimum 61 after 120 s). An LP-relaxation worker plus the core-based worker close it.
CPSAT_PARAMETERS = {"subsolvers": ["max_lp", "core"]}


def solve_milp(problem: CellProblem, *, backend: str = "cp-sat", time_limit: float | None = None,
               warm_start=None, workers: int = 2, max_rounds: int = 200) -> SolveResult:
    """Solve the candidate-site model with exact backhaul connectivity (lazy cuts).

    backend: "cp-sat" (default), "highs" or "scip".
    time_limit: overall wall-clock limit (s) for the cut loop; None: no limit.
    warm_start: drone-cell positions ((k, 2) m, e.g. the GA's). They are added to the
        candidate set (so the result is never worse than a feasible warm start) and
        handed to the backend as a hint/start solution when feasible.
    workers: CP-SAT workers / MIP threads.

    Returns a SolveResult: ``x`` positions (k, 2) with k <= m, ``objective`` covered
    users, ``bound`` an upper bound valid for the *candidate* problem (all user
    points, pairwise R_d-circle intersections, R_d circles met with the r1 and
    R_g + R_d circles and the area edges, and the warm start); ``info`` holds
    ``continuous_bound`` (valid for the continuous problem: max coverage by m discs
    without overlap/backhaul constraints), ``global_optimal`` (objective equals the
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

    relax = coverage_upper_bound(problem, problem.n_cells, time_limit=left())
    cont_bound = float(relax.bound)
    cand = candidate_sites(problem, extra=warm)
    empty = np.zeros((0, 2))
    if len(cand.points) == 0 or cont_bound == 0:
        return SolveResult(Status.OPTIMAL, objective=0.0, bound=0.0, x=empty, backend=backend,
                           solve_time=time.perf_counter() - t0,
                           message="no user can be covered by a feasible drone-cell: optimum 0 (no sites)",
                           info={"continuous_bound": cont_bound, "global_optimal": True, "rounds": 0,
                                 "model_stats": {"candidates": len(cand.points)}})
    # incumbent: greedy, or the warm start (or its feasible part) when better
    inc = greedy_placement(problem, cand)
    inc_val = evaluate(problem, inc).covered
    warm_used = False
    if warm is not None and len(warm):
        w = _feasible_subset(problem, warm[: problem.n_cells] if len(warm) <= problem.n_cells else warm)
        if len(w) <= problem.n_cells:
            wv = evaluate(problem, w).covered
            if wv >= inc_val:
                inc, inc_val, warm_used = w, wv, True
    info: dict[str, Any] = {"continuous_bound": cont_bound, "relaxation_time": relax.solve_time}
    if inc_val >= cont_bound:
        return SolveResult(Status.OPTIMAL, objective=float(inc_val), bound=cont_bound, x=inc, backend=backend,
                           solve_time=time.perf_counter() - t0, warm_started=warm_used,
                           message=("bound valid for the continuous problem (max coverage by m discs without "
                                    "overlap/backhaul) and attained: globally optimal"),
                           info={**info, "global_optimal": True, "rounds": 0, "model_stats": {}})
    b_prev = float(coverage_upper_bound(problem, problem.n_cells - 1, time_limit=left()).bound)
    tree = cKDTree(cand.points)
    cuts: list = []
    state = {"inc": inc, "inc_val": inc_val, "rounds": 0, "raw": "", "stats": {}}

    def cut_loop(keep: np.ndarray) -> tuple[str, float]:
        """Solve the model restricted to ``keep`` exactly with lazy cuts.
        Returns ("optimal", value) or ("stopped", bound of the restricted problem)."""
        rbound = math.inf
        while state["rounds"] < max_rounds:
            state["rounds"] += 1
            mdl = build_milp(problem, backend=backend, candidates=cand, keep=keep, cuts=cuts)
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
    best_bound = cont_bound
    status = Status.FEASIBLE
    g = state["inc_val"] + 0.5 * (cont_bound - state["inc_val"])
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
    glob = obj >= cont_bound
    msg = (f"bound {best_bound:g} valid for the candidate problem (the candidate sites described in the "
           f"docstring); continuous-problem upper bound {cont_bound:g} (max coverage by m discs without "
           f"overlap/backhaul)" + ("; attained: globally optimal" if glob else ""))
    if status is not Status.OPTIMAL:
        msg += f"; stopped after {rounds} cut rounds (time limit or round limit) before proving optimality"
    return SolveResult(status, objective=obj, bound=float(best_bound), x=inc, backend=backend, backend_status=raw,
                       message=msg, solve_time=time.perf_counter() - t0, iterations=rounds,
                       warm_started=warm_used,
                       info={**info, "global_optimal": glob, "rounds": rounds, "model_stats": last_stats})
