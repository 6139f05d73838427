"""Herding plots: herd and drones at any recorded time, the final state, the footprint radius over time."""

from __future__ import annotations

from typing import Any

import numpy as np

from droneplan.core.validation import check_array, check_positive, check_real
from droneplan.scenarios.herding import HerdingFrame, HerdingPhase, HerdingScenario, HerdingTrace
from droneplan.studies.plots._animation import check_options, frame_indices, save_gif
from droneplan.studies.plots._common import as_trace_dict, figure_axes, keep_in_view

__all__ = ["plot_state", "plot_final", "plot_footprint", "animate"]


def _frame_at(trace: HerdingTrace, t: float) -> HerdingFrame:
    """The stored state (frames, snapshots, final) nearest to time t (s)."""
    stored = [*trace.frames, *trace.snapshots.values(), trace.final]
    return min(stored, key=lambda f: abs(f.t - t))


def plot_state(
    source: Any, t: float | None = None, *, goal: Any = None, ax: Any = None, title: str | None = None
):
    """The herd, its centroid and the drones at one instant, with the goal G in view; returns the figure.

    source: a :class:`HerdingTrace` (``t`` in s picks the nearest stored state among the
    run's frames, snapshots and final state, so record them with ``simulate(...,
    frame_every=..., snapshot_times=...)``; None: the final state), a :class:`HerdingFrame`,
    or a :class:`HerdingScenario` (its initial state). goal: G (2,) in m (default: the trace's or
    scenario's goal). Drones are drawn with their heading. ax: a 2-D axes or None. Axes in m.
    A state with NaN or inf positions is refused (ValueError naming ``source``).

    title: axes title (None: the time and phase).
    """
    if t is not None:
        t = check_real("t", t)
    if goal is not None:
        goal = check_array("goal", goal, shape=(2,))
    if isinstance(source, HerdingTrace):
        frame = source.final if t is None else _frame_at(source, t)
        goal = source.goal if goal is None else goal
    elif isinstance(source, HerdingScenario):
        frame = HerdingFrame(
            t=0.0,
            animals=source.animals,
            drones=source.drones,
            headings=source.headings,
            phase=HerdingPhase.GATHERING,
        )
        goal = source.goal if goal is None else goal
    elif isinstance(source, HerdingFrame):
        frame = source
    else:
        raise TypeError(
            f"source must be a HerdingTrace, HerdingFrame or HerdingScenario, got {type(source).__name__}"
        )
    a, d = np.asarray(frame.animals, float), np.asarray(frame.drones, float)
    if not (np.all(np.isfinite(a)) and np.all(np.isfinite(d)) and np.all(np.isfinite(frame.headings))):
        raise ValueError(f"source: the state at t = {frame.t} s has NaN or inf positions or headings")
    fig, ax = figure_axes(ax, title=title, figsize=(7, 4.5))
    c = a.mean(axis=0)
    ax.scatter(*a.T, s=3, c="tab:brown", label=f"animals ({len(a)})")
    ax.plot(*c, "+", color="k", ms=10, mew=1.5, label="herd centroid")
    ax.scatter(*d.T, marker="s", s=28, c="tab:red", zorder=3, label=f"drones ({len(d)})")
    span = float(np.ptp(np.concatenate([a, d]), axis=0).max()) if len(a) + len(d) > 1 else 1.0
    arrow = 0.04 * max(span, 1.0)
    h = np.asarray(frame.headings, float)
    ax.quiver(
        d[:, 0],
        d[:, 1],
        np.cos(h) * arrow,
        np.sin(h) * arrow,
        angles="xy",
        scale_units="xy",
        scale=1,
        color="tab:red",
        width=0.004,
    )
    pts = [a, d]
    if goal is not None:
        g = np.asarray(goal, float).reshape(2)
        ax.plot(*g, "*", color="tab:green", ms=14, label="goal G")
        pts.append(g[None])
    ax.set_aspect("equal", adjustable="datalim")
    keep_in_view(ax, np.concatenate(pts))
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.legend(fontsize=7, loc="best")
    ax.set_title(
        title if title is not None else f"t = {frame.t:.1f} s ({frame.t / 60:.1f} min), {frame.phase.value}",
        fontsize=9,
    )
    return fig


def plot_final(trace: HerdingTrace, *, ax: Any = None, title: str | None = None):
    """The final state of a run (herd, drones, goal G); returns the figure (see :func:`plot_state`).

    trace: the HerdingTrace of a run.
    ax: matplotlib axes to draw on (None: a new figure).
    title: axes title (None: none).
    """
    if not isinstance(trace, HerdingTrace):
        raise TypeError(f"trace must be a HerdingTrace, got {type(trace).__name__}")
    f = trace.final
    if not all(np.all(np.isfinite(np.asarray(v, float))) for v in (f.animals, f.drones, f.headings)):
        raise ValueError("trace: the final state has NaN or inf positions or headings")
    return plot_state(trace, None, ax=ax, title=title)


def plot_footprint(traces: Any, *, R_c: float | None = None, ax: Any = None, title: str | None = None):
    """Footprint radius (max animal-to-centroid distance, m) against time (min), Fig. 6.7a style.

    traces: a :class:`HerdingTrace` or {label: HerdingTrace}; a dotted line marks each run's end
    of gathering; R_c (m) draws the gathering threshold. Returns the figure. ax: a 2-D axes or None.

    title: axes title (None: none).
    """
    runs = as_trace_dict(traces, HerdingTrace)
    if R_c is not None:
        R_c = check_positive("R_c", R_c)
    fig, ax = figure_axes(ax, title=title, figsize=(7, 4))
    for label, tr in runs.items():
        (line,) = ax.plot(tr.t / 60.0, tr.footprint_radius, label=label)
        if tr.gather_time is not None:
            ax.axvline(tr.gather_time / 60.0, ls=":", lw=0.8, color=line.get_color())
    if R_c is not None:
        ax.axhline(R_c, color="k", lw=0.6, label=f"R_c = {R_c:g} m")
    ax.plot([], [], "k:", lw=0.8, label="end of gathering")
    ax.set_xlabel("t (min)")
    ax.set_ylabel("footprint radius (m)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    if title is not None:
        ax.set_title(title)
    return fig


def animate(trace: Any, path: Any, *, fps: int = 8, stride: int = 1, goal: Any = None):
    """Write an animated GIF (top view, m) of a herding run's frames; returns the path (a Path).

    trace: a :class:`HerdingTrace` recorded with ``simulate(..., frame_every=...)`` (its
    ``frames`` are animated). path: the GIF file (str or os.PathLike ending in .gif; its folder
    is created). fps: frames per second of the GIF (an int, 1 to 100). stride: animate every
    ``stride``-th recorded frame (an int >= 1; the last frame is always shown). goal: G (2,) in
    m, kept in view (default: the trace's goal). Frames with NaN or inf positions are refused.
    """
    import matplotlib.pyplot as plt

    if not isinstance(trace, HerdingTrace):
        raise TypeError(f"trace must be a HerdingTrace, got {type(trace).__name__}")
    path, frame_rate, step = check_options(path, fps, stride)
    if not trace.frames:
        raise ValueError("trace has no frames: run simulate(..., frame_every=...)")
    goal = check_array("goal", trace.goal if goal is None else goal, shape=(2,))
    frames = [trace.frames[k] for k in frame_indices(len(trace.frames), step)]
    allpts = np.concatenate([np.concatenate([f.animals, f.drones]) for f in frames] + [goal.reshape(1, 2)])
    if not np.all(np.isfinite(allpts)):
        raise ValueError("trace frames must hold finite positions (a frame has NaN or inf)")
    lo, hi = allpts.min(axis=0) - 20, allpts.max(axis=0) + 20
    fig, ax = plt.subplots(figsize=(7, 4))
    ax.set_xlim(lo[0], hi[0])
    ax.set_ylim(lo[1], hi[1])
    ax.set_aspect("equal")
    herd = ax.scatter([], [], s=3, c="tab:brown", label="animals")
    drones = ax.scatter([], [], marker="s", c="tab:red", s=25, label="drones")
    ax.plot(*goal, "*", color="tab:green", ms=12, label="goal G")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.legend(fontsize=7, loc="upper right")
    title = ax.set_title("")

    def update(k: int):
        f = frames[k]
        herd.set_offsets(f.animals)
        drones.set_offsets(f.drones)
        title.set_text(f"t = {f.t / 60:.1f} min, {f.phase.value}")
        return herd, drones, title

    return save_gif(fig, update, list(range(len(frames))), path, frame_rate)
