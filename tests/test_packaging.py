"""`python -m build` gives an sdist and a wheel that carry every layer under the droneplan namespace,
and the built wheel imports and runs its command line (installed without the editable checkout)."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import tarfile
import zipfile
from pathlib import Path

import pytest

from droneplan._layers import LAYERS

ROOT = Path(__file__).resolve().parents[1]


def _run(cmd: list[str], **kwargs) -> subprocess.CompletedProcess:
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=900, **kwargs)
    assert proc.returncode == 0, f"{' '.join(cmd)} failed:\n{proc.stdout[-3000:]}\n{proc.stderr[-3000:]}"
    return proc


@pytest.mark.slow
def test_build_gives_a_wheel_and_sdist_that_carry_every_layer(tmp_path):
    src = tmp_path / "src"
    # a clean copy of the tracked files (no .venv, build/ or egg-info from the working tree)
    files = _run(["git", "ls-files", "-z"], cwd=ROOT).stdout.split("\0")
    for rel in filter(None, files):
        target = src / rel
        target.parent.mkdir(parents=True, exist_ok=True)
        if (ROOT / rel).is_symlink():
            target.symlink_to(os.readlink(ROOT / rel))
        elif (ROOT / rel).is_file():
            shutil.copy2(ROOT / rel, target)
    dist = tmp_path / "dist"
    _run([sys.executable, "-m", "build", "--outdir", str(dist), str(src)])
    (wheel,) = dist.glob("droneplan-*.whl")
    (sdist,) = dist.glob("droneplan-*.tar.gz")

    names = zipfile.ZipFile(wheel).namelist()
    for layer in LAYERS:
        assert f"droneplan/{layer}/__init__.py" in names, f"the wheel lacks droneplan.{layer}"
    assert any(n.endswith("entry_points.txt") for n in names)
    assert any(n.endswith("licenses/LICENSE") for n in names)
    with tarfile.open(sdist) as tar:
        members = {m.split("/", 1)[1] for m in tar.getnames() if "/" in m}
    layer_inits = [f"{x}/__init__.py" for x in LAYERS]
    needed_files = ("setup.py", "pyproject.toml", "LICENSE", "CHANGELOG.md", *layer_inits)
    for needed in needed_files:
        assert needed in members, f"the sdist lacks {needed}"

    # install the wheel alone into a target directory and run it from there (dependencies come
    # from this environment; the target directory comes first on sys.path)
    target = tmp_path / "site"
    pip = [sys.executable, "-m", "pip", "install", "--no-deps", "--no-index", "--target", str(target)]
    _run([*pip, str(wheel)])
    env = {**os.environ, "PYTHONPATH": str(target)}
    code = "import droneplan, droneplan.solvers as s; print(droneplan.__version__, s.__file__)"
    out = _run([sys.executable, "-c", code], env=env, cwd=tmp_path).stdout
    assert str(target) in out, f"droneplan was not imported from the installed wheel: {out}"
    help_text = _run([sys.executable, "-m", "droneplan.studies.cli", "--help"], env=env, cwd=tmp_path).stdout
    assert "reproduce" in help_text and "gap" in help_text
    assert (target / "bin" / "droneplan").is_file(), "the wheel installs no droneplan script"
