"""A Gymnasium environment of herding with barking drones (thesis ch. 6), and its policy controller.

:class:`HerdingEnv` steps the dynamics of :func:`droneplan.scenarios.herding.simulate`: the same
drone model (:func:`~droneplan.scenarios.herding.drone_step`), animal step and phase rules, drawn
from the same random stream. One environment step is one drone sub-step, i.e. one call of a
herder's ``command`` (``params.delta / params.drone_substeps`` seconds, 0.2 s by default); the
animals move after the last sub-step of each animal step.

Observation (float64, length ``7 + 4 n_d``), in metres unless stated, from the animals' positions at
the start of the current animal step and the drones' state now:

====================  =====================================================================
index                 entry
====================  =====================================================================
0, 1                  herd centroid C_o minus the goal G (m)
2                     footprint radius: largest animal-to-centroid distance (m)
3                     root mean square animal-to-centroid distance (m)
4, 5                  the animal farthest from the centroid, minus the centroid (m)
6                     phase: 0 gathering, 1 driving (or done)
7 + 4j, 8 + 4j        drone j's position minus the centroid (m)
9 + 4j, 10 + 4j       cos and sin of drone j's heading angle (dimensionless)
====================  =====================================================================

Action (float64, length ``2 n_d``): the speeds v_j (m/s, within [-V_max, V_max]) then the heading
rates omega_j (rad/s, within [-U_max, U_max]) of the drones, a
:class:`~droneplan.scenarios.herding.HerdingCommand`.

Reward (thesis §6.4: gather the herd within R_c of its centroid, then drive it to G): after each
animal step, the decrease of ``footprint radius + |C_o - G|`` over the step (m), plus
``success_bonus`` when the episode ends successfully; 0 on the other sub-steps.
"""

from __future__ import annotations

import math
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from numpy.typing import NDArray

from droneplan.core.validation import check_bool, check_nonneg, check_positive, check_size
from droneplan.scenarios.envs._common import POSITION_BOUND, check_action, check_policy
from droneplan.scenarios.herding import (
    HerdingCommand,
    HerdingObservation,
    HerdingParams,
    HerdingPhase,
    HerdingScenario,
    animal_step,
    drone_step,
    herd_measures,
    next_phase,
    thesis_scenario,
)

__all__ = ["HerdingEnv", "policy_controller", "herding_observation_vector", "herding_command"]


def herding_observation_vector(obs: HerdingObservation, goal: Any) -> NDArray[np.float64]:
    """The observation vector of :class:`HerdingEnv` (module docstring) for a herder's observation.

    obs: a :class:`~droneplan.scenarios.herding.HerdingObservation`; goal: (2,) the designated
    location G (m).
    """
    c = np.asarray(obs.centroid, dtype=float)
    d = np.asarray(obs.animals, dtype=float) - c
    sq = d[:, 0] * d[:, 0] + d[:, 1] * d[:, 1]
    far = int(np.argmax(sq))
    n_d = obs.drones.shape[0]
    out = np.empty(7 + 4 * n_d)
    out[0:2] = c - np.asarray(goal, dtype=float)
    out[2] = math.sqrt(float(sq[far]))
    out[3] = math.sqrt(float(np.mean(sq)))
    out[4:6] = d[far]
    out[6] = 0.0 if obs.phase == HerdingPhase.GATHERING else 1.0
    per_drone = out[7:].reshape(n_d, 4)
    per_drone[:, 0:2] = obs.drones - c
    per_drone[:, 2] = np.cos(obs.headings)
    per_drone[:, 3] = np.sin(obs.headings)
    return out


def _action_bounds(params: HerdingParams) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The action space's (low, high): speeds (m/s) then heading rates (rad/s), one per drone."""
    n = params.n_drones
    high = np.concatenate([np.full(n, params.V_max), np.full(n, params.U_max)])
    return -high, high


def herding_command(action: Any, params: HerdingParams) -> HerdingCommand:
    """The :class:`~droneplan.scenarios.herding.HerdingCommand` of an action of :class:`HerdingEnv`.

    action: (2 n_d,) the drones' speeds (m/s) then heading rates (rad/s), within the limits of
    ``params`` (a one-line ValueError naming ``action`` otherwise); params: the run's HerdingParams.
    """
    a = check_action(action, *_action_bounds(params))
    n = params.n_drones
    return HerdingCommand(a[:n].copy(), a[n:].copy())


def _potential(centroid: NDArray[np.float64], radius: float, goal: NDArray[np.float64]) -> float:
    """footprint radius + distance from the centroid to the goal (m): what the reward decreases."""
    g = centroid - goal
    return radius + math.hypot(float(g[0]), float(g[1]))


class HerdingEnv(gym.Env):
    """Herding with barking drones as a ``gymnasium.Env`` (observation, action and reward: the
    module docstring of :mod:`droneplan.scenarios.envs.herding`).

    An episode terminates when every animal is in the goal region (phase done), or when gathering
    finishes with ``stop_after_gathering``; both earn ``success_bonus`` (an episode whose scenario
    is already over at reset terminates at its first step). It is truncated at
    ``t_max`` (the animal steps :func:`~droneplan.scenarios.herding.simulate` would run).

    scenario: the :class:`~droneplan.scenarios.herding.HerdingScenario` to herd; None (default):
        each reset draws ``thesis_scenario(n_animals, seed=..., n_drones=n_drones)`` from the
        reset's random stream. ``reset(options={"scenario": s})`` runs one episode on ``s`` (with
        as many drones and the same V_max, U_max). With a fixed scenario, ``reset(seed=k)`` then
        steps the animals with the random stream ``simulate(scenario, controller, seed=k)`` uses.
    n_animals: herd size of the drawn scenarios (count, >= 1).
    n_drones: number of drones of the drawn scenarios (count, >= 1).
    t_max: simulated time limit of an episode (s).
    success_bonus: reward added at a successful end (m, the unit of the progress reward).
    stop_after_gathering: end the episode when gathering finishes.
    """

    def __init__(
        self,
        scenario: HerdingScenario | None = None,
        *,
        n_animals: int = 20,
        n_drones: int = 4,
        t_max: float = 600.0,
        success_bonus: float = 1000.0,
        stop_after_gathering: bool = False,
    ) -> None:
        if scenario is not None and not isinstance(scenario, HerdingScenario):
            raise TypeError(f"scenario must be a HerdingScenario or None, got {type(scenario).__name__}")
        self.scenario = scenario
        self.n_animals = n_animals
        self.n_drones = n_drones
        # the drawn scenario's checks, now: a bad n_animals or n_drones fails here, not at reset
        template = scenario if scenario is not None else thesis_scenario(n_animals, 0, n_drones=n_drones)
        self.t_max = check_positive("t_max", t_max)
        check_size("t_max", math.ceil(self.t_max / template.params.delta) * template.n_animals)
        self.success_bonus = check_nonneg("success_bonus", success_bonus)
        self.stop_after_gathering = check_bool("stop_after_gathering", stop_after_gathering)
        self._template = template
        low, high = _action_bounds(template.params)
        self.action_space = spaces.Box(low, high, dtype=np.float64)
        n_d = template.params.n_drones
        obs_high = np.full(7 + 4 * n_d, POSITION_BOUND)
        obs_high[6] = 1.0
        obs_high[9::4] = obs_high[10::4] = 1.0
        obs_low = -obs_high
        obs_low[2:4] = obs_low[6] = 0.0
        self.observation_space = spaces.Box(obs_low, obs_high, dtype=np.float64)
        self._run: dict[str, Any] = {}

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[NDArray[np.float64], dict[str, Any]]:
        """Start an episode: ``seed`` seeds the episode's random stream (int >= 0; None: go on
        with the current one); ``options``: ``{"scenario": HerdingScenario}`` for this episode."""
        super().reset(seed=seed)
        scenario = self._episode_scenario(options)
        p = scenario.params
        sub = p.drone_substeps
        self._run = {
            "scenario": scenario,
            "animals": scenario.animals.copy(),
            "heading": np.zeros_like(scenario.animals),
            "drones": scenario.drones.copy(),
            "headings": scenario.headings.copy(),
            "step": 0,
            "sub": 0,
            "dts": p.delta / sub,
            "n_steps": math.ceil(self.t_max / p.delta),
            "phase": HerdingPhase.GATHERING,
        }
        self._measure()
        return self._vector(), self._info()

    def _episode_scenario(self, options: dict[str, Any] | None) -> HerdingScenario:
        """The scenario of the episode starting now (``options``, the constructor's or a draw)."""
        chosen = (options or {}).get("scenario", self.scenario)
        if chosen is None:
            seed = int(self.np_random.integers(2**63 - 1))
            return thesis_scenario(self.n_animals, seed, n_drones=self.n_drones)
        if not isinstance(chosen, HerdingScenario):
            raise TypeError(f"options['scenario'] must be a HerdingScenario, got {type(chosen).__name__}")
        mine, theirs = self._template.params, chosen.params
        if (theirs.n_drones, theirs.V_max, theirs.U_max) != (mine.n_drones, mine.V_max, mine.U_max):
            raise ValueError(
                f"options['scenario'] must have the {mine.n_drones} drones and the limits V_max, U_max "
                "the spaces were built for"
            )
        return chosen

    def _measure(self) -> None:
        """Centroid, footprint radius, delivered share and phase after an animal step (or at t = 0)."""
        run = self._run
        scenario = run["scenario"]
        c, r, share = herd_measures(run["animals"], scenario.goal, scenario.params.goal_radius)
        phase, _, _, stop = next_phase(run["phase"], r, share, scenario.params, self.stop_after_gathering)
        # a scenario already over at reset (gathered or delivered) ends at the first step
        run.update(centroid=c, radius=r, share=share, phase=phase, stop=stop or run.get("stop", False))

    def observation(self) -> HerdingObservation:
        """The herder's observation of the current sub-step (what ``simulate`` would pass to ``command``)."""
        run = self._run
        if not run:
            raise RuntimeError("reset() must be called before the environment is used")
        p = run["scenario"].params
        t = run["step"] * p.delta + run["sub"] * run["dts"]
        return HerdingObservation(
            t,
            run["animals"],
            run["centroid"],
            run["phase"],
            run["drones"],
            run["headings"],
            run["dts"],
            run["sub"] == 0,
        )

    def _vector(self) -> NDArray[np.float64]:
        return herding_observation_vector(self.observation(), self._run["scenario"].goal)

    def _info(self) -> dict[str, Any]:
        run = self._run
        return {
            "t": run["step"] * run["scenario"].params.delta + run["sub"] * run["dts"],
            "phase": run["phase"],
            "centroid": run["centroid"].copy(),
            "footprint_radius": run["radius"],
            "delivered": run["share"],
            "animals": run["animals"].copy(),
            "drones": run["drones"].copy(),
        }

    def step(self, action: Any) -> tuple[NDArray[np.float64], float, bool, bool, dict[str, Any]]:
        """Fly the drones for one sub-step with ``action`` (module docstring; a one-line ValueError
        naming ``action`` when it lies outside the action space), then move the animals after the
        last sub-step of an animal step. Returns (observation, reward, terminated, truncated, info)."""
        if not self._run:
            raise RuntimeError("reset() must be called before step()")
        run = self._run
        scenario = run["scenario"]
        p = scenario.params
        v, omega = herding_command(action, p)
        run["drones"], run["headings"] = drone_step(run["drones"], run["headings"], v, omega, p, run["dts"])
        run["sub"] += 1
        reward, terminated, truncated = 0.0, False, False
        if run["sub"] == p.drone_substeps:
            before = _potential(run["centroid"], run["radius"], scenario.goal)
            run["animals"], run["heading"], _ = animal_step(
                run["animals"],
                run["heading"],
                run["drones"],
                p,
                self.np_random,
                p.delta,
                None,
                run["centroid"],
            )
            run["step"] += 1
            run["sub"] = 0
            self._measure()
            reward = before - _potential(run["centroid"], run["radius"], scenario.goal)
            terminated = bool(run["stop"] or run["phase"] == HerdingPhase.DONE)
            reward += self.success_bonus if terminated else 0.0
            truncated = not terminated and run["step"] >= run["n_steps"]
        return self._vector(), float(reward), terminated, truncated, self._info()


class policy_controller:
    """A herder (the closed-loop contract) that flies ``policy``, a callable from the observation
    vector of :class:`HerdingEnv` to its action, in :func:`~droneplan.scenarios.herding.simulate`:
    every ``command`` maps the observation with :func:`herding_observation_vector` and the action
    with :func:`herding_command`, as the environment does, so the run is the environment's.

    policy: a callable ``obs_vector (7 + 4 n_d,) -> action (2 n_d,)`` (speeds in m/s, then heading
        rates in rad/s); e.g. a trained network's predict function. In a study, pass the class with
        ``params={"policy": fn}`` (``droneplan.studies.methods.Method``).
    """

    def __init__(self, policy: Any) -> None:
        self.policy = check_policy(policy)
        self.phase = HerdingPhase.GATHERING
        self._goal: NDArray[np.float64] | None = None
        self._params: HerdingParams | None = None

    def reset(self, scenario: HerdingScenario, *, seed: Any = None) -> None:
        """Start a run on ``scenario`` (the policy draws nothing: ``seed`` is unused)."""
        if not isinstance(scenario, HerdingScenario):
            raise TypeError(f"scenario must be a HerdingScenario, got {type(scenario).__name__}")
        self._goal = scenario.goal
        self._params = scenario.params
        self.phase = HerdingPhase.GATHERING

    def command(self, obs: HerdingObservation) -> HerdingCommand:
        """The policy's command for this sub-step: speeds (m/s) and heading rates (rad/s)."""
        if self._goal is None or self._params is None:
            raise RuntimeError("reset() must be called before command()")
        self.phase = obs.phase
        return herding_command(self.policy(herding_observation_vector(obs, self._goal)), self._params)
