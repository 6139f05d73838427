"""The documentation site builds with warnings as errors and covers every public name.

`mkdocs build --strict` fails on a broken link or anchor, a missing snippet (the quickstart and
install pages include README.md's command blocks) and an API entry mkdocstrings cannot resolve.
"""

from __future__ import annotations

import ast
import html
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
FRONT_DOORS = ("covert", "cells", "shark", "herding")


def _build(config: Path, site: Path, extra_env: dict[str, str] | None = None) -> subprocess.CompletedProcess:
    env = {**os.environ, "NO_MKDOCS_2_WARNING": "1", **(extra_env or {})}
    return subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "-f", str(config), "-d", str(site)],
        capture_output=True,
        text=True,
        env=env,
        timeout=600,
    )


def _all(door: str) -> list[str]:
    tree = ast.parse((ROOT / "droneplan" / f"{door}.py").read_text())
    for node in tree.body:
        if isinstance(node, ast.Assign) and any(getattr(t, "id", None) == "__all__" for t in node.targets):
            return list(ast.literal_eval(node.value))
    raise AssertionError(f"droneplan/{door}.py has no __all__")


@pytest.fixture(scope="module")
def site(tmp_path_factory) -> Path:
    # A small reproduction report of our own (not whatever results/ holds on this machine).
    import matplotlib.pyplot as plt

    from droneplan.studies.common import ComparisonTable
    from droneplan.studies.thesis.report import write_report

    out = tmp_path_factory.mktemp("results")
    table = ComparisonTable("Table 4.3")
    table.add("m = 2, GA users", 120.0, 118.0, "one seed")
    table.emit(out / "cells", "table_4_3")
    fig, ax = plt.subplots(figsize=(2, 2))
    ax.plot([0, 1], [1, 0])
    fig.savefig(out / "cells" / "map.png")
    plt.close(fig)
    write_report(out)
    site = tmp_path_factory.mktemp("site")
    proc = _build(ROOT / "mkdocs.yml", site, {"DRONEPLAN_REPORT_DIR": str(out)})
    assert proc.returncode == 0, f"mkdocs build --strict failed:\n{proc.stdout}\n{proc.stderr}"
    return site


def test_site_includes_the_last_reproduction_report(site):
    assert 'href="report/report.html"' in (site / "reproduction.html").read_text()
    for rel in ("report/report.html", "report/cells/table_4_3.csv", "report/cells/map.png"):
        assert (site / rel).is_file(), f"the site lacks {rel}"
    assert (site / "report/cells/map.png").read_bytes().startswith(b"\x89PNG")


def test_site_has_a_page_per_problem(site):
    for door in FRONT_DOORS:
        page = site / "problems" / f"{door}.html"
        assert page.is_file(), f"no page for {door}"
        text = page.read_text()
        sections = ("The thesis model", "Our explicit model", "What is proven", "Deviations from the thesis")
        for section in sections:
            assert section in text, f"problems/{door}: no section {section!r}"


def test_api_pages_name_every_public_name(site):
    for door in FRONT_DOORS:
        html = (site / "api" / f"{door}.html").read_text()
        ids = set(re.findall(r'id="(droneplan\.[\w.]+)"', html))
        missing = [n for n in _all(door) if f"droneplan.{door}.{n}" not in ids]
        assert not missing, f"api/{door}.html does not document {missing}"
    ids = set(re.findall(r'id="(droneplan\.[\w.]+)"', (site / "api" / "index.html").read_text()))
    top = [n for n in _all("__init__") if n not in FRONT_DOORS and not n.startswith("__")]
    # a name the front door provides lazily (module __getattr__) is rendered under its source module
    lacking = [n for n in top if f"droneplan.{n}" not in ids and not any(i.endswith(f".{n}") for i in ids)]
    assert top and not lacking, f"api/index.html lacks {lacking}"


def test_quickstart_includes_the_readme_blocks(site):
    """The quickstart shows the README's install command and every README Python block verbatim."""
    readme = (ROOT / "README.md").read_text()
    blocks = re.findall(r"\[start:(?:install-run|quickstart-\w+)\] -->\n```\w+\n(.+?)\n```", readme, re.S)
    quickstart = readme.split("## Python quickstart", 1)[1].split("\n## ", 1)[0]
    marked = len(re.findall(r"\[start:quickstart-\w+\]", quickstart))
    assert marked == len(re.findall(r"^```python$", quickstart, re.M)) == len(blocks) - 1 >= 4, (
        "every Python block of the README's quickstart needs quickstart-<name> snippet markers"
    )
    text = html.unescape(re.sub(r"<[^>]+>", "", (site / "quickstart.html").read_text()))
    for block in blocks:
        for line in block.splitlines():
            assert line.strip() in text, f"quickstart.html lacks README line {line!r}"


@pytest.mark.slow
def test_a_broken_link_fails_the_build(tmp_path):
    """The build is strict for real: a page linking to a missing page makes it exit non-zero."""
    copy = tmp_path / "repo"
    copy.mkdir()
    for name in ("mkdocs.yml", "README.md", "CHANGELOG.md", ".typing", "droneplan"):
        (copy / name).symlink_to(ROOT / name)
    shutil.copytree(ROOT / "docs", copy / "docs")
    with (copy / "docs" / "index.md").open("a") as fh:
        fh.write("\nSee [a page that does not exist](nowhere.md).\n")
    proc = _build(copy / "mkdocs.yml", tmp_path / "site", {"DRONEPLAN_REPORT_DIR": str(tmp_path)})
    assert proc.returncode != 0
    assert "nowhere.md" in proc.stdout + proc.stderr
