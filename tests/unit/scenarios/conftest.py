"""Fixtures shared by the scenario tests: a small cells placement and one short trace per
closed-loop problem (what the exports, missions and maps are made from)."""

from __future__ import annotations

import pytest

import droneplan as dp


@pytest.fixture(scope="module")
def cells():
    """(problem, greedy plan) of Table 4.2 with m = 2, seed 0."""
    problem = dp.cells.thesis_problem(n_cells=2, seed=0)
    return problem, dp.cells.greedy_placement(problem)


@pytest.fixture(scope="module")
def traces():
    """A short covert, shark and herding run, by problem name."""
    covert = dp.covert.simulate(
        dp.covert.thesis_case(1, seed=0), dp.covert.SlidingModeObserver(), seed=3, t_max=8.0
    )
    shark = dp.shark.simulate(
        dp.shark.InterceptionScenario(dp.shark.thesis_trajectories()["a"]),
        dp.shark.VirtualSharkInterceptor(),
        seed=3,
    )
    herd = dp.herding.simulate(
        dp.herding.thesis_scenario(15, seed=0, field_size=(100.0, 100.0), goal=(-100.0, 50.0)),
        dp.herding.ProposedHerder(),
        t_max=6.0,
        seed=3,
    )
    return {"covert": covert, "shark": shark, "herding": herd}
