"""The speed summary: each goal beside its measured value, with wall, CPU and load recorded.

No timing is asserted (timings belong to ``droneplan bench``): the tests check what each row
says against what was measured, and that bad input is refused by name.
"""

from __future__ import annotations

import json
import math
import re

import pytest

from droneplan.studies import bench_summary as bs


def test_an_import_row_lists_no_heavy_library_and_judges_its_goal():
    row = bs.measure_import(repeats=1)
    assert row.quantity.startswith("import droneplan,")
    assert "heavy libraries loaded: none" in row.note
    assert row.value == row.wall > 0 and row.cpu >= 0
    assert row.met == (row.value <= bs.IMPORT_GOAL_S)
    doors = bs.measure_import(doors=True, repeats=1)
    assert "every front door" in doors.quantity and "heavy libraries loaded: none" in doors.note


def test_a_herding_row_is_simulated_time_over_cpu_time():
    row = bs.measure_herding(30, t_max=2.0)
    # 2 s at the thesis's 0.2 s step: the ratio is the simulated time over the CPU time
    assert row.value == pytest.approx(2.0 / row.cpu, rel=1e-9)
    assert row.goal == "—" and row.met is None  # no goal for 30 animals
    assert row.wall > 0 and (math.isnan(row.load) or row.load >= 0)


def test_a_goal_is_met_only_when_the_measured_value_reaches_it(monkeypatch):
    monkeypatch.setitem(bs.HERDING_GOALS, 30, 1e-6)
    assert bs.measure_herding(30, t_max=1.0).met is True
    monkeypatch.setitem(bs.HERDING_GOALS, 30, 1e12)
    row = bs.measure_herding(30, t_max=1.0)
    assert row.goal == ">= 1e+12" and row.met is False


def test_the_summary_table_and_files(tmp_path, monkeypatch):
    monkeypatch.setattr(
        bs, "measure_import", lambda **kw: bs.BenchRow("import", "<= 0.5", 0.2, True, 0.2, 0.1, 1.0)
    )
    monkeypatch.setattr(
        bs,
        "measure_gap",
        lambda problem, **kw: bs.gap_row(problem, instances=2, wall=8.0, cpu=12.0, load=1.0),
    )
    monkeypatch.setattr(
        bs, "measure_reproduce", lambda out, **kw: bs.reproduce_row(wall=150.0, cpu=280.0, load=0.5, note="x")
    )
    rows = bs.bench_summary(sizes=(20,))
    kinds = [
        "import",
        "import",
        "herding",
        "gap",
        "gap",
        "gap",
        "gap",
        "droneplan reproduce --quick (s wall)",
    ]
    assert [r.quantity.split(",")[0] for r in rows] == kinds
    assert [r.quantity for r in rows[3:7]] == [f"gap, {p} (s wall per instance)" for p in bs.GAP_GOALS]
    text = bs.summary_markdown(rows)
    assert text.count("\n") == 2 + len(rows)
    assert "| <= 0.5 | 0.200 | yes |" in text
    assert "| gap, covert (s wall per instance) | <= 30 | 4.000 | yes |" in text
    assert "| droneplan reproduce --quick (s wall) | <= 120 | 150.0 | NO |" in text
    path = bs.write_summary(rows, tmp_path / "out")
    assert path.read_text() == text
    saved = json.loads((tmp_path / "out" / "bench_summary.json").read_text())
    assert [r["value"] for r in saved] == [r.value for r in rows]


def test_a_gap_row_is_wall_time_per_instance_with_cpu_per_instance_in_its_note():
    row = bs.gap_row("covert", instances=4, wall=100.0, cpu=180.0, load=2.5, note="how")
    assert row.value == 25.0 and row.goal == "<= 30" and row.met is True
    assert (row.wall, row.cpu, row.load) == (100.0, 180.0, 2.5)
    assert row.note == "4 instances, 45.0 CPU-s per instance; how"
    slow = bs.gap_row("covert", instances=1, wall=31.0, cpu=40.0, load=0.0)
    assert slow.met is False
    other = bs.gap_row("shark", instances=3, wall=9.0, cpu=6.0, load=0.0)
    assert other.goal == "—" and other.met is None and other.value == 3.0


def test_the_reproduce_row_reads_a_runs_time_table(tmp_path):
    from droneplan.studies.jobs import JobTiming, time_table

    timings = [
        JobTiming("a", "covert case 1", start=10.0, end=40.0, wall=30.0, cpu=25.0),
        JobTiming("b", "shark table 5.2", start=12.0, end=70.0, wall=58.0, cpu=50.0),
    ]
    time_table(timings).to_csv(tmp_path / "reproduce_times.csv", index=False)
    row = bs.reproduce_row_from_times(tmp_path)  # the run's directory or the file itself
    assert row == bs.reproduce_row_from_times(tmp_path / "reproduce_times.csv")
    assert row.value == row.wall == 60.0 and row.cpu == 75.0 and math.isnan(row.load)
    assert row.goal == "<= 120" and row.met is True and "2 jobs of covert, shark;" in row.note
    (tmp_path / "other.csv").write_text("section,jobs,cpu_s,job_wall_s,span_s\ncovert,1,1.0,1.0,1.0\n")
    with pytest.raises(ValueError, match=r"^path: .* has no 'total' row"):
        bs.reproduce_row_from_times(tmp_path / "other.csv")
    (tmp_path / "foreign.csv").write_text("a,b\n1,2\n")
    with pytest.raises(ValueError, match=r"^path: .* lacks the columns"):
        bs.reproduce_row_from_times(tmp_path / "foreign.csv")
    # the summary reads a given table before it measures anything, so a bad path fails at once
    with pytest.raises(ValueError, match=r"^path: .* lacks the columns"):
        bs.bench_summary(sizes=(), gap_problems=(), reproduce_times=tmp_path / "foreign.csv")


def test_bench_cli_summary_options(tmp_path):
    """--summary-only and --reproduce-times go with 'bench all'; a bad times file exits in one line."""
    from droneplan.studies import cli

    for argv in (["bench", "cells", "--summary-only"], ["bench", "cells", "--reproduce-times", "x.csv"]):
        with pytest.raises(SystemExit, match="goes with 'bench all'"):
            cli.main([*argv, "--out", str(tmp_path)])
    with pytest.raises(SystemExit, match="applies to 'bench cells'"):
        cli.main(["bench", "herding", "--time-limit", "5", "--out", str(tmp_path)])
    with pytest.raises(SystemExit, match=r"^droneplan: time_limit"):
        cli.main(["bench", "cells", "--time-limit", "-5", "--out", str(tmp_path)])
    with pytest.raises(SystemExit):  # argparse: not a number
        cli.main(["bench", "cells", "--time-limit", "soon", "--out", str(tmp_path)])
    (tmp_path / "foreign.csv").write_text("a,b\n1,2\n")
    argv = ["bench", "all", "--summary-only", "--reproduce-times", str(tmp_path / "foreign.csv")]
    with pytest.raises(SystemExit, match=r"^droneplan: path: .* lacks the columns"):
        cli.main([*argv, "--out", str(tmp_path)])


def test_a_gap_study_is_timed_in_a_child_process(tmp_path):
    row = bs.measure_gap("shark", seeds=1, out=tmp_path / "gap", workers=2)
    # one random path and one random fleet; the value is the wall time over those two instances
    assert row.note.startswith("2 instances,") and row.value == pytest.approx(row.wall / 2)
    assert row.cpu > 0 and row.goal == "—"
    with pytest.raises(ValueError, match=r"^out must not hold a results store"):
        bs.measure_gap("shark", seeds=1, out=tmp_path / "gap")


@pytest.mark.parametrize(
    ("call", "name", "error"),
    [
        (lambda: bs.measure_herding(0), "n_animals", ValueError),
        (lambda: bs.measure_herding(10, t_max=-1.0), "t_max", ValueError),
        (lambda: bs.measure_herding(10, repeats=0), "repeats", ValueError),
        (lambda: bs.measure_herding(2.5), "n_animals", TypeError),
        (lambda: bs.measure_import(repeats=0), "repeats", ValueError),
        (lambda: bs.bench_summary(sizes=(200, -1)), "sizes[1]", ValueError),
        (lambda: bs.bench_summary(sizes=(), gap_problems=("cells", "x")), "gap_problems[1]", ValueError),
        (lambda: bs.gap_row("x", instances=1, wall=1.0, cpu=1.0, load=0.0), "problem", ValueError),
        (lambda: bs.gap_row("cells", instances=0, wall=1.0, cpu=1.0, load=0.0), "instances", ValueError),
        (lambda: bs.measure_gap("cells", seeds=0, out="unused"), "seeds", ValueError),
    ],
)
def test_bad_input_is_refused_by_name(call, name, error):
    with pytest.raises(error, match="^" + re.escape(name)):
        call()
