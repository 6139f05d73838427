"""Exact optimal operator altitude (the model behind Prop. 5.3.1)."""

from __future__ import annotations

from typing import overload

import numpy as np
from numpy.typing import ArrayLike, NDArray

from droneplan.core.validation import check_array, check_instance
from droneplan.scenarios.shark import THESIS_TABLE_5_1, SharkParams

__all__ = ["optimal_altitude"]


@overload
def optimal_altitude(z_s: float, params: SharkParams = ...) -> tuple[float, float]: ...
@overload
def optimal_altitude(
    z_s: ArrayLike, params: SharkParams = ...
) -> tuple[NDArray[np.float64], NDArray[np.float64]]: ...
def optimal_altitude(
    z_s: ArrayLike, params: SharkParams = THESIS_TABLE_5_1
) -> tuple[float, float] | tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Exact maximiser of the interception radius eps(z_o - z_s) over lmin <= z_o <= le.

    z_s: shark altitude(s) (m, <= 0), scalar or array. Returns (z_o*, eps*) in metres,
    same shape as z_s. eps(h) = max_k sqrt(eps_o^2 - (h - l_k)^2) is the maximum of two
    functions each unimodal in z_o with its peak at z_o = z_s + l_k, so for each ball the
    best altitude is that peak clipped to [lmin, le]; the better ball wins (ball 1 on a
    tie, as the thesis chooses plane 1). When no ball reaches the shark, eps* = 0 and the
    operator waits at lmin (thesis, case (d)).

    params: problem parameters, SharkParams (default: THESIS_TABLE_5_1).
    """
    check_instance("params", params, SharkParams)
    z = check_array("z_s", z_s)
    if np.any(z > 0):
        raise ValueError("z_s must be <= 0 (the shark is under the sea surface)")
    best_z = np.full(z.shape, params.lmin)
    best_e = np.zeros(z.shape)
    for lk in (params.l1, params.l2):
        zk = np.clip(z + lk, params.lmin, params.le)
        ek = np.sqrt(np.clip(params.eps_o**2 - (zk - z - lk) ** 2, 0.0, None))
        better = ek > best_e + 1e-12
        best_z = np.where(better, zk, best_z)
        best_e = np.where(better, ek, best_e)
    if best_z.ndim == 0:
        return float(best_z), float(best_e)
    return best_z, best_e
