"""Repeated runs of a gap study: one seed per run, success rates, resumption, deterministic methods."""

from __future__ import annotations

import math
import sqlite3

import numpy as np
import pytest

import droneplan as dp
from droneplan.core.validation import run_seed
from droneplan.studies.analysis import summary_table
from droneplan.studies.instances import family_instances
from droneplan.studies.library import lookup
from droneplan.studies.methods import Method
from droneplan.studies.store import _V2_COLUMNS, STORE_NAME, ResultStore
from droneplan.studies.study import MAX_RUNS, check_runs

P_SUCCESS = 0.6
_OPTIMAL: dict[str, np.ndarray] = {}  # the optimal plan, set by the fixture (the forked jobs inherit it)
_LOG: dict[str, str] = {}  # where each call of a method appends a line (the jobs run in child processes)


@pytest.fixture(scope="module")
def small():
    """A Table 4.2 instance with one drone-cell, its certified optimum and an optimal plan."""
    inst = family_instances("table4.2", m=1, seeds=[0])[0]
    entry = lookup(inst)
    assert entry is not None and entry.bound_kind == "proven-global" and entry.status == "optimal"
    _OPTIMAL["plan"] = np.asarray(entry.plan, dtype=float)
    return inst, entry


def _log_call(name: str, seed: int) -> None:
    with open(_LOG["path"], "a", encoding="utf-8") as fh:
        fh.write(f"{name} {seed}\n")


def lucky(problem, *, seed, time_limit):
    """The optimal plan when the seed's draw is below P_SUCCESS, else no drone-cell at all."""
    _log_call("lucky", seed)
    if np.random.default_rng(seed).random() < P_SUCCESS:
        return _OPTIMAL["plan"]
    return np.empty((0, 2))


def steady(problem, *, seed, time_limit):
    """The same plan whatever the seed (declares nothing: detected as deterministic)."""
    _log_call("steady", seed)
    return _OPTIMAL["plan"]


def _calls(name: str) -> list[int]:
    with open(_LOG["path"], encoding="utf-8") as fh:
        return [int(s) for n, s in (line.split() for line in fh) if n == name]


def _study(tmp_path, methods, runs):
    return dp.gap(
        "cells",
        methods=methods,
        instances="table4.2",
        m=1,
        seeds=[0],
        runs=runs,
        out=tmp_path / "out",
        workers=2,
        time_limit=30,
        progress=False,
    )


def test_run_seeds_keep_run_zero_and_differ():
    assert run_seed(7, 0) == 7 and run_seed(0, 0) == 0
    seeds = [run_seed(7, r) for r in range(200)]
    assert len(set(seeds)) == 200 and all(s >= 0 for s in seeds)
    assert seeds == [run_seed(7, r) for r in range(200)]  # reproducible


def test_success_rate_of_a_stochastic_method_and_resumption(tmp_path, small):
    inst, entry = small
    _LOG["path"] = str(tmp_path / "calls.log")
    method = Method("lucky", lucky, deterministic=False)
    df = _study(tmp_path, [method], runs=40)
    assert len(_calls("lucky")) == 40
    df = _study(tmp_path, [method], runs=60)  # only the 20 missing runs are made
    calls = _calls("lucky")
    assert len(calls) == 60
    rows = df[df["method"] == "lucky"]
    assert sorted(rows["run"]) == list(range(60))
    assert rows["run_seed"].nunique() == 60  # one distinct seed per run, recorded
    assert sorted(rows["run_seed"]) == sorted(calls)  # ... and the one the method was given
    assert int(rows.loc[rows["run"] == 0, "run_seed"].iloc[0]) == (inst.seed or 0)
    assert (rows["deterministic"] == False).all()  # noqa: E712 (object column of bools)
    table = summary_table(df)
    (line,) = table[table["method"] == "lucky"].to_dict("records")
    assert line["target_kind"] == "proven" and line["runs"] == 60
    sd = math.sqrt(P_SUCCESS * (1 - P_SUCCESS) / 60)
    assert abs(line["success_rate"] - P_SUCCESS) <= 4 * sd
    expected = np.mean([np.random.default_rng(s).random() < P_SUCCESS for s in calls])
    assert line["success_rate"] == pytest.approx(expected)
    ok = rows["objective"] >= entry.value * (1 - 1e-6)
    ert = rows["time_s"].sum() / ok.sum()
    assert line["ert_s"] == pytest.approx(ert)
    assert line["median_objective"] == pytest.approx(rows["objective"].median())
    assert line["q1_objective"] <= line["median_objective"] <= line["q3_objective"]


def test_a_deterministic_method_runs_once(tmp_path, small):
    _LOG["path"] = str(tmp_path / "calls.log")
    declared = Method("declared", steady, deterministic=True)
    df = _study(tmp_path, [declared], runs=5)
    rows = df[df["method"] == "declared"]
    assert len(_calls("steady")) == 1 and list(rows["run"]) == [0]
    assert list(rows["deterministic"]) == [True]
    _LOG["path"] = str(tmp_path / "calls2.log")
    detected = Method("detected", steady)  # declares nothing: run twice, then stopped
    df = _study(tmp_path, [detected], runs=5)
    rows = df[df["method"] == "detected"]
    assert len(_calls("steady")) == 2 and sorted(rows["run"]) == [0, 1]
    assert list(rows["deterministic"]) == [True, True]
    line = summary_table(df).set_index("method").loc["detected"]
    assert line["success_rate"] == 1.0 and line["ert_s"] == pytest.approx(rows["time_s"].sum() / 2)


def test_one_run_summary_has_no_ert_for_failures_and_unchanged_columns(tmp_path, small):
    df = _study(tmp_path, ["greedy"], runs=1)
    assert set(df["run"]) == {0}
    greedy = df[df["method"] == "greedy"]
    assert list(greedy["deterministic"]) == [True]
    table = summary_table(df)
    assert {"n", "solved", "at_best", "median_gap_to_best"} <= set(table.columns)
    assert table.attrs["success_tol"] == 1e-6


@pytest.mark.parametrize("runs", [0, -1, 1.5, "3", True, None, MAX_RUNS + 1])
def test_bad_runs_are_refused_in_one_line(runs):
    with pytest.raises(ValueError, match=r"^runs must be an int from 1 to") as info:
        check_runs(runs)
    assert "\n" not in str(info.value)


def test_bad_runs_refused_by_gap_before_any_work(tmp_path):
    with pytest.raises(ValueError, match=r"^runs "):
        dp.gap("cells", methods=["greedy"], m=1, seeds=1, runs=0, out=tmp_path, progress=False)
    assert not (tmp_path / STORE_NAME).exists()


def _v2_store(path) -> None:
    con = sqlite3.connect(path)
    cols = ", ".join(f'"{c}"' + (" TEXT NOT NULL DEFAULT ''" if c == "config" else "") for c in _V2_COLUMNS)
    for table in ("rows", "superseded"):
        con.execute(
            f"CREATE TABLE {table} ({cols}, extras TEXT NOT NULL DEFAULT '{{}}', "
            "PRIMARY KEY (problem, instance, method, config))"
        )
    con.execute(
        "CREATE TABLE claims (problem TEXT NOT NULL, instance TEXT NOT NULL, method TEXT NOT NULL, "
        "config TEXT NOT NULL, host TEXT NOT NULL, pid INTEGER NOT NULL, claimed_at REAL NOT NULL, "
        "PRIMARY KEY (problem, instance, method, config))"
    )
    con.execute("CREATE TABLE meta (key TEXT PRIMARY KEY, value TEXT NOT NULL)")
    con.execute("INSERT INTO meta VALUES ('schema_version', '2')")
    names = ("problem", "instance", "method", "role", "sense", "status", "objective", "config", "flag")
    marks = ", ".join("?" * len(names))
    for table, method, obj, config in (
        ("rows", "a", 3.0, "c2"),
        ("rows", "b", 2.0, "c1"),
        ("superseded", "a", 1.0, "c1"),
    ):
        con.execute(
            f"INSERT INTO {table} ({', '.join(names)}) VALUES ({marks})",
            ("herding", "t:seed=0", method, "heuristic", "min", "feasible", obj, config, ""),
        )
    con.commit()
    con.close()


def test_v2_store_is_migrated_with_its_rows_as_run_zero(tmp_path):
    path = tmp_path / STORE_NAME
    _v2_store(path)
    with ResultStore(path, readonly=True) as ro:  # read as it is
        assert ro.version == 2 and list(ro.frame()["run"]) == [0, 0]
    with ResultStore(path) as store:
        assert store._con.execute("SELECT value FROM meta").fetchone()[0] == "3"
        full = store.frame(include_superseded=True)
        assert len(full) == 3 and set(full["run"]) == {0}
        assert sorted(zip(full["method"], full["objective"], full["superseded"], strict=True)) == [
            ("a", 1.0, True),
            ("a", 3.0, False),
            ("b", 2.0, False),
        ]
        assert store.done_keys() == {
            ("herding", "t:seed=0", "a", "c2", 0),
            ("herding", "t:seed=0", "b", "c1", 0),
        }
        row = {
            "problem": "herding",
            "instance": "t:seed=0",
            "method": "a",
            "config": "c2",
            "status": "feasible",
        }
        store.write([{**row, "run": 1, "objective": 4.0}])  # another run of the same config: both stay
        assert sorted(store.frame()["run"]) == [0, 0, 1]
        assert store.try_claim(("herding", "t:seed=0", "a", "c2", 2))
        assert not store.try_claim(("herding", "t:seed=0", "a", "c2", 1))  # done


@pytest.mark.parametrize("value", ["0", "1001", "2.5", "many"])
def test_cli_refuses_bad_runs_in_one_line(tmp_path, value):
    from droneplan.studies import cli

    out = tmp_path / "out"
    with pytest.raises(SystemExit) as info:
        cli.main(
            [
                "gap",
                "cells",
                "--method",
                "greedy",
                "--m",
                "1",
                "--seeds",
                "1",
                "--runs",
                value,
                "--out",
                str(out),
            ]
        )
    text = str(info.value.code)
    assert text.startswith("droneplan: --runs must be an int from 1 to 1000") and "\n" not in text
    with pytest.raises(SystemExit, match=r"^droneplan: --runs goes with an open study"):
        cli.main(["gap", "cells", "--seeds", "1", "--runs", "3", "--out", str(out)])
