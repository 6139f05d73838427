"""Solver-backed interception: virtual-shark warm starts for the OCP and the receding-horizon
OCPInterceptor."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
from numpy.typing import NDArray

from droneplan.core.validation import check_array, check_instance, check_positive, require_set
from droneplan.formulations.shark import InterceptionOCP, InterceptionPlan, solve_interception
from droneplan.planners.shark.pursuit import VirtualSharkInterceptor
from droneplan.scenarios.shark import (
    THESIS_TABLE_5_1,
    InterceptionScenario,
    SharkCommand,
    SharkObservation,
    SharkParams,
    SharkPhase,
    SharkTrajectory,
    clip_velocity,
    simulate,
)
from droneplan.solvers.result import SolveResult, Status

__all__ = ["virtual_shark_plan", "optimal_interception", "OCPInterceptor"]


def virtual_shark_plan(
    trajectory: SharkTrajectory, operator0, params: SharkParams = THESIS_TABLE_5_1, *, side: int | None = None
) -> tuple[InterceptionPlan | None, VirtualSharkInterceptor]:
    """Roll the virtual-shark interceptor out on a known path; its path up to the capture of S2 as a plan.

    Returns (plan or None if it never reached S2, the controller after the run; its
    ``capture_time`` is the virtual-shark interception time comparable with the OCP's T).

    trajectory: the shark's known SharkTrajectory.
    operator0: (3,) operator start (m).
    params: problem parameters, SharkParams (default: THESIS_TABLE_5_1).
    side: +1 (left of the shark's heading) or -1 (right) to force the side of the approach,
        None: the thesis rule (the operator's side).
    """
    check_instance("trajectory", trajectory, SharkTrajectory)
    check_instance("params", params, SharkParams)
    operator0 = check_array("operator0", operator0, shape=(3,))
    vs = VirtualSharkInterceptor(params, side=side)
    tr = simulate(InterceptionScenario(trajectory, params, operator0), vs)
    if vs.capture_time is None:
        return None, vs
    k = round(vs.capture_time / params.Ts)
    s = side if side is not None else 0
    return InterceptionPlan.from_samples(tr.t[: k + 1], tr.operator[: k + 1], s, "virtual-shark"), vs


def optimal_interception(
    trajectory: SharkTrajectory,
    operator0,
    params: SharkParams = THESIS_TABLE_5_1,
    *,
    N: int = 50,
    time_limit: float | None = None,
) -> SolveResult:
    """Offline optimum for a known path: the OCP warm-started from virtual-shark rollouts on both sides.

    Also tries the formulation's two crude starts; ``info["virtual_shark_T"]`` holds the thesis
    algorithm's capture time (s) with its own side rule, ``info["start_won"]`` whether a
    virtual-shark rollout or a crude start gave the best plan (``warm_started`` is True only
    for the former); ``bound`` is the proven lower bound on T.

    trajectory: the shark's known SharkTrajectory.
    operator0: (3,) operator start (m).
    params: problem parameters, SharkParams (default: THESIS_TABLE_5_1).
    N: number of control intervals (count).
    time_limit: wall-clock limit per IPOPT solve (s), None: none.
    """
    check_instance("trajectory", trajectory, SharkTrajectory)
    check_instance("params", params, SharkParams)
    operator0 = check_array("operator0", operator0, shape=(3,))
    starts = []
    _, ref = virtual_shark_plan(trajectory, operator0, params)
    for side in (1, -1):
        plan, _ = virtual_shark_plan(trajectory, operator0, params, side=side)
        if plan is not None:
            starts.append(plan)
    ocp = InterceptionOCP(params, N=N, path=trajectory)
    starts += ocp.default_guesses(operator0)
    res = solve_interception(trajectory, operator0, params, N=N, warm_starts=starts, time_limit=time_limit)
    return dataclasses.replace(res, info={**res.info, "virtual_shark_T": ref.capture_time})


class OCPInterceptor:
    """Receding-horizon interception: re-solve the OCP every Ts and apply the first control.

    params: problem parameters; N: OCP intervals; path: the shark's known path (None: predict
    it at constant velocity from each measurement — the online controller); margin: clearance
    margin (m); time_limit: IPOPT wall-clock limit per solve (s); max_iter: IPOPT iteration limit
    per solve; hold_timeout: s in the final hold without contact before replanning again.

    The first solve starts from the virtual-shark rollout (known path) or the formulation's
    crude starts on both sides (best kept); later solves start from the previous plan shifted
    by Ts, reusing its duals after a successful solve. ``solve_times`` (s), ``statuses`` and
    ``converged`` (True where IPOPT reached a local optimum; a solve is FEASIBLE either way,
    never OPTIMAL) record every solve. When no solve of a replan gives a plan, the operator flies at VoMxy
    towards the point one second ahead of the shark (a pursuit fallback) and ``fallbacks``
    counts that replan; the simulator copies both counts into the trace (``trace.fallbacks``,
    ``trace.status_counts``). Once the remaining time is below Ts the operator steps onto the
    terminal point and holds (``at_interception``, ``SharkPhase.HOLD``), as the thesis's step 3.
    """

    def __init__(
        self,
        params: SharkParams = THESIS_TABLE_5_1,
        *,
        N: int = 20,
        path: SharkTrajectory | None = None,
        margin: float = 0.05,
        time_limit: float | None = None,
        max_iter: int = 300,
        hold_timeout: float = 1.0,
    ):
        check_instance("params", params, SharkParams)
        check_positive("hold_timeout", hold_timeout)
        self.params, self.N, self.path, self.margin = params, N, path, margin
        self.time_limit = time_limit
        self.hold_timeout = hold_timeout
        self.ocp = InterceptionOCP(
            params, N=N, path=path, margin=margin, time_limit=time_limit, max_iter=max_iter
        )
        self._start()

    def reset(self, scenario: InterceptionScenario, *, seed=None) -> None:
        """Start a new run (``seed`` unused: the controller is deterministic)."""
        if scenario.params != self.params:
            raise ValueError("OCPInterceptor was built for other params than the scenario's")
        self._start()

    def _start(self) -> None:
        self.phase = SharkPhase.APPROACH
        self.at_interception = False
        self.fallbacks = 0
        self.capture_time: float | None = None
        self._last: SolveResult | None = None
        self._hold_since: float | None = None  # time the final hold began (s)
        self.solve_times: list[float] = []
        self.statuses: list[str] = []
        self.converged: list[bool] = []
        self.plans: list[InterceptionPlan] = []

    def _first_guesses(self, t, O, S, V):
        if self.path is not None:
            sub = SharkTrajectory(
                self.path.t[: len(self.path.t) - round(t / self.params.Ts)],
                self.path.pos[round(t / self.params.Ts) :],
                self.path.vel[round(t / self.params.Ts) :],
                self.path.name,
            )
            out = []
            for side in (1, -1):
                plan, _ = virtual_shark_plan(sub, O, self.params, side=side)
                if plan is not None:
                    out.append(plan)
            return out + self.ocp.default_guesses(O, t0=t)
        return self.ocp.default_guesses(O, shark_state=(S, V))

    def _solve(self, t, O, S, V) -> SolveResult | None:
        kw = dict(t0=t) if self.path is not None else dict(shark_state=(S, V))
        ok = (Status.OPTIMAL, Status.FEASIBLE)
        if self._last is not None and self._last.status in ok:
            prev = self._last.x
            Ts = self.params.Ts
            T = max(prev.T - Ts, Ts)
            tt = Ts + np.linspace(0.0, T, self.N + 1)
            pos = prev.position(tt)
            pos[0] = O
            guess = InterceptionPlan(tt - Ts, pos, np.diff(pos, axis=0) / (T / self.N), T, prev.side)
            res = self.ocp.solve(O, guess=guess, warm_start=self._last, **kw)
            self.solve_times.append(res.solve_time)
            self.statuses.append(res.status.name)
            self.converged.append(res.converged)
            if res.status in ok:
                return res
        best: SolveResult | None = None
        best_T = math.inf  # best.objective
        for g in self._first_guesses(t, O, S, V):
            r = self.ocp.solve(O, guess=g, **kw)
            self.solve_times.append(r.solve_time)
            self.statuses.append(r.status.name)
            self.converged.append(r.converged)
            if r.status in ok:
                t_int = require_set(r.objective, "a solved OCP reports its T")
                if best is None or t_int < best_T:
                    best, best_T = r, t_int
        return best

    def command(self, obs: SharkObservation) -> SharkCommand:
        """Velocity command (m/s) for the next Ts; ``at_interception`` once holding at the terminal point."""
        v = self._velocity(obs.t, obs.operator, obs.shark_pos, obs.shark_vel)
        return SharkCommand(v, self.at_interception)

    def _velocity(self, t: float, operator, shark_pos, shark_vel) -> NDArray[np.float64]:
        p = self.params
        O = np.asarray(operator, float)
        if self.phase == SharkPhase.HOLD:
            hold_since = require_set(self._hold_since, "the hold start is set on entering the hold")
            if t - hold_since <= self.hold_timeout + 1e-9:
                return np.zeros(3)
            self.phase, self._last, self.at_interception = SharkPhase.APPROACH, None, False
        res = self._solve(t, O, np.asarray(shark_pos, float), np.asarray(shark_vel, float))
        self._last = res
        if res is None:  # no plan: close in on the shark's front as a fallback
            self.fallbacks += 1
            d = np.asarray(shark_pos, float) + np.r_[np.asarray(shark_vel, float)[:2], 0.0] - O
            d[2] = 0.0
            return clip_velocity(p.VoMxy * d / (np.linalg.norm(d) + 1e-9), p)[0]
        plan = res.x
        self.plans.append(plan)
        if p.Ts + 1e-9 >= plan.T:  # reach the terminal point within this step, then hold
            self.phase, self.at_interception = SharkPhase.HOLD, True
            self.capture_time = t + plan.T
            self._hold_since = t
            return clip_velocity((plan.operator[-1] - O) / p.Ts, p)[0]
        return clip_velocity((plan.position(p.Ts) - O) / p.Ts, p)[0]
