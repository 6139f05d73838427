"""The certified reference library: instances with their best known plans and proven bounds.

Each family with a library has one file ``data/<family>.json.gz`` in this package: one entry per
instance id with the best plan droneplan knows, its value (re-evaluated by droneplan's own
evaluator when certified, and again by the tests), the best proven bound and its kind, the
status (``optimal`` when value and bound meet), how it was obtained (engine, wall time, time
limit, droneplan version, git commit, date) and the instance's fingerprint, so an entry is only
used for exactly the data it was certified on.

A study on library instances reads its reference from here instead of re-solving: it adds a
``library`` row per instance (role ``model``) carrying that value and bound, against which the
requested methods' gaps are measured. ``droneplan certify <family>`` (:func:`certify`) produces
and extends the files; it resumes where it stopped and writes after every entry.

How each kind is certified:

``cells``        the exact branch and bound (``engine="bnb"``) within the time limit; the bound
                 is for the candidate-site problem (``candidate-set``), or ``proven-global`` when
                 the continuous-problem upper bound is attained. A variant instance (weights,
                 no-fly zones, capacity, altitude levels) by the MILP (``solve_exact``'s default
                 engine for it, CP-SAT, one worker), its objective the variant's ``value``
``cells-mobile`` the joint model of all epochs (``solve_mobile``, CP-SAT, one worker); its bound is
                 for the candidate sites of every epoch (``candidate-set``); when it is not proven,
                 the better of its plan and the myopic baseline's
``cells-fleet``  the fewest-drone-cells model (``min_fleet``, one worker); value and bound are
                 counts of drone-cells (``candidate-set``); when it is not proven, the better of
                 its plan and the greedy fleet's
``shark-fleet``  the bottleneck operator-to-shark assignment (CP-SAT); when it is not proven, the
                 better of its plan and the nearest-free-operator baseline's
``allocation``   the exact combinatorial algorithm, cross-checked by CP-SAT up to n = 16
                 (``proven-global``)
``shark-path``   the best frontal first-contact time of the built-in interceptors (virtual
                 shark, classical pursuit, receding-horizon OCP) in closed loop; no bound is
                 proven for the closed loop, so the entry holds the best known value only
"""

from __future__ import annotations

import dataclasses
import datetime as _dt
import fcntl
import functools
import gzip
import json
import os
import tempfile
from collections.abc import Iterable, Mapping
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

from droneplan.core.files import JsonFileError, read_json
from droneplan.scenarios.cell_variants import VARIANTS
from droneplan.studies.instances import FAMILIES, StudyInstance, family_instances

__all__ = [
    "LIBRARY_FORMAT",
    "LIBRARY_DIR",
    "LIBRARY_FAMILIES",
    "LibraryEntry",
    "library_path",
    "load_library",
    "lookup",
    "certify_instance",
    "save_library",
]

LIBRARY_FORMAT = "droneplan-library"
LIBRARY_DIR = Path(__file__).resolve().parent / "data"
"""Where the shipped library files live (inside the installed package)."""

LIBRARY_FAMILIES: dict[str, dict[str, Any]] = {
    "table4.2": {"m": (1, 2, 3, 4, 5, 6), "seeds": 100},
    **{f"table4.2-{variant}": {"m": (1, 2, 3, 4), "seeds": 20} for variant in VARIANTS},
    "table4.2-mobile": {"m": (1, 2), "seeds": 20},
    "min-fleet": {"m": (4,), "coverage": (0.05, 0.1), "seeds": 20},
    "allocation": {"n": tuple(range(2, 65)), "seeds": 5},
    "table5.1": {"path": ("a", "b", "c", "d")},
    "random-path": {"seeds": 20},
}
"""The families the shipped library covers and the sizes and seeds it holds."""


class LibraryFileError(ValueError):
    """A library file that cannot be read (one line, starting with the path)."""


@dataclass(frozen=True)
class LibraryEntry:
    """One certified instance.

    id, fingerprint: the instance's id and data hash. value: the best known objective (the
    problem's units; verified by droneplan's evaluator). bound: the best proven bound (None when
    none is proven) of kind ``bound_kind``. status: ``optimal`` when value meets bound, else
    ``feasible``. sense: ``max`` or ``min``. plan: the best plan as JSON values (cells: positions
    (k, 2) m; allocation: {"target", "direction"}; shark: {"controller"}). engine: what found and
    proved it. time_s: its wall time (s); time_limit_s: the limit it ran under. droneplan_version,
    git_commit, certified_at: provenance. message: the engine's message.
    """

    id: str
    fingerprint: str
    value: float
    bound: float | None
    bound_kind: str
    status: str
    sense: str
    plan: Any
    engine: str
    time_s: float
    time_limit_s: float | None
    droneplan_version: str
    git_commit: str | None
    certified_at: str
    message: str = ""
    code_hash: str | None = None
    packages: Mapping[str, Any] | None = None
    cpu: str | None = None
    cores: int | None = None

    @property
    def gap(self) -> float | None:
        """Relative gap between value and bound (0 when proven optimal; None without a bound)."""
        if self.bound is None:
            return None
        diff = (self.bound - self.value) if self.sense == "max" else (self.value - self.bound)
        return diff / max(abs(self.bound), 1e-9)


def library_path(family: str, directory: str | os.PathLike | None = None) -> Path:
    """The library file of ``family`` (in ``directory``, default the package's ``LIBRARY_DIR``)."""
    return Path(directory or LIBRARY_DIR) / f"{family}.json.gz"


def _read(path: Path) -> dict[str, LibraryEntry]:
    if not path.exists():
        return {}
    try:
        doc = read_json(path)
    except JsonFileError as exc:
        raise LibraryFileError(
            str(exc).replace(f"{path}: ", f"{path}: not a readable library file: ", 1)
        ) from None
    if (
        not isinstance(doc, Mapping)
        or doc.get("format") != LIBRARY_FORMAT
        or not isinstance(doc.get("entries"), list)
    ):
        raise LibraryFileError(f"{path}: not a droneplan library file")
    fields = {f.name for f in dataclasses.fields(LibraryEntry)}
    entries = {}
    for i, e in enumerate(doc["entries"]):
        unknown = sorted(set(e) - fields) if isinstance(e, Mapping) else []
        if not isinstance(e, Mapping) or unknown or "id" not in e:
            what = f"unknown fields {unknown}" if unknown else "not an entry"
            raise LibraryFileError(f"{path}: entry {i} has {what}; this droneplan reads {LIBRARY_FORMAT!r}")
        try:
            entries[e["id"]] = LibraryEntry(**e)
        except TypeError as exc:
            raise LibraryFileError(f"{path}: entry {i} ({e['id']!r}) is incomplete: {exc}") from None
    return entries


@functools.lru_cache(maxsize=16)
def _cached(path: str, mtime: float) -> dict[str, LibraryEntry]:
    return _read(Path(path))


def load_library(family: str, directory: str | os.PathLike | None = None) -> dict[str, LibraryEntry]:
    """Every entry of ``family``'s library by instance id (empty when it has none)."""
    path = library_path(family, directory)
    if not path.exists():
        return {}
    return dict(_cached(str(path), path.stat().st_mtime))


def lookup(instance: StudyInstance, directory: str | os.PathLike | None = None) -> LibraryEntry | None:
    """The library entry of ``instance``, or None (no library, no entry, or other data under that id)."""
    if instance.family not in FAMILIES and instance.family != "user":
        return None
    entry = load_library(instance.family, directory).get(instance.id)
    if entry is None or entry.fingerprint != instance.fingerprint():
        return None
    return entry


def save_library(
    family: str,
    entries: Mapping[str, LibraryEntry],
    directory: str | os.PathLike | None = None,
    *,
    merge: bool = False,
) -> Path:
    """Write ``family``'s library atomically (sorted by id, gzip-compressed JSON).

    merge: add ``entries`` to what the file holds now (read under an exclusive lock, so
    concurrent certify runs on one family never drop each other's entries) instead of
    replacing the file's content.
    """
    path = library_path(family, directory)
    path.parent.mkdir(parents=True, exist_ok=True)
    if not merge:
        return _write(family, path, entries)
    with open(path.with_name(f".{path.name}.lock"), "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        try:
            return _write(family, path, {**_read(path), **entries})
        finally:
            fcntl.flock(lock, fcntl.LOCK_UN)


def _write(family: str, path: Path, entries: Mapping[str, LibraryEntry]) -> Path:
    fam = FAMILIES.get(family)
    doc = {
        "format": LIBRARY_FORMAT,
        "family": family,
        "family_version": None if fam is None else fam.version,
        "entries": [asdict(entries[k]) for k in sorted(entries)],
    }
    data = gzip.compress(json.dumps(doc, allow_nan=False, separators=(",", ":")).encode(), mtime=0)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    with os.fdopen(fd, "wb") as fh:
        fh.write(data)
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(tmp, 0o666 & ~umask)  # as any file written with open(): mkstemp makes it 0600
    os.replace(tmp, path)
    _cached.cache_clear()
    return path


# --------------------------------------------------------------------------- certifying one instance
def _now() -> str:
    return _dt.datetime.now(_dt.UTC).replace(microsecond=0).isoformat()


def certify_instance(instance: StudyInstance, *, time_limit: float | None) -> dict[str, Any]:
    """Find and prove the best plan of one instance (runs in a job's child process), by its kind's
    certification procedure (:meth:`~droneplan.studies.kinds.base.Kind.certify`).

    Returns the entry's fields except provenance (a dict); raises when the engine's plan does not
    verify, so a wrong entry is never written.
    """
    from droneplan.studies.harness import execute, score
    from droneplan.studies.methods import BUILTIN

    def run(name: str, limit: float | None) -> tuple[Any, Any]:
        method = BUILTIN[name]
        returned = execute(instance, method, 0, limit)
        return returned, score(instance, method, returned)

    return instance.kind_class.certify(instance, time_limit=time_limit, run=run)


def library_instances(family: str, **size: Any) -> list[StudyInstance]:
    """The instances of ``family`` the shipped library covers (``LIBRARY_FAMILIES``), or ``size`` ones."""
    if family not in LIBRARY_FAMILIES:
        raise ValueError(
            f"no certified library for family {family!r}; families: {', '.join(LIBRARY_FAMILIES)}"
        )
    spec: dict[str, Any] = {**LIBRARY_FAMILIES[family], **size}
    return family_instances(family, **spec)


def entry_from(
    instance: StudyInstance, fields: Mapping[str, Any], *, time_limit: float | None, prov: Mapping[str, Any]
) -> LibraryEntry:
    """A :class:`LibraryEntry` from :func:`certify_instance`'s fields and the run's provenance."""
    return LibraryEntry(
        id=instance.id,
        fingerprint=instance.fingerprint(),
        time_limit_s=time_limit,
        droneplan_version=str(prov.get("droneplan_version")),
        git_commit=prov.get("git_commit"),
        certified_at=_now(),
        code_hash=prov.get("code_hash"),
        packages=prov.get("packages"),
        cpu=prov.get("cpu"),
        cores=prov.get("cores"),
        **fields,
    )


def entries_to_certify(
    instances: Iterable[StudyInstance], existing: Mapping[str, LibraryEntry], *, force: bool, improve: bool
) -> list[StudyInstance]:
    """The instances without a current entry (or with an unproven one when ``improve``)."""
    todo = []
    for inst in instances:
        e = existing.get(inst.id)
        if force or e is None or e.fingerprint != inst.fingerprint() or (improve and e.status != "optimal"):
            todo.append(inst)
    return todo
