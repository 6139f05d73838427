"""Running a method on an instance and scoring what it returned, independently of the method.

One *job* is one (instance, method) pair. It runs in a child process with a time limit
(:mod:`droneplan.studies.runner`), so a method that hangs, sleeps or crashes costs one row and
not the study. What the method returned is then scored by droneplan's own evaluator, never by
the method's word:

``cells``         the positions go through ``formulations.cells.evaluate`` (overlap, GBS
                  overlap, backhaul, count, bounds); objective = covered users
``cells-mobile``  the (T, k, w) plan goes through ``evaluate_mobile`` (every epoch's constraints and
                  the moves); objective = covered weight summed over the epochs
``cells-fleet``   the positions go through ``evaluate`` and must reach the coverage share;
                  objective = the number of drone-cells placed
``allocation``    ``(target, direction)`` becomes an allocation whose travels droneplan computes
                  and ``check_allocation`` verifies against (6.20)-(6.23); objective = max travel (m)
``shark-fleet``   ``(sharks, operator)`` must serve exactly the sharks to serve (all, or the n
                  closest to a swimmer) with distinct operators; objective = latest predicted
                  interception time (s) from droneplan's ``interception_time_matrix``
closed loop       the controller runs inside the problem's simulator; objective = the simulator's
                  metric (shark: time of first contact, s, which must be frontal and not early;
                  covert: max recorded bearing change, deg; herding: gathering + driving time, s)
bound engines     droneplan's registered bound engines of closed-loop kinds
                  (``Method.is_bound_engine``) return a proven bound with its kind and extras;
                  their row has role ``bound``, no objective, and the bound only if its kind is
                  one the store ranks (``BOUND_KINDS``)

A warm-started composite ``"ENGINE<HEURISTIC"`` (:class:`~droneplan.studies.methods.WarmStarted`)
runs as :func:`run_warm_started` says: its heuristic in a process of its own, whose plan is scored
here like any method's, then droneplan's engine in the job's process, warm-started with a verified
plan; its row is scored as the engine's, with both parts' times and the start's fate as extras.

Statuses of a row: ``optimal``/``feasible`` (a verified plan), ``infeasible`` (the plan violates a
constraint, named in ``message``), ``invalid`` (a return value of the wrong type or shape, NaN or
inf), ``no_solution`` (the method returned nothing), ``timeout``, ``error`` (the method raised; the
exception in ``message``). A number the method claims goes to ``claimed_objective``; when it
differs from droneplan's the row is flagged ``claim-mismatch``. Only droneplan's exact engines
(``Method.trusted_bound``) put a bound in ``bound``.
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from droneplan.solvers.result import SolveResult, Status
from droneplan.studies.instances import StudyInstance
from droneplan.studies.methods import CLOSED_LOOP_KINDS, Method, WarmStarted

__all__ = [
    "Scored",
    "execute",
    "execute_plain",
    "score",
    "SENSE_OF_KIND",
    "HERDING_T_MAX",
    "STATIC_KINDS",
    "BUDGET_KEYWORDS",
    "COMPOSITE_INFO",
    "HEURISTIC_SHARE",
    "HEURISTIC_GRACE_S",
    "MIN_ENGINE_S",
    "allocation_of",
    "run_warm_started",
    "method_arguments",
]

COMPOSITE_INFO = "composite"
"""The entry of a warm-started composite's ``SolveResult.info`` that holds its row's extras (both
parts' times, the heuristic's verified objective, the warm start's fate)."""

SENSE_OF_KIND = {
    "cells": "max",
    "cells-mobile": "max",
    "cells-fleet": "min",
    "allocation": "min",
    "shark-path": "min",
    "shark-fleet": "min",
    "covert-run": "min",
    "herding-run": "min",
}
"""The direction in which each kind's objective is better."""

HERDING_T_MAX = 1800.0
"""Simulated horizon of a herding run (s), as the simulator's default."""

_CLAIM_TOL = 1e-6


@dataclass
class Scored:
    """Droneplan's verdict on one job (the method-independent part of its row)."""

    status: str
    objective: float | None = None
    bound: float | None = None
    bound_kind: str = "none"
    claimed_objective: float | None = None
    flags: list[str] = field(default_factory=list)
    message: str = ""
    warm_started: bool = False
    extras: dict[str, Any] = field(default_factory=dict)


# --------------------------------------------------------------------------- in the child
BUDGET_KEYWORDS = ("cpu_limit", "max_evaluations")
"""The study's optional budgets a method receives when it names them among its parameters."""


def execute(
    instance: StudyInstance,
    method: Method,
    seed: int,
    time_limit: float | None,
    budgets: Mapping[str, Any] | None = None,
) -> Any:
    """Run ``method`` on ``instance`` (in the job's child process) and return what is to be scored.

    Static kinds return the method's raw return value; ``budgets`` (``cpu_limit`` in CPU-s,
    ``max_evaluations``, and ``report``: True to hand the method a
    :class:`~droneplan.studies.traces.Reporter`) reach the method as keywords when it names them
    (:meth:`~droneplan.studies.methods.Method.accepts`). Closed-loop kinds return droneplan's
    simulator's metrics (a dict): the simulator runs here, in a process the method never runs in,
    and the controller in a process of its own (:class:`~droneplan.studies.sandbox.ControllerProcess`)
    that only answers commands; a controller that fails or answers with something other than a
    plain command gives ``{"controller_failed": message}``.
    """
    data = instance.data
    if instance.kind in STATIC_KINDS:
        if isinstance(method, WarmStarted):
            return run_warm_started(instance, method, seed, time_limit, budgets)
        extra = _method_keywords(method, budgets or {})
        return method.call(*method_arguments(instance), seed=seed, time_limit=time_limit, **extra)
    if method.is_bound_engine:
        return method.call(data, seed=seed, time_limit=time_limit)
    from droneplan.studies.sandbox import ControllerFailed, ControllerProcess

    t0 = time.perf_counter()
    with ControllerProcess(method.controller) as ctl:
        try:
            metrics = _simulate(instance, ctl, seed)
        except ControllerFailed as exc:
            metrics = {"controller_failed": str(exc), "failure_status": exc.status}
        metrics["method_time_s"] = ctl.method_time_s
    metrics["simulation_time_s"] = max(0.0, time.perf_counter() - t0 - metrics["method_time_s"])
    return metrics


STATIC_KINDS = ("cells", "cells-mobile", "cells-fleet", "allocation", "shark-fleet")
"""The kinds whose methods return a plan (the others run a controller in a simulator)."""


def method_arguments(instance: StudyInstance) -> tuple[Any, ...]:
    """The positional arguments a method of a static kind is called with (module docstring of
    :mod:`~droneplan.studies.methods`: the contract per kind); arrays are copies.

    instance: an instance of one of ``STATIC_KINDS``.
    """
    data = instance.data
    if instance.kind in ("cells", "cells-mobile"):
        return (data,)
    if instance.kind == "cells-fleet":
        return (data.problem, data.coverage)
    if instance.kind == "allocation":
        return (data.drone_s.copy(), data.steer_s.copy(), data.perimeter)
    if instance.kind == "shark-fleet":
        return tuple(a.copy() for a in (data.operators, data.sharks_pos, data.sharks_vel, data.humans))
    raise ValueError(f"instance kind {instance.kind!r} is not one of {', '.join(STATIC_KINDS)}")


def _method_keywords(method: Method, budgets: Mapping[str, Any]) -> dict[str, Any]:
    """The study's budgets the method names, and a reporter when it takes one and one is wanted."""
    extra = {k: budgets[k] for k in BUDGET_KEYWORDS if budgets.get(k) is not None and method.accepts(k)}
    if budgets.get("report") and method.accepts("report"):
        from droneplan.studies.reporter import Reporter
        from droneplan.studies.runner import send_report

        extra["report"] = Reporter(send_report)
    return extra


def execute_plain(
    instance: StudyInstance,
    method: Method,
    seed: int,
    time_limit: float | None,
    budgets: Mapping[str, Any] | None = None,
) -> bytes:
    """:func:`execute`, with its result as a :mod:`~droneplan.studies.wire` message (in the job's
    child process): a return value that is not plain data becomes a refusal, scored ``invalid``."""
    from droneplan.studies import wire

    value = execute(instance, method, seed, time_limit, budgets)
    try:
        return wire.encode(value)
    except wire.NotPlainError as exc:
        return wire.refusal(exc, value)


def _simulate(instance: StudyInstance, ctl: Any, seed: int) -> dict[str, Any]:
    """The simulator's metrics of one closed-loop run of ``ctl`` on ``instance`` (droneplan's own run)."""
    data = instance.data
    if instance.kind == "shark-path":
        from droneplan.scenarios.shark import simulate

        shark = simulate(data, ctl, seed=seed)
        return {
            "intercept_time": shark.intercept_time,
            "frontal": bool(shark.frontal),
            "touched_early": bool(shark.touched_early),
            "interception_distance": shark.interception_distance,
            "fallbacks": int(shark.fallbacks),
            "capture_time": _number(getattr(ctl, "capture_time", None)),
        }
    if instance.kind == "covert-run":
        from droneplan.scenarios.covert import simulate as simulate_covert

        covert = simulate_covert(data, ctl, seed=seed)
        return {
            "beta_max_deg": math.degrees(covert.beta_max) if covert.beta_max is not None else None,
            "sphere_error": covert.sphere_error,
            "t_a": covert.t_a,
            "fallbacks": int(covert.fallbacks),
        }
    from droneplan.scenarios.herding import simulate as simulate_herding

    herd = simulate_herding(data, ctl, t_max=HERDING_T_MAX, seed=seed)
    return {"total_time": herd.total_time, "gather_time": herd.gather_time, "fallbacks": int(herd.fallbacks)}


# --------------------------------------------------------------------------- in the parent
def _number(v: Any) -> float | None:
    """A finite float from a Python or numpy number; None otherwise."""
    if isinstance(v, (bool, np.bool_)) or v is None:
        return None
    if isinstance(v, (int, float, np.integer, np.floating)):
        f = float(v)
        return f if math.isfinite(f) else None
    if isinstance(v, np.ndarray) and v.shape == () and v.dtype.kind in "iuf":
        return _number(v.item())
    return None


def _scalar(v: Any) -> bool:
    """Whether ``v`` is a value a row's extra column holds (None, a bool, a finite number, a str)."""
    return v is None or isinstance(v, (bool, str)) or _number(v) is not None


def _describe(v: Any) -> str:
    text = repr(v)
    return text if len(text) <= 60 else text[:57] + "..."


SAID = "said_"
"""The prefix of the row extras a method reports about its own run (``SolveResult.info["extras"]``
and its ``solve_time``): claims, recorded as such."""

MAX_SAID = 32
"""The most ``info["extras"]`` entries of one result kept on its row."""


def _claims(scored: Scored, result: SolveResult, method: Method) -> None:
    """Record what a SolveResult claims beside droneplan's own numbers."""
    claimed = result.objective
    if claimed is not None:
        num = _number(claimed)
        if num is None:
            scored.flags.append("claim-invalid")
            scored.extras["claimed_objective_text"] = _describe(claimed)
        else:
            scored.claimed_objective = num
    status = result.status
    scored.extras["claimed_status"] = status.value if isinstance(status, Status) else _describe(status)
    if not isinstance(status, Status):
        scored.flags.append("claim-invalid")
    scored.warm_started = bool(getattr(result, "warm_started", False))
    info = result.info if isinstance(result.info, Mapping) else {}
    evaluations = _number(info.get("evaluations"))
    if evaluations is not None:
        scored.extras["evaluations"] = evaluations
    if result.bound is not None and not method.trusted_bound:
        scored.extras["claimed_bound"] = _number(result.bound)
    if method.trusted_bound:  # droneplan's engines: their own solve time and search nodes
        scored.extras["solve_time_s"] = _number(result.solve_time)
        stats = info.get("model_stats")
        places = (info, stats if isinstance(stats, Mapping) else {})
        found = (_number(d.get(k)) for d in places for k in ("nodes", "num_branches"))
        nodes = next((n for n in found if n is not None), None)
        if nodes is not None:  # the branch and bound's search nodes, CP-SAT's branches
            scored.extras["nodes"] = nodes
        composite = info.get(COMPOSITE_INFO) if isinstance(method, WarmStarted) else None
        if isinstance(composite, Mapping):
            scored.extras.update({str(k): v for k, v in composite.items() if _scalar(v)})
    # what a method says about its run (``info["extras"]``, its own clock) is kept under ``said_``
    # names beside droneplan's numbers, never in their place
    said = info.get("extras")
    if isinstance(said, Mapping):
        kept = list(said.items())[:MAX_SAID]
        scored.extras.update({f"{SAID}{str(k)[:40]}": v for k, v in kept if _scalar(v)})
    scored.extras.setdefault(f"{SAID}solve_time_s", _number(result.solve_time))


def _check_claim(scored: Scored) -> None:
    if scored.claimed_objective is None or scored.objective is None:
        return
    if abs(scored.claimed_objective - scored.objective) > _CLAIM_TOL * max(1.0, abs(scored.objective)):
        scored.flags.append("claim-mismatch")
        scored.message = (
            f"the method claims {scored.claimed_objective:g}, droneplan measures {scored.objective:g}; "
            + scored.message
        ).rstrip("; ")


def _unwrap(returned: Any, method: Method, scored: Scored) -> tuple[Any, bool]:
    """The plan inside ``returned`` and whether there is one (a SolveResult may carry none)."""
    if isinstance(returned, SolveResult):
        _claims(scored, returned, method)
        if returned.x is None:
            scored.status = "no_solution"
            scored.message = f"the method returned no plan (its status: {scored.extras['claimed_status']})"
            return None, False
        return returned.x, True
    return returned, True


def _numeric_plan(plan: Any, tail: tuple[int, ...], lead: int | None = None) -> np.ndarray | str:
    """``plan`` as a float array of shape (k, *tail), or (lead, k, *tail) when ``lead`` is given
    (one placement per epoch); a one-line reason when it is not one."""
    try:
        raw = np.asarray(plan)
    except (TypeError, ValueError):
        raw = np.asarray(None)
    if raw.dtype.kind not in "iuf" and raw.size:
        return f"positions must be numbers (reals), got {_describe(plan)}"
    pos = raw.astype(float)
    head = () if lead is None else (lead,)
    if pos.size == 0:
        pos = pos.reshape(*head, 0, *tail)
    if lead is None and pos.ndim == 1 and pos.shape == tail:
        pos = pos.reshape(1, *tail)
    shape = pos.shape[: len(head)] + pos.shape[len(head) + 1 :]
    if pos.ndim != len(head) + 1 + len(tail) or shape != head + tail:
        want = ", ".join(str(d) for d in (*head, "k", *tail))
        return f"positions must have shape ({want}), got {pos.shape}"
    if not np.all(np.isfinite(pos)):
        return "positions contain NaN or inf"
    return pos


def _cells_plan(
    returned: Any, method: Method, tail: tuple[int, ...], n_cells: int, lead: int | None = None
) -> tuple[Scored, np.ndarray | None]:
    """The verdict so far and the plan of at most ``n_cells`` drone-cells in ``returned``
    (:func:`_numeric_plan`'s shapes); the plan is None when the verdict is already final."""
    scored = Scored("feasible")
    plan, has = _unwrap(returned, method, scored)
    if not has:
        return scored, None
    pos = _numeric_plan(plan, tail, lead)
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


def _score_cells(instance: StudyInstance, returned: Any, method: Method) -> Scored:
    from droneplan.formulations.cells import evaluate

    problem = instance.data  # plans (x, y), or (x, y, h) with altitude levels
    scored, pos = _cells_plan(returned, method, (problem.plan_width,), problem.n_cells)
    if pos is None:
        return scored
    ev = evaluate(problem, pos)
    scored.extras["n_placed"] = len(pos)
    if not ev.feasible:
        _infeasible(scored, ev.violations)
        scored.extras["covered_if_feasible"] = ev.value
        return scored
    scored.objective = float(ev.value)  # covered users; the covered (served) weight of a variant
    _trusted(scored, returned, method)
    return scored


def _infeasible(scored: Scored, violations: Any) -> None:
    """Mark ``scored`` infeasible with the first three ``violations`` in its message."""
    more = f" (+{len(violations) - 3} more)" if len(violations) > 3 else ""
    scored.status = "infeasible"
    scored.message = "; ".join(violations[:3]) + more


def _trusted(scored: Scored, returned: Any, method: Method) -> None:
    """A cells engine's bound and status (only a trusted method's ``SolveResult``), then the claim
    check."""
    if method.trusted_bound and isinstance(returned, SolveResult):
        bound = _number(returned.bound)
        if bound is not None:
            scored.bound = bound
            scored.bound_kind = "proven-global" if returned.info.get("global_optimal") else "candidate-set"
        if returned.status is Status.OPTIMAL:
            scored.status = "optimal"
        scored.message = returned.message
    _check_claim(scored)


def _score_cells_mobile(instance: StudyInstance, returned: Any, method: Method) -> Scored:
    from droneplan.formulations.cells import evaluate_mobile

    mp = instance.data
    width, n_cells = mp.problem.plan_width, mp.problem.n_cells
    scored, pos = _cells_plan(returned, method, (width,), n_cells, lead=mp.n_epochs)
    if pos is None:
        return scored
    ev = evaluate_mobile(mp, pos)
    scored.extras["per_epoch"] = list(ev.per_epoch)
    if not ev.feasible:
        _infeasible(scored, ev.violations)
        return scored
    scored.objective = float(ev.value)  # covered weight summed over the epochs
    _trusted(scored, returned, method)
    return scored


def _score_cells_fleet(instance: StudyInstance, returned: Any, method: Method) -> Scored:
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
        _infeasible(scored, violations)
        return scored
    scored.objective = float(len(pos))  # drone-cells used
    _trusted(scored, returned, method)
    return scored


_STATIC_CELLS = {
    "cells": _score_cells,
    "cells-mobile": _score_cells_mobile,
    "cells-fleet": _score_cells_fleet,
}
"""The scorers of the cells kinds."""


def _score_allocation(instance: StudyInstance, returned: Any, method: Method) -> Scored:  # noqa: C901
    from droneplan.formulations.herding import Allocation, check_allocation

    scored = Scored("feasible")
    plan, has = _unwrap(returned, method, scored)
    if not has:
        return scored
    data = instance.data
    n, M = data.n, data.perimeter
    if isinstance(plan, Allocation):
        claimed_travel = _number(np.max(plan.travel)) if np.size(plan.travel) else None
        if scored.claimed_objective is None and claimed_travel is not None:
            scored.claimed_objective = claimed_travel
        target, direction = plan.target, plan.direction
    elif isinstance(plan, (tuple, list)) and len(plan) == 2:
        target, direction = plan
    else:
        return Scored(
            "invalid",
            message="an allocation method returns (target, direction) or an Allocation, got "
            + _describe(plan),
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
                "invalid", message=f"{name} must hold integers, got {_describe(arr)}", extras=scored.extras
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
    _check_claim(scored)
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


_FLEET_COSTS: dict[str, np.ndarray] = {}  # interception-time matrices by instance fingerprint


def _fleet_costs(instance: StudyInstance) -> tuple[np.ndarray, np.ndarray]:
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
        return "a fleet method returns (sharks, operator) or an Assignment, got " + _describe(plan)
    try:
        arrs = [np.asarray(a) for a in plan]
    except (TypeError, ValueError):
        return "sharks and operator must be arrays of integers"
    for name, arr in zip(("sharks", "operator"), arrs, strict=True):
        if arr.ndim != 1 or arr.dtype.kind not in "iu":
            return f"{name} must be a 1-D array of integers, got {_describe(arr)}"
    if arrs[0].shape != arrs[1].shape:
        return f"sharks and operator must have the same length, got {arrs[0].shape} and {arrs[1].shape}"
    if np.any(arrs[1] < 0) or np.any(arrs[1] >= n):
        return f"operator indexes must lie in 0..{n - 1}"
    return arrs[0].astype(int), arrs[1].astype(int)


def _score_fleet(instance: StudyInstance, returned: Any, method: Method) -> Scored:
    scored = Scored("feasible")
    plan, has = _unwrap(returned, method, scored)
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
        bound = _number(returned.bound)
        if bound is not None:
            scored.bound, scored.bound_kind = bound, "proven-global"
        scored.message = returned.message
    _check_claim(scored)
    return scored


def _score_closed_loop(instance: StudyInstance, metrics: Mapping[str, Any]) -> Scored:
    extras = {
        k: v
        for k, v in metrics.items()
        if k not in ("intercept_time", "beta_max_deg", "total_time", "controller_failed", "failure_status")
    }
    if "controller_failed" in metrics:
        status = "invalid" if metrics.get("failure_status") == "invalid" else "error"
        return Scored(status, message=str(metrics["controller_failed"]), extras=extras)
    if instance.kind == "shark-path":
        t = _number(metrics.get("intercept_time"))
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
    if instance.kind == "covert-run":
        b = _number(metrics.get("beta_max_deg"))
        if b is None:
            return Scored(
                "no_solution", message="no bearing change recorded (no target observed)", extras=extras
            )
        return Scored(
            "feasible", objective=b, message="max recorded bearing change beta_max, deg", extras=extras
        )
    total = _number(metrics.get("total_time"))
    if total is None:
        return Scored(
            "no_solution",
            message=f"the herd was not gathered and driven within {HERDING_T_MAX:g} s",
            extras=extras,
        )
    return Scored("feasible", objective=total, message="gathering + driving time, s", extras=extras)


def _score_bound_engine(returned: Mapping[str, Any]) -> Scored:
    """A registered bound engine's result: its status, proven bound (of a ranked kind) and extras."""
    from droneplan.studies.store import BOUND_KINDS

    status = str(returned.get("status", ""))
    if status not in ("optimal", "no_solution"):
        return Scored("error", message=f"internal: a bound engine returned status {_describe(status)}")
    bound = _number(returned.get("bound"))
    kind = str(returned.get("bound_kind", "none"))
    if bound is not None and (kind not in BOUND_KINDS or kind == "none"):
        return Scored("error", message=f"internal: a bound engine returned bound kind {_describe(kind)}")
    extras = dict(returned.get("extras") or {})
    return Scored(
        status, bound=bound, bound_kind=kind, message=str(returned.get("message", "")), extras=extras
    )


def score(instance: StudyInstance, method: Method, returned: Any) -> Scored:
    """Droneplan's verdict on what ``method`` returned for ``instance`` (module docstring: the rules)."""
    from droneplan.studies.wire import Refused

    if isinstance(returned, Refused):
        return Scored(
            "invalid",
            message=f"the method returned something that is not plain data ({returned.why}); "
            "methods return numbers, arrays, tuples, lists, dicts or droneplan's result types",
            extras={"returned_type": returned.type_name} if returned.type_name else {},
        )
    if instance.kind in _STATIC_CELLS:
        return _STATIC_CELLS[instance.kind](instance, returned, method)
    if instance.kind == "allocation":
        return _score_allocation(instance, returned, method)
    if instance.kind == "shark-fleet":
        return _score_fleet(instance, returned, method)
    if instance.kind in CLOSED_LOOP_KINDS:
        if not isinstance(returned, Mapping):
            return Scored("error", message=f"internal: the simulation returned {_describe(returned)}")
        if method.is_bound_engine:
            return _score_bound_engine(returned)
        return _score_closed_loop(instance, returned)
    raise ValueError(f"unknown instance kind {instance.kind!r}")


HEURISTIC_SHARE = 0.5
"""The share of a warm-started composite's time limit its heuristic may use (the engine gets the rest)."""

HEURISTIC_GRACE_S = 1.0
"""How long a composite's heuristic may overrun its share before its process is killed (s)."""

MIN_ENGINE_S = 0.05
"""The least time limit the engine of a composite is given (s), however long the heuristic took."""

HEURISTIC_RESULT_BYTES = 64 << 20
"""The largest plan a composite's heuristic may send back (bytes; as a study's method)."""

_OK = ("optimal", "feasible")
_TIE_TOL = 1e-9  # relative: values closer than this are the same


# --------------------------------------------------------------------------- warm-started composites
def run_warm_started(
    instance: StudyInstance,
    method: WarmStarted,
    seed: int,
    time_limit: float | None,
    budgets: Mapping[str, Any] | None = None,
) -> SolveResult:
    """Run a warm-started composite ``"ENGINE<HEURISTIC"`` on ``instance`` (in the job's process).

    1. The heuristic runs in a process of its own (:func:`~droneplan.studies.runner.run_isolated`):
       it may be the user's code, so it never runs in the process whose engine result the row
       trusts. Its plan comes back as a plain-data message (:mod:`~droneplan.studies.wire`).
    2. :func:`score` checks that plan as it checks any method's; only a verified plan
       (``optimal``/``feasible``) becomes the start. A heuristic that raised, crashed, timed out
       or returned an invalid or infeasible plan leaves the engine to run cold.
    3. The engine (droneplan's registered exact engine, its bound trusted) runs warm-started: the
       cells engines' ``warm_start`` (``solve_exact``), the allocation's CP-SAT ``hint``.

    The time limit ``T`` is split: the heuristic gets at most ``HEURISTIC_SHARE * T`` (its process
    is killed ``HEURISTIC_GRACE_S`` later), the engine the rest, ``T`` minus the heuristic's wall
    time (at least ``MIN_ENGINE_S``), so a composite competes with a study's other methods on the
    same wall budget. ``info[COMPOSITE_INFO]`` (the row's extras) holds: ``heuristic``, ``engine``
    (the parts' names); ``heuristic_status`` (droneplan's verdict on its plan, or its process's
    fate: ``timeout``, ``error``, ``crashed``); ``heuristic_objective`` (droneplan's value of its
    plan; None without a verified plan); ``heuristic_time_s``, ``heuristic_cpu_s``;
    ``heuristic_time_limit_s``, ``engine_time_limit_s`` (the split); ``engine_time_s`` (the
    engine's solve time); ``warm_start`` (``used``: the plan, or its polished feasible part, was
    the engine's incumbent or hint; ``not used``: the engine's own start was better; ``cold``),
    ``warm_start_reason`` (why, in a sentence), ``warm_start_value``,
    ``warm_start_polished_value`` (cells: after the engines' polish); ``kept`` (``engine``, or
    ``heuristic`` when the engine stopped with a plan worse than the start, which the row then
    reports with the engine's bound).

    instance: an instance of the composite's kind.
    method: the composite (:func:`~droneplan.studies.methods.warm_started`).
    seed: the run's seed, handed to the heuristic (the engine is deterministic).
    time_limit: the composite's wall-time limit (s), None: none (the heuristic then has none either).
    budgets: the study's budgets (``cpu_limit``, ``max_evaluations``); they reach the heuristic
        when it names them.

    Returns the engine's SolveResult (or the start, with the engine's bound, when the engine's plan
    is worse: extra ``kept``), its ``info[COMPOSITE_INFO]`` the row's extras.
    """
    if not isinstance(method, WarmStarted) or method.engine is None or method.heuristic is None:
        raise TypeError(f"method must be a warm-started composite, got {type(method).__name__}")
    from droneplan.studies.runner import Job, run_isolated

    t0 = time.perf_counter()
    h_limit = None if time_limit is None else HEURISTIC_SHARE * time_limit
    h_budgets = {k: v for k, v in (budgets or {}).items() if k in BUDGET_KEYWORDS}
    job = Job(
        "heuristic",
        execute_plain,
        (instance, method.heuristic, seed, h_limit, h_budgets),
        time_limit=h_limit,
        returns="bytes",
        max_result_bytes=HEURISTIC_RESULT_BYTES,
    )
    outcome = run_isolated(job, grace=HEURISTIC_GRACE_S)
    facts: dict[str, Any] = {
        "heuristic": method.heuristic.name,
        "engine": method.engine.name,
        "heuristic_time_s": outcome.wall_s,
        "heuristic_cpu_s": outcome.cpu_s,
        "heuristic_time_limit_s": h_limit,
    }
    start, verdict = _verified_start(instance, method, outcome, facts, HEURISTIC_RESULT_BYTES)
    left = None if time_limit is None else max(time_limit - (time.perf_counter() - t0), MIN_ENGINE_S)
    facts["engine_time_limit_s"] = left
    t1 = time.perf_counter()
    result = method.engine.call(*method_arguments(instance), seed=seed, time_limit=left, warm_start=start)
    facts["engine_time_s"] = result.solve_time if result.solve_time else time.perf_counter() - t1
    if start is not None and verdict is not None:
        _fate(instance.kind, result, verdict, facts)
        result = _better_of(instance.kind, result, start, verdict, facts)
    return dataclasses.replace(result, info={**result.info, COMPOSITE_INFO: facts})


def _verified_start(
    instance: StudyInstance, method: WarmStarted, outcome: Any, facts: dict[str, Any], max_bytes: int
) -> tuple[Any, Scored | None]:
    """The heuristic's plan as the engine's start (cells: positions; allocation: an Allocation) and
    droneplan's verdict on it, or (None, None) with the reason in ``facts``."""
    from droneplan.studies import wire

    def cold(status: str, why: str) -> tuple[None, None]:
        facts.update(
            heuristic_status=status, heuristic_objective=None, warm_start="cold", warm_start_reason=why
        )
        return None, None

    if outcome.status != "ok":
        return cold(outcome.status, f"the heuristic's process ended with {outcome.status}: {outcome.error}")
    try:
        value = wire.decode(outcome.value, max_bytes=max_bytes)
    except (wire.WireError, TypeError) as exc:
        return cold("invalid", f"the heuristic's process sent an unreadable result: {exc}")
    heuristic = method.heuristic
    if heuristic is None:  # refused by WarmStarted; kept for the type checker
        return cold("error", "the composite has no heuristic")
    try:
        verdict = score(instance, heuristic, value)
    except Exception as exc:  # noqa: BLE001 - a plan the evaluator cannot read is no start
        return cold("invalid", f"droneplan could not score the heuristic's plan: {type(exc).__name__}: {exc}")
    if verdict.status not in _OK or verdict.objective is None:
        why = verdict.message or "no plan"
        return cold(verdict.status, f"the heuristic's plan is {verdict.status} ({why}); the engine ran cold")
    facts.update(heuristic_status=verdict.status, heuristic_objective=verdict.objective)
    plan = value.x if isinstance(value, SolveResult) else value
    if instance.kind == "allocation":
        if hasattr(plan, "target") and hasattr(plan, "direction"):
            plan = (plan.target, plan.direction)
        target, direction = (np.asarray(a).astype(int) for a in plan)
        return allocation_of(instance.data, target, direction), verdict
    return np.asarray(plan, dtype=float), verdict


def _fate(kind: str, result: SolveResult, verdict: Scored, facts: dict[str, Any]) -> None:
    """What became of a verified start: the cells engines' ``info["warm_start"]``, or the hint's
    fate on CP-SAT."""
    facts["warm_start_value"] = verdict.objective
    ws = result.info.get("warm_start") if isinstance(result.info, Mapping) else None
    if kind == "cells" and isinstance(ws, Mapping):
        facts["warm_start"] = "used" if ws.get("used") else "not used"
        facts["warm_start_reason"] = str(ws.get("reason", ""))
        facts["warm_start_polished_value"] = ws.get("polished_value")
        return
    reached = bool(result.warm_started)
    facts["warm_start"] = "used" if reached else "not used"
    answer = f"; the engine's answer {result.objective:g}" if result.objective is not None else ""
    facts["warm_start_reason"] = (
        f"handed to {result.backend or 'the engine'} as a hint (value {verdict.objective:g}){answer}"
        if reached
        else f"the engine did not take the start (value {verdict.objective:g}){answer}"
    )


def _better_of(
    kind: str, result: SolveResult, start: Any, verdict: Scored, facts: dict[str, Any]
) -> SolveResult:
    """The engine's result, or the start with the engine's bound when the engine's plan is worse
    (or missing): the composite never returns less than its verified start."""
    facts["kept"] = "engine"
    h = verdict.objective
    if h is None:
        return result
    tol = _TIE_TOL * max(1.0, abs(h))  # the engine's and droneplan's arithmetic may differ in the last bits
    worse = result.objective is None or (
        result.objective < h - tol if SENSE_OF_KIND[kind] == "max" else result.objective > h + tol
    )
    if result.has_solution and not worse:
        return result
    facts["kept"] = "heuristic"
    return dataclasses.replace(
        result,
        status=Status.FEASIBLE,
        objective=h,
        x=start,
        message=f"the engine's plan was worse than its start; the start is kept ({result.message})",
    )
