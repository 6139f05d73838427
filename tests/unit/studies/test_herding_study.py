"""studies.thesis.herding: the allocation gap rows and tables, and one run record."""

import numpy as np
import pytest

from droneplan.studies.common import make_executor
from droneplan.studies.store import load_results
from droneplan.studies.thesis import herding as study


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


def test_bench_whole_run_rows_record_cpu_wall_and_load(monkeypatch):
    """The bench's whole-run rows (1000 and 10^5 animals): sim s per CPU s with the CPU time, the
    wall time and the load average; a small herd in a small field stands in for both here."""
    from droneplan.studies.common import ComparisonTable

    real = study.thesis_scenario
    monkeypatch.setattr(
        study, "thesis_scenario", lambda n, seed=0: real(min(n, 40), seed=seed, field_size=(200.0, 100.0))
    )
    monkeypatch.setattr(study, "WHOLE_RUN_HORIZONS", {1000: (30.0, 30.0), 100_000: (2.0, 2.0)})
    table = ComparisonTable("speed")
    study._bench_whole_runs(table, quick=True)
    assert [r["quantity"] for r in table.rows] == [
        "simulation, 1000 animals + 4 drones, whole run (sim s / CPU s)",
        "simulation, 100000 animals + 4 drones, whole run (sim s / CPU s)",
    ]
    for row in table.rows:
        assert np.isfinite(float(row["this run"])) and float(row["this run"]) > 0
        note = row["how measured"]
        assert "CPU-s" in note and "wall" in note and "load average" in note
    r = study.whole_run_rate(40, 2.0)
    assert r["sim_s"] == 2.0 and r["cpu_s"] > 0 and r["rate"] == r["sim_s"] / r["cpu_s"]


def _scenario_of(task):
    """The scenario a sweep task's run simulates (as studies.thesis.herding._run_traced builds it)."""
    from droneplan.scenarios.herding import thesis_scenario

    field = task.get("field")
    size = (float(field), float(field)) if field else (1200.0, 600.0)
    return thesis_scenario(
        int(task["n"]),
        seed=int(task["seed"]),
        field_size=size,
        n_drones=int(task.get("n_drones", 4)),
        **task.get("params", {}),
    )


def test_sweep_points_on_the_default_scenario_share_one_run():
    """n_d = 4, V_max = 25, V_animal = 4, R_b = 100 and d_s = 30 are the §6.5 set-up: one task per
    seed and size, whose scenario is the default one; every other point keeps its own task and
    simulates the value it names."""
    tasks = study._sweep_tasks(False)
    ids = [t["instance"] for t in tasks]
    assert len(ids) == len(set(ids))
    n_points = sum(len(full) for (_, full, _, _, _) in study.SWEEPS.values())
    defaults_per_run = 5  # one value of each of five sweeps is the set-up's own
    assert len(tasks) == (n_points - defaults_per_run + 1) * study.SWEEP_SEEDS * 2
    default = {
        name: study._sweep_task(name, key, value, 200, 3)["instance"]
        for name, (_, _, _, _, key), value in [
            (nm, study.SWEEPS[nm], v)
            for nm, v in [("n_drones", 4), ("V_max", 25), ("V_animal", 4), ("R_b", 100), ("d_s", 30)]
        ]
    }
    assert len(set(default.values())) == 1
    shared = next(t for t in tasks if t["instance"] == next(iter(default.values())))
    base = _scenario_of({"n": 200, "seed": 3})
    assert _scenario_of(shared).params == base.params
    for name, (_, full, _, _, key) in study.SWEEPS.items():
        for value in full:
            sc = _scenario_of(study._sweep_task(name, key, value, 1000, 1))
            if key == "field":
                assert np.ptp(sc.animals, axis=0) == pytest.approx([value, value], rel=0.05)
            elif key == "n_drones":
                assert sc.params.n_drones == value
            else:
                assert getattr(sc.params, key) == value
