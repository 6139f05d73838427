"""studies.herding: the allocation gap rows and tables, and one run record."""

import numpy as np
import pytest

from droneplan.studies import herding as study
from droneplan.studies.common import make_executor
from droneplan.studies.store import load_results


@pytest.mark.parametrize("n", [2, 5, 7])
def test_allocators_agree_with_exact(n, tmp_path):
    import droneplan

    df = droneplan.gap(
        "herding",
        methods=["exact", "alg3", "cp-sat", "collision-blind"],
        n=n,
        seeds=3,
        out=tmp_path,
        workers=2,
    )
    for _, g in df.groupby("instance"):
        rows = g.set_index("method")
        exact = rows.loc["exact", "objective"]
        assert rows.loc["alg3", "objective"] == pytest.approx(exact, abs=1e-9)
        assert rows.loc["cp-sat", "objective"] == pytest.approx(exact, abs=1e-9)
        assert rows.loc["cp-sat", "bound"] <= rows.loc["cp-sat", "objective"] + 1e-9
        assert rows.loc["collision-blind", "claimed_objective"] <= exact + 1e-9  # relaxation
        assert rows.loc["alg3", "gap_to_best"] == pytest.approx(0.0, abs=1e-9)
        assert rows.loc["alg3", "gap_to_bound"] == pytest.approx(0.0, abs=1e-9)
        assert rows.loc["library", "objective"] == pytest.approx(exact, abs=1e-9)  # the certified optimum


def test_gap_writes_resumable_store_and_table(tmp_path, capsys):
    with make_executor(1) as ex:
        study.gap(seeds=1, executor=ex, out=tmp_path)
    df = load_results(tmp_path)
    assert sorted(df["size"].unique()) == [2, 4, 6, 7, 8, 16, 64]
    assert (df["gap_to_bound"].dropna() >= -1e-9).all()
    assert (tmp_path / "gap_herding.png").exists() and (tmp_path / "gap_summary.csv").exists()
    printed = capsys.readouterr().out
    assert "alg3 = exact" in printed and "100% of 1" in printed
    n = len(df)
    with make_executor(1) as ex:  # resuming does not recompute or duplicate rows
        study.gap(seeds=1, executor=ex, out=tmp_path)
    assert len(load_results(tmp_path)) == n


def test_run_once_record():
    r = study.run_once(
        {
            "n": 20,
            "seed": 0,
            "method": "proposed",
            "t_max": 400.0,
            "field": 150.0,
            "gather_only": True,
            "snapshots": [0.0, 10.0],
        }
    )
    assert r["gather_time"] is not None and r["gather_after_hull"] is not None
    assert 0 < r["on_hull_time"] < r["gather_time"]
    assert r["max_animal_speed"] <= 4.0 + 1e-9
    assert r["curve_r"][0] > r["R_c"]  # the herd starts spread out
    assert np.all(np.diff(r["curve_t"]) > 0)
    assert set(r["snapshots"]) == {0.0, 10.0}
    assert r["n_crossing_allocations"] == 0


def test_reproduce_runs_go_through_the_store_and_come_back(tmp_path):
    from droneplan.studies.store import STORE_NAME, ResultStore

    task = {
        "problem": "herding",
        "instance": "fig-test:seed=0",
        "n": 20,
        "seed": 0,
        "t_max": 400.0,
        "field": 150.0,
        "gather_only": True,
        "snapshots": [0.0, 10.0],
    }
    with ResultStore(tmp_path / STORE_NAME) as store, make_executor(1) as ex:
        recs = study._run_all([task], ex, store, "test")
    assert sorted(r["method"] for r in recs) == ["benchmark", "proposed"]
    direct = study.run_once({**task, "method": "proposed"})
    rec = next(r for r in recs if r["method"] == "proposed")
    assert rec["gather_time"] == direct["gather_time"]  # same seed, same run
    np.testing.assert_allclose(rec["curve_r"], direct["curve_r"])
    np.testing.assert_allclose(rec["snapshots"][10.0].animals, direct["snapshots"][10.0].animals)
    assert rec["snapshots"][10.0].phase == direct["snapshots"][10.0].phase
    df = load_results(tmp_path)
    assert set(df["method"]) == {"proposed", "benchmark"} and (df["role"] == "heuristic").all()
    assert df.set_index("method").loc["proposed", "objective"] == direct["gather_time"]


def test_bench_speed_rows_record_cpu_wall_and_load(monkeypatch):
    """The bench's speed rows: sim s per CPU s at three herd sizes and the import time, each with
    its CPU time, wall time and the load average (the herds are shrunk here to keep it quick)."""
    from droneplan.studies.common import ComparisonTable

    real = study.thesis_scenario
    monkeypatch.setattr(study, "thesis_scenario", lambda n, seed=0: real(min(n, 30), seed=seed))
    table = ComparisonTable("speed")
    study._bench_speed(table)
    assert [r["quantity"].split(",")[0] for r in table.rows] == ["simulation"] * 3 + ["import droneplan"]
    for row in table.rows:
        value = float(row["this run"])
        assert np.isfinite(value) and value > 0
        assert "load average" in row["how measured"]
    assert all("CPU-s" in r["how measured"] and "wall" in r["how measured"] for r in table.rows[:3])
    assert [r["thesis"] for r in table.rows] == ["—", "target >= 200", "target >= 50", "target <= 0.5"]
