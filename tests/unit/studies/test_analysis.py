"""Study analysis: performance profiles, shifted geometric mean, summary table, figures, files.

Every number is checked against a value worked out by hand in the comments.
"""

from __future__ import annotations

import math

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
import pytest
from matplotlib.figure import Figure

from droneplan.studies.analysis import (
    GAP_ZERO_TOL,
    SUMMARY_COLUMNS,
    performance_profile,
    performance_ratios,
    shifted_geometric_mean,
    snap_gap,
    summary_markdown,
    summary_table,
)
from droneplan.studies.plots.profiles import (
    plot_gap_distribution,
    plot_performance_profile,
    write_study_outputs,
)


def _row(instance, method, status, objective, time_s, *, sense="min", role="heuristic", size=3, **extra):
    row = {
        "problem": "cells",
        "instance": instance,
        "size": size,
        "method": method,
        "role": role,
        "sense": sense,
        "status": status,
        "objective": objective,
        "bound": None,
        "gap_to_bound": None,
        "gap_to_best": None,
        "time_s": time_s,
        "flag": "",
    }
    row.update(extra)
    return row


@pytest.fixture
def three():
    """3 instances x methods A, B, C (C not run on i3), one bound row.

    objective ratios (1 + relative gap to the best *solved* objective):
      i1 (min): A 10, B 12, C 15        -> best 10: A 1, B 1.2, C 1.5
      i2 (min): A 20, B 20, C 5 but infeasible -> best 20 (C's 5 does not count): A 1, B 1, C inf
      i3 (max): A 8, B 10, bound row 11 -> best 10 (the bound row is no method): A 1.2, B 1
    time ratios (to the least time of a solved run):
      i1: A 1, B 2, C 0.5               -> A 2, B 4, C 1
      i2: A 4, B 2, C 0.1 (failed)      -> A 2, B 1, C inf
      i3: A 2, B 2                      -> A 1, B 1
    """
    rows = [
        _row("i1", "A", "optimal", 10.0, 1.0),
        _row("i1", "B", "feasible", 12.0, 2.0),
        _row("i1", "C", "feasible", 15.0, 0.5),
        _row("i2", "A", "feasible", 20.0, 4.0),
        _row("i2", "B", "feasible", 20.0, 2.0),
        _row("i2", "C", "infeasible", 5.0, 0.1),
        _row("i3", "A", "feasible", 8.0, 2.0, sense="max"),
        _row("i3", "B", "optimal", 10.0, 2.0, sense="max"),
        _row("i3", "ub", "optimal", 11.0, 0.01, sense="max", role="bound"),
    ]
    return pd.DataFrame(rows)


def _fractions(prof, method):
    g = prof[prof["method"] == method]
    return dict(zip(g["tau"].round(12), g["fraction"], strict=True))


# --------------------------------------------------------------------------- profiles
def test_objective_profile_by_hand(three):
    prof = performance_profile(three, measure="objective", taus=[1.0, 1.2, 1.5, 2.0])
    assert list(dict.fromkeys(prof["method"])) == ["A", "B", "C"]  # no bound row
    # A: ratios {1, 1, 1.2} over 3 instances; B: {1.2, 1, 1}; C: {1.5, inf} over its 2 instances
    assert _fractions(prof, "A") == pytest.approx({1.0: 2 / 3, 1.2: 1.0, 1.5: 1.0, 2.0: 1.0})
    assert _fractions(prof, "B") == pytest.approx({1.0: 2 / 3, 1.2: 1.0, 1.5: 1.0, 2.0: 1.0})
    assert _fractions(prof, "C") == pytest.approx({1.0: 0.0, 1.2: 0.0, 1.5: 0.5, 2.0: 0.5})


def test_default_taus_are_the_ratios_that_occur(three):
    prof = performance_profile(three)
    assert sorted(set(prof["tau"].round(12))) == [1.0, 1.2, 1.5]
    assert _fractions(prof, "C") == pytest.approx({1.0: 0.0, 1.2: 0.0, 1.5: 0.5})


def test_time_profile_by_hand(three):
    prof = performance_profile(three, measure="time", taus=[1.0, 2.0, 4.0])
    # A: {2, 2, 1}; B: {4, 1, 1}; C: {1, inf}
    assert _fractions(prof, "A") == pytest.approx({1.0: 1 / 3, 2.0: 1.0, 4.0: 1.0})
    assert _fractions(prof, "B") == pytest.approx({1.0: 2 / 3, 2.0: 2 / 3, 4.0: 1.0})
    assert _fractions(prof, "C") == pytest.approx({1.0: 0.5, 2.0: 0.5, 4.0: 0.5})


def test_ratios_by_hand(three):
    r = performance_ratios(three).set_index(["instance", "method"])["ratio"]
    assert r[("i1", "C")] == pytest.approx(1.5)
    assert r[("i3", "A")] == pytest.approx(1.2)  # max: 1 + (10 - 8) / 10
    assert r[("i2", "C")] == math.inf
    assert ("i3", "ub") not in r.index


def test_objective_ratio_handles_zero_and_negative_objectives():
    # min, best -10: gap of -5 is (-5 - -10) / 10 = 0.5; of 0 is 1.0
    # max, best 0: gap of -2 is (0 - -2) / 1e-9 (floored denominator) -> huge but finite
    df = pd.DataFrame(
        [
            _row("a", "X", "optimal", -10.0, 1.0),
            _row("a", "Y", "feasible", -5.0, 1.0),
            _row("a", "Z", "feasible", 0.0, 1.0),
            _row("b", "X", "feasible", 0.0, 1.0, sense="max"),
            _row("b", "Y", "feasible", -2.0, 1.0, sense="max"),
        ]
    )
    r = performance_ratios(df).set_index(["instance", "method"])["ratio"]
    assert r[("a", "X")] == 1.0
    assert r[("a", "Y")] == pytest.approx(1.5)
    assert r[("a", "Z")] == pytest.approx(2.0)
    assert r[("b", "X")] == 1.0
    assert r[("b", "Y")] == pytest.approx(1 + 2 / 1e-9)


def test_time_floor_makes_zero_times_tie():
    df = pd.DataFrame([_row("a", "X", "optimal", 1.0, 0.0), _row("a", "Y", "optimal", 1.0, 0.0005)])
    r = performance_ratios(df, measure="time")["ratio"].to_numpy()
    assert r.tolist() == [1.0, 1.0]  # both raised to the 1 ms floor
    r = performance_ratios(df, measure="time", time_floor=1e-4)["ratio"].to_numpy()
    assert r.tolist() == pytest.approx([1.0, 5.0])


def test_solved_without_a_time_counts_as_failure():
    df = pd.DataFrame([_row("a", "X", "optimal", 1.0, None), _row("a", "Y", "feasible", 2.0, 3.0)])
    r = performance_ratios(df, measure="time")["ratio"].tolist()
    assert r == [math.inf, 1.0]


def test_a_method_is_one_method_whatever_its_per_instance_configs(three):
    # the config hash covers the instance's data, so it differs between the instances of one method
    cfg = three["instance"].astype(str) + "-" + three["method"].astype(str)
    prof = performance_profile(three.assign(config=cfg), measure="time", taus=[1.0])
    assert set(prof["method"]) == {"A", "B", "C"}
    superseded = three[three["method"] == "A"].assign(config="older")
    with pytest.raises(ValueError, match="several rows for method 'A'"):
        performance_profile(pd.concat([three.assign(config=cfg), superseded], ignore_index=True))


def test_duplicate_runs_and_bad_arguments_are_refused(three):
    with pytest.raises(ValueError, match="several rows for method 'A'"):
        performance_profile(pd.concat([three, three.iloc[[0]]]))
    with pytest.raises(ValueError, match="measure"):
        performance_profile(three, measure="speed")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="taus"):
        performance_profile(three, taus=[0.0, 1.0])
    with pytest.raises(ValueError, match="taus"):
        performance_profile(three, taus=[])
    with pytest.raises(TypeError, match="df"):
        performance_profile(three.to_dict())  # type: ignore[arg-type]
    with pytest.raises(ValueError, match=r"lacks the column\(s\) \['sense'\]"):
        performance_profile(three.drop(columns="sense"))
    with pytest.raises(ValueError, match="sense"):
        performance_profile(three.assign(sense="up"))
    with pytest.raises(ValueError, match="time_floor"):
        performance_profile(three, measure="time", time_floor=0.0)


def test_profile_of_no_method_rows_is_empty(three):
    prof = performance_profile(three[three["role"] == "bound"])
    assert prof.empty and list(prof.columns) == ["method", "tau", "fraction"]


# --------------------------------------------------------------------------- shifted geometric mean
def test_shifted_geometric_mean_by_hand():
    assert shifted_geometric_mean([1.0, 3.0]) == pytest.approx(math.sqrt(2 * 4) - 1)
    assert shifted_geometric_mean([0.0, 8.0]) == pytest.approx(2.0)  # sqrt(1 * 9) - 1
    assert shifted_geometric_mean([10.0, 10.0, 10.0], shift=5.0) == pytest.approx(10.0)
    assert shifted_geometric_mean([2.0, 8.0], shift=0.0) == pytest.approx(4.0)  # plain geometric mean
    assert shifted_geometric_mean([0.0, 8.0], shift=0.0) == 0.0


def test_shifted_geometric_mean_refuses_bad_input():
    with pytest.raises(ValueError, match="values must hold at least one"):
        shifted_geometric_mean([])
    with pytest.raises(ValueError, match="values must be >= 0"):
        shifted_geometric_mean([1.0, -0.5])
    with pytest.raises(ValueError, match="values must be finite"):
        shifted_geometric_mean([1.0, float("nan")])
    with pytest.raises(ValueError, match="shift must be >= 0"):
        shifted_geometric_mean([1.0], shift=-1.0)
    with pytest.raises(TypeError, match="values"):
        shifted_geometric_mean("123")


# --------------------------------------------------------------------------- summary
@pytest.fixture
def mixed():
    """Method M on 8 instances of size 3 with every kind of outcome, N on 2 of size 4, a bound."""
    statuses = ["optimal", "feasible", "feasible", "infeasible", "invalid", "timeout", "error", "unbounded"]
    gb = [0.0, 0.1, 0.3, -1.0, None, None, None, None]  # the infeasible run's gap must not count
    gt = [0.0, 0.0, 0.2, -0.5, None, None, None, None]
    times = [1.0, 3.0, 0.0, 1.0, 1.0, 7.0, None, 1.0]
    flags = ["", "claim-mismatch", "", "beats-bound", None, "", "", ""]
    rows = [
        _row(f"i{k}", "M", s, 1.0, t, gap_to_bound=b, gap_to_best=g, flag=f)
        for k, (s, b, g, t, f) in enumerate(zip(statuses, gb, gt, times, flags, strict=True))
    ]
    rows += [
        _row("j0", "N", "no_solution", None, 2.0, size=4),
        _row("j1", "N", "optimal", 5.0, 2.0, size=4, gap_to_bound=0.5, gap_to_best=0.0),
        _row("i0", "lp", "optimal", 0.5, 0.1, role="bound"),
    ]
    return pd.DataFrame(rows)


def test_summary_counts_per_status(mixed):
    table = summary_table(mixed)
    assert list(table.columns) == list(SUMMARY_COLUMNS)
    assert table["method"].tolist() == ["M", "N"]  # no bound row; size 3 before size 4
    m = table.iloc[0].to_dict()
    assert (m["n"], m["solved"], m["infeasible"], m["invalid"], m["timeout"], m["error"]) == (
        8,
        3,
        1,
        1,
        1,
        1,
    )
    assert (m["no_solution"], m["other"]) == (0, 1)  # unbounded
    assert m["at_best"] == 2  # gaps 0, 0 among solved; the infeasible run's -0.5 does not count
    assert m["flagged"] == 2  # None counts as no flag
    # gap_to_bound over the solved runs: [0, 0.1, 0.3] -> median 0.1, p95 0.1 + 0.9 * 0.2 = 0.28
    assert m["median_gap_to_bound"] == pytest.approx(0.1)
    assert m["p95_gap_to_bound"] == pytest.approx(0.28)
    assert m["median_gap_to_best"] == pytest.approx(0.0)
    assert m["p95_gap_to_best"] == pytest.approx(0.18)  # [0, 0, 0.2]
    # times of every run that recorded one: 1, 3, 0, 1, 1, 7, 1
    # -> shift 1: (2*4*1*2*2*8*2)^(1/7) - 1 = 2^(9/7) - 1
    assert m["sgm_time_s"] == pytest.approx(2 ** (9 / 7) - 1)
    n = table.iloc[1].to_dict()
    assert (n["size"], n["n"], n["solved"], n["no_solution"], n["other"]) == (4, 2, 1, 1, 0)
    assert n["sgm_time_s"] == pytest.approx(2.0)


def test_summary_prints_float_noise_gaps_as_zero():
    """A bound equal to the objective up to rounding gives gaps like -5.15e-16: the summary (table,
    CSV and Markdown) reports 0, while a real gap of 1e-6 stays."""
    rows = [
        _row("i0", "M", "feasible", 1.0, 1.0, gap_to_bound=-5.15e-16, gap_to_best=3e-10),
        _row("i1", "M", "feasible", 1.0, 1.0, gap_to_bound=-5.15e-16, gap_to_best=-2e-10),
        _row("i0", "N", "feasible", 1.0, 1.0, gap_to_bound=1e-6, gap_to_best=1e-6),
    ]
    table = summary_table(pd.DataFrame(rows)).set_index("method")
    for col in ("median_gap_to_bound", "p95_gap_to_bound", "median_gap_to_best", "p95_gap_to_best"):
        assert table.loc["M", col] == 0.0 and not math.copysign(1.0, table.loc["M", col]) < 0
        assert table.loc["N", col] == pytest.approx(1e-6, rel=1e-12)
    md = summary_markdown(pd.DataFrame(rows))
    assert "e-16" not in md and "e-10" not in md and "1e-06" in md
    assert snap_gap(GAP_ZERO_TOL) == 0.0 and snap_gap(2 * GAP_ZERO_TOL) == 2 * GAP_ZERO_TOL
    assert math.isnan(snap_gap(math.nan)) and snap_gap(math.inf) == math.inf


def test_summary_sorts_by_median_gap_and_reads_old_frames(mixed):
    # a second method of size 3 with a smaller median gap to the bound comes first
    better = mixed[mixed["method"] == "M"].assign(method="K", gap_to_bound=0.01)
    table = summary_table(pd.concat([mixed, better], ignore_index=True).drop(columns="flag"))
    assert table["method"].tolist() == ["K", "M", "N"]
    assert table["flagged"].tolist() == [0, 0, 0]  # no flag column: no flags


def test_summary_of_no_gap_columns_and_of_empty_frames(mixed):
    table = summary_table(mixed.drop(columns=["gap_to_bound", "gap_to_best", "time_s"]))
    assert table["at_best"].tolist() == [0, 0]
    assert table["median_gap_to_bound"].isna().all() and table["sgm_time_s"].isna().all()
    empty = summary_table(mixed.iloc[0:0])
    assert empty.empty and list(empty.columns) == list(SUMMARY_COLUMNS)
    with pytest.raises(ValueError, match="status"):
        summary_table(mixed.drop(columns="status"))


def test_summary_markdown(mixed):
    md = summary_markdown(mixed)
    assert "### cells (11 instances)" not in md  # instances are counted once
    assert "### cells (10 instances)" in md
    lines = [ln for ln in md.splitlines() if ln.startswith("|")]
    assert lines[0].startswith("| size | method | n | solved | infeasible |")
    assert lines[2].startswith("| 3 | M | 8 | 3 | 1 | 1 | 1 | 1 | 0 | 1 | 2 | 0.1 | 0.28 |")
    assert "| 4 | N | 2 | 1 |" in lines[3]
    assert "| 0.5 | 0.5 | 0 | 0 | 2 | 0 |" in lines[3]  # N's gaps, mean time and flags
    no_gaps = summary_markdown(mixed.drop(columns=["gap_to_bound"]))
    assert "| 3 | M | 8 | 3 | 1 | 1 | 1 | 1 | 0 | 1 | 2 | — | — | 0 |" in no_gaps  # missing shows as —
    assert "(no method rows)" in summary_markdown(mixed[mixed["role"] == "bound"])


# --------------------------------------------------------------------------- figures
def _lines(ax):
    return {ln.get_label(): ln for ln in ax.get_lines() if not ln.get_label().startswith("_")}


def test_profile_figure_draws_one_step_line_per_method(three):
    fig = plot_performance_profile(three, measure="objective")
    try:
        assert isinstance(fig, Figure)
        ax = fig.axes[0]
        lines = _lines(ax)
        assert set(lines) == {"A", "B", "C"}
        assert ax.get_xscale() == "log"
        assert "log2" in ax.get_xlabel() and "≤ τ" in ax.get_ylabel()
        assert "objective" in ax.get_title() and "3 instances" in ax.get_title()
        # C's line: 0 until 1.5, then 0.5 to the right end
        y = np.asarray(lines["C"].get_ydata(), dtype=float)
        assert y.min() == 0.0 and y.max() == pytest.approx(0.5)
    finally:
        plt.close(fig)


def test_profile_figure_on_a_given_axes(three):
    fig, axes = plt.subplots(1, 2)
    try:
        assert plot_performance_profile(three, measure="time", ax=axes[1]) is fig
        assert not axes[0].get_lines() and set(_lines(axes[1])) == {"A", "B", "C"}
        assert "time" in axes[1].get_title()
    finally:
        plt.close(fig)
    with pytest.raises(TypeError, match="ax"):
        plot_performance_profile(three, ax="left")


@pytest.mark.parametrize("case", ["empty", "one method", "all fail"])
def test_profile_figure_degenerate_cases(three, case):
    df = {
        "empty": three.iloc[0:0],
        "one method": three[three["method"] == "A"],
        "all fail": three.assign(status="timeout"),
    }[case]
    fig = plot_performance_profile(df)
    try:
        ax = fig.axes[0]
        texts = " ".join(t.get_text() for t in ax.texts)
        if case == "empty":
            assert not _lines(ax) and "no method rows" in texts
        elif case == "one method":
            assert set(_lines(ax)) == {"A"} and not texts
        else:
            assert set(_lines(ax)) == {"A", "B", "C"} and "no method solved" in texts
            assert all(np.all(np.asarray(ln.get_ydata()) == 0) for ln in _lines(ax).values())
        fig.canvas.draw()  # renders without error
    finally:
        plt.close(fig)


def test_gap_distribution_is_an_ecdf_per_method_and_size(mixed):
    fig = plot_gap_distribution(mixed, column="gap_to_bound")
    try:
        ax = fig.axes[0]
        lines = _lines(ax)
        assert set(lines) == {"M, size 3", "N, size 4"}
        assert lines["M, size 3"].get_linestyle() != lines["N, size 4"].get_linestyle()
        assert "gap_to_bound" in ax.get_title() and "gap_to_bound" in ax.get_xlabel()
        # M: 3 solved gaps 0, 0.1, 0.3 out of 8 runs -> steps 1/8, 2/8, 3/8 and stays at 3/8
        y = np.asarray(lines["M, size 3"].get_ydata(), dtype=float)
        assert y.tolist() == pytest.approx([0.0, 1 / 8, 2 / 8, 3 / 8, 3 / 8])
        x = np.asarray(lines["M, size 3"].get_xdata(), dtype=float)
        assert x[1:4].tolist() == pytest.approx([0.0, 0.1, 0.3])
    finally:
        plt.close(fig)


@pytest.mark.parametrize("case", ["empty", "one method", "all fail", "no columns"])
def test_gap_distribution_degenerate_cases(mixed, case):
    df = {
        "empty": mixed.iloc[0:0],
        "one method": mixed[mixed["method"] == "N"],
        "all fail": mixed.assign(status="error"),
        "no columns": pd.DataFrame(),
    }[case]
    fig = plot_gap_distribution(df, column="gap_to_best")
    try:
        ax = fig.axes[0]
        texts = " ".join(t.get_text() for t in ax.texts)
        if case == "one method":
            assert set(_lines(ax)) == {"N"} and not texts
        elif case == "all fail":
            assert not _lines(ax) and "no solved run has a gap_to_best" in texts
        else:
            assert not _lines(ax) and "no rows" in texts
        fig.canvas.draw()
    finally:
        plt.close(fig)
    with pytest.raises(ValueError, match="column"):
        plot_gap_distribution(mixed, column="gap")


# --------------------------------------------------------------------------- files
def test_write_study_outputs(tmp_path, mixed):
    pytest.importorskip("pyarrow")
    df = mixed.assign(message="ok")
    paths = write_study_outputs(df, tmp_path / "new" / "dir", stem="gap")
    names = {k: p.name for k, p in paths.items()}
    assert names == {
        "summary_csv": "gap_summary.csv",
        "summary_md": "gap_summary.md",
        "profile_objective": "gap_profile_objective.png",
        "profile_time": "gap_profile_time.png",
        "gaps": "gap_gaps.png",
        "rows": "gap_rows.parquet",
    }
    assert all(p.is_file() and p.stat().st_size > 0 for p in paths.values())
    assert pd.read_csv(paths["summary_csv"])["n"].tolist() == [8, 2]
    assert paths["summary_md"].read_text() == summary_markdown(df)
    back = pd.read_parquet(paths["rows"])
    pd.testing.assert_frame_equal(back, df)
    with pytest.raises(ValueError, match="stem"):
        write_study_outputs(df, tmp_path, stem="a/b")


def test_parquet_keeps_mixed_object_columns_as_json(tmp_path, mixed):
    pytest.importorskip("pyarrow")
    df = mixed.assign(cells_extra=[1, "a", {"k": 1}, None, 2.5, "b", "c", "d", 1, 2, 3])
    paths = write_study_outputs(df, tmp_path, stem="s")
    back = pd.read_parquet(paths["rows"])
    assert back["cells_extra"].tolist()[:3] == ["1", '"a"', '{"k": 1}'] and pd.isna(back["cells_extra"][3])
    pd.testing.assert_frame_equal(back.drop(columns="cells_extra"), df.drop(columns="cells_extra"))


def test_parquet_round_trip_of_a_store_frame(tmp_path):
    pytest.importorskip("pyarrow")
    from droneplan.studies.store import Outcome, ResultStore, build_rows

    with ResultStore(tmp_path / "r.sqlite") as store:
        for s in range(2):
            outcomes = [
                Outcome(
                    "ga", "heuristic", "feasible", objective=10.0 + s, time_s=0.5, extras={"sites": [1, s]}
                ),
                Outcome("milp", "model", "no_solution" if s else "optimal", objective=None if s else 12.0),
            ]
            store.write(build_rows("cells", f"t:seed={s}", seed=s, size=2, sense="max", outcomes=outcomes))
        df = store.frame()
    back = pd.read_parquet(write_study_outputs(df, tmp_path)["rows"])
    # the list-valued extra comes back as JSON text (missing as null); the rest unchanged
    assert back["cells_sites"].tolist()[0] == "[1, 0]" and pd.isna(back["cells_sites"].tolist()[1])
    # columns holding only empty strings come back as pandas' string dtype: same values, other dtype
    empty_text = [c for c in df.columns if df[c].dtype == object and (df[c] == "").all()]
    back = back.astype(dict.fromkeys(empty_text, object))
    pd.testing.assert_frame_equal(back.drop(columns="cells_sites"), df.drop(columns="cells_sites"))


def test_without_pyarrow_nothing_is_written(tmp_path, mixed, monkeypatch):
    import importlib.util

    real = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec", lambda name: None if name == "pyarrow" else real(name))
    with pytest.raises(ImportError, match="pip install pyarrow"):
        write_study_outputs(mixed, tmp_path / "out")
    assert not (tmp_path / "out").exists()


def test_profile_fractions_agree_with_counting_on_many_runs():
    """The profile counts with a sorted search (n log n), not an n_taus x n_runs matrix: 4000
    instances of two methods (a default grid of thousands of ratios) stay small, and every
    fraction equals the brute-force count of the method's ratios within the tolerance."""
    rng = np.random.default_rng(0)
    rows = []
    for k in range(4000):
        status = "infeasible" if k % 97 == 0 else "feasible"
        rows.append(_row(f"i{k}", "A", status, float(rng.uniform(1, 10)), float(rng.uniform(0.1, 2))))
        rows.append(_row(f"i{k}", "B", "feasible", float(rng.uniform(1, 10)), float(rng.uniform(0.1, 2))))
    df = pd.DataFrame(rows)
    prof = performance_profile(df)
    ratios = performance_ratios(df)
    for method in ("A", "B"):
        r = ratios.loc[ratios["method"] == method, "ratio"].to_numpy(dtype=float)
        g = prof[prof["method"] == method]
        taus, got = g["tau"].to_numpy(), g["fraction"].to_numpy()
        sample = rng.choice(len(taus), 200, replace=False)
        brute = [(r <= t * (1 + 1e-12)).mean() for t in taus[sample]]
        assert np.allclose(got[sample], brute, rtol=0, atol=1e-12)
        assert np.all(np.diff(got) >= 0) and got[-1] == pytest.approx(np.isfinite(r).mean())
