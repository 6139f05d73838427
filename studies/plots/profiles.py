"""Figures comparing methods across a study's instances: performance profiles and gap ECDFs.

Both take the long-format rows of :mod:`droneplan.studies.store`, an optional matplotlib
``ax`` (a new figure is made when it is None) and return the ``Figure``. Matplotlib is
imported inside the functions. Empty data, a single method and studies where every run
failed give a figure that says so instead of an exception. The ratios, the solved/failed
rule and the treatment of ``bound``/``task`` rows are those of :mod:`droneplan.studies.analysis`.
:func:`write_study_outputs` writes a study's summary, these figures and its rows into a folder.
"""

from __future__ import annotations

import importlib
import importlib.util
import json
import math
import os
from pathlib import Path
from typing import Any, Literal

import numpy as np
import pandas as pd

from droneplan.core.validation import check_instance
from droneplan.studies.analysis import (
    labelled_rows,
    performance_profile,
    solved_mask,
    summary_markdown,
    summary_table,
)

__all__ = ["plot_performance_profile", "plot_gap_distribution", "write_study_outputs"]

_STYLES = ("-", "--", ":", "-.")
_XLABEL = {
    "objective": "τ = 1 + relative gap to the best solved objective (log2 scale)",
    "time": "τ = time / least time of a solved run (log2 scale)",
}


def plot_performance_profile(
    df: pd.DataFrame,
    measure: Literal["objective", "time"] = "objective",
    ax: Any = None,
    *,
    time_floor: float = 1e-3,
):
    """Step plot of the Dolan-Moré performance profile, one line per method, on a log2 τ axis.

    df: rows of the results schema; measure: ``"objective"`` or ``"time"`` (ratios as in
    :func:`~droneplan.studies.analysis.performance_profile`); ax: matplotlib Axes to draw
    on, or None for a new figure; time_floor: least time (s) a run is credited with.
    The y axis is the fraction of the method's instances whose ratio is <= τ; a line that
    stays below 1 on the right is the share of instances the method failed on.
    Returns the Figure.
    """
    from droneplan.studies.plots._common import figure_axes

    prof = performance_profile(df, measure=measure, time_floor=time_floor)
    fig, ax = figure_axes(ax, figsize=(6.0, 4.2))
    n_inst = df[["problem", "instance"]].drop_duplicates().shape[0] if len(df) else 0
    ax.set_title(f"Performance profile: {measure} ({n_inst} instances; a failure never counts)", fontsize=10)
    ax.set_xlabel(_XLABEL[measure])
    ax.set_ylabel("fraction of instances with ratio ≤ τ")
    ax.set_ylim(-0.03, 1.03)
    ax.grid(alpha=0.3)
    if prof.empty:
        ax.text(0.5, 0.5, "no method rows to compare", ha="center", va="center", transform=ax.transAxes)
        ax.set_xscale("log", base=2)
        ax.set_xlim(1.0, 2.0)
        return fig
    tau_max = float(prof["tau"].max())
    right = max(2.0, 2.0 * tau_max) if tau_max > 1.0 else 2.0
    for method, g in prof.groupby("method", sort=False):
        x = np.append(g["tau"].to_numpy(), right)
        y = np.append(g["fraction"].to_numpy(), g["fraction"].iloc[-1])
        ax.step(x, y, where="post", label=str(method))
    if not (prof["fraction"] > 0).any():
        ax.text(0.5, 0.5, "no method solved any instance", ha="center", va="center", transform=ax.transAxes)
    ax.set_xscale("log", base=2)
    ax.set_xlim(min(1.0, float(prof["tau"].min())), right)
    ax.legend(fontsize=8, loc="best")
    return fig


def plot_gap_distribution(df: pd.DataFrame, column: str = "gap_to_bound", ax: Any = None):
    """Empirical distribution (ECDF) of a relative gap per method, one line style per size.

    df: rows of the results schema; column: the gap column to plot (``"gap_to_bound"`` or
    ``"gap_to_best"``, relative and dimensionless); ax: matplotlib Axes to draw on, or None
    for a new figure. A curve at height y over x says: the share y of the method's runs of
    that size was solved with a gap <= x. Failed runs and solved runs without a gap are in
    the denominator but never counted, so such a curve ends below 1. A wide range of
    positive gaps is drawn on a symmetric log axis (linear near 0). Returns the Figure.
    """
    from droneplan.studies.plots._common import figure_axes

    check_instance("df", df, pd.DataFrame)
    check_instance("column", column, str)
    if len(df) and column not in df.columns:
        raise ValueError(f"column must be a column of df, got {column!r}")
    fig, ax = figure_axes(ax, figsize=(6.0, 4.2))
    kinds = ""
    if column == "gap_to_bound" and "gap_bound_kind" in df.columns:
        kinds = ",".join(sorted(set(df["gap_bound_kind"].dropna().astype(str))))
    ax.set_title(
        f"ECDF of {column}: share of runs solved within x" + (f"\n(bound kind: {kinds})" if kinds else ""),
        fontsize=10,
    )
    ax.set_xlabel(f"{column} (relative, dimensionless)")
    ax.set_ylabel("fraction of runs (failures never count)")
    ax.set_ylim(-0.03, 1.03)
    ax.grid(alpha=0.3)
    needed = ("problem", "method", "role", "status")
    if not len(df) or any(c not in df.columns for c in needed):
        ax.text(0.5, 0.5, "no rows", ha="center", va="center", transform=ax.transAxes)
        return fig
    if "size" not in df.columns:
        df = df.assign(size=pd.NA)
    rows = labelled_rows(df, ("bound", "task"))
    vals = pd.to_numeric(rows[column], errors="coerce").astype(float).where(solved_mask(rows))
    rows = rows.assign(_v=vals, _size=rows["size"].map(lambda s: "?" if pd.isna(s) else str(s)))
    finite = vals[np.isfinite(vals)]
    if not len(finite):
        msg = "no method rows" if not len(rows) else f"no solved run has a {column}"
        ax.text(0.5, 0.5, msg, ha="center", va="center", transform=ax.transAxes)
        return fig
    lo, hi = float(finite.min()), float(finite.max())
    positive = finite[finite > 0]
    symlog = bool(len(positive)) and positive.max() > 100 * positive.min()
    if symlog:  # gaps spanning decades: linear below the smallest positive gap, log above
        thresh = max(float(positive.min()), 1e-6 * hi)
        left, right = (-thresh if lo >= 0 else 2.0 * lo), 2.0 * hi
    else:
        pad = 0.05 * (hi - lo) if hi > lo else max(0.05 * abs(hi), 1e-3)
        left, right = min(lo, 0.0) - pad, hi + pad
    sizes = list(dict.fromkeys(rows["_size"]))
    style = {s: _STYLES[k % len(_STYLES)] for k, s in enumerate(sizes)}
    colours = {m: f"C{k % 10}" for k, m in enumerate(dict.fromkeys(rows["label"]))}
    for (method, size), g in rows.groupby(["label", "_size"], sort=False):
        v = np.sort(g["_v"].to_numpy()[np.isfinite(g["_v"].to_numpy())])
        n = len(g)
        x = np.concatenate([[left], v, [right]])
        y = np.concatenate([[0.0], np.arange(1, len(v) + 1) / n, [len(v) / n]])
        label = str(method) if len(sizes) == 1 else f"{method}, size {size}"
        ax.step(x, y, where="post", color=colours[method], linestyle=style[size], label=label)
    if symlog:
        ax.set_xscale("symlog", linthresh=thresh)
    ax.set_xlim(left, right)
    ax.legend(fontsize=8, loc="best")
    return fig


# --------------------------------------------------------------------------- files
def _arrow_accepts(pa: Any, column: pd.Series) -> bool:
    """True when pyarrow stores ``column`` as one typed column (else it goes as JSON text)."""
    try:
        pa.array(column, from_pandas=True)
    except (pa.ArrowInvalid, pa.ArrowTypeError, pa.ArrowNotImplementedError):
        return False
    return True


def _missing(v: Any) -> bool:
    return v is None or v is pd.NA or (isinstance(v, float) and math.isnan(v))


def _json_text(v: Any) -> str | None:
    if _missing(v):
        return None
    if hasattr(v, "tolist"):  # numpy arrays and scalars
        v = v.tolist()
    return json.dumps(v, default=str)


def _parquet_ready(df: pd.DataFrame) -> pd.DataFrame:
    """``df`` with object columns of lists, dicts or mixed scalars written as JSON text.

    Such columns (problem extras such as a list of sites) would otherwise come back from
    Parquet as arrays, or not be written at all; every other column round-trips unchanged.
    """
    pa = importlib.import_module("pyarrow")  # typed as Any: pyarrow ships no type information
    out = df
    for c in df.columns:
        if df[c].dtype != object:
            continue
        present = [v for v in df[c] if not _missing(v)]
        nested = any(isinstance(v, (list, tuple, dict, set, np.ndarray)) for v in present)
        if not nested and _arrow_accepts(pa, df[c]):
            continue
        if out is df:
            out = df.copy()
        out[c] = pd.Series([_json_text(v) for v in df[c]], index=df.index, dtype=object)
    return out


def write_study_outputs(df: pd.DataFrame, out: str | os.PathLike, *, stem: str = "study") -> dict[str, Path]:
    """Write a study's summary, profiles, gap figure and rows into the folder ``out``.

    df: rows of the results schema; out: folder (created with its parents); stem: prefix of
    the file names (no path separators). Files: ``<stem>_summary.csv`` and
    ``<stem>_summary.md`` (:func:`summary_table`), ``<stem>_profile_objective.png`` and
    ``<stem>_profile_time.png`` (performance profiles, of run 0 when the study repeated its
    runs: the instance's own seed), ``<stem>_gaps.png`` (distribution of
    the gaps to the bound and to the best per method and size) and ``<stem>_rows.parquet``
    (the rows; a column of lists, dicts or mixed types is stored as JSON text, every other
    column reads back unchanged with ``pandas.read_parquet``). Needs pyarrow for
    the Parquet file: an ImportError saying so is raised before anything is written.
    Returns ``{"summary_csv", "summary_md", "profile_objective", "profile_time", "gaps",
    "rows"}`` mapped to the paths written.
    """
    check_instance("df", df, pd.DataFrame)
    needed = ("problem", "instance", "size", "method", "role", "sense", "status", "objective", "time_s")
    missing = [c for c in needed if c not in df.columns]
    if missing:
        raise ValueError(f"df lacks the column(s) {missing} of the results schema")
    check_instance("stem", stem, str)
    if not stem or any(sep in stem for sep in ("/", "\\", os.sep)):
        raise ValueError(f"stem must be a non-empty file-name prefix without path separators, got {stem!r}")
    check_instance("out", out, (str, os.PathLike))
    if importlib.util.find_spec("pyarrow") is None:  # checked up front: no half-written output folder
        raise ImportError(
            "write_study_outputs writes the rows as Parquet, which needs pyarrow: pip install pyarrow"
        )
    import matplotlib.pyplot as plt

    folder = Path(out)
    folder.mkdir(parents=True, exist_ok=True)
    paths = {
        "summary_csv": folder / f"{stem}_summary.csv",
        "summary_md": folder / f"{stem}_summary.md",
        "profile_objective": folder / f"{stem}_profile_objective.png",
        "profile_time": folder / f"{stem}_profile_time.png",
        "gaps": folder / f"{stem}_gaps.png",
        "rows": folder / f"{stem}_rows.parquet",
    }
    summary_table(df).to_csv(paths["summary_csv"], index=False)
    paths["summary_md"].write_text(summary_markdown(df))
    measures: tuple[Literal["objective", "time"], ...] = ("objective", "time")
    first_runs = df[df["run"] == 0] if "run" in df.columns else df  # a profile takes one run per pair
    for measure in measures:
        fig = plot_performance_profile(first_runs, measure=measure)
        fig.savefig(paths[f"profile_{measure}"], dpi=110)
        plt.close(fig)
    fig, axes = plt.subplots(1, 2, figsize=(11.0, 4.2))
    for ax, col in zip(axes, ("gap_to_bound", "gap_to_best"), strict=True):
        plot_gap_distribution(df, column=col, ax=ax)
    fig.tight_layout()
    fig.savefig(paths["gaps"], dpi=110)
    plt.close(fig)
    _parquet_ready(df).to_parquet(paths["rows"], index=False)
    return paths
