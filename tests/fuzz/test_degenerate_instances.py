"""Degenerate but valid instances give a result, not an exception or
a stall (each call below is bounded by a time limit or a short horizon)."""

from __future__ import annotations

import numpy as np
import pytest

import droneplan as dp


def _problem(users, n_cells=2):
    return dp.cells.CellProblem(
        users, [[0.0, 0.0]], n_cells, 500.0, 1000.0, 3500.0, 3000.0, bounds=(-3000.0, 3000.0, -3000.0, 3000.0)
    )


@pytest.mark.parametrize(
    ("users", "expected"),
    [
        (np.full((12, 2), [1800.0, 0.0]), 12),  # all users at one point
        (np.full((5, 2), [300.0, 0.0]), 0),  # zero coverable users: all already served by the GBS
        (np.zeros((0, 2)), 0),  # no users at all
    ],
)
def test_cells_degenerate_users(users, expected):
    problem = _problem(users)
    milp = dp.cells.solve_milp(problem, time_limit=20)
    assert milp.status is dp.Status.OPTIMAL and milp.objective == expected
    assert milp.bound is not None and milp.objective <= milp.bound
    ex = dp.cells.exhaustive(problem, time_limit=20)
    assert ex.objective == expected
    ga = dp.cells.genetic(problem, pop_size=6, iter_max=3, restarts=2, seed=0)
    assert 0 <= ga.objective <= milp.bound


def test_cells_one_drone_cell():
    problem = _problem([[1700.0, 0.0], [1750.0, 40.0], [-1800.0, 0.0]], n_cells=1)
    milp = dp.cells.solve_milp(problem, time_limit=20)
    assert milp.status is dp.Status.OPTIMAL and milp.objective == 2


def test_herding_more_drones_than_steering_points():
    """A herd at one point has 4 steering points (the square around it); 6 drones share them."""
    res = dp.herding.solve_allocation([1.0, 3.0, 5.0, 7.0, 9.0, 11.0], [0.5, 4.0], 12.0)
    assert res.status is dp.Status.OPTIMAL
    assert dp.herding.check_allocation(
        [1.0, 3.0, 5.0, 7.0, 9.0, 11.0], [0.5, 4.0], 12.0, res.x
    ) == pytest.approx(res.objective)


def test_shark_path_that_turns_back():
    """A shark that swims right then turns back: the simulators and the OCP give a result."""
    path = dp.shark.make_trajectory(lambda t: np.where(t < 4.0, 0.0, np.pi), 5.0, -3.0, duration=12.0)
    for controller in (dp.shark.ClassicalPursuit(), dp.shark.VirtualSharkInterceptor()):
        trace = dp.shark.simulate(path, controller)
        assert np.all(np.isfinite(trace.operator))
    res = dp.shark.solve_interception(path, dp.shark.operator_start(path), N=15, time_limit=20)
    assert isinstance(res.status, dp.Status)
    assert res.objective is None or np.isfinite(res.objective)


def test_covert_targets_that_stop():
    """Targets whose paths end before the mission (targets_stop=True) stand still; the run finishes."""
    params = dp.covert.THESIS_TABLE_3_2
    paths = (
        dp.covert.TargetPath([[120.0, 120.0, 0.0], [150.0, 130.0, 0.0]]),
        dp.covert.TargetPath([[160.0, 100.0, 0.0], [160.0, 100.5, 0.0]]),
    )
    sc = dp.covert.CovertScenario(params, dp.covert.Terrain(), paths, targets_stop=True)
    trace = dp.covert.simulate(sc, dp.covert.SlidingModeObserver())
    assert trace.finished and np.isfinite(trace.beta_max)
    assert np.allclose(trace.targets[-1, 0], [150.0, 130.0, 0.0])
