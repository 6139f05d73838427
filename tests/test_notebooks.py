"""Every notebook under notebooks/ runs top to bottom (fast mode) and asserts its outcome."""

from __future__ import annotations

import os
from pathlib import Path

import nbformat
import pytest
from nbclient import NotebookClient

ROOT = Path(__file__).resolve().parents[1]
NOTEBOOKS = sorted((ROOT / "notebooks").glob("*.ipynb"))


def test_notebooks_are_saved_without_outputs():
    for path in NOTEBOOKS:
        nb = nbformat.read(path, as_version=4)
        for cell in nb.cells:
            if cell.cell_type == "code":
                assert not cell.outputs and cell.execution_count is None, f"{path.name} has saved outputs"


FRONT_DOORS = {"droneplan", "droneplan.cells", "droneplan.covert", "droneplan.shark", "droneplan.herding"}


@pytest.mark.parametrize("path", NOTEBOOKS, ids=[p.stem for p in NOTEBOOKS])
def test_notebooks_use_only_the_front_doors(path):
    """``import droneplan as dp`` / ``from droneplan import cells``: no layer module is imported."""
    import ast

    nb = nbformat.read(path, as_version=4)
    used = set()
    for cell in nb.cells:
        if cell.cell_type != "code":
            continue
        code = "\n".join(
            line for line in cell.source.splitlines() if not line.lstrip().startswith(("%", "!"))
        )
        for node in ast.walk(ast.parse(code)):
            if isinstance(node, ast.Import):
                used |= {a.name for a in node.names if a.name.split(".")[0] == "droneplan"}
            elif isinstance(node, ast.ImportFrom) and (node.module or "").split(".")[0] == "droneplan":
                used |= (
                    {node.module}
                    if node.module != "droneplan"
                    else {f"droneplan.{a.name}" for a in node.names}
                )
    assert used, f"{path.name} does not import droneplan"
    assert used <= FRONT_DOORS, f"{path.name} imports {sorted(used - FRONT_DOORS)} (use the front doors)"


@pytest.mark.notebooks
@pytest.mark.parametrize("path", NOTEBOOKS, ids=[p.stem for p in NOTEBOOKS])
def test_notebook_runs(path, tmp_path, monkeypatch):
    monkeypatch.setenv("DRONEPLAN_FAST", "1")
    monkeypatch.setenv("MPLBACKEND", "Agg")
    monkeypatch.setenv("PYTHONPATH", str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    nb = nbformat.read(path, as_version=4)
    client = NotebookClient(
        nb, timeout=600, kernel_name="python3", resources={"metadata": {"path": str(tmp_path)}}
    )
    client.execute()
