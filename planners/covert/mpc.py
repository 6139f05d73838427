"""MPC controllers for covert observation (thesis ch. 3).

- :class:`MPCObserver`: receding-horizon min-max bearing control built on
  :mod:`formulations.covert` (IPOPT or OSQP-based SQP), falling back to the
  sliding-mode command when a solve fails.
- :class:`SafeguardedMPCObserver`: the same MPC, but at every replan the sliding-mode law
  is also rolled out under the same target prediction and the candidate with the lower
  predicted maximum bearing change over the horizon is executed; its approach to the
  sphere is bounded by an arrival deadline instead of a fixed schedule.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from droneplan.core.validation import check_in_range, check_int, check_nonneg, check_positive, require_set
from droneplan.planners.covert.sliding import (
    DONE,
    ON_SPHERE,
    RETREAT,
    TO_SPHERE,
    SlidingSettings,
    _PhasedController,
    rollout_sliding,
    sliding_steering,
    turn_command,
)
from droneplan.scenarios.covert import (
    CovertCommand,
    CovertObservation,
    CovertParams,
    CovertPhase,
    CovertScenario,
    bearing_changes,
    rotate_heading,
)
from droneplan.scenarios.covert.dynamics import cross3
from droneplan.solvers.registry import get_backend
from droneplan.solvers.result import SolveResult

if TYPE_CHECKING:  # formulations.covert is imported when a controller is built (it loads CasADi)
    from droneplan.formulations.covert import BearingMPC, MPCData, MPCPlan, MPCSettings, RecedingBearingMPC

__all__ = ["MPCObserverSettings", "MPCObserver", "SafeguardSettings", "SafeguardedMPCObserver"]


@dataclass(frozen=True)
class MPCObserverSettings:
    """Settings of the receding-horizon controller around the bearing MPC."""

    backend: str = "ipopt"
    """A registered "nlp" backend: "ipopt" (NLP solved by IPOPT every period) or "osqp"
    (SQP / real-time iteration with OSQP)."""
    progress: float = 0.7
    """Transit phases must close the distance to their goal (sphere, D_s) at progress * V_max
    on a schedule fixed when the phase starts (after 1 s to turn)."""
    window: int = 10
    """Number of past measurements in the constant-velocity fit of each target."""
    idle_speed: float = 0.5
    """If the warm-started plan's first speed is below this (m/s) while the sliding-mode law
    would fly, the MPC is re-solved from the sliding-mode rollout and the plan with the lower
    NLP objective is kept (escapes the v = 0 stationary point)."""

    def __post_init__(self) -> None:
        get_backend(self.backend, kind="nlp")  # ValueError naming the known NLP backends
        check_in_range("progress", self.progress, 0.0, 1.0, lo_open=True)
        check_int("window", self.window, min_value=2)
        check_nonneg("idle_speed", self.idle_speed)


class MPCObserver(_PhasedController):
    """Min-max bearing MPC (formulations.covert) in closed loop, with the sliding-mode phases.

    Each period: fit a constant-velocity model to the last ``window`` measured positions
    of each observable target, predict them over the horizon, solve the MPC warm-started
    from the previous plan shifted by one period (the first period: the sliding-mode
    rollout), apply the first command. A failed solve applies the sliding-mode command
    instead and is counted in ``fallbacks``. ``starts`` records, per solve, the start of the
    result that was kept ("sliding-rollout" or "shifted-plan"; "" when the solve failed).
    Within home_radius of D_s the drone flies straight home as in the sliding-mode Retreat.

    settings: SlidingSettings of the phase logic and the fallback law (default: SlidingSettings()).
    mpc: MPCSettings of the bearing MPC (default: MPCSettings()).
    observer: MPCObserverSettings of the receding-horizon loop (default: MPCObserverSettings()).
    """

    def __init__(
        self,
        settings: SlidingSettings | None = None,
        mpc: MPCSettings | None = None,
        observer: MPCObserverSettings | None = None,
    ):
        super().__init__(settings)
        from droneplan.formulations.covert import MPCSettings

        self.mpc_settings = mpc if mpc is not None else MPCSettings()
        self.observer = observer if observer is not None else MPCObserverSettings()
        self._solver: RecedingBearingMPC | None = None
        self._key: tuple[CovertParams, int] | None = None
        self.statuses: list[str] = []
        self.predicted_beta: list[float] = []

    def reset(self, scenario: CovertScenario, *, seed: Any = None) -> None:
        from droneplan.formulations.covert import RecedingBearingMPC, build_bearing_mpc

        super().reset(scenario, seed=seed)
        key = (scenario.params, scenario.n_targets)
        if self._solver is None or self._key != key:
            model = build_bearing_mpc(scenario.params, scenario.n_targets, self.mpc_settings)
            self._solver = RecedingBearingMPC(model, backend=self.observer.backend)
            self._key = key
        self._hist_t: list[float] = []
        self._hist_A: list[NDArray[np.float64]] = []
        self._prev: SolveResult | None = None
        self._prev_phase: CovertPhase | None = None
        self._phase_start: tuple[float, float] = (0.0, 0.0)
        self.statuses = []
        self.starts: list[str] = []
        self.predicted_beta = []
        self.restarts = 0
        # between replans: (turn axis, or None when the sliding-mode law flies this interval;
        # turn rate (rad/s); periods left; speed (m/s))
        self._hold: tuple[NDArray[np.float64] | None, float, int, float] | None = None

    # -- target prediction
    def _fit(
        self, obs: CovertObservation
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.bool_]]:
        """Record this measurement; constant-velocity fit (position (n,3) m, velocity (n,3) m/s,
        fitted (n,) bool) of each target over the last ``window`` measurements, at time obs.t."""
        A_meas = obs.drone + obs.rel  # NaN rows for unobservable targets
        self._hist_t.append(obs.t)
        self._hist_A.append(A_meas)
        W_ = self.observer.window
        self._hist_t, self._hist_A = self._hist_t[-W_:], self._hist_A[-W_:]
        T = np.asarray(self._hist_t)
        H = np.asarray(self._hist_A)  # (w, n, 3)
        n = A_meas.shape[0]
        pos = np.tile(self.params.F_arr, (n, 1)).astype(float)
        vel = np.zeros((n, 3))
        fitted = np.zeros(n, bool)
        for j in range(n):
            ok = ~np.isnan(H[:, j, 0])
            if not ok[-1]:
                continue
            fitted[j] = True
            tj, Aj = T[ok] - obs.t, H[ok, j]
            if tj.size >= 2:
                X = np.column_stack([np.ones_like(tj), tj])
                coef, *_ = np.linalg.lstsq(X, Aj, rcond=None)
                pos[j], vel[j] = coef[0], coef[1]
                speed = np.linalg.norm(vel[j])
                if speed > self.params.V_T * 1.5:  # noisy fit: cap at a plausible speed
                    vel[j] = vel[j] * (self.params.V_T * 1.5 / speed)
            else:
                pos[j] = Aj[-1]
        self._fitted: tuple[NDArray[np.float64], NDArray[np.float64]] = (pos, vel)
        return pos, vel, fitted

    def _predict(self, obs: CovertObservation, times: NDArray[np.float64]) -> NDArray[np.float64]:
        """(len(times), n, 3) predicted positions at obs.t + times (F for targets not seen now)."""
        pos, vel, _ = self._fit(obs)
        return pos[None] + times[:, None, None] * vel[None]

    # -- phase constraints
    def _phase_bounds(
        self, obs: CovertObservation, node_t: NDArray[np.float64]
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        p = self.params
        N = node_t.size
        d0 = float(np.linalg.norm(p.F_arr - obs.drone))
        s0 = float(np.linalg.norm(p.D_s_arr - obs.drone))
        if self.phase != self._prev_phase:
            self._phase_start = (obs.t, d0 if self.phase == TO_SPHERE else s0)
            self._prev_phase = self.phase
        t_start, dist_start = self._phase_start
        rate = self.observer.progress * p.V_max
        sched = dist_start - rate * np.maximum(0.0, obs.t + node_t - t_start - 1.0)
        # behind the schedule: close the distance at the scheduled rate from now on
        catch_up = (d0 if self.phase == TO_SPHERE else s0) - rate * node_t
        inf = np.full(N, np.inf)
        if self.phase == TO_SPHERE:
            hi = np.maximum(p.L_u, np.maximum(sched, catch_up))
            return np.full(N, p.L_u), hi, inf
        if self.phase == ON_SPHERE:
            return np.full(N, p.L_u), np.full(N, p.L_u), inf
        home = np.maximum(self.settings.home_radius * 0.5, np.maximum(sched, catch_up))
        return np.zeros(N), inf, home

    def _shifted_guess(self, model: BearingMPC, data: MPCData) -> NDArray[np.float64]:
        from droneplan.formulations.covert import rollout_guess

        prev = self._prev
        N = model.settings.horizon
        times = np.concatenate([[0.0], np.cumsum(model.durations)])
        if prev is None or not prev.has_solution:
            # first step (or after a failure): roll out the sliding-mode law on the predictions
            u, v = self._sliding_rollout(model, data, times)
            return rollout_guess(model, data, u, v)
        plan = prev.x
        tq = times[:-1] + model.durations[0]  # command times in the old plan's clock
        idx = np.clip(np.searchsorted(plan.times, tq, side="right") - 1, 0, N - 1)
        return rollout_guess(model, data, plan.u[idx], plan.v[idx])

    def _sliding_rollout(
        self, model: BearingMPC, data: MPCData, times: NDArray[np.float64] | None
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        from droneplan.scenarios.covert import rotate_heading

        p = self.params
        D, h = np.asarray(data.D0, float), np.asarray(data.h0, float)
        us, vs = [], []
        mask = np.asarray(data.mask, bool)
        for k, dt in enumerate(model.durations):
            A = np.asarray(data.targets[max(k - 1, 0)])[mask]
            b = sliding_steering(self.phase, D, A, p, self.settings)
            u, v = turn_command(h, b, p, self.settings, float(dt), throttle=self.phase == ON_SPHERE)
            us.append(u)
            vs.append(v)
            h_new, integral = rotate_heading(h, u, float(dt))
            D, h = D + v * integral, h_new
        return np.array(us), np.array(vs)

    def command(self, obs: CovertObservation) -> CovertCommand:  # noqa: C901, PLR0915
        """u (3,) (rad/s) and v (m/s) for this control period."""
        from droneplan.formulations.covert import MPCData

        phase_before = self.phase
        self._update_phase_mpc(obs)
        p = self.params
        solver = require_set(self._solver, "reset() builds the solver before the first step")
        model = solver.model
        node_t = np.cumsum(model.durations)
        pred = self._predict(obs, node_t)
        if self.phase == DONE:
            return CovertCommand(np.zeros(3), 0.0)
        if self._hold is not None and self._hold[2] > 0 and self.phase == phase_before:
            # between solves: keep turning at the planned rate about the planned axis
            # (axis None: the safeguard chose the sliding-mode law for this replan interval)
            axis, rate, left, v_hold = self._hold
            self._hold = (axis, rate, left - 1, v_hold)
            if axis is None:
                return self.sliding_command(obs)
            return CovertCommand(rate * cross3(axis, obs.heading), v_hold)
        self._hold = None
        home = self.phase == RETREAT and np.linalg.norm(p.D_s_arr - obs.drone) <= self.settings.home_radius
        if home or not obs.observable.any():
            self._prev = None
            return self.sliding_command(obs)
        lo, hi, home_hi = self._phase_bounds(obs, node_t)
        tangent = np.zeros(node_t.size, bool)
        if self.phase == ON_SPHERE:
            tangent[1:] = True
        data = MPCData(
            D0=obs.drone,
            h0=obs.heading,
            targets=pred,
            mask=obs.observable.copy(),
            sphere_lo=lo,
            sphere_hi=hi,
            home_hi=home_hi,
            tangent=tangent,
        )
        x0 = self._shifted_guess(model, data)
        label = "shifted-plan" if self._prev is not None and self._prev.has_solution else "sliding-rollout"
        res = solver.solve(data, x0=x0, warm=self._prev, start=label)
        elapsed = res.solve_time
        idle = not res.has_solution or abs(res.x.v[0]) < self.observer.idle_speed
        if solver.local_optimum and self._prev is not None and idle:
            # the plan does not move now: v = 0 with a heading orthogonal to the descent direction
            # is a stationary point of the bilinear dynamics, and a min-max objective dominated by
            # a later node does not push the first move. If the sliding-mode law would move,
            # restart from its rollout and keep the plan with the lower NLP objective.
            u_s, v_s = self._sliding_rollout(model, data, None)
            if abs(v_s[0]) >= self.observer.idle_speed:
                from droneplan.formulations.covert import rollout_guess

                res2 = solver.solve(data, x0=rollout_guess(model, data, u_s, v_s), start="sliding-rollout")
                elapsed += res2.solve_time
                if res2.has_solution and (not res.has_solution or res2.info["f"] < res.info["f"] - 1e-12):
                    res = res2
                self.restarts += 1
        res = replace(res, solve_time=elapsed)
        self.solve_times.append(res.solve_time)
        self.statuses.append(res.status.value)
        self.starts.append(str(res.info.get("start", "")) if res.has_solution else "")
        if not res.has_solution:
            self.fallbacks += 1
            self._prev = None
            return self.sliding_command(obs)  # and re-solve at the next period
        self._prev = res
        self.predicted_beta.append(require_set(res.objective, "a plan with a solution has an objective"))
        if self._prefer_sliding(obs, res, model):
            self._hold = (None, 0.0, model.settings.replan_every - 1, 0.0)
            return self.sliding_command(obs)
        plan = res.x
        u = np.asarray(plan.u[0], float)
        u = u - np.dot(u, obs.heading) * obs.heading
        nu = float(np.linalg.norm(u))
        if nu > p.U_max:
            u = u * (p.U_max / nu)
        v = float(np.clip(plan.v[0], -p.V_max, p.V_max))
        nu = float(np.linalg.norm(u))
        axis = cross3(obs.heading, u / nu) if nu > 1e-12 else np.zeros(3)
        self._hold = (axis, nu, model.settings.replan_every - 1, v)
        return CovertCommand(u, v)

    def _prefer_sliding(self, obs: CovertObservation, res: SolveResult, model: BearingMPC) -> bool:
        """Whether to fly the sliding-mode law instead of the solved plan (never, here)."""
        return False

    def _update_phase_mpc(self, obs: CovertObservation) -> None:
        """As the sliding mode, but the return flight is planned at progress * V_max."""
        self._update_phase(obs, return_speed=self.observer.progress * self.params.V_max, extra_margin=1.0)


# --------------------------------------------------------------------------- safeguarded MPC
@dataclass(frozen=True)
class SafeguardSettings:
    """Settings of :class:`SafeguardedMPCObserver` (on top of MPCObserverSettings)."""

    arrival_tolerance: float | None = 2.0
    """The approach must reach the sphere by the arrival deadline (s): the earliest, over the
    replans t of the approach so far, of t + (arrival time of the sliding-mode law rolled out
    from the current state on the current target prediction) + arrival_tolerance. None: keep
    MPCObserver's approach schedule (progress * V_max)."""
    score_horizon: float | None = None
    """Length (s) of the window over which both candidates are scored, from now (rounded to
    control periods; None: the whole MPC horizon). The constant-velocity prediction errs most at
    the end of the horizon, where the min-max is usually attained."""
    margin: float = math.radians(0.2)
    """The MPC plan is executed only if its score is at least this much lower than the sliding
    rollout's (rad): the sliding-mode law is a feedback law, re-evaluated every period on fresh
    measurements, whereas the plan is replayed open loop until the next replan. 0.2 deg: with 0,
    the closed loop was worse than the sliding mode on thesis case 2 (13.50 vs 13.35 deg) and on
    2 of 8 random groups (by up to 0.09 deg); with 0.2 deg on 2 of those 8 by at most 0.011 deg
    (random_case(2 + s % 5, s), s = 0..7), with the same mean gain."""
    envelope_speed: float = 0.7
    """Before the deadline, the planned distance to the sphere must stay below
    envelope_speed * V_max * (deadline - t) (dimensionless fraction of V_max): the drone can still
    arrive in time at that radial speed."""

    def __post_init__(self) -> None:
        if self.arrival_tolerance is not None:
            check_nonneg("arrival_tolerance", self.arrival_tolerance)
        if self.score_horizon is not None:
            check_positive("score_horizon", self.score_horizon)
        check_nonneg("margin", self.margin)
        check_in_range("envelope_speed", self.envelope_speed, 0.0, 1.0, lo_open=True)


class SafeguardedMPCObserver(MPCObserver):
    """MPCObserver that never executes a plan predicted to be worse than the sliding-mode law.

    At each replan the MPC is solved as in :class:`MPCObserver`; the sliding-mode law is also
    rolled out (:func:`planners.covert.sliding.rollout_sliding`) from the same state on the same
    constant-velocity target prediction, and both candidates are scored by the same metric: the
    predicted max over the observable targets and over every control instant of the horizon of
    the bearing change (3.6), the MPC plan's commands being replayed exactly as the controller
    applies them (first command, then the planned constant-rate turns). The MPC plan is executed
    for the replan interval only if its score is <= the sliding rollout's; otherwise the sliding-
    mode law flies that interval (always available: it needs no solve). The guarantee is per
    replan and on the prediction; the closed loops can still differ (prediction errors, and a
    choice that is best over one horizon is not best over the whole period).

    The approach to the sphere is part of the min-max (the to-sphere nodes carry the bearing
    objective); with ``safeguard.arrival_tolerance`` set, the fixed progress schedule is
    replaced by an arrival deadline (see :class:`SafeguardSettings`): the planned distance to
    the sphere must let the drone arrive by the deadline at envelope_speed * V_max, and after
    the deadline a drone still approaching flies the sliding-mode law (which approaches at up
    to V_max). ``arrival_deadline`` holds the deadline (s); ``choices`` lists the candidate
    executed at each replan ("mpc" / "sliding"); ``predicted_scores`` the (mpc, sliding) scores
    (rad).

    settings, mpc, observer: as for MPCObserver.
    safeguard: SafeguardSettings (default: SafeguardSettings()).
    """

    def __init__(
        self,
        settings: SlidingSettings | None = None,
        mpc: MPCSettings | None = None,
        observer: MPCObserverSettings | None = None,
        safeguard: SafeguardSettings | None = None,
    ):
        super().__init__(settings, mpc, observer)
        self.safeguard = safeguard if safeguard is not None else SafeguardSettings()
        if not isinstance(self.safeguard, SafeguardSettings):
            raise TypeError("safeguard must be a SafeguardSettings")

    def reset(self, scenario: CovertScenario, *, seed: Any = None) -> None:
        super().reset(scenario, seed=seed)
        self.arrival_deadline: float | None = None
        self.choices: list[str] = []
        self.predicted_scores: list[tuple[float, float]] = []
        self.late_sliding = 0

    # -- the common metric
    def _fine_targets(self, steps: int, mask: NDArray[np.bool_]) -> NDArray[np.float64]:
        pos, vel = self._fitted
        t = np.arange(steps + 1) * self.params.dt
        return (pos[None] + t[:, None, None] * vel[None])[:, mask]

    def _score(self, D: NDArray[np.float64], A: NDArray[np.float64]) -> float:
        """max over instants 1..K and targets of beta (rad) for positions D (K+1,3), targets A (K+1,k,3)."""
        return float(np.max(bearing_changes(D[1:], A[1:], self.params.R)))

    def _replay_plan(self, obs: CovertObservation, plan: MPCPlan, model: BearingMPC) -> NDArray[np.float64]:
        """Positions (K+1, 3) at the control instants when the controller applies ``plan``."""
        p = self.params
        D, h = obs.drone.copy(), obs.heading.copy()
        out = [D.copy()]
        for k, dur in enumerate(model.durations):
            u = np.asarray(plan.u[k], float)
            u = u - np.dot(u, h) * h
            nu = float(np.linalg.norm(u))
            if nu > p.U_max:
                u, nu = u * (p.U_max / nu), p.U_max
            axis = cross3(h, u / nu) if nu > 1e-12 else np.zeros(3)
            v = float(np.clip(plan.v[k], -p.V_max, p.V_max))
            for _ in range(round(dur / p.dt)):
                h_new, integral = rotate_heading(h, nu * cross3(axis, h), p.dt)
                D, h = D + v * integral, h_new
                out.append(D.copy())
        return np.asarray(out)

    def _prefer_sliding(self, obs: CovertObservation, res: SolveResult, model: BearingMPC) -> bool:
        t0 = time.perf_counter()
        try:
            return self._choose(obs, res, model)
        finally:  # the scoring is part of this replan's computing time
            self.solve_times[-1] += time.perf_counter() - t0

    def _choose(self, obs: CovertObservation, res: SolveResult, model: BearingMPC) -> bool:
        mask = obs.observable
        D_mpc = self._replay_plan(obs, res.x, model)
        K = D_mpc.shape[0] - 1
        A = self._fine_targets(K, mask)
        D_sl, _, _ = rollout_sliding(self.phase, obs.drone, obs.heading, A[:K], self.params, self.settings)
        sh = self.safeguard.score_horizon
        W_ = K if sh is None else max(1, min(K, round(sh / self.params.dt)))
        s_mpc, s_sl = self._score(D_mpc[: W_ + 1], A[: W_ + 1]), self._score(D_sl[: W_ + 1], A[: W_ + 1])
        if self.phase == TO_SPHERE and self.arrival_deadline is not None:
            # a plan that would not arrive by the deadline is not admissible (its score would
            # profit from staying away); the sliding law approaches at up to V_max
            d_end = float(np.linalg.norm(self.params.F_arr - D_mpc[-1])) - self.params.L_u
            room = (
                self.safeguard.envelope_speed
                * self.params.V_max
                * max(0.0, self.arrival_deadline - obs.t - K * self.params.dt)
            )
            if d_end > room + 1.0:
                s_mpc = math.inf
        self.predicted_scores.append((s_mpc, s_sl))
        choice = "mpc" if s_mpc <= s_sl - self.safeguard.margin else "sliding"
        self.choices.append(choice)
        return choice == "sliding"

    # -- the approach: deadline instead of a schedule
    def _predicted_sliding_arrival(self, obs: CovertObservation) -> float:
        """Time (s) the sliding-mode law needs to reach the sphere on the current prediction
        (rolled out for at most 3 straight-flight times + 10 s)."""
        p = self.params
        gap = max(0.0, float(np.linalg.norm(p.F_arr - obs.drone)) - p.L_u)
        steps = round((3.0 * gap / p.V_max + 10.0) / p.dt)
        A = self._fine_targets(steps, obs.observable)
        _, _, phases = rollout_sliding(TO_SPHERE, obs.drone, obs.heading, A[:steps], p, self.settings)
        on = [k for k, ph in enumerate(phases) if ph != TO_SPHERE]
        return (on[0] if on else steps) * p.dt

    def _phase_bounds(
        self, obs: CovertObservation, node_t: NDArray[np.float64]
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        lo, hi, home = super()._phase_bounds(obs, node_t)
        tol = self.safeguard.arrival_tolerance
        if self.phase != TO_SPHERE or tol is None:
            return lo, hi, home
        p = self.params
        # the deadline only moves earlier: at each replan, the sliding-mode law's predicted arrival
        # from the current state (on the latest prediction) + tol, if that is earlier
        d_now = obs.t + self._predicted_sliding_arrival(obs) + tol
        if self.arrival_deadline is None or d_now < self.arrival_deadline:
            self.arrival_deadline = d_now
        rate = self.safeguard.envelope_speed * p.V_max
        d0 = float(np.linalg.norm(p.F_arr - obs.drone))
        envelope = p.L_u + rate * np.maximum(0.0, self.arrival_deadline - obs.t - node_t)
        catch_up = d0 - rate * node_t  # behind the envelope: close in at its rate from now on
        return lo, np.maximum(p.L_u, np.maximum(envelope, catch_up)), home

    def command(self, obs: CovertObservation) -> CovertCommand:
        """u (3,) (rad/s) and v (m/s) for this control period."""
        if (
            self.phase == TO_SPHERE
            and self.arrival_deadline is not None
            and obs.t > self.arrival_deadline
            and float(np.linalg.norm(self.params.F_arr - obs.drone))
            > self.params.L_u + self.settings.arrival_tol
        ):
            # past the deadline and still approaching: fly the sliding-mode law (keep the history)
            self._update_phase_mpc(obs)
            self._fit(obs)
            self._hold = None
            self.late_sliding += 1
            return self.sliding_command(obs)
        return super().command(obs)
