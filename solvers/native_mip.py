"""What the MIP backends driven through their own Python interface share (SCIP through pyscipopt,
Gurobi through gurobipy): the argument checks of a solve, the readout that turns a solver's
state into a truthful :class:`~droneplan.solvers.base.NativeReadout`, and the temporary-file
write of a model file.

The status rules, the same for both backends:

- OPTIMAL only when the solver says optimal *and* its dual bound meets the objective
  (``GAP_TOLERANCE``): a stop at a relative gap the caller allowed is FEASIBLE;
- a limit (time, nodes, gap, interrupt ...) with a solution is FEASIBLE, without one
  NO_SOLUTION; ``bound`` is the solver's dual bound in both cases (None when it is infinite);
- a code the adapter's ``status_map`` lacks is ERROR.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from droneplan.core.validation import check_time_limit
from droneplan.solvers.base import NativeReadout
from droneplan.solvers.result import Status

__all__ = ["GAP_TOLERANCE", "MipRun", "check_solve_settings", "mip_readout"]

GAP_TOLERANCE = 1e-6
"""Largest ``|bound - objective| / max(1, |objective|)`` at which a solve reported optimal counts as
proven (the solvers' own optimality tolerances are below it)."""


def check_solve_settings(
    time_limit: float | None, workers: int | None, options: Mapping[str, Any] | None
) -> tuple[float | None, dict[str, Any]]:
    """Check the settings of ``LinearModel.solve``; returns ``(relative_gap, backend options)``.

    time_limit: wall-clock limit in seconds or None. workers: threads, a positive int or None.
    options: backend parameters by the backend's own names, plus ``relative_gap`` (stop below
    this relative MIP gap, in [0, 1)), which is taken out. Each error names its parameter.
    """
    check_time_limit(time_limit)
    if workers is not None and (isinstance(workers, bool) or not isinstance(workers, int) or workers < 1):
        raise ValueError(f"workers must be a positive int, got {workers!r}")
    if options is not None and not isinstance(options, Mapping):
        raise TypeError(
            f"options must be a mapping of parameter names to values, got {type(options).__name__}"
        )
    opts = dict(options or {})
    relative_gap = opts.pop("relative_gap", None)
    if relative_gap is not None and (
        isinstance(relative_gap, bool)
        or not isinstance(relative_gap, (int, float))
        or not 0 <= relative_gap < 1
    ):
        raise ValueError(f"options['relative_gap'] must be a number in [0, 1), got {relative_gap!r}")
    return (None if relative_gap is None else float(relative_gap)), opts


@dataclass
class MipRun:
    """A finished native solve, as the readout needs it (read by the adapter from its solver)."""

    code_name: str
    """The solver's own status, as text."""
    solution_count: int
    """Solutions the solver holds (0: none)."""
    objective: Callable[[], float]
    """The incumbent's objective value (called only when there is one)."""
    values: Callable[[Sequence[Any]], np.ndarray]
    """The incumbent's values of the given variables (called only when there is one)."""
    dual_bound: float | None
    """The solver's dual bound (None or infinite: none)."""
    nodes: int | None
    """Branch-and-bound nodes."""


def _finite(value: float | None) -> float | None:
    if value is None:
        return None
    value = float(value)
    return value if math.isfinite(value) and abs(value) < 1e19 else None


def mip_readout(
    run: MipRun, status: Status, variables: Sequence[Any], name: str, hint_note: str = ""
) -> NativeReadout:
    """The result of a native MIP solve under the module's status rules.

    run: what the solver returned. status: the mapped status of ``run.code_name``.
    variables: the variables whose values form ``x``. name: the backend's registry name (for
    messages). hint_note: a note about the start solution for the message ("" for none).
    """
    notes = [hint_note] if hint_note else []
    if status is Status.NO_SOLUTION and run.solution_count > 0:
        status = Status.FEASIBLE
    objective = x = None
    if status.has_solution:
        if run.solution_count == 0:
            status = Status.ERROR
            notes.append(f"{name} reported {run.code_name} but holds no solution")
        else:
            objective = float(run.objective())
            x = np.asarray(run.values(variables), dtype=float)
    bound = _finite(run.dual_bound)
    if status is Status.OPTIMAL and (
        objective is None
        or bound is None
        or abs(bound - objective) > GAP_TOLERANCE * max(1.0, abs(objective))
    ):
        status = Status.FEASIBLE
        notes.append(
            f"{name} reported {run.code_name} with bound {bound} and objective {objective}: not proven"
        )
    if status is Status.NO_SOLUTION:
        notes.append(f"stopped at a limit ({run.code_name}) without a feasible solution")
    elif status is Status.FEASIBLE and run.code_name.lower() != "optimal":
        notes.append(f"stopped at a limit ({run.code_name}); the incumbent is not proven optimal")
    elif status is Status.ERROR and not notes:
        notes.append(f"{name} returned status {run.code_name}")
    return NativeReadout(
        objective=objective,
        bound=bound,
        x=x,
        iterations=run.nodes if status.has_solution else None,
        message="; ".join(notes),
        status=status,
    )
