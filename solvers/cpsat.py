"""Adapter for OR-Tools CP-SAT: native CP-SAT models ("cp") and the LinearModel builder ("linear")."""

from __future__ import annotations

import functools
import os
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from droneplan.core.validation import check_time_limit
from droneplan.solvers.base import BackendAdapter, CpBackend, LinearBackend, NativeReadout, run_native
from droneplan.solvers.linear import LinearModel
from droneplan.solvers.result import SolveResult, Status

if TYPE_CHECKING:
    from ortools.sat.python import cp_model

__all__ = ["BACKEND", "STATUS_MAP", "CpSatAdapter", "CpSatLinearModel", "solve_cpsat"]

BACKEND = "cp-sat"

# CP-SAT's native statuses (the CpSolverStatus codes of cp_model.proto, written as numbers so
# that this module loads without OR-Tools; a test holds them against cp_model's constants);
# FEASIBLE means a solution without a proof of optimality.
STATUS_MAP: dict[Any, Status] = {
    4: Status.OPTIMAL,  # cp_model.OPTIMAL
    2: Status.FEASIBLE,  # cp_model.FEASIBLE
    3: Status.INFEASIBLE,  # cp_model.INFEASIBLE
    0: Status.NO_SOLUTION,  # cp_model.UNKNOWN
    1: Status.ERROR,  # cp_model.MODEL_INVALID
}


def _check_workers(workers: int | None) -> None:
    if workers is not None and (isinstance(workers, bool) or not isinstance(workers, int) or workers < 1):
        raise ValueError(f"workers must be a positive int, got {workers!r}")


class CpSatAdapter(BackendAdapter, CpBackend, LinearBackend):
    """OR-Tools CP-SAT (a lazy clause generation CP/SAT solver with LP relaxations)."""

    name = BACKEND
    status_map = STATUS_MAP
    description = "OR-Tools CP-SAT: integer/Boolean models, proven bounds"
    requires = ("ortools",)

    def status_name(self, code: Any) -> str:
        from ortools.sat.python import cp_model

        try:
            return cp_model.CpSolver().status_name(code)
        except Exception:  # noqa: BLE001 - not a CP-SAT code: show it as it is
            return str(code)

    def new_model(self) -> CpSatLinearModel:
        return CpSatLinearModel()

    def solve_cp(  # noqa: C901
        self,
        model: cp_model.CpModel,
        *,
        variables: Sequence[Any] = (),
        time_limit: float | None = None,
        workers: int | None = None,
        hint: Mapping[Any, int] | None = None,
        verbose: bool = False,
        seed: int | None = None,
        parameters: Mapping[str, Any] | None = None,
        on_solution: Callable[[np.ndarray, float | None, float | None], Any] | None = None,
    ) -> SolveResult:
        """Solve a CP-SAT model.

        model: the model, as a builder left it (objective optional).
        variables: integer/Boolean variables whose solution values form ``x`` (in order).
        time_limit: wall-clock limit in seconds (None: no limit).
        workers: number of search workers (None: CP-SAT's default, all cores).
        hint: a starting assignment {variable: value}; handed to CP-SAT as solution hints.
        verbose: print CP-SAT's search log (default quiet).
        seed: CP-SAT's random seed.
        parameters: further CP-SAT parameters by their SatParameters field name, e.g.
            ``{"subsolvers": ["max_lp", "core"]}`` (a list sets a repeated field).
        on_solution: called as ``on_solution(x, objective, bound)`` with each solution CP-SAT
            finds (``x`` the int64 values of ``variables``; objective and bound None without an
            objective), from CP-SAT's solution callback while it runs.

        Returns a SolveResult: ``x`` is an int64 array of the values of ``variables``
        (None without a solution), ``objective`` the objective value and ``bound`` CP-SAT's
        best objective bound (both None for a model without objective or solution).
        """
        from ortools.sat.python import cp_model

        if not isinstance(model, cp_model.CpModel):
            raise TypeError(f"model must be a cp_model.CpModel, got {type(model).__name__}")
        check_time_limit(time_limit)
        _check_workers(workers)
        model.clear_hints()  # type: ignore[no-untyped-call]  # OR-Tools ships this method unannotated
        if hint:
            for var, value in hint.items():
                model.add_hint(var, int(value))
        solver = cp_model.CpSolver()
        params = solver.parameters
        if time_limit is not None:
            params.max_time_in_seconds = float(time_limit)
        if workers is not None:
            params.num_workers = workers
        if seed is not None:
            params.random_seed = int(seed)
        params.log_search_progress = bool(verbose)
        # CP-SAT's own Ctrl-C handler would swallow the signal (a study would record the cut-short
        # solve as finished) and reset SIGINT to SIG_DFL afterwards; leave Ctrl-C to Python.
        params.catch_sigint_signal = False
        for name, value in (parameters or {}).items():
            if not hasattr(params, name):
                raise ValueError(f"unknown CP-SAT parameter {name!r}")
            if isinstance(value, (list, tuple)):
                field = getattr(params, name)
                field.clear()
                field.extend(value)
            else:
                try:
                    setattr(params, name, value)
                except (TypeError, ValueError) as exc:
                    raise ValueError(f"CP-SAT parameter {name}={value!r}: {exc}") from exc

        def read(code: Any, _payload: Any, status: Status, _elapsed: float) -> NativeReadout:
            objective = bound = x = None
            if status.has_solution:
                x = np.array([solver.value(v) for v in variables], dtype=np.int64)
                if model.has_objective():
                    objective = float(solver.objective_value)
                    bound = float(solver.best_objective_bound)
            message = ""
            if status is Status.ERROR:
                message = f"CP-SAT: {self.status_name(code)}; model validation: {model.validate() or 'ok'}"
            elif status is Status.NO_SOLUTION:
                message = "CP-SAT stopped (time limit) before finding a solution"
            return NativeReadout(
                objective=objective,
                bound=bound,
                x=x,
                iterations=int(solver.num_branches),
                message=message,
                info={
                    "num_branches": int(solver.num_branches),
                    "num_conflicts": int(solver.num_conflicts),
                    "wall_time": float(solver.wall_time),
                },
            )

        callback = None
        if on_solution is not None:
            callback = _solution_callback_class()(variables, model.has_objective(), on_solution)
        hinted = bool(hint)
        result = run_native(self, lambda: (solver.solve(model, callback), None), read, warm_started=hinted)
        if callback is not None and callback.error is not None:
            raise callback.error
        return result


@functools.cache
def _solution_callback_class() -> Any:
    """CP-SAT's solution callback, subclassed once OR-Tools is imported (this module loads
    without it)."""
    from ortools.sat.python import cp_model

    class SolutionCallback(cp_model.CpSolverSolutionCallback):
        def __init__(self, variables: Sequence[Any], has_objective: bool, send: Callable[..., Any]):
            super().__init__()
            self._variables, self._has_objective, self._send = list(variables), has_objective, send
            self.error: BaseException | None = None

        def on_solution_callback(self) -> None:
            if self.error is not None:
                return
            x = np.array([self.value(v) for v in self._variables], dtype=np.int64)
            objective = float(self.objective_value) if self._has_objective else None
            bound = float(self.best_objective_bound) if self._has_objective else None
            try:
                self._send(x, objective, bound)
            except BaseException as exc:  # noqa: BLE001 - raised again once CP-SAT has stopped
                self.error = exc
                self.stop_search()

    return SolutionCallback


class CpSatLinearModel(LinearModel):
    """LinearModel on CP-SAT (Booleans and integers only; ``unit_var`` is Boolean)."""

    backend = BACKEND

    @property
    def takes_hint(self) -> bool:
        return True

    def __init__(self) -> None:
        from ortools.sat.python import cp_model

        self._model = cp_model.CpModel()

    @property
    def native(self) -> cp_model.CpModel:
        return self._model

    def bool_var(self, name: str = "") -> Any:
        return self._model.new_bool_var(name)

    def int_var(self, lb: int, ub: int, name: str = "") -> Any:
        return self._model.new_int_var(int(lb), int(ub), name)

    def unit_var(self, name: str = "") -> Any:
        return self._model.new_bool_var(name)

    def add(self, constraint: Any) -> None:
        self._model.add(constraint)

    def add_at_most_one(self, variables: Sequence[Any]) -> None:
        if len(variables) >= 2:
            self._model.add_at_most_one(variables)

    def add_exactly_one(self, variables: Sequence[Any]) -> None:
        self._model.add_exactly_one(variables)

    def add_implies_any(self, literal: Any, variables: Sequence[Any]) -> None:
        # a clause is much cheaper to build and presolve than the equivalent linear row
        self._model.add_bool_or([literal.Not(), *variables])

    def sum(self, terms: Any) -> Any:
        from ortools.sat.python import cp_model

        return cp_model.LinearExpr.sum(list(terms))

    def maximize(self, expr: Any) -> None:
        self._model.maximize(expr)

    def minimize(self, expr: Any) -> None:
        self._model.minimize(expr)

    def write(self, path: str | os.PathLike[str]) -> Path:
        """Write the model as an MPS or LP file (:func:`~droneplan.solvers.model_files.write_cp_model`)."""
        from droneplan.solvers.model_files import write_cp_model

        return write_cp_model(self._model, path)

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
        """Solve on CP-SAT; ``options`` are SatParameters fields and ``on_solution`` is called from
        CP-SAT's solution callback (see CpSatAdapter.solve_cp)."""
        int_hint = None if hint is None else {var: int(value) for var, value in hint.items()}
        return CpSatAdapter().solve_cp(
            self._model,
            variables=variables,
            time_limit=time_limit,
            workers=workers,
            hint=int_hint,
            verbose=verbose,
            parameters=options,
            on_solution=on_solution,
        )


def solve_cpsat(
    model: cp_model.CpModel,
    *,
    variables: Sequence[Any] = (),
    time_limit: float | None = None,
    workers: int | None = None,
    hint: Mapping[Any, int] | None = None,
    seed: int | None = None,
    log: bool = False,
    parameters: Mapping[str, Any] | None = None,
) -> SolveResult:
    """Solve a CP-SAT model (same as ``get_backend("cp-sat").solve_cp``; ``log`` = ``verbose``)."""
    return CpSatAdapter().solve_cp(
        model,
        variables=variables,
        time_limit=time_limit,
        workers=workers,
        hint=hint,
        verbose=log,
        seed=seed,
        parameters=parameters,
    )
