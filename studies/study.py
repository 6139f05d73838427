"""Open gap studies: the user's methods against droneplan's on families, library or own instances.

:func:`gap` is the one way to run a study. For every (instance, method) pair it runs one job (or
``runs`` jobs, each with its own seed: :func:`~droneplan.core.validation.run_seed`) in
a child process with a time limit (:mod:`droneplan.studies.runner`), scores what came back with
droneplan's own evaluator (:mod:`droneplan.studies.harness`) and writes one row to the store at
``out`` with provenance and a configuration hash (:mod:`droneplan.studies.provenance`). On
instances of the certified library (:mod:`droneplan.studies.library`) it adds a ``library`` row
with the certified value and bound instead of re-solving; on other instances of a kind with an
exact engine, a ``reference`` row solved for the study (:mod:`droneplan.studies.references`). A
rerun resumes: jobs whose row is in
the store under the same configuration are not run again; a job whose configuration changed
(code, method, parameters, time limit, instance data) is run again and its old row is set aside.

The gaps of every row (``gap_to_bound``, ``gap_to_best``) are computed when the store is read,
over the current rows of each instance.

Repeated runs: with ``runs=R`` run r of a pair gets the seed ``run_seed(instance seed, r)`` (run 0
the instance's own seed, so ``R = 1`` is the study as it always was) and its row the key column
``run``. A method declared deterministic (``Method.deterministic``) runs once; one that declares
nothing runs twice first, and when both runs return the same plan it is marked deterministic
(column ``deterministic``) and not run again. A rerun with a larger R runs only the missing runs.

Budgets and traces: ``cpu_limit`` (CPU-s) is each job's ``RLIMIT_CPU`` (with ``GRACE_S``), and
reaches a method that names a ``cpu_limit`` parameter; a method that does not gets it as its
``time_limit`` (single-threaded, it then uses at most that much CPU), and the job's wall limit
is ``CPU_WALL_FACTOR`` times it unless ``time_limit`` says otherwise. ``max_evaluations``
reaches the methods that name it (the GA, exhaustive search). A method that names a ``report``
parameter gets a :class:`~droneplan.studies.traces.Reporter`; its reports, thinned to
``MAX_TRACE_POINTS`` per run, are scored like final plans and stored in ``out/traces.sqlite``
(:func:`~droneplan.studies.trace_store.load_traces`). Each row records wall time (``time_s``),
CPU time (extra ``cpu_s``) and the evaluations the method says it used (extra ``evaluations``).
"""

from __future__ import annotations

import contextlib
import dataclasses
import hashlib
import json
import numbers
import os
import sys
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pandas as pd

from droneplan.core.validation import check_bool, check_instance, check_int, run_seed
from droneplan.solvers.result import SolveResult
from droneplan.studies import wire
from droneplan.studies.harness import Scored, execute_plain, score
from droneplan.studies.instances import StudyInstance, resolve_instances
from droneplan.studies.library import lookup
from droneplan.studies.methods import Method, check_study_time_limit, resolve_methods
from droneplan.studies.provenance import config_hash, provenance, provenance_columns
from droneplan.studies.references import REFERENCE_METHOD, check_reference, entry_row, reference_rows
from droneplan.studies.runner import CallOutcome, IsolatedCall, run_calls, run_isolated
from droneplan.studies.store import (
    LIBRARY_METHOD,
    LIBRARY_SUSPECT,
    PROBLEMS,
    STORE_NAME,
    Outcome,
    ResultStore,
    build_rows,
)
from droneplan.studies.trace_store import TRACES_NAME, TraceStore
from droneplan.studies.traces import MAX_TRACE_POINTS, score_reports, takes_report

__all__ = [
    "gap",
    "summary",
    "bench_library_study",
    "StudyPlan",
    "plan_study",
    "DEFAULT_TIME_LIMIT",
    "GRACE_S",
    "LIBRARY_METHOD",
    "MAX_RESULT_BYTES",
    "SCORE_TIME_LIMIT",
    "JOB_MEMORY_HEADROOM",
    "address_space_limit",
    "MAX_RUNS",
    "CPU_WALL_FACTOR",
    "check_runs",
    "check_budgets",
]

DEFAULT_TIME_LIMIT = 300.0
"""Per-method, per-instance wall-time limit (s) when a study is given none."""

GRACE_S = 3.0
"""How long a job may overrun its time limit before the harness kills it (s)."""


MAX_RESULT_BYTES = 64 << 20
"""The largest return value a method's process may send back (bytes of its plain-data message)."""

SCORE_TIME_LIMIT = 60.0
"""Wall time droneplan's scoring of one returned plan may take (s); past it the row is ``invalid``."""

JOB_MEMORY_HEADROOM = 8 << 30
"""Address space a job may use beyond the study process's own (bytes) when ``gap`` is given no
``memory_limit``: a forked job starts as a copy of the study process, so its limit is the study's
virtual size plus this."""

SCORE_MEMORY_HEADROOM = 2 << 30
"""Address space droneplan's scoring of one plan may use beyond the study process's own (bytes)."""

MAX_RUNS = 1000
"""The most runs per (instance, method) pair a study agrees to (``gap(runs=...)``)."""

CPU_WALL_FACTOR = 10.0
"""In a study declared in CPU seconds (``cpu_limit``) without a ``time_limit``, each job's wall
limit is this many times its CPU limit: a backstop against a method that waits without
computing, far enough that load on a shared machine does not reach it."""

STUDY = "gap"
_PLAN_HASH = "plan_hash"  # the extra (``<problem>_plan_hash``) comparing the plans of runs 0 and 1


def check_budgets(cpu_limit: Any, max_evaluations: Any) -> tuple[float | None, int | None]:
    """(cpu_limit, max_evaluations) checked: a finite number of CPU-s > 0 and an int >= 1, or
    None; a one-line ValueError naming the field otherwise.

    cpu_limit: CPU seconds per job, or None.
    max_evaluations: evaluations per job (for methods that take it), or None.
    """
    from droneplan.core.validation import check_time_limit

    try:
        cpu = check_time_limit(cpu_limit, "cpu_limit")
    except TypeError as exc:
        raise ValueError(str(exc)) from None
    if max_evaluations is not None:
        ok = isinstance(max_evaluations, numbers.Integral) and not isinstance(max_evaluations, bool)
        if not ok or int(max_evaluations) < 1:
            raise ValueError(f"max_evaluations must be an int >= 1 or None, got {max_evaluations!r}")
        max_evaluations = int(max_evaluations)
    return cpu, max_evaluations


def check_runs(runs: Any) -> int:
    """``runs`` as an int from 1 to ``MAX_RUNS``; a one-line ValueError naming ``runs`` otherwise.

    runs: the number of runs per (instance, method) pair.
    """
    ok = isinstance(runs, numbers.Integral) and not isinstance(runs, bool)
    if not ok or not 1 <= int(runs) <= MAX_RUNS:
        text = repr(runs) if len(repr(runs)) <= 40 else type(runs).__name__
        raise ValueError(
            f"runs must be an int from 1 to {MAX_RUNS} (runs per instance and method), got {text}"
        )
    return int(runs)


@dataclass(frozen=True)
class _Task:
    instance: StudyInstance
    method: Method
    config: str
    params: dict[str, Any]
    time_limit: float | None
    run: int = 0
    seed: int = 0
    deterministic: bool | None = None
    budgets: tuple[float | None, int | None] = (None, None)
    """(cpu_limit in CPU-s, max_evaluations)."""

    def job(self, key: Any) -> IsolatedCall:
        """The runner's job of this task: the method in a child, under its wall and CPU limits,
        reporting when it takes a ``report`` (static kinds)."""
        cpu_limit, max_evaluations = self.budgets
        reports = not self.instance.kind_class.closed_loop and takes_report(self.method)
        wall = self.time_limit
        method_limit = wall
        if cpu_limit is not None and not self.method.accepts("cpu_limit"):
            method_limit = cpu_limit if wall is None else min(wall, cpu_limit)
        budgets = {"cpu_limit": cpu_limit, "max_evaluations": max_evaluations, "report": reports}
        return IsolatedCall(
            key,
            execute_plain,
            (self.instance, self.method, self.seed, method_limit, budgets),
            time_limit=wall,
            returns="bytes",
            max_result_bytes=MAX_RESULT_BYTES,
            cpu_limit=cpu_limit,
            max_reports=MAX_TRACE_POINTS if reports else 0,
        )


@dataclass(frozen=True)
class StudyPlan:
    """What a study will do: its instances, methods and the jobs with their configuration hashes."""

    problem: str
    kind: str
    instances: list[StudyInstance]
    methods: list[Method]
    time_limit: float | None
    tasks: list[_Task]


def _params_json(method: Method) -> Any:
    """The method's parameters by value (:func:`~droneplan.studies.method_hash.params_value`); an
    object without a stable value is refused with a one-line ValueError naming the method."""
    from droneplan.studies.method_hash import params_value

    try:
        return params_value(dict(method.params))
    except TypeError as exc:
        raise ValueError(f"method {method.name!r}: {exc}") from None


def plan_study(
    problem: str,
    *,
    methods: Any = None,
    instances: Any = None,
    time_limit: float | None = None,
    runs: int = 1,
    cpu_limit: float | None = None,
    max_evaluations: int | None = None,
    **size: Any,
) -> StudyPlan:
    """Resolve a study's instances and methods and hash each job's configuration (runs nothing).

    problem, methods, instances, time_limit, runs, cpu_limit, max_evaluations, size: as in
    :func:`gap`. A deterministic method gets one job per instance, any other ``runs`` jobs
    (run 0 .. runs - 1).
    """
    runs = check_runs(runs)
    budgets = check_budgets(cpu_limit, max_evaluations)
    if problem not in PROBLEMS:
        raise ValueError(f"problem must be one of {', '.join(PROBLEMS)}, got {problem!r}")
    if time_limit is not None:
        limit = check_study_time_limit(time_limit)
    elif budgets[0] is not None:
        limit = CPU_WALL_FACTOR * budgets[0]
    else:
        limit = DEFAULT_TIME_LIMIT
    insts = resolve_instances(problem, instances, **size)
    kinds = sorted({i.kind for i in insts})
    if len(kinds) != 1:
        raise ValueError(f"a study runs on one kind of instance; these mix {', '.join(kinds)}")
    kind = kinds[0]
    meths = resolve_methods(kind, methods)
    reserved = [m.name for m in meths if m.name in (LIBRARY_METHOD, REFERENCE_METHOD)]
    if reserved:
        raise ValueError(f"method name {reserved[0]!r} is reserved for the instance's reference row")
    code = provenance()["code_hash"]
    tasks = []
    for inst in insts:
        fp = inst.fingerprint()
        for m in meths:
            params = _params_json(m)
            own_limit = limit if m.time_limit is None else m.time_limit
            setting = {
                "method": m.name,
                "code": m.fingerprint(),
                "params": params,
                "time_limit": own_limit,
                "instance": fp,
                "family_version": inst.version,
                "droneplan": code,
            }
            # a budget is part of the configuration only when set (older rows keep their hash)
            names = ("cpu_limit", "max_evaluations")
            setting.update({k: v for k, v in zip(names, budgets, strict=True) if v is not None})
            cfg = config_hash(setting)
            for r in range(1 if m.deterministic else runs):
                seed = run_seed(inst.seed or 0, r)
                tasks.append(_Task(inst, m, cfg, params, own_limit, r, seed, m.deterministic, budgets))
    return StudyPlan(problem, kind, insts, meths, limit, tasks)


def _row(
    task: _Task, verdict: Scored, *, time_s: float | None, cpu_s: float | None, time_limit: float | None
) -> dict:
    inst, m = task.instance, task.method
    outcome = Outcome(
        method=m.name,
        role=m.role,
        status=verdict.status,
        objective=verdict.objective,
        bound=verdict.bound,
        bound_kind=verdict.bound_kind if verdict.bound is not None else "none",
        time_s=time_s,
        warm_started=verdict.warm_started,
        message=verdict.message,
        extras={**verdict.extras, "cpu_s": cpu_s, "builtin": m.builtin},
    )
    (row,) = build_rows(
        inst.problem,
        inst.id,
        seed=inst.seed,
        size=inst.size,
        sense=inst.kind_class.sense,
        outcomes=[outcome],
        study=STUDY,
    )
    row.update(
        config=task.config,
        flag=";".join(dict.fromkeys(verdict.flags)),
        claimed_objective=verdict.claimed_objective,
        family=inst.family,
        family_version=inst.version,
        method_params=json.dumps(task.params, sort_keys=True),
        time_limit_s=time_limit,
        run=task.run,
        run_seed=task.seed,
        deterministic=task.deterministic,
        **provenance_columns(),
    )
    return row


def _library_row(inst: StudyInstance) -> dict | None:
    entry = lookup(inst)
    if entry is None:
        return None
    return entry_row(inst, entry, method=LIBRARY_METHOD, role="model", source="certified library")


def _verdict(task: _Task, outcome: CallOutcome) -> tuple[Scored, float | None]:
    """Droneplan's verdict on one job's outcome, and the time its scoring took (s; None: not scored).

    The method's plain-data message is decoded here (nothing in it is executed) and scored in a
    process of its own under :data:`SCORE_TIME_LIMIT` and a memory limit, so a plan that is costly
    to check costs the study a bounded time and no memory.
    """
    if outcome.status == "ok":
        try:
            value = wire.decode(outcome.value, max_bytes=MAX_RESULT_BYTES)
        except (wire.WireError, TypeError) as exc:
            return Scored("invalid", message=f"the method's process sent an unreadable result: {exc}"), None
        scored, score_s = _score_isolated(task, value)
        if task.deterministic is None and task.run <= 1:
            scored.extras[_PLAN_HASH] = _plan_hash(value)
        return scored, score_s
    if outcome.status == "timeout":
        return Scored("timeout", message=outcome.error), None
    if outcome.status == "crashed":
        return Scored("error", message=f"the method's process {outcome.error}"), None
    if outcome.error.startswith("the result has"):  # over MAX_RESULT_BYTES
        return Scored("invalid", message=outcome.error), None
    # the method's own traceback (its last frames) helps its author; the row keeps the one-line cause
    return Scored("error", message=outcome.error, extras={"traceback": outcome.traceback[-2000:]}), None


def _plan_hash(value: Any) -> str | None:
    """A digest (16 hex) of the plan a method returned (a ``SolveResult``'s ``x``, else the value:
    positions, an assignment, a closed-loop run's metrics), to tell whether two runs agree."""
    plan = value.x if isinstance(value, SolveResult) else value
    try:
        return hashlib.sha256(wire.encode(plan)).hexdigest()[:16]
    except (wire.NotPlainError, TypeError, ValueError):
        return None


def _score_isolated(task: _Task, value: Any) -> tuple[Scored, float]:
    """:func:`~droneplan.studies.harness.score` run in a forked child with a time and memory budget."""
    job = IsolatedCall("score", score, (task.instance, task.method, value), time_limit=SCORE_TIME_LIMIT)
    oc = run_isolated(job, grace=1.0, memory_limit=address_space_limit(SCORE_MEMORY_HEADROOM))
    if oc.status == "ok" and isinstance(oc.value, Scored):
        return oc.value, oc.wall_s
    if oc.status == "timeout":
        why = f"scoring the plan took longer than {SCORE_TIME_LIMIT:g} s"
    elif oc.status == "error" and oc.error.startswith("MemoryError"):
        why = f"scoring the plan needed more than {SCORE_MEMORY_HEADROOM >> 30} GiB"
    else:
        why = f"could not score the return value: {oc.error}"
    return Scored("invalid", message=why), oc.wall_s


def address_space_limit(headroom: int) -> int | None:
    """This process's virtual size plus ``headroom`` (bytes): an ``RLIMIT_AS`` for a forked child
    that may allocate ``headroom`` more; None where the size cannot be read (no ``/proc``)."""
    try:
        with open("/proc/self/status", encoding="ascii") as fh:
            for line in fh:
                if line.startswith("VmSize:"):
                    return int(line.split()[1]) * 1024 + headroom
    except (OSError, ValueError, IndexError):
        return None
    return None


@contextlib.contextmanager
def _dask_outcomes(
    address: str | None, jobs: list[IsolatedCall], grace: float, headroom: int, executor: Any = None
) -> Iterator[Iterator[CallOutcome]]:
    """Outcomes of ``jobs`` computed on a Dask cluster (each job isolated in a child on its worker,
    whose result comes back as the bytes of its plain-data message, decoded and scored here)."""
    import concurrent.futures as cf

    from droneplan.studies.common import make_executor

    with contextlib.ExitStack() as stack:
        ex = executor if executor is not None else stack.enter_context(make_executor(dask_address=address))
        futures = [ex.submit(_run_on_worker, job, grace, headroom) for job in jobs]

        def gen() -> Iterator[CallOutcome]:
            for fut in cf.as_completed(futures):
                yield fut.result()

        yield gen()


def _run_on_worker(job: IsolatedCall, grace: float, headroom: int) -> CallOutcome:
    """One job in a child of this (Dask worker) process, with ``headroom`` bytes of address space
    beyond this process's own."""
    return run_isolated(job, grace=grace, memory_limit=address_space_limit(headroom))


def _run_options(workers: Any, dask: Any, progress: Any, store: Any, executor: Any) -> tuple[int, Any]:
    """(jobs at once, the Dask executor or None) from :func:`gap`'s run options, each checked by name."""
    from droneplan.studies.common import StudyExecutor

    check_bool("progress", progress)
    check_instance("store", store, ResultStore, optional=True)
    check_instance("executor", executor, StudyExecutor, optional=True)
    if dask is not None and not isinstance(dask, str):
        raise TypeError(f"dask must be a scheduler address (str) or None, got {type(dask).__name__}")
    n_workers = (os.cpu_count() or 1) if workers is None else check_int("workers", workers, min_value=1)
    if executor is None:
        return n_workers, None
    if executor.kind == "dask":
        return n_workers, executor
    return executor.slots, None


def gap(
    problem: str,
    *,
    methods: Any = None,
    instances: Any = None,
    out: str | os.PathLike,
    workers: int | None = None,
    dask: str | None = None,
    time_limit: float | None = None,
    progress: bool = True,
    store: ResultStore | None = None,
    executor: Any = None,
    memory_limit: int | None = None,
    runs: int = 1,
    cpu_limit: float | None = None,
    max_evaluations: int | None = None,
    reference: str = "auto",
    reference_time_limit: float | None = None,
    **size: Any,
) -> pd.DataFrame:
    """Run a gap study of ``methods`` on ``instances`` and return its rows (long format).

    problem: ``cells``, ``herding``, ``shark`` or ``covert``.
    methods: registered names (``"ga"``, ``"exhaustive"``, ``"bnb"``, ``"milp"``, ``"exact"``,
        ``"alg3"``, ``"virtual-shark"``, ``"sliding"`` ...), ``"module:function"`` strings, the
        user's functions or controller classes, ``(name, target)`` pairs or
        :class:`~droneplan.studies.methods.Method` objects (one or a list; contracts in
        :mod:`droneplan.studies.methods`); None: on covert runs and shark paths the built-in
        controllers and bound engines (``methods.DEFAULT_METHODS``), elsewhere an error.
    instances: None (the problem's default family), a family name, a path to an instance file or
        directory, or a list of instances / data objects
        (:func:`~droneplan.studies.instances.resolve_instances`).
    out: directory of the results store (``out/results.sqlite``, exported to ``results.csv`` and
        ``results.parquet`` after the run).
    workers: jobs run at once on this machine (default: the number of cores).
    dask: address of a Dask scheduler to run the jobs on instead.
    time_limit: wall-time limit per method and instance (s; default ``DEFAULT_TIME_LIMIT``); a job
        still running ``GRACE_S`` after it is killed and recorded as ``timeout``.
    progress: show a progress bar.
    store: an open :class:`~droneplan.studies.store.ResultStore` to write to instead of
        ``out/results.sqlite`` (the built-in studies share one).
    executor: a :class:`~droneplan.studies.common.StudyExecutor` whose kind decides where the jobs
        run (serial: one at a time; processes: as many as its slots; dask: on its cluster), instead
        of ``workers``/``dask``.
    memory_limit: address space each job may use beyond the study process's own (bytes; default
        ``JOB_MEMORY_HEADROOM``, 8 GiB), applied as ``RLIMIT_AS`` of its process: an allocation past
        it fails in the method (an ``error`` row naming MemoryError) instead of exhausting the machine.
    runs: runs per (instance, method) pair, 1 to ``MAX_RUNS`` (default 1); run r gets the seed
        :func:`~droneplan.core.validation.run_seed` ``(instance seed, r)`` (run 0 the instance's own)
        and the row's ``run``/``run_seed``; a deterministic method runs once (module docstring).
    cpu_limit: CPU seconds per job (None: none): the job's ``RLIMIT_CPU`` (with ``GRACE_S``), a
        budget that does not shrink with the load; passed to methods that name a ``cpu_limit``
        parameter, and the ``time_limit`` of those that do not (module docstring). Without a
        ``time_limit`` the wall limit is ``CPU_WALL_FACTOR`` times it.
    max_evaluations: an evaluation budget per job for the methods that name a
        ``max_evaluations`` parameter (the GA: fitness evaluations; exhaustive search: last-cell
        searches); None: none.
    reference: ``"auto"`` (default): an instance the certified library does not hold, of a kind
        with an exact engine (cells, moving users, fleet size, allocation, shark fleets), gets its
        reference solved by that engine (unless the study runs it), kept in a local library under
        ``out`` and reported as a row of method ``reference``, role ``bound``
        (:mod:`droneplan.studies.references`); ``"none"``: no solve, one line says how many
        instances have no proven reference.
    reference_time_limit: wall time per reference solve (s; default
        ``references.DEFAULT_REFERENCE_TIME_LIMIT``, 300 s); past it the engine's best plan and
        bound are the (unproven) reference.
    size: the family's size parameters (``m=4``, ``n=[8, 16]``) and ``seeds``, ``first_seed``.

    Returns the current rows of these instances for these methods and their references (library
    or solved), with gaps filled in; rows already in the store under the same configuration are
    reused, not rerun.
    """
    n_workers, dask_executor = _run_options(workers, dask, progress, store, executor)
    headroom = (
        JOB_MEMORY_HEADROOM if memory_limit is None else check_int("memory_limit", memory_limit, min_value=1)
    )
    runs = check_runs(runs)
    reference, reference_limit = check_reference(reference, reference_time_limit)
    plan = plan_study(
        problem,
        methods=methods,
        instances=instances,
        time_limit=time_limit,
        runs=runs,
        cpu_limit=cpu_limit,
        max_evaluations=max_evaluations,
        **size,
    )
    out = Path(out)
    execution = _Execution(n_workers, dask, dask_executor, headroom, f"{problem} gap" if progress else None)
    with contextlib.ExitStack() as stack:
        if store is None:
            store = stack.enter_context(ResultStore(out / STORE_NAME))
        if any(not t.instance.kind_class.closed_loop and takes_report(t.method) for t in plan.tasks):
            execution.traces = stack.enter_context(TraceStore(Path(store.path).parent / TRACES_NAME))
        store.bind_instances(problem, {i.id: i.fingerprint() for i in plan.instances})
        done = store.done_keys(problem)
        lib_rows = [r for r in (_library_row(i) for i in plan.instances) if r is not None]
        lib_rows += reference_rows(
            plan.instances,
            plan.methods,
            out=out,
            reference=reference,
            time_limit=reference_limit,
            workers=n_workers,
            progress=progress,
        )
        set_aside = store.write([r for r in lib_rows if _key(r) not in done]) if lib_rows else 0
        todo = [t for t in plan.tasks if _task_key(problem, t) not in done]
        first = [t for t in todo if _first_batch(t)]
        jobs = execution.run(store, problem, first)
        pruned = 0
        if runs > 1:
            same = _settle_determinism(store, plan)
            later = [t for t in todo if not _first_batch(t)]
            kept = [
                dataclasses.replace(t, deterministic=False) if t.deterministic is None else t
                for t in later
                if (t.instance.id, t.method.name) not in same
            ]
            pruned = len(later) - len(kept)
            jobs.add(execution.run(store, problem, kept))
        _report_counts(len(plan.tasks) - pruned, jobs.ran, jobs.busy, set_aside + jobs.set_aside)
        df = store.frame(problem=problem)
        out.mkdir(parents=True, exist_ok=True)
        for suffix in ("csv", "parquet"):
            store.export(out / f"results.{suffix}")
    wanted_ids = {i.id for i in plan.instances}
    wanted_methods = {m.name for m in plan.methods} | {LIBRARY_METHOD, REFERENCE_METHOD}
    mask = df["instance"].isin(wanted_ids) & df["method"].isin(wanted_methods) & (df["run"] < runs)
    found = df[mask].reset_index(drop=True)
    _report_suspect_library(found)
    return found


@dataclass
class _Execution:
    """Where and how a study's jobs run (the options of :func:`gap`)."""

    workers: int
    dask: str | None
    dask_executor: Any
    headroom: int
    progress: str | None
    traces: TraceStore | None = None

    def run(self, store: ResultStore, problem: str, tasks: list[_Task]) -> _ClaimedJobs:
        """Run ``tasks`` (each claimed in ``store`` just before it starts) and write one row per job."""
        jobs = _ClaimedJobs(store, problem, tasks)
        if not tasks:
            return jobs
        try:
            with (
                _dask_outcomes(self.dask, list(jobs), GRACE_S, self.headroom, self.dask_executor)
                if self.dask or self.dask_executor is not None
                else contextlib.nullcontext(
                    run_calls(
                        jobs,
                        workers=self.workers,
                        grace=GRACE_S,
                        progress=self.progress,
                        memory_limit=address_space_limit(self.headroom),
                    )
                )
            ) as outcomes:
                for oc in outcomes:
                    task = jobs.by_key[oc.key]  # type: ignore[index]
                    verdict, score_s = _verdict(task, oc)
                    verdict.extras["score_time_s"] = score_s
                    if oc.n_reports and self.traces is not None:
                        _record_trace(self.traces, _task_key(problem, task), task, oc, verdict)
                    row = _row(task, verdict, time_s=oc.wall_s, cpu_s=oc.cpu_s, time_limit=task.time_limit)
                    jobs.set_aside += store.write([row])  # writing a row ends its claim
                    jobs.in_flight.discard(oc.key)
        finally:
            jobs.release_unfinished()
        return jobs


def _record_trace(traces: TraceStore, key: tuple, task: _Task, oc: CallOutcome, verdict: Scored) -> None:
    """Score the reports of one run (in a child, like a final plan), store them as its trace and
    note them on the row: ``reports`` (how many the method made), ``trace_points`` (kept), and
    the flag ``trace-claim-mismatch`` when a report's claim differs from droneplan's score."""
    job = IsolatedCall(
        "trace", score_reports, (task.instance, task.method, oc.reports), time_limit=SCORE_TIME_LIMIT
    )
    scored = run_isolated(job, grace=1.0, memory_limit=address_space_limit(SCORE_MEMORY_HEADROOM))
    verdict.extras["reports"] = oc.n_reports
    if scored.status != "ok" or not isinstance(scored.value, list):
        verdict.extras["trace_error"] = scored.error or f"scoring the reports gave {scored.status}"
        return
    points = scored.value
    verdict.extras["trace_points"] = traces.write(key, points)
    if any("claim-mismatch" in (p.get("flag") or "") for p in points):
        verdict.flags.append("trace-claim-mismatch")


def _first_batch(t: _Task) -> bool:
    """Whether a task runs before the determinism of its method is settled: run 0, and run 1 of a
    method that declares none."""
    return t.run == 0 or (t.run == 1 and t.deterministic is None)


def _settle_determinism(store: ResultStore, plan: StudyPlan) -> set[tuple[str, str]]:
    """The (instance id, method) pairs of methods declaring no determinism whose runs 0 and 1
    returned the same plan (equal ``plan_hash``; a run that returned nothing readable has none):
    their two rows are marked deterministic (the others' rows, stochastic) and no further run is
    made of them."""
    undecided = {
        (t.instance.id, t.method.name): t for t in plan.tasks if t.deterministic is None and t.run == 1
    }
    if not undecided:
        return set()
    df = store.frame(problem=plan.problem)
    column = f"{plan.problem}_{_PLAN_HASH}"
    same: set[tuple[str, str]] = set()
    keys: dict[bool, list[tuple[str, str, str, str, int]]] = {True: [], False: []}
    for pair, task in undecided.items():
        rows = df[(df["instance"] == pair[0]) & (df["method"] == pair[1]) & (df["config"] == task.config)]
        hashes = {int(r["run"]): r.get(column) for _, r in rows.iterrows()}
        h0, h1 = hashes.get(0), hashes.get(1)
        agree = isinstance(h0, str) and h0 == h1
        if agree:
            same.add(pair)
        keys[agree] += [(plan.problem, pair[0], pair[1], task.config, r) for r in (0, 1)]
    for value, marked in keys.items():
        if marked:
            store.mark_deterministic(marked, value)
    return same


def _report_suspect_library(df: pd.DataFrame) -> None:
    """One line on stderr per certified-library entry that a verified plan of this study beats."""
    suspect = df[(df["method"] == LIBRARY_METHOD) & df["flag"].fillna("").str.contains(LIBRARY_SUSPECT)]
    for _, lib in suspect.iterrows():
        rows = df[(df["instance"] == lib["instance"]) & (df["method"] != LIBRARY_METHOD)]
        best = rows.loc[rows["objective"].idxmax() if lib["sense"] == "max" else rows["objective"].idxmin()]
        print(
            f"droneplan: the certified library entry of {lib['instance']} is suspect: {best['method']}'s "
            f"plan, verified by droneplan, scores {best['objective']:g} beyond its proven bound "
            f"{lib['bound']:g}; recheck it with `droneplan certify {lib['family']} --verify`",
            file=sys.stderr,
            flush=True,
        )


class _ClaimedJobs:
    """The study's jobs, each claimed in the store just before it starts (lazily, as the runner
    asks for the next one), so a job another study on the same store has claimed or finished is
    skipped, and an interrupt has only the few jobs in flight to release."""

    def __init__(self, store: ResultStore, problem: str, todo: list[_Task]) -> None:
        self.store, self.problem, self.todo = store, problem, todo
        self.by_key = {(t.instance.id, t.method.name, t.run): t for t in todo}
        self.in_flight: set[tuple[str, str, int]] = set()
        self.ran = self.busy = self.set_aside = 0

    def add(self, other: _ClaimedJobs) -> None:
        """Count the jobs of ``other`` (a later batch of the same study) with these."""
        self.ran, self.busy = self.ran + other.ran, self.busy + other.busy
        self.set_aside += other.set_aside

    def __len__(self) -> int:
        return len(self.todo)

    def _store_key(self, t: _Task) -> tuple:
        return _task_key(self.problem, t)

    def __iter__(self) -> Iterator[IsolatedCall]:
        for t in self.todo:
            if not self.store.try_claim(self._store_key(t)):
                self.busy += 1
                continue
            self.ran += 1
            key = (t.instance.id, t.method.name, t.run)
            self.in_flight.add(key)
            yield t.job(key)

    def release_unfinished(self) -> None:
        """Give back the claims of jobs that started but wrote no row (an interrupt, an error)."""
        for key in list(self.in_flight):
            with contextlib.suppress(Exception):
                self.store.release(self._store_key(self.by_key[key]))
        self.in_flight.clear()


def _key(row: dict) -> tuple:
    return (row["problem"], row["instance"], row["method"], row["config"], int(row.get("run") or 0))


def _task_key(problem: str, t: _Task) -> tuple[str, str, str, str, int]:
    """The store key of a task's row."""
    return (problem, t.instance.id, t.method.name, t.config, t.run)


def _report_counts(total: int, ran: int, busy: int, set_aside: int) -> None:
    parts = [f"{ran} of {total} jobs run", f"{total - ran - busy} reused from the store"]
    if busy:
        parts.append(f"{busy} running in another study on the same store (not repeated)")
    if set_aside:
        parts.append(f"{set_aside} older rows computed under other settings set aside")
    print("droneplan gap: " + "; ".join(parts), file=sys.stderr, flush=True)


def bench_library_study(
    out: str | os.PathLike,
    *,
    method: Any = "greedy",
    m: int = 3,
    seeds: int = 100,
    resolve: int = 3,
    workers: int = 2,
) -> dict[str, float]:
    """Time a study of a cheap method over library instances against re-solving their optima, in one run.

    out: a scratch directory for the study's store. method: the method studied. m, seeds: the
    Table 4.2 instances (m drone-cells, seeds 0 .. seeds - 1). resolve: how many of them are
    re-solved by the exact branch and bound to estimate what re-solving all would cost (s).
    workers: jobs at once.
    Returns wall and CPU seconds of the study, the estimated wall time of re-solving every
    instance on ``workers`` cores, their ratio and the 1-minute load average before and after.
    """
    import resource
    import time

    from droneplan.formulations.cells import solve_exact
    from droneplan.studies.instances import family_instances

    def cpu() -> float:
        own, kids = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
        return own.ru_utime + own.ru_stime + kids.ru_utime + kids.ru_stime

    load0 = os.getloadavg()[0]
    c0, t0 = cpu(), time.perf_counter()
    df = gap("cells", methods=[method], m=m, seeds=seeds, out=out, workers=workers, progress=False)
    wall, cpu_s = time.perf_counter() - t0, cpu() - c0
    if (df["method"] == LIBRARY_METHOD).sum() < seeds:
        raise RuntimeError(f"the library lacks some of the {seeds} instances at m={m}")
    times = []
    for inst in family_instances("table4.2", m=m, seeds=resolve):
        t1 = time.perf_counter()
        solve_exact(inst.data, engine="bnb", workers=1)
        times.append(time.perf_counter() - t1)
    resolve_wall = sum(times) / len(times) * seeds / workers
    return {
        "study_wall_s": wall,
        "study_cpu_s": cpu_s,
        "resolve_wall_s_estimate": resolve_wall,
        "ratio": wall / resolve_wall,
        "load_before": load0,
        "load_after": os.getloadavg()[0],
    }


def summary(df: pd.DataFrame) -> pd.DataFrame:
    """The per-method summary of a study's rows (:func:`droneplan.studies.analysis.summary_table`)."""
    from droneplan.studies.analysis import summary_table

    return summary_table(df)
