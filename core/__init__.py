"""The base layer: helpers that know nothing of drones or solvers and that every layer may import.

``validation`` holds the shared argument checks, work budgets and seed helpers; ``files`` reads
the JSON files users hand to droneplan (gzip expansion capped, one-line errors).
"""

__all__: list[str] = []
