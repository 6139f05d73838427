"""Sliding-mode guidance laws of §6.4.1-6.4.2: Fly to edge (6.7)-(6.13), Fly on edge (6.14)-(6.16).

Commands are (v, omega): speed along the heading a (m/s) and heading rate
(rad/s), with u = omega a_perp, |u| = |omega| (6.4)-(6.6).

Discrete-time saturation (our addition, against the chattering of the sliding-mode
laws in sampled time, which §6.4 does not treat): the literal laws command
|v| = V_max and |u| = U_max until the target is reached, which in a sampled simulation
overshoots and chatters by V_max*dt around O*. We
cap |v| at |(a, b)|/dt (the step along the heading never overshoots the
projection of the target, so the distance to it never grows) and the turn at the
angle to go divided by dt, so a drone stops on O* ("enables the drone to stay at
O*", §6.4.2). Signs are the thesis's:
v = V_max g(a, b), u = U_max g(a, b) F(a, b).
"""

from __future__ import annotations

import math

import numpy as np

from droneplan.planners.herding.geometry import ExtendedHull

__all__ = ["OVERSHOOT_TOL", "F", "g", "steer", "fly_to_edge", "next_waypoint", "fly_on_edge"]

OVERSHOOT_TOL = 1.0
"""m: a target less than this far behind the drone (along its direction) counts as reached."""


def F(w1: np.ndarray, w2: np.ndarray) -> np.ndarray:
    """(6.7): unit vector orthogonal to unit ``w1`` towards ``w2`` (0 if w2 is parallel to w1); rows."""
    w1 = np.atleast_2d(w1)
    w2 = np.atleast_2d(w2)
    f = w2 - np.sum(w1 * w2, axis=1, keepdims=True) * w1
    n = np.linalg.norm(f, axis=1, keepdims=True)
    return np.divide(f, n, out=np.zeros_like(f), where=n > 1e-12)


def g(w1: np.ndarray, w2: np.ndarray) -> np.ndarray:
    """(6.8): +1 where (w1, w2) > 0, else -1; rows."""
    return np.where(np.sum(np.atleast_2d(w1) * np.atleast_2d(w2), axis=1) > 0, 1.0, -1.0)


def steer(headings: np.ndarray, b: np.ndarray, V_max: float, U_max: float, dt: float):
    """The law (6.12)-(6.13) (or (6.15)-(6.16) with b*) for each drone, with saturation.

    headings: (n,) heading angles, rad; b: (n, 2) vectors to the target, m.
    Returns (v (n,), omega (n,)).

    Written per coordinate (the same values as :func:`g` and :func:`F` of the rows, to the last
    bit, without numpy's reductions over the short last axis); up to ``_SCALAR_MAX`` drones in
    plain Python floats (the same operations, the same values).
    """
    ax, ay = np.cos(headings), np.sin(headings)
    b = np.asarray(b, dtype=float)
    if ax.ndim == 1 and ax.size <= _SCALAR_MAX and b.shape == (ax.size, 2):
        return _steer_scalar(ax.tolist(), ay.tolist(), b.tolist(), V_max, U_max, dt)
    bx, by = b[:, 0], b[:, 1]
    ab = ax * bx + ay * by  # (a, b)
    gg = np.where(ab > 0, 1.0, -1.0)  # g(a, b)
    fx, fy = bx - ab * ax, by - ab * ay  # F(a, b) before normalising
    fn = np.sqrt(fx * fx + fy * fy)
    ok = fn > 1e-12
    ux = np.divide(fx, fn, out=np.zeros_like(fx), where=ok)  # unit, orthogonal to a, towards b
    uy = np.divide(fy, fn, out=np.zeros_like(fy), where=ok)
    # sign of rotation of u = U_max g F:  +1 if u points to a rotated by +90 deg
    turn_sign = gg * np.sign(ux * -ay + uy * ax)
    # angle between the flying direction g*a and b: the turn needed
    nb = np.sqrt(bx * bx + by * by)
    cosang = np.divide((gg * ax) * bx + (gg * ay) * by, nb, out=np.ones_like(nb), where=nb > 1e-12)
    ang = np.arccos(np.clip(cosang, -1.0, 1.0))
    omega = turn_sign * np.minimum(U_max, ang / dt)
    along = np.abs(ab)  # progress available along the heading
    v = gg * np.minimum(V_max, along / dt)
    return v, omega


def _sign(x: float) -> float:
    """np.sign of a Python float (0.0 for both zeros, NaN for NaN)."""
    return 1.0 if x > 0 else -1.0 if x < 0 else (x if x != x else 0.0)


def _minimum(a: float, x: float) -> float:
    """np.minimum(a, x) for a finite ``a`` (a NaN ``x`` propagates)."""
    return a if a < x else x


def _steer_scalar(ax: list[float], ay: list[float], b: list[list[float]], V_max, U_max, dt):
    """:func:`steer` for a few drones, one at a time in Python floats (the numpy version's
    operations in the same order; arccos stays numpy's, on all drones at once)."""
    gg_l, turn_l, cos_l, along_l = [], [], [], []
    for axi, ayi, (bx, by) in zip(ax, ay, b, strict=True):
        ab = axi * bx + ayi * by
        gg = 1.0 if ab > 0 else -1.0
        fx, fy = bx - ab * axi, by - ab * ayi
        fn = math.sqrt(fx * fx + fy * fy)
        ux, uy = (fx / fn, fy / fn) if fn > 1e-12 else (0.0, 0.0)
        turn_l.append(gg * _sign(ux * -ayi + uy * axi))
        nb = math.sqrt(bx * bx + by * by)
        cos_l.append(((gg * axi) * bx + (gg * ayi) * by) / nb if nb > 1e-12 else 1.0)
        gg_l.append(gg)
        along_l.append(abs(ab))
    ang = np.arccos([min(max(c, -1.0), 1.0) for c in cos_l]).tolist()  # np.clip's values
    omega = [t * _minimum(U_max, a / dt) for t, a in zip(turn_l, ang, strict=True)]
    v = [gg * _minimum(V_max, al / dt) for gg, al in zip(gg_l, along_l, strict=True)]
    return np.array(v), np.array(omega)


def fly_to_edge(
    drones: np.ndarray, headings: np.ndarray, hull: ExtendedHull, V_max: float, U_max: float, dt: float
):
    """Fly to edge (6.11)-(6.13): head for the closest point O of the closest edge.

    Returns (v, omega, b) with b (n, 2) the vector from each drone to O, m.
    """
    _, close, _ = hull.project(drones)
    b = close - drones
    v, omega = steer(headings, b, V_max, U_max, dt)
    return v, omega, b


def next_waypoint(
    hull: ExtendedHull, s_drone: np.ndarray, edge: np.ndarray, s_target: np.ndarray, direction: np.ndarray
) -> np.ndarray:
    """O* of (6.14): the target if it lies before the next vertex in ``direction``, else that vertex.

    s_drone, s_target: (n,) arc positions, m; edge: (n,) current edge index; direction: (n,) +-1.
    The drone "may fly to the vertex of the adjacent edge in the given direction
    multiple times ... until reaching the selected vertex" (§6.4.2).
    """
    M = hull.perimeter
    n_e = len(hull.vertices)
    if s_drone.size <= _SCALAR_MAX:
        return hull.point_at(_waypoint_s(hull.cum.tolist(), M, n_e, s_drone, edge, s_target, direction))
    rem = np.mod((s_target - s_drone) * direction, M)
    # a target just behind (rounding, or a one-step overshoot) is reached, not a lap ahead
    rem = np.where(rem > M - OVERSHOOT_TOL, 0.0, rem)
    nxt = np.where(direction > 0, hull.cum[edge + 1], hull.cum[edge])
    to_v = np.mod((nxt - s_drone) * direction, M)
    # standing on the vertex already: the next one along the direction
    at_v = to_v < 1e-9
    nxt2 = np.where(direction > 0, hull.cum[(edge + 2) % n_e], hull.cum[(edge - 1) % n_e])
    nxt = np.where(at_v, nxt2, nxt)
    to_v = np.where(at_v, np.mod((nxt - s_drone) * direction, M), to_v)
    s_star = np.where(rem <= to_v, s_target, nxt)
    return hull.point_at(s_star)


_SCALAR_MAX = 12
"""Up to this many drones, :func:`next_waypoint` picks the arc positions in plain Python floats
(the same operations as the numpy version, the same values to the last bit)."""


def _waypoint_s(cum: list[float], M: float, n_e: int, s_drone, edge, s_target, direction) -> np.ndarray:
    """Arc positions of O* for a few drones (:func:`next_waypoint`'s rule, one drone at a time)."""
    out = []
    for s, e, st, d in zip(
        s_drone.tolist(), edge.tolist(), s_target.tolist(), direction.tolist(), strict=True
    ):
        rem = ((st - s) * d) % M  # Python's float % rounds as np.mod
        if rem > M - OVERSHOOT_TOL:  # a target just behind is reached, not a lap ahead
            rem = 0.0
        nxt = cum[e + 1] if d > 0 else cum[e]
        to_v = ((nxt - s) * d) % M
        if to_v < 1e-9:  # standing on the vertex already: the next one along the direction
            nxt = cum[(e + 2) % n_e] if d > 0 else cum[(e - 1) % n_e]
            to_v = ((nxt - s) * d) % M
        out.append(st if rem <= to_v else nxt)
    return np.array(out, dtype=float)


def fly_on_edge(
    drones: np.ndarray,
    headings: np.ndarray,
    hull: ExtendedHull,
    s_target: np.ndarray,
    direction: np.ndarray,
    V_max: float,
    U_max: float,
    dt: float,
):
    """Fly on edge (6.14)-(6.16): b* = b + o*, b keeping the drone on the hull, o* to O*.

    s_target: (n,) arc positions to reach, m; direction: (n,) +1 (increasing arc) or -1.
    Returns (v, omega, s_drone) with s_drone the drones' current arc positions.
    """
    s, close, edge = hull.project(drones)
    b = close - drones
    o_star = next_waypoint(hull, s, edge, np.asarray(s_target, dtype=float), np.asarray(direction)) - drones
    v, omega = steer(headings, b + o_star, V_max, U_max, dt)
    return v, omega, s
