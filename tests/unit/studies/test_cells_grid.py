"""The ``bench cells`` scale grid: its density scaling, its rows and one row run in a fresh
process (on a tiny setting; no timing is asserted)."""

import json
import math

import pandas as pd
import pytest

from droneplan.formulations.cells import ENGINES, solve_exact
from droneplan.scenarios.cells import THESIS_TABLE_4_2, expected_user_count, thesis_problem
from droneplan.studies.thesis.cells import (
    GRID_DENSITIES,
    GRID_MS,
    GRID_QUICK_TIME_LIMIT,
    GRID_TIME_LIMIT,
    bench_grid_row,
    bench_grid_specs,
    density_params,
    grid_main,
    grid_text,
)


def test_density_params_scale_both_intensities_and_the_expected_users():
    p = density_params(4)
    assert p.lambda_c == pytest.approx(4 * THESIS_TABLE_4_2.lambda_c)
    assert p.lambda_nc == pytest.approx(4 * THESIS_TABLE_4_2.lambda_nc)
    assert (p.R_d, p.r1, p.r2, p.n_clusters) == (
        THESIS_TABLE_4_2.R_d,
        THESIS_TABLE_4_2.r1,
        THESIS_TABLE_4_2.r2,
        THESIS_TABLE_4_2.n_clusters,
    )
    assert expected_user_count(p) == pytest.approx(4 * expected_user_count(THESIS_TABLE_4_2))
    with pytest.raises(ValueError, match="factor"):
        density_params(0)


def test_grid_specs_cover_every_m_density_engine_once():
    full = bench_grid_specs(quick=False)
    keys = {(r["m"], r["density"], r["engine"]) for r in full}
    assert len(full) == len(keys) == len(GRID_MS) * len(GRID_DENSITIES) * len(ENGINES)
    assert {r["time_limit"] for r in full} == {GRID_TIME_LIMIT}
    quick = bench_grid_specs(quick=True)
    assert 0 < len(quick) < len(full)
    assert {r["time_limit"] for r in quick} == {GRID_QUICK_TIME_LIMIT}
    assert {r["time_limit"] for r in bench_grid_specs(quick=True, time_limit=7)} == {7.0}


@pytest.mark.parametrize(
    ("kw", "name"),
    [
        ({"time_limit": -1}, "time_limit"),
        ({"ms": [0]}, "ms"),
        ({"densities": [-2]}, "densities"),
        ({"engines": ["simplex"]}, "engines"),
        ({"seed": -1}, "seed"),
        ({"workers": 0}, "workers"),
    ],
)
def test_grid_specs_name_the_bad_parameter(kw, name):
    with pytest.raises(ValueError, match=name):
        bench_grid_specs(quick=True, **kw)


def test_grid_row_runs_in_a_fresh_process_and_both_engines_agree():
    specs = bench_grid_specs(quick=True, ms=[2], densities=[0.05], time_limit=60, seed=3)
    rows = [bench_grid_row(s) for s in specs]
    assert [r["engine"] for r in rows] == list(ENGINES)
    # the same instance solved here, in this process, is the oracle of the rows' values
    ref = solve_exact(thesis_problem(2, 3, params=density_params(0.05)), engine="bnb")
    for r in rows:
        assert r["status"] == "OPTIMAL"
        assert r["objective"] == r["bound"] == ref.objective
        assert r["users"] == len(thesis_problem(2, 3, params=density_params(0.05)).targets)
        assert r["time_to_proof_s"] == r["wall_s"] > 0
        assert r["cpu_s"] > 0
        assert r["peak_rss_mib"] >= r["base_rss_mib"] > 0
        assert math.isfinite(r["load_1min"])
        assert grid_text(r).startswith(f"OPTIMAL {ref.objective:g}/{ref.objective:g} proven in")


def test_a_failing_grid_row_is_recorded_not_raised():
    # a density whose user count the scenario refuses up front: the child process fails
    spec = bench_grid_specs(quick=True, ms=[2], densities=[1e12], engines=["bnb"], time_limit=5)[0]
    row = bench_grid_row(spec)
    assert row["status"] == "ERROR" and "ValueError" in row["error"]
    assert row["time_to_proof_s"] is None
    assert grid_text(row).startswith("ERROR (ValueError")


def test_grid_main_runs_the_chosen_subset_and_writes_its_rows(tmp_path):
    args = ["--ms", "2", "3", "--densities", "0.3", "--engines", "bnb", "--seed", "3", "--time-limit", "60"]
    assert grid_main([*args, "--out", str(tmp_path)]) == 0
    df = pd.read_csv(tmp_path / "bench_cells_grid.csv")
    assert list(zip(df["m"], df["density"], df["engine"], strict=True)) == [
        (2, 0.3, "bnb"),
        (3, 0.3, "bnb"),
    ]
    assert set(df["seed"]) == {3} and set(df["time_limit"]) == {60.0}
    for m, obj, stats in zip(df["m"], df["objective"], df["model_stats"], strict=True):
        ref = solve_exact(thesis_problem(int(m), 3, params=density_params(0.3)), engine="bnb", workers=1)
        assert obj == ref.objective
        # the engine's counters travel with the row (both instances need a search)
        row_stats, ref_stats = json.loads(stats), ref.info["model_stats"]
        assert row_stats["nodes"] == ref_stats["nodes"] > 0
        assert row_stats["candidates"] == ref_stats["candidates"]


@pytest.mark.parametrize(
    "args",
    [["--engines", "simplex"], ["--ms", "two"], ["--ms", "2"]],  # the last one lacks --out
)
def test_grid_main_refuses_bad_arguments(args):
    with pytest.raises(SystemExit) as e:
        grid_main(args)
    assert e.value.code == 2


def test_a_refused_grid_row_is_measured(monkeypatch):
    """An engine's refusal (a model over the machine's cap, here a cap of 1,000 terms) is a row
    with status REFUSED, the message and the seconds and memory the refusal took."""
    from droneplan.formulations.cells import _milp
    from droneplan.studies.thesis.cells import _grid_solve

    monkeypatch.setattr(_milp, "model_term_cap", lambda: 1000)
    monkeypatch.setattr(_milp, "LP_FIXING_MAX_TERMS", 100)
    spec = bench_grid_specs(quick=True, ms=[4], densities=[1.0], engines=["milp"], time_limit=120)[0]
    row = {**spec, **_grid_solve(spec), "load_1min": 0.5}
    assert row["status"] == "REFUSED" and "more than 1,000 terms" in row["error"]
    assert row["wall_s"] > 0 and row["cpu_s"] > 0 and row["peak_rss_mib"] >= row["base_rss_mib"] > 0
    assert grid_text(row).startswith("REFUSED after ") and "more than 1,000 terms" in grid_text(row)
