"""Every notebook under notebooks/ runs top to bottom (fast mode) and asserts its outcome, and is
saved with the outputs of such a run (docs/execute_notebooks.py) so that a reader sees them."""

from __future__ import annotations

import importlib.util
import os
from pathlib import Path

import nbformat
import pytest
from nbclient import NotebookClient

ROOT = Path(__file__).resolve().parents[1]
NOTEBOOKS = sorted((ROOT / "notebooks").glob("*.ipynb"))


def _execute_notebooks_module():
    """``docs/execute_notebooks.py``, the script that saves the notebooks with their outputs."""
    spec = importlib.util.spec_from_file_location("execute_notebooks", ROOT / "docs" / "execute_notebooks.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _code_cells(nb) -> list:
    return [cell for cell in nb.cells if cell.cell_type == "code"]


def _shown(cell) -> set[str]:
    """What a reader sees of a cell's outputs: its result and figures (stderr left aside)."""
    kinds = set()
    for out in cell.outputs:
        if out.output_type in ("execute_result", "display_data"):
            kinds |= {"figure" if "image/png" in out.get("data", {}) else out.output_type}
        elif out.output_type == "error":
            kinds.add("error")
    return kinds


@pytest.mark.parametrize("path", NOTEBOOKS, ids=[p.stem for p in NOTEBOOKS])
def test_notebooks_carry_the_outputs_of_their_current_cells(path):
    """The saved outputs come from a fast run of these very cells (docs/execute_notebooks.py):
    the digest of the code cells matches the one saved with the outputs, every code cell ran
    once, in order, and none raised."""
    digest = _execute_notebooks_module().sources_digest
    nb = nbformat.read(path, as_version=4)
    saved = nb.metadata.get("droneplan", {}).get("sources_sha256")
    assert saved == digest(nb), (
        f"{path.name}: cells changed since the outputs were saved; "
        f"run python docs/execute_notebooks.py {path.stem}"
    )
    cells = _code_cells(nb)
    assert [c.execution_count for c in cells] == list(range(1, len(cells) + 1)), (
        f"{path.name}: not run in order"
    )
    assert not any("error" in _shown(c) for c in cells), f"{path.name} was saved with an error"


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
    saved = nbformat.read(path, as_version=4)
    assert [_shown(c) for c in _code_cells(nb)] == [_shown(c) for c in _code_cells(saved)], (
        f"{path.name}: a fresh run shows other results or figures than the saved copy"
    )
