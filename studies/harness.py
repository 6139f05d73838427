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
import time
from collections.abc import Mapping
from typing import Any

from droneplan.solvers.result import SolveResult, Status
from droneplan.studies.instances import StudyInstance
from droneplan.studies.kinds import KINDS
from droneplan.studies.kinds.herding import HERDING_T_MAX, allocation_of
from droneplan.studies.methods import Method, WarmStarted
from droneplan.studies.scoring import COMPOSITE_INFO, Scored, describe, number

SENSE_OF_KIND = {name: kind.sense for name, kind in KINDS.items()}
"""The direction in which each kind's objective is better (a view of the kind classes)."""

STATIC_KINDS = tuple(name for name, kind in KINDS.items() if not kind.closed_loop)
"""The kinds whose methods return a plan (the others run a controller in a simulator)."""


def method_arguments(instance: StudyInstance) -> tuple[Any, ...]:
    """The positional arguments a method of a static kind is called with (its kind's
    :meth:`~droneplan.studies.kinds.base.Kind.arguments`); arrays are copies.

    instance: an instance of one of ``STATIC_KINDS``.
    """
    kind = instance.kind_class
    if kind.closed_loop:
        raise ValueError(f"instance kind {instance.kind!r} is not one of {', '.join(STATIC_KINDS)}")
    return kind.arguments(instance.data)


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
    kind = instance.kind_class
    if not kind.closed_loop:
        if isinstance(method, WarmStarted):
            return run_warm_started(instance, method, seed, time_limit, budgets)
        extra = _method_keywords(method, budgets or {})
        return kind.execute(instance.data, method, seed=seed, time_limit=time_limit, **extra)
    if method.is_bound_engine:
        return method.call(instance.data, seed=seed, time_limit=time_limit)
    from droneplan.studies.sandbox import ControllerFailed, ControllerProcess

    t0 = time.perf_counter()
    with ControllerProcess(method.controller) as ctl:
        try:
            metrics = kind.simulate(instance.data, ctl, seed)
        except ControllerFailed as exc:
            metrics = {"controller_failed": str(exc), "failure_status": exc.status}
        metrics["method_time_s"] = ctl.method_time_s
    metrics["simulation_time_s"] = max(0.0, time.perf_counter() - t0 - metrics["method_time_s"])
    return metrics


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


# --------------------------------------------------------------------------- in the parent


def _score_bound_engine(returned: Mapping[str, Any]) -> Scored:
    """A registered bound engine's result: its status, proven bound (of a ranked kind) and extras."""
    from droneplan.studies.store import BOUND_KINDS

    status = str(returned.get("status", ""))
    if status not in ("optimal", "no_solution"):
        return Scored("error", message=f"internal: a bound engine returned status {describe(status)}")
    bound = number(returned.get("bound"))
    kind = str(returned.get("bound_kind", "none"))
    if bound is not None and (kind not in BOUND_KINDS or kind == "none"):
        return Scored("error", message=f"internal: a bound engine returned bound kind {describe(kind)}")
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
    kind = instance.kind_class
    if kind.closed_loop:
        if not isinstance(returned, Mapping):
            return Scored("error", message=f"internal: the simulation returned {describe(returned)}")
        if method.is_bound_engine:
            return _score_bound_engine(returned)
    return kind.score(instance, returned, method)


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
    from droneplan.studies.runner import IsolatedCall, run_isolated

    t0 = time.perf_counter()
    h_limit = None if time_limit is None else HEURISTIC_SHARE * time_limit
    h_budgets = {k: v for k, v in (budgets or {}).items() if k in BUDGET_KEYWORDS}
    job = IsolatedCall(
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
        _fate(result, verdict, facts)
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
    return instance.kind_class.warm_start(instance.data, plan), verdict


def _fate(result: SolveResult, verdict: Scored, facts: dict[str, Any]) -> None:
    """What became of a verified start: the engine's own account (``info["warm_start"]``, as the
    cells engines give it), or the hint's fate on CP-SAT."""
    facts["warm_start_value"] = verdict.objective
    ws = result.info.get("warm_start") if isinstance(result.info, Mapping) else None
    if isinstance(ws, Mapping):  # the cells engines say what became of their start
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
