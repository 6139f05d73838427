"""The branch and bound's sites and nodes (``_bnb``): the candidate sites in the search's
order with the relations the rules read, the search node, and the link tests of ``evaluate``
on a placement.

The sites are held in the search's order (weight |S(c)| descending, ties by index), so
each placement is enumerated as the sequence of its sites in one fixed order. Values are
always exact unions of user sets (Python int bit sets); the packed uint64 rows of the same
sets serve the vectorised rules (item 7 of ``_bnb_dual``, item 13 of ``_bnb_elimination``).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol

import numpy as np
from scipy.spatial import cKDTree

from droneplan.formulations.cells._core import TOL, Candidates, pairwise_distances
from droneplan.scenarios.cells import CellProblem


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


@dataclass
class Sites:
    """The candidate sites in the search's order (weight |S(c)| descending, ties by index) and
    the relations the rules read; built once and shared by the searches over the same sites.

    order: (n,) candidate index of each site; pts: (n, 2) positions (m); w: (n,) weights
    |S(c)| (users); bits: S(c) as Python int bit sets; packed: the same as packed uint64 rows
    (item 7); tree: a KD-tree over ``pts``; clique: (n,) the clique of each site (item 2);
    conflict: the overlaps (4.8) as :class:`BitRows`."""

    order: np.ndarray
    pts: np.ndarray
    w: np.ndarray
    bits: list[int]
    packed: np.ndarray
    tree: cKDTree
    clique: np.ndarray
    conflict: BitRows


def build_sites(problem: CellProblem, cand: Candidates, out_of_time: Callable[[], bool]) -> Sites:
    """The :class:`Sites` of ``cand`` for ``problem`` (its users and R_d).

    problem: the CellProblem; cand: its candidate sites; out_of_time: called while the
    conflict relation is built (``conflict_rows``), which raises ``_Timeout`` once it is True."""
    n = len(cand.points)
    w_all = np.array([len(c) for c in cand.cover], dtype=np.int64)
    order = np.lexsort((np.arange(n), -w_all))
    pts = cand.points[order]
    w = w_all[order]
    tree = cKDTree(pts)
    return Sites(
        order,
        pts,
        w,
        user_bits(cand, order),
        packed_users(problem, cand, order),
        tree,
        clique_partition(problem, cand, order, pts, w, tree),
        conflict_rows(pts, problem.R_d, out_of_time),
    )


def shares_sites(parent: SearchView | None, problem: CellProblem, cand: Candidates) -> bool:
    """True when ``parent`` searches the same ``cand`` (the same object) for the same users and
    R_d: the order and every structure of :class:`Sites` depend on these only, so a search
    shares the parent's instead of building copies (item 9's searches; each conflict relation
    is n^2 / 8 bytes)."""
    return (
        parent is not None
        and parent.cand is cand
        and parent.problem.R_d == problem.R_d
        and np.array_equal(parent.problem.targets, problem.targets)
    )


def user_bits(cand: Candidates, order: np.ndarray) -> list[int]:
    """S(c) of each site (in the search order ``order``) as a Python int bit set."""
    bits = [0] * len(order)
    for k, i in enumerate(order.tolist()):
        b = 0
        for u in cand.cover[i].tolist():
            b |= 1 << int(u)
        bits[k] = b
    return bits


def packed_users(problem: CellProblem, cand: Candidates, order: np.ndarray) -> np.ndarray:
    """Item 7: the coverage sets as packed uint64 bit rows (users of cover), in the order ``order``."""
    n_words = max((len(problem.targets) + 63) // 64, 1)
    member = np.zeros((len(order), n_words * 64), dtype=bool)
    for k, i in enumerate(order.tolist()):
        member[k, cand.cover[i]] = True
    return np.packbits(member, axis=1, bitorder="little").view(np.uint64)


def clique_partition(
    problem: CellProblem, cand: Candidates, order: np.ndarray, pts: np.ndarray, w: np.ndarray, tree: cKDTree
) -> np.ndarray:
    """Item 2: the clique of each site, heaviest unassigned site first.

    The sites are partitioned once into cliques of the conflict graph: a site's clique holds
    the still unassigned sites within R_d - TOL of it, which are pairwise < 2 R_d - 2 TOL apart,
    so they overlap pairwise and at most one of them is chosen (``_bnb_bounds.clique_values``
    reads the partition)."""
    n = len(pts)
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
    return clique


def conflict_rows(pts: np.ndarray, R_d: float, out_of_time: Callable[[], bool]) -> BitRows:
    """Conflicts (4.8): distance < 2 R_d - TOL, as packed bit rows, built a grid cell at a
    time: the two sites of a conflicting pair lie in cells of side R_d at most two apart
    in x and in y, so each cell's sites are tested against the sites of its 5 x 5 block
    only, and their rows are packed whole. Table 4.2 density x4 (63,984 sites): the
    search's set-up took 42.8 s with a KD-tree query and a bit update per pair, 9.5 s so
    (the same rows). Raises ``_Timeout`` once ``out_of_time()`` is True (at a cell's end).

    pts: (n, 2) the sites (m); R_d: the drone-cell radius (m); out_of_time: the time test."""
    n = len(pts)
    rows = BitRows(np.zeros((n, (n + 7) // 8), dtype=np.uint8), n)
    if n == 0:
        return rows
    cell = np.floor((pts - pts.min(axis=0)) / R_d).astype(np.int64)
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
            dense[:, near] = pairwise_distances(pts[sites], pts[near]) < 2 * R_d - TOL
            dense[np.arange(len(sites)), sites] = False
            rows.packed[sites] = np.packbits(dense, axis=1, bitorder="little")
        if out_of_time():
            raise _Timeout()
    return rows


def placed(s: SearchView, P: list[int]) -> tuple[np.ndarray, np.ndarray]:
    """(dpp, reach) of a non-empty P: the (|P|, |P|) distances of its sites (m) and which
    of them have a link path (<= r1 + TOL to a GBS, <= r2 + TOL between sites, the
    tests of ``evaluate``) to a GBS through P.

    s: the search; P: the placed sites (indices in the search's order)."""
    pp = s.pts[P]
    dpp = pairwise_distances(pp, pp)
    link = dpp <= s.r2t
    reach = s.dg[P] <= s.r1t
    for _ in range(len(P)):
        nr = reach | np.any(link & reach[None, :], axis=1)
        if np.array_equal(nr, reach):
            break
        reach = nr
    return dpp, reach


def reach_of(s: SearchView, P: list[int]) -> np.ndarray:
    """(|P|,) bool: sites of P with a link path to a GBS through P (:func:`placed`).

    s: the search; P: the placed sites."""
    return placed(s, P)[1]


def connecting(s: SearchView, R: list[int], C: np.ndarray, reach: np.ndarray | None = None) -> np.ndarray:
    """(|C|,) bool: R + q is connected (the link tests of ``evaluate``) for q in C.

    s: the search; R: placed sites; C: candidate sites (indices); reach: ``reach_of(s, R)``
    when the caller has it already."""
    if not R:
        return s.dg[C] <= s.r1t
    pr = s.pts[R]
    reach = reach_of(s, R) if reach is None else reach
    link = pairwise_distances(pr, s.pts[C]) <= s.r2t
    rq = (s.dg[C] <= s.r1t) | np.any(link & reach[:, None], axis=0)
    if reach.all():
        return rq
    adj = pairwise_distances(pr, pr) <= s.r2t
    R2 = reach[:, None] | (link & rq[None, :])
    for _ in range(len(R)):
        nr = R2 | np.any(adj[:, :, None] & R2[None, :, :], axis=1)
        if np.array_equal(nr, R2):
            break
        R2 = nr
    return rq & R2.all(axis=0)


class SearchView(Protocol):
    """What the rules of the ``_bnb_*`` modules read and update on the search
    (``_bnb.BranchAndBoundSearch``, described there): the sites in the search's order, the
    ranges, the incumbent and the rule settings and counters."""

    problem: CellProblem
    cand: Candidates
    n: int
    m: int
    order: np.ndarray
    pts: np.ndarray
    w: np.ndarray
    bits: list[int]
    packed: np.ndarray
    tree: cKDTree
    clique: np.ndarray
    conflict: BitRows
    dg: np.ndarray
    cg: np.ndarray
    r2: float
    r1t: float
    r2t: float
    all_linked: bool
    t0: float
    time_limit: float | None
    node_limit: int | None
    nodes: int
    best_val: int
    best: list[int] | None
    separated: int
    stack_bounds: list[float]
    conf_bound: list[float]
    witness: bool
    dual_from: float
    dual_runs: int
    dual_cuts: int
    lens: dict[int, np.ndarray]
    free: SearchView | None
    exchange_sizes: tuple[int, ...]
    split: tuple[int, int, int]

    def expired(self) -> bool:
        """True once the node budget or the time limit is used up."""
        ...

    def tick(self) -> None:
        """Count a search node and check the limits."""
        ...

    def offer(self, P: list[int]) -> None:
        """Make the placement P the incumbent when feasible and better."""
        ...

    def compatible(self, R: list[int]) -> np.ndarray:
        """(n,) bool: the sites outside R that overlap no site of R."""
        ...

    def bits_of(self, R: list[int]) -> int:
        """S(R) as a bit set."""
        ...

    def link_rows(self) -> LinkRows:
        """The sites within r2 + TOL of each other."""
        ...

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
        """Search (or with ``probe`` only bound) below the node P."""
        ...

    def relaxed(self, problem: CellProblem) -> SearchView:
        """A search of the same sites for ``problem`` sharing this one's site structures."""
        ...

    def relaxed_bound(self, problem: CellProblem, time_limit: float | None) -> float:
        """The bound of a whole search of the same sites for ``problem`` within ``time_limit``."""
        ...


_ROW_CACHE_BYTES = 128 * 2**20
"""Bytes of unpacked conflict rows a :class:`BitRows` keeps."""

_CONFLICT_ROWS = 512
"""``conflict_rows`` tests this many sites of a grid cell at a time (a (rows, n) bool block: 32 MiB
at 64k sites)."""
