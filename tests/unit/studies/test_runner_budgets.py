"""The job runner's CPU-time limit and the reports a job sends while it runs."""

from __future__ import annotations

import itertools
import os
import time

import pytest

from droneplan.studies.runner import IsolatedCall, run_isolated, send_report

pytestmark = pytest.mark.skipif(not hasattr(os, "fork"), reason="the runner is POSIX-only")


def _spin(seconds: float) -> str:
    """Burn CPU for ``seconds`` of process CPU time."""
    start, spins = time.process_time(), 0
    while time.process_time() - start < seconds:
        spins += 1
    return "done" if spins else "never ran"


def test_a_job_within_its_cpu_limit_finishes():
    outcome = run_isolated(IsolatedCall("ok", _spin, (0.2,), cpu_limit=5.0), grace=0.5)
    assert outcome.status == "ok" and outcome.value == "done"
    assert 0.2 <= outcome.cpu_s < 5.0


def test_a_job_over_its_cpu_limit_is_stopped_by_the_kernel_as_a_timeout():
    """RLIMIT_CPU sends SIGXCPU at limit + grace (rounded up to whole seconds): a timeout that says
    so, after at least the limit and well before the job's own 30 s."""
    outcome = run_isolated(IsolatedCall("spin", _spin, (30.0,), cpu_limit=1.0), grace=0.5)
    assert outcome.status == "timeout"
    assert "CPU limit 1.0 s" in outcome.error
    assert 1.0 <= outcome.cpu_s < 5.0


def test_a_sleeping_job_is_not_stopped_by_its_cpu_limit():
    """CPU time, not wall time: a job that waits uses no CPU."""
    outcome = run_isolated(IsolatedCall("nap", time.sleep, (1.5,), cpu_limit=1.0), grace=0.0)
    assert outcome.status == "ok" and outcome.wall_s >= 1.5


@pytest.mark.parametrize("bad", [0, -1.0, float("nan"), float("inf")])
def test_a_cpu_limit_must_be_positive_and_finite(bad):
    with pytest.raises(ValueError, match="cpu_limit"):
        IsolatedCall("bad", _spin, (0.1,), cpu_limit=bad)


def _reporter(count: int) -> int:
    for i in range(count):
        send_report({"i": i})
    return count


def test_every_report_of_a_short_job_is_kept_in_order():
    outcome = run_isolated(IsolatedCall("few", _reporter, (5,), max_reports=10))
    assert outcome.status == "ok" and outcome.value == 5
    assert [r["i"] for r in outcome.reports] == [0, 1, 2, 3, 4] and outcome.n_reports == 5


@pytest.mark.parametrize("count", [11, 200, 5000])
def test_many_reports_are_thinned_to_the_cap_keeping_the_first_and_the_last(count):
    outcome = run_isolated(IsolatedCall("many", _reporter, (count,), max_reports=10))
    kept = [r["i"] for r in outcome.reports]
    assert outcome.n_reports == count
    assert len(kept) <= 10 and kept[0] == 0 and kept[-1] == count - 1
    assert kept == sorted(set(kept))
    strides = {b - a for a, b in itertools.pairwise(kept[:-1])}
    assert len(strides) == 1  # evenly spaced but for the last one


def test_reports_of_a_bytes_job_stay_bytes_and_must_be_bytes():
    def job() -> bytes:
        send_report(b"first")
        try:
            send_report("not bytes")
        except TypeError:
            send_report(b"refused a str")
        return b"result"

    outcome = run_isolated(IsolatedCall("bytes", job, returns="bytes", max_reports=5))
    assert outcome.value == b"result" and outcome.reports == (b"first", b"refused a str")


def test_a_report_to_a_job_that_takes_none_is_an_error_outcome():
    outcome = run_isolated(IsolatedCall("unwanted", _reporter, (1,)))
    assert outcome.status == "error" and "max_reports" in outcome.error


def test_reports_survive_a_timeout():
    def slow() -> None:
        send_report("started")
        time.sleep(30)

    outcome = run_isolated(IsolatedCall("slow", slow, time_limit=0.5, max_reports=4), grace=0.2)
    assert outcome.status == "timeout" and outcome.reports == ("started",)


def test_send_report_outside_a_job_raises():
    with pytest.raises(RuntimeError, match="job runner"):
        send_report("nobody listens")


def test_max_reports_of_one_is_refused():
    with pytest.raises(ValueError, match="max_reports"):
        IsolatedCall("one", _reporter, (1,), max_reports=1)
