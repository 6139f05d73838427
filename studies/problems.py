"""The problems droneplan studies, in one place.

Every module that needs the list of problems (the command line, the report, the results
store, the study front door) imports ``PROBLEMS`` from here, so adding a problem is one edit.
Each name is also the name of its study module ``droneplan.studies.thesis.<name>`` and of its front
door ``droneplan.<name>``.
"""

from __future__ import annotations

__all__ = ["PROBLEMS"]

PROBLEMS: tuple[str, ...] = ("covert", "cells", "shark", "herding")
"""Names of the problems in the thesis's chapter order (chapters 3-6), the order in which the
command line and the report present them."""
