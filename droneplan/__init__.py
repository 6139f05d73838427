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
``export_mission(plan_or_trace, path, origin=(lat, lon, alt))`` writes autopilot mission files
(MAVLink ``.wpl``, QGroundControl ``.plan``, KML); ``to_geojson``/``to_geodataframe`` give a
plan or trace in WGS 84 (``droneplan.scenarios.geo.LocalFrame`` maps local metres to lat/lon).
"""

import importlib
import importlib.util
import os
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from droneplan._layers import LAYERS as _LAYERS

if TYPE_CHECKING:  # the names for type checkers; at run time __getattr__ imports them
    from droneplan import cells, covert, herding, shark
    from droneplan.scenarios.geo_export import to_geodataframe, to_geojson
    from droneplan.scenarios.missions import export_mission
    from droneplan.solvers.result import SolveResult, Status
    from droneplan.studies.store import load_results
    from droneplan.studies.trace_store import load_traces

__version__ = "0.1.0"

__all__ = [
    "cells",
    "covert",
    "herding",
    "shark",
    "SolveResult",
    "Status",
    "load_results",
    "load_traces",
    "run_gap",
    "gap",
    "summary_table",
    "performance_profile",
    "plot_performance_profile",
    "plot_anytime",
    "plot_anytime_ecdf",
    "anytime_summary",
    "family_instances",
    "save_instance",
    "load_instance",
    "export_mission",
    "to_geojson",
    "to_geodataframe",
    "__version__",
]

_STUDY_NAMES = (
    "gap",
    "load_traces",
    "summary_table",
    "performance_profile",
    "plot_performance_profile",
    "plot_anytime",
    "plot_anytime_ecdf",
    "anytime_summary",
    "family_instances",
    "save_instance",
    "load_instance",
)
"""Study names resolved on first use (importing them loads the study machinery)."""


_FRONT_DOORS = ("cells", "covert", "herding", "shark")


def _check_one_tree() -> None:
    """Refuse, in one line, layers that would load from another tree than the front doors.

    An editable install maps each layer folder to ``droneplan.<layer>`` by absolute path. A
    Python started in a copy of the repository finds this ``droneplan/`` in the copy first,
    and then the layers of the installed checkout: two trees in one process. A layer belongs
    to this tree when its folder sits beside ``droneplan/`` (a checkout) or inside it (a
    wheel), as written or with symlinks resolved. Only the layers' specs are looked up;
    nothing is imported.
    """
    front = os.path.dirname(os.path.abspath(__file__))
    for layer in _LAYERS:
        spec = importlib.util.find_spec(f"droneplan.{layer}")
        if spec is None:  # not installed at all: the first import of the layer says so
            continue
        if spec.origin is not None:
            folder = os.path.dirname(os.path.abspath(spec.origin))
        elif spec.submodule_search_locations:
            folder = os.path.abspath(next(iter(spec.submodule_search_locations)))
        else:
            continue
        if not any(
            os.path.dirname(f(folder)) in (f(front), os.path.dirname(f(front)))
            for f in (os.path.abspath, os.path.realpath)
        ):
            raise ImportError(
                f"droneplan: the front doors load from {front} but droneplan.{layer} from {folder}, "
                f"another tree; install this tree with `pip install -e .` in {os.path.dirname(front)}"
            )


_check_one_tree()


def __getattr__(name: str) -> Any:
    """Import a front door or a public name on first use: ``import droneplan`` loads none of
    the solver libraries, cvxpy, matplotlib or pandas; each loads with the first name that needs it."""
    value: Any
    if name in _FRONT_DOORS or name in _LAYERS:
        value = importlib.import_module(f"droneplan.{name}")
    elif name == "run_gap":
        from droneplan.studies.thesis.problem_studies import run_gap

        value = run_gap
    elif name in ("SolveResult", "Status"):
        from droneplan.solvers.result import SolveResult, Status  # noqa: F401

        value = locals()[name]
    elif name == "export_mission":
        from droneplan.scenarios.missions import export_mission

        value = export_mission
    elif name in ("to_geojson", "to_geodataframe"):
        from droneplan.scenarios.geo_export import to_geodataframe, to_geojson  # noqa: F401

        value = locals()[name]
    elif name == "load_results":
        from droneplan.studies.store import load_results

        value = load_results
    elif name in _STUDY_NAMES:
        from droneplan.studies.analysis import performance_profile, summary_table  # noqa: F401
        from droneplan.studies.instances import family_instances, load_instance, save_instance  # noqa: F401
        from droneplan.studies.plots.anytime import plot_anytime, plot_anytime_ecdf  # noqa: F401
        from droneplan.studies.plots.profiles import plot_performance_profile  # noqa: F401
        from droneplan.studies.study import gap  # noqa: F401
        from droneplan.studies.trace_store import load_traces  # noqa: F401
        from droneplan.studies.traces import anytime_summary  # noqa: F401

        value = locals()[name]
    else:
        raise AttributeError(f"module 'droneplan' has no attribute {name!r}")
    globals()[name] = value  # later lookups skip __getattr__
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))


def _lazy_names(
    namespace: dict[str, Any],
    sources: dict[str, tuple[str, ...]],
    deprecated: dict[str, str] | None = None,
) -> tuple[Callable[[str], Any], Callable[[], list[str]]]:
    """A module ``__getattr__`` and ``__dir__`` for a front door whose public names load on first use.

    namespace: the front door's ``globals()`` (it holds ``__name__`` and ``__all__``; each name,
    once imported, is stored there so later lookups skip ``__getattr__``).
    sources: module -> the names the front door takes from it.
    deprecated: old name -> new name, answered with the new name's value and a
        ``DeprecationWarning`` for one release (not listed by ``__dir__``).
    """
    module = namespace["__name__"]
    where = {name: source for source, names in sources.items() for name in names}
    renamed = dict(deprecated or {})

    def __getattr__(name: str) -> Any:
        if name in renamed:
            from droneplan.core.deprecation import warn_renamed

            warn_renamed(name, renamed[name], where=module)
            return __getattr__(renamed[name])
        source = where.get(name)
        if source is None:
            raise AttributeError(f"module {module!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(source), name)
        namespace[name] = value
        return value

    def __dir__() -> list[str]:
        return sorted(set(namespace) | set(namespace.get("__all__", ())))

    return __getattr__, __dir__
