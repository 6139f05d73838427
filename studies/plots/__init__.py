"""Plotting helpers for every problem (presentation, so in the ``studies`` layer).

One module per problem; the front doors re-export them (``droneplan.cells.plot_map``,
``droneplan.covert.plot_path``, ...). Every helper takes an optional ``ax`` (a new figure is
made when it is None), returns the matplotlib ``Figure``, labels its axes with units, draws a
legend and keeps the goal/target in view.
"""

from droneplan.studies.plots.cells import plot_deployment_region, plot_map
from droneplan.studies.plots.covert import plot_bearing, plot_path, plot_stealth_front
from droneplan.studies.plots.herding import plot_final, plot_footprint, plot_state
from droneplan.studies.plots.shark import plot_time_series, plot_top_view

__all__ = [
    "plot_map",
    "plot_deployment_region",
    "plot_path",
    "plot_bearing",
    "plot_stealth_front",
    "plot_top_view",
    "plot_time_series",
    "plot_state",
    "plot_final",
    "plot_footprint",
]
