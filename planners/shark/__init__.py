"""Shark interception controllers (thesis ch. 5)."""

from planners.shark.altitude import thesis_altitude
from planners.shark.fleet import allocate_operators, interception_time_matrix
from planners.shark.ocp import OCPInterceptor, optimal_interception, virtual_shark_plan
from planners.shark.repel import RepellingOperator
from planners.shark.pursuit import ClassicalPursuit, VirtualSharkInterceptor

__all__ = ["thesis_altitude", "ClassicalPursuit", "VirtualSharkInterceptor", "OCPInterceptor",
           "optimal_interception", "virtual_shark_plan", "allocate_operators", "interception_time_matrix",
           "RepellingOperator"]
