"""Bad input to the cells formulations: refused up front, the error naming the parameter."""

import numpy as np
import pytest

from droneplan.core.validation import work_limits
from droneplan.formulations.cells import CellProblem, branch_and_bound, candidate_sites, coverage_upper_bound
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
