"""The symlink tree .typing/droneplan gives mypy (and the docs build) the installed view of the
package: droneplan/*.py plus one link per layer folder, as setup.py maps them (droneplan/_layers.py)."""

import os
from pathlib import Path

from droneplan._layers import LAYERS

ROOT = Path(__file__).resolve().parents[1]
TREE = ROOT / ".typing" / "droneplan"


def test_typing_tree_mirrors_the_installed_package():
    expected = {p.name: p for p in (ROOT / "droneplan").glob("*.py")}
    expected.update({layer: ROOT / layer for layer in LAYERS})
    present = {p.name: p for p in TREE.iterdir()}
    missing = sorted(set(expected) - set(present))
    extra = sorted(set(present) - set(expected))
    fix = (
        "cd .typing/droneplan && ln -s ../../droneplan/NAME.py . (a front-door module) or ln -s ../../LAYER ."
    )
    assert not missing, f"add symlinks for {missing} to .typing/droneplan ({fix})"
    assert not extra, f"remove {extra} from .typing/droneplan (no such module or layer any more)"
    for name, link in present.items():
        assert link.is_symlink(), f".typing/droneplan/{name} must be a symlink"
        assert not os.path.isabs(os.readlink(link)), f".typing/droneplan/{name} must be a relative link"
        assert link.resolve() == expected[name].resolve(), f".typing/droneplan/{name} points elsewhere"
