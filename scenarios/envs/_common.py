"""What the environments share: the position bound of their observation spaces, the action check
and the base of the policy controllers."""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

POSITION_BOUND = 1e7
"""Bound (m) on every position and distance entry of the observation spaces (finite, so the spaces
are proper boxes; no run comes near it: a drone at full speed covers a few tens of km per hour)."""

TIME_BOUND = 1e7
"""Bound (s) on the time entry of an observation vector (about 116 days)."""


def check_action(action: Any, low: NDArray[np.float64], high: NDArray[np.float64]) -> NDArray[np.float64]:
    """``action`` as a float64 vector, refused with a one-line ValueError (naming ``action``) unless
    it has the shape of ``low`` and lies within [low, high] (the action space's bounds)."""
    try:
        a = np.array(action, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"action must be a numeric array of shape {low.shape}, got {action!r:.80}") from None
    if a.shape != low.shape:
        raise ValueError(f"action must have shape {low.shape}, got {a.shape}")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"action must be finite, got {a.tolist()}")
    bad = np.flatnonzero((a < low) | (a > high))
    if bad.size:
        i = int(bad[0])
        raise ValueError(
            f"action[{i}] = {a[i]:.6g} is outside the action space [{low[i]:.6g}, {high[i]:.6g}]"
        )
    return a


def check_policy(policy: Any) -> Any:
    """``policy`` if it is callable, else a one-line TypeError naming ``policy``."""
    if not callable(policy) or isinstance(policy, type):
        raise TypeError(f"policy must be a callable obs_vector -> action, got {type(policy).__name__}")
    return policy
