"""The layer folders, written once.

Each name is a folder at the top of the repository that installs as ``droneplan.<name>``,
lowest layer first. ``setup.py`` reads this file without importing droneplan (it maps
each folder into the namespace), ``droneplan/__init__.py`` checks that every layer comes
from the same tree as the front doors, and the tests read it too. This module imports
nothing.
"""

LAYERS = ("core", "solvers", "scenarios", "formulations", "planners", "studies")
