"""The linear backends hand each solution they find to ``on_solution`` (CP-SAT while it runs,
pywraplp backends once at the end), and an exception raised there reaches the caller."""

from __future__ import annotations

import numpy as np
import pytest

from droneplan.solvers import get_backend

WEIGHTS = [23, 31, 29, 44, 53, 38, 63, 85, 89, 82]
VALUES = [92, 57, 49, 68, 60, 43, 67, 84, 87, 72]
CAPACITY = 165
OPTIMUM = 309  # the classic 10-item knapsack (items 0, 1, 2, 3, 5)


def _knapsack(backend: str):
    lin = get_backend(backend, kind="linear").new_model()
    x = [lin.bool_var(f"take{i}") for i in range(len(WEIGHTS))]
    lin.add(lin.sum(w * v for w, v in zip(WEIGHTS, x, strict=True)) <= CAPACITY)
    lin.maximize(lin.sum(c * v for c, v in zip(VALUES, x, strict=True)))
    return lin, x


@pytest.mark.parametrize("backend", ["cp-sat", "highs"])
def test_each_reported_solution_is_feasible_and_the_last_is_the_result(backend):
    lin, x = _knapsack(backend)
    seen = []
    res = lin.solve(variables=x, time_limit=30, workers=1, on_solution=lambda *s: seen.append(s))
    assert res.objective == OPTIMUM and seen
    for values, objective, bound in seen:
        take = np.asarray(values) > 0.5
        assert np.dot(WEIGHTS, take) <= CAPACITY
        assert objective == pytest.approx(np.dot(VALUES, take))
        assert bound is None or bound >= objective - 1e-9
    objectives = [s[1] for s in seen]
    assert objectives == sorted(objectives) and objectives[-1] == OPTIMUM


@pytest.mark.parametrize("backend", ["cp-sat", "highs"])
def test_an_exception_in_on_solution_reaches_the_caller(backend):
    lin, x = _knapsack(backend)

    def refuse(*_):
        raise KeyError("stop here")

    with pytest.raises(KeyError, match="stop here"):
        lin.solve(variables=x, time_limit=30, workers=1, on_solution=refuse)
