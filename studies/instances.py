"""Study instances: named, versioned families with stable ids, the user's own data, one JSON file each.

An instance is what one row of a gap study is about. :class:`StudyInstance` pairs the problem's
own object (its ``data``) with where it came from:

``problem``   ``cells`` | ``herding`` | ``shark`` | ``covert``
``kind``      what the data is, and so which method contract applies (``KINDS``):
              ``cells`` (a :class:`~droneplan.scenarios.cells.CellProblem`), ``allocation``
              (an :class:`AllocationInstance`), ``shark-path`` (an
              :class:`~droneplan.scenarios.shark.simulate.InterceptionScenario`), ``shark-fleet``
              (a :class:`FleetInstance`: operators and sharks to assign), ``herding-run``
              (a :class:`~droneplan.scenarios.herding.HerdingScenario`), ``covert-run`` (a covert
              scenario)
``family``    the family name (``"table4.2"``, ``"allocation"`` ...) or ``"user"``
``version``   the family's version: bumped whenever its generator would give other data for the
              same parameters, so an id never names two different instances
``params``    the family's parameters for this instance (``{"m": 4, "seed": 3}``)

Its ``id`` is ``"<family>@<version>:<k>=<v>,..."`` (``"table4.2@1:m=4,seed=3"``); a user
instance's id is ``"user:<name>#<8 hex of its fingerprint>"`` or ``"user:<fingerprint>"``.
:meth:`StudyInstance.fingerprint` hashes the data itself, so an id means one data set: a user's
edited data gets another id, and an instance file whose data is not what its family's
generator makes is read as a user instance.

Families are listed in ``FAMILIES`` (:func:`family_instances` expands one into instances).
:func:`save_instance` / :func:`load_instance` write and read one JSON file per instance (the data
is stored in full where it is plain numbers; covert scenarios are rebuilt from their family
parameters and checked against the stored fingerprint).
"""

from __future__ import annotations

import gzip
import json
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from droneplan.core.files import JsonFileError, read_json
from droneplan.core.validation import check_int, check_work
from droneplan.studies.kinds import FAMILIES, Family, Kind, kind_named, kind_of_data
from droneplan.studies.kinds import KINDS as _KIND_CLASSES
from droneplan.studies.kinds.cells import FleetSizeInstance
from droneplan.studies.kinds.herding import AllocationInstance, random_allocation_instance
from droneplan.studies.kinds.shark import FleetInstance
from droneplan.studies.provenance import config_hash

__all__ = [
    "KINDS",
    "INSTANCE_FORMAT",
    "AllocationInstance",
    "FleetInstance",
    "FleetSizeInstance",
    "StudyInstance",
    "Kind",
    "Family",
    "FAMILIES",
    "family_instances",
    "as_instance",
    "resolve_instances",
    "save_instance",
    "load_instance",
    "load_instances",
    "InstanceFileError",
    "random_allocation_instance",
]

KINDS = tuple(_KIND_CLASSES)
"""The names of the instance kinds (the classes are in :data:`droneplan.studies.kinds.KINDS`)."""
PROBLEM_OF_KIND = {name: kind.problem for name, kind in _KIND_CLASSES.items()}
"""The problem of each kind (a view of the kind classes)."""
INSTANCE_FORMAT = "droneplan-instance"
"""The ``format`` field of an instance file; ``format_version`` below is bumped on changes."""
INSTANCE_FORMAT_VERSION = 1


class InstanceFileError(ValueError):
    """An instance file that cannot be read: not JSON, another format, or data that does not match."""


# --------------------------------------------------------------------------- data <-> JSON


# --------------------------------------------------------------------------- the instance
@dataclass(frozen=True)
class StudyInstance:
    """One instance of a study with its origin (module docstring: fields, id, fingerprint)."""

    problem: str
    kind: str
    family: str
    version: int
    params: Mapping[str, Any]
    data: Any = field(repr=False, compare=False)
    name: str | None = None
    """A user instance's name (its id is ``"user:<name>#<8 hex of its fingerprint>"``); None for
    family instances."""

    def __post_init__(self) -> None:
        kind = kind_named(self.kind)
        if kind.problem != self.problem:
            raise ValueError(f"a {self.kind!r} instance belongs to problem {kind.problem!r}")

    @property
    def kind_class(self) -> Kind:
        """The instance's :class:`~droneplan.studies.kinds.base.Kind` (codec, sense, contract,
        execute, score, certify, families)."""
        return _KIND_CLASSES[self.kind]

    @property
    def id(self) -> str:
        """The stable id (``"table4.2@1:m=4,seed=3"``, ``"user:<name>#<fingerprint[:8]>"`` or
        ``"user:<fingerprint>"``). A user instance's id carries its data's fingerprint, so other
        data under the same name is another instance, never compared with this one."""
        if self.family == "user":
            fp = self.fingerprint()
            return f"user:{self.name}#{fp[:8]}" if self.name else f"user:{fp}"
        return f"{self.family}@{self.version}:" + ",".join(
            f"{k}={self.params[k]}" for k in sorted(self.params)
        )

    @property
    def seed(self) -> int | None:
        """The instance's seed when its family has one."""
        s = self.params.get("seed")
        return None if s is None else int(s)

    @property
    def size(self) -> int:
        """The problem's main size (cells m, allocation n, drones of a herding run, targets, 1 for a path)."""
        return self.kind_class.size(self.data)

    def payload(self) -> dict | None:
        """The data as plain JSON values (None for kinds rebuilt from their family)."""
        return self.kind_class.encode(self.data)

    def fingerprint(self) -> str:
        """A hash of the data (16 hex): equal for equal data, whatever the id."""
        payload = self.payload()
        if payload is None:
            payload = {"family": self.family, "version": self.version, "params": dict(self.params)}
        return config_hash({"kind": self.kind, "data": payload})

    def to_dict(self) -> dict:
        """The instance as one JSON-able dict (the instance-file format)."""
        return {
            "format": INSTANCE_FORMAT,
            "format_version": INSTANCE_FORMAT_VERSION,
            "problem": self.problem,
            "kind": self.kind,
            "family": self.family,
            "version": self.version,
            "params": dict(self.params),
            "name": self.name,
            "id": self.id,
            "fingerprint": self.fingerprint(),
            "data": self.payload(),
        }

    @classmethod
    def from_dict(cls, d: Mapping[str, Any], *, source: str = "instance") -> StudyInstance:
        """An instance from :meth:`to_dict` output; :class:`InstanceFileError` when it does not fit."""
        if not isinstance(d, Mapping) or d.get("format") != INSTANCE_FORMAT:
            raise InstanceFileError(f"{source}: not a droneplan instance (no format {INSTANCE_FORMAT!r})")
        if d.get("format_version") != INSTANCE_FORMAT_VERSION:
            raise InstanceFileError(
                f"{source}: instance format version {d.get('format_version')!r}, this droneplan reads "
                f"{INSTANCE_FORMAT_VERSION}"
            )
        kind = d.get("kind")
        if kind not in _KIND_CLASSES:
            raise InstanceFileError(f"{source}: unknown kind {kind!r}; known: {', '.join(_KIND_CLASSES)}")
        family, params = d.get("family"), dict(d.get("params") or {})
        try:
            if d.get("data") is not None:
                data = _KIND_CLASSES[kind].decode(d["data"])
            elif family in FAMILIES:
                fam = FAMILIES[family]
                if fam.version != d.get("version"):
                    raise InstanceFileError(
                        f"{source}: family {family!r} is at version {fam.version}, the file has "
                        f"{d.get('version')!r} and no data to rebuild from"
                    )
                data = fam.build(**params)
            else:
                raise InstanceFileError(f"{source}: no data and no known family to rebuild it from")
        except InstanceFileError:
            raise
        except (KeyError, TypeError, ValueError) as exc:
            raise InstanceFileError(f"{source}: bad {kind} data: {type(exc).__name__}: {exc}") from None
        inst = cls(
            problem=_KIND_CLASSES[kind].problem,
            kind=kind,
            family=str(family),
            version=int(d.get("version") or 0),
            params=params,
            data=data,
            name=d.get("name"),
        )
        if d.get("fingerprint") and d["fingerprint"] != inst.fingerprint():
            raise InstanceFileError(
                f"{source}: the data does not match its fingerprint (stored {d['fingerprint']}, "
                f"computed {inst.fingerprint()}); the file was edited or its family changed"
            )
        return _as_generated(inst)


def _as_generated(inst: StudyInstance) -> StudyInstance:
    """``inst`` if its data is what its family's generator makes for its parameters; otherwise the
    same data as a user instance (id ``user:<fingerprint>``), so that a family id always means the
    generator's data and a changed file is never compared with the family's instance."""
    if inst.family == "user" or inst.payload() is None:
        return inst
    fam = FAMILIES.get(inst.family)
    try:
        generated = fam is not None and fam.version == inst.version and fam.build(**inst.params)
        same = bool(generated) and (
            StudyInstance(
                inst.problem, inst.kind, inst.family, inst.version, inst.params, generated
            ).fingerprint()
            == inst.fingerprint()
        )
    except (TypeError, ValueError):
        same = False
    if same:
        return inst
    return StudyInstance(inst.problem, inst.kind, "user", 0, {}, inst.data)


# --------------------------------------------------------------------------- families


DEFAULT_FAMILY = {
    "cells": "table4.2",
    "herding": "allocation",
    "shark": "random-path",
    "covert": "random-group",
}
"""The family a study uses when it is given no instances."""


def _values(name: str, v: Any) -> list:
    if isinstance(v, str) or not isinstance(v, Iterable):
        return [v]
    out = list(v)
    if not out:
        raise ValueError(f"{name} must not be empty")
    return out


def family_instances(
    family: str, *, seeds: int | Iterable[int] | None = None, first_seed: int = 0, **size: Any
) -> list[StudyInstance]:
    """The instances of ``family`` over its size grid and seeds.

    family: a name in ``FAMILIES``. seeds: how many seeds (an int: ``first_seed`` ..
    ``first_seed + seeds - 1``) or the seeds themselves; default 1. first_seed: see seeds.
    size: values of the family's grid parameters (one value or a list each, e.g. ``m=[3, 4]``);
    defaults to the family's grid.
    """
    if family not in FAMILIES:
        raise ValueError(f"unknown instance family {family!r}; known: {', '.join(sorted(FAMILIES))}")
    fam = FAMILIES[family]
    unknown = sorted(set(size) - set(fam.grid))
    if unknown:
        raise ValueError(
            f"family {family!r} has no size parameter {', '.join(unknown)}; its parameters: "
            f"{', '.join(fam.grid) or 'none besides seeds'}"
        )
    first_seed = check_int("first_seed", first_seed, min_value=0)
    if seeds is None:
        seed_list = [first_seed]
    elif isinstance(seeds, Iterable):
        seed_list = [check_int("seeds[]", s, min_value=0) for s in seeds]
    else:
        count = check_int("seeds", seeds, min_value=1)
        check_work("seeds (instances to build)", count, "evaluations")
        seed_list = list(range(first_seed, first_seed + count))
    grids = [_values(k, size.get(k, fam.defaults.get(k))) for k in fam.grid]
    combos: list[dict[str, Any]] = [{}]
    for k, values in zip(fam.grid, grids, strict=True):
        combos = [{**c, k: v} for c in combos for v in values]
    check_work("seeds x size grid (instances to build)", len(combos) * len(seed_list), "evaluations")
    out = []
    for c in combos:
        for s in seed_list if fam.seeded else [None]:
            params = {**c, "seed": s} if fam.seeded else dict(c)
            out.append(
                StudyInstance(fam.problem, fam.kind, fam.name, fam.version, params, fam.build(**params))
            )
    return out


def as_instance(obj: Any, *, name: str | None = None) -> StudyInstance:
    """``obj`` as a :class:`StudyInstance`: itself, or the user's own data object wrapped as family ``user``.

    obj: a StudyInstance, CellProblem, AllocationInstance, InterceptionScenario, FleetInstance,
    HerdingScenario or covert scenario. name: the user instance's name (default: its fingerprint).
    """
    if isinstance(obj, StudyInstance):
        return obj
    kind = kind_of_data(obj)
    if kind.encode(obj) is None:
        raise TypeError("a covert scenario cannot be saved or named by content: use the 'thesis-case' family")
    return StudyInstance(kind.problem, kind.name, "user", 0, {}, obj, name=name)


def resolve_instances(problem: str, instances: Any = None, **size: Any) -> list[StudyInstance]:
    """The instances a study of ``problem`` runs on.

    instances: None (the problem's default family, ``DEFAULT_FAMILY``), a family name, a path to
    an instance file or a directory of them (``*.json``/``*.json.gz``), or a list of
    StudyInstances and data objects (see :func:`as_instance`). size: the family's size
    parameters and ``seeds``/``first_seed`` (only with a family).
    """
    if instances is None:
        instances = DEFAULT_FAMILY[problem]
    if isinstance(instances, (str, Path)):
        if isinstance(instances, str) and instances in FAMILIES:
            out = family_instances(instances, **size)
        elif Path(instances).exists():
            if size:
                raise ValueError(f"size parameters {sorted(size)} apply to families, not to instance files")
            out = load_instances(instances)
        else:
            raise ValueError(
                f"instances: {str(instances)!r} is neither an instance family "
                f"({', '.join(sorted(FAMILIES))}) nor an existing file or directory"
            )
    else:
        if size:
            raise ValueError(f"size parameters {sorted(size)} apply to families, not to a list of instances")
        out = [as_instance(x) for x in _values("instances", instances)]
    wrong = [i.id for i in out if i.problem != problem]
    if wrong:
        raise ValueError(f"instances of another problem than {problem!r}: {', '.join(wrong[:3])}")
    ids = [i.id for i in out]
    if len(set(ids)) != len(ids):
        dup = sorted({i for i in ids if ids.count(i) > 1})
        raise ValueError(f"instances repeat ids: {', '.join(dup[:3])}")
    return out


# --------------------------------------------------------------------------- files
def save_instance(instance: Any, path: str | Path) -> Path:
    """Write one instance to a JSON file (``.json``, or gzip-compressed ``.json.gz``); returns the path.

    instance: a StudyInstance or a data object (:func:`as_instance`). path: the file to write.
    """
    inst = as_instance(instance)
    path = Path(path)
    text = json.dumps(inst.to_dict(), allow_nan=False)
    if path.name.endswith(".gz"):
        path.write_bytes(gzip.compress(text.encode()))
    else:
        path.write_text(text)
    return path


def load_instance(path: str | Path) -> StudyInstance:
    """Read one instance file written by :func:`save_instance`; :class:`InstanceFileError` on a bad file.

    path: the ``.json`` or ``.json.gz`` file.
    """
    path = Path(path)
    try:
        d = read_json(path, parse_constant=_reject_constant)
    except JsonFileError as exc:
        raise InstanceFileError(
            str(exc).replace(f"{path}: ", f"{path}: not a readable instance file: ", 1)
        ) from None
    try:
        return StudyInstance.from_dict(d, source=str(path))
    except RecursionError:
        raise InstanceFileError(f"{path}: data nested too deeply to read") from None


def _reject_constant(name: str) -> float:
    raise ValueError(f"{name} is not a number an instance may hold")


def load_instances(path: str | Path) -> list[StudyInstance]:
    """Every instance in a file or a directory (``*.json`` and ``*.json.gz``, sorted by name)."""
    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(f"instances: {path} does not exist")
    files = (
        [path]
        if path.is_file()
        else sorted([*path.glob("*.json"), *path.glob("*.json.gz")], key=lambda p: p.name)
    )
    if not files:
        raise ValueError(f"instances: no *.json instance file in {path}")
    return [load_instance(f) for f in files]
