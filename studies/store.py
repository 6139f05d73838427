"""One long-format results schema for every study, and the crash-safe store that holds it.

Schema (version 3)
------------------
One row per ``(problem, instance, method, config, run)``; the columns (``COLUMNS``) are the same
for all four problems:

``study``         which study wrote the row (``"gap"``, ``"fig6.7"``, ``"table4.3"`` ...)
``problem``       ``covert`` | ``cells`` | ``shark`` | ``herding``
``instance``      a stable id of the instance, e.g. ``"gap:n_targets=3,seed=7"``
                  (:func:`instance_id`); the same task always gets the same id
``seed``          the instance's seed; ``size`` its main size (``SIZE_MEANING``)
``method``        the heuristic, model or bound that produced the row
``role``          ``heuristic`` | ``model`` | ``bound`` (``task`` for an error row)
``sense``         ``min`` or ``max``: the direction in which ``objective`` is better
``status``        a :class:`~droneplan.solvers.result.Status` value (``optimal``,
                  ``feasible``, ``no_solution`` ...) or ``error`` (the task raised),
                  ``timeout``, ``infeasible`` (an infeasible plan), ``invalid`` (a return
                  value of the wrong type or shape)
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
``gap_to_best``   relative gap of ``objective`` to the best objective that a solved row
                  (status ``optimal``/``feasible``, role other than ``bound``, not flagged
                  ``beats-bound``) reached on the instance (0 for the best)
``time_s``        wall time of the method (s); ``warm_started`` whether it was warm-started
``message``       a solver message or, for an error row, the exception
``config``        16 hex digits identifying how the row was computed (settings and code,
                  :func:`~droneplan.studies.provenance.config_hash`); part of the key
``flag``          ``''`` or ``;``-joined flags: ``beats-bound`` (the objective is better
                  than a ``proven-global``/``candidate-set`` bound of the instance, relative
                  tolerance 1e-9: one of them is wrong), ``claim-mismatch`` ...
``claimed_objective`` what the method said its objective was (the evaluator's value is
                  ``objective``); ``family``, ``family_version`` the instance family;
                  ``method_params`` the method's settings (JSON); ``time_limit_s`` (s)
``droneplan_version``, ``git_commit``, ``code_hash``, ``packages`` (JSON: name -> version),
``cpu``, ``cores``, ``finished_at`` (ISO 8601, UTC): provenance
(:func:`~droneplan.studies.provenance.provenance_columns`)
``run``           the repetition of the (instance, method) job, 0 .. R-1 (``droneplan.gap(runs=R)``);
                  part of the key; 0 for a study that runs each job once
``run_seed``      the seed the run was given (run 0: the instance's seed; run r:
                  :func:`~droneplan.core.validation.run_seed`); None where no seed was passed
``deterministic`` True when the method gives the same plan whatever the seed (declared, or seen
                  on runs 0 and 1; it then runs once), False when it is stochastic, None unknown

plus problem-specific extras as prefixed columns ``<problem>_<name>`` (kept as JSON in the
store and expanded by :meth:`ResultStore.frame`).

The gap columns and the ``beats-bound`` flag depend on the other rows of the instance, so
they are recomputed whenever rows are read (:func:`fill_gaps`): a row written later (a
better heuristic, a tighter bound) updates the gaps of the rows written before it.

How a problem's study emits rows
--------------------------------
A study defines a module-level task function ``task -> list[row]`` (so process pools and
Dask can pickle it). Each task dict holds ``problem`` and ``instance`` (use
:func:`instance_id`) plus whatever the function needs. The function runs every method on
the instance, turns each outcome into an :class:`Outcome` (:meth:`Outcome.of` converts a
``SolveResult``) and returns ``build_rows(problem, instance, seed=..., size=..., sense=...,
outcomes=[...])``, which fills the gaps. :func:`droneplan.studies.jobs.map_rows` runs the
tasks not yet in the store through an executor, adds the ``config`` and provenance columns,
and writes each task's rows in one transaction. ::

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
SQLite from the standard library in WAL mode with ``synchronous=FULL``: a write goes in one
transaction, so killing the process at any instant (``kill -9`` mid-write included) leaves
either all of its rows or none, never a torn row; the primary key makes duplicates
impossible. After each write the log is checkpointed into the main file, so a copy of the
``.sqlite`` file alone holds every finished row. A row whose ``(problem, instance, method)``
is written again with another ``config`` moves to the ``superseded`` table (kept, not read
by default), with every run of that config. A store of schema version 2 is migrated in place
when opened for writing (its rows, current and superseded, become run 0), and one of version 1
through version 2; a
store of another version, or a file that is not a store, is refused with a
:class:`StoreError` saying what to do, as is every failure of the file system or SQLite.
Concurrent runs on one store avoid doing the same job twice with
:meth:`ResultStore.try_claim`.
"""

from __future__ import annotations

import contextlib
import errno
import json
import math
import numbers
import os
import socket
import sqlite3
import tempfile
import time
import urllib.parse
from collections import defaultdict
from collections.abc import Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Self, TypeGuard

import numpy as np
import pandas as pd

from droneplan.core.validation import check_bool
from droneplan.studies.problems import PROBLEMS

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
    "SOLVED_STATUSES",
    "BEATS_BOUND",
    "LIBRARY_METHOD",
    "REFERENCE_METHOD",
    "LIBRARY_SUSPECT",
    "SIZE_MEANING",
    "OBJECTIVE_UNITS",
    "StoreError",
    "InstanceDataError",
    "instance_id",
    "Outcome",
    "build_rows",
    "error_row",
    "fill_gaps",
    "ResultStore",
    "load_results",
]

SCHEMA_VERSION = 3
"""Bumped whenever ``COLUMNS`` or their meaning change; versions 1 and 2 are migrated, others refused."""

STORE_NAME = "results.sqlite"
"""File name of the store inside an ``--out`` directory."""

_V1_COLUMNS = (
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

_V2_COLUMNS = (
    *_V1_COLUMNS,
    "config",
    "flag",
    "claimed_objective",
    "family",
    "family_version",
    "method_params",
    "time_limit_s",
    "droneplan_version",
    "git_commit",
    "code_hash",
    "packages",
    "cpu",
    "cores",
    "finished_at",
)

COLUMNS = (*_V2_COLUMNS, "run", "run_seed", "deterministic")
"""The schema's columns, in order (extras follow as ``<problem>_<name>``)."""

KEY = ("problem", "instance", "method", "config", "run")
"""The columns that identify a row."""

ROLES = ("heuristic", "model", "bound")
BOUND_KINDS = ("proven-global", "candidate-set", "instantaneous", "local", "none")
"""Strongest first: ``gap_to_bound`` uses the strongest kind present on an instance."""
SENSES = ("min", "max")
ERROR_STATUS = "error"
SOLVED_STATUSES = ("optimal", "feasible")
"""Statuses of rows whose objective may define the instance's best (``gap_to_best``)."""
BEATS_BOUND = "beats-bound"
"""Flag of a row whose objective is better than a proven-global or candidate-set bound."""
LIBRARY_METHOD = "library"
"""The ``method`` of the reference row a study reads from the certified library."""
REFERENCE_METHOD = "reference"
"""The ``method`` of the row holding a reference solved for a study (role ``bound``:
:mod:`droneplan.studies.references`)."""
LIBRARY_SUSPECT = "library-suspect"
"""The flag of a library row whose proven bound a verified plan of the same instance beats."""
_STRICT_KINDS = ("proven-global", "candidate-set")
_TASK_METHOD = "task"

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
    """The store cannot be used (other schema version, not a store, unwritable, disk full ...)."""


class InstanceDataError(ValueError):
    """An instance id the store already holds under other data (one line)."""


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


def _num(v: Any) -> float | None:
    """``v`` as a finite float (Python or numpy number), else None (None, NaN, inf, bool, text)."""
    if v is None or isinstance(v, (bool, np.bool_)) or not isinstance(v, numbers.Real):
        return None
    f = float(v)
    return f if math.isfinite(f) else None


def _finite(v: Any) -> TypeGuard[float]:
    return _num(v) is not None


def _flags(flag: Any) -> list[str]:
    if flag is None or (isinstance(flag, float) and math.isnan(flag)) or flag is pd.NA:
        return []
    return [f for f in str(flag).split(";") if f]


def _join_flags(flags: Iterable[str]) -> str:
    return ";".join(dict.fromkeys(f for f in flags if f))


def _beats(objective: float | None, limit: float | None, sense: str) -> bool:
    """Whether ``objective`` is better than the bound ``limit`` beyond the relative tolerance 1e-9."""
    return objective is not None and limit is not None and _rel_gap(objective, limit, sense) < -_EPS


def _gap_columns(  # noqa: C901
    cols: Mapping[str, Sequence[Any]], reference: Sequence[bool] | None = None
) -> dict[str, list[Any]]:
    """``gap_to_bound``, ``gap_bound_kind``, ``gap_to_best`` and ``flag`` of every row.

    cols: per column (problem, instance, method, role, status, sense, objective, bound,
    bound_kind, flag) one value per row; reference: which rows may define an instance's
    best and bounds (default: all).
    """
    n = len(cols["problem"])
    out: dict[str, list[Any]] = {
        "gap_to_bound": [None] * n,
        "gap_bound_kind": [None] * n,
        "gap_to_best": [None] * n,
        "flag": [_join_flags(f for f in _flags(v) if f != BEATS_BOUND) for v in cols["flag"]],
    }
    groups: dict[tuple[Any, Any], list[int]] = defaultdict(list)
    for k in range(n):
        groups[(cols["problem"][k], cols["instance"][k])].append(k)
    obj = [_num(v) for v in cols["objective"]]
    bnd = [_num(v) for v in cols["bound"]]
    for idx in groups.values():
        sense = next((cols["sense"][k] for k in idx if cols["sense"][k] in SENSES), None)
        if sense is None:
            continue
        better = max if sense == "min" else min  # the tightest bound
        suspect = _suspect_library_rows(cols, idx, obj, bnd, sense)
        for k in suspect:
            out["flag"][k] = _join_flags([*_flags(out["flag"][k]), LIBRARY_SUSPECT])
        ref = [k for k in idx if (reference is None or reference[k]) and k not in suspect]
        strict = [bnd[k] for k in ref if cols["bound_kind"][k] in _STRICT_KINDS and bnd[k] is not None]
        limit = better(v for v in strict if v is not None) if strict else None
        beats = {k: _beats(obj[k], limit, sense) for k in idx}
        ref_bound, ref_kind = None, None
        for kind in BOUND_KINDS[:-1]:
            bounds = [bnd[k] for k in ref if cols["bound_kind"][k] == kind and bnd[k] is not None]
            if bounds:  # the tightest bound of the strongest kind present
                ref_bound, ref_kind = better(v for v in bounds if v is not None), kind
                break
        solved = [
            obj[k]
            for k in ref
            if obj[k] is not None
            and cols["role"][k] != "bound"
            and cols["status"][k] in SOLVED_STATUSES
            and not beats[k]
        ]
        best = (min if sense == "min" else max)(v for v in solved if v is not None) if solved else None
        for k in idx:
            o = obj[k]
            if beats[k]:
                out["flag"][k] = _join_flags([*_flags(out["flag"][k]), BEATS_BOUND])
            if o is None or cols["role"][k] == "bound":
                continue
            if ref_bound is not None:
                out["gap_to_bound"][k] = _rel_gap(o, ref_bound, sense)
                out["gap_bound_kind"][k] = ref_kind
            if best is not None:
                out["gap_to_best"][k] = _rel_gap(o, best, sense)
    return out


def _suspect_library_rows(
    cols: Mapping[str, Sequence[Any]], idx: list[int], obj: list[Any], bnd: list[Any], sense: str
) -> set[int]:
    """The certified-library rows of one instance whose proven bound a plan droneplan verified
    beats: the library is wrong there, not the method (the row gets ``library-suspect`` and its
    bound defines no gap)."""
    verified = [
        k
        for k in idx
        if cols["method"][k] != LIBRARY_METHOD
        and cols["role"][k] != "bound"
        and cols["status"][k] in SOLVED_STATUSES
        and obj[k] is not None
    ]
    return {
        k
        for k in idx
        if cols["method"][k] == LIBRARY_METHOD
        and bnd[k] is not None
        and any(_beats(obj[j], bnd[k], sense) for j in verified)
    }


_GAP_INPUTS = ("problem", "instance", "method", "role", "status", "sense", "objective", "bound")


def fill_gaps(df: pd.DataFrame, reference: Sequence[bool] | pd.Series | None = None) -> pd.DataFrame:
    """``df`` with ``gap_to_bound``, ``gap_bound_kind``, ``gap_to_best`` and ``flag`` recomputed.

    df: rows in the results schema (any order, any number of instances); per
    ``(problem, instance)`` the best objective and the reference bound are taken over its
    rows: the best over rows with status ``optimal``/``feasible`` and a role other than
    ``bound``, the bound as the tightest of the strongest ``bound_kind`` present. A row whose
    objective is better than a ``proven-global`` or ``candidate-set`` bound of its instance by
    more than the relative tolerance 1e-9 gets ``beats-bound`` in its ``flag`` and does not
    define the best (its own gaps, then negative, are still given). reference: a boolean
    per row, False for rows that get gaps but define neither best nor bound (e.g.
    superseded rows); default all True. Returns a new frame with the same rows and order.
    """
    df = df.copy()
    for c in (*_GAP_INPUTS, "bound_kind", "flag", "gap_to_bound", "gap_bound_kind", "gap_to_best"):
        if c not in df.columns:
            df[c] = None
    if reference is not None:
        reference = [bool(v) for v in reference]
        if len(reference) != len(df):
            raise ValueError(f"reference must have one value per row ({len(df)}), got {len(reference)}")
    cols = {c: df[c].astype(object).tolist() for c in (*_GAP_INPUTS, "bound_kind", "flag")}
    for c, values in _gap_columns(cols, reference).items():
        df[c] = pd.Series(values, index=df.index, dtype=float if c.startswith("gap_to") else object)
    return df


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
    """The rows of one instance, with ``gap_to_bound``, ``gap_to_best`` and ``flag`` filled in.

    problem: one of ``PROBLEMS``; instance: its stable id (:func:`instance_id`);
    seed, size: the instance parameters (``SIZE_MEANING``); sense: ``min``/``max``;
    outcomes: one :class:`Outcome` per method; study: defaults to the part of ``instance``
    before ``':'``. The gaps follow :func:`fill_gaps` (the store recomputes them on read).
    ``config`` is ``''`` and the provenance columns are None until the rows are written by
    :func:`~droneplan.studies.jobs.map_rows` (or filled by the caller).
    """
    if problem not in PROBLEMS:
        raise ValueError(f"problem must be one of {PROBLEMS}, got {problem!r}")
    if sense not in SENSES:
        raise ValueError(f"sense must be 'min' or 'max', got {sense!r}")
    names = [o.method for o in outcomes]
    if len(set(names)) != len(names):
        raise ValueError(f"duplicate methods on instance {instance!r}: {names}")
    study = study or instance.split(":", 1)[0]
    rows = []
    for o in outcomes:
        row: dict[str, Any] = dict.fromkeys(COLUMNS)
        row.update(
            study=study,
            problem=problem,
            instance=instance,
            seed=None if seed is None else int(seed),
            size=None if size is None else int(size),
            method=o.method,
            role=o.role,
            sense=sense,
            status=str(o.status),
            objective=_num(o.objective),
            bound=_num(o.bound),
            bound_kind=o.bound_kind,
            time_s=_num(o.time_s),
            warm_started=bool(o.warm_started),
            message=str(o.message or ""),
            config="",
            flag="",
        )
        row.update({f"{problem}_{k}": _jsonable(v) for k, v in o.extras.items()})
        rows.append(row)
    if rows:
        gaps = _gap_columns({c: [r[c] for r in rows] for c in (*_GAP_INPUTS, "bound_kind", "flag")})
        for k, row in enumerate(rows):
            for c, values in gaps.items():
                row[c] = values[k]
    return rows


def error_row(
    problem: str, instance: str, message: str, *, seed: int | None = None, size: int | None = None
) -> dict:
    """The row recorded for a task that raised: method ``task``, status ``error``.

    problem, instance: the task's; message: the exception; seed, size: the instance's.
    It is removed when the instance's rows are written later.
    """
    row = dict.fromkeys(COLUMNS)
    row.update(
        study=instance.split(":", 1)[0],
        problem=problem,
        instance=instance,
        seed=seed,
        size=size,
        method=_TASK_METHOD,
        role=_TASK_METHOD,
        status=ERROR_STATUS,
        warm_started=False,
        message=message,
        config="",
        flag="",
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


# --------------------------------------------------------------------------- errors
_SQLITE_PERM, _SQLITE_BUSY, _SQLITE_LOCKED, _SQLITE_READONLY = 3, 5, 6, 8
_SQLITE_IOERR, _SQLITE_CORRUPT, _SQLITE_FULL, _SQLITE_CANTOPEN, _SQLITE_NOTADB = 10, 11, 13, 14, 26


def _first_line(exc: BaseException) -> str:
    text = str(exc).strip()
    return text.splitlines()[0] if text else type(exc).__name__


def _store_error(path: Path, exc: BaseException, action: str) -> StoreError:
    """A one-line :class:`StoreError` for a failure of SQLite or the OS while ``action``-ing ``path``."""
    if isinstance(exc, StoreError):
        return exc
    code = getattr(exc, "sqlite_errorcode", None)
    primary = None if code is None else int(code) & 0xFF
    text = _first_line(exc)
    if isinstance(exc, OSError):
        text = exc.strerror or text
        primary = {
            errno.ENOSPC: _SQLITE_FULL,
            errno.EDQUOT: _SQLITE_FULL,
            errno.EACCES: _SQLITE_READONLY,
            errno.EPERM: _SQLITE_READONLY,
            errno.EROFS: _SQLITE_READONLY,
        }.get(exc.errno or 0)
    if primary == _SQLITE_FULL:
        return StoreError(
            f"the disk holding {path} is full ({text}) while trying to {action} it; free some space "
            "and rerun (finished rows are kept)"
        )
    if primary in (_SQLITE_READONLY, _SQLITE_PERM):
        return StoreError(
            f"cannot {action} the results store {path}: {text} (read-only file or directory); make it "
            "writable or choose another --out (load_results can still read it)"
        )
    if primary == _SQLITE_CANTOPEN:
        return StoreError(
            f"cannot open the results store {path}: {text} (a directory, a missing or read-only "
            "folder?); check the path and its permissions or choose another --out (load_results can "
            "read a read-only store)"
        )
    if primary in (_SQLITE_NOTADB, _SQLITE_CORRUPT):
        return StoreError(
            f"{path} is not a usable results store ({text}); move it away or choose another --out"
        )
    if primary in (_SQLITE_BUSY, _SQLITE_LOCKED):
        return StoreError(
            f"the results store {path} stayed locked by another process ({text}); wait for that run "
            "to finish or choose another --out"
        )
    if primary == _SQLITE_IOERR:
        return StoreError(f"I/O error on the results store {path} ({text}); check the disk, then rerun")
    return StoreError(f"cannot {action} the results store {path}: {text}")


# --------------------------------------------------------------------------- the store
_CORE = list(COLUMNS)
_COLUMN_TYPE = {"config": " TEXT NOT NULL DEFAULT ''", "run": " INTEGER NOT NULL DEFAULT 0"}


def _table_ddl(name: str) -> str:
    cols = ", ".join(f'"{c}"' + _COLUMN_TYPE.get(c, "") for c in _CORE)
    return (
        f"CREATE TABLE IF NOT EXISTS {name} ({cols}, extras TEXT NOT NULL DEFAULT '{{}}', "
        f"PRIMARY KEY ({', '.join(KEY)}))"
    )


_CLAIMS_DDL = (
    "CREATE TABLE IF NOT EXISTS claims (problem TEXT NOT NULL, instance TEXT NOT NULL, "
    "method TEXT NOT NULL, config TEXT NOT NULL, run INTEGER NOT NULL, host TEXT NOT NULL, "
    "pid INTEGER NOT NULL, claimed_at REAL NOT NULL, PRIMARY KEY (problem, instance, method, config, run))"
)
_INSTANCE_DATA_DDL = (
    "CREATE TABLE IF NOT EXISTS instance_data (problem TEXT NOT NULL, instance TEXT NOT NULL, "
    "fingerprint TEXT NOT NULL, PRIMARY KEY (problem, instance))"
)
_KEY_WHERE = " AND ".join(f"{k} = ?" for k in KEY)
_MIGRATED = (1, 2)  # the older schema versions a writable store is migrated from
_TEXT_JSON = ("method_params", "packages")  # JSON text columns: a mapping given is encoded

DEFAULT_STALE_AFTER_S = 6 * 3600.0
"""A claim older than this (s) can be taken over even when its process may still run."""


def _process_started_at(pid: int) -> float | None:
    """When process ``pid`` started (Unix time, s), from ``/proc``; None where it cannot be read."""
    try:
        with open(f"/proc/{pid}/stat", encoding="ascii", errors="replace") as fh:
            ticks = int(fh.read().rsplit(")", 1)[-1].split()[19])
        with open("/proc/stat", encoding="ascii") as fh:
            boot = next(float(line.split()[1]) for line in fh if line.startswith("btime "))
        return boot + ticks / os.sysconf("SC_CLK_TCK")
    except (OSError, ValueError, IndexError, StopIteration):
        return None


def _claimant_alive(pid: int, claimed_at: float) -> bool:
    """Whether the process that made a claim at ``claimed_at`` (Unix time, s) still runs: ``pid``
    is alive and started before the claim (a pid reused by a later process is not the claimant)."""
    if not _pid_alive(pid):
        return False
    started = _process_started_at(pid)
    return started is None or started <= claimed_at + 2.0  # the clock-tick rounding of /proc


def _pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    except OSError:
        return False
    try:  # a zombie (exited, not yet reaped) is dead for our purpose
        with open(f"/proc/{pid}/stat", encoding="ascii", errors="replace") as fh:
            return fh.read().rsplit(")", 1)[-1].split()[0] != "Z"
    except (OSError, IndexError):
        return True


class ResultStore:
    """The crash-safe store of one ``--out`` directory (SQLite, WAL, one transaction per write).

    path: the SQLite file (created with its parent directory unless ``readonly``).
    readonly: open for reading only (``mode=ro``; in a read-only directory the file is read
    as immutable); a version-1 store is then read as it is instead of being migrated.
    Use as a context manager or call :meth:`close`. Raises :class:`StoreError` when the
    file is not a store of a known schema version or cannot be opened.
    """

    def __init__(self, path: str | os.PathLike, *, readonly: bool = False):
        self.path = Path(path)
        self.readonly = bool(readonly)
        self._con: sqlite3.Connection | None = None
        try:
            if self.readonly:
                self._con, self.version = self._open_readonly()
            else:
                self.path.parent.mkdir(parents=True, exist_ok=True)
                self._con = sqlite3.connect(self.path, timeout=30.0, isolation_level=None)
                self._con.execute("PRAGMA journal_mode=WAL")
                self._con.execute("PRAGMA synchronous=FULL")
                self._init_schema()
                self.version = SCHEMA_VERSION
        except BaseException as exc:
            self.close()
            if isinstance(exc, (sqlite3.Error, OSError)):
                raise _store_error(self.path, exc, "open") from exc
            raise

    # ------------------------------------------------------------------ opening
    def _uri(self, flag: str) -> str:
        return "file:" + urllib.parse.quote(str(self.path.resolve())) + "?" + flag

    def _open_readonly(self) -> tuple[sqlite3.Connection, int]:
        if not self.path.is_file():
            raise StoreError(f"no results store at {self.path}; check the path (or run the study first)")
        con = sqlite3.connect(self._uri("mode=ro"), uri=True, timeout=30.0, isolation_level=None)
        try:
            return con, self._check_version(con)
        except sqlite3.Error as exc:
            con.close()
            code = (getattr(exc, "sqlite_errorcode", 0) or 0) & 0xFF
            if code not in (_SQLITE_CANTOPEN, _SQLITE_READONLY, _SQLITE_PERM, _SQLITE_IOERR):
                raise
        # mode=ro needs to create the -shm beside the file: not possible in a read-only folder
        wal = self.path.with_name(self.path.name + "-wal")
        if wal.exists() and wal.stat().st_size > 0:
            raise StoreError(
                f"cannot read {self.path}: its write-ahead log {wal.name} may hold rows, and reading "
                f"it needs write access to {self.path.parent}; make that folder writable, or copy "
                f"{self.path.name} and {wal.name} together into a writable folder and read the copy"
            )
        con = sqlite3.connect(self._uri("immutable=1"), uri=True, timeout=30.0, isolation_level=None)
        try:
            return con, self._check_version(con)
        except BaseException:
            con.close()
            raise

    def _check_version(self, con: sqlite3.Connection) -> int:
        """The schema version of the store behind ``con`` (read-only); StoreError if not a store."""
        tables = {r[0] for r in con.execute("SELECT name FROM sqlite_master WHERE type = 'table'")}
        if "meta" not in tables:
            if "rows" in tables:
                raise self._no_version()
            raise StoreError(
                f"{self.path} is not a results store (an SQLite file without droneplan's tables); "
                "check the path"
            )
        version = self._version_of(con)
        if version not in _MIGRATED and version != SCHEMA_VERSION:
            raise self._other_version(version)
        return version

    def _no_version(self) -> StoreError:
        return StoreError(
            f"{self.path} has rows but no schema version (written by an older droneplan); "
            "move it away or choose another --out, then rerun the study"
        )

    def _other_version(self, found: Any) -> StoreError:
        return StoreError(
            f"{self.path} was written with results schema version {found}; this droneplan writes "
            f"version {SCHEMA_VERSION} (and migrates versions 1 and 2). Move it away (or choose another "
            "--out) and rerun the study; rows of different schemas are not mixed"
        )

    def _version_of(self, con: sqlite3.Connection) -> Any:
        found = con.execute("SELECT value FROM meta WHERE key = 'schema_version'").fetchone()
        if found is None:
            raise self._no_version()
        try:
            return int(found[0])
        except (TypeError, ValueError):
            return found[0]

    def _init_schema(self) -> None:
        con = self._connection()
        con.execute("BEGIN IMMEDIATE")
        try:
            tables = {r[0] for r in con.execute("SELECT name FROM sqlite_master WHERE type = 'table'")}
            if "meta" not in tables:
                if "rows" in tables:
                    raise self._no_version()
                if tables:
                    raise StoreError(
                        f"{self.path} is an SQLite file of something else (tables: "
                        f"{', '.join(sorted(tables))}); move it away or choose another --out"
                    )
                con.execute("CREATE TABLE meta (key TEXT PRIMARY KEY, value TEXT NOT NULL)")
                con.execute("INSERT INTO meta VALUES ('schema_version', ?)", (str(SCHEMA_VERSION),))
            else:
                version = self._version_of(con)
                if version == 1:
                    self._migrate_v1(con)
                elif version == 2:
                    self._migrate_v2(con)
                elif version != SCHEMA_VERSION:
                    raise self._other_version(version)
            con.execute(_table_ddl("rows"))
            con.execute(_table_ddl("superseded"))
            con.execute(_CLAIMS_DDL)
            con.execute(_INSTANCE_DATA_DDL)
            con.execute("COMMIT")
        except BaseException:  # e.g. Ctrl-C: undo a half-done transaction (a committed one stays)
            self._rollback()
            raise

    def _migrate_v1(self, con: sqlite3.Connection) -> None:
        """Version 1 -> 3 (through 2) inside the caller's transaction: the rows become current rows,
        config '' (version 2), run 0 (version 3)."""
        have = [r[1] for r in con.execute("PRAGMA table_info(rows)")]
        cols = [c for c in _V1_COLUMNS if c in have] + ["extras"]
        if "problem" not in have or "method" not in have:
            raise StoreError(f"{self.path} says schema version 1 but its rows table is not one; move it away")
        if "config" in have:  # a version-2 table: migrating would drop its provenance columns
            raise StoreError(
                f"{self.path} says schema version 1 but holds version-2 rows (was its version edited?); "
                "refusing to migrate it"
            )
        names = ", ".join(f'"{c}"' for c in cols)
        con.execute(_table_ddl("rows_v2"))
        con.execute(f"INSERT INTO rows_v2 ({names}, config, flag) SELECT {names}, '', '' FROM rows")
        con.execute("DROP TABLE rows")
        con.execute("ALTER TABLE rows_v2 RENAME TO rows")
        con.execute("UPDATE meta SET value = ? WHERE key = 'schema_version'", (str(SCHEMA_VERSION),))

    def _migrate_v2(self, con: sqlite3.Connection) -> None:
        """Version 2 -> 3 inside the caller's transaction: every row, current or superseded, becomes
        run 0 (``run_seed`` and ``deterministic`` None); open claims, keyed without a run, are dropped."""
        tables = {r[0] for r in con.execute("SELECT name FROM sqlite_master WHERE type = 'table'")}
        for table in ("rows", "superseded"):
            if table not in tables:
                continue
            have = [r[1] for r in con.execute(f"PRAGMA table_info({table})")]
            if "run" in have:
                raise StoreError(
                    f"{self.path} says schema version 2 but holds version-3 rows (was its version "
                    "edited?); refusing to migrate it"
                )
            names = ", ".join(f'"{c}"' for c in [*(c for c in _V2_COLUMNS if c in have), "extras"])
            con.execute(_table_ddl(f"{table}_v3"))
            con.execute(f"INSERT INTO {table}_v3 ({names}, run) SELECT {names}, 0 FROM {table}")
            con.execute(f"DROP TABLE {table}")
            con.execute(f"ALTER TABLE {table}_v3 RENAME TO {table}")
        con.execute("DROP TABLE IF EXISTS claims")
        con.execute("UPDATE meta SET value = ? WHERE key = 'schema_version'", (str(SCHEMA_VERSION),))

    def _connection(self) -> sqlite3.Connection:
        if self._con is None:
            raise StoreError(f"the results store {self.path} is closed")
        return self._con

    def _rollback(self) -> None:
        con = self._con
        if con is not None and con.in_transaction:
            with contextlib.suppress(sqlite3.Error):
                con.execute("ROLLBACK")

    def _writable(self) -> sqlite3.Connection:
        if self.readonly:
            raise StoreError(
                f"the results store {self.path} is open read-only; open it without readonly=True"
            )
        return self._connection()

    def _checkpoint(self) -> None:
        """Copy committed pages into the main file, so it alone holds every finished row."""
        with contextlib.suppress(sqlite3.Error):
            self._connection().execute("PRAGMA wal_checkpoint(PASSIVE)")

    # ------------------------------------------------------------------ context
    def __enter__(self) -> Self:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def close(self) -> None:
        """Close the connection (the rows are already on disk)."""
        if self._con is not None:
            with contextlib.suppress(sqlite3.Error):
                self._con.close()
            self._con = None

    # ------------------------------------------------------------------ writing
    def write(self, rows: Iterable[Mapping[str, Any]]) -> int:  # noqa: C901
        """Write rows in one transaction, each replacing the row of the same key; returns how many
        older rows were set aside.

        rows: mappings with at least ``problem``, ``instance``, ``method`` (``config``
        missing means ``''``, ``run`` missing means 0); other columns of ``COLUMNS`` may be
        missing (None), keys outside ``COLUMNS`` are stored as extras. A row of the same ``(problem, instance,
        method)`` but another ``config`` moves to the ``superseded`` table (counted in the
        return value); rows of other methods stay. An error row of method ``task``
        (:func:`error_row`) is removed when its instance gets rows of other methods.
        """
        rows = list(rows)
        if not rows:
            return 0
        records: list[tuple[tuple[str, ...], tuple[Any, ...]]] = []
        for r in rows:
            missing = [k for k in KEY[:3] if r.get(k) in (None, "")]
            if missing:
                raise ValueError(f"row lacks key columns {missing}: {dict(r)}")
            if r.get("problem") not in PROBLEMS:
                raise ValueError(f"row has unknown problem {r.get('problem')!r}")
            config = r.get("config")
            if config is None:
                config = ""
            if not isinstance(config, str):
                raise TypeError(f"row config must be a str, got {type(config).__name__}")
            values = {c: _jsonable(r.get(c)) for c in _CORE}
            values["config"] = config
            values["run"] = _run_of(r.get("run"))
            if values["deterministic"] is not None:
                values["deterministic"] = int(bool(values["deterministic"]))
            values["flag"] = _join_flags(_flags(values["flag"]))
            values["warm_started"] = int(bool(r.get("warm_started")))
            for c in _TEXT_JSON:
                if isinstance(values[c], (dict, list)):
                    values[c] = json.dumps(values[c], sort_keys=True, allow_nan=False)
            extras = {k: _jsonable(v) for k, v in r.items() if k not in _CORE}
            try:
                extras_json = json.dumps(extras, sort_keys=True, allow_nan=False)
            except (TypeError, ValueError) as exc:
                raise TypeError(f"row extras must be JSON values: {exc}") from None
            key = (*(str(values[k]) for k in KEY[:4]), values["run"])
            records.append((key, (*(values[c] for c in _CORE), extras_json)))
        keys = [k for k, _ in records]
        if len(set(keys)) != len(keys):
            raise ValueError("rows repeat a key (problem, instance, method, config, run)")
        task_rows = {(k[0], k[1]) for k in keys if k[2] == _TASK_METHOD}
        solved = sorted({(k[0], k[1]) for k in keys if k[2] != _TASK_METHOD} - task_rows)
        insert = f"INSERT OR REPLACE INTO rows VALUES ({', '.join('?' * (len(_CORE) + 1))})"
        same_method = "problem = ? AND instance = ? AND method = ? AND config != ?"
        set_aside = 0
        with self._transaction() as con:
            for key, record in records:
                cur = con.execute(
                    f"INSERT OR REPLACE INTO superseded SELECT * FROM rows WHERE {same_method}", key[:4]
                )
                set_aside += max(cur.rowcount, 0)
                con.execute(f"DELETE FROM rows WHERE {same_method}", key[:4])
                con.execute(f"DELETE FROM superseded WHERE {_KEY_WHERE}", key)
                con.execute(f"DELETE FROM claims WHERE {_KEY_WHERE}", key)
                con.execute(insert, record)
            con.executemany(
                "DELETE FROM rows WHERE problem = ? AND instance = ? AND method = ? AND status = ? "
                "AND role = ?",
                [(p, i, _TASK_METHOD, ERROR_STATUS, _TASK_METHOD) for p, i in solved],
            )
        self._checkpoint()
        return set_aside

    # ------------------------------------------------------------------ instance data
    def bind_instances(self, problem: str, fingerprints: Mapping[str, str]) -> None:
        """Record the data fingerprint of each instance id of ``problem`` (id -> fingerprint), and
        refuse, with a one-line :class:`InstanceDataError` and before anything is written, an id
        this store already holds under another fingerprint: one id means one data set, so rows
        computed on other data are never compared with these."""
        with self._transaction() as con:
            known = dict(
                con.execute("SELECT instance, fingerprint FROM instance_data WHERE problem = ?", (problem,))
            )
            clash = sorted(i for i, fp in fingerprints.items() if known.get(i, fp) != fp)
            if clash:
                first = clash[0]
                raise InstanceDataError(
                    f"instance {first!r} names other data in {self.path} (stored fingerprint "
                    f"{known[first]}, now {fingerprints[first]}"
                    + (f"; {len(clash) - 1} more ids too" if len(clash) > 1 else "")
                    + "): give the changed data another name or family version, or use another --out"
                )
            con.executemany(
                "INSERT OR IGNORE INTO instance_data VALUES (?, ?, ?)",
                [(problem, i, fp) for i, fp in fingerprints.items()],
            )

    @contextlib.contextmanager
    def _transaction(self) -> Iterator[sqlite3.Connection]:
        """A write transaction (``BEGIN IMMEDIATE`` .. ``COMMIT``), rolled back on any exception;
        an SQLite or OS error becomes a one-line :class:`StoreError`."""
        con = self._writable()
        try:
            con.execute("BEGIN IMMEDIATE")
            yield con
            con.execute("COMMIT")
        except BaseException as exc:  # e.g. Ctrl-C: undo a half-done transaction (a committed one stays)
            self._rollback()
            if isinstance(exc, (sqlite3.Error, OSError)):
                raise _store_error(self.path, exc, "write") from exc
            raise

    # ------------------------------------------------------------------ claims
    def _full_key(self, key: Sequence[Any]) -> tuple[str, str, str, str, int]:
        key = tuple(key)
        if len(key) == 3:
            key = (*key, "")
        if len(key) == 4:
            key = (*key, 0)
        if len(key) != 5 or not all(isinstance(k, str) for k in key[:4]):
            raise ValueError(
                f"key must be (problem, instance, method[, config[, run]]) with strings first, got {key!r}"
            )
        return (key[0], key[1], key[2], key[3], _run_of(key[4]))

    def try_claim(self, key: Sequence[str], *, stale_after: float = DEFAULT_STALE_AFTER_S) -> bool:
        """Claim the job ``key`` for this process; False when someone else is doing or did it.

        key: ``(problem, instance, method, config, run)`` (config ``''`` and run 0 when left out).
        stale_after: seconds after which another process's claim counts as abandoned.
        Atomic across processes: of several runs claiming one key, one gets True. A claim
        is taken over when its process has died (same host) or it is older than
        ``stale_after``; a key that already has a row with a status other than ``error``
        cannot be claimed. :meth:`write` of the key's row (or :meth:`release`) ends the claim.
        """
        full = self._full_key(key)
        if isinstance(stale_after, bool) or not isinstance(stale_after, (int, float)) or not stale_after > 0:
            raise ValueError(f"stale_after must be a number of seconds > 0, got {stale_after!r}")
        host, pid, now = socket.gethostname(), os.getpid(), time.time()
        with self._transaction() as con:
            done = con.execute(
                f"SELECT 1 FROM rows WHERE {_KEY_WHERE} AND IFNULL(status, '') != ?", (*full, ERROR_STATUS)
            ).fetchone()
            held = con.execute(
                f"SELECT host, pid, claimed_at FROM claims WHERE {_KEY_WHERE}", full
            ).fetchone()
            free = held is None or (
                (held[0], held[1]) == (host, pid)
                or (held[0] == host and not _claimant_alive(int(held[1]), float(held[2])))
                or now - float(held[2]) > stale_after
            )
            ok = free and done is None
            if ok:
                con.execute(
                    "INSERT OR REPLACE INTO claims VALUES (?, ?, ?, ?, ?, ?, ?, ?)", (*full, host, pid, now)
                )
        return ok

    def release(self, key: Sequence[str]) -> None:
        """Give up this process's claim on ``key`` (a claim of another process stays).

        key: ``(problem, instance, method, config, run)`` as given to :meth:`try_claim`.
        """
        full = self._full_key(key)
        con = self._writable()
        try:
            con.execute(
                f"DELETE FROM claims WHERE {_KEY_WHERE} AND host = ? AND pid = ?",
                (*full, socket.gethostname(), os.getpid()),
            )
        except sqlite3.Error as exc:
            raise _store_error(self.path, exc, "write") from exc

    # ------------------------------------------------------------------ reading
    def _query(self, sql: str, args: Sequence[Any] = ()) -> list[tuple]:
        try:
            return self._connection().execute(sql, args).fetchall()
        except sqlite3.Error as exc:
            raise _store_error(self.path, exc, "read") from exc

    def done_configs(self, problem: str | None = None) -> set[tuple[str, str, str]]:
        """``(problem, instance, config)`` triples with rows of that config and no error row among them.

        problem: only this problem's (default all).
        """
        where = " WHERE problem = ?" if problem else ""
        q = (
            f"SELECT problem, instance, config, MAX(status = ?) FROM rows{where} "
            "GROUP BY problem, instance, config"
        )
        args = (ERROR_STATUS, problem) if problem else (ERROR_STATUS,)
        return {(p, i, c or "") for p, i, c, err in self._query(q, args) if not err}

    def done_instances(self, problem: str | None = None, config: str | None = None) -> set[tuple[str, str]]:
        """``(problem, instance)`` pairs whose rows are on disk without an error row.

        problem: only this problem's (default all); config: only rows of this
        configuration count (default any: then an error row of any config means not done).
        """
        if config is not None:
            return {(p, i) for p, i, c in self.done_configs(problem) if c == config}
        where = " WHERE problem = ?" if problem else ""
        q = f"SELECT problem, instance, MAX(status = ?) FROM rows{where} GROUP BY problem, instance"
        args = (ERROR_STATUS, problem) if problem else (ERROR_STATUS,)
        return {(p, i) for p, i, err in self._query(q, args) if not err}

    def done_keys(self, problem: str | None = None) -> set[tuple[str, str, str, str, int]]:
        """Full keys ``(problem, instance, method, config, run)`` of current rows whose status is
        not ``error``.

        problem: only this problem's (default all).
        """
        where = " AND problem = ?" if problem else ""
        q = f"SELECT problem, instance, method, config, run FROM rows WHERE IFNULL(status, '') != ?{where}"
        args = (ERROR_STATUS, problem) if problem else (ERROR_STATUS,)
        return {(p, i, m, c or "", int(r or 0)) for p, i, m, c, r in self._query(q, args)}

    def mark_deterministic(self, keys: Iterable[Sequence[Any]], value: bool | None) -> None:
        """Set ``deterministic`` of the current rows ``keys`` to ``value`` in one transaction.

        keys: full keys ``(problem, instance, method, config, run)``; value: True, False or None.
        """
        if value is not None and not isinstance(value, bool):
            raise TypeError(f"value must be True, False or None, got {value!r}")
        flag = None if value is None else int(value)
        with self._transaction() as con:
            con.executemany(
                f"UPDATE rows SET deterministic = ? WHERE {_KEY_WHERE}",
                [(flag, *self._full_key(k)) for k in keys],
            )
        self._checkpoint()

    def runs(self, problem: str | None = None) -> list[dict[str, Any]]:
        """Who made the current rows: one dict per distinct (``droneplan_version``, ``git_commit``,
        ``code_hash``, ``cpu``, ``cores``) with ``rows`` (count) and ``first``/``last`` (the
        earliest and latest ``finished_at``, ISO 8601 UTC), most rows first.

        problem: only this problem's rows (default all).
        """
        keys = ("droneplan_version", "git_commit", "code_hash", "cpu", "cores")
        where = " WHERE problem = ?" if problem else ""
        q = (
            f"SELECT {', '.join(keys)}, COUNT(*), MIN(finished_at), MAX(finished_at) FROM rows{where} "
            f"GROUP BY {', '.join(keys)} ORDER BY COUNT(*) DESC"
        )
        found = self._query(q, (problem,) if problem else ())
        return [
            {**dict(zip(keys, r[:5], strict=True)), "rows": r[5], "first": r[6], "last": r[7]} for r in found
        ]

    def count(self) -> int:
        """Number of current rows in the store (superseded rows not counted)."""
        return int(self._query("SELECT COUNT(*) FROM rows")[0][0])

    def _has_table(self, name: str) -> bool:
        return bool(self._query("SELECT 1 FROM sqlite_master WHERE type = 'table' AND name = ?", (name,)))

    def frame(
        self, problem: str | None = None, study: str | None = None, *, include_superseded: bool = False
    ) -> pd.DataFrame:
        """The rows as a DataFrame: ``COLUMNS`` then the prefixed extras, in key order.

        problem, study: optional filters. The gaps and ``beats-bound`` flags are computed
        over the current rows of each instance (:func:`fill_gaps`). include_superseded: also
        the rows set aside by a later configuration, with a boolean column ``superseded``
        (they get gaps against the current rows but define neither best nor bound).
        """
        where, args = ("", []) if not problem else (" WHERE problem = ?", [problem])
        data = [(False, *r) for r in self._query(f"SELECT * FROM rows{where}", args)]
        names = [d[1] for d in self._connection().execute("PRAGMA table_info(rows)")]
        if include_superseded and self._has_table("superseded"):
            data += [(True, *r) for r in self._query(f"SELECT * FROM superseded{where}", args)]
        df = _to_frame(["superseded", *names], data)
        return _finish(df, study=study, include_superseded=include_superseded)

    def export(self, path: str | os.PathLike, **filters: Any) -> Path:
        """Write the rows to ``path`` (``.csv`` or ``.parquet``) through a temporary file.

        path: the file written; it is replaced atomically, so a reader never sees a
        half-written export and two runs exporting to one path do not collide.
        filters: ``problem``/``study`` as for :meth:`frame`.
        """
        path = Path(path)
        if path.suffix not in (".csv", ".parquet"):
            raise ValueError(f"export path must end in .csv or .parquet, got {path.name!r}")
        _atomic_export(self.frame(**filters), path)
        return path


def _atomic_export(df: pd.DataFrame, path: Path) -> None:
    tmp: Path | None = None
    try:
        with tempfile.NamedTemporaryFile(
            dir=path.parent, prefix=f".{path.name}.", suffix=".tmp", delete=False
        ) as fh:
            tmp = Path(fh.name)
        mask = os.umask(0)
        os.umask(mask)
        os.chmod(tmp, 0o666 & ~mask)  # the permissions a plain open() would give
        if path.suffix == ".parquet":
            _parquet_ready(df).to_parquet(tmp, index=False)
        else:
            df.to_csv(tmp, index=False)
        os.replace(tmp, path)
        tmp = None
    except OSError as exc:
        raise _store_error(path, exc, "export") from exc
    finally:
        if tmp is not None:
            with contextlib.suppress(OSError):
                tmp.unlink()


def _parquet_ready(df: pd.DataFrame) -> pd.DataFrame:
    """Object columns holding mixed values (lists, mixed types) as JSON text, which Parquet can store."""
    df = df.copy()
    for c in df.columns:
        if df[c].dtype != object:
            continue
        values = [v for v in df[c] if v is not None and not (isinstance(v, float) and math.isnan(v))]
        kinds = {type(v) for v in values}
        if len(kinds) > 1 or (kinds and not kinds <= {str, bool, int, float}):
            df[c] = [None if v is None else json.dumps(_jsonable(v), sort_keys=True) for v in df[c]]
    return df


def _missing(v: Any) -> bool:
    return v is None or v is pd.NA or (isinstance(v, float) and math.isnan(v))


def _run_of(v: Any) -> int:
    """A row's ``run``: an int >= 0 (None means 0)."""
    if v is None:
        return 0
    if isinstance(v, (bool, np.bool_)) or not isinstance(v, numbers.Integral) or int(v) < 0:
        raise ValueError(f"run must be an int >= 0, got {v!r}")
    return int(v)


def _to_frame(names: Sequence[str], data: Sequence[tuple]) -> pd.DataFrame:
    ix = names.index("extras")
    core = pd.DataFrame([r[:ix] + r[ix + 1 :] for r in data], columns=[n for n in names if n != "extras"])
    extras = pd.DataFrame([json.loads(r[ix] or "{}") for r in data], index=core.index)
    extras = extras[[c for c in extras.columns if c not in core.columns]]
    return pd.concat([core, extras], axis=1) if len(extras.columns) else core


def _finish(df: pd.DataFrame, *, study: str | None, include_superseded: bool) -> pd.DataFrame:
    """Gaps over the current rows, the study filter, schema column order, types, key order."""
    if "run" not in df.columns:  # a store of schema version 1 or 2 read as it is: one run
        df = df.assign(run=0)
    if "superseded" not in df.columns:
        df = df.assign(superseded=False)
    df["superseded"] = df["superseded"].fillna(False).astype(bool)
    for c in ("config", "flag"):
        if c not in df.columns:
            df[c] = ""
    if len(df):
        df = fill_gaps(df, reference=~df["superseded"])
    if study:
        df = df[df["study"] == study]
    extras = [c for c in df.columns if c not in COLUMNS and c != "superseded"]
    df = df.reindex(columns=[*COLUMNS, *(["superseded"] if include_superseded else []), *extras])
    df = _typed(df)
    order = [*KEY, *(["superseded"] if include_superseded else [])]
    return df.sort_values(order, kind="stable").reset_index(drop=True)


def _typed(df: pd.DataFrame) -> pd.DataFrame:
    for c in (
        "objective",
        "bound",
        "gap_to_bound",
        "gap_to_best",
        "time_s",
        "claimed_objective",
        "time_limit_s",
    ):
        df[c] = pd.to_numeric(df[c], errors="coerce").astype(float)
    for c in ("seed", "size", "family_version", "cores", "run_seed"):
        df[c] = pd.to_numeric(df[c], errors="coerce").astype("Int64")
    df["run"] = pd.to_numeric(df["run"], errors="coerce").fillna(0).astype("int64")
    df["deterministic"] = pd.Series(
        [None if _missing(v) else bool(v) for v in df["deterministic"]], index=df.index, dtype=object
    )
    df["warm_started"] = df["warm_started"].fillna(0).astype(bool)
    for c in ("config", "flag"):
        df[c] = df[c].astype(object).where(df[c].notna(), "").astype(object)
    return df


def _empty_frame(include_superseded: bool = False) -> pd.DataFrame:
    cols = [*COLUMNS, *(["superseded"] if include_superseded else [])]
    return _typed(pd.DataFrame(columns=cols))


def load_results(
    out: str | os.PathLike,
    *,
    problem: str | None = None,
    study: str | None = None,
    include_superseded: bool = False,
) -> pd.DataFrame:
    """The result rows of an ``--out`` directory, in the one long-format schema, read-only.

    out: the directory given to ``droneplan gap/reproduce --out`` or a store file itself.
    A directory's store is ``out/results.sqlite``; stores a study wrote into a problem's
    own folder (``out/<problem>/results.sqlite``, e.g. ``herding.gap(out=out / "herding")``
    without a store) are read too, and nothing deeper (copies archived further down are
    ignored). problem, study: optional filters; include_superseded: also the rows set
    aside by a later configuration (column ``superseded``). Returns a DataFrame with
    ``COLUMNS`` first, then prefixed extras. Raises FileNotFoundError when there is no
    store, :class:`StoreError` when one cannot be read.
    """
    include_superseded = check_bool("include_superseded", include_superseded)
    for name, value in (("problem", problem), ("study", study)):
        if value is not None and not isinstance(value, str):
            raise TypeError(f"{name} must be a str or None, got {type(value).__name__}")
    out = Path(out)
    if not out.exists():
        raise FileNotFoundError(f"out: {out} does not exist")
    if out.is_file():
        paths = [out]
    else:
        candidates = [out / STORE_NAME, *(out / p / STORE_NAME for p in PROBLEMS)]
        paths = [p for p in candidates if p.is_file()]
        if not paths:
            raise FileNotFoundError(
                f"out: no results store in {out} (expected {out / STORE_NAME}); run a study with --out {out}"
            )
    frames = []
    for p in paths:
        with ResultStore(p, readonly=True) as store:
            frames.append(store.frame(problem=problem, include_superseded=True))
    frames = [f for f in frames if len(f)]
    if not frames:
        return _empty_frame(include_superseded)
    df = pd.concat(frames, ignore_index=True) if len(frames) > 1 else frames[0]
    # the same row in two stores: the first store (out/results.sqlite) wins
    df = df.drop_duplicates(subset=[*KEY, "superseded"], keep="first")
    if not include_superseded:
        df = df[~df["superseded"]].drop(columns="superseded")
    return _finish(df.reset_index(drop=True), study=study, include_superseded=include_superseded)
