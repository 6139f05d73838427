"""Thesis ch. 6 planners: steering-point allocation baselines, hull guidance and herders."""

from planners.herding.allocation import allocate_bruteforce, allocate_collision_blind, crosses

__all__ = ["allocate_bruteforce", "allocate_collision_blind", "crosses"]
