"""The interactive map of a herding run (``droneplan.herding.map``)."""

from __future__ import annotations

from typing import Any

import folium
import numpy as np

from droneplan.core.validation import check_int
from droneplan.scenarios.herding import HerdingTrace
from droneplan.studies.plots.maps._base import (
    MAX_ANIMALS,
    MAX_STEPS,
    Projection,
    TimeSlider,
    add_track,
    check_positions,
    check_tiles,
    new_map,
    popup,
    thin,
)

__all__ = ["map"]


def _time(value: float | None) -> str:
    return "not reached" if value is None else f"{value:.0f} s ({value / 60:.1f} min)"


def map(  # shadows the builtin in this module only: the front door's name is droneplan.herding.map
    trace: HerdingTrace,
    *,
    origin: Any = None,
    tiles: str | None = None,
    max_steps: int = MAX_STEPS,
    max_animals: int = MAX_ANIMALS,
) -> folium.Map:
    """Interactive top view (Leaflet, through folium) of a herding run; returns the folium Map.

    Layers: the drones' tracks and the herd centroid's track, with markers that the time slider
    (bottom left) moves; the animals (an even sample of at most ``max_animals``) moved by the
    slider through the run's stored frames (``simulate(..., frame_every=...)``), or at their final
    positions when the run stored none; and the goal G, whose popup gives the gathering and total
    times (s) and the share delivered.

    trace: a :class:`HerdingTrace` (positions in local metres).
    origin: None to draw in local metres (Leaflet's simple CRS, no background), or (lat, lon) /
        (lat, lon, alt) in degrees and metres (or a :class:`~droneplan.scenarios.geo.LocalFrame`)
        that the local (0, 0) stands for.
    tiles: None (no background map: works offline) or a folium tile set such as
        ``"OpenStreetMap"`` (needs the network, and ``origin``: refused without it).
    max_steps: most instants kept for the slider and the tracks (count >= 2), evenly thinned with
        the first and the last.
    max_animals: most animals drawn (count >= 1), an even sample of the herd.
    """
    if not isinstance(trace, HerdingTrace):
        raise TypeError(f"trace must be a HerdingTrace, got {type(trace).__name__}")
    most = check_int("max_steps", max_steps, min_value=2)
    n_animals = check_int("max_animals", max_animals, min_value=1)
    tiles = check_tiles(tiles)
    if trace.frames:  # the slider steps through the stored frames, animals included
        steps = thin(len(trace.frames), most)
        times = np.array([trace.frames[k].t for k in steps], dtype=float)
        animals = check_positions("trace (animals)", np.stack([trace.frames[k].animals for k in steps]))
        drones = check_positions("trace (drones)", np.stack([trace.frames[k].drones for k in steps]))
    else:  # through the recorded drone positions; the animals stay at their final positions
        steps = thin(len(trace.t), most)
        times = np.asarray(trace.t, dtype=float)[steps]
        animals = check_positions("trace (animals)", np.asarray(trace.final.animals)[None])
        drones = check_positions("trace (drones)", np.asarray(trace.drones)[steps])
    centroid = check_positions("trace (centroid)", trace.centroid)
    goal = check_positions("trace (goal)", trace.goal).reshape(2)
    herd = np.unique(np.linspace(0, animals.shape[1] - 1, min(n_animals, animals.shape[1])).astype(int))
    proj = Projection(origin)
    extent = [animals.reshape(-1, 2), drones.reshape(-1, 2), centroid, goal[None]]
    fmap = new_map(proj, np.concatenate(extent), tiles=tiles)
    delivered = f"{100 * trace.delivered[-1]:.0f} %" if len(trace.delivered) else "not recorded"
    folium.CircleMarker(
        proj.point(goal),
        radius=9,
        color="#2ca02c",
        fill=True,
        fill_opacity=1.0,
        class_name="dp-goal",
        popup=popup(
            f"goal G at ({goal[0]:.0f}, {goal[1]:.0f}) m",
            f"gathered at {_time(trace.gather_time)}",
            f"delivered at {_time(trace.total_time)}",
            f"delivered at the end: {delivered}",
        ),
        tooltip="goal G",
    ).add_to(folium.FeatureGroup(name="goal G").add_to(fmap))
    tracks: list[tuple[folium.CircleMarker, list[list[float]]]] = []
    label = f"animals ({len(herd)} of {animals.shape[1]} drawn)"
    group = folium.FeatureGroup(name=label)
    for j in herd:
        pts = proj.points(animals[:, j])
        marker = folium.CircleMarker(
            pts[0],
            radius=3,
            color="#8c564b",
            fill=True,
            fill_opacity=0.9,
            weight=1,
            class_name="dp-animal",
            tooltip=f"animal {j}",
        )
        marker.add_to(group)
        if len(pts) == len(times):  # animals move with the slider only through stored frames
            tracks.append((marker, pts))
    group.add_to(fmap)
    centroid_steps = thin(len(trace.t), most)
    group = folium.FeatureGroup(name="herd centroid")
    marker, _ = add_track(
        group,
        proj,
        centroid[centroid_steps],
        color="#111111",
        class_name="dp-centroid",
        radius=4,
        label="herd centroid",
        lines=("herd centroid", f"final footprint radius {trace.footprint_radius[-1]:.0f} m"),
    )
    group.add_to(fmap)
    tracks.append((marker, [proj.point(c) for c in _at(trace.t, centroid, times)]))
    group = folium.FeatureGroup(name=f"drones ({drones.shape[1]})")
    tracks.extend(
        add_track(
            group,
            proj,
            drones[:, j],
            color="#d62728",
            class_name="dp-drone",
            label=f"drone {j}",
            lines=(f"drone {j}", f"regroupings of the herd: {trace.regroupings}"),
        )
        for j in range(drones.shape[1])
    )
    group.add_to(fmap)
    if len(times) > 1:
        fmap.add_child(TimeSlider(times, tracks))
    folium.LayerControl(collapsed=False).add_to(fmap)
    return fmap


def _at(t: np.ndarray, values: np.ndarray, times: np.ndarray) -> np.ndarray:
    """(len(times), 2) the rows of ``values`` recorded at ``t`` (s) nearest to each of ``times`` (s)."""
    t = np.asarray(t, dtype=float)
    idx = np.clip(np.searchsorted(t, times), 0, len(t) - 1)
    before = np.clip(idx - 1, 0, len(t) - 1)
    idx = np.where(np.abs(t[before] - times) < np.abs(t[idx] - times), before, idx)
    return values[idx]
