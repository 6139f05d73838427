"""The LP fixing of the cells MILP (``_milp`` item 10) drops only sites that no placement
better than the incumbent holds, and the solve with it keeps the brute-force optimum.

A site may be dropped for the objective cut lo (the incumbent's value) only when every
feasible placement holding it covers at most lo users; the enumeration below finds, for
every candidate site, the best feasible placement that holds it.
"""

import itertools

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from droneplan.formulations.cells import (
    _milp,
    branch_and_bound,
    build_milp,
    candidate_sites,
    coverage_upper_bound,
    evaluate,
    solve_exact,
)
from droneplan.formulations.cells._core import TOL, pairwise_distances
from droneplan.solvers.result import Status


def best_holding_each_site(problem, cand):
    """Per candidate site: the most users a feasible placement holding it covers (0 if none),
    by enumerating every set of pairwise non-overlapping sites of size <= m."""
    pts = cand.points
    ok = pairwise_distances(pts, pts) >= 2 * problem.R_d - TOL
    best = np.zeros(len(pts), dtype=np.int64)
    for k in range(1, problem.n_cells + 1):
        for combo in itertools.combinations(range(len(pts)), k):
            if k > 1 and not all(ok[a, b] for a, b in itertools.combinations(combo, 2)):
                continue
            ev = evaluate(problem, pts[list(combo)])
            if ev.feasible:
                idx = list(combo)
                best[idx] = np.maximum(best[idx], ev.covered)
    return best


def disc_bounds(problem):
    return [0.0] + [float(coverage_upper_bound(problem, k).bound) for k in range(1, problem.n_cells + 1)]


@settings(max_examples=12, deadline=None)
@given(st.integers(0, 10_000), st.sampled_from([(2, 3), (3, 3), (2, 4)]), st.integers(0, 2))
def test_fixed_sites_cannot_beat_the_cut(clustered, seed, shape, below):
    # at m = 4 the LP merges hop levels 3 and 4 (a relaxation, as item 10 runs it)
    n_clusters, m = shape
    p = clustered(seed, n_clusters, 3, m=m, background=3)
    cand = candidate_sites(p)
    best = best_holding_each_site(p, cand)
    opt = int(best.max())
    lo = max(opt - below, 0)  # an incumbent value at or below the optimum
    bounds = disc_bounds(p)
    keep = np.arange(len(cand.points))
    out = _milp.lp_fixing(
        p,
        cand,
        keep,
        incumbent=np.zeros((0, 2)),
        objective_range=(lo, bounds[-1]),
        disc_bounds=bounds,
        max_level=3,
    )
    assert out is not None
    alive, bound, stats = out
    # sound: a dropped site is in no placement covering more than lo users
    assert np.all(best[~alive] <= lo), (best[~alive], lo)
    # the LP bound holds for every placement worth lo or more
    assert bound >= opt
    assert stats["lp_fixed_sites"] == int((~alive).sum())


def fix_one_below_optimum(p, cand, opt):
    """The LP fixing of every candidate site with the objective cut one below the optimum."""
    bounds = disc_bounds(p)
    return _milp.lp_fixing(
        p,
        cand,
        np.arange(len(cand.points)),
        incumbent=np.zeros((0, 2)),
        objective_range=(opt - 1, bounds[-1]),
        disc_bounds=bounds,
    )


def test_fixing_drops_sites_on_clustered_instances(clustered):
    dropped = 0
    for seed in range(4):
        p = clustered(seed, 3, 3, m=3, background=3)
        cand = candidate_sites(p)
        out = fix_one_below_optimum(p, cand, int(best_holding_each_site(p, cand).max()))
        assert out is not None
        dropped += int((~out[0]).sum())
    assert dropped > 0


@pytest.mark.parametrize("seed", range(4))
def test_solve_with_fixing_equals_brute_force(clustered, brute_force, monkeypatch, seed):
    monkeypatch.setattr(_milp, "LP_FIXING_MIN_SITES", 0)  # run it on these small models too
    p = clustered(seed, 3, 3, m=3, background=3)
    res = solve_exact(p, engine="milp", backend="cp-sat", time_limit=60, workers=1)
    assert res.status is Status.OPTIMAL
    assert res.objective == brute_force(p)
    ev = evaluate(p, res.x)
    assert ev.feasible and ev.covered == res.objective
    if res.info["model_stats"]:  # no early exit: item 10 ran before the model
        assert "lp_bound" in res.info["model_stats"]


@pytest.mark.parametrize("seed", range(3))
def test_merged_levels_are_a_relaxation(clustered, seed):
    # levels 3..5 merged into one: fewer level variables, and its optimum is at least the
    # exact optimum (every connected placement satisfies the merged rows)
    p = clustered(seed, 4, 3, m=5, half_width=7.0, background=3)
    bb = branch_and_bound(p, time_limit=60, workers=1)
    assert bb.status is Status.OPTIMAL
    exact = build_milp(p, backend="cp-sat")
    merged = build_milp(p, backend="cp-sat", max_level=3)
    assert merged.stats["level_vars"] < exact.stats["level_vars"]
    res = merged.model.solve(variables=merged.x, time_limit=60, workers=1)
    assert res.status is Status.OPTIMAL
    assert round(res.objective) >= bb.objective


@pytest.mark.parametrize(("max_level", "error"), [(2, ValueError), (1.5, TypeError), ("3", TypeError)])
def test_bad_max_level_is_refused_by_name(clustered, max_level, error):
    with pytest.raises(error, match="max_level"):
        build_milp(clustered(0, 2, 3, m=4, background=3), max_level=max_level)


@pytest.mark.parametrize(
    ("load", "cores", "factor"), [(None, 2, 1.0), (1.0, 2, 1.0), (2.0, 2, 1.0), (6.0, 2, 3.0)]
)
def test_the_simplex_share_is_stretched_only_on_an_oversubscribed_machine(monkeypatch, load, cores, factor):
    """The simplex gets LP_FIXING_IPM_AFTER seconds of a whole core: on a machine running more
    processes than cores the wall-clock threshold grows by the load per core."""
    monkeypatch.setattr(_milp, "machine_load", lambda: load)
    monkeypatch.setattr(_milp.os, "cpu_count", lambda: cores)
    assert _milp._ipm_after() == pytest.approx(factor * _milp.LP_FIXING_IPM_AFTER)


def test_lp_fixing_hands_a_slow_simplex_over_to_ipm(clustered, monkeypatch):
    """With a tiny simplex share the fixing still ends with a valid bound, from IPM (named in
    its stats), and drops no site that a placement better than the incumbent holds."""
    monkeypatch.setattr(_milp, "_ipm_after", lambda: 1e-6)
    p = clustered(2, 3, 3, m=3, background=3)
    cand = candidate_sites(p)
    best = best_holding_each_site(p, cand)
    opt = int(best.max())
    out = fix_one_below_optimum(p, cand, opt)
    assert out is not None
    alive, bound, stats = out
    assert stats["lp_method"] == "simplex, then ipm"
    assert bound >= opt and np.all(best[~alive] <= opt - 1)
