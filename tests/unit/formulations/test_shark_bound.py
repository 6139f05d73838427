"""The proven lower bound on the interception time (relaxation of the OCP) and truthful warm starts."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from droneplan.formulations.shark import optimal_altitude, solve_interception
from droneplan.formulations.shark.bound import interception_time_bound
from droneplan.planners.shark import VirtualSharkInterceptor, optimal_interception
from droneplan.scenarios.shark import THESIS_TABLE_5_1 as P
from droneplan.scenarios.shark import (
    operator_start,
    random_trajectory,
    simulate,
)
from droneplan.solvers.result import Status
from droneplan.solvers.search import first_root_lipschitz


# ---------------------------------------------------------------- the generic search
def test_first_root_is_not_skipped_when_feasibility_is_not_monotone():
    # feasible only on a narrow window [0.99, 1.01] and again from 5: a bisection on [0, 6]
    # (f(3) > 0, f(6) <= 0) would answer ~5; the scan must stop at 0.99
    def f(t):  # Lipschitz 1
        return min(abs(t - 1.0) - 0.01, 5.0 - t)

    r = first_root_lipschitz(f, 0.0, 6.0, 1.0)
    assert r.lower is not None and r.lower <= 0.99 + 1e-9 and r.lower >= 0.99 - 1e-5


@settings(max_examples=60, deadline=None)
@given(st.lists(st.floats(0.5, 20.0), min_size=1, max_size=5), st.floats(0.001, 0.5))
def test_first_root_lower_bound_against_dense_grid(centres, width):
    def f(t):  # Lipschitz 1
        return min(abs(t - c) for c in centres) - width

    r = first_root_lipschitz(f, 0.0, 25.0, 1.0)
    grid = np.linspace(0.0, 25.0, 250001)
    vals = np.array([f(t) for t in grid[::10]])
    first = grid[::10][np.argmax(vals <= 0)]
    assert r.lower is not None and r.lower <= first + 1e-9
    assert r.lower >= min(centres) - width - 1e-4  # and tight


def test_first_root_none_when_never_feasible_and_bad_input():
    assert first_root_lipschitz(lambda t: 1.0 + 0 * t, 0.0, 3.0, 2.0).lower is None
    with pytest.raises(ValueError, match="lipschitz"):
        first_root_lipschitz(lambda t: t, 0.0, 1.0, 0.0)
    with pytest.raises(ValueError, match="lo <= hi"):
        first_root_lipschitz(lambda t: t, 1.0, 0.0, 1.0)


# ---------------------------------------------------------------- the interception bound
def test_bound_equals_closed_form_head_on():
    # shark swimming +x at v, operator D ahead on its path at the optimal altitude: the relaxation's
    # optimum flies straight at it: T = (D - eps' - slack) / (v + VoMxy); the OCP attains it (slack 0)
    v, D, zs = 5.0, 40.0, -3.0
    zo, eps = optimal_altitude(zs)
    O0 = np.array([D, 0.0, zo])
    shark = (np.array([0.0, 0.0, zs]), np.array([v, 0.0]))
    for slack in (0.0, P.gamma):
        b = interception_time_bound(shark, O0, slack=slack)
        T = (D - eps * (1 + P.gamma) * v / math.sqrt(v * v + 1e-6) - slack) / (v + P.VoMxy)
        assert b.status == Status.OPTIMAL and math.isclose(b.bound, T, abs_tol=1e-4) and b.bound <= T + 1e-9
    res = solve_interception(shark, O0, N=30)
    assert res.bound <= res.objective and res.gap < 0.01


def _plain_bound(tr, O0):
    """Horizontal distance / closing speed: the shark moves at most vmax, the goal is eps'(max) ahead."""
    vmax = float(np.max(np.linalg.norm(tr.vel[:, :2], axis=1)))
    d0 = float(np.hypot(*(tr.pos[0, :2] - O0[:2])))
    return max(0.0, d0 - P.eps_o * (1 + P.gamma) - P.gamma) / (P.VoMxy + 1.01 * vmax)


@pytest.mark.parametrize("seed", [101, 102, 103])
def test_bound_below_ocp_and_virtual_shark_above_plain_bound(seed):
    tr = random_trajectory(seed)
    bearing = float(np.random.default_rng(seed).uniform(-180, 180))
    O0 = operator_start(tr, bearing_deg=bearing)
    res = optimal_interception(tr, O0, N=40)
    assert res.status.has_solution and res.bound is not None
    assert res.bound <= res.objective + 1e-6
    vs = VirtualSharkInterceptor()
    simulate(tr, vs, operator0=O0)
    if vs.capture_time is not None:
        assert res.bound <= vs.capture_time + 1e-9
    assert res.bound >= _plain_bound(tr, O0) - 1e-9
    assert "lower bound" in res.message


@pytest.mark.slow
@pytest.mark.parametrize("seed", range(110, 122))
def test_bound_below_ocp_and_virtual_shark_many_paths(seed):
    test_bound_below_ocp_and_virtual_shark_above_plain_bound(seed)


@settings(max_examples=15, deadline=None)
@given(st.integers(0, 10**6), st.floats(-180, 180))
def test_bound_below_virtual_shark_capture_on_random_paths(seed, bearing):
    tr = random_trajectory(seed, duration=20.0)
    O0 = operator_start(tr, bearing_deg=bearing)
    b = interception_time_bound(tr, O0)
    assert b.bound is None or b.bound >= _plain_bound(tr, O0) - 1e-9
    vs = VirtualSharkInterceptor()
    simulate(tr, vs, operator0=O0)
    if vs.capture_time is not None:
        assert b.bound is not None and b.bound <= vs.capture_time + 1e-9


def test_bound_none_when_unreachable_within_horizon():
    shark = (np.array([0.0, 0.0, -3.0]), np.array([5.0, 0.0]))
    b = interception_time_bound(shark, np.array([-500.0, 0.0, 2.0]), t_max=5.0)
    assert b.status == Status.INFEASIBLE and b.bound is None and "no bound" in b.message


# ---------------------------------------------------------------- bad input
def test_shark_inside_the_field_is_refused():
    with pytest.raises(ValueError, match="inside the field"):
        solve_interception((np.array([0.0, 0, -3]), np.array([3.0, 0])), np.array([0.5, 0, 1.5]), N=10)
    tr = random_trajectory(3)
    with pytest.raises(ValueError, match="inside the field"):
        solve_interception(tr, tr.pos[0] + np.array([0.0, 0.0, 1.0 + P.l1]), N=10)


# ---------------------------------------------------------------- truthful warm starts
def test_warm_started_matches_the_start_that_won():
    tr = random_trajectory(7)
    O0 = operator_start(tr)
    crude = solve_interception(tr, O0, N=30)
    assert not crude.warm_started and crude.info["start_won"] == "crude"
    res = optimal_interception(tr, O0, N=30)
    won = [t for t in res.info["tried"] if t[3] is not None and math.isclose(t[3], res.objective)]
    assert res.info["start_won"] in {t[0] for t in won}
    assert res.warm_started == (res.info["start_won"] == "virtual-shark")
