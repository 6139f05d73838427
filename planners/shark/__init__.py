"""Shark interception controllers (thesis ch. 5)."""

from droneplan.planners.shark.altitude import thesis_altitude
from droneplan.planners.shark.fleet import allocate_operators, interception_time_matrix
from droneplan.planners.shark.ocp import OCPInterceptor, optimal_interception, virtual_shark_plan
from droneplan.planners.shark.pursuit import ClassicalPursuit, VirtualSharkInterceptor
from droneplan.planners.shark.repel import RepellingOperator

__all__ = [
    "thesis_altitude",
    "ClassicalPursuit",
    "VirtualSharkInterceptor",
    "OCPInterceptor",
    "optimal_interception",
    "virtual_shark_plan",
    "allocate_operators",
    "interception_time_matrix",
    "RepellingOperator",
]
