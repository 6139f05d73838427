"""A Gymnasium environment of covert observation with motion camouflage (thesis ch. 3), and its
policy controller.

:class:`CovertEnv` steps the dynamics of :func:`droneplan.scenarios.covert.simulate`: the same
measurements (:func:`~droneplan.scenarios.covert.dynamics.observe_targets`, noise from the
episode's random stream) and the same drone model (3.2)-(3.5)
(:func:`~droneplan.scenarios.covert.step_drone`). One environment step is one control period
``params.dt`` (0.1 s by default). The drone starts at D_s, heading towards F.

Observation (float64, length ``7 + 4 n`` for n targets):

==================  ==================================================================
index               entry
==================  ==================================================================
0                   time t (s)
1-3                 drone position D (m)
4-6                 drone heading h (unit vector, dimensionless)
7 + 4j .. 9 + 4j    measured a_j = A_j - D of target j (m); 0 when it is not observable
10 + 4j             1 when target j is observable (line of sight), else 0
==================  ==================================================================

Action (float64, length 4): the heading rate u (3,) (rad/s, each component within
[-U_max, U_max]) and the speed v (m/s, within [-V_max, V_max]), a
:class:`~droneplan.scenarios.covert.CovertCommand`; the simulator projects u on the plane
orthogonal to h and scales it to |u| <= U_max, as for any controller.

Reward (thesis (3.6)-(3.8): observe without being noticed, i.e. keep the bearing change small):
minus the largest bearing change beta_j (3.6) over the observable targets at the end of the step
(rad, from the true positions; 0 when none is observable).

The mission's phases follow the drone's position: to-sphere until it first comes within L_u of F,
on-sphere while it stays there, retreat once it leaves; the episode terminates one step after the
drone, having reached the sphere, is back within ``home_radius`` of D_s (when a controller would
report ``finished``), and is truncated at ``t_max``.
"""

from __future__ import annotations

import math
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from numpy.typing import NDArray

from droneplan.core.validation import check_nonneg, check_positive
from droneplan.scenarios.covert.dynamics import (
    CovertCommand,
    CovertObservation,
    CovertPhase,
    _start,
    bearing_changes,
    observe_targets,
    step_drone,
)
from droneplan.scenarios.covert.world import CovertParams, CovertScenario, thesis_case
from droneplan.scenarios.envs._common import POSITION_BOUND, TIME_BOUND, check_action, check_policy

__all__ = ["CovertEnv", "policy_controller", "covert_observation_vector", "covert_command", "MissionProgress"]


def covert_observation_vector(obs: CovertObservation) -> NDArray[np.float64]:
    """The observation vector of :class:`CovertEnv` (module docstring) for a controller's observation.

    obs: a :class:`~droneplan.scenarios.covert.CovertObservation` (positions in m, time in s).
    """
    n = obs.rel.shape[0]
    out = np.empty(7 + 4 * n)
    out[0] = obs.t
    out[1:4] = obs.drone
    out[4:7] = obs.heading
    per_target = out[7:].reshape(n, 4)
    per_target[:, 0:3] = np.where(obs.observable[:, None], obs.rel, 0.0)
    per_target[:, 3] = obs.observable
    return out


def _action_bounds(params: CovertParams) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The action space's (low, high): heading rate u (rad/s, per component) then speed v (m/s)."""
    high = np.array([params.U_max, params.U_max, params.U_max, params.V_max])
    return -high, high


def covert_command(action: Any, params: CovertParams) -> CovertCommand:
    """The :class:`~droneplan.scenarios.covert.CovertCommand` of an action of :class:`CovertEnv`.

    action: (4,) heading rate u (rad/s) then speed v (m/s), within the limits of ``params`` (a
    one-line ValueError naming ``action`` otherwise); params: the run's CovertParams.
    """
    a = check_action(action, *_action_bounds(params))
    return CovertCommand(a[:3].copy(), float(a[3]))


class MissionProgress:
    """The mission's phase from the drone's position (the module docstring's rule), shared by
    :class:`CovertEnv` and :class:`policy_controller` so that both end a run at the same step.

    params: the run's CovertParams; home_radius: distance to D_s (m) that counts as back home.
    """

    def __init__(self, params: CovertParams, home_radius: float) -> None:
        self.params = params
        self.home_radius = home_radius
        self.phase = CovertPhase.TO_SPHERE
        self.finished = False

    def update(self, drone: NDArray[np.float64]) -> bool:
        """Advance the phase for the drone position ``drone`` (3,) (m); True once it is back home."""
        p = self.params
        on_sphere = float(np.linalg.norm(p.F_arr - drone)) <= p.L_u
        if self.phase == CovertPhase.TO_SPHERE and on_sphere:
            self.phase = CovertPhase.ON_SPHERE
        elif self.phase == CovertPhase.ON_SPHERE and not on_sphere:
            self.phase = CovertPhase.RETREAT
        if self.phase != CovertPhase.TO_SPHERE and np.linalg.norm(p.D_s_arr - drone) <= self.home_radius:
            self.phase = CovertPhase.DONE
            self.finished = True
        return self.finished


def _scenario(scenario: Any) -> CovertScenario | int:
    if isinstance(scenario, CovertScenario):
        return scenario
    if scenario in (1, 2) and not isinstance(scenario, bool):
        return int(scenario)
    raise TypeError(f"scenario must be a CovertScenario or a thesis case, 1 or 2, got {scenario!r:.60}")


class CovertEnv(gym.Env):
    """Covert observation as a ``gymnasium.Env`` (observation, action, reward and episode end: the
    module docstring of :mod:`droneplan.scenarios.envs.covert`).

    scenario: a :class:`~droneplan.scenarios.covert.CovertScenario`, or a thesis case: 1 (default,
        ``thesis_case(1)``: two targets) or 2 (ten targets: each reset draws ``thesis_case(2, seed)``
        from the reset's random stream). ``reset(options={"scenario": s})`` runs one episode on
        ``s`` (as many targets, the same limits). With a fixed scenario, ``reset(seed=k)`` draws the
        noise ``simulate(scenario, controller, noise=noise, seed=k)`` draws.
    noise: measurement noise amplitude as a fraction of each measured component (>= 0).
    t_max: episode time limit (s); None: the scenario's duration + 60 s (as ``simulate``).
    home_radius: distance to D_s (m) that counts as back home (the mission's end).
    """

    def __init__(
        self,
        scenario: Any = 1,
        *,
        noise: float = 0.0,
        t_max: float | None = None,
        home_radius: float = 5.0,
    ) -> None:
        self.scenario = _scenario(scenario)
        self.noise = check_nonneg("noise", noise)
        self.t_max = None if t_max is None else check_positive("t_max", t_max)
        self.home_radius = check_positive("home_radius", home_radius)
        template = self.scenario if isinstance(self.scenario, CovertScenario) else thesis_case(self.scenario)
        self._template = template
        self.action_space = spaces.Box(*_action_bounds(template.params), dtype=np.float64)
        n = template.n_targets
        high = np.full(7 + 4 * n, POSITION_BOUND)
        high[0] = TIME_BOUND
        high[4:7] = 1.0 + 1e-9  # a unit vector (rounding may pass 1 by an ulp)
        high[10::4] = 1.0
        low = -high
        low[0] = low[10::4] = 0.0
        self.observation_space = spaces.Box(low, high, dtype=np.float64)
        self._run: dict[str, Any] = {}

    def _episode_scenario(self, options: dict[str, Any] | None) -> CovertScenario:
        chosen = (options or {}).get("scenario", self.scenario)
        if isinstance(chosen, int) and not isinstance(chosen, bool):
            return self._template if chosen == 1 else thesis_case(2, int(self.np_random.integers(2**31)))
        if not isinstance(chosen, CovertScenario):
            raise TypeError(f"options['scenario'] must be a CovertScenario, got {type(chosen).__name__}")
        same_limits = (chosen.params.U_max, chosen.params.V_max) == (
            self._template.params.U_max,
            self._template.params.V_max,
        )
        if chosen.n_targets != self._template.n_targets or not same_limits:
            raise ValueError(
                "options['scenario'] must have the number of targets and the limits U_max, V_max the "
                f"spaces were built for ({self._template.n_targets} targets)"
            )
        return chosen

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[NDArray[np.float64], dict[str, Any]]:
        """Start an episode: ``seed`` seeds the episode's random stream (int >= 0; None: go on
        with the current one); ``options``: ``{"scenario": CovertScenario}`` for this episode."""
        super().reset(seed=seed)
        scenario = self._episode_scenario(options)
        _, t_stop, D, h = _start(scenario, self.t_max, None, False)
        p = scenario.params
        self._run = {
            "scenario": scenario,
            "k": 0,
            "steps": math.ceil(t_stop / p.dt - 1e-9),
            "drone": D,
            "heading": h,
            "progress": MissionProgress(p, self.home_radius),
        }
        self._observe()
        return covert_observation_vector(self._run["obs"]), self._info(0.0)

    def _observe(self) -> None:
        run = self._run
        t = run["k"] * run["scenario"].params.dt
        rel, mask = observe_targets(run["scenario"], t, run["drone"], self.noise, self.np_random)
        run["obs"] = CovertObservation(t, run["drone"].copy(), run["heading"].copy(), rel, mask)

    def observation(self) -> CovertObservation:
        """The controller's observation now (what ``simulate`` would pass to ``command``)."""
        if not self._run:
            raise RuntimeError("reset() must be called before the environment is used")
        return self._run["obs"]

    def _info(self, beta_max: float) -> dict[str, Any]:
        run = self._run
        return {
            "t": run["obs"].t,
            "drone": run["drone"].copy(),
            "phase": run["progress"].phase,
            "beta_max": beta_max,
        }

    def _beta_max(self) -> float:
        """Largest true bearing change (rad) over the targets observable now (0 when none is)."""
        run = self._run
        obs, scenario = run["obs"], run["scenario"]
        if not obs.observable.any():
            return 0.0
        targets = scenario.targets_at(obs.t)[obs.observable]
        return float(np.max(bearing_changes(run["drone"], targets, scenario.params.R)))

    def step(self, action: Any) -> tuple[NDArray[np.float64], float, bool, bool, dict[str, Any]]:
        """Fly the drone for one control period with ``action`` (module docstring; a one-line
        ValueError naming ``action`` when it lies outside the action space). Returns (observation,
        reward, terminated, truncated, info); info holds ``beta_max`` (rad) and ``phase``."""
        if not self._run:
            raise RuntimeError("reset() must be called before step()")
        run = self._run
        p = run["scenario"].params
        u, v = covert_command(action, p)
        finished = run["progress"].update(run["obs"].drone)
        run["drone"], run["heading"], _, _ = step_drone(run["drone"], run["heading"], u, v, p.dt, p)
        run["k"] += 1
        self._observe()
        beta = self._beta_max()
        truncated = not finished and run["k"] >= run["steps"]
        return covert_observation_vector(run["obs"]), -beta, finished, truncated, self._info(beta)


class policy_controller:
    """A covert-observation controller (the closed-loop contract) that flies ``policy``, a callable
    from the observation vector of :class:`CovertEnv` to its action, in
    :func:`~droneplan.scenarios.covert.simulate`: every ``command`` maps the observation with
    :func:`covert_observation_vector` and the action with :func:`covert_command`, as the environment
    does, and ``phase`` and ``finished`` follow :class:`MissionProgress`, so the run is the
    environment's.

    policy: a callable ``obs_vector (7 + 4 n,) -> action (4,)`` (heading rate u in rad/s, speed v in
        m/s); e.g. a trained network's predict function. In a study, pass the class with
        ``params={"policy": fn}`` (``droneplan.studies.methods.Method``).
    home_radius: distance to D_s (m) that counts as back home (as the environment's).
    """

    def __init__(self, policy: Any, *, home_radius: float = 5.0) -> None:
        self.policy = check_policy(policy)
        self.home_radius = check_positive("home_radius", home_radius)
        self.phase = CovertPhase.TO_SPHERE
        self.finished = False
        self._progress: MissionProgress | None = None

    def reset(self, scenario: CovertScenario, *, seed: Any = None) -> None:
        """Start a run on ``scenario`` (the policy draws nothing: ``seed`` is unused)."""
        if not isinstance(scenario, CovertScenario):
            raise TypeError(f"scenario must be a CovertScenario, got {type(scenario).__name__}")
        self._progress = MissionProgress(scenario.params, self.home_radius)
        self.phase = CovertPhase.TO_SPHERE
        self.finished = False

    def command(self, obs: CovertObservation) -> CovertCommand:
        """The policy's command for the next control period: heading rate u (rad/s), speed v (m/s)."""
        if self._progress is None:
            raise RuntimeError("reset() must be called before command()")
        cmd = covert_command(self.policy(covert_observation_vector(obs)), self._progress.params)
        self.finished = self._progress.update(obs.drone)
        self.phase = self._progress.phase
        return cmd
