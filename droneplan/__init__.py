"""droneplan: four drone planning problems of the thesis *Some Problems of Deployment
and Navigation of Civilian Aerial Drones* (ch. 3-6) as explicit optimisation models,
with the thesis's heuristics as baselines and warm starts.

Front doors, one per problem (each re-exports what a user of that problem needs)::

    import droneplan as dp

    dp.covert  # ch. 3, covert observation of moving animals
    dp.cells  # ch. 4, backhaul-aware drone-cell placement
    dp.shark  # ch. 5, shark interception
    dp.herding  # ch. 6, herding with barking drones

The layers (``droneplan.scenarios``, ``.formulations``, ``.solvers``, ``.planners``,
``.studies``) hold the implementation; ``SolveResult``/``Status`` are the result
contract every solve returns; ``gap(problem, methods=[...], instances=..., out=...)`` runs an
open gap study of registered and the user's own methods on instance families, the certified
library or the user's data (``droneplan gap --method``), ``run_gap(problem, seeds=..., out=...)``
the built-in gap study of a problem like ``droneplan gap``, and ``load_results(out)`` reads
every study row of an ``--out`` directory as one long-format DataFrame.
"""

from typing import Any

from droneplan import cells, covert, herding, shark
from droneplan.solvers.result import SolveResult, Status
from droneplan.studies.store import load_results

__version__ = "0.1.0"

__all__ = [
    "cells",
    "covert",
    "herding",
    "shark",
    "SolveResult",
    "Status",
    "load_results",
    "run_gap",
    "gap",
    "__version__",
]


def __getattr__(name: str) -> Any:
    # run_gap lives in the CLI module; importing it lazily keeps `python -m droneplan.studies.cli`
    # free of runpy's "found in sys.modules" warning
    if name == "run_gap":
        from droneplan.studies.cli import run_gap

        return run_gap
    if name == "gap":
        from droneplan.studies.study import gap

        return gap
    raise AttributeError(f"module 'droneplan' has no attribute {name!r}")
