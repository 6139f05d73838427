"""The primal heuristics of the branch and bound (``_bnb``): a 1-swap local search, then an
exchange search that re-solves exactly (with the search below, rooted there) every incumbent
minus 1 or 2 of its sites (minus 3 as well in the polish of ``_exact``, ``exchange_sizes``).
Both only propose placements, checked with ``evaluate`` before they become the incumbent
(``offer``); exactness rests on the bounds alone."""

from __future__ import annotations

import contextlib
import itertools
import math

import numpy as np

from droneplan.formulations.cells._bnb_relays import _close
from droneplan.formulations.cells._bnb_sites import SearchView, _popcount_rows, _Timeout, connecting


def local_search(s: SearchView, X: list[int]) -> None:
    """Primal heuristic (no effect on exactness): replace one site of X by the candidate
    that covers most, keeping X feasible, while that improves; the result becomes the
    incumbent only after ``evaluate`` confirms it.

    s: the search; X: a feasible placement (site indices).
    """
    cur = int(_popcount_rows(np.bitwise_or.reduce(s.packed[X], axis=0)[None, :])[0]) if X else 0
    for _ in range(50):
        if s.expired():
            break
        moved = _swap(s, X, cur)
        if moved is None:
            break
        X, cur = moved
    s.offer(X)


def _swap(s: SearchView, X: list[int], cur: int) -> tuple[list[int], int] | None:
    """One improving move of :func:`local_search` (None when there is none)."""
    for i in range(len(X) + (len(X) < s.m)):
        R = X[:i] + X[i + 1 :]
        C = np.flatnonzero(s.compatible(R))
        if len(C) == 0:
            continue
        covR = np.bitwise_or.reduce(s.packed[R], axis=0) if R else np.zeros(s.packed.shape[1], s.packed.dtype)
        valR = int(_popcount_rows(covR[None, :])[0])
        gain = _popcount_rows(s.packed[C] & ~covR)
        good = np.flatnonzero(valR + gain > cur)
        if len(good):
            good = good[connecting(s, R, C[good])]
        if len(good):
            q = int(C[good[np.argmax(gain[good])]])
            return [*R, q], valR + int(gain[good].max())
    return None


def exchange(s: SearchView, X: list[int]) -> None:
    """Primal heuristic (no effect on exactness): for every set D of sites of the
    incumbent X, of each size in ``exchange_sizes`` in turn, search all completions of
    X - D exactly (the search below, rooted at X - D) for one better than the incumbent;
    repeat from each improvement.

    s: the search; X: the incumbent (site indices).
    """
    better: list[int] | None = X
    while better is not None and not s.expired():
        better = _exchange_pass(s, better)


def _exchange_pass(s: SearchView, X: list[int]) -> list[int] | None:
    """One pass of :func:`exchange`: the improved incumbent's sites, or None."""
    for k in s.exchange_sizes:
        for D in itertools.combinations(range(len(X)), k):
            R = sorted(X[i] for i in range(len(X)) if i not in D)
            mask = s.compatible(R)
            before = s.best_val
            s.dfs(R, s.bits_of(R), mask, _close(s.pts[R], s.cg[R], s.r2), math.inf)
            if s.best_val > before and s.best is not None:
                return sorted(s.best)
    return None


def improve_start(s: SearchView, incumbent: np.ndarray) -> None:
    """The primal heuristics from the incumbent's sites (when all are candidates).

    s: the search; incumbent: (k, 2) the start placement (m).
    """
    start = []
    for p0 in incumbent:
        hit = np.flatnonzero(np.hypot(*(s.pts - p0).T) <= 1e-3)
        if len(hit):
            start.append(int(hit[0]))
    if len(start) != len(incumbent):
        return
    local_search(s, sorted(set(start)))
    if s.best is None:
        s.best = sorted(set(start))
    with contextlib.suppress(_Timeout):
        exchange(s, s.best)
