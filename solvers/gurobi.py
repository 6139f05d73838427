"""Adapter for Gurobi through gurobipy (the ``gurobi`` extra: ``pip install "droneplan[gurobi]"``),
registered as "gurobi".

The pip wheel of gurobipy carries a size-limited licence that needs no network (about 2,000
variables and 2,000 constraints); a larger model makes Gurobi refuse the solve, and the result is
an ERROR whose message holds Gurobi's own words ("Model too large for size-limited license"),
never a crash. A full licence, found by gurobipy in its usual places, lifts the limit.

Gurobi's MIP gap defaults to 1e-4; the adapter sets it to 0 unless the caller passes
``relative_gap``, so that OPTIMAL means proven (:mod:`~droneplan.solvers.native_mip` holds the
status rules: OPTIMAL only with the gap closed, a limit with a solution FEASIBLE with Gurobi's
dual bound).

gurobipy is imported inside the methods, so loading this module (and listing the backend)
imports nothing of Gurobi. One quiet environment per process serves every model (so the licence
banner is not printed).
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

__all__ = ["BACKEND", "STATUS_MAP", "STATUS_NAMES", "GurobiAdapter", "GurobiLinearModel"]

BACKEND = "gurobi"

# Gurobi's optimisation status codes (GRB.Status), written as numbers so that this module loads
# without gurobipy; a test holds them against GRB.Status. A limit maps to NO_SOLUTION, and to
# FEASIBLE when Gurobi holds a solution (native_mip.mip_readout); LOADED (1), NUMERIC (12),
# INPROGRESS (14) and any other code are ERROR.
STATUS_NAMES: dict[int, str] = {
    1: "LOADED",
    2: "OPTIMAL",
    3: "INFEASIBLE",
    4: "INF_OR_UNBD",
    5: "UNBOUNDED",
    6: "CUTOFF",
    7: "ITERATION_LIMIT",
    8: "NODE_LIMIT",
    9: "TIME_LIMIT",
    10: "SOLUTION_LIMIT",
    11: "INTERRUPTED",
    12: "NUMERIC",
    13: "SUBOPTIMAL",
    14: "INPROGRESS",
    15: "USER_OBJ_LIMIT",
    16: "WORK_LIMIT",
    17: "MEM_LIMIT",
    18: "LOCALLY_OPTIMAL",
    19: "LOCALLY_INFEASIBLE",
}
"""Gurobi's status code -> its name in ``GRB.Status``."""

STATUS_MAP: dict[Any, Status] = {
    2: Status.OPTIMAL,
    3: Status.INFEASIBLE,
    4: Status.UNBOUNDED,  # infeasible or unbounded: Gurobi cannot tell
    5: Status.UNBOUNDED,
    **dict.fromkeys((6, 7, 8, 9, 10, 11, 13, 15, 16, 17, 18, 19), Status.NO_SOLUTION),
}

_LICENCE_HINT = (
    "the pip wheel's size-limited licence covers about 2,000 variables and constraints; "
    "a full Gurobi licence lifts the limit"
)


@functools.cache
def _environment() -> Any:
    """One started, quiet gurobipy environment for the process (GurobiError when refused)."""
    import gurobipy as gp

    env = gp.Env(empty=True)
    env.setParam("OutputFlag", 0)
    env.start()
    return env


class GurobiAdapter(BackendAdapter, LinearBackend):
    """Gurobi (branch and cut) through gurobipy; takes a start solution (``Start`` values, partial
    allowed: Gurobi completes it when it can)."""

    name = BACKEND
    status_map = STATUS_MAP
    description = "Gurobi MILP through gurobipy (the pip wheel's licence is size-limited)"
    requires = ("gurobipy",)
    install_hint = 'pip install "droneplan[gurobi]"'

    def status_name(self, code: Any) -> str:
        return STATUS_NAMES.get(code, str(code)) if isinstance(code, int) else str(code)

    def is_available(self) -> bool:
        return self.requires_installed() and not self._start_error()

    def unavailable_reason(self) -> str:
        if not self.requires_installed():
            return super().unavailable_reason()
        error = self._start_error()
        return f"gurobipy could not start an environment (licence): {error}" if error else ""

    @staticmethod
    @functools.cache
    def _start_error() -> str:
        """Gurobi's refusal to start an environment, in one line ("" when it starts)."""
        import gurobipy as gp

        try:
            _environment()
        except gp.GurobiError as exc:
            return str(exc)
        return ""

    def new_model(self) -> GurobiLinearModel:
        return GurobiLinearModel(self)

    def read_model(self, path: str | os.PathLike[str]) -> GurobiLinearModel:
        """A model read from a model file.

        path: an existing ``.mps`` or ``.lp`` file (e.g. one written by ``LinearModel.write``).
        Its variables, in the file's order, are ``model.native.getVars()``.
        """
        import gurobipy as gp

        source = check_model_file(path)
        return GurobiLinearModel(self, gp.read(source, env=_environment()))


class GurobiLinearModel(LinearModel):
    """LinearModel on a gurobipy ``Model`` (``unit_var`` is continuous in [0, 1])."""

    def __init__(self, adapter: GurobiAdapter, native: Any = None) -> None:
        import gurobipy as gp

        self._adapter = adapter
        self.backend = adapter.name
        self._model = gp.Model(env=_environment()) if native is None else native
        self._started = False

    @property
    def takes_hint(self) -> bool:
        return True

    @property
    def native(self) -> Any:
        return self._model

    def _added(self, var: Any) -> Any:
        """``var`` once the model knows it (gurobipy hashes a variable only after an update, and
        formulations key their start solutions by variable)."""
        self._model.update()
        return var

    def bool_var(self, name: str = "") -> Any:
        from gurobipy import GRB

        return self._added(self._model.addVar(vtype=GRB.BINARY, name=name))

    def int_var(self, lb: int, ub: int, name: str = "") -> Any:
        from gurobipy import GRB

        return self._added(self._model.addVar(lb=int(lb), ub=int(ub), vtype=GRB.INTEGER, name=name))

    def unit_var(self, name: str = "") -> Any:
        from gurobipy import GRB

        return self._added(self._model.addVar(lb=0.0, ub=1.0, vtype=GRB.CONTINUOUS, name=name))

    def add(self, constraint: Any) -> None:
        """Add ``lhs <= rhs``, ``lhs >= rhs`` or ``lhs == rhs``; a comparison that Python already
        decided (a bool: both sides numbers) adds nothing when True and an infeasible row when False."""
        if isinstance(constraint, (bool, np.bool_)):
            if not constraint:
                never = self._model.addVar(lb=0.0, ub=0.0, name="never")
                self._model.addConstr(never >= 1)
            return
        self._model.addConstr(constraint)

    def sum(self, terms: Any) -> Any:
        import gurobipy as gp

        return gp.quicksum(terms)

    def maximize(self, expr: Any) -> None:
        from gurobipy import GRB

        self._model.setObjective(expr, GRB.MAXIMIZE)

    def minimize(self, expr: Any) -> None:
        from gurobipy import GRB

        self._model.setObjective(expr, GRB.MINIMIZE)

    def write(self, path: str | os.PathLike[str]) -> Path:
        """Write the model with Gurobi's own writers: ``.mps`` or ``.lp``."""
        self._model.update()
        return write_through_temp(path, self._model.write)

    def _hand_over(self, hint: Mapping[Any, float] | None) -> bool:
        """Set ``hint`` as Gurobi's start values, clearing those of an earlier solve; True when
        a start was set."""
        from gurobipy import GRB

        model = self._model
        if self._started:
            model.update()
            model.setAttr("Start", model.getVars(), [GRB.UNDEFINED] * model.NumVars)
            self._started = False
        if not hint:
            return False
        model.setAttr("Start", list(hint), [float(v) for v in hint.values()])
        self._started = True
        return True

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
        """Solve on Gurobi (see ``LinearModel.solve``). ``options`` are Gurobi parameters by name
        (e.g. ``{"Presolve": 0}``) plus ``relative_gap`` (default 0: solved to a closed gap);
        ``workers`` sets ``Threads`` (None: Gurobi's default); ``time_limit`` is in seconds;
        ``on_solution`` gets the final solution once. A model beyond the licence's size gives an
        ERROR result whose message says so."""
        from gurobipy import GRB

        relative_gap, params = check_solve_settings(time_limit, workers, options)
        model = self._model
        model.Params.OutputFlag = int(bool(verbose))
        model.Params.TimeLimit = GRB.INFINITY if time_limit is None else float(time_limit)
        model.Params.Threads = 0 if workers is None else workers
        model.Params.MIPGap = 0.0 if relative_gap is None else relative_gap
        for key, value in params.items():
            try:
                model.setParam(key, value)
            except Exception as exc:  # gurobipy raises several types for a bad parameter
                raise ValueError(f"options: Gurobi parameter {key}={value!r} refused: {exc}") from exc
        handed = self._hand_over(hint)
        name = self.backend

        def call() -> tuple[int, None]:
            model.optimize()
            return int(model.Status), None

        def read(code: Any, _payload: Any, status: Status, _elapsed: float) -> NativeReadout:
            run = MipRun(
                code_name=self._adapter.status_name(code),
                solution_count=int(model.SolCount),
                objective=lambda: float(model.ObjVal),
                values=lambda vs: np.array(model.getAttr("X", list(vs)) if len(vs) else [], dtype=float),
                dual_bound=_dual_bound(model),
                nodes=int(model.NodeCount) if model.IsMIP else None,
            )
            return mip_readout(run, status, variables, name)

        result = run_native(self._adapter, call, read, warm_started=handed)
        if result.status is Status.ERROR and "size-limited" in result.message:
            result = _with_note(result, _LICENCE_HINT)
        if on_solution is not None and result.has_solution:
            on_solution(np.asarray(result.x), result.objective, result.bound)
        return result


def _dual_bound(model: Any) -> float | None:
    """Gurobi's dual bound (``ObjBound``); None when Gurobi has none (infeasible, no LP solved)."""
    import gurobipy as gp

    try:
        return float(model.ObjBound)
    except (gp.GurobiError, AttributeError):
        return None


def _with_note(result: SolveResult, note: str) -> SolveResult:
    """``result`` with ``note`` added to its message."""
    import dataclasses

    return dataclasses.replace(result, message=f"{result.message}; {note}")
