"""A safe upper bound of a maximisation MILP from the duals of its LP relaxation, and the
bound with any one binary variable set to 1 (for reduced-cost fixing).

Weak duality with a box, written so that it needs nothing from the LP solver to be valid:
for the model ``max c x`` subject to ``lo_r <= A x <= up_r`` and ``l <= x <= u`` (every
bound of x finite), take *any* row multipliers y and d = c - A^T y. Every x of the box
with A x in the row range satisfies

    c x = y (A x) + d x <= sum_r (y_r up_r if y_r > 0 else y_r lo_r) + sum_j max(d_j l_j, d_j u_j) = B(y),

(a multiplier whose side of the row is infinite is set to 0 first). So B(y) bounds the LP
relaxation and hence every integer point, whether or not y is optimal or even feasible for
the dual: the LP solver (HiGHS's simplex) only makes it tight. With x_j fixed to 1 (a
binary, l_j = 0, u_j = 1), the j-th term is d_j instead of max(0, d_j), so every point with
x_j = 1 is bounded by B(y) + min(d_j, 0). The sums are taken in float64; ``margin`` adds
1e-9 times the sum of the absolute values of every product involved, plus 1e-7, which is
more than their rounding error.
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from ortools.linear_solver import pywraplp

from droneplan.core.validation import check_time_limit

__all__ = ["LP_METHODS", "LpBound", "lp_dual_bound"]


@dataclass(frozen=True)
class LpBound:
    """The result of :func:`lp_dual_bound`."""

    bound: float
    """B(y) + margin: every feasible point's objective is at most this (objective units)."""
    at_one: np.ndarray
    """Per requested variable: the bound on every feasible point where that variable is 1."""
    status: str
    """HiGHS's model status of the LP solve (the bound is valid whatever it is)."""
    lp_value: float | None
    """The LP optimum HiGHS reports (None without one); ``bound`` is its safe counterpart."""
    time: float
    """Wall-clock seconds of the LP solve and the bound."""
    method: str = "simplex"
    """The LP algorithm(s) whose duals gave the bound: "simplex", "ipm", or "simplex, then ipm"
    (``lp_dual_bound(ipm_after=)``)."""


LP_METHODS = ("simplex", "ipm")
"""LP algorithms of :func:`lp_dual_bound`: HiGHS's dual simplex, or its interior point method
(IPX) followed by crossover to a basic solution."""


def lp_dual_bound(
    solver: pywraplp.Solver,
    variables: Sequence[Any],
    *,
    time_limit: float | None = None,
    method: str = "simplex",
    ipm_after: float | None = None,
) -> LpBound:
    """A safe upper bound of the maximisation model ``solver`` (module docstring) from the
    row duals of its LP relaxation, solved by HiGHS (highspy), and the bound with each of
    ``variables`` set to 1.

    solver: a pywraplp model with a maximised linear objective and every variable bounded.
    variables: binary variables of ``solver`` (0/1 bounds) whose fixed-to-1 bound is wanted.
    time_limit: seconds for the LP solve (None: none); at the limit the duals reached so far
        still give a valid, weaker bound.
    method: "simplex" (default) or "ipm" (``LP_METHODS``). The bound is valid either way (it
        needs nothing from the solver); IPM with crossover solved the lifted hop LP of Table
        4.2 m = 6 seed 1 (1.5 M terms) in 47 s, where the simplex had not in 300 s, but its
        duals fixed fewer sites on m = 6 seed 5 (768 against 2 007, same LP value 88.90).
    ipm_after: None (default), or seconds > 0, with ``method="simplex"``: when the simplex has
        not ended after this long, IPM solves the LP again in the rest of ``time_limit``, and
        the bounds of the two solves are combined (each the smaller; both are valid). A
        stopped simplex leaves duals that bound almost nothing, while IPM can be far faster on
        a degenerate LP (the simplex's own duals, where it ends in time, fixed more sites).
    """
    from droneplan.solvers.mip import _highs_model

    time_limit, ipm_after = _checked_settings(solver, time_limit, method, ipm_after)
    t0 = time.perf_counter()
    highs = _highs_model(solver)
    lp = highs.getLp()
    cols = np.array([v.index() for v in variables], dtype=np.int64)
    col_lo, col_up = np.asarray(lp.col_lower_, dtype=float), np.asarray(lp.col_upper_, dtype=float)
    if not (np.isfinite(col_lo).all() and np.isfinite(col_up).all()):
        raise ValueError("solver must bound every variable (the dual bound uses the box)")
    if len(cols) and (np.any(col_lo[cols] != 0) or np.any(col_up[cols] != 1)):
        raise ValueError("variables must be 0/1 variables of solver")
    lp.integrality_ = []

    def left() -> float | None:
        return None if time_limit is None else max(time_limit - (time.perf_counter() - t0), 1e-3)

    first = left() if ipm_after is None else min(ipm_after, left() or math.inf)
    status, value, bound, at_one = _solve_and_bound(highs, lp, cols, method, first, presolve=True)
    used = method
    if ipm_after is not None and status != "Optimal" and (left() or math.inf) > IPM_MIN_SECONDS:
        status, value, ipm_bound, ipm_at_one = _solve_and_bound(highs, lp, cols, "ipm", left(), presolve=True)
        bound, at_one, used = min(bound, ipm_bound), np.minimum(at_one, ipm_at_one), "simplex, then ipm"
        method = "ipm"
    if status == "Optimal" and value is not None and _swamped(bound, value):
        # HiGHS's postsolve can return huge, nearly cancelling duals (|y| ~ 6e9 on a degenerate
        # LP); they stay valid but their rounding margin swamps the bound. Solved again without
        # presolve, and each bound is the smaller of the two (both are valid).
        retry = _solve_and_bound(highs, lp, cols, method, left(), presolve=False)
        bound, at_one = min(bound, retry[2]), np.minimum(at_one, retry[3])
    return LpBound(
        bound=bound, at_one=at_one, status=status, lp_value=value, time=time.perf_counter() - t0, method=used
    )


IPM_MIN_SECONDS = 0.05
"""``lp_dual_bound(ipm_after=)`` starts IPM only with more than this many seconds left."""


def _checked_settings(
    solver: Any, time_limit: Any, method: Any, ipm_after: Any
) -> tuple[float | None, float | None]:
    """Check :func:`lp_dual_bound`'s model and settings by name; returns (time_limit, ipm_after)."""
    if method not in LP_METHODS:
        raise ValueError(f"method must be one of {LP_METHODS}, got {method!r}")
    time_limit = check_time_limit(time_limit)
    if ipm_after is not None:
        ipm_after = check_time_limit(ipm_after, "ipm_after")
        if method != "simplex":
            raise ValueError(f"ipm_after needs method='simplex', got method={method!r}")
    if not isinstance(solver, pywraplp.Solver):
        raise TypeError(f"solver must be a pywraplp.Solver, got {type(solver).__name__}")
    if not solver.Objective().maximization():
        raise ValueError("solver must maximise its objective (lp_dual_bound bounds from above)")
    return time_limit, ipm_after


PRESOLVE_RETRY_GAP = 1e-4
""":func:`lp_dual_bound` solves the LP again without HiGHS's presolve when its bound exceeds the
reported LP optimum by more than this share of it (at least 1 objective unit times this). Table
4.2 m = 6 seed 18, the LP fixing's model: LP optimum 109 (the incumbent), bound 2,527.5 with
presolve (duals up to 5.8e9), 109.0001 without (duals up to 67), which proves the incumbent."""


def _swamped(bound: float, value: float) -> bool:
    """True when the dual bound exceeds the reported LP optimum by more than
    ``PRESOLVE_RETRY_GAP`` of it (at least of 1 objective unit)."""
    return bound - value > PRESOLVE_RETRY_GAP * max(1.0, abs(value))


def _solve_and_bound(
    highs: Any, lp: Any, cols: np.ndarray, method: str, time_limit: float | None, *, presolve: bool
) -> tuple[str, float | None, float, np.ndarray]:
    """Solve the LP ``lp`` on ``highs`` and return (status, LP value or None, B(y) + margin, the
    bounds with each column of ``cols`` at 1), from the duals it returns (module docstring)."""
    import highspy  # type: ignore[import-untyped]
    import scipy.sparse as sp

    highs.passModel(lp)
    highs.setOptionValue("presolve", "on" if presolve else "off")
    if method == "ipm":  # crossover on: without it HiGHS returned no usable duals (tried)
        highs.setOptionValue("solver", "ipm")
        highs.setOptionValue("run_crossover", "on")
    if time_limit is not None:
        highs.setOptionValue("time_limit", time_limit)
    highs.run()
    status = highs.modelStatusToString(highs.getModelStatus())
    value = highs.getInfo().objective_function_value if status == "Optimal" else None
    y = np.asarray(highs.getSolution().row_dual, dtype=float)
    col_lo, col_up = np.asarray(lp.col_lower_, dtype=float), np.asarray(lp.col_upper_, dtype=float)
    row_lo, row_up = np.asarray(lp.row_lower_, dtype=float), np.asarray(lp.row_upper_, dtype=float)
    if len(y) != len(row_lo) or not np.isfinite(y).all():
        y = np.zeros(len(row_lo))  # no duals: B(0) is the box bound of the objective, still valid
    y = np.where(((y > 0) & ~np.isfinite(row_up)) | ((y < 0) & ~np.isfinite(row_lo)), 0.0, y)
    mat = highs.getLp().a_matrix_
    kind = sp.csr_matrix if mat.format_ == highspy.MatrixFormat.kRowwise else sp.csc_matrix
    a = kind(
        (np.asarray(mat.value_), np.asarray(mat.index_), np.asarray(mat.start_)),
        shape=(len(row_lo), len(col_lo)),
    ).tocsr()
    up_f = np.where(np.isfinite(row_up), row_up, 0.0)  # y_r is 0 where its side is infinite
    lo_f = np.where(np.isfinite(row_lo), row_lo, 0.0)
    row_part = np.where(y > 0, y * up_f, y * lo_f)
    d = np.asarray(lp.col_cost_, dtype=float) - a.T @ y
    col_part = np.maximum(d * col_lo, d * col_up)
    scale = np.abs(row_part).sum() + np.abs(col_part).sum() + float((abs(a).T @ np.abs(y)).sum())
    margin = 1e-9 * scale + 1e-7
    bound = float(row_part.sum() + col_part.sum() + float(lp.offset_)) + margin
    at_one = bound - col_part[cols] + d[cols] if len(cols) else np.zeros(0)  # = bound + min(d_j, 0)
    if not math.isfinite(bound):
        raise RuntimeError(f"internal: the dual bound is not finite ({bound})")
    return status, value, bound, np.asarray(at_one, dtype=float)
