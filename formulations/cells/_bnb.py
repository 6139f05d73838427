"""Exact combinatorial branch and bound over the candidate sites (thesis ch. 4).

Solves the same *candidate problem* as the MILP of ``_milp`` (choose at most m candidate
sites, pairwise non-overlapping, every one linked to a GBS through chosen sites, maximise
the users covered) by depth-first enumeration with exact pruning. Every placement X is
enumerated as the sequence of its sites in one fixed order (weight |S(c)| descending,
ties by index), so each X is reached from exactly one branch; a branch is cut only when
a valid upper bound on everything below it is <= the incumbent value, so the search
proves optimality when it ends.

Why each element is exact:

1. **Additive bound.** Below a node holding sites P (last in the order: site i), every
   completion Q consists of sites after i that do not overlap P or each other, and
   |S(P u Q)| <= |S(P)| + sum_{q in Q} |S(q)| (a union is at most the sum). Non-overlap
   makes this nearly tight: two chosen sites >= 2 R_d - TOL apart share only users in a
   lens of width ~TOL. The sum is never used as a value, only as a bound; values are
   exact unions (bitsets).
2. **Clique partition.** The sites are partitioned once into cliques of the conflict
   graph: a site's clique holds the still unassigned sites within R_d - TOL of it, which
   are pairwise < 2 R_d - 2 TOL apart, so they overlap pairwise and at most one of them
   is chosen. Hence sum_{q in Q} |S(q)| <= the sum of the r largest per-clique maxima
   over the sites still compatible with P (r = free slots). Sites overlapping P are not
   compatible, so a cluster already covered by P does not count again.
3. **Relay lower bound.** In a connected placement the path from a GBS to a chosen site
   a passes through chosen sites; between consecutive P-sites s, t (or the GBS and the
   first one) on it lie at least ceil((|s - t| - r2 - TOL) / (r2 + TOL)) further sites
   (ceil((|a - G| - r1 - TOL) / (r2 + TOL)) from the GBS), every link being at most
   r2 + TOL (r1 + TOL to a GBS). The shortest such path count over the complete graph
   on P and the GBSs is a lower bound on the relays outside P that P needs, so a branch
   with more needed relays than free slots holds no feasible placement. (Ceilings are
   taken of x - 1e-6 so rounding can only lower the bound.)
4. **Order cut.** Sites after i weigh at most |S(j)| for the next candidate j, so once
   |S(P)| + r |S(j)| <= incumbent no later candidate can lead above it. Sites cut this
   way weigh at most w_th = floor((z - |S(P)|) / r); they may still be the lighter
   members of a completion, so the clique values of item 2 are padded with w_th when
   fewer than r cliques remain among the heavier sites.
5. **Bridge slot.** If some P sites have no link path to a GBS through P (the link
   tests of ``evaluate``), the first site off that group on a path to a GBS is a
   completion site within r2 + TOL of one of them; so one of the r slots holds at most
   the heaviest such candidate.
6. **Linkable slot.** The first completion site on a path from a GBS links to a GBS or
   to a P site reached through P, so its relay lower bound (item 3) is 0; one slot holds
   at most the heaviest candidate with that bound 0 (and a node with none has no
   non-empty completion).
7. **Greedy dual of coverage.** For any set G of sites, coverage is monotone and
   submodular, so |S(Q) - S(P)| <= f(G) + sum_{q in Q} gain(q | G) <= f(G) + the r
   largest gains (f, gains over the users outside S(P), Q among the candidates that pass
   item 3); G runs through the greedy sets G_0 = {}, G_1, ..., G_r, and item 6 applies to
   the gains as well. Used at nodes with >= 3 free slots (at 2 it cost more than it cut:
   m=4 seed 3 not proven in 59 s cpu, against 14 s without it).
8. **Two relay slots.** If an unreached P site a has relay lower bound >= 2, its path
   to a GBS holds >= 2 completion sites; the one next to the GBS side (item 6) and the
   one next to a's group (item 5) are then distinct, so two slots are bounded by the
   heaviest linkable and the heaviest bridge candidate (items 5, 6 and 7 combined).

9. **Backhaul-free bounds.** Dropping backhaul leaves the same problem on the same
   candidates with every site linked (``_without_backhaul``: ranges beyond every
   candidate). Its optimum B_k for k sites, found by this search (items 1-8; the
   relay items then never bind), bounds any k pairwise non-overlapping candidates, so a
   node with r free slots holds at most |S(P)| + B_r (a union is at most the sum).
10. **Site elimination.** Before the search, a site c is cleared when no placement
   containing c can beat the incumbent z: first when |S(c)| + B_{m-1} <= z (item 9 for
   the other m - 1 sites), then when the bound of the node {c} (items 1-9, over every
   remaining site that does not overlap c, in any order: items 1-8 do not use the order
   beyond item 4, whose padding w_th covers the cut sites) is <= z; repeated while sites
   are cleared. A cleared site can join no better placement, so dropping it everywhere
   (also as a relay) keeps the search exact, and relay items 3, 5, 6 and 8 then see only
   the sites that can still be used. Each backhaul-free search of item 9 gets the
   bounds of the smaller ones and eliminates sites in the same way. Measured with items
   9-11 at m = 6 (Table 4.2, 300 s): seeds 0, 2, 4, 7, 8 and 9 proven (worst 17 s;
   before: 2, 8 and 9); seeds 1, 3, 5 and 6 stayed open (incumbents 6-11 % below B_6)
   until items 11-12 and the split (all 10 within 300 s, worst 175 s on seed 1).

11. **Sibling replacement.** At a node P, let a be a child searched before b (a earlier
   in the order). Suppose a is direct when b is, links to every P site that b links to,
   and either covers every user that b adds to S(P) or keeps at least as many. "Keeps"
   means the users of a outside S(P) and outside the lens that completion sites not
   overlapping a can reach: those are the sites within 2 R_d of a, and they cover only
   users at the edge of a's disc. Let E be the remaining candidates that overlap a but
   not b, or link to b but not to a. Then for each completion Q of P + b that avoids E:
   - P + a + Q is feasible;
   - it covers at least as much: |S(P + a + Q)| = |S(P + Q)| + |S(a) - S(P + Q)|, and
     |S(b) - S(P + Q)| <= |S(b) - S(P)|;
   - it lies in a's subtree (Q comes after b, so after a).
   That subtree never holds a placement better than the final incumbent, by induction
   over the children: a's own subtree is searched in full or under this same rule.
   So b is skipped when E is empty. Otherwise only completions holding a site of E are
   searched (``must``):
   - a node without an E site left is cut;
   - one slot holds at most the heaviest E site;
   - the last slots take only E sites;
   - with at most ``_MUST_BRANCH`` E sites left and 3 or more free slots, the node
     branches on them: it searches P + e for each E site e in turn, and e's completions
     hold no earlier E site.
   Inside such a node (completions must meet a set M), a child b outside M is compared
   with its siblings too: each of M and E drops only completions that an earlier child's
   subtree holds, so b keeps the smaller of the two sets. The 16 latest siblings within
   600 m are tried. Clusters give many near-identical sites: the 24-user cluster of m = 6
   seed 3 has 8, and seed 6's 22-user clusters have more than 20. Otherwise each of them
   repeats a nearly identical subtree (50-60 s each on seed 3). The sibling tests use the
   link matrix (``link_matrix``) and, for the lens, the sites within 2 R_d + 2 m of a that
   do not overlap it (``lens_sites``); with distances over every candidate, item 11 took
   48 of 150 s on m = 6 seed 1.

12. **Far-apart unreached groups.** Let the P sites without a link path to a GBS
   through P form k <= 3 groups (components of the link graph), pairwise more than
   2 (r2 + TOL) apart, and let L be the remaining sites that are direct or linked to a
   reached P site. On a shortest path from a group g to a GBS, the node after the last
   g site is a completion site b_g linked to g (not a GBS, a reached site or another
   group: the group would be reached or larger). Bridges of different groups are
   distinct (no site is within r2 + TOL of two groups), so the completion holds k
   bridges, each at most the heaviest site near its group, and r - k other sites
   bounded by the clique values of item 2. When the groups are also more than
   3 (r2 + TOL) apart, successors count too. If b_g is not in L, the next node is a
   completion site v linked to b_g, within 2 (r2 + TOL) of g, and neither a bridge (a
   bridge of g' linked to b_g puts g' within 3 (r2 + TOL) of g) nor in another group.
   So for each choice of which bridges lie outside L, the completion holds k bridges
   (each at most the heaviest site of its kind near its group) and, if any bridge lies
   outside L, one more site v, with the other r - k - 1 sites bounded by item 2. When
   that uses every slot, v is the successor of every such group (linked to a bridge
   candidate of each) and ends their paths: it is in L or linked to a bridge in L.
   When every bridge lies outside L, v or another site is in L (item 6).
   ``_separated_groups`` takes the largest bound over the choices. The successor's
   link to a bridge candidate is tested exactly, on the packed link rows of
   ``_link_rows`` (built once per search). Testing it with coordinates took 140 of
   241 s on m = 6 seed 1, so that version tested only at r = 3. Measured on m = 6
   seed 1 (Table 4.2): the subtree of its first two sites took 82 s before item 12 and
   4 s with it.

With ``workers`` > 1 the search is split over forked processes (``_split_root``): each
takes its share of the children of every node at depth 1 (m >= 4), so one heavy root
child does not stay on one core.

The last two slots are enumerated without a search node per site (the same tests,
vectorised over the candidates). Two primal heuristics improve the start before the
search: a 1-swap local search, then an exchange search that re-solves exactly (with the
search below, rooted there) every incumbent minus 1 or 2 of its sites. Both only propose
placements, checked with ``evaluate`` before they become the incumbent; exactness rests
on the bounds above alone.

The search stops at the time limit with the incumbent and a valid bound: every
unexplored placement lies below the current or a later child of a node on the current
path, so it is bounded by that node's bound and (children come in weight order, item 4)
by |S(P)| + r |S(j)| for the current child j; the largest of these level bounds over the
path is reported (with workers, the largest over the workers). Before, the bound was
lost as the time-out unwound the path, and a stopped search reported ``upper``.
"""

from __future__ import annotations

import contextlib
import itertools
import math
import multiprocessing
import os
import queue
import time
from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from droneplan.formulations.cells._core import TOL, Candidates, evaluate, pairwise_distances
from droneplan.scenarios.cells import CellProblem


@dataclass
class BnbResult:
    """Outcome of :func:`search`."""

    positions: np.ndarray
    """(k, 2) the best placement found (m)."""
    value: int
    """Users it covers."""
    bound: float
    """Upper bound on the candidate problem (== value when ``proven``)."""
    proven: bool
    """True when the search finished (the placement is optimal over the candidates)."""
    nodes: int
    """Search nodes visited."""
    eliminated: int = 0
    """Candidate sites cleared before the search (item 10)."""
    elimination_time: float = 0.0
    """Seconds spent on items 9-10 (the backhaul-free searches and the site tests)."""
    separated: int = 0
    """Node bounds that item 12 (far-apart unreached groups) lowered."""


class _Timeout(Exception):
    """Raised inside the search when the time limit expires; caught by the solve, which then
    returns the incumbent with the bound of the unexplored branches."""


@dataclass
class _State:
    best_val: int
    nodes: int = 0
    separated: int = 0
    frontier: float | None = None
    """At a time-out in the main search: the bound on every placement not yet searched."""
    best: list[int] | None = None


_POP8 = np.array([bin(i).count("1") for i in range(256)], dtype=np.int64)


def _popcount_rows(a: np.ndarray) -> np.ndarray:
    """Number of set bits in each row of a 2-D unsigned integer array."""
    if hasattr(np, "bitwise_count"):
        return np.bitwise_count(a).sum(axis=1, dtype=np.int64)
    return _POP8[np.ascontiguousarray(a).view(np.uint8)].sum(axis=1)


def _relay_cost(d: np.ndarray, reach: float, r2: float) -> np.ndarray:
    """Lower bound on the relays needed to bridge a distance ``d`` when the first link
    reaches ``reach`` and each further link r2 (tolerances included, item 3)."""
    x = (d - reach - TOL) / (r2 + TOL) - 1e-6
    return np.maximum(np.ceil(x), 0.0)


def search(  # noqa: C901, PLR0915
    problem: CellProblem,
    cand: Candidates,
    incumbent: np.ndarray,
    incumbent_value: int,
    *,
    upper: float = math.inf,
    time_limit: float | None = None,
    eliminate: bool = True,
    heuristics: bool = True,
    free_bounds: list[float] | None = None,
    workers: int = 1,
    node_limit: int | None = None,
    main: bool = True,
) -> BnbResult:
    """Exact search of the candidate problem (module docstring).

    problem: the CellProblem; cand: its candidate sites (``candidate_sites``);
    incumbent: a feasible placement ((k, 2) m) worth ``incumbent_value`` users;
    upper: a known upper bound (e.g. the continuous one): the search stops once the
    incumbent reaches it; time_limit: seconds (None: none); eliminate: use items 9-10
    (tests switch them off to check item 9's searches alone); heuristics: run the primal heuristics
    before the search (tests switch them off to start from a given incumbent);
    free_bounds: item 9's B_0, ..., B_{m-1} when known (each backhaul-free search gets
    those of the smaller ones, so it eliminates sites without searching again);
    workers: processes that share the children of the root (``_split_root``); used when
    m >= 3, there are at least ``_SPLIT_MIN_SITES`` candidates and processes can be
    forked (else the search runs in this process alone); node_limit: stop like at the time
    limit after about this many search nodes (checked every ``_CHECK_EVERY``; a
    deterministic budget); main: False runs the primal heuristics only (no elimination, no
    main search; the result is not proven and its bound is ``upper``), to hand another
    engine a start.
    """
    t0 = time.perf_counter()
    m = problem.n_cells
    n = len(cand.points)
    best_pos = np.asarray(incumbent, dtype=float).reshape(-1, 2)
    best_val = int(incumbent_value)
    if n == 0 or m == 0 or best_val >= upper:
        return BnbResult(best_pos, best_val, float(min(upper, best_val) if n == 0 else upper), True, 0)
    _check_memory(n)
    w_all = np.array([len(c) for c in cand.cover], dtype=np.int64)
    order = np.lexsort((np.arange(n), -w_all))
    pts = cand.points[order]
    w = w_all[order]
    bits = [0] * n
    for k, i in enumerate(order.tolist()):
        b = 0
        for u in cand.cover[i].tolist():
            b |= 1 << int(u)
        bits[k] = b
    # item 7: coverage sets as packed bit rows (users of cover, in the sorted order)
    n_words = max((len(problem.targets) + 63) // 64, 1)
    member = np.zeros((n, n_words * 64), dtype=bool)
    for k, i in enumerate(order.tolist()):
        member[k, cand.cover[i]] = True
    packed = np.packbits(member, axis=1, bitorder="little").view(np.uint64)
    del member
    # item 2: clique partition, heaviest unassigned site first
    tree = cKDTree(pts)
    clique = np.full(n, -1, dtype=np.int64)
    n_cl = 0
    for i in range(n):
        if clique[i] >= 0:
            continue
        # centred on the centroid of the users the site covers (a cluster's heaviest sites
        # ring its centre, so one disc there holds all of them), else on the site itself
        ctr = problem.targets[cand.cover[order[i]]].mean(axis=0) if w[i] else pts[i]
        if math.dist(ctr, pts[i]) >= problem.R_d - 2 * TOL:
            ctr = pts[i]
        nb = np.asarray(tree.query_ball_point(ctr, problem.R_d - 2 * TOL), dtype=np.int64)
        nb = nb[clique[nb] < 0]
        clique[nb] = n_cl
        clique[i] = n_cl
        n_cl += 1
    # conflicts (4.8): distance < 2 R_d - TOL, as rows of a dense boolean matrix
    conflict = np.zeros((n, n), dtype=bool)
    pairs = tree.query_pairs(2 * problem.R_d, output_type="ndarray")
    if len(pairs):
        d = np.hypot(*(pts[pairs[:, 0]] - pts[pairs[:, 1]]).T)
        pairs = pairs[d < 2 * problem.R_d - TOL]
        conflict[pairs[:, 0], pairs[:, 1]] = True
        conflict[pairs[:, 1], pairs[:, 0]] = True
    dg = np.min(pairwise_distances(pts, problem.gbs), axis=1)
    cg = _relay_cost(dg, problem.r1, problem.r2)  # item 3, GBS -> site
    r2 = problem.r2

    def top_cliques(idx: np.ndarray, k: int) -> list[int]:
        """The k largest per-clique maxima over the sites ``idx`` (sorted heaviest first)."""
        out: list[int] = []
        if k <= 0:
            return out
        seen: set[int] = set()
        lo = 0
        while lo < len(idx):
            hi = min(len(idx), lo + 64)
            for t, c in zip(idx[lo:hi].tolist(), clique[idx[lo:hi]].tolist(), strict=True):
                if c not in seen:
                    seen.add(c)
                    out.append(int(w[t]))
                    if len(out) == k:
                        return out
            lo = hi
        return out

    state = _State(best_val)
    stack_bounds: list[float] = []
    # item 9: conf_bound[k] bounds the users any k pairwise non-overlapping candidates cover
    conf_bound: list[float] = list(free_bounds or [])
    r1t, r2t = problem.r1 + TOL, problem.r2 + TOL

    link_cache: dict[str, np.ndarray] = {}

    def link_rows() -> np.ndarray:
        """``_link_rows(pts, r2t)``, built on first use (item 12's exact link test)."""
        if "rows" not in link_cache:
            link_cache["rows"] = _link_rows(pts, r2t)
        return link_cache["rows"]

    def link_matrix() -> np.ndarray:
        """(n, n) bool: sites within r2 + TOL of each other (``link_rows`` unpacked, for
        item 11), built on first use."""
        if "matrix" not in link_cache:
            link_cache["matrix"] = np.unpackbits(link_rows(), axis=1, count=n, bitorder="little").view(bool)
        return link_cache["matrix"]

    lens_of: dict[int, np.ndarray] = {}

    def lens_sites(a: int) -> np.ndarray:
        """Item 11: the sites within 2 R_d (+ 2 m) of site a that do not overlap it, the
        only ones that can cover users of a when a is placed."""
        if a not in lens_of:
            near = np.asarray(tree.query_ball_point(pts[a], 2 * problem.R_d + 2.0), dtype=np.int64)
            lens_of[a] = np.sort(near[~conflict[a, near]])
        return lens_of[a]

    def expired() -> bool:
        if node_limit is not None and state.nodes >= node_limit:
            return True
        return time_limit is not None and time.perf_counter() - t0 >= time_limit

    in_main = [False]

    def timed_out() -> _Timeout:
        """The time-out, raised from the main search after recording the bound of what it
        has not searched (``state.frontier``): every such placement lies below the current
        or a later child of a node on the path, whose level bound ``stack_bounds`` holds."""
        if in_main[0]:
            state.frontier = max(stack_bounds, default=float(upper))  # empty: at the root
        return _Timeout()

    # the split: (this worker's index, workers, depth whose children are dealt out) and the
    # incumbent value the workers share
    split = [0, 1, 0]
    shared: list = []

    def checkpoint() -> bool:
        """Every ``_CHECK_EVERY`` nodes: share the incumbent value with the other workers (a value only:
        each worker keeps the placements it found), then test the time limit."""
        if shared:
            with shared[0].get_lock():
                if state.best_val > shared[0].value:
                    shared[0].value = state.best_val
                elif shared[0].value > state.best_val:
                    state.best_val = int(shared[0].value)
        return expired()

    def greedy_dual(P: list[int], C: np.ndarray, dist: np.ndarray, reach: np.ndarray, r: int) -> float:
        """Item 7: an upper bound on |S(Q) - S(P)| over completions Q of at most r sites of
        C that fit the relay bound of P + q, by submodularity of coverage."""
        if P:
            pp = pts[P]
            ej = _relay_cost(pairwise_distances(pp, pts[C]), r2, r2)
            gj, newd = _through(dist, gj_direct=cg[C], ej=ej, epp=pp_cost(P))
            need = np.maximum(gj, newd.max(axis=0))
            keep = need <= r - 1
            C, g0 = C[keep], gj[keep] <= 0
            covered = np.bitwise_or.reduce(packed[P], axis=0)
            if reach.all():
                near = None
            else:  # item 5: bridge candidates, within r2 + TOL of an unreached P site
                pu = pp[~reach]
                near = np.any(
                    pairwise_distances(pu, pts[C]) <= r2t,
                    axis=0,
                )
                if not near.any():
                    return -math.inf  # P cannot be completed: no feasible placement below
        else:
            C = C[cg[C] <= r - 1]
            g0 = cg[C] <= 0
            covered = np.zeros(packed.shape[1], dtype=packed.dtype)
            near = None
        if len(C) == 0 or not g0.any():
            return 0.0  # item 6: a non-empty completion holds a site with gj = 0
        two = near is not None and r >= 2 and float(dist[~reach].max()) >= 2
        rows = packed[C]
        f_g = 0
        best = math.inf
        for k in range(r + 1):
            gain = _popcount_rows(rows & ~covered)
            top = np.sort(gain if len(gain) <= r else np.partition(gain, len(gain) - r)[-r:])
            # item 6 again: one of the r gains is that of a site with gj = 0
            best = min(best, f_g + int(top.sum()), f_g + int(gain[g0].max()) + int(top[1:].sum()))
            if near is not None:  # item 5: one gain from a bridge, two distinct ones (item 8)
                best = min(best, f_g + int(gain[near].max()) + int(top[1:].sum()))
                if two:
                    best = min(best, f_g + int(gain[near].max()) + int(gain[g0].max()) + int(top[2:].sum()))
            if k == r:
                break
            g = int(np.argmax(gain))
            if gain[g] == 0:
                break
            f_g += int(gain[g])
            covered = covered | rows[g]
        return float(best)

    def pp_cost(P: list[int]) -> np.ndarray:
        """(|P|, |P|) relay lower bounds between the sites of P (item 3)."""
        pp = pts[P]
        return _relay_cost(pairwise_distances(pp, pp), r2, r2)

    def reach_of(P: list[int]) -> np.ndarray:
        """(|P|,) bool: sites of P with a link path (<= r1 + TOL to a GBS, <= r2 + TOL
        between sites, the tests of ``evaluate``) to a GBS through P."""
        pp = pts[P]
        link = pairwise_distances(pp, pp) <= r2t
        reach = dg[P] <= r1t
        for _ in range(len(P)):
            nr = reach | np.any(link & reach[None, :], axis=1)
            if np.array_equal(nr, reach):
                break
            reach = nr
        return reach

    def last_site(P: list[int], ubits: int, C: np.ndarray, reach: np.ndarray, val: int) -> None:
        """The last free slot: every candidate q of C (sorted heaviest first, each keeping
        P + q non-overlapping) that makes P + q connected (the exact link test of
        ``evaluate``), while |S(P)| + |S(q)| can beat the incumbent."""
        C = C[val + w[C] > state.best_val]
        if len(C) == 0:
            return
        ok = connecting(P, C, reach)
        for q in C[ok].tolist():
            if val + int(w[q]) <= state.best_val:
                break
            if (ubits | bits[q]).bit_count() > state.best_val:
                ev = evaluate(problem, pts[[*P, q]])
                if ev.feasible and ev.covered > state.best_val:
                    state.best_val, state.best = int(ev.covered), [*P, q]

    def dfs(  # noqa: C901, PLR0915
        P: list[int],
        ubits: int,
        cmask: np.ndarray,
        dist: np.ndarray,
        nb: float,
        probe: bool = False,
        must: np.ndarray | None = None,
    ) -> float | None:
        """Search below the node P (``cmask``: the sites that may complete it). With
        ``probe``, only bound it: the node bound, or None when no placement P + Q with Q
        from ``cmask`` covers more than the incumbent (item 10); nothing is searched.
        ``must`` (bool over the sites): only completions holding one of them (item 11)."""
        # dist[k]: relay lower bound from a GBS to P[k] (item 3)
        state.nodes += 1
        if state.nodes % _CHECK_EVERY == 0 and checkpoint():
            raise timed_out()
        val = ubits.bit_count()
        pp = pts[P]
        if P:
            dpp = pairwise_distances(pp, pp)
            link = dpp <= r2t
            reach = dg[P] <= r1t
            for _ in range(len(P)):
                nr = reach | np.any(link & reach[None, :], axis=1)
                if np.array_equal(nr, reach):
                    break
                reach = nr
        else:
            reach = np.zeros(0, dtype=bool)
        if val > state.best_val and reach.all():
            ev = evaluate(problem, pp)
            if ev.feasible and ev.covered > state.best_val:
                state.best_val, state.best = int(ev.covered), list(P)
        r = m - len(P)
        if probe and r <= 1:
            return math.inf  # probes are only made with >= 2 free slots; never prune here
        if r == 0:
            return None
        if must is not None:  # item 11: completions must hold a site of ``must``
            cmask_must = cmask & must
            if not cmask_must.any():
                return None
            w_must = int(w[np.flatnonzero(cmask_must)[0]])
        z = state.best_val
        if r == 1:
            last_site(P, ubits, np.flatnonzero(cmask if must is None else cmask_must), reach, val)
            return None
        # item 4: candidates heavy enough, then the relay lower bound of P + j (item 3)
        C = np.flatnonzero(cmask)
        if r >= 3:  # item 7 over every candidate that fits the relay bound
            cover_bound = greedy_dual(P, C, dist, reach, r)
            if val + cover_bound <= z:
                return None
        else:
            cover_bound = math.inf
        C = C[val + r * w[C] > z]
        if len(C) == 0:
            return None
        cgj = cg[C]
        if P:
            dpj = pairwise_distances(pp, pts[C])
            ej = _relay_cost(dpj, r2, r2)  # (|P|, |C|)
            gj, newd = _through(dist, gj_direct=cgj, ej=ej, epp=pp_cost(P))
            need = np.maximum(gj, newd.max(axis=0))
        else:
            gj = cgj
            need = cgj
            newd = np.zeros((0, len(C)))
            dpj = np.zeros((0, len(C)))
        ok = np.flatnonzero(need <= r - 1)
        if len(ok) == 0:
            return None
        Cok = C[ok]
        # node bound: items 1-2 over the sites that can still join (need <= r - 1). Sites
        # cut by item 4 weigh at most w_th; they may still be the lighter members of a
        # completion, so missing clique values are padded with w_th.
        w_th = max((z - val) // r, 0)
        tops = top_cliques(Cok, r)
        tops += [w_th] * (r - len(tops))
        b = val + sum(tops)
        # item 6: the first completion site on a path from a GBS links to a GBS or to a
        # reached P site, so its relay lower bound gj is 0: one slot holds at most the
        # heaviest candidate with gj = 0
        g0 = gj[ok] <= 0
        wg = max(int(w[Cok[g0][0]]) if g0.any() else 0, w_th)
        b = min(b, val + wg + sum(tops[: r - 1]))
        b_sep = math.inf  # item 12
        if not reach.all():
            # item 5: the P sites without a link path to a GBS need a chosen site of the
            # completion within r2 + TOL of one of them (the first site off that group on
            # a path to a GBS); that slot holds at most the heaviest such site
            near = np.any(dpj[:, ok][~reach] <= r2t, axis=0)
            wb = max(int(w[Cok[near][0]]) if near.any() else 0, w_th)
            b = min(b, val + wb + sum(tops[: r - 1]))
            if r >= 2 and float(dist[~reach].max()) >= 2:  # item 8
                b = min(b, val + wb + wg + sum(tops[: r - 2]))
            if r >= 2:  # item 12: far-apart unreached groups need their own bridges
                sep = _separated_groups(pts, w, dg, P, dpp, reach, cmask, r, tops, r1t, r2t, link_rows())
                if val + sep < b:
                    b_sep = val + sep
                    state.separated += 1
        if must is not None:  # item 11: one slot holds a site of ``must``
            b = min(b, val + w_must + sum(tops[: r - 1]))
        bf = min(float(b), val + cover_bound, nb, b_sep)
        if r < len(conf_bound):  # item 9
            bf = min(bf, val + conf_bound[r])
        if bf <= z:
            return None
        if probe:
            return bf
        if must is not None and r >= 3 and int(cmask_must.sum()) <= _MUST_BRANCH:
            # item 11 by branching: every completion holds a site e of ``must``; search
            # P + e for each e in turn, its completions holding no earlier one
            stack_bounds.append(bf)
            try:
                must_branch(P, ubits, cmask, cmask_must, dist, r, bf)
            finally:
                stack_bounds.pop()
            return None
        stack_bounds.append(bf)
        if r == 2:  # the last two slots without a search node per first site (same test)
            full = np.flatnonzero(cmask)
            neg_w = -w[full]  # non-decreasing
        explored: list[int] = []
        try:
            dealt = split[1] > 1 and len(P) == split[2] and not probe
            for pos, k in enumerate(ok.tolist()):
                j = int(C[k])
                z = state.best_val
                if val + r * int(w[j]) <= z:
                    break
                # the level bound: this child and the later ones add r sites of weight <= w[j]
                stack_bounds[-1] = min(bf, val + r * int(w[j]))
                # the split: at depth split[2], worker i searches the children at positions
                # i, i + workers, ... (the same in every worker: see _split_root)
                mine = not dealt or pos % split[1] == split[0]
                if r == 2:
                    if not mine:
                        explored.append(j)
                        continue
                    state.nodes += 1
                    if state.nodes % _CHECK_EVERY == 0 and checkpoint():
                        raise timed_out()
                    ubj = ubits | bits[j]
                    valj = ubj.bit_count()
                    lo = int(np.searchsorted(full, j, side="right"))
                    hi = int(np.searchsorted(neg_w, valj - z, side="left"))  # w > z - valj
                    pj = [*P, j]
                    if valj > z:  # P + j alone
                        rj = reach_of(pj)
                        if rj.all():
                            ev = evaluate(problem, pts[pj])
                            if ev.feasible and ev.covered > state.best_val:
                                state.best_val, state.best = int(ev.covered), pj
                    if hi > lo:
                        cq = full[lo:hi]
                        cq = cq[~conflict[j, cq]]
                        if must is not None and not must[j]:
                            cq = cq[must[cq]]
                        # item 11 (the lighter last sites are bounded); under ``must`` only
                        # for j outside it, whose last site is then in ``must`` in any case
                        if len(cq) and (must is None or not must[j]):
                            in_cq = np.zeros(n, dtype=bool)
                            in_cq[cq] = True
                            replace = replaced_by_sibling(P, ubits, j, in_cq, explored)
                            if replace is True:
                                cq = cq[:0]
                            elif isinstance(replace, np.ndarray):
                                cq = cq[replace[cq]]
                        last_site(pj, ubj, cq, reach_of(pj), valj)
                    explored.append(j)
                    continue
                cm = cmask & ~conflict[j]
                cm[: j + 1] = False
                child_must = None if must is None or must[j] else must
                if must is None or child_must is not None:  # item 11
                    # under ``must`` only for j outside it: the child keeps the smaller of
                    # the two sets (each drops only completions held by an earlier child)
                    replace = replaced_by_sibling(P, ubits, j, cm, explored)
                    if replace is True:
                        explored.append(j)
                        continue
                    if isinstance(replace, np.ndarray) and (
                        child_must is None
                        or np.count_nonzero(replace & cm) < np.count_nonzero(child_must & cm)
                    ):
                        child_must = replace
                explored.append(j)
                if not mine:
                    continue
                nd = np.append(newd[:, k], gj[k]) if P else np.array([gj[k]])
                # shortest paths can only shorten further inside P + j: recompute exactly
                pj = [*P, j]
                dfs(pj, ubits | bits[j], cm, _close(pts[pj], nd, r2), bf, must=child_must)
        finally:
            stack_bounds.pop()
        return None

    def must_branch(
        P: list[int],
        ubits: int,
        cmask: np.ndarray,
        cmask_must: np.ndarray,
        dist: np.ndarray,
        r: int,
        nb: float,
    ) -> None:
        """Item 11 by branching: search the nodes P + e for the sites e of ``cmask_must``
        (the sites of ``must`` left), each completed from ``cmask`` without the earlier
        ones, so every completion holding a site of ``must`` is searched once. At the split
        depth the e are dealt out like children (``_split_root``)."""
        rest = cmask.copy()
        epp = pp_cost(P) if P else np.zeros((0, 0))
        for pos, e in enumerate(np.flatnonzero(cmask_must).tolist()):
            rest[e] = False
            if split[1] > 1 and len(P) == split[2] and pos % split[1] != split[0]:
                continue
            if P:
                ee = _relay_cost(np.hypot(*(pts[P] - pts[e]).T)[:, None], r2, r2)
                ge, nde = _through(dist, gj_direct=cg[[e]], ej=ee, epp=epp)
                if max(float(ge[0]), float(nde.max())) > r - 1:  # item 3: P + e needs too many relays
                    continue
                nd = np.append(nde[:, 0], ge[0])
            else:
                if cg[e] > r - 1:
                    continue
                nd = np.array([cg[e]])
            pe = [*P, e]
            dfs(pe, ubits | bits[e], rest & ~conflict[e], _close(pts[pe], nd, r2), nb)

    def replaced_by_sibling(
        P: list[int], ubits: int, b: int, cm: np.ndarray, explored: list[int]
    ) -> bool | np.ndarray | None:
        """Item 11 for the child P + b, given siblings ``explored`` before it: True when a
        sibling can replace b in every completion (skip b), a bool mask E over the sites
        when it can in every completion avoiding E (search only completions meeting E),
        None when no sibling qualifies."""
        new_b = bits[b] & ~ubits
        best: np.ndarray | None = None
        best_count = 0
        linked = link_matrix()
        for a in reversed(explored[-_SIBLINGS:]):
            if math.dist(pts[a], pts[b]) > _SIBLING_RADIUS or dg[b] <= r1t < dg[a]:
                continue
            if P and np.any(linked[b, P] & ~linked[a, P]):
                continue
            if new_b & ~bits[a]:
                # not a cover of b's new users: compare counts instead. A completion site
                # that does not overlap a covers users of a only in a lens at the edge of
                # a's disc (sites within 2 R_d of a); a keeps every other user of its own
                lens = 0
                for s in lens_sites(a).tolist():
                    if cm[s]:
                        lens |= bits[s]
                if (bits[a] & ~ubits & ~lens).bit_count() < new_b.bit_count():
                    continue
            e = cm & (conflict[a] | (linked[b] & ~linked[a]))
            count = int(np.count_nonzero(e))
            if count == 0:
                return True
            if best is None or count < best_count:
                best, best_count = e, count
        return best

    def connecting(R: list[int], C: np.ndarray, reach: np.ndarray | None = None) -> np.ndarray:
        """(|C|,) bool: R + q is connected (the link tests of ``evaluate``) for q in C;
        ``reach`` is ``reach_of(R)`` when the caller has it already."""
        if not R:
            return dg[C] <= r1t
        pr = pts[R]
        reach = reach_of(R) if reach is None else reach
        link = pairwise_distances(pr, pts[C]) <= r2t
        rq = (dg[C] <= r1t) | np.any(link & reach[:, None], axis=0)
        if reach.all():
            return rq
        adj = pairwise_distances(pr, pr) <= r2t
        R2 = reach[:, None] | (link & rq[None, :])
        for _ in range(len(R)):
            nr = R2 | np.any(adj[:, :, None] & R2[None, :, :], axis=1)
            if np.array_equal(nr, R2):
                break
            R2 = nr
        return rq & R2.all(axis=0)

    def local_search(X: list[int]) -> None:
        """Primal heuristic (no effect on exactness): replace one site of X by the candidate
        that covers most, keeping X feasible, while that improves; the result becomes the
        incumbent only after ``evaluate`` confirms it."""
        cur = int(_popcount_rows(np.bitwise_or.reduce(packed[X], axis=0)[None, :])[0]) if X else 0
        for _ in range(50):
            if expired():
                break
            moved = False
            for i in range(len(X) + (len(X) < m)):
                R = X[:i] + X[i + 1 :]
                mask = ~np.any(conflict[R], axis=0) if R else np.ones(n, dtype=bool)
                mask[R] = False
                C = np.flatnonzero(mask)
                if len(C) == 0:
                    continue
                covR = (
                    np.bitwise_or.reduce(packed[R], axis=0) if R else np.zeros(packed.shape[1], packed.dtype)
                )
                valR = int(_popcount_rows(covR[None, :])[0])
                gain = _popcount_rows(packed[C] & ~covR)
                good = np.flatnonzero(valR + gain > cur)
                if len(good) == 0:
                    continue
                good = good[connecting(R, C[good])]
                if len(good) == 0:
                    continue
                q = int(C[good[np.argmax(gain[good])]])
                X, cur, moved = [*R, q], valR + int(gain[good].max()), True
                break
            if not moved:
                break
        ev = evaluate(problem, pts[X])
        if ev.feasible and ev.covered > state.best_val:
            state.best_val, state.best = int(ev.covered), list(X)

    def exchange(X: list[int]) -> None:
        """Primal heuristic (no effect on exactness): for every set D of 1 or 2 sites of
        the incumbent X, search all completions of X - D exactly (the search below, rooted
        at X - D) for one better than the incumbent; repeat from each improvement."""
        improved = True
        while improved and not expired():
            improved = False
            for k in (1, 2):
                for D in itertools.combinations(range(len(X)), k):
                    R = sorted(X[i] for i in range(len(X)) if i not in D)
                    mask = ~np.any(conflict[R], axis=0) if R else np.ones(n, dtype=bool)
                    mask[R] = False
                    ub = 0
                    for i in R:
                        ub |= bits[i]
                    before = state.best_val
                    dfs(R, ub, mask, _close(pts[R], cg[R], r2), math.inf)
                    if state.best_val > before and state.best is not None:
                        X, improved = sorted(state.best), True
                        break
                if improved:
                    break

    def eliminate_sites(alive: np.ndarray) -> None:
        """Items 9-10: fill ``conf_bound`` from exact backhaul-free searches, then clear in
        ``alive`` every site that no placement better than the incumbent can contain."""
        if len(conf_bound) < m:  # B_1 .. B_{m-1} not given: compute them
            unlinked = _without_backhaul(problem, pts)
            conf_bound[:] = [0.0]
            # the backhaul-free searches get at most a quarter of the time left (a search cut
            # short still returns a valid bound); each one eliminates sites with the bounds
            # of the smaller ones
            t_b = time.perf_counter()
            budget = None if time_limit is None else 0.25 * (time_limit - (t_b - t0))
            for k in range(1, m):
                if expired():
                    raise _Timeout
                left = None if budget is None else max(budget - (time.perf_counter() - t_b), 0.01)
                sub = search(unlinked(k), cand, np.zeros((0, 2)), 0, time_limit=left, free_bounds=conf_bound)
                conf_bound.append(sub.bound)
        alive &= w + conf_bound[m - 1] > state.best_val  # item 10, first test
        for _ in range(4):  # item 10, probes, until no site is cleared
            cleared = 0
            for c in np.flatnonzero(alive).tolist():
                cm = alive & ~conflict[c]
                cm[c] = False
                if dfs([c], bits[c], cm, cg[[c]], math.inf, probe=True) is None:
                    alive[c] = False
                    cleared += 1
            if cleared == 0:
                break

    start = []
    for p0 in best_pos:
        hit = np.flatnonzero(np.hypot(*(pts - p0).T) <= 1e-3)
        if len(hit):
            start.append(int(hit[0]))
    if heuristics and len(start) == len(best_pos):
        local_search(sorted(set(start)))
        if state.best is None:
            state.best = sorted(set(start))
        with contextlib.suppress(_Timeout):
            exchange(state.best)

    def open_bound() -> float:
        """After a time-out: the bound on the placements not searched (``upper`` when the
        main search had not started)."""
        return float(upper) if state.frontier is None else float(min(state.frontier, upper))

    root_mask = np.ones(n, dtype=bool)
    proven = True
    elimination_time = 0.0
    if not main:
        found = pts[state.best] if state.best is not None else best_pos
        return BnbResult(found, int(state.best_val), float(upper), False, int(state.nodes))
    try:
        if eliminate and m >= 3:
            t_el = time.perf_counter()
            try:
                eliminate_sites(root_mask)
            finally:
                elimination_time = time.perf_counter() - t_el
        if workers > 1 and m >= 3 and n >= _SPLIT_MIN_SITES and _can_fork():

            def search_share(index: int) -> tuple[bool, float, list[int] | None, int, int, int]:
                split[:] = [index, workers, 1 if m >= 4 else 0]
                done = True
                in_main[0] = True
                try:
                    dfs([], 0, root_mask, np.zeros(0), float(upper))
                except _Timeout:
                    done = False
                bound_i = float(state.best_val) if done else max(state.best_val, open_bound())
                own = None if state.best is None else int(evaluate(problem, pts[state.best]).covered)
                return done, bound_i, state.best, -1 if own is None else own, state.nodes, state.separated

            nodes_before, separated_before = state.nodes, state.separated
            shares = _split_root(search_share, workers, state.best_val, shared)
            for _, _, placement, value, _, _ in shares:
                if placement is not None and value > state.best_val:
                    state.best_val, state.best = value, placement
            state.nodes = nodes_before + sum(sh[4] - nodes_before for sh in shares)
            state.separated = separated_before + sum(sh[5] - separated_before for sh in shares)
            if not all(sh[0] for sh in shares):
                state.frontier = max(sh[1] for sh in shares)
                raise _Timeout
        else:
            in_main[0] = True
            dfs([], 0, root_mask, np.zeros(0), float(upper))
    except _Timeout:
        proven = False
    bound = float(state.best_val) if proven else max(float(state.best_val), open_bound())
    bound = min(bound, float(upper)) if upper < math.inf else bound
    if state.best is not None:
        best_pos = pts[state.best]
    return BnbResult(
        best_pos,
        int(state.best_val),
        bound,
        proven,
        int(state.nodes),
        eliminated=int(n - root_mask.sum()),
        elimination_time=elimination_time,
        separated=int(state.separated),
    )


def _check_memory(n: int) -> None:
    """Refuse up front a search whose dense (n, n) conflict and link matrices (1 byte per
    entry each) would not fit in this machine's memory, naming the size asked for."""
    need = 2.0 * n * n
    try:
        avail = float(os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES"))
    except (AttributeError, ValueError, OSError):  # not knowable here: let the search try
        return
    if need > avail:
        raise ValueError(
            f"problem: the branch and bound would hold two dense {n} x {n} site matrices "
            f"({need / 2**30:.1f} GiB), more than this machine's memory ({avail / 2**30:.1f} GiB); "
            "use engine='milp' or fewer candidate sites"
        )


_CHECK_EVERY = 256
"""Search nodes between two checks of the limits (and shares of the incumbent value)."""

_SPLIT_MIN_SITES = 1000
"""Candidates from which ``search(workers > 1)`` splits the root (on smaller
instances starting processes costs more than the search)."""


def _can_fork() -> bool:
    """True when worker processes can be forked here (a 'fork' start method, and this
    process is not itself a daemonic worker, which may not have children)."""
    return "fork" in multiprocessing.get_all_start_methods() and not multiprocessing.current_process().daemon


def _split_root(search_share, workers: int, incumbent: int, shared: list) -> list:
    """Run ``search_share(i)`` for i < ``workers`` in forked processes; return their results.

    Each worker walks the tree down to the split depth (the root's children for m >= 4,
    the root for m = 3) and, at every node there, searches the children at positions i,
    i + workers, ... of the node's candidate list. That list is the same in every worker
    up to where a worker with a better incumbent cuts it (item 4 keeps a prefix), so
    every child belongs to one worker, and a node pruned by one worker holds nothing
    better than its incumbent. Item 11 stays exact across workers: every worker passes
    every child in the same order, and each sibling's subtree is searched by the worker
    that owns it against an incumbent no better than the final one. The workers share
    the incumbent value through ``shared`` (filled here with the synchronised value)
    every ``_CHECK_EVERY`` nodes."""
    ctx = multiprocessing.get_context("fork")
    value = ctx.Value("i", int(incumbent))
    shared[:] = [value]
    results = ctx.Queue()

    def run(index: int) -> None:
        results.put((index, search_share(index)))

    procs = [ctx.Process(target=run, args=(i,), daemon=True) for i in range(workers)]
    for proc in procs:
        proc.start()
    out: dict[int, tuple] = {}
    try:
        while len(out) < workers:
            try:
                index, share = results.get(timeout=1.0)
                out[index] = share
            except queue.Empty:
                if any(p.exitcode not in (None, 0) for p in procs):
                    raise RuntimeError("a branch-and-bound worker process failed") from None
    finally:
        for proc in procs:
            proc.join(timeout=5.0)
            if proc.is_alive():
                proc.terminate()
        shared.clear()
    return [out[i] for i in range(workers)]


def _separated_groups(  # noqa: C901, PLR0915
    pts: np.ndarray,
    w: np.ndarray,
    dg: np.ndarray,
    P: list[int],
    dpp: np.ndarray,
    reach: np.ndarray,
    cmask: np.ndarray,
    r: int,
    tops: list[int],
    r1t: float,
    r2t: float,
    links: np.ndarray | None = None,
) -> float:
    """Item 12: an upper bound on sum_{q in Q} w[q] over the completions Q (at most r
    sites of ``cmask``) that connect the placement P, when the unreached groups of P are
    at most 3 and pairwise more than 2 r2t apart (else math.inf; the successors are
    charged beyond 3 r2t only); -math.inf when no Q can.

    pts (n, 2) sites (m), w (n,) their weights, dg (n,) their distances to the nearest
    GBS (m); P: indices of the placed sites, dpp their (|P|, |P|) distances (m), reach
    (|P|,) which of them reach a GBS through P; tops: r values, the i-th bounding the
    i-th heaviest completion site outside the bridge and successor slots; r1t, r2t: the
    link ranges with tolerance (m); links: ``_link_rows(pts, r2t)`` (built here if None)."""
    un = np.flatnonzero(~reach)
    link = dpp[np.ix_(un, un)] <= r2t
    group = np.full(len(un), -1)
    k = 0
    for seed in range(len(un)):
        if group[seed] >= 0:
            continue
        group[seed] = k
        todo = [seed]
        while todo:
            a = todo.pop()
            for c in np.flatnonzero(link[a] & (group < 0)).tolist():
                group[c] = k
                todo.append(c)
        k += 1
    if k > 3:
        return math.inf
    members = [un[group == g] for g in range(k)]
    apart = min(
        (dpp[np.ix_(members[g1], members[g2])].min() for g1, g2 in itertools.combinations(range(k), 2)),
        default=math.inf,
    )
    if apart <= 2 * r2t:
        return math.inf
    full = np.flatnonzero(cmask)
    if len(full) == 0:
        return -math.inf
    pf = pts[full]
    in_l = dg[full] <= r1t  # L: linkable (direct or linked to a reached P site)
    if reach.any():
        pr = pts[[P[i] for i in np.flatnonzero(reach).tolist()]]
        d_r = pairwise_distances(pr, pf)
        in_l |= np.any(d_r <= r2t, axis=0)

    wf = w[full].astype(float)

    def heaviest(mask: np.ndarray) -> float:
        return float(wf[mask].max()) if mask.any() else -math.inf

    w_l = heaviest(in_l)
    if w_l == -math.inf:
        return -math.inf  # item 6: no completion site can link to a GBS
    d_to = []  # (k, |full|): distance of each site to each group (m)
    for g in members:
        pg = pts[[P[i] for i in g.tolist()]]
        d_to.append(pairwise_distances(pg, pf).min(axis=0))
    bridge_l, bridge_n, succ_to = [], [], []
    for g in range(k):
        near = d_to[g] <= r2t
        if not near.any():
            return -math.inf  # item 5: the group cannot be reached
        bridge_l.append(heaviest(near & in_l))
        bridge_n.append(heaviest(near & ~in_l))
        # the successor is linked to a bridge outside L, so within 2 r2t of the group
        two = d_to[g] <= 2 * r2t
        if apart > 3 * r2t:
            if links is None:
                links = _link_rows(pts, r2t)
            two &= _linked_to(links, full, full[near & ~in_l])
        succ_to.append(two)
    if apart <= 3 * r2t:  # a successor may be another group's bridge: count the bridges only
        if k > r:
            return -math.inf
        return sum(max(bridge_l[g], bridge_n[g]) for g in range(k)) + sum(tops[: r - k])
    best = -math.inf
    for outside in itertools.product((False, True), repeat=k):
        slots = k + any(outside)
        if slots > r:
            continue
        # -inf where a group has no bridge of the kind ``outside`` asks for
        base = sum(bridge_n[g] if outside[g] else bridge_l[g] for g in range(k))
        far = [g for g in range(k) if outside[g]]
        if not far:
            best = max(best, base + sum(tops[: r - k]))
            continue
        if slots == r:
            # Q is the bridges and one site v: the successor of every group in ``far``, so
            # linked to a bridge of each; it ends their paths, so it is in L or linked to a
            # bridge in L (within 2 r2t of a group not in ``far``)
            v = np.logical_and.reduce([succ_to[g] for g in far]) & in_l
            for h in range(k):
                if not outside[h]:
                    v |= np.logical_and.reduce([succ_to[g] for g in far]) & (d_to[h] <= 2 * r2t)
            best = max(best, base + heaviest(v))
            continue
        w_s = max(heaviest(succ_to[g]) for g in far)
        if len(far) < k:  # some bridge is in L; the successor may lie anywhere
            best = max(best, base + w_s + sum(tops[: r - slots]))
        else:  # no bridge in L: the successor or another completion site is in L (item 6)
            w_sl = max(heaviest(succ_to[g] & in_l) for g in far)
            opts = [w_sl + sum(tops[: r - slots]), w_s + w_l + sum(tops[: r - slots - 1])]
            best = max(best, base + max(opts))
    return float(best)


def _link_rows(pts: np.ndarray, reach: float) -> np.ndarray:
    """(n, ceil(n / 8)) uint8: row i holds bit j (little-endian packing) when sites i and
    j of ``pts`` ((n, 2) m) are within ``reach`` (m) of each other."""
    n = len(pts)
    out = np.zeros((n, (n + 7) // 8), dtype=np.uint8)
    for lo in range(0, n, 512):
        part = pts[lo : lo + 512]
        d = pairwise_distances(part, pts)
        out[lo : lo + 512] = np.packbits(d <= reach, axis=1, bitorder="little")
    return out


def _linked_to(links: np.ndarray, sites: np.ndarray, q: np.ndarray) -> np.ndarray:
    """(len(sites),) bool: which of the sites (indices) are linked to some site of q
    (indices), by the rows ``links`` of ``_link_rows``."""
    if len(q) == 0:
        return np.zeros(len(sites), dtype=bool)
    row = np.bitwise_or.reduce(links[q], axis=0)
    return np.unpackbits(row, count=len(links), bitorder="little").astype(bool)[sites]


def _through(
    dist: np.ndarray, *, gj_direct: np.ndarray, ej: np.ndarray, epp: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Item 3 for P + j, vectorised over candidates j: shortest relay counts in the
    complete graph on the GBSs, P and j. ``dist`` (|P|,) holds them for P alone (closed
    over P), ``gj_direct`` (|C|,) the GBS -> j costs, ``ej`` (|P|, |C|) the P -> j costs,
    ``epp`` (|P|, |P|) the P -> P costs. Returns (gj, newd): GBS -> j and GBS -> each P
    site, every path through j included (relaxed to closure: a path may enter j and then
    pass through further P sites)."""
    gj = np.minimum(gj_direct, np.min(dist[:, None] + ej, axis=0))
    newd = np.minimum(dist[:, None], gj[None, :] + ej)
    for _ in range(len(dist)):
        nd = np.minimum(newd, np.min(newd[:, None, :] + epp[:, :, None], axis=0))
        if np.array_equal(nd, newd):
            break
        newd = nd
    return gj, newd


def _close(pp: np.ndarray, dist: np.ndarray, r2: float) -> np.ndarray:
    """Shortest relay counts from a GBS to each of the sites ``pp`` given their direct
    estimates ``dist``: relax through the complete graph of link costs (item 3)."""
    k = len(pp)
    if k <= 1:
        return dist
    e = _relay_cost(pairwise_distances(pp, pp), r2, r2)
    d = dist.copy()
    for _ in range(k):
        nd = np.minimum(d, np.min(d[:, None] + e, axis=0))
        if np.array_equal(nd, d):
            break
        d = nd
    return d


_SIBLINGS = 16
"""Item 11: explored siblings tried as replacements of a new child (the latest ones)."""
_SIBLING_RADIUS = 600.0
"""Item 11: only siblings this close (m) are tried; farther ones rarely qualify."""
_MUST_BRANCH = 32
"""Item 11: a node whose completions must hold one of at most this many sites branches
on those sites (``must_branch``) instead of on its heaviest candidates."""


def _without_backhaul(problem: CellProblem, pts: np.ndarray):
    """k -> the problem with k drone-cells whose backhaul ranges reach every candidate
    site from every GBS and from each other (the relaxation of items 9-10; users, radii,
    GBS cells and bounds unchanged)."""
    span = float(np.linalg.norm(pts[:, None, :] - problem.gbs[None, :, :], axis=2).max())
    reach = 3.0 * span + problem.r1 + problem.r2

    def with_cells(k: int) -> CellProblem:
        return CellProblem(
            users=problem.users,
            gbs=problem.gbs,
            n_cells=k,
            R_d=problem.R_d,
            R_g=problem.R_g,
            r1=reach,
            r2=reach,
            bounds=problem.bounds,
        )

    return with_cells
