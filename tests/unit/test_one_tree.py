"""``import droneplan`` takes the front doors and the layers from one tree, or refuses in one line.

An editable install maps each layer folder to ``droneplan.<layer>`` by absolute path. A Python
started in a copy of the repository would find the copy's ``droneplan/`` first and the layers of
the installed checkout after it: two trees in one process. ``droneplan/__init__.py`` checks where
the layers would load from and raises an ImportError that says how to reinstall.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import droneplan
from droneplan._layers import LAYERS

FRONT = Path(droneplan.__file__).resolve().parent

REPORT = (
    "import sys\n"
    "try:\n"
    "    import droneplan\n"
    "except ImportError as e:\n"
    "    print(e)\n"
    "    sys.exit(3)\n"
    "import importlib\n"
    "print(droneplan.__file__)\n"
    "for layer in droneplan._LAYERS:\n"
    "    print(importlib.import_module('droneplan.' + layer).__file__)\n"
)


def _python(cwd: Path) -> subprocess.CompletedProcess:
    # `python -c` puts the working directory first on sys.path, as a shell started in a copy does
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONSAFEPATH", "PYTHONPATH")}
    return subprocess.run(
        [sys.executable, "-c", REPORT], cwd=cwd, env=env, capture_output=True, text=True, timeout=120
    )


def test_front_doors_from_a_copy_with_the_installed_layers_fail_in_one_line(tmp_path):
    copy = tmp_path / "copy"
    (copy / "droneplan").mkdir(parents=True)
    for path in FRONT.glob("*.py"):
        shutil.copy2(path, copy / "droneplan" / path.name)
    proc = _python(copy)
    assert proc.returncode == 3, proc.stdout + proc.stderr
    lines = proc.stdout.splitlines()
    assert len(lines) == 1, proc.stdout
    (message,) = lines
    assert "another tree" in message
    assert f"`pip install -e .` in {copy}" in message
    assert str(copy / "droneplan") in message


def test_the_installed_tree_imports_its_own_layers(tmp_path):
    for cwd in (tmp_path, FRONT.parent):
        proc = _python(cwd)
        assert proc.returncode == 0, proc.stdout + proc.stderr
        first, *layers = (Path(line).resolve() for line in proc.stdout.splitlines())
        assert first.parent == FRONT
        assert len(layers) == len(LAYERS)
        for layer, init in zip(LAYERS, layers, strict=True):
            assert init.parent.name == layer
            assert init.parent.parent in (FRONT, FRONT.parent), f"droneplan.{layer} loads from {init}"


def test_the_layer_names_are_written_once():
    """setup.py and droneplan/__init__.py read droneplan/_layers.py; no other file spells the list."""
    root = FRONT.parent
    spelled = ", ".join(f'"{layer}"' for layer in LAYERS)
    folders = ("droneplan", *LAYERS, "tests")
    paths = [root / "setup.py", *(p for f in folders for p in (root / f).rglob("*.py"))]
    found = sorted(str(path.relative_to(root)) for path in paths if spelled in path.read_text())
    assert found == ["droneplan/_layers.py"], found
    assert droneplan._LAYERS == LAYERS
