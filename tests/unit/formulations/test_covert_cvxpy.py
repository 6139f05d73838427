"""The covert convex programs as cvxpy models: DPP, re-solved with new data, open to users'
constraints and solvers, and giving the same optimum as the direct Clarabel layout."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from droneplan.formulations.covert_bounds import (
    InstantMinmaxProgram,
    SlackModel,
    build_instant_slack,
    build_mission_slack,
    instant_minmax_bearing,
    mission_front,
    mission_lower_bound,
    solve_slack,
)
from droneplan.scenarios.covert import THESIS_TABLE_3_2 as P
from droneplan.scenarios.covert import random_case
from droneplan.solvers.result import Status


def _targets(seed, n):
    rng = np.random.default_rng(seed)
    return np.column_stack([rng.uniform(80, 195, n), rng.uniform(80, 195, n), rng.uniform(0, 25, n)])


def _balls(seed, n_balls):
    rng = np.random.default_rng(seed)
    return np.column_stack([P.F_arr + rng.uniform(-300, 300, (n_balls, 3)), rng.uniform(50, 500, n_balls)])


def test_models_are_dpp_printable_and_solved_as_optimal():
    model = build_instant_slack(P, _targets(1, 4), 0.9)
    assert isinstance(model, SlackModel)
    assert model.problem.is_dpp() and model.problem.is_dcp()
    text = str(model.problem)
    assert "maximize s" in text and "SOC" in text
    res = solve_slack(model)
    assert res.status is Status.OPTIMAL and res.backend == "cvxpy-clarabel"
    assert res.x.shape == (3,)
    assert np.linalg.norm(res.x - P.F_arr) <= P.L_u * (1 + 1e-6)  # D in metres, inside the ball
    assert res.info["ds_dc"] < 0  # s decreases in c

    sc = random_case(3, 5)
    mission = build_mission_slack(sc, 20.0, 10.0, 0.9)
    assert mission.problem.is_dpp() and mission.n_balls == 2  # from the start and back home
    assert solve_slack(mission).status is Status.OPTIMAL


def test_model_compiles_once_and_is_resolved_with_new_data():
    model = build_instant_slack(P, _targets(2, 3), 0.8, balls=_balls(3, 1), radius=210.0)
    first = solve_slack(model)
    compiled = model.problem._cache.param_prog
    assert compiled is not None
    model.set_data(P, _targets(4, 3), balls=_balls(5, 1), radius=230.0)
    model.c.value = 0.7
    second = solve_slack(model)
    assert model.problem._cache.param_prog is compiled  # the same compiled program, new data
    fresh = solve_slack(build_instant_slack(P, _targets(4, 3), 0.7, balls=_balls(5, 1), radius=230.0))
    assert first.status is second.status is fresh.status is Status.OPTIMAL
    assert second.objective == pytest.approx(fresh.objective, abs=1e-6)


def test_user_constraints_and_other_solvers():
    import cvxpy as cp

    model = build_instant_slack(P, _targets(6, 5), 0.95)
    base = solve_slack(model).objective
    low = cp.Problem(model.problem.objective, [*model.problem.constraints, model.D[2] <= 5.0])  # metres
    low.solve(solver=cp.CLARABEL)
    assert low.status == cp.OPTIMAL
    assert float(model.D.value[2]) <= 5.0 + 1e-6 and low.value <= base + 1e-9
    scs = solve_slack(model, solver="SCS", eps=1e-8)
    assert scs.backend == "cvxpy-scs" and scs.has_solution
    assert scs.objective == pytest.approx(base, abs=1e-4)


def test_statuses_are_mapped_honestly():
    from droneplan.formulations.covert_bounds import _cvxpy_status

    far = np.array([[P.F_arr[0] + 2000.0, P.F_arr[1], P.F_arr[2], 10.0]])  # a ball that misses |D - F| <= L
    model = build_instant_slack(P, _targets(7, 2), 0.5, balls=far)
    res = solve_slack(model)
    assert res.status is Status.INFEASIBLE and res.objective is None
    assert _cvxpy_status("optimal") is Status.OPTIMAL
    assert _cvxpy_status("optimal_inaccurate") is Status.FEASIBLE
    assert _cvxpy_status("infeasible_inaccurate") is Status.NO_SOLUTION
    assert _cvxpy_status("solver_error") is Status.ERROR


@settings(max_examples=30, deadline=None)
@given(
    st.integers(0, 10**6),
    st.integers(1, 8),
    st.integers(0, 2),
    st.floats(0.05, 0.99),
    st.floats(200.0, 260.0),
)
def test_cvxpy_slack_optimum_equals_the_direct_clarabel_one(seed, n, n_balls, c, radius):
    A, balls = _targets(seed, n), _balls(seed + 1, n_balls)
    direct = InstantMinmaxProgram(n, n_balls)
    direct.set_instance(P, A, balls, radius)
    got = direct._s(c)
    model = build_instant_slack(P, A, c, balls=balls if n_balls else None, radius=radius)
    res = solve_slack(model)
    assert got is not None
    if res.status is Status.INFEASIBLE:
        assert got[0] == -math.inf
        return
    assert res.status is Status.OPTIMAL
    assert res.objective == pytest.approx(got[0], abs=1e-6)


def test_cvxpy_backend_gives_the_same_instant_optimum():
    rng = np.random.default_rng(20261128)
    for _ in range(12):
        A = _targets(int(rng.integers(10**6)), int(rng.integers(1, 10)))
        direct = instant_minmax_bearing(P, A)
        via = instant_minmax_bearing(P, A, backend="cvxpy")
        assert direct.status is via.status is Status.OPTIMAL
        assert direct.backend == "clarabel" and via.backend == "cvxpy"
        assert via.objective == pytest.approx(direct.objective, abs=1e-6)
        assert via.bound <= via.objective and via.objective - via.bound < 1e-4


def test_cvxpy_backend_gives_the_same_mission_bound():
    sc = random_case(3, 5)
    times = np.arange(0.0, sc.params.duration + 1e-9, 6.0)
    direct = mission_lower_bound(sc, 10.0, times=times)
    via = mission_lower_bound(sc, 10.0, times=times, backend="cvxpy")
    assert np.array_equal(np.isfinite(direct.per_instant), np.isfinite(via.per_instant))
    ok = np.isfinite(direct.per_instant)
    # certified bounds: the same optimum, each certified one step of about 1e-6 in cos(theta) below
    assert np.allclose(direct.per_instant[ok], via.per_instant[ok], atol=1e-4)
    assert via.value == pytest.approx(direct.value, abs=1e-4)
    front = mission_front(sc, [10.0, 20.0], times=times, backend="cvxpy")
    assert front[1].value <= front[0].value + 1e-7


def test_bad_input():
    with pytest.raises(ValueError, match="backend"):
        instant_minmax_bearing(P, _targets(1, 2), backend="gurobi")
    with pytest.raises(ValueError, match="backend"):
        mission_lower_bound(random_case(3, 5), 10.0, backend="nope")
    with pytest.raises(ValueError, match=r"^c "):
        build_instant_slack(P, _targets(1, 2), 1.5)
    with pytest.raises(ValueError, match="targets"):
        build_instant_slack(P, np.zeros((0, 3)), 0.5)
    model = build_instant_slack(P, _targets(1, 2), 0.5)
    with pytest.raises(ValueError, match="targets"):
        model.set_data(P, _targets(1, 3))
    with pytest.raises(ValueError, match="targets"):
        model.set_data(P, np.array([P.R_arr, P.R_arr]))
    with pytest.raises(TypeError, match="model"):
        solve_slack("not a model")
