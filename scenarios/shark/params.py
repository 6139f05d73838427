"""Table 5.1 parameters of the shark-interception problem (thesis ch. 5) and the field model.

Coordinates: metres, z up, sea surface at z = 0; the operator flies at z_o in
[lmin, le] > 0, the shark swims at z_s <= 0.

Field model (thesis §5.4, "two partly overlapped balls"): two balls of radius
eps_o centred l1 and l2 below the operator.  The radius of the field on a
horizontal plane a height h below the operator is therefore

    eps(h) = max_k sqrt(eps_o**2 - (h - l_k)**2)   (0 where no ball reaches),

which satisfies eq. 5.2 (eps(l1) = eps(l2) = eps_o) and reaches down to
l2 + eps_o = lmax = 11 m with Table 5.1.  A "touch" is the shark's snout, a point,
entering either ball (our reading of the thesis, which does not model the shark's body).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

import numpy as np
from numpy.typing import NDArray

from droneplan.core.validation import check_array, check_positive, check_real

__all__ = ["SharkParams", "THESIS_TABLE_5_1", "field_radius", "touches", "inside_field"]


@dataclass(frozen=True)
class SharkParams:
    """Parameters of the operator, its electric field and the shark (Table 5.1 and our choices).

    Table 5.1 gives only the total operator speed VoM = 8 m/s. Eq. 5.3 needs the
    split VoM**2 = VoMxy**2 + VoMz**2 with VoMxy > VsMxy and VoMz > VsMz (the premise
    of Prop. 5.3.2). We choose VoMxy = 7.5 m/s (the thesis's sharks average up to
    5.78 m/s, Table 5.2, so 7.5 leaves a margin over the shark's 6.5 m/s top speed)
    and hence VoMz = sqrt(64 - 56.25) = 2.78 m/s, which still beats the shark's
    1 m/s vertical limit and moves the operator across its whole altitude band
    [lmin, le] in 0.36 s.  VsMxy, VsMz and gamma are not given in the thesis.
    """

    lmin: float = 1.0
    """Minimum operator altitude above the sea surface (m)."""
    le: float = 2.0
    """Maximum operator altitude that keeps the field's shape under water (m)."""
    l1: float = 4.5
    """Depth of optimal plane 1 (centre of ball 1) below the operator (m)."""
    l2: float = 7.5
    """Depth of optimal plane 2 (centre of ball 2) below the operator (m)."""
    lmax: float = 11.0
    """Depth of the bottom of the peripheral field below the operator (m); l2 + eps_o for the ball model."""
    eps_o: float = 3.5
    """Field radius on the optimal planes = radius of each ball (m)."""
    VoMxy: float = 7.5
    """Maximum horizontal operator speed (m/s); our split of VoM = 8 m/s."""
    VoMz: float = math.sqrt(8.0**2 - 7.5**2)
    """Maximum vertical operator speed (m/s); sqrt(VoM**2 - VoMxy**2) = 2.78 m/s."""
    VsMxy: float = 6.5
    """Maximum horizontal shark speed (m/s); our choice (thesis averages 5.3-5.8 m/s)."""
    VsMz: float = 1.0
    """Maximum vertical shark speed (m/s); our choice."""
    Di: float = 13.0
    """Initial operator-shark separation (m), horizontal."""
    Ts: float = 0.1
    """Sampling time of controllers and simulator (s)."""
    gamma: float = 0.1
    """Capture radius (m) and relative margin of eps' = eps*(1 + gamma) (eq. 5.8); thesis value not given."""

    def __post_init__(self) -> None:
        for f in fields(self):
            check_real(f.name, getattr(self, f.name))
        for name in ("lmin", "eps_o", "VoMxy", "VoMz", "VsMxy", "VsMz", "Ts", "gamma", "Di"):
            check_positive(name, getattr(self, name))
        if not self.lmin < self.le:
            raise ValueError(f"lmin < le violated (eq. 5.1): lmin={self.lmin}, le={self.le}")
        if not self.l1 < self.l2:
            raise ValueError(f"l1 < l2 violated (eq. 5.1): l1={self.l1}, l2={self.l2}")
        if not self.le < self.l1:
            raise ValueError(f"le < l1 violated (eq. 5.1): le={self.le}, l1={self.l1}")
        if not self.l2 < self.lmax:
            raise ValueError(f"l2 < lmax violated (eq. 5.1): l2={self.l2}, lmax={self.lmax}")
        if not self.VoMxy > self.VsMxy:
            raise ValueError(f"VoMxy > VsMxy violated (premise of Prop. 5.3.2): {self.VoMxy} <= {self.VsMxy}")
        if not self.VoMz > self.VsMz:
            raise ValueError(f"VoMz > VsMz violated (premise of Prop. 5.3.2): {self.VoMz} <= {self.VsMz}")
        if not self.Di > self.eps_o:
            raise ValueError(
                f"Di > eps_o violated (premise of Prop. 5.3.2): Di={self.Di}, eps_o={self.eps_o}"
            )

    @property
    def VoM(self) -> float:
        """Total maximum operator speed sqrt(VoMxy**2 + VoMz**2) (m/s), eq. 5.3."""
        return math.hypot(self.VoMxy, self.VoMz)

    @property
    def VsM(self) -> float:
        """Total maximum shark speed (m/s), eq. 5.3."""
        return math.hypot(self.VsMxy, self.VsMz)

    @property
    def ball_depths(self) -> NDArray[np.float64]:
        """Depths (l1, l2) of the two ball centres below the operator (m)."""
        return np.array([self.l1, self.l2])


THESIS_TABLE_5_1 = SharkParams()
"""Table 5.1 (lmin=1, le=2, l1=4.5, l2=7.5, lmax=11, eps_o=3.5 m, VoM=8 m/s, Di=13 m,
Ts=0.1 s) with our VoM split."""


def field_radius(h, params: SharkParams = THESIS_TABLE_5_1) -> NDArray[np.float64]:
    """Radius eps(h) (m) of the field on the plane h metres below the operator (vectorised, eq. 5.2).

    0 where neither ball reaches the plane.

    params: problem parameters, SharkParams (default: THESIS_TABLE_5_1).
    """
    if not isinstance(params, SharkParams):
        raise TypeError(f"params must be SharkParams, got {type(params).__name__}")
    h = check_array("h", h)
    d = h[..., None] - params.ball_depths
    r2 = params.eps_o**2 - d**2
    return np.sqrt(np.clip(r2, 0.0, None)).max(axis=-1)


def inside_field(shark, operator, params: SharkParams = THESIS_TABLE_5_1) -> NDArray[np.float64]:
    """Signed clearance (m): min over the balls of |shark - centre| - eps_o; <= 0 means touching.

    shark, operator: arrays (..., 3) in metres (broadcast together).
    """
    if not isinstance(params, SharkParams):
        raise TypeError(f"params must be SharkParams, got {type(params).__name__}")
    s = check_array("shark", shark)
    o = check_array("operator", operator)
    for name, arr in (("shark", s), ("operator", o)):
        if arr.ndim == 0 or arr.shape[-1] != 3:
            raise ValueError(f"{name} must have shape (..., 3), got {arr.shape}")
    try:
        np.broadcast_shapes(s.shape, o.shape)
    except ValueError:
        raise ValueError(f"shark {s.shape} and operator {o.shape} must broadcast together") from None
    dist = []  # clearance to ball 1, ball 2
    for lk in (params.l1, params.l2):
        c = np.array(o, dtype=float)
        c[..., 2] = c[..., 2] - lk
        dist.append(np.linalg.norm(s - c, axis=-1) - params.eps_o)
    return np.minimum(dist[0], dist[1])


def touches(shark, operator, params: SharkParams = THESIS_TABLE_5_1) -> NDArray[np.bool_]:
    """True where the shark's snout (a point) is inside either ball of the field (a point, not the
    shark's body: see the module docstring).

    operator: (..., 3) operator positions (m).
    params: problem parameters, SharkParams (default: THESIS_TABLE_5_1).
    """
    return inside_field(shark, operator, params) <= 0.0
