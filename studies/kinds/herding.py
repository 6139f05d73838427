"""The two herding kinds (thesis ch. 6): ``allocation`` (steering points to assign to drones,
§6.4) and ``herding-run`` (a whole gathering and driving run in the simulator)."""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from droneplan.core.validation import check_array, check_int, check_positive
from droneplan.scenarios.herding import HerdingParams, HerdingScenario, thesis_scenario
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

__all__ = [
    "AllocationKind",
    "HerdingRunKind",
    "AllocationInstance",
    "random_allocation_instance",
    "allocation_of",
    "HERDING_T_MAX",
]

HERDING_T_MAX = 1800.0
"""Simulated horizon of a herding run (s), as the simulator's default."""


@dataclass(frozen=True)
class AllocationInstance:
    """A steering-point allocation instance (thesis §6.4): arc positions on the extended hull.

    drone_s: (n,) drone arc positions (m) in [0, perimeter). steer_s: (k,) steering-point arc
    positions (m) in [0, perimeter), k <= n (missing points are padded as in
    ``formulations.herding.pad_steering_points``). perimeter: extended-hull perimeter M (m) > 0.
    """

    drone_s: np.ndarray
    steer_s: np.ndarray
    perimeter: float

    def __post_init__(self) -> None:
        M = check_positive("perimeter", self.perimeter)
        d = check_array("drone_s", self.drone_s, ndim=1, min_rows=1)
        s = check_array("steer_s", self.steer_s, ndim=1, min_rows=1)
        for name, arr in (("drone_s", d), ("steer_s", s)):
            if np.any(arr < 0) or np.any(arr >= M):
                raise ValueError(f"{name} must lie in [0, perimeter) = [0, {M})")
        if len(s) > len(d):
            raise ValueError(f"steer_s has {len(s)} points but there are only {len(d)} drones")
        object.__setattr__(self, "perimeter", M)
        object.__setattr__(self, "drone_s", d)
        object.__setattr__(self, "steer_s", s)

    @property
    def n(self) -> int:
        """Number of drones."""
        return len(self.drone_s)


def random_allocation_instance(n: int, seed: int):
    """Drones and steering points on the extended hull of a random herd (arc lengths, m): the data
    of the ``allocation`` family, ``(drone_s, steer_s, perimeter)``.

    n: number of drones (and of steering points); seed: the herd's and the positions' seed."""
    from droneplan.planners.herding.geometry import ExtendedHull

    rng = np.random.default_rng(seed)
    herd = rng.uniform((0, 0), (1200, 600), size=(200, 2))
    hull = ExtendedHull.from_points(herd, 30.0)
    M = hull.perimeter
    drones = np.sort(rng.uniform(0, M, n))
    k = len(hull.vertex_s)
    steer = rng.choice(hull.vertex_s, size=min(n, k), replace=False) if k >= n else hull.vertex_s
    if len(steer) < n:
        steer = np.concatenate([steer, rng.uniform(0, M, n - len(steer))])
    return drones, np.mod(steer, M), M


def _allocation(n: int, seed: int) -> AllocationInstance:
    d, s, M = random_allocation_instance(check_int("n", n, min_value=1), check_int("seed", seed, min_value=0))
    return AllocationInstance(d, s, M)


def _herding_run(n_animals: int, seed: int) -> HerdingScenario:
    return thesis_scenario(
        check_int("n_animals", n_animals, min_value=1), check_int("seed", seed, min_value=0)
    )


def _herding_to(s: HerdingScenario) -> dict:
    return {
        "params": dataclasses.asdict(s.params),
        "animals": plain_array(s.animals),
        "drones": plain_array(s.drones),
        "headings": plain_array(s.headings),
        "goal": plain_array(s.goal),
        "field": [float(v) for v in s.field],
    }


def _herding_from(d: Mapping[str, Any]) -> HerdingScenario:
    fields: dict[str, Any] = {k: tuple(v) if isinstance(v, list) else v for k, v in d["params"].items()}
    params = HerdingParams(**fields)
    return HerdingScenario(
        params,
        np.asarray(d["animals"]),
        np.asarray(d["drones"]),
        np.asarray(d["headings"]),
        np.asarray(d["goal"]),
        tuple(d["field"]),
    )


def _score_allocation(instance: InstanceLike, returned: Any, method: MethodLike) -> Scored:  # noqa: C901
    from droneplan.formulations.herding import Allocation, check_allocation

    scored = Scored("feasible")
    plan, has = unwrap(returned, method, scored)
    if not has:
        return scored
    data = instance.data
    n, M = data.n, data.perimeter
    if isinstance(plan, Allocation):
        claimed_travel = number(np.max(plan.travel)) if np.size(plan.travel) else None
        if scored.claimed_objective is None and claimed_travel is not None:
            scored.claimed_objective = claimed_travel
        target, direction = plan.target, plan.direction
    elif isinstance(plan, (tuple, list)) and len(plan) == 2:
        target, direction = plan
    else:
        return Scored(
            "invalid",
            message="an allocation method returns (target, direction) or an Allocation, got "
            + describe(plan),
            extras=scored.extras,
        )
    try:
        t_arr = np.asarray(target)
        d_arr = np.asarray(direction)
    except (TypeError, ValueError):
        return Scored(
            "invalid", message="target and direction must be arrays of integers", extras=scored.extras
        )
    for name, arr in (("target", t_arr), ("direction", d_arr)):
        if arr.shape != (n,):
            return Scored(
                "invalid", message=f"{name} must have shape ({n},), got {arr.shape}", extras=scored.extras
            )
        if arr.dtype.kind not in "iuf" or (arr.dtype.kind == "f" and not np.all(np.isfinite(arr))):
            return Scored(
                "invalid", message=f"{name} must hold finite integers, got {arr.dtype}", extras=scored.extras
            )
        if not np.all(arr == np.round(arr)):
            return Scored(
                "invalid", message=f"{name} must hold integers, got {describe(arr)}", extras=scored.extras
            )
    t_int, d_int = t_arr.astype(int), d_arr.astype(int)
    if np.any(t_int < 0) or np.any(t_int >= n):
        return Scored("invalid", message=f"target indexes must lie in 0..{n - 1}", extras=scored.extras)
    alloc = allocation_of(data, t_int, d_int)
    try:
        value = check_allocation(data.drone_s, data.steer_s, M, alloc)
    except ValueError as exc:
        scored.status = "infeasible"
        scored.message = str(exc)
        scored.extras["max_travel_if_feasible"] = float(np.max(alloc.travel))
        return scored
    scored.objective = value
    if method.trusted_bound and isinstance(returned, SolveResult) and returned.status is Status.OPTIMAL:
        scored.status = "optimal"
        scored.bound, scored.bound_kind = value, "proven-global"
        scored.message = returned.message
    check_claim(scored)
    return scored


def allocation_of(data: Any, target: np.ndarray, direction: np.ndarray) -> Any:
    """The herding :class:`~droneplan.formulations.herding.Allocation` of ``(target, direction)`` on an
    allocation instance, with the travels droneplan computes (not checked: ``check_allocation`` does).

    data: the allocation instance's data (``drone_s``, ``steer_s``, ``perimeter``, ``n``).
    target: (n,) int, each drone's index into the steering points padded by ``pad_steering_points``.
    direction: (n,) int, +1 (increasing arc length) or -1 for each drone.
    """
    from droneplan.formulations.herding import Allocation, pad_steering_points

    M = data.perimeter
    points = pad_steering_points(data.steer_s, data.n, M)
    dest = points[target]
    travel = np.where(direction > 0, np.mod(dest - data.drone_s, M), np.mod(data.drone_s - dest, M))
    return Allocation(target=target, direction=direction, travel=travel, points=points)


def _certify_allocation(instance: InstanceLike, time_limit: float | None) -> dict[str, Any]:
    from droneplan.formulations.herding import check_allocation, solve_allocation

    d = instance.data
    res = solve_allocation(d.drone_s, d.steer_s, d.perimeter)
    value = check_allocation(d.drone_s, d.steer_s, d.perimeter, res.x)
    engine = "exact combinatorial allocation"
    if d.n <= 16:
        cp = solve_allocation(d.drone_s, d.steer_s, d.perimeter, engine="cp-sat", time_limit=time_limit)
        if (
            cp.status.value != "optimal"
            or cp.objective is None
            or abs(float(cp.objective) - value) > 1e-6 * max(1.0, d.perimeter)
        ):
            raise RuntimeError(
                f"{instance.id}: CP-SAT ({cp.status.name}, {cp.objective}) disagrees with exact {value}"
            )
        engine += " = CP-SAT assignment model"
    return {
        "value": value,
        "bound": value,
        "bound_kind": "proven-global",
        "status": "optimal",
        "sense": "min",
        "plan": {
            "target": np.asarray(res.x.target).tolist(),
            "direction": np.asarray(res.x.direction).tolist(),
        },
        "engine": engine,
        "time_s": float(res.solve_time),
        "message": res.message,
    }


class AllocationKind(Kind):
    """Steering points to assign (an :class:`AllocationInstance`): methods are called
    ``fn(drone_s, steer_s, perimeter, *, seed, time_limit)`` and return ``(target, direction)``
    or an ``Allocation``; droneplan computes the travels and checks (6.20)-(6.23)."""

    name = "allocation"
    problem = "herding"
    sense = "min"
    data_type = AllocationInstance
    objective = "the longest travel of a drone to its steering point (m)"

    def encode(self, data: Any) -> dict | None:
        return {
            "drone_s": plain_array(data.drone_s),
            "steer_s": plain_array(data.steer_s),
            "perimeter": float(data.perimeter),
        }

    def decode(self, payload: Mapping[str, Any]) -> Any:
        return AllocationInstance(
            np.asarray(payload["drone_s"]), np.asarray(payload["steer_s"]), payload["perimeter"]
        )

    def size(self, data: Any) -> int:
        return data.n

    def arguments(self, data: Any) -> tuple[Any, ...]:
        return (data.drone_s.copy(), data.steer_s.copy(), data.perimeter)

    def score(self, instance: InstanceLike, returned: Any, method: MethodLike) -> Scored:
        return _score_allocation(instance, returned, method)

    def certify(
        self, instance: InstanceLike, *, time_limit: float | None, run: MethodRunner
    ) -> dict[str, Any]:
        return _certify_allocation(instance, time_limit)

    def warm_start(self, data: Any, plan: Any) -> Any:
        """A verified ``(target, direction)`` or ``Allocation`` as the ``Allocation`` the CP-SAT
        model takes as its hint (travels computed by droneplan).

        data: the allocation instance. plan: the verified plan.
        """
        if hasattr(plan, "target") and hasattr(plan, "direction"):
            plan = (plan.target, plan.direction)
        target, direction = (np.asarray(a).astype(int) for a in plan)
        return allocation_of(data, target, direction)

    def families(self) -> tuple[Family, ...]:
        return (
            self.family(
                "allocation",
                1,
                {"n": (2, 4, 6, 7, 8, 16, 32, 64)},
                _allocation,
                "steering-point allocation: n drones and steering points on the extended hull of a "
                "random herd",
            ),
        )


class HerdingRunKind(ClosedLoopKind):
    """A herding run (a :class:`~droneplan.scenarios.herding.HerdingScenario`): methods are herder
    controllers; droneplan's simulator runs them for at most ``HERDING_T_MAX`` s."""

    name = "herding-run"
    problem = "herding"
    sense = "min"
    data_type = HerdingScenario
    metric = "total_time"
    objective = "gathering + driving time (s)"

    def encode(self, data: Any) -> dict | None:
        return _herding_to(data)

    def decode(self, payload: Mapping[str, Any]) -> Any:
        return _herding_from(payload)

    def size(self, data: Any) -> int:
        return int(data.params.n_drones)

    def simulate(self, data: Any, controller: Any, seed: int) -> dict[str, Any]:
        from droneplan.scenarios.herding import simulate as simulate_herding

        herd = simulate_herding(data, controller, t_max=HERDING_T_MAX, seed=seed)
        return {
            "total_time": herd.total_time,
            "gather_time": herd.gather_time,
            "fallbacks": int(herd.fallbacks),
        }

    def score_metrics(self, metrics: Mapping[str, Any], extras: dict[str, Any]) -> Scored:
        total = number(metrics.get("total_time"))
        if total is None:
            return Scored(
                "no_solution",
                message=f"the herd was not gathered and driven within {HERDING_T_MAX:g} s",
                extras=extras,
            )
        return Scored("feasible", objective=total, message="gathering + driving time, s", extras=extras)

    def families(self) -> tuple[Family, ...]:
        return (
            self.family(
                "table6.2",
                1,
                {"n_animals": (200,)},
                _herding_run,
                "Table 6.2 herding run: animals uniform in the 1200 m x 600 m field, 4 drones",
            ),
        )
