"""Map the repository's top-level layer folders into the one installed namespace.

``scenarios/``, ``formulations/``, ``solvers/``, ``planners/`` and ``studies/`` stay
at the top of the repository (the project's layout) but install as
``droneplan.scenarios`` ... ``droneplan.studies``; ``droneplan/`` is the front door.
Nothing else goes on the import path. Everything else is in pyproject.toml. The layer
names are written once, in ``droneplan/_layers.py``, which is run here without importing
droneplan.
"""

import runpy
from pathlib import Path

from setuptools import find_packages, setup

_LAYERS_FILE = Path(__file__).resolve().parent / "droneplan" / "_layers.py"
LAYERS: tuple[str, ...] = runpy.run_path(str(_LAYERS_FILE))["LAYERS"]

packages = ["droneplan", *(f"droneplan.{sub}" for sub in find_packages("droneplan"))]
package_dir = {"droneplan": "droneplan"}
for layer in LAYERS:
    packages += [f"droneplan.{layer}", *(f"droneplan.{layer}.{sub}" for sub in find_packages(layer))]
    package_dir[f"droneplan.{layer}"] = layer

setup(packages=packages, package_dir=package_dir)
