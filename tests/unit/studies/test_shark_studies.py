import math

import numpy as np

from droneplan.studies import shark as study
from droneplan.studies.common import ComparisonTable


def test_fig_5_10_records_the_infeasible_range(tmp_path):
    t = ComparisonTable("x")
    study._fig_5_10(tmp_path, t)
    assert (tmp_path / "fig_5_10.png").exists()
    data = np.loadtxt(tmp_path / "fig_5_10.csv", delimiter=",", skiprows=1)
    z, zt = data[:, 0], data[:, 1]
    assert np.all(data[:, 3] <= 2.0 + 1e-12) and np.any(zt > 2.0)
    assert "(-5.50, -3.50)" in t.rows[0]["this run"]


def test_gap_rows_are_consistent():
    row = study._gap_task(dict(kind="path", seed=3))
    assert row["ocp_status"] == "OPTIMAL" and row["ocp_T"] <= row["vs_T"] + 1e-6
    assert math.isclose(row["ratio"], row["ocp_T"] / row["vs_T"])
    row = study._gap_task(dict(kind="assign", seed=1))
    assert row["opt_status"] == "OPTIMAL" and row["opt_latest"] <= row["greedy_latest"] + 1e-9
