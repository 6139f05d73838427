"""Reproductions as a graph of jobs, scheduled together on one executor.

A reproduction (``droneplan reproduce``) is a list of :class:`Job`: simulations, solves and
study tasks that produce results, and the steps that turn those results into the thesis's
tables and figures. Each job names the jobs it needs; :func:`run_jobs` runs every job whose
inputs are ready, the ones heading the longest chains of estimated work first, so the jobs
of all problems share one pool and its cores stay busy. Jobs that write rows of the results
store (:func:`row_jobs`) are skipped when the store already holds their rows, so an
interrupted reproduction resumes. Every job's wall and CPU time is measured where it runs,
and :func:`time_table` sums them per section.

This is droneplan's one execution stack. A job with a ``time_limit`` or ``memory_limit`` runs
in a forked child of the worker that takes it (:func:`droneplan.studies.runner.run_isolated`,
the isolated, time-limited runner below the graph), so it can be killed without losing the
worker. :func:`map_rows`, the store tasks of the built-in studies, is the graph of independent
store-task jobs.
"""

from __future__ import annotations

import concurrent.futures as cf
import contextlib
import os
import sys
import time
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from typing import Any

import pandas as pd
from tqdm.auto import tqdm

from droneplan.core.validation import check_int, check_time_limit
from droneplan.studies.common import (
    StudyError,
    StudyExecutor,
    TaskFn,
    _call_task,
    _InterruptGuard,
    _Recorder,
    task_config,
)
from droneplan.studies.store import COLUMNS, ResultStore, error_row

__all__ = [
    "TIMES_NAME",
    "JOB_TIMES_NAME",
    "Job",
    "JobTiming",
    "JobsFailed",
    "JobLimitExceeded",
    "ISOLATION_GRACE_S",
    "row_jobs",
    "run_jobs",
    "map_rows",
    "time_table",
    "idle_estimate",
    "run_reproduction",
]

TIMES_NAME = "reproduce_times.csv"
"""The per-section time table a reproduction writes in its ``--out`` folder (:func:`time_table`;
its ``total`` row's ``span_s`` is the run's wall time, s)."""
JOB_TIMES_NAME = "reproduce_job_times.csv"
"""The per-job timings a reproduction writes beside :data:`TIMES_NAME`."""


@dataclass(frozen=True)
class Job:
    """One unit of a reproduction.

    key: unique name (``"covert/case1/sliding"``); section: the row of the time table it counts
    in (``"covert case 1"``); fn: a module-level function (picklable), called as
    ``fn(**kwargs, **{name: result of job key for name, key in needs.items()})``; needs: the
    jobs whose results it takes, by parameter name; after: jobs that must finish first whose
    results it does not take (e.g. the store rows a table reads); cost: estimated CPU seconds,
    used to run the longest chains first; task: for a store task (:func:`row_jobs`), the task
    mapping whose rows the job writes; local: the job writes files under ``--out`` or reads the
    store by its path, so on a Dask cluster (whose workers may be other machines) it runs in the
    scheduling process (local process pools share the machine and run it like any other);
    time_limit: wall seconds the job may take, or None (no limit); memory_limit: the
    address-space limit of the job in bytes, or None. With either set, the job runs in a forked
    child of its worker (:func:`droneplan.studies.runner.run_isolated`, killed
    :data:`ISOLATION_GRACE_S` after its limit): a job that overruns, crashes or exhausts its
    memory fails with the runner's one-line message (a store task gets an error row) and the
    worker goes on.
    """

    key: str
    section: str
    fn: Callable[..., Any]
    kwargs: Mapping[str, Any] = field(default_factory=dict)
    needs: Mapping[str, str] = field(default_factory=dict)
    after: tuple[str, ...] = ()
    cost: float = 1.0
    task: Mapping[str, Any] | None = None
    local: bool = False
    time_limit: float | None = None
    memory_limit: int | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "time_limit", check_time_limit(self.time_limit))
        if self.memory_limit is not None:
            object.__setattr__(
                self, "memory_limit", check_int("memory_limit", self.memory_limit, min_value=1)
            )

    @property
    def isolated(self) -> bool:
        """Whether the job runs in a child process of its own (it has a time or memory limit)."""
        return self.time_limit is not None or self.memory_limit is not None


ISOLATION_GRACE_S = 2.0
"""Seconds an isolated job may overrun its ``time_limit`` before its child is killed."""


class JobLimitExceeded(RuntimeError):
    """An isolated job timed out, crashed or raised in its child; the message is the runner's."""


def _isolated(
    fn: Callable[..., Any], kwargs: Mapping[str, Any], limits: tuple[float | None, int | None]
) -> Any:
    """Run ``fn(**kwargs)`` in a forked child with ``limits`` (time limit s, memory bytes)."""
    from droneplan.studies.runner import IsolatedCall, run_isolated

    time_limit, memory_limit = limits
    outcome = run_isolated(
        IsolatedCall("job", fn, kwargs=dict(kwargs), time_limit=time_limit),
        grace=ISOLATION_GRACE_S,
        memory_limit=memory_limit,
    )
    if outcome.status != "ok":
        raise JobLimitExceeded(outcome.error)
    return outcome.value


@dataclass(frozen=True)
class JobTiming:
    """Where one job's time went: ``wall`` and ``cpu`` in s measured in the process that ran
    it, ``start``/``end`` in s since the run began (as seen by the scheduler)."""

    key: str
    section: str
    wall: float
    cpu: float
    start: float
    end: float
    skipped: bool = False


class JobsFailed(StudyError):
    """Some jobs raised; the message names them (jobs that needed them did not run) and
    ``timings`` holds the timing of every job that ran."""

    timings: list[JobTiming]


def row_jobs(
    fn: TaskFn, tasks: Iterable[Mapping[str, Any]], *, section: str, cost: float | Callable[[Mapping], float]
) -> list[Job]:
    """One :class:`Job` per store task: runs ``fn(task)`` (as :func:`map_rows` does,
    an exception becomes an error row) and the scheduler writes the rows to the store.

    fn: the task function (module-level); tasks: mappings with ``problem`` and ``instance``;
    section: the time-table row; cost: estimated CPU seconds per task, a number or a function
    of the task. The job keys are ``problem/instance``.
    """
    jobs = []
    for t in tasks:
        c = cost(t) if callable(cost) else cost
        jobs.append(
            Job(
                f"{t['problem']}/{t['instance']}",
                section,
                _call_task,
                {"fn": fn, "task": t},
                cost=float(c),
                task=dict(t),
            )
        )
    return jobs


def _cpu_s() -> float:
    """CPU seconds of this process and of the child processes it has waited for."""
    import resource

    kids = resource.getrusage(resource.RUSAGE_CHILDREN)
    return time.process_time() + kids.ru_utime + kids.ru_stime


def _timed(fn: Callable[..., Any], kwargs: Mapping[str, Any]) -> tuple[Any, float, float]:
    """Run ``fn(**kwargs)`` and return (result, wall s, CPU s of this process and of the child
    processes the job waited for, e.g. the jobs of a gap study it ran)."""
    w0, c0 = time.perf_counter(), _cpu_s()
    result = fn(**kwargs)
    return result, time.perf_counter() - w0, _cpu_s() - c0


def _priorities(jobs: Mapping[str, Job]) -> dict[str, float]:
    """Each job's cost plus the costliest chain of jobs waiting on it (the longest-first key)."""
    users: dict[str, list[str]] = {k: [] for k in jobs}
    for j in jobs.values():
        for dep in (*j.needs.values(), *j.after):
            users[dep].append(j.key)
    level: dict[str, float] = {}

    def visit(k: str) -> float:
        if k not in level:
            level[k] = jobs[k].cost + max((visit(u) for u in users[k]), default=0.0)
        return level[k]

    for k in jobs:
        visit(k)
    return level


def _check(jobs: list[Job]) -> dict[str, Job]:
    by_key: dict[str, Job] = {}
    for j in jobs:
        if j.key in by_key:
            raise ValueError(f"jobs repeat the key {j.key!r}")
        by_key[j.key] = j
    for j in jobs:
        missing = [d for d in (*j.needs.values(), *j.after) if d not in by_key]
        if missing:
            raise ValueError(f"job {j.key!r} needs unknown jobs {missing}")
    seen: dict[str, int] = {}

    def acyclic(k: str) -> None:
        state = seen.get(k)
        if state == 2:
            return
        if state == 1:
            raise ValueError(f"jobs form a cycle through {k!r}")
        seen[k] = 1
        for d in (*by_key[k].needs.values(), *by_key[k].after):
            acyclic(d)
        seen[k] = 2

    for k in by_key:
        acyclic(k)
    return by_key


class _Run:
    """The state of one :func:`run_jobs` call."""

    def __init__(self, jobs: list[Job], store: ResultStore | None):
        self.jobs = _check(jobs)
        self.order = {k: i for i, k in enumerate(self.jobs)}
        if store is None and any(j.task is not None for j in jobs):
            raise ValueError("store tasks among the jobs need a store")
        self.store = store
        self.prio = _priorities(self.jobs)
        self.waiting = {k: set(j.needs.values()) | set(j.after) for k, j in self.jobs.items()}
        self.users: dict[str, list[str]] = {k: [] for k in self.jobs}
        for k, deps in self.waiting.items():
            for d in deps:
                self.users[d].append(k)
        self.results: dict[str, Any] = {}
        self.timings: list[JobTiming] = []
        self.failed: dict[str, str] = {}
        self.t0 = time.perf_counter()
        self.configs: dict[tuple[str, str], str] = {}
        done = store.done_configs() if store is not None else set()
        self.done_rows: set[str] = set()
        for j in self.jobs.values():
            if j.task is not None:
                pi = (str(j.task["problem"]), str(j.task["instance"]))
                self.configs[pi] = task_config(j.task)
                if (*pi, self.configs[pi]) in done:
                    self.done_rows.add(j.key)
        self.done_rows |= self._only_feeding(self.done_rows)
        self.recorder = _Recorder(store, self.configs, tqdm(disable=True)) if store is not None else None

    def _only_feeding(self, done: set[str]) -> set[str]:
        """Jobs whose every user is in ``done`` or among them (work only resumed tasks needed)."""
        skip: set[str] = set()
        changed = True
        while changed:
            changed = False
            for k, us in self.users.items():
                if (
                    self.jobs[k].task is None
                    and k not in done
                    and k not in skip
                    and us
                    and all(u in done or u in skip for u in us)
                ):
                    skip.add(k)
                    changed = True
        return skip

    def ready(self) -> list[str]:
        """The jobs whose inputs are all in, in the order to start them: store tasks first (they
        are cheap and put finished work on disk, so a long run stopped midway keeps it and frees
        its inputs' results), then the longest chains; ties in the order the jobs were given."""
        keys = [k for k, deps in self.waiting.items() if not deps]
        return sorted(keys, key=lambda k: (self.jobs[k].task is None, -self.prio[k], self.order[k]))

    def start(self, key: str) -> tuple[Callable[..., Any], dict[str, Any]] | None:
        """Take ``key`` off the waiting list; its call, or None when there is nothing to run."""
        del self.waiting[key]
        job = self.jobs[key]
        if key in self.done_rows:
            self.finish(key, None, 0.0, 0.0, time.perf_counter() - self.t0, skipped=True)
            return None
        bad = [d for d in (*job.needs.values(), *job.after) if d in self.failed]
        if bad and job.task is not None:  # as in map_rows: an error row, retried on the next run
            self.finish(key, self._error_rows(job, f"{bad[0]} failed: {self.failed[bad[0]]}"), 0.0, 0.0, 0.0)
            return None
        if bad:
            self.failed[key] = f"not run: {bad[0]} failed"
            self.release(key)
            return None
        kwargs = dict(job.kwargs)
        kwargs.update({name: self.results[dep] for name, dep in job.needs.items()})
        if job.isolated:
            return _isolated, {"fn": job.fn, "kwargs": kwargs, "limits": (job.time_limit, job.memory_limit)}
        return job.fn, kwargs

    @staticmethod
    def _error_rows(job: Job, message: str) -> list[dict]:
        t = job.task or {}
        return [error_row(t["problem"], t["instance"], message, seed=t.get("seed"), size=t.get("size"))]

    def fail(self, key: str, exc: BaseException) -> None:
        """Record that ``key`` raised: a store task gets an error row, any other job fails."""
        job = self.jobs[key]
        message = f"{type(exc).__name__}: {exc}"
        if job.task is not None:
            self.finish(key, self._error_rows(job, message), 0.0, 0.0, 0.0)
            return
        self.failed[key] = message
        self.release(key)

    def finish(
        self, key: str, result: Any, wall: float, cpu: float, start: float, *, skipped: bool = False
    ) -> None:
        job = self.jobs[key]
        now = time.perf_counter() - self.t0
        self.timings.append(JobTiming(key, job.section, wall, cpu, start, now, skipped))
        if job.task is not None:
            if result is not None and self.recorder is not None:
                self.recorder.write(job.task, result)
            result = None
        self.results[key] = result
        self.release(key)

    def release(self, key: str) -> None:
        for u in self.users[key]:
            if u in self.waiting:
                self.waiting[u].discard(key)
        # forget results nobody still waits for
        for d in (*self.jobs[key].needs.values(),):
            if all(u not in self.waiting for u in self.users[d]):
                self.results.pop(d, None)


def run_jobs(
    jobs: list[Job],
    *,
    executor: StudyExecutor,
    store: ResultStore | None = None,
    progress: bool | str = True,
) -> list[JobTiming]:
    """Run every job once its inputs are ready, on ``executor``: a store task as soon as it can
    start (its rows are on disk from then on), the others longest chains first.

    jobs: the jobs (keys unique, no cycles); executor: from :func:`common.make_executor` (a
    serial one runs the jobs in this process in the same order rules); store: the results
    store the store tasks write to (needed when there are any; tasks it already holds are
    skipped); progress: True prints a line per finished section, a string shows a progress bar
    over the jobs to run with that label, False shows nothing. Rows of an earlier code or
    settings version that new rows set aside are counted and reported once on stderr. Returns
    the timing of every job. Raises :class:`JobsFailed` naming the jobs that raised, after every
    job that did not depend on them has run; Ctrl-C stops the run (KeyboardInterrupt) keeping
    the rows written.
    """
    jobs = list(jobs)
    label = progress if isinstance(progress, str) else ""
    run = _Run(jobs, store)
    tasks_to_run = sum(j.task is not None and k not in run.done_rows for k, j in run.jobs.items())
    with tqdm(
        total=tasks_to_run, desc=label, disable=not isinstance(progress, str) or not tasks_to_run
    ) as bar:
        if run.recorder is not None:
            run.recorder.bar = bar  # counts each store task as its rows are written
        left = dict.fromkeys({j.section for j in run.jobs.values()}, 0)
        for j in run.jobs.values():
            left[j.section] += 1

        def done(key: str) -> None:
            sec = run.jobs[key].section
            left[sec] -= 1
            if progress is True and left[sec] == 0:
                print(f"[{time.perf_counter() - run.t0:6.1f} s] {sec}: done", flush=True)

        try:
            with _InterruptGuard(executor) as guard:
                if executor.kind == "serial":
                    _serial(run, guard, done)
                else:
                    _parallel(run, executor, guard, done)
        finally:
            superseded = run.recorder.superseded if run.recorder is not None else 0
            if superseded:
                print(
                    f"droneplan: {label or 'study'}: {superseded} row(s) of an earlier code or "
                    "settings version set aside (load_results(..., include_superseded=True) shows them)",
                    file=sys.stderr,
                    flush=True,
                )
    # a failure that only fed store tasks is already in their error rows (retried on a rerun)
    failed = {
        k: m
        for k, m in run.failed.items()
        if not (run.users[k] and all(run.jobs[u].task is not None for u in run.users[k]))
    }
    if failed:
        first = [f"{k}: {m}" for k, m in failed.items() if not m.startswith("not run")]
        error = JobsFailed(f"{len(failed)} job(s) failed or could not run; " + "; ".join(first[:5]))
        error.timings = run.timings
        raise error
    return run.timings


def map_rows(
    fn: TaskFn,
    tasks: Iterable[Mapping[str, Any]],
    *,
    executor: StudyExecutor,
    store: ResultStore,
    desc: str = "",
) -> pd.DataFrame:
    """Run ``fn(task)`` for every task whose rows are not yet in ``store`` (or errored): the
    graph of one independent store-task job per task (:func:`row_jobs`, :func:`run_jobs`).

    Each task is a dict with ``problem`` and ``instance`` (and optionally ``seed``, ``size``);
    ``fn`` must be picklable (a module-level function) and return that instance's rows
    (:func:`~droneplan.studies.store.build_rows`). Each row gets the task's ``config``
    (:func:`~droneplan.studies.common.task_config`: its settings and the code) and the
    provenance columns; a task counts as done when its instance has rows of that config and no
    error row, so a rerun after a code or settings change computes new rows, and the older rows
    of the same methods are set aside (the count is shown on the progress bar and printed once).
    Each task's rows are written in one transaction as it finishes, in the order given. A task
    that raises becomes an error row (rerun on the next call); Ctrl-C stops the study
    (KeyboardInterrupt), keeping every row finished before it and discarding results that came
    back after it.

    executor: from :func:`~droneplan.studies.common.make_executor`; store: the open results
    store; desc: the progress bar's label. Returns the current rows of the given tasks'
    instances (old and new) in the schema of :mod:`droneplan.studies.store`.
    """
    tasks = list(tasks)
    for t in tasks:
        if "problem" not in t or "instance" not in t:
            raise ValueError(f"every task needs 'problem' and 'instance', got {sorted(t)}")
    keys = [(t["problem"], t["instance"]) for t in tasks]
    if len(set(keys)) != len(keys):
        raise ValueError("tasks repeat an instance id")
    run_jobs(
        row_jobs(fn, tasks, section=desc or "study", cost=1.0), executor=executor, store=store, progress=desc
    )
    wanted = set(keys)
    frames = [store.frame(problem=p) for p in sorted({p for p, _ in wanted})]
    df = pd.concat(frames, ignore_index=True) if frames else store.frame()
    if not len(df):
        return df
    mask = [(p, i) in wanted for p, i in zip(df["problem"], df["instance"], strict=True)]
    df = df[mask].reset_index(drop=True)
    empty_extras = [c for c in df.columns if c not in COLUMNS and df[c].isna().all()]
    return df.drop(columns=empty_extras)


def _serial(run: _Run, guard: _InterruptGuard, done: Callable[[str], None]) -> None:
    while run.waiting:
        key = run.ready()[0]
        guard.check()
        call = run.start(key)
        if call is not None:
            start = time.perf_counter() - run.t0
            try:
                result, wall, cpu = _timed(call[0], call[1])
            except Exception as exc:  # noqa: BLE001 - recorded; the jobs that need it do not run
                run.fail(key, exc)
            else:
                guard.rearm()
                guard.check()
                run.finish(key, result, wall, cpu, start)
        done(key)


def _submit_ready(
    run: _Run,
    executor: StudyExecutor,
    pending: dict[cf.Future, tuple[str, float]],
    done: Callable[[str], None],
) -> None:
    """Start ready jobs, highest priority first, until every slot is busy."""
    for key in run.ready():
        if len(pending) >= executor.slots:
            return
        call = run.start(key)
        if call is None:
            done(key)
            continue
        start = time.perf_counter() - run.t0
        if executor.kind == "dask" and run.jobs[key].local:
            fut: cf.Future = cf.Future()
            try:
                fut.set_result(_timed(call[0], call[1]))
            except Exception as exc:  # noqa: BLE001 - recorded by _collect
                fut.set_exception(exc)
            _collect(run, fut, key, start)
            done(key)
            continue
        pending[executor.submit(_timed, call[0], call[1])] = (key, start)


def _collect(run: _Run, fut: cf.Future, key: str, start: float) -> None:
    try:
        result, wall, cpu = fut.result()
    except Exception as exc:  # noqa: BLE001 - recorded; the jobs that need it do not run
        run.fail(key, exc)
    else:
        run.finish(key, result, wall, cpu, start)


def _parallel(
    run: _Run, executor: StudyExecutor, guard: _InterruptGuard, done: Callable[[str], None]
) -> None:
    pending: dict[cf.Future, tuple[str, float]] = {}
    try:
        while run.waiting or pending:
            _submit_ready(run, executor, pending, done)
            if not pending:
                continue
            finished, _ = cf.wait(list(pending), timeout=0.25, return_when=cf.FIRST_COMPLETED)
            guard.check()
            for fut in finished:
                key, start = pending.pop(fut)
                _collect(run, fut, key, start)
                done(key)
    except BaseException:
        for fut in pending:
            fut.cancel()
        executor.kill()
        raise


def time_table(timings: list[JobTiming]) -> pd.DataFrame:
    """Per section: jobs run (``jobs``; resumed ones not counted), ``cpu_s`` (CPU seconds summed
    over its jobs), ``job_wall_s`` (their wall seconds summed) and ``span_s`` (first start to
    last end, s), sorted by CPU; a last row ``total``."""
    rows = []
    for sec in sorted({t.section for t in timings}):
        ts = [t for t in timings if t.section == sec]
        ran = [t for t in ts if not t.skipped]
        rows.append(
            {
                "section": sec,
                "jobs": len(ran),
                "cpu_s": sum(t.cpu for t in ran),
                "job_wall_s": sum(t.wall for t in ran),
                "span_s": max(t.end for t in ts) - min(t.start for t in ts),
            }
        )
    df = pd.DataFrame(rows, columns=["section", "jobs", "cpu_s", "job_wall_s", "span_s"])
    df = df.sort_values("cpu_s", ascending=False, ignore_index=True)
    if len(timings):
        total = {
            "section": "total",
            "jobs": int(df["jobs"].sum()),
            "cpu_s": float(df["cpu_s"].sum()),
            "job_wall_s": float(df["job_wall_s"].sum()),
            "span_s": max(t.end for t in timings) - min(t.start for t in timings),
        }
        df = pd.concat([df, pd.DataFrame([total])], ignore_index=True)
    return df


def idle_estimate(jobs: list[Job], timings: list[JobTiming], slots: int) -> tuple[float, float]:
    """(critical path, estimated wall on ``slots`` idle cores) in s from the measured CPU times:
    the costliest chain of dependent jobs, and the larger of it and total CPU / slots."""
    cpu = {t.key: t.cpu for t in timings}
    by_key = {j.key: j for j in jobs}
    memo: dict[str, float] = {}

    def chain(k: str) -> float:
        if k not in memo:
            j = by_key[k]
            memo[k] = cpu.get(k, 0.0) + max((chain(d) for d in (*j.needs.values(), *j.after)), default=0.0)
        return memo[k]

    path = max((chain(k) for k in by_key), default=0.0)
    return path, max(path, sum(cpu.values()) / max(1, slots))


def run_reproduction(
    jobs: list[Job],
    *,
    executor: StudyExecutor | None = None,
    store: ResultStore | None = None,
    out: str | os.PathLike | None = None,
) -> list[JobTiming]:
    """:func:`run_jobs` for one problem's ``reproduce``: ``executor`` defaults to a serial one,
    and ``store`` to ``out/results.sqlite`` when some jobs are store tasks (``out`` is then
    needed). Returns the job timings."""
    from droneplan.studies.common import make_executor, open_store

    with contextlib.ExitStack() as stack:
        ex = executor or stack.enter_context(make_executor(1))
        st = store
        if st is None and any(j.task is not None for j in jobs):
            if out is None:
                raise ValueError("out is needed to open the default store of store tasks")
            st = stack.enter_context(open_store(None, out))
        return run_jobs(jobs, executor=ex, store=st)
