import numpy as np

from droneplan.studies.common import ComparisonTable
from droneplan.studies.thesis import shark as study


def test_fig_5_10_records_the_infeasible_range(tmp_path):
    t = ComparisonTable("x")
    study._fig_5_10(tmp_path, t)
    assert (tmp_path / "fig_5_10.png").exists()
    data = np.loadtxt(tmp_path / "fig_5_10.csv", delimiter=",", skiprows=1)
    zt = data[:, 1]
    assert np.all(data[:, 3] <= 2.0 + 1e-12) and np.any(zt > 2.0)
    assert "(-5.50, -3.50)" in t.rows[0]["this run"]
