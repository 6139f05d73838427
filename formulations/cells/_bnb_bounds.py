"""The node bound of the branch and bound (``_bnb``): items 1, 2, 4-6, 8 and 9 of its rules, one
function each, and :func:`node_bound`, which combines them with item 7 (``_bnb_dual``), item 11's
slot (``_bnb_siblings``) and item 12 (``_bnb_groups``). Each function's docstring gives the
exactness argument of its item; item 3 (the relay lower bound) is in ``_bnb_relays``.

A branch is cut only when a valid upper bound on everything below it is <= the incumbent value,
and a node's bound is the least of all the rules."""

from __future__ import annotations

import math

import numpy as np

from droneplan.formulations.cells._bnb_dual import greedy_dual
from droneplan.formulations.cells._bnb_groups import separated_bound
from droneplan.formulations.cells._bnb_relays import relay_filter
from droneplan.formulations.cells._bnb_sites import Children, Node, SearchView


def top_cliques(s: SearchView, idx: np.ndarray, k: int) -> list[int]:
    """The k largest per-clique maxima over the sites ``idx`` (sorted heaviest first).

    s: the search; idx: site indices (heaviest first); k: how many.
    """
    out: list[int] = []
    if k <= 0:
        return out
    seen: set[int] = set()
    for lo in range(0, len(idx), 64):
        part = idx[lo : lo + 64]
        for t, c in zip(part.tolist(), s.clique[part].tolist(), strict=True):
            if c not in seen:
                seen.add(c)
                out.append(int(s.w[t]))
                if len(out) == k:
                    return out
    return out


def clique_values(s: SearchView, Cok: np.ndarray, r: int, w_th: int) -> list[int]:
    """Items 1, 2 and 4: r values, the i-th bounding the weight of the i-th heaviest site
    of any completion from ``Cok`` plus sites lighter than ``w_th`` (cut by item 4): the
    r largest per-clique maxima over ``Cok``, padded with ``w_th``.

    s: the search; Cok: the candidates that pass items 3-4 (heaviest first); r: free
    slots; w_th: the weight bound of the sites item 4 cut.

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

    4. **Order cut.** Sites after i weigh at most |S(j)| for the next candidate j, so once
    |S(P)| + r |S(j)| <= incumbent no later candidate can lead above it. Sites cut this
    way weigh at most w_th = floor((z - |S(P)|) / r); they may still be the lighter
    members of a completion, so the clique values of item 2 are padded with w_th when
    fewer than r cliques remain among the heavier sites.
    """
    tops = top_cliques(s, Cok, r)
    return tops + [w_th] * (r - len(tops))


def linkable_weight(s: SearchView, kids: Children, w_th: int) -> int:
    """Item 6: the first completion site on a path from a GBS links to a GBS or to a
    reached P site, so its relay lower bound gj is 0: one slot holds at most the
    heaviest candidate with gj = 0 (or a site cut by item 4, of weight <= ``w_th``).

    s: the search; kids: the node's children (:class:`Children`); w_th: item 4's weight bound.

    6. **Linkable slot.** The first completion site on a path from a GBS links to a GBS or
    to a P site reached through P, so its relay lower bound (item 3) is 0; one slot holds
    at most the heaviest candidate with that bound 0 (and a node with none has no
    non-empty completion).
    """
    Cok = kids.C[kids.ok]
    g0 = kids.gj[kids.ok] <= 0
    return max(int(s.w[Cok[g0][0]]) if g0.any() else 0, w_th)


def unreached_bounds(
    s: SearchView, node: Node, kids: Children, tops: list[int], w_th: int, wg: int, b: float
) -> tuple[float, float]:
    """Items 5, 8 and 12 at a node whose P has unreached sites (and r >= 2 free
    slots): returns (b lowered by items 5 and 8, item 12's bound or inf).

    s: the search; node: the node; kids: its children; tops: the clique values (items 2, 4);
    w_th: item 4's weight bound; wg: item 6's linkable weight; b: the bound so far.

    5. **Bridge slot.** If some P sites have no link path to a GBS through P (the link
    tests of ``evaluate``), the first site off that group on a path to a GBS is a
    completion site within r2 + TOL of one of them; so one of the r slots holds at most
    the heaviest such candidate.

    8. **Two relay slots.** If an unreached P site a has relay lower bound >= 2, its path
    to a GBS holds >= 2 completion sites; the one next to the GBS side (item 6) and the
    one next to a's group (item 5) are then distinct, so two slots are bounded by the
    heaviest linkable and the heaviest bridge candidate (items 5, 6 and 7 combined).
    """
    val, r = node.val, s.m - node.depth
    Cok = kids.C[kids.ok]
    # item 5: the P sites without a link path to a GBS need a chosen site of the
    # completion within r2 + TOL of one of them (the first site off that group on a
    # path to a GBS); that slot holds at most the heaviest such site
    near = np.any(kids.dpj[:, kids.ok][~node.reach] <= s.r2t, axis=0)
    wb = max(int(s.w[Cok[near][0]]) if near.any() else 0, w_th)
    b = min(b, val + wb + sum(tops[: r - 1]))
    if float(node.dist[~node.reach].max()) >= 2:  # item 8
        b = min(b, val + wb + wg + sum(tops[: r - 2]))
    sep = separated_bound(s, node, r, tops)  # item 12
    if val + sep < b:
        s.separated += 1
        return b, val + sep
    return b, math.inf


def node_bound(s: SearchView, node: Node, nb: float) -> Children | None:
    """Every rule at a node with r >= 2 free slots: None when no completion can beat the
    incumbent, else its children with the node bound (``Children.bound``); ``nb``: the
    parent's bound.

    s: the search; node: the node.

    9. **Backhaul-free bounds.** Dropping backhaul leaves the same problem on the same
    candidates with every site linked (``_without_backhaul``: ranges beyond every
    candidate). Its optimum B_k for k sites, found by this search (items 1-8; the
    relay items then never bind), bounds any k pairwise non-overlapping candidates, so a
    node with r free slots holds at most |S(P)| + B_r (a union is at most the sum).
    """
    z, val, r = s.best_val, node.val, s.m - node.depth
    full = np.flatnonzero(node.cmask)
    C = full[val + r * s.w[full] > z]  # item 4
    if len(C) == 0:
        return None
    kids = relay_filter(s, node, C)
    if kids is None:
        return None
    # node bound: items 1-2 over the sites that can still join (need <= r - 1). Sites
    # cut by item 4 weigh at most w_th; they may still be the lighter members of a
    # completion, so missing clique values are padded with w_th.
    w_th = max((z - val) // r, 0)
    tops = clique_values(s, kids.C[kids.ok], r, w_th)
    b: float = val + sum(tops)
    wg = linkable_weight(s, kids, w_th)
    b = min(b, val + wg + sum(tops[: r - 1]))
    b_sep = math.inf
    if not node.reach.all():
        b, b_sep = unreached_bounds(s, node, kids, tops, w_th, wg, b)
    if node.cmask_must is not None:  # item 11: one slot holds a site of ``must``
        w_must = int(s.w[np.flatnonzero(node.cmask_must)[0]])
        b = min(b, val + w_must + sum(tops[: r - 1]))
    bf = min(float(b), nb, b_sep)
    if r < len(s.conf_bound):  # item 9
        bf = min(bf, val + s.conf_bound[r])
    if bf <= z:
        return None
    if r >= s.dual_from:  # item 7 (the costliest rule, last) over every candidate of item 3
        s.dual_runs += 1
        bf = min(bf, val + greedy_dual(s, node.P, full, node.dist, node.reach, r))
        if bf <= z:
            s.dual_cuts += 1
            return None
    kids.bound = bf
    return kids
