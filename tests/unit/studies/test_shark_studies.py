import numpy as np
import pytest

from droneplan.studies import shark as study
from droneplan.studies.common import ComparisonTable


def test_fig_5_10_records_the_infeasible_range(tmp_path):
    t = ComparisonTable("x")
    study._fig_5_10(tmp_path, t)
    assert (tmp_path / "fig_5_10.png").exists()
    data = np.loadtxt(tmp_path / "fig_5_10.csv", delimiter=",", skiprows=1)
    zt = data[:, 1]
    assert np.all(data[:, 3] <= 2.0 + 1e-12) and np.any(zt > 2.0)
    assert "(-5.50, -3.50)" in t.rows[0]["this run"]


def test_assignment_gap_rows_are_consistent():
    rows = {
        r["method"]: r
        for r in study.gap_task(dict(problem="shark", instance="gap-assign:seed=1", kind="assign", seed=1))
    }
    assert rows["bottleneck"]["status"] == "optimal"
    assert rows["bottleneck"]["objective"] <= rows["greedy"]["objective"] + 1e-9
    assert rows["greedy"]["gap_to_bound"] >= -1e-9 and rows["greedy"]["gap_bound_kind"] == "proven-global"
    with pytest.raises(ValueError, match="task kind must be 'assign'"):
        study.gap_task(dict(problem="shark", instance="gap-path:seed=3", kind="path", seed=3))
