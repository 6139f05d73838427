"""The result contract shared by every solver adapter and every static planner.

Every ``solve_*`` function of ``formulations`` and every heuristic that returns a
static plan returns a :class:`SolveResult`. Adapters map their backend's native
status codes to :class:`Status` through an explicit dictionary; a code missing
from that dictionary maps to ``Status.ERROR`` (see :func:`map_status`).
"""

from __future__ import annotations

import enum
import math
from collections.abc import Hashable, Mapping
from dataclasses import dataclass, field
from typing import Any

__all__ = ["Status", "map_status", "SolveResult"]


class Status(enum.Enum):
    """Outcome of a solve, independent of the backend."""

    OPTIMAL = "optimal"
    """A solution proven optimal (within the backend's tolerance): never a local NLP or SQP optimum."""
    FEASIBLE = "feasible"
    """A solution whose optimality is not proven (time limit, heuristic, local NLP or SQP stop);
    a local method's converged KKT point has ``info["local_optimum"]`` True."""
    INFEASIBLE = "infeasible"
    """Proven infeasible."""
    UNBOUNDED = "unbounded"
    """Proven unbounded (or infeasible-or-unbounded where the backend cannot tell)."""
    NO_SOLUTION = "no_solution"
    """A limit was reached before any solution was found."""
    ERROR = "error"
    """The backend failed, or returned a code this adapter does not know."""

    @property
    def has_solution(self) -> bool:
        """True for OPTIMAL and FEASIBLE: ``x`` and ``objective`` are meaningful."""
        return self in (Status.OPTIMAL, Status.FEASIBLE)


def map_status(code: Hashable, table: Mapping[Hashable, Status]) -> Status:
    """Translate a native status ``code`` through ``table``; unknown codes give ERROR."""
    return table.get(code, Status.ERROR)


@dataclass(frozen=True)
class SolveResult:
    """What a solve or a static planner returns.

    ``objective`` and ``bound`` are in the problem's own units (covered users,
    seconds, metres ...). For a maximisation a valid ``bound`` satisfies
    ``objective <= bound``; for a minimisation ``objective >= bound``.
    """

    status: Status
    """Backend-independent outcome."""
    objective: float | None = None
    """Objective value of ``x``; None when there is no solution."""
    bound: float | None = None
    """Best proven bound on the optimum; None for heuristics and local NLP solves."""
    x: Any = None
    """The problem's own solution object (positions, allocation, trajectory, vector)."""
    backend: str = ""
    """Name of the backend or method that produced the result."""
    backend_status: str = ""
    """The backend's raw status code or string."""
    message: str = ""
    """Human-readable detail: what the bound is valid for, why a solve failed."""
    solve_time: float = 0.0
    """Wall-clock time of the solve in seconds."""
    iterations: int | None = None
    """Iterations (IPOPT/OSQP), branch-and-bound nodes or generations, if known."""
    warm_started: bool = False
    """True when a supplied warm start was actually handed to the backend."""
    info: Mapping[str, Any] = field(default_factory=dict)
    """Extra per-method data (duals, seed used, per-restart bests ...)."""

    def __post_init__(self) -> None:
        if not isinstance(self.status, Status):
            raise TypeError(f"status must be a Status, got {type(self.status).__name__}")
        if self.solve_time < 0:
            raise ValueError(f"solve_time must be >= 0, got {self.solve_time}")

    @property
    def has_solution(self) -> bool:
        """True when ``x`` and ``objective`` hold a solution (OPTIMAL or FEASIBLE)."""
        return self.status.has_solution

    @property
    def converged(self) -> bool:
        """True when the solve stopped at an optimum: proven (OPTIMAL), or local (FEASIBLE with
        ``info["local_optimum"]`` True: a local NLP or SQP method reached a KKT point)."""
        if self.status is Status.OPTIMAL:
            return True
        return self.status is Status.FEASIBLE and bool(self.info.get("local_optimum", False))

    @property
    def gap(self) -> float | None:
        """Relative optimality gap ``|bound - objective| / max(|objective|, 1e-9)``.

        None when either value is missing; 0 when both are equal (also both zero).
        """
        if self.objective is None or self.bound is None:
            return None
        if not (math.isfinite(self.objective) and math.isfinite(self.bound)):
            return math.inf
        diff = abs(self.bound - self.objective)
        if diff == 0.0:
            return 0.0
        return diff / max(abs(self.objective), 1e-9)
