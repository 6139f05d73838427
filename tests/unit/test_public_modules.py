"""Every public module of every layer declares ``__all__``, and every name it lists exists."""

from __future__ import annotations

import importlib
import pkgutil

import pytest

from droneplan._layers import LAYERS


def _public_modules() -> list[str]:
    names = []
    for layer in LAYERS:
        pkg = importlib.import_module(f"droneplan.{layer}")
        names.append(pkg.__name__)
        names.extend(
            info.name
            for info in pkgutil.walk_packages(pkg.__path__, f"droneplan.{layer}.")
            if not info.name.rsplit(".", 1)[-1].startswith("_")
        )
    return names


@pytest.mark.parametrize("name", _public_modules())
def test_public_module_declares_all(name):
    module = importlib.import_module(name)
    assert hasattr(module, "__all__"), f"{name} has no __all__"
    missing = [n for n in module.__all__ if not hasattr(module, n)]
    assert not missing, f"{name}.__all__ lists names it does not define: {missing}"
