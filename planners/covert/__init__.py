"""Controllers for covert observation (thesis ch. 3).

- :mod:`planners.covert.sliding`: the thesis's sliding-mode navigation laws
  (:class:`SlidingModeObserver`) and the hover benchmark (:class:`HoverBenchmark`).
- :mod:`planners.covert.mpc`: the min-max bearing MPC in closed loop
  (:class:`MPCObserver`) and its safeguarded variant (:class:`SafeguardedMPCObserver`).
"""

from droneplan.planners.covert.mpc import (
    MPCObserver,
    MPCObserverSettings,
    SafeguardedMPCObserver,
    SafeguardSettings,
)
from droneplan.planners.covert.sliding import (
    HoverBenchmark,
    SlidingModeObserver,
    SlidingSettings,
    W,
    g,
    rollout_sliding,
    selection_weights,
    sliding_steering,
    turn_command,
)

__all__ = [
    "W",
    "g",
    "SlidingSettings",
    "sliding_steering",
    "selection_weights",
    "turn_command",
    "rollout_sliding",
    "SlidingModeObserver",
    "HoverBenchmark",
    "MPCObserver",
    "MPCObserverSettings",
    "SafeguardSettings",
    "SafeguardedMPCObserver",
]
