"""Pywraplp models by backend name: :func:`new_mip` gives an empty model of a registered
pywraplp backend (HiGHS, SCIP ...), :func:`solve_mip` solves it through that backend's adapter.

This module sits above the registry (it looks backends up by name); the adapters in
:mod:`~droneplan.solvers.mip` sit below it.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any

from droneplan.solvers.mip import PywraplpAdapter
from droneplan.solvers.registry import available_backends, get_backend
from droneplan.solvers.result import SolveResult

if TYPE_CHECKING:
    from ortools.linear_solver import pywraplp

__all__ = ["new_mip", "solve_mip"]


def new_mip(backend: str = "highs") -> pywraplp.Solver:
    """An empty pywraplp model for ``backend`` (a registered pywraplp backend: "highs", "scip")."""
    mip = [n for n in available_backends("linear") if isinstance(get_backend(n), PywraplpAdapter)]
    if not isinstance(backend, str) or backend.lower() not in mip:
        raise ValueError(f"unknown MIP backend {backend!r}; choose from {mip}")
    adapter = get_backend(backend, kind="linear")
    return adapter.new_native()


def solve_mip(
    solver: pywraplp.Solver,
    *,
    variables: Sequence[Any] = (),
    time_limit: float | None = None,
    warm_start: Mapping[Any, float] | None = None,
    threads: int | None = None,
    relative_gap: float | None = None,
    verbose: bool = False,
) -> SolveResult:
    """Solve a model built in a :func:`new_mip` container.

    variables: variables whose solution values form ``x`` (float array, in order).
    time_limit: wall-clock limit in seconds (None: no limit).
    warm_start: a start solution {variable: value}; passed to backends that accept one
        (SCIP); ``warm_started`` says whether it was used.
    threads: solver threads (None: backend default).
    relative_gap: stop when the relative MIP gap is below this (None: backend default).
    verbose: let the solver print its log (default quiet).

    ``objective`` is the model's objective, ``bound`` the backend's best bound (the
    objective itself for a pure LP solved to optimality).
    """
    from ortools.linear_solver import pywraplp

    if not isinstance(solver, pywraplp.Solver):
        raise TypeError(f"solver must be a pywraplp.Solver from new_mip, got {type(solver).__name__}")
    name = getattr(solver, "_droneplan_backend", None)
    if name is None:
        raise ValueError("solve_mip needs a model created by new_mip(backend)")
    adapter: PywraplpAdapter = get_backend(name, kind="linear")
    return adapter.solve_native(
        solver,
        variables=variables,
        time_limit=time_limit,
        warm_start=warm_start,
        threads=threads,
        relative_gap=relative_gap,
        verbose=verbose,
    )
