"""The candidate model with altitude levels: each drone-cell flies at one level h and covers the
users within R(h) of its ground position (``CellProblem(altitudes=, channel=)``).

Sites are the candidate sites of every level (``candidate_sites``: each level's construction
with its own radius), so a site is a (position, level) pair. The model::

    max  covered (or served) weight                       (``_model._objective_part``)
    s.t. sum_s x_s <= m
         sum_{s in K} x_s <= 1   ground |s - t| < R(h_s) + R(h_t) for s, t in K  (4.8, two radii)
         hop levels: z_{s,l} <= sum_{t in N(s)} z_{t,l-1},  x_s = sum_l z_{s,l}   (backhaul)

N(s) holds the sites within r2 of s in 3-D that do not overlap s (an overlapping one is never
chosen with s); level 1 is the direct sites (3-D distance to a GBS at height 0 within r1), whose
z is x. The hop labelling is exact as for the thesis model (``_milp``, item 3b): a hop count on a
shortest backhaul path meets the rows, and by induction on l every labelled site reaches a GBS.
Non-overlap is written as cliques K (:func:`_overlap_cliques`): sites in one half-open square
of side (2 R_min - TOL) / sqrt(2) (R_min the smallest radius), then each remaining conflicting
pair in the row of its smaller-radius site, grouped by the partner's level and a 60-degree
sector. The model still grows with the conflicting pairs (each is a term of one row): meant for
instances up to some ten thousand sites. :class:`SiteBlock` writes one such placement into
a model, also at one altitude (the epochs of ``_mobile``).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

import numpy as np
from scipy.spatial import cKDTree

from droneplan.formulations.cells._core import TOL, Candidates, candidate_sites
from droneplan.formulations.cells._model import CellModel, _new_model, _objective_part, _sites_by_user
from droneplan.scenarios.cells import CellProblem

__all__ = ["build_level_model", "SiteBlock"]


def build_level_model(
    problem: CellProblem, *, backend: str = "cp-sat", deadline: float | None = None
) -> CellModel | None:
    """The candidate model of a problem with altitude levels (module docstring) on ``backend``;
    None when ``deadline`` (a ``time.perf_counter()`` value; None: none) passes while it is built."""
    if problem.altitudes is None:
        raise ValueError("build_level_model needs a problem with altitude levels")
    lin = _new_model(backend)
    block = SiteBlock(lin, problem, late=lambda: deadline is not None and time.perf_counter() > deadline)
    if not block.complete:
        return None
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
    epochs of moving users) share one model. ``late()`` (None: never) is asked while the rows
    are written; once it is true the block stops and ``complete`` is False."""

    def __init__(
        self,
        lin,
        problem: CellProblem,
        cand: Candidates | None = None,
        late: Callable[[], bool] | None = None,
    ) -> None:
        self.complete = False
        self.cand = candidate_sites(problem) if cand is None else cand
        pts = self.cand.points
        self.heights = np.zeros(len(pts)) if self.cand.heights is None else self.cand.heights
        self.radius = np.full(len(pts), problem.R_d) if self.cand.radius is None else self.cand.radius
        self.x = [lin.bool_var(f"x{i}") for i in range(len(pts))]
        self.y, self.objective, _, _, self.group_of, self.serve = _objective_part(
            lin, self.x, pts, self.cand.cover, problem, True, self.radius
        )
        levels = 1 if problem.altitudes is None else len(problem.altitudes)
        self.stats: dict[str, Any] = {"candidates": len(pts), "kept": len(pts), "levels": levels}
        self.z: dict[tuple[int, int], Any] = {}
        if self.x:
            lin.add(lin.sum(self.x) <= problem.n_cells)
            overlap = _conflicting_pairs(pts, self.radius)
            cliques = _overlap_cliques(pts, self.radius, self.heights, overlap)
            for clique in cliques:
                lin.add(lin.sum(self.x[i] for i in clique.tolist()) <= 1)
            hops = _hop_rows(lin, self.x, pts, self.heights, self.radius, self.cand.direct, problem, late)
            if hops is None:
                return
            self.z, self.stats["connectivity_terms"] = hops
            self.stats["pairs"] = len(overlap)
            self.stats["cliques"] = len(cliques)
        self.complete = True


def _conflicting_pairs(pts: np.ndarray, radius: np.ndarray) -> np.ndarray:
    """Pairs (i, j), i < j, of sites closer on the ground than the sum of their radii (minus
    ``TOL``): an (P, 2) int array."""
    none = np.zeros((0, 2), dtype=np.int64)
    if len(pts) < 2:
        return none
    near = cKDTree(pts).query_pairs(2.0 * float(radius.max()), output_type="ndarray")
    if not len(near):
        return none
    d = np.hypot(*(pts[near[:, 0]] - pts[near[:, 1]]).T)
    return near[d < radius[near[:, 0]] + radius[near[:, 1]] - TOL].astype(np.int64)


def _overlap_cliques(
    pts: np.ndarray, radius: np.ndarray, heights: np.ndarray, pairs: np.ndarray
) -> list[np.ndarray]:
    """The conflicting ``pairs`` as clique rows (each pair inside at least one row).

    Squares: two sites in one half-open square of side L / sqrt(2), L = 2 R_min - TOL, are less
    than L <= R_i + R_j - TOL apart. Sectors: a pair (a, b) is oriented so that R_a <= R_b (ties
    by index) and grouped by a, b's level and b's 60-degree sector around a; two partners b, b'
    of one group at distances p, q < R_a + R_b from a are apart by less than max(p, q) (their
    directions differ by less than 60 degrees) < R_a + R_b <= 2 R_b = R_b + R_b', so they
    conflict and the group is a clique."""
    if not len(pairs):
        return []
    side = (2.0 * float(radius.min()) - TOL) / np.sqrt(2.0)
    cliques: list[np.ndarray] = []
    in_square = np.zeros(len(pairs), dtype=bool)
    for shift in ((0.0, 0.0), (0.5, 0.0), (0.0, 0.5), (0.5, 0.5)):
        key = np.floor(pts / side - np.asarray(shift)).astype(np.int64)
        _, cell = np.unique(key, axis=0, return_inverse=True)
        cell = cell.ravel()
        order = np.argsort(cell, kind="stable")
        cuts = np.flatnonzero(np.diff(cell[order])) + 1
        cliques.extend(np.sort(g) for g in np.split(order, cuts) if len(g) > 1)
        in_square |= cell[pairs[:, 0]] == cell[pairs[:, 1]]
    rest = pairs[~in_square]
    if not len(rest):
        return cliques
    flip = (radius[rest[:, 0]] > radius[rest[:, 1]]) | (
        (radius[rest[:, 0]] == radius[rest[:, 1]]) & (rest[:, 0] > rest[:, 1])
    )
    a = np.where(flip, rest[:, 1], rest[:, 0])
    b = np.where(flip, rest[:, 0], rest[:, 1])
    d = pts[b] - pts[a]
    sector = np.floor((np.arctan2(d[:, 1], d[:, 0]) + np.pi) / (np.pi / 3)).astype(np.int64) % 6
    _, level = np.unique(np.c_[heights, radius], axis=0, return_inverse=True)
    key = (a * (int(level.max()) + 1) + level.ravel()[b]) * 6 + sector
    order = np.argsort(key, kind="stable")
    starts = np.flatnonzero(np.r_[True, np.diff(key[order]) != 0])
    cliques.extend(np.r_[a[g[0]], b[g]] for g in np.split(order, starts[1:]))
    return cliques


def _hop_rows(
    lin,
    x: list,
    pts: np.ndarray,
    heights: np.ndarray,
    radius: np.ndarray,
    direct: np.ndarray,
    problem: CellProblem,
    late: Callable[[], bool] | None = None,
) -> tuple[dict, int] | None:
    """The hop-level rows (module docstring); returns (z by (site, level), terms written), or
    None once ``late()`` is true."""
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
    for k, s in enumerate(far.tolist()):
        if late is not None and k % 64 == 0 and late():
            return None
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
