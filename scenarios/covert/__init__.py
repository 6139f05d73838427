"""Covert observation of moving animals with motion camouflage (thesis ch. 3).

The world of chapter 3: the Table 3.2 parameters, an uneven terrain over the
200 m x 200 m zone, animals (targets) walking on it, occlusions, measurement
noise, the drone's non-holonomic kinematics (3.2)-(3.5), the bearing change
(3.6) and a closed-loop simulator.

Units: metres, seconds, radians. ``U_max`` is the bound on ``|u|`` with
``dh/dt = u`` and ``|h| = 1``, i.e. a heading turn rate in rad/s
(the thesis table prints m/s^2).

Controllers plug into :func:`simulate` through the closed-loop contract shared by
every problem (:mod:`droneplan.scenarios.loop`):

- ``reset(scenario, *, seed=None)`` before the run;
- ``command(obs: CovertObservation) -> CovertCommand`` (``u``, ``v``) once per control
  period ``params.dt``;
- attributes ``phase`` (a :class:`CovertPhase`) and ``finished`` (bool), read after
  every command;
- optional ``fallbacks`` (int), ``statuses`` and ``solve_times`` (list of s), counted in the trace.
"""

from droneplan.scenarios.covert.dynamics import (
    Controller,
    CovertCommand,
    CovertFrame,
    CovertObservation,
    CovertPhase,
    CovertTrace,
    bearing_changes,
    measure,
    nearest_on_line,
    rotate_heading,
    simulate,
    step_drone,
)
from droneplan.scenarios.covert.world import (
    CASE1_TERRAIN,
    FIG_3_13_OBSTACLE,
    HABITAT,
    LAYOUTS,
    THESIS_TABLE_3_2,
    ZONE,
    CovertParams,
    CovertScenario,
    Obstacle,
    Occlusion,
    TargetPath,
    Terrain,
    random_case,
    thesis_case,
    two_target_layout,
)

__all__ = [
    "CovertParams",
    "THESIS_TABLE_3_2",
    "Terrain",
    "TargetPath",
    "Occlusion",
    "Obstacle",
    "FIG_3_13_OBSTACLE",
    "CovertScenario",
    "CovertObservation",
    "CovertCommand",
    "CovertPhase",
    "CovertFrame",
    "Controller",
    "CovertTrace",
    "thesis_case",
    "random_case",
    "two_target_layout",
    "LAYOUTS",
    "bearing_changes",
    "nearest_on_line",
    "rotate_heading",
    "step_drone",
    "measure",
    "simulate",
    "ZONE",
    "HABITAT",
    "CASE1_TERRAIN",
]
