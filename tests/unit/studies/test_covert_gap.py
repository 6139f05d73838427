"""studies.covert_gap: the covert gap study writes consistent, resumable rows."""

from __future__ import annotations

import pytest

import droneplan.studies.covert as covert
import droneplan.studies.covert_gap as sc
from droneplan.studies.common import make_executor
from droneplan.studies.store import load_results


def test_gap_names_are_reachable_from_the_covert_study_module():
    assert covert.gap is sc.gap and covert.GAP_THESIS is sc.GAP_THESIS
    with pytest.raises(AttributeError, match="no_such_name"):
        _ = covert.no_such_name


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
