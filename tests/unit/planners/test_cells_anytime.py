"""The thesis GA and exhaustive search report their incumbents as they find them and keep to an
evaluation budget, without changing their result."""

from __future__ import annotations

import numpy as np
import pytest

from droneplan.formulations.cells import evaluate
from droneplan.planners.cells import exhaustive, genetic
from droneplan.scenarios.cells import thesis_problem


@pytest.mark.parametrize(("m", "seed"), [(1, 0), (2, 0), (2, 5), (3, 1)])
def test_the_ga_reports_strictly_better_feasible_plans_and_runs_the_same(m, seed):
    problem = thesis_problem(m, seed)
    plain = genetic(problem, seed=seed, restarts=4, pop_size=20)
    seen: list[np.ndarray] = []
    traced = genetic(problem, seed=seed, restarts=4, pop_size=20, report=seen.append)
    assert np.array_equal(plain.x, traced.x) and plain.objective == traced.objective
    values = [evaluate(problem, x).covered for x in seen]
    assert all(evaluate(problem, x).feasible for x in seen)
    assert values == sorted(set(values))  # each report improves on the one before
    assert values[-1] == traced.objective


def test_the_ga_keeps_to_its_evaluation_budget():
    problem = thesis_problem(2, 0)
    full = genetic(problem, seed=1, restarts=4, pop_size=20)
    for budget in (80, 200, 1000, 3000):
        res = genetic(problem, seed=1, restarts=4, pop_size=20, max_evaluations=budget)
        assert 80 <= res.info["evaluations"] <= max(budget, 80)  # the first population is always drawn
        assert res.objective <= full.objective
    assert full.info["evaluations"] > 3000
    with pytest.raises(ValueError, match="max_evaluations"):
        genetic(problem, seed=1, max_evaluations=0)


@pytest.mark.parametrize(("m", "seed"), [(1, 0), (2, 0), (2, 3)])
def test_exhaustive_reports_strictly_better_plans_ending_with_its_result(m, seed):
    problem = thesis_problem(m, seed)
    seen: list[np.ndarray] = []
    res = exhaustive(problem, report=seen.append)
    values = [evaluate(problem, x).covered for x in seen]
    assert values == sorted(set(values)) and values[-1] == res.objective
    assert np.array_equal(seen[-1], res.x)


def test_exhaustive_keeps_to_its_budget_of_last_cell_searches():
    problem = thesis_problem(2, 0)
    full = exhaustive(problem)
    cut = exhaustive(problem, max_evaluations=3)
    assert cut.info["last_cell_searches"] == 3 < full.info["last_cell_searches"]
    assert not cut.info["complete"] and "budget of 3" in cut.message
    assert cut.objective <= full.objective
    with pytest.raises(ValueError, match="max_evaluations"):
        exhaustive(problem, max_evaluations=-1)
