"""One long-format results schema for every study, and the crash-safe store that holds it.

Schema
------
One row per ``(problem, instance, method)``; the columns (``COLUMNS``) are the same for
all four problems:

``study``         which study wrote the row (``"gap"``, ``"fig6.7"``, ``"table4.3"`` ...)
``problem``       ``covert`` | ``cells`` | ``shark`` | ``herding``
``instance``      a stable id of the instance, e.g. ``"gap:n_targets=3,seed=7"``
                  (:func:`instance_id`); the same task always gets the same id
``seed``          the instance's seed; ``size`` its main size (``SIZE_MEANING``)
``method``        the heuristic, model or bound that produced the row
``role``          ``heuristic`` | ``model`` | ``bound`` (``task`` for an error row)
``sense``         ``min`` or ``max``: the direction in which ``objective`` is better
``status``        a :class:`~droneplan.solvers.result.Status` value (``optimal``,
                  ``feasible``, ``no_solution`` ...) or ``error`` for a task that raised
``objective``     in the problem's own units (see ``OBJECTIVE_UNITS``)
``bound``         the bound this method proves (None when it proves none)
``bound_kind``    what ``bound`` is proven for: ``proven-global`` (the instance's true
                  optimum), ``candidate-set`` (the optimum over a finite candidate set),
                  ``instantaneous`` (a per-instant optimum, not a whole-run bound),
                  ``local`` (a local optimum, no proof), ``none``
``gap_to_bound``  relative gap of ``objective`` to the tightest bound of the instance's
                  strongest bound kind (``gap_bound_kind`` names that kind):
                  ``(objective - bound) / |bound|`` for ``min``, ``(bound - objective) / |bound|``
                  for ``max`` (denominator floored at 1e-9)
``gap_to_best``   relative gap of ``objective`` to the best objective any method of the
                  ``heuristic``/``model`` roles reached on the instance (0 for the best)
``time_s``        wall time of the method (s); ``warm_started`` whether it was warm-started
``message``       a solver message or, for an error row, the exception
plus problem-specific extras as prefixed columns ``<problem>_<name>`` (kept as JSON in the
store and expanded by :meth:`ResultStore.frame`).

How a problem's study emits rows
--------------------------------
A study defines a module-level task function ``task -> list[row]`` (so process pools and
Dask can pickle it). Each task dict holds ``problem`` and ``instance`` (use
:func:`instance_id`) plus whatever the function needs. The function runs every method on
the instance, turns each outcome into an :class:`Outcome` (:meth:`Outcome.of` converts a
``SolveResult``) and returns ``build_rows(problem, instance, seed=..., size=..., sense=...,
outcomes=[...])``, which fills the gaps. :func:`droneplan.studies.common.map_rows` runs the
tasks not yet in the store through an executor and writes each task's rows in one
transaction. ::

    def my_task(task):
        p = make_instance(task["seed"])
        ga, milp = genetic(p, seed=task["seed"]), solve_milp(p)
        return build_rows(
            "cells",
            task["instance"],
            seed=task["seed"],
            size=3,
            sense="max",
            outcomes=[
                Outcome.of("ga", "heuristic", ga),
                Outcome.of("milp", "model", milp, bound_kind="candidate-set"),
            ],
        )


    with ResultStore(out / STORE_NAME) as store, make_executor(2) as ex:
        map_rows(
            my_task,
            [{"problem": "cells", "instance": instance_id("gap", seed=s), "seed": s} for s in range(10)],
            executor=ex,
            store=store,
        )

Store
-----
SQLite from the standard library in WAL mode with ``synchronous=FULL``: a task's rows go in
one transaction, so killing the process at any instant (``kill -9`` mid-write included)
leaves either all of a task's rows or none, never a torn row; the primary key
``(problem, instance, method)`` makes duplicates impossible. A store written by another
schema version is refused with a message saying what to do.
"""

from __future__ import annotations

import json
import math
import os
import sqlite3
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Self, TypeGuard

import pandas as pd

__all__ = [
    "SCHEMA_VERSION",
    "STORE_NAME",
    "COLUMNS",
    "KEY",
    "PROBLEMS",
    "ROLES",
    "BOUND_KINDS",
    "SENSES",
    "ERROR_STATUS",
    "SIZE_MEANING",
    "OBJECTIVE_UNITS",
    "StoreError",
    "instance_id",
    "Outcome",
    "build_rows",
    "error_row",
    "ResultStore",
    "load_results",
]

SCHEMA_VERSION = 1
"""Bumped whenever ``COLUMNS`` or their meaning change; older stores are refused."""

STORE_NAME = "results.sqlite"
"""File name of the store inside an ``--out`` directory."""

COLUMNS = (
    "study",
    "problem",
    "instance",
    "seed",
    "size",
    "method",
    "role",
    "sense",
    "status",
    "objective",
    "bound",
    "bound_kind",
    "gap_to_bound",
    "gap_bound_kind",
    "gap_to_best",
    "time_s",
    "warm_started",
    "message",
)
"""The schema's columns, in order (extras follow as ``<problem>_<name>``)."""

KEY = ("problem", "instance", "method")
"""The columns that identify a row."""

PROBLEMS = ("covert", "cells", "shark", "herding")
ROLES = ("heuristic", "model", "bound")
BOUND_KINDS = ("proven-global", "candidate-set", "instantaneous", "local", "none")
"""Strongest first: ``gap_to_bound`` uses the strongest kind present on an instance."""
SENSES = ("min", "max")
ERROR_STATUS = "error"

SIZE_MEANING = {
    "covert": "number of targets",
    "cells": "number of drone-cells m",
    "shark": "operators (fleet instances) or 1 (path instances)",
    "herding": "number of drones n",
}
OBJECTIVE_UNITS = {
    "covert": "max recorded bearing change beta_max (deg)",
    "cells": "covered users",
    "shark": "interception time (s) or latest interception (s)",
    "herding": "max travel (m) or time (s)",
}

_EPS = 1e-9


class StoreError(RuntimeError):
    """The store cannot be used (other schema version, not a store, unwritable)."""


def instance_id(study: str, **params: Any) -> str:
    """A stable instance id ``"<study>:k1=v1,k2=v2"`` (parameters sorted by name)."""
    if not study or ":" in study:
        raise ValueError(f"study must be a non-empty name without ':', got {study!r}")
    return f"{study}:" + ",".join(f"{k}={params[k]}" for k in sorted(params))


@dataclass
class Outcome:
    """What one method did on one instance, before the gaps are filled in.

    method: name of the heuristic/model/bound; role: heuristic | model | bound;
    status: a Status value string (``optimal``, ``feasible`` ...); objective, bound in the
    problem's units; bound_kind: what ``bound`` is proven for (``BOUND_KINDS``);
    time_s: wall time (s); warm_started: whether a warm start was used;
    extras: problem-specific values (scalars), stored as ``<problem>_<name>`` columns.
    """

    method: str
    role: str
    status: str
    objective: float | None = None
    bound: float | None = None
    bound_kind: str = "none"
    time_s: float | None = None
    warm_started: bool = False
    message: str = ""
    extras: Mapping[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if self.role not in ROLES:
            raise ValueError(f"role must be one of {ROLES}, got {self.role!r}")
        if self.bound_kind not in BOUND_KINDS:
            raise ValueError(f"bound_kind must be one of {BOUND_KINDS}, got {self.bound_kind!r}")
        if self.bound is not None and self.bound_kind == "none":
            raise ValueError(f"method {self.method!r}: a bound needs a bound_kind other than 'none'")

    @classmethod
    def of(
        cls,
        method: str,
        role: str,
        result,
        *,
        bound_kind: str | None = None,
        objective: float | None = None,
        extras: Mapping[str, Any] | None = None,
    ) -> Outcome:
        """An outcome from a ``SolveResult``: its status, objective, bound, time and warm start.

        bound_kind: required when ``result.bound`` is set (what the bound is proven for).
        objective: overrides ``result.objective`` (e.g. a unit conversion).
        """
        bound = result.bound if result.bound is not None and math.isfinite(result.bound) else None
        if bound is None:
            kind = "none"
        elif bound_kind is None:
            raise ValueError(f"method {method!r} has a bound: say what it is proven for (bound_kind)")
        else:
            kind = bound_kind
        obj = objective if objective is not None else (result.objective if result.has_solution else None)
        return cls(
            method=method,
            role=role,
            status=result.status.value,
            objective=obj,
            bound=bound,
            bound_kind=kind,
            time_s=result.solve_time,
            warm_started=bool(result.warm_started),
            message=result.message,
            extras=dict(extras or {}),
        )


def _rel_gap(value: float, ref: float, sense: str) -> float:
    diff = (value - ref) if sense == "min" else (ref - value)
    return diff / max(abs(ref), _EPS)


def _finite(v: Any) -> TypeGuard[float]:
    return v is not None and isinstance(v, (int, float)) and math.isfinite(v)


def build_rows(
    problem: str,
    instance: str,
    *,
    seed: int | None,
    size: int | None,
    sense: str,
    outcomes: Sequence[Outcome],
    study: str | None = None,
) -> list[dict]:
    """The rows of one instance, with ``gap_to_bound`` and ``gap_to_best`` filled in.

    problem: one of ``PROBLEMS``; instance: its stable id (:func:`instance_id`);
    seed, size: the instance parameters (``SIZE_MEANING``); sense: ``min``/``max``;
    study: defaults to the part of ``instance`` before ``':'``.
    """
    if problem not in PROBLEMS:
        raise ValueError(f"problem must be one of {PROBLEMS}, got {problem!r}")
    if sense not in SENSES:
        raise ValueError(f"sense must be 'min' or 'max', got {sense!r}")
    names = [o.method for o in outcomes]
    if len(set(names)) != len(names):
        raise ValueError(f"duplicate methods on instance {instance!r}: {names}")
    study = study or instance.split(":", 1)[0]
    solved = [o.objective for o in outcomes if o.role != "bound" and _finite(o.objective)]
    best = (min(solved) if sense == "min" else max(solved)) if solved else None
    ref_bound, ref_kind = None, None
    for kind in BOUND_KINDS[:-1]:
        bounds = [o.bound for o in outcomes if o.bound_kind == kind and _finite(o.bound)]
        if bounds:  # the tightest bound of the strongest kind present
            ref_bound, ref_kind = (max(bounds) if sense == "min" else min(bounds)), kind
            break
    rows = []
    for o in outcomes:
        obj = float(o.objective) if _finite(o.objective) else None
        row = {
            "study": study,
            "problem": problem,
            "instance": instance,
            "seed": None if seed is None else int(seed),
            "size": None if size is None else int(size),
            "method": o.method,
            "role": o.role,
            "sense": sense,
            "status": str(o.status),
            "objective": obj,
            "bound": float(o.bound) if _finite(o.bound) else None,
            "bound_kind": o.bound_kind,
            "gap_to_bound": _rel_gap(obj, ref_bound, sense)
            if (obj is not None and ref_bound is not None and o.role != "bound")
            else None,
            "gap_bound_kind": ref_kind
            if (obj is not None and ref_bound is not None and o.role != "bound")
            else None,
            "gap_to_best": _rel_gap(obj, best, sense)
            if (obj is not None and best is not None and o.role != "bound")
            else None,
            "time_s": None if o.time_s is None else float(o.time_s),
            "warm_started": bool(o.warm_started),
            "message": str(o.message or ""),
        }
        row.update({f"{problem}_{k}": _jsonable(v) for k, v in o.extras.items()})
        rows.append(row)
    return rows


def error_row(
    problem: str, instance: str, message: str, *, seed: int | None = None, size: int | None = None
) -> dict:
    """The row recorded for a task that raised: method ``task``, status ``error``."""
    row = dict.fromkeys(COLUMNS)
    row.update(
        study=instance.split(":", 1)[0],
        problem=problem,
        instance=instance,
        seed=seed,
        size=size,
        method="task",
        role="task",
        status=ERROR_STATUS,
        warm_started=False,
        message=message,
    )
    return row


def _jsonable(v: Any) -> Any:
    if hasattr(v, "tolist"):  # numpy scalars and arrays
        v = v.tolist()
    if isinstance(v, float) and not math.isfinite(v):
        return None
    if isinstance(v, (list, tuple)):
        return [_jsonable(x) for x in v]
    if isinstance(v, dict):
        return {str(k): _jsonable(x) for k, x in v.items()}
    return v


# --------------------------------------------------------------------------- the store
_CORE = list(COLUMNS)
_DDL = (
    "CREATE TABLE IF NOT EXISTS rows ("
    + ", ".join(f'"{c}"' for c in _CORE)
    + ", extras TEXT NOT NULL DEFAULT '{}', PRIMARY KEY (problem, instance, method))"
)


class ResultStore:
    """The crash-safe store of one ``--out`` directory (SQLite, WAL, one transaction per task).

    path: the SQLite file (created with its parent directory). Use as a context manager
    or call :meth:`close`. Raises :class:`StoreError` when the file is not a store of this
    schema version or cannot be written.
    """

    def __init__(self, path: str | os.PathLike):
        self.path = Path(path)
        try:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            self._con = sqlite3.connect(self.path, timeout=30.0, isolation_level=None)
            self._con.execute("PRAGMA journal_mode=WAL")
            self._con.execute("PRAGMA synchronous=FULL")
            self._init_schema()
        except sqlite3.DatabaseError as exc:
            raise StoreError(
                f"{self.path} is not a usable results store ({exc}); move it away or choose another --out"
            ) from exc
        except OSError as exc:
            raise StoreError(f"cannot write the results store {self.path}: {exc.strerror or exc}") from exc

    def _init_schema(self) -> None:
        con = self._con
        con.execute("BEGIN IMMEDIATE")
        try:
            con.execute("CREATE TABLE IF NOT EXISTS meta (key TEXT PRIMARY KEY, value TEXT NOT NULL)")
            found = con.execute("SELECT value FROM meta WHERE key = 'schema_version'").fetchone()
            if found is None:
                has_rows = con.execute("SELECT name FROM sqlite_master WHERE name = 'rows'").fetchone()
                if has_rows:
                    raise StoreError(
                        f"{self.path} has rows but no schema version (written by an older droneplan); "
                        "move it away or choose another --out, then rerun the study"
                    )
                con.execute("INSERT INTO meta VALUES ('schema_version', ?)", (str(SCHEMA_VERSION),))
                con.execute(_DDL)
            elif int(found[0]) != SCHEMA_VERSION:
                raise StoreError(
                    f"{self.path} was written with results schema version {found[0]}; this droneplan "
                    f"writes version {SCHEMA_VERSION}. Move it away (or choose another --out) and "
                    "rerun the study; rows of different schemas are not mixed"
                )
            con.execute("COMMIT")
        except BaseException:  # e.g. Ctrl-C: undo a half-done transaction (a committed one stays)
            if con.in_transaction:
                con.execute("ROLLBACK")
            raise

    # ------------------------------------------------------------------ context
    def __enter__(self) -> Self:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def close(self) -> None:
        """Close the connection (the rows are already on disk)."""
        self._con.close()

    # ------------------------------------------------------------------ writing
    def write(self, rows: Iterable[Mapping[str, Any]]) -> None:
        """Write one task's rows in one transaction, replacing that task's earlier rows.

        Every row repeats ``problem`` and ``instance``; the rows of those instances that
        were on disk before (e.g. an error row being retried) are replaced atomically.
        """
        rows = list(rows)
        if not rows:
            return
        for r in rows:
            missing = [k for k in KEY if r.get(k) in (None, "")]
            if missing:
                raise ValueError(f"row lacks key columns {missing}: {dict(r)}")
            if r.get("problem") not in PROBLEMS:
                raise ValueError(f"row has unknown problem {r.get('problem')!r}")
        instances = {(r["problem"], r["instance"]) for r in rows}
        records = []
        for r in rows:
            core = [_jsonable(r.get(c)) for c in _CORE]
            core[_CORE.index("warm_started")] = int(bool(r.get("warm_started")))
            extras = {k: _jsonable(v) for k, v in r.items() if k not in _CORE}
            records.append((*core, json.dumps(extras, sort_keys=True, allow_nan=False)))
        con = self._con
        con.execute("BEGIN IMMEDIATE")
        try:
            con.executemany("DELETE FROM rows WHERE problem = ? AND instance = ?", sorted(instances))
            con.executemany(f"INSERT INTO rows VALUES ({', '.join('?' * (len(_CORE) + 1))})", records)
            con.execute("COMMIT")
        except BaseException:  # e.g. Ctrl-C: undo a half-done transaction (a committed one stays)
            if con.in_transaction:
                con.execute("ROLLBACK")
            raise

    # ------------------------------------------------------------------ reading
    def done_instances(self, problem: str | None = None) -> set[tuple[str, str]]:
        """``(problem, instance)`` pairs whose rows are on disk without an error row."""
        q = (
            "SELECT problem, instance, MAX(status = ?) FROM rows"
            + (" WHERE problem = ?" if problem else "")
            + " GROUP BY problem, instance"
        )
        args = (ERROR_STATUS, problem) if problem else (ERROR_STATUS,)
        return {(p, i) for p, i, err in self._con.execute(q, args) if not err}

    def count(self) -> int:
        """Number of rows in the store."""
        return int(self._con.execute("SELECT COUNT(*) FROM rows").fetchone()[0])

    def frame(self, problem: str | None = None, study: str | None = None) -> pd.DataFrame:
        """The rows as a DataFrame: ``COLUMNS`` then the prefixed extras, in key order."""
        where, args = [], []
        if problem:
            where.append("problem = ?")
            args.append(problem)
        if study:
            where.append("study = ?")
            args.append(study)
        q = (
            "SELECT * FROM rows"
            + (" WHERE " + " AND ".join(where) if where else "")
            + " ORDER BY problem, instance, method"
        )
        cur = self._con.execute(q, args)
        names = [d[0] for d in cur.description]
        data = cur.fetchall()
        return _to_frame(names, data)

    def export(self, path: str | os.PathLike, **filters: str) -> Path:
        """Write the rows to ``path`` (``.csv`` or ``.parquet``, the latter needs pyarrow)."""
        path = Path(path)
        df = self.frame(**filters)
        if path.suffix == ".parquet":
            df.to_parquet(path, index=False)
        elif path.suffix == ".csv":
            tmp = path.with_suffix(".csv.tmp")
            df.to_csv(tmp, index=False)
            os.replace(tmp, path)  # a reader never sees a half-written export
        else:
            raise ValueError(f"export path must end in .csv or .parquet, got {path.name!r}")
        return path


def _to_frame(names: Sequence[str], data: Sequence[tuple]) -> pd.DataFrame:
    ix = names.index("extras")
    core = pd.DataFrame([r[:ix] + r[ix + 1 :] for r in data], columns=[n for n in names if n != "extras"])
    core = core.reindex(columns=list(COLUMNS))
    extras = pd.DataFrame([json.loads(r[ix]) for r in data], index=core.index)
    df = pd.concat([core, extras], axis=1) if len(extras.columns) else core
    return _typed(df)


def _typed(df: pd.DataFrame) -> pd.DataFrame:
    for c in ("objective", "bound", "gap_to_bound", "gap_to_best", "time_s"):
        df[c] = pd.to_numeric(df[c], errors="coerce").astype(float)
    for c in ("seed", "size"):
        df[c] = pd.to_numeric(df[c], errors="coerce").astype("Int64")
    df["warm_started"] = df["warm_started"].fillna(0).astype(bool)
    return df


def load_results(
    out: str | os.PathLike, *, problem: str | None = None, study: str | None = None
) -> pd.DataFrame:
    """Every result row under an ``--out`` directory, in the one long-format schema.

    out: the directory given to ``droneplan gap/reproduce --out`` (searched recursively
    for ``results.sqlite``) or a store file itself. problem, study: optional filters.
    Returns a DataFrame with ``COLUMNS`` first, then prefixed extras; an empty frame with
    those columns when nothing was found.
    """
    out = Path(out)
    if not out.exists():
        raise FileNotFoundError(f"out: {out} does not exist")
    paths = [out] if out.is_file() else sorted(out.rglob(STORE_NAME))
    frames = []
    for p in paths:
        with ResultStore(p) as store:
            frames.append(store.frame(problem=problem, study=study))
    frames = [f for f in frames if len(f)]
    if not frames:
        return _typed(pd.DataFrame(columns=list(COLUMNS)))
    df = pd.concat(frames, ignore_index=True)
    return df.drop_duplicates(subset=list(KEY), keep="last").reset_index(drop=True)
