"""The CLI lists what exists and refuses what does not; the study machinery resumes."""

from __future__ import annotations

import subprocess
import sys

import pandas as pd
import pytest

from droneplan.studies import cli
from droneplan.studies.common import ComparisonTable, ResumableCSV, make_executor, map_rows


def test_help_runs_and_names_available_problems():
    out = subprocess.run([sys.executable, "-m", "droneplan.studies.cli", "--help"], capture_output=True, text=True,
                         check=True).stdout
    for sub in ("reproduce", "gap", "bench"):
        assert sub in out
    avail = cli.available_problems()
    assert "available problems:" in out
    for p in avail:
        assert p in out.split("available problems:")[1]


def test_unavailable_or_unknown_problem_is_refused(monkeypatch):
    monkeypatch.setattr(cli, "available_problems", lambda: [])
    with pytest.raises(SystemExit, match="not implemented yet"):
        cli.main(["reproduce", "cells", "--quick"])
    with pytest.raises(SystemExit):
        cli.main(["bench", "nonsense"])


def _square(task):
    return {"seed": task["seed"], "value": task["seed"] ** 2}


def test_map_rows_appends_and_resumes(tmp_path):
    store = ResumableCSV(tmp_path / "rows.csv", key=["seed"])
    with make_executor(workers=1) as ex:
        df = map_rows(_square, [{"seed": s} for s in range(3)], executor=ex, store=store)
    assert sorted(df["value"]) == [0, 1, 4]
    calls = []

    def counting(task):
        calls.append(task["seed"])
        return _square(task)

    with make_executor(workers=1) as ex:
        df = map_rows(counting, [{"seed": s} for s in range(5)], executor=ex, store=store)
    assert sorted(calls) == [3, 4]  # the three finished rows were not recomputed
    assert sorted(df["value"]) == [0, 1, 4, 9, 16]


def test_process_pool_executor(tmp_path):
    store = ResumableCSV(tmp_path / "rows.csv", key=["seed"])
    with make_executor(workers=2) as ex:
        df = map_rows(_square, [{"seed": s} for s in range(4)], executor=ex, store=store)
    assert sorted(df["value"]) == [0, 1, 4, 9]


def test_bad_arguments():
    with pytest.raises(ValueError, match="workers"):
        make_executor(workers=0).__enter__()
    with pytest.raises(ValueError, match="key"):
        ResumableCSV("x.csv", key=[])


def test_comparison_table(tmp_path):
    t = ComparisonTable("Table X")
    t.add("max beta (deg)", 15.5, 14.25, "simulate case 1")
    text = t.render()
    assert "thesis" in text and "15.5" in text and "14.25" in text
    t.emit(tmp_path, "table_x")
    df = pd.read_csv(tmp_path / "table_x.csv")
    assert list(df.columns) == ["quantity", "thesis", "this run", "how measured"]


def test_all_dependencies_import_in_one_process():
    code = ("import cvxpy, casadi, osqp, shapely, scipy, pandas, matplotlib, tqdm;"
            "from ortools.sat.python import cp_model; from ortools.linear_solver import pywraplp;"
            "assert pywraplp.Solver.CreateSolver('HIGHS') is not None;"
            "assert pywraplp.Solver.CreateSolver('SCIP') is not None;"
            "import numpy as np; x = cvxpy.Variable(2);"
            "p = cvxpy.Problem(cvxpy.Minimize(cvxpy.sum_squares(x - 1)), [cvxpy.sum(x) <= 1]);"
            "p.solve();"
            "assert abs(p.value - 0.5) < 1e-4; print('ok')")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip().endswith("ok")


def test_dask_executor_maps_rows(tmp_path):
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=False,
                                  dashboard_address=None) as cluster:
        store = ResumableCSV(tmp_path / "rows.csv", key=["seed"])
        with make_executor(dask_address=cluster.scheduler_address) as ex:
            df = map_rows(_square, [{"seed": s} for s in range(3)], executor=ex, store=store)
    assert sorted(df["value"]) == [0, 1, 4]
