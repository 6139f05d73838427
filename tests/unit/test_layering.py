"""Imports point one way between the layers (docs/architecture.md, section 1). Checked on the source text
(AST), so it holds for every module in the tree, including ones added later.

The lowest layer, ``core`` (the shared argument checks, work budgets and seed helpers),
knows nothing of drones or solvers and imports no other layer, so every layer may import it.
No module is exempt from the rules."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

from droneplan._layers import LAYERS

ROOT = Path(__file__).resolve().parents[2]
ALLOWED = {
    "core": set(),
    "solvers": {"core"},
    "scenarios": {"core"},
    "formulations": {"core", "solvers", "scenarios"},
    "planners": {"core", "solvers", "scenarios", "formulations"},
    "studies": {"core", "solvers", "scenarios", "formulations", "planners"},
}


def _imported_layers(path: Path) -> set[str]:
    tree = ast.parse(path.read_text(), filename=str(path))
    found = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            names = [node.module]
        else:
            continue
        for name in names:
            parts = name.split(".")
            if parts[0] in LAYERS:
                raise AssertionError(f"{path}: imports {name!r} outside the droneplan namespace")
            if parts[0] == "droneplan" and len(parts) > 1:
                # the front doors (droneplan.cells, ...) sit above every layer
                found.add(parts[1] if parts[1] in LAYERS else "droneplan")
    return found


@pytest.mark.parametrize("layer", LAYERS)
def test_layer_imports_point_one_way(layer):
    files = sorted((ROOT / layer).rglob("*.py"))
    assert files, f"layer {layer} has no modules"
    bad = {}
    for path in files:
        wrong = _imported_layers(path) - ALLOWED[layer] - {layer}
        if wrong:
            bad[str(path.relative_to(ROOT))] = sorted(wrong)
    assert not bad, f"{layer} imports layers it must not: {bad}"


def test_layers_do_not_import_the_front_doors():
    for layer in LAYERS:
        for path in (ROOT / layer).rglob("*.py"):
            assert "droneplan" not in _imported_layers(path), path


def test_nothing_imports_studies_outside_studies():
    for layer in LAYERS[:-1]:
        for path in (ROOT / layer).rglob("*.py"):
            assert "studies" not in _imported_layers(path), path


def test_the_base_layer_imports_nothing_of_droneplan():
    for path in sorted((ROOT / "core").rglob("*.py")):
        tree = ast.parse(path.read_text(), filename=str(path))
        for node in ast.walk(tree):
            where = (path, ast.dump(node))
            if isinstance(node, ast.ImportFrom):
                assert node.level == 0 and not (node.module or "").startswith("droneplan"), where
            elif isinstance(node, ast.Import):
                assert not any(a.name.startswith("droneplan") for a in node.names), where
