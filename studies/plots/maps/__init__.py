"""Interactive maps (Leaflet, through folium), one module per problem, each with a ``map``
that the front door re-exports (``droneplan.cells.map``, ``droneplan.covert.map``, ...).

Positions are local metres. Without an ``origin`` a map uses Leaflet's simple CRS: one map unit
is a metre, there is no background and no geographic position. With ``origin=(lat, lon)`` the
local (0, 0) stands for that point and the map is on WGS 84 (through
:class:`~droneplan.scenarios.geo.LocalFrame`), where a tile background can be added. The pages
load Leaflet (and nothing else) from its CDN; :func:`map_html` can write a local copy into the
page instead, so that it works offline.
"""

from droneplan.studies.plots.maps._base import (
    LEAFLET_CSS,
    LEAFLET_JS,
    MAX_ANIMALS,
    MAX_STEPS,
    embed_html,
    map_html,
)

__all__ = [
    "MAX_STEPS",
    "MAX_ANIMALS",
    "LEAFLET_JS",
    "LEAFLET_CSS",
    "map_html",
    "embed_html",
    "report_map_html",
]


def report_map_html(problem: str) -> str:
    """The interactive map the reproduction report shows in the section of ``problem`` (HTML: a
    heading, a caption and an ``<iframe>``), or "" for a problem without one. Today that is the
    drone-cell placement of the thesis instance (:func:`~.cells.placement_report_html`).

    problem: a problem's name (``"covert"``, ``"cells"``, ``"shark"``, ``"herding"``).
    """
    if problem != "cells":
        return ""
    from droneplan.studies.plots.maps.cells import placement_report_html

    return placement_report_html()
