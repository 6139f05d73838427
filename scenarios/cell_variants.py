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
:func:`mobile_instance` is the smaller world of the ``table4.2-mobile`` family
(``MOBILE_PARAMS``: Table 4.2's densities, radii and ranges on a 4 km x 4 km area with 3 clusters,
about 60 users; ``MOBILE_EPOCHS`` epochs; drone-cells move at most ``MOBILE_MAX_MOVE_M``
between epochs): the joint model of all epochs has one placement per epoch and a transport
between them, too large at the full Table 4.2 scale for a library of proofs.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np
from numpy.typing import NDArray
from shapely.geometry import box

from droneplan.core.validation import check_array, check_int
from droneplan.scenarios.air_to_ground import AirToGround
from droneplan.scenarios.cells import THESIS_TABLE_4_2, CellProblem, thesis_problem

__all__ = [
    "VARIANTS",
    "CAPACITY",
    "ALTITUDES_M",
    "NO_FLY_BOX_M",
    "EPOCH_S",
    "DRIFT_SD_M_S",
    "thesis_variant_problem",
    "drifting_snapshots",
    "MOBILE_PARAMS",
    "MOBILE_EPOCHS",
    "MOBILE_MAX_MOVE_M",
    "mobile_instance",
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


MOBILE_PARAMS = dataclasses.replace(THESIS_TABLE_4_2, half_width=2000.0, n_clusters=3)
"""The world of :func:`mobile_instance`: Table 4.2 on a 4 km x 4 km area with 3 clusters."""

MOBILE_EPOCHS = 3
"""Epochs of :func:`mobile_instance`."""

MOBILE_MAX_MOVE_M = 100.0
"""The most a drone-cell of :func:`mobile_instance` moves between epochs (m)."""


def mobile_instance(n_cells: int, seed: int) -> tuple[CellProblem, NDArray[np.float64]]:
    """The moving-users instance of ``seed``: the problem (``MOBILE_PARAMS``, ``n_cells``
    drone-cells) and its users' (``MOBILE_EPOCHS``, n, 2) drifting positions (m).

    n_cells: drone-cells m (count >= 1). seed: the instance seed (int >= 0).
    """
    check_int("n_cells", n_cells, min_value=1)
    seed = check_int("seed", seed, min_value=0)
    base = thesis_problem(n_cells, seed, params=MOBILE_PARAMS)
    return base, drifting_snapshots(base.users, seed, MOBILE_EPOCHS)
