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

import dataclasses
import gzip
import json
import math
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from droneplan.core.files import JsonFileError, read_json
from droneplan.core.validation import check_array, check_int, check_positive, check_work
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
from droneplan.scenarios.herding import HerdingParams, HerdingScenario, thesis_scenario
from droneplan.scenarios.shark.params import SharkParams
from droneplan.scenarios.shark.simulate import InterceptionScenario
from droneplan.scenarios.shark.trajectories import SharkTrajectory, random_trajectory, thesis_trajectories
from droneplan.studies.provenance import config_hash

__all__ = [
    "KINDS",
    "INSTANCE_FORMAT",
    "AllocationInstance",
    "FleetInstance",
    "FleetSizeInstance",
    "StudyInstance",
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

KINDS = (
    "cells",
    "cells-mobile",
    "cells-fleet",
    "allocation",
    "shark-path",
    "shark-fleet",
    "herding-run",
    "covert-run",
)
PROBLEM_OF_KIND = {
    "cells": "cells",
    "cells-mobile": "cells",
    "cells-fleet": "cells",
    "allocation": "herding",
    "shark-path": "shark",
    "shark-fleet": "shark",
    "herding-run": "herding",
    "covert-run": "covert",
}
INSTANCE_FORMAT = "droneplan-instance"
"""The ``format`` field of an instance file; ``format_version`` below is bumped on changes."""
INSTANCE_FORMAT_VERSION = 1


class InstanceFileError(ValueError):
    """An instance file that cannot be read: not JSON, another format, or data that does not match."""


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


@dataclass(frozen=True)
class FleetInstance:
    """Operators to assign to sharks (thesis §5.3.1): each selected shark gets its own operator.

    operators: (n, 3) operator positions (m). sharks_pos: (s, 3) shark positions (m). sharks_vel:
    (s, 3) shark velocities (m/s; predicted constant). humans: (h, 2) swimmer positions (m); when
    s > n the n sharks closest to a swimmer are the ones to serve.
    """

    operators: np.ndarray
    sharks_pos: np.ndarray
    sharks_vel: np.ndarray
    humans: np.ndarray

    def __post_init__(self) -> None:
        O = check_array("operators", self.operators, shape=(None, 3), min_rows=1)
        S = check_array("sharks_pos", self.sharks_pos, shape=(None, 3), min_rows=1)
        V = check_array("sharks_vel", self.sharks_vel, shape=(len(S), 3))
        H = check_array("humans", self.humans, shape=(None, 2), min_rows=1)
        for name, arr in (("operators", O), ("sharks_pos", S), ("sharks_vel", V), ("humans", H)):
            object.__setattr__(self, name, arr)

    @property
    def n(self) -> int:
        """Number of operators."""
        return len(self.operators)


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
def _arr(a: Any) -> list:
    return np.asarray(a, dtype=float).tolist()


def _cells_to(p: CellProblem) -> dict:
    return {
        "users": _arr(p.users),
        "gbs": _arr(p.gbs),
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
        out["weights"] = _arr(p.weights)
    if p.no_fly:
        out["no_fly"] = [
            [_arr(zone.exterior.coords), *(_arr(hole.coords) for hole in zone.interiors)] for zone in p.no_fly
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


def _mobile_to(mp: Any) -> dict:
    return {"problem": _cells_to(mp.problem), "snapshots": _arr(mp.snapshots), "max_move": float(mp.max_move)}


def _mobile_from(d: Mapping[str, Any]) -> Any:
    from droneplan.formulations.cells import MobileProblem

    return MobileProblem(_cells_from(d["problem"]), np.asarray(d["snapshots"]), d["max_move"])


def _fleet_size_to(f: FleetSizeInstance) -> dict:
    return {"problem": _cells_to(f.problem), "coverage": float(f.coverage)}


def _fleet_size_from(d: Mapping[str, Any]) -> FleetSizeInstance:
    return FleetSizeInstance(_cells_from(d["problem"]), d["coverage"])


def _alloc_to(a: AllocationInstance) -> dict:
    return {"drone_s": _arr(a.drone_s), "steer_s": _arr(a.steer_s), "perimeter": float(a.perimeter)}


def _alloc_from(d: Mapping[str, Any]) -> AllocationInstance:
    return AllocationInstance(np.asarray(d["drone_s"]), np.asarray(d["steer_s"]), d["perimeter"])


def _fleet_to(f: FleetInstance) -> dict:
    return {k: _arr(getattr(f, k)) for k in ("operators", "sharks_pos", "sharks_vel", "humans")}


def _fleet_from(d: Mapping[str, Any]) -> FleetInstance:
    return FleetInstance(*(np.asarray(d[k]) for k in ("operators", "sharks_pos", "sharks_vel", "humans")))


def _shark_to(s: InterceptionScenario) -> dict:
    tr = s.trajectory
    return {
        "trajectory": {
            "t": _arr(tr.t),
            "pos": _arr(tr.pos),
            "vel": _arr(tr.vel),
            "name": tr.name,
            "seed": tr.seed,
        },
        "params": dataclasses.asdict(s.params),
        "operator0": None if s.operator0 is None else _arr(s.operator0),
        "bearing_deg": float(s.bearing_deg),
    }


def _shark_from(d: Mapping[str, Any]) -> InterceptionScenario:
    t = d["trajectory"]
    tr = SharkTrajectory(
        np.asarray(t["t"]),
        np.asarray(t["pos"]),
        np.asarray(t["vel"]),
        name=t.get("name", ""),
        seed=t.get("seed"),
    )
    return InterceptionScenario(tr, SharkParams(**d["params"]), d.get("operator0"), d.get("bearing_deg", 0.0))


def _herding_to(s: HerdingScenario) -> dict:
    return {
        "params": dataclasses.asdict(s.params),
        "animals": _arr(s.animals),
        "drones": _arr(s.drones),
        "headings": _arr(s.headings),
        "goal": _arr(s.goal),
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


def _covert_to(s: Any) -> dict | None:
    return None  # rebuilt from the family's parameters (terrain and paths are generated objects)


_CODECS: dict[str, tuple[Callable[[Any], dict | None], Callable[[Mapping[str, Any]], Any], type | None]] = {
    "cells": (_cells_to, _cells_from, CellProblem),
    "cells-mobile": (_mobile_to, _mobile_from, None),
    "cells-fleet": (_fleet_size_to, _fleet_size_from, FleetSizeInstance),
    "allocation": (_alloc_to, _alloc_from, AllocationInstance),
    "shark-path": (_shark_to, _shark_from, InterceptionScenario),
    "shark-fleet": (_fleet_to, _fleet_from, FleetInstance),
    "herding-run": (_herding_to, _herding_from, HerdingScenario),
    "covert-run": (_covert_to, lambda d: None, None),
}


def _kind_of(data: Any) -> str:
    for kind, (_, _, cls) in _CODECS.items():
        if cls is not None and isinstance(data, cls):
            return kind
    if type(data).__name__ == "CovertScenario":
        return "covert-run"
    if type(data).__name__ == "MobileProblem":  # not imported here: it lives in formulations
        return "cells-mobile"
    raise TypeError(
        "an instance must be a CellProblem, MobileProblem, FleetSizeInstance, AllocationInstance, "
        "InterceptionScenario, FleetInstance, "
        "HerdingScenario or "
        f"covert scenario (or a StudyInstance), got {type(data).__name__}"
    )


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
        if self.kind not in KINDS:
            raise ValueError(f"kind must be one of {KINDS}, got {self.kind!r}")
        if PROBLEM_OF_KIND[self.kind] != self.problem:
            raise ValueError(f"a {self.kind!r} instance belongs to problem {PROBLEM_OF_KIND[self.kind]!r}")

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
        d = self.data
        if self.kind == "cells":
            return int(d.n_cells)
        if self.kind == "cells-mobile":
            return int(d.problem.n_cells)
        if self.kind in ("allocation", "shark-fleet", "cells-fleet"):
            return d.n
        if self.kind == "herding-run":
            return int(d.params.n_drones)
        if self.kind == "covert-run":
            return len(d.paths)
        return 1

    def payload(self) -> dict | None:
        """The data as plain JSON values (None for kinds rebuilt from their family)."""
        return _CODECS[self.kind][0](self.data)

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
        if kind not in KINDS:
            raise InstanceFileError(f"{source}: unknown kind {kind!r}; known: {', '.join(KINDS)}")
        family, params = d.get("family"), dict(d.get("params") or {})
        try:
            if d.get("data") is not None:
                data = _CODECS[kind][1](d["data"])
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
            problem=PROBLEM_OF_KIND[kind],
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
@dataclass(frozen=True)
class Family:
    """A named, versioned instance generator.

    name: its name; problem, kind: what it makes; version: bumped whenever ``build`` would give
    other data for the same parameters; grid: the size parameters besides ``seed`` (e.g.
    ``("m",)``) with their defaults in ``defaults``; seeded: whether instances take a seed;
    build(**params): the data; describe: one line for docs and ``--help``.
    """

    name: str
    problem: str
    kind: str
    version: int
    grid: tuple[str, ...]
    defaults: Mapping[str, Sequence[Any]]
    build: Callable[..., Any]
    describe: str
    seeded: bool = True


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


def _shark_thesis(path: str) -> InterceptionScenario:
    paths = thesis_trajectories()
    if path not in paths:
        raise ValueError(f"path must be one of {sorted(paths)}, got {path!r}")
    return InterceptionScenario(paths[path])


def _shark_random(seed: int) -> InterceptionScenario:
    seed = check_int("seed", seed, min_value=0)
    bearing = float(np.random.default_rng(seed).uniform(-180, 180))
    return InterceptionScenario(random_trajectory(seed), bearing_deg=bearing)


def _shark_fleet(seed: int) -> FleetInstance:
    g = np.random.default_rng(check_int("seed", seed, min_value=0))
    n, s = int(g.integers(2, 5)), int(g.integers(2, 6))
    O = np.c_[g.uniform(-60, 60, (n, 2)), np.full(n, 2.0)]
    S = np.c_[g.uniform(-60, 60, (s, 2)), g.uniform(-5, -1, s)]
    spd, hdg = g.uniform(1.0, 5.0, s), g.uniform(-np.pi, np.pi, s)  # below VoMxy: every shark is reachable
    V = np.c_[spd * np.cos(hdg), spd * np.sin(hdg), np.zeros(s)]
    return FleetInstance(O, S, V, g.uniform(-30, 30, (6, 2)))


def _herding_run(n_animals: int, seed: int) -> HerdingScenario:
    return thesis_scenario(
        check_int("n_animals", n_animals, min_value=1), check_int("seed", seed, min_value=0)
    )


def _covert_case(case: int, seed: int):
    from droneplan.scenarios.covert import thesis_case

    return thesis_case(
        check_int("case", case, min_value=1, max_value=2), check_int("seed", seed, min_value=0)
    )


def _covert_random(n_targets: int, seed: int):
    from droneplan.scenarios.covert import random_case

    return random_case(check_int("n_targets", n_targets, min_value=1), check_int("seed", seed, min_value=0))


FAMILIES: dict[str, Family] = {
    f.name: f
    for f in (
        Family(
            "table4.2",
            "cells",
            "cells",
            1,
            ("m",),
            {"m": (1, 2, 3, 4, 5, 6)},
            _cells_family(),
            "Table 4.2: Matern-clustered and background users, 10 km x 10 km, one GBS; m drone-cells",
        ),
        Family(
            "table4.2-clusters",
            "cells",
            "cells",
            1,
            ("m",),
            {"m": (1, 2, 3, 4)},
            _cells_family(clustered_only=True),
            "Table 4.2 with clustered users only (no background users, lambda_nc = 0)",
        ),
        Family(
            "table4.2-dense",
            "cells",
            "cells",
            1,
            ("m",),
            {"m": (3, 4)},
            _cells_family({"lambda_c": 2.0, "lambda_nc": 2.0}),
            "Table 4.2 with twice the user densities (lambda_c and lambda_nc x 2)",
        ),
        Family(
            "table4.2-large-m",
            "cells",
            "cells",
            1,
            ("m",),
            {"m": (7, 8, 10)},
            _cells_family(),
            "Table 4.2 users with more drone-cells than the thesis used (m >= 7)",
        ),
        *(
            Family(
                f"table4.2-{variant}",
                "cells",
                "cells",
                1,
                ("m",),
                {"m": (1, 2, 3, 4)},
                _cells_variant_family(variant),
                _VARIANT_DESCRIPTIONS[variant],
            )
            for variant in VARIANTS
        ),
        Family(
            "table4.2-mobile",
            "cells",
            "cells-mobile",
            1,
            ("m",),
            {"m": (1, 2, 3, 4)},
            _cells_mobile,
            f"Table 4.2 on 4 km x 4 km (3 clusters), users drifting over {MOBILE_EPOCHS} epochs "
            f"{EPOCH_S:g} s apart; drone-cells move at most {MOBILE_MAX_MOVE_M:g} m an epoch",
        ),
        Family(
            "min-fleet",
            "cells",
            "cells-fleet",
            1,
            ("m", "coverage"),
            {"m": (4,), "coverage": (0.05, 0.1)},
            _cells_fleet_size,
            "Table 4.2: the fewest of at most m drone-cells covering a share of the users",
        ),
        Family(
            "allocation",
            "herding",
            "allocation",
            1,
            ("n",),
            {"n": (2, 4, 6, 7, 8, 16, 32, 64)},
            _allocation,
            "steering-point allocation: n drones and steering points on the extended hull of a random herd",
        ),
        Family(
            "table6.2",
            "herding",
            "herding-run",
            1,
            ("n_animals",),
            {"n_animals": (200,)},
            _herding_run,
            "Table 6.2 herding run: animals uniform in the 1200 m x 600 m field, 4 drones",
        ),
        Family(
            "table5.1",
            "shark",
            "shark-path",
            1,
            ("path",),
            {"path": ("a", "b", "c", "d")},
            _shark_thesis,
            "Table 5.1 interception on the Fig. 5.12 shark paths a-d (operator 13 m away)",
            seeded=False,
        ),
        Family(
            "random-path",
            "shark",
            "shark-path",
            1,
            (),
            {},
            _shark_random,
            "random curvy shark path (random curvature, speed, depth) and a random start bearing",
        ),
        Family(
            "random-fleet",
            "shark",
            "shark-fleet",
            1,
            (),
            {},
            _shark_fleet,
            "random fleet: 2-4 operators, 2-5 sharks at constant velocity, 6 swimmers (120 m x 120 m)",
        ),
        Family(
            "thesis-case",
            "covert",
            "covert-run",
            1,
            ("case",),
            {"case": (1, 2)},
            _covert_case,
            "Table 3.2 covert observation cases 1 (two targets) and 2 (ten targets)",
        ),
        Family(
            "random-group",
            "covert",
            "covert-run",
            1,
            ("n_targets",),
            {"n_targets": (2, 3, 4)},
            _covert_random,
            "random group of targets on curvy paths over uneven terrain",
        ),
    )
}
"""Every instance family by name."""

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
    kind = _kind_of(obj)
    if kind == "covert-run":
        raise TypeError("a covert scenario cannot be saved or named by content: use the 'thesis-case' family")
    return StudyInstance(PROBLEM_OF_KIND[kind], kind, "user", 0, {}, obj, name=name)


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
