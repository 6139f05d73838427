"""The anytime traces of a study, stored beside its rows: ``<out>/traces.sqlite``.

One table, ``traces``, keyed like the rows (``problem``, ``instance``, ``method``, ``config``,
``run``) plus ``seq``, the point's place in its run's trace; its other columns are
:data:`~droneplan.studies.traces.TRACE_COLUMNS`. A run's trace is written in one transaction
that first deletes whatever an earlier, interrupted attempt of the same key left, so a trace is
whole or absent. SQLite in WAL mode with ``synchronous=FULL``, as the results store.

:func:`load_traces` reads the traces of the rows a study currently holds (a trace of a row that
was superseded by another configuration is left out unless asked for).
"""

from __future__ import annotations

import contextlib
import math
import os
import sqlite3
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

import pandas as pd

from droneplan.studies.store import KEY, StoreError
from droneplan.studies.traces import TRACE_COLUMNS

__all__ = ["TRACES_NAME", "TRACE_KEY", "TraceStore", "load_traces"]

TRACES_NAME = "traces.sqlite"
"""The file name of a study's traces under its ``out`` directory."""
TRACE_KEY = (*KEY, "seq")
"""The key of a trace point: the row's key and the point's index in its run's trace."""

_TYPES = {
    "run": "INTEGER NOT NULL",
    "seq": "INTEGER NOT NULL",
    "t": "REAL",
    "objective": "REAL",
    "claimed_objective": "REAL",
    "bound": "REAL",
}
_COLUMNS = (*TRACE_KEY, *TRACE_COLUMNS)
_DDL = (
    "CREATE TABLE IF NOT EXISTS traces ("
    + ", ".join(f'"{c}" {_TYPES.get(c, "TEXT")}' for c in _COLUMNS)
    + f", PRIMARY KEY ({', '.join(TRACE_KEY)}))"
)


class TraceStore:
    """The traces file of one ``out`` directory.

    path: the SQLite file (created with its directory unless ``readonly``).
    readonly: open an existing file for reading only.
    """

    def __init__(self, path: str | os.PathLike, *, readonly: bool = False) -> None:
        self.path = Path(path)
        try:
            if readonly:
                self._con = sqlite3.connect(f"file:{self.path}?mode=ro", uri=True, isolation_level=None)
            else:
                self.path.parent.mkdir(parents=True, exist_ok=True)
                self._con = sqlite3.connect(self.path, isolation_level=None, timeout=60.0)
                self._con.execute("PRAGMA journal_mode=WAL")
                self._con.execute("PRAGMA synchronous=FULL")
                self._con.execute(_DDL)
        except sqlite3.Error as exc:
            raise StoreError(f"cannot open the traces file {self.path}: {exc}") from None

    def __enter__(self) -> TraceStore:
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()

    def close(self) -> None:
        """Close the file (its log checkpointed into it)."""
        with contextlib.suppress(sqlite3.Error):
            self._con.execute("PRAGMA wal_checkpoint(TRUNCATE)")
        self._con.close()

    def write(self, key: Sequence[Any], points: Iterable[Mapping[str, Any]]) -> int:
        """Replace the trace of the row ``key`` (problem, instance, method, config, run) by
        ``points`` (dicts with the :data:`TRACE_COLUMNS`), in one transaction; returns how many."""
        if len(key) != len(KEY):
            raise ValueError(f"a trace key has the {len(KEY)} fields {KEY}, got {tuple(key)!r}")
        records = [(*key, seq, *(_cell(p.get(c)) for c in TRACE_COLUMNS)) for seq, p in enumerate(points)]
        where = " AND ".join(f"{k} = ?" for k in KEY)
        marks = ", ".join("?" * len(_COLUMNS))
        try:
            self._con.execute("BEGIN IMMEDIATE")
            self._con.execute(f"DELETE FROM traces WHERE {where}", tuple(key))
            self._con.executemany(f"INSERT INTO traces VALUES ({marks})", records)
            self._con.execute("COMMIT")
        except BaseException as exc:
            with contextlib.suppress(sqlite3.Error):
                self._con.execute("ROLLBACK")
            if isinstance(exc, sqlite3.Error):
                raise StoreError(f"cannot write to the traces file {self.path}: {exc}") from None
            raise
        return len(records)

    def frame(self) -> pd.DataFrame:
        """Every trace point, in key and ``seq`` order."""
        try:
            cur = self._con.execute(f"SELECT * FROM traces ORDER BY {', '.join(TRACE_KEY)}")
            data = cur.fetchall()
        except sqlite3.Error as exc:
            raise StoreError(f"cannot read the traces file {self.path}: {exc}") from None
        return pd.DataFrame(data, columns=list(_COLUMNS))


def _cell(v: Any) -> Any:
    """A value SQLite stores: None for NaN/inf, Python numbers and strings as they are."""
    if isinstance(v, float) and not math.isfinite(v):
        return None
    if hasattr(v, "item") and not isinstance(v, (str, bytes)):
        return _cell(v.item())
    return v


def load_traces(out: str | os.PathLike, *, include_superseded: bool = False) -> pd.DataFrame:
    """The anytime traces of the study in ``out``: one row per scored report, with the row key
    (``problem``, ``instance``, ``method``, ``config``, ``run``), ``seq``, ``t`` (s since the
    method started), ``objective`` (droneplan's score of the reported plan), ``claimed_objective``,
    ``bound``, ``status``, ``message`` and ``flag``. Empty (with these columns) when no method of
    the study reported.

    out: the study's directory (the ``out`` of ``gap``).
    include_superseded: also the traces of rows since rerun under another configuration.
    """
    from droneplan.core.validation import check_bool
    from droneplan.studies.store import load_results

    check_bool("include_superseded", include_superseded)
    path = Path(out) / TRACES_NAME
    if not path.exists():
        return pd.DataFrame(columns=list(_COLUMNS))
    with TraceStore(path, readonly=True) as store:
        df = store.frame()
    if include_superseded or df.empty:
        return df
    rows = load_results(out)
    if rows.empty:
        return df.iloc[0:0]
    current = rows[list(KEY)].drop_duplicates()
    current = current.assign(run=current["run"].astype(int))
    return df.merge(current, on=list(KEY), how="inner")[list(_COLUMNS)]
