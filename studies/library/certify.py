"""``droneplan certify <family>``: produce or extend a family's certified library file.

Every instance without a current entry is certified in its own time-limited child process
(:mod:`droneplan.studies.runner`), ``workers`` at a time; the library file is rewritten after every
entry, so an interrupted run keeps what it finished and the same command resumes it.

On a Dask cluster (``dask=ADDRESS``, ``droneplan certify ... --dask ADDRESS``, or a Dask
``executor`` of :func:`~droneplan.studies.common.make_executor`) each instance's child process runs
on a worker (:func:`~droneplan.studies.runner.run_isolated` there), which sends back only the
entry's fields. The library file is written here, by the process that holds its lock, after each
instance as it comes back, exactly as in a local run: a worker never writes library files.
"""

from __future__ import annotations

import concurrent.futures as cf
import contextlib
import os
import random
from collections.abc import Iterator, Sequence
from typing import Any

from tqdm.auto import tqdm

from droneplan.core.validation import check_instance, check_int, check_sequence, check_time_limit
from droneplan.studies.common import StudyError, StudyExecutor, make_executor
from droneplan.studies.library import (
    LIBRARY_FAMILIES,
    certify_instance,
    entries_to_certify,
    entry_from,
    library_instances,
    load_library,
    save_library,
)
from droneplan.studies.provenance import provenance
from droneplan.studies.runner import CallOutcome, IsolatedCall, run_calls, run_isolated

__all__ = [
    "certify",
    "verify",
    "certifications",
    "check_cluster_options",
    "connect",
    "option_message",
    "CERTIFY_GRACE_S",
]

CERTIFY_GRACE_S = 30.0
"""How long a certification may overrun its time limit before its process is killed (s): the
engines stop themselves at the limit and return their best plan and bound."""


def certify(
    family: str,
    *,
    time_limit: float | None = 300.0,
    workers: int | None = None,
    directory: str | os.PathLike | None = None,
    force: bool = False,
    improve: bool = False,
    progress: bool = True,
    dask: str | None = None,
    executor: StudyExecutor | None = None,
    **size: Any,
) -> dict[str, Any]:
    """Certify the instances of ``family`` and write its library file; return a summary.

    family: a family in ``LIBRARY_FAMILIES``. time_limit: per instance (s; None: none).
    workers: instances certified at once (default: number of cores). directory: where the
    library files are (default: the package's). force: redo every entry. improve: redo the
    entries that are not proven optimal. progress: show a progress bar. dask: the address of a
    Dask scheduler (``"tcp://host:8786"``) to certify the instances on, instead of ``workers``
    local processes; one that does not answer within 5 s is a :class:`StudyError` naming
    ``dask``, raised before any file is written. executor: a
    :class:`~droneplan.studies.common.StudyExecutor` instead (a Dask one runs the instances on its
    cluster; a local one gives the number of instances at once). The entries are written here in
    either case, after each instance (module docstring). size: the family's sizes and
    ``seeds``/``first_seed`` (default: what ``LIBRARY_FAMILIES`` lists).
    Returns {"family", "path", "certified", "failed", "entries", "proven"} (counts and the path).
    """
    if family not in LIBRARY_FAMILIES:
        raise ValueError(
            f"no certified library for family {family!r}; families: {', '.join(LIBRARY_FAMILIES)}"
        )
    time_limit = check_time_limit(time_limit)
    workers = check_int("workers", workers if workers is not None else (os.cpu_count() or 1), min_value=1)
    check_cluster_options(dask, executor)
    instances = library_instances(family, **size)
    entries = load_library(family, directory)
    todo = entries_to_certify(instances, entries, force=force, improve=improve)
    by_id = {inst.id: inst for inst in todo}
    prov = provenance()
    failed: list[str] = []
    path = None
    with contextlib.ExitStack() as stack:
        runner = connect(stack, dask, executor)
        desc = f"certify {family}" if progress else None
        for outcome in certifications(todo, time_limit, workers, desc, executor=runner):
            inst = by_id[str(outcome.key)]
            if outcome.status != "ok":
                failed.append(f"{inst.id}: {outcome.status}: {outcome.error}")
                continue
            old = entries.get(inst.id)
            new = entry_from(inst, outcome.value, time_limit=time_limit, prov=prov)
            if (
                old is not None
                and old.fingerprint == new.fingerprint
                and not force
                and _better_or_equal(old, new)
            ):
                continue  # an improve run that did not improve keeps the older, better entry
            entries[inst.id] = new
            path = save_library(family, {inst.id: new}, directory, merge=True)  # here, under its lock
    wanted = {inst.id for inst in instances}
    held = [e for k, e in entries.items() if k in wanted]
    return {
        "family": family,
        "path": str(path) if path else None,
        "certified": len(todo) - len(failed),
        "failed": failed,
        "entries": len(held),
        "proven": sum(e.status == "optimal" for e in held),
    }


def certifications(
    instances: list[Any],
    time_limit: float | None,
    workers: int,
    progress: str | None,
    *,
    executor: StudyExecutor | None = None,
) -> Iterator[CallOutcome]:
    """The outcomes of certifying each instance in its own time-limited child process.

    instances: the StudyInstances. time_limit: per instance (s; None: none; the child is killed
    ``CERTIFY_GRACE_S`` after it). workers: children at once. progress: a progress bar's
    description, or None for none. executor: None (``workers`` local children), a local
    :class:`~droneplan.studies.common.StudyExecutor` (as many children as its slots) or a Dask one
    (each child on a worker of its cluster). Yields one ``CallOutcome`` per instance (key: its id;
    value: :func:`~droneplan.studies.library.certify_instance`'s fields) as each finishes.
    """
    jobs = [
        IsolatedCall(inst.id, certify_instance, (inst,), {"time_limit": time_limit}, time_limit=time_limit)
        for inst in instances
    ]
    if executor is not None and executor.kind == "dask":
        yield from _on_cluster(jobs, executor, progress)
        return
    if executor is not None:
        workers = executor.slots
    yield from run_calls(jobs, workers=workers, grace=CERTIFY_GRACE_S, progress=progress)


def _on_cluster(
    jobs: list[IsolatedCall], executor: StudyExecutor, progress: str | None
) -> Iterator[CallOutcome]:
    """The outcomes of ``jobs``, each run in a child of a Dask worker (``run_isolated`` there), as
    they come back; a job whose worker failed is a ``"crashed"`` outcome. Leaving early (an
    interrupt, an error while an outcome is written) cancels the jobs not yet finished."""
    futures = {executor.submit(run_isolated, job, grace=CERTIFY_GRACE_S): job.key for job in jobs}
    try:
        with tqdm(total=len(futures), desc=progress, disable=progress is None) as bar:
            for fut in cf.as_completed(futures):
                try:
                    outcome = fut.result()
                except Exception as exc:  # noqa: BLE001 - the worker died or lost the job: one failure
                    outcome = CallOutcome(futures[fut], "crashed", error=f"worker failed: {_one_line(exc)}")
                bar.update(1)
                yield outcome
    finally:
        for fut in futures:
            fut.cancel()


def _one_line(exc: BaseException) -> str:
    """``"Type: message"`` of ``exc`` on one line (at most 200 characters)."""
    return f"{type(exc).__name__}: {' '.join(str(exc).split())}"[:200]


def check_cluster_options(dask: object, executor: object) -> None:
    """Refuse, naming the parameter, a ``dask`` that is not a scheduler address (str or None), an
    ``executor`` that is not a :class:`~droneplan.studies.common.StudyExecutor` (or None), or
    both given."""
    check_instance("dask", dask, str, optional=True)
    check_instance("executor", executor, StudyExecutor, optional=True)
    if dask is not None and executor is not None:
        raise ValueError("dask and executor: give one of them, not both")
    if isinstance(dask, str) and not dask.strip():
        raise ValueError(f"dask must be a scheduler address such as 'tcp://host:8786', got {dask!r}")


def option_message(exc: BaseException) -> str:
    """The message of ``exc`` for the command line: a leading ``dask:`` (the keyword) becomes
    ``--dask:`` (the option)."""
    text = str(exc)
    return f"--{text}" if text.startswith("dask:") else text


def connect(
    stack: contextlib.ExitStack, dask: str | None, executor: StudyExecutor | None
) -> StudyExecutor | None:
    """``executor``, or (with ``dask``) an executor on the Dask scheduler at that address, opened
    in ``stack`` (:func:`~droneplan.studies.common.make_executor`, at most 5 s to answer); a
    scheduler that does not answer is a one-line :class:`StudyError` starting ``dask:``."""
    if dask is None:
        return executor
    try:
        return stack.enter_context(make_executor(dask_address=dask))
    except StudyError as exc:
        raise StudyError(f"dask: {exc}") from None


def _better_or_equal(old, new) -> bool:
    """True when ``old`` is at least as good as ``new`` in value and bound."""
    sign = 1 if old.sense == "max" else -1
    value_ok = sign * (old.value - new.value) >= 0
    if new.bound is None:
        return value_ok
    if old.bound is None:
        return False
    return value_ok and sign * (new.bound - old.bound) >= 0


def verify(
    family: str,
    *,
    time_limit: float | None = 300.0,
    workers: int | None = None,
    directory: str | os.PathLike | None = None,
    ids: Sequence[str] | None = None,
    sample: int | None = None,
    seed: int | None = None,
    progress: bool = True,
    dask: str | None = None,
    executor: StudyExecutor | None = None,
) -> dict[str, Any]:
    """Re-prove the stored entries of ``family`` and report those that do not hold; writes nothing.

    An entry does not hold when the fresh certification finds a plan better than its stored
    bound, or proves another optimum than the one it states. family, time_limit, workers,
    directory, dask, executor: as for :func:`certify`. ids: re-prove only these entries (None: all). sample:
    re-prove this many of them drawn at random (None: all). seed: the draw's seed (None: a fresh
    one, reported in the summary so a draw can be repeated). Returns {"family", "checked",
    "seed", "failed"} (``failed``: one line per entry).
    """
    if family not in LIBRARY_FAMILIES:
        raise ValueError(
            f"no certified library for family {family!r}; families: {', '.join(LIBRARY_FAMILIES)}"
        )
    time_limit = check_time_limit(time_limit)
    workers = check_int("workers", workers if workers is not None else (os.cpu_count() or 1), min_value=1)
    check_cluster_options(dask, executor)
    entries = load_library(family, directory)
    instances = [inst for inst in library_instances(family) if inst.id in entries]
    if ids is not None:
        instances = _chosen(instances, ids)
    seed = random.SystemRandom().randrange(2**31) if seed is None else check_int("seed", seed, min_value=0)
    if sample is not None and check_int("sample", sample, min_value=1) < len(instances):
        instances = random.Random(seed).sample(instances, sample)
    failed = []
    with contextlib.ExitStack() as stack:
        runner = connect(stack, dask, executor)
        desc = f"verify {family}" if progress else None
        for outcome in certifications(instances, time_limit, workers, desc, executor=runner):
            entry = entries[str(outcome.key)]
            if outcome.status != "ok":
                failed.append(f"{entry.id}: not re-proven ({outcome.status}: {outcome.error})")
                continue
            why = entry_disagrees(entry, outcome.value)
            if why:
                failed.append(f"{entry.id}: {why}")
    return {"family": family, "checked": len(instances), "seed": seed, "failed": failed}


def _chosen(instances: list[Any], ids: Sequence[str]) -> list[Any]:
    """The instances of ``instances`` named in ``ids``; an id without an entry is refused."""
    wanted = {str(i) for i in check_sequence("ids", ids)}
    unknown = sorted(wanted - {inst.id for inst in instances})
    if unknown:
        raise ValueError(f"ids: no library entry {unknown[0]!r} ({len(unknown)} unknown)")
    return [inst for inst in instances if inst.id in wanted]


def entry_disagrees(entry: Any, fresh: dict[str, Any], tol: float = 1e-6) -> str:
    """Why a stored entry does not hold against a fresh certification (``certify_instance``'s
    fields), or ``""`` when it holds."""
    sign = 1.0 if entry.sense == "max" else -1.0
    value, bound = float(fresh["value"]), fresh.get("bound")
    if entry.bound is not None and sign * (value - entry.bound) > tol * max(1.0, abs(entry.bound)):
        return f"a plan of value {value:g} beats the stored bound {entry.bound:g}"
    proven = fresh.get("status") == "optimal" and bound is not None
    if proven and entry.status == "optimal" and abs(value - entry.value) > tol * max(1.0, abs(value)):
        return f"the optimum is {value:g}, the entry states {entry.value:g}"
    if entry.bound is None and abs(value - entry.value) > tol * max(1.0, abs(value)):
        return f"the best value found now is {value:g}, the entry states {entry.value:g}"
    return ""
