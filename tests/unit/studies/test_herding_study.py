"""studies.herding: the allocation gap rows and tables, and one run record."""

import numpy as np
import pandas as pd
import pytest

from droneplan.studies import herding as study
from droneplan.studies.common import make_executor


@pytest.mark.parametrize("n", [2, 5, 7])
def test_gap_row_allocators_agree_with_exact(n):
    for seed in range(3):
        row = study.gap_row({"n": n, "seed": seed})
        assert row["alg3"] == pytest.approx(row["exact"], abs=1e-9)
        assert row["cpsat"] == pytest.approx(row["exact"], abs=1e-9)
        assert row["cpsat_bound"] <= row["cpsat"] + 1e-9
        assert row["blind"] <= row["exact"] + 1e-9  # relaxation


def test_gap_writes_resumable_csv_and_table(tmp_path, capsys):
    with make_executor(1) as ex:
        study.gap(seeds=1, executor=ex, out=tmp_path)
    df = pd.read_csv(tmp_path / "gap_allocation.csv")
    assert sorted(df["n"]) == [2, 4, 6, 7, 8, 16, 64]
    assert np.all(df["blind"] <= df["exact"] + 1e-9)
    assert (tmp_path / "gap_allocation.csv").exists()
    printed = capsys.readouterr().out
    assert "Algorithm 3 = exact" in printed and "100% of 1" in printed
    # resuming does not recompute or duplicate rows
    with make_executor(1) as ex:
        study.gap(seeds=1, executor=ex, out=tmp_path)
    assert len(pd.read_csv(tmp_path / "gap_allocation.csv")) == 7


def test_run_once_record():
    r = study.run_once({"n": 20, "seed": 0, "method": "proposed", "t_max": 400.0, "field": 150.0,
                        "gather_only": True, "snapshots": [0.0, 10.0]})
    assert r["gather_time"] is not None and r["gather_after_hull"] is not None
    assert 0 < r["on_hull_time"] < r["gather_time"]
    assert r["max_animal_speed"] <= 4.0 + 1e-9
    assert r["curve_r"][0] > r["R_c"]  # the herd starts spread out
    assert np.all(np.diff(r["curve_t"]) > 0)
    assert set(r["snapshots"]) == {0.0, 10.0}
    assert r["n_crossing_allocations"] == 0
