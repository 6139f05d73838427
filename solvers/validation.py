"""Argument checks shared by the adapters (misuse raises; solver failures do not)."""

from __future__ import annotations

import math


def check_time_limit(time_limit: float | None) -> None:
    """Raise unless ``time_limit`` is None or a finite number of seconds > 0."""
    if time_limit is None:
        return
    if isinstance(time_limit, bool) or not isinstance(time_limit, (int, float)):
        raise TypeError(f"time_limit must be a number of seconds or None, got {type(time_limit).__name__}")
    if not math.isfinite(time_limit) or time_limit <= 0:
        raise ValueError(f"time_limit must be a finite number of seconds > 0, got {time_limit}")
