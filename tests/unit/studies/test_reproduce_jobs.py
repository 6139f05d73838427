"""The job scheduler of ``droneplan reproduce``: order, failures, resuming, the time table, and
the same rows from a serial and a parallel run."""

from __future__ import annotations

import pandas as pd
import pytest

from droneplan.studies.common import make_executor
from droneplan.studies.jobs import Job, JobsFailed, idle_estimate, row_jobs, run_jobs, time_table
from droneplan.studies.store import ResultStore, instance_id
from droneplan.studies.thesis import cells, herding


def _add(a: int, b: int = 0) -> int:
    return a + b


def _boom() -> int:
    raise RuntimeError("boom")


def _task_rows(task) -> list[dict]:
    return cells.reproduce_task(task)


def _graph() -> list[Job]:
    return [
        Job("x", "s1", _add, {"a": 1}, cost=1.0),
        Job("y", "s1", _add, {"a": 2}, cost=5.0),
        Job("z", "s2", _add, {}, {"a": "x", "b": "y"}, cost=1.0),
        Job("w", "s2", _add, {"b": 10}, {"a": "z"}, cost=1.0),
    ]


def test_results_flow_to_the_jobs_that_need_them():
    seen = []

    def record(a: int, b: int = 0) -> int:
        seen.append((a, b))
        return a + b

    jobs = [Job(j.key, j.section, record, j.kwargs, j.needs, cost=j.cost) for j in _graph()]
    with make_executor(1) as ex:
        timings = run_jobs(jobs, executor=ex, progress=False)
    # y (the costliest chain) first, then x, then z = x + y, then w = z + 10
    assert seen == [(2, 0), (1, 0), (1, 2), (3, 10)]
    assert [t.key for t in timings] == ["y", "x", "z", "w"]


def test_a_failure_stops_only_the_jobs_that_need_it():
    jobs = [*_graph(), Job("bad", "s3", _boom), Job("after-bad", "s3", _add, {"b": 1}, {"a": "bad"})]
    with make_executor(1) as ex, pytest.raises(JobsFailed, match="bad: RuntimeError: boom"):
        run_jobs(jobs, executor=ex, progress=False)


@pytest.mark.parametrize(
    ("jobs", "message"),
    [
        ([Job("a", "s", _add, {"a": 1}), Job("a", "s", _add, {"a": 2})], "repeat the key 'a'"),
        ([Job("a", "s", _add, {}, {"a": "nope"})], "unknown jobs"),
        ([Job("a", "s", _add, {}, {"a": "b"}), Job("b", "s", _add, {}, {"a": "a"})], "cycle"),
    ],
)
def test_bad_graphs_are_refused(jobs, message):
    with make_executor(1) as ex, pytest.raises(ValueError, match=message):
        run_jobs(jobs, executor=ex, progress=False)


def test_store_tasks_need_a_store():
    task = {"problem": "cells", "instance": "t", "kind": "exact", "m": 1, "seed": 0, "exact_limit": 5.0}
    with make_executor(1) as ex, pytest.raises(ValueError, match="need a store"):
        run_jobs(row_jobs(_task_rows, [task], section="s", cost=1.0), executor=ex, progress=False)


def test_time_table_sums_the_jobs():
    with make_executor(1) as ex:
        timings = run_jobs(_graph(), executor=ex, progress=False)
    table = time_table(timings)
    assert list(table["section"])[-1] == "total"
    assert table["jobs"].iloc[-1] == 4
    assert table["cpu_s"].iloc[-1] == pytest.approx(sum(t.cpu for t in timings))
    path, idle = idle_estimate(_graph(), timings, 2)
    cpu = {t.key: t.cpu for t in timings}
    assert path == pytest.approx(max(cpu["x"], cpu["y"]) + cpu["z"] + cpu["w"])
    assert idle == pytest.approx(max(path, sum(cpu.values()) / 2))


def _tiny_jobs(store_path) -> list[Job]:
    """A tiny reproduction: cells exact solves at m = 1 (clustered and not), herding pairs on 30 animals."""
    nc = [
        {
            "problem": "cells",
            "instance": instance_id("tiny-nc", m=1, seed=s),
            "kind": "exact-nc",
            "m": 1,
            "seed": s,
            "exact_limit": 30.0,
        }
        for s in range(3)
    ]
    exact = [
        {
            "problem": "cells",
            "instance": instance_id("tiny-exact", m=1),
            "kind": "exact",
            "m": 1,
            "seed": 0,
            "exact_limit": 30.0,
        }
    ]
    herd = [
        {
            "problem": "herding",
            "instance": instance_id("tiny-herd", n=30, seed=s),
            "n": 30,
            "seed": s,
            "t_max": 120.0,
            "gather_only": True,
        }
        for s in range(2)
    ]
    return [
        *row_jobs(cells.reproduce_task, nc + exact, section="cells", cost=cells._task_cost),
        *herding._pair_jobs(herd, "herding"),
    ]


_COMPARED = ["problem", "instance", "method", "seed", "size", "status", "objective", "bound"]


def _rows(path) -> pd.DataFrame:
    with ResultStore(path) as st:
        df = st.frame()
    return df[_COMPARED].sort_values(["problem", "instance", "method"], ignore_index=True)


def test_serial_and_parallel_runs_write_the_same_rows(tmp_path):
    frames = []
    for workers in (1, 2):
        path = tmp_path / f"w{workers}" / "results.sqlite"
        path.parent.mkdir()
        with make_executor(workers) as ex, ResultStore(path) as st:
            run_jobs(_tiny_jobs(path), executor=ex, store=st, progress=False)
        frames.append(_rows(path))
    serial, parallel = frames
    # branch and bound and continuous bound per exact solve; two herders per herd
    assert len(serial) == 3 * 2 + 2 + 2 * 2
    assert (serial["status"] != "error").all()
    pd.testing.assert_frame_equal(serial, parallel)


def test_a_rerun_resumes_from_the_store(tmp_path):
    path = tmp_path / "results.sqlite"
    jobs = _tiny_jobs(path)[:3]  # the non-clustered solves
    with make_executor(1) as ex, ResultStore(path) as st:
        first = run_jobs(jobs, executor=ex, store=st, progress=False)
        again = run_jobs(jobs, executor=ex, store=st, progress=False)
    assert not any(t.skipped for t in first)
    assert all(t.skipped for t in again)
    assert time_table(again)["jobs"].iloc[-1] == 0


def test_a_failing_run_becomes_an_error_row(tmp_path):
    path = tmp_path / "results.sqlite"
    bad = {"problem": "herding", "instance": "bad", "n": -5, "seed": 0, "t_max": 10.0}
    jobs = herding._pair_jobs([bad], "herding")
    with make_executor(1) as ex, ResultStore(path) as st:
        run_jobs(jobs, executor=ex, store=st, progress=False)
        df = st.frame()
    assert list(df["status"]) == ["error"]
    assert "failed" in df["message"].iloc[0]


def test_the_animated_herding_run_is_the_run_of_the_table():
    """Recording frames for the GIF does not change the Fig. 6.7 run whose record the table uses."""
    task = {"problem": "herding", "instance": "t", "n": 20, "seed": 3, "t_max": 200.0, "field": 150.0}
    record, trace = herding._method_run(task, "proposed", frame_every=20.0)
    plain = herding._method_run(task, "proposed")
    assert len(trace.frames) >= 2
    for key in ("gather_time", "total_time", "sim_time", "max_animal_speed"):
        assert record[key] == plain[key]
    assert (record["curve_r"] == plain["curve_r"]).all()
    rows = herding._pair_job(task, (record, trace), plain)
    assert [r["objective"] for r in rows] == [plain["total_time"]] * 2


def _rows_for(task) -> list[dict]:
    from droneplan.studies.store import Outcome, build_rows

    outcome = Outcome("m", "heuristic", "feasible", objective=1.0)
    return build_rows("herding", task["instance"], seed=0, size=1, sense="min", outcomes=[outcome])


def test_a_store_task_runs_as_soon_as_its_inputs_are_in(tmp_path):
    """A long run keeps its finished work: the store task joining two runs starts before the
    other, longer chains, so its rows are on disk while those still run."""
    task = {"problem": "herding", "instance": "t:seed=0"}
    jobs = [
        Job("long1", "s", _add, {"a": 1}, cost=10.0),
        Job("long2", "s", _add, {"a": 2}, cost=10.0),
        Job("r1", "s", _add, {"a": 3}, cost=30.0),
        Job("r2", "s", _add, {"a": 4}, cost=30.0),
        Job("join", "s", _join_rows, {"task": task}, {"a": "r1", "b": "r2"}, cost=0.05, task=task),
    ]
    path = tmp_path / "results.sqlite"
    with make_executor(1) as ex, ResultStore(path) as st:  # serial: the start order is the rule's
        timings = run_jobs(jobs, executor=ex, store=st, progress=False)
        assert list(st.frame()["status"]) == ["feasible"]
    order = [t.key for t in timings]  # serial: in the order they ran
    assert order.index("join") < order.index("long1")
    assert order[:3] in (["r1", "r2", "join"], ["r2", "r1", "join"])


def _join_rows(task, a: int, b: int) -> list[dict]:
    return _rows_for(task)


def _sleep_then(value: int, seconds: float) -> int:
    import time

    time.sleep(seconds)
    return value


def _allocate(megabytes: int) -> int:
    return len(bytearray(megabytes << 20))


def test_a_job_with_a_limit_runs_isolated_and_fails_alone_when_it_overruns(tmp_path):
    import resource
    import time

    from droneplan.studies import jobs as jobs_module

    monkey_grace = jobs_module.ISOLATION_GRACE_S
    jobs_module.ISOLATION_GRACE_S = 0.2
    try:
        vm = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss << 10
        graph = [
            Job("quick", "s", _sleep_then, {"value": 3, "seconds": 0.0}, time_limit=5.0),
            Job("slow", "s", _sleep_then, {"value": 4, "seconds": 30.0}, time_limit=0.5),
            Job("greedy", "s", _allocate, {"megabytes": 4096}, memory_limit=vm + (512 << 20) + (1 << 30)),
            Job("sum", "s", _add, {}, {"a": "quick"}),
            Job("after-slow", "s", _add, {}, {"a": "slow"}),
        ]
        t0 = time.perf_counter()
        with make_executor(1) as ex, pytest.raises(JobsFailed) as failed:
            run_jobs(graph, executor=ex, progress=False)
        assert time.perf_counter() - t0 < 20.0  # the slow job was killed, not waited for
    finally:
        jobs_module.ISOLATION_GRACE_S = monkey_grace
    message = str(failed.value)
    assert "slow: JobLimitExceeded: killed after" in message and "time limit 0.5 s" in message
    assert "greedy: JobLimitExceeded: MemoryError" in message
    ran = {t.key for t in failed.value.timings}
    assert ran == {"quick", "sum"}  # failed jobs have no timing; after-slow did not run
    assert Job("k", "s", _add).isolated is False and Job("k", "s", _add, time_limit=1.0).isolated
    with pytest.raises(ValueError, match="time_limit"):
        Job("k", "s", _add, time_limit=-1.0)
    with pytest.raises(ValueError, match="memory_limit"):
        Job("k", "s", _add, memory_limit=0)


def test_an_isolated_store_task_that_overruns_becomes_an_error_row(tmp_path):
    from droneplan.studies import jobs as jobs_module

    task = {"problem": "herding", "instance": instance_id("iso", seed=0), "seed": 0}
    (job,) = row_jobs(_sleep_task, [task], section="s", cost=1.0)
    job = jobs_module.Job(job.key, job.section, job.fn, job.kwargs, task=job.task, time_limit=0.3)
    with ResultStore(tmp_path / "r.sqlite") as store, make_executor(1) as ex:
        run_jobs([job], executor=ex, store=store, progress=False)
        df = store.frame()
    assert list(df["status"]) == ["error"] and "killed after" in df["message"].iloc[0]


def _sleep_task(task) -> list[dict]:
    import time

    time.sleep(30.0)
    return []


def test_the_runner_names_of_the_previous_release_still_answer():
    from droneplan.studies import runner

    with pytest.warns(DeprecationWarning, match="IsolatedCall"):
        assert runner.Job is runner.IsolatedCall
    with pytest.warns(DeprecationWarning, match="run_calls"):
        assert runner.run_jobs is runner.run_calls
    with pytest.warns(DeprecationWarning, match="CallOutcome"):
        assert runner.JobOutcome is runner.CallOutcome
