import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from droneplan.formulations.shark import optimal_altitude
from droneplan.planners.shark import (
    ClassicalPursuit,
    OCPInterceptor,
    RepellingOperator,
    VirtualSharkInterceptor,
    optimal_interception,
    thesis_altitude,
)
from droneplan.scenarios.shark import (
    THESIS_TABLE_5_1 as P,
)
from droneplan.scenarios.shark import (
    RepellingMode,
    SharkBehaviour,
    field_radius,
    make_trajectory,
    operator_start,
    random_trajectory,
    simulate,
    simulate_repelling,
    thesis_trajectories,
)
from droneplan.solvers.result import Status


def test_thesis_altitude_is_eq_5_6_5_7():
    cases = {  # z_s: (z_o*, eps*) by hand from 5.6-5.7 with Table 5.1
        0.0: (2.0, field_radius(2.0)),
        -2.0: (2.0, field_radius(4.0)),
        -3.0: (1.5, 3.5),
        -3.5: (1.0, 3.5),
        -4.0: (3.5, 3.5),
        -6.0: (1.5, 3.5),
        -6.5: (1.0, 3.5),
        -8.0: (1.0, field_radius(9.0)),
        -10.5: (1.0, 0.0),
    }
    for z, (zo, eps) in cases.items():
        got = thesis_altitude(z)
        assert math.isclose(got[0], zo) and math.isclose(got[1], eps), z


def test_thesis_altitude_leaves_band_exactly_on_minus_5_5_to_minus_3_5():
    z = np.linspace(-12, 0, 24001)
    zo, eps = thesis_altitude(z)
    out = (zo > P.le + 1e-12) | (zo < P.lmin - 1e-12)
    assert out.any()
    lo, hi = z[out].min(), z[out].max()
    assert math.isclose(lo, -5.5, abs_tol=1e-3) and math.isclose(hi, -3.5, abs_tol=1e-3)
    # where it stays in the band it agrees with the exact maximiser
    zx, ex = optimal_altitude(z)
    assert np.allclose(ex[~out], eps[~out]) and np.allclose(zx[~out], zo[~out])
    # where it leaves the band the thesis promises eps_o, the exact optimum is smaller
    assert np.all(ex[out] < P.eps_o) and np.all(eps[out] == P.eps_o)


def _check_props(trace):
    assert trace.intercepted  # Prop. 5.3.2: finite time
    assert not trace.touched_early  # Prop. 5.3.3
    assert trace.frontal  # Prop. 5.3.4: heading points at the operator
    z_s = trace.shark[-1, 2]
    assert trace.contact_eps >= optimal_altitude(min(z_s, 0))[1] - 0.05  # largest radius


@pytest.mark.parametrize("name", "abcd")
def test_virtual_shark_props_on_thesis_paths(name):
    _check_props(simulate(thesis_trajectories()[name], VirtualSharkInterceptor()))


@settings(max_examples=25, deadline=None)
@given(st.integers(0, 10_000), st.floats(-180, 180))
def test_virtual_shark_props_on_random_flat_paths(seed, bearing):
    # the proofs treat S, S1, S2 as relatively static: a constant heading (speed, depth vary)
    tr = random_trajectory(seed, curvy=False)
    _check_props(simulate(tr, VirtualSharkInterceptor(), bearing_deg=bearing))


def test_virtual_shark_prop_5_3_3_fails_on_a_curvy_path():
    # recorded counterexample: the shark turns during step 2 so the operator crosses inside eps'
    tr = random_trajectory(9)
    trace = simulate(tr, VirtualSharkInterceptor(), bearing_deg=133)
    assert trace.touched_early


def test_classical_pursuit_not_frontal_on_a():
    trace = simulate(thesis_trajectories()["a"], ClassicalPursuit())
    assert trace.intercepted and not trace.frontal and trace.frontal_angle > 90  # from behind


def test_literal_classical_pursuit_stalls_under_altitude_floor():
    trace = simulate(thesis_trajectories()["a"], ClassicalPursuit(aim="shark"), t_max=20)
    assert not trace.intercepted and trace.D_h[-1] > field_radius(trace.operator[-1, 2] - trace.shark[-1, 2])


def test_virtual_shark_handles_stopping_and_deep_shark():
    # shark slows to a stop: the heading is kept, no NaN, interception still frontal
    stop = make_trajectory(
        lambda t: 0 * t, lambda t: np.maximum(5.0 - 1.0 * t, 0.0), lambda t: -3 + 0 * t, duration=20
    )
    _check_props(simulate(stop, VirtualSharkInterceptor()))
    # a shark below the field's reach: operator waits at lmin, never touches
    deep = make_trajectory(lambda t: 0 * t, lambda t: 4 + 0 * t, lambda t: -10.5 + 0 * t, duration=15)
    tr = simulate(deep, VirtualSharkInterceptor())
    assert not tr.intercepted and np.allclose(tr.operator[-20:, 2], P.lmin)


def test_virtual_shark_bad_options():
    with pytest.raises(ValueError, match="side must be"):
        VirtualSharkInterceptor(side=2)
    with pytest.raises(ValueError, match="altitude must be"):
        VirtualSharkInterceptor(altitude="x")


# ---------------------------------------------------------------- OCP vs virtual shark


@pytest.mark.parametrize("name", "abcd")
def test_ocp_time_not_worse_than_virtual_shark_on_thesis_paths(name):
    tr = thesis_trajectories()[name]
    res = optimal_interception(tr, operator_start(tr), N=40)
    # a local optimum of the OCP with a proven bound below it: FEASIBLE, never OPTIMAL
    assert res.status == Status.FEASIBLE and res.info["local_optimum"] and res.converged
    assert res.warm_started == (res.info["start_won"] == "virtual-shark")
    assert res.objective <= res.info["virtual_shark_T"] + 1e-6
    assert res.bound is not None and res.bound <= res.objective + 1e-6


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_ocp_time_not_worse_than_virtual_shark_on_random_paths(seed):
    tr = random_trajectory(seed)
    res = optimal_interception(tr, operator_start(tr, bearing_deg=-60.0 * seed), N=40)
    assert res.info["virtual_shark_T"] is not None
    assert res.status.has_solution and res.objective <= res.info["virtual_shark_T"] + 1e-6


def test_online_ocp_interceptor_intercepts_frontally_on_a():
    ctl = OCPInterceptor(N=15)
    trace = simulate(thesis_trajectories()["a"], ctl)
    _check_props(trace)
    assert all(ctl.converged) and len(ctl.converged) == len(ctl.statuses)
    assert trace.fallbacks == 0 and trace.status_counts == {"FEASIBLE": len(ctl.statuses)}
    vs = simulate(thesis_trajectories()["a"], VirtualSharkInterceptor())
    assert trace.intercept_time < vs.intercept_time


@pytest.mark.parametrize("budget", [{"max_iter": 2}, {"time_limit": 1e-4}])
def test_online_ocp_counts_its_pursuit_fallbacks_in_the_trace(budget):
    # an OCP that cannot solve in its budget falls back to pursuit on every replan,
    # and the trace says so (same name as the covert MPC's counter)
    ctl = OCPInterceptor(N=15, **budget)
    trace = simulate(thesis_trajectories()["a"], ctl, t_max=2.0)
    replans = len(trace.t) - 1
    assert trace.fallbacks == replans == ctl.fallbacks
    # two crude starts per replan, none with a plan
    assert trace.status_counts == {"NO_SOLUTION": 2 * replans}
    assert not trace.intercepted


def test_allocation_optimal_not_worse_than_greedy():
    from droneplan.planners.shark import allocate_operators

    g = np.random.default_rng(5)
    O = np.c_[g.uniform(-40, 40, (3, 2)), np.full(3, 2.0)]
    S = np.c_[g.uniform(-40, 40, (3, 2)), np.full(3, -3.0)]
    V = np.c_[g.normal(0, 1, (3, 2)) * 3, np.zeros(3)]
    H = g.uniform(-20, 20, (4, 2))
    opt = allocate_operators(O, S, V, H)
    gr = allocate_operators(O, S, V, H, greedy=True)
    assert np.isfinite(opt.objective) and opt.objective <= gr.objective + 1e-9


# ---------------------------------------------------------------- repelling (procedure 1-5 of §5.3.1)


class _Idle:
    phase = None

    def reset(self, scenario, *, seed=None):
        """An idle operator keeps no state."""

    def command(self, obs):
        return np.zeros(3)


@pytest.mark.parametrize("seed", [0, 3])
def test_repelling_drives_shark_away_where_idle_operator_lets_it_bite(seed):
    H = np.array([[0.0, 0.0], [10.0, 5.0]])
    S0 = np.array([[100.0, 60.0]])
    O0 = np.array([[0.0, -30.0, 2.0]])
    ctl = RepellingOperator(0)
    tr = simulate_repelling(S0, O0, H, [ctl], seed=seed, t_max=400)
    assert not tr.attacked and tr.left.all() and tr.reactions[0] >= 1
    assert ctl.interceptions == tr.reactions[0] + tr.ignored[0]
    assert isinstance(ctl.phase, RepellingMode)
    again = simulate_repelling(S0, O0, H, [ctl], seed=seed, t_max=400)  # reset starts a fresh episode
    assert (
        ctl.interceptions == again.reactions[0] + again.ignored[0] and again.reactions[0] == tr.reactions[0]
    )
    idle = simulate_repelling(S0, O0, H, [_Idle()], seed=seed, t_max=400)
    assert idle.attacked and idle.reactions[0] == 0


def test_two_sharks_two_operators_with_allocation():
    from droneplan.planners.shark import allocate_operators

    H = np.array([[0.0, 0.0]])
    S0 = np.array([[90.0, 40.0, -3.0], [-80.0, 50.0, -3.0]])
    O0 = np.array([[-10.0, -20.0, 2.0], [10.0, -20.0, 2.0]])
    beh = SharkBehaviour()
    V0 = np.array([-(S0[j, :2]) / np.linalg.norm(S0[j, :2]) * beh.speed for j in range(2)])
    alloc = allocate_operators(O0, S0, np.c_[V0, np.zeros(2)], H)
    ctls = [None, None]
    for j, i in zip(alloc.x.sharks, alloc.x.operator, strict=True):
        ctls[i] = RepellingOperator(int(j))
    tr = simulate_repelling(S0, O0, H, ctls, behaviour=beh, seed=1, t_max=400)
    assert not tr.attacked and tr.left.all() and (tr.reactions >= 1).all()


def test_repelling_bad_input():
    with pytest.raises(ValueError, match="T_w must be >= 0"):
        RepellingOperator(0, T_w=-1)
    with pytest.raises(ValueError, match=r"return_prob must be in \[0, 1\]"):
        SharkBehaviour(return_prob=2)
    with pytest.raises(ValueError, match="one controller per operator"):
        simulate_repelling(np.zeros((1, 2)), np.zeros((1, 3)), np.ones((1, 2)), [])


def test_reversing_shark_literal_step_2_never_closes_restart_does():
    rev = make_trajectory(
        lambda t: np.where(t < 2.0, 0.0, np.pi), lambda t: 4.5 + 0 * t, lambda t: -3 + 0 * t, duration=30
    )
    literal = simulate(rev, VirtualSharkInterceptor(restart_step1=False), bearing_deg=-60)
    assert not literal.intercepted and np.all(literal.phase[-50:] == 2)  # stuck in step 2
    fixed = simulate(rev, VirtualSharkInterceptor(), bearing_deg=-60)
    assert fixed.intercepted
    for b in (-105, 0, 90, 180):  # other start bearings: still frontal and not early
        _check_props(simulate(rev, VirtualSharkInterceptor(), bearing_deg=b))
