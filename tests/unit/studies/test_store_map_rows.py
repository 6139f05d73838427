"""map_rows stamps rows with a config and provenance, resumes per config, reports set-aside rows;
summaries survive a study whose every row is an error row."""

from __future__ import annotations

import json

import matplotlib
import pytest

from droneplan.studies import common
from droneplan.studies.common import make_executor, report_study, summarize, task_config
from droneplan.studies.jobs import map_rows
from droneplan.studies.provenance import config_hash, provenance
from droneplan.studies.store import STORE_NAME, Outcome, ResultStore, build_rows, instance_id

matplotlib.use("Agg")


def _square(task):
    s = task["seed"]
    return build_rows(
        "herding",
        task["instance"],
        seed=s,
        size=1,
        sense="min",
        outcomes=[Outcome("square", "heuristic", "feasible", objective=float(s * s) + task.get("shift", 0))],
    )


def _boom(task):
    raise RuntimeError(f"planned failure on {task['instance']}")


def _tasks(n, **extra):
    return [
        {"problem": "herding", "instance": instance_id("t", seed=s), "seed": s, **extra} for s in range(n)
    ]


def test_task_config_hashes_the_settings_and_the_code(monkeypatch):
    task = {"problem": "herding", "instance": "t:seed=1", "seed": 1, "w": (0.5, 2)}
    expected = config_hash({"task": {"seed": 1, "w": [0.5, 2]}, "code_hash": provenance()["code_hash"]})
    assert task_config(task) == expected
    assert task_config({**task, "instance": "other"}) == expected  # the id is not a setting
    assert task_config({**task, "w": (0.5, 3)}) != expected
    monkeypatch.setattr(common, "provenance", lambda: {"code_hash": "0" * 16})
    assert task_config(task) != expected
    with pytest.raises(TypeError, match=r"t:seed=1.*set"):
        task_config({**task, "w": {1, 2}})


def test_rows_carry_config_and_provenance_and_resume_per_config(tmp_path, monkeypatch, capsys):
    with ResultStore(tmp_path / STORE_NAME) as store:
        with make_executor(workers=1) as ex:
            df = map_rows(_square, _tasks(2), executor=ex, store=store)
        assert list(df["config"]) == [task_config(t) for t in _tasks(2)]
        assert (df["code_hash"] == provenance()["code_hash"]).all()
        assert json.loads(df["packages"].iloc[0]) == provenance()["packages"]
        assert df["finished_at"].str.endswith("+00:00").all() and (df["cores"] == provenance()["cores"]).all()
        calls = []

        def counting(task):
            calls.append(task["seed"])
            return _square(task)

        with make_executor(workers=1) as ex:
            map_rows(counting, _tasks(3), executor=ex, store=store)
        assert calls == [2]  # same settings, same code: resumed
        assert "set aside" not in capsys.readouterr().err
        with make_executor(workers=1) as ex:  # another setting: every task runs again
            df = map_rows(counting, _tasks(3, shift=10), executor=ex, store=store, desc="shifted")
        assert calls == [2, 0, 1, 2] and sorted(df["objective"]) == [10, 11, 14]
        assert "shifted: 3 row(s) of an earlier code or settings version set aside" in capsys.readouterr().err
        monkeypatch.setattr(common, "provenance", lambda: {"code_hash": "f" * 16})
        with make_executor(workers=2) as ex:  # a code change: again, through a process pool
            df = map_rows(_square, _tasks(3, shift=10), executor=ex, store=store)
        assert "3 row(s)" in capsys.readouterr().err
        assert store.count() == 3 and len(store.frame(include_superseded=True)) == 9


def test_error_rows_get_a_config_and_an_all_error_study_is_summarized(tmp_path, capsys):
    with ResultStore(tmp_path / STORE_NAME) as store, make_executor(workers=1) as ex:
        df = map_rows(_boom, _tasks(2), executor=ex, store=store)
        assert list(df["status"]) == ["error", "error"] and list(df["config"]) == [
            task_config(t) for t in _tasks(2)
        ]
        assert store.done_instances() == set()
        summary = summarize(df)
        assert summary.loc[0, "errors"] == 2 and summary.loc[0, "best_rate"] == 0.0
        assert summary.loc[0, "median_gap_to_best"] is None
        report_study(df, tmp_path / "rep", "herding")
        assert (tmp_path / "rep" / "gap_herding.png").exists()
        assert "task" in capsys.readouterr().out
        df = map_rows(_square, _tasks(2), executor=ex, store=store)  # retried: the error rows go
        assert list(df["status"]) == ["feasible", "feasible"]
    assert list(summarize(df.iloc[0:0]).columns)[:3] == ["problem", "method", "role"]
