"""solve_exact reports each better placement as its engine finds it, and runs the same with or
without the reports."""

from __future__ import annotations

import numpy as np
import pytest

from droneplan.formulations.cells import evaluate, solve_exact
from droneplan.scenarios.cell_variants import thesis_variant_problem
from droneplan.scenarios.cells import thesis_problem


@pytest.mark.parametrize("engine", ["bnb", "milp"])
@pytest.mark.parametrize(("m", "seed"), [(2, 0), (3, 1)])
def test_reports_improve_and_end_at_the_result(engine, m, seed):
    problem = thesis_problem(m, seed)
    seen = []
    traced = solve_exact(
        problem, engine=engine, workers=1, time_limit=120, report=lambda x, bound: seen.append((x, bound))
    )
    plain = solve_exact(problem, engine=engine, workers=1, time_limit=120)
    assert traced.objective == plain.objective and traced.bound == plain.bound
    assert np.array_equal(traced.x, plain.x)
    values = [evaluate(problem, x).covered for x, _ in seen]
    assert all(evaluate(problem, x).feasible for x, _ in seen)
    assert values == sorted(set(values)) and values[-1] == traced.objective
    assert all(bound >= traced.objective for _, bound in seen)  # the continuous bound holds throughout


def test_a_variant_reports_its_final_plan():
    problem = thesis_variant_problem("weighted", 1, 0)
    seen = []
    res = solve_exact(problem, time_limit=60, report=lambda x, bound: seen.append((x, bound)))
    assert len(seen) == 1 and np.array_equal(seen[0][0], res.x) and seen[0][1] == res.bound


def test_report_must_be_callable():
    with pytest.raises(TypeError, match="report"):
        solve_exact(thesis_problem(1, 0), report="print")
