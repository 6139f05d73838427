"""No package code, test, documentation page or notebook cites the design card or an issue number.

A comment, docstring or page states the decision itself; "DESIGN §4" or "issue 12 item 7"
points a reader at a document they may not have and that can change under them.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from droneplan._layers import LAYERS

ROOT = Path(__file__).resolve().parents[1]
FOLDERS = (*LAYERS, "droneplan", "tests", "docs", "notebooks")
THIS_FILE = Path(__file__).resolve()  # its examples of citations are what the pattern must catch
TOP_FILES = ("README.md", "CHANGELOG.md")
SUFFIXES = {".py", ".md", ".ipynb", ".txt", ".yml", ".yaml", ".toml", ".cfg"}

DESIGN_CARD = re.compile(r"\bDESIGN\b|\bdesign card\b")  # "DESIGN §4", "DESIGN.md"; "design" alone is a word
ISSUE = re.compile(r"\bissues?\s*#?\s*\d+|/issues/\d+", re.IGNORECASE)  # "issue 12", "Issue #12", a link


def _cites(line: str) -> bool:
    """True when ``line`` cites the design card or an issue."""
    return bool(DESIGN_CARD.search(line) or ISSUE.search(line))


def _files() -> list[Path]:
    found = [ROOT / name for name in TOP_FILES if (ROOT / name).is_file()]
    for folder in FOLDERS:
        found += [
            p
            for p in sorted((ROOT / folder).rglob("*"))
            if p.is_file() and p.suffix in SUFFIXES and "__pycache__" not in p.parts and p != THIS_FILE
        ]
    return found


def test_the_scan_covers_every_layer_the_docs_and_the_notebooks():
    files = _files()
    for folder in FOLDERS:
        assert any(p.is_relative_to(ROOT / folder) for p in files), f"nothing scanned under {folder}/"
    assert len(files) > 100


@pytest.mark.parametrize(
    "line",
    [
        "# rotation so |a| = 1 (DESIGN §4: U_max is the heading rate)",
        "see DESIGN.md for the decision",
        "nothing: issue 12 item 7), so E_i is put",
        "the thesis states neither rule (our choice, Issue #12)",
        "as the design card lists",
        "https://github.com/owner/repo/issues/45",
    ],
)
def test_the_pattern_catches_a_citation(line):
    assert _cites(line)


@pytest.mark.parametrize(
    "line",
    ["the design of record is docs/architecture.md", "a known issue with HiGHS 1.15", "issue the command"],
)
def test_the_pattern_leaves_ordinary_words(line):
    assert not _cites(line)


def test_no_design_or_issue_citations():
    hits = []
    for path in _files():
        text = path.read_text(encoding="utf-8", errors="replace")
        for number, line in enumerate(text.splitlines(), 1):
            if _cites(line):
                hits.append(f"{path.relative_to(ROOT)}:{number}: {line.strip()[:100]}")
    assert not hits, "state the decision instead of citing it:\n" + "\n".join(hits)
