"""studies.covert: the stealth front refuses budgets it cannot meet."""

from __future__ import annotations

import pytest

import droneplan.studies.covert as sc


def test_stealth_front_budget_names_the_parameter_that_made_it_large():
    import droneplan as dp

    case = dp.covert.thesis_case(1)
    trace = dp.covert.simulate(case, dp.covert.HoverBenchmark(), max_time=1.0)
    # many arrival times on few instants: the arrival count is to blame
    with pytest.raises(ValueError, match=r"^n_arrivals asks for \d+ solver calls, more than the limit"):
        sc.stealth_front(case, {"hover": trace}, n_arrivals=10**6, step=0.5)
    # few arrival times on a fine grid of instants: the step is to blame
    with pytest.raises(ValueError, match=r"^step asks for \d+ solver calls, more than the limit"):
        sc.stealth_front(case, {"hover": trace}, n_arrivals=2, step=1e-6)


def test_quick_case_2_runs_the_thesis_comparison_and_the_mpc_only(tmp_path):
    """Quick: the MPC variants run on case 1 only, and case 2's table needs no run it lacks;
    the full reproduction runs every controller on both cases."""
    by_key = {j.key: j for j in sc.reproduce_jobs(quick=True, out=tmp_path)}
    runs = {k.split("/")[-1] for k in by_key if k.startswith("covert/base/case2/") and k.count("/") == 3}
    assert {"hover", "sliding", "mpc"} <= runs
    assert not runs & {"mpc-osqp", "mpc-slow", "mpc-safe"}
    table = by_key["covert/base/case2/table"]
    assert set(table.needs.values()) <= set(by_key)
    case1 = {k.split("/")[-1] for k in by_key if k.startswith("covert/base/case1/")}
    assert {"mpc-osqp", "mpc-slow", "mpc-safe"} <= case1
    full = {j.key for j in sc.reproduce_jobs(quick=False, out=tmp_path)}
    assert {f"covert/base/case2/{name}" for name in sc.RUN_COST} <= full
