"""The two shark kinds (thesis ch. 5): ``shark-path`` (one interception in the simulator) and
``shark-fleet`` (operators to assign to sharks, §5.3.1)."""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from droneplan.core.validation import check_array, check_int
from droneplan.scenarios.shark.params import SharkParams
from droneplan.scenarios.shark.simulate import InterceptionScenario
from droneplan.scenarios.shark.trajectories import SharkTrajectory, random_trajectory, thesis_trajectories
from droneplan.solvers.result import SolveResult, Status
from droneplan.studies.kinds.base import (
    ClosedLoopKind,
    Family,
    InstanceLike,
    Kind,
    MethodLike,
    MethodRunner,
    plain_array,
)
from droneplan.studies.scoring import Scored, check_claim, describe, number, unwrap

__all__ = ["SharkPathKind", "SharkFleetKind", "FleetInstance"]


@dataclass(frozen=True)
class FleetInstance:
    """Operators to assign to sharks (thesis §5.3.1): each selected shark gets its own operator.

    operators: (n, 3) operator positions (m). sharks_pos: (s, 3) shark positions (m). sharks_vel:
    (s, 3) shark velocities (m/s; predicted constant). humans: (h, 2) swimmer positions (m); when
    s > n the n sharks closest to a swimmer are the ones to serve.
    """

    operators: np.ndarray
    sharks_pos: np.ndarray
    sharks_vel: np.ndarray
    humans: np.ndarray

    def __post_init__(self) -> None:
        O = check_array("operators", self.operators, shape=(None, 3), min_rows=1)
        S = check_array("sharks_pos", self.sharks_pos, shape=(None, 3), min_rows=1)
        V = check_array("sharks_vel", self.sharks_vel, shape=(len(S), 3))
        H = check_array("humans", self.humans, shape=(None, 2), min_rows=1)
        for name, arr in (("operators", O), ("sharks_pos", S), ("sharks_vel", V), ("humans", H)):
            object.__setattr__(self, name, arr)

    @property
    def n(self) -> int:
        """Number of operators."""
        return len(self.operators)


def _shark_to(s: InterceptionScenario) -> dict:
    tr = s.trajectory
    return {
        "trajectory": {
            "t": plain_array(tr.t),
            "pos": plain_array(tr.pos),
            "vel": plain_array(tr.vel),
            "name": tr.name,
            "seed": tr.seed,
        },
        "params": dataclasses.asdict(s.params),
        "operator0": None if s.operator0 is None else plain_array(s.operator0),
        "bearing_deg": float(s.bearing_deg),
    }


def _shark_from(d: Mapping[str, Any]) -> InterceptionScenario:
    t = d["trajectory"]
    tr = SharkTrajectory(
        np.asarray(t["t"]),
        np.asarray(t["pos"]),
        np.asarray(t["vel"]),
        name=t.get("name", ""),
        seed=t.get("seed"),
    )
    return InterceptionScenario(tr, SharkParams(**d["params"]), d.get("operator0"), d.get("bearing_deg", 0.0))


def _shark_thesis(path: str) -> InterceptionScenario:
    paths = thesis_trajectories()
    if path not in paths:
        raise ValueError(f"path must be one of {sorted(paths)}, got {path!r}")
    return InterceptionScenario(paths[path])


def _shark_random(seed: int) -> InterceptionScenario:
    seed = check_int("seed", seed, min_value=0)
    bearing = float(np.random.default_rng(seed).uniform(-180, 180))
    return InterceptionScenario(random_trajectory(seed), bearing_deg=bearing)


def _shark_fleet(seed: int) -> FleetInstance:
    g = np.random.default_rng(check_int("seed", seed, min_value=0))
    n, s = int(g.integers(2, 5)), int(g.integers(2, 6))
    O = np.c_[g.uniform(-60, 60, (n, 2)), np.full(n, 2.0)]
    S = np.c_[g.uniform(-60, 60, (s, 2)), g.uniform(-5, -1, s)]
    spd, hdg = g.uniform(1.0, 5.0, s), g.uniform(-np.pi, np.pi, s)  # below VoMxy: every shark is reachable
    V = np.c_[spd * np.cos(hdg), spd * np.sin(hdg), np.zeros(s)]
    return FleetInstance(O, S, V, g.uniform(-30, 30, (6, 2)))


_FLEET_COSTS: dict[str, np.ndarray] = {}  # interception-time matrices by instance fingerprint


def _fleet_costs(instance: InstanceLike) -> tuple[np.ndarray, np.ndarray]:
    """(interception-time matrix (n, s) in s, indices of the sharks to serve) of a fleet instance."""
    from droneplan.formulations.shark import select_sharks
    from droneplan.planners.shark import interception_time_matrix

    d = instance.data
    key = instance.fingerprint()
    if key not in _FLEET_COSTS:
        if len(_FLEET_COSTS) > 64:
            _FLEET_COSTS.clear()
        _FLEET_COSTS[key] = interception_time_matrix(d.operators, d.sharks_pos, d.sharks_vel)
    near = np.min(np.linalg.norm(d.sharks_pos[:, None, :2] - d.humans[None, :, :2], axis=2), axis=1)
    n, s = len(d.operators), len(d.sharks_pos)
    return _FLEET_COSTS[key], select_sharks(near, n) if s > n else np.arange(s)


def _fleet_plan(plan: Any, n: int) -> tuple[np.ndarray, np.ndarray] | str:
    """(sharks, operator) as integer arrays, or why they are not an assignment."""
    if hasattr(plan, "sharks") and hasattr(plan, "operator"):
        plan = (plan.sharks, plan.operator)
    if not (isinstance(plan, (tuple, list)) and len(plan) == 2):
        return "a fleet method returns (sharks, operator) or an Assignment, got " + describe(plan)
    try:
        arrs = [np.asarray(a) for a in plan]
    except (TypeError, ValueError):
        return "sharks and operator must be arrays of integers"
    for name, arr in zip(("sharks", "operator"), arrs, strict=True):
        if arr.ndim != 1 or arr.dtype.kind not in "iu":
            return f"{name} must be a 1-D array of integers, got {describe(arr)}"
    if arrs[0].shape != arrs[1].shape:
        return f"sharks and operator must have the same length, got {arrs[0].shape} and {arrs[1].shape}"
    if np.any(arrs[1] < 0) or np.any(arrs[1] >= n):
        return f"operator indexes must lie in 0..{n - 1}"
    return arrs[0].astype(int), arrs[1].astype(int)


def _score_fleet(instance: InstanceLike, returned: Any, method: MethodLike) -> Scored:
    scored = Scored("feasible")
    plan, has = unwrap(returned, method, scored)
    if not has:
        return scored
    cost, serve = _fleet_costs(instance)
    found = _fleet_plan(plan, len(cost))
    if isinstance(found, str):
        return Scored("invalid", message=found, extras=scored.extras)
    sharks, operator = found
    if sorted(sharks.tolist()) != serve.tolist():
        scored.status = "infeasible"
        scored.message = (
            f"the sharks to serve are {serve.tolist()}, the plan serves {sorted(sharks.tolist())}"
        )
        return scored
    if len(set(operator.tolist())) != len(operator):
        scored.status = "infeasible"
        scored.message = "an operator is sent to two sharks"
        return scored
    times = cost[operator, sharks]
    if not np.all(np.isfinite(times)):
        k = int(np.argmax(~np.isfinite(times)))
        scored.status = "infeasible"
        scored.message = (
            f"operator {operator[k]} cannot reach shark {sharks[k]} within the prediction horizon"
        )
        return scored
    scored.objective = float(times.max())
    scored.extras["n_sharks"] = len(instance.data.sharks_pos)
    if method.trusted_bound and isinstance(returned, SolveResult) and returned.status is Status.OPTIMAL:
        scored.status = "optimal"
        bound = number(returned.bound)
        if bound is not None:
            scored.bound, scored.bound_kind = bound, "proven-global"
        scored.message = returned.message
    check_claim(scored)
    return scored


_SHARK_CONTROLLERS = ("virtual-shark", "classical-pursuit", "ocp")


class SharkPathKind(ClosedLoopKind):
    """One interception (an :class:`~droneplan.scenarios.shark.simulate.InterceptionScenario`):
    methods are interceptor controllers; the first contact must be frontal and not early."""

    name = "shark-path"
    problem = "shark"
    sense = "min"
    data_type = InterceptionScenario
    metric = "intercept_time"
    default_methods = ("virtual-shark", "ocp", "interception-bound")
    objective = "time of the first (frontal) contact (s)"

    def encode(self, data: Any) -> dict | None:
        return _shark_to(data)

    def decode(self, payload: Mapping[str, Any]) -> Any:
        return _shark_from(payload)

    def simulate(self, data: Any, controller: Any, seed: int) -> dict[str, Any]:
        from droneplan.scenarios.shark import simulate

        shark = simulate(data, controller, seed=seed)
        return {
            "intercept_time": shark.intercept_time,
            "frontal": bool(shark.frontal),
            "touched_early": bool(shark.touched_early),
            "interception_distance": shark.interception_distance,
            "fallbacks": int(shark.fallbacks),
            "capture_time": number(getattr(controller, "capture_time", None)),
        }

    def score_metrics(self, metrics: Mapping[str, Any], extras: dict[str, Any]) -> Scored:
        t = number(metrics.get("intercept_time"))
        if metrics.get("touched_early"):
            return Scored(
                "infeasible", message="the field touched the shark before the frontal contact", extras=extras
            )
        if t is None:
            return Scored("no_solution", message="no contact within the shark path's horizon", extras=extras)
        if not metrics.get("frontal"):
            return Scored(
                "infeasible",
                message="first contact not frontal (the shark's heading does not point at the operator)",
                extras={**extras, "contact_time_if_frontal": t},
            )
        return Scored("feasible", objective=t, message="time of first (frontal) contact, s", extras=extras)

    def certify(
        self, instance: InstanceLike, *, time_limit: float | None, run: MethodRunner
    ) -> dict[str, Any]:
        """The best frontal contact of the built-in interceptors (no proven bound: a feasible entry).

        instance: the study instance. time_limit: unused (the runs are simulated to the path's end).
        run: runs a registered method on the instance.
        """
        best: tuple[float, str] | None = None
        t0 = time.perf_counter()
        tried = []
        for name in _SHARK_CONTROLLERS:
            _, verdict = run(name, None)
            tried.append(
                f"{name}: {verdict.status}" + (f" {verdict.objective:.3f} s" if verdict.objective else "")
            )
            if verdict.objective is not None and (best is None or verdict.objective < best[0]):
                best = (verdict.objective, name)
        if best is None:
            raise RuntimeError(
                f"{instance.id}: no built-in interceptor made a valid frontal contact ({'; '.join(tried)})"
            )
        return {
            "value": best[0],
            "bound": None,
            "bound_kind": "none",
            "status": "feasible",
            "sense": "min",
            "plan": {"controller": best[1]},
            "engine": "best closed-loop frontal contact of " + ", ".join(_SHARK_CONTROLLERS),
            "time_s": time.perf_counter() - t0,
            "message": "; ".join(tried),
        }

    def families(self) -> tuple[Family, ...]:
        return (
            self.family(
                "table5.1",
                1,
                {"path": ("a", "b", "c", "d")},
                _shark_thesis,
                "Table 5.1 interception on the Fig. 5.12 shark paths a-d (operator 13 m away)",
                seeded=False,
            ),
            self.family(
                "random-path",
                1,
                {},
                _shark_random,
                "random curvy shark path (random curvature, speed, depth) and a random start bearing",
            ),
        )


class SharkFleetKind(Kind):
    """Operators to assign to sharks (a :class:`FleetInstance`): methods are called
    ``fn(operators, sharks_pos, sharks_vel, humans, *, seed, time_limit)`` and return
    ``(sharks, operator)`` or an ``Assignment``."""

    name = "shark-fleet"
    problem = "shark"
    sense = "min"
    data_type = FleetInstance
    default_methods = ("bottleneck", "greedy-nearest")
    exact_engine, baseline = "bottleneck", "greedy-nearest"
    objective = "the latest predicted interception time (s)"

    def encode(self, data: Any) -> dict | None:
        return {k: plain_array(getattr(data, k)) for k in ("operators", "sharks_pos", "sharks_vel", "humans")}

    def decode(self, payload: Mapping[str, Any]) -> Any:
        return FleetInstance(
            *(np.asarray(payload[k]) for k in ("operators", "sharks_pos", "sharks_vel", "humans"))
        )

    def size(self, data: Any) -> int:
        return data.n

    def arguments(self, data: Any) -> tuple[Any, ...]:
        return tuple(a.copy() for a in (data.operators, data.sharks_pos, data.sharks_vel, data.humans))

    def score(self, instance: InstanceLike, returned: Any, method: MethodLike) -> Scored:
        return _score_fleet(instance, returned, method)

    def families(self) -> tuple[Family, ...]:
        return (
            self.family(
                "random-fleet",
                1,
                {},
                _shark_fleet,
                "random fleet: 2-4 operators, 2-5 sharks at constant velocity, 6 swimmers (120 m x 120 m)",
            ),
        )
