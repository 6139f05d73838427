"""The HiGHS adapter at its time limit: HiGHS's incumbent comes back (FEASIBLE) with its bound."""

import numpy as np

from droneplan.solvers.mip_models import new_mip, solve_mip
from droneplan.solvers.result import Status


def _knapsack(n, k, seed, integer=True):
    rng = np.random.default_rng(seed)
    s = new_mip("highs")
    x = [s.BoolVar(f"x{i}") if integer else s.NumVar(0.0, 1.0, f"x{i}") for i in range(n)]
    W = rng.integers(1, 100, (k, n))
    cap = W.sum(axis=1) // 3
    for r in range(k):
        s.Add(sum(int(W[r, i]) * x[i] for i in range(n)) <= int(cap[r]))
    v = rng.integers(1, 100, n)
    s.Maximize(sum(int(v[i]) * x[i] for i in range(n)))
    return s, x, W, cap, v


def test_stopped_at_the_time_limit_returns_the_incumbent_and_a_bound():
    # a 300-item, 40-row multi-dimensional knapsack is far from solved in 0.3 s; through
    # pywraplp HiGHS reported no solution at all here
    s, x, W, cap, v = _knapsack(300, 40, 1)
    res = solve_mip(s, variables=x, time_limit=0.3)
    assert res.status.has_solution, res.message
    xx = np.round(res.x)
    assert np.allclose(res.x, xx) and np.all(W @ xx <= cap)
    assert res.objective == float(v @ xx)
    assert res.bound is not None and res.bound >= res.objective
    if res.status is Status.FEASIBLE:
        assert "kTimeLimit" in res.message and res.bound > res.objective - 1e-9


def test_small_models_are_still_solved_and_proven():
    s, x, W, cap, v = _knapsack(12, 3, 2)
    res = solve_mip(s, variables=x, time_limit=30)
    best = max(
        float(v @ np.array(bits)) for bits in np.ndindex(*(2,) * 12) if np.all(W @ np.array(bits) <= cap)
    )
    assert res.status is Status.OPTIMAL and res.objective == best == res.bound
    lp, y, *_ = _knapsack(12, 3, 2, integer=False)
    rel = solve_mip(lp, variables=y)
    assert rel.status is Status.OPTIMAL and rel.bound == rel.objective >= best


def test_an_infeasible_model_is_reported():
    s = new_mip("highs")
    a = s.BoolVar("a")
    s.Add(a >= 2)
    s.Maximize(a)
    assert solve_mip(s, variables=[a]).status is Status.INFEASIBLE
