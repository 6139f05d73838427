"""Schema v2 of the results store: migration, per-row upserts, superseded rows, gaps on read,
beats-bound flags, numpy numbers, failures as StoreError, read-only stores, exports, claims."""

from __future__ import annotations

import contextlib
import json
import os
import shutil
import sqlite3
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from droneplan.studies import store as store_module
from droneplan.studies.store import (
    BEATS_BOUND,
    COLUMNS,
    KEY,
    SCHEMA_VERSION,
    STORE_NAME,
    Outcome,
    ResultStore,
    StoreError,
    build_rows,
    error_row,
    fill_gaps,
    load_results,
)


def _row(
    method, objective=None, *, instance="t:seed=0", config="", role="heuristic", status="feasible", **kw
):
    r = dict.fromkeys(COLUMNS)
    r.update(
        study="t",
        problem="herding",
        instance=instance,
        method=method,
        role=role,
        sense="min",
        status=status,
        objective=objective,
        bound_kind="none",
        config=config,
    )
    r.update(kw)
    return r


def _bound(value, kind="proven-global", method="exact", **kw):
    return _row(method, value, role="model", status="optimal", bound=value, bound_kind=kind, **kw)


# --------------------------------------------------------------------------- schema and migration
_V1_DDL = (
    "CREATE TABLE rows (study, problem, instance, seed, size, method, role, sense, status, objective, "
    "bound, bound_kind, gap_to_bound, gap_bound_kind, gap_to_best, time_s, warm_started, message, "
    "extras TEXT NOT NULL DEFAULT '{}', PRIMARY KEY (problem, instance, method))"
)


def _v1_store(path: Path) -> None:
    con = sqlite3.connect(path)
    con.execute("PRAGMA journal_mode=WAL")
    con.execute("CREATE TABLE meta (key TEXT PRIMARY KEY, value TEXT NOT NULL)")
    con.execute("INSERT INTO meta VALUES ('schema_version', '1')")
    con.execute(_V1_DDL)
    for seed, (m, obj) in enumerate([("a", 3.0), ("b", 4.0)]):
        con.execute(
            "INSERT INTO rows VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)",
            (
                *("t", "herding", "t:seed=0", 0, 2, m, "heuristic", "min", "feasible", obj, None, "none"),
                *(None, None, None, 0.5, 0, "", json.dumps({"herding_k": seed})),
            ),
        )
    con.commit()
    con.close()


def test_columns_and_key_of_schema_3():
    assert SCHEMA_VERSION == 3
    assert KEY == ("problem", "instance", "method", "config", "run")
    assert COLUMNS[COLUMNS.index("message") + 1 :] == (
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
        "run",
        "run_seed",
        "deterministic",
    )


def test_v1_store_is_migrated_in_place(tmp_path):
    path = tmp_path / STORE_NAME
    _v1_store(path)
    with ResultStore(path, readonly=True) as ro:  # read as it is, not migrated
        assert ro.version == 1 and ro.count() == 2
        df = ro.frame()
        assert list(df["config"]) == ["", ""] and list(df["gap_to_best"]) == [0.0, 1 / 3]
    with ResultStore(path) as store:
        assert store._con.execute("SELECT value FROM meta").fetchone()[0] == "3"
        df = store.frame()
        assert list(df["method"]) == ["a", "b"] and list(df["config"]) == ["", ""]
        assert list(df["run"]) == [0, 0]  # version 1 -> 3 through 2: one run each
        assert list(df["herding_k"]) == [0, 1] and list(df["gap_to_best"]) == [0.0, 1 / 3]
        assert store.done_instances() == {("herding", "t:seed=0")}
        assert store.write([_row("a", 2.0, config="c1")]) == 1  # the migrated row is superseded
    with ResultStore(path) as again:  # opening a current store changes nothing
        assert again.count() == 2 and len(again.frame(include_superseded=True)) == 3


def test_newer_or_foreign_stores_are_refused_in_one_line(tmp_path):
    newer = tmp_path / "newer.sqlite"
    con = sqlite3.connect(newer)
    con.execute("CREATE TABLE meta (key TEXT PRIMARY KEY, value TEXT)")
    con.execute("INSERT INTO meta VALUES ('schema_version', '4')")
    con.commit()
    con.close()
    for readonly in (False, True):
        with pytest.raises(StoreError, match=r"schema version 4.*Move it away") as info:
            ResultStore(newer, readonly=readonly)
        assert "\n" not in str(info.value) and str(newer) in str(info.value)
    other = tmp_path / "other.sqlite"
    con = sqlite3.connect(other)
    con.execute("CREATE TABLE customers (name)")
    con.commit()
    con.close()
    with pytest.raises(StoreError, match="something else"):
        ResultStore(other)
    assert [r[0] for r in sqlite3.connect(other).execute("SELECT name FROM sqlite_master")] == ["customers"]
    with pytest.raises(StoreError, match="not a results store"):
        ResultStore(other, readonly=True)
    with pytest.raises(StoreError, match="no results store"):
        ResultStore(tmp_path / "missing.sqlite", readonly=True)


def test_corrupt_file_gives_store_error_on_open_or_read(tmp_path):
    path = tmp_path / STORE_NAME
    with ResultStore(path) as store:
        store.write([_row(f"m{k}", float(k), message="x" * 2000) for k in range(40)])
    data = bytearray(path.read_bytes())
    assert len(data) > 3 * 4096
    data[4096 * 2 : 4096 * 3] = b"\xff" * 4096  # a page of the rows table overwritten
    path.write_bytes(bytes(data))
    with pytest.raises(StoreError, match="not a usable results store") as info, ResultStore(path) as store:
        store.frame()
    assert str(path) in str(info.value) and "\n" not in str(info.value)
    half = tmp_path / "half.sqlite"
    half.write_bytes(path.read_bytes()[:100])  # a torn copy: header only
    with pytest.raises(StoreError, match="not a usable results store"):
        ResultStore(half)


# --------------------------------------------------------------------------- writing
def test_write_keeps_other_methods_and_sets_aside_other_configs(tmp_path):
    with ResultStore(tmp_path / STORE_NAME) as store:
        assert store.write([_row("a", 3.0, config="c1"), _row("b", 4.0, config="c1")]) == 0
        assert store.write([_row("c", 5.0, config="c2")]) == 0  # another method: a and b stay
        assert sorted(store.frame()["method"]) == ["a", "b", "c"]
        assert store.write([_row("a", 2.5, config="c2")]) == 1  # a of c1 is set aside
        df = store.frame()
        assert sorted(zip(df["method"], df["config"], strict=True)) == [("a", "c2"), ("b", "c1"), ("c", "c2")]
        assert df.set_index("method").loc["b", "gap_to_best"] == pytest.approx(1.5 / 2.5)
        assert store.write([_row("a", 2.5, config="c2")]) == 0  # the same key again: replaced
        full = store.frame(include_superseded=True)
        old = full[full["superseded"]]
        assert list(zip(old["method"], old["config"], old["objective"], strict=True)) == [("a", "c1", 3.0)]
        # a superseded row gets its gap against the current rows but is not the best
        assert old["gap_to_best"].iloc[0] == pytest.approx(0.5 / 2.5)
        assert store.write([_row("a", 3.0, config="c1")]) == 1  # back to c1: c2 set aside, c1 current
        full = store.frame(include_superseded=True)
        assert sorted(zip(full["config"], full["superseded"], strict=True))[:2] == [
            ("c1", False),
            ("c1", False),
        ]
        assert len(full) == 4 and full["superseded"].sum() == 1
        assert store.done_keys() == {
            ("herding", "t:seed=0", "a", "c1", 0),
            ("herding", "t:seed=0", "b", "c1", 0),
            ("herding", "t:seed=0", "c", "c2", 0),
        }
    df = load_results(tmp_path, include_superseded=True)
    assert df["superseded"].sum() == 1 and len(load_results(tmp_path)) == 3


def test_error_row_goes_when_the_instance_gets_rows_and_done_by_config(tmp_path):
    with ResultStore(tmp_path / STORE_NAME) as store:
        err = error_row("herding", "t:seed=0", "boom")
        assert store.write([{**err, "config": "c1"}]) == 0
        assert store.done_instances() == set() and store.done_keys() == set()
        store.write([_row("a", 1.0, config="c1"), _row("b", 2.0, config="c1")])
        assert "task" not in set(store.frame()["method"])
        assert store.done_instances() == {("herding", "t:seed=0")}
        assert store.done_instances(config="c1") == {("herding", "t:seed=0")}
        assert store.done_instances(config="c2") == set()
        store.write([{**err, "config": "c2"}])  # a rerun under c2 failed: the c1 rows stay
        assert store.done_instances() == set()  # some error row: not done (legacy question)
        assert store.done_instances(config="c1") == {("herding", "t:seed=0")}
        assert store.done_configs() == {("herding", "t:seed=0", "c1")}
        store.write([_row("x", 1.0, instance="t:seed=1")])  # missing config means ''
        assert ("herding", "t:seed=1", "x", "", 0) in store.done_keys()
        with pytest.raises(ValueError, match="repeat a key"):
            store.write([_row("a", 1.0), _row("a", 2.0)])
        with pytest.raises(ValueError, match="key columns"):
            store.write([{"problem": "herding", "instance": "t:seed=0"}])
        with pytest.raises(TypeError, match="config"):
            store.write([_row("a", 1.0, config=3)])


# --------------------------------------------------------------------------- gaps on read
def test_gaps_are_computed_on_read_over_the_current_rows(tmp_path):
    with ResultStore(tmp_path / STORE_NAME) as store:
        store.write([_row("heur", 12.0)])
        assert np.isnan(store.frame()["gap_to_bound"].iloc[0])
        store.write([_bound(10.0)])  # a later write: the earlier row's gaps change on read
        df = store.frame().set_index("method")
        assert df.loc["heur", "gap_to_bound"] == pytest.approx(0.2)
        assert df.loc["heur", "gap_bound_kind"] == "proven-global"
        assert df.loc["heur", "gap_to_best"] == pytest.approx(0.2)
        # the same numbers as build_rows gives for the same outcomes
        rows = build_rows(
            "herding",
            "t:seed=0",
            seed=0,
            size=1,
            sense="min",
            outcomes=[
                Outcome("heur", "heuristic", "feasible", objective=12.0),
                Outcome("exact", "model", "optimal", objective=10.0, bound=10.0, bound_kind="proven-global"),
            ],
        )
        assert {r["method"]: r["gap_to_best"] for r in rows} == pytest.approx(df["gap_to_best"].to_dict())


def test_beats_bound_flag_and_only_solved_rows_define_the_best():
    df = pd.DataFrame(
        [
            _bound(10.0, kind="candidate-set", method="milp"),
            _row("cheat", 9.0, flag="claim-mismatch"),  # better than a candidate-set optimum
            _row("near", 10.0 - 1e-12),  # within the relative tolerance: no flag
            _row("heur", 11.0),
            _row("late", 10.5, status="timeout"),  # not solved: does not define the best
            _row("inst", None, role="bound", bound=12.0, bound_kind="instantaneous"),
        ]
    )
    out = fill_gaps(df).set_index("method")
    assert out.loc["cheat", "flag"] == f"claim-mismatch;{BEATS_BOUND}"
    assert out.loc["cheat", "gap_to_bound"] == pytest.approx(-0.1)  # still given, negative
    assert out.loc["cheat", "gap_to_best"] < 0
    assert out.loc["near", "flag"] == "" and out.loc["heur", "flag"] == ""
    assert out.loc["near", "gap_to_best"] == 0.0  # the best is near, not cheat
    assert out.loc["heur", "gap_to_best"] == pytest.approx(1 / (10 - 1e-12))
    assert out.loc["late", "gap_to_best"] == pytest.approx(0.5 / (10 - 1e-12))
    assert out.loc["milp", "gap_bound_kind"] == "candidate-set"
    again = fill_gaps(out.reset_index())  # idempotent: no duplicated flags
    assert again.set_index("method").loc["cheat", "flag"] == f"claim-mismatch;{BEATS_BOUND}"
    fixed = fill_gaps(out.reset_index().assign(bound=[8.0, *[None] * 4, 12.0]))
    assert fixed.set_index("method").loc["cheat", "flag"] == "claim-mismatch"  # recomputed, not sticky
    # maximisation: better means larger; a local bound never flags
    mx = pd.DataFrame(
        [
            {**_bound(100.0), "sense": "max"},
            {**_row("ga", 101.0), "sense": "max"},
            {**_row("loc", 105.0, role="model", bound=99.0, bound_kind="local"), "sense": "max"},
        ]
    )
    flags = fill_gaps(mx).set_index("method")["flag"]
    assert flags.to_dict() == {"exact": "", "ga": BEATS_BOUND, "loc": BEATS_BOUND}
    assert fill_gaps(mx.iloc[1:]).set_index("method")["flag"].to_dict() == {"ga": "", "loc": ""}


def test_numpy_scalars_are_numbers_and_nan_is_none(tmp_path):
    rows = build_rows(
        "cells",
        "gap:seed=1",
        seed=np.int64(1),
        size=np.int32(3),
        sense="max",
        outcomes=[
            Outcome(
                "milp",
                "model",
                "optimal",
                objective=np.int64(90),
                bound=np.float32(100.0),
                bound_kind="candidate-set",
            ),
            Outcome("ga", "heuristic", "feasible", objective=np.float32(80.0), time_s=np.float64(0.5)),
            Outcome("nan", "heuristic", "feasible", objective=float("nan"), time_s=float("inf")),
        ],
    )
    by = {r["method"]: r for r in rows}
    assert by["milp"]["objective"] == 90.0 and by["milp"]["bound"] == 100.0
    assert by["ga"]["gap_to_bound"] == pytest.approx(0.2) and by["ga"]["gap_to_best"] == pytest.approx(1 / 9)
    assert by["nan"]["objective"] is None and by["nan"]["time_s"] is None
    with ResultStore(tmp_path / STORE_NAME) as store:
        store.write(rows)
        store.write([{**_row("np", np.float32(0.25), instance="t:seed=5"), "bound": np.float64(np.nan)}])
        df = store.frame().set_index("method")
    assert df.loc["ga", "gap_to_best"] == pytest.approx(1 / 9)
    assert df.loc["np", "objective"] == 0.25 and np.isnan(df.loc["np", "bound"])


# --------------------------------------------------------------------------- failures
def test_disk_full_is_a_store_error(tmp_path):
    path = tmp_path / STORE_NAME
    with ResultStore(path) as store:
        store.write([_row("a", 1.0)])
        store._con.execute(f"PRAGMA max_page_count = {store._con.execute('PRAGMA page_count').fetchone()[0]}")
        with pytest.raises(StoreError, match="full") as info:
            store.write([_row(f"m{k}", 1.0, message="x" * 5000) for k in range(50)])
        assert str(path) in str(info.value) and "\n" not in str(info.value)
        assert store.count() == 1  # the failed write left nothing behind


@contextlib.contextmanager
def _read_only(*paths: Path):
    """chmod the paths read-only; as root (who ignores modes) also set the immutable attribute."""
    modes = {p: p.stat().st_mode for p in paths}
    immutable: list[Path] = []
    try:
        for p in paths:
            p.chmod(0o555 if p.is_dir() else 0o444)
        if os.geteuid() == 0:
            if shutil.which("chattr") is None:
                pytest.skip("as root, a read-only file needs chattr")
            for p in paths:
                if subprocess.run(["chattr", "+i", str(p)], capture_output=True).returncode != 0:
                    pytest.skip("chattr +i is not supported here")
                immutable.append(p)
        yield
    finally:
        for p in immutable:
            subprocess.run(["chattr", "-i", str(p)], check=False)
        for p, mode in modes.items():
            p.chmod(mode)


def test_read_only_store_can_be_read_but_not_written(tmp_path):
    out = tmp_path / "out"
    path = out / STORE_NAME
    with ResultStore(path) as store:
        store.write([_row("a", 1.0), _row("b", 2.0)])
    assert sorted(os.listdir(out)) == [STORE_NAME]  # closed cleanly: no -wal/-shm left
    with _read_only(path, out):
        with (
            pytest.raises(StoreError, match=r"cannot open the results store|read-only") as info,
            ResultStore(path) as store,
        ):
            store.write([_row("c", 1.0)])
        assert str(path) in str(info.value) and "\n" not in str(info.value)
        with ResultStore(path, readonly=True) as ro:
            assert ro.count() == 2
            with pytest.raises(StoreError, match="read-only"):
                ro.write([_row("c", 1.0)])
        assert list(load_results(out)["method"]) == ["a", "b"]
    with ResultStore(path) as store:  # a read-only file in a writable folder
        store.write([_row("c", 1.0)])
    with _read_only(path):
        with pytest.raises(StoreError, match="read-only"):
            ResultStore(path).write([_row("d", 1.0)])
        assert len(load_results(out)) == 3


def test_read_only_open_refuses_a_wal_it_cannot_use(tmp_path):
    out = tmp_path / "out"
    path = out / STORE_NAME
    writer = ResultStore(path)
    writer.write([_row("a", 1.0)])
    writer._con.execute("PRAGMA wal_autocheckpoint=0")
    reader = sqlite3.connect(path)  # holds a snapshot: the checkpoint cannot finish
    reader.execute("BEGIN")
    reader.execute("SELECT COUNT(*) FROM rows").fetchone()
    writer.write([_row("b", 2.0)])
    reader.rollback()
    reader.close()
    copy = tmp_path / "copy"
    copy.mkdir()
    shutil.copy(path, copy / STORE_NAME)
    shutil.copy(path.with_name(STORE_NAME + "-wal"), copy / (STORE_NAME + "-wal"))
    writer.close()
    assert (copy / (STORE_NAME + "-wal")).stat().st_size > 0
    with _read_only(copy / STORE_NAME, copy), pytest.raises(StoreError, match="write-ahead log"):
        load_results(copy)
    assert len(load_results(copy)) == 2  # writable again: the log is read


def test_a_copy_of_the_main_file_alone_has_every_finished_row(tmp_path):
    path = tmp_path / STORE_NAME
    with ResultStore(path) as store:
        for k in range(5):
            store.write([_row("a", float(k), instance=f"t:seed={k}"), _row("b", 1.0, instance=f"t:seed={k}")])
        copy = tmp_path / "copy.sqlite"
        shutil.copy(path, copy)  # mid-run, without the -wal
        assert store.count() == 10
    with ResultStore(copy, readonly=True) as ro:
        assert ro.count() == 10


# --------------------------------------------------------------------------- exports
def test_exports_go_through_unique_temporary_files(tmp_path, monkeypatch):
    with ResultStore(tmp_path / STORE_NAME) as store:
        store.write([_row("a", 1.0, herding_curve=[1.0, 2.0]), _row("b", 2.0, herding_curve="text")])
        real_to_csv = pd.DataFrame.to_csv
        used = []

        def to_csv(df, target, *args, **kwargs):
            used.append(Path(target))
            if len(used) == 1:  # a second run exports to the same path meanwhile
                store.export(tmp_path / "results.csv")
            return real_to_csv(df, target, *args, **kwargs)

        monkeypatch.setattr(pd.DataFrame, "to_csv", to_csv)
        store.export(tmp_path / "results.csv")
        monkeypatch.undo()
        assert len(used) == 2 and used[0] != used[1] and {p.parent for p in used} == {tmp_path}
        assert len(pd.read_csv(tmp_path / "results.csv")) == 2
        store.export(tmp_path / "results.parquet")
        with pytest.raises(ValueError, match=r"csv or \.parquet"):
            store.export(tmp_path / "results.xlsx")
    back = pd.read_parquet(tmp_path / "results.parquet")
    assert list(back["method"]) == ["a", "b"] and list(back["objective"]) == [1.0, 2.0]
    assert list(back["herding_curve"]) == ["[1.0, 2.0]", '"text"']  # mixed values as JSON text
    assert sorted(p.name for p in tmp_path.iterdir() if p.name.endswith(".tmp")) == []
    assert (tmp_path / "results.csv").stat().st_mode & 0o777 == 0o666 & ~_umask()


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


# --------------------------------------------------------------------------- load_results
def test_load_results_reads_the_out_store_and_problem_stores_only(tmp_path):
    with ResultStore(tmp_path / STORE_NAME) as store:
        store.write([_row("a", 1.0)])
    with ResultStore(tmp_path / "cells" / STORE_NAME) as store:
        store.write([{**_row("ga", 5.0), "problem": "cells", "instance": "gap:seed=0"}])
    archived = tmp_path / "archive" / "2020" / STORE_NAME
    with ResultStore(archived) as store:
        store.write([_row("a", 100.0), _row("old", 1.0)])
    df = load_results(tmp_path)
    assert sorted(zip(df["problem"], df["method"], df["objective"], strict=True)) == [
        ("cells", "ga", 5.0),
        ("herding", "a", 1.0),
    ]
    assert list(load_results(tmp_path, problem="cells")["method"]) == ["ga"]
    assert list(load_results(archived)["method"]) == ["a", "old"]  # a file is read as given


# --------------------------------------------------------------------------- claims
_CLAIMER = textwrap.dedent(
    """
    import sys, time
    from droneplan.studies.store import ResultStore

    path, log, n = sys.argv[1], sys.argv[2], int(sys.argv[3])
    with ResultStore(path) as store, open(log, "a") as fh:
        for k in range(n):
            key = ("herding", f"t:seed={k}", "m", "c")
            if store.try_claim(key):
                fh.write(f"{k}\\n")
                fh.flush()
                time.sleep(0.005)
                store.write([{"problem": "herding", "instance": key[1], "method": "m", "config": "c",
                              "status": "feasible", "objective": float(k)}])
    """
)


def test_two_processes_never_do_the_same_job(tmp_path):
    path, n = tmp_path / STORE_NAME, 60
    ResultStore(path).close()
    logs = [tmp_path / f"log{j}" for j in range(2)]
    procs = [
        subprocess.Popen(
            [sys.executable, "-c", _CLAIMER, str(path), str(log), str(n)], stderr=subprocess.PIPE
        )
        for log in logs
    ]
    for p in procs:
        _, err = p.communicate(timeout=120)
        assert p.returncode == 0, err.decode()
    done = [int(x) for log in logs for x in log.read_text().split()]
    assert sorted(done) == list(range(n))  # every job once, none twice
    with ResultStore(path) as store:
        assert store.count() == n
        assert store._con.execute("SELECT COUNT(*) FROM claims").fetchone()[0] == 0  # writes ended them


def test_claims_of_dead_stale_and_live_processes(tmp_path):
    path = tmp_path / STORE_NAME
    key = ("herding", "t:seed=0", "m", "c")
    hold = textwrap.dedent(
        f"""
        import sys, time
        from droneplan.studies.store import ResultStore
        store = ResultStore({str(path)!r})
        assert store.try_claim({key!r})
        print("claimed", flush=True)
        time.sleep(float(sys.argv[1]))
        """
    )
    ResultStore(path).close()
    live = subprocess.Popen([sys.executable, "-c", hold, "60"], stdout=subprocess.PIPE, text=True)
    try:
        assert live.stdout.readline().strip() == "claimed"
        with ResultStore(path) as store:
            assert not store.try_claim(key)  # held by a live process
            store.release(key)  # not ours: stays
            assert not store.try_claim(key)
            time.sleep(0.05)
            assert store.try_claim(key, stale_after=0.01)  # older than stale_after: taken over
            assert store.try_claim(key)  # ours now
            store.release(key)
    finally:
        live.kill()
        live.wait()
    dead = subprocess.run([sys.executable, "-c", hold, "0"], capture_output=True, text=True, check=True)
    assert dead.stdout.strip() == "claimed"
    with ResultStore(path) as store:
        holder = store._con.execute("SELECT pid FROM claims").fetchone()[0]
        assert holder != os.getpid()
        assert store.try_claim(key)  # its process has died: taken over
        store.write([_row("m", 1.0, instance="t:seed=0", config="c")])
        assert not store.try_claim(key)  # done
        assert store.try_claim(key[:3])  # config '' is another job
        with pytest.raises(ValueError, match="key"):
            store.try_claim(("herding", "x"))
        with pytest.raises(ValueError, match="stale_after"):
            store.try_claim(key, stale_after=0)
    with ResultStore(path, readonly=True) as ro, pytest.raises(StoreError, match="read-only"):
        ro.try_claim(key)


def test_store_module_exports_its_public_names():
    for name in store_module.__all__:
        assert hasattr(store_module, name), name


def test_runs_says_which_machine_and_code_made_the_rows(tmp_path):
    """One entry per (version, commit, code hash, CPU, cores), most rows first, with the span of
    finishing times; a problem filter counts only its rows."""
    common = {"droneplan_version": "0.1.0", "cores": 2, "code_hash": "abc"}
    with ResultStore(tmp_path / STORE_NAME) as st:
        st.write(
            [
                _row(
                    "a",
                    1.0,
                    instance="t:seed=0",
                    cpu="CPU X",
                    git_commit="c1",
                    finished_at="2026-01-01T10:00:00",
                    **common,
                ),
                _row(
                    "b",
                    2.0,
                    instance="t:seed=0",
                    cpu="CPU X",
                    git_commit="c1",
                    finished_at="2026-01-01T12:00:00",
                    **common,
                ),
                _row(
                    "a",
                    3.0,
                    instance="t:seed=1",
                    cpu="CPU Y",
                    git_commit="c2",
                    finished_at="2026-01-02T09:00:00",
                    **common,
                ),
            ]
        )
        runs = st.runs()
        assert [(r["cpu"], r["git_commit"], r["rows"]) for r in runs] == [
            ("CPU X", "c1", 2),
            ("CPU Y", "c2", 1),
        ]
        assert (runs[0]["first"], runs[0]["last"]) == ("2026-01-01T10:00:00", "2026-01-01T12:00:00")
        assert st.runs("cells") == []
