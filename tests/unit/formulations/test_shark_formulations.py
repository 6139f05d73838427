import dataclasses
import itertools
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from droneplan.formulations.shark import (
    InterceptionOCP,
    InterceptionPlan,
    assignment_cost,
    build_interception_nlp,
    greedy_assignment,
    optimal_altitude,
    select_sharks,
    solve_assignment,
    solve_interception,
)
from droneplan.scenarios.shark import THESIS_TABLE_5_1 as P
from droneplan.scenarios.shark import field_radius, inside_field, thesis_trajectories
from droneplan.solvers.result import Status


@settings(max_examples=80, deadline=None)
@given(st.floats(-12.0, 0.0))
def test_optimal_altitude_equals_dense_grid(z_s):
    zo, eps = optimal_altitude(z_s)
    grid = np.linspace(P.lmin, P.le, 20001)
    vals = field_radius(grid - z_s)
    assert P.lmin <= zo <= P.le
    assert math.isclose(eps, float(field_radius(zo - z_s)), abs_tol=1e-12)
    assert eps >= vals.max() - 1e-9  # no grid point is better
    assert eps <= vals.max() + 1e-3  # and it is attained (grid step 5e-5 m)


def test_optimal_altitude_vectorised_and_bad_input():
    z = np.linspace(-11, 0, 50)
    zo, eps = optimal_altitude(z)
    assert zo.shape == z.shape and np.all(eps >= 0)
    assert optimal_altitude(-20.0) == (P.lmin, 0.0)  # out of reach: wait at lmin
    with pytest.raises(ValueError, match="must be finite"):
        optimal_altitude(float("nan"))
    with pytest.raises(ValueError, match="must be <= 0"):
        optimal_altitude(0.5)


# ---------------------------------------------------------------- interception OCP


def _check_plan(res, shark_at, O0):
    plan = res.x
    assert res.status == Status.FEASIBLE and res.info["local_optimum"]  # a local optimum, not proven
    assert math.isclose(res.objective, plan.T)
    assert np.allclose(plan.operator[0], O0)
    assert np.all(np.hypot(plan.velocity[:, 0], plan.velocity[:, 1]) <= P.VoMxy + 1e-6)
    assert np.all(np.abs(plan.velocity[:, 2]) <= P.VoMz + 1e-6)
    assert np.all(plan.operator[:, 2] >= P.lmin - 1e-7) and np.all(plan.operator[:, 2] <= P.le + 1e-7)
    # terminal: frontal at eps*(1+gamma), optimal altitude
    S_T, V_T = shark_at(plan.T)
    zo, eps = optimal_altitude(min(S_T[2], 0.0))
    goal = S_T[:2] + eps * (1 + P.gamma) * V_T[:2] / np.linalg.norm(V_T[:2])
    assert np.allclose(plan.operator[-1, :2], goal, atol=1e-4) and math.isclose(
        plan.operator[-1, 2], zo, abs_tol=1e-4
    )
    # no touch before T on a fine grid (between nodes the operator moves linearly)
    tt = np.linspace(0, plan.T, 1001)[:-1]
    S = np.array([shark_at(t)[0] for t in tt])
    assert np.all(inside_field(S, plan.position(tt)) > -1e-3)


def test_head_on_constant_velocity_matches_closed_form():
    # shark at the origin swimming +x at v, operator D ahead on its path at the optimal altitude:
    # the optimum flies straight at it and stops eps' ahead: T = (D - eps') / (v + VoMxy)
    v, D, zs = 5.0, 40.0, -3.0
    zo, eps = optimal_altitude(zs)
    O0 = np.array([D, 0.0, zo])
    res = solve_interception((np.array([0, 0, zs]), np.array([v, 0.0])), O0, N=30)
    T = (D - eps * (1 + P.gamma)) / (v + P.VoMxy)
    assert math.isclose(res.objective, T, rel_tol=1e-4)
    _check_plan(res, lambda t: (np.array([v * t, 0, zs]), np.array([v, 0, 0])), O0)


def test_offline_ocp_respects_model_on_thesis_path_b():
    tr = thesis_trajectories()["b"]
    O0 = np.array([tr.pos[0, 0] - 5, tr.pos[0, 1] - 12, 2.0])
    res = solve_interception(tr, O0, N=50)
    assert len(res.info["tried"]) == 2  # both sides of the path
    _check_plan(res, tr.at, O0)
    # lower bound: the horizontal distance to the goal at T cannot be covered faster than VoMxy
    assert res.objective * P.VoMxy >= np.linalg.norm(res.x.operator[-1, :2] - O0[:2]) - 1e-6


def test_ocp_solve_with_a_solved_warm_start_without_a_plan_uses_the_default_guess():
    """A solved warm_start whose x is not an InterceptionPlan (here the raw vector) is not a
    starting plan: the solve starts from the default guess, as without warm_start."""
    ocp = InterceptionOCP(N=10)
    O0 = np.array([-5.0, -12.0, 2.0])
    state = (np.zeros(3), np.array([1.0, 0.0]))
    cold = ocp.solve(O0, shark_state=state)
    assert cold.has_solution
    foreign = dataclasses.replace(cold, x=np.asarray(cold.info["x_vector"]))
    res = ocp.solve(O0, shark_state=state, warm_start=foreign)
    assert res.has_solution
    assert isinstance(res.x, InterceptionPlan)
    assert abs(res.objective - cold.objective) < 1e-3


def test_ocp_bad_input():
    with pytest.raises(ValueError, match="N must be >= 2"):
        build_interception_nlp(N=1)
    ocp = InterceptionOCP(N=5)
    with pytest.raises(ValueError, match="shark_state"):
        ocp.solve(np.zeros(3))
    with pytest.raises(ValueError, match="operator0 must be a finite"):
        ocp.solve(np.array([np.nan, 0, 1]), shark_state=(np.zeros(3), np.ones(2)))
    with pytest.raises(ValueError, match="SharkTrajectory or"):
        solve_interception((np.zeros(3),), np.zeros(3))


# ---------------------------------------------------------------- assignment


def _brute(cost, sharks):
    n = cost.shape[0]
    best = None
    for perm in itertools.permutations(range(n), len(sharks)):
        v = assignment_cost(cost, sharks, perm)
        if best is None or (v[0], v[1]) < best:
            best = (v[0], v[1])
    return best


@settings(max_examples=25, deadline=None)
@given(st.integers(1, 5), st.integers(1, 5), st.integers(0, 10**6))
def test_assignment_equals_brute_force(n, s, seed):
    g = np.random.default_rng(seed)
    cost = g.uniform(1, 20, (n, s)).round(3)
    d = g.uniform(0, 100, s)
    res = solve_assignment(cost, shark_to_human=d, workers=1)
    assert res.status == Status.OPTIMAL
    sharks = select_sharks(d, n) if s > n else np.arange(s)
    assert np.array_equal(res.x.sharks, sharks)
    assert len(set(res.x.operator.tolist())) == len(sharks)  # one shark per operator
    latest, total = _brute(cost, sharks)
    assert math.isclose(res.objective, latest, abs_tol=1e-9)
    assert math.isclose(res.x.total, total, abs_tol=2e-3 * len(sharks))
    assert res.bound is not None and res.bound <= res.objective + 1e-9
    greedy = greedy_assignment(g.uniform(0, 50, (n, 3)), g.uniform(0, 50, (s, 3)), d, cost)
    assert greedy.objective >= res.objective - 1e-9


def test_select_sharks_thesis_rule_and_bad_input():
    assert select_sharks([50.0, 10.0, 30.0, 5.0], 2).tolist() == [1, 3]
    with pytest.raises(ValueError, match="shark_to_human"):
        solve_assignment(np.ones((2, 3)))
    with pytest.raises(ValueError, match="cost entries must be >= 0"):
        solve_assignment(np.array([[1.0, -2.0]]))
