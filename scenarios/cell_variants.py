"""Thesis-process instances of the drone-cell variants.

Each is the Table 4.2 instance of a seed (:func:`~droneplan.scenarios.cells.thesis_problem`) with
one variant of the model added, with these parameters (our choice; the thesis has no variants):

``weighted``   an integer demand of 1-5 per user, uniform, drawn with the seed + 1000
``nofly``      a 2 km x 3 km no-fly zone east of the GBS, [1.5, 3.5] x [-1.5, 1.5] km
``capacity``   20 users per drone-cell (``CAPACITY``)
``3d``         altitude levels 200 and 400 m with the default
               :class:`~droneplan.scenarios.air_to_ground.AirToGround` channel
               (coverage radii R(h) = 402 and 605 m)

Moving users (:func:`drifting_snapshots`): each user drifts at a constant velocity drawn per user,
N(0, 1.5 m/s) per axis with the seed + 2000, observed every ``EPOCH_S`` seconds.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray
from shapely.geometry import box

from droneplan.core.validation import check_array, check_int
from droneplan.scenarios.air_to_ground import AirToGround
from droneplan.scenarios.cells import CellProblem, thesis_problem

__all__ = [
    "VARIANTS",
    "CAPACITY",
    "ALTITUDES_M",
    "NO_FLY_BOX_M",
    "EPOCH_S",
    "DRIFT_SD_M_S",
    "thesis_variant_problem",
    "drifting_snapshots",
]

VARIANTS = ("weighted", "nofly", "capacity", "3d")
"""The single-epoch variants :func:`thesis_variant_problem` builds."""

CAPACITY = 20
"""Users a drone-cell serves at most in the ``capacity`` variant."""

ALTITUDES_M = (200.0, 400.0)
"""The altitude levels of the ``3d`` variant (m)."""

NO_FLY_BOX_M = (1500.0, -1500.0, 3500.0, 1500.0)
"""The ``nofly`` variant's forbidden rectangle (x_min, y_min, x_max, y_max), m, GBS at the origin."""

EPOCH_S = 60.0
"""Seconds between the epochs of :func:`drifting_snapshots`."""

DRIFT_SD_M_S = 1.5
"""Standard deviation of each velocity component of a drifting user (m/s)."""


def thesis_variant_problem(variant: str, n_cells: int, seed: int) -> CellProblem:
    """The Table 4.2 instance of ``seed`` with ``n_cells`` drone-cells and ``variant`` added.

    variant: one of ``VARIANTS`` (module docstring). n_cells: drone-cells m (count >= 1).
    seed: the instance seed (int >= 0; the users are Table 4.2's of this seed).
    """
    check_int("n_cells", n_cells, min_value=1)
    seed = check_int("seed", seed, min_value=0)
    if variant not in VARIANTS:
        raise ValueError(f"variant must be one of {VARIANTS}, got {variant!r}")
    base = thesis_problem(n_cells, seed)
    extra: dict[str, Any]
    if variant == "weighted":
        extra = {"weights": np.random.default_rng(seed + 1000).integers(1, 6, len(base.users)).astype(float)}
    elif variant == "nofly":
        extra = {"no_fly": [box(*NO_FLY_BOX_M)]}
    elif variant == "capacity":
        extra = {"capacity": CAPACITY}
    else:
        extra = {"altitudes": list(ALTITUDES_M), "channel": AirToGround()}
    return base._replace(**extra)


def drifting_snapshots(users: NDArray[np.float64], seed: int, epochs: int) -> NDArray[np.float64]:
    """Positions of drifting users at ``epochs`` epochs ``EPOCH_S`` apart: a (T, n, 2) array (m).

    users: the first epoch's positions ((n, 2) m). seed: the instance seed (int >= 0; the
    velocities are drawn with seed + 2000). epochs: T (count >= 1).
    """
    seed = check_int("seed", seed, min_value=0)
    epochs = check_int("epochs", epochs, min_value=1)
    users = check_array("users", users, shape=(None, 2))
    velocity = np.random.default_rng(seed + 2000).normal(0.0, DRIFT_SD_M_S, size=users.shape)
    return np.stack([users + velocity * EPOCH_S * t for t in range(epochs)])
