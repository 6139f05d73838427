"""The candidate model object a user extends (:class:`CellModel`) and the objective rows every
cells model shares: the covered weight (with the user substitution and aggregation of the
thesis engine) and, with a capacity, the served weight of a 0-1 assignment."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from droneplan.core.validation import check_int
from droneplan.formulations.cells._core import TOL, pairwise_distances
from droneplan.scenarios.cells import CellProblem
from droneplan.solvers.registry import get_backend

__all__ = ["CellModel"]


@dataclass
class CellModel:
    """The candidate model of a :class:`CellProblem` (the output of :func:`build_milp`), open to
    the user's own rows and objective terms.

    Decision variables: ``x[i]`` (0-1) chooses candidate site ``points[i]``; ``covered(u)`` is
    the linear expression equal to 1 when active user u (an index into ``problem.targets``)
    is covered (served, with a capacity) and 0 otherwise; ``levels[(i, l)]`` labels a
    non-direct site with its hop count l >= 2 to a GBS (backhaul with relays); ``serve[(u, i)]``
    (with a capacity) assigns user u to site i.

    Add rows with ``model.add(expr <= rhs)`` (``model.sum`` builds sums) and objective terms
    with :meth:`add_objective`, then solve with :func:`droneplan.cells.solve_prepared`.
    Coefficients and right-hand sides must be integers on CP-SAT (the default backend);
    HiGHS and SCIP take any numbers.
    """

    problem: CellProblem
    """The instance."""
    backend: str
    """"cp-sat", "highs" or "scip"."""
    points: np.ndarray
    """(c, 2) candidate sites kept in the model (m)."""
    cover: list
    """cover[i]: active-user indices covered by site i."""
    direct: np.ndarray
    """(c,) bool, site within r1 of a GBS."""
    model: Any
    """The :class:`droneplan.solvers.linear.LinearModel` (``model.native`` is the backend's own)."""
    x: list
    """Site variables, one per row of ``points``."""
    y: dict
    """User coverage variables keyed by a representative active-user index (users covered by
    the same sites, in a lens, share one; see :meth:`covered`)."""
    levels: dict = field(default_factory=dict)
    """Hop-level variables z keyed by (site index, level) for non-direct sites (levels >= 2)."""
    squares: dict = field(default_factory=dict)
    """Square variables of the hop rows: (level, square) -> (variable, its sites)."""
    stats: dict = field(default_factory=dict)
    """Sizes: candidates, kept, users, cliques, pairs, level variables and terms."""
    objective: Any = None
    """The objective expression (covered or served weight, plus the user's terms)."""
    group_of: dict = field(default_factory=dict)
    """Active user with a coverage variable -> the key of its variable in ``y``."""
    serve: dict = field(default_factory=dict)
    """With a capacity: (active user, site index) -> 0-1 assignment variable."""
    user_sites: dict = field(default_factory=dict)
    """Active user -> indices of the sites covering it (users no site covers are absent)."""
    cliques: dict = field(default_factory=dict)
    """Active user -> its covering sites, when they pairwise overlap (at most one is chosen)."""

    site_heights: np.ndarray | None = None
    """(c,) altitude (m) of each site with altitude levels; None at one altitude."""

    @property
    def heights(self) -> np.ndarray | None:
        """(c,) altitude (m) of each site with altitude levels; None: the thesis model places every
        drone-cell at one altitude."""
        return self.site_heights

    def plan(self, chosen: np.ndarray) -> np.ndarray:
        """The plan of the sites flagged in ``chosen`` ((c,) bool): (k, 2) positions (m), or
        (k, 3) with the altitude column."""
        if self.site_heights is None:
            return self.points[chosen].reshape(-1, 2)
        return np.column_stack([self.points[chosen], self.site_heights[chosen]]).reshape(-1, 3)

    def covered(self, user: int) -> Any:
        """The linear expression that is 1 when active user ``user`` (an index into
        ``problem.targets``) is covered (with a capacity: served) and 0 otherwise."""
        u = check_int("user", user, min_value=0, max_value=len(self.problem.targets) - 1)
        if self.problem.capacity is not None:
            return self.model.sum(v for (w, _), v in self.serve.items() if w == u)
        if u in self.group_of:
            return self.y[self.group_of[u]]
        return self.model.sum(self.x[i] for i in self.user_sites.get(u, []))

    def sites_in(self, geometry: Any) -> np.ndarray:
        """Indices of the sites inside or on a shapely ``geometry`` (e.g. a Polygon, in metres)."""
        import shapely

        if not isinstance(geometry, shapely.Geometry):
            raise TypeError(f"geometry must be a shapely geometry, got {type(geometry).__name__}")
        if not len(self.points):
            return np.zeros(0, dtype=np.int64)
        return np.flatnonzero(shapely.intersects(geometry, shapely.points(self.points)))

    def add(self, constraint: Any) -> None:
        """Add a linear row ``lhs <= rhs``, ``lhs >= rhs`` or ``lhs == rhs`` over the variables."""
        self.model.add(constraint)

    def sum(self, terms: Any) -> Any:
        """The sum of ``terms`` as a backend expression (0 for none)."""
        return self.model.sum(list(terms))

    def add_objective(self, expr: Any) -> None:
        """Add ``expr`` to the maximised objective."""
        self.objective = self.objective + expr
        self.model.maximize(self.objective)


def _new_model(backend: str):
    """An empty linear model on ``backend`` (a registry name of kind "linear")."""
    return get_backend(backend, kind="linear").new_model()


def _user_clique_sites(
    points: np.ndarray, cover: list, targets: np.ndarray, radius: float | np.ndarray
) -> dict[int, list[int]]:
    """For every active user u whose covering sites pairwise overlap, the indices of those
    sites (an at-most-one row, item 5 of the module docstring). Users in a lens (two
    covering sites c, d with |c - d| >= R_c + R_d - TOL, so both may be chosen) are left out.

    radius: the coverage radius (m) of every site (R_d), or one per site (altitude levels).
    Exact: sites c, d both within R + TOL of u and >= R_c + R_d - TOL apart are each
    >= R - 2 TOL from u (triangle inequality), so only such "rim" sites need the
    pairwise test."""
    R = np.broadcast_to(np.asarray(radius, dtype=float), (len(points),))
    by_user: dict[int, list[int]] = {}
    for i, c in enumerate(cover):
        for u in c.tolist():
            by_user.setdefault(int(u), []).append(i)
    out: dict[int, list[int]] = {}
    for u, sites in by_user.items():
        if len(sites) < 2:
            continue
        s = np.asarray(sites, dtype=np.int64)
        d = np.hypot(*(points[s] - targets[u]).T)
        rim = s[d >= R[s] - 3 * TOL]
        if len(rim) >= 2:
            q = points[rim]
            dd = pairwise_distances(q, q)
            if np.any(dd >= R[rim][:, None] + R[rim][None, :] - TOL):
                continue
        out[u] = sites
    return out


def _coverage_objective(lin, x: list, pts, cover: list, problem: CellProblem, user_cliques: bool, radius):
    """The covered weight (covered users without ``weights``) as a linear expression over the
    site variables ``x``.

    Returns (y, objective, clique rows, users written without a variable, group of each user
    with a variable). ``radius``: each site's coverage radius (m; None: R_d for all).

    - **Substitution (exact).** A user u whose covering sites C_u pairwise overlap (item 5)
      is covered by at most one chosen site, so it is covered exactly when
      ``sum_{c in C_u} x_c = 1``: it needs no variable, and each of its sites gains its weight
      (1 without ``weights``) in the objective (with the at-most-one row over C_u, which also
      tightens the LP).
    - **Aggregation (exact).** The other users (in a lens, or all of them without
      ``user_cliques``) with the same covering sites are covered together: one variable
      y_g <= sum_{c in C_g} x_c counts all of them, weighted by their total weight.

    ``y`` maps a representative user of each aggregated group to its variable; the last
    mapping gives each aggregated user its representative."""
    by_user = _sites_by_user(cover)
    cliques = (
        _user_clique_sites(pts, cover, problem.targets, problem.R_d if radius is None else radius)
        if user_cliques and len(pts)
        else {}
    )
    weight = (
        problem.target_weights if problem.weights is not None else np.ones(len(problem.targets), np.int64)
    )
    site_w = np.zeros(len(pts), dtype=weight.dtype)
    for u, sites in cliques.items():
        site_w[sites] += weight[u]
        lin.add_at_most_one([x[i] for i in sites])
    groups: dict[tuple[int, ...], list[int]] = {}
    for u, sites in by_user.items():
        if u not in cliques:
            groups.setdefault(tuple(sites), []).append(u)
    y: dict[int, Any] = {}
    group_of: dict[int, int] = {}
    terms = [_coefficient(site_w[i]) * x[i] for i in np.flatnonzero(site_w).tolist()]
    for group, users in groups.items():
        v = lin.unit_var(f"covered{users[0]}")
        y[users[0]] = v
        group_of.update(dict.fromkeys(users, users[0]))
        lin.add_implies_any(v, [x[i] for i in group])  # (4.9): counted only if a chosen site covers it
        terms.append(_coefficient(weight[users].sum()) * v)
    return y, lin.sum(terms), cliques, len(cliques), group_of


def _objective_part(
    lin,
    x: list,
    pts: np.ndarray,
    cover: list,
    problem: CellProblem,
    user_cliques: bool,
    radius: np.ndarray | None = None,
):
    """The objective and its variables: (y, objective, clique rows, substituted users, group of
    each user with a variable, assignment variables); the served weight with a capacity
    (``_capacity_objective``), the covered weight otherwise (``_coverage_objective``, sites of
    coverage ``radius``, m, each; None: R_d)."""
    if problem.capacity is None:
        return (*_coverage_objective(lin, x, pts, cover, problem, user_cliques, radius), {})
    serve, objective = _capacity_objective(lin, x, cover, problem)
    return {}, objective, {}, 0, {}, serve


def _sites_by_user(cover: list) -> dict[int, list[int]]:
    """Active-user index -> indices of the sites covering it (users no site covers left out)."""
    by_user: dict[int, list[int]] = {}
    for i, c in enumerate(cover):
        for u in c.tolist():
            by_user.setdefault(int(u), []).append(i)
    return by_user


def _capacity_objective(lin, x: list, cover: list, problem: CellProblem) -> tuple[dict, Any]:
    """The served weight under ``problem.capacity`` as a linear expression: a 0-1 variable
    s_{u,c} per user u and site c covering it, ``sum_c s_{u,c} <= 1`` (served once),
    ``sum_u s_{u,c} <= C x_c`` (capacity, and only by a chosen site), and the objective at most the
    weight of the C m heaviest users (valid, and a bound the backend has without its LP); returns
    ({(u, c): s_{u,c}}, objective sum_{u,c} w_u s_{u,c}). Users of weight 0 get no variable."""
    capacity = int(problem.capacity or 0)
    weight = problem.target_weights
    serve: dict[tuple[int, int], Any] = {}
    per_site: dict[int, list] = {}
    terms = []
    for u, sites in _sites_by_user(cover).items():
        if weight[u] <= 0:
            continue
        arcs = []
        for c in sites:
            s_uc = lin.bool_var(f"serve{u}_{c}")
            serve[(u, c)] = s_uc
            arcs.append(s_uc)
            per_site.setdefault(c, []).append(s_uc)
            terms.append(_coefficient(weight[u]) * s_uc)
        lin.add_at_most_one(arcs)
    for c, arcs in per_site.items():
        lin.add(lin.sum(arcs) <= capacity * x[c])
    objective = lin.sum(terms)
    if terms:
        lin.add(objective <= _coefficient(capacity_bound(problem)))
    return serve, objective


def capacity_bound(problem: CellProblem) -> float:
    """At most ``n_cells`` drone-cells serve C users each: the weight of the C m heaviest users
    bounds the served weight (a problem with a capacity)."""
    weight = problem.target_weights
    top = np.sort(weight[weight > 0])[::-1][: int(problem.capacity or 0) * problem.n_cells]
    return float(top.sum())


def _coefficient(w: float) -> float | int:
    """An objective coefficient: an int when the weight is integral (CP-SAT keeps an integer objective)."""
    return int(w) if float(w).is_integer() else float(w)
