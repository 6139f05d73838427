"""Anytime traces: the incumbents a method reports while it runs, scored like its final plan.

A method of a static kind (cells, allocation, shark fleets) may take a keyword ``report``. It is
then called with a :class:`~droneplan.studies.reporter.Reporter`, which the method calls with
each new incumbent::

    def my_method(problem, *, seed, time_limit, report=None):
        ...
        if report is not None:
            report(plan)  # the plan, as the method would return it
            report(plan, objective=v, bound=b)  # with what the method claims of it

The reporter stamps each call with the time since the method started (s, in the job's child
process) and sends it to the study as plain data (:mod:`~droneplan.studies.wire`); the runner
keeps at most :data:`MAX_TRACE_POINTS` of them per run, the first and the last among them
(:attr:`~droneplan.studies.runner.IsolatedCall.max_reports`). The study then scores every kept report
with droneplan's own evaluator (:func:`score_trace`), exactly as a final plan: an infeasible
plan is ``infeasible``, a claimed objective that differs from droneplan's is flagged
``claim-mismatch``, and a bound counts only from droneplan's exact engines. A call with
something that is not plain data, or beyond :data:`MAX_REPORT_CALLS`, becomes an ``invalid``
entry of the trace; it never costs the run its row.

From scored traces and a reference value per instance (the proven optimum, or the best known):

- :func:`trace_gaps`: the relative gap of the incumbent at each reported time;
- :func:`primal_integral`: the integral of the primal gap over time (Berthold, Oper. Res. Lett.
  41 (2013) 611-614): 0 for a method that starts at the optimum, the horizon for one that never
  finds a plan;
- :func:`ecdf`: the fraction of (instance, run) pairs that reach gap <= tau by time t, over a
  grid of times (fixed target) or of targets (fixed budget), as IOHanalyzer plots them.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from typing import Any

import numpy as np
import pandas as pd

from droneplan.studies.harness import score
from droneplan.studies.instances import StudyInstance
from droneplan.studies.methods import Method
from droneplan.studies.reporter import MAX_REPORT_CALLS, Reporter

__all__ = [
    "MAX_REPORT_CALLS",
    "MAX_TRACE_POINTS",
    "TRACE_COLUMNS",
    "Reporter",
    "takes_report",
    "score_trace",
    "score_reports",
    "MAX_REPORT_BYTES",
    "trace_gaps",
    "primal_integral",
    "ecdf",
    "anytime_gaps",
    "anytime_summary",
    "gap_over_time",
]

MAX_TRACE_POINTS = 200
"""Reports kept per run (the first, the last and evenly thinned ones between them)."""
TRACE_COLUMNS = ("t", "objective", "claimed_objective", "bound", "status", "message", "flag")
"""The columns of a scored trace point, beside the row key: ``t`` (s since the method started),
``objective`` (droneplan's score of the reported plan), ``claimed_objective`` (what the method
said it was), ``bound`` (an exact engine's proven bound at that time), ``status``, ``message``,
``flag``."""


def takes_report(method: Method) -> bool:
    """Whether ``method`` takes a ``report`` keyword (:meth:`Method.accepts`) on a kind whose
    methods return plans (a closed-loop controller does not report)."""
    return not method.is_class and method.accepts("report")


def score_trace(instance: StudyInstance, method: Method, reports: Iterable[Any]) -> list[dict[str, Any]]:
    """Each decoded report of one run scored by droneplan's evaluator: dicts with the keys of
    :data:`TRACE_COLUMNS`, in the order of the reports.

    instance: the study instance the method ran on.
    method: the method (its ``trusted_bound`` decides whether a reported bound counts).
    reports: the reports as the study decoded them (dicts with ``t`` and ``plan`` or
        ``invalid``; anything else is an ``invalid`` point).
    """
    points = []
    for report in reports:
        t = _finite(report.get("t")) if isinstance(report, Mapping) else None
        if not isinstance(report, Mapping) or t is None or t < 0:
            points.append(_invalid(None, "a report without a time stamp"))
        elif "invalid" in report:
            points.append(_invalid(t, str(report["invalid"])))
        elif "plan" not in report:
            points.append(_invalid(t, "a report without a plan"))
        else:
            scored = score(instance, method, report["plan"])
            points.append(
                {
                    "t": t,
                    "objective": scored.objective,
                    "claimed_objective": scored.claimed_objective,
                    "bound": scored.bound,
                    "status": scored.status,
                    "message": scored.message,
                    "flag": ";".join(scored.flags),
                }
            )
    return points


def score_reports(instance: StudyInstance, method: Method, reports: Sequence[bytes]) -> list[dict[str, Any]]:
    """:func:`score_trace` of a run's reports as the runner returned them (plain-data messages,
    decoded here; one that cannot be read is an ``invalid`` point).

    instance: the study instance. method: the method that reported. reports: the kept reports.
    """
    from droneplan.studies import wire

    decoded: list[Any] = []
    for raw in reports:
        try:
            decoded.append(wire.decode(raw, max_bytes=MAX_REPORT_BYTES))
        except (wire.WireError, TypeError) as exc:
            decoded.append({"t": 0.0, "invalid": f"an unreadable report: {exc}"})
    return score_trace(instance, method, decoded)


MAX_REPORT_BYTES = 16 << 20
"""The largest report decoded (bytes of its plain-data message)."""


def _invalid(t: float | None, why: str) -> dict[str, Any]:
    return {
        "t": t,
        "objective": None,
        "claimed_objective": None,
        "bound": None,
        "status": "invalid",
        "message": why,
        "flag": "",
    }


def _finite(v: Any) -> float | None:
    if isinstance(v, bool) or not isinstance(v, (int, float, np.integer, np.floating)):
        return None
    f = float(v)
    return f if math.isfinite(f) else None


# --------------------------------------------------------------------------- reading traces
def trace_gaps(
    traces: pd.DataFrame, reference: Mapping[str, float], sense: str | Mapping[str, str]
) -> pd.DataFrame:
    """``traces`` with a column ``gap``: the relative gap of the best solved point so far (at
    each row, in time order per run) to the instance's reference value, ``|ref - best| /
    max(|ref|, 1e-9)``, never below 0; NaN before the first solved point.

    traces: scored trace points with columns ``instance``, ``method``, ``run`` (optional), ``t``,
        ``objective``, ``status``.
    reference: instance -> reference value (the proven optimum, or the best known).
    sense: ``"min"`` or ``"max"``, or instance -> sense.
    """
    df = traces.sort_values([c for c in ("instance", "method", "run", "t") if c in traces.columns]).copy()
    solved = df["status"].isin(("optimal", "feasible")) & df["objective"].notna()
    value = df["objective"].where(solved)
    keys = [c for c in ("instance", "method", "run") if c in df.columns]
    senses = df["instance"].map(sense) if isinstance(sense, Mapping) else pd.Series(sense, index=df.index)
    signed = value.where(senses == "min", -value)  # smaller is better for both senses
    best = signed.groupby([df[k] for k in keys]).cummin()
    best = best.where(senses == "min", -best)
    ref = df["instance"].map(reference).astype(float)
    gap = (best - ref).abs() / np.maximum(ref.abs(), 1e-9)
    df["gap"] = gap.where(best.notna())
    return df


def primal_integral(times: Sequence[float], gaps: Sequence[float], horizon: float) -> float:
    """The primal integral of one run (Berthold 2013): the integral over [0, ``horizon``] of the
    primal gap, which is 1 until the first incumbent and then ``min(1, gap)`` of the current
    incumbent (a step function). In seconds; smaller is better.

    times: report times (s), non-decreasing.
    gaps: the relative gap of the incumbent at each time (NaN: no incumbent yet).
    horizon: the end of the run (s), >= 0.
    """
    if not math.isfinite(horizon) or horizon < 0:
        raise ValueError(f"horizon must be a finite number of seconds >= 0, got {horizon}")
    t = np.asarray(times, float)
    g = np.asarray(gaps, float)
    if t.shape != g.shape or t.ndim != 1:
        raise ValueError(f"times and gaps must be 1-D of one length, got {t.shape} and {g.shape}")
    if len(t) and np.any(np.diff(t) < 0):
        raise ValueError("times must be non-decreasing")
    edges = np.concatenate([[0.0], np.clip(t, 0.0, horizon), [horizon]])
    levels = np.concatenate([[1.0], np.where(np.isnan(g), 1.0, np.minimum(g, 1.0))])
    return float(np.sum(np.diff(edges) * levels))


def ecdf(
    gaps: pd.DataFrame,
    *,
    targets: Sequence[float],
    times: Sequence[float],
    pairs: int | Mapping[str, int] | None = None,
) -> pd.DataFrame:
    """The fraction of (instance, run) pairs of each method whose incumbent reached gap <= tau by
    time t, for every tau in ``targets`` and t in ``times``: columns ``method``, ``target``,
    ``t``, ``fraction``. Read it at one target over the times (fixed target) or at one time over
    the targets (fixed budget).

    gaps: the output of :func:`trace_gaps` (columns ``instance``, ``method``, ``t``, ``gap``,
        ``run`` optional).
    targets: gap thresholds tau (relative, >= 0).
    times: time points (s).
    pairs: the number of (instance, run) pairs per method that the fraction divides by (a
        pair without any trace point counts as never reaching a target); None: the pairs
        present in ``gaps``.
    """
    run_keys = [c for c in ("instance", "run") if c in gaps.columns]
    rows = []
    for method, part in gaps.groupby("method", sort=True):
        first_hit = {}
        for tau in targets:
            hit = part[part["gap"] <= tau + 1e-12]
            first_hit[tau] = hit.groupby(run_keys)["t"].min() if len(hit) else pd.Series(dtype=float)
        present = part.groupby(run_keys).ngroups
        total = pairs.get(method, present) if isinstance(pairs, Mapping) else (pairs or present)
        for tau in targets:
            reached = np.sort(first_hit[tau].to_numpy(float))
            for t in times:
                count = int(np.searchsorted(reached, t, side="right"))
                rows.append(
                    {"method": method, "target": float(tau), "t": float(t), "fraction": count / max(total, 1)}
                )
    return pd.DataFrame(rows, columns=["method", "target", "t", "fraction"])


# --------------------------------------------------------------------------- a study's anytime view
def anytime_gaps(rows: pd.DataFrame, traces: pd.DataFrame) -> pd.DataFrame:
    """The trace points of a study with their ``gap`` to each instance's target (its proven
    optimum, else the best known objective: :func:`~droneplan.studies.analysis.instance_targets`)
    and the run's ``horizon`` (s: its row's wall time, or its last report when the row has none).

    rows: the study's rows (``load_results``). traces: its traces (``load_traces``).
    """
    from droneplan.studies.analysis import instance_targets

    if traces.empty:
        return traces.assign(gap=pd.Series(dtype=float), horizon=pd.Series(dtype=float))
    targets = instance_targets(rows).set_index("instance")
    gaps = trace_gaps(traces, targets["target"].to_dict(), targets["sense"].to_dict())
    keys = ["instance", "method", "run"]
    wall = rows.assign(run=rows["run"].astype(int)).groupby(keys)["time_s"].max()
    last = gaps.groupby(keys)["t"].max()
    horizon = wall.reindex(last.index).fillna(last).clip(lower=last)
    return gaps.merge(horizon.rename("horizon").reset_index(), on=keys, how="left")


def anytime_summary(rows: pd.DataFrame, traces: pd.DataFrame) -> pd.DataFrame:
    """Per method: ``runs`` with a trace, the median and mean ``primal_integral`` (s, over each
    run's horizon), the ``final_gap`` median, and ``time_to_best`` median (s until the run's
    incumbent reached its final value; NaN when it never had one).

    rows: the study's rows (``load_results``). traces: its traces (``load_traces``).
    """
    gaps = anytime_gaps(rows, traces)
    out = []
    for method, part in gaps.groupby("method", sort=True):
        integrals, finals, reached = [], [], []
        for _, run in part.groupby(["instance", "run"]):
            run = run.sort_values("t")
            integrals.append(primal_integral(run["t"], run["gap"], float(run["horizon"].iloc[0])))
            gap = run["gap"].to_numpy(float)
            finals.append(gap[-1])
            settled = (
                np.flatnonzero(gap <= np.nanmin(gap) + 1e-12) if np.isfinite(gap).any() else np.array([], int)
            )
            reached.append(float(run["t"].iloc[settled[0]]) if len(settled) else math.nan)
        out.append(
            {
                "method": method,
                "runs": len(integrals),
                "primal_integral_median": float(np.median(integrals)),
                "primal_integral_mean": float(np.mean(integrals)),
                "final_gap_median": _nanmedian(finals),
                "time_to_best_median": _nanmedian(reached),
            }
        )
    columns = [
        "method",
        "runs",
        "primal_integral_median",
        "primal_integral_mean",
        "final_gap_median",
        "time_to_best_median",
    ]
    return pd.DataFrame(out, columns=columns)


def gap_over_time(gaps: pd.DataFrame, times: Sequence[float]) -> pd.DataFrame:
    """The incumbent's gap of every run at each of ``times`` (1 before its first plan, capped at
    1), and per method its median and quartiles: columns ``method``, ``t``, ``q1``, ``median``,
    ``q3``.

    gaps: the output of :func:`anytime_gaps`. times: time points (s).
    """
    grid = np.asarray(times, float)
    out = []
    for method, part in gaps.groupby("method", sort=True):
        curves = []
        for _, run in part.groupby(["instance", "run"]):
            run = run.sort_values("t")
            t = run["t"].to_numpy(float)
            g = np.minimum(np.nan_to_num(run["gap"].to_numpy(float), nan=1.0), 1.0)
            at = np.searchsorted(t, grid, side="right") - 1
            curves.append(np.where(at >= 0, g[np.maximum(at, 0)], 1.0))
        q1, med, q3 = np.percentile(np.array(curves), [25, 50, 75], axis=0)
        out += [
            {"method": method, "t": float(x), "q1": a, "median": b, "q3": c}
            for x, a, b, c in zip(grid, q1, med, q3, strict=True)
        ]
    return pd.DataFrame(out, columns=["method", "t", "q1", "median", "q3"])


def _nanmedian(values: Sequence[float]) -> float:
    """The median of the finite values, NaN when there is none."""
    finite = np.asarray(values, float)
    finite = finite[np.isfinite(finite)]
    return float(np.median(finite)) if len(finite) else math.nan
