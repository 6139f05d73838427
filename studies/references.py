"""A reference for every instance of a study: the certified library, or an exact solve cached under ``out``.

A gap study measures its methods against a proven reference. On instances of the shipped
certified library (:mod:`droneplan.studies.library`) that reference is the ``library`` row. On
any other instance of a kind with an exact engine (``REFERENCE_KINDS``: drone-cell placement,
moving users, fleet size, the herding allocation, shark fleets), :func:`reference_rows` solves
it by the same procedure the library is certified with
(:func:`~droneplan.studies.library.certify_instance`), in a child process under its own time
limit, and keeps the entry in a local library under the study's folder
(``out/library/<family>.json.gz``; a user's own instances under ``user``), so a rerun reads it
instead of solving again. It reaches the study as a row of method ``reference`` and role
``bound``: its bound defines the instances' gaps to bound, and its value, when proven, is the
target of success rates (:func:`~droneplan.studies.analysis.instance_targets`); it never counts
as a method's result.

No reference is solved for an instance whose study already runs its kind's exact engine (that
row carries the bound), nor with ``reference="none"``, which instead prints how many instances
have no proven reference.
"""

from __future__ import annotations

import json
import sys
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any

from droneplan.core.validation import check_time_limit
from droneplan.studies.instances import StudyInstance
from droneplan.studies.library import LibraryEntry, entry_from, lookup, save_library
from droneplan.studies.provenance import config_hash, provenance
from droneplan.studies.store import REFERENCE_METHOD, build_rows

__all__ = [
    "REFERENCE_METHOD",
    "REFERENCE_KINDS",
    "REFERENCE_CHOICES",
    "DEFAULT_REFERENCE_TIME_LIMIT",
    "LOCAL_LIBRARY",
    "check_reference",
    "entry_row",
    "reference_rows",
]

REFERENCE_KINDS = ("cells", "cells-mobile", "cells-fleet", "allocation", "shark-fleet")
"""The instance kinds with an exact engine, whose references a study solves when none is certified."""

REFERENCE_CHOICES = ("auto", "none")
"""What ``gap(reference=...)`` accepts."""

DEFAULT_REFERENCE_TIME_LIMIT = 300.0
"""Wall time one reference solve may take when the study names none (s); the engine then
returns its best plan and bound (an unproven reference)."""

LOCAL_LIBRARY = "library"
"""The folder under a study's ``out`` that holds the references it solved (library files)."""

STUDY = "gap"


def check_reference(reference: Any, time_limit: Any) -> tuple[str, float]:
    """``reference`` and ``reference_time_limit`` of :func:`~droneplan.studies.study.gap`, checked.

    reference: ``"auto"`` or ``"none"``. time_limit: seconds per reference solve (None: the
    default ``DEFAULT_REFERENCE_TIME_LIMIT``). Returns them; a one-line ValueError or TypeError
    naming the parameter otherwise.
    """
    if not isinstance(reference, str) or reference not in REFERENCE_CHOICES:
        short = isinstance(reference, str) and len(reference) <= 40
        shown = repr(reference) if short else type(reference).__name__
        raise ValueError(f"reference must be one of {', '.join(map(repr, REFERENCE_CHOICES))}, got {shown}")
    if time_limit is None:
        return reference, DEFAULT_REFERENCE_TIME_LIMIT
    return reference, float(check_time_limit(time_limit, name="reference_time_limit") or 0.0)


def entry_row(inst: StudyInstance, entry: LibraryEntry, *, method: str, role: str, source: str) -> dict:
    """The study row of a library entry: the instance's value, bound and provenance.

    inst: the instance. entry: its library entry. method: the row's method (``library`` or
    ``reference``); role: its role (``model``, ``bound``). source: how the message names where
    the entry comes from (``certified library``, ``reference solved for this study``).
    """
    from droneplan.studies.store import Outcome

    outcome = Outcome(
        method=method,
        role=role,
        status=entry.status,
        objective=entry.value,
        bound=entry.bound,
        bound_kind=entry.bound_kind if entry.bound is not None else "none",
        time_s=entry.time_s,
        message=f"{source}: {entry.engine}, {entry.certified_at}, droneplan {entry.droneplan_version}",
        extras={"library_gap": entry.gap},
    )
    (row,) = build_rows(
        inst.problem,
        inst.id,
        seed=inst.seed,
        size=inst.size,
        sense=entry.sense,
        outcomes=[outcome],
        study=STUDY,
    )
    row.update(
        config=config_hash(
            {"library": entry.fingerprint, "certified_at": entry.certified_at, "value": entry.value}
        ),
        flag="",
        claimed_objective=None,
        family=inst.family,
        family_version=inst.version,
        method_params="{}",
        time_limit_s=entry.time_limit_s,
        droneplan_version=entry.droneplan_version,
        git_commit=entry.git_commit,
        code_hash=entry.code_hash,
        packages=None if entry.packages is None else json.dumps(dict(entry.packages), sort_keys=True),
        cpu=entry.cpu,
        cores=entry.cores,
        finished_at=entry.certified_at,
    )
    return row


def _has_engine(kind: str, methods: Iterable[Any]) -> bool:
    """Whether a method of the study is a built-in exact engine of ``kind`` (its row is the reference)."""
    return any(m.builtin and m.trusted_bound and m.role == "model" and kind in m.kinds for m in methods)


def reference_rows(
    instances: Sequence[StudyInstance],
    methods: Sequence[Any],
    *,
    out: Path,
    reference: str,
    time_limit: float,
    workers: int,
    progress: bool,
) -> list[dict]:
    """The ``reference`` rows of a study's instances that the certified library does not hold.

    instances, methods: the study's (:class:`~droneplan.studies.methods.Method` s). out: the
    study's folder (the local library is ``out/library``). reference: ``"auto"`` (solve what is
    missing) or ``"none"`` (solve nothing; print how many instances lack a proven reference).
    time_limit: per reference solve (s). workers: solves at once. progress: a progress bar.
    Instances of kinds outside ``REFERENCE_KINDS``, or whose study runs the kind's exact engine,
    get no row. A solve that fails is reported in one line on stderr and gives no row.
    """
    missing = [i for i in instances if lookup(i) is None]
    if reference == "none":
        unproven = sum(1 for i in instances if (e := lookup(i)) is None or e.status != "optimal")
        if unproven:
            print(
                f"droneplan gap: {unproven} of {len(instances)} instances have no proven reference "
                "(reference='none'): their gaps to bound come from the methods' own bounds only",
                file=sys.stderr,
                flush=True,
            )
        return []
    wanted = [i for i in missing if i.kind in REFERENCE_KINDS and not _has_engine(i.kind, methods)]
    if not wanted:
        return []
    directory = Path(out) / LOCAL_LIBRARY
    held = {i.id: e for i in wanted if (e := lookup(i, directory)) is not None}
    todo = [i for i in wanted if i.id not in held]
    held.update(_solve(todo, directory, time_limit, workers, progress))
    source = f"reference solved for this study (kept in {directory})"
    return [
        entry_row(i, held[i.id], method=REFERENCE_METHOD, role="bound", source=source)
        for i in wanted
        if i.id in held
    ]


def _solve(
    todo: list[StudyInstance], directory: Path, time_limit: float, workers: int, progress: bool
) -> dict[str, LibraryEntry]:
    """Certify ``todo`` in child processes, keep each entry in the local library as it comes."""
    from droneplan.studies.library.certify import certifications

    if not todo:
        return {}
    by_id = {i.id: i for i in todo}
    prov = provenance()
    got: dict[str, LibraryEntry] = {}
    failed = []
    for oc in certifications(todo, time_limit, workers, "references" if progress else None):
        inst = by_id[str(oc.key)]
        if oc.status != "ok":
            failed.append(f"{inst.id} ({oc.status}: {oc.error})")
            continue
        entry = entry_from(inst, oc.value, time_limit=time_limit, prov=prov)
        save_library(inst.family, {inst.id: entry}, directory, merge=True)
        got[inst.id] = entry
    if failed:
        print(
            f"droneplan gap: no reference for {len(failed)} instance(s): {'; '.join(failed)[:400]}",
            file=sys.stderr,
            flush=True,
        )
    return got
