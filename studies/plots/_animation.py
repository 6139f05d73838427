"""The one GIF writer behind the ``animate`` helpers of the closed-loop problems (covert, shark,
herding): option checks, frame selection and saving through matplotlib's PillowWriter (Pillow
only; no ffmpeg needed)."""

from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from droneplan.core.validation import check_int

__all__ = ["MAX_FRAMES", "check_options", "frame_indices", "save_gif", "finite_or_raise"]

MAX_FRAMES = 2000
"""Most frames one GIF may hold (count); a longer run needs a larger ``stride``."""


def check_options(path: Any, fps: Any, stride: Any) -> tuple[Path, int, int]:
    """(path, fps, stride) checked: path a str or os.PathLike naming a .gif file; fps an int in
    1..100 (frames per second of the GIF); stride an int >= 1 (recorded instants per frame).
    TypeError/ValueError naming the parameter otherwise; nothing is written."""
    frame_rate = check_int("fps", fps, min_value=1, max_value=100)
    step = check_int("stride", stride, min_value=1)
    if isinstance(path, bool) or not isinstance(path, (str, os.PathLike)):
        raise TypeError(f"path must be a str or os.PathLike, got {type(path).__name__}")
    if Path(path).suffix.lower() != ".gif":
        raise ValueError(f"path must name a .gif file, got {str(path)!r}")
    return Path(path), frame_rate, step


def frame_indices(n: int, stride: int) -> list[int]:
    """Every ``stride``-th of ``n`` recorded instants, always ending on the last one.

    ValueError naming ``trace`` when there is no recorded instant, naming ``stride`` when that makes
    more than MAX_FRAMES frames."""
    if n <= 0:
        raise ValueError("trace has no recorded instants: there is nothing to animate")
    idx = list(range(0, n, stride))
    if idx[-1] != n - 1:
        idx.append(n - 1)
    if len(idx) > MAX_FRAMES:
        raise ValueError(
            f"stride = {stride} gives {len(idx)} frames from {n} recorded instants, more than "
            f"{MAX_FRAMES}; use stride >= {-(-n // MAX_FRAMES)}"
        )
    return idx


def save_gif(fig: Any, update: Callable[[int], Any], frames: list[int], path: Path, fps: int) -> Path:
    """Draw ``update(k)`` for each k of ``frames`` on ``fig`` and save the animation as a GIF at
    ``fps`` frames per second; the folder of ``path`` is created and the figure closed. Returns path."""
    import matplotlib.pyplot as plt
    from matplotlib.animation import FuncAnimation, PillowWriter

    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        anim = FuncAnimation(fig, update, frames=frames, blit=False, cache_frame_data=False)
        anim.save(path, writer=PillowWriter(fps=fps))
    finally:
        plt.close(fig)
    return path


def finite_or_raise(name: str, values: Any, what: str) -> None:
    """ValueError naming ``name`` when ``values`` (array-like) holds NaN or inf."""
    if not np.all(np.isfinite(np.asarray(values, dtype=float))):
        raise ValueError(f"{name}: {what} hold NaN or inf")
