"""Gap studies with anytime traces and budgets: a user method's reports are scored like its final
plan and stored beside its row; CPU and evaluation budgets reach the methods that take them."""

from __future__ import annotations

import os
import time

import numpy as np
import pytest

import droneplan as dp
from droneplan.formulations.cells import evaluate, greedy_placement
from droneplan.studies.instances import family_instances

pytestmark = pytest.mark.skipif(not hasattr(os, "fork"), reason="the job runner is POSIX-only")


@pytest.fixture(scope="module")
def instances():
    return family_instances("table4.2", m=2, seeds=[0, 1])


def climbing(problem, *, seed, time_limit, report=None):
    """Reports an empty plan, then one drone-cell of the greedy plan, then the greedy plan."""
    plan = greedy_placement(problem)
    for k in range(len(plan) + 1):
        if report is not None:
            report(plan[:k])
    return plan


def boasting(problem, *, seed, time_limit, report=None):
    """Reports the greedy plan with an objective it does not reach."""
    plan = greedy_placement(problem)
    report(plan, objective=evaluate(problem, plan).covered + 5)
    return plan


def test_reports_become_a_scored_trace_beside_the_row(tmp_path, instances):
    rows = dp.gap("cells", methods=[("climb", climbing)], instances=instances, out=tmp_path, progress=False)
    traces = dp.load_traces(tmp_path)
    mine = rows[rows["method"] == "climb"]
    assert len(mine) == 2 and set(traces["instance"]) == set(mine["instance"])
    for inst in instances:
        trace = traces[traces["instance"] == inst.id].sort_values("seq")
        plan = greedy_placement(inst.data)
        want = [evaluate(inst.data, plan[:k]).covered for k in range(len(plan) + 1)]
        assert trace["objective"].tolist() == want
        assert (trace["status"] == "feasible").all() and trace["t"].is_monotonic_increasing
        row = mine[mine["instance"] == inst.id].iloc[0]
        assert row["cells_reports"] == len(want) and row["cells_trace_points"] == len(want)
    assert set(traces["config"]) == set(mine["config"])


def test_a_lying_report_flags_the_trace_and_the_row(tmp_path, instances):
    rows = dp.gap(
        "cells", methods=[("boast", boasting)], instances=instances[:1], out=tmp_path, progress=False
    )
    traces = dp.load_traces(tmp_path)
    assert traces["flag"].str.contains("claim-mismatch").all()
    assert "trace-claim-mismatch" in rows[rows["method"] == "boast"]["flag"].iloc[0]


def test_a_study_without_reporting_methods_has_no_traces(tmp_path, instances):
    dp.gap("cells", methods=["greedy"], instances=instances[:1], out=tmp_path, progress=False)
    traces = dp.load_traces(tmp_path)
    assert traces.empty and "objective" in traces.columns


def test_the_ga_reports_and_keeps_to_an_evaluation_budget(tmp_path, instances):
    rows = dp.gap(
        "cells", methods=["ga"], instances=instances[:1], out=tmp_path, progress=False, max_evaluations=3000
    )
    ga = rows[rows["method"] == "ga"].iloc[0]
    assert 0 < ga["cells_evaluations"] <= 3000
    trace = dp.load_traces(tmp_path)
    assert len(trace) >= 1 and trace["objective"].iloc[-1] == ga["objective"]


def spinning(problem, *, seed, time_limit):
    """Ignores its limits and computes for a long time."""
    end, spins = time.process_time() + 60.0, 0
    while time.process_time() < end:
        spins += 1
    return np.zeros((0, 2)) if spins else None


def frugal(problem, *, seed, time_limit, cpu_limit=None):
    """Records the CPU budget it was given."""
    return dp.SolveResult(dp.Status.FEASIBLE, x=greedy_placement(problem), info={"evaluations": cpu_limit})


def test_a_cpu_limit_stops_a_method_and_reaches_those_that_take_it(tmp_path, instances):
    rows = dp.gap(
        "cells",
        methods=[("spin", spinning), ("frugal", frugal)],
        instances=instances[:1],
        out=tmp_path,
        progress=False,
        cpu_limit=1.0,
    )
    spin = rows[rows["method"] == "spin"].iloc[0]
    assert spin["status"] == "timeout" and "CPU limit" in spin["message"]
    assert spin["cells_cpu_s"] < 10.0
    assert rows[rows["method"] == "frugal"].iloc[0]["cells_evaluations"] == 1.0


@pytest.mark.parametrize(
    ("field", "value"), [("cpu_limit", 0), ("cpu_limit", float("nan")), ("max_evaluations", 0)]
)
def test_bad_budgets_are_refused_in_one_line(tmp_path, instances, field, value):
    with pytest.raises(ValueError, match=field):
        dp.gap(
            "cells",
            methods=["greedy"],
            instances=instances[:1],
            out=tmp_path,
            progress=False,
            **{field: value},
        )


@pytest.mark.parametrize(
    ("flag", "value", "words"),
    [
        ("--cpu-limit", "abc", "must be a number"),
        ("--cpu-limit", "0", "cpu_limit must be"),
        ("--max-evaluations", "1.5", "must be a number"),
        ("--max-evaluations", "0", "max_evaluations must be"),
    ],
)
def test_cli_refuses_bad_budgets_in_one_line(tmp_path, flag, value, words):
    from droneplan.studies import cli

    args = [
        "gap",
        "cells",
        "--method",
        "greedy",
        "--m",
        "1",
        "--seeds",
        "1",
        flag,
        value,
        "--out",
        str(tmp_path),
    ]
    with pytest.raises(SystemExit) as info:
        cli.main(args)
    text = str(info.value.code)
    assert text.startswith(f"droneplan: {flag}") and words in text and "\n" not in text
    with pytest.raises(SystemExit, match=f"^droneplan: {flag} goes with an open study"):
        cli.main(["gap", "cells", "--seeds", "1", flag, "3", "--out", str(tmp_path)])


def test_anytime_summary_and_figures_of_a_study(tmp_path, instances):
    import matplotlib.pyplot as plt

    rows = dp.gap(
        "cells", methods=[("climb", climbing), "greedy"], instances=instances, out=tmp_path, progress=False
    )
    traces = dp.load_traces(tmp_path)
    table = dp.anytime_summary(rows, traces).set_index("method")
    assert list(table.index) == ["climb"] and table.loc["climb", "runs"] == 2
    # the climb ends at the greedy plan: its final gap is the greedy's gap to the best known plan
    assert 0 <= table.loc["climb", "final_gap_median"] <= 1
    assert table.loc["climb", "primal_integral_median"] > 0
    for plot in (dp.plot_anytime, dp.plot_anytime_ecdf):
        fig = plot(rows, traces)
        assert fig.axes[0].get_lines()
        plt.close(fig)
    empty = dp.plot_anytime(rows, traces.iloc[0:0])
    assert "no method reported" in empty.axes[0].texts[0].get_text()
    plt.close(empty)


def test_the_cli_writes_the_anytime_figures(tmp_path):
    from droneplan.studies import cli

    args = ["gap", "cells", "--method", "ga", "--m", "1", "--seeds", "1", "--max-evaluations", "2000"]
    code = cli.main([*args, "--out", str(tmp_path)])
    assert code == 0
    for name in ("gap_anytime.png", "gap_anytime_ecdf.png", "gap_anytime.csv"):
        assert (tmp_path / "cells" / name).stat().st_size > 0
