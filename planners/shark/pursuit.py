"""Classical pursuit (eq. 5.5) and the two-phase virtual-shark interceptor (eqs. 5.8-5.20).

Both implement the closed-loop controller contract (``reset(scenario, *, seed)``,
``command(SharkObservation) -> SharkCommand``, ``phase``) of `scenarios.shark.simulate`.

Discretisation and documented fixes (deviations from the thesis, each with its reason):
- Speed limits: eq. 5.14/5.5 command VoM along the 3-D line of sight; the command is
  then clipped to |v_xy| <= VoMxy, |v_z| <= VoMz (the limits of §5.3.2).
- Final step: when a pursued point is reachable within one Ts the operator moves
  onto it (instead of overshooting and chattering around the capture ball gamma), and
  5.14 aims at S1's position at the end of the step (S1 + Ts v_s) rather than the current
  one, which otherwise chatters around S1 when the step is comparable to the distance.
- Side rule (5.12, 5.20): p is the perpendicular of the shark's horizontal velocity on
  the operator's side of the shark's path (line through S for p, through S2 for p').
- Shark speed -> 0 (5.16 divides by |v_sxy|): below ``speed_eps`` the last heading is
  kept and 5.16 is replaced by its limit -p'_unit * VoMxy.
- Out of reach (eps* = 0): the geometry uses eps_o so the operator keeps station ahead
  of the shark at lmin and waits for it to rise (thesis, case (d)).
- Reversal: step 2 (5.16) only moves the operator across the shark's path, so if the shark
  reverses or turns sharply during step 2 the along-path gap to S2 is never closed and the
  operator shadows the shark forever. With ``restart_step1=True`` (default) the interceptor
  returns to step 1 when that gap exceeds eps' (``False``: the thesis's law alone).
- Step 3 ("immediately slows down"): horizontal velocity 0, altitude kept at z_o*;
  if the shark has not touched the field after ``hold_timeout`` s (it turned away),
  the interceptor starts again from step 1.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from droneplan.core.validation import check_bool, check_instance, check_positive, require_set
from droneplan.formulations.shark import optimal_altitude
from droneplan.planners.shark.altitude import thesis_altitude
from droneplan.scenarios.shark import (
    THESIS_TABLE_5_1,
    InterceptionScenario,
    SharkCommand,
    SharkObservation,
    SharkParams,
    SharkPhase,
    clip_velocity,
)

__all__ = ["ClassicalPursuit", "VirtualSharkInterceptor"]


class ClassicalPursuit:
    """Classical pursuit, eq. 5.5: v_o = VoM (A - O)/|A - O|, clipped to the per-axis limits.

    aim: "above" (default) aims at A = (S_xy, z_o*(z_s)), the reachable point above the
        shark; "shark" aims at A = S literally. Taken literally, 5.5 points below the
        operator's altitude floor lmin, the vertical part is wasted and the operator
        stalls where VoM*cos(elevation) = |v_s| (on path a it hovers 3.59 m behind the
        shark and never touches, while the thesis's Fig. 5.11 shows a contact).
    It has no notion of an interception point: ``at_interception`` is always True (any
    contact is the one it aims for), ``phase`` is ``SharkPhase.PURSUIT``.

    params: problem parameters, SharkParams (default: THESIS_TABLE_5_1).
    """

    at_interception = True
    phase = SharkPhase.PURSUIT

    def __init__(self, params: SharkParams = THESIS_TABLE_5_1, *, aim: str = "above"):
        check_instance("params", params, SharkParams)
        if aim not in ("above", "shark"):
            raise ValueError(f"aim must be 'above' or 'shark', got {aim!r}")
        self.params = params
        self.aim = aim

    def reset(self, scenario: InterceptionScenario, *, seed=None) -> None:
        """Start a run (the scenario's params replace the constructor's; deterministic, ``seed`` unused)."""
        self.params = scenario.params

    def command(self, obs: SharkObservation) -> SharkCommand:
        """Velocity command (m/s) of eq. 5.5."""
        A = np.array(obs.shark_pos, dtype=float)
        if self.aim == "above":
            A[2] = optimal_altitude(min(A[2], 0.0), self.params)[0]
        d = A - np.asarray(obs.operator, float)
        n = np.linalg.norm(d)
        if n < 1e-12:
            return SharkCommand(np.zeros(3), True)
        return SharkCommand(clip_velocity(self.params.VoM * d / n, self.params)[0], True)


def _rot_left(u: NDArray[np.float64]) -> NDArray[np.float64]:
    return np.array([-u[1], u[0]])


class VirtualSharkInterceptor:
    """The thesis's interception algorithm (§5.3.2): pursue S1, then S2, then slow down.

    params: problem parameters (the simulator's replace them at reset).
    altitude: "exact" (default: `formulations.shark.optimal_altitude`) or "thesis"
        (Prop. 5.3.1 verbatim, clipped to [lmin, le]).
    side: None (thesis rule: the operator's side of the path), +1 (left of the shark's
        heading) or -1 (right) to force the side of the approach.
    speed_eps: shark speed (m/s) below which the last heading is kept.
    hold_timeout: time (s) in step 3 without contact before restarting at step 1.
    restart_step1: return to step 1 when S2 is no longer beside the operator (see module doc).

    Attributes: ``phase`` (``SharkPhase.APPROACH``, ``CROSS``, ``HOLD`` = the thesis's steps 1, 2, 3),
    ``at_interception`` (step 3), ``capture_time`` (s,
    time step 3 was entered, i.e. the interception point was reached).
    """

    def __init__(
        self,
        params: SharkParams = THESIS_TABLE_5_1,
        *,
        altitude: str = "exact",
        side: int | None = None,
        speed_eps: float = 0.05,
        hold_timeout: float = 1.0,
        restart_step1: bool = True,
    ):
        if altitude not in ("exact", "thesis"):
            raise ValueError(f"altitude must be 'exact' or 'thesis', got {altitude!r}")
        if side not in (None, 1, -1):
            raise ValueError(f"side must be None, +1 or -1, got {side!r}")
        check_instance("params", params, SharkParams)
        check_positive("speed_eps", speed_eps)
        check_positive("hold_timeout", hold_timeout)
        self.params = params
        self.altitude = altitude
        self.side = side
        self.speed_eps = speed_eps
        self.hold_timeout = hold_timeout
        self.restart_step1 = check_bool("restart_step1", restart_step1)
        self._start(params)

    def reset(self, scenario: InterceptionScenario, *, seed=None) -> None:
        """Start a new run at step 1 (the scenario's params replace the constructor's; ``seed`` unused)."""
        self._start(scenario.params)

    def _start(self, params: SharkParams) -> None:
        self.params = params
        self.phase = SharkPhase.APPROACH
        self.at_interception = False
        self.capture_time: float | None = None
        self._heading = np.array([1.0, 0.0])
        self._side2: int | None = None  # side of the line through S2 in step 2 (+1 left, -1 right)
        self._hold_since: float | None = None  # time step 3 was entered (s)

    # geometry -----------------------------------------------------------------------------
    def altitude_target(self, z_s: float) -> tuple[float, float]:
        """(z_o*, eps*) in m for shark altitude z_s, by the configured rule."""
        z_s = min(float(z_s), 0.0)
        if self.altitude == "exact":
            return optimal_altitude(z_s, self.params)
        zo, eps = thesis_altitude(z_s, self.params)
        return min(max(zo, self.params.lmin), self.params.le), eps

    def virtual_sharks(self, operator, shark_pos, shark_vel):
        """(S1, S2, u, p_side) of eqs. 5.8-5.13: virtual sharks (3,) at altitude z_o*, unit heading u."""
        p = self.params
        v = np.asarray(shark_vel, float)[:2]
        sp = np.linalg.norm(v)
        if sp >= self.speed_eps:
            self._heading = v / sp
        u = self._heading
        zo, eps = self.altitude_target(shark_pos[2])
        eps_ref = eps if eps > 0 else p.eps_o
        e1 = eps_ref * (1 + p.gamma)  # 5.8
        S = np.asarray(shark_pos, float)[:2]
        O = np.asarray(operator, float)[:2]
        side = self.side
        if side is None:
            cross = u[0] * (O[1] - S[1]) - u[1] * (O[0] - S[0])
            side = 1 if cross >= 0 else -1  # operator's side of the path (fix of 5.12)
        pu = side * _rot_left(u)
        S2 = S + u * e1  # 5.9
        S1 = S2 + pu * e1  # 5.10
        return np.r_[S1, zo], np.r_[S2, zo], u, side

    # control ------------------------------------------------------------------------------
    def _vz(self, z, zo) -> float:
        dz = zo - z
        lim = self.params.VoMz
        if abs(dz) <= lim * self.params.Ts:
            return dz / self.params.Ts
        return math.copysign(lim, dz)  # 5.17

    def command(self, obs: SharkObservation) -> SharkCommand:
        """Velocity command (m/s) for the next Ts; ``at_interception`` once in step 3."""
        v = self._velocity(obs.t, obs.operator, obs.shark_pos, obs.shark_vel)
        return SharkCommand(v, self.at_interception)

    def _velocity(self, t: float, operator, shark_pos, shark_vel) -> NDArray[np.float64]:  # noqa: C901
        p = self.params
        O = np.asarray(operator, float)
        Vs = np.asarray(shark_vel, float)
        S1, S2, u, side = self.virtual_sharks(O, shark_pos, shark_vel)
        vxy = Vs[:2]
        sp = float(np.linalg.norm(vxy))
        if self.phase == SharkPhase.APPROACH and np.linalg.norm(S1 - O) <= p.gamma:  # 5.15
            self.phase = SharkPhase.CROSS
            self._side2 = side
        if self.phase == SharkPhase.CROSS and self.restart_step1:
            e1 = np.linalg.norm(S2[:2] - np.asarray(shark_pos, float)[:2])
            if abs(float((O[:2] - S2[:2]) @ u)) > e1:  # S2 no longer beside the operator
                self.phase = SharkPhase.APPROACH
        if self.phase == SharkPhase.CROSS and np.linalg.norm(S2 - O) <= p.gamma:  # 5.19
            self.phase = SharkPhase.HOLD
            self.capture_time = t
            self._hold_since = t
        if self.phase == SharkPhase.HOLD:
            hold_since = require_set(self._hold_since, "the hold start is set on entering step 3")
            if t - hold_since > self.hold_timeout + 1e-9:
                self.phase = SharkPhase.APPROACH
                self._hold_since = None
        self.at_interception = self.phase == SharkPhase.HOLD

        if self.phase == SharkPhase.APPROACH:  # 5.14 with the final-step saturation
            target_next = S1 + p.Ts * np.r_[vxy, 0.0]
            d = target_next - O
            if np.hypot(d[0], d[1]) <= p.VoMxy * p.Ts and abs(d[2]) <= p.VoMz * p.Ts:
                return d / p.Ts
            # aim at where S1 will be after this step: pursuing the current point with steps
            # comparable to the distance chatters around S1 without closing in
            return clip_velocity(p.VoM * d / np.linalg.norm(d), p)[0]
        if self.phase == SharkPhase.CROSS:  # 5.16-5.18
            rel = O[:2] - S2[:2]
            cross = u[0] * rel[1] - u[1] * rel[0]
            if abs(cross) > 1e-9:
                self._side2 = 1 if cross > 0 else -1  # side of the line through S2 (fix of 5.20)
            pp = require_set(self._side2, "the side is set on entering step 2") * _rot_left(u)
            d_next = S2[:2] + p.Ts * vxy - O[:2]
            if np.linalg.norm(d_next) <= p.VoMxy * p.Ts:
                v_xy = d_next / p.Ts
            elif sp < self.speed_eps:
                v_xy = -pp * p.VoMxy  # limit of 5.16 as |v_sxy| -> 0
            else:
                v_xy = -pp * math.sqrt(max(p.VoMxy**2 - sp**2, 0.0)) + vxy  # 5.16 with p' = |v_sxy| pp
            return clip_velocity(np.r_[v_xy, self._vz(O[2], S2[2])], p)[0]
        # step 3: slow down, keep the optimal altitude
        return np.array([0.0, 0.0, self._vz(O[2], S2[2])])
