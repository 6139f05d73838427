"""Covert-observation plots: the drone's 3-D path with the observation sphere and targets, and beta_m(t)."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

from droneplan.core.validation import check_bool, check_positive
from droneplan.scenarios.covert import CovertScenario, CovertTrace
from droneplan.studies.plots._animation import check_options, frame_indices, save_gif
from droneplan.studies.plots._common import as_trace_dict, figure_axes

__all__ = ["plot_path", "plot_bearing", "plot_stealth_front", "plot_optimised_front", "animate"]


def _sphere_patch(scenario: CovertScenario, drone_paths: list[NDArray[np.float64]], n: int = 20):
    """Wireframe (x, y, z in m) of the part of the observation sphere |D - F| = L_u the drones fly near:
    their azimuth range about F widened by 0.3 rad, elevations from 0 up to theirs plus 0.3 rad."""
    p = scenario.params
    return _sphere_wire(p.F_arr, p.L_u, drone_paths, n)


def _sphere_wire(F: NDArray[np.float64], L_u: float, drone_paths: list[NDArray[np.float64]], n: int = 20):
    """The wireframe of :func:`_sphere_patch` for a sphere of centre F (3,) and radius L_u (m)."""
    rel = np.concatenate(drone_paths) - F
    mean_az = math.atan2(rel[:, 1].mean(), rel[:, 0].mean())
    az = mean_az + np.angle(np.exp(1j * (np.arctan2(rel[:, 1], rel[:, 0]) - mean_az)))
    el = np.arctan2(rel[:, 2], np.hypot(rel[:, 0], rel[:, 1]))
    u = np.linspace(az.min() - 0.3, az.max() + 0.3, n)
    v = np.linspace(0.0, min(float(el.max()) + 0.3, 0.5 * math.pi), max(n // 2, 2))
    return (
        F[0] + L_u * np.outer(np.cos(u), np.cos(v)),
        F[1] + L_u * np.outer(np.sin(u), np.cos(v)),
        F[2] + L_u * np.outer(np.ones_like(u), np.sin(v)),
    )


def plot_path(
    scenario: CovertScenario, traces: Any, *, ax: Any = None, title: str | None = None, terrain: bool = True
):
    """3-D view of covert-observation runs; returns the figure.

    scenario: the :class:`CovertScenario` the runs share; traces: a :class:`CovertTrace` or
    {label: CovertTrace}. Draws the drone paths, the observation sphere |D - F| = L_u (its upper
    half), the target paths (first trace) with their start and end, the reference point R, the
    centre F and the start D_s, and the terrain (``terrain``). ax: a 3-D axes
    (``fig.add_subplot(projection="3d")``) or None for a new figure. Axes in m.

    title: axes title (None: none).
    """
    if not isinstance(scenario, CovertScenario):
        raise TypeError(f"scenario must be a CovertScenario, got {type(scenario).__name__}")
    check_bool("terrain", terrain)
    runs = as_trace_dict(traces, CovertTrace)
    for name, tr in runs.items():
        if not (np.all(np.isfinite(tr.drone)) and np.all(np.isfinite(tr.targets))):
            raise ValueError(f"traces[{name!r}]: the drone or target positions hold NaN or inf")
    fig, ax = figure_axes(ax, title=title, figsize=(8, 6), projection="3d")
    p = scenario.params
    pts = [p.F_arr[None], p.D_s_arr[None], p.R_arr[None]]
    first = next(iter(runs.values()))
    for j in range(first.targets.shape[1]):
        path = first.targets[:, j]
        ax.plot(*path.T, color="tab:brown", lw=1, label="target paths" if j == 0 else None)
        ax.scatter(
            *path[0], color="tab:brown", marker="o", s=12, label="targets at start" if j == 0 else None
        )
        ax.scatter(*path[-1], color="tab:brown", marker="x", s=16, label="targets at end" if j == 0 else None)
        pts.append(path)
    for name, tr in runs.items():
        ax.plot(*tr.drone.T, lw=1.5, label=f"drone: {name}")
        pts.append(tr.drone)
    sx, sy, sz = _sphere_patch(scenario, [tr.drone for tr in runs.values()])
    ax.plot_wireframe(
        sx, sy, sz, color="0.6", lw=0.3, alpha=0.6, label=f"observation sphere (L_u = {p.L_u:g} m)"
    )
    ax.scatter(*p.F_arr, color="k", marker="+", s=40, label="sphere centre F")
    ax.scatter(*p.R_arr, color="k", marker="^", s=30, label="reference point R")
    ax.scatter(*p.D_s_arr, color="tab:green", marker="s", s=30, label="start D_s")
    allp = np.concatenate(
        [np.asarray(a, float).reshape(-1, 3) for a in pts] + [np.c_[sx.ravel(), sy.ravel(), sz.ravel()]]
    )
    lo, hi = allp.min(axis=0), allp.max(axis=0)
    if terrain:
        X, Y = np.meshgrid(np.linspace(lo[0], hi[0], 30), np.linspace(lo[1], hi[1], 30))
        Z = scenario.terrain.height(X, Y)
        ax.plot_surface(X, Y, Z, cmap="YlGn", alpha=0.3, linewidth=0)
        lo[2] = min(lo[2], float(Z.min()))
    pad = 0.03 * np.maximum(hi - lo, 1.0)
    ax.set_xlim(lo[0] - pad[0], hi[0] + pad[0])
    ax.set_ylim(lo[1] - pad[1], hi[1] + pad[1])
    ax.set_zlim(lo[2] - pad[2], hi[2] + pad[2])
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_zlabel("z (m)")
    ax.legend(loc="upper left", fontsize=7)
    if title is not None:
        ax.set_title(title)
    return fig


def plot_bearing(traces: Any, *, ax: Any = None, title: str | None = None):
    """Maximum bearing change beta_m (deg) against time (s) for one or several runs; returns the figure.

    traces: a :class:`CovertTrace` or {label: CovertTrace}; the legend gives each run's beta_max.
    Arrival on and departure from the sphere are marked with dotted lines. ax: a 2-D axes or None.

    title: axes title (None: none).
    """
    runs = as_trace_dict(traces, CovertTrace)
    fig, ax = figure_axes(ax, title=title, figsize=(7, 4))
    for name, tr in runs.items():
        (line,) = ax.plot(
            tr.t, np.degrees(tr.beta_m), label=f"{name} (max {math.degrees(tr.beta_max):.2f} deg)"
        )
        for t_mark in (tr.t_a, tr.t_f):
            if t_mark is not None:
                ax.axvline(t_mark, color=line.get_color(), ls=":", lw=0.8)
    ax.set_xlabel("t (s)")
    ax.set_ylabel("max bearing change beta_m (deg)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, title="dotted: on the sphere from / until", title_fontsize=7)
    if title is not None:
        ax.set_title(title)
    return fig


def plot_stealth_front(points: Any, bound: Any, *, ax: Any = None, title: str | None = None):
    """beta_max (deg) against arrival time on the sphere (s): one marker per run and the whole-mission
    lower bound for any controller arriving by then; returns the figure.

    points, bound: the DataFrames of :func:`studies.thesis.covert.stealth_front`. ax: a 2-D axes or None;
    title: the axes title (None: none). points needs the columns method, t_a and beta_max_deg;
    bound the columns t_a and bound_deg (either may have no rows).
    """
    _check_frame("points", points, ("method", "t_a", "beta_max_deg"))
    _check_frame("bound", bound, ("t_a", "bound_deg"))
    fig, ax = figure_axes(ax, title=title, figsize=(7, 4.5))
    ax.plot(bound.t_a, bound.bound_deg, "k.-", label="lower bound: any controller on the sphere by t_a")
    for _, r in points.iterrows():
        ax.plot(r.t_a, r.beta_max_deg, "o", label=f"{r.method} ({r.beta_max_deg:.2f} deg)")
    ax.set_xlabel("arrival time on the sphere t_a (s)")
    ax.set_ylabel("beta_max (deg)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7)
    if title is not None:
        ax.set_title(title)
    return fig


def plot_optimised_front(
    points: Any, curve: Any, *, ax: Any = None, title: str | None = None, margin_deg: float = 1.0
):
    """Figure of the optimised stealth-arrival front: beta_max (deg) against the arrival-time limit (s).

    points, curve: the two DataFrames of :func:`studies.thesis.covert_front.optimised_front` (points needs
    arrival_limit_s, beta_max_deg, bound_deg and certified_within_deg; curve t_a and bound_deg;
    either may have no rows). Each point is drawn at its limit with its bound below it; points
    certified within ``margin_deg`` (deg, > 0) are filled, the others hollow, and each is labelled
    with its distance to the bound. ax: a 2-D axes or None; title: the axes title (None: a default).
    """
    _check_frame("points", points, ("arrival_limit_s", "beta_max_deg", "bound_deg", "certified_within_deg"))
    _check_frame("curve", curve, ("t_a", "bound_deg"))
    margin_deg = check_positive("margin_deg", margin_deg)
    fig, ax = figure_axes(ax, title=title, figsize=(7, 4.5))
    if len(curve):
        ax.plot(curve.t_a, curve.bound_deg, "k--", label="whole-mission lower bound (curve)")
    pts = points.dropna(subset=["beta_max_deg"])
    ax.plot(pts.arrival_limit_s, pts.beta_max_deg, "C0-", lw=1, label="optimised front (closed loop)")
    ax.plot(pts.arrival_limit_s, pts.bound_deg, "kx", label="bound of each point's class")
    cert = pts.certified_within_deg <= margin_deg
    ax.plot(
        pts.arrival_limit_s[cert],
        pts.beta_max_deg[cert],
        "o",
        color="C0",
        label=f"certified within {margin_deg:g} deg",
    )
    ax.plot(
        pts.arrival_limit_s[~cert],
        pts.beta_max_deg[~cert],
        "o",
        mfc="none",
        color="C0",
        label=f"gap above {margin_deg:g} deg",
    )
    for _, r in pts.iterrows():
        ax.annotate(
            f"+{r.certified_within_deg:.2f} deg",
            (r.arrival_limit_s, r.beta_max_deg),
            textcoords="offset points",
            xytext=(4, 4),
        )
    ax.set_xlabel("arrival-time limit (s)")
    ax.set_ylabel("max bearing change (deg)")
    ax.set_title(title if title is not None else "Stealth vs arrival time: optimised front and lower bound")
    ax.legend(fontsize=8)
    return fig


def _check_frame(name: str, df: Any, columns: tuple[str, ...]) -> None:
    import pandas as pd

    if not isinstance(df, pd.DataFrame):
        raise TypeError(f"{name} must be a pandas DataFrame, got {type(df).__name__}")
    missing = [c for c in columns if c not in df.columns]
    if missing:
        raise ValueError(f"{name} lacks the column(s) {missing} (needs {list(columns)})")


def animate(trace: Any, path: Any, *, fps: int = 8, stride: int = 1, view: str = "top"):  # noqa: PLR0915
    """Write an animated GIF of a covert-observation run; returns the path (a Path).

    trace: a :class:`CovertTrace` (every recorded instant, spaced by the control period dt, is a
    candidate frame). path: the GIF file (str or os.PathLike ending in .gif; its folder is
    created). fps: frames per second of the GIF (an int, 1 to 100). stride: animate every
    ``stride``-th recorded instant (an int >= 1; the last instant is always shown, at most
    2000 frames). view: "top" (x, y in m: the observation sphere's horizon circle of radius
    L_u and its cross-section at the drone's altitude, the targets and their tracks, the drone
    and its track, R and F) or "3d" (x, y, z in m: the part of the sphere the drone flies near,
    targets, drone). The title gives the time (s), the phase and beta_m (deg). A run whose drone
    or target positions hold NaN or inf is refused (ValueError naming ``trace``).
    """
    import matplotlib.pyplot as plt

    if not isinstance(trace, CovertTrace):
        raise TypeError(f"trace must be a CovertTrace, got {type(trace).__name__}")
    path, frame_rate, step = check_options(path, fps, stride)
    if view not in ("top", "3d"):
        raise ValueError(f"view must be 'top' or '3d', got {view!r}")
    if not (np.all(np.isfinite(trace.drone)) and np.all(np.isfinite(trace.targets))):
        raise ValueError("trace: the drone or target positions hold NaN or inf")
    frames = frame_indices(len(trace.t), step)
    F, R, L_u = np.asarray(trace.F, float), np.asarray(trace.R, float), float(trace.L_u)
    D, A = trace.drone, trace.targets
    n = A.shape[1]
    beta_m = np.degrees(trace.beta_m)
    pts = np.concatenate([D, A.reshape(-1, 3), F[None], R[None]])
    if view == "3d":
        fig = plt.figure(figsize=(7, 5.5))
        ax = fig.add_subplot(projection="3d")
        sx, sy, sz = _sphere_wire(F, L_u, [D])
        ax.plot_wireframe(
            sx, sy, sz, color="0.6", lw=0.3, alpha=0.5, label=f"observation sphere (L_u = {L_u:g} m)"
        )
        for j in range(n):
            ax.plot(
                *A[:, j].T, color="tab:brown", lw=0.6, alpha=0.4, label="target tracks" if j == 0 else None
            )
        ax.scatter(*F, color="k", marker="+", s=40, label="sphere centre F")
        ax.scatter(*R, color="k", marker="^", s=30, label="reference point R")
        (track,) = ax.plot([], [], [], color="tab:blue", lw=1.5, label="drone")
        (now,) = ax.plot([], [], [], "o", color="tab:blue", ms=5)
        (herd,) = ax.plot([], [], [], "o", color="tab:brown", ms=4, ls="", label="targets")
        allp = np.concatenate([pts, np.c_[sx.ravel(), sy.ravel(), sz.ravel()]])
        lo, hi = allp.min(axis=0), allp.max(axis=0)
        pad = 0.03 * np.maximum(hi - lo, 1.0)
        ax.set_xlim(lo[0] - pad[0], hi[0] + pad[0])
        ax.set_ylim(lo[1] - pad[1], hi[1] + pad[1])
        ax.set_zlim(lo[2] - pad[2], hi[2] + pad[2])
        ax.set_zlabel("z (m)")
        circle = None
    else:
        fig, ax = plt.subplots(figsize=(6.5, 6))
        th = np.linspace(0.0, 2.0 * math.pi, 120)
        ax.plot(
            F[0] + L_u * np.cos(th),
            F[1] + L_u * np.sin(th),
            color="0.6",
            lw=0.8,
            ls="--",
            label=f"observation sphere at z = {F[2]:g} m (L_u = {L_u:g} m)",
        )
        (circle,) = ax.plot([], [], color="tab:purple", lw=0.9, label="sphere at the drone's altitude")
        for j in range(n):
            ax.plot(
                *A[:, j, :2].T,
                color="tab:brown",
                lw=0.6,
                alpha=0.4,
                label="target tracks" if j == 0 else None,
            )
        ax.plot(*F[:2], "k+", ms=8, label="sphere centre F")
        ax.plot(*R[:2], "k^", ms=6, label="reference point R")
        (track,) = ax.plot([], [], color="tab:blue", lw=1.5, label="drone")
        (now,) = ax.plot([], [], "o", color="tab:blue", ms=5)
        (herd,) = ax.plot([], [], "o", color="tab:brown", ms=4, ls="", label="targets")
        lo = np.minimum(pts[:, :2].min(axis=0), F[:2] - L_u)
        hi = np.maximum(pts[:, :2].max(axis=0), F[:2])
        pad = 0.04 * np.maximum(hi - lo, 1.0)
        ax.set_xlim(lo[0] - pad[0], hi[0] + pad[0])
        ax.set_ylim(lo[1] - pad[1], hi[1] + pad[1])
        ax.set_aspect("equal")
        ax.grid(alpha=0.3)
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.legend(fontsize=6, loc="upper left")
    title = ax.set_title("")

    def update(k: int):
        i = frames[k]
        if view == "3d":
            track.set_data_3d(*D[: i + 1].T)
            now.set_data_3d(*D[i : i + 1].T)
            herd.set_data_3d(*A[i].T)
        else:
            track.set_data(*D[: i + 1, :2].T)
            now.set_data(*D[i : i + 1, :2].T)
            herd.set_data(*A[i, :, :2].T)
            dz = D[i, 2] - F[2]
            r = math.sqrt(L_u * L_u - dz * dz) if abs(dz) < L_u else 0.0
            if circle is not None:
                circle.set_data(F[0] + r * np.cos(th), F[1] + r * np.sin(th))
        bm = f"{beta_m[i]:.1f} deg" if np.isfinite(beta_m[i]) else "no target seen"
        title.set_text(f"t = {trace.t[i]:.1f} s, {trace.phase[i]}, beta_m = {bm}")
        return track, now, herd, circle, title

    return save_gif(fig, update, list(range(len(frames))), path, frame_rate)
