"""The Gymnasium environments of herding, shark interception and covert observation, and the
policy controllers that fly the same policies in the problems' simulators."""

from __future__ import annotations

import subprocess
import sys
import warnings

import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import droneplan as dp

# check_env's advice that the environments do not follow: actions in physical units (not
# normalised to [-1, 1]), and no registered spec to test render modes through
ALLOWED_WARNINGS = ("symmetric and normalized space", "not having a spec")


def _checked(env) -> None:
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        check_env(env.unwrapped)
    others = [str(w.message) for w in caught if not any(a in str(w.message) for a in ALLOWED_WARNINGS)]
    assert not others


def _episode(env, policy, seed, options=None):
    """(observations, rewards, infos, terminated, truncated) of one episode flown by ``policy``."""
    obs, info = env.reset(seed=seed, options=options)
    observations, rewards, infos = [obs], [], [info]
    terminated = truncated = False
    while not (terminated or truncated):
        obs, reward, terminated, truncated, info = env.step(policy(obs))
        observations.append(obs)
        rewards.append(reward)
        infos.append(info)
    return np.array(observations), np.array(rewards), infos, terminated, truncated


# --------------------------------------------------------------------------- scripted policies
def herding_policy(obs):
    """Each drone turns towards a point 30 m beyond the animal farthest from the centroid and flies
    at 10 m/s (a crude collecting rule, through the observation vector only)."""
    n = (obs.size - 7) // 4
    far = obs[4:6]
    target = far * (1.0 + 30.0 / max(float(np.hypot(*far)), 1e-9))
    drones = obs[7:].reshape(n, 4)
    to_target = target - drones[:, :2]
    error = np.arctan2(to_target[:, 1], to_target[:, 0]) - np.arctan2(drones[:, 3], drones[:, 2])
    error = (error + np.pi) % (2 * np.pi) - np.pi
    return np.concatenate([np.full(n, 10.0), np.clip(3.0 * error, -5.0, 5.0)])


def shark_policy(obs):
    """Classical pursuit of the point above the shark (eq. 5.5) at full horizontal speed, holding
    the top of the altitude band."""
    rel = obs[:2]
    v_xy = 7.5 * rel / max(float(np.hypot(*rel)), 1e-9)
    return np.array([v_xy[0], v_xy[1], np.clip(2.0 - obs[6], -2.7, 2.7)])


def covert_policy_for(params):
    """Fly towards F for 8 s, then home to D_s (turning at most U_max), slowing near the goal."""

    def policy(obs):
        t, drone, heading = obs[0], obs[1:4], obs[4:7]
        goal = params.F_arr if t < 8.0 else params.D_s_arr
        to_goal = goal - drone
        dist = float(np.linalg.norm(to_goal))
        e = to_goal / max(dist, 1e-9)
        turn = e - np.dot(e, heading) * heading
        if np.dot(e, heading) < 0 and np.linalg.norm(turn) < 0.5:  # behind: turn left
            turn = np.cross(heading, [0.0, 0.0, 1.0])
        u = np.clip(4.0 * turn, -params.U_max, params.U_max)
        return np.concatenate([u, [min(params.V_max, dist)]])

    return policy


# --------------------------------------------------------------------------- herding
def _herd():
    return dp.herding.thesis_scenario(8, seed=1, n_drones=2)


def test_herding_env_passes_the_gymnasium_checker():
    _checked(dp.herding.HerdingEnv(n_animals=6, n_drones=2, t_max=5.0))


def test_herding_env_and_policy_controller_fly_the_same_run():
    scenario = _herd()
    env = dp.herding.HerdingEnv(scenario, t_max=20.0)
    _, rewards, infos, terminated, truncated = _episode(env, herding_policy, seed=3)
    trace = dp.herding.simulate(scenario, dp.herding.policy_controller(herding_policy), t_max=20.0, seed=3)
    drones = np.array([info["drones"] for info in infos])
    assert drones.shape == trace.drones.shape
    np.testing.assert_allclose(drones, trace.drones, rtol=0, atol=1e-9)
    np.testing.assert_allclose(infos[-1]["animals"], trace.final.animals, rtol=0, atol=1e-9)
    assert truncated and not terminated and trace.total_time is None
    # the progress reward sums to the decrease of (footprint radius + centroid-to-goal distance)
    potential = trace.footprint_radius + np.linalg.norm(trace.centroid - scenario.goal, axis=1)
    assert rewards.sum() == pytest.approx(potential[0] - potential[-1], abs=1e-9)


def test_herding_env_steps_each_drone_sub_step():
    # three commands per animal step: the environment's steps are the controller's calls
    scenario = dp.herding.with_params(_herd(), drone_substeps=3)
    env = dp.herding.HerdingEnv(scenario, t_max=4.0)
    _, rewards, infos, _, truncated = _episode(env, herding_policy, seed=2)
    trace = dp.herding.simulate(scenario, dp.herding.policy_controller(herding_policy), t_max=4.0, seed=2)
    drones = np.array([info["drones"] for info in infos])[::3]  # at the animal steps
    assert truncated and rewards.size == 3 * (trace.t.size - 1)
    np.testing.assert_allclose(drones, trace.drones, rtol=0, atol=1e-9)
    np.testing.assert_allclose(infos[-1]["animals"], trace.final.animals, rtol=0, atol=1e-9)
    assert np.count_nonzero(rewards[np.arange(rewards.size) % 3 != 2]) == 0  # paid after animal steps


def test_herding_env_ends_with_the_bonus_when_gathering_finishes():
    scenario = dp.herding.with_params(_herd(), R_c=500.0)  # gathered at the first animal step
    env = dp.herding.HerdingEnv(scenario, t_max=10.0, success_bonus=7.0, stop_after_gathering=True)
    obs, before = env.reset(seed=0)
    assert before["phase"] == dp.herding.HerdingPhase.DRIVING
    _, reward, terminated, truncated, after = env.step(herding_policy(obs))
    assert terminated and not truncated

    def potential(info):
        return info["footprint_radius"] + np.linalg.norm(info["centroid"] - scenario.goal)

    assert reward == pytest.approx(potential(before) - potential(after) + 7.0, abs=1e-9)


def test_herding_env_drawn_scenarios_repeat_with_the_seed():
    env = dp.herding.HerdingEnv(n_animals=5, n_drones=2, t_max=3.0)
    first, r1, *_ = _episode(env, herding_policy, seed=11)
    again, r2, *_ = _episode(env, herding_policy, seed=11)
    other, *_ = _episode(env, herding_policy, seed=12)
    np.testing.assert_array_equal(first, again)
    np.testing.assert_array_equal(r1, r2)
    assert not np.array_equal(first[0], other[0])


def test_herding_env_runs_the_scenario_of_the_options():
    env = dp.herding.HerdingEnv(n_animals=5, n_drones=2)
    scenario = _herd()
    _, info = env.reset(seed=0, options={"scenario": scenario})
    np.testing.assert_array_equal(info["animals"], scenario.animals)
    with pytest.raises(ValueError, match="options"):
        env.reset(options={"scenario": dp.herding.thesis_scenario(5, seed=0, n_drones=3)})


@pytest.mark.parametrize("bad", [np.full(4, 30.0), np.zeros(3), [np.nan, 0, 0, 0], "fast"])
def test_herding_env_refuses_an_action_outside_its_space(bad):
    env = dp.herding.HerdingEnv(n_animals=5, n_drones=2)
    env.reset(seed=0)
    with pytest.raises(ValueError, match=r"^action") as info:
        env.step(bad)
    assert "\n" not in str(info.value)


# --------------------------------------------------------------------------- shark
def test_shark_env_passes_the_gymnasium_checker():
    _checked(dp.shark.InterceptionEnv(duration=5.0))


@pytest.mark.parametrize("path", ["a", "d"])
def test_shark_env_and_policy_controller_fly_the_same_run(path):
    scenario = dp.shark.InterceptionScenario(dp.shark.thesis_trajectories(duration=10.0)[path])
    env = dp.shark.InterceptionEnv(scenario, nonfrontal_penalty=5.0)
    _, rewards, infos, terminated, _ = _episode(env, shark_policy, seed=0)
    trace = dp.shark.simulate(scenario, dp.shark.policy_controller(shark_policy), seed=0)
    operator = np.array([info["operator"] for info in infos])
    assert operator.shape == trace.operator.shape
    np.testing.assert_allclose(operator, trace.operator, rtol=0, atol=1e-9)
    assert terminated and trace.intercepted
    assert infos[-1]["intercept_time"] == trace.intercept_time
    assert infos[-1]["frontal"] == trace.frontal
    # the rewards sum to minus the interception time, less the penalty of a non-frontal contact
    expected = -trace.intercept_time - (0.0 if trace.frontal else 5.0)
    assert rewards.sum() == pytest.approx(expected, abs=1e-9)


def test_shark_env_truncates_at_the_end_of_the_path():
    env = dp.shark.InterceptionEnv("a", duration=1.0)
    _, rewards, _, terminated, truncated = _episode(env, lambda obs: np.zeros(3), seed=0)
    assert truncated and not terminated and rewards.size == 10
    np.testing.assert_allclose(rewards, -0.1)


def test_shark_env_drawn_paths_repeat_with_the_seed():
    env = dp.shark.InterceptionEnv(duration=4.0)
    first, r1, *_ = _episode(env, shark_policy, seed=5)
    again, r2, *_ = _episode(env, shark_policy, seed=5)
    other, *_ = _episode(env, shark_policy, seed=6)
    np.testing.assert_array_equal(first, again)
    np.testing.assert_array_equal(r1, r2)
    assert not np.array_equal(first[0], other[0])


@pytest.mark.parametrize("bad", [[8.0, 0.0, 0.0], [0.0, 0.0, 3.0], np.zeros(4), [np.inf, 0, 0]])
def test_shark_env_refuses_an_action_outside_its_space(bad):
    env = dp.shark.InterceptionEnv("a", duration=2.0)
    env.reset(seed=0)
    with pytest.raises(ValueError, match=r"^action"):
        env.step(bad)


# --------------------------------------------------------------------------- covert
def test_covert_env_passes_the_gymnasium_checker():
    _checked(dp.covert.CovertEnv(t_max=2.0))


def test_covert_env_and_policy_controller_fly_the_same_run():
    scenario = dp.covert.thesis_case(1)
    policy = covert_policy_for(scenario.params)
    env = dp.covert.CovertEnv(scenario, noise=0.05, t_max=40.0)
    _, rewards, infos, terminated, truncated = _episode(env, policy, seed=4)
    trace = dp.covert.simulate(scenario, dp.covert.policy_controller(policy), noise=0.05, seed=4, t_max=40.0)
    drone = np.array([info["drone"] for info in infos])
    assert drone.shape == trace.drone.shape
    np.testing.assert_allclose(drone, trace.drone, rtol=0, atol=1e-9)
    assert terminated and not truncated and trace.finished
    assert infos[-1]["phase"] == trace.phase[-1] == dp.covert.CovertPhase.DONE
    # the reward is minus the largest bearing change over the observable targets after each step
    np.testing.assert_allclose(rewards, -np.nan_to_num(trace.beta_m[1:]), rtol=0, atol=1e-12)


def test_covert_env_noise_repeats_with_the_seed():
    env = dp.covert.CovertEnv(noise=0.1, t_max=1.0)
    policy = covert_policy_for(dp.covert.THESIS_TABLE_3_2)
    first, *_ = _episode(env, policy, seed=2)
    again, *_ = _episode(env, policy, seed=2)
    other, *_ = _episode(env, policy, seed=3)
    np.testing.assert_array_equal(first, again)
    assert not np.array_equal(first, other)


def test_covert_env_refuses_other_target_counts_in_the_options():
    env = dp.covert.CovertEnv()
    with pytest.raises(ValueError, match="options"):
        env.reset(options={"scenario": dp.covert.random_case(3, 0)})


@pytest.mark.parametrize("bad", [[6.0, 0.0, 0.0, 1.0], [0.0, 0.0, 0.0, 11.0], np.zeros(3), None])
def test_covert_env_refuses_an_action_outside_its_space(bad):
    env = dp.covert.CovertEnv(t_max=1.0)
    env.reset(seed=0)
    with pytest.raises(ValueError, match=r"^action"):
        env.step(bad)


# --------------------------------------------------------------------------- all three
@pytest.mark.parametrize("problem", ["herding", "shark", "covert"])
def test_policy_controller_refuses_a_policy_that_is_not_callable(problem):
    with pytest.raises(TypeError, match=r"^policy"):
        getattr(dp, problem).policy_controller("fast")


def test_importing_droneplan_and_its_front_doors_loads_no_gymnasium():
    code = (
        "import sys\nimport droneplan as dp\n"
        "[getattr(dp, d).simulate for d in ('covert', 'shark', 'herding')]\n"
        "print('gymnasium' in sys.modules)\n"
        "dp.herding.HerdingEnv\n"
        "print('gymnasium' in sys.modules)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["False", "True"]
