"""Closed-loop simulation of one operator intercepting one shark on a prescribed path (eq. 5.4 at Ts)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np

from droneplan.scenarios.shark.params import THESIS_TABLE_5_1, SharkParams, field_radius, inside_field
from droneplan.scenarios.shark.trajectories import SharkTrajectory
from droneplan.solvers.validation import check_array, check_in_range, check_int, check_methods, check_real

__all__ = ["InterceptionController", "InterceptionTrace", "simulate_interception", "operator_start",
           "clip_velocity", "FRONTAL_TOL_DEG", "DEFAULT_BEARING_DEG"]

DEFAULT_BEARING_DEG = -105.0
"""Default operator start bearing (deg) from the shark's initial heading: behind-right.

The thesis does not state where the operator starts (only Di = 13 m); -105 deg puts the
virtual-shark interception distance on path a near Table 5.2's 29.70 m.
"""

FRONTAL_TOL_DEG = 10.0
"""Tolerance (deg) on the angle between the shark's horizontal heading and the shark->operator direction."""


class InterceptionController(Protocol):
    """What the simulator needs from a controller (planners implement it).

    ``reset(operator, params)`` before a run; ``step(t, operator, shark_pos, shark_vel)``
    returns the commanded operator velocity (3,) in m/s; ``at_interception`` is True
    once the controller has reached its interception point (its first field contact
    is then intended); ``phase`` is an int logged for plots.
    """

    at_interception: bool
    phase: int

    def reset(self, operator: np.ndarray, params: SharkParams) -> None: ...

    def step(self, t: float, operator: np.ndarray, shark_pos: np.ndarray, shark_vel: np.ndarray) -> np.ndarray: ...


@dataclass
class InterceptionTrace:
    """Time series and outcome of one interception run.

    t (K,) s; operator, shark (K,3) m; operator_vel, shark_vel (K,3) m/s;
    eps (K,) field radius on the shark's plane eps(z_o - z_s) (m); D_h (K,) horizontal
    operator-shark distance (m); phase (K,) controller phase.
    intercept_time: first field contact (s) or None; interception_distance: |S(contact) - S(0)|
    (m, Table 5.2's metric) or None; frontal: the shark's horizontal heading points at the
    operator within ``frontal_tol_deg`` at first contact; frontal_angle (deg);
    touched_early: first contact came before the controller reached its interception point;
    contact_eps: eps on the shark's plane at contact (m); clipped_steps: commands the
    simulator had to clip to the speed limits.
    """

    t: np.ndarray
    operator: np.ndarray
    shark: np.ndarray
    operator_vel: np.ndarray
    shark_vel: np.ndarray
    eps: np.ndarray
    D_h: np.ndarray
    phase: np.ndarray
    intercept_time: float | None
    interception_distance: float | None
    frontal: bool
    frontal_angle: float | None
    touched_early: bool
    contact_eps: float | None
    clipped_steps: int
    frontal_tol_deg: float = FRONTAL_TOL_DEG
    name: str = ""
    info: dict = field(default_factory=dict)

    @property
    def intercepted(self) -> bool:
        """True when the field touched the shark within the simulated horizon."""
        return self.intercept_time is not None


def clip_velocity(v, params: SharkParams) -> tuple[np.ndarray, bool]:
    """Clip a velocity (3,) to |v_xy| <= VoMxy and |v_z| <= VoMz; return it and whether it was clipped."""
    v = np.array(v, dtype=float)
    if not np.all(np.isfinite(v)):
        raise ValueError(f"controller returned a non-finite velocity {v}")
    clipped = False
    n = math.hypot(v[0], v[1])
    if n > params.VoMxy * (1 + 1e-9):
        v[:2] *= params.VoMxy / n
        clipped = True
    if abs(v[2]) > params.VoMz * (1 + 1e-9):
        v[2] = math.copysign(params.VoMz, v[2])
        clipped = True
    return v, clipped


def operator_start(trajectory: SharkTrajectory, params: SharkParams = THESIS_TABLE_5_1, *,
                   bearing_deg: float = DEFAULT_BEARING_DEG, altitude: float | None = None) -> np.ndarray:
    """Operator start: Di metres from the shark horizontally, at ``bearing_deg`` from its initial heading.

    bearing 0 = straight ahead, -90 = to the right of the shark (default DEFAULT_BEARING_DEG); altitude defaults to le.
    """
    if not isinstance(trajectory, SharkTrajectory):
        raise TypeError(f"trajectory must be a SharkTrajectory, got {type(trajectory).__name__}")
    if not isinstance(params, SharkParams):
        raise TypeError(f"params must be SharkParams, got {type(params).__name__}")
    bearing_deg = check_real("bearing_deg", bearing_deg)
    s0, v0 = trajectory.pos[0], trajectory.vel[0]
    psi = math.atan2(v0[1], v0[0]) + math.radians(bearing_deg)
    z = params.le if altitude is None else check_in_range("altitude", altitude, params.lmin, params.le)
    return np.array([s0[0] + params.Di * math.cos(psi), s0[1] + params.Di * math.sin(psi), z])


def simulate_interception(trajectory: SharkTrajectory, controller: InterceptionController,
                          params: SharkParams = THESIS_TABLE_5_1, *, operator0=None,
                          bearing_deg: float = DEFAULT_BEARING_DEG, t_max: float | None = None,
                          frontal_tol_deg: float = FRONTAL_TOL_DEG, substeps: int = 10) -> InterceptionTrace:
    """Run ``controller`` against the shark's path with the integrator dynamics (5.4) at Ts.

    The operator starts at ``operator0`` (m) or at ``operator_start(trajectory, params,
    bearing_deg=...)``; commands are clipped to the speed limits and the altitude to
    [lmin, le]; field contact is checked on ``substeps`` points per step (linear motion of
    both within a step). The run stops at the first contact or at ``t_max`` (s; default the
    path's duration).
    """
    if not isinstance(trajectory, SharkTrajectory):
        raise TypeError(f"trajectory must be a SharkTrajectory, got {type(trajectory).__name__}")
    if not isinstance(params, SharkParams):
        raise TypeError(f"params must be SharkParams, got {type(params).__name__}")
    check_methods("controller", controller, ("reset", "step"))
    if trajectory.dt != params.Ts and not math.isclose(trajectory.dt, params.Ts, rel_tol=1e-9):
        raise ValueError(f"trajectory dt={trajectory.dt} must equal Ts={params.Ts}")
    if t_max is not None:
        check_in_range("t_max", t_max, 0.0, lo_open=True)
    frontal_tol_deg = check_in_range("frontal_tol_deg", frontal_tol_deg, 0.0, 180.0, lo_open=True, hi_open=True)
    substeps = check_int("substeps", substeps, min_value=1, max_value=10_000)
    if operator0 is None:
        O = operator_start(trajectory, params, bearing_deg=bearing_deg)
    else:
        O = check_array("operator0", operator0, shape=(3,))
        # the simulator keeps the altitude in [lmin, le]; a start outside would be recorded
        # as a jump at an impossible speed
        check_in_range("operator0[2] (altitude)", O[2], params.lmin, params.le)
    if np.hypot(*(O[:2] - trajectory.pos[0, :2])) <= params.eps_o:
        raise ValueError(f"initial horizontal separation must exceed eps_o={params.eps_o} (Prop. 5.3.2)")
    n_max = len(trajectory.t) - 1 if t_max is None else min(len(trajectory.t) - 1, int(round(t_max / params.Ts)))
    controller.reset(O.copy(), params)
    ops, ovs, phases = [O.copy()], [], []
    clipped_steps = 0
    contact = None
    fr = np.linspace(0.0, 1.0, substeps + 1)[1:]
    for k in range(n_max):
        S, V = trajectory.pos[k], trajectory.vel[k]
        v = controller.step(float(trajectory.t[k]), O.copy(), S.copy(), V.copy())
        # the command covers [t_k, t_k + Ts]: the controller's flag after deciding it tells
        # whether a contact during this step is intended
        ready = bool(getattr(controller, "at_interception", True))
        phases.append(int(getattr(controller, "phase", 0)))
        v, c = clip_velocity(v, params)
        clipped_steps += c
        On = O + params.Ts * v
        On[2] = min(max(On[2], params.lmin), params.le)
        v = (On - O) / params.Ts
        ovs.append(v)
        # contact check on the segment (both move linearly within the step)
        Sn = trajectory.pos[k + 1]
        Ss = S + fr[:, None] * (Sn - S)
        Os = O + fr[:, None] * (On - O)
        clear = inside_field(Ss, Os, params)
        O = On
        ops.append(O.copy())
        if np.any(clear <= 0):
            j = int(np.argmax(clear <= 0))
            tc = float(trajectory.t[k] + fr[j] * params.Ts)
            Vc = V + fr[j] * (trajectory.vel[k + 1] - V)
            contact = (k + 1, tc, Ss[j], Vc, Os[j], ready)
            break
    K = len(ops)
    t = trajectory.t[:K]
    op = np.array(ops)
    ov = np.vstack([np.array(ovs), np.zeros((1, 3))]) if ovs else np.zeros((1, 3))
    sh = trajectory.pos[:K]
    sv = trajectory.vel[:K]
    eps = field_radius(op[:, 2] - sh[:, 2], params)
    D_h = np.hypot(*(op[:, :2] - sh[:, :2]).T)
    phase = np.array(phases + [phases[-1] if phases else 0])
    if contact is None:
        return InterceptionTrace(t, op, sh, ov, sv, eps, D_h, phase, None, None, False, None, False, None,
                                 clipped_steps, frontal_tol_deg, trajectory.name)
    _, tc, Sc, Vc, Oc, ready = contact
    rel = Oc[:2] - Sc[:2]
    hv = Vc[:2]
    if np.linalg.norm(hv) < 1e-9 or np.linalg.norm(rel) < 1e-9:
        angle = 0.0 if np.linalg.norm(rel) < 1e-9 else 180.0
    else:
        cosang = np.dot(rel, hv) / (np.linalg.norm(rel) * np.linalg.norm(hv))
        angle = math.degrees(math.acos(max(-1.0, min(1.0, cosang))))
    return InterceptionTrace(
        t, op, sh, ov, sv, eps, D_h, phase, tc, float(np.linalg.norm(Sc - trajectory.pos[0])),
        angle <= frontal_tol_deg, angle, not ready, float(field_radius(Oc[2] - Sc[2], params)),
        clipped_steps, frontal_tol_deg, trajectory.name)
