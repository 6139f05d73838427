"""Shark interception models (thesis ch. 5): exact optimal altitude, time-optimal interception
OCP, assignment."""

from droneplan.formulations.shark.altitude import optimal_altitude
from droneplan.formulations.shark.assignment import (
    Assignment,
    assignment_cost,
    build_assignment_model,
    greedy_assignment,
    select_sharks,
    solve_assignment,
)
from droneplan.formulations.shark.bound import frontal_point, interception_time_bound
from droneplan.formulations.shark.ocp import (
    InterceptionOCP,
    InterceptionPlan,
    build_interception_nlp,
    casadi_optimal_altitude,
    solve_interception,
)

__all__ = [
    "optimal_altitude",
    "InterceptionOCP",
    "InterceptionPlan",
    "build_interception_nlp",
    "casadi_optimal_altitude",
    "solve_interception",
    "Assignment",
    "assignment_cost",
    "build_assignment_model",
    "greedy_assignment",
    "select_sharks",
    "solve_assignment",
    "frontal_point",
    "interception_time_bound",
]
