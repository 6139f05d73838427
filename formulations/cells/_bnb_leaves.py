"""The last two free slots of the branch and bound (``_bnb``), enumerated without a search
node per site: the same tests as a search node (the order cut of item 4, item 11 against the
siblings, the exact link test of ``evaluate``), vectorised over the candidates."""

from __future__ import annotations

import numpy as np

from droneplan.formulations.cells._bnb_siblings import siblings_cut
from droneplan.formulations.cells._bnb_sites import Node, SearchView, connecting, reach_of


def last_pair(
    s: SearchView, node: Node, j: int, last_two: tuple[np.ndarray, np.ndarray], explored: list[int]
) -> None:
    """The child P + j of a node with two free slots, and its last sites (the tests of
    a search node, vectorised over the candidates).

    s: the search; node: the parent node; j: the child's site; last_two: (the parent's
    completion sites, their weights negated); explored: the siblings searched before j."""
    s.tick()
    full, neg_w = last_two
    z, must = s.best_val, node.must
    ubj = node.ubits | s.bits[j]
    valj = ubj.bit_count()
    lo = int(np.searchsorted(full, j, side="right"))
    hi = int(np.searchsorted(neg_w, valj - z, side="left"))  # w > z - valj
    pj = [*node.P, j]
    if valj > z and reach_of(s, pj).all():  # P + j alone
        s.offer(pj)
    if hi <= lo:
        return
    cq = full[lo:hi]
    cq = cq[~s.conflict.at(j, cq)]
    # item 11 (the lighter last sites are bounded); under ``must`` only for j outside
    # it, whose last site is then in ``must`` in any case
    if must is None or not must[j]:
        if must is not None:
            cq = cq[must[cq]]
        if len(cq):
            cq = siblings_cut(s, node, j, cq, explored)
    last_site(s, pj, ubj, cq, reach_of(s, pj), valj)


def last_site(s: SearchView, P: list[int], ubits: int, C: np.ndarray, reach: np.ndarray, val: int) -> None:
    """The last free slot: every candidate q of C (sorted heaviest first, each keeping
    P + q non-overlapping) that makes P + q connected (the exact link test of
    ``evaluate``), while |S(P)| + |S(q)| can beat the incumbent.

    s: the search; P: the placed sites; ubits: S(P) as a bit set; C: the candidates
    (indices); reach: ``reach_of(s, P)``; val: |S(P)|."""
    C = C[val + s.w[C] > s.best_val]
    if len(C) == 0:
        return
    ok = connecting(s, P, C, reach)
    for q in C[ok].tolist():
        if val + int(s.w[q]) <= s.best_val:
            break
        if (ubits | s.bits[q]).bit_count() > s.best_val:
            s.offer([*P, q])
