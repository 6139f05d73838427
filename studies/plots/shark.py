"""Shark-interception plots: the top view of the runs and their time series."""

from __future__ import annotations

from typing import Any

import numpy as np

from droneplan.scenarios.shark import InterceptionTrace
from droneplan.studies.plots._animation import check_options, frame_indices, save_gif
from droneplan.studies.plots._common import as_trace_dict, figure_axes, keep_in_view

__all__ = ["plot_top_view", "plot_time_series", "animate"]

_QUANTITIES = {
    "clearance": "D_h - eps(h) (m); contact at 0",
    "altitude": "altitude z (m)",
    "speed": "speed (m/s)",
}


def plot_top_view(traces: Any, *, ax: Any = None, title: str | None = None):
    """Top view (x, y in m) of interception runs against one shark path; returns the figure.

    traces: an :class:`InterceptionTrace` or {label: InterceptionTrace} on the same path.
    Draws the shark's path (from the longest run) with its start, each operator's path with its
    start, and at first contact the field's circle of radius eps on the shark's plane and the
    contact angle in the legend. ax: a 2-D axes or None for a new figure.

    title: axes title (None: none).
    """
    runs = as_trace_dict(traces, InterceptionTrace)
    fig, ax = figure_axes(ax, title=title, figsize=(6.5, 5))
    longest = max(runs.values(), key=lambda tr: len(tr.t))
    ax.plot(*longest.shark[:, :2].T, "k", lw=2, label="shark")
    ax.plot(*longest.shark[0, :2], "ko", ms=5, label="shark start")
    th = np.linspace(0.0, 2 * np.pi, 72)
    pts = [longest.shark[:, :2]]
    for name, tr in runs.items():
        label = (
            f"{name}: contact at {tr.intercept_time:.1f} s, {tr.frontal_angle:.0f} deg off the heading"
            if tr.intercepted
            else f"{name}: no contact"
        )
        (line,) = ax.plot(*tr.operator[:, :2].T, lw=1.3, label=label)
        ax.plot(*tr.operator[0, :2], "o", color=line.get_color(), ms=4)
        pts.append(tr.operator[:, :2])
        if tr.intercepted:
            O = tr.final.operator
            ax.plot(
                O[0] + tr.contact_eps * np.cos(th),
                O[1] + tr.contact_eps * np.sin(th),
                color=line.get_color(),
                lw=0.8,
                ls="--",
            )
            ax.plot(*tr.final.shark[:2], "x", color=line.get_color(), ms=7)
    ax.plot([], [], "k--", lw=0.8, label="field at contact (radius eps)")
    ax.plot([], [], "kx", label="shark at contact")
    ax.set_aspect("equal", adjustable="datalim")
    keep_in_view(ax, np.concatenate(pts))
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7)
    if title is not None:
        ax.set_title(title)
    return fig


def plot_time_series(traces: Any, quantity: str = "clearance", *, ax: Any = None, title: str | None = None):
    """One time series of interception runs against time (s); returns the figure.

    quantity: "clearance" (horizontal distance minus the field radius on the shark's plane,
    D_h - eps(h), m: the field touches the shark at 0), "altitude" (operator z_o and shark z_s,
    m) or "speed" (|v_o| and |v_s|, m/s). traces: an :class:`InterceptionTrace` or {label: trace}.
    Each run's contact time is marked with a dotted line. ax: a 2-D axes or None.

    title: axes title (None: none).
    """
    if quantity not in _QUANTITIES:
        raise ValueError(f"quantity must be one of {sorted(_QUANTITIES)}, got {quantity!r}")
    runs = as_trace_dict(traces, InterceptionTrace)
    fig, ax = figure_axes(ax, title=title, figsize=(7, 4))
    longest = max(runs.values(), key=lambda tr: len(tr.t))
    if quantity == "altitude":
        ax.plot(longest.t, longest.shark[:, 2], "k", lw=2, label="shark z_s")
    elif quantity == "speed":
        ax.plot(longest.t, np.linalg.norm(longest.shark_vel, axis=1), "k", lw=2, label="shark |v_s|")
    else:
        ax.axhline(0.0, color="k", lw=0.8, label="contact")
    for name, tr in runs.items():
        if quantity == "clearance":
            y, label = tr.D_h - tr.eps, name
        elif quantity == "altitude":
            y, label = tr.operator[:, 2], f"{name} z_o"
        else:  # the last velocity row is a placeholder (no command after the run ends)
            y, label = np.r_[np.linalg.norm(tr.operator_vel[:-1], axis=1), np.nan], f"{name} |v_o|"
        (line,) = ax.plot(tr.t, y, label=label)
        if tr.intercepted:
            ax.axvline(tr.intercept_time, color=line.get_color(), ls=":", lw=0.8)
    ax.set_xlabel("t (s)")
    ax.set_ylabel(_QUANTITIES[quantity])
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7)
    if title is not None:
        ax.set_title(title)
    return fig


def animate(trace: Any, path: Any, *, fps: int = 8, stride: int = 1):
    """Write an animated GIF (top view, x and y in m) of an interception run; returns the path (a Path).

    trace: an :class:`InterceptionTrace` (every recorded instant, spaced by the control period
    Ts, is a candidate frame). path: the GIF file (str or os.PathLike ending in .gif; its
    folder is created). fps: frames per second of the GIF (an int, 1 to 100). stride: animate
    every ``stride``-th recorded instant (an int >= 1; the last instant, the contact when there
    is one, is always shown; at most 2000 frames). Each frame shows the shark and the operator
    with their tracks so far and the field's circle of radius eps (m) on the shark's plane about
    the operator; the title gives the time (s) and the clearance D_h - eps (m, contact at 0).
    A run whose positions or field radii hold NaN or inf is refused (ValueError naming ``trace``).
    """
    import matplotlib.pyplot as plt

    if not isinstance(trace, InterceptionTrace):
        raise TypeError(f"trace must be an InterceptionTrace, got {type(trace).__name__}")
    path, frame_rate, step = check_options(path, fps, stride)
    O, S, eps = trace.operator, trace.shark, trace.eps
    if not (np.all(np.isfinite(O)) and np.all(np.isfinite(S)) and np.all(np.isfinite(eps))):
        raise ValueError("trace: the operator or shark positions or the field radii eps hold NaN or inf")
    frames = frame_indices(len(trace.t), step)
    fig, ax = plt.subplots(figsize=(6.5, 5.5))
    ax.plot(*S[:, :2].T, color="k", lw=0.6, alpha=0.3)
    ax.plot(*O[:, :2].T, color="tab:blue", lw=0.6, alpha=0.3)
    (shark_track,) = ax.plot([], [], "k", lw=1.8, label="shark")
    (shark_now,) = ax.plot([], [], "k>", ms=7)
    (op_track,) = ax.plot([], [], color="tab:blue", lw=1.3, label="operator")
    (op_now,) = ax.plot([], [], "o", color="tab:blue", ms=5)
    (field,) = ax.plot(
        [], [], color="tab:red", lw=0.9, ls="--", label="field on the shark's plane (radius eps)"
    )
    th = np.linspace(0.0, 2.0 * np.pi, 72)
    big = float(np.max(eps)) if eps.size else 0.0
    keep_in_view(ax, np.concatenate([S[:, :2], O[:, :2] - big, O[:, :2] + big]))
    ax.set_aspect("equal", adjustable="box")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, loc="upper left")
    title = ax.set_title("")
    heading = np.degrees(np.arctan2(trace.shark_vel[:, 1], trace.shark_vel[:, 0]))

    def update(k: int):
        i = frames[k]
        shark_track.set_data(*S[: i + 1, :2].T)
        shark_now.set_data(S[i : i + 1, 0], S[i : i + 1, 1])
        if np.isfinite(heading[i]):
            shark_now.set_marker((3, 0, heading[i] - 90.0))
        op_track.set_data(*O[: i + 1, :2].T)
        op_now.set_data(O[i : i + 1, 0], O[i : i + 1, 1])
        field.set_data(O[i, 0] + eps[i] * np.cos(th), O[i, 1] + eps[i] * np.sin(th))
        contact = " (contact)" if trace.intercepted and i == len(trace.t) - 1 else ""
        title.set_text(
            f"t = {trace.t[i]:.1f} s, clearance D_h - eps = {trace.D_h[i] - eps[i]:.1f} m{contact}"
        )
        return shark_track, shark_now, op_track, op_now, field, title

    return save_gif(fig, update, list(range(len(frames))), path, frame_rate)
