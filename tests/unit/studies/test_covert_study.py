"""studies.covert: the gap study writes consistent, resumable rows."""

from __future__ import annotations

import pandas as pd
import pytest

import droneplan.studies.covert as sc
from droneplan.studies.common import make_executor


def test_gap_rows_are_consistent_and_resumable(tmp_path, monkeypatch):
    calls = []
    real = sc._gap_task

    def counting(task):
        calls.append(task)
        return real(task)

    monkeypatch.setattr(sc, "_gap_task", counting)
    with make_executor(1) as ex:
        sc.gap(seeds=1, executor=ex, out=tmp_path)
        sc.gap(seeds=1, executor=ex, out=tmp_path)  # resumes: nothing recomputed
    assert len(calls) == 1
    df = pd.read_csv(tmp_path / "gap.csv")
    assert len(df) == 1
    row = df.iloc[0]
    assert row.n_targets == 2
    # the proven on-sphere lower bound is below what the sliding mode recorded on the sphere
    assert row.onsphere_lower_bound_deg <= row.sliding_onsphere_max_deg + 1e-9
    assert row.sliding_onsphere_max_deg <= row.beta_sliding_deg + 1e-9
    # the safeguarded MPC reaches the sphere by its deadline (predicted sliding arrival + 2 s)
    assert row.t_a_mpc_safe_s <= row.t_a_sliding_s + 2.5
    assert row.mpc_safe_vs_sliding_pct == pytest.approx(
        100 * (row.beta_mpc_safe_deg - row.beta_sliding_deg) / row.beta_sliding_deg)
    assert (tmp_path / "gap_summary.csv").exists()
