"""Covert observation physics: bearing changes (3.6), the drone model (3.2)-(3.5), simulation."""

from __future__ import annotations

import enum
import math
import warnings
from dataclasses import dataclass, field
from typing import Any, NamedTuple, Protocol

import numpy as np
from numpy.typing import NDArray

from droneplan.core.deprecation import renamed_keywords
from droneplan.core.validation import (
    check_array,
    check_bool,
    check_methods,
    check_nonneg,
    check_positive,
    resolve_seed,
)
from droneplan.scenarios.covert.world import CovertParams, CovertScenario
from droneplan.scenarios.loop import Frame, LoopTrace, controller_counters

__all__ = [
    "CovertPhase",
    "bearing_changes",
    "nearest_on_line",
    "rotate_heading",
    "step_drone",
    "measure",
    "observe_targets",
    "CovertObservation",
    "CovertCommand",
    "Controller",
    "CovertFrame",
    "CovertTrace",
    "simulate",
]


class CovertPhase(enum.StrEnum):
    """Phases of a covert-observation mission (thesis §3.4 and Algorithm 1), in order.

    TAKE_OFF and LANDING appear only in a run simulated with ``simulate(..., vtol=True)``; the
    thesis's simulations leave the vertical take-off and landing out (§3.5) and so does the default.
    """

    TAKE_OFF = "take-off"
    """Vertical take-off from the VTOL position D_v on the ground straight up to D_s (§3.4)."""
    TO_SPHERE = "to-sphere"
    """Flying from D_s to the observation sphere (To-sphere law)."""
    ON_SPHERE = "on-sphere"
    """On the sphere |D - F| = L_u, observing (On-sphere law)."""
    RETREAT = "retreat"
    """Flying back to D_s (Retreat law, Algorithm 1 step 1)."""
    LANDING = "landing"
    """Vertical landing from D_s straight down to the ground (Algorithm 1 step 2)."""
    DONE = "done"
    """Back at D_s (on the ground at D_v with ``vtol=True``); the mission is over."""


# --------------------------------------------------------------------------- geometry
def cross3(a: NDArray[np.float64], b: NDArray[np.float64]) -> NDArray[np.float64]:
    """Cross product of (..., 3) arrays over the last axis (broadcast), without checks.

    The same values as ``np.cross(a, b)`` to the last bit (the same products and differences,
    component by component) at a fraction of its cost on single vectors, which the closed loops
    call thousands of times per run.
    """
    if a.ndim == 1 and b.ndim == 1:  # Python floats: the same IEEE products, no array temporaries
        x0, x1, x2 = a.tolist()
        y0, y1, y2 = b.tolist()
        return np.array([x1 * y2 - x2 * y1, x2 * y0 - x0 * y2, x0 * y1 - x1 * y0])
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    return np.stack([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0], axis=-1)


def bearing_changes(drone: Any, targets: Any, R: Any) -> NDArray[np.float64]:
    """Bearing changes beta_j (3.6) in radians, vectorised.

    drone: (..., 3) drone positions D (m); targets: (..., n, 3) target positions A_j (m),
    broadcast against drone[..., None, :]; R: (3,) reference point (m).
    beta_j is the angle at A_j between the directions to R and to D, i.e. the angle
    between a_j = A_j - D and a_j - r = A_j - R (computed with atan2, stable near 0 and pi).
    Raises ValueError when a target coincides with R or with the drone, or on non-finite input.
    """
    D = check_array("drone", drone)
    A = check_array("targets", targets)
    Rv = check_array("R", R, shape=(3,))
    if D.shape[-1:] != (3,) or A.shape[-1:] != (3,) or Rv.shape != (3,):
        raise ValueError(
            f"drone (...,3), targets (...,n,3), R (3,) expected; got {D.shape}, {A.shape}, {Rv.shape}"
        )
    if not (np.isfinite(D).all() and np.isfinite(A).all() and np.isfinite(Rv).all()):
        raise ValueError("drone, targets and R must be finite")
    a = A - D[..., None, :]
    c = A - Rv
    na = np.linalg.norm(a, axis=-1)
    nc = np.linalg.norm(c, axis=-1)
    if A.size and np.min(nc) < 1e-9:
        raise ValueError("a target coincides with the reference point R")
    if A.size and np.min(na) < 1e-9:
        raise ValueError("a target coincides with the drone")
    cross = np.linalg.norm(cross3(a, c), axis=-1)
    dot = np.sum(a * c, axis=-1)
    return np.arctan2(cross, dot)


def nearest_on_line(a: Any, r: Any) -> NDArray[np.float64]:
    """p_j of (3.11): vector from the drone to the nearest point of the line through A_j and R.

    a: (..., 3) vectors a_j = A_j - D; r: (3,) or (..., 3) vector r = R - D (m). Returns (..., 3) (m).
    """
    a = np.asarray(a, dtype=float)
    r = np.asarray(r, dtype=float)
    ra = np.sum(r * a, axis=-1, keepdims=True)
    aa = np.sum(a * a, axis=-1, keepdims=True)
    rr = np.sum(r * r, axis=-1, keepdims=True)
    den = rr + aa - 2.0 * ra
    if np.any(den < 1e-18):
        raise ValueError("a target coincides with the reference point R")
    return ((aa - ra) * r + (rr - ra) * a) / den


def rotate_heading(h: Any, u: Any, dt: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Exact zero-order-hold step of dh/dt = u, dD/dt = h over dt with u orthogonal to h.

    The heading rotates at the constant rate |u| (rad/s) in the plane of (h, u):
    h(dt) = cos(w dt) h + sin(w dt) u/w, and the returned integral
    int_0^dt h = sin(w dt)/w h + (1 - cos(w dt))/w^2 u (s), so D += v * integral.
    Returns (new heading with |h| = 1 up to rounding, integral). u must be orthogonal to h.
    """
    h = np.asarray(h, dtype=float)
    u = np.asarray(u, dtype=float)
    w = float(np.linalg.norm(u))
    th = w * dt
    if th < 1e-6:
        s_over = dt * (1.0 - th * th / 6.0)
        c_over = dt * dt * (0.5 - th * th / 24.0)
        cth = 1.0 - th * th / 2.0
        sth_w = s_over
    else:
        s_over = math.sin(th) / w
        c_over = (1.0 - math.cos(th)) / (w * w)
        cth = math.cos(th)
        sth_w = s_over
    h_new = cth * h + sth_w * u
    h_new = h_new / np.linalg.norm(h_new)
    return h_new, s_over * h + c_over * u


def step_drone(
    D: Any, h: Any, u: Any, v: float, dt: float, params: CovertParams
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], float]:
    """One plant step of (3.2)-(3.5): actuator limits, then the exact rotation of the heading.

    The command is made admissible first: u is projected on the plane orthogonal to h
    (3.5) and scaled to |u| <= U_max, v is clipped to [-V_max, V_max] (3.4).
    Returns (D_next, h_next, u_applied, v_applied).
    """
    h = np.asarray(h, dtype=float)
    u = np.asarray(u, dtype=float)
    if not (np.isfinite(u).all() and math.isfinite(v)):
        raise ValueError(f"command must be finite, got u={u}, v={v}")
    u = u - np.dot(u, h) * h
    nu = np.linalg.norm(u)
    if nu > params.U_max:
        u = u * (params.U_max / nu)
    v = float(np.clip(v, -params.V_max, params.V_max))
    h_new, integral = rotate_heading(h, u, dt)
    return np.asarray(D, float) + v * integral, h_new, u, v


def measure(true_rel: NDArray[np.float64], noise: float, rng: np.random.Generator) -> NDArray[np.float64]:
    """Noisy measurement of the vectors a_j: each component times (1 + noise * U(-1, 1)).

    noise: amplitude as a fraction of the true measurement (thesis: 0.02 to 0.10).
    """
    if noise == 0.0:
        return true_rel.copy()
    return true_rel * (1.0 + noise * rng.uniform(-1.0, 1.0, size=true_rel.shape))


def observe_targets(
    scenario: CovertScenario, t: float, drone: NDArray[np.float64], noise: float, rng: np.random.Generator
) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """What the drone measures at time ``t`` (s) from ``drone`` (3,) (m), as :func:`simulate` does:
    (the measured vectors a_j = A_j - D (n, 3) (m), NaN rows for the unobservable targets; the
    (n,) observable mask). noise: amplitude as a fraction of each component (:func:`measure`);
    rng: the run's generator for the noise (drawn from when noise > 0, observable or not)."""
    A = scenario.targets_at(t)
    obsmask = scenario.observable_at(t, drone)
    rel = measure(A - drone, noise, rng)
    rel[~obsmask] = np.nan
    return rel, obsmask


# --------------------------------------------------------------------------- simulation
@dataclass(frozen=True)
class CovertObservation:
    """What the drone knows at one control instant (the argument of ``Controller.command``)."""

    t: float
    """Time (s)."""
    drone: NDArray[np.float64]
    """Drone position D (3,) (m), from GPS."""
    heading: NDArray[np.float64]
    """Drone heading h (3,), unit."""
    rel: NDArray[np.float64]
    """Measured vectors a_j = A_j - D (n, 3) (m); rows of unobservable targets are NaN."""
    observable: NDArray[np.bool_]
    """(n,) bool: target j is observable (line of sight)."""

    @property
    def targets(self) -> NDArray[np.float64]:
        """Measured absolute positions of the observable targets (k, 3) (m)."""
        return self.drone + self.rel[self.observable]


class CovertCommand(NamedTuple):
    """A drone command for one control period (3.2)-(3.5); the simulator makes it admissible."""

    u: NDArray[np.float64]
    """(3,) heading rate dh/dt (rad/s), orthogonal to the heading."""
    v: float
    """Speed along the heading (m/s)."""


class Controller(Protocol):
    """A covert-observation controller (the closed-loop contract of :mod:`droneplan.scenarios.loop`)."""

    phase: CovertPhase
    """Phase after the last command."""
    finished: bool
    """True once the drone is back at D_s (the run then ends)."""

    def reset(self, scenario: CovertScenario, *, seed: Any = None) -> None: ...

    def command(self, obs: CovertObservation) -> CovertCommand: ...


@dataclass(frozen=True, kw_only=True)
class CovertFrame(Frame):
    """The state of a covert run at one instant."""

    drone: NDArray[np.float64]
    """(3,) drone position D (m)."""
    heading: NDArray[np.float64]
    """(3,) unit heading h."""
    targets: NDArray[np.float64]
    """(n, 3) true target positions (m)."""
    phase: CovertPhase
    """Controller phase."""


@dataclass(kw_only=True)
class CovertTrace(LoopTrace):
    """A closed-loop run. Arrays are sampled at the control instants t_k = k dt (``t``, s);
    ``final`` is the last recorded instant."""

    drone: NDArray[np.float64]
    """(T, 3) drone positions (m)."""
    heading: NDArray[np.float64]
    """(T, 3) headings (unit)."""
    targets: NDArray[np.float64]
    """(T, n, 3) true target positions (m)."""
    beta: NDArray[np.float64]
    """(T, n) true bearing changes (rad); NaN where the target is not observable."""
    beta_max: float
    """Maximum recorded beta_m over the run (rad); the thesis's headline metric (nan if no target)."""
    sphere_error: float
    """max | |D - F| - L_u | for t_a <= t <= t_f (m); nan if the sphere was never reached."""
    t_a: float | None
    """Arrival time on the observation sphere (s)."""
    t_f: float | None
    """Time the drone leaves the sphere (start of the retreat) (s)."""
    phase: NDArray[np.object_]
    """(T,) :class:`CovertPhase` of the controller after each command (object array)."""
    u: NDArray[np.float64]
    """(T, 3) commanded u as returned by the controller (NaN on the last row)."""
    v: NDArray[np.float64]
    """(T,) commanded v (m/s) (NaN on the last row); during take-off and landing, which the simulator
    flies itself (u = 0, heading held), the vertical speed (m/s, up positive)."""
    finished: bool
    """The controller reported that it was back at D_s."""
    solve_times: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0))
    """Per-step solver times reported by the controller (s)."""

    def frame(self, k: int) -> CovertFrame:
        """The state at recorded instant ``k`` (negative counts from the end)."""
        return CovertFrame(
            t=float(self.t[k]),
            drone=self.drone[k],
            heading=self.heading[k],
            targets=self.targets[k],
            phase=self.phase[k],
        )

    @property
    def frames(self) -> list[CovertFrame]:
        """Every recorded instant as a :class:`CovertFrame`."""
        return [self.frame(k) for k in range(len(self.t))]

    @property
    def beta_m(self) -> NDArray[np.float64]:
        """(T,) maximum bearing change over the observable targets (rad; NaN if none)."""
        out = np.full(self.beta.shape[0], np.nan)
        if self.beta.shape[1]:
            ok = ~np.all(np.isnan(self.beta), axis=1)
            out[ok] = np.nanmax(self.beta[ok], axis=1)
        return out

    @property
    def distance_to_F(self) -> NDArray[np.float64]:
        """(T,) |D - F| (m)."""
        return self.distance_to(self.F)

    def distance_to(self, point: Any) -> NDArray[np.float64]:
        """(T,) distance from the drone to a point (m)."""
        return np.linalg.norm(self.drone - np.asarray(point, float), axis=1)

    F: tuple[float, float, float] = (200.0, 200.0, 0.0)
    """Centre of the observation sphere of the run (m)."""
    L_u: float = 200.0
    """Radius of the observation sphere of the run (m)."""
    R: tuple[float, float, float] = (10.0, 10.0, 40.0)
    """Reference point of the run's camouflage constraint lines (m)."""


@dataclass
class _Record:
    """What the closed loop records at each instant: time (s), drone position (m) and heading,
    the command (u, v) applied from that instant on (NaN at the last) and the phase."""

    t: list[float] = field(default_factory=list)
    drone: list[NDArray[np.float64]] = field(default_factory=list)
    heading: list[NDArray[np.float64]] = field(default_factory=list)
    u: list[NDArray[np.float64]] = field(default_factory=list)
    v: list[float] = field(default_factory=list)
    phase: list[Any] = field(default_factory=list)

    def state(self, t: float, D: NDArray[np.float64], h: NDArray[np.float64]) -> None:
        self.t.append(t)
        self.drone.append(D.copy())
        self.heading.append(h.copy())

    def command(self, u: NDArray[np.float64], v: float, phase: Any) -> None:
        self.u.append(u)
        self.v.append(v)
        self.phase.append(phase)

    def last(self, phase: Any) -> None:
        """Close the record: no command from the last instant on."""
        self.command(np.full(3, np.nan), np.nan, phase)


def _start(
    scenario: CovertScenario, t_max: Any, initial_heading: Any, vtol: bool
) -> tuple[float, float, NDArray[np.float64], NDArray[np.float64]]:
    """Check the run's settings; returns (climb: height of D_s above the ground below it (m), 0
    without ``vtol``; t_stop (s); the start position (D_s, or D_v with ``vtol``); the unit heading)."""
    if not isinstance(scenario, CovertScenario):
        raise TypeError(f"scenario must be a CovertScenario, got {type(scenario).__name__}")
    p = scenario.params
    climb = 0.0
    if vtol:
        climb = float(p.D_s[2] - scenario.terrain.height(p.D_s[0], p.D_s[1]))
        if climb <= 0:
            raise ValueError(
                f"vtol=True needs D_s above the ground, but D_s is {-climb:.3f} m below the terrain there"
            )
    t_stop = p.duration + 60.0 + 2.0 * climb / p.V_max if t_max is None else check_positive("t_max", t_max)
    if t_stop / p.dt > 1e7:
        raise ValueError(f"t_max asks for {t_stop / p.dt:.3g} steps of dt = {p.dt} s, more than 1e7")
    D = p.D_s_arr.copy()
    if vtol:
        D[2] -= climb  # D_v, on the ground below D_s
    h = (
        p.F_arr - p.D_s_arr
        if initial_heading is None
        else check_array("initial_heading", initial_heading, shape=(3,))
    )
    if np.linalg.norm(h) == 0:
        raise ValueError("initial_heading must be a non-zero vector")
    return climb, t_stop, D, h / np.linalg.norm(h)


def _vertical_step(
    leg: CovertPhase, D: NDArray[np.float64], ground: float, p: CovertParams
) -> tuple[NDArray[np.float64], float]:
    """One step of a vertical leg at V_max: up to D_s (TAKE_OFF) or down to ``ground`` (LANDING).
    Returns the new position and the vertical speed (m/s) flown."""
    room = p.D_s[2] - D[2] if leg == CovertPhase.TAKE_OFF else D[2] - ground
    dz = min(p.V_max * p.dt, max(room, 0.0))
    dz = dz if leg == CovertPhase.TAKE_OFF else -dz
    return D + np.array([0.0, 0.0, dz]), dz / p.dt


def _warn_without_targets(scenario: CovertScenario) -> None:
    """A run without a target is allowed (the drone's dynamics alone), but never silently."""
    if not scenario.n_targets:
        warnings.warn(
            "the scenario has no target: the bearing change is undefined, so the trace's beta_max "
            "is NaN (this run shows the drone's dynamics only)",
            UserWarning,
            stacklevel=3,
        )


@renamed_keywords(max_time="t_max")
def simulate(
    scenario: CovertScenario,
    controller: Controller,
    *,
    noise: float = 0.0,
    seed: int | np.random.Generator | None = None,
    t_max: float | None = None,
    initial_heading: Any = None,
    vtol: bool = False,
) -> CovertTrace:
    """Run ``controller`` on ``scenario`` in closed loop from D_s until it reports it is back.

    controller: a :class:`Controller` (``reset(scenario, seed=...)``, ``command(CovertObservation)
        -> CovertCommand``, ``phase``, ``finished``; optional ``fallbacks``, ``statuses``, ``solve_times``).
    noise: measurement noise amplitude as a fraction of each measured component (>= 0).
    seed: seed for the noise (int, Generator or None: a seed is drawn; recorded in the trace).
    t_max: the horizon, a hard stop (s; formerly ``max_time``); default duration + 60 s (plus the
        take-off and landing with ``vtol``).
    initial_heading: initial h (default: from D_s towards F).
    vtol: fly the whole mission of the thesis (§3.4, Algorithm 1): a vertical take-off from the VTOL
        position D_v on the ground below D_s (terrain height at D_s's x, y) up to D_s, the controller's
        mission from D_s back to D_s, then a vertical landing straight down to the ground. The
        simulator flies both vertical legs at V_max (the thesis gives no speed) without calling the
        controller and records them as the phases TAKE_OFF and LANDING; the controller is reset
        before the take-off and first called on arrival at D_s. False (default): the drone starts
        and ends at D_s, as in the thesis's simulations (§3.5).
    Returns a :class:`CovertTrace` (beta is computed from the true positions).
    """
    check_methods("controller", controller, ("reset", "command"))
    noise = check_nonneg("noise", noise)
    vtol = check_bool("vtol", vtol)
    _, t_stop, D, h = _start(scenario, t_max, initial_heading, vtol)
    _warn_without_targets(scenario)  # after _start, which checks that it is a CovertScenario
    p = scenario.params
    rng, drawn = resolve_seed(seed)
    seed = seed if drawn is None else drawn  # record the seed drawn for seed=None
    controller.reset(scenario, seed=seed)
    steps = math.ceil(t_stop / p.dt - 1e-9)
    rec = _Record()
    finished = False
    leg = CovertPhase.TAKE_OFF if vtol else None  # the vertical leg being flown (None: the controller)
    ground = 0.0  # ground height below the drone when it lands (m)
    for k in range(steps + 1):
        t = k * p.dt
        rel, obsmask = observe_targets(scenario, t, D, noise, rng)
        rec.state(t, D, h)
        if k == steps:
            rec.last(controller.phase if leg is None else leg)
            break
        if leg is not None:  # a vertical leg: straight up to D_s or down to the ground at V_max
            D, vz = _vertical_step(leg, D, ground, p)
            rec.command(np.zeros(3), vz, leg)
            if leg == CovertPhase.TAKE_OFF and D[2] >= p.D_s[2] - 1e-9:
                D, leg = p.D_s_arr.copy(), None
            elif leg == CovertPhase.LANDING and D[2] <= ground + 1e-9:
                D[2] = ground
                finished = True
                rec.state((k + 1) * p.dt, D, h)
                rec.last(CovertPhase.DONE)
                break
            continue
        u, v = controller.command(CovertObservation(t, D.copy(), h.copy(), rel, obsmask))
        if vtol and controller.finished:  # home at D_s: land straight down (Algorithm 1 step 2)
            rec.command(np.zeros(3), 0.0, CovertPhase.LANDING)
            leg = CovertPhase.LANDING
            ground = float(scenario.terrain.height(D[0], D[1]))
            continue
        u = np.asarray(u, dtype=float)
        rec.command(u.copy(), float(v), controller.phase)
        D, h, _, _ = step_drone(D, h, u, float(v), p.dt, p)
        if controller.finished:
            finished = True
            rec.state((k + 1) * p.dt, D, h)  # the final state
            rec.last(CovertPhase.DONE)
            break
    return _trace(scenario, controller, rec, seed, finished)


def _trace(
    scenario: CovertScenario, controller: Controller, rec: _Record, seed: Any, finished: bool
) -> CovertTrace:
    """The :class:`CovertTrace` of a recorded run: bearing changes from the true positions, the
    phase times t_a and t_f, the largest distance from the sphere while on it."""
    p = scenario.params
    t_arr = np.asarray(rec.t)
    drone = np.asarray(rec.drone)
    targets = scenario.targets_at(t_arr)
    if scenario.n_targets:
        beta = bearing_changes(drone, targets, p.R)
        beta[~scenario.observable_at(t_arr, drone)] = np.nan
    else:
        beta = np.zeros((t_arr.size, 0))
    phase = np.empty(len(rec.phase), dtype=object)
    phase[:] = [CovertPhase(ph) for ph in rec.phase]
    on = np.nonzero(phase == CovertPhase.ON_SPHERE)[0]
    ret = np.nonzero((phase == CovertPhase.RETREAT) | (phase == CovertPhase.DONE))[0]
    t_a = float(t_arr[on[0]]) if on.size else None
    t_f = float(t_arr[ret[0]]) if ret.size and on.size else None
    if on.size:
        i1 = ret[0] if ret.size else len(t_arr) - 1
        dist = np.linalg.norm(drone[on[0] : i1 + 1] - p.F_arr, axis=1)
        sphere_error = float(np.max(np.abs(dist - p.L_u)))
    else:
        sphere_error = math.nan
    bm = beta[~np.isnan(beta)]
    final = CovertFrame(
        t=float(t_arr[-1]),
        drone=drone[-1],
        heading=np.asarray(rec.heading[-1]),
        targets=targets[-1],
        phase=phase[-1],
    )
    return CovertTrace(
        t=t_arr,
        final=final,
        seed=seed,
        **controller_counters(controller),
        drone=drone,
        heading=np.asarray(rec.heading),
        targets=targets,
        beta=beta,
        beta_max=float(bm.max()) if bm.size else math.nan,
        sphere_error=sphere_error,
        t_a=t_a,
        t_f=t_f,
        phase=phase,
        u=np.asarray(rec.u),
        v=np.asarray(rec.v),
        finished=finished,
        F=p.F,
        L_u=p.L_u,
        R=p.R,
    )
