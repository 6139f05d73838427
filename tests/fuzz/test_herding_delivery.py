"""Herds are delivered whole (completion = every animal in the goal region,
``HerdingTrace.delivered``, regrouping when the herd spreads while driving)."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

import droneplan as dp


class _Idle:
    """A herder double that keeps its drones still and records the phases it is shown."""

    phase = dp.herding.HerdingPhase.GATHERING

    def reset(self, scenario, *, seed=None):
        """Start recording."""
        self.seen = []

    def command(self, obs):
        self.seen.append(obs.phase)
        return dp.herding.HerdingCommand(np.zeros(len(obs.drones)), np.zeros(len(obs.drones)))


def _ring(radius: float, n: int, centre) -> np.ndarray:
    phi = 2 * math.pi * np.arange(n) / n
    return np.asarray(centre) + radius * np.column_stack([np.cos(phi), np.sin(phi)])


def test_a_herd_around_the_goal_but_outside_the_yard_is_not_delivered():
    """Completion was "centroid within goal_radius", so a herd whose centroid sat on G
    counted as delivered with every animal outside the goal region."""
    base = dp.herding.thesis_scenario(30, seed=0)
    goal = base.goal
    sc = replace(base, animals=_ring(55.0, 30, goal), params=replace(base.params, graze_prob=0.0))
    assert sc.params.goal_radius < 55.0 <= sc.params.R_c
    trace = dp.herding.simulate(sc, _Idle(), t_max=2.0, seed=0)
    assert trace.gather_time == 0.0
    assert trace.total_time is None
    assert np.all(trace.delivered == 0.0)


def test_delivered_is_the_fraction_of_animals_in_the_goal_region():
    """HerdingTrace.delivered at each recorded time."""
    base = dp.herding.thesis_scenario(10, seed=0)
    inside = _ring(10.0, 4, base.goal)
    outside = _ring(30.0, 6, base.goal + np.array([300.0, 0.0]))
    sc = replace(base, animals=np.vstack([inside, outside]), params=replace(base.params, graze_prob=0.0))
    trace = dp.herding.simulate(sc, _Idle(), t_max=1.0, seed=0)
    assert len(trace.delivered) == len(trace.t)
    assert trace.delivered[0] == 0.4


def test_a_herd_that_spreads_while_driving_is_gathered_again():
    """The herd split while driving and the run still finished; now the phase goes
    back to gathering when the footprint exceeds regroup_factor * R_c."""
    base = dp.herding.thesis_scenario(40, seed=0)
    params = replace(base.params, regroup_factor=1.0, graze_prob=1.0)
    sc = replace(
        base, animals=_ring(params.R_c - 0.05, 40, base.goal + np.array([500.0, 0.0])), params=params
    )
    idle = _Idle()
    trace = dp.herding.simulate(sc, idle, t_max=5.0, seed=1)
    assert trace.regroupings >= 1
    phases = list(idle.seen)
    first_drive = phases.index(dp.herding.HerdingPhase.DRIVING)
    assert dp.herding.HerdingPhase.GATHERING in phases[first_drive:]
    # the thesis herders follow the simulator back to gathering
    trace = dp.herding.simulate(sc, dp.herding.ProposedHerder(), t_max=5.0, seed=1)
    assert trace.regroupings >= 1


def test_a_finished_run_has_every_animal_in_the_goal_region():
    """When total_time is set, delivered is 1 there (every animal within goal_radius of G)."""
    base = dp.herding.thesis_scenario(20, seed=0)
    sc = replace(base, animals=_ring(5.0, 20, base.goal))
    trace = dp.herding.simulate(sc, _Idle(), t_max=2.0, seed=0)
    assert trace.total_time == 0.0 and trace.delivered[-1] == 1.0
    final = trace.final.animals
    assert np.all(np.linalg.norm(final - base.goal, axis=1) <= base.params.goal_radius)
