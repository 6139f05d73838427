"""Items 10 and 13 of the branch and bound (``_bnb``): the sites cleared before the search, by
their probe bound (:func:`eliminate_sites`) and by dominance (:func:`drop_dominated`); each
docstring gives the exactness argument. A cleared site can join no better placement, so the
search and the relay rules then see only the sites that can still be used."""

from __future__ import annotations

import math

import numpy as np
from scipy.spatial import cKDTree

from droneplan.formulations.cells._bnb_relaxed import backhaul_free_bounds
from droneplan.formulations.cells._bnb_sites import SearchView
from droneplan.formulations.cells._core import TOL


def eliminate_sites(s: SearchView, alive: np.ndarray) -> None:
    """Items 9-10: fill ``conf_bound`` when not given, then clear in ``alive`` every site
    that no placement better than the incumbent can contain.

    s: the search; alive: (n,) bool over the sites, cleared in place.

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
    """
    if len(s.conf_bound) < s.m:
        backhaul_free_bounds(s)
    alive &= s.w + s.conf_bound[s.m - 1] > s.best_val  # item 10, first test
    todo = np.flatnonzero(alive)
    for _ in range(4):  # item 10, probes, until no site is cleared
        bounds = probe_sites(s, todo, alive)
        if not np.isneginf(bounds).any():
            break
        # a probe's bound falls only as far as clearing other sites lowers it: probe again
        # the sites whose bound came within _REPROBE_MARGIN of the incumbent (at Table 4.2
        # density x 4 a second probe of all 14.9k left cleared 5 sites in 114 s)
        todo = todo[(bounds > -math.inf) & (bounds <= s.best_val + _REPROBE_MARGIN)]


def probe_sites(s: SearchView, sites: np.ndarray, alive: np.ndarray) -> np.ndarray:
    """Item 10's probes (:func:`site_bound`) of ``sites`` (indices) in turn, each cleared
    site at once out of ``alive`` (so later probes see fewer sites); returns their bounds
    (-inf for the cleared ones). Item 7 is left out of the probes after the first
    ``_DUAL_TRIAL`` when it cut fewer than 1 % of the probes it ran in (its bound is only
    an extra cut, so leaving it out keeps every probe valid; at Table 4.2 density x 4 it
    cut no probe the other rules had not, at 4 ms a probe).

    s: the search; sites: the sites to probe (indices); alive: (n,) bool, cleared in place.
    """
    bounds = np.full(len(sites), -math.inf)
    runs0, cuts0, dual_from = s.dual_runs, s.dual_cuts, s.dual_from
    try:
        for k, c in enumerate(sites.tolist()):
            runs = s.dual_runs - runs0
            if k == _DUAL_TRIAL and runs >= _DUAL_TRIAL // 4 and 100 * (s.dual_cuts - cuts0) < runs:
                s.dual_from = math.inf
            b = site_bound(s, c, alive)
            if b is None:
                alive[c] = False
            else:
                bounds[k] = b
    finally:
        s.dual_from = dual_from
    return bounds


def site_bound(s: SearchView, c: int, alive: np.ndarray) -> float | None:
    """Item 10's probe: the bound of the node {c} (items 1-9) over the completions from
    the sites of ``alive`` that do not overlap c; None when no placement holding c and
    otherwise sites of ``alive`` can beat the incumbent.

    s: the search; c: the site; alive: (n,) bool, the sites still usable.
    """
    cm = alive & ~s.conflict.row(c)
    cm[c] = False
    return s.dfs([c], s.bits[c], cm, s.cg[[c]], math.inf, probe=True)


def site_can_improve(s: SearchView, c: int, alive: np.ndarray) -> bool:
    """Item 10: False when no placement holding site c and otherwise sites of ``alive``
    can beat the incumbent (:func:`site_bound`).

    s: the search; c: the site; alive: (n,) bool, the sites still usable.
    """
    return site_bound(s, c, alive) is not None


def drop_dominated(s: SearchView, alive: np.ndarray) -> int:
    """Item 13: clear in ``alive`` every site dominated by another alive site; returns
    how many were cleared.

    s: the search; alive: (n,) bool over the sites, cleared in place.

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
    """
    idx = np.flatnonzero(alive)
    if len(idx) < 2:
        return 0
    pts = s.pts[idx]
    tree = cKDTree(pts)
    pairs = tree.query_pairs(_DOMINANCE_RADIUS, output_type="ndarray")
    if len(pairs) == 0:
        return 0
    # (c, d) with d earlier in the search order (so w[d] >= w[c]), as positions in idx
    pairs = np.sort(pairs, axis=1)
    d_loc, c_loc = pairs[:, 0], pairs[:, 1]
    c, d = idx[c_loc], idx[d_loc]
    direct = s.dg <= s.r1t
    ok = ~direct[c] | direct[d]
    for lo in range(0, len(c), 4096):  # S(c) within S(d), a block of pairs at a time
        sl = slice(lo, lo + 4096)
        ok[sl] &= ~np.any(s.packed[c[sl]] & ~s.packed[d[sl]], axis=1)
    c_loc, c, d = c_loc[ok], c[ok], d[ok]
    if len(c) == 0:
        return 0
    gap = np.hypot(*(s.pts[c] - s.pts[d]).T)
    at = pts[c_loc]
    r_conf = 2 * s.problem.R_d - TOL

    def annulus(inner: np.ndarray | float, outer: np.ndarray | float) -> np.ndarray:
        """Alive sites within [inner - 1e-6, outer + 1e-6] of c (a superset of the annulus)."""
        far = tree.query_ball_point(at, np.asarray(outer) + 1e-6, return_length=True)
        near = tree.query_ball_point(at, np.maximum(np.asarray(inner) - 1e-6, 0.0), return_length=True)
        return far - near

    # sites overlapping d but not c, or linked to c but not to d: none on these annuli
    ok = annulus(r_conf, r_conf + gap) == 0
    ok &= annulus(s.r2t - gap, s.r2t) == 0
    # a pair's own sites lie inside both inner discs (the gap is far below 2 R_d - TOL)
    ok &= gap < min(r_conf, s.r2t) / 2
    drop = np.unique(c[ok])
    alive[drop] = False
    return len(drop)


_REPROBE_MARGIN = 2
"""Item 10: after a probe round that cleared sites, the sites whose bound came within this
many users of the incumbent are probed again."""
_DUAL_TRIAL = 1000
"""Item 10: probes after which item 7 is left out of the rest when it cut almost none."""

_DOMINANCE_RADIUS = 50.0
"""Item 13: dominating sites are sought this close (m); farther pairs rarely qualify, as
their annuli are wide."""
