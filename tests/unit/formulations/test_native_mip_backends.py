"""The cells model and the herding allocation model on the MIP backends driven through their own
Python interface ("pyscipopt": SCIP, "gurobi": Gurobi): the same optimum as HiGHS, CP-SAT and
brute force on small instances (small enough for Gurobi's size-limited licence; if the licence
still refuses a model the test is skipped with Gurobi's reason)."""

from __future__ import annotations

import numpy as np
import pytest

from droneplan.formulations.cells import CellProblem, evaluate, solve_exact, write_model
from droneplan.formulations.herding import build_allocation_model, solve_allocation, write_allocation_model
from droneplan.planners.herding import allocate_bruteforce
from droneplan.solvers import Status, available_backends, get_backend
from droneplan.solvers.registry import unavailable_backends
from droneplan.studies.instances import random_allocation_instance

NATIVE = ["pyscipopt", "gurobi"]


def _require(backend: str) -> None:
    if backend not in available_backends("linear"):
        pytest.skip(f"{backend}: {unavailable_backends('linear').get(backend, 'not registered')}")


def _solved(result):
    """``result``, or a skip when Gurobi's size-limited licence refused the model."""
    if result.status is Status.ERROR and "size-limited" in result.message:
        pytest.skip(f"{result.backend}: the licence refused the model: {result.message}")
    return result


def _three_cells(seed: int) -> CellProblem:
    """Ten users, three drone-cells: the greedy start and its polish stay below the continuous
    bound, so the candidate model really runs (two rounds on HiGHS)."""
    users = np.random.default_rng(seed).uniform(-6, 6, size=(10, 2))
    return CellProblem(users=users, gbs=np.zeros((1, 2)), n_cells=3, R_d=1.0, R_g=1.0, r1=3.0, r2=2.5)


@pytest.mark.parametrize("seed", [0, 4])
@pytest.mark.parametrize("backend", NATIVE)
def test_cells_model_optimum_equals_highs_cpsat_and_brute_force(brute_force, backend, seed):
    _require(backend)
    problem = _three_cells(seed)
    res = _solved(solve_exact(problem, engine="milp", backend=backend, time_limit=120))
    assert res.status is Status.OPTIMAL and res.backend == backend
    assert res.info["rounds"] >= 1  # the model was solved, not skipped by the start
    assert res.objective == brute_force(problem)
    ev = evaluate(problem, res.x)
    assert ev.feasible and ev.covered == res.objective
    assert res.objective <= res.bound <= res.info["continuous_bound"]
    for reference in ("highs", "cp-sat"):
        assert (
            solve_exact(problem, engine="milp", backend=reference, time_limit=120).objective == res.objective
        )


@pytest.mark.parametrize("backend", NATIVE)
def test_cells_warm_start_on_the_backend(backend):
    _require(backend)
    problem = _three_cells(1)
    reference = solve_exact(problem, engine="milp", backend="highs", time_limit=120)
    warm = _solved(
        solve_exact(problem, engine="milp", backend=backend, warm_start=reference.x, time_limit=120)
    )
    assert warm.status is Status.OPTIMAL and warm.objective == reference.objective
    assert warm.info["warm_start"]["used"]


@pytest.mark.parametrize("backend", NATIVE)
def test_cells_model_written_by_the_backend_has_the_optimum_in_highs(tmp_path, backend):
    import highspy

    _require(backend)
    problem = _three_cells(0)
    path = write_model(problem, tmp_path / "cells.mps", backend=backend)
    h = highspy.Highs()
    h.silent()
    assert h.readModel(str(path)) == highspy.HighsStatus.kOk
    h.run()
    assert h.getModelStatus() == highspy.HighsModelStatus.kOptimal
    optimum = solve_exact(problem, engine="bnb", workers=1, time_limit=120)
    assert optimum.status is Status.OPTIMAL
    assert h.getInfo().objective_function_value == pytest.approx(optimum.objective)


@pytest.mark.parametrize(("n", "seed"), [(3, 0), (5, 1), (6, 2)])
@pytest.mark.parametrize("backend", NATIVE)
def test_allocation_model_file_on_the_backend_equals_exact_and_brute_force(tmp_path, backend, n, seed):
    """The herding allocation model, written as MPS by droneplan, read and solved by the backend:
    its optimal travel rank gives the exact algorithm's, CP-SAT's and brute force's maximum travel."""
    _require(backend)
    drone_s, steer_s, perimeter = random_allocation_instance(n, seed)
    path = write_allocation_model(drone_s, steer_s, perimeter, tmp_path / "alloc.mps")
    model = get_backend(backend, kind="linear").read_model(path)
    res = _solved(model.solve(variables=model.native.getVars(), time_limit=60))
    assert res.status is Status.OPTIMAL
    travel = build_allocation_model(drone_s, steer_s, perimeter).travel_values[round(res.objective)]
    exact = solve_allocation(drone_s, steer_s, perimeter)
    assert travel == pytest.approx(exact.objective)
    assert travel == pytest.approx(solve_allocation(drone_s, steer_s, perimeter, engine="cp-sat").objective)
    assert travel == pytest.approx(allocate_bruteforce(drone_s, steer_s, perimeter).objective)
