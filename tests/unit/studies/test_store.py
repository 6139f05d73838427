"""The results schema and the SQLite store: gaps, round trip, refusals, torn files."""

from __future__ import annotations

import math
import sqlite3

import pandas as pd
import pytest

import droneplan
from droneplan.studies.store import (
    COLUMNS,
    STORE_NAME,
    Outcome,
    ResultStore,
    StoreError,
    build_rows,
    error_row,
    instance_id,
    load_results,
)


def _rows(seed=0, sense="min"):
    return build_rows(
        "herding",
        instance_id("t", seed=seed),
        seed=seed,
        size=3,
        sense=sense,
        outcomes=[
            Outcome(
                "exact",
                "model",
                "optimal",
                objective=10.0,
                bound=10.0,
                bound_kind="proven-global",
                time_s=0.1,
            ),
            Outcome(
                "heur", "heuristic", "feasible", objective=12.0, time_s=0.01, extras={"note": "x", "k": 3}
            ),
            Outcome("relax", "bound", "optimal", bound=8.0, bound_kind="proven-global"),
            Outcome("inst", "bound", "optimal", bound=11.0, bound_kind="instantaneous"),
        ],
    )


def test_build_rows_fills_gaps_against_the_strongest_tightest_bound():
    rows = {r["method"]: r for r in _rows()}
    # strongest kind present is proven-global; tightest of those for a minimisation is 10
    assert rows["heur"]["gap_to_bound"] == pytest.approx(0.2)
    assert rows["heur"]["gap_bound_kind"] == "proven-global"
    assert rows["exact"]["gap_to_bound"] == 0.0
    assert rows["heur"]["gap_to_best"] == pytest.approx(0.2)
    assert rows["relax"]["gap_to_bound"] is None and rows["relax"]["objective"] is None
    assert rows["heur"]["herding_note"] == "x"  # extras are prefixed with the problem
    assert list(rows["exact"])[: len(COLUMNS)] == list(COLUMNS)


def test_build_rows_maximisation_and_bad_input():
    rows = {
        r["method"]: r
        for r in build_rows(
            "cells",
            "gap:seed=1",
            seed=1,
            size=3,
            sense="max",
            outcomes=[
                Outcome("milp", "model", "optimal", objective=90, bound=100, bound_kind="candidate-set"),
                Outcome("ga", "heuristic", "feasible", objective=80),
            ],
        )
    }
    assert rows["ga"]["gap_to_bound"] == pytest.approx(0.2)
    assert rows["ga"]["gap_to_best"] == pytest.approx(10 / 90)
    with pytest.raises(ValueError, match="role"):
        Outcome("x", "oracle", "optimal")
    with pytest.raises(ValueError, match="bound_kind"):
        Outcome("x", "model", "optimal", bound=1.0)
    with pytest.raises(ValueError, match="sense"):
        build_rows("cells", "gap:seed=1", seed=1, size=1, sense="up", outcomes=[])
    with pytest.raises(ValueError, match="problem"):
        build_rows("fish", "gap:seed=1", seed=1, size=1, sense="min", outcomes=[])


def test_store_round_trip_replace_and_load_results(tmp_path):
    with ResultStore(tmp_path / STORE_NAME) as store:
        store.write([error_row("herding", instance_id("t", seed=0), "boom")])
        assert store.done_instances() == set()  # an error row is not done
        store.write(_rows(0))  # replaces the error row atomically
        store.write(_rows(1))
        assert store.done_instances() == {("herding", "t:seed=0"), ("herding", "t:seed=1")}
        assert store.count() == 8
        store.export(tmp_path / "results.csv")
    df = droneplan.load_results(tmp_path)
    assert list(df.columns[: len(COLUMNS)]) == list(COLUMNS)
    assert len(df) == 8 and not df.duplicated(["problem", "instance", "method"]).any()
    assert (df["status"] != "error").all()
    assert df["warm_started"].dtype == bool and df["seed"].dtype == "Int64"
    heur = df[df["method"] == "heur"].iloc[0]
    assert heur["herding_k"] == 3 and math.isclose(heur["gap_to_bound"], 0.2)
    csv = pd.read_csv(tmp_path / "results.csv")
    assert len(csv) == 8


def test_load_results_of_an_empty_store_has_the_schema(tmp_path):
    with pytest.raises(FileNotFoundError, match="no results store"):
        load_results(tmp_path)  # a directory without a store
    ResultStore(tmp_path / STORE_NAME).close()
    df = load_results(tmp_path)
    assert df.empty and list(df.columns) == list(COLUMNS)
    with pytest.raises(FileNotFoundError, match="out"):
        load_results(tmp_path / "missing")


def test_store_of_another_schema_or_not_a_store_is_refused(tmp_path):
    old = tmp_path / "old.sqlite"
    con = sqlite3.connect(old)
    con.execute("CREATE TABLE meta (key TEXT PRIMARY KEY, value TEXT)")
    con.execute("INSERT INTO meta VALUES ('schema_version', '0')")
    con.commit()
    con.close()
    with pytest.raises(StoreError, match=r"schema version 0.*Move it away"):
        ResultStore(old)
    legacy = tmp_path / "legacy.sqlite"
    con = sqlite3.connect(legacy)
    con.execute("CREATE TABLE rows (a)")
    con.commit()
    con.close()
    with pytest.raises(StoreError, match="no schema version"):
        ResultStore(legacy)
    garbage = tmp_path / "garbage.sqlite"
    garbage.write_bytes(b"seed,value\n1,2\n3,")  # e.g. a torn CSV under the store's name
    with pytest.raises(StoreError, match="not a usable results store"):
        ResultStore(garbage)


def test_torn_wal_tail_is_ignored(tmp_path):
    """A write torn by kill -9 leaves a partial frame at the end of the WAL: committed rows survive."""
    path = tmp_path / STORE_NAME
    store = ResultStore(path)
    store.write(_rows(0))
    store._con.execute("PRAGMA wal_autocheckpoint=0")
    store.write(_rows(1))
    wal = path.with_name(path.name + "-wal")
    assert wal.exists()
    # simulate the process dying: copy the files as they are on disk, add a torn tail to the WAL
    copy = tmp_path / "copy" / STORE_NAME
    copy.parent.mkdir()
    copy.write_bytes(path.read_bytes())
    copy.with_name(STORE_NAME + "-wal").write_bytes(wal.read_bytes() + b"\x37\x7f\x06\x82" + b"\x00" * 1000)
    store.close()
    with ResultStore(copy) as again:
        assert again.count() == 8
        assert again._con.execute("PRAGMA integrity_check").fetchone()[0] == "ok"
