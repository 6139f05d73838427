"""Certified one-dimensional searches (generic; knows nothing of drones)."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

__all__ = ["FirstRoot", "first_root_lipschitz"]


@dataclass(frozen=True)
class FirstRoot:
    """Outcome of :func:`first_root_lipschitz`.

    lower: every t in [lo, lower) has f(t) > 0 (proven from the Lipschitz constant), so the
    first t with f(t) <= 0 is >= lower; None when f > 0 on the whole interval [lo, hi].
    found: a point with f(found) <= 0 (None if the search stopped before reaching one).
    evaluations: calls of f.
    """

    lower: float | None
    found: float | None
    evaluations: int


def first_root_lipschitz(
    f: Callable[[float], float],
    lo: float,
    hi: float,
    lipschitz: float,
    *,
    resolution: float = 1e-6,
    max_evaluations: int = 1_000_000,
) -> FirstRoot:
    """Lower bound on the first t in [lo, hi] with f(t) <= 0, for f Lipschitz with constant ``lipschitz``.

    Feasibility need not be monotone in t: from a point with f(t) > 0 no root lies in
    [t, t + f(t) / L), so the scan t <- t + f(t) / L never skips the first root (a bisection
    on a non-monotone f could). The scan stops at the first t with f(t) <= 0 (then lower = t),
    when the steps fall below ``resolution`` (lower = the last certified t; the first root is
    within about ``resolution`` above it), past ``hi`` (lower None: no root), or after
    ``max_evaluations`` (lower = the last certified t, still a valid lower bound).
    """
    if not (math.isfinite(lo) and math.isfinite(hi) and lo <= hi):
        raise ValueError(f"need finite lo <= hi, got lo={lo}, hi={hi}")
    if not (math.isfinite(lipschitz) and lipschitz > 0):
        raise ValueError(f"lipschitz must be finite and > 0, got {lipschitz}")
    if not (math.isfinite(resolution) and resolution > 0):
        raise ValueError(f"resolution must be finite and > 0, got {resolution}")
    t, n = lo, 0
    while n < max_evaluations:
        v = float(f(t))
        n += 1
        if math.isnan(v):
            raise ValueError(f"f returned NaN at t={t}")
        if v <= 0:
            return FirstRoot(t, t, n)
        if t >= hi:
            return FirstRoot(None, None, n)
        step = v / lipschitz
        if step < resolution or t + step == t:  # the second: a step below the float spacing of t
            return FirstRoot(t, None, n)
        t = min(t + step, hi)
    return FirstRoot(t, None, n)
