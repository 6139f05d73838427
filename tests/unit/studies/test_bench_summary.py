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
    rows = bs.bench_summary(sizes=(20,))
    assert [r.quantity.split(",")[0] for r in rows] == ["import", "import", "herding"]
    text = bs.summary_markdown(rows)
    assert text.count("\n") == 2 + len(rows)
    assert "| <= 0.5 | 0.200 | yes |" in text
    path = bs.write_summary(rows, tmp_path / "out")
    assert path.read_text() == text
    saved = json.loads((tmp_path / "out" / "bench_summary.json").read_text())
    assert [r["value"] for r in saved] == [r.value for r in rows]


@pytest.mark.parametrize(
    ("call", "name", "error"),
    [
        (lambda: bs.measure_herding(0), "n_animals", ValueError),
        (lambda: bs.measure_herding(10, t_max=-1.0), "t_max", ValueError),
        (lambda: bs.measure_herding(10, repeats=0), "repeats", ValueError),
        (lambda: bs.measure_herding(2.5), "n_animals", TypeError),
        (lambda: bs.measure_import(repeats=0), "repeats", ValueError),
        (lambda: bs.bench_summary(sizes=(200, -1)), "sizes[1]", ValueError),
    ],
)
def test_bad_input_is_refused_by_name(call, name, error):
    with pytest.raises(error, match="^" + re.escape(name)):
        call()
