import dataclasses
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from droneplan.scenarios.shark import (
    THESIS_TABLE_5_1,
    InterceptionScenario,
    SharkCommand,
    SharkFrame,
    SharkPhase,
    field_radius,
    inside_field,
    operator_start,
    random_trajectory,
    simulate,
    thesis_trajectories,
    touches,
)

P = THESIS_TABLE_5_1


def test_table_5_1_values_and_speed_split():
    assert (P.lmin, P.le, P.l1, P.l2, P.lmax, P.eps_o, P.Di, P.Ts) == (1, 2, 4.5, 7.5, 11, 3.5, 13, 0.1)
    assert math.isclose(P.VoM, 8.0)
    assert P.VoMxy > P.VsMxy and P.VoMz > P.VsMz
    assert math.isclose(P.l2 + P.eps_o, P.lmax)  # ball model reaches exactly lmax


@pytest.mark.parametrize(
    ("change", "word"),
    [
        (dict(VoMxy=6.0), "VoMxy > VsMxy"),
        (dict(VoMz=0.5), "VoMz > VsMz"),
        (dict(lmin=2.0), "lmin < le"),
        (dict(l1=8.0), "l1 < l2"),
        (dict(eps_o=0.0), "eps_o"),
        (dict(Di=3.0), "Di > eps_o"),
        (dict(Ts=float("nan")), "Ts"),
        (dict(gamma=float("inf")), "gamma"),
    ],
)
def test_bad_params_raise(change, word):
    with pytest.raises(ValueError, match=word):
        dataclasses.replace(P, **change)


def test_field_radius_matches_definition():
    assert math.isclose(field_radius(P.l1), P.eps_o) and math.isclose(field_radius(P.l2), P.eps_o)
    assert field_radius(P.lmax + 0.01) == 0 and field_radius(P.l1 - P.eps_o - 0.01) == 0
    # between the planes the union dips to the lens intersection
    assert math.isclose(field_radius(6.0), math.sqrt(3.5**2 - 1.5**2))


@settings(max_examples=60, deadline=None)
@given(st.floats(-12, 0), st.floats(0, 6), st.floats(1, 2))
def test_touch_equals_horizontal_radius_test(z_s, dxy, z_o):
    shark = np.array([dxy, 0.0, z_s])
    op = np.array([0.0, 0.0, z_o])
    eps = field_radius(z_o - z_s)
    if abs(dxy - eps) > 1e-9:
        assert bool(touches(shark, op)) == (dxy < eps)
        assert (float(inside_field(shark, op)) <= 0) == (dxy < eps)


def test_thesis_trajectories_family():
    tr = thesis_trajectories()
    assert set(tr) == {"a", "b", "c", "d"}
    assert all(v.name == k for k, v in tr.items())  # each path keeps its label
    for k, v in tr.items():
        sp = np.hypot(v.vel[:, 0], v.vel[:, 1])
        assert sp.max() <= P.VsMxy and np.abs(v.vel[:, 2]).max() <= P.VsMz and v.pos[:, 2].max() < 0
        # velocities are consistent with positions
        assert np.allclose(
            np.diff(v.pos[:, :2], axis=0) / v.dt, 0.5 * (v.vel[1:, :2] + v.vel[:-1, :2]), atol=0.05
        )
        heading = np.unwrap(np.arctan2(v.vel[:, 1], v.vel[:, 0]))
        flat = np.ptp(heading) < 1e-9
        assert flat == (k in "ab")
        assert (np.ptp(v.pos[:, 2]) < 1e-9) == (k in "ac")
        assert (np.ptp(sp) < 1e-9) == (k in "ab")
        assert 5.0 < v.average_speed() < 6.2


def test_random_trajectory_reproducible_and_limited():
    a, b = random_trajectory(3), random_trajectory(3)
    assert np.array_equal(a.pos, b.pos) and a.seed == 3
    assert not np.array_equal(a.pos, random_trajectory(4).pos)
    for s in range(20):
        t = random_trajectory(s)
        assert np.hypot(t.vel[:, 0], t.vel[:, 1]).max() <= P.VsMxy
        assert np.abs(t.vel[:, 2]).max() <= P.VsMz and t.pos[:, 2].max() <= -0.3 + 1e-9
    with pytest.raises(TypeError, match="seed"):
        random_trajectory("x")


def test_operator_start_and_bad_start():
    tr = thesis_trajectories()["a"]
    o = operator_start(tr)
    assert math.isclose(np.hypot(*(o[:2] - tr.pos[0, :2])), P.Di)
    with pytest.raises(ValueError, match="exceed eps_o"):
        simulate(tr, _Hover(), operator0=tr.pos[0] + [1.0, 0, 5.0])
    with pytest.raises(ValueError, match="bearing_deg must be finite"):
        operator_start(tr, bearing_deg=float("nan"))


class _Hover:
    phase = SharkPhase.PURSUIT

    def reset(self, scenario, *, seed=None):
        """A hovering operator keeps no state between runs."""

    def command(self, obs):
        return SharkCommand(np.zeros(3), True)


def test_simulator_contact_geometry_with_hovering_operator():
    # a hovering operator straight ahead of path a at the optimal plane-1 altitude is hit head-on
    tr = thesis_trajectories()["a"]
    o0 = np.array([30.0, 0.0, 1.5])
    tr_ = simulate(tr, _Hover(), operator0=o0)
    # shark at z=-3, operator at 1.5: h = 4.5 = l1, eps = 3.5; contact when x_s = 26.5
    assert math.isclose(tr_.intercept_time, 26.5 / 5.34, abs_tol=0.011)
    assert math.isclose(tr_.interception_distance, 26.5, abs_tol=0.06)
    assert tr_.frontal and tr_.frontal_angle < 1e-6 and not tr_.touched_early
    assert math.isclose(tr_.contact_eps, 3.5)
    # beside the path (offset 4 m > eps) it is never touched
    miss = simulate(tr, _Hover(), operator0=np.array([30.0, 4.0, 1.5]), t_max=10)
    assert miss.intercept_time is None and not miss.frontal


def test_simulate_takes_a_scenario_and_fills_the_shared_trace_fields():
    tr = thesis_trajectories()["a"]
    o0 = np.array([30.0, 0.0, 1.5])
    old = simulate(tr, _Hover(), P, operator0=o0)
    new = simulate(InterceptionScenario(tr, P, operator0=o0), _Hover(), seed=7)
    assert new.intercept_time == old.intercept_time and np.array_equal(new.operator, old.operator)
    assert new.seed == 7 and new.fallbacks == 0 and new.status_counts == {}
    # the final state is the last recorded instant, frames are SharkFrame objects
    assert isinstance(new.final, SharkFrame) and new.final.t == new.t[-1]
    assert np.array_equal(new.final.operator, new.operator[-1]) and np.array_equal(
        new.final.shark, new.shark[-1]
    )
    assert len(new.frames) == len(new.t) and all(f.phase is SharkPhase.PURSUIT for f in new.frames)
    with pytest.raises(ValueError, match="already set"):
        simulate(InterceptionScenario(tr, P), _Hover(), P)
    with pytest.raises(TypeError, match="scenario"):
        simulate("a", _Hover())


def test_simulator_rejects_non_finite_input():
    tr = thesis_trajectories()["a"]
    with pytest.raises(ValueError, match="t_max"):
        simulate(tr, _Hover(), t_max=float("inf"))
    with pytest.raises(ValueError, match="operator0"):
        simulate(tr, _Hover(), operator0=[np.nan, 0.0, 1.0])

    class _Bad(_Hover):
        def command(self, obs):
            return SharkCommand(np.array([np.nan, 0.0, 0.0]))

    with pytest.raises(ValueError, match="non-finite"):
        simulate(tr, _Bad())
