"""The branch and bound's root site elimination as preprocessing of the cells MILP
(``_exact._eliminate_for_model``): the sites it keeps still hold an optimal placement when one
beats the incumbent, and the MILP with it (``bnb_elimination=True``) and without it (the
default) agree with brute force."""

import itertools

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from droneplan.formulations.cells import _exact, evaluate, solve_exact
from droneplan.formulations.cells._core import TOL, pairwise_distances
from droneplan.formulations.cells._prepare import prepare
from droneplan.solvers.result import Status


def best_over(problem, pts) -> int:
    """The most users a feasible placement of the sites ``pts`` covers (0 if none), by
    enumerating every set of pairwise non-overlapping sites of size <= m."""
    ok = pairwise_distances(pts, pts) >= 2 * problem.R_d - TOL
    best = 0
    for k in range(1, problem.n_cells + 1):
        for combo in itertools.combinations(range(len(pts)), k):
            if k > 1 and not all(ok[a, b] for a, b in itertools.combinations(combo, 2)):
                continue
            ev = evaluate(problem, pts[list(combo)])
            if ev.feasible and ev.covered > best:
                best = int(ev.covered)
    return best


@settings(max_examples=8, deadline=None)
@given(st.integers(0, 10_000), st.sampled_from([(3, 3), (4, 3)]), st.booleans())
def test_kept_sites_hold_an_optimum(clustered, seed, shape, weak_start):
    n_clusters, m = shape
    p = clustered(seed, n_clusters, 3, m=m, background=3)
    prep = prepare(p)
    full_opt = best_over(p, prep.cand.points)
    if weak_start and len(prep.inc) > 1:  # an incumbent below the greedy one: more sites can beat it
        prep.inc = prep.inc[:1]
        prep.inc_val = int(evaluate(p, prep.inc).covered)
    z0 = prep.inc_val
    _exact._eliminate_for_model(prep)
    info = prep.info["elimination"]
    assert info["run"], info
    # the incumbent is a feasible placement of the kept sites, never worse than before
    ev = evaluate(p, prep.inc)
    assert ev.feasible and ev.covered == prep.inc_val >= z0
    kept = best_over(p, prep.cand.points)
    assert kept >= prep.inc_val
    # a placement better than the incumbent survives the elimination (at its value)
    assert max(kept, prep.inc_val) == full_opt


@settings(max_examples=4, deadline=None)
@given(st.integers(0, 10_000), st.sampled_from([(3, 3), (4, 3)]))
def test_milp_with_and_without_elimination_equal_brute_force(clustered, brute_force, seed, shape):
    n_clusters, m = shape
    p = clustered(seed, n_clusters, 3, m=m, background=2)
    opt = brute_force(p)
    for elimination in (False, True):
        res = solve_exact(p, engine="milp", workers=1, time_limit=120, bnb_elimination=elimination)
        assert res.status is Status.OPTIMAL
        assert res.objective == opt
        assert evaluate(p, np.asarray(res.x).reshape(-1, 2)).covered == opt
    bnb = solve_exact(p, engine="bnb", workers=1, time_limit=120)
    assert bnb.status is Status.OPTIMAL and bnb.objective == opt


def test_weak_incumbent_drops_sites(clustered):
    # from a one-site start (4 users, the optimum 5) most sites are cleared or dominated
    p = clustered(0, 3, 3, m=3, background=3)
    prep = prepare(p)
    prep.inc = prep.inc[:1]
    prep.inc_val = int(evaluate(p, prep.inc).covered)
    _exact._eliminate_for_model(prep)
    info = prep.info["elimination"]
    assert info["complete"] and info["dominated"] >= 1
    assert info["kept"] < info["sites"] / 2
    assert best_over(p, prep.cand.points) == best_over(p, prepare(p).cand.points)


def test_bnb_elimination_is_checked(clustered):
    p = clustered(0, 3, 3, m=3)
    with pytest.raises(TypeError, match="bnb_elimination"):
        solve_exact(p, engine="milp", bnb_elimination="yes")
