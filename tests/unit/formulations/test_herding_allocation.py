"""Steering-point allocation (6.21)-(6.23): exact == CP-SAT == Algorithm 3, and bad input."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from droneplan.formulations.herding import (
    Allocation,
    check_allocation,
    pad_steering_points,
    solve_allocation,
)
from droneplan.planners.herding import allocate_bruteforce, allocate_collision_blind, crosses
from droneplan.solvers.result import Status


@st.composite
def instances(draw, n_max=6):
    n = draw(st.integers(1, n_max))
    M = draw(st.floats(1.0, 2000.0))
    grid = st.integers(0, 10_000)
    # positions on a grid (many ties between travels) or continuous
    if draw(st.booleans()):
        d = [M * draw(grid) / 10_001 for _ in range(n)]
        s = [M * v / 10_001 for v in draw(st.lists(grid, min_size=n, max_size=n, unique=True))]
    else:
        d = draw(st.lists(st.floats(0.0, M, exclude_max=True), min_size=n, max_size=n))
        s = draw(st.lists(st.floats(0.0, M, exclude_max=True), min_size=n, max_size=n, unique=True))
    return np.array(d), np.array(s), M


@settings(max_examples=60, deadline=None)
@given(instances())
def test_exact_cpsat_bruteforce_agree(inst):
    d, s, M = inst
    ex = solve_allocation(d, s, M, engine="exact")
    cp = solve_allocation(d, s, M, engine="cp-sat")
    bf = allocate_bruteforce(d, s, M)
    assert ex.status == cp.status == bf.status
    if not ex.has_solution:
        return
    assert ex.status is Status.OPTIMAL and cp.status is Status.OPTIMAL
    assert ex.objective == pytest.approx(bf.objective, abs=1e-9 * M)
    assert cp.objective == pytest.approx(bf.objective, abs=1e-9 * M)
    assert cp.bound <= cp.objective + 1e-9 * M
    for res in (ex, cp, bf):
        # independent re-check of (6.19)-(6.23); objective = reported max travel
        assert check_allocation(d, s, M, res.x) == pytest.approx(res.objective, abs=1e-9 * M)
        assert not crosses(d, M, res.x)
        assert set(np.unique(res.x.direction)) <= {-1, 1}
        assert np.all(res.x.travel >= 0) and np.all(res.x.travel < M)
    # the collision-blind bottleneck is a relaxation: never worse than the optimum
    cb = allocate_collision_blind(d, s, M)
    assert cb.objective <= ex.objective + 1e-9 * M


@settings(max_examples=30, deadline=None)
@given(instances(n_max=5))
def test_cpsat_hint_from_exact_keeps_optimum(inst):
    d, s, M = inst
    ex = solve_allocation(d, s, M)
    if not ex.has_solution:
        return
    cp = solve_allocation(d, s, M, engine="cp-sat", warm_start=ex.x)
    assert cp.warm_started
    assert cp.objective == pytest.approx(ex.objective, abs=1e-9 * M)


def test_example_by_hand():
    # drones at 0 and 50 on a 100 m hull; steering points at 10 and 60: shift 0, both +10
    res = solve_allocation([0.0, 50.0], [60.0, 10.0], 100.0)
    assert res.objective == pytest.approx(10.0)
    assert list(res.x.target) == [1, 0] and list(res.x.direction) == [1, 1]
    # crossing assignment (drone 0 -> 60 backwards, drone 1 -> 10 backwards) would be 40 each
    shifted = Allocation(np.array([0, 1]), np.array([-1, -1]), np.array([40.0, 40.0]), np.array([60.0, 10.0]))
    assert crosses([0.0, 50.0], 100.0, shifted) is False  # same cyclic order: a valid shift
    cross = Allocation(np.array([0, 1]), np.array([1, -1]), np.array([60.0, 40.0]), np.array([60.0, 10.0]))
    assert crosses([0.0, 50.0], 100.0, cross) is True


def test_collision_blind_can_cross():
    # whenever the collision-blind bottleneck crosses, it is strictly better than
    # the collision-free optimum on paper (otherwise the exact one would be returned)
    M = 100.0
    hits = 0
    rng = np.random.default_rng(1)
    for _ in range(200):
        d, s = rng.uniform(0, M, 4), rng.uniform(0, M, 4)
        cb = allocate_collision_blind(d, s, M)
        hits += cb.info["crosses"]
        assert cb.objective <= solve_allocation(d, s, M).objective + 1e-9
    assert hits > 0  # the order constraints are not redundant


def test_coincident_steering_points_infeasible():
    res = solve_allocation([0.0, 40.0], [10.0, 10.0], 100.0)
    assert res.status is Status.INFEASIBLE
    assert solve_allocation([0.0, 40.0], [10.0, 10.0], 100.0, engine="cp-sat").status is Status.INFEASIBLE
    assert allocate_bruteforce([0.0, 40.0], [10.0, 10.0], 100.0).status is Status.INFEASIBLE
    # one drone: the order constraints are vacuous
    assert solve_allocation([5.0], [95.0], 100.0).objective == pytest.approx(10.0)


def test_fewer_steering_points_than_drones_rule():
    pts = pad_steering_points([0.0], 4, 100.0)
    assert np.allclose(np.sort(pts), [0.0, 25.0, 50.0, 75.0])
    d = np.array([1.0, 30.0, 52.0, 80.0])
    ex = solve_allocation(d, [0.0], 100.0)
    bf = allocate_bruteforce(d, [0.0], 100.0)
    cp = solve_allocation(d, [0.0], 100.0, engine="cp-sat")
    assert ex.objective == pytest.approx(bf.objective) == pytest.approx(cp.objective)
    assert "padded" in ex.message
    assert sorted(ex.x.target) == [0, 1, 2, 3]


@pytest.mark.parametrize(
    ("args", "match"),
    [
        (([], [1.0], 10.0), "at least one drone"),
        (([1.0], [], 10.0), "at least one steering"),
        (([1.0], [1.0, 2.0], 10.0), "mismatched lengths"),
        (([1.0], [1.0], 0.0), "perimeter"),
        (([1.0], [1.0], -3.0), "perimeter"),
        (([1.0], [1.0], float("nan")), "perimeter"),
        (([10.0], [1.0], 10.0), r"drone_s must lie in \[0, perimeter\)"),
        (([-1.0], [1.0], 10.0), "drone_s must lie"),
        (([1.0], [float("inf")], 10.0), "steer_s must be finite"),
        (([[1.0]], [1.0], 10.0), "1-D"),
    ],
)
def test_bad_input(args, match):
    for fn in (solve_allocation, allocate_bruteforce, allocate_collision_blind):
        with pytest.raises(ValueError, match=match):
            fn(*args)
    with pytest.raises(ValueError, match=r"^engine"):
        solve_allocation([1.0], [1.0], 10.0, engine="greedy")


def test_bruteforce_refuses_large_n():
    with pytest.raises(ValueError, match="max_drones"):
        allocate_bruteforce(np.arange(10.0), np.arange(10.0) + 0.5, 20.0)


@pytest.mark.parametrize(
    ("value", "error", "match"),
    [
        (float("nan"), TypeError, "must be an int"),
        (3.0, TypeError, "must be an int"),
        (True, TypeError, "must be an int"),
        (0, ValueError, "must be >= 1"),
    ],
)
def test_counts_are_checked_as_ints(value, error, match):
    with pytest.raises(error, match=f"max_drones {match}"):
        allocate_bruteforce([1.0, 4.0], [2.0, 6.0], 10.0, max_drones=value)
    with pytest.raises(error, match=f"workers {match}"):
        solve_allocation([1.0, 4.0], [2.0, 6.0], 10.0, workers=value)
