"""The interactive map of a drone-cell placement (``droneplan.cells.map``)."""

from __future__ import annotations

import html
from collections import deque
from typing import Any

import folium
import numpy as np
from branca.element import Figure

from droneplan.core.validation import check_array, check_int
from droneplan.formulations.cells import TOL, CellProblem, evaluate
from droneplan.solvers.result import SolveResult
from droneplan.studies.plots.maps._base import PointCloud, Projection, check_tiles, embed_html, new_map, popup

__all__ = ["map", "plan_of", "backhaul_tree", "placement_report_html"]

USER_CLASSES = {"covered": "dp-user-covered", "uncovered": "dp-user-uncovered", "served": "dp-user-gbs"}
"""The CSS class of each user marker's SVG path, by kind: covered by a drone-cell, not covered,
served by a GBS already."""


def plan_of(problem: CellProblem, result: Any) -> np.ndarray:
    """The (k, w) drone-cell positions (m) of ``result``: a :class:`SolveResult` (its ``x``) or the
    positions themselves; w = 2 (x, y), or 3 (x, y, h) when the problem has altitude levels.

    problem: the placement problem; result: a SolveResult with a plan or a (k, w) array (m).
    """
    if isinstance(result, SolveResult):
        if result.x is None:
            raise ValueError(f"result has no plan (x is None; status {result.status.name})")
        result = result.x
    width = problem.plan_width
    plan = check_array("result", result)
    if plan.size == 0:
        plan = plan.reshape(0, width)
    elif plan.ndim == 1 and plan.shape[0] == width:
        plan = plan.reshape(1, width)
    return check_array("result", plan, shape=(None, width))


def _radii(problem: CellProblem, plan: np.ndarray) -> np.ndarray:
    """(k,) coverage radius of each drone-cell (m): R_d, or R(h) of its nearest altitude level."""
    if problem.altitudes is None or problem.level_radii is None or not len(plan):
        return np.full(len(plan), problem.R_d)
    gap = np.abs(plan[:, 2:3] - np.asarray(problem.altitudes)[None, :])
    return np.asarray(problem.level_radii)[np.argmin(gap, axis=1)]


def backhaul_tree(problem: CellProblem, plan: np.ndarray) -> list[tuple[str, int, int, float]]:
    """For each drone-cell of ``plan`` ((k, w) m), the first link of its shortest backhaul route:
    (``"gbs"`` or ``"cell"``, that GBS's or relay's index, hops to a GBS, link length in m), or
    ("none", -1, -1, nan) without a route. Links are drone-GBS <= r1 (a GBS at height 0) and
    drone-drone <= r2, in 3-D when the plan has altitudes.

    problem: the placement problem (GBS positions and ranges in m).
    """
    k = len(plan)
    h = plan[:, 2] if plan.shape[1] == 3 else np.zeros(k)
    to_gbs = np.hypot(np.linalg.norm(plan[:, None, :2] - problem.gbs[None, :, :], axis=2), h[:, None])
    between = np.hypot(np.linalg.norm(plan[:, None, :2] - plan[None, :, :2], axis=2), h[:, None] - h[None, :])
    route: list[tuple[str, int, int, float]] = [("none", -1, -1, float("nan"))] * k
    queue: deque[int] = deque()
    for i in range(k):
        g = int(np.argmin(to_gbs[i])) if problem.gbs.size else -1
        if g >= 0 and to_gbs[i, g] <= problem.r1 + TOL:
            route[i] = ("gbs", g, 1, float(to_gbs[i, g]))
            queue.append(i)
    while queue:  # breadth first: each drone-cell gets its fewest hops
        i = queue.popleft()
        for j in np.flatnonzero((between[i] <= problem.r2 + TOL) & (np.arange(k) != i)):
            if route[j][0] == "none":
                route[j] = ("cell", i, route[i][2] + 1, float(between[i, j]))
                queue.append(int(j))
    return route


def _add_users(
    fmap: folium.Map, proj: Projection, problem: CellProblem, covered: np.ndarray, most: int
) -> None:
    """The users in three layers (covered, not covered, served by a GBS), each evenly sampled to at
    most ``most`` markers."""
    kinds = {
        "covered": covered,
        "uncovered": problem.active & ~covered,
        "served": ~problem.active,
    }
    colors = {"covered": "#111111", "uncovered": "#ff7f0e", "served": "#999999"}
    labels = {"covered": "users covered", "uncovered": "users not covered", "served": "users served by a GBS"}
    for kind, mask in kinds.items():
        idx = np.flatnonzero(mask)
        if not len(idx):
            continue
        shown = idx[np.unique(np.linspace(0, len(idx) - 1, min(most, len(idx))).astype(int))]
        name = f"{labels[kind]} ({len(idx)})" + (f", {len(shown)} drawn" if len(shown) < len(idx) else "")
        PointCloud(
            proj.points(problem.users[shown]),
            name,
            color=colors[kind],
            radius=2.5,
            class_name=USER_CLASSES[kind],
        ).add_to(fmap)


def _add_zones(fmap: folium.Map, proj: Projection, problem: CellProblem) -> None:
    """The no-fly zones (red polygons), with their area in a popup."""
    if not problem.no_fly:
        return
    group = folium.FeatureGroup(name=f"no-fly zones ({len(problem.no_fly)})")
    for z, zone in enumerate(problem.no_fly):
        rings = [proj.points(np.asarray(zone.exterior.coords))]
        rings += [proj.points(np.asarray(hole.coords)) for hole in zone.interiors]
        folium.Polygon(
            rings,
            color="#d62728",
            fill=True,
            fill_opacity=0.25,
            weight=2,
            class_name="dp-no-fly",
            popup=popup(f"no-fly zone {z}", f"area {zone.area / 1e6:.3f} km2"),
            tooltip=f"no-fly zone {z}",
        ).add_to(group)
    group.add_to(fmap)


def _add_gbs(fmap: folium.Map, proj: Projection, problem: CellProblem) -> None:
    """The ground base stations with their cells of radius R_g."""
    group = folium.FeatureGroup(name=f"ground base stations ({len(problem.gbs)})")
    d = np.linalg.norm(problem.users[:, None, :] - problem.gbs[None, :, :], axis=2)
    for g, xy in enumerate(problem.gbs):
        served = int(np.sum(d[:, g] <= problem.R_g)) if len(problem.users) else 0
        lines = [
            f"GBS {g} at ({xy[0]:.0f}, {xy[1]:.0f}) m",
            f"cell radius R_g = {problem.R_g:g} m, users within it: {served}",
            f"backhaul range to drone-cells r1 = {problem.r1:g} m",
        ]
        folium.Circle(proj.point(xy), radius=problem.R_g, color="#1f77b4", weight=1, fill=False).add_to(group)
        folium.CircleMarker(
            proj.point(xy),
            radius=8,
            color="#1f77b4",
            fill=True,
            fill_opacity=1.0,
            class_name="dp-gbs",
            popup=popup(*lines),
            tooltip=f"GBS {g}",
        ).add_to(group)
    group.add_to(fmap)


def _add_cells(fmap: folium.Map, proj: Projection, problem: CellProblem, plan: np.ndarray) -> None:
    """The drone-cells (markers with popups), their coverage disks and the backhaul links."""
    radii = _radii(problem, plan)
    routes = backhaul_tree(problem, plan)
    d = np.linalg.norm(problem.users[:, None, :] - plan[None, :, :2], axis=2) if len(plan) else None
    cells = folium.FeatureGroup(name=f"drone-cells ({len(plan)})")
    disks = folium.FeatureGroup(name="drone-cell coverage")
    links = folium.FeatureGroup(name="backhaul links")
    for i, xy in enumerate(plan):
        users_in = int(np.sum((d[:, i] <= radii[i] + TOL) & problem.active)) if d is not None else 0
        kind, via, hops, length = routes[i]
        if kind == "none":
            backhaul = "backhaul: no route to a GBS"
        else:
            via_name = f"GBS {via}" if kind == "gbs" else f"drone-cell {via}"
            backhaul = f"backhaul: {hops} hop(s) to a GBS, next {via_name} at {length:.0f} m"
            end = problem.gbs[via] if kind == "gbs" else plan[via, :2]
            reach = problem.r1 if kind == "gbs" else problem.r2
            folium.PolyLine(
                [proj.point(xy[:2]), proj.point(end)],
                color="#2ca02c",
                weight=3,
                class_name="dp-link",
                tooltip=f"drone-cell {i} to {via_name}: {length:.0f} m (range {reach:g} m)",
            ).add_to(links)
        lines = [f"drone-cell {i} at ({xy[0]:.0f}, {xy[1]:.0f}) m"]
        if plan.shape[1] == 3:
            lines.append(f"altitude h = {xy[2]:g} m")
        lines += [f"coverage radius {radii[i]:.0f} m", f"users covered: {users_in}", backhaul]
        folium.Circle(
            proj.point(xy[:2]),
            radius=float(radii[i]),
            color="#000000",
            weight=1,
            fill=True,
            fill_opacity=0.05,
        ).add_to(disks)
        folium.CircleMarker(
            proj.point(xy[:2]),
            radius=7,
            color="#000000" if kind != "none" else "#d62728",
            fill=True,
            fill_opacity=1.0,
            class_name="dp-cell",
            popup=popup(*lines),
            tooltip=f"drone-cell {i}: {users_in} users",
        ).add_to(cells)
    for group in (disks, links, cells):
        group.add_to(fmap)


def map(  # shadows the builtin in this module only: the front door's name is droneplan.cells.map
    problem: CellProblem, result: Any, *, origin: Any = None, tiles: str | None = None, max_users: int = 5000
) -> folium.Map:
    """Interactive map (Leaflet, through folium) of a drone-cell placement; returns the folium Map.

    Layers, each switchable in the layer control: the users (covered by a drone-cell, not covered,
    served by a GBS already), the ground base stations with their cells of radius R_g, the no-fly
    zones, the drone-cells with their coverage disks (R_d, or R(h) of their altitude level) and the
    backhaul links of each drone-cell's shortest route to a GBS (drone-GBS <= r1, drone-drone <= r2;
    a drone-cell without a route is red). Clicking a drone-cell shows its position (m), altitude,
    coverage radius, users covered and its route; a GBS, its radii and the users within R_g.
    Display it in a notebook by leaving it as a cell's value, or save it with ``.save("map.html")``.

    problem: the :class:`CellProblem` (positions in local metres).
    result: a :class:`SolveResult` with a plan (``x``) or the (k, 2) drone-cell positions (m),
        (k, 3) (x, y, h) when the problem has altitude levels.
    origin: None to draw in local metres (Leaflet's simple CRS: one map unit is a metre, no
        background, no geographic position), or (lat, lon) / (lat, lon, alt) in degrees and metres
        (or a :class:`~droneplan.scenarios.geo.LocalFrame`) that the local (0, 0) stands for: the
        map is then on WGS 84 and can show ``tiles``.
    tiles: None (no background map: works offline) or a folium tile set such as
        ``"OpenStreetMap"`` (needs the network, and ``origin``: refused without it).
    max_users: most user markers drawn per layer (count >= 1); a larger layer is sampled evenly
        and its name says so.
    """
    if not isinstance(problem, CellProblem):
        raise TypeError(f"problem must be a CellProblem, got {type(problem).__name__}")
    plan = plan_of(problem, result)
    most = check_int("max_users", max_users, min_value=1)
    tiles = check_tiles(tiles)
    proj = Projection(origin)
    ev = evaluate(problem, plan)
    extent = [problem.gbs, plan[:, :2], problem.users]
    if problem.bounds is not None:
        xmin, xmax, ymin, ymax = problem.bounds
        extent.append(np.array([[xmin, ymin], [xmax, ymax]]))
    fmap = new_map(proj, np.concatenate(extent), tiles=tiles)
    _add_users(fmap, proj, problem, ev.covered_mask, most)
    _add_zones(fmap, proj, problem)
    _add_gbs(fmap, proj, problem)
    _add_cells(fmap, proj, problem, plan)
    title = f"{ev.covered} users covered by {len(plan)} drone-cell(s)" + (
        "" if ev.feasible else " (infeasible)"
    )
    root = fmap.get_root()
    if isinstance(root, Figure):  # the page's title: what a browser tab shows
        root.header.add_child(folium.Element(f"<title>{html.escape(title)}</title>"), name="title")
    folium.LayerControl(collapsed=False).add_to(fmap)
    return fmap


def placement_report_html(n_cells: int = 2, seed: int = 0) -> str:
    """The reproduction report's interactive map: a heading, a caption and an ``<iframe>`` with the
    map of the thesis instance (Table 4.2) of ``seed`` with ``n_cells`` drone-cells, placed as the
    certified library's plan of that instance when it holds one, else by the greedy placement.

    n_cells: drone-cells m (count >= 1); seed: the instance seed (int >= 0).
    """
    from droneplan.formulations.cells import greedy_placement
    from droneplan.scenarios.cells import thesis_problem
    from droneplan.studies.instances import family_instances
    from droneplan.studies.library import lookup

    n_cells = check_int("n_cells", n_cells, min_value=1)
    seed = check_int("seed", seed, min_value=0)
    problem = thesis_problem(n_cells, seed)
    entry = lookup(family_instances("table4.2", m=n_cells, seeds=[seed])[0])
    plan, how = greedy_placement(problem), "greedy placement"
    if entry is not None and evaluate(problem, entry.plan).feasible:
        plan, how = np.asarray(entry.plan, dtype=float), f"certified library plan ({entry.status})"
    covered = evaluate(problem, plan).covered
    caption = (
        f"Thesis instance (Table 4.2, seed {seed}) with {n_cells} drone-cells, {how}: {covered} users "
        "covered. Local metres; click a drone-cell or a GBS for its numbers, switch layers at the top right."
    )
    return (
        "<h3>Interactive placement map</h3>\n"
        f"<p>{html.escape(caption)}</p>\n{embed_html(map(problem, plan), title='drone-cell placement map')}\n"
    )
