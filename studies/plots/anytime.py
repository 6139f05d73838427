"""Anytime figures of a gap study: how close each method's incumbent is to the target over time.

Both take the study's rows and traces (``load_results(out)``, ``load_traces(out)``), an optional
matplotlib ``ax`` (a new figure is made when it is None) and return the ``Figure``. The gap of a
run at time t is the relative gap of its best reported plan so far to the instance's target (the
proven optimum, else the best known objective), 1 before its first plan
(:mod:`droneplan.studies.traces`). A study without traces gives a figure that says so.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
import pandas as pd

from droneplan.studies.traces import anytime_gaps, ecdf, gap_over_time

__all__ = ["plot_anytime", "plot_anytime_ecdf"]


def _time_grid(gaps: pd.DataFrame, points: int = 120) -> np.ndarray:
    """Log-spaced times (s) from the first report to the longest horizon."""
    t = gaps["t"].to_numpy(float)
    positive = t[t > 0]
    lo = max(float(positive.min()) if len(positive) else 1e-3, 1e-4)
    hi = max(float(gaps["horizon"].max()), lo * 10.0)
    return np.geomspace(lo, hi, points)


def _anytime_axes(rows: pd.DataFrame, traces: pd.DataFrame, ax: Any, ylabel: str) -> tuple[Any, Any, Any]:
    """(figure, axes, gaps) with the time axis, ``ylabel`` and grid set; gaps None (and the axes
    saying so) when no method reported."""
    from droneplan.studies.plots._common import figure_axes

    fig, ax = figure_axes(ax, figsize=(6.4, 4.2))
    ax.set_xlabel("time since the method started (s, log scale)")
    ax.set_ylabel(ylabel)
    ax.set_ylim(-0.02, 1.02)
    ax.grid(alpha=0.3)
    gaps = anytime_gaps(rows, traces)
    if gaps.empty:
        ax.text(0.5, 0.5, "no method reported incumbents", ha="center", va="center", transform=ax.transAxes)
        return fig, ax, None
    return fig, ax, gaps


def plot_anytime(rows: pd.DataFrame, traces: pd.DataFrame, ax: Any = None):
    """Gap to the target against time, one line per method: the median over instances and runs,
    with the band between the quartiles; time on a log axis.

    rows: the study's rows; traces: its traces; ax: matplotlib Axes to draw on, or None.
    Returns the Figure.
    """
    fig, ax, gaps = _anytime_axes(rows, traces, ax, "relative gap of the incumbent to the target")
    if gaps is None:
        return fig
    grid = _time_grid(gaps)
    curves = gap_over_time(gaps, grid.tolist())
    for method, g in curves.groupby("method", sort=True):
        (line,) = ax.step(g["t"], g["median"], where="post", label=f"{method} (median)")
        ax.fill_between(g["t"], g["q1"], g["q3"], step="post", alpha=0.2, color=line.get_color())
    ax.set_xscale("log")
    runs = gaps.groupby(["instance", "run"]).ngroups
    ax.set_title(f"Anytime gap ({runs} instance-runs; band: quartiles)", fontsize=10)
    ax.legend(fontsize=8)
    return fig


def plot_anytime_ecdf(
    rows: pd.DataFrame, traces: pd.DataFrame, ax: Any = None, *, targets: Sequence[float] = (0.0, 0.01, 0.05)
):
    """Fixed-target ECDFs: for each method and gap target tau, the fraction of (instance, run)
    pairs whose incumbent reached gap <= tau by time t (log time axis).

    rows: the study's rows; traces: its traces; ax: matplotlib Axes to draw on, or None;
    targets: the gap targets tau (relative). Returns the Figure.
    """
    from droneplan.core.validation import check_array

    taus = check_array("targets", targets, ndim=1)
    if np.any(taus < 0):
        raise ValueError(f"targets must be gaps >= 0, got {taus.min()}")
    targets = taus.tolist()
    fig, ax, gaps = _anytime_axes(rows, traces, ax, "fraction of instance-runs with gap ≤ τ")
    if gaps is None:
        return fig
    grid = _time_grid(gaps)
    table = ecdf(gaps, targets=targets, times=grid.tolist())
    styles = ("-", "--", ":", "-.")
    colors: dict[str, Any] = {}
    for (method, tau), g in table.groupby(["method", "target"], sort=True):
        style = styles[list(targets).index(tau) % len(styles)] if tau in targets else "-"
        (line,) = ax.step(g["t"], g["fraction"], where="post", linestyle=style, color=colors.get(method))
        colors.setdefault(method, line.get_color())
        line.set_label(f"{method}, τ = {tau:g}")
    ax.set_xscale("log")
    ax.set_title("Fixed-target ECDF of the anytime gap", fontsize=10)
    ax.legend(fontsize=7)
    return fig
