"""Independent scoring of what a method returns: droneplan's evaluator decides, never the method."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from droneplan.formulations.cells import evaluate
from droneplan.formulations.herding import pad_steering_points
from droneplan.solvers.result import SolveResult, Status
from droneplan.studies.harness import execute, score
from droneplan.studies.instances import AllocationInstance, as_instance, family_instances
from droneplan.studies.methods import BUILTIN, Method, resolve_methods


@pytest.fixture(scope="module")
def cells():
    return family_instances("table4.2", m=2, seeds=[0])[0]


def _user(fn):
    return Method("user", fn)


def _score(inst, returned):
    return score(inst, _user(lambda *a, **k: returned), returned)


def test_cells_valid_plan_is_scored_by_evaluate(cells):
    plan = BUILTIN["greedy"].call(cells.data, seed=0, time_limit=None)
    verdict = _score(cells, plan)
    assert verdict.status == "feasible"
    assert verdict.objective == evaluate(cells.data, plan).covered
    assert verdict.bound is None  # a user method's bound is never recorded as proven


@pytest.mark.parametrize(
    ("returned", "status", "words"),
    [
        (np.array([[np.nan, 0.0]]), "invalid", "NaN or inf"),
        (np.array([[np.inf, 0.0]]), "invalid", "NaN or inf"),
        (np.zeros((2, 3)), "invalid", "shape (k, 2)"),
        ("north of the river", "invalid", "must be numbers"),
        ([[0.0, 0.0]], "infeasible", "overlaps GBS"),
        (np.array([[2000.0, 0.0], [2100.0, 0.0]]), "infeasible", "overlap"),
        (np.array([[2000.0, 0.0], [0.0, 2000.0], [-2000.0, 0.0]]), "invalid", "n_cells = 2"),
        (np.array([[4900.0, 4900.0]]), "infeasible", "no backhaul"),
    ],
)
def test_cells_misbehaving_returns(cells, returned, status, words):
    verdict = _score(cells, returned)
    assert verdict.status == status
    assert words in verdict.message
    assert verdict.objective is None


def test_cells_claims_are_kept_apart_and_flagged(cells):
    plan = np.array([[2000.0, 0.0]])
    true = evaluate(cells.data, plan).covered
    honest = SolveResult(Status.FEASIBLE, objective=np.int64(true), x=plan)
    v = _score(cells, honest)
    assert v.claimed_objective == true and v.flags == [] and v.objective == true
    liar = SolveResult(Status.OPTIMAL, objective=true + 50.0, bound=true + 50.0, x=plan)
    v = _score(cells, liar)
    assert v.objective == true and v.claimed_objective == true + 50
    assert "claim-mismatch" in v.flags and v.status == "feasible"  # a user's OPTIMAL is not believed
    assert v.bound is None and v.extras["claimed_bound"] == true + 50
    nan_claim = SolveResult(Status.FEASIBLE, objective=float("nan"), x=plan)
    assert "claim-invalid" in _score(cells, nan_claim).flags
    empty = SolveResult(Status.NO_SOLUTION)
    assert _score(cells, empty).status == "no_solution"


def test_cells_trusted_engine_keeps_its_bound(cells):
    res = BUILTIN["bnb"].call(cells.data, seed=0, time_limit=60)
    v = score(cells, BUILTIN["bnb"], res)
    assert v.status == "optimal" and v.bound is not None and v.objective <= v.bound + 1e-9


@pytest.fixture(scope="module")
def alloc():
    return as_instance(AllocationInstance(np.array([10.0, 40.0, 70.0]), np.array([20.0, 50.0, 80.0]), 100.0))


def test_allocation_valid_and_crossing(alloc):
    d = alloc.data
    v = _score(alloc, (np.array([0, 1, 2]), np.array([1, 1, 1])))
    assert v.status == "feasible" and v.objective == pytest.approx(10.0)
    # drone 0 to point 1 forward, drone 1 to point 0 backward: they would cross
    v = _score(alloc, (np.array([1, 0, 2]), np.array([1, -1, 1])))
    assert v.status == "infeasible" and "(6.2" in v.message
    # brute force: the best feasible allocation equals the exact method's optimum
    best = np.inf
    for perm in itertools.permutations(range(3)):
        for dirs in itertools.product((-1, 1), repeat=3):
            s = _score(alloc, (np.array(perm), np.array(dirs)))
            if s.status == "feasible":
                best = min(best, s.objective)
    exact = BUILTIN["exact"].call(d.drone_s, d.steer_s, d.perimeter, seed=0, time_limit=None)
    assert best == pytest.approx(exact.objective)
    verdict = score(alloc, BUILTIN["exact"], exact)
    assert verdict.status == "optimal" and verdict.bound == pytest.approx(best)


@pytest.mark.parametrize(
    ("returned", "words"),
    [
        ((np.array([0, 1]), np.array([1, 1, 1])), "shape (3,)"),
        ((np.array([0.5, 1, 2]), np.array([1, 1, 1])), "integers"),
        ((np.array([0, 1, 7]), np.array([1, 1, 1])), "0..2"),
        ((np.array([0, 1, 2]), np.array([1, np.nan, 1])), "finite"),
        ("forward", "(target, direction)"),
        ((np.array(["a", "b", "c"]), np.array([1, 1, 1])), "integers"),
    ],
)
def test_allocation_invalid_returns(alloc, returned, words):
    v = _score(alloc, returned)
    assert v.status == "invalid" and words in v.message


def test_allocation_bad_direction_and_padding():
    inst = as_instance(AllocationInstance(np.array([10.0, 40.0, 70.0]), np.array([20.0]), 100.0))
    v = _score(inst, (np.array([0, 1, 2]), np.array([1, 2, 1])))
    assert v.status == "infeasible" and "+1 or -1" in v.message
    points = pad_steering_points(inst.data.steer_s, 3, 100.0)
    assert len(points) == 3
    exact = BUILTIN["exact"].call(inst.data.drone_s, inst.data.steer_s, 100.0, seed=0, time_limit=None)
    assert _score(inst, exact).objective == pytest.approx(exact.objective)


def test_collision_blind_is_caught_when_it_crosses():
    # the relaxation often crosses; droneplan's check rejects exactly those plans
    crossed = 0
    for seed in range(30):
        inst = family_instances("allocation", n=6, seeds=[seed])[0]
        d = inst.data
        res = BUILTIN["collision-blind"].call(d.drone_s, d.steer_s, d.perimeter, seed=0, time_limit=None)
        v = score(inst, BUILTIN["collision-blind"], res)
        crosses = bool(res.info["crosses"])
        assert (v.status == "infeasible") == crosses
        crossed += crosses
    assert crossed > 0


def test_method_resolution_errors():
    with pytest.raises(ValueError, match="unknown method 'gaa'"):
        resolve_methods("cells", ["gaa"])
    with pytest.raises(ValueError, match="runs on allocation"):
        resolve_methods("cells", ["exact"])
    with pytest.raises(ValueError, match="repeat names"):
        resolve_methods("cells", [lambda p, **k: None, ("lambda-0", lambda p, **k: None)])
    with pytest.raises(ValueError, match="cannot import module"):
        resolve_methods("cells", ["no_such_module_xyz:fn"])
    with pytest.raises(TypeError, match="controller class"):
        resolve_methods("shark-path", [lambda *a, **k: None])
    ms = resolve_methods("cells", {"mine": lambda p, **k: np.zeros((0, 2))})
    assert ms[0].name == "mine" and not ms[0].trusted_bound


def test_execute_runs_a_user_function(cells):
    seen = {}

    def mine(problem, *, seed, time_limit, k=1):
        seen.update(seed=seed, time_limit=time_limit, k=k)
        return np.zeros((0, 2))

    out = execute(cells, Method("mine", mine, params={"k": 3}), 7, 5.0)
    assert out.shape == (0, 2) and seen == {"seed": 7, "time_limit": 5.0, "k": 3}
