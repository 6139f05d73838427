"""Item 11 of the branch and bound (``_bnb``): sibling replacement
(:func:`replaced_by_sibling`, whose docstring gives the exactness argument)."""

from __future__ import annotations

import math

import numpy as np

from droneplan.formulations.cells._bnb_relays import _close, pp_cost, relays_with
from droneplan.formulations.cells._bnb_sites import Node, SearchView


def lens_sites(s: SearchView, a: int) -> np.ndarray:
    """Item 11: the sites within 2 R_d (+ 2 m) of site a that do not overlap it, the
    only ones that can cover users of a when a is placed.

    s: the search; a: a site (index).
    """
    if a not in s.lens:
        near = np.asarray(s.tree.query_ball_point(s.pts[a], 2 * s.problem.R_d + 2.0), dtype=np.int64)
        s.lens[a] = np.sort(near[~s.conflict.at(a, near)])
    return s.lens[a]


def replaced_by_sibling(
    s: SearchView, P: list[int], ubits: int, b: int, cm: np.ndarray, explored: list[int]
) -> bool | np.ndarray | None:
    """Item 11 for the child P + b, given siblings ``explored`` before it: True when a
    sibling can replace b in every completion (skip b), a bool mask E over the sites
    when it can in every completion avoiding E (search only completions meeting E),
    None when no sibling qualifies.

    s: the search; P: the placed sites; ubits: S(P) as a bit set; b: the child's site;
    cm: the child's completion sites (bool over the sites); explored: the siblings searched
    before b, in order.

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
    use the link rows (``link_rows``) and, for the lens, the sites within 2 R_d + 2 m of
    a that do not overlap it (``lens_sites``).
    """
    new_b = s.bits[b] & ~ubits
    best: np.ndarray | None = None
    best_count = 0
    for a in reversed(explored[-_SIBLINGS:]):
        if not _may_replace(s, P, ubits, a, b, new_b, cm):
            continue
        if s.all_linked:  # b links to no site that a does not
            e = cm & s.conflict.row(a)
        else:
            linked = s.link_rows()
            e = cm & (s.conflict.row(a) | (linked.row(b) & ~linked.row(a)))
        count = int(np.count_nonzero(e))
        if count == 0:
            return True
        if best is None or count < best_count:
            best, best_count = e, count
    return best


def _may_replace(s: SearchView, P: list[int], ubits: int, a: int, b: int, new_b: int, cm: np.ndarray) -> bool:
    """Item 11's tests of sibling a against b: close, direct when b is, linked to every
    P site b links to, and covering b's new users or keeping at least as many."""
    if math.dist(s.pts[a], s.pts[b]) > _SIBLING_RADIUS or s.dg[b] <= s.r1t < s.dg[a]:
        return False
    if P and not s.all_linked:
        linked = s.link_rows()
        if np.any(linked.at(b, P) & ~linked.at(a, P)):
            return False
    if not new_b & ~s.bits[a]:
        return True
    # not a cover of b's new users: compare counts instead. A completion site that does
    # not overlap a covers users of a only in a lens at the edge of a's disc (sites
    # within 2 R_d of a); a keeps every other user of its own
    lens = 0
    for q in lens_sites(s, a).tolist():
        if cm[q]:
            lens |= s.bits[q]
    return (s.bits[a] & ~ubits & ~lens).bit_count() >= new_b.bit_count()


def siblings_cut(s: SearchView, node: Node, j: int, cq: np.ndarray, explored: list[int]) -> np.ndarray:
    """Item 11 on the last sites ``cq`` of P + j: the ones a sibling cannot stand in for.

    s: the search; node: the parent node; j: the child's site; cq: its last sites
    (indices); explored: the siblings searched before j.
    """
    in_cq = np.zeros(s.n, dtype=bool)
    in_cq[cq] = True
    replace = replaced_by_sibling(s, node.P, node.ubits, j, in_cq, explored)
    if replace is True:
        return cq[:0]
    if isinstance(replace, np.ndarray):
        return cq[replace[cq]]
    return cq


def must_branch(s: SearchView, node: Node, cmask_must: np.ndarray, nb: float) -> None:
    """Item 11 by branching: search the nodes P + e for the sites e of ``cmask_must``
    (the sites of ``must`` left), each completed from ``cmask`` without the earlier
    ones, so every completion holding a site of ``must`` is searched once. At the split
    depth the e are dealt out like children (``_bnb._split_root``).

    s: the search; node: the node; cmask_must: its completion sites of ``must``; nb: the
    node's bound."""
    P, r = node.P, s.m - node.depth
    rest = node.cmask.copy()
    epp = pp_cost(s, P) if P else np.zeros((0, 0))
    dealt = s.split[1] > 1 and len(P) == s.split[2]
    for pos, e in enumerate(np.flatnonzero(cmask_must).tolist()):
        rest[e] = False
        if dealt and pos % s.split[1] != s.split[0]:
            continue
        nd = relays_with(s, P, node.dist, e, epp)
        if float(nd.max()) > r - 1:  # item 3: P + e needs too many relays
            continue
        pe = [*P, e]
        s.dfs(
            pe,
            node.ubits | s.bits[e],
            rest & ~s.conflict.row(e),
            _close(s.pts[pe], nd, s.r2),
            nb,
        )


_SIBLINGS = 16
"""Item 11: explored siblings tried as replacements of a new child (the latest ones)."""
_SIBLING_RADIUS = 600.0
"""Item 11: only siblings this close (m) are tried; farther ones rarely qualify."""
