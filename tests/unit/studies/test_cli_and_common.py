"""The CLI lists what exists and refuses what does not; the study machinery resumes."""

from __future__ import annotations

import subprocess
import sys

import pandas as pd
import pytest

from droneplan.studies import cli
from droneplan.studies.common import ComparisonTable, make_executor, summarize
from droneplan.studies.jobs import map_rows
from droneplan.studies.store import (
    STORE_NAME,
    Outcome,
    ResultStore,
    build_rows,
    instance_id,
)
from droneplan.studies.thesis import problem_studies


def test_help_runs_and_names_available_problems():
    out = subprocess.run(
        [sys.executable, "-m", "droneplan.studies.cli", "--help"], capture_output=True, text=True, check=True
    ).stdout
    for sub in ("reproduce", "gap", "bench"):
        assert sub in out
    avail = cli.available_problems()
    assert "available problems:" in out
    for p in avail:
        assert p in out.split("available problems:")[1]


def test_unavailable_or_unknown_problem_is_refused(monkeypatch):
    monkeypatch.setattr(problem_studies, "available_problems", list)
    with pytest.raises(SystemExit, match="not implemented yet"):
        cli.main(["reproduce", "cells", "--quick"])
    with pytest.raises(SystemExit):
        cli.main(["bench", "nonsense"])


def _square(task):
    s = task["seed"]
    return build_rows(
        "herding",
        task["instance"],
        seed=s,
        size=1,
        sense="min",
        outcomes=[Outcome("square", "heuristic", "feasible", objective=float(s * s))],
    )


def _tasks(n):
    return [{"problem": "herding", "instance": instance_id("t", seed=s), "seed": s} for s in range(n)]


def test_map_rows_writes_and_resumes(tmp_path):
    with ResultStore(tmp_path / STORE_NAME) as store:
        with make_executor(workers=1) as ex:
            df = map_rows(_square, _tasks(3), executor=ex, store=store)
        assert sorted(df["objective"]) == [0, 1, 4]
        calls = []

        def counting(task):
            calls.append(task["seed"])
            return _square(task)

        with make_executor(workers=1) as ex:
            df = map_rows(counting, _tasks(5), executor=ex, store=store)
        assert sorted(calls) == [3, 4]  # the three finished instances were not recomputed
        assert sorted(df["objective"]) == [0, 1, 4, 9, 16]


def test_serial_executor_runs_each_task_when_consumed(tmp_path):
    """--workers 1: the first task's row is on disk before the second task starts."""
    seen = []
    with ResultStore(tmp_path / STORE_NAME) as store:

        def probe(task):
            seen.append(store.count())
            return _square(task)

        with make_executor(workers=1) as ex:
            map_rows(probe, _tasks(3), executor=ex, store=store)
    assert seen == [0, 1, 2]


def test_process_pool_executor(tmp_path):
    with ResultStore(tmp_path / STORE_NAME) as store, make_executor(workers=2) as ex:
        df = map_rows(_square, _tasks(4), executor=ex, store=store)
    assert sorted(df["objective"]) == [0, 1, 4, 9]


def test_bad_arguments(tmp_path):
    with pytest.raises(ValueError, match="workers"):
        make_executor(workers=0).__enter__()
    with ResultStore(tmp_path / STORE_NAME) as store, make_executor(workers=1) as ex:
        with pytest.raises(ValueError, match="instance"):
            map_rows(_square, [{"seed": 1}], executor=ex, store=store)
        with pytest.raises(ValueError, match="repeat"):
            map_rows(_square, _tasks(2) + _tasks(1), executor=ex, store=store)


def test_comparison_table(tmp_path):
    t = ComparisonTable("Table X")
    t.add("max beta (deg)", 15.5, 14.25, "simulate case 1")
    t.add("time (min)", 10.0, 20.0, "a long description " * 10)
    t.add("text only", "< 0.3", "0.2", "strings: no deviation")
    text = t.render(width=80)
    assert "thesis" in text and "15.5" in text and "14.25" in text
    assert max(len(line) for line in text.splitlines()) <= 80
    df = t.frame()
    assert list(df["deviation"]) == ["-8%", "+100%", ""]
    assert list(df["flag"]) == ["ok", "!", ""]  # beyond DEVIATION_THRESHOLD = 25 %
    t.emit(tmp_path, "table_x")
    df = pd.read_csv(tmp_path / "table_x.csv")
    assert list(df.columns) == ["quantity", "thesis", "this run", "deviation", "flag", "how measured", "why"]
    assert "| max beta (deg) | 15.5 | 14.25 | -8% | ok |" in (tmp_path / "table_x.md").read_text()


def test_summarize_counts_and_gaps():
    rows = []
    for s in range(4):
        rows += build_rows(
            "cells",
            instance_id("t", seed=s),
            seed=s,
            size=3,
            sense="max",
            outcomes=[
                Outcome("milp", "model", "optimal", objective=10.0, bound=10.0, bound_kind="candidate-set"),
                Outcome("ga", "heuristic", "feasible", objective=10.0 - (s == 0) * 5.0),
            ],
        )
    summary = summarize(pd.DataFrame(rows), {("cells", "ga"): "P_Global = 1"}).set_index("method")
    assert summary.loc["ga", "count"] == 4 and summary.loc["ga", "best_rate"] == 0.75
    assert summary.loc["ga", "median_gap_to_bound"] == 0.0
    assert summary.loc["ga", "mean_gap_to_bound"] == pytest.approx(0.5 / 4)
    assert summary.loc["ga", "thesis"] == "P_Global = 1"
    assert summary.loc["milp", "success_rate"] == 1.0


def test_summarize_prints_float_noise_gaps_as_zero():
    """An objective equal to the bound up to rounding (gap -5.15e-16) summarises as a gap of 0."""
    rows = pd.DataFrame(
        {
            "problem": ["covert"] * 2,
            "method": ["sliding"] * 2,
            "role": ["heuristic"] * 2,
            "status": ["feasible"] * 2,
            "gap_to_bound": [-5.15e-16, 4e-10],
            "gap_to_best": [0.0, 2e-3],
        }
    )
    rec = summarize(rows).iloc[0]
    assert rec["median_gap_to_bound"] == 0.0 and rec["mean_gap_to_bound"] == 0.0
    assert rec["p95_gap_to_bound"] == 0.0
    assert rec["p95_gap_to_best"] == pytest.approx(0.95 * 2e-3)


def test_all_dependencies_import_in_one_process():
    code = (
        "import cvxpy, casadi, osqp, shapely, scipy, pandas, matplotlib, tqdm;"
        "from ortools.sat.python import cp_model; from ortools.linear_solver import pywraplp;"
        "assert pywraplp.Solver.CreateSolver('HIGHS') is not None;"
        "assert pywraplp.Solver.CreateSolver('SCIP') is not None;"
        "import numpy as np; x = cvxpy.Variable(2);"
        "p = cvxpy.Problem(cvxpy.Minimize(cvxpy.sum_squares(x - 1)), [cvxpy.sum(x) <= 1]);"
        "p.solve();"
        "assert abs(p.value - 0.5) < 1e-4; print('ok')"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip().endswith("ok")


def test_dask_executor_maps_rows(tmp_path):
    distributed = pytest.importorskip("distributed")
    with (
        distributed.LocalCluster(
            n_workers=1, threads_per_worker=1, processes=False, dashboard_address=None
        ) as cluster,
        ResultStore(tmp_path / STORE_NAME) as store,
        make_executor(dask_address=cluster.scheduler_address) as ex,
    ):
        df = map_rows(_square, _tasks(3), executor=ex, store=store)
    assert sorted(df["objective"]) == [0, 1, 4]


def _failing_task(task):
    raise RuntimeError(f"planned failure on {task['instance']}")


def _fake_table(out):
    ComparisonTable("fake table").emit(out, "fake")


def test_reproduce_report_is_written_when_a_task_errors(tmp_path, monkeypatch):
    """An error row does not suppress --report: the page shows what finished, the exit code is 1."""
    import types

    from droneplan.studies.jobs import Job, row_jobs

    def reproduce_jobs(*, quick, out, store_path):
        rows = row_jobs(_square, _tasks(2), section="fake", cost=1.0)
        rows += row_jobs(
            _failing_task, [{"problem": "herding", "instance": "t:bad", "seed": 9}], section="fake", cost=1.0
        )
        return [*rows, Job("fake/table", "fake", _fake_table, {"out": out}, local=True)]

    monkeypatch.setattr(cli, "_load", lambda problem: types.SimpleNamespace(reproduce_jobs=reproduce_jobs))
    monkeypatch.setattr(problem_studies, "available_problems", lambda: ["herding"])
    code = cli.main(["reproduce", "herding", "--quick", "--out", str(tmp_path), "--workers", "1", "--report"])
    assert code == 1
    assert (tmp_path / "report.html").is_file()
    rows = pd.read_csv(tmp_path / "results.csv")
    assert sorted(rows["status"].unique()) == ["error", "feasible"]


def test_run_gap_bounds_workers_and_checks_dask_address(tmp_path):
    import os

    from droneplan.studies.common import WORKERS_PER_CORE

    most = WORKERS_PER_CORE * (os.cpu_count() or 1)
    with pytest.raises(ValueError, match=rf"^workers .*{most}"):
        cli.run_gap("cells", seeds=1, out=tmp_path / "a", workers=most + 1)
    with pytest.raises(ValueError, match=r"^workers"):
        cli.run_gap("cells", seeds=1, out=tmp_path / "b", workers=10**12)
    with pytest.raises(TypeError, match=r"^dask_address must be str"):
        cli.run_gap("cells", seeds=1, out=tmp_path / "c", dask_address=10**12)
    assert not list(tmp_path.iterdir())  # refused before --out was created
    with pytest.raises(ValueError, match=r"^workers"):
        make_executor(workers=most + 1).__enter__()


def test_cli_workers_beyond_the_bound_exit_naming_the_option(tmp_path):
    import os

    from droneplan.studies.common import WORKERS_PER_CORE

    most = WORKERS_PER_CORE * (os.cpu_count() or 1)
    args = ["gap", "cells", "--seeds", "1", "--out", str(tmp_path / "o"), "--workers"]
    for workers in (0, most + 1, 10**12):
        with pytest.raises(SystemExit, match=rf"--workers must be in \[1, {most}\]"):
            cli.main([*args, str(workers)])
    assert not (tmp_path / "o").exists()  # refused before --out was created


def test_timed_and_measured_record_wall_cpu_and_load():
    """A bench measurement holds the median wall and CPU time of one call and the load average;
    busy work shows up as CPU time, a sleep only as wall time."""
    import math
    import time

    from droneplan.studies.common import measured, timed

    result, m = timed(sum, range(200_000), repeat=3)
    assert result == sum(range(200_000))
    assert m.cpu_s > 0 and m.wall_s > 0
    assert math.isfinite(m.load) and m.load >= 0
    assert "CPU-s" in m.note and "s wall" in m.note and "load average" in m.note
    with measured() as idle:
        time.sleep(0.2)
    assert idle.wall_s >= 0.2
    assert idle.cpu_s < idle.wall_s / 2
    with pytest.raises(ValueError, match="repeat"):
        timed(sum, [1], repeat=0)
