"""studies.covert: the gap study writes consistent, resumable rows."""

from __future__ import annotations

import pytest

import droneplan.studies.covert as sc
from droneplan.studies.common import make_executor
from droneplan.studies.store import load_results


def _must_not_run(task):
    raise AssertionError(f"resume recomputed {task['instance']}")


def test_gap_rows_are_consistent_and_resumable(tmp_path, monkeypatch):
    # the covert gap is the heaviest task: it also exercises the Dask path (threads in this process)
    distributed = pytest.importorskip("distributed")
    with (
        distributed.LocalCluster(
            n_workers=1, threads_per_worker=1, processes=False, dashboard_address=None
        ) as c,
        make_executor(dask_address=c.scheduler_address) as ex,
    ):
        sc.gap(seeds=1, executor=ex, out=tmp_path)
        monkeypatch.setattr(sc, "gap_task", _must_not_run)
        sc.gap(seeds=1, executor=ex, out=tmp_path)  # resumes: nothing recomputed (else an error row)
    df = load_results(tmp_path)
    assert (df["status"] != "error").all(), df["message"].tolist()
    df = df.set_index("method")
    assert set(df.index) == {"hover", "sliding", "mpc", "mpc-safeguarded", "onsphere-optimum"}
    assert (df["size"] == 2).all()
    # the proven on-sphere optimum is below what the sliding mode recorded on the sphere
    assert df.loc["onsphere-optimum", "bound"] <= df.loc["sliding", "covert_onsphere_max_deg"] + 1e-9
    assert df.loc["sliding", "covert_onsphere_max_deg"] <= df.loc["sliding", "objective"] + 1e-9
    # the safeguarded MPC reaches the sphere by its deadline (predicted sliding arrival + 2 s)
    assert df.loc["mpc-safeguarded", "covert_t_a_s"] <= df.loc["sliding", "covert_t_a_s"] + 2.5
    assert df.loc["sliding", "gap_bound_kind"] == "instantaneous"
    assert (tmp_path / "gap_summary.csv").exists() and (tmp_path / "gap_covert.png").exists()


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
