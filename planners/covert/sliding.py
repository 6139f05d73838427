"""Sliding-mode controllers for covert observation (thesis ch. 3).

- :class:`SlidingModeObserver`: the thesis's sliding-mode navigation laws, To-sphere
  (3.16)-(3.17), On-sphere (3.8)-(3.15) and the Retreat strategy (3.18)-(3.19), with
  the piecewise-linear saturation variant the thesis simulates (§3.5) or the pure
  sign-type law.
- :class:`HoverBenchmark`: the thesis benchmark (fly towards F to the sphere, hover,
  fly straight back to D_s).
(the MPC controllers are in :mod:`planners.covert.mpc`.)

All controllers follow the protocol of :func:`scenarios.covert.simulate`.

Decisions where the thesis is silent or its literal law fails in discrete time (all in
:class:`SlidingSettings`; the literal law stays available with ``saturation=False``):

- W(mu1, mu2) normalises mu1 (the projection (3.9) needs a unit mu1; the thesis applies W to f).
- Saturation (§3.5 "piecewise linear continuous saturation"): the direction-to-the-line terms
  are saturated within ``eps_line`` of the constraint line, the worst-target switch (3.13) is
  replaced by weights over the targets within ``delta_beta`` of the maximum (without it the
  drone chatters between two lines near R and never leaves D_s), the turn rate is
  min(U_max, angle / dt), the speed is V_max cos(angle) (and times |b| on the sphere: the
  throttle of §3.5), the arrival on the sphere and at D_s is not overshot.
- The literal (3.17) adds p_m (metres) to a unit vector; with ``saturation=False`` the
  default enters p_m by its direction (``unit_p``), see that field.
- The observation ends when the remaining period equals the straight return time plus
  ``return_margin``; within ``home_radius`` of D_s the Retreat flies straight home
  (Remark 3.4.2: D_s is outside the targets' visual field).
- Initial heading: towards F. U_max is a turn rate (rad/s; Table 3.2 prints m/s^2).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from droneplan.core.validation import check_bool, check_in_range, check_nonneg, check_positive
from droneplan.scenarios.covert import (
    CovertCommand,
    CovertObservation,
    CovertParams,
    CovertPhase,
    CovertScenario,
    bearing_changes,
    nearest_on_line,
    step_drone,
)

__all__ = [
    "W",
    "g",
    "SlidingSettings",
    "sliding_steering",
    "selection_weights",
    "turn_command",
    "SlidingModeObserver",
    "HoverBenchmark",
    "rollout_sliding",
]

TO_SPHERE, ON_SPHERE, RETREAT, DONE = (
    CovertPhase.TO_SPHERE,
    CovertPhase.ON_SPHERE,
    CovertPhase.RETREAT,
    CovertPhase.DONE,
)


# --------------------------------------------------------------------------- W and g
def W(mu1: Any, mu2: Any) -> NDArray[np.float64]:
    """W(mu1, mu2) of (3.8)-(3.9), vectorised over leading axes.

    The unit vector in the plane of mu1 and mu2 orthogonal to mu1 and directed
    towards mu2 (Remark 3.4.1); 0 when mu1 and mu2 are collinear or mu2 = 0.
    mu1 is normalised first (the projection in (3.9) needs a unit mu1; the thesis
    applies W to non-unit vectors such as f). Raises ValueError if mu1 = 0.
    """
    m1 = np.asarray(mu1, dtype=float)
    m2 = np.asarray(mu2, dtype=float)
    n1 = np.linalg.norm(m1, axis=-1, keepdims=True)
    if np.any(n1 == 0) or not (np.isfinite(m1).all() and np.isfinite(m2).all()):
        raise ValueError("W needs a non-zero finite mu1 and a finite mu2")
    e1 = m1 / n1
    w = m2 - np.sum(e1 * m2, axis=-1, keepdims=True) * e1
    nw = np.linalg.norm(w, axis=-1, keepdims=True)
    scale = np.maximum(np.linalg.norm(m2, axis=-1, keepdims=True), 1e-300)
    zero = nw <= 1e-12 * scale
    return np.where(zero, 0.0, w / np.where(zero, 1.0, nw))


def g(mu1: Any, mu2: Any) -> NDArray[np.float64] | float:
    """g(mu1, mu2) of (3.10): +1 if mu1 . mu2 > 0, else -1 (vectorised)."""
    d = np.sum(np.asarray(mu1, float) * np.asarray(mu2, float), axis=-1)
    out = np.where(d > 0, 1.0, -1.0)
    return float(out) if out.ndim == 0 else out


# --------------------------------------------------------------------------- settings
@dataclass(frozen=True)
class SlidingSettings:
    """Settings of the sliding-mode laws and of the phase logic shared by all controllers."""

    saturation: bool = True
    """Use the piecewise-linear saturation of the sign-type functions of (3.15) (thesis §3.5);
    False: the literal switching law (chatters)."""
    eps_line: float = 2.0
    """Saturation width of the direction-to-the-line (sign-type) terms (m): within this distance
    of the constraint line, W(f, p_m) on the sphere (and with it the speed) and the p_m term of
    (3.17)/(3.19) shrink linearly to 0."""
    cos_sat: float = 1.0
    """Saturation of g(h, b): speed is V_max * clip((h . b_hat) / cos_sat, -1, 1) (dimensionless)."""
    home_radius: float = 15.0
    """Within this distance of D_s the Retreat flies straight to D_s (m); Remark 3.4.2 puts D_s
    outside the targets' visual field, so no target is tracked there."""
    return_margin: float = 2.0
    """The observation ends at duration - (|D - D_s| / V_max + return_margin) (s)."""
    arrival_tol: float = 0.05
    """Distance at which the sphere or D_s counts as reached (m)."""
    delta_beta: float = math.radians(1.0)
    """Saturation width of the worst-target selection (3.13) (rad), see selection_weights."""
    unit_p: bool = True
    """Without saturation: enter p_m as its direction in the sums p_m + b* of (3.17) and (3.19)
    (with saturation the term is p_m / max(|p_m|, eps_line)). The literal sum
    adds a length (m) to a unit vector, so it depends on the unit of length; with Table 3.2
    it keeps the drone sliding between the constraint lines near R far longer than the
    thesis's t_a = 7.4 s. False: the literal sum."""

    def __post_init__(self) -> None:
        for name in ("eps_line", "cos_sat", "home_radius", "arrival_tol", "delta_beta"):
            check_positive(name, getattr(self, name))
        check_in_range("cos_sat", self.cos_sat, hi=1.0)
        check_nonneg("return_margin", self.return_margin)
        check_bool("saturation", self.saturation)
        check_bool("unit_p", self.unit_p)


# --------------------------------------------------------------------------- the laws
def _p_term(p_m: NDArray[np.float64], settings: SlidingSettings) -> NDArray[np.float64]:
    """The p_m term of (3.17)/(3.19): saturated p_m / max(|p_m|, eps_line), else p_m or its direction."""
    if settings.saturation:
        return p_m / max(float(np.linalg.norm(p_m)), settings.eps_line)
    return p_m / np.linalg.norm(p_m) if settings.unit_p else p_m


def _steer_for(
    phase: str,
    D: NDArray[np.float64],
    p_m: NDArray[np.float64],
    params: CovertParams,
    settings: SlidingSettings,
) -> NDArray[np.float64]:
    """b_m of the phase given p_m, the vector to the chosen target's constraint line."""
    f = params.F_arr - D
    s = params.D_s_arr - D
    if phase == ON_SPHERE:
        if not settings.saturation:
            return W(f, p_m)
        e = f / np.linalg.norm(f)
        w = p_m - np.dot(e, p_m) * e
        return w / max(float(np.linalg.norm(w)), settings.eps_line)
    goal = f if phase == TO_SPHERE else s
    if np.linalg.norm(p_m) < 1e-9:
        return goal / max(float(np.linalg.norm(goal)), 1e-12)
    return _p_term(p_m, settings) + W(p_m, goal)


def selection_weights(beta: NDArray[np.float64], settings: SlidingSettings) -> NDArray[np.float64]:
    """Weights of the targets in the steering vector (A1, (3.13)).

    Literal law: 1 for the target with the largest bearing change, 0 for the others.
    Saturated law: the argmax selection is a sign-type switch between targets, so it is
    replaced by the continuous w_j = max(0, 1 - (beta_m - beta_j) / delta_beta), normalised
    (targets within delta_beta of the maximum share the steering, as a sliding mode does
    on the surface beta_i = beta_j).
    """
    if not settings.saturation:
        w = np.zeros(beta.shape)
        w[int(np.argmax(beta))] = 1.0
        return w
    w = np.maximum(0.0, 1.0 - (beta.max() - beta) / settings.delta_beta)
    return w / w.sum()


def sliding_steering(
    phase: str,
    D: NDArray[np.float64],
    A: NDArray[np.float64],
    params: CovertParams,
    settings: SlidingSettings,
) -> NDArray[np.float64]:
    """The steering vector b_m (m or unit, as in the thesis) of the current phase.

    D: drone position (3,); A: observable target positions (k, 3), k may be 0.
    to-sphere (3.16)-(3.17): f if k = 0, else p_m + W(p_m, f);
    on-sphere (3.14): W(f, p_m) (saturated: w(f, p_m) / max(|w|, eps_line)), 0 if k = 0;
    retreat (3.18)-(3.19): s if k = 0 or within home_radius of D_s, else p_m + W(p_m, s).
    The target m is chosen by :func:`selection_weights` (a weighted sum of the b_m of the
    tied targets in the saturated variant).
    """
    f = params.F_arr - D
    s = params.D_s_arr - D
    k = A.shape[0]
    if phase not in (TO_SPHERE, ON_SPHERE, RETREAT):
        return np.zeros(3)
    if k == 0:
        goals: dict[str, NDArray[np.float64]] = {TO_SPHERE: f, ON_SPHERE: np.zeros(3), RETREAT: s}
        return goals[phase]
    if phase == RETREAT and np.linalg.norm(s) <= settings.home_radius:
        return s
    beta = bearing_changes(D, A, params.R)
    w = selection_weights(beta, settings)
    r = params.R_arr - D
    b = np.zeros(3)
    for j in np.nonzero(w)[0]:
        p_j = nearest_on_line(A[j] - D, r)
        b = b + w[j] * _steer_for(phase, D, p_j, params, settings)
    return b


def turn_command(
    h: NDArray[np.float64],
    b: NDArray[np.float64],
    params: CovertParams,
    settings: SlidingSettings,
    dt: float,
    *,
    throttle: bool = False,
) -> tuple[NDArray[np.float64], float]:
    """The control (3.15): turn h towards b (or -h when b is behind) and fly at +-V_max.

    Literal law: u = U_max g(h, b) W(h, b), v = V_max g(h, b). Saturated law: the turn
    rate is min(U_max, theta / dt) with theta the angle between g h and b (no overshoot
    in one period), and v = V_max * clip((h . b_hat) / cos_sat, -1, 1), times min(1, |b|)
    when ``throttle`` (used on the sphere, where the saturated b shrinks near the constraint
    line: the throttle control of §3.5).
    b = 0 (nothing to steer towards) gives u = 0, v = 0.
    """
    nb = float(np.linalg.norm(b))
    if nb < 1e-12:
        return np.zeros(3), 0.0
    sign = float(g(h, b))  # h and b are single vectors: g is a scalar
    Wv = W(h, b)
    if not settings.saturation:
        return params.U_max * sign * Wv, params.V_max * sign
    c = float(np.dot(h, b) / nb)
    theta = math.acos(min(1.0, abs(c)))
    rate = min(params.U_max, theta / dt)
    v = params.V_max * min(1.0, nb if throttle else 1.0) * float(np.clip(c / settings.cos_sat, -1.0, 1.0))
    return rate * sign * Wv, v


def _cap_speed(
    v: float, h: NDArray[np.float64], toward: NDArray[np.float64], room: float, dt: float
) -> float:
    """Limit |v| so that one step along +-h does not advance more than ``room`` along ``toward``."""
    e = toward / max(float(np.linalg.norm(toward)), 1e-12)
    closing = math.copysign(1.0, v) * float(np.dot(h, e))
    if closing <= 1e-6:
        return v
    vmax = max(room, 0.0) / (dt * closing)
    return math.copysign(min(abs(v), vmax), v)


class _PhasedController:
    """Phase logic shared by the controllers: to-sphere -> on-sphere -> retreat -> done."""

    def __init__(self, settings: SlidingSettings | None = None):
        self.settings = settings if settings is not None else SlidingSettings()
        if not isinstance(self.settings, SlidingSettings):
            raise TypeError("settings must be a SlidingSettings")
        self._params: CovertParams | None = None
        self.phase = TO_SPHERE
        self.finished = False
        self.fallbacks = 0
        self.solve_times: list[float] = []

    @property
    def params(self) -> CovertParams:
        """The parameters of the scenario of the current run (set by :meth:`reset`)."""
        if self._params is None:
            raise RuntimeError("reset() must be called before the controller is used")
        return self._params

    def reset(self, scenario: CovertScenario, *, seed: Any = None) -> None:
        """Start a run on ``scenario`` (the laws are deterministic: ``seed`` is unused)."""
        self._params = scenario.params
        self.scenario = scenario
        self.phase = TO_SPHERE
        self.finished = False
        self.fallbacks = 0
        self.solve_times = []

    def _update_phase(
        self, obs: CovertObservation, *, return_speed: float | None = None, extra_margin: float = 0.0
    ) -> None:
        """Advance to-sphere -> on-sphere -> retreat -> done; the retreat starts when a
        flight home at ``return_speed`` (m/s, default V_max) would end at the duration."""
        p, st = self.params, self.settings
        D = obs.drone
        speed = p.V_max if return_speed is None else return_speed
        leave_at = p.duration - (np.linalg.norm(p.D_s_arr - D) / speed + st.return_margin + extra_margin)
        if self.phase == TO_SPHERE and np.linalg.norm(p.F_arr - D) <= p.L_u + st.arrival_tol:
            self.phase = ON_SPHERE
        if self.phase in (TO_SPHERE, ON_SPHERE) and obs.t >= leave_at:
            self.phase = RETREAT
        if self.phase == RETREAT and np.linalg.norm(p.D_s_arr - D) <= st.arrival_tol:
            self.phase = DONE
            self.finished = True

    def _limit(self, u: NDArray[np.float64], v: float, obs: CovertObservation) -> CovertCommand:
        """Saturated variant only: do not cross the sphere on arrival, do not overshoot D_s."""
        p = self.params
        if not self.settings.saturation:
            return CovertCommand(u, v)
        D, h = obs.drone, obs.heading
        if self.phase == TO_SPHERE:
            f = p.F_arr - D
            v = _cap_speed(v, h, f, float(np.linalg.norm(f)) - p.L_u, p.dt)
        elif self.phase == RETREAT:
            s = p.D_s_arr - D
            v = _cap_speed(v, h, s, float(np.linalg.norm(s)), p.dt)
        return CovertCommand(u, v)

    def sliding_command(self, obs: CovertObservation) -> CovertCommand:
        """The sliding-mode command for this observation in the current phase."""
        if self.phase == DONE:
            return CovertCommand(np.zeros(3), 0.0)
        A = obs.targets
        b = sliding_steering(self.phase, obs.drone, A, self.params, self.settings)
        u, v = turn_command(
            obs.heading, b, self.params, self.settings, self.params.dt, throttle=self.phase == ON_SPHERE
        )
        return self._limit(u, v, obs)


class SlidingModeObserver(_PhasedController):
    """The thesis's navigation laws (To-sphere, On-sphere, Retreat) as a closed-loop controller.

    settings: :class:`SlidingSettings` (saturation variant by default, as simulated in §3.5).
    """

    def command(self, obs: CovertObservation) -> CovertCommand:
        """u (3,) (rad/s) and v (m/s) for this control period."""
        self._update_phase(obs)
        return self.sliding_command(obs)


class HoverBenchmark(_PhasedController):
    """Thesis benchmark (§3.5): fly towards F to the sphere, stay there, then fly straight to D_s.

    Uses the same turn/speed law as the saturated sliding mode with b = f, 0, s.
    """

    def command(self, obs: CovertObservation) -> CovertCommand:
        """u (3,) (rad/s) and v (m/s) for this control period."""
        self._update_phase(obs)
        p = self.params
        if self.phase == TO_SPHERE:
            b = p.F_arr - obs.drone
        elif self.phase == RETREAT:
            b = p.D_s_arr - obs.drone
        else:
            return CovertCommand(np.zeros(3), 0.0)
        sat = SlidingSettings(**{**self.settings.__dict__, "saturation": True})
        u, v = turn_command(obs.heading, b, p, sat, p.dt)
        f = p.F_arr - obs.drone
        if self.phase == TO_SPHERE:
            v = _cap_speed(v, obs.heading, f, float(np.linalg.norm(f)) - p.L_u, p.dt)
        else:
            v = _cap_speed(v, obs.heading, b, float(np.linalg.norm(b)), p.dt)
        return CovertCommand(u, v)


def rollout_sliding(
    phase: CovertPhase | str,
    D: Any,
    h: Any,
    targets: Any,
    params: CovertParams,
    settings: SlidingSettings | None = None,
) -> tuple[NDArray[np.float64], NDArray[np.float64], list[CovertPhase]]:
    """Open-loop prediction of the :class:`SlidingModeObserver` from (D, h) in ``phase``.

    targets: (K, k, 3) positions (m) of the observable targets at the K control instants
    t = 0, dt, ..., (K-1) dt (e.g. a constant-velocity prediction). Applies the same law,
    saturation caps and plant step as the closed-loop observer, period by period, with the
    to-sphere -> on-sphere and retreat -> done switches; the switch to the retreat (a
    clock decision) is not made inside the rollout. Returns positions (K+1, 3) (m),
    headings (K+1, 3) and the phase used in each of the K periods.

    params: problem parameters, CovertParams (Table 3.2).
    settings: SlidingSettings (default: SlidingSettings()).
    """
    st = settings if settings is not None else SlidingSettings()
    p = params
    phase = CovertPhase(phase)  # ValueError for an unknown phase name
    A_all = np.asarray(targets, dtype=float)
    if A_all.ndim != 3 or A_all.shape[2] != 3:
        raise ValueError(f"targets must have shape (K, k, 3), got {A_all.shape}")
    D = np.asarray(D, dtype=float).copy()
    h = np.asarray(h, dtype=float).copy()
    Ds, hs = [D.copy()], [h.copy()]
    phases: list[CovertPhase] = []
    for k in range(A_all.shape[0]):
        if phase == TO_SPHERE and np.linalg.norm(p.F_arr - D) <= p.L_u + st.arrival_tol:
            phase = ON_SPHERE
        if phase == RETREAT and np.linalg.norm(p.D_s_arr - D) <= st.arrival_tol:
            phase = DONE
        phases.append(phase)
        if phase == DONE:
            u, v = np.zeros(3), 0.0
        else:
            b = sliding_steering(phase, D, A_all[k], p, st)
            u, v = turn_command(h, b, p, st, p.dt, throttle=phase == ON_SPHERE)
            if st.saturation and phase == TO_SPHERE:
                f = p.F_arr - D
                v = _cap_speed(v, h, f, float(np.linalg.norm(f)) - p.L_u, p.dt)
            elif st.saturation and phase == RETREAT:
                s = p.D_s_arr - D
                v = _cap_speed(v, h, s, float(np.linalg.norm(s)), p.dt)
        D, h, _, _ = step_drone(D, h, u, v, p.dt, p)
        Ds.append(D.copy())
        hs.append(h.copy())
    return np.asarray(Ds), np.asarray(hs), phases
