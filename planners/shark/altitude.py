"""Proposition 5.3.1 verbatim (eqs. 5.6-5.7) — the thesis's altitude rule, kept as the baseline.

With Table 5.1 case (c) puts the operator at z_s + l2 > le for -5.5 < z_s < -3.5 m,
outside its own constraint lmin <= z_o <= le; `formulations.shark.optimal_altitude`
is the exact maximiser.
"""

from __future__ import annotations

from typing import overload

import numpy as np
from numpy.typing import ArrayLike, NDArray

from droneplan.core.validation import check_array, check_instance
from droneplan.scenarios.shark import THESIS_TABLE_5_1, SharkParams, field_radius

__all__ = ["thesis_altitude"]


@overload
def thesis_altitude(z_s: float, params: SharkParams = ...) -> tuple[float, float]: ...
@overload
def thesis_altitude(
    z_s: ArrayLike, params: SharkParams = ...
) -> tuple[NDArray[np.float64], NDArray[np.float64]]: ...
def thesis_altitude(
    z_s: ArrayLike, params: SharkParams = THESIS_TABLE_5_1
) -> tuple[float, float] | tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(z_o*, eps*) of eqs. 5.6 and 5.7 for shark altitude(s) z_s (m, <= 0), verbatim.

    params: problem parameters, SharkParams (default: THESIS_TABLE_5_1).
    """
    check_instance("params", params, SharkParams)
    z = check_array("z_s", z_s)
    if np.any(z > 0):
        raise ValueError("z_s must be <= 0 (the shark is under the sea surface)")
    p = params
    case_a = (p.le - p.l1 < z) & (z <= 0)
    case_b = (p.lmin - p.l1 <= z) & (z <= p.le - p.l1)
    case_c = (p.lmin - p.l2 <= z) & (z < p.lmin - p.l1)
    zo = np.select(
        [case_a, case_b, case_c], [np.full(z.shape, p.le), z + p.l1, z + p.l2], default=p.lmin
    )  # 5.6
    e_a = field_radius(p.le - z, p)
    e_c = field_radius(p.lmin - z, p)
    eps = np.select(  # 5.7
        [case_a, (p.lmin - p.l2 <= z) & (z <= p.le - p.l1), (p.lmin - p.lmax <= z) & (z < p.lmin - p.l2)],
        [e_a, np.full(z.shape, p.eps_o), e_c],
        default=0.0,
    )
    if zo.ndim == 0:
        return float(zo), float(eps)
    return zo, eps
