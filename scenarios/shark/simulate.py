"""Closed-loop simulation of one operator intercepting one shark on a prescribed path (eq. 5.4 at Ts)."""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass, field
from typing import Any, NamedTuple, Protocol

import numpy as np
from numpy.typing import NDArray

from droneplan.core.deprecation import deprecated_names
from droneplan.core.validation import (
    MAX_COORDINATE,
    check_array,
    check_in_range,
    check_int,
    check_methods,
)
from droneplan.scenarios.loop import Frame, LoopTrace, controller_counters
from droneplan.scenarios.shark.params import THESIS_TABLE_5_1, SharkParams, field_radius, inside_field
from droneplan.scenarios.shark.trajectories import SharkTrajectory

__all__ = [
    "SharkPhase",
    "InterceptionScenario",
    "SharkObservation",
    "SharkCommand",
    "SharkFrame",
    "InterceptionController",
    "InterceptionTrace",
    "simulate",
    "operator_start",
    "clip_velocity",
    "operator_step",
    "OperatorStep",
    "frontal_angle",
    "FRONTAL_TOL_DEG",
    "DEFAULT_BEARING_DEG",
]

DEFAULT_BEARING_DEG = -105.0
"""Default operator start bearing (deg) from the shark's initial heading: behind-right.

The thesis does not state where the operator starts (only Di = 13 m); -105 deg puts the
virtual-shark interception distance on path a near Table 5.2's 29.70 m.
"""

FRONTAL_TOL_DEG = 10.0
"""Tolerance (deg) on the angle between the shark's horizontal heading and the shark->operator direction."""


class SharkPhase(enum.IntEnum):
    """Phases of an interception controller (thesis §5.3.2; values are the thesis's step numbers)."""

    PURSUIT = 0
    """No phases: classical pursuit (eq. 5.5) aims at the shark throughout."""
    APPROACH = 1
    """Step 1: approach the first virtual shark S1 (eq. 5.14), or follow the OCP plan."""
    CROSS = 2
    """Step 2: cross in front of the shark to the second virtual shark S2 (eqs. 5.16-5.18)."""
    HOLD = 3
    """Step 3: at the interception point, slow down and wait for the shark to touch the field."""


@dataclass(frozen=True)
class InterceptionScenario:
    """One interception run's set-up: the shark's path, Table 5.1 parameters and the operator's start."""

    trajectory: SharkTrajectory
    """The shark's path, sampled at ``params.Ts``."""
    params: SharkParams = THESIS_TABLE_5_1
    """Problem parameters (Table 5.1)."""
    operator0: Any = None
    """Operator start (3,) (m); None: :func:`operator_start` at ``bearing_deg``."""
    bearing_deg: float = DEFAULT_BEARING_DEG
    """Start bearing (deg) from the shark's initial heading when ``operator0`` is None."""

    def __post_init__(self) -> None:
        if not isinstance(self.trajectory, SharkTrajectory):
            raise TypeError(f"trajectory must be a SharkTrajectory, got {type(self.trajectory).__name__}")
        if not isinstance(self.params, SharkParams):
            raise TypeError(f"params must be SharkParams, got {type(self.params).__name__}")
        if self.trajectory.dt != self.params.Ts and not math.isclose(
            self.trajectory.dt, self.params.Ts, rel_tol=1e-9
        ):
            raise ValueError(f"trajectory dt={self.trajectory.dt} must equal Ts={self.params.Ts}")
        if self.operator0 is not None:
            O = check_array("operator0", self.operator0, shape=(3,))
            # the simulator keeps the altitude in [lmin, le]; a start outside would be recorded
            # as a jump at an impossible speed
            check_in_range("operator0[2] (altitude)", O[2], self.params.lmin, self.params.le)
            object.__setattr__(self, "operator0", O)
        check_in_range("bearing_deg", self.bearing_deg, -MAX_COORDINATE, MAX_COORDINATE)

    @property
    def operator(self) -> NDArray[np.float64]:
        """The operator's start position (3,) (m)."""
        if self.operator0 is None:
            return operator_start(self.trajectory, self.params, bearing_deg=self.bearing_deg)
        return np.array(self.operator0, dtype=float)


@dataclass(frozen=True)
class SharkObservation:
    """What the operator's controller knows at one control instant (the argument of ``command``)."""

    t: float
    """Time (s)."""
    operator: NDArray[np.float64]
    """(3,) operator position O (m)."""
    shark_pos: NDArray[np.float64]
    """(3,) shark snout position S (m)."""
    shark_vel: NDArray[np.float64]
    """(3,) shark velocity (m/s)."""


class SharkCommand(NamedTuple):
    """An operator command for the next Ts."""

    velocity: NDArray[np.float64]
    """(3,) operator velocity (m/s); the simulator clips it to |v_xy| <= VoMxy, |v_z| <= VoMz."""
    at_interception: bool = True
    """The controller has reached its interception point, so a field contact during this step is
    the one it aims for (a contact while False counts as ``touched_early``)."""


class InterceptionController(Protocol):
    """A shark-interception controller (the closed-loop contract of :mod:`droneplan.scenarios.loop`).

    ``reset(scenario, *, seed=None)`` before a run (``scenario`` an :class:`InterceptionScenario`);
    ``command(SharkObservation) -> SharkCommand`` every Ts; ``phase`` a :class:`SharkPhase`;
    optional ``fallbacks``, ``statuses``, ``solve_times`` are counted in the trace.
    """

    phase: SharkPhase

    def reset(self, scenario: InterceptionScenario, *, seed: Any = None) -> None: ...

    def command(self, obs: SharkObservation) -> SharkCommand: ...


@dataclass(frozen=True, kw_only=True)
class SharkFrame(Frame):
    """The state of an interception run at one instant."""

    operator: NDArray[np.float64]
    """(3,) operator position (m)."""
    shark: NDArray[np.float64]
    """(3,) shark position (m)."""
    shark_vel: NDArray[np.float64]
    """(3,) shark velocity (m/s)."""
    phase: SharkPhase
    """Controller phase."""


@dataclass(kw_only=True)
class InterceptionTrace(LoopTrace):
    """Time series and outcome of one interception run.

    t (K,) s; operator, shark (K,3) m; operator_vel, shark_vel (K,3) m/s;
    eps (K,) field radius on the shark's plane eps(z_o - z_s) (m); D_h (K,) horizontal
    operator-shark distance (m); phase (K,) :class:`SharkPhase` (object array).
    intercept_time: first field contact (s) or None; interception_distance: |S(contact) - S(0)|
    (m, Table 5.2's metric) or None; frontal: the shark's horizontal heading points at the
    operator within ``frontal_tol_deg`` at first contact; frontal_angle (deg);
    touched_early: first contact came before the controller reached its interception point;
    contact_eps: eps on the shark's plane at contact (m); clipped_steps: commands the
    simulator had to clip to the speed limits; ``final`` the last recorded instant (the step
    that ended with the contact); fallbacks / status_counts: the controller's solver fallbacks
    and solve statuses.
    """

    operator: NDArray[np.float64]
    shark: NDArray[np.float64]
    operator_vel: NDArray[np.float64]
    shark_vel: NDArray[np.float64]
    eps: NDArray[np.float64]
    D_h: NDArray[np.float64]
    phase: NDArray[np.object_]
    intercept_time: float | None
    interception_distance: float | None
    frontal: bool
    frontal_angle: float | None
    touched_early: bool
    contact_eps: float | None
    clipped_steps: int
    frontal_tol_deg: float = FRONTAL_TOL_DEG
    name: str = ""
    """The shark path's label (SharkTrajectory.name)."""
    info: dict = field(default_factory=dict)
    """Extra per-run data from the controller and simulator."""

    solve_times: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0))
    """Per-solve times reported by the controller (s)."""

    def frame(self, k: int) -> SharkFrame:
        """The state at recorded instant ``k`` (negative counts from the end)."""
        return SharkFrame(
            t=float(self.t[k]),
            operator=self.operator[k],
            shark=self.shark[k],
            shark_vel=self.shark_vel[k],
            phase=self.phase[k],
        )

    @property
    def frames(self) -> list[SharkFrame]:
        """Every recorded instant as a :class:`SharkFrame`."""
        return [self.frame(k) for k in range(len(self.t))]

    @property
    def intercepted(self) -> bool:
        """True when the field touched the shark within the simulated horizon."""
        return self.intercept_time is not None


def clip_velocity(v, params: SharkParams) -> tuple[NDArray[np.float64], bool]:
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


def operator_start(
    trajectory: SharkTrajectory,
    params: SharkParams = THESIS_TABLE_5_1,
    *,
    bearing_deg: float = DEFAULT_BEARING_DEG,
    altitude: float | None = None,
) -> NDArray[np.float64]:
    """Operator start: Di metres from the shark horizontally, at ``bearing_deg`` from its initial heading.

    bearing 0 = straight ahead, -90 = to the right of the shark (default DEFAULT_BEARING_DEG);
    altitude defaults to le.

    trajectory: the shark's SharkTrajectory (its first sample is used).
    params: problem parameters, SharkParams (default: THESIS_TABLE_5_1).
    """
    if not isinstance(trajectory, SharkTrajectory):
        raise TypeError(f"trajectory must be a SharkTrajectory, got {type(trajectory).__name__}")
    if not isinstance(params, SharkParams):
        raise TypeError(f"params must be SharkParams, got {type(params).__name__}")
    bearing_deg = check_in_range("bearing_deg", bearing_deg, -MAX_COORDINATE, MAX_COORDINATE)
    s0, v0 = trajectory.pos[0], trajectory.vel[0]
    psi = math.atan2(v0[1], v0[0]) + math.radians(bearing_deg)
    z = params.le if altitude is None else check_in_range("altitude", altitude, params.lmin, params.le)
    return np.array([s0[0] + params.Di * math.cos(psi), s0[1] + params.Di * math.sin(psi), z])


class OperatorStep(NamedTuple):
    """One step of Ts of the operator's dynamics (5.4), from :func:`operator_step`."""

    operator: NDArray[np.float64]
    """(3,) operator position at the end of the step (m)."""
    velocity: NDArray[np.float64]
    """(3,) velocity flown (m/s): the command clipped to the speed limits and the altitude band."""
    clipped: bool
    """The command exceeded the speed limits and was clipped."""
    contact: tuple[float, NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]] | None
    """The first field contact within the step: (time (s), shark position (3,) m, shark velocity
    (3,) m/s, operator position (3,) m); None without contact."""


def operator_step(
    operator: NDArray[np.float64],
    velocity,
    trajectory: SharkTrajectory,
    k: int,
    params: SharkParams,
    fractions: NDArray[np.float64],
) -> OperatorStep:
    """Fly the operator from sample ``k`` to ``k + 1`` of the shark's path with ``velocity`` (the
    step of :func:`simulate`): clip it to the speed limits, keep the altitude in [lmin, le], and
    check the field contact at the fractions of the step ``fractions`` (both move linearly).

    operator: (3,) position at t_k (m); velocity: (3,) command (m/s); trajectory: the shark's path;
    k: the sample index; params: the run's SharkParams; fractions: increasing, in (0, 1].
    """
    v, clipped = clip_velocity(velocity, params)
    On = operator + params.Ts * v
    On[2] = min(max(On[2], params.lmin), params.le)
    v = (On - operator) / params.Ts
    # contact check on the segment (both move linearly within the step)
    S, V = trajectory.pos[k], trajectory.vel[k]
    Sn = trajectory.pos[k + 1]
    Ss = S + fractions[:, None] * (Sn - S)
    Os = operator + fractions[:, None] * (On - operator)
    clear = inside_field(Ss, Os, params)
    contact = None
    if np.any(clear <= 0):
        j = int(np.argmax(clear <= 0))
        tc = float(trajectory.t[k] + fractions[j] * params.Ts)
        Vc = V + fractions[j] * (trajectory.vel[k + 1] - V)
        contact = (tc, Ss[j], Vc, Os[j])
    return OperatorStep(On, v, clipped, contact)


def frontal_angle(operator, shark, shark_vel) -> float:
    """Angle (deg) between the shark's horizontal heading and the shark-to-operator direction.

    operator, shark: (3,) positions (m); shark_vel: (3,) shark velocity (m/s). 0 when they
    coincide horizontally, 180 when the shark stands still.
    """
    rel = np.asarray(operator)[:2] - np.asarray(shark)[:2]
    hv = np.asarray(shark_vel)[:2]
    if np.linalg.norm(hv) < 1e-9 or np.linalg.norm(rel) < 1e-9:
        return 0.0 if np.linalg.norm(rel) < 1e-9 else 180.0
    cosang = np.dot(rel, hv) / (np.linalg.norm(rel) * np.linalg.norm(hv))
    return math.degrees(math.acos(max(-1.0, min(1.0, cosang))))


def simulate(
    scenario: InterceptionScenario | SharkTrajectory,
    controller: InterceptionController,
    params: SharkParams | None = None,
    *,
    seed: Any = None,
    operator0=None,
    bearing_deg: float | None = None,
    t_max: float | None = None,
    frontal_tol_deg: float = FRONTAL_TOL_DEG,
    substeps: int = 10,
) -> InterceptionTrace:
    """Run ``controller`` against the shark's path with the integrator dynamics (5.4) at Ts.

    scenario: an :class:`InterceptionScenario`, or a :class:`SharkTrajectory` with ``params``
        (default Table 5.1), ``operator0`` and ``bearing_deg`` given here (the older call).
    controller: an :class:`InterceptionController`.
    seed: passed to ``controller.reset`` and recorded (the simulation itself is deterministic).
    The operator starts at ``operator0`` (m) or at ``operator_start(trajectory, params,
    bearing_deg=...)``; commands are clipped to the speed limits and the altitude to
    [lmin, le]; field contact is checked on ``substeps`` points per step (linear motion of
    both within a step). The run stops at the first contact or at ``t_max`` (s; default the
    path's duration).

    frontal_tol_deg: tolerance (deg) on the shark's heading pointing at the operator at first
        contact, for ``frontal``.
    """
    if isinstance(scenario, InterceptionScenario):
        if params is not None or operator0 is not None or bearing_deg is not None:
            raise ValueError("params, operator0 and bearing_deg are already set by the InterceptionScenario")
    elif isinstance(scenario, SharkTrajectory):
        scenario = InterceptionScenario(
            scenario,
            THESIS_TABLE_5_1 if params is None else params,
            operator0,
            DEFAULT_BEARING_DEG if bearing_deg is None else bearing_deg,
        )
    else:
        raise TypeError(
            f"scenario must be an InterceptionScenario or a SharkTrajectory, got {type(scenario).__name__}"
        )
    check_methods("controller", controller, ("reset", "command"))
    trajectory, params = scenario.trajectory, scenario.params
    if t_max is not None:
        check_in_range("t_max", t_max, 0.0, lo_open=True)
    frontal_tol_deg = check_in_range(
        "frontal_tol_deg", frontal_tol_deg, 0.0, 180.0, lo_open=True, hi_open=True
    )
    substeps = check_int("substeps", substeps, min_value=1, max_value=10_000)
    O = scenario.operator
    if np.hypot(*(O[:2] - trajectory.pos[0, :2])) <= params.eps_o:
        raise ValueError(f"initial horizontal separation must exceed eps_o={params.eps_o} (Prop. 5.3.2)")
    n_max = len(trajectory.t) - 1 if t_max is None else min(len(trajectory.t) - 1, round(t_max / params.Ts))
    controller.reset(scenario, seed=seed)
    ops, ovs, phases = [O.copy()], [], []
    clipped_steps = 0
    contact = None
    fr = np.linspace(0.0, 1.0, substeps + 1)[1:]
    for k in range(n_max):
        S, V = trajectory.pos[k], trajectory.vel[k]
        cmd = controller.command(SharkObservation(float(trajectory.t[k]), O.copy(), S.copy(), V.copy()))
        # the command covers [t_k, t_k + Ts]: its flag tells whether a contact during this step is intended
        v, ready = (cmd.velocity, bool(cmd.at_interception)) if isinstance(cmd, SharkCommand) else (cmd, True)
        phases.append(SharkPhase(getattr(controller, "phase", SharkPhase.PURSUIT)))
        step = operator_step(O, v, trajectory, k, params, fr)
        clipped_steps += step.clipped
        ovs.append(step.velocity)
        O = step.operator
        ops.append(O.copy())
        if step.contact is not None:
            contact = (k + 1, *step.contact, ready)
            break
    K = len(ops)
    t = trajectory.t[:K]
    op = np.array(ops)
    ov = np.vstack([np.array(ovs), np.zeros((1, 3))]) if ovs else np.zeros((1, 3))
    sh = trajectory.pos[:K]
    sv = trajectory.vel[:K]
    eps = field_radius(op[:, 2] - sh[:, 2], params)
    D_h = np.hypot(*(op[:, :2] - sh[:, :2]).T)
    phase = np.empty(K, dtype=object)
    phase[:] = [
        *phases,
        phases[-1] if phases else SharkPhase(getattr(controller, "phase", SharkPhase.PURSUIT)),
    ]
    common = dict(
        t=t,
        final=SharkFrame(t=float(t[-1]), operator=op[-1], shark=sh[-1], shark_vel=sv[-1], phase=phase[-1]),
        seed=seed,
        **controller_counters(controller),
        operator=op,
        shark=sh,
        operator_vel=ov,
        shark_vel=sv,
        eps=eps,
        D_h=D_h,
        phase=phase,
        clipped_steps=clipped_steps,
        frontal_tol_deg=frontal_tol_deg,
        name=trajectory.name,
    )
    if contact is None:
        return InterceptionTrace(
            **common,
            intercept_time=None,
            interception_distance=None,
            frontal=False,
            frontal_angle=None,
            touched_early=False,
            contact_eps=None,
        )
    _, tc, Sc, Vc, Oc, ready = contact
    angle = frontal_angle(Oc, Sc, Vc)
    return InterceptionTrace(
        **common,
        intercept_time=tc,
        interception_distance=float(np.linalg.norm(Sc - trajectory.pos[0])),
        frontal=angle <= frontal_tol_deg,
        frontal_angle=angle,
        touched_early=not ready,
        contact_eps=float(field_radius(Oc[2] - Sc[2], params)),
    )


__getattr__ = deprecated_names(__name__, {"simulate_interception": "simulate"}, globals())
