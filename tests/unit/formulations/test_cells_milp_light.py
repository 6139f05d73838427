"""The light-site rows of the cells MILP (``_milp`` item 9) cut off only placements that the
disc bounds already exclude, and the model with them keeps the optimum.

A placement worth at least ``lo`` cannot hold sites Y with sum_{c in Y} |S(c)| + B_{m-|Y|} < lo
(a union is at most the sum of its parts); the rows must cut nothing else, and they must cut
every single site and every pair the bound excludes (the strength the docstring claims).
"""

import itertools

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from droneplan.formulations.cells import build_milp, coverage_upper_bound, evaluate
from droneplan.formulations.cells._milp import _light_site_rows
from droneplan.solvers.result import Status


class _Term:
    """A site index times a coefficient, as the rows build it."""

    def __init__(self, index: int, coef: int = 1) -> None:
        self.index, self.coef = index, coef

    def __rmul__(self, k: int) -> "_Term":
        return _Term(self.index, k * self.coef)


class _Expr:
    """A linear expression over site indices (coefficient per index)."""

    def __init__(self, coef: dict[int, int]) -> None:
        self.coef = coef

    def __le__(self, rhs: int) -> tuple[dict[int, int], int]:
        return self.coef, rhs


class _Recorder:
    """The two model calls ``_light_site_rows`` makes, recorded as (coefficients, rhs) rows."""

    def __init__(self) -> None:
        self.rows: list[tuple[dict[int, int], int]] = []

    def sum(self, terms) -> _Expr:
        out: dict[int, int] = {}
        for t in terms:
            out[t.index] = out.get(t.index, 0) + t.coef
        return _Expr(out)

    def add(self, row) -> None:
        self.rows.append(row)


def _sites(n: int) -> list[_Term]:
    return [_Term(i) for i in range(n)]


def _cut(rows, chosen: tuple[int, ...]) -> bool:
    return any(sum(coef.get(i, 0) for i in chosen) > rhs for coef, rhs in rows)


def _excluded(weights, bounds, lo, chosen, max_size) -> bool:
    """Some Y within ``chosen`` (|Y| <= max_size) has sum |S| + B_{m-|Y|} < lo."""
    m = len(bounds) - 1
    return any(
        sum(weights[i] for i in y) + bounds[m - k] < lo
        for k in range(1, min(len(chosen), max_size) + 1)
        for y in itertools.combinations(chosen, k)
    )


@settings(max_examples=300, deadline=None)
@given(
    st.lists(st.integers(0, 12), min_size=1, max_size=7),
    st.integers(1, 3),
    st.lists(st.integers(0, 15), min_size=3, max_size=3),
    st.integers(0, 40),
)
def test_rows_cut_exactly_what_the_disc_bounds_exclude(weights, m, steps, lo):
    bounds = [0.0, *np.cumsum(steps[:m]).astype(float).tolist()]
    w = np.array(weights, dtype=np.int64)
    rec = _Recorder()
    n_rows = _light_site_rows(rec, _sites(len(w)), w, float(lo), bounds)
    assert n_rows == len(rec.rows)
    for size in range(1, min(m, len(w)) + 1):
        for chosen in itertools.combinations(range(len(w)), size):
            cut = _cut(rec.rows, chosen)
            # sound: a cut placement is excluded by the bound
            assert not cut or _excluded(weights, bounds, lo, chosen, m), (chosen, rec.rows)
            # as strong as claimed: a site or a pair the bound excludes is cut
            assert cut or not _excluded(weights, bounds, lo, chosen, 2), (chosen, rec.rows)


def test_rows_cut_a_light_site_and_a_light_pair_only():
    # m = 3, B = (0, 10, 18, 25), lo = 24: a site needs |S| >= 6 (6 + B_2 = 24), two sites
    # |S(a)| + |S(b)| >= 14 (14 + B_1 = 24)
    w = np.array([6, 7, 8, 3], dtype=np.int64)
    rec = _Recorder()
    _light_site_rows(rec, _sites(4), w, 24.0, [0.0, 10.0, 18.0, 25.0])
    assert _cut(rec.rows, (3,))  # 3 + 18 < 24
    assert not _cut(rec.rows, (0,))
    assert _cut(rec.rows, (0, 1))  # 13 + 10 < 24
    assert not _cut(rec.rows, (0, 2))  # 14 + 10 = 24
    assert not _cut(rec.rows, (1, 2))


def disc_bounds(problem):
    return [0.0] + [float(coverage_upper_bound(problem, k).bound) for k in range(1, problem.n_cells + 1)]


@settings(max_examples=12, deadline=None)
@given(st.integers(0, 10_000), st.integers(2, 3), st.sampled_from(["cp-sat", "highs"]))
def test_model_with_the_rows_at_the_optimum_keeps_it(clustered, brute_force, seed, n_clusters, backend):
    # lo = the optimum itself: the strongest rows a solve can get, and still the optimum stays
    p = clustered(seed, n_clusters, 3, m=3, background=4)
    opt = brute_force(p)
    bounds = disc_bounds(p)
    mdl = build_milp(p, backend=backend, objective_range=(opt, bounds[-1]), disc_bounds=bounds)
    res = mdl.model.solve(variables=mdl.x, time_limit=60, workers=1)
    assert res.status is Status.OPTIMAL
    chosen = mdl.points[np.asarray(res.x) > 0.5]
    ev = evaluate(p, chosen)
    assert ev.feasible and ev.covered == round(res.objective) == opt


def test_rows_are_written_on_clustered_instances(clustered, brute_force):
    rows = 0
    for seed in range(6):
        p = clustered(seed, 3, 3, m=3, background=4)
        opt = brute_force(p)
        bounds = disc_bounds(p)
        mdl = build_milp(p, objective_range=(opt, bounds[-1]), disc_bounds=bounds)
        rows += mdl.stats["light_site_rows"]
        assert build_milp(p, objective_range=(opt, bounds[-1])).stats["light_site_rows"] == 0
    assert rows > 0


@pytest.mark.parametrize(
    ("disc_bounds_arg", "error"),
    [
        ("0 1 2 3", TypeError),
        ([0, 1, 2], ValueError),
        ([0, 1, 2, 3, 4], ValueError),
        ([1, 2, 3, 4], ValueError),
        ([0, 3, 2, 4], ValueError),
        ([0, 1, "2", 3], TypeError),
        ([0, 1, float("nan"), 3], ValueError),
    ],
)
def test_bad_disc_bounds_are_refused_by_name(clustered, disc_bounds_arg, error):
    p = clustered(0, 2, 3, m=3, background=4)
    with pytest.raises(error, match="disc_bounds"):
        build_milp(p, disc_bounds=disc_bounds_arg)
