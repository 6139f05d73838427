"""Shared pieces of the plotting helpers: the optional-axes convention and keeping points in view."""

from __future__ import annotations

from typing import Any

import matplotlib.axes
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.figure import Figure

__all__ = ["figure_axes", "keep_in_view", "as_trace_dict"]


def figure_axes(
    ax: Any = None,
    *,
    figsize: tuple[float, float] = (6.0, 4.5),
    projection: str | None = None,
    title: Any = None,
):
    """(figure, axes): ``ax`` and its figure, or a new figure with one axes of ``projection``.

    title: the caller's ``title`` argument, checked here (a str or None) before any figure exists.
    Raises TypeError when ``ax`` is not a matplotlib Axes or ``title`` is not a str, ValueError when
    ``ax`` has the wrong projection.
    """
    if title is not None and not isinstance(title, str):
        raise TypeError(f"title must be a str or None, got {type(title).__name__}")
    if ax is None:
        fig = plt.figure(figsize=figsize)
        return fig, fig.add_subplot(projection=projection)
    if not isinstance(ax, matplotlib.axes.Axes):
        raise TypeError(f"ax must be a matplotlib Axes or None, got {type(ax).__name__}")
    want = projection or "rectilinear"
    if ax.name != want:
        raise ValueError(f"ax must be a {want!r} axes, got {ax.name!r}")
    owner = ax.get_figure()
    if not isinstance(owner, Figure):
        raise ValueError("ax must belong to a matplotlib Figure (a subfigure's axes are not supported)")
    return owner, ax


def keep_in_view(ax: Any, points: Any, *, margin: float = 0.05) -> None:
    """Widen the x/y limits of a 2-D ``ax`` so all ``points`` ((k, 2), m) are inside, with a margin."""
    pts = np.asarray(points, dtype=float).reshape(-1, 2)
    pts = pts[np.all(np.isfinite(pts), axis=1)]
    if not len(pts):
        return
    x0, x1 = ax.get_xlim()
    y0, y1 = ax.get_ylim()
    lo = np.minimum(pts.min(axis=0), [x0, y0])
    hi = np.maximum(pts.max(axis=0), [x1, y1])
    pad = margin * np.maximum(hi - lo, 1.0)
    if pts[:, 0].min() < x0 or pts[:, 0].max() > x1:
        ax.set_xlim(lo[0] - pad[0], hi[0] + pad[0])
    if pts[:, 1].min() < y0 or pts[:, 1].max() > y1:
        ax.set_ylim(lo[1] - pad[1], hi[1] + pad[1])


def as_trace_dict(traces: Any, trace_type: type, name: str = "traces") -> dict[str, Any]:
    """{label: trace} from one trace (labelled by its ``name`` or "run") or a dict of them.

    TypeError naming ``name`` for anything else; ValueError when a trace has no recorded instant."""
    if isinstance(traces, trace_type):
        runs = {getattr(traces, "name", "") or "run": traces}
    elif isinstance(traces, dict) and traces and all(isinstance(v, trace_type) for v in traces.values()):
        runs = {str(k): v for k, v in traces.items()}
    else:
        raise TypeError(
            f"{name} must be a {trace_type.__name__} or a non-empty dict of them, got {type(traces).__name__}"
        )
    for label, trace in runs.items():
        if len(np.atleast_1d(getattr(trace, "t", ()))) == 0:
            raise ValueError(f"{name}[{label!r}] has no recorded instants: there is nothing to plot")
    return runs
