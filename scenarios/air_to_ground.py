"""The air-to-ground channel of a drone-cell and the coverage radius it gives at each altitude.

Mean path loss between a drone-cell at height h and a ground user at horizontal distance r
(Al-Hourani, Kandeepan and Lardner, "Optimal LAP altitude for maximum coverage", IEEE Wireless
Communications Letters 3(6), 2014, eqs. 1-5)::

    PL(r, h) = FSPL(d) + eta_LoS P_LoS(theta) + eta_NLoS (1 - P_LoS(theta))    dB
    FSPL(d)  = 20 log10(4 pi f d / c),   d = sqrt(r^2 + h^2)
    P_LoS    = 1 / (1 + a exp(-b (theta - a))),   theta = atan(h / r) in degrees

A user is covered when PL <= ``max_path_loss_db``. With eta_NLoS >= eta_LoS the loss grows with
r at a fixed h (the distance grows and the elevation falls), so the covered ground is a disc of
radius R(h), found by bisection.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from droneplan.core.validation import check_positive, check_real

__all__ = ["AirToGround", "SPEED_OF_LIGHT", "URBAN"]

SPEED_OF_LIGHT = 299_792_458.0
"""m/s."""

URBAN = (9.61, 0.16, 1.0, 20.0)
"""(a, b, eta_LoS dB, eta_NLoS dB) of the urban environment in Al-Hourani et al. (2014), Table I."""


@dataclass(frozen=True)
class AirToGround:
    """The air-to-ground channel (module docstring). Defaults: the urban environment of
    Al-Hourani et al. (2014) (``URBAN``), a 2 GHz carrier, and a 100 dB path-loss budget
    (droneplan's choice, not the paper's: R(h) of a few hundred metres to a kilometre at
    100-1000 m, the scale of thesis Table 4.2).

    a, b: the S-curve parameters of P_LoS (a > 0, b > 0). eta_los_db, eta_nlos_db: mean excess
    losses (dB, >= 0, eta_nlos_db >= eta_los_db). frequency_hz: carrier (Hz, > 0).
    max_path_loss_db: the largest mean path loss at which a user is covered (dB).
    """

    a: float = URBAN[0]
    b: float = URBAN[1]
    eta_los_db: float = URBAN[2]
    eta_nlos_db: float = URBAN[3]
    frequency_hz: float = 2.0e9
    max_path_loss_db: float = 100.0

    def __post_init__(self) -> None:
        for name in ("a", "b", "frequency_hz"):
            object.__setattr__(self, name, check_positive(name, getattr(self, name)))
        for name in ("eta_los_db", "eta_nlos_db"):
            value = check_real(name, getattr(self, name))
            if value < 0:
                raise ValueError(f"{name} must be >= 0 dB, got {value}")
            object.__setattr__(self, name, value)
        object.__setattr__(self, "max_path_loss_db", check_real("max_path_loss_db", self.max_path_loss_db))
        if self.eta_nlos_db < self.eta_los_db:
            raise ValueError(
                f"eta_nlos_db must be >= eta_los_db (the covered ground is then a disc), "
                f"got {self.eta_nlos_db} < {self.eta_los_db}"
            )

    def los_probability(self, elevation_deg: ArrayLike) -> NDArray[np.float64]:
        """P_LoS at elevation angles (degrees)."""
        theta = np.asarray(elevation_deg, dtype=float)
        return 1.0 / (1.0 + self.a * np.exp(-self.b * (theta - self.a)))

    def path_loss_db(self, ground_distance: ArrayLike, height: ArrayLike) -> NDArray[np.float64]:
        """Mean path loss (dB) at horizontal distance ``ground_distance`` (m, >= 0) from a
        drone-cell at ``height`` (m, > 0)."""
        r = np.asarray(ground_distance, dtype=float)
        h = np.asarray(height, dtype=float)
        d = np.hypot(r, h)
        fspl = 20.0 * np.log10(4.0 * math.pi * self.frequency_hz * d / SPEED_OF_LIGHT)
        p_los = self.los_probability(np.degrees(np.arctan2(h, r)))
        return fspl + self.eta_los_db * p_los + self.eta_nlos_db * (1.0 - p_los)

    def coverage_radius(self, height: float) -> float:
        """R(h): the largest horizontal distance (m) at which a user is covered by a drone-cell at
        ``height`` (m > 0); 0 when not even the user straight below is (to 1e-6 m)."""
        h = check_positive("height", height)
        if self.path_loss_db(0.0, h) > self.max_path_loss_db:
            return 0.0
        hi = max(h, 1.0)
        while self.path_loss_db(hi, h) <= self.max_path_loss_db:
            hi *= 2.0
        lo = 0.0
        while hi - lo > 1e-7 * max(hi, 1.0):
            mid = 0.5 * (lo + hi)
            if self.path_loss_db(mid, h) <= self.max_path_loss_db:
                lo = mid
            else:
                hi = mid
        return lo
