"""The interactive map of a shark-interception run (``droneplan.shark.map``)."""

from __future__ import annotations

from typing import Any

import folium
import numpy as np

from droneplan.core.validation import check_int
from droneplan.scenarios.shark import InterceptionTrace
from droneplan.studies.plots.maps._base import (
    MAX_STEPS,
    Projection,
    TimeSlider,
    add_track,
    check_positions,
    check_tiles,
    new_map,
    thin,
)

__all__ = ["map"]


def map(  # shadows the builtin in this module only: the front door's name is droneplan.shark.map
    trace: InterceptionTrace, *, origin: Any = None, tiles: str | None = None, max_steps: int = MAX_STEPS
) -> folium.Map:
    """Interactive top view (Leaflet, through folium) of a shark-interception run; returns the folium Map.

    Layers: the shark's and the operator drone's tracks with markers that the time slider (bottom
    left) moves, and at first contact the field's circle of radius eps on the shark's plane. Popups
    give the contact time (s), the interception distance (m) and the contact angle (deg).

    trace: an :class:`InterceptionTrace` (positions in local metres).
    origin: None to draw in local metres (Leaflet's simple CRS, no background), or (lat, lon) /
        (lat, lon, alt) in degrees and metres (or a :class:`~droneplan.scenarios.geo.LocalFrame`)
        that the local (0, 0) stands for.
    tiles: None (no background map: works offline) or a folium tile set such as
        ``"OpenStreetMap"`` (needs the network, and ``origin``: refused without it).
    max_steps: most recorded instants kept for the slider and the tracks (count >= 2), evenly
        thinned with the first and the last.
    """
    if not isinstance(trace, InterceptionTrace):
        raise TypeError(f"trace must be an InterceptionTrace, got {type(trace).__name__}")
    most = check_int("max_steps", max_steps, min_value=2)
    tiles = check_tiles(tiles)
    shark = check_positions("trace (shark)", trace.shark)
    operator = check_positions("trace (operator)", trace.operator)
    proj = Projection(origin)
    steps = thin(len(trace.t), most)
    fmap = new_map(proj, np.concatenate([shark[:, :2], operator[:, :2]]), tiles=tiles)
    if trace.intercepted:
        outcome = (
            f"contact at t = {trace.intercept_time:.1f} s, {trace.interception_distance:.1f} m from the "
            f"shark's start, {trace.frontal_angle:.0f} deg off its heading"
        )
    else:
        outcome = "no contact"
    tracks: list[tuple[folium.CircleMarker, list[list[float]]]] = []
    group = folium.FeatureGroup(name="shark")
    tracks.append(
        add_track(
            group,
            proj,
            shark[steps],
            color="#111111",
            class_name="dp-shark",
            label="shark",
            lines=(
                f"shark {trace.name}".strip(),
                f"depth {-shark[:, 2].max():.1f} to {-shark[:, 2].min():.1f} m",
                outcome,
            ),
        )
    )
    group.add_to(fmap)
    group = folium.FeatureGroup(name="operator drone")
    tracks.append(
        add_track(
            group,
            proj,
            operator[steps],
            color="#1f77b4",
            class_name="dp-drone",
            label="operator drone",
            lines=(
                "operator drone",
                f"altitude {operator[:, 2].min():.1f} to {operator[:, 2].max():.1f} m",
                outcome,
            ),
        )
    )
    if trace.intercepted and trace.contact_eps is not None:
        folium.Circle(
            proj.point(operator[-1, :2]),  # the operator at first contact: the last recorded instant
            radius=float(trace.contact_eps),
            color="#d62728",
            weight=2,
            dash_array="6 4",
            fill=False,
            tooltip=f"field at contact: radius eps = {trace.contact_eps:.2f} m on the shark's plane",
        ).add_to(group)
    group.add_to(fmap)
    fmap.add_child(TimeSlider(np.asarray(trace.t)[steps], tracks))
    folium.LayerControl(collapsed=False).add_to(fmap)
    return fmap
