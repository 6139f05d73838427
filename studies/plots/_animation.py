"""The one GIF writer behind the ``animate`` helpers of the closed-loop problems (covert, shark,
herding): option checks, frame selection and saving the frames with Pillow (no ffmpeg
needed), the static part of the figure drawn once."""

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
    """Draw ``update(k)`` for each k of ``frames`` on ``fig`` and save the frames as a looping GIF at
    ``fps`` frames per second; the folder of ``path`` is created and the figure closed. Returns path.

    ``update`` returns every artist it changes (None entries are skipped). The rest of the figure
    (axes, ticks, legend, tracks) is drawn once and each frame redraws only those artists over it
    (blitting): matplotlib's own ``Animation.save`` draws the whole figure twice per frame, and the
    axes' text is most of that work. The pixels are the same as a full draw's, except that the
    changing artists lie on top.
    """
    import matplotlib.pyplot as plt
    from PIL import Image

    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        canvas = fig.canvas
        images = []
        for i, k in enumerate(frames):
            changed = [a for a in _as_artists(update(k)) if a is not None]
            if i == 0:  # the static part, once: the changing artists left out of it
                for a in changed:
                    a.set_animated(True)
                canvas.draw()
                background = canvas.copy_from_bbox(fig.bbox)
            canvas.restore_region(background)
            for a in changed:
                fig.draw_artist(a)
            size = canvas.get_width_height(physical=True)
            images.append(Image.frombuffer("RGBA", size, bytes(canvas.buffer_rgba()), "raw", "RGBA", 0, 1))
        images[0].save(path, save_all=True, append_images=images[1:], duration=int(1000 / fps), loop=0)
    finally:
        plt.close(fig)
    return path


def _as_artists(changed: Any) -> list[Any]:
    """The artists an ``update`` returned (one artist, or a list or tuple of them)."""
    return list(changed) if isinstance(changed, (list, tuple)) else [changed]


def finite_or_raise(name: str, values: Any, what: str) -> None:
    """ValueError naming ``name`` when ``values`` (array-like) holds NaN or inf."""
    if not np.all(np.isfinite(np.asarray(values, dtype=float))):
        raise ValueError(f"{name}: {what} hold NaN or inf")
