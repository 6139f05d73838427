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


def _mobile(max_move=1.5):
    rng = np.random.default_rng(3)
    users = rng.uniform(-4.0, 4.0, size=(10, 2))
    drift = rng.normal(0.0, 0.4, size=users.shape)
    snapshots = np.stack([users + t * drift for t in range(3)])
    return dp.cells.MobileProblem(_variant().with_cells(2), snapshots, max_move)


def stay_at_the_first_greedy_placement(mp, *, seed, time_limit):
    """A user method of the moving-users contract: epoch 0's greedy placement, never moved."""
    first = dp.cells.greedy_placement(mp.epochs[0])
    return np.stack([first] * mp.n_epochs)


def one_cell_at_each_epochs_best_site(mp, *, seed, time_limit):
    """A user method that moves too far: each epoch's own best single site."""
    return np.stack([dp.cells.solve_exact(e.with_cells(1)).x for e in mp.epochs])


def test_a_moving_users_study_scores_the_summed_weight_and_the_moves(tmp_path):
    from droneplan.studies.instances import load_instance, save_instance

    mp = _mobile(max_move=0.05)
    inst = as_instance(mp)
    assert inst.kind == "cells-mobile"
    back = load_instance(save_instance(inst, tmp_path / "mobile.json"))
    assert back.id == inst.id and np.array_equal(back.data.snapshots, mp.snapshots)
    methods = ["joint", "myopic", stay_at_the_first_greedy_placement, one_cell_at_each_epochs_best_site]
    dp.gap("cells", methods=methods, instances=[mp], out=tmp_path / "s", progress=False)
    rows = dp.load_results(tmp_path / "s").set_index("method")
    assert rows.loc["joint", "status"] == "optimal"
    stay = stay_at_the_first_greedy_placement(mp, seed=0, time_limit=None)
    assert rows.loc["stay_at_the_first_greedy_placement", "objective"] == pytest.approx(
        dp.cells.evaluate_mobile(mp, stay).value
    )
    for name in ("myopic", "stay_at_the_first_greedy_placement"):
        assert rows.loc[name, "objective"] <= rows.loc["joint", "objective"] + 1e-9
    jumpy = one_cell_at_each_epochs_best_site(mp, seed=0, time_limit=None)
    assert not dp.cells.evaluate_mobile(mp, jumpy).feasible  # the best sites lie apart
    assert rows.loc["one_cell_at_each_epochs_best_site", "status"] == "infeasible"
    assert "max_move" in rows.loc["one_cell_at_each_epochs_best_site", "message"]


def greedy_but_one_short(problem, coverage, *, seed, time_limit):
    """A user method of the fleet-size contract that always places one drone-cell."""
    return dp.cells.greedy_placement(problem.with_cells(1))


def test_a_fleet_size_study_counts_drone_cells_and_refuses_a_short_share(tmp_path):
    from droneplan.studies.instances import FleetSizeInstance

    problem = _variant().with_cells(3)
    total = len(problem.targets)
    one = evaluate(problem, dp.cells.greedy_placement(problem.with_cells(1))).value
    share = min(1.0, (one + 1) / total)  # one drone-cell falls short by construction
    inst = FleetSizeInstance(problem, share)
    methods = ["min-fleet", "greedy-fleet", greedy_but_one_short]
    dp.gap("cells", methods=methods, instances=[inst], out=tmp_path, progress=False)
    rows = dp.load_results(tmp_path).set_index("method")
    exact = dp.cells.min_fleet(problem, coverage=share, time_limit=60)
    assert exact.status is dp.Status.OPTIMAL
    assert rows.loc["min-fleet", "status"] == "optimal"
    assert rows.loc["min-fleet", "objective"] == exact.objective >= 2
    assert rows.loc["greedy-fleet", "objective"] >= exact.objective
    assert rows.loc["greedy_but_one_short", "status"] == "infeasible"
    assert "short of" in rows.loc["greedy_but_one_short", "message"]


def test_a_fleet_size_instance_refuses_a_share_outside_0_1():
    from droneplan.studies.instances import FleetSizeInstance

    for bad in (0.0, -0.5, 1.5, float("nan")):
        with pytest.raises(ValueError, match="coverage"):
            FleetSizeInstance(_variant(), bad)


def test_cross_certification_refuses_a_variant_family_naming_the_one_engine():
    from droneplan.studies.library.cross import cross_certify

    with pytest.raises(ValueError, match="only the MILP"):
        cross_certify("table4.2-nofly", m=1, seeds=1, progress=None)
