"""Map the repository's top-level layer folders into the one installed namespace.

``scenarios/``, ``formulations/``, ``solvers/``, ``planners/`` and ``studies/`` stay
at the top of the repository (the project's layout) but install as
``droneplan.scenarios`` ... ``droneplan.studies``; ``droneplan/`` is the front door.
Nothing else goes on the import path. Everything else is in pyproject.toml.
"""

from setuptools import find_packages, setup

LAYERS = ("core", "solvers", "scenarios", "formulations", "planners", "studies")

packages = ["droneplan", *(f"droneplan.{sub}" for sub in find_packages("droneplan"))]
package_dir = {"droneplan": "droneplan"}
for layer in LAYERS:
    packages += [f"droneplan.{layer}", *(f"droneplan.{layer}.{sub}" for sub in find_packages(layer))]
    package_dir[f"droneplan.{layer}"] = layer

setup(packages=packages, package_dir=package_dir)
