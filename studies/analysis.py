"""What researchers read off a study's rows: performance profiles and a summary table.

The figures and the files of a study (:func:`~droneplan.studies.plots.profiles.write_study_outputs`)
are drawn from these in :mod:`droneplan.studies.plots.profiles`, which imports this module (never
the reverse).

Every function takes the long-format rows of :mod:`droneplan.studies.store` (one row per
``(problem, instance, method[, config])``) as a pandas DataFrame.

Conventions shared by all of them
---------------------------------
- Rows of role ``bound`` prove bounds; they are not methods and are left out. Rows of role
  ``task`` (a whole task that raised, with no method named) are counted by
  :func:`summary_table` under the method ``task`` but take no part in the profiles.
- A run is *solved* when its status is ``optimal`` or ``feasible``; every other status
  (``infeasible``, ``invalid``, ``timeout``, ``error``, ``no_solution``, ...) is a failure,
  whatever objective the row may carry.
- A method is its name: its ``config`` hash differs from instance to instance (it hashes the
  instance's data too), so configurations are not methods. Pass current rows only (what
  ``load_results`` returns by default): two rows of one method on one instance are refused.
- A frame without a ``flag`` column (written before schema v2) is read as if every flag
  were ``''``.

Performance profiles (Dolan and Moré, Math. Program. 91 (2002) 201-213)
----------------------------------------------------------------------
For each instance and each method run on it, the performance ratio ``r >= 1`` compares the
method with the best *solved* run on that instance; a failed run gets ``r = inf``. The
profile of a method is ``fraction(tau)``: the share of the instances on which that method
was run (the others do not count for it) with ``r <= tau``.

- ``measure="time"``: ``r = max(t, floor) / max(t_best, floor)`` with ``t_best`` the least
  time of a solved run and ``floor = time_floor`` (1 ms by default), so runs faster than
  the clock's useful resolution tie and a zero time never divides.
- ``measure="objective"``: ``r = 1 + gap`` where ``gap`` is the relative gap to the best
  solved objective ``b`` of the instance, measured as the store measures ``gap_to_best``:
  ``(v - b) / max(|b|, 1e-9)`` for ``sense == "min"`` and ``(b - v) / max(|b|, 1e-9)`` for
  ``"max"``. This is well defined for zero and negative objectives. For a minimisation
  with positive objectives it equals the ratio ``v / b`` of Dolan and Moré; for a
  maximisation it is ``2 - v / b``, which never exceeds ``b / v``. The gap is recomputed
  over solved runs only, so a failed run's objective never sets the best; ``fraction(tau)``
  therefore reads "share of instances solved within a relative gap ``tau - 1`` of the
  best method".
- A solved run without a finite measure (no time, no objective) is counted as a failure.
- ``r <= tau`` is tested with a relative tolerance of 1e-12, so ratios that are equal on
  paper compare equal in floating point.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any, Literal

import numpy as np
import pandas as pd

from droneplan.core.validation import check_array, check_instance, check_nonneg, check_positive
from droneplan.studies.store import REFERENCE_METHOD

__all__ = [
    "SOLVED_STATUSES",
    "FAILURE_COLUMNS",
    "AT_BEST_TOL",
    "GAP_ZERO_TOL",
    "SUMMARY_COLUMNS",
    "SUCCESS_TOL",
    "instance_targets",
    "performance_ratios",
    "performance_profile",
    "shifted_geometric_mean",
    "snap_gap",
    "summary_table",
    "summary_markdown",
    "labelled_rows",
    "solved_mask",
]

SOLVED_STATUSES = ("optimal", "feasible")
"""Statuses of a run that returned a usable plan; every other status is a failure."""

FAILURE_COLUMNS = ("infeasible", "invalid", "timeout", "error", "no_solution")
"""Failure statuses counted in columns of their own by :func:`summary_table` (others go to ``other``)."""

AT_BEST_TOL = 1e-6
"""A solved run is at the best when its ``gap_to_best`` is at most this (dimensionless)."""

GAP_ZERO_TOL = 1e-9
"""A summary statistic of relative gaps within this of 0 (dimensionless) is reported as exactly 0:
float noise (a bound equal to the objective up to rounding, e.g. -5e-16), not a gap."""

_GAP_FLOOR = 1e-9  # the store's denominator floor of a relative gap
_RATIO_RTOL = 1e-12
_NOT_METHODS = ("bound",)
_NOT_PROFILED = ("bound", "task")


def snap_gap(value: float) -> float:
    """``value`` (a relative gap, dimensionless), or 0.0 when it is within ``GAP_ZERO_TOL`` of 0
    (NaN and inf stay as they are)."""
    return 0.0 if abs(value) <= GAP_ZERO_TOL else value


# --------------------------------------------------------------------------- input handling
def _require(df: Any, columns: Sequence[str], name: str = "df") -> pd.DataFrame:
    check_instance(name, df, pd.DataFrame)
    missing = [c for c in columns if c not in df.columns]
    if missing:
        raise ValueError(f"{name} lacks the column(s) {missing} of the results schema")
    return df


def labelled_rows(df: pd.DataFrame, exclude_roles: Sequence[str]) -> pd.DataFrame:
    """The method rows of ``df`` with a ``label`` column (the method's name).

    df: rows of the results schema; exclude_roles: the roles left out (e.g. ``("bound",)``).
    """
    rows = df[~df["role"].isin(exclude_roles)].copy()
    rows["label"] = rows["method"].astype(str).astype(object)
    return rows


def solved_mask(rows: pd.DataFrame) -> pd.Series:
    """Per row of ``rows`` (results schema), whether its run is solved (``SOLVED_STATUSES``).

    rows: rows with a ``status`` column.
    """
    return rows["status"].astype(str).isin(SOLVED_STATUSES)


def _flags(rows: pd.DataFrame) -> pd.Series:
    if "flag" not in rows.columns:
        return pd.Series("", index=rows.index, dtype=object)
    return rows["flag"].astype(object).where(rows["flag"].notna(), "").astype(str)


# --------------------------------------------------------------------------- performance profile
def performance_ratios(
    df: pd.DataFrame, *, measure: Literal["objective", "time"] = "objective", time_floor: float = 1e-3
) -> pd.DataFrame:
    """Per (instance, method) the performance ratio of the module docstring (inf for a failure).

    df: rows of the results schema; measure: ``"objective"`` or ``"time"``;
    time_floor: least time (s) a run is credited with (see the module docstring).
    Returns columns problem, instance, method, ratio (dimensionless, >= 1 or inf).
    """
    if measure not in ("objective", "time"):
        raise ValueError(f"measure must be 'objective' or 'time', got {measure!r}")
    floor = check_positive("time_floor", time_floor)
    value_col = "objective" if measure == "objective" else "time_s"
    needed = ["problem", "instance", "method", "role", "status", value_col]
    if measure == "objective":
        needed.append("sense")
    rows = labelled_rows(_require(df, needed), _NOT_PROFILED)
    dup = rows.duplicated(["problem", "instance", "label"], keep=False)
    if dup.any():
        first = rows[dup].iloc[0]
        raise ValueError(
            f"df has several rows for method {first['label']!r} on instance {first['instance']!r}; "
            "a profile needs one run per (instance, method): filter the rows first"
        )
    value = pd.to_numeric(rows[value_col], errors="coerce").astype(float).to_numpy()
    ok = solved_mask(rows).to_numpy() & np.isfinite(value)
    ratio = np.full(len(rows), np.inf)
    if measure == "time":
        value = np.maximum(value, floor)
    for idx in rows.groupby(["problem", "instance"], sort=False).indices.values():
        good = idx[ok[idx]]
        if not len(good):
            continue
        v = value[good]
        if measure == "time":
            ratio[good] = v / v.min()
            continue
        senses = set(rows["sense"].iloc[idx].astype(str))
        if len(senses) != 1 or not senses <= {"min", "max"}:
            inst = rows["instance"].iloc[idx[0]]
            raise ValueError(
                f"sense of instance {inst!r} must be one of 'min'/'max' for all rows, got {senses}"
            )
        if senses == {"min"}:
            best = v.min()
            gap = (v - best) / max(abs(best), _GAP_FLOOR)
        else:
            best = v.max()
            gap = (best - v) / max(abs(best), _GAP_FLOOR)
        ratio[good] = 1.0 + gap
    return pd.DataFrame(
        {
            "problem": rows["problem"].to_numpy(),
            "instance": rows["instance"].to_numpy(),
            "method": rows["label"].to_numpy(),
            "ratio": ratio,
        }
    )


def performance_profile(
    df: pd.DataFrame,
    *,
    measure: Literal["objective", "time"] = "objective",
    taus: Any = None,
    time_floor: float = 1e-3,
) -> pd.DataFrame:
    """The Dolan-Moré performance profile of every method (definition in the module docstring).

    df: rows of the results schema; measure: ``"objective"`` (ratio ``1 + relative gap to
    the best solved objective``, respecting ``sense``) or ``"time"`` (ratio to the least
    time of a solved run); taus: the ratios (dimensionless, > 0) at which to evaluate the
    profile, default every finite ratio that occurs plus 1; time_floor: least time (s) a run
    is credited with in the time profile.
    Returns a DataFrame with columns method, tau, fraction (the share of the method's
    instances, a fraction in [0, 1], whose ratio is <= tau), methods in order of first
    appearance and taus ascending; empty when ``df`` has no method rows.
    """
    ratios = performance_ratios(df, measure=measure, time_floor=time_floor)
    if taus is None:
        finite = ratios["ratio"].to_numpy()
        grid = np.unique(np.concatenate([[1.0], finite[np.isfinite(finite)]]))
    else:
        grid = np.unique(check_array("taus", taus, ndim=1, min_rows=1))
        if grid.min() <= 0:
            raise ValueError(f"taus must be > 0, got {grid.min()}")
    out = []
    for method, g in ratios.groupby("method", sort=False):
        r = np.sort(g["ratio"].to_numpy(dtype=float))  # NaN sorts last and, like inf, is never counted
        frac = np.searchsorted(r, grid * (1 + _RATIO_RTOL), side="right") / len(r)
        out.append(pd.DataFrame({"method": method, "tau": grid, "fraction": frac}))
    if not out:
        return pd.DataFrame(
            {
                "method": pd.Series(dtype=object),
                "tau": pd.Series(dtype=float),
                "fraction": pd.Series(dtype=float),
            }
        )
    return pd.concat(out, ignore_index=True)


# --------------------------------------------------------------------------- shifted geometric mean
def shifted_geometric_mean(values: Any, shift: float = 1.0) -> float:
    """``exp(mean(log(v + shift))) - shift`` of non-negative ``values``.

    The usual mean of solve times in MIP benchmarking, with a shift of 1 s (T. Achterberg,
    *Constraint Integer Programming*, PhD thesis, TU Berlin, 2007): the shift keeps the many
    very short runs from dominating the mean as they would in a plain geometric mean.
    values: finite numbers >= 0 (e.g. times in s), at least one, no NaN; shift: >= 0, in the
    unit of ``values`` (0 gives the plain geometric mean). Returns a float in that unit.
    """
    v = check_array("values", values, ndim=1)
    if v.size == 0:
        raise ValueError("values must hold at least one number, got none")
    if v.min() < 0:
        raise ValueError(f"values must be >= 0, got {v.min()}")
    s = check_nonneg("shift", shift)
    with np.errstate(divide="ignore"):  # a zero with shift 0 gives log 0 = -inf and a mean of 0
        return float(np.exp(np.mean(np.log(v + s))) - s)


# --------------------------------------------------------------------------- summary table
SUMMARY_COLUMNS = (
    "problem",
    "size",
    "method",
    "n",
    "solved",
    *FAILURE_COLUMNS,
    "other",
    "at_best",
    "median_gap_to_bound",
    "p95_gap_to_bound",
    "median_gap_to_best",
    "p95_gap_to_best",
    "sgm_time_s",
    "flagged",
    "runs",
    "success_rate",
    "target_kind",
    "mean_objective",
    "q1_objective",
    "median_objective",
    "q3_objective",
    "ert_s",
)
"""Columns of :func:`summary_table`, in order."""

SUCCESS_TOL = 1e-6
"""Default relative tolerance (dimensionless) within which a run's objective reaches the target of
its instance (:func:`summary_table`'s ``success_rate`` and ``ert_s``)."""

_STRICT_FLAGS = ("beats-bound", "library-suspect")


def summary_table(
    df: pd.DataFrame, *, time_shift: float = 1.0, success_tol: float = SUCCESS_TOL
) -> pd.DataFrame:
    """One row per (problem, size, method): what happened to its runs and how good they were.

    df: rows of the results schema (roles other than ``bound``; ``flag`` may be absent; one row
    per run when a study made several, column ``run``);
    time_shift: shift (s) of the shifted geometric mean of the times; success_tol: relative
    tolerance (dimensionless, default ``SUCCESS_TOL``, kept in ``table.attrs["success_tol"]``)
    within which a run reaches its instance's target.
    Columns (``SUMMARY_COLUMNS``): ``n`` runs (count); ``solved`` (status optimal/feasible);
    one count per failure status of ``FAILURE_COLUMNS`` and ``other`` for any further
    status, so that ``solved + infeasible + invalid + timeout + error + no_solution + other
    == n``; ``at_best`` solved runs with ``gap_to_best <= AT_BEST_TOL``; median and 95th
    percentile (linear interpolation) of ``gap_to_bound`` and ``gap_to_best`` over solved
    runs (relative gaps, dimensionless; NaN when none has one; within ``GAP_ZERO_TOL`` of 0:
    exactly 0); ``sgm_time_s`` the shifted
    geometric mean (s) of the times of all runs that recorded one, failures included (a
    timeout counts with the time at which it was stopped); ``flagged`` runs whose ``flag``
    is non-empty. Repeated runs and success: ``runs`` the number of distinct ``run`` indices
    (1 without the column); ``success_rate`` the share of runs that are solved with an objective
    within ``success_tol`` (relative, as ``gap_to_best``) of the target of their instance
    (:func:`instance_targets`): the proven optimum, or the best known objective where none is
    proven; ``target_kind`` says which (``proven``, ``best-known`` or ``mixed`` over the group's
    instances); ``mean_objective``, ``q1_objective``, ``median_objective``, ``q3_objective``
    over solved runs (the problem's units; quartiles by linear interpolation); ``ert_s`` the
    expected running time to the target as IOHprofiler defines it (s): the sum over all runs of
    the time used (``time_s``, a successful run's time being its time to success, since a method
    returns once) divided by the number of successful runs, inf when none succeeded. Sorted by
    problem, size, median gap to the bound, median gap to the best (missing gaps last), then
    method.
    """
    _require(df, ["problem", "size", "method", "role", "status"])
    shift = check_nonneg("time_shift", time_shift)
    tol = check_nonneg("success_tol", success_tol)
    rows = labelled_rows(df, _NOT_METHODS)
    status = rows["status"].astype(str)
    solved = solved_mask(rows)
    flags = _flags(rows)
    num = {
        c: (
            pd.to_numeric(rows[c], errors="coerce").astype(float)
            if c in rows.columns
            else pd.Series(np.nan, index=rows.index)
        )
        for c in ("gap_to_bound", "gap_to_best", "time_s", "objective")
    }
    reached, kind = _successes(df, rows, solved, num["objective"], tol)
    run = (
        pd.to_numeric(rows["run"], errors="coerce").fillna(0)
        if "run" in rows.columns
        else pd.Series(0, index=rows.index)
    )
    out = []
    for (problem, size, method), g in rows.groupby(["problem", "size", "label"], sort=False, dropna=False):
        ix = g.index
        sv = solved.loc[ix]
        st = status.loc[ix]
        rec: dict[str, Any] = {"problem": problem, "size": size, "method": method, "n": len(g)}
        rec["solved"] = int(sv.sum())
        for c in FAILURE_COLUMNS:
            rec[c] = int((st == c).sum())
        rec["other"] = len(g) - rec["solved"] - sum(rec[c] for c in FAILURE_COLUMNS)
        rec["at_best"] = int((sv & (num["gap_to_best"].loc[ix] <= AT_BEST_TOL)).sum())
        for c in ("gap_to_bound", "gap_to_best"):
            v = num[c].loc[ix][sv].dropna()
            rec[f"median_{c}"] = snap_gap(float(v.median())) if len(v) else math.nan
            rec[f"p95_{c}"] = snap_gap(float(v.quantile(0.95))) if len(v) else math.nan
        t = num["time_s"].loc[ix].dropna()
        t = t[np.isfinite(t) & (t >= 0)]
        rec["sgm_time_s"] = shifted_geometric_mean(t.to_numpy(), shift) if len(t) else math.nan
        rec["flagged"] = int((flags.loc[ix] != "").sum())
        rec["runs"] = int(run.loc[ix].nunique())
        rec.update(
            _run_statistics(
                reached.loc[ix], kind.loc[ix], num["objective"].loc[ix][sv], num["time_s"].loc[ix]
            )
        )
        out.append(rec)
    table = pd.DataFrame(out, columns=list(SUMMARY_COLUMNS))
    table.attrs["success_tol"] = tol
    if not len(table):
        return table
    table = table.sort_values(
        ["problem", "size", "median_gap_to_bound", "median_gap_to_best", "method"],
        na_position="last",
        kind="stable",
    )
    table = table.reset_index(drop=True)
    table.attrs["success_tol"] = tol
    return table


def instance_targets(df: pd.DataFrame) -> pd.DataFrame:
    """The target of every instance of ``df``: its proven optimum, else its best known objective.

    df: rows of the results schema. The proven optimum is the objective of a row with status
    ``optimal`` and ``bound_kind`` ``proven-global`` (a droneplan engine or the certified library;
    rows flagged ``beats-bound`` or ``library-suspect`` excluded); without one, the best
    objective of a solved run of a role other than ``bound`` (not flagged). A reference solved
    for the study (method ``reference``, role ``bound``) is a proven optimum like the library's,
    never a best-known value. Returns columns
    problem, instance, sense, target (the problem's units; NaN when nothing was solved) and
    target_kind (``proven``, ``best-known`` or ``none``).
    """
    _require(df, ["problem", "instance", "role", "status", "sense", "objective"])
    obj = pd.to_numeric(df["objective"], errors="coerce").astype(float)
    bound_kind = df["bound_kind"].astype(str) if "bound_kind" in df.columns else pd.Series("", index=df.index)
    clean = ~_flags(df).str.split(";").apply(lambda fs: any(f in _STRICT_FLAGS for f in fs))
    solved = clean & solved_mask(df) & np.isfinite(obj)
    usable = solved & (df["role"] != "bound")
    reference = solved & (df["method"] == REFERENCE_METHOD) if "method" in df.columns else False
    proven = (usable | reference) & (df["status"] == "optimal") & (bound_kind == "proven-global")
    out = []
    for (problem, instance), g in df.groupby(["problem", "instance"], sort=False):
        ix = g.index
        sense = str(g["sense"].iloc[0])
        pick = max if sense == "max" else min
        if proven.loc[ix].any():
            target, what = pick(obj.loc[ix][proven.loc[ix]]), "proven"
        elif usable.loc[ix].any():
            target, what = pick(obj.loc[ix][usable.loc[ix]]), "best-known"
        else:
            target, what = math.nan, "none"
        out.append(
            {"problem": problem, "instance": instance, "sense": sense, "target": target, "target_kind": what}
        )
    return pd.DataFrame(out, columns=["problem", "instance", "sense", "target", "target_kind"])


def _successes(
    df: pd.DataFrame, rows: pd.DataFrame, solved: pd.Series, objective: pd.Series, tol: float
) -> tuple[pd.Series, pd.Series]:
    """Per method row: whether it reached its instance's target (solved, within ``tol``), and the
    kind of that target."""
    if not {"instance", "sense", "objective"} <= set(df.columns) or not len(rows):
        none = pd.Series("none", index=rows.index, dtype=object)
        return pd.Series(False, index=rows.index), none
    targets = instance_targets(df).set_index(["problem", "instance"])
    keys = pd.MultiIndex.from_arrays([rows["problem"], rows["instance"]])
    target = targets["target"].reindex(keys).to_numpy(dtype=float)
    kind = pd.Series(targets["target_kind"].reindex(keys).to_numpy(), index=rows.index, dtype=object)
    v = objective.to_numpy(dtype=float)
    maxim = (rows["sense"].astype(str) == "max").to_numpy()
    with np.errstate(invalid="ignore"):
        gap = np.where(maxim, target - v, v - target) / np.maximum(np.abs(target), _GAP_FLOOR)
        ok = solved.to_numpy() & np.isfinite(gap) & (gap <= tol)
    return pd.Series(ok, index=rows.index), kind


def _run_statistics(
    reached: pd.Series, kind: pd.Series, objective: pd.Series, time_s: pd.Series
) -> dict[str, Any]:
    """``success_rate`` .. ``ert_s`` of one (problem, size, method) group (see :func:`summary_table`)."""
    kinds = set(kind) - {"none"}
    v = objective.dropna()
    n_ok = int(reached.sum())
    used = float(time_s.fillna(0.0).clip(lower=0.0).sum())
    return {
        "success_rate": n_ok / len(reached) if len(reached) else math.nan,
        "target_kind": kinds.pop() if len(kinds) == 1 else ("mixed" if kinds else "none"),
        "mean_objective": float(v.mean()) if len(v) else math.nan,
        "q1_objective": float(v.quantile(0.25)) if len(v) else math.nan,
        "median_objective": float(v.median()) if len(v) else math.nan,
        "q3_objective": float(v.quantile(0.75)) if len(v) else math.nan,
        "ert_s": used / n_ok if n_ok else math.inf,
    }


def _cell(v: Any) -> str:
    if v is None or v is pd.NA or (isinstance(v, float) and math.isnan(v)):
        return "—"
    if isinstance(v, (float, np.floating)):
        return f"{v:.3g}"
    return str(v).replace("|", "\\|")


def summary_markdown(df: pd.DataFrame, *, time_shift: float = 1.0, success_tol: float = SUCCESS_TOL) -> str:
    """:func:`summary_table` of ``df`` as GitHub Markdown: one section and table per problem.

    df: rows of the results schema; time_shift: shift (s) of the mean time (see
    :func:`summary_table`); success_tol: relative tolerance of a successful run (dimensionless, see
    :func:`summary_table`). Missing values show as ``—``; gaps are relative (dimensionless).
    """
    table = summary_table(df, time_shift=time_shift, success_tol=success_tol)
    head = (
        "Runs per (problem, size, method). solved: status optimal or feasible; at best: solved "
        f"with gap to the best <= {AT_BEST_TOL:g}; gaps are relative, over solved runs; "
        f"time: shifted geometric mean (shift {time_shift:g} s) over runs that recorded one; "
        "flagged: rows with a non-empty flag. success rate: share of runs within a relative "
        f"{success_tol:g} of the target (target kind: the proven optimum or the best known value); "
        "ert: expected running time to the target (s), IOHprofiler's (inf: no run reached it)."
    )
    if not len(table):
        return head + "\n\n(no method rows)\n"
    cols = [c for c in SUMMARY_COLUMNS if c != "problem"]
    names = [c.replace("_", " ") for c in cols]
    parts = [head]
    for problem, g in table.groupby("problem", sort=False):
        n_inst = df.loc[df["problem"] == problem, "instance"].nunique()
        parts += [
            "",
            f"### {problem} ({n_inst} instances)",
            "",
            "| " + " | ".join(names) + " |",
            "|" + "---|" * len(names),
            *("| " + " | ".join(_cell(v) for v in r) + " |" for r in g[cols].itertuples(index=False)),
        ]
    return "\n".join(parts) + "\n"
