"""The interactive map of a covert-observation run (``droneplan.covert.map``)."""

from __future__ import annotations

import math
from typing import Any

import folium
import numpy as np

from droneplan.core.validation import check_int
from droneplan.scenarios.covert import CovertTrace
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


def map(  # shadows the builtin in this module only: the front door's name is droneplan.covert.map
    trace: CovertTrace, *, origin: Any = None, tiles: str | None = None, max_steps: int = MAX_STEPS
) -> folium.Map:
    """Interactive top view (Leaflet, through folium) of a covert-observation run; returns the folium Map.

    Layers: the drone's ground track with a marker that the time slider (bottom left) moves, the
    targets' tracks and markers likewise, and the observation sphere's trace on the ground (radius
    sqrt(L_u^2 - F_z^2) about F), the centre F, the reference point R and the start. Popups give
    altitudes (m), the maximum bearing change beta_max (deg) and the times on the sphere (s).

    trace: a :class:`CovertTrace` (positions in local metres).
    origin: None to draw in local metres (Leaflet's simple CRS, no background), or (lat, lon) /
        (lat, lon, alt) in degrees and metres (or a :class:`~droneplan.scenarios.geo.LocalFrame`)
        that the local (0, 0) stands for.
    tiles: None (no background map: works offline) or a folium tile set such as
        ``"OpenStreetMap"`` (needs the network, and ``origin``: refused without it).
    max_steps: most recorded instants kept for the slider and the tracks (count >= 2), evenly
        thinned with the first and the last.
    """
    if not isinstance(trace, CovertTrace):
        raise TypeError(f"trace must be a CovertTrace, got {type(trace).__name__}")
    most = check_int("max_steps", max_steps, min_value=2)
    tiles = check_tiles(tiles)
    drone = check_positions("trace (drone)", trace.drone)
    targets = check_positions("trace (targets)", trace.targets) if trace.targets.size else trace.targets
    proj = Projection(origin)
    steps = thin(len(trace.t), most)
    F = np.asarray(trace.F, dtype=float)
    ground = math.sqrt(max(trace.L_u**2 - F[2] ** 2, 0.0))
    extent = [drone[:, :2], F[None, :2] + np.array([[-ground, -ground], [ground, ground]])]
    if targets.size:
        extent.append(targets[..., :2].reshape(-1, 2))
    fmap = new_map(proj, np.concatenate(extent), tiles=tiles)
    scene = folium.FeatureGroup(name="observation sphere, F, R and start")
    folium.Circle(
        proj.point(F[:2]),
        radius=max(ground, 1e-3),
        color="#7f7f7f",
        weight=1,
        fill=False,
        tooltip=f"observation sphere on the ground (L_u = {trace.L_u:g} m)",
    ).add_to(scene)
    for xy, label, cls in (
        (F, f"sphere centre F, z = {F[2]:g} m", "dp-centre"),
        (np.asarray(trace.R, dtype=float), f"reference point R, z = {trace.R[2]:g} m", "dp-reference"),
        (drone[0], f"start D_s, z = {drone[0, 2]:g} m", "dp-start"),
    ):
        folium.CircleMarker(
            proj.point(xy[:2]), radius=4, color="#000000", fill=True, class_name=cls, tooltip=label
        ).add_to(scene)
    scene.add_to(fmap)
    beta = "nan" if not math.isfinite(trace.beta_max) else f"{math.degrees(trace.beta_max):.2f}"
    sphere = "never on the sphere" if trace.t_a is None else f"on the sphere from t = {trace.t_a:.1f} s"
    if trace.t_f is not None:
        sphere += f" until t = {trace.t_f:.1f} s"
    tracks: list[tuple[folium.CircleMarker, list[list[float]]]] = []
    if targets.size:
        group = folium.FeatureGroup(name=f"targets ({targets.shape[1]})")
        tracks.extend(
            add_track(
                group,
                proj,
                targets[steps, j],
                color="#8c564b",
                class_name="dp-target",
                radius=5,
                label=f"target {j}",
                lines=(f"target {j}", f"start z = {targets[0, j, 2]:g} m"),
            )
            for j in range(targets.shape[1])
        )
        group.add_to(fmap)
    group = folium.FeatureGroup(name="drone")
    lines = (
        "drone",
        f"max bearing change beta_max = {beta} deg",
        sphere,
        f"altitude {drone[:, 2].min():.0f} to {drone[:, 2].max():.0f} m",
        f"run length {trace.t[-1]:.1f} s",
    )
    tracks.append(
        add_track(
            group, proj, drone[steps], color="#1f77b4", class_name="dp-drone", label="drone", lines=lines
        )
    )
    group.add_to(fmap)
    fmap.add_child(TimeSlider(np.asarray(trace.t)[steps], tracks))
    folium.LayerControl(collapsed=False).add_to(fmap)
    return fmap
