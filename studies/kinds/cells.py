"""The three drone-cell kinds (thesis ch. 4): ``cells`` (one placement), ``cells-mobile`` (moving
users, one placement per epoch) and ``cells-fleet`` (the fewest drone-cells covering a share).

Their plans are scored by droneplan's own evaluators (``formulations.cells.evaluate`` and
``evaluate_mobile``); a bound is recorded only from droneplan's exact engines.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from droneplan.core.validation import check_int, check_positive
from droneplan.scenarios.air_to_ground import AirToGround
from droneplan.scenarios.cell_variants import (
    CAPACITY,
    EPOCH_S,
    MOBILE_EPOCHS,
    MOBILE_MAX_MOVE_M,
    VARIANTS,
    mobile_instance,
    thesis_variant_problem,
)
from droneplan.scenarios.cells import THESIS_TABLE_4_2, CellProblem, thesis_problem
from droneplan.solvers.result import SolveResult, Status
from droneplan.studies.kinds.base import (
    Family,
    InstanceLike,
    Kind,
    MethodLike,
    MethodRunner,
    plain_array,
)
from droneplan.studies.scoring import (
    Scored,
    check_claim,
    mark_infeasible,
    number,
    numeric_plan,
    unwrap,
)

__all__ = ["CellsKind", "CellsMobileKind", "CellsFleetKind", "FleetSizeInstance"]


@dataclass(frozen=True)
class FleetSizeInstance:
    """The smallest fleet of drone-cells that covers a share of the users' weight (with backhaul
    and every constraint of the problem).

    problem: the CellProblem; its ``n_cells`` is the largest fleet allowed. coverage: the share
    of the active users' weight (served weight, with a capacity) to reach, in (0, 1].
    """

    problem: CellProblem
    coverage: float

    def __post_init__(self) -> None:
        if not isinstance(self.problem, CellProblem):
            raise TypeError(f"problem must be a CellProblem, got {type(self.problem).__name__}")
        share = check_positive("coverage", self.coverage)
        if share > 1.0:
            raise ValueError(f"coverage must be a share in (0, 1], got {share}")
        object.__setattr__(self, "coverage", share)

    @property
    def n(self) -> int:
        """The largest fleet allowed (``problem.n_cells``)."""
        return int(self.problem.n_cells)

    @property
    def required_value(self) -> float:
        """The covered (served) weight a plan must reach: ``coverage`` of the total, rounded up
        when every weight is an integer (as ``min_fleet`` does)."""
        weights = self.problem.target_weights
        need = self.coverage * float(weights.sum())
        return float(math.ceil(need - 1e-9)) if np.all(np.mod(weights, 1.0) == 0) else need


# --------------------------------------------------------------------------- data <-> JSON


def _cells_to(p: CellProblem) -> dict:
    return {
        "users": plain_array(p.users),
        "gbs": plain_array(p.gbs),
        "n_cells": int(p.n_cells),
        "R_d": float(p.R_d),
        "R_g": float(p.R_g),
        "r1": float(p.r1),
        "r2": float(p.r2),
        "bounds": None if p.bounds is None else [float(b) for b in p.bounds],
        **_cells_variants_to(p),
    }


def _cells_variants_to(p: CellProblem) -> dict:
    """The variant fields of a cells instance (none for the thesis model, so its data, and so its
    fingerprint, stay as they were): weights, no-fly zones as rings (exterior first, closed
    vertex lists in metres) and the capacity."""
    out: dict[str, Any] = {}
    if p.weights is not None:
        out["weights"] = plain_array(p.weights)
    if p.no_fly:
        out["no_fly"] = [
            [plain_array(zone.exterior.coords), *(plain_array(hole.coords) for hole in zone.interiors)]
            for zone in p.no_fly
        ]
    if p.capacity is not None:
        out["capacity"] = int(p.capacity)
    if p.altitudes is not None and p.channel is not None:
        out["altitudes"] = [float(h) for h in p.altitudes]
        out["channel"] = {name: float(getattr(p.channel, name)) for name in _CHANNEL_FIELDS}
    return out


_CHANNEL_FIELDS = ("a", "b", "eta_los_db", "eta_nlos_db", "frequency_hz", "max_path_loss_db")


def _cells_from(d: Mapping[str, Any]) -> CellProblem:
    from shapely.geometry import Polygon

    users = np.asarray(d["users"]).reshape(-1, 2)  # no float(): "1.5" or true stays refused
    zones = []
    for i, rings in enumerate(d.get("no_fly") or []):
        if not isinstance(rings, list) or not rings:
            raise ValueError(f"no_fly[{i}] must be a list of rings (closed vertex lists), exterior first")
        zones.append(Polygon(rings[0], rings[1:]))
    return CellProblem(
        users,
        d["gbs"],
        d["n_cells"],
        d["R_d"],
        d["R_g"],
        d["r1"],
        d["r2"],
        d.get("bounds"),
        weights=d.get("weights"),
        no_fly=zones,
        capacity=d.get("capacity"),
        altitudes=d.get("altitudes"),
        channel=_channel_from(d.get("channel")),
    )


def _channel_from(d: Any) -> AirToGround | None:
    if d is None:
        return None
    if not isinstance(d, Mapping) or set(d) != set(_CHANNEL_FIELDS):
        raise ValueError(f"channel must be an object with the fields {list(_CHANNEL_FIELDS)}")
    return AirToGround(**d)


# --------------------------------------------------------------------------- families


def _cells_family(scale: Mapping[str, float] | None = None, *, clustered_only: bool = False):
    def build(m: int, seed: int) -> CellProblem:
        params = THESIS_TABLE_4_2
        if clustered_only:
            params = dataclasses.replace(params, lambda_nc=0.0)
        if scale:
            params = dataclasses.replace(params, **{k: getattr(params, k) * v for k, v in scale.items()})
        return thesis_problem(
            check_int("m", m, min_value=1), check_int("seed", seed, min_value=0), params=params
        )

    return build


def _cells_variant_family(variant: str):
    def build(m: int, seed: int) -> CellProblem:
        return thesis_variant_problem(variant, m, seed)

    return build


_VARIANT_DESCRIPTIONS = {
    "weighted": "Table 4.2 with an integer demand weight of 1-5 per user (objective: covered weight)",
    "nofly": "Table 4.2 with a 2 km x 3 km no-fly zone east of the GBS ([1.5, 3.5] x [-1.5, 1.5] km)",
    "capacity": f"Table 4.2 with a capacity of {CAPACITY} users per drone-cell (objective: served users)",
    "3d": "Table 4.2 with altitude levels 200 and 400 m and the urban air-to-ground channel",
}


def _cells_mobile(m: int, seed: int) -> Any:
    from droneplan.formulations.cells import MobileProblem

    base, snapshots = mobile_instance(m, seed)
    return MobileProblem(base, snapshots, MOBILE_MAX_MOVE_M)


def _cells_fleet_size(m: int, coverage: float, seed: int) -> FleetSizeInstance:
    problem = thesis_problem(check_int("m", m, min_value=1), check_int("seed", seed, min_value=0))
    return FleetSizeInstance(problem, coverage)


# --------------------------------------------------------------------------- scoring


def _cells_plan(
    returned: Any, method: MethodLike, tail: tuple[int, ...], n_cells: int, lead: int | None = None
) -> tuple[Scored, np.ndarray | None]:
    """The verdict so far and the plan of at most ``n_cells`` drone-cells in ``returned``
    (:func:`numeric_plan`'s shapes); the plan is None when the verdict is already final."""
    scored = Scored("feasible")
    plan, has = unwrap(returned, method, scored)
    if not has:
        return scored, None
    pos = numeric_plan(plan, tail, lead)
    if isinstance(pos, str):
        return Scored("invalid", message=pos, extras=scored.extras), None
    if pos.shape[-2] > n_cells:  # refused before any work that grows with the number of cells
        return (
            Scored(
                "invalid",
                message=f"the plan places {pos.shape[-2]} drone-cells; the instance has n_cells = {n_cells}",
                extras=scored.extras,
            ),
            None,
        )
    return scored, pos


def _trusted(scored: Scored, returned: Any, method: MethodLike) -> None:
    """A cells engine's bound and status (only a trusted method's ``SolveResult``), then the claim
    check."""
    if method.trusted_bound and isinstance(returned, SolveResult):
        bound = number(returned.bound)
        if bound is not None:
            scored.bound = bound
            scored.bound_kind = "proven-global" if returned.info.get("global_optimal") else "candidate-set"
        if returned.status is Status.OPTIMAL:
            scored.status = "optimal"
        scored.message = returned.message
    check_claim(scored)


def _score_cells(instance: InstanceLike, returned: Any, method: MethodLike) -> Scored:
    from droneplan.formulations.cells import evaluate

    problem = instance.data  # plans (x, y), or (x, y, h) with altitude levels
    scored, pos = _cells_plan(returned, method, (problem.plan_width,), problem.n_cells)
    if pos is None:
        return scored
    ev = evaluate(problem, pos)
    scored.extras["n_placed"] = len(pos)
    if not ev.feasible:
        mark_infeasible(scored, ev.violations)
        scored.extras["covered_if_feasible"] = ev.value
        return scored
    scored.objective = float(ev.value)  # covered users; the covered (served) weight of a variant
    _trusted(scored, returned, method)
    return scored


def _score_cells_mobile(instance: InstanceLike, returned: Any, method: MethodLike) -> Scored:
    from droneplan.formulations.cells import evaluate_mobile

    mp = instance.data
    width, n_cells = mp.problem.plan_width, mp.problem.n_cells
    scored, pos = _cells_plan(returned, method, (width,), n_cells, lead=mp.n_epochs)
    if pos is None:
        return scored
    ev = evaluate_mobile(mp, pos)
    scored.extras["per_epoch"] = list(ev.per_epoch)
    if not ev.feasible:
        mark_infeasible(scored, ev.violations)
        return scored
    scored.objective = float(ev.value)  # covered weight summed over the epochs
    _trusted(scored, returned, method)
    return scored


def _score_cells_fleet(instance: InstanceLike, returned: Any, method: MethodLike) -> Scored:
    from droneplan.formulations.cells import evaluate

    problem, need = instance.data.problem, instance.data.required_value
    scored, pos = _cells_plan(returned, method, (problem.plan_width,), problem.n_cells)
    if pos is None:
        return scored
    ev = evaluate(problem, pos)
    scored.extras["share"] = ev.value / max(float(problem.target_weights.sum()), 1e-300)
    violations = list(ev.violations)
    if ev.value < need - 1e-9 * max(1.0, need):
        violations.append(f"the plan covers {ev.value:g} of the weight, short of the {need:g} required")
    if violations:
        mark_infeasible(scored, violations)
        return scored
    scored.objective = float(len(pos))  # drone-cells used
    _trusted(scored, returned, method)
    return scored


def _certify_cells(instance: InstanceLike, time_limit: float | None) -> dict[str, Any]:
    from droneplan.formulations import cells

    problem = instance.data
    engine = "milp" if problem.variants else "bnb"
    res = cells.solve_exact(problem, engine=engine, time_limit=time_limit, workers=1)
    if res.x is None or res.objective is None:
        raise RuntimeError(f"{instance.id}: the {engine} found no plan ({res.status.name}: {res.message})")
    ev = cells.evaluate(problem, res.x)
    if not ev.feasible or abs(ev.value - float(res.objective)) > 1e-6 * max(1.0, ev.value):
        raise RuntimeError(
            f"{instance.id}: the engine's plan does not verify (value {ev.value:g}, claims {res.objective}; "
            f"{'; '.join(ev.violations)})"
        )
    bound = None if res.bound is None else float(res.bound)
    kind = "proven-global" if res.info.get("global_optimal") else "candidate-set"
    described = (
        "cells branch and bound (engine='bnb', workers=1)"
        if engine == "bnb"
        else f"cells MILP (engine='milp', {res.backend}, workers=1)"
    )
    return {
        "value": float(ev.value),
        "bound": bound,
        "bound_kind": kind if bound is not None else "none",
        "status": "optimal" if bound is not None and bound <= ev.value + 1e-9 else "feasible",
        "sense": "max",
        "plan": np.asarray(res.x, dtype=float).reshape(-1, problem.plan_width).tolist(),
        "engine": described,
        "time_s": float(res.solve_time),
        "message": res.message,
    }


# --------------------------------------------------------------------------- the kinds
class CellsKind(Kind):
    """One drone-cell placement (a :class:`~droneplan.scenarios.cells.CellProblem`, variants
    included); methods are called ``fn(problem, *, seed, time_limit)`` and return (k, 2) positions
    (m), or (k, 3) with altitude levels."""

    name = "cells"
    problem = "cells"
    sense = "max"
    data_type = CellProblem
    objective = "covered users (the covered, or served, weight of a variant)"

    def encode(self, data: Any) -> dict | None:
        return _cells_to(data)

    def decode(self, payload: Mapping[str, Any]) -> Any:
        return _cells_from(payload)

    def size(self, data: Any) -> int:
        return int(data.n_cells)

    def score(self, instance: InstanceLike, returned: Any, method: MethodLike) -> Scored:
        return _score_cells(instance, returned, method)

    def certify(
        self, instance: InstanceLike, *, time_limit: float | None, run: MethodRunner
    ) -> dict[str, Any]:
        return _certify_cells(instance, time_limit)

    def families(self) -> tuple[Family, ...]:
        m = {"m": (1, 2, 3, 4, 5, 6)}
        return (
            self.family(
                "table4.2",
                1,
                m,
                _cells_family(),
                "Table 4.2: Matern-clustered and background users, 10 km x 10 km, one GBS; m drone-cells",
            ),
            self.family(
                "table4.2-clusters",
                1,
                {"m": (1, 2, 3, 4)},
                _cells_family(clustered_only=True),
                "Table 4.2 with clustered users only (no background users, lambda_nc = 0)",
            ),
            self.family(
                "table4.2-dense",
                1,
                {"m": (3, 4)},
                _cells_family({"lambda_c": 2.0, "lambda_nc": 2.0}),
                "Table 4.2 with twice the user densities (lambda_c and lambda_nc x 2)",
            ),
            self.family(
                "table4.2-large-m",
                1,
                {"m": (7, 8, 10)},
                _cells_family(),
                "Table 4.2 users with more drone-cells than the thesis used (m >= 7)",
            ),
            *(
                self.family(
                    f"table4.2-{variant}",
                    1,
                    {"m": (1, 2, 3, 4)},
                    _cells_variant_family(variant),
                    _VARIANT_DESCRIPTIONS[variant],
                )
                for variant in VARIANTS
            ),
        )


class CellsMobileKind(Kind):
    """Moving users (a ``formulations.cells.MobileProblem``): methods are called
    ``fn(mobile_problem, *, seed, time_limit)`` and return one placement per epoch, (T, k, 2) or
    (T, k, 3) positions (m), each drone-cell keeping its index."""

    name = "cells-mobile"
    problem = "cells"
    sense = "max"
    default_methods = ("joint", "myopic")
    exact_engine, baseline = "joint", "myopic"
    objective = "covered weight summed over the epochs"

    def holds(self, data: Any) -> bool:
        return type(data).__name__ == "MobileProblem"

    def encode(self, data: Any) -> dict | None:
        return {
            "problem": _cells_to(data.problem),
            "snapshots": plain_array(data.snapshots),
            "max_move": float(data.max_move),
        }

    def decode(self, payload: Mapping[str, Any]) -> Any:
        from droneplan.formulations.cells import MobileProblem

        return MobileProblem(
            _cells_from(payload["problem"]), np.asarray(payload["snapshots"]), payload["max_move"]
        )

    def size(self, data: Any) -> int:
        return int(data.problem.n_cells)

    def score(self, instance: InstanceLike, returned: Any, method: MethodLike) -> Scored:
        return _score_cells_mobile(instance, returned, method)

    def families(self) -> tuple[Family, ...]:
        return (
            self.family(
                "table4.2-mobile",
                1,
                {"m": (1, 2, 3, 4)},
                _cells_mobile,
                f"Table 4.2 on 4 km x 4 km (3 clusters), users drifting over {MOBILE_EPOCHS} epochs "
                f"{EPOCH_S:g} s apart; drone-cells move at most {MOBILE_MAX_MOVE_M:g} m an epoch",
            ),
        )


class CellsFleetKind(Kind):
    """The smallest fleet (a :class:`FleetSizeInstance`): methods are called
    ``fn(problem, coverage, *, seed, time_limit)`` and return (k, 2) or (k, 3) positions (m) that
    must reach the coverage share."""

    name = "cells-fleet"
    problem = "cells"
    sense = "min"
    data_type = FleetSizeInstance
    default_methods = ("min-fleet", "greedy-fleet")
    exact_engine, baseline = "min-fleet", "greedy-fleet"
    objective = "drone-cells placed"

    def encode(self, data: Any) -> dict | None:
        return {"problem": _cells_to(data.problem), "coverage": float(data.coverage)}

    def decode(self, payload: Mapping[str, Any]) -> Any:
        return FleetSizeInstance(_cells_from(payload["problem"]), payload["coverage"])

    def size(self, data: Any) -> int:
        return data.n

    def arguments(self, data: Any) -> tuple[Any, ...]:
        return (data.problem, data.coverage)

    def score(self, instance: InstanceLike, returned: Any, method: MethodLike) -> Scored:
        return _score_cells_fleet(instance, returned, method)

    def families(self) -> tuple[Family, ...]:
        return (
            self.family(
                "min-fleet",
                1,
                {"m": (4,), "coverage": (0.05, 0.1)},
                _cells_fleet_size,
                "Table 4.2: the fewest of at most m drone-cells covering a share of the users",
            ),
        )
