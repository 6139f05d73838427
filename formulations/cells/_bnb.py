"""Exact combinatorial branch and bound over the candidate sites (thesis ch. 4).

Solves the same *candidate problem* as the MILP of ``_milp`` (choose at most m candidate
sites, pairwise non-overlapping, every one linked to a GBS through chosen sites, maximise
the users covered) by depth-first enumeration with exact pruning. Every placement X is
enumerated as the sequence of its sites in one fixed order (weight |S(c)| descending,
ties by index), so each X is reached from exactly one branch; a branch is cut only when
a valid upper bound on everything below it is <= the incumbent value, so the search
proves optimality when it ends.

This module holds the search (:class:`BranchAndBoundSearch`: its state, the node loop,
the incumbent, the bound, the time limit and the worker split). The bound and pruning rules
are functions of their own modules, each with the argument that makes it exact in its
docstring (the measurements that chose between the options, per-seed timings and
proof-search logs, are on the page ``docs/findings/cells-bnb.md``):

- items 1, 2, 4, 5, 6, 8 and 9 (the additive bound, the clique partition, the order cut, the
  bridge slot, the linkable slot, two relay slots, the backhaul-free bounds B_k) and the node
  bound that combines every rule: ``_bnb_bounds`` (the clique partition itself is built in
  ``_bnb_sites.clique_partition``);
- item 3 (the relay lower bound): ``_bnb_relays``;
- item 7 (the greedy dual of coverage): ``_bnb_dual``;
- items 9 and 14 (the backhaul-free searches, the backhaul-free completion below a node):
  ``_bnb_relaxed``;
- items 10 and 13 (site elimination by probes, dominated sites): ``_bnb_elimination``;
- item 11 (sibling replacement): ``_bnb_siblings``;
- item 12 (far-apart unreached groups): ``_bnb_groups``;
- the primal heuristics: ``_bnb_heuristics``; the sites, nodes and link tests:
  ``_bnb_sites``.

With ``workers`` > 1 the search is split over forked processes (``_split_root``): each
takes its share of the children of every node at depth 1 (m >= 4), so one heavy root
child does not stay on one core.

The last two slots are enumerated without a search node per site (the same tests,
vectorised over the candidates). Two primal heuristics improve the start before the
search: a 1-swap local search, then an exchange search that re-solves exactly (with the
search below, rooted there) every incumbent minus 1 or 2 of its sites (minus 3 as well in
the polish of ``_exact``, ``exchange_sizes``). Both only propose
placements, checked with ``evaluate`` before they become the incumbent; exactness rests
on the bounds alone.

The search stops at the time limit with the incumbent and a valid bound: every
unexplored placement lies below the current or a later child of a node on the current
path, so it is bounded by that node's bound and (children come in weight order, item 4)
by |S(P)| + r |S(j)| for the current child j; the largest of these level bounds over the
path is reported (with workers, the largest over the workers).
"""

from __future__ import annotations

import functools
import math
import multiprocessing
import os
import queue
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np

from droneplan.core.validation import check_work, machine_memory
from droneplan.formulations.cells._bnb_bounds import node_bound
from droneplan.formulations.cells._bnb_elimination import drop_dominated, eliminate_sites
from droneplan.formulations.cells._bnb_heuristics import improve_start
from droneplan.formulations.cells._bnb_leaves import last_pair, last_site
from droneplan.formulations.cells._bnb_relaxed import free_completion
from droneplan.formulations.cells._bnb_relays import _close, _relay_cost
from droneplan.formulations.cells._bnb_siblings import must_branch, replaced_by_sibling
from droneplan.formulations.cells._bnb_sites import (
    Children,
    LinkRows,
    Node,
    SearchView,
    Sites,
    _Timeout,
    _Witness,
    build_sites,
    placed,
    shares_sites,
)
from droneplan.formulations.cells._core import TOL, Candidates, evaluate, pairwise_distances
from droneplan.scenarios.cells import CellProblem


class Peer(Protocol):
    """Another engine solving the same candidate problem beside the search (``_portfolio``)."""

    def best_value(self) -> int:
        """Users covered by the best feasible placement the peer has found so far."""
        ...

    def finished(self) -> bool:
        """True once the peer has proved its placement optimal."""
        ...


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
    """Candidate sites cleared before the search (items 10 and 13)."""
    dominated: int = 0
    """Of those, sites cleared as dominated (item 13)."""
    elimination_time: float = 0.0
    """Seconds spent on items 9-10 (the backhaul-free searches and the site tests)."""
    separated: int = 0
    """Node bounds that item 12 (far-apart unreached groups) lowered."""
    built: bool = True
    """False when the time limit passed while the site relations were built: nothing ran."""


@dataclass
class _Share:
    """What one worker of the split search hands back (``_split_root``)."""

    done: bool
    bound: float
    placement: list[int] | None
    value: int
    nodes: int
    separated: int


class BranchAndBoundSearch:
    """The search of the module docstring with its state on the object.

    The sites are held in the search's order (``_bnb_sites.Sites``: ``order``, ``pts`` (n, 2) m,
    ``w`` (n,) weights, ``bits``, ``packed``, ``tree``, ``clique``, ``conflict``), with ``dg`` the
    distance to the nearest GBS (m) and ``cg`` its relay lower bound (item 3). The search state
    is ``best_val``/``best`` (the incumbent, as site indices), ``nodes``, ``separated``
    (item 12 counts), ``stack_bounds`` (the level bounds of the current path), ``frontier``
    (the bound on the unsearched placements after a time-out) and ``conf_bound`` (item 9's B_k).

    The rules are functions of the ``_bnb_*`` modules that read the search (as a
    ``_bnb_sites.SearchView``) and a :class:`Node`, so a test can call one alone; :meth:`node`
    builds the node of any placement P for such tests.

    problem: the CellProblem; cand: its candidate sites; incumbent_value: users the
    incumbent covers; upper: a known upper bound; time_limit: seconds from ``t0``
    (None: none); node_limit: stop after about this many nodes; free_bounds: item 9's
    B_0, ..., B_{m-1} when known; t0: ``time.perf_counter()`` at the start of the
    solve (default: now); parent: a search over the same ``cand`` (the same object) and
    users whose site structures (order, user sets, cliques, conflicts) this one shares
    instead of building copies (item 9's backhaul-free searches).
    """

    exchange_sizes: tuple[int, ...] = (1, 2)
    """Sizes of the site sets that the exchange heuristic takes out of the incumbent."""

    def __init__(
        self,
        problem: CellProblem,
        cand: Candidates,
        incumbent_value: int,
        *,
        upper: float = math.inf,
        time_limit: float | None = None,
        node_limit: int | None = None,
        free_bounds: list[float] | None = None,
        t0: float | None = None,
        parent: BranchAndBoundSearch | None = None,
    ) -> None:
        self.t0 = time.perf_counter() if t0 is None else t0
        self.problem = problem
        self.cand = cand
        self.n = len(cand.points)
        # a placement holds distinct candidate sites, so no more than n of them (exact)
        self.m = min(problem.n_cells, self.n)
        self.upper = upper
        self.time_limit = time_limit
        self.node_limit = node_limit
        self.r2 = problem.r2
        self.r1t, self.r2t = problem.r1 + TOL, problem.r2 + TOL
        # the same sites in the same order: share the parent's structures (item 9's searches)
        sites: Sites | None = (
            parent.sites if parent is not None and shares_sites(parent, problem, cand) else None
        )
        self.sites: Sites = build_sites(problem, cand, self.out_of_time) if sites is None else sites
        self.order, self.pts, self.w = self.sites.order, self.sites.pts, self.sites.w
        self.bits, self.packed, self.tree = self.sites.bits, self.sites.packed, self.sites.tree
        self.clique, self.conflict = self.sites.clique, self.sites.conflict
        self.dg = np.min(pairwise_distances(self.pts, problem.gbs), axis=1)
        # every two sites linked (item 9's searches): the link relations are never built
        # and the link tests of items 11-12 hold trivially
        span = float(np.hypot(*np.ptp(self.pts, axis=0))) if self.n else 0.0  # >= every site distance
        self.all_linked = bool(self.r2t >= span and float(self.dg.max(initial=0.0)) <= self.r1t)
        self.cg = _relay_cost(self.dg, problem.r1, problem.r2)  # item 3, GBS -> site
        # the search state
        self.best_val = int(incumbent_value)
        self.best: list[int] | None = None
        self.nodes = 0
        self.separated = 0
        self.frontier: float | None = None
        self.stack_bounds: list[float] = []
        # item 9: conf_bound[k] bounds the users any k pairwise non-overlapping candidates cover
        self.conf_bound: list[float] = list(free_bounds or [])
        self.in_main = False
        # the split: (this worker's index, workers, depth whose children are dealt out) and
        # the incumbent value the workers share (filled by ``_split_root``)
        self.split: tuple[int, int, int] = (0, 1, 0)
        self.shared: list = []
        self._links: LinkRows | None = None
        self.lens: dict[int, np.ndarray] = {}  # item 11: the lens sites of each site asked for, kept
        self.witness = False  # stop at the first placement better than the incumbent (item 14)
        self.dual_from: float = 3  # item 7 at nodes with this many free slots or more
        self.dual_runs = 0  # nodes where item 7 ran, and where it cut (the other rules had not)
        self.dual_cuts = 0
        self.free: SearchView | None = None  # item 14's relaxed search, built on first use
        self.free_cuts = 0
        # called with each new incumbent's positions (k, 2), in this process only (forked
        # workers' incumbents reach the caller with the result)
        self.on_incumbent: Callable[[np.ndarray], Any] | None = None
        self.owner = os.getpid()
        # another engine solving the same candidate problem beside this search (``_portfolio``):
        # its incumbent value raises ours, and its proof ends the search
        self.peer: Peer | None = None

    def link_rows(self) -> LinkRows:
        """The sites within r2 + TOL of each other (:class:`LinkRows`: a row is built when
        first used; items 11 and 12's exact link tests)."""
        if self._links is None:
            self._links = LinkRows(self.pts, self.r2t)
        return self._links

    def relaxed(self, problem: CellProblem) -> BranchAndBoundSearch:
        """A search of the same sites for ``problem`` (item 14's relaxed problem) with this
        one's incumbent value, site structures, start time and time limit."""
        return BranchAndBoundSearch(
            problem, self.cand, self.best_val, parent=self, t0=self.t0, time_limit=self.time_limit
        )

    def relaxed_bound(self, problem: CellProblem, time_limit: float | None) -> float:
        """The bound of the whole search (:func:`search`, no incumbent) of the same sites for
        ``problem`` within ``time_limit`` s, with this one's ``conf_bound`` (item 9)."""
        none = np.zeros((0, 2))
        return search(
            problem, self.cand, none, 0, time_limit=time_limit, free_bounds=self.conf_bound, parent=self
        ).bound

    def eliminate_sites(self, alive: np.ndarray) -> None:
        """Items 9-10 (``_bnb_elimination.eliminate_sites``) on ``alive`` (bool over the sites)."""
        eliminate_sites(self, alive)

    def drop_dominated(self, alive: np.ndarray) -> int:
        """Item 13 (``_bnb_elimination.drop_dominated``) on ``alive``; returns the sites cleared."""
        return drop_dominated(self, alive)

    def expired(self) -> bool:
        """True once the node budget or the time limit is used up, or the peer engine has proved."""
        if self.node_limit is not None and self.nodes >= self.node_limit:
            return True
        if self.peer is not None and self.peer.finished():
            return True
        return self.out_of_time()

    def out_of_time(self) -> bool:
        """True once the time limit is used up."""
        return self.time_limit is not None and time.perf_counter() - self.t0 >= self.time_limit

    def timed_out(self) -> _Timeout:
        """The time-out, raised from the main search after recording the bound of what it
        has not searched (``frontier``): every such placement lies below the current or a
        later child of a node on the path, whose level bound ``stack_bounds`` holds."""
        if self.in_main:
            self.frontier = max(self.stack_bounds, default=float(self.upper))  # empty: at the root
        return _Timeout()

    def checkpoint(self) -> bool:
        """Every ``_CHECK_EVERY`` nodes: share the incumbent value with the other workers (a
        value only: each worker keeps the placements it found) and take the peer engine's, then
        test the limits."""
        if self.peer is not None:
            self.best_val = max(self.best_val, self.peer.best_value())
        if self.shared:
            with self.shared[0].get_lock():
                if self.best_val > self.shared[0].value:
                    self.shared[0].value = self.best_val
                elif self.shared[0].value > self.best_val:
                    self.best_val = int(self.shared[0].value)
        return self.expired()

    def tick(self) -> None:
        """Count a search node; every ``_CHECK_EVERY`` nodes check the limits (and share the
        incumbent), and the clock at every node: a node's cost grows with m and the depth, so
        on a large m a few hundred nodes can take minutes."""
        self.nodes += 1
        if self.nodes % _CHECK_EVERY == 0:
            if self.checkpoint():
                raise self.timed_out()
        elif self.time_limit is not None and time.perf_counter() - self.t0 >= self.time_limit:
            raise self.timed_out()

    def open_bound(self) -> float:
        """After a time-out: the bound on the placements not searched (``upper`` when the
        main search had not started)."""
        return float(self.upper) if self.frontier is None else float(min(self.frontier, self.upper))

    def offer(self, P: list[int]) -> None:
        """Make the placement P the incumbent when ``evaluate`` finds it feasible and better."""
        ev = evaluate(self.problem, self.pts[P])
        if ev.feasible and ev.covered > self.best_val:
            self.best_val, self.best = int(ev.covered), list(P)
            if self.on_incumbent is not None and os.getpid() == self.owner:
                self.on_incumbent(self.pts[P])
            if self.witness:
                raise _Witness

    def compatible(self, R: list[int]) -> np.ndarray:
        """(n,) bool: the sites outside R that overlap no site of R."""
        mask = ~self.conflict.any_of(R)
        mask[R] = False
        return mask

    def node(self, P: list[int], cmask: np.ndarray | None = None, must: np.ndarray | None = None) -> Node:
        """The search node of the sites P (any order; for tests and the heuristics): its
        completions are ``cmask`` (default: every site after the last of P that overlaps
        none of P), ``dist`` closed over P (item 3)."""
        P = sorted(P)
        if cmask is None:
            cmask = self.compatible(P)
            cmask[: (P[-1] + 1 if P else 0)] = False
        dist = _close(self.pts[P], self.cg[P], self.r2) if P else np.zeros(0)
        return self._node(P, self.bits_of(P), cmask, dist, must)

    def _node(
        self, P: list[int], ubits: int, cmask: np.ndarray, dist: np.ndarray, must: np.ndarray | None
    ) -> Node:
        """The node of P (:class:`Node`) given what the caller has: S(P) ``ubits``, ``cmask``,
        ``dist`` (item 3) and ``must`` (item 11)."""
        if P:
            dpp, reach = placed(self, P)
        else:
            dpp, reach = np.zeros((0, 0)), np.zeros(0, dtype=bool)
        node = Node(P, ubits, cmask, dist, reach, dpp, must)
        if must is not None:
            node.cmask_must = cmask & must
        return node

    def bits_of(self, R: list[int]) -> int:
        """S(R) as a Python int bit set (R: site indices)."""
        ub = 0
        for i in R:
            ub |= self.bits[i]
        return ub

    def dfs(
        self,
        P: list[int],
        ubits: int,
        cmask: np.ndarray,
        dist: np.ndarray,
        nb: float,
        probe: bool = False,
        must: np.ndarray | None = None,
    ) -> float | None:
        """Search below the node P (``cmask``: the sites that may complete it; ``dist``:
        relay lower bounds from a GBS to P's sites, item 3; ``nb``: the parent's bound).
        With ``probe``, only bound it: the node bound, or None when no placement P + Q with
        Q from ``cmask`` covers more than the incumbent (item 10); nothing is searched.
        ``must`` (bool over the sites): only completions holding one of them (item 11)."""
        self.tick()
        node = self._node(P, ubits, cmask, dist, must)
        if node.val > self.best_val and node.reach.all():
            self.offer(P)
        r = self.m - len(P)
        if probe and r <= 1:
            return math.inf  # probes are only made with >= 2 free slots; never prune here
        if r == 0 or (node.cmask_must is not None and not node.cmask_must.any()):
            return None
        if r == 1:
            last = cmask if node.cmask_must is None else node.cmask_must
            last_site(self, P, ubits, np.flatnonzero(last), node.reach, node.val)
            return None
        kids = node_bound(self, node, nb)
        if kids is None:
            return None
        if probe:
            return kids.bound
        if r >= 3 and len(P) >= _FREE_DEPTH and not self.all_linked and free_completion(self, node) is False:
            self.free_cuts += 1  # item 14: not even the relaxed problem beats z below P
            return None
        self.stack_bounds.append(kids.bound)
        try:
            if node.cmask_must is not None and r >= 3 and int(node.cmask_must.sum()) <= _MUST_BRANCH:
                # item 11 by branching: every completion holds a site e of ``must``; search
                # P + e for each e in turn, its completions holding no earlier one
                must_branch(self, node, node.cmask_must, kids.bound)
            else:
                self.branch(node, kids)
        finally:
            self.stack_bounds.pop()
        return None

    def branch(self, node: Node, kids: Children) -> None:
        """Search the children of the node in order, heaviest first, while item 4 lets them
        beat the incumbent; the node's level bound is the last entry of ``stack_bounds``."""
        r, val = self.m - node.depth, node.val
        last_two = None
        if r == 2:  # the last two slots without a search node per first site (same test)
            full = np.flatnonzero(node.cmask)
            last_two = (full, -self.w[full])  # the second is non-decreasing
        explored: list[int] = []
        dealt = self.split[1] > 1 and node.depth == self.split[2]
        for pos, k in enumerate(kids.ok.tolist()):
            j = int(kids.C[k])
            if val + r * int(self.w[j]) <= self.best_val:
                break
            # the level bound: this child and the later ones add r sites of weight <= w[j]
            self.stack_bounds[-1] = min(kids.bound, val + r * int(self.w[j]))
            # the split: at depth split[2], worker i searches the children at positions
            # i, i + workers, ... (the same in every worker: see _split_root)
            mine = not dealt or pos % self.split[1] == self.split[0]
            if last_two is not None:
                if mine:
                    last_pair(self, node, j, last_two, explored)
            else:
                self.child(node, kids, k, mine, explored)
            explored.append(j)

    def child(self, node: Node, kids: Children, k: int, mine: bool, explored: list[int]) -> None:
        """The child P + j (j = ``kids.C[k]``) of a node with three or more free slots:
        item 11 against its siblings, then the search below it when this worker owns it."""
        j = int(kids.C[k])
        cm = node.cmask & ~self.conflict.row(j)
        cm[: j + 1] = False
        must = node.must
        child_must = None if must is None or must[j] else must
        if must is None or child_must is not None:  # item 11
            # under ``must`` only for j outside it: the child keeps the smaller of the two
            # sets (each drops only completions held by an earlier child)
            replace = replaced_by_sibling(self, node.P, node.ubits, j, cm, explored)
            if replace is True:
                return
            if isinstance(replace, np.ndarray) and (
                child_must is None or np.count_nonzero(replace & cm) < np.count_nonzero(child_must & cm)
            ):
                child_must = replace
        if not mine:
            return
        P = node.P
        nd = np.append(kids.newd[:, k], kids.gj[k]) if P else np.array([kids.gj[k]])
        # shortest paths can only shorten further inside P + j: recompute exactly
        pj = [*P, j]
        self.dfs(
            pj, node.ubits | self.bits[j], cm, _close(self.pts[pj], nd, self.r2), kids.bound, must=child_must
        )

    def _search_share(self, index: int, *, workers: int, root: np.ndarray) -> _Share:
        """One worker's share of the split search (``_split_root``)."""
        self.split = (index, workers, 1 if self.m >= 4 else 0)
        done = True
        self.in_main = True
        try:
            self.dfs([], 0, root, np.zeros(0), float(self.upper))
        except _Timeout:
            done = False
        bound = float(self.best_val) if done else max(self.best_val, self.open_bound())
        own = None if self.best is None else int(evaluate(self.problem, self.pts[self.best]).covered)
        return _Share(done, bound, self.best, -1 if own is None else own, self.nodes, self.separated)

    def split_search(self, root: np.ndarray, workers: int) -> None:
        """The main search over ``workers`` forked processes; raises ``_Timeout`` (with
        ``frontier`` set) when one of them stopped at the limit."""
        nodes_before, separated_before = self.nodes, self.separated
        share = functools.partial(self._search_share, workers=workers, root=root)
        shares: list[_Share] = _split_root(share, workers, self.best_val, self.shared)
        for sh in shares:
            if sh.placement is not None and sh.value > self.best_val:
                self.best_val, self.best = sh.value, sh.placement
        self.nodes = nodes_before + sum(sh.nodes - nodes_before for sh in shares)
        self.separated = separated_before + sum(sh.separated - separated_before for sh in shares)
        if not all(sh.done for sh in shares):
            self.frontier = max(sh.bound for sh in shares)
            raise _Timeout

    def run(
        self, incumbent: np.ndarray, *, eliminate: bool, heuristics: bool, workers: int, main: bool
    ) -> BnbResult:
        """The whole search (:func:`search`'s parameters) from the placement ``incumbent``."""
        if heuristics:
            improve_start(self, incumbent)
        if not main:
            found = self.pts[self.best] if self.best is not None else incumbent
            return BnbResult(found, int(self.best_val), float(self.upper), False, int(self.nodes))
        root = np.ones(self.n, dtype=bool)
        proven = True
        elimination_time = 0.0
        dominated = 0
        try:
            if eliminate and self.m >= 3:
                t_el = time.perf_counter()
                try:
                    eliminate_sites(self, root)
                    dominated = drop_dominated(self, root)
                finally:
                    elimination_time = time.perf_counter() - t_el
            if workers > 1 and self.m >= 3 and self.n >= _SPLIT_MIN_SITES and _can_fork():
                self.split_search(root, workers)
            else:
                self.in_main = True
                self.dfs([], 0, root, np.zeros(0), float(self.upper))
        except _Timeout:
            proven = False
        bound = float(self.best_val) if proven else max(float(self.best_val), self.open_bound())
        bound = min(bound, float(self.upper)) if self.upper < math.inf else bound
        return BnbResult(
            self.pts[self.best] if self.best is not None else incumbent,
            int(self.best_val),
            bound,
            proven,
            int(self.nodes),
            eliminated=int(self.n - root.sum()),
            elimination_time=elimination_time,
            separated=int(self.separated),
            dominated=dominated,
        )


def search(
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
    parent: BranchAndBoundSearch | None = None,
    exchange_sizes: tuple[int, ...] | None = None,
    on_incumbent: Callable[[np.ndarray], Any] | None = None,
    peer: Peer | None = None,
) -> BnbResult:
    """Exact search of the candidate problem (module docstring; the state lives on a
    :class:`BranchAndBoundSearch`).

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
    engine a start. parent: a search over the same ``cand`` whose site structures this one
    shares (item 9's searches). exchange_sizes: the sizes of the site sets the exchange
    heuristic takes out of the incumbent (None: ``BranchAndBoundSearch.exchange_sizes``).
    on_incumbent: called with the positions ((k, 2) m) of each new incumbent the search finds in
    this process (an anytime trace; those of forked workers come back with the result).
    peer: another engine on the same candidate problem (``_portfolio``): every ``_CHECK_EVERY``
    nodes the search takes its incumbent value (exact: a value some feasible placement covers, so
    pruning what cannot beat it loses no better placement; the placement itself is the peer's)
    and stops, unproven, once the peer has proved.
    """
    t0 = time.perf_counter()
    n = len(cand.points)
    best_pos = np.asarray(incumbent, dtype=float).reshape(-1, 2)
    best_val = int(incumbent_value)
    if n == 0 or problem.n_cells == 0 or best_val >= upper:
        return BnbResult(best_pos, best_val, float(min(upper, best_val) if n == 0 else upper), True, 0)
    _check_memory(n)
    # a node's bounds (item 7's greedy sets over every candidate) handle about m n elements
    check_work("n_cells", float(min(problem.n_cells, n)) * n, "elements")
    try:
        bb = BranchAndBoundSearch(
            problem,
            cand,
            best_val,
            upper=upper,
            time_limit=time_limit,
            node_limit=node_limit,
            free_bounds=free_bounds,
            t0=t0,
            parent=parent,
        )
    except _Timeout:  # the time limit passed while the site relations were built: nothing searched
        return BnbResult(best_pos, best_val, float(upper), False, 0, built=False)
    if exchange_sizes is not None:
        bb.exchange_sizes = tuple(exchange_sizes)
    bb.on_incumbent = on_incumbent
    bb.peer = peer
    return bb.run(best_pos, eliminate=eliminate, heuristics=heuristics, workers=workers, main=main)


def relation_bytes(n: int) -> float:
    """Bytes the search's two site relations over ``n`` candidates take (conflict and link, as
    packed bit rows of ceil(n / 8) bytes)."""
    return 2.0 * n * ((n + 7) // 8)


def relations_fit(n: int, share: float = 1.0) -> bool:
    """True when the search's site relations over ``n`` candidates (``relation_bytes``) take
    at most ``share`` of this machine's memory, or when that memory is not knowable here."""
    avail = machine_memory()
    return avail is None or relation_bytes(n) <= share * avail


def _check_memory(n: int) -> None:
    """Refuse up front a search whose conflict and link relations (``relation_bytes``) would
    not fit in this machine's memory, naming the size asked for."""
    if not relations_fit(n):
        need, avail = relation_bytes(n), machine_memory() or 0.0
        raise ValueError(
            f"problem: the branch and bound would hold two {n} x {n} site relations as bit rows "
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


_FREE_DEPTH = 1
"""Item 14: the relaxed completion search runs at nodes of at least this depth."""

_MUST_BRANCH = 32
"""Item 11: a node whose completions must hold one of at most this many sites branches
on those sites (``must_branch``) instead of on its heaviest candidates."""
