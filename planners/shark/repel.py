"""The thesis's shark-repelling procedure (§5.3.1, steps 1-5) as an operator controller.

Per step the operator (assigned to one shark) does:
1. cover: if the shark is within ``cover_distance`` of a swimmer and closing in, hover with
   the field centred over that swimmer (at the optimal altitude for the shark's depth);
2. intercept: if the shark approaches a swimmer (closing speed > ``closing_speed`` within
   ``alert_radius``), intercept it with the virtual-shark algorithm (or the online OCP);
3. wait T_w after each interception (field contact), following the shark at
   ``follow_distance``; also follow when the shark is not approaching anyone;
4. repeat until the shark is ``safety_distance`` from every swimmer;
5. then fly back to ``base`` (the episode's end).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from droneplan.core.validation import check_array, check_instance, check_int, check_nonneg
from droneplan.formulations.shark import optimal_altitude
from droneplan.planners.shark.ocp import OCPInterceptor
from droneplan.planners.shark.pursuit import VirtualSharkInterceptor
from droneplan.scenarios.shark import (
    THESIS_TABLE_5_1,
    InterceptionScenario,
    RepellingMode,
    RepellingObservation,
    RepellingScenario,
    SharkCommand,
    SharkObservation,
    SharkParams,
    clip_velocity,
    constant_velocity_trajectory,
)

__all__ = ["RepellingOperator"]


class RepellingOperator:
    """Operator controller for `scenarios.shark.simulate_repelling` following §5.3.1.

    shark: index of the allocated shark; T_w: waiting time after each interception (s);
    follow_distance: stand-off while following (m); alert_radius: distance of the shark to a
    swimmer within which an approach triggers an interception (m); cover_distance: closer than
    this the operator covers the swimmer instead (m); closing_speed: approach speed that
    counts as "approaching" (m/s); safety_distance: distance at which the shark has left (m;
    300 m rather than the thesis's example 3 km: on the reproduction's episodes 3 km gave the
    same attacks and interceptions and only added ~540 s of the shark swimming away at 5 m/s);
    base: (3,) return position (m); interceptor: "virtual-shark" or "ocp" (online OCP).
    Follows the closed-loop contract (``reset``, ``command(RepellingObservation) -> SharkCommand``);
    ``phase`` is a :class:`RepellingMode`; ``interceptions`` counts field contacts with its shark.

    params: problem parameters, SharkParams (default: THESIS_TABLE_5_1).
    """

    def __init__(
        self,
        shark: int,
        params: SharkParams = THESIS_TABLE_5_1,
        *,
        T_w: float = 4.0,
        follow_distance: float = 12.0,
        alert_radius: float = 150.0,
        cover_distance: float = 10.0,
        closing_speed: float = 0.5,
        safety_distance: float = 300.0,
        base=(0.0, -100.0, 2.0),
        interceptor: str = "virtual-shark",
    ):
        for name, v in dict(
            T_w=T_w,
            follow_distance=follow_distance,
            alert_radius=alert_radius,
            cover_distance=cover_distance,
            closing_speed=closing_speed,
            safety_distance=safety_distance,
        ).items():
            check_nonneg(name, v)
        check_int("shark", shark, min_value=0)
        check_instance("params", params, SharkParams)
        check_array("base", base, shape=(3,))
        if interceptor not in ("virtual-shark", "ocp"):
            raise ValueError(f"interceptor must be 'virtual-shark' or 'ocp', got {interceptor!r}")
        self.shark, self.params, self.T_w = int(shark), params, T_w
        self.follow_distance, self.alert_radius = follow_distance, alert_radius
        self.cover_distance, self.closing_speed = cover_distance, closing_speed
        self.safety_distance = safety_distance
        self.base = np.asarray(base, float)
        self.kind = interceptor
        self._start()

    def _start(self) -> None:
        self.phase = RepellingMode.FOLLOW
        self.interceptions = 0
        self._wait_until = -np.inf
        self._ctl: OCPInterceptor | VirtualSharkInterceptor | None = None

    def reset(self, scenario: RepellingScenario, *, seed=None) -> None:
        """Start an episode (the scenario's params replace the constructor's; ``seed`` unused)."""
        self.params = scenario.params
        self._start()

    def _new_interceptor(self) -> OCPInterceptor | VirtualSharkInterceptor:
        if self.kind == "ocp":
            return OCPInterceptor(self.params, N=15)
        return VirtualSharkInterceptor(self.params)

    def _goto(
        self,
        O: NDArray[np.float64],
        target: NDArray[np.float64],
        feedforward: NDArray[np.float64] | None = None,
    ) -> NDArray[np.float64]:
        p = self.params
        d = target - O
        ff = np.zeros(2) if feedforward is None else feedforward
        vxy = ff + d[:2] / p.Ts
        n = np.linalg.norm(vxy)
        if n > p.VoMxy:
            vxy = vxy * p.VoMxy / n
        vz = float(np.clip(d[2] / p.Ts, -p.VoMz, p.VoMz))
        return clip_velocity(np.r_[vxy, vz], p)[0]

    def command(self, obs: RepellingObservation) -> SharkCommand:
        """Velocity command (m/s) for the next Ts."""
        v = self._velocity(obs.t, obs.operator, obs.sharks_pos, obs.sharks_vel, obs.swimmers, obs.contact)
        return SharkCommand(v, True)

    def _velocity(self, t, operator, sharks_pos, sharks_vel, swimmers, contact) -> NDArray[np.float64]:
        p = self.params
        O = np.asarray(operator, float)
        S = np.asarray(sharks_pos, float)[self.shark]
        V = np.asarray(sharks_vel, float)[self.shark]
        H = np.asarray(swimmers, float)[:, :2]
        dh = np.linalg.norm(H - S[:2], axis=1)
        near = H[np.argmin(dh)]
        to_h = (near - S[:2]) / max(dh.min(), 1e-9)
        closing = float(V[:2] @ to_h) > self.closing_speed
        zo = optimal_altitude(min(S[2], 0.0), p)[0]
        if contact[self.shark]:
            self.interceptions += 1
            self._wait_until = t + self.T_w
            self._ctl = None
        if dh.min() > self.safety_distance or self.phase == RepellingMode.RETURN:
            self.phase = RepellingMode.RETURN
            return self._goto(O, self.base)
        if closing and dh.min() < self.cover_distance:
            self.phase = RepellingMode.COVER
            self._ctl = None
            return self._goto(O, np.r_[near, zo])
        if t < self._wait_until or not (closing and dh.min() < self.alert_radius):
            self.phase = RepellingMode.WAIT if t < self._wait_until else RepellingMode.FOLLOW
            self._ctl = None
            rel = O[:2] - S[:2]
            u = rel / max(np.linalg.norm(rel), 1e-9)
            return self._goto(O, np.r_[S[:2] + self.follow_distance * u, p.le], V[:2])
        if self._ctl is None:
            self._ctl = self._new_interceptor()
            # the interceptors read only the parameters from the scenario; the shark's path is unknown here
            flat_v = np.r_[V[:2], 0.0]
            self._ctl.reset(
                InterceptionScenario(constant_velocity_trajectory(S, flat_v, duration=p.Ts, dt=p.Ts), p, O)
            )
        self.phase = RepellingMode.INTERCEPT
        return self._ctl.command(SharkObservation(t, O, S, V)).velocity
