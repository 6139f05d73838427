"""The candidate model with altitude levels: each drone-cell flies at one level h and covers the
users within R(h) of its ground position (``CellProblem(altitudes=, channel=)``).

Sites are the candidate sites of every level (``candidate_sites``: each level's construction
with its own radius), so a site is a (position, level) pair. The model::

    max  covered (or served) weight                       (``_model._objective_part``)
    s.t. sum_s x_s <= m
         x_s + x_t <= 1      ground |s - t| < R(h_s) + R(h_t)          (4.8 with two radii)
         hop levels: z_{s,l} <= sum_{t in N(s)} z_{t,l-1},  x_s = sum_l z_{s,l}   (backhaul)

N(s) holds the sites within r2 of s in 3-D that do not overlap s (an overlapping one is never
chosen with s); level 1 is the direct sites (3-D distance to a GBS at height 0 within r1), whose
z is x. The hop labelling is exact as for the thesis model (``_milp``, item 3b): a hop count on a
shortest backhaul path meets the rows, and by induction on l every labelled site reaches a GBS.
Non-overlap is written pair by pair (cKDTree), so the model grows with the conflicting pairs:
meant for instances up to a few thousand sites. :class:`SiteBlock` writes one such placement into
a model, also at one altitude (the epochs of ``_mobile``).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from scipy.spatial import cKDTree

from droneplan.formulations.cells._core import TOL, Candidates, candidate_sites
from droneplan.formulations.cells._model import CellModel, _new_model, _objective_part, _sites_by_user
from droneplan.scenarios.cells import CellProblem

__all__ = ["build_level_model", "SiteBlock"]


def build_level_model(problem: CellProblem, *, backend: str = "cp-sat") -> CellModel:
    """The candidate model of a problem with altitude levels (module docstring) on ``backend``."""
    if problem.altitudes is None:
        raise ValueError("build_level_model needs a problem with altitude levels")
    lin = _new_model(backend)
    block = SiteBlock(lin, problem)
    if block.x:
        lin.maximize(block.objective)
    return CellModel(
        problem=problem,
        backend=backend,
        points=block.cand.points,
        cover=block.cand.cover,
        direct=block.cand.direct,
        model=lin,
        x=block.x,
        y=block.y,
        levels=block.z,
        stats=block.stats,
        objective=block.objective,
        group_of=block.group_of,
        serve=block.serve,
        user_sites=_sites_by_user(block.cand.cover),
        site_heights=block.heights,
    )


class SiteBlock:
    """One placement written into the linear model ``lin``: the candidate sites of ``problem``
    (or ``cand``, candidates of ``problem`` built by the caller)
    (any variant; at one altitude the heights are 0 and every radius is R_d), their variables
    and rows (module docstring). Its objective is returned, not set, so that several blocks (the
    epochs of moving users) share one model."""

    def __init__(self, lin, problem: CellProblem, cand: Candidates | None = None) -> None:
        self.cand = candidate_sites(problem) if cand is None else cand
        pts = self.cand.points
        self.heights = np.zeros(len(pts)) if self.cand.heights is None else self.cand.heights
        self.radius = np.full(len(pts), problem.R_d) if self.cand.radius is None else self.cand.radius
        self.x = [lin.bool_var(f"x{i}") for i in range(len(pts))]
        self.y, self.objective, _, _, self.group_of, self.serve = _objective_part(
            lin, self.x, pts, self.cand.cover, problem, False
        )
        levels = 1 if problem.altitudes is None else len(problem.altitudes)
        self.stats: dict[str, Any] = {"candidates": len(pts), "kept": len(pts), "levels": levels}
        self.z: dict[tuple[int, int], Any] = {}
        if self.x:
            lin.add(lin.sum(self.x) <= problem.n_cells)
            overlap = _conflicting_pairs(pts, self.radius)
            for i, j in overlap:
                lin.add(self.x[i] + self.x[j] <= 1)
            self.z, self.stats["connectivity_terms"] = _hop_rows(
                lin, self.x, pts, self.heights, self.radius, self.cand.direct, problem
            )
            self.stats["pairs"] = len(overlap)


def _conflicting_pairs(pts: np.ndarray, radius: np.ndarray) -> list[tuple[int, int]]:
    """Pairs of sites closer on the ground than the sum of their radii (minus ``TOL``)."""
    if len(pts) < 2:
        return []
    tree = cKDTree(pts)
    near = tree.query_pairs(2.0 * float(radius.max()), output_type="ndarray")
    if not len(near):
        return []
    d = np.hypot(*(pts[near[:, 0]] - pts[near[:, 1]]).T)
    keep = d < radius[near[:, 0]] + radius[near[:, 1]] - TOL
    return [(int(i), int(j)) for i, j in near[keep]]


def _hop_rows(
    lin,
    x: list,
    pts: np.ndarray,
    heights: np.ndarray,
    radius: np.ndarray,
    direct: np.ndarray,
    problem: CellProblem,
) -> tuple[dict, int]:
    """The hop-level rows (module docstring); returns (z by (site, level), terms written)."""
    m = problem.n_cells
    far = np.flatnonzero(~direct)
    z: dict[tuple[int, int], Any] = {}
    if not len(far):
        return z, 0
    if m < 2:
        for s in far.tolist():
            lin.add(x[s] == 0)
        return z, 0
    tree = cKDTree(pts)
    for s in far.tolist():
        for level in range(2, m + 1):
            z[(s, level)] = lin.bool_var(f"z{s}_{level}")
        lin.add(x[s] == lin.sum(z[(s, level)] for level in range(2, m + 1)))
    terms = 0
    for s in far.tolist():
        cand = np.asarray(tree.query_ball_point(pts[s], problem.r2 + TOL), dtype=np.int64)
        cand = cand[cand != s]
        ground = np.hypot(*(pts[cand] - pts[s]).T)
        linked = np.hypot(ground, heights[cand] - heights[s]) <= problem.r2 + TOL
        apart = ground >= radius[cand] + radius[s] - TOL
        neighbours = cand[linked & apart].tolist()
        for level in range(2, m + 1):
            feed = [x[t] for t in neighbours if direct[t]] if level == 2 else []
            feed += [z[(t, level - 1)] for t in neighbours if not direct[t] and level - 1 >= 2]
            lin.add(z[(s, level)] <= lin.sum(feed))
            terms += len(feed)
    return z, terms
