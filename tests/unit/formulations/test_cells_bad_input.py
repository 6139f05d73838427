"""Bad input to the cells formulations: refused up front, the error naming the parameter."""

import numpy as np
import pytest

from droneplan.core.validation import work_limits
from droneplan.formulations.cells import (
    CellProblem,
    branch_and_bound,
    build_milp,
    candidate_sites,
    connected_mask,
    coverage_upper_bound,
    solve_exact,
    solve_milp,
)
from droneplan.formulations.cells._bnb import search


def _problem(n_users, m, seed=0):
    rng = np.random.default_rng(seed)
    return CellProblem(
        users=rng.uniform(-6, 6, size=(n_users, 2)),
        gbs=np.zeros((1, 2)),
        n_cells=m,
        R_d=1.0,
        R_g=1.0,
        r1=3.0,
        r2=2.5,
    )


@pytest.mark.parametrize("n_discs", [-1, -5])
def test_coverage_bound_refuses_a_negative_number_of_discs(n_discs):
    with pytest.raises(ValueError, match="n_discs"):
        coverage_upper_bound(_problem(6, 2), n_discs)


@pytest.mark.parametrize("n_discs", [1.5, "2", True])
def test_coverage_bound_refuses_a_non_integer_number_of_discs(n_discs):
    with pytest.raises(TypeError, match="n_discs"):
        coverage_upper_bound(_problem(6, 2), n_discs)


def test_coverage_bound_with_zero_discs_is_zero_and_grows_with_the_discs():
    p = _problem(8, 3)
    values = [coverage_upper_bound(p, k).bound for k in range(4)]
    assert values[0] == 0 and values == sorted(values) and values[-1] <= 8


def test_branch_and_bound_refuses_a_search_beyond_the_work_budget():
    p = _problem(9, 10**6)
    n = len(candidate_sites(p).points)
    with work_limits(elements=n * n - 1), pytest.raises(ValueError, match="n_cells"):
        branch_and_bound(p, workers=1, time_limit=30)


def test_more_cells_than_candidate_sites_is_the_same_problem():
    # a placement holds distinct candidate sites: m beyond their number changes nothing,
    # and the search no longer carries a million free slots through every node
    p = _problem(6, 10**6, seed=3)
    cand = candidate_sites(p)
    q = _problem(6, len(cand.points), seed=3)
    big = search(p, cand, np.zeros((0, 2)), 0, time_limit=60)
    same = search(q, cand, np.zeros((0, 2)), 0, time_limit=60)
    assert big.proven and same.proven and big.value == same.value
    assert branch_and_bound(p, workers=1, time_limit=60).objective == big.value


# ---------------------------------------------------------------- each parameter named in its error
_CHAIN = np.array([[2.5, 0.0], [4.5, 0.0], [6.5, 0.0]])
"""Three drone-cells in a row from the GBS at the origin: the first links directly (r1 = 3),
the others relay through it (r2 = 2.5)."""


def test_connected_mask_relays_only_through_usable_cells():
    p = _problem(4, 3)
    assert connected_mask(p, _CHAIN).tolist() == [True, True, True]
    assert connected_mask(p, _CHAIN, usable=np.array([True, False, True])).tolist() == [True, False, False]
    assert connected_mask(p, _CHAIN, usable=[False, True, True]).tolist() == [False, False, False]
    assert connected_mask(p, np.zeros((0, 2)), usable=[]).shape == (0,)


@pytest.mark.parametrize(
    ("usable", "error"),
    [
        (10**12, TypeError),
        (1e-300, TypeError),
        ("yes", TypeError),
        (np.ones(3), TypeError),
        (np.ones(2, bool), ValueError),
        (np.ones((3, 1), bool), ValueError),
    ],
)
def test_connected_mask_refuses_a_usable_that_is_no_bool_mask_of_the_cells(usable, error):
    with pytest.raises(error, match=r"^usable"):
        connected_mask(_problem(4, 3), _CHAIN, usable=usable)


@pytest.mark.parametrize("extra", [1e12, 1e-300, 10**12, np.full((2, 2), np.nan), np.zeros((2, 3))])
def test_candidate_sites_names_extra_in_its_errors(extra):
    with pytest.raises(ValueError, match=r"^extra"):
        candidate_sites(_problem(5, 2), extra=extra)


def test_candidate_sites_still_takes_extra_points():
    p = _problem(5, 2)
    base = candidate_sites(p)
    site = np.array([[3.0, 3.0]])
    more = candidate_sites(p, extra=site)
    assert len(more.points) == len(base.points) + 1
    assert np.any(np.all(np.isclose(more.points, site), axis=1))


@pytest.mark.parametrize(
    ("kwargs", "name", "error"),
    [
        ({"candidates": 1e12}, "candidates", TypeError),
        ({"candidates": "sites"}, "candidates", TypeError),
        ({"keep": 1e12}, "keep", TypeError),
        ({"keep": 10**12}, "keep", ValueError),
        ({"keep": [0.5, 1.0]}, "keep", TypeError),
        ({"keep": [True, False]}, "keep", TypeError),
        ({"keep": [0, 10**12]}, "keep", ValueError),
        ({"keep": [-1]}, "keep", ValueError),
        ({"keep": [0, 0]}, "keep", ValueError),
        ({"objective_range": 1e12}, "objective_range", TypeError),
        ({"objective_range": (1.0,)}, "objective_range", ValueError),
        ({"objective_range": (1.0, 2.0, 3.0)}, "objective_range", ValueError),
        ({"objective_range": (np.nan, 2.0)}, "objective_range", ValueError),
        ({"objective_range": (0.0, "all")}, "objective_range", TypeError),
        ({"pair_limit": np.nan}, "pair_limit", TypeError),
        ({"pair_limit": -1}, "pair_limit", ValueError),
        ({"user_cliques": "yes"}, "user_cliques", TypeError),
    ],
)
def test_build_milp_names_each_bad_argument(kwargs, name, error):
    with pytest.raises(error, match=f"^{name}"):
        build_milp(_problem(6, 2), **kwargs)


def test_build_milp_keeps_the_given_candidates_and_objective_range():
    p = _problem(6, 2)
    cand = candidate_sites(p)
    keep = np.arange(0, len(cand.points), 2)
    mdl = build_milp(p, candidates=cand, keep=list(keep), objective_range=[1, 4], pair_limit=0)
    assert mdl is not None and np.array_equal(mdl.points, cand.points[keep])
    assert mdl.stats["candidates"] == len(cand.points) and mdl.stats["kept"] == len(keep)
    empty = build_milp(p, candidates=cand, keep=[])
    assert empty is not None and len(empty.points) == 0


_SOLVERS = [
    pytest.param(lambda p, **kw: solve_exact(p, engine="milp", workers=1, **kw), id="solve_exact"),
    pytest.param(lambda p, **kw: solve_milp(p, workers=1, **kw), id="solve_milp"),
]


@pytest.mark.parametrize("solve", _SOLVERS)
@pytest.mark.parametrize(
    ("kwargs", "name", "error"),
    [
        ({"user_cliques": "yes"}, "user_cliques", TypeError),
        ({"max_rounds": np.nan}, "max_rounds", TypeError),
        ({"max_rounds": 2.0}, "max_rounds", TypeError),
        ({"max_rounds": -1}, "max_rounds", ValueError),
        ({"warm_start": 1e12}, "warm_start", ValueError),
        ({"warm_start": 10**12}, "warm_start", ValueError),
        ({"warm_start": np.zeros((2, 3))}, "warm_start", ValueError),
        ({"warm_start": [[np.nan, 0.0]]}, "warm_start", ValueError),
    ],
)
def test_the_exact_entries_name_each_bad_argument(solve, kwargs, name, error):
    with pytest.raises(error, match=f"^{name}"):
        solve(_problem(6, 2), **kwargs)


@pytest.mark.parametrize("warm_start", [1e-300, 10**12, np.zeros((1, 3))])
def test_branch_and_bound_names_warm_start_in_its_errors(warm_start):
    with pytest.raises(ValueError, match=r"^warm_start"):
        branch_and_bound(_problem(6, 2), warm_start=warm_start, workers=1)


def test_the_engines_agree_with_a_warm_start_and_a_round_limit():
    p = _problem(8, 2, seed=1)
    warm = np.array([[2.5, 0.0]])
    bnb = branch_and_bound(p, warm_start=warm, workers=1, time_limit=60)
    milp = solve_milp(p, warm_start=warm, workers=1, max_rounds=200, user_cliques=False, time_limit=60)
    assert bnb.status.name == milp.status.name == "OPTIMAL"
    assert bnb.objective == milp.objective >= 1
