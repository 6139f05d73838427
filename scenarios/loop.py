"""The closed-loop contract shared by covert observation, shark interception and herding.

Every closed-loop problem (thesis ch. 3, 5, 6) is run the same way::

    trace = simulate(scenario, controller, *, seed=...)

where ``controller`` follows :class:`Controller`:

- ``reset(scenario, *, seed=None)`` once before the run (``seed``: the run's seed, for
  controllers that draw random numbers);
- ``command(obs) -> command`` once per control period: ``obs`` is the problem's
  observation dataclass (``CovertObservation``, ``SharkObservation``,
  ``HerdingObservation``) and the return value the problem's command
  (``CovertCommand``, ``SharkCommand``, ``HerdingCommand``; a plain tuple of the
  same fields is accepted);
- ``phase``: the controller's phase after the last command, a member of the
  problem's phase enum (``CovertPhase``, ``SharkPhase``, ``HerdingPhase``);
- optional counters the simulator copies into the trace: ``fallbacks`` (int, control
  steps where a solver failed and a fallback command was used), ``statuses`` (list of
  solve status names, one per solve) and ``solve_times`` (list of s, one per solve).

Every simulator returns a trace derived from :class:`LoopTrace`: times ``t`` in seconds,
the ``final`` state as a :class:`Frame` (whatever was sampled), the ``seed`` used, and
``fallbacks`` / ``status_counts``. Frames are the problem's :class:`Frame` subclass.

This module imports no other layer of droneplan.
"""

from __future__ import annotations

import enum
from collections import Counter
from dataclasses import dataclass, field
from typing import Any, Protocol, runtime_checkable

import numpy as np

__all__ = ["Controller", "Frame", "LoopTrace", "controller_counters"]


@dataclass(frozen=True, kw_only=True)
class Frame:
    """The state of a closed-loop run at one instant (base of each problem's frame type)."""

    t: float
    """Time (s)."""


@runtime_checkable
class Controller(Protocol):
    """What every closed-loop simulator needs from a controller (see the module docstring)."""

    phase: enum.Enum

    def reset(self, scenario: Any, *, seed: Any = None) -> None:
        """Start a new run on ``scenario``."""

    def command(self, obs: Any) -> Any:
        """The command for the next control period, given this period's observation."""


@dataclass(kw_only=True)
class LoopTrace:
    """Fields every closed-loop trace has (each problem's trace adds its own)."""

    t: np.ndarray
    """(T,) times of the recorded instants (s)."""
    final: Frame
    """The state at the end of the run (always stored, whatever was sampled)."""
    seed: Any = None
    """The seed the run used (int, Generator or None as given to ``simulate``)."""
    fallbacks: int = 0
    """Control steps where a solver failed and the controller used a fallback command."""
    status_counts: dict[str, int] = field(default_factory=dict)
    """How many solves ended with each status name (e.g. ``{"OPTIMAL": 40, "NO_SOLUTION": 2}``); empty
    for controllers that solve nothing."""


def controller_counters(controller: Any) -> dict[str, Any]:
    """``fallbacks``, ``status_counts``, ``solve_times`` (s, array) from a controller's optional counters."""
    statuses = getattr(controller, "statuses", None)
    solve_times = getattr(controller, "solve_times", None)
    return {
        "fallbacks": int(getattr(controller, "fallbacks", 0)),
        # a status may be recorded as an enum member or as its name or value ("optimal" -> "OPTIMAL")
        "status_counts": dict(Counter(str(getattr(s, "name", s)).upper() for s in (statuses or ()))),
        "solve_times": np.asarray([] if solve_times is None else solve_times, dtype=float),
    }
