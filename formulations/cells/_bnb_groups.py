"""Item 12 of the branch and bound (``_bnb``): far-apart unreached groups of placed sites
(:func:`_separated_groups`, whose docstring gives the exactness argument)."""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from droneplan.formulations.cells._bnb_sites import LinkRows, Node, SearchView
from droneplan.formulations.cells._core import pairwise_distances


def separated_bound(s: SearchView, node: Node, r: int, tops: list[int]) -> float:
    """Item 12 (:func:`_separated_groups`) at the node: a bound on the completion's weight.

    s: the search; node: the node; r: its free slots; tops: the clique values of item 2."""
    return _separated_groups(
        s.pts,
        s.w,
        s.dg,
        node.P,
        node.dpp,
        node.reach,
        node.cmask,
        r,
        tops,
        s.r1t,
        s.r2t,
        s.link_rows(),
    )


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
    (:class:`LinkRows`, or its rows as one packed array), built here if None.

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
    """
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


_LINK_ROWS_MAX = 64
"""Item 12: beyond this many bridge candidates their links are found with a KD-tree rather
than by their rows (stacking thousands of rows took 250 of 600 s at density x 4)."""

_SUCCESSOR_PREFIX = 512
"""Item 12: the successor link test runs on this many of the heaviest sites near a group
(``_successor_sites``)."""
