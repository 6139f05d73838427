"""The reproduction report: every table beside the thesis, every figure, and only valid references."""

from __future__ import annotations

import csv
import html
import io
from html.parser import HTMLParser
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import pytest

from droneplan.studies.cli import _parser
from droneplan.studies.common import ComparisonTable
from droneplan.studies.thesis.report import (
    DEVIATIONS,
    PROBLEMS,
    REPORT_NAME,
    deviations_markdown,
    write_report,
)

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


class _Page(HTMLParser):
    """Collects references (src/href), element ids, and table rows as lists of cell texts."""

    def __init__(self) -> None:
        super().__init__()
        self.refs: list[str] = []
        self.ids: set[str] = set()
        self.rows: list[list[str]] = []
        self._row: list[str] | None = None
        self._cell: list[str] | None = None

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        for key in ("src", "href"):
            if a.get(key):
                self.refs.append(a[key])
        if a.get("id"):
            self.ids.add(a["id"])
        if tag == "tr":
            self._row = []
        elif tag in ("td", "th"):
            self._cell = []

    def handle_endtag(self, tag):
        if tag in ("td", "th") and self._row is not None and self._cell is not None:
            self._row.append("".join(self._cell).strip())
            self._cell = None
        elif tag == "tr" and self._row is not None:
            self.rows.append(self._row)
            self._row = None

    def handle_data(self, data):
        if self._cell is not None:
            self._cell.append(data)


def check_report(page: Path) -> _Page:
    """Parse ``page``; every reference must be an anchor on the page or an existing, valid file."""
    parsed = _Page()
    parsed.feed(page.read_text(encoding="utf-8"))
    for ref in parsed.refs:
        assert "://" not in ref, f"{ref}: the report must be self-contained (no remote references)"
        if ref.startswith("#"):
            assert ref[1:] in parsed.ids, f"anchor {ref} has no target"
            continue
        target = page.parent / ref
        assert target.is_file(), f"{ref} does not exist"
        if target.suffix == ".png":
            data = target.read_bytes()
            assert data.startswith(PNG_SIGNATURE), f"{ref} is not a PNG"
            assert plt.imread(target).size > 0, f"{ref} does not decode"
        elif target.suffix == ".csv":
            assert list(csv.reader(io.StringIO(target.read_text(encoding="utf-8")))), f"{ref} is empty"
        else:
            raise AssertionError(f"{ref}: unexpected file type")
    return parsed


@pytest.fixture
def out(tmp_path) -> Path:
    cells = tmp_path / "cells"
    table = ComparisonTable("Table 4.3: covered users")
    table.add("m = 2, GA", 120.0, 121.0, "median over 3 seeds")
    table.add("m = 2, time (s)", 202.0, 1.5, "one run, loaded machine")
    table.emit(cells, "table_4_3")
    fig, ax = plt.subplots(figsize=(2, 2))
    ax.plot([0, 1], [0, 1])
    fig.savefig(cells / "fig_4_4_map.png")
    plt.close(fig)
    (cells / "gap_rows.csv").write_text("instance,method,objective\n0,ga,10\n")
    shark = tmp_path / "shark"
    shark.mkdir()
    with (shark / "table_5_2.csv").open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["quantity", "thesis", "this run", "deviation", "flag", "how measured"])
        w.writerow(["path a", "2.0", "3.1", "+55%", "!", "virtual shark, Ts = 0.1 s"])
    return tmp_path


def test_report_shows_every_table_beside_the_thesis_and_every_figure(out):
    page = write_report(out)
    assert page == out / REPORT_NAME
    parsed = check_report(page)
    rows = {r[0]: r for r in parsed.rows if r}
    assert rows["m = 2, GA"][1:3] == ["120", "121"]  # thesis beside this run, as emitted
    assert rows["path a"][:4] == ["path a", "2.0", "3.1", "+55%"]  # the deviation column is shown
    assert "cells/fig_4_4_map.png" in parsed.refs
    assert "cells/gap_rows.csv" in parsed.refs  # non-table data is linked, not tabulated
    assert "gap_rows" not in parsed.ids
    text = page.read_text()
    assert 'class="flagged unexplained"' in text  # beyond the threshold without a reason: highlighted
    for problem in PROBLEMS:
        assert problem in parsed.ids
        for dev in DEVIATIONS[problem]:  # a note per deliberate deviation
            assert html.escape(dev.why) in text
    assert "Not reproduced in this run" in text  # covert and herding have no directory here


def test_report_rejects_a_missing_directory_and_unknown_problems(tmp_path):
    with pytest.raises(ValueError, match="out"):
        write_report(tmp_path / "nowhere")
    with pytest.raises(ValueError, match="problems"):
        write_report(tmp_path, problems=["cells", "boats"])
    with pytest.raises(ValueError, match="problem"):
        deviations_markdown("boats")


def test_check_report_catches_a_missing_image(out):
    page = write_report(out)
    (out / "cells" / "fig_4_4_map.png").unlink()
    with pytest.raises(AssertionError, match="does not exist"):
        check_report(page)


def test_reproduce_has_a_report_flag():
    assert _parser().parse_args(["reproduce", "--quick", "--report"]).report is True
    assert _parser().parse_args(["reproduce"]).report is False


def test_every_problem_has_deviation_notes_as_a_markdown_table():
    for problem in PROBLEMS:
        table = deviations_markdown(problem).splitlines()
        assert table[0] == "| where | thesis | here | why |"
        assert len(table) == 2 + len(DEVIATIONS[problem])
        assert all(line.count(" | ") == 3 for line in table[2:]), "a '|' inside a note must be escaped"


def test_report_states_the_machine_code_and_run_time(out):
    """With a results store and a time table in the folder, the page says which machine and code
    made the rows and how long the last reproduce took, per section; without them it says nothing."""
    assert 'id="run"' not in write_report(out).read_text()
    from droneplan.studies.jobs import TIMES_NAME
    from droneplan.studies.store import COLUMNS, STORE_NAME, ResultStore

    row = dict.fromkeys(COLUMNS)
    row.update(study="t", problem="cells", instance="t:seed=0", method="ga", role="heuristic", sense="max")
    row.update(status="feasible", objective=3.0, bound_kind="none", config="", cpu="Test CPU 9000", cores=2)
    row.update(
        git_commit="deadbeef", code_hash="c0de", droneplan_version="0.1.0", finished_at="2026-11-26T01:00:00"
    )
    with ResultStore(out / STORE_NAME) as st:
        st.write([row])
    (out / TIMES_NAME).write_text(
        "section,jobs,cpu_s,job_wall_s,span_s\ncells table 4.3,3,10.0,10.5,6.0\ntotal,3,10.0,10.5,6.2\n"
    )
    text = write_report(out).read_text()
    assert 'id="run"' in text
    assert "Test CPU 9000 (2 cores)" in text and "commit deadbeef" in text
    assert "took 6 s of wall time and 10 CPU seconds in its 3 jobs" in text
    assert "<td>cells table 4.3</td><td>3</td><td>10.0</td><td>6.0</td>" in text
