"""Shark interception models (thesis ch. 5): exact optimal altitude, time-optimal interception OCP, assignment."""

from formulations.shark.altitude import optimal_altitude

__all__ = ["optimal_altitude"]
