"""Studies survive kill -9, stop cleanly on Ctrl-C and keep going past a failing task.

Real subprocesses run ``tests/unit/studies/study_tasks.py`` (fake tasks through the real
executor/store machinery) or the ``droneplan`` CLI, and are killed at random moments.
"""

from __future__ import annotations

import os
import random
import signal
import sqlite3
import subprocess
import sys
import time
from pathlib import Path

import pytest

from droneplan.studies.store import STORE_NAME, ResultStore, load_results

pytestmark = pytest.mark.slow  # real subprocesses killed at random moments: ~3 min, run in CI

HELPER = Path(__file__).resolve().parents[1] / "unit" / "studies" / "study_tasks.py"


def _start(out: Path, mode: str, n: int, delay: float, env=None) -> subprocess.Popen:
    return subprocess.Popen(
        [sys.executable, str(HELPER), str(out), mode, str(n), str(delay)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env={**os.environ, **(env or {})},
    )


def _wait_started(proc: subprocess.Popen) -> None:
    line = proc.stdout.readline()
    assert line.strip() == "started", proc.stderr.read()


def _wait_rows(path: Path, at_least: int, timeout: float = 60.0) -> None:
    t0 = time.monotonic()
    while time.monotonic() - t0 < timeout:
        if path.exists():
            con = sqlite3.connect(path, timeout=10)
            try:
                n = con.execute("SELECT COUNT(*) FROM rows").fetchone()[0]
            except sqlite3.OperationalError:
                n = 0
            con.close()
            if n >= at_least:
                return
        time.sleep(0.05)
    raise AssertionError(f"fewer than {at_least} rows after {timeout} s")


def _check_complete_pairs(path: Path, n_tasks: int | None = None) -> int:
    with ResultStore(path) as store:
        assert store._con.execute("PRAGMA integrity_check").fetchone()[0] == "ok"
        df = store.frame()
    assert not df.duplicated(["problem", "instance", "method"]).any()
    per = df.groupby("instance").size()
    assert (per == 2).all(), per[per != 2]  # a task's rows are all there or none
    if n_tasks is not None:
        assert len(per) == n_tasks
    return len(per)


@pytest.mark.parametrize("mode", ["serial", "processes"])
def test_sigkill_at_random_moments_then_resume(tmp_path, mode):
    rng = random.Random(7)
    path = tmp_path / STORE_NAME
    n = 40
    for _ in range(4):
        proc = _start(path, mode, n, 0.02)
        time.sleep(rng.uniform(0.5, 2.5))
        proc.kill()
        proc.wait()
        if path.exists():
            _check_complete_pairs(path)
    proc = _start(path, mode, n, 0.0)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 0, err
    _check_complete_pairs(path, n_tasks=n)


@pytest.mark.parametrize("mode", ["serial", "processes", "dask"])
def test_ctrl_c_exits_130_within_seconds_and_keeps_finished_rows(tmp_path, mode):
    if mode == "dask":
        pytest.importorskip("distributed")
    path = tmp_path / STORE_NAME
    proc = _start(path, mode, 400, 0.1)
    _wait_started(proc)
    _wait_rows(path, 4)
    t0 = time.monotonic()
    proc.send_signal(signal.SIGINT)
    proc.communicate(timeout=30)
    assert time.monotonic() - t0 < 6.0
    assert proc.returncode == 130
    done = _check_complete_pairs(path)
    assert 2 <= done < 400
    proc = _start(path, mode, 20 + done, 0.0)  # resume: only the missing tasks run
    proc.communicate(timeout=120)
    assert proc.returncode == 0
    _check_complete_pairs(path)


def test_ctrl_c_inside_a_cpsat_solve_is_not_recorded(tmp_path):
    path = tmp_path / STORE_NAME
    proc = _start(path, "cpsat", 2, 0.0)
    _wait_started(proc)
    time.sleep(2.0)  # inside the first 20 s solve
    t0 = time.monotonic()
    proc.send_signal(signal.SIGINT)
    proc.communicate(timeout=30)
    assert time.monotonic() - t0 < 6.0
    assert proc.returncode == 130
    with ResultStore(path) as store:
        assert store.count() == 0  # the cut-short solve left no "finished" row


def test_failing_task_becomes_error_row_and_is_retried(tmp_path):
    path = tmp_path / STORE_NAME
    proc = _start(path, "processes", 6, 0.0, env={"FAIL_SEEDS": "1,4"})
    proc.communicate(timeout=120)
    assert proc.returncode == 0
    df = load_results(path)
    err = df[df["status"] == "error"]
    assert sorted(err["seed"]) == [1, 4]
    assert err["message"].str.contains("planned failure on seed").all()
    assert (df[df["status"] != "error"].groupby("instance").size() == 2).all()
    assert df[df["status"] != "error"]["instance"].nunique() == 4
    proc = _start(path, "serial", 6, 0.0, env={"FAIL_SEEDS": ""})
    proc.communicate(timeout=120)
    _check_complete_pairs(path, n_tasks=6)


# --------------------------------------------------------------------------- the CLI
def _cli(*args, timeout=120) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "droneplan.studies.cli", *args],
        capture_output=True,
        text=True,
        timeout=timeout,
        check=False,
    )


def test_cli_bad_out_and_unreachable_dask_give_one_line_errors(tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("x")
    r = _cli("gap", "herding", "--seeds", "1", "--out", str(blocker / "sub"))
    assert r.returncode == 2 and "Traceback" not in r.stderr
    assert len(r.stderr.strip().splitlines()) == 1 and "--out" in r.stderr
    t0 = time.monotonic()
    r = _cli("gap", "herding", "--seeds", "1", "--dask", "tcp://127.0.0.1:9", "--out", str(tmp_path / "o"))
    assert r.returncode == 2 and "Traceback" not in r.stderr
    assert len(r.stderr.strip().splitlines()) == 1 and "Dask scheduler" in r.stderr
    assert time.monotonic() - t0 < 25  # a 5 s connect timeout plus start-up, not 30 s
    old = tmp_path / "old"
    old.mkdir()
    con = sqlite3.connect(old / STORE_NAME)
    con.execute("CREATE TABLE meta (key TEXT PRIMARY KEY, value TEXT)")
    con.execute("INSERT INTO meta VALUES ('schema_version', '0')")
    con.commit()
    con.close()
    r = _cli("gap", "herding", "--seeds", "1", "--out", str(old))
    assert r.returncode == 2 and "Move it away" in r.stderr and "Traceback" not in r.stderr


def test_cli_ctrl_c_serial_exits_130_and_resumes(tmp_path):
    out = tmp_path / "o"
    proc = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "droneplan.studies.cli",
            "gap",
            "herding",
            "--seeds",
            "40",
            "--workers",
            "1",
            "--out",
            str(out),
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    _wait_rows(out / STORE_NAME, 8, timeout=120)
    t0 = time.monotonic()
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=30)
    assert time.monotonic() - t0 < 6.0
    assert proc.returncode == 130 and "rerun the same command to resume" in err
    df = load_results(out)
    assert len(df) and not df.duplicated(["problem", "instance", "method"]).any()
    assert (df["status"] != "error").all()
