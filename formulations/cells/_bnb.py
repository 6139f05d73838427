"""Exact combinatorial branch and bound over the candidate sites (thesis ch. 4).

Solves the same *candidate problem* as the MILP of ``_milp`` (choose at most m candidate
sites, pairwise non-overlapping, every one linked to a GBS through chosen sites, maximise
the users covered) by depth-first enumeration with exact pruning. Every placement X is
enumerated as the sequence of its sites in one fixed order (weight |S(c)| descending,
ties by index), so each X is reached from exactly one branch; a branch is cut only when
a valid upper bound on everything below it is <= the incumbent value, so the search
proves optimality when it ends.

Why each element is exact (the measurements that chose between the options, per-seed
timings and proof-search logs, are on the page ``docs/findings/cells-bnb.md``):

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
   the gains as well. Used at nodes with >= 3 free slots (at 2 it cost more than it cut),
   and only where the other rules did not cut the node (it is the costliest: a node's bound
   is the least of all the rules either way).
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
   bounds of the smaller ones and eliminates sites in the same way.
   The probes (``probe_sites``) leave item 7 out once it has cut under 1 % of the first
   ``_DUAL_TRIAL``, and a repeated round probes only the sites whose last bound came within
   ``_REPROBE_MARGIN`` of z (a probe only ever drops sites, so probing fewer keeps it exact).

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
   600 m are tried. Clusters give many near-identical sites, and without this rule each of
   them repeats a nearly identical subtree. The sibling tests
   use the link matrix (``link_matrix``) and, for the lens, the sites within 2 R_d + 2 m of
   a that do not overlap it (``lens_sites``).

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
   link to a bridge candidate is tested exactly, on packed link rows (``LinkRows``:
   each row built when first used, then kept). The successor link test runs on the
   ``_SUCCESSOR_PREFIX`` heaviest sites near a group and counts the lighter ones as linked
   (``_successor_sites``): item 12 reads only heaviest weights, which a superset can only
   raise.

13. **Dominated sites.** After item 10, let A be the sites still alive. Site d dominates
   site c when d comes before c in the search order and
   - S(c) is a subset of S(d);
   - d is direct (within r1 + TOL of a GBS) when c is;
   - every site of A (other than c and d) that does not overlap c does not overlap d;
   - every site of A (other than c and d) linked to c is linked to d.
   Set inclusion alone is not enough: d may overlap a site that c does not, or miss a
   link c has, and then swapping c for d breaks a placement; the last two conditions rule
   that out, over every site a better placement can use (item 10). Take a placement X
   of sites of A better than the incumbent that holds c. If d is not in X, X - c + d
   overlaps nothing (the third condition), every link of c is a link of d (the second and
   fourth), so it stays connected, and it covers S(X) or more (the first). If d is in X,
   X - c is connected the same way (a path through c passes through d) and covers S(X).
   Each swap moves a site to an earlier place in the order or removes one, so repeating
   them ends with a placement of the same value or better and no dominated site: clearing
   every dominated site keeps an optimal placement when one beats the incumbent. The two
   geometric conditions are tested on counts (``cKDTree`` over A): the sites overlapping
   d but not c lie at distances [2 R_d - TOL, 2 R_d - TOL + |c - d|] from c, those linked
   to c but not to d at (r2 + TOL - |c - d|, r2 + TOL]; an empty annulus (widened by
   1e-6 m) is sufficient. Pairs are sought within ``_DOMINANCE_RADIUS`` (thin annuli).

14. **Backhaul-free completion.** At a node P with r >= 3 free slots and depth >= 1,
   the search of item 9 (backhaul dropped: every site linked) is run below P itself, over
   the same completions (``cmask``, and ``must`` of item 11), with the incumbent value z
   as its incumbent; it stops at the first placement above z (``free_completion``). Every
   feasible completion of P is a completion of the relaxed problem (the same sites,
   pairwise non-overlapping, fewer constraints) covering the same users, so when that
   search ends without one, no feasible placement below P beats z and the node is cut.
   Its own rules are items 1-6 and 9-11 on the relaxed problem, exact there (item 11
   included: no earlier sibling's subtree held a placement above z, or the search would
   have stopped). A search stopped at its node budget cuts nothing.

With ``workers`` > 1 the search is split over forked processes (``_split_root``): each
takes its share of the children of every node at depth 1 (m >= 4), so one heavy root
child does not stay on one core.

The last two slots are enumerated without a search node per site (the same tests,
vectorised over the candidates). Two primal heuristics improve the start before the
search: a 1-swap local search, then an exchange search that re-solves exactly (with the
search below, rooted there) every incumbent minus 1 or 2 of its sites (minus 3 as well in
the polish of ``_exact``, ``exchange_sizes``). Both only propose
placements, checked with ``evaluate`` before they become the incumbent; exactness rests
on the bounds above alone.

The search stops at the time limit with the incumbent and a valid bound: every
unexplored placement lies below the current or a later child of a node on the current
path, so it is bounded by that node's bound and (children come in weight order, item 4)
by |S(P)| + r |S(j)| for the current child j; the largest of these level bounds over the
path is reported (with workers, the largest over the workers).
"""

from __future__ import annotations

import contextlib
import functools
import itertools
import math
import multiprocessing
import queue
import time
from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from droneplan.core.validation import check_work, machine_memory
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
    """Candidate sites cleared before the search (items 10 and 13)."""
    dominated: int = 0
    """Of those, sites cleared as dominated (item 13)."""
    elimination_time: float = 0.0
    """Seconds spent on items 9-10 (the backhaul-free searches and the site tests)."""
    separated: int = 0
    """Node bounds that item 12 (far-apart unreached groups) lowered."""
    built: bool = True
    """False when the time limit passed while the site relations were built: nothing ran."""


class _Witness(Exception):
    """Raised by a search with ``witness`` set when it finds a placement better than its
    incumbent (item 14 only asks whether one exists)."""


class _Timeout(Exception):
    """Raised inside the search when the time limit expires; caught by the solve, which then
    returns the incumbent with the bound of the unexplored branches."""


@dataclass
class Node:
    """A search node: the placed sites P (indices in the search's weight order) and what
    the bound rules read from it."""

    P: list[int]
    """Placed sites."""
    ubits: int
    """S(P) as a bit set over the users."""
    cmask: np.ndarray
    """(n,) bool: the sites that may complete P."""
    dist: np.ndarray
    """(|P|,) relay lower bound from a GBS to each site of P (item 3, closed over P)."""
    reach: np.ndarray
    """(|P|,) bool: sites of P with a link path to a GBS through P."""
    dpp: np.ndarray
    """(|P|, |P|) distances between the sites of P (m)."""
    must: np.ndarray | None = None
    """(n,) bool: completions must hold one of these sites (item 11), or None."""
    cmask_must: np.ndarray | None = None
    """``cmask & must`` (None without ``must``)."""

    @property
    def val(self) -> int:
        """|S(P)|, users covered by P."""
        return self.ubits.bit_count()

    @property
    def depth(self) -> int:
        """Placed sites so far (|P|)."""
        return len(self.P)


@dataclass
class Children:
    """A node's candidate children that pass items 3-4, and the node's bound."""

    C: np.ndarray
    """Candidates heavy enough for item 4 (indices, heaviest first)."""
    ok: np.ndarray
    """Positions in ``C`` of those that also pass the relay bound (item 3)."""
    gj: np.ndarray
    """(|C|,) relay lower bound from a GBS to each candidate j through P + j."""
    newd: np.ndarray
    """(|P|, |C|) relay lower bounds to the P sites with j added."""
    dpj: np.ndarray
    """(|P|, |C|) distances from the P sites to the candidates (m)."""
    bound: float = math.inf
    """The node bound (every rule combined)."""


@dataclass
class _Share:
    """What one worker of the split search hands back (``_split_root``)."""

    done: bool
    bound: float
    placement: list[int] | None
    value: int
    nodes: int
    separated: int


_POP8 = np.array([bin(i).count("1") for i in range(256)], dtype=np.int64)


def _popcount_rows(a: np.ndarray) -> np.ndarray:
    """Number of set bits in each row of a 2-D unsigned integer array."""
    if hasattr(np, "bitwise_count"):
        return np.bitwise_count(a).sum(axis=1, dtype=np.int64)
    return _POP8[np.ascontiguousarray(a).view(np.uint8)].sum(axis=1)


def _masked_max(values: np.ndarray, mask: np.ndarray) -> int:
    """The largest of ``values`` under the bool ``mask`` (of the same length or longer: its
    prefix is used); -1 when none."""
    sel = values[mask[: len(values)]]
    return int(sel.max()) if len(sel) else -1


def _relay_cost(d: np.ndarray, reach: float, r2: float) -> np.ndarray:
    """Lower bound on the relays needed to bridge a distance ``d`` when the first link
    reaches ``reach`` and each further link r2 (tolerances included, item 3)."""
    x = (d - reach - TOL) / (r2 + TOL) - 1e-6
    return np.maximum(np.ceil(x), 0.0)


class BitRows:
    """A symmetric (n, n) boolean relation between sites, held as packed bit rows
    (little-endian, ceil(n / 8) bytes a row: n^2 / 8 bytes in all, against n^2 for a dense
    boolean matrix).

    packed: (n, ceil(n / 8)) uint8 rows; n: number of sites."""

    def __init__(self, packed: np.ndarray, n: int) -> None:
        self.packed = packed
        self.n = n
        # unpacked rows kept once asked for, up to _ROW_CACHE_BYTES (the search asks for the
        # same sites' rows again and again: 4.2M unpacks, 33 of 430 CPU-s on m = 8 seed 3)
        self._rows: dict[int, np.ndarray] = {}
        self._rows_max = _ROW_CACHE_BYTES // max(n, 1)

    def set(self, i: np.ndarray, j: np.ndarray) -> None:
        """Relate the sites i[k] and j[k] (index arrays), in that direction only."""
        np.bitwise_or.at(self.packed, (i, j >> 3), (1 << (j & 7)).astype(np.uint8))
        self._rows.clear()

    def row(self, i: int) -> np.ndarray:
        """(n,) bool: the sites related to site i (read-only: it may be a kept copy)."""
        got = self._rows.get(i)
        if got is None:
            got = np.unpackbits(self.packed[i], count=self.n, bitorder="little").view(bool)
            got.flags.writeable = False
            if len(self._rows) < self._rows_max:
                self._rows[i] = got
        return got

    def any_of(self, rows: list[int]) -> np.ndarray:
        """(n,) bool: the sites related to some site of ``rows`` (none when it is empty)."""
        if not rows:
            return np.zeros(self.n, dtype=bool)
        merged = np.bitwise_or.reduce(self.packed[rows], axis=0)
        return np.unpackbits(merged, count=self.n, bitorder="little").view(bool)

    def at(self, i: int, cols) -> np.ndarray:
        """Bool array: whether site i is related to each of the sites ``cols`` (indices)."""
        cols = np.asarray(cols, dtype=np.int64)
        return ((self.packed[i, cols >> 3] >> (cols & 7).astype(np.uint8)) & 1).astype(bool)


class LinkRows:
    """The sites within ``reach`` (m) of each other as packed bit rows (little-endian,
    ceil(n / 8) bytes a row), each row computed on first use (the same distance test) and kept.

    Only the rows the search asks for are built: item 11 reads those of nearby siblings and
    item 12 those of bridge candidates. Building every row took 160 s and n^2 / 8 bytes
    (512 MiB) at Table 4.2 density x 4 (64k sites), before the search had used a handful.

    pts: (n, 2) site positions (m); reach: link range with its tolerance (m)."""

    def __init__(self, pts: np.ndarray, reach: float) -> None:
        self.pts = pts
        self.reach = reach
        self.n = len(pts)
        self._rows: dict[int, np.ndarray] = {}

    def __len__(self) -> int:
        return self.n

    def packed(self, i: int) -> np.ndarray:
        """(ceil(n / 8),) uint8: site i's packed row."""
        row = self._rows.get(i)
        if row is None:
            d = pairwise_distances(self.pts[[i]], self.pts)[0]
            row = self._rows[i] = np.packbits(d <= self.reach, bitorder="little")
        return row

    def __getitem__(self, q) -> np.ndarray:
        """(len(q), ceil(n / 8)) uint8: the packed rows of the sites ``q`` (indices)."""
        return np.stack([self.packed(int(i)) for i in np.asarray(q).tolist()])

    def row(self, i: int) -> np.ndarray:
        """(n,) bool: the sites linked to site i."""
        return np.unpackbits(self.packed(i), count=self.n, bitorder="little").view(bool)

    def at(self, i: int, cols) -> np.ndarray:
        """Bool array: whether site i is linked to each of the sites ``cols`` (indices)."""
        cols = np.asarray(cols, dtype=np.int64)
        return pairwise_distances(self.pts[[i]], self.pts[cols])[0] <= self.reach


class BranchAndBoundSearch:
    """The search of the module docstring with its state on the object.

    The sites are held in the search's order (weight |S(c)| descending, ties by index):
    ``pts`` (n, 2) m, ``w`` (n,) weights, ``bits`` their user sets as Python ints,
    ``packed`` the same as packed uint64 rows (item 7), ``clique`` the clique of each
    site (item 2), ``conflict`` the overlaps (4.8) as :class:`BitRows`, ``dg`` the distance to the
    nearest GBS (m) and ``cg`` its relay lower bound (item 3). The search state is
    ``best_val``/``best`` (the incumbent, as site indices), ``nodes``, ``separated``
    (item 12 counts), ``stack_bounds`` (the level bounds of the current path),
    ``frontier`` (the bound on the unsearched placements after a time-out) and
    ``conf_bound`` (item 9's B_k).

    Each bound rule is a method that reads a :class:`Node` and returns its bound, so a
    test can call one alone: :meth:`greedy_dual` (item 7), :meth:`clique_values`
    (items 2 and 4), :meth:`relay_filter` (item 3), :meth:`linkable_weight` (item 6),
    :meth:`unreached_bounds` (items 5, 8 and 12), :meth:`replaced_by_sibling` (item 11),
    :meth:`site_can_improve` (item 10), :meth:`free_completion` (item 14);
    :meth:`node_bound` combines items 1-12 with item 9.
    :meth:`node` builds the node of any placement P for such tests.

    problem: the CellProblem; cand: its candidate sites; incumbent_value: users the
    incumbent covers; upper: a known upper bound; time_limit: seconds from ``t0``
    (None: none); node_limit: stop after about this many nodes; free_bounds: item 9's
    B_0, ..., B_{m-1} when known; t0: ``time.perf_counter()`` at the start of the
    solve (default: now); parent: a search over the same ``cand`` (the same object) and
    users whose site structures (order, user sets, cliques, conflicts) this one shares
    instead of building copies (item 9's backhaul-free searches).
    """

    order: np.ndarray
    pts: np.ndarray
    w: np.ndarray
    exchange_sizes: tuple[int, ...] = (1, 2)
    """Sizes of the site sets that :meth:`exchange` takes out of the incumbent."""
    bits: list[int]
    packed: np.ndarray
    tree: cKDTree
    clique: np.ndarray
    conflict: BitRows

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
        if (
            parent is not None
            and parent.cand is cand
            and parent.problem.R_d == problem.R_d
            and np.array_equal(parent.problem.targets, problem.targets)
        ):
            # the same sites in the same order (the order and every structure below depend
            # on the sites, the users and R_d only): share them instead of building copies
            # (item 9's searches; each conflict relation is n^2 / 8 bytes)
            self.order, self.pts, self.w = parent.order, parent.pts, parent.w
            self.bits, self.packed, self.tree = parent.bits, parent.packed, parent.tree
            self.clique, self.conflict = parent.clique, parent.conflict
        else:
            w_all = np.array([len(c) for c in cand.cover], dtype=np.int64)
            self.order = np.lexsort((np.arange(self.n), -w_all))
            self.pts = cand.points[self.order]
            self.w = w_all[self.order]
            self.bits = self._user_bits()
            self.packed = self._packed_users()
            self.tree = cKDTree(self.pts)
            self.clique = self._clique_partition()
            self.conflict = self._conflicts()
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
        self._lens: dict[int, np.ndarray] = {}
        self.witness = False  # stop at the first placement better than the incumbent (item 14)
        self.dual_from: float = 3  # item 7 at nodes with this many free slots or more
        self.dual_runs = 0  # nodes where item 7 ran, and where it cut (the other rules had not)
        self.dual_cuts = 0
        self._free: BranchAndBoundSearch | None = None  # item 14's relaxed search, built on first use
        self.free_cuts = 0

    # ------------------------------------------------------------------ set-up
    def _user_bits(self) -> list[int]:
        """S(c) of each site (in the search order) as a Python int bit set."""
        bits = [0] * self.n
        for k, i in enumerate(self.order.tolist()):
            b = 0
            for u in self.cand.cover[i].tolist():
                b |= 1 << int(u)
            bits[k] = b
        return bits

    def _packed_users(self) -> np.ndarray:
        """Item 7: the coverage sets as packed uint64 bit rows (users of cover)."""
        n_words = max((len(self.problem.targets) + 63) // 64, 1)
        member = np.zeros((self.n, n_words * 64), dtype=bool)
        for k, i in enumerate(self.order.tolist()):
            member[k, self.cand.cover[i]] = True
        return np.packbits(member, axis=1, bitorder="little").view(np.uint64)

    def _clique_partition(self) -> np.ndarray:
        """Item 2: the clique of each site, heaviest unassigned site first."""
        problem, pts = self.problem, self.pts
        clique = np.full(self.n, -1, dtype=np.int64)
        n_cl = 0
        for i in range(self.n):
            if clique[i] >= 0:
                continue
            # centred on the centroid of the users the site covers (a cluster's heaviest sites
            # ring its centre, so one disc there holds all of them), else on the site itself
            ctr = problem.targets[self.cand.cover[self.order[i]]].mean(axis=0) if self.w[i] else pts[i]
            if math.dist(ctr, pts[i]) >= problem.R_d - 2 * TOL:
                ctr = pts[i]
            nb = np.asarray(self.tree.query_ball_point(ctr, problem.R_d - 2 * TOL), dtype=np.int64)
            nb = nb[clique[nb] < 0]
            clique[nb] = n_cl
            clique[i] = n_cl
            n_cl += 1
        return clique

    def _conflicts(self) -> BitRows:
        """Conflicts (4.8): distance < 2 R_d - TOL, as packed bit rows, built a grid cell at a
        time: the two sites of a conflicting pair lie in cells of side R_d at most two apart
        in x and in y, so each cell's sites are tested against the sites of its 5 x 5 block
        only, and their rows are packed whole. Table 4.2 density x4 (63,984 sites): the
        search's set-up took 42.8 s with a KD-tree query and a bit update per pair, 9.5 s so
        (the same rows). Raises ``_Timeout`` once the time limit has passed (at a cell's end)."""
        R_d = self.problem.R_d
        n = self.n
        rows = BitRows(np.zeros((n, (n + 7) // 8), dtype=np.uint8), n)
        if n == 0:
            return rows
        cell = np.floor((self.pts - self.pts.min(axis=0)) / R_d).astype(np.int64)
        ny = int(cell[:, 1].max()) + 5
        key = (cell[:, 0] + 2) * ny + cell[:, 1] + 2  # a border of empty cells around the grid
        by_key = np.argsort(key, kind="stable")
        keys, starts = np.unique(key[by_key], return_index=True)
        ends = np.append(starts[1:], n)
        for k, a, b in zip(keys.tolist(), starts.tolist(), ends.tolist(), strict=True):
            block = [k + dx * ny + dy for dx in range(-2, 3) for dy in range(-2, 3)]
            pos = np.searchsorted(keys, block)
            hit = (pos < len(keys)) & (keys[np.minimum(pos, len(keys) - 1)] == block)
            near = np.concatenate([by_key[starts[q] : ends[q]] for q in pos[hit].tolist()])
            for lo in range(a, b, _CONFLICT_ROWS):  # at most _CONFLICT_ROWS rows of n bools at once
                sites = by_key[lo : min(lo + _CONFLICT_ROWS, b)]
                dense = np.zeros((len(sites), n), dtype=bool)
                dense[:, near] = pairwise_distances(self.pts[sites], self.pts[near]) < 2 * R_d - TOL
                dense[np.arange(len(sites)), sites] = False
                rows.packed[sites] = np.packbits(dense, axis=1, bitorder="little")
            if self.out_of_time():
                raise _Timeout()
        return rows

    def link_rows(self) -> LinkRows:
        """The sites within r2 + TOL of each other (:class:`LinkRows`: a row is built when
        first used; items 11 and 12's exact link tests)."""
        if self._links is None:
            self._links = LinkRows(self.pts, self.r2t)
        return self._links

    def link_matrix(self) -> LinkRows:
        """The same relation as :meth:`link_rows` (item 11 reads rows and single links)."""
        return self.link_rows()

    def lens_sites(self, a: int) -> np.ndarray:
        """Item 11: the sites within 2 R_d (+ 2 m) of site a that do not overlap it, the
        only ones that can cover users of a when a is placed."""
        if a not in self._lens:
            near = np.asarray(
                self.tree.query_ball_point(self.pts[a], 2 * self.problem.R_d + 2.0), dtype=np.int64
            )
            self._lens[a] = np.sort(near[~self.conflict.at(a, near)])
        return self._lens[a]

    # ------------------------------------------------------------------ limits
    def expired(self) -> bool:
        """True once the node budget or the time limit is used up."""
        if self.node_limit is not None and self.nodes >= self.node_limit:
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
        value only: each worker keeps the placements it found), then test the time limit."""
        if self.shared:
            with self.shared[0].get_lock():
                if self.best_val > self.shared[0].value:
                    self.shared[0].value = self.best_val
                elif self.shared[0].value > self.best_val:
                    self.best_val = int(self.shared[0].value)
        return self.expired()

    def _tick(self) -> None:
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

    # ------------------------------------------------------------------ placements
    def offer(self, P: list[int]) -> None:
        """Make the placement P the incumbent when ``evaluate`` finds it feasible and better."""
        ev = evaluate(self.problem, self.pts[P])
        if ev.feasible and ev.covered > self.best_val:
            self.best_val, self.best = int(ev.covered), list(P)
            if self.witness:
                raise _Witness

    def placed(self, P: list[int]) -> tuple[np.ndarray, np.ndarray]:
        """(dpp, reach) of a non-empty P: the (|P|, |P|) distances of its sites (m) and which
        of them have a link path (<= r1 + TOL to a GBS, <= r2 + TOL between sites, the
        tests of ``evaluate``) to a GBS through P."""
        pp = self.pts[P]
        dpp = pairwise_distances(pp, pp)
        link = dpp <= self.r2t
        reach = self.dg[P] <= self.r1t
        for _ in range(len(P)):
            nr = reach | np.any(link & reach[None, :], axis=1)
            if np.array_equal(nr, reach):
                break
            reach = nr
        return dpp, reach

    def reach_of(self, P: list[int]) -> np.ndarray:
        """(|P|,) bool: sites of P with a link path to a GBS through P (:meth:`placed`)."""
        return self.placed(P)[1]

    def pp_cost(self, P: list[int]) -> np.ndarray:
        """(|P|, |P|) relay lower bounds between the sites of P (item 3)."""
        pp = self.pts[P]
        return _relay_cost(pairwise_distances(pp, pp), self.r2, self.r2)

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
        return self._node(P, self._bits_of(P), cmask, dist, must)

    def _node(
        self, P: list[int], ubits: int, cmask: np.ndarray, dist: np.ndarray, must: np.ndarray | None
    ) -> Node:
        if P:
            dpp, reach = self.placed(P)
        else:
            dpp, reach = np.zeros((0, 0)), np.zeros(0, dtype=bool)
        node = Node(P, ubits, cmask, dist, reach, dpp, must)
        if must is not None:
            node.cmask_must = cmask & must
        return node

    def _bits_of(self, R: list[int]) -> int:
        ub = 0
        for i in R:
            ub |= self.bits[i]
        return ub

    def connecting(self, R: list[int], C: np.ndarray, reach: np.ndarray | None = None) -> np.ndarray:
        """(|C|,) bool: R + q is connected (the link tests of ``evaluate``) for q in C;
        ``reach`` is ``reach_of(R)`` when the caller has it already."""
        if not R:
            return self.dg[C] <= self.r1t
        pr = self.pts[R]
        reach = self.reach_of(R) if reach is None else reach
        link = pairwise_distances(pr, self.pts[C]) <= self.r2t
        rq = (self.dg[C] <= self.r1t) | np.any(link & reach[:, None], axis=0)
        if reach.all():
            return rq
        adj = pairwise_distances(pr, pr) <= self.r2t
        R2 = reach[:, None] | (link & rq[None, :])
        for _ in range(len(R)):
            nr = R2 | np.any(adj[:, :, None] & R2[None, :, :], axis=1)
            if np.array_equal(nr, R2):
                break
            R2 = nr
        return rq & R2.all(axis=0)

    # ------------------------------------------------------------------ bound rules
    def top_cliques(self, idx: np.ndarray, k: int) -> list[int]:
        """The k largest per-clique maxima over the sites ``idx`` (sorted heaviest first)."""
        out: list[int] = []
        if k <= 0:
            return out
        seen: set[int] = set()
        for lo in range(0, len(idx), 64):
            part = idx[lo : lo + 64]
            for t, c in zip(part.tolist(), self.clique[part].tolist(), strict=True):
                if c not in seen:
                    seen.add(c)
                    out.append(int(self.w[t]))
                    if len(out) == k:
                        return out
        return out

    def clique_values(self, Cok: np.ndarray, r: int, w_th: int) -> list[int]:
        """Items 1, 2 and 4: r values, the i-th bounding the weight of the i-th heaviest site
        of any completion from ``Cok`` plus sites lighter than ``w_th`` (cut by item 4): the
        r largest per-clique maxima over ``Cok``, padded with ``w_th``."""
        tops = self.top_cliques(Cok, r)
        return tops + [w_th] * (r - len(tops))

    def greedy_dual(self, P: list[int], C: np.ndarray, dist: np.ndarray, reach: np.ndarray, r: int) -> float:
        """Item 7: an upper bound on |S(Q) - S(P)| over completions Q of at most r sites of
        C that fit the relay bound of P + q, by submodularity of coverage (-inf when P
        cannot be completed)."""
        if P:
            kept = self._dual_candidates(P, C, dist, reach, r)
            if kept is None:
                return -math.inf  # P cannot be completed: no feasible placement below
            C, g0, covered, near = kept
        else:
            C = C[self.cg[C] <= r - 1]
            g0 = self.cg[C] <= 0
            covered = np.zeros(self.packed.shape[1], dtype=self.packed.dtype)
            near = None
        if len(C) == 0 or not g0.any():
            return 0.0  # item 6: a non-empty completion holds a site with gj = 0
        two = near is not None and r >= 2 and float(dist[~reach].max()) >= 2
        return self._greedy_gains(C, covered, g0, near, two, r)

    def _dual_candidates(self, P: list[int], C: np.ndarray, dist: np.ndarray, reach: np.ndarray, r: int):
        """Item 7's candidates below a non-empty P: (C, g0, covered, near) with the sites
        of C that pass item 3, which of them have gj = 0 (item 6), S(P) as packed rows, and
        the bridge candidates of item 5 (None when P is reached); None when none exists."""
        pp = self.pts[P]
        ej = _relay_cost(pairwise_distances(pp, self.pts[C]), self.r2, self.r2)
        gj, newd = _through(dist, gj_direct=self.cg[C], ej=ej, epp=self.pp_cost(P))
        need = np.maximum(gj, newd.max(axis=0))
        keep = need <= r - 1
        C, g0 = C[keep], gj[keep] <= 0
        covered = np.bitwise_or.reduce(self.packed[P], axis=0)
        near = None
        if not reach.all():  # item 5: bridge candidates, within r2 + TOL of an unreached P site
            near = np.any(pairwise_distances(pp[~reach], self.pts[C]) <= self.r2t, axis=0)
            if not near.any():
                return None
        return C, g0, covered, near

    def _greedy_gains(
        self, C: np.ndarray, covered: np.ndarray, g0: np.ndarray, near: np.ndarray | None, two: bool, r: int
    ) -> float:
        """Item 7's loop over the greedy sets G_0, ..., G_r (with items 5, 6 and 8) over the
        sites C (in the search order, so by weight, heaviest first)."""
        masks = [g0] if near is None else [g0, near]
        f_g = 0
        best = math.inf
        end = 0
        for k in range(r + 1):
            gain, end = self._lazy_gains(C, covered, masks, r, end)
            top = np.sort(gain if len(gain) <= r else np.partition(gain, len(gain) - r)[-r:])
            # item 6 again: one of the r gains is that of a site with gj = 0
            best = min(best, f_g + int(top.sum()), f_g + _masked_max(gain, g0) + int(top[1:].sum()))
            if near is not None:  # item 5: one gain from a bridge, two distinct ones (item 8)
                w_near = _masked_max(gain, near)
                best = min(best, f_g + w_near + int(top[1:].sum()))
                if two:
                    best = min(best, f_g + w_near + _masked_max(gain, g0) + int(top[2:].sum()))
            g = int(np.argmax(gain))
            if k == r or gain[g] == 0:
                break
            f_g += int(gain[g])
            covered = covered | self.packed[C[g]]
        return float(best)

    def _lazy_gains(
        self, C: np.ndarray, covered: np.ndarray, masks: list[np.ndarray], r: int, end: int
    ) -> tuple[np.ndarray, int]:
        """Item 7's gains |S(c) - covered| of a prefix C[:e] (e >= ``end``) that holds every
        value the greedy step reads: the r largest gains, the largest under each mask and
        the largest of all. A gain is at most the site's weight and C runs by weight, so the
        sites after C[e] (weight <= w[C[e]]) change none of them once w[C[e]] is at most the
        r-th largest gain and at most each mask's largest (ties leave every sum unchanged)."""
        n = len(C)
        end = min(n, max(end, 8 * r, 256))
        while True:
            gain = _popcount_rows(self.packed[C[:end]] & ~covered)
            if end == n:
                return gain, end
            thr = int(np.partition(gain, len(gain) - r)[-r]) if len(gain) >= r else -1
            for mask in masks:
                thr = min(thr, _masked_max(gain, mask[:end]))
            if int(self.w[C[end]]) <= thr:
                return gain, end
            end = min(n, 4 * end)

    def relay_filter(self, node: Node, C: np.ndarray) -> Children | None:
        """Item 3: the candidates j of C for which P + j keeps its relay lower bound within
        the free slots (``need <= r - 1``), with what the children need; None when none."""
        r = self.m - node.depth
        cgj = self.cg[C]
        if node.P:
            dpj = pairwise_distances(self.pts[node.P], self.pts[C])
            ej = _relay_cost(dpj, self.r2, self.r2)  # (|P|, |C|)
            gj, newd = _through(node.dist, gj_direct=cgj, ej=ej, epp=self.pp_cost(node.P))
            need = np.maximum(gj, newd.max(axis=0))
        else:
            gj = need = cgj
            newd = np.zeros((0, len(C)))
            dpj = np.zeros((0, len(C)))
        ok = np.flatnonzero(need <= r - 1)
        if len(ok) == 0:
            return None
        return Children(C, ok, gj, newd, dpj)

    def linkable_weight(self, kids: Children, w_th: int) -> int:
        """Item 6: the first completion site on a path from a GBS links to a GBS or to a
        reached P site, so its relay lower bound gj is 0: one slot holds at most the
        heaviest candidate with gj = 0 (or a site cut by item 4, of weight <= ``w_th``)."""
        Cok = kids.C[kids.ok]
        g0 = kids.gj[kids.ok] <= 0
        return max(int(self.w[Cok[g0][0]]) if g0.any() else 0, w_th)

    def unreached_bounds(
        self, node: Node, kids: Children, tops: list[int], w_th: int, wg: int, b: float
    ) -> tuple[float, float]:
        """Items 5, 8 and 12 at a node whose P has unreached sites (and r >= 2 free
        slots): returns (b lowered by items 5 and 8, item 12's bound or inf)."""
        val, r = node.val, self.m - node.depth
        Cok = kids.C[kids.ok]
        # item 5: the P sites without a link path to a GBS need a chosen site of the
        # completion within r2 + TOL of one of them (the first site off that group on a
        # path to a GBS); that slot holds at most the heaviest such site
        near = np.any(kids.dpj[:, kids.ok][~node.reach] <= self.r2t, axis=0)
        wb = max(int(self.w[Cok[near][0]]) if near.any() else 0, w_th)
        b = min(b, val + wb + sum(tops[: r - 1]))
        if float(node.dist[~node.reach].max()) >= 2:  # item 8
            b = min(b, val + wb + wg + sum(tops[: r - 2]))
        sep = self.separated_bound(node, r, tops)  # item 12
        if val + sep < b:
            self.separated += 1
            return b, val + sep
        return b, math.inf

    def separated_bound(self, node: Node, r: int, tops: list[int]) -> float:
        """Item 12 (``_separated_groups``) at the node: a bound on the completion's weight."""
        return _separated_groups(
            self.pts,
            self.w,
            self.dg,
            node.P,
            node.dpp,
            node.reach,
            node.cmask,
            r,
            tops,
            self.r1t,
            self.r2t,
            self.link_rows(),
        )

    def node_bound(self, node: Node, nb: float) -> Children | None:
        """Every rule at a node with r >= 2 free slots: None when no completion can beat the
        incumbent, else its children with the node bound (``Children.bound``); ``nb``: the
        parent's bound."""
        z, val, r = self.best_val, node.val, self.m - node.depth
        full = np.flatnonzero(node.cmask)
        C = full[val + r * self.w[full] > z]  # item 4
        if len(C) == 0:
            return None
        kids = self.relay_filter(node, C)
        if kids is None:
            return None
        # node bound: items 1-2 over the sites that can still join (need <= r - 1). Sites
        # cut by item 4 weigh at most w_th; they may still be the lighter members of a
        # completion, so missing clique values are padded with w_th.
        w_th = max((z - val) // r, 0)
        tops = self.clique_values(kids.C[kids.ok], r, w_th)
        b: float = val + sum(tops)
        wg = self.linkable_weight(kids, w_th)
        b = min(b, val + wg + sum(tops[: r - 1]))
        b_sep = math.inf
        if not node.reach.all():
            b, b_sep = self.unreached_bounds(node, kids, tops, w_th, wg, b)
        if node.cmask_must is not None:  # item 11: one slot holds a site of ``must``
            w_must = int(self.w[np.flatnonzero(node.cmask_must)[0]])
            b = min(b, val + w_must + sum(tops[: r - 1]))
        bf = min(float(b), nb, b_sep)
        if r < len(self.conf_bound):  # item 9
            bf = min(bf, val + self.conf_bound[r])
        if bf <= z:
            return None
        if r >= self.dual_from:  # item 7 (the costliest rule, last) over every candidate of item 3
            self.dual_runs += 1
            bf = min(bf, val + self.greedy_dual(node.P, full, node.dist, node.reach, r))
            if bf <= z:
                self.dual_cuts += 1
                return None
        kids.bound = bf
        return kids

    def replaced_by_sibling(
        self, P: list[int], ubits: int, b: int, cm: np.ndarray, explored: list[int]
    ) -> bool | np.ndarray | None:
        """Item 11 for the child P + b, given siblings ``explored`` before it: True when a
        sibling can replace b in every completion (skip b), a bool mask E over the sites
        when it can in every completion avoiding E (search only completions meeting E),
        None when no sibling qualifies."""
        new_b = self.bits[b] & ~ubits
        best: np.ndarray | None = None
        best_count = 0
        for a in reversed(explored[-_SIBLINGS:]):
            if not self._may_replace(P, ubits, a, b, new_b, cm):
                continue
            if self.all_linked:  # b links to no site that a does not
                e = cm & self.conflict.row(a)
            else:
                linked = self.link_matrix()
                e = cm & (self.conflict.row(a) | (linked.row(b) & ~linked.row(a)))
            count = int(np.count_nonzero(e))
            if count == 0:
                return True
            if best is None or count < best_count:
                best, best_count = e, count
        return best

    def _may_replace(self, P: list[int], ubits: int, a: int, b: int, new_b: int, cm: np.ndarray) -> bool:
        """Item 11's tests of sibling a against b: close, direct when b is, linked to every
        P site b links to, and covering b's new users or keeping at least as many."""
        if math.dist(self.pts[a], self.pts[b]) > _SIBLING_RADIUS or self.dg[b] <= self.r1t < self.dg[a]:
            return False
        if P and not self.all_linked:
            linked = self.link_matrix()
            if np.any(linked.at(b, P) & ~linked.at(a, P)):
                return False
        if not new_b & ~self.bits[a]:
            return True
        # not a cover of b's new users: compare counts instead. A completion site that does
        # not overlap a covers users of a only in a lens at the edge of a's disc (sites
        # within 2 R_d of a); a keeps every other user of its own
        lens = 0
        for s in self.lens_sites(a).tolist():
            if cm[s]:
                lens |= self.bits[s]
        return (self.bits[a] & ~ubits & ~lens).bit_count() >= new_b.bit_count()

    def site_bound(self, c: int, alive: np.ndarray) -> float | None:
        """Item 10's probe: the bound of the node {c} (items 1-9) over the completions from
        the sites of ``alive`` that do not overlap c; None when no placement holding c and
        otherwise sites of ``alive`` can beat the incumbent."""
        cm = alive & ~self.conflict.row(c)
        cm[c] = False
        return self.dfs([c], self.bits[c], cm, self.cg[[c]], math.inf, probe=True)

    def site_can_improve(self, c: int, alive: np.ndarray) -> bool:
        """Item 10: False when no placement holding site c and otherwise sites of ``alive``
        can beat the incumbent (:meth:`site_bound`)."""
        return self.site_bound(c, alive) is not None

    def free_completion(self, node: Node, node_limit: int | None = None) -> bool | None:
        """Item 14: whether some completion Q of the node makes P + Q cover more than the
        incumbent z with backhaul dropped (every site linked; ``cmask`` and ``must`` kept),
        found by the exact search of item 9 rooted at P, which stops at the first such
        placement. False: no feasible placement below the node beats z either. None when the
        relaxed search stops at its node budget (``node_limit``, default ``_FREE_NODES``) or
        the time limit first: nothing is known then."""
        free = self._free
        if free is None:
            unlinked = _without_backhaul(self.problem, self.pts)(self.m)
            free = self._free = BranchAndBoundSearch(
                unlinked, self.cand, self.best_val, parent=self, t0=self.t0, time_limit=self.time_limit
            )
            free.witness = True
            free.dual_from = math.inf  # item 7 cost more than it cut there
        free.conf_bound = self.conf_bound  # B_k bound the relaxed problem too (item 9)
        free.best_val, free.best, free.nodes = self.best_val, None, 0
        free.node_limit = _FREE_NODES if node_limit is None else node_limit
        P = node.P
        try:
            free.dfs(list(P), node.ubits, node.cmask, free.cg[P], math.inf, must=node.must)
        except _Witness:
            return True
        except _Timeout:
            return None
        finally:
            free.stack_bounds.clear()
        return False

    # ------------------------------------------------------------------ the search
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
        self._tick()
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
            self.last_site(P, ubits, np.flatnonzero(last), node.reach, node.val)
            return None
        kids = self.node_bound(node, nb)
        if kids is None:
            return None
        if probe:
            return kids.bound
        if r >= 3 and len(P) >= _FREE_DEPTH and not self.all_linked and self.free_completion(node) is False:
            self.free_cuts += 1  # item 14: not even the relaxed problem beats z below P
            return None
        self.stack_bounds.append(kids.bound)
        try:
            if node.cmask_must is not None and r >= 3 and int(node.cmask_must.sum()) <= _MUST_BRANCH:
                # item 11 by branching: every completion holds a site e of ``must``; search
                # P + e for each e in turn, its completions holding no earlier one
                self.must_branch(node, node.cmask_must, kids.bound)
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
                    self.last_pair(node, j, last_two, explored)
            else:
                self.child(node, kids, k, mine, explored)
            explored.append(j)

    def last_pair(
        self, node: Node, j: int, last_two: tuple[np.ndarray, np.ndarray], explored: list[int]
    ) -> None:
        """The child P + j of a node with two free slots, and its last sites (the tests of
        a search node, vectorised over the candidates)."""
        self._tick()
        full, neg_w = last_two
        z, must = self.best_val, node.must
        ubj = node.ubits | self.bits[j]
        valj = ubj.bit_count()
        lo = int(np.searchsorted(full, j, side="right"))
        hi = int(np.searchsorted(neg_w, valj - z, side="left"))  # w > z - valj
        pj = [*node.P, j]
        if valj > z and self.reach_of(pj).all():  # P + j alone
            self.offer(pj)
        if hi <= lo:
            return
        cq = full[lo:hi]
        cq = cq[~self.conflict.at(j, cq)]
        # item 11 (the lighter last sites are bounded); under ``must`` only for j outside
        # it, whose last site is then in ``must`` in any case
        if must is None or not must[j]:
            if must is not None:
                cq = cq[must[cq]]
            if len(cq):
                cq = self._siblings_cut(node, j, cq, explored)
        self.last_site(pj, ubj, cq, self.reach_of(pj), valj)

    def _siblings_cut(self, node: Node, j: int, cq: np.ndarray, explored: list[int]) -> np.ndarray:
        """Item 11 on the last sites ``cq`` of P + j: the ones a sibling cannot stand in for."""
        in_cq = np.zeros(self.n, dtype=bool)
        in_cq[cq] = True
        replace = self.replaced_by_sibling(node.P, node.ubits, j, in_cq, explored)
        if replace is True:
            return cq[:0]
        if isinstance(replace, np.ndarray):
            return cq[replace[cq]]
        return cq

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
            replace = self.replaced_by_sibling(node.P, node.ubits, j, cm, explored)
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

    def must_branch(self, node: Node, cmask_must: np.ndarray, nb: float) -> None:
        """Item 11 by branching: search the nodes P + e for the sites e of ``cmask_must``
        (the sites of ``must`` left), each completed from ``cmask`` without the earlier
        ones, so every completion holding a site of ``must`` is searched once. At the split
        depth the e are dealt out like children (``_split_root``)."""
        P, r = node.P, self.m - node.depth
        rest = node.cmask.copy()
        epp = self.pp_cost(P) if P else np.zeros((0, 0))
        dealt = self.split[1] > 1 and len(P) == self.split[2]
        for pos, e in enumerate(np.flatnonzero(cmask_must).tolist()):
            rest[e] = False
            if dealt and pos % self.split[1] != self.split[0]:
                continue
            nd = self._relays_with(P, node.dist, e, epp)
            if float(nd.max()) > r - 1:  # item 3: P + e needs too many relays
                continue
            pe = [*P, e]
            self.dfs(
                pe,
                node.ubits | self.bits[e],
                rest & ~self.conflict.row(e),
                _close(self.pts[pe], nd, self.r2),
                nb,
            )

    def _relays_with(self, P: list[int], dist: np.ndarray, e: int, epp: np.ndarray) -> np.ndarray:
        """Item 3 for P + e: the relay lower bounds to P's sites and (last) to e."""
        if not P:
            return np.array([self.cg[e]])
        ee = _relay_cost(pairwise_distances(self.pts[P], self.pts[[e]]), self.r2, self.r2)
        ge, nde = _through(dist, gj_direct=self.cg[[e]], ej=ee, epp=epp)
        return np.append(nde[:, 0], ge[0])

    def last_site(self, P: list[int], ubits: int, C: np.ndarray, reach: np.ndarray, val: int) -> None:
        """The last free slot: every candidate q of C (sorted heaviest first, each keeping
        P + q non-overlapping) that makes P + q connected (the exact link test of
        ``evaluate``), while |S(P)| + |S(q)| can beat the incumbent."""
        C = C[val + self.w[C] > self.best_val]
        if len(C) == 0:
            return
        ok = self.connecting(P, C, reach)
        for q in C[ok].tolist():
            if val + int(self.w[q]) <= self.best_val:
                break
            if (ubits | self.bits[q]).bit_count() > self.best_val:
                self.offer([*P, q])

    # ------------------------------------------------------------------ heuristics, elimination
    def local_search(self, X: list[int]) -> None:
        """Primal heuristic (no effect on exactness): replace one site of X by the candidate
        that covers most, keeping X feasible, while that improves; the result becomes the
        incumbent only after ``evaluate`` confirms it."""
        cur = int(_popcount_rows(np.bitwise_or.reduce(self.packed[X], axis=0)[None, :])[0]) if X else 0
        for _ in range(50):
            if self.expired():
                break
            moved = self._swap(X, cur)
            if moved is None:
                break
            X, cur = moved
        self.offer(X)

    def _swap(self, X: list[int], cur: int) -> tuple[list[int], int] | None:
        """One improving move of :meth:`local_search` (None when there is none)."""
        for i in range(len(X) + (len(X) < self.m)):
            R = X[:i] + X[i + 1 :]
            C = np.flatnonzero(self.compatible(R))
            if len(C) == 0:
                continue
            covR = (
                np.bitwise_or.reduce(self.packed[R], axis=0)
                if R
                else np.zeros(self.packed.shape[1], self.packed.dtype)
            )
            valR = int(_popcount_rows(covR[None, :])[0])
            gain = _popcount_rows(self.packed[C] & ~covR)
            good = np.flatnonzero(valR + gain > cur)
            if len(good):
                good = good[self.connecting(R, C[good])]
            if len(good):
                q = int(C[good[np.argmax(gain[good])]])
                return [*R, q], valR + int(gain[good].max())
        return None

    def exchange(self, X: list[int]) -> None:
        """Primal heuristic (no effect on exactness): for every set D of sites of the
        incumbent X, of each size in ``exchange_sizes`` in turn, search all completions of
        X - D exactly (the search below, rooted at X - D) for one better than the incumbent;
        repeat from each improvement."""
        better: list[int] | None = X
        while better is not None and not self.expired():
            better = self._exchange_pass(better)

    def _exchange_pass(self, X: list[int]) -> list[int] | None:
        """One pass of :meth:`exchange`: the improved incumbent's sites, or None."""
        for k in self.exchange_sizes:
            for D in itertools.combinations(range(len(X)), k):
                R = sorted(X[i] for i in range(len(X)) if i not in D)
                mask = self.compatible(R)
                before = self.best_val
                self.dfs(R, self._bits_of(R), mask, _close(self.pts[R], self.cg[R], self.r2), math.inf)
                if self.best_val > before and self.best is not None:
                    return sorted(self.best)
        return None

    def backhaul_free_bounds(self) -> None:
        """Item 9: fill ``conf_bound`` (B_0, ..., B_{m-1}) from exact backhaul-free searches.
        They get at most a quarter of the time left (a search cut short still returns a
        valid bound); each one eliminates sites with the bounds of the smaller ones."""
        unlinked = _without_backhaul(self.problem, self.pts)
        self.conf_bound[:] = [0.0]
        t_b = time.perf_counter()
        budget = None if self.time_limit is None else 0.25 * (self.time_limit - (t_b - self.t0))
        for k in range(1, self.m):
            if self.expired():
                raise _Timeout
            left = None if budget is None else max(budget - (time.perf_counter() - t_b), 0.01)
            sub = search(
                unlinked(k),
                self.cand,
                np.zeros((0, 2)),
                0,
                time_limit=left,
                free_bounds=self.conf_bound,
                parent=self,
            )
            self.conf_bound.append(sub.bound)

    def eliminate_sites(self, alive: np.ndarray) -> None:
        """Items 9-10: fill ``conf_bound`` when not given, then clear in ``alive`` every site
        that no placement better than the incumbent can contain."""
        if len(self.conf_bound) < self.m:
            self.backhaul_free_bounds()
        alive &= self.w + self.conf_bound[self.m - 1] > self.best_val  # item 10, first test
        todo = np.flatnonzero(alive)
        for _ in range(4):  # item 10, probes, until no site is cleared
            bounds = self.probe_sites(todo, alive)
            if not np.isneginf(bounds).any():
                break
            # a probe's bound falls only as far as clearing other sites lowers it: probe again
            # the sites whose bound came within _REPROBE_MARGIN of the incumbent (at Table 4.2
            # density x 4 a second probe of all 14.9k left cleared 5 sites in 114 s)
            todo = todo[(bounds > -math.inf) & (bounds <= self.best_val + _REPROBE_MARGIN)]

    def probe_sites(self, sites: np.ndarray, alive: np.ndarray) -> np.ndarray:
        """Item 10's probes (:meth:`site_bound`) of ``sites`` (indices) in turn, each cleared
        site at once out of ``alive`` (so later probes see fewer sites); returns their bounds
        (-inf for the cleared ones). Item 7 is left out of the probes after the first
        ``_DUAL_TRIAL`` when it cut fewer than 1 % of the probes it ran in (its bound is only
        an extra cut, so leaving it out keeps every probe valid; at Table 4.2 density x 4 it
        cut no probe the other rules had not, at 4 ms a probe)."""
        bounds = np.full(len(sites), -math.inf)
        runs0, cuts0, dual_from = self.dual_runs, self.dual_cuts, self.dual_from
        try:
            for k, c in enumerate(sites.tolist()):
                runs = self.dual_runs - runs0
                if k == _DUAL_TRIAL and runs >= _DUAL_TRIAL // 4 and 100 * (self.dual_cuts - cuts0) < runs:
                    self.dual_from = math.inf
                b = self.site_bound(c, alive)
                if b is None:
                    alive[c] = False
                else:
                    bounds[k] = b
        finally:
            self.dual_from = dual_from
        return bounds

    def drop_dominated(self, alive: np.ndarray) -> int:
        """Item 13: clear in ``alive`` every site dominated by another alive site; returns
        how many were cleared."""
        idx = np.flatnonzero(alive)
        if len(idx) < 2:
            return 0
        pts = self.pts[idx]
        tree = cKDTree(pts)
        pairs = tree.query_pairs(_DOMINANCE_RADIUS, output_type="ndarray")
        if len(pairs) == 0:
            return 0
        # (c, d) with d earlier in the search order (so w[d] >= w[c]), as positions in idx
        pairs = np.sort(pairs, axis=1)
        d_loc, c_loc = pairs[:, 0], pairs[:, 1]
        c, d = idx[c_loc], idx[d_loc]
        direct = self.dg <= self.r1t
        ok = ~direct[c] | direct[d]
        for lo in range(0, len(c), 4096):  # S(c) within S(d), a block of pairs at a time
            sl = slice(lo, lo + 4096)
            ok[sl] &= ~np.any(self.packed[c[sl]] & ~self.packed[d[sl]], axis=1)
        c_loc, c, d = c_loc[ok], c[ok], d[ok]
        if len(c) == 0:
            return 0
        gap = np.hypot(*(self.pts[c] - self.pts[d]).T)
        at = pts[c_loc]
        r_conf = 2 * self.problem.R_d - TOL

        def annulus(inner: np.ndarray | float, outer: np.ndarray | float) -> np.ndarray:
            """Alive sites within [inner - 1e-6, outer + 1e-6] of c (a superset of the annulus)."""
            far = tree.query_ball_point(at, np.asarray(outer) + 1e-6, return_length=True)
            near = tree.query_ball_point(at, np.maximum(np.asarray(inner) - 1e-6, 0.0), return_length=True)
            return far - near

        # sites overlapping d but not c, or linked to c but not to d: none on these annuli
        ok = annulus(r_conf, r_conf + gap) == 0
        ok &= annulus(self.r2t - gap, self.r2t) == 0
        # a pair's own sites lie inside both inner discs (the gap is far below 2 R_d - TOL)
        ok &= gap < min(r_conf, self.r2t) / 2
        drop = np.unique(c[ok])
        alive[drop] = False
        return len(drop)

    def improve_start(self, incumbent: np.ndarray) -> None:
        """The primal heuristics from the incumbent's sites (when all are candidates)."""
        start = []
        for p0 in incumbent:
            hit = np.flatnonzero(np.hypot(*(self.pts - p0).T) <= 1e-3)
            if len(hit):
                start.append(int(hit[0]))
        if len(start) != len(incumbent):
            return
        self.local_search(sorted(set(start)))
        if self.best is None:
            self.best = sorted(set(start))
        with contextlib.suppress(_Timeout):
            self.exchange(self.best)

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
            self.improve_start(incumbent)
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
                    self.eliminate_sites(root)
                    dominated = self.drop_dominated(root)
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


def _separated_groups(
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
    links: np.ndarray | LinkRows | None = None,
) -> float:
    """Item 12: an upper bound on sum_{q in Q} w[q] over the completions Q (at most r
    sites of ``cmask``) that connect the placement P, when the unreached groups of P are
    at most 3 and pairwise more than 2 r2t apart (else math.inf; the successors are
    charged beyond 3 r2t only); -math.inf when no Q can.

    pts (n, 2) sites (m), w (n,) their weights, dg (n,) their distances to the nearest
    GBS (m); P: indices of the placed sites, dpp their (|P|, |P|) distances (m), reach
    (|P|,) which of them reach a GBS through P; tops: r values, the i-th bounding the
    i-th heaviest completion site outside the bridge and successor slots; r1t, r2t: the
    link ranges with tolerance (m); links: the link relation of the sites within r2t
    (:class:`LinkRows`, or its rows as one packed array), built here if None."""
    members = _unreached_groups(dpp, reach, r2t)
    k = len(members)
    if k > 3:
        return math.inf
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
        in_l |= np.any(pairwise_distances(pr, pf) <= r2t, axis=0)
    wf = w[full].astype(float)
    w_l = _heaviest(wf, in_l)
    if w_l == -math.inf:
        return -math.inf  # item 6: no completion site can link to a GBS
    # (k, |full|): distance of each site to each group (m)
    d_to = [pairwise_distances(pts[[P[i] for i in g.tolist()]], pf).min(axis=0) for g in members]
    if not all((d <= r2t).any() for d in d_to):
        return -math.inf  # item 5: a group cannot be reached
    bridge_l = [_heaviest(wf, (d <= r2t) & in_l) for d in d_to]
    bridge_n = [_heaviest(wf, (d <= r2t) & ~in_l) for d in d_to]
    if apart <= 3 * r2t:  # a successor may be another group's bridge: count the bridges only
        if k > r:
            return -math.inf
        return sum(max(bridge_l[g], bridge_n[g]) for g in range(k)) + sum(tops[: r - k])
    # the successor is linked to a bridge outside L, so within 2 r2t of the group
    rows = LinkRows(pts, r2t) if links is None else links
    succ_to = [_successor_sites(rows, full, d, in_l, r2t) for d in d_to]
    sides = _GroupSides(bridge_l, bridge_n, succ_to, d_to, in_l, wf, w_l, r2t)
    return float(max(sides.bound(outside, r, tops) for outside in itertools.product((False, True), repeat=k)))


def _unreached_groups(dpp: np.ndarray, reach: np.ndarray, r2t: float) -> list[np.ndarray]:
    """Item 12: the unreached sites of P (indices into P) split into the components of
    their link graph (links <= r2t, m)."""
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
    return [un[group == g] for g in range(k)]


def _heaviest(wf: np.ndarray, mask: np.ndarray) -> float:
    """The largest weight of ``wf`` under ``mask`` (-inf when none)."""
    return float(wf[mask].max()) if mask.any() else -math.inf


@dataclass
class _GroupSides:
    """Item 12 when the groups are more than 3 r2t apart: per group g, the heaviest bridge
    in L (``bridge_l[g]``) and outside it (``bridge_n[g]``), the successor candidates
    (``succ_to[g]``, bool over the completion sites), the distances to the group (``d_to[g]``,
    m); ``in_l`` and ``wf`` over the completion sites; ``w_l`` the heaviest site in L."""

    bridge_l: list[float]
    bridge_n: list[float]
    succ_to: list[np.ndarray]
    d_to: list[np.ndarray]
    in_l: np.ndarray
    wf: np.ndarray
    w_l: float
    r2t: float

    def bound(self, outside: tuple[bool, ...], r: int, tops: list[int]) -> float:
        """The bound when the groups' bridges lie outside L exactly where ``outside`` says
        (-inf when that choice is impossible)."""
        k = len(outside)
        slots = k + any(outside)
        if slots > r:
            return -math.inf
        # -inf where a group has no bridge of the kind ``outside`` asks for
        base = sum(self.bridge_n[g] if outside[g] else self.bridge_l[g] for g in range(k))
        far = [g for g in range(k) if outside[g]]
        if not far:
            return base + sum(tops[: r - k])
        if slots == r:
            return base + self._last_successor(outside, far)
        w_s = max(_heaviest(self.wf, self.succ_to[g]) for g in far)
        if len(far) < k:  # some bridge is in L; the successor may lie anywhere
            return base + w_s + sum(tops[: r - slots])
        # no bridge in L: the successor or another completion site is in L (item 6)
        w_sl = max(_heaviest(self.wf, self.succ_to[g] & self.in_l) for g in far)
        return base + max(w_sl + sum(tops[: r - slots]), w_s + self.w_l + sum(tops[: r - slots - 1]))

    def _last_successor(self, outside: tuple[bool, ...], far: list[int]) -> float:
        """Q is the bridges and one site v: the successor of every group in ``far``, so
        linked to a bridge of each; it ends their paths, so it is in L or linked to a
        bridge in L (within 2 r2t of a group not in ``far``)."""
        common = np.logical_and.reduce([self.succ_to[g] for g in far])
        v = common & self.in_l
        for h in range(len(outside)):
            if not outside[h]:
                v |= common & (self.d_to[h] <= 2 * self.r2t)
        return _heaviest(self.wf, v)


def _successor_sites(links, full: np.ndarray, d: np.ndarray, in_l: np.ndarray, r2t: float) -> np.ndarray:
    """Item 12: (len(full),) bool, a superset of the completion sites ``full`` (indices, in
    the search order: heaviest first) within 2 r2t of a group (``d``: their distances to it,
    m) that link to a bridge of that group outside L (``in_l``). The link test runs on the
    first ``_SUCCESSOR_PREFIX`` sites within 2 r2t only; the later ones count as linked.
    Item 12 reads these sets only through the heaviest weight of their intersections with
    other masks, and every bound it builds grows with those weights, so a superset keeps the
    bound valid (the later sites weigh no more than the prefix's, so a weight read from the
    prefix is the exact one). At Table 4.2 density x 4 the full test took 103 of 356 s of site
    elimination."""
    near = np.flatnonzero(d <= 2 * r2t)
    out = np.zeros(len(full), dtype=bool)
    out[near[_SUCCESSOR_PREFIX:]] = True
    head = near[:_SUCCESSOR_PREFIX]
    if len(head):
        out[head] = _linked_to(links, full[head], full[(d <= r2t) & ~in_l])
    return out


def _linked_to(links, sites: np.ndarray, q: np.ndarray) -> np.ndarray:
    """(len(sites),) bool: which of the sites (indices) are linked to some site of q
    (indices), by the packed rows ``links`` (:class:`LinkRows`, or its rows as one array)."""
    if len(q) == 0:
        return np.zeros(len(sites), dtype=bool)
    if isinstance(links, LinkRows) and len(q) > _LINK_ROWS_MAX:
        # many rows asked for: the nearest site of q by a KD-tree instead, within the range
        # widened by 1e-6 m, so the sites returned include every linked one (item 12 then
        # counts at most a few more successors: its bound can only grow, and stays valid)
        near, _ = cKDTree(links.pts[q]).query(links.pts[sites], distance_upper_bound=links.reach + 1e-6)
        return np.isfinite(near)
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


_LINK_ROWS_MAX = 64
"""Item 12: beyond this many bridge candidates their links are found with a KD-tree rather
than by their rows (stacking thousands of rows took 250 of 600 s at density x 4)."""

_ROW_CACHE_BYTES = 128 * 2**20
"""Bytes of unpacked conflict rows a :class:`BitRows` keeps."""

_REPROBE_MARGIN = 2
"""Item 10: after a probe round that cleared sites, the sites whose bound came within this
many users of the incumbent are probed again."""
_DUAL_TRIAL = 1000
"""Item 10: probes after which item 7 is left out of the rest when it cut almost none."""

_SUCCESSOR_PREFIX = 512
"""Item 12: the successor link test runs on this many of the heaviest sites near a group
(``_successor_sites``)."""

_CONFLICT_ROWS = 512
"""``_conflicts`` tests this many sites of a grid cell at a time (a (rows, n) bool block: 32 MiB
at 64k sites)."""

_DOMINANCE_RADIUS = 50.0
"""Item 13: dominating sites are sought this close (m); farther pairs rarely qualify, as
their annuli are wide."""

_FREE_DEPTH = 1
"""Item 14: the relaxed completion search runs at nodes of at least this depth."""
_FREE_NODES = 20_000
"""Item 14: node budget of one relaxed completion search."""
"""Item 14: node budget of one relaxed completion search."""

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
    span = float(pairwise_distances(pts, problem.gbs).max())
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
