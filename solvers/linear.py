"""One builder interface for linear 0-1/integer models, implemented per backend.

A formulation writes its model once against :class:`LinearModel` and runs it on
any backend of kind "linear" (CP-SAT, HiGHS, SCIP, ...)::

    lin = get_backend(backend, kind="linear").new_model()
    x = [lin.bool_var(f"x{i}") for i in range(n)]
    y = lin.unit_var("y")  # 0-1, integrality not needed by the model
    lin.add(y <= lin.sum(x))  # constraints are built with <=, >=, ==
    lin.add_at_most_one(x[:3])
    lin.maximize(y)
    res = lin.solve(variables=x, time_limit=10, workers=1, hint={x[0]: 1})

Variables and expressions are the backend's own objects (so ``+``, ``*`` by a
number and comparisons work as in that library); only the calls on the model go
through this interface. Coefficients must be integers for CP-SAT.
"""

from __future__ import annotations

import abc
import os
from collections.abc import Callable, Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from droneplan.solvers.result import SolveResult

__all__ = ["LinearModel"]


class LinearModel(abc.ABC):
    """A linear model under construction for one backend (made by ``LinearBackend.new_model``)."""

    backend: str
    """Registry name of the backend that will solve it."""

    @property
    def takes_hint(self) -> bool:
        """True when ``solve(hint=...)`` hands the start solution to the backend."""
        return False

    @property
    @abc.abstractmethod
    def native(self) -> Any:
        """The backend's own model object, for backend-specific extras."""

    @abc.abstractmethod
    def bool_var(self, name: str = "") -> Any:
        """A new 0-1 integer variable."""

    @abc.abstractmethod
    def int_var(self, lb: int, ub: int, name: str = "") -> Any:
        """A new integer variable in [lb, ub]."""

    @abc.abstractmethod
    def unit_var(self, name: str = "") -> Any:
        """A new variable in [0, 1] whose integrality the model does not need (an optimum
        exists with it at 0 or 1, e.g. a coverage indicator bounded by a sum of Booleans).

        Continuous for MIP backends (fewer integers to branch on); Boolean for backends
        without continuous variables (CP-SAT)."""

    @abc.abstractmethod
    def add(self, constraint: Any) -> None:
        """Add a linear constraint written as ``lhs <= rhs``, ``lhs >= rhs`` or ``lhs == rhs``."""

    def add_at_most_one(self, variables: Sequence[Any]) -> None:
        """At most one of the Boolean ``variables`` is 1 (nothing is added for fewer than two)."""
        if len(variables) >= 2:
            self.add(self.sum(variables) <= 1)

    def add_implies_any(self, literal: Any, variables: Sequence[Any]) -> None:
        """``literal <= sum(variables)`` for Booleans: ``literal`` = 1 needs one of ``variables``
        at 1 (``literal`` = 0 when ``variables`` is empty)."""
        self.add(literal <= self.sum(variables))

    def add_exactly_one(self, variables: Sequence[Any]) -> None:
        """Exactly one of the Boolean ``variables`` is 1."""
        self.add(self.sum(variables) == 1)

    def sum(self, terms: Iterable[Any]) -> Any:
        """The sum of ``terms`` as a backend expression (0 for no terms)."""
        return sum(terms)

    @abc.abstractmethod
    def maximize(self, expr: Any) -> None:
        """Set the objective to maximise ``expr``."""

    @abc.abstractmethod
    def minimize(self, expr: Any) -> None:
        """Set the objective to minimise ``expr``."""

    @abc.abstractmethod
    def write(self, path: str | os.PathLike[str]) -> Path:
        """Write the model as it stands to ``path`` (``.mps``: free MPS; ``.lp``: CPLEX LP),
        through a temporary file renamed into place; returns the path."""

    @abc.abstractmethod
    def solve(
        self,
        *,
        variables: Sequence[Any] = (),
        time_limit: float | None = None,
        workers: int | None = None,
        hint: Mapping[Any, float] | None = None,
        verbose: bool = False,
        options: Mapping[str, Any] | None = None,
        on_solution: Callable[[np.ndarray, float | None, float | None], Any] | None = None,
    ) -> SolveResult:
        """Solve the model.

        variables: variables whose values form ``x`` (in order).
        time_limit: wall-clock limit in seconds (None: none).
        workers: solver threads / search workers (None: backend default).
        hint: a start solution {variable: value}; used when ``takes_hint``, and the result's
            ``warm_started`` says whether it was.
        verbose: let the backend print its log (default quiet).
        options: backend-specific parameters by the backend's own names.
        on_solution: called as ``on_solution(x, objective, bound)`` with each improving solution
            (``x`` the values of ``variables``) while the backend runs, where it reports them
            (CP-SAT); a backend that cannot calls it once, with the final solution. Its
            exceptions propagate.

        Returns a SolveResult with ``objective``, the backend's proven ``bound`` and ``x``.
        """
