"""Item 3 of the branch and bound (``_bnb``): the relay lower bound (:func:`relay_filter`, whose
docstring gives the exactness argument) and the shortest relay counts it reads."""

from __future__ import annotations

import numpy as np

from droneplan.formulations.cells._bnb_sites import Children, Node, SearchView
from droneplan.formulations.cells._core import TOL, pairwise_distances


def _relay_cost(d: np.ndarray, reach: float, r2: float) -> np.ndarray:
    """Lower bound on the relays needed to bridge a distance ``d`` when the first link
    reaches ``reach`` and each further link r2 (tolerances included, item 3)."""
    x = (d - reach - TOL) / (r2 + TOL) - 1e-6
    return np.maximum(np.ceil(x), 0.0)


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


def relay_filter(s: SearchView, node: Node, C: np.ndarray) -> Children | None:
    """Item 3: the candidates j of C for which P + j keeps its relay lower
    bound within the free slots (``need <= r - 1``), with what the children need; None when none.

    s: the search; node: the node of P; C: its candidate children (indices).

    3. **Relay lower bound.** In a connected placement the path from a GBS to a chosen site
    a passes through chosen sites; between consecutive P-sites s, t (or the GBS and the
    first one) on it lie at least ceil((|s - t| - r2 - TOL) / (r2 + TOL)) further sites
    (ceil((|a - G| - r1 - TOL) / (r2 + TOL)) from the GBS), every link being at most
    r2 + TOL (r1 + TOL to a GBS). The shortest such path count over the complete graph
    on P and the GBSs is a lower bound on the relays outside P that P needs, so a branch
    with more needed relays than free slots holds no feasible placement. (Ceilings are
    taken of x - 1e-6 so rounding can only lower the bound.)
    """
    r = s.m - node.depth
    cgj = s.cg[C]
    if node.P:
        dpj = pairwise_distances(s.pts[node.P], s.pts[C])
        ej = _relay_cost(dpj, s.r2, s.r2)  # (|P|, |C|)
        gj, newd = _through(node.dist, gj_direct=cgj, ej=ej, epp=pp_cost(s, node.P))
        need = np.maximum(gj, newd.max(axis=0))
    else:
        gj = need = cgj
        newd = np.zeros((0, len(C)))
        dpj = np.zeros((0, len(C)))
    ok = np.flatnonzero(need <= r - 1)
    if len(ok) == 0:
        return None
    return Children(C, ok, gj, newd, dpj)


def relays_with(s: SearchView, P: list[int], dist: np.ndarray, e: int, epp: np.ndarray) -> np.ndarray:
    """Item 3 for P + e: the relay lower bounds to P's sites and (last) to e.

    s: the search; P: the placed sites; dist: their relay lower bounds from a GBS; e: the
    added site; epp: ``pp_cost(s, P)``."""
    if not P:
        return np.array([s.cg[e]])
    ee = _relay_cost(pairwise_distances(s.pts[P], s.pts[[e]]), s.r2, s.r2)
    ge, nde = _through(dist, gj_direct=s.cg[[e]], ej=ee, epp=epp)
    return np.append(nde[:, 0], ge[0])


def pp_cost(s: SearchView, P: list[int]) -> np.ndarray:
    """(|P|, |P|) relay lower bounds between the sites of P (item 3).

    s: the search; P: the placed sites."""
    pp = s.pts[P]
    return _relay_cost(pairwise_distances(pp, pp), s.r2, s.r2)
