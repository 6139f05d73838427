"""A Gymnasium environment of shark interception (thesis ch. 5), and its policy controller.

:class:`InterceptionEnv` steps the dynamics of :func:`droneplan.scenarios.shark.simulate`: the
operator's integrator (5.4) at Ts with the same clipping, altitude band and field-contact check
(:func:`~droneplan.scenarios.shark.simulate.operator_step`) against the shark's prescribed path.
One environment step is one control period Ts (0.1 s in Table 5.1).

Observation (float64, length 7):

=======  ==============================================================
index    entry
=======  ==============================================================
0-2      shark snout position minus operator position, S - O (m)
3-5      shark velocity (m/s)
6        operator altitude z_o (m)
=======  ==============================================================

Action (float64, length 3): the operator's velocity (m/s), within [-VoMxy, VoMxy] on x and y and
[-VoMz, VoMz] on z; the simulator scales a horizontal part longer than VoMxy back to VoMxy and keeps
the altitude in [lmin, le], as for any controller. The command's ``at_interception`` flag is True
(any contact is the one the policy aims for).

Reward (thesis §5.3: intercept the shark as early as possible, frontally): -Ts per step (s), and on
the step of the first field contact minus the time from the step's start to the contact, minus
``nonfrontal_penalty`` when the contact is not frontal (the shark's horizontal heading farther than
``frontal_tol_deg`` from the shark-to-operator direction). The sum over an episode that ends in a
frontal contact is minus the interception time.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from numpy.typing import NDArray

from droneplan.core.validation import check_in_range, check_int, check_nonneg, check_positive
from droneplan.scenarios.envs._common import POSITION_BOUND, check_action, check_policy
from droneplan.scenarios.shark.params import THESIS_TABLE_5_1, SharkParams
from droneplan.scenarios.shark.simulate import (
    FRONTAL_TOL_DEG,
    InterceptionScenario,
    SharkCommand,
    SharkObservation,
    SharkPhase,
    frontal_angle,
    operator_step,
)
from droneplan.scenarios.shark.trajectories import SharkTrajectory, random_trajectory, thesis_trajectories

__all__ = ["InterceptionEnv", "policy_controller", "shark_observation_vector", "shark_command"]


def shark_observation_vector(obs: SharkObservation) -> NDArray[np.float64]:
    """The observation vector of :class:`InterceptionEnv` (module docstring) for a controller's
    observation.

    obs: a :class:`~droneplan.scenarios.shark.SharkObservation` (positions in m, velocity in m/s).
    """
    out = np.empty(7)
    out[0:3] = np.asarray(obs.shark_pos, dtype=float) - np.asarray(obs.operator, dtype=float)
    out[3:6] = obs.shark_vel
    out[6] = obs.operator[2]
    return out


def _action_bounds(params: SharkParams) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The action space's (low, high): the operator's velocity limits per axis (m/s)."""
    high = np.array([params.VoMxy, params.VoMxy, params.VoMz])
    return -high, high


def shark_command(action: Any, params: SharkParams) -> SharkCommand:
    """The :class:`~droneplan.scenarios.shark.SharkCommand` of an action of :class:`InterceptionEnv`.

    action: (3,) operator velocity (m/s) within the per-axis limits of ``params`` (a one-line
    ValueError naming ``action`` otherwise); params: the run's SharkParams.
    """
    return SharkCommand(check_action(action, *_action_bounds(params)), True)


def _scenario(scenario: Any, duration: float) -> InterceptionScenario | None:
    """The constructor's scenario: an InterceptionScenario, a path (a SharkTrajectory or the name of a
    thesis path, "a" to "d"), or None (a random path per episode)."""
    if scenario is None or isinstance(scenario, InterceptionScenario):
        return scenario
    if isinstance(scenario, SharkTrajectory):
        return InterceptionScenario(scenario)
    if isinstance(scenario, str):
        paths = thesis_trajectories(duration=duration)
        if scenario not in paths:
            raise ValueError(f"scenario must name a thesis path {sorted(paths)}, got {scenario!r}")
        return InterceptionScenario(paths[scenario])
    raise TypeError(
        "scenario must be an InterceptionScenario, a SharkTrajectory, a thesis path name or None, "
        f"got {type(scenario).__name__}"
    )


def _check_start(scenario: InterceptionScenario, where: str) -> None:
    """The operator must start farther than eps_o from the shark (as :func:`simulate` requires)."""
    O, S = scenario.operator, scenario.trajectory.pos[0]
    if np.hypot(*(O[:2] - S[:2])) <= scenario.params.eps_o:
        raise ValueError(
            f"{where}: the initial horizontal separation must exceed eps_o={scenario.params.eps_o}"
        )


class InterceptionEnv(gym.Env):
    """Shark interception as a ``gymnasium.Env`` (observation, action and reward: the module
    docstring of :mod:`droneplan.scenarios.envs.shark`).

    An episode terminates at the first field contact and is truncated at the end of the shark's
    path (or at ``t_max``), as :func:`~droneplan.scenarios.shark.simulate` stops.

    scenario: an :class:`~droneplan.scenarios.shark.InterceptionScenario`, a
        :class:`~droneplan.scenarios.shark.SharkTrajectory` (Table 5.1, default start), the name of
        a thesis path ("a" to "d", ``duration`` s long), or None (default): each reset draws
        ``random_trajectory(seed, duration=duration)`` from the reset's random stream.
        ``reset(options={"scenario": s})`` runs one episode on ``s`` (same parameters).
    duration: length of the drawn or thesis paths (s).
    t_max: episode time limit (s); None: the path's duration.
    frontal_tol_deg: tolerance (deg) on the shark's heading pointing at the operator at contact.
    substeps: contact checks per step (count, as ``simulate``).
    nonfrontal_penalty: reward subtracted at a contact that is not frontal (s).
    """

    def __init__(
        self,
        scenario: Any = None,
        *,
        duration: float = 40.0,
        t_max: float | None = None,
        frontal_tol_deg: float = FRONTAL_TOL_DEG,
        substeps: int = 10,
        nonfrontal_penalty: float = 10.0,
    ) -> None:
        self.duration = check_positive("duration", duration)
        self.scenario = _scenario(scenario, self.duration)
        if self.scenario is not None:
            _check_start(self.scenario, "scenario")
        self.t_max = None if t_max is None else check_in_range("t_max", t_max, 0.0, lo_open=True)
        self.frontal_tol_deg = check_in_range(
            "frontal_tol_deg", frontal_tol_deg, 0.0, 180.0, lo_open=True, hi_open=True
        )
        self.substeps = check_int("substeps", substeps, min_value=1, max_value=10_000)
        self.nonfrontal_penalty = check_nonneg("nonfrontal_penalty", nonfrontal_penalty)
        self.params = self.scenario.params if self.scenario is not None else THESIS_TABLE_5_1
        self.action_space = spaces.Box(*_action_bounds(self.params), dtype=np.float64)
        high = np.full(7, POSITION_BOUND)
        self.observation_space = spaces.Box(-high, high, dtype=np.float64)
        self._fractions = np.linspace(0.0, 1.0, self.substeps + 1)[1:]
        self._run: dict[str, Any] = {}

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[NDArray[np.float64], dict[str, Any]]:
        """Start an episode: ``seed`` seeds the episode's random stream (int >= 0; None: go on
        with the current one); ``options``: ``{"scenario": InterceptionScenario}`` for this episode."""
        super().reset(seed=seed)
        scenario = (options or {}).get("scenario", self.scenario)
        if scenario is None:
            path_seed = int(self.np_random.integers(2**63 - 1))
            scenario = InterceptionScenario(random_trajectory(path_seed, duration=self.duration))
        elif not isinstance(scenario, InterceptionScenario):
            raise TypeError(
                f"options['scenario'] must be an InterceptionScenario, got {type(scenario).__name__}"
            )
        elif scenario.params != self.params:
            raise ValueError("options['scenario'] must have the parameters the spaces were built for")
        _check_start(scenario, "options['scenario']")
        n = len(scenario.trajectory.t) - 1
        n_max = n if self.t_max is None else min(n, round(self.t_max / scenario.params.Ts))
        self._run = {"scenario": scenario, "k": 0, "n_max": n_max, "operator": scenario.operator}
        return shark_observation_vector(self.observation()), self._info(None)

    def observation(self) -> SharkObservation:
        """The controller's observation now (what ``simulate`` would pass to ``command``)."""
        if not self._run:
            raise RuntimeError("reset() must be called before the environment is used")
        run = self._run
        tr, k = run["scenario"].trajectory, run["k"]
        return SharkObservation(float(tr.t[k]), run["operator"].copy(), tr.pos[k].copy(), tr.vel[k].copy())

    def _info(self, contact: Any) -> dict[str, Any]:
        run = self._run
        tr = run["scenario"].trajectory
        info = {
            "t": float(tr.t[run["k"]]),
            "operator": run["operator"].copy(),
            "shark": tr.pos[run["k"]].copy(),
        }
        if contact is not None:
            angle = frontal_angle(contact[3], contact[1], contact[2])
            info.update(intercept_time=contact[0], frontal_angle=angle, frontal=angle <= self.frontal_tol_deg)
        return info

    def step(self, action: Any) -> tuple[NDArray[np.float64], float, bool, bool, dict[str, Any]]:
        """Fly the operator for one Ts with the velocity ``action`` (m/s; a one-line ValueError naming
        ``action`` when it lies outside the action space). Returns (observation, reward,
        terminated, truncated, info); info holds ``intercept_time`` (s), ``frontal_angle`` (deg)
        and ``frontal`` on the contact step."""
        if not self._run:
            raise RuntimeError("reset() must be called before step()")
        run = self._run
        scenario = run["scenario"]
        cmd = shark_command(action, scenario.params)
        tr, k = scenario.trajectory, run["k"]
        step = operator_step(run["operator"], cmd.velocity, tr, k, scenario.params, self._fractions)
        run["operator"] = step.operator
        run["k"] = k + 1
        reward = -scenario.params.Ts
        terminated = step.contact is not None
        if step.contact is not None:
            reward = -(step.contact[0] - float(tr.t[k]))
            if frontal_angle(step.contact[3], step.contact[1], step.contact[2]) > self.frontal_tol_deg:
                reward -= self.nonfrontal_penalty
        truncated = not terminated and run["k"] >= run["n_max"]
        obs = shark_observation_vector(self.observation())
        return obs, float(reward), terminated, truncated, self._info(step.contact)


class policy_controller:
    """A shark-interception controller (the closed-loop contract) that flies ``policy``, a callable
    from the observation vector of :class:`InterceptionEnv` to its action, in
    :func:`~droneplan.scenarios.shark.simulate`: every ``command`` maps the observation with
    :func:`shark_observation_vector` and the action with :func:`shark_command`, as the environment
    does, so the run is the environment's. ``phase`` is ``SharkPhase.PURSUIT`` (a policy has no
    phases).

    policy: a callable ``obs_vector (7,) -> action (3,)`` (the operator's velocity, m/s); e.g. a
        trained network's predict function. In a study, pass the class with
        ``params={"policy": fn}`` (``droneplan.studies.methods.Method``).
    """

    def __init__(self, policy: Any) -> None:
        self.policy = check_policy(policy)
        self.phase = SharkPhase.PURSUIT
        self._params: SharkParams | None = None

    def reset(self, scenario: InterceptionScenario, *, seed: Any = None) -> None:
        """Start a run on ``scenario`` (the policy draws nothing: ``seed`` is unused)."""
        if not isinstance(scenario, InterceptionScenario):
            raise TypeError(f"scenario must be an InterceptionScenario, got {type(scenario).__name__}")
        self._params = scenario.params

    def command(self, obs: SharkObservation) -> SharkCommand:
        """The policy's velocity command (m/s) for the next Ts."""
        if self._params is None:
            raise RuntimeError("reset() must be called before command()")
        return shark_command(self.policy(shark_observation_vector(obs)), self._params)
