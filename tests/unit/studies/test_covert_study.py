"""studies.covert: the gap study writes consistent, resumable rows."""

from __future__ import annotations

import droneplan.studies.covert as sc
from droneplan.studies.common import make_executor
from droneplan.studies.store import load_results


def test_gap_rows_are_consistent_and_resumable(tmp_path, monkeypatch):
    calls = []
    real = sc.gap_task

    def counting(task):
        calls.append(task)
        return real(task)

    monkeypatch.setattr(sc, "gap_task", counting)
    with make_executor(1) as ex:
        sc.gap(seeds=1, executor=ex, out=tmp_path)
        sc.gap(seeds=1, executor=ex, out=tmp_path)  # resumes: nothing recomputed
    assert len(calls) == 1
    df = load_results(tmp_path).set_index("method")
    assert set(df.index) == {"hover", "sliding", "mpc", "mpc-safeguarded", "onsphere-optimum"}
    assert (df["size"] == 2).all()
    # the proven on-sphere optimum is below what the sliding mode recorded on the sphere
    assert df.loc["onsphere-optimum", "bound"] <= df.loc["sliding", "covert_onsphere_max_deg"] + 1e-9
    assert df.loc["sliding", "covert_onsphere_max_deg"] <= df.loc["sliding", "objective"] + 1e-9
    # the safeguarded MPC reaches the sphere by its deadline (predicted sliding arrival + 2 s)
    assert df.loc["mpc-safeguarded", "covert_t_a_s"] <= df.loc["sliding", "covert_t_a_s"] + 2.5
    assert df.loc["sliding", "gap_bound_kind"] == "instantaneous"
    assert (tmp_path / "gap_summary.csv").exists() and (tmp_path / "gap_covert.png").exists()
