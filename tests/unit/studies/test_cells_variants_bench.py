"""The variant rows of ``bench cells --variants`` on the smallest sizes."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from droneplan.formulations.cells import CellProblem, evaluate
from droneplan.scenarios import cell_variants
from droneplan.scenarios.cell_variants import VARIANTS, thesis_variant_problem
from droneplan.studies import cells_variants
from droneplan.studies.cells_variants import bench_variants


def test_variant_problems_are_the_thesis_instance_with_one_variant_each():
    fields = {"weighted": "weights", "nofly": "no_fly", "capacity": "capacity", "3d": "altitudes"}
    for name in VARIANTS:
        p = thesis_variant_problem(name, 2, 0)
        assert p.variants == (fields[name],)
        assert evaluate(p, []).value == 0.0 and p.n_cells == 2
    with pytest.raises(ValueError, match="variant"):
        thesis_variant_problem("heavy", 2, 0)


def _small_thesis_problem(m, seed, params=None):
    """A small clustered stand-in for the Table 4.2 instance (radii in units of R_d = 1)."""
    rng = np.random.default_rng(seed)
    users = np.concatenate([rng.normal(c, 0.3, size=(3, 2)) for c in ([2.5, 0.0], [-2.5, 1.0], [0.0, 4.0])])
    return CellProblem(users, [[0.0, 0.0]], m, 1.0, 1.0, 3.0, 2.5)


def test_bench_variants_writes_a_row_per_variant_seed(tmp_path, monkeypatch):
    """The rows and their file, on a small stand-in instance (the bench itself runs Table 4.2)."""
    monkeypatch.setattr(cells_variants, "thesis_problem", _small_thesis_problem)
    monkeypatch.setattr(cell_variants, "thesis_problem", _small_thesis_problem)
    rows = bench_variants(seeds=[0], m=2, time_limit=60.0, out=tmp_path, epochs=2)
    df = pd.read_csv(tmp_path / "bench_variants.csv")
    assert len(df) == len(rows) == len(VARIANTS) + 3 + 3
    proven = df[df["variant"].isin(VARIANTS)]
    assert (proven["status"] == "optimal").all()
    assert (proven["objective"] <= proven["bound"] + 1e-6).all()
    joint, greedy = (
        df.loc[df["variant"] == name, "objective"].item() for name in ("mobile joint", "mobile myopic")
    )
    assert greedy <= joint + 1e-9
    warm = df.loc[df["variant"] == "mobile joint warm", "objective"].item()
    assert greedy <= warm + 1e-9 and warm == pytest.approx(joint)  # both proven on this small world


def test_bench_variants_resumes_an_interrupted_grid(tmp_path, monkeypatch):
    """A row already in the file is kept and not run again; a missing one is run."""
    monkeypatch.setattr(cells_variants, "thesis_problem", _small_thesis_problem)
    monkeypatch.setattr(cell_variants, "thesis_problem", _small_thesis_problem)
    first = bench_variants(seeds=[0], m=2, time_limit=60.0, out=tmp_path, epochs=2)
    path = tmp_path / "bench_variants.csv"
    frame = pd.read_csv(path)
    frame.iloc[:-3].to_csv(path, index=False)  # as if stopped before the moving-users rows
    calls = []
    original = cells_variants.solve_exact
    monkeypatch.setattr(cells_variants, "solve_exact", lambda *a, **k: calls.append(1) or original(*a, **k))
    again = bench_variants(seeds=[0], m=2, time_limit=60.0, out=tmp_path, epochs=2)
    assert not calls
    assert len(again) == len(first)
    assert [row["variant"] for row in again] == [row["variant"] for row in first]
    assert len(pd.read_csv(path)) == len(first)


def test_the_summary_counts_settled_rows_and_lists_the_open_ones():
    from droneplan.studies.cells_variants import variants_summary

    def row(variant, seed, status, obj, bound, cpu):
        return {
            "variant": variant,
            "seed": seed,
            "status": status,
            "objective": obj,
            "bound": bound,
            "cpu_s": cpu,
            "load_1min": 1.5,
        }

    text = variants_summary(
        [
            row("capacity", 0, "feasible", 56.0, 80.0, 600.0),
            row("capacity", 1, "optimal", 50.0, 50.0, 30.0),
            row("min-fleet 20%", 0, "infeasible", None, None, 10.0),
            row("min-fleet 20%", 1, "infeasible", float("nan"), float("nan"), 20.0),
        ]
    )
    lines = text.splitlines()
    assert lines[2] == "| capacity | 2 | 1 | 30 | 0: 56 / 80 | 1.5 |"
    assert lines[3] == "| min-fleet 20% | 2 | 2 | 15 | - | 1.5 |"
