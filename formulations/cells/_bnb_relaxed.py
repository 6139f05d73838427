"""Items 9 and 14 of the branch and bound (``_bnb``): the backhaul-free relaxation, its bounds
B_k (:func:`backhaul_free_bounds`) and the backhaul-free completion below a node
(:func:`free_completion`, whose docstring gives the exactness argument)."""

from __future__ import annotations

import math
import time

import numpy as np

from droneplan.formulations.cells._bnb_sites import Node, SearchView, _Timeout, _Witness
from droneplan.formulations.cells._core import pairwise_distances
from droneplan.scenarios.cells import CellProblem


def backhaul_free_bounds(s: SearchView) -> None:
    """Item 9: fill ``conf_bound`` (B_0, ..., B_{m-1}) from exact backhaul-free searches.
    They get at most a quarter of the time left (a search cut short still returns a
    valid bound); each one eliminates sites with the bounds of the smaller ones.

    s: the search (its ``conf_bound`` is filled).

    Item 9 (the backhaul-free bounds) and why they are exact: :func:`_bnb_bounds.node_bound`.
    """
    unlinked = _without_backhaul(s.problem, s.pts)
    s.conf_bound[:] = [0.0]
    t_b = time.perf_counter()
    budget = None if s.time_limit is None else 0.25 * (s.time_limit - (t_b - s.t0))
    for k in range(1, s.m):
        if s.expired():
            raise _Timeout
        left = None if budget is None else max(budget - (time.perf_counter() - t_b), 0.01)
        s.conf_bound.append(s.relaxed_bound(unlinked(k), left))


def free_completion(s: SearchView, node: Node, node_limit: int | None = None) -> bool | None:
    """Item 14: whether some completion Q of the node makes P + Q cover more than the
    incumbent z with backhaul dropped (every site linked; ``cmask`` and ``must`` kept),
    found by the exact search of item 9 rooted at P, which stops at the first such
    placement. False: no feasible placement below the node beats z either. None when the
    relaxed search stops at its node budget (``node_limit``, default ``_FREE_NODES``) or
    the time limit first: nothing is known then.

    s: the search; node: the node; node_limit: the relaxed search's node budget.

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
    """
    free = s.free
    if free is None:
        unlinked = _without_backhaul(s.problem, s.pts)(s.m)
        free = s.free = s.relaxed(unlinked)
        free.witness = True
        free.dual_from = math.inf  # item 7 cost more than it cut there
    free.conf_bound = s.conf_bound  # B_k bound the relaxed problem too (item 9)
    free.best_val, free.best, free.nodes = s.best_val, None, 0
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


def _without_backhaul(problem: CellProblem, pts: np.ndarray):
    """k -> the problem with k drone-cells whose backhaul ranges reach every candidate
    site from every GBS and from each other (the relaxation of items 9-10; users, radii,
    GBS cells and bounds unchanged).

    problem: the CellProblem; pts: (n, 2) the candidate sites (m)."""
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


_FREE_NODES = 20_000
"""Item 14: node budget of one relaxed completion search."""
