"""Cells variant instances in gap studies: their fields travel with the instance (file, id) and
the scorer recomputes the variant's objective."""

from __future__ import annotations

import numpy as np
import pytest
from shapely.geometry import Polygon

import droneplan as dp
from droneplan.formulations.cells import evaluate
from droneplan.studies.instances import as_instance

RADII = {"R_d": 1.0, "R_g": 1.0, "r1": 3.0, "r2": 2.5}


def _variant(**extra):
    rng = np.random.default_rng(0)
    users = rng.uniform(-4.0, 4.0, size=(12, 2))
    return dp.cells.CellProblem(users, [[0.0, 0.0]], 2, **RADII, **extra)


def test_variant_fields_survive_a_file_and_change_the_id(tmp_path):
    zone = Polygon([(0, 0), (3, 0), (3, 3), (0, 3)], [[(1, 1), (2, 1), (2, 2), (1, 1)]])
    p = _variant(weights=np.linspace(0.0, 3.0, 12), no_fly=[zone], capacity=2)
    back = dp.load_instance(dp.save_instance(p, tmp_path / "v.json")).data
    assert back.variants == ("weights", "no_fly", "capacity")
    assert np.array_equal(back.weights, p.weights) and back.no_fly[0].equals(zone) and back.capacity == 2
    plain, weighted = (as_instance(q).id for q in (_variant(), p))
    assert plain != weighted


def test_a_variant_study_scores_the_weight_and_names_the_engine_that_can(tmp_path):
    p = _variant(weights=np.arange(12.0), capacity=2)
    dp.gap("cells", methods=["greedy", "milp", "bnb"], instances=[p], out=tmp_path, progress=False)
    rows = dp.load_results(tmp_path).set_index("method")
    assert rows.loc["milp", "status"] == "optimal"
    best = dp.cells.solve_exact(p, time_limit=60).objective
    assert rows.loc["milp", "objective"] == pytest.approx(best)
    greedy = dp.cells.greedy_placement(p)
    assert rows.loc["greedy", "objective"] == pytest.approx(evaluate(p, greedy).value)
    assert rows.loc["greedy", "objective"] <= best + 1e-6
    assert rows.loc["bnb", "status"] == "error" and "engine='milp'" in rows.loc["bnb", "message"]


def test_altitude_levels_travel_with_the_instance_and_plans_are_scored_in_3d(tmp_path):
    users = np.random.default_rng(1).uniform(-1500.0, 1500.0, size=(10, 2))
    p = dp.cells.CellProblem(
        users,
        [[0.0, 0.0]],
        2,
        300.0,
        300.0,
        1500.0,
        1400.0,
        altitudes=[100.0, 300.0],
        channel=dp.cells.AirToGround(),
    )
    back = dp.load_instance(dp.save_instance(p, tmp_path / "levels.json")).data
    assert back.altitudes == p.altitudes and back.channel == p.channel
    dp.gap("cells", methods=["greedy", "milp"], instances=[p], out=tmp_path / "study", progress=False)
    rows = dp.load_results(tmp_path / "study").set_index("method")
    assert rows.loc["milp", "status"] == "optimal"
    assert rows.loc["greedy", "objective"] == pytest.approx(evaluate(p, dp.cells.greedy_placement(p)).value)
    assert rows.loc["greedy", "objective"] <= rows.loc["milp", "objective"]
