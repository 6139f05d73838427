"""Backend adapters under one result contract. Knows nothing of drones."""

from droneplan.solvers.result import SolveResult, Status, map_status

__all__ = ["SolveResult", "Status", "map_status"]
