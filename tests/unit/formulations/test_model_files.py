"""The cells model and the allocation model written as MPS / LP files read back by HiGHS."""

from __future__ import annotations

import highspy
import numpy as np
import pytest
from ortools.sat.python import cp_model

from droneplan.formulations.cells import build_milp, solve_exact, solve_model, write_model
from droneplan.formulations.herding import build_allocation_model, solve_allocation, write_allocation_model
from droneplan.scenarios.cells import CellProblem
from droneplan.solvers.model_files import write_cp_model
from droneplan.studies.instances import random_allocation_instance


def _problem(seed: int, n: int = 14, m: int = 2) -> CellProblem:
    users = np.random.default_rng(seed).uniform(-6, 6, size=(n, 2))
    return CellProblem(users=users, gbs=np.zeros((1, 2)), n_cells=m, R_d=1.0, R_g=1.0, r1=3.0, r2=2.5)


def _highs_optimum(path) -> tuple[float, str, list[str]]:
    """HiGHS's optimum of the model in ``path``, its status and its column names."""
    h = highspy.Highs()
    h.silent()
    assert h.readModel(str(path)) == highspy.HighsStatus.kOk
    h.setOptionValue("time_limit", 60.0)
    h.run()
    names = [h.getColName(i)[1] for i in range(h.getNumCol())]
    return h.getInfo().objective_function_value, h.modelStatusToString(h.getModelStatus()), names


@pytest.mark.parametrize("suffix", [".mps", ".lp"])
@pytest.mark.parametrize("backend", ["cp-sat", "highs"])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_a_written_cells_model_has_droneplans_optimum(tmp_path, suffix, backend, seed):
    problem = _problem(seed)
    path = write_model(problem, tmp_path / f"cells{suffix}", backend=backend)
    value, status, names = _highs_optimum(path)
    optimum = solve_exact(problem, engine="bnb", workers=1, time_limit=60)
    assert status == "Optimal" and optimum.status.name == "OPTIMAL"
    assert value == pytest.approx(optimum.objective)
    assert any(n.startswith("site") for n in names) and not any(n.startswith("x") for n in names)


def test_a_user_row_reaches_the_file(tmp_path):
    problem = _problem(3, n=16)
    model = build_milp(problem)
    best = solve_model(model)
    chosen = [i for i, p in enumerate(model.points) if any(np.allclose(p, q) for q in best.x)]
    model.add(model.sum(model.x[i] for i in chosen) <= len(chosen) - 1)  # not this placement again
    again = solve_model(model)
    value, status, _ = _highs_optimum(write_model(model, tmp_path / "own.mps"))
    assert status == "Optimal" and value == pytest.approx(again.objective) and value <= best.objective


@pytest.mark.parametrize(("n", "seed"), [(3, 0), (5, 1), (6, 2)])
def test_a_written_allocation_model_has_the_exact_allocations_optimum(tmp_path, n, seed):
    drone_s, steer_s, perimeter = random_allocation_instance(n, seed)
    path = write_allocation_model(drone_s, steer_s, perimeter, tmp_path / "alloc.lp")
    rank, status, names = _highs_optimum(path)
    travel = build_allocation_model(drone_s, steer_s, perimeter).travel_values[round(rank)]
    assert status == "Optimal"
    assert travel == pytest.approx(solve_allocation(drone_s, steer_s, perimeter).objective)
    assert "max_travel_rank" in names and any(n.startswith("drone") for n in names)


def test_clauses_with_an_enforcement_literal_and_negations_translate_exactly(tmp_path):
    model = cp_model.CpModel()
    a, b, c = (model.new_bool_var(name) for name in "abc")
    model.add_bool_or([a.Not(), b]).only_enforce_if(c)  # c => (not a or b)
    model.add_exactly_one([a, c.Not()])  # a + (1 - c) == 1
    model.add_at_most_one([b, c])
    model.maximize(3 * a + 2 * b + c)
    # brute force over the 8 points of the cube, with the same logic
    best = max(
        3 * x + 2 * y + z
        for x in (0, 1)
        for y in (0, 1)
        for z in (0, 1)
        if (not z or (not x or y)) and x + (1 - z) == 1 and y + z <= 1
    )
    value, status, _ = _highs_optimum(write_cp_model(model, tmp_path / "m.mps"))
    assert status == "Optimal" and value == best


@pytest.mark.parametrize(
    ("name", "message"),
    [("model.txt", "must end in .mps or .lp"), ("missing/model.mps", "does not exist")],
)
def test_a_bad_path_is_refused_in_one_line_and_nothing_is_written(tmp_path, name, message):
    with pytest.raises(ValueError, match=message) as err:
        write_model(_problem(0, n=4, m=1), tmp_path / name)
    assert "\n" not in str(err.value) and list(tmp_path.iterdir()) == []


def test_a_constraint_without_a_linear_form_is_named_and_nothing_is_written(tmp_path):
    model = cp_model.CpModel()
    xs = [model.new_int_var(0, 3, f"x{i}") for i in range(3)]
    model.add_all_different(xs).with_name("distinct")
    with pytest.raises(ValueError, match="'distinct' is a CP-SAT all_diff"):
        write_cp_model(model, tmp_path / "m.lp")
    assert list(tmp_path.iterdir()) == []
