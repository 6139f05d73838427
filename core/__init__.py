"""The base layer: helpers that know nothing of drones or solvers and that every layer may import.

``validation`` holds the shared argument checks, work budgets and seed helpers.
"""

__all__: list[str] = []
