"""Every reproduce row beyond the deviation threshold carries a reason; speed rows are speed-ups."""

from __future__ import annotations

import csv
import re
from pathlib import Path

import pandas as pd
import pytest

from droneplan.studies.common import ComparisonTable
from droneplan.studies.thesis.report import (
    FLAG_REASONS,
    PROBLEMS,
    flag_reasons,
    flag_reasons_markdown,
    write_report,
)

DOCS = Path(__file__).resolve().parents[3] / "docs" / "problems"

CASE = "Case {}: maximum recorded bearing change (Fig. 3.{})"
T43 = (
    "Table 4.3 - computing time and GA success (thesis instance vs ours, seed 0; "
    "exact optimum by the branch and bound)"
)
F43 = "Fig. 4.3 - GA success without / with restarts (m=2, P=100)"
ABLATION = (
    "GA ablation - P_Global vs exhaustive search (the thesis's criterion) / vs the exact optimum, "
    "2 thesis-scale seeds; per-seed rows in ga_ablation_seeds.csv"
)
T52 = "Shark ch. 5: Table 5.2 (interception distance)"
F67 = "Fig. 6.7: gathering and total herding time (4 drones, 1200 m x 600 m field)"

# Every row that `droneplan reproduce <problem> --quick` flagged (deviation beyond 25 %), one problem
# at a time on 25 Nov 2026: (problem, table title, quantity, thesis value, value of that run).
QUICK_FLAGGED = [
    ("covert", CASE.format(1, 10), "beta_max sliding mode (deg)", 15.5, 21.18),
    ("covert", CASE.format(1, 10), "reduction sliding vs hover (%)", -28.9, -6.726),
    ("covert", CASE.format(2, 14), "beta_max hover benchmark (deg)", 32.2, 17.51),
    ("covert", CASE.format(2, 14), "beta_max sliding mode (deg)", 22.2, 13.37),
    ("covert", CASE.format(2, 14), "reduction sliding vs hover (%)", -33.1, -23.65),
    ("cells", T43, "m=1 P_Global vs ES (thesis criterion)", 1.0, 0.3333),
    ("cells", T43, "m=1 P_Global vs exact optimum", 1.0, 0.3333),
    ("cells", T43, "m=2 P_Global vs ES (thesis criterion)", 1.0, 0.0),
    ("cells", T43, "m=2 P_Global vs exact optimum", 1.0, 0.0),
    ("cells", T43, "m=3 P_Global vs ES (thesis criterion)", 1.0, 0.0),
    ("cells", T43, "m=3 P_Global vs exact optimum", 1.0, 0.0),
    ("cells", F43, "success 1 x 2000 iterations", 0.12, 0.0),
    ("cells", F43, "success 40 restarts x 50 iterations", 0.92, 0.0),
    ("cells", ABLATION, "m=1 thesis GA (Tables 4.1, 4.3): P_Global vs ES", 1.0, 0.1667),
    ("cells", ABLATION, "m=2 thesis GA (Tables 4.1, 4.3): P_Global vs ES", 1.0, 0.5),
    ("shark", T52, "Table 5.2 (d): interception distance, virtual shark (m)", 21.26, 26.95),
    ("herding", F67, "200 animals: benchmark minus proposed, total (min)", 3.3, 5.983),
    ("herding", F67, "1000 animals: proposed gathering time (min)", 10.1, 13.39),
    ("herding", F67, "1000 animals: benchmark minus proposed, total (min)", 4.1, 1.823),
]


def test_a_flagged_row_without_a_reason_is_reported():
    t = ComparisonTable("Table X")
    t.add("within", 10.0, 11.0, "one run")
    t.add("beyond", 10.0, 20.0, "one run")
    assert [r["flag"] for r in t.rows] == ["ok", "!"]
    assert t.unexplained() == ["beyond"]
    assert "WITHOUT A REASON: beyond" in t.render(width=100)
    t.add("beyond, explained", 10.0, 20.0, "one run", why="a measured cause")
    assert t.unexplained() == ["beyond"]  # the explained row is not listed
    assert t.rows[-1]["why"] == "a measured cause"


def test_the_explainer_fills_flagged_rows_only_and_why_adds_the_measurement():
    seen = []

    def explain(title, quantity):
        seen.append((title, quantity))
        return "the reason [backed]" if quantity.startswith("x") else ""

    t = ComparisonTable("T", explain=explain)
    t.add("x within", 1.0, 1.1, "", why="detail")  # within the threshold: no reason shown
    t.add("x beyond", 1.0, 3.0, "", why="measured 3")
    t.add("y beyond", 1.0, 3.0, "")
    t.add("x statement", "< 1", "0.5", "")  # no deviation: nothing to explain
    assert [r["why"] for r in t.rows] == ["", "the reason [backed]; measured 3", "", ""]
    assert seen == [("T", "x beyond"), ("T", "y beyond")]
    assert t.unexplained() == ["y beyond"]


def test_speed_rows_are_speed_ups_never_flags(tmp_path):
    t = ComparisonTable("Times")
    t.add("T_ES (s)", 0.78, 0.0527, "wall time", kind="speed")  # 14.8x faster
    t.add("T_GA (s)", 8.1, 16.2, "wall time", kind="speed")  # 2x slower: still no fidelity flag
    t.add("T_ES (s), stopped", 1449, "20 (stopped at 20 s)", "wall time", kind="speed")
    t.add("T (s), big", 276970, 10.0, "wall time", kind="speed")
    df = t.frame()
    assert list(df["deviation"]) == ["15x faster", "2x slower", "", "27697x faster"]
    assert list(df["flag"]) == ["", "", "", ""]
    assert t.unexplained() == []
    t.emit(tmp_path, "times")
    assert pd.read_csv(tmp_path / "times.csv", keep_default_na=False)["deviation"].iloc[0] == "15x faster"


def test_columns_and_bad_arguments(tmp_path):
    t = ComparisonTable("T")
    t.add("q", 2.0, 1.0, "how", why="w")
    t.emit(tmp_path, "t")
    header = next(csv.reader((tmp_path / "t.csv").open()))
    assert header == ["quantity", "thesis", "this run", "deviation", "flag", "how measured", "why"]
    assert "| q | 2 | 1 | -50% | ! | how | w |" in (tmp_path / "t.md").read_text()
    with pytest.raises(ValueError, match="kind"):
        t.add("q", 1.0, 1.0, "", kind="time")
    with pytest.raises(TypeError, match="why"):
        t.add("q", 1.0, 1.0, "", why=None)  # type: ignore[arg-type]


@pytest.mark.parametrize(("problem", "title", "quantity", "thesis", "ours"), QUICK_FLAGGED)
def test_every_row_the_quick_reproduction_flags_has_a_reason(problem, title, quantity, thesis, ours):
    t = ComparisonTable(title, explain=flag_reasons(problem))
    t.add(quantity, thesis, ours, "as in the reproduction")
    assert t.rows[0]["flag"] == "!"
    assert t.unexplained() == [], f"{problem}: {title}: {quantity} has no reason"


def test_table_4_3_times_are_speed_ups_with_the_thesis_machine_as_reason():
    t = ComparisonTable(T43, explain=flag_reasons("cells"))
    t.add("m=1 T_ES (s)", 0.78, 0.07329, "wall time", kind="speed")
    t.add("m=2 T_GA (s)", 8.1, 1.053, "wall time", kind="speed")
    assert [(r["deviation"], r["flag"]) for r in t.rows] == [("11x faster", ""), ("7.7x faster", "")]
    assert all("§4.4" in r["why"] and "MATLAB" in r["why"] for r in t.rows)


def test_every_reason_is_one_line_and_cites_the_thesis_or_a_measurement():
    cites = re.compile(r"§\d|Fig\. ?\d|Figs \d|Table \d|Prop\. \d|measured")
    assert set(FLAG_REASONS) == set(PROBLEMS)
    for problem, entries in FLAG_REASONS.items():
        for e in entries:
            assert e.reason and "\n" not in e.reason and "\n" not in e.backing, e.where
            assert cites.search(e.backing), f"{problem}: {e.where}: backing cites nothing"
            re.compile(e.table), re.compile(e.rows)
    with pytest.raises(ValueError, match="problem"):
        flag_reasons("boats")
    with pytest.raises(ValueError, match="problem"):
        flag_reasons_markdown("boats")


@pytest.mark.parametrize("problem", PROBLEMS)
def test_the_problem_page_repeats_the_reasons(problem):
    page = (DOCS / f"{problem}.md").read_text(encoding="utf-8")
    assert flag_reasons_markdown(problem) in page, (
        f"docs/problems/{problem}.md must hold flag_reasons_markdown({problem!r}) verbatim"
    )


def test_the_report_lists_flagged_rows_with_their_reason_and_marks_those_without(tmp_path):
    t = ComparisonTable("Table 5.2 (interception distance)", explain=flag_reasons("shark"))
    t.add("Table 5.2 (d): interception distance, virtual shark (m)", 21.26, 26.95, "one run")
    t.add("a quantity nobody explains", 1.0, 2.0, "one run")
    t.add("m=1 T_ES (s)", 0.78, 0.05, "wall time", kind="speed")
    t.emit(tmp_path / "shark", "table_5_2")
    text = write_report(tmp_path, problems=["shark"]).read_text(encoding="utf-8")
    assert "Rows beyond the threshold (2) and why" in text
    assert "the shark paths are our shapes" in text
    assert text.count("NO REASON GIVEN") == 1
    assert 'class="flagged unexplained"' in text
    assert "16x faster" in text
