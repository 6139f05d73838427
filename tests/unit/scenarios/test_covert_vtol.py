"""The vertical take-off and landing of the thesis's covert mission (§3.4, Algorithm 1 step 2)."""

from __future__ import annotations

import math

import numpy as np
import pytest

import droneplan as dp
from droneplan.scenarios.covert import CovertPhase, CovertScenario, Terrain

P = CovertPhase


@pytest.fixture(scope="module")
def case1():
    return dp.covert.thesis_case(1)


@pytest.fixture(scope="module")
def run(case1):
    return dp.covert.simulate(case1, dp.covert.SlidingModeObserver(), vtol=True)


def _blocks(phases) -> list[CovertPhase]:
    out: list[CovertPhase] = []
    for ph in phases:
        if not out or out[-1] != ph:
            out.append(ph)
    return out


def test_the_mission_takes_off_first_and_lands_last(run):
    assert _blocks(run.phase) == [P.TAKE_OFF, P.TO_SPHERE, P.ON_SPHERE, P.RETREAT, P.LANDING, P.DONE]
    assert run.finished
    assert run.t_a is not None and run.t_f is not None and run.t_a < run.t_f


def test_take_off_climbs_straight_up_from_the_ground_below_d_s_to_d_s(run, case1):
    p = case1.params
    ground = float(case1.terrain.height(p.D_s[0], p.D_s[1]))
    up = np.nonzero(run.phase == P.TAKE_OFF)[0]
    assert up[0] == 0 and np.array_equal(up, np.arange(up.size))  # one block at the start
    # D_v is on the ground below D_s; the climb is flown at V_max: ceil(climb / (V_max dt)) steps
    assert np.allclose(run.drone[0], [p.D_s[0], p.D_s[1], ground])
    assert up.size == math.ceil((p.D_s[2] - ground) / (p.V_max * p.dt))
    leg = run.drone[: up.size + 1]  # up to the first instant of the controller's mission
    assert np.array_equal(leg[:, :2], np.tile(p.D_s_arr[:2], (leg.shape[0], 1)))  # no horizontal motion
    assert np.all(np.diff(leg[:, 2]) > 0) and np.all(np.diff(leg[:, 2]) <= p.V_max * p.dt + 1e-12)
    assert np.array_equal(run.drone[up.size], p.D_s_arr)  # the controller starts at D_s
    assert np.allclose(run.v[up], np.diff(leg[:, 2]) / p.dt)  # recorded as the vertical speed


def test_landing_descends_straight_down_to_the_ground_where_the_retreat_ended(run, case1):
    p = case1.params
    down = np.nonzero(run.phase == P.LANDING)[0]
    assert down.size and np.array_equal(down, np.arange(down[0], down[-1] + 1))
    assert down[-1] == len(run.t) - 2  # then the final DONE row
    leg = run.drone[down[0] :]
    assert np.all(leg[:, :2] == leg[0, :2])  # no horizontal motion
    assert np.linalg.norm(leg[0] - p.D_s_arr) <= dp.covert.SlidingSettings().arrival_tol + 1e-9
    assert np.all(np.diff(leg[:, 2]) <= 0) and np.all(np.diff(leg[:, 2]) >= -p.V_max * p.dt - 1e-12)
    assert leg[-1, 2] == pytest.approx(float(case1.terrain.height(*leg[-1, :2])), abs=1e-9)


def test_default_mission_is_the_thesis_s_simulated_one_without_vtol(case1):
    a = dp.covert.simulate(case1, dp.covert.HoverBenchmark())
    b = dp.covert.simulate(case1, dp.covert.HoverBenchmark(), vtol=False)
    assert _blocks(a.phase) == [P.TO_SPHERE, P.ON_SPHERE, P.RETREAT, P.DONE]
    assert np.array_equal(a.drone[0], case1.params.D_s_arr)
    assert np.array_equal(a.drone, b.drone) and a.beta_max == b.beta_max


def test_a_run_cut_short_during_the_take_off_ends_in_take_off(case1):
    tr = dp.covert.simulate(case1, dp.covert.HoverBenchmark(), vtol=True, t_max=1.0)
    assert set(tr.phase) == {P.TAKE_OFF} and not tr.finished
    assert np.all(tr.drone[:, :2] == case1.params.D_s_arr[:2])


@pytest.mark.parametrize("value", ["yes", 1, None, 1.0])
def test_vtol_must_be_a_bool(case1, value):
    with pytest.raises(TypeError, match="vtol"):
        dp.covert.simulate(case1, dp.covert.HoverBenchmark(), vtol=value, t_max=1.0)


def test_vtol_needs_d_s_above_the_ground(case1):
    p = case1.params
    hill = Terrain(((p.D_s[0], p.D_s[1], p.D_s[2] + 5.0, 10.0),))
    sc = CovertScenario(p, hill, case1.paths)
    with pytest.raises(ValueError, match="vtol"):
        dp.covert.simulate(sc, dp.covert.HoverBenchmark(), vtol=True)
    tr = dp.covert.simulate(sc, dp.covert.HoverBenchmark(), t_max=1.0)  # without VTOL it still runs
    assert tr.phase[0] == P.TO_SPHERE
