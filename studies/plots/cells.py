"""Drone-cell placement maps (thesis Fig. 4.4 style)."""

from __future__ import annotations

from typing import Any

import numpy as np
from matplotlib.lines import Line2D
from matplotlib.patches import Circle

from droneplan.core.validation import check_bool, check_int, check_size
from droneplan.formulations.cells import CellProblem, evaluate
from droneplan.planners.cells import deployment_region
from droneplan.studies.plots._common import figure_axes, keep_in_view

__all__ = ["plot_map", "plot_deployment_region"]


def _links(problem: CellProblem, pos: np.ndarray, connected: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The backhaul links within range, as (k, 2, 2) segments (m): those of drone-cells that reach a
    GBS, and those of drone-cells that do not. Drone-GBS within r1, drone-drone within r2. Links
    drawn twice (coincident drone-cells) and links of zero length are dropped."""
    check_size("positions (drone-cell pairs)", float(len(pos)) ** 2 + len(pos) * len(problem.gbs))
    good_cell = np.asarray(connected, bool)
    d_g = np.linalg.norm(pos[:, None, :] - problem.gbs[None, :, :], axis=2)
    cell_g, gbs = np.nonzero(d_g <= problem.r1)
    d_d = np.linalg.norm(pos[:, None, :] - pos[None, :, :], axis=2)
    cell_i, cell_j = np.nonzero(np.triu((d_d <= problem.r2) & (d_d > 0), k=1))
    seg = np.concatenate(
        [np.stack([pos[cell_g], problem.gbs[gbs]], axis=1), np.stack([pos[cell_i], pos[cell_j]], axis=1)]
    ).reshape(-1, 2, 2)
    good = np.concatenate([good_cell[cell_g], good_cell[cell_i]])
    return _unique_segments(seg[good]), _unique_segments(seg[~good])


def _unique_segments(seg: np.ndarray) -> np.ndarray:
    """The distinct (n, 2, 2) segments of ``seg``."""
    if not len(seg):
        return seg
    return np.unique(seg.reshape(-1, 4), axis=0).reshape(-1, 2, 2)


def _polyline(segments: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """x and y of (n, p, 2) polylines joined into one line, NaN between polylines: one matplotlib
    artist for any number of links or circles."""
    n, p = segments.shape[:2]
    xy = np.full((n, p + 1, 2), np.nan)
    xy[:, :p] = segments
    return xy[..., 0].ravel(), xy[..., 1].ravel()


def _circles(centres: np.ndarray, radius: float, points: int = 97) -> np.ndarray:
    """(n, points, 2) closed polylines of the circles of ``radius`` (m) around ``centres``."""
    angle = np.linspace(0.0, 2.0 * np.pi, points)
    ring = radius * np.stack([np.cos(angle), np.sin(angle)], axis=1)
    return np.asarray(centres, float).reshape(-1, 1, 2) + ring[None, :, :]


def plot_map(  # noqa: C901
    problem: CellProblem, positions: Any, *, ax: Any = None, title: str | None = None, ranges: bool = False
):
    """Map of a drone-cell placement; returns the figure.

    problem: the :class:`CellProblem`; positions: (k, 2) drone-cell positions (m).
    Draws the users (grey: served by a GBS already, light: not covered, black: covered by a
    drone-cell), each GBS with its cell of radius R_g, the drone-cells with their coverage disk
    of radius R_d, and the backhaul links in use (drone-GBS within r1, drone-drone within r2;
    solid when the drone-cell reaches a GBS, dashed red when it does not). ``ranges`` also draws
    the r1 circles around the GBSs. ax: a 2-D matplotlib axes, or None for a new figure;
    title: the axes title (None: none).
    The view covers ``problem.bounds`` (or all users, GBSs and drone-cells).

    title: axes title (None: none).
    """
    if not isinstance(problem, CellProblem):
        raise TypeError(f"problem must be a CellProblem, got {type(problem).__name__}")
    check_bool("ranges", ranges)
    ev = evaluate(problem, positions)
    pos = np.asarray(positions, dtype=float).reshape(-1, 2)
    fig, ax = figure_axes(ax, title=title, figsize=(5.5, 5.5))
    users = problem.users
    served = ~problem.active
    covered = ev.covered_mask
    uncovered = problem.active & ~covered
    ax.scatter(*users[served].T, s=3, c="0.75", label="users served by a GBS")
    ax.scatter(*users[uncovered].T, s=3, c="tab:orange", label="users not covered")
    ax.scatter(*users[covered].T, s=4, c="k", label=f"covered users ({ev.covered})")
    for g in problem.gbs:
        ax.add_patch(Circle(g, problem.R_g, fill=False, color="tab:blue", lw=1.0))
        if ranges:
            ax.add_patch(Circle(g, problem.r1, fill=False, color="tab:blue", ls="--", lw=0.6))
    ax.scatter(*problem.gbs.T, marker="^", s=60, c="tab:blue", zorder=3, label="GBS (cell radius R_g)")
    # backhaul links in use
    link_ok: dict[str, Any] = dict(color="tab:green", lw=1.2)  # matplotlib line style keywords
    link_bad: dict[str, Any] = dict(color="tab:red", lw=1.2, linestyle="--")
    ok, bad = _links(problem, pos, ev.connected)
    for segments, style in ((ok, link_ok), (bad, link_bad)):
        if len(segments):
            ax.plot(*_polyline(segments), **style)
    if len(pos):  # one artist for all coverage disks: a thousand drone-cells draw as fast as one
        ax.plot(*_polyline(_circles(np.unique(pos, axis=0), problem.R_d)), color="k", lw=1.0)
    if len(pos):
        ax.scatter(*pos.T, marker="s", s=30, c="k", zorder=3, label="drone-cells (coverage radius R_d)")
    handles, labels = ax.get_legend_handles_labels()
    handles.append(Line2D([], [], **link_ok))
    labels.append("backhaul link (drone-GBS <= r1, drone-drone <= r2)")
    if len(pos) and not ev.connected.all():
        handles.append(Line2D([], [], **link_bad))
        labels.append("link of a drone-cell without backhaul")
    ax.set_aspect("equal")
    if problem.bounds is not None:
        ax.set_xlim(problem.bounds[0], problem.bounds[1])
        ax.set_ylim(problem.bounds[2], problem.bounds[3])
    else:
        ax.autoscale_view()
    keep_in_view(ax, np.concatenate([problem.gbs, pos]))
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.legend(handles, labels, fontsize=7, loc="upper right")
    if title is not None:
        ax.set_title(title, fontsize=9)
    return fig


def plot_deployment_region(problem: CellProblem, placed: Any = (), *, ax: Any = None, quad_segs: int = 64):
    """Thesis Fig. 4.2: the deployment region (Definition 4.3.1, grey) of one more drone-cell
    given the GBSs and the drone-cells ``placed`` ((k, 2) m); returns the figure.

    problem: the :class:`CellProblem` (GBSs, radii, bounds). Draws the keep-out circles
    (R_g + R_d around each GBS, 2 R_d around each placed cell,
    solid) and the backhaul circles (r1 around GBSs, r2 around placed cells, dashed). The
    region is :meth:`Region.geometry` (shapely) with ``quad_segs`` segments per quarter circle.
    ax: a 2-D matplotlib axes, or None for a new figure. quad_segs: segments per quarter circle
    (int >= 1; the polygons' vertices count against the array-element budget).
    """
    from shapely.geometry import MultiPolygon, Polygon

    region = deployment_region(problem, placed)
    quad_segs = check_int("quad_segs", quad_segs, min_value=1)
    check_size("quad_segs", 4 * quad_segs * len(region.circles()) * 2)  # polygon vertices (x, y)
    geom = region.geometry(quad_segs=quad_segs)
    fig, ax = figure_axes(ax, figsize=(5.5, 5.5))
    polys = (
        list(geom.geoms) if isinstance(geom, MultiPolygon) else ([geom] if isinstance(geom, Polygon) else [])
    )
    for k, poly in enumerate(p for p in polys if not p.is_empty):
        ax.fill(*poly.exterior.xy, color="0.8", label="deployment region" if k == 0 else None)
        for hole in poly.interiors:
            ax.fill(*hole.xy, color="white")
    for discs, style in ((region.exclude, {"color": "k"}), (region.link, {"color": "tab:red", "ls": "--"})):
        rings = [_circles(np.array([[cx, cy]]), r) for cx, cy, r in dict.fromkeys(discs)]
        if rings:  # one artist per style, each distinct circle once
            ax.plot(*_polyline(np.concatenate(rings)), lw=0.8, **style)
    ax.scatter(*problem.gbs.T, marker="^", s=60, c="tab:blue", zorder=3, label="GBS")
    pl = np.asarray(placed, dtype=float).reshape(-1, 2)
    if len(pl):
        ax.scatter(*pl.T, marker="s", s=30, c="k", zorder=3, label="deployed drone-cell")
    handles, labels = ax.get_legend_handles_labels()
    handles += [Line2D([], [], color="k", lw=0.8), Line2D([], [], color="tab:red", ls="--", lw=0.8)]
    labels += ["keep-out (R_g + R_d, 2 R_d)", "backhaul reach (r1, r2)"]
    reach = max(r for _, _, r in region.circles())
    centres = np.concatenate([problem.gbs, pl])
    ax.set_xlim(centres[:, 0].min() - reach, centres[:, 0].max() + reach)
    ax.set_ylim(centres[:, 1].min() - reach, centres[:, 1].max() + reach)
    ax.set_aspect("equal")
    keep_in_view(ax, centres)
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.legend(handles, labels, fontsize=7, loc="upper right")
    ax.set_title(f"deployment region: {geom.area / 1e6:.1f} km$^2$", fontsize=9)
    return fig
