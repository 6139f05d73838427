"""Anytime traces: what a method reports is scored like a final plan; gaps, primal integrals and
ECDFs computed from traces agree with hand-worked values."""

from __future__ import annotations

import math
import os

import numpy as np
import pandas as pd
import pytest

from droneplan.formulations.cells import evaluate
from droneplan.studies import wire
from droneplan.studies.instances import family_instances
from droneplan.studies.methods import BUILTIN, Method
from droneplan.studies.reporter import MAX_REPORT_CALLS, Reporter
from droneplan.studies.runner import IsolatedCall, run_isolated, send_report
from droneplan.studies.traces import (
    ecdf,
    primal_integral,
    score_trace,
    takes_report,
    trace_gaps,
)


@pytest.fixture(scope="module")
def cells():
    return family_instances("table4.2", m=2, seeds=[0])[0]


def _decoded(sent: list[bytes]) -> list:
    return [wire.decode(b, max_bytes=1 << 20) for b in sent]


def test_takes_report_needs_a_named_keyword():
    def with_report(problem, *, seed, time_limit, report=None): ...
    def with_kwargs(problem, **kwargs): ...

    assert takes_report(Method("a", with_report))
    assert not takes_report(Method("b", with_kwargs))
    assert not takes_report(Method("c", lambda problem, *, seed, time_limit: None))


def test_reports_are_scored_like_final_plans(cells):
    sent: list[bytes] = []
    report = Reporter(sent.append)
    good = BUILTIN["greedy"].call(cells.data, seed=0, time_limit=None)
    report(good)
    report(good, objective=1e6)  # a lie about a good plan
    report(np.array([[0.0, 0.0]]))  # inside the GBS cell
    report(np.array([[np.nan, 1.0]]))
    report(object())  # not plain data
    points = score_trace(cells, Method("user", lambda *a, **k: None), _decoded(sent))
    assert [p["status"] for p in points] == ["feasible", "feasible", "infeasible", "invalid", "invalid"]
    assert points[0]["objective"] == evaluate(cells.data, good).covered
    assert "claim-mismatch" in points[1]["flag"] and points[1]["claimed_objective"] == 1e6
    assert all(p["bound"] is None for p in points)  # a user method's bound never counts
    assert "plain data" in points[4]["message"]
    times = [p["t"] for p in points]
    assert times == sorted(times) and times[0] >= 0


def test_a_method_reporting_too_often_gets_one_invalid_point():
    sent: list[bytes] = []
    report = Reporter(sent.append)
    report.calls = MAX_REPORT_CALLS  # as if it had reported that often already
    for _ in range(3):
        report(np.zeros((0, 2)))
    assert len(sent) == 1 and "more than" in wire.decode(sent[0], max_bytes=1 << 16)["invalid"]


def test_score_trace_refuses_entries_without_time_or_plan(cells):
    points = score_trace(cells, BUILTIN["greedy"], [{"plan": []}, {"t": -1, "plan": []}, {"t": 1.0}, "x"])
    assert [p["status"] for p in points] == ["invalid"] * 4


@pytest.mark.skipif(not hasattr(os, "fork"), reason="the runner is POSIX-only")
def test_a_reporting_method_in_a_child_keeps_at_most_the_cap_with_first_and_last(cells):
    def job() -> bytes:
        report = Reporter(send_report)
        for i in range(500):
            report(np.array([[2000.0 + i, 0.0]]))
        return b"done"

    outcome = run_isolated(IsolatedCall("r", job, returns="bytes", max_reports=20))
    xs = [r["plan"][0][0] for r in _decoded(list(outcome.reports))]
    assert outcome.n_reports == 500 and len(xs) <= 20 and xs[0] == 2000.0 and xs[-1] == 2499.0


def test_trace_gaps_track_the_best_point_so_far_for_both_senses():
    traces = pd.DataFrame(
        {
            "instance": ["a"] * 4 + ["b"] * 3,
            "method": "m",
            "run": 0,
            "t": [0.5, 1.0, 2.0, 3.0, 0.1, 0.2, 0.3],
            "objective": [None, 8.0, 6.0, 10.0, 30.0, 20.0, 25.0],
            "status": ["invalid", "feasible", "feasible", "feasible", "feasible", "feasible", "feasible"],
        }
    )
    out = trace_gaps(traces, {"a": 10.0, "b": 20.0}, {"a": "max", "b": "min"})
    a, b = out[out["instance"] == "a"]["gap"].tolist(), out[out["instance"] == "b"]["gap"].tolist()
    assert math.isnan(a[0]) and a[1:] == pytest.approx([0.2, 0.2, 0.0])
    assert b == pytest.approx([0.5, 0.0, 0.0])


def test_primal_integral_of_step_functions():
    assert primal_integral([], [], 10.0) == 10.0  # never found a plan
    assert primal_integral([0.0], [0.0], 10.0) == 0.0  # the optimum at once
    # gap 1 (no plan) for 2 s, then 0.5 for 3 s, then 0 for 5 s
    assert primal_integral([2.0, 5.0], [0.5, 0.0], 10.0) == pytest.approx(2.0 + 1.5)
    assert primal_integral([1.0], [7.0], 4.0) == pytest.approx(4.0)  # gaps capped at 1
    assert primal_integral([1.0, 20.0], [0.0, 0.0], 4.0) == pytest.approx(1.0)  # cut at the horizon
    with pytest.raises(ValueError, match="non-decreasing"):
        primal_integral([2.0, 1.0], [0.1, 0.1], 5.0)


def test_ecdf_counts_pairs_reaching_a_target_by_a_time():
    gaps = pd.DataFrame(
        {
            "instance": ["a", "a", "b", "c"],
            "method": "m",
            "run": 0,
            "t": [1.0, 3.0, 2.0, 0.5],
            "gap": [0.5, 0.0, 0.1, np.nan],
        }
    )
    table = ecdf(gaps, targets=[0.0, 0.2], times=[0.9, 2.0, 3.0], pairs=4)
    at = {(r.target, r.t): r.fraction for r in table.itertuples()}
    assert at[(0.0, 0.9)] == 0 and at[(0.0, 3.0)] == 0.25
    assert at[(0.2, 2.0)] == 0.25 and at[(0.2, 3.0)] == 0.5
