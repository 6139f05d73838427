"""The Prop. 5.3.3 counter-example of docs/problems/shark.md, recomputed with the call the page shows."""

import math

import numpy as np
import pytest

import droneplan as dp
from droneplan.scenarios.shark import SharkPhase


@pytest.fixture(scope="module")
def curvy():
    scenario = dp.shark.InterceptionScenario(dp.shark.random_trajectory(9), bearing_deg=133)
    return dp.shark.simulate(scenario, dp.shark.VirtualSharkInterceptor())


def test_the_virtual_shark_touches_the_shark_early_at_the_documented_time(curvy):
    assert curvy.touched_early
    assert curvy.intercept_time == pytest.approx(7.39, abs=0.02)
    # in step 2, never having captured S2, at the documented contact point
    assert curvy.phase[-1] == SharkPhase.CROSS
    k = len(curvy.t) - 1
    f = (curvy.intercept_time - curvy.t[k - 1]) / (curvy.t[k] - curvy.t[k - 1])
    shark = curvy.shark[k - 1] + f * (curvy.shark[k] - curvy.shark[k - 1])
    operator = curvy.operator[k - 1] + f * (curvy.operator[k] - curvy.operator[k - 1])
    assert np.allclose(shark, [-39.95, 4.85, -5.71], atol=0.02)
    assert np.allclose(operator, [-42.40, 7.35, 1.79], atol=0.02)
    assert curvy.contact_eps == pytest.approx(3.5, abs=1e-6)
    assert curvy.interception_distance == pytest.approx(40.24, abs=0.02)
    assert curvy.frontal_angle == pytest.approx(2.07, abs=0.05)


def test_the_shark_turns_during_step_2(curvy):
    step2 = np.flatnonzero(curvy.phase == SharkPhase.CROSS)
    assert curvy.t[step2[0]] == pytest.approx(3.8)
    v = curvy.shark_vel[[step2[0], -1], :2]
    turn = math.degrees(math.atan2(*v[1][::-1]) - math.atan2(*v[0][::-1]))
    turn = (turn + 180) % 360 - 180
    assert turn == pytest.approx(-68.6, abs=0.5)


def test_the_same_path_without_its_turns_is_met_without_an_early_touch():
    scenario = dp.shark.InterceptionScenario(dp.shark.random_trajectory(9, curvy=False), bearing_deg=133)
    flat = dp.shark.simulate(scenario, dp.shark.VirtualSharkInterceptor())
    assert flat.intercepted and flat.frontal and not flat.touched_early
    assert flat.intercept_time == pytest.approx(9.16, abs=0.02)
