"""Shark interception world (thesis ch. 5): Table 5.1, field model, shark paths, simulator, repelling."""

from droneplan.core.deprecation import deprecated_names
from droneplan.scenarios.shark.params import (
    THESIS_TABLE_5_1,
    SharkParams,
    field_radius,
    inside_field,
    touches,
)
from droneplan.scenarios.shark.repel import (
    AlarmLevel,
    ObserverDrone,
    RepellingMode,
    RepellingObservation,
    RepellingScenario,
    RepellingTrace,
    SharkBehaviour,
    alarm_level,
    sharks_to_repel,
    simulate_repelling,
)
from droneplan.scenarios.shark.simulate import (
    DEFAULT_BEARING_DEG,
    FRONTAL_TOL_DEG,
    InterceptionController,
    InterceptionScenario,
    InterceptionTrace,
    SharkCommand,
    SharkFrame,
    SharkObservation,
    SharkPhase,
    clip_velocity,
    operator_start,
    simulate,
)
from droneplan.scenarios.shark.trajectories import (
    SharkTrajectory,
    constant_velocity_trajectory,
    make_trajectory,
    random_trajectory,
    thesis_trajectories,
)

__all__ = [
    "THESIS_TABLE_5_1",
    "SharkParams",
    "field_radius",
    "inside_field",
    "touches",
    "DEFAULT_BEARING_DEG",
    "FRONTAL_TOL_DEG",
    "SharkPhase",
    "InterceptionScenario",
    "SharkObservation",
    "SharkCommand",
    "SharkFrame",
    "InterceptionController",
    "InterceptionTrace",
    "clip_velocity",
    "operator_start",
    "simulate",
    "SharkTrajectory",
    "constant_velocity_trajectory",
    "make_trajectory",
    "random_trajectory",
    "thesis_trajectories",
    "RepellingTrace",
    "SharkBehaviour",
    "simulate_repelling",
    "ObserverDrone",
    "AlarmLevel",
    "alarm_level",
    "sharks_to_repel",
    "RepellingMode",
    "RepellingScenario",
    "RepellingObservation",
]


__getattr__ = deprecated_names(__name__, {"simulate_interception": "simulate"}, globals())
