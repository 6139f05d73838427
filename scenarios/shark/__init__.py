"""Shark interception world (thesis ch. 5): Table 5.1, field model, shark paths, simulator, repelling."""

from droneplan.scenarios.shark.params import THESIS_TABLE_5_1, SharkParams, field_radius, inside_field, touches
from droneplan.scenarios.shark.repel import (RepellingMode, RepellingObservation, RepellingScenario, RepellingTrace,
                                            SharkBehaviour, simulate_repelling)
from droneplan.scenarios.shark.simulate import (DEFAULT_BEARING_DEG, FRONTAL_TOL_DEG, InterceptionController,
                                               InterceptionScenario, InterceptionTrace, SharkCommand, SharkFrame,
                                               SharkObservation, SharkPhase, clip_velocity, operator_start, simulate,
                                               simulate_interception)
from droneplan.scenarios.shark.trajectories import (SharkTrajectory, constant_velocity_trajectory, make_trajectory,
                                          random_trajectory, thesis_trajectories)

__all__ = [
    "THESIS_TABLE_5_1", "SharkParams", "field_radius", "inside_field", "touches",
    "DEFAULT_BEARING_DEG", "FRONTAL_TOL_DEG", "SharkPhase", "InterceptionScenario", "SharkObservation", "SharkCommand",
    "SharkFrame", "InterceptionController", "InterceptionTrace", "clip_velocity", "operator_start",
    "simulate", "simulate_interception", "SharkTrajectory", "constant_velocity_trajectory", "make_trajectory",
    "random_trajectory", "thesis_trajectories", "RepellingTrace", "SharkBehaviour", "simulate_repelling",
    "RepellingMode", "RepellingScenario", "RepellingObservation",
]
