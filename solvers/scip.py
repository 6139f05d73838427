"""Adapter for SCIP through its own Python interface, pyscipopt (the ``scip`` extra:
``pip install "droneplan[scip]"``), registered as "pyscipopt".

The backend "scip" reaches the same solver through OR-Tools' pywraplp (:mod:`~droneplan.solvers.mip`)
and needs nothing beyond OR-Tools; this one talks to SCIP directly: its own status codes, its
dual bound, its partial start solutions, its model-file reader and writer. The status rules are
those of :mod:`~droneplan.solvers.native_mip` (OPTIMAL only with the gap closed).

pyscipopt is imported inside the methods, so loading this module (and listing the backend)
imports nothing of SCIP.
"""

from __future__ import annotations

import functools
import os
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from droneplan.solvers.base import BackendAdapter, LinearBackend, NativeReadout, run_native
from droneplan.solvers.linear import LinearModel
from droneplan.solvers.model_files import check_model_file, write_through_temp
from droneplan.solvers.native_mip import MipRun, check_solve_settings, mip_readout
from droneplan.solvers.result import SolveResult, Status

__all__ = ["BACKEND", "STATUS_MAP", "PyScipOptAdapter", "ScipLinearModel"]

BACKEND = "pyscipopt"

# SCIP's statuses as pyscipopt's Model.getStatus() names them; "unknown" and any other name are ERROR.
# A limit maps to NO_SOLUTION, and to FEASIBLE when SCIP holds a solution (native_mip.mip_readout).
STATUS_MAP: dict[Any, Status] = {
    "optimal": Status.OPTIMAL,
    "infeasible": Status.INFEASIBLE,
    "unbounded": Status.UNBOUNDED,
    "inforunbd": Status.UNBOUNDED,
    **dict.fromkeys(
        (
            "timelimit",
            "nodelimit",
            "totalnodelimit",
            "stallnodelimit",
            "gaplimit",
            "memlimit",
            "sollimit",
            "bestsollimit",
            "restartlimit",
            "primallimit",
            "duallimit",
            "userinterrupt",
            "terminate",
        ),
        Status.NO_SOLUTION,
    ),
}

_NO_TIME_LIMIT = 1e20  # SCIP's infinity for limits/time


@functools.cache
def _variable_class() -> type:
    """The variables the model hands out: a pyscipopt expression of one variable that can key a
    dict (pyscipopt's own ``Variable`` cannot: it compares into constraints and has no hash, and
    formulations key their start solutions by variable). Arithmetic and comparisons are
    pyscipopt's own; ``.var`` is the SCIP variable. Made once pyscipopt is imported (this module
    loads without it)."""
    from pyscipopt import Expr
    from pyscipopt.scip import Term

    class ScipVariable(Expr):
        __hash__ = object.__hash__

        def __init__(self, var: Any) -> None:
            super().__init__({Term(var): 1.0})
            self.var = var

        def __repr__(self) -> str:
            return f"ScipVariable({self.var.name})"

    return ScipVariable


class PyScipOptAdapter(BackendAdapter, LinearBackend):
    """SCIP (branch and cut) through pyscipopt. ``workers`` is checked and otherwise unused: SCIP's
    branch and cut runs on one thread. Takes a start solution, handed over as a partial solution
    that SCIP completes when it can."""

    name = BACKEND
    status_map = STATUS_MAP
    description = "SCIP MILP through its own Python interface (pyscipopt)"
    requires = ("pyscipopt",)
    install_hint = 'pip install "droneplan[scip]"'

    def new_model(self) -> ScipLinearModel:
        return ScipLinearModel(self)

    def read_model(self, path: str | os.PathLike[str]) -> ScipLinearModel:
        """A model read from a model file.

        path: an existing ``.mps`` or ``.lp`` file (e.g. one written by ``LinearModel.write``).
        Its variables, in the file's order, are ``model.native.getVars()``.
        """
        source = check_model_file(path)
        lin = ScipLinearModel(self)
        lin.native.readProblem(source)
        return lin


class ScipLinearModel(LinearModel):
    """LinearModel on a pyscipopt ``Model`` (``unit_var`` is continuous in [0, 1]). Its variables are
    pyscipopt expressions of one variable that can key a dict (``.var`` is the SCIP variable).
    The model may be changed and solved again after a solve (SCIP's solving data is freed first)."""

    def __init__(self, adapter: PyScipOptAdapter) -> None:
        from pyscipopt import Model

        self._adapter = adapter
        self.backend = adapter.name
        self._model = Model()
        self._model.hideOutput()
        self._solved = False

    @property
    def takes_hint(self) -> bool:
        return True

    @property
    def native(self) -> Any:
        return self._model

    def _editable(self) -> Any:
        """The model, its solving data freed if it was solved (SCIP changes only the original)."""
        if self._solved:
            self._model.freeTransform()
            self._solved = False
        return self._model

    def bool_var(self, name: str = "") -> Any:
        return _variable_class()(self._editable().addVar(name, vtype="B"))

    def int_var(self, lb: int, ub: int, name: str = "") -> Any:
        return _variable_class()(self._editable().addVar(name, vtype="I", lb=int(lb), ub=int(ub)))

    def unit_var(self, name: str = "") -> Any:
        return _variable_class()(self._editable().addVar(name, vtype="C", lb=0.0, ub=1.0))

    def add(self, constraint: Any) -> None:
        """Add ``lhs <= rhs``, ``lhs >= rhs`` or ``lhs == rhs``; a comparison that Python already
        decided (a bool: both sides numbers) adds nothing when True and an infeasible row when False."""
        model = self._editable()
        if isinstance(constraint, (bool, np.bool_)):
            if not constraint:
                never = model.addVar("never", vtype="C", lb=0.0, ub=0.0)
                model.addCons(never >= 1)
            return
        model.addCons(constraint)

    def sum(self, terms: Any) -> Any:
        from pyscipopt import quicksum

        return quicksum(terms)

    def maximize(self, expr: Any) -> None:
        self._editable().setObjective(expr, sense="maximize")

    def minimize(self, expr: Any) -> None:
        self._editable().setObjective(expr, sense="minimize")

    def write(self, path: str | os.PathLike[str]) -> Path:
        """Write the model (as built, not presolved) with SCIP's own writers: ``.mps`` or ``.lp``."""
        return write_through_temp(path, lambda tmp: self._model.writeProblem(tmp, trans=False, verbose=False))

    def _hand_over(self, hint: Mapping[Any, float]) -> bool:
        """Give SCIP ``hint`` as a partial solution; True when SCIP stored it."""
        model = self._model
        sol = model.createPartialSol()
        for var, value in hint.items():
            model.setSolVal(sol, getattr(var, "var", var), float(value))
        return bool(model.addSol(sol, free=True))

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
        """Solve on SCIP (see ``LinearModel.solve``). ``options`` are SCIP parameters by name (e.g.
        ``{"presolving/maxrounds": 0}``) plus ``relative_gap``; ``workers`` is checked and unused
        (one thread); ``on_solution`` gets the final solution once. ``time_limit`` is in seconds."""
        relative_gap, params = check_solve_settings(time_limit, workers, options)
        model = self._editable()
        model.hideOutput(quiet=not verbose)
        model.setParam("limits/time", _NO_TIME_LIMIT if time_limit is None else max(float(time_limit), 1e-3))
        model.setParam("limits/gap", 0.0 if relative_gap is None else relative_gap)
        for key, value in params.items():
            try:
                model.setParam(key, value)
            except Exception as exc:  # pyscipopt raises several types for a bad parameter
                raise ValueError(f"options: SCIP parameter {key}={value!r} refused: {exc}") from exc
        handed = self._hand_over(hint) if hint else False
        name = self.backend

        def call() -> tuple[str, None]:
            self._solved = True
            model.optimize()
            return str(model.getStatus()), None

        def read(code: Any, _payload: Any, status: Status, _elapsed: float) -> NativeReadout:
            count = int(model.getNSols())
            best = model.getBestSol() if count else None
            run = MipRun(
                code_name=str(code),
                solution_count=count,
                objective=model.getObjVal,
                values=lambda vs: np.array([model.getSolVal(best, v) for v in vs], dtype=float),
                dual_bound=float(model.getDualbound()),
                nodes=int(model.getNNodes()),
            )
            note = "start solution refused by SCIP" if hint and not handed else ""
            return mip_readout(run, status, variables, name, note)

        result = run_native(self._adapter, call, read, warm_started=handed)
        if on_solution is not None and result.has_solution:
            on_solution(np.asarray(result.x), result.objective, result.bound)
        return result
