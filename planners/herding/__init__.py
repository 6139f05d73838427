"""Thesis ch. 6 planners: steering-point allocation baselines, hull geometry, guidance laws, herders."""

from droneplan.planners.herding.allocation import allocate_bruteforce, allocate_collision_blind, crosses
from droneplan.planners.herding.geometry import (
    ExtendedHull,
    convex_hull,
    extended_hull_vertices,
    min_enclosing_circle,
)
from droneplan.planners.herding.guidance import F, fly_on_edge, fly_to_edge, g, next_waypoint, steer
from droneplan.planners.herding.herders import (
    BenchmarkHerder,
    HerderSettings,
    ProposedHerder,
    steering_points,
)

__all__ = [
    "allocate_bruteforce",
    "allocate_collision_blind",
    "crosses",
    "ExtendedHull",
    "convex_hull",
    "extended_hull_vertices",
    "min_enclosing_circle",
    "F",
    "g",
    "steer",
    "fly_to_edge",
    "fly_on_edge",
    "next_waypoint",
    "ProposedHerder",
    "BenchmarkHerder",
    "HerderSettings",
    "steering_points",
]
