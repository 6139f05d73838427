"""Item 7 of the branch and bound (``_bnb``): the greedy dual of coverage
(:func:`greedy_dual`, whose docstring gives the exactness argument)."""

from __future__ import annotations

import math

import numpy as np

from droneplan.formulations.cells._bnb_relays import _relay_cost, _through, pp_cost
from droneplan.formulations.cells._bnb_sites import SearchView, _masked_max, _popcount_rows
from droneplan.formulations.cells._core import pairwise_distances


def greedy_dual(
    s: SearchView, P: list[int], C: np.ndarray, dist: np.ndarray, reach: np.ndarray, r: int
) -> float:
    """Item 7: an upper bound on |S(Q) - S(P)| over completions Q of at most r sites of
    C that fit the relay bound of P + q, by submodularity of coverage (-inf when P
    cannot be completed).

    s: the search; P: the placed sites; C: the candidate sites (indices, in the search order);
    dist: P's relay lower bounds (item 3); reach: which P sites reach a GBS; r: free slots.

    7. **Greedy dual of coverage.** For any set G of sites, coverage is monotone and
    submodular, so |S(Q) - S(P)| <= f(G) + sum_{q in Q} gain(q | G) <= f(G) + the r
    largest gains (f, gains over the users outside S(P), Q among the candidates that pass
    item 3); G runs through the greedy sets G_0 = {}, G_1, ..., G_r, and item 6 applies to
    the gains as well. Used at nodes with >= 3 free slots (at 2 it cost more than it cut),
    and only where the other rules did not cut the node (it is the costliest: a node's bound
    is the least of all the rules either way).
    """
    if P:
        kept = _dual_candidates(s, P, C, dist, reach, r)
        if kept is None:
            return -math.inf  # P cannot be completed: no feasible placement below
        C, g0, covered, near = kept
    else:
        C = C[s.cg[C] <= r - 1]
        g0 = s.cg[C] <= 0
        covered = np.zeros(s.packed.shape[1], dtype=s.packed.dtype)
        near = None
    if len(C) == 0 or not g0.any():
        return 0.0  # item 6: a non-empty completion holds a site with gj = 0
    two = near is not None and r >= 2 and float(dist[~reach].max()) >= 2
    return _greedy_gains(s, C, covered, g0, near, two, r)


def _dual_candidates(s: SearchView, P: list[int], C: np.ndarray, dist: np.ndarray, reach: np.ndarray, r: int):
    """Item 7's candidates below a non-empty P: (C, g0, covered, near) with the sites
    of C that pass item 3, which of them have gj = 0 (item 6), S(P) as packed rows, and
    the bridge candidates of item 5 (None when P is reached); None when none exists."""
    pp = s.pts[P]
    ej = _relay_cost(pairwise_distances(pp, s.pts[C]), s.r2, s.r2)
    gj, newd = _through(dist, gj_direct=s.cg[C], ej=ej, epp=pp_cost(s, P))
    need = np.maximum(gj, newd.max(axis=0))
    keep = need <= r - 1
    C, g0 = C[keep], gj[keep] <= 0
    covered = np.bitwise_or.reduce(s.packed[P], axis=0)
    near = None
    if not reach.all():  # item 5: bridge candidates, within r2 + TOL of an unreached P site
        near = np.any(pairwise_distances(pp[~reach], s.pts[C]) <= s.r2t, axis=0)
        if not near.any():
            return None
    return C, g0, covered, near


def _greedy_gains(
    s: SearchView,
    C: np.ndarray,
    covered: np.ndarray,
    g0: np.ndarray,
    near: np.ndarray | None,
    two: bool,
    r: int,
) -> float:
    """Item 7's loop over the greedy sets G_0, ..., G_r (with items 5, 6 and 8) over the
    sites C (in the search order, so by weight, heaviest first)."""
    masks = [g0] if near is None else [g0, near]
    f_g = 0
    best = math.inf
    end = 0
    for k in range(r + 1):
        gain, end = _lazy_gains(s, C, covered, masks, r, end)
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
        covered = covered | s.packed[C[g]]
    return float(best)


def _lazy_gains(
    s: SearchView, C: np.ndarray, covered: np.ndarray, masks: list[np.ndarray], r: int, end: int
) -> tuple[np.ndarray, int]:
    """Item 7's gains |S(c) - covered| of a prefix C[:e] (e >= ``end``) that holds every
    value the greedy step reads: the r largest gains, the largest under each mask and
    the largest of all. A gain is at most the site's weight and C runs by weight, so the
    sites after C[e] (weight <= w[C[e]]) change none of them once w[C[e]] is at most the
    r-th largest gain and at most each mask's largest (ties leave every sum unchanged)."""
    n = len(C)
    end = min(n, max(end, 8 * r, 256))
    while True:
        gain = _popcount_rows(s.packed[C[:end]] & ~covered)
        if end == n:
            return gain, end
        thr = int(np.partition(gain, len(gain) - r)[-r]) if len(gain) >= r else -1
        for mask in masks:
            thr = min(thr, _masked_max(gain, mask[:end]))
        if int(s.w[C[end]]) <= thr:
            return gain, end
        end = min(n, 4 * end)
