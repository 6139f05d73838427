"""The cells variants (weights, no-fly zones, capacity) and the open model: the MILP against brute
force over the candidate sites, evaluate's checks, the user's rows, bad input."""

from __future__ import annotations

import itertools
import pickle

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from shapely.geometry import box

import droneplan as dp
from droneplan.formulations.cells import (
    CellProblem,
    build_milp,
    candidate_sites,
    evaluate,
    solve_exact,
    solve_model,
)
from droneplan.solvers.result import Status

RADII = {"R_d": 1.0, "R_g": 1.0, "r1": 3.0, "r2": 2.5}


def _best_value_by_enumeration(problem: CellProblem, extra_ok=None) -> float:
    """The largest ``evaluate(...).value`` over every feasible set of 0..m candidate sites (that
    also passes ``extra_ok(plan)`` when given); -inf when no set qualifies."""
    cand = candidate_sites(problem)
    best = -np.inf
    for k in range(problem.n_cells + 1):
        for combo in itertools.combinations(range(len(cand.points)), k):
            plan = cand.points[list(combo)].reshape(-1, 2)
            ev = evaluate(problem, plan)
            if ev.feasible and (extra_ok is None or extra_ok(plan, ev)) and ev.value > best:
                best = ev.value
    return best


def _users(seed: int, n: int) -> np.ndarray:
    return np.random.default_rng(seed).uniform(-4.5, 4.5, size=(n, 2))


SMALL = settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.too_slow])


@SMALL
@given(seed=st.integers(0, 10_000), m=st.integers(1, 2), backend=st.sampled_from(["cp-sat", "highs"]))
def test_weighted_milp_equals_brute_force(seed, m, backend):
    rng = np.random.default_rng(seed)
    users = _users(seed, 7)
    weights = np.round(rng.uniform(0.0, 5.0, len(users)), 3)
    p = CellProblem(users, [[0.0, 0.0]], m, **RADII, weights=weights)
    res = solve_exact(p, backend=backend, time_limit=60)
    assert res.status is Status.OPTIMAL and res.info["engine"] == "milp"
    best = _best_value_by_enumeration(p)
    assert res.objective == pytest.approx(best, abs=1e-3)
    assert evaluate(p, res.x).feasible
    assert evaluate(p, res.x).value == pytest.approx(best, abs=1e-3)
    assert res.objective <= res.bound + 1e-3


@SMALL
@given(
    seed=st.integers(0, 10_000),
    m=st.integers(1, 2),
    corner=st.tuples(st.floats(-4, 2), st.floats(-4, 2)),
    size=st.floats(0.5, 3.0),
)
def test_no_fly_milp_equals_brute_force(seed, m, corner, size):
    zone = box(corner[0], corner[1], corner[0] + size, corner[1] + size)
    p = CellProblem(_users(seed, 7), [[0.0, 0.0]], m, **RADII, no_fly=[zone])
    res = solve_exact(p, time_limit=60)
    assert res.status is Status.OPTIMAL
    assert res.objective == pytest.approx(_best_value_by_enumeration(p))
    ev = evaluate(p, res.x)
    assert ev.feasible
    for site in res.x:
        assert zone.exterior.distance(_point(site)) > 0 and not zone.contains(_point(site))


def _point(xy):
    from shapely.geometry import Point

    return Point(float(xy[0]), float(xy[1]))


@settings(max_examples=8, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 10_000), m=st.integers(1, 2), capacity=st.integers(1, 3), weighted=st.booleans())
def test_capacity_milp_equals_brute_force(seed, m, capacity, weighted):
    rng = np.random.default_rng(seed)
    users = _users(seed, 6)
    weights = rng.integers(0, 4, len(users)).astype(float) if weighted else None
    p = CellProblem(users, [[0.0, 0.0]], m, **RADII, capacity=capacity, weights=weights)
    res = solve_exact(p, time_limit=60)
    assert res.status is Status.OPTIMAL
    assert res.objective == pytest.approx(_best_value_by_enumeration(p))
    assert evaluate(p, res.x).value == pytest.approx(res.objective)


def test_served_weight_is_a_b_matching():
    """Three users in one drone-cell of capacity 2: the two heaviest are served."""
    p = CellProblem([[5.0, 0.0], [5.2, 0.0], [5.0, 0.2]], [[0.0, 0.0]], 1, **RADII, weights=[1.0, 4.0, 2.0])
    site = [[5.1, 0.1]]
    assert evaluate(p, site).value == pytest.approx(7.0)
    capped = CellProblem(p.users, p.gbs, 1, **RADII, weights=p.weights, capacity=2)
    assert evaluate(capped, site).value == pytest.approx(6.0)
    assert evaluate(capped, site).covered == 3  # covered is still the count within R_d


def test_evaluate_flags_a_site_in_or_on_a_no_fly_zone():
    p = CellProblem([[2.5, 0.0]], [[0.0, 0.0]], 2, **RADII, no_fly=[box(2.2, -1.0, 2.8, 1.0)])
    assert "no-fly" in " ".join(evaluate(p, [[2.5, 0.0]]).violations)
    assert not evaluate(p, [[2.8, 0.5]]).feasible  # on the edge
    assert evaluate(p, [[2.81, 0.0]]).feasible


def test_the_default_problem_is_the_thesis_model():
    p = CellProblem(_users(0, 10), [[0.0, 0.0]], 2, **RADII)
    assert p.variants == ()
    assert solve_exact(p, time_limit=60).info["engine"] in ("auto", "bnb")  # not the variants' model
    assert evaluate(p, [[2.5, 0.0]]).value == evaluate(p, [[2.5, 0.0]]).covered


def test_variants_survive_pickling_and_with_cells():
    zone = box(1.0, 1.0, 2.0, 2.0)
    p = CellProblem(
        _users(1, 5), [[0.0, 0.0]], 2, **RADII, weights=[1, 2, 3, 4, 5], no_fly=[zone], capacity=2
    )
    for q in (pickle.loads(pickle.dumps(p)), p.with_cells(3)):
        assert q.variants == ("weights", "no_fly", "capacity")
        assert np.array_equal(q.weights, p.weights) and q.capacity == 2 and q.no_fly[0].equals(zone)


def test_the_branch_and_bound_refuses_a_variant_naming_the_engine_that_can():
    p = CellProblem(_users(2, 5), [[0.0, 0.0]], 2, **RADII, capacity=1)
    with pytest.raises(ValueError, match=r"engine 'bnb'.*capacity.*milp"):
        solve_exact(p, engine="bnb")


def test_a_no_fly_zone_over_every_site_gives_the_empty_plan_optimal():
    p = CellProblem(_users(3, 6), [[0.0, 0.0]], 2, **RADII, no_fly=[box(-50, -50, 50, 50)])
    res = solve_exact(p, time_limit=30)
    assert res.status is Status.OPTIMAL
    assert res.x.shape == (0, 2) and res.objective == 0


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"weights": [1.0, -1.0, 1.0]}, "weights"),
        ({"weights": [1.0, float("nan"), 1.0]}, "weights"),
        ({"weights": [1.0, 1.0]}, "weights"),
        ({"no_fly": [[[0, 0], [1, 0], [1, 1]]]}, "no_fly"),  # not closed
        ({"no_fly": [[[0, 0], [1, 1], [1, 0], [0, 1], [0, 0]]]}, "no_fly"),  # self-intersecting
        ({"no_fly": ["a square"]}, "no_fly"),
        ({"capacity": 0}, "capacity"),
        ({"capacity": 1.5}, "capacity"),
    ],
)
def test_bad_variant_input_is_a_one_line_error_naming_the_field(kwargs, field):
    with pytest.raises((ValueError, TypeError)) as err:
        CellProblem([[3.0, 0.0], [4.0, 0.0], [5.0, 0.0]], [[0.0, 0.0]], 2, **RADII, **kwargs)
    assert field in str(err.value) and "\n" not in str(err.value)


# ------------------------------------------------------------------------ the open model
def test_user_rows_forbidding_sites_and_covering_a_district_are_proven_by_brute_force():
    """A polygon that forbids sites plus "cover at least half of the users inside a district"."""
    users = _users(11, 8)
    p = CellProblem(users, [[0.0, 0.0]], 2, **RADII)
    forbidden = box(0.0, -5.0, 5.0, 0.0)
    district = box(-5.0, 0.0, 0.0, 5.0)
    inside = [u for u, xy in enumerate(p.targets) if district.contains(_point(xy))]
    need = int(np.ceil(0.5 * len(inside)))
    model = build_milp(p)
    for i in model.sites_in(forbidden):
        model.add(model.x[i] == 0)
    model.add(model.sum(model.covered(u) for u in inside) >= need)
    res = solve_model(model, time_limit=60)

    def allowed(plan, ev):
        in_district = sum(bool(ev.covered_mask[np.flatnonzero(p.active)[u]]) for u in inside)
        return in_district >= need and not any(forbidden.intersects(_point(s)) for s in plan)

    best = _best_value_by_enumeration(p, allowed)
    if best == -np.inf:
        assert res.status is Status.INFEASIBLE
    else:
        assert res.status is Status.OPTIMAL and res.objective == pytest.approx(best)
        assert allowed(res.x, evaluate(p, res.x))


def test_a_row_no_plan_meets_is_infeasible_not_an_error():
    p = CellProblem(_users(5, 6), [[0.0, 0.0]], 1, **RADII)
    model = build_milp(p)
    model.add(model.sum(model.x) >= 2)  # one drone-cell at most
    assert solve_model(model, time_limit=30).status is Status.INFEASIBLE


def test_covered_expressions_match_the_plan_on_every_backend():
    p = CellProblem(_users(7, 9), [[0.0, 0.0]], 2, **RADII, weights=np.arange(9.0))
    for backend in ("cp-sat", "highs"):
        model = build_milp(p, backend=backend)
        res = solve_model(model, time_limit=60)
        assert res.status is Status.OPTIMAL
        ev = res.info["evaluation"]
        assert res.objective == pytest.approx(ev.value)
        assert res.objective == pytest.approx(_best_value_by_enumeration(p))


def test_an_objective_term_changes_the_optimum():
    """Maximise coverage minus a cost of 10 per drone-cell: on users far from the GBS, none pays."""
    p = CellProblem([[3.0, 0.0], [3.5, 0.2]], [[0.0, 0.0]], 2, **RADII)
    model = build_milp(p)
    model.add_objective(-10 * model.sum(model.x))
    res = solve_model(model, time_limit=30)
    assert res.status is Status.OPTIMAL and res.objective == 0 and res.x.shape == (0, 2)


def test_the_front_door_reaches_the_open_model():
    assert dp.cells.solve_model is solve_model
    p = dp.cells.CellProblem(_users(9, 4), [[0.0, 0.0]], 1, **RADII)
    assert dp.cells.build_milp(p).heights is None


# ------------------------------------------------------------------------ the smallest fleet
def _fewest_by_enumeration(problem: CellProblem, need: float) -> int | None:
    """The fewest candidate sites of a feasible placement worth at least ``need``; None if none is."""
    cand = candidate_sites(problem)
    for k in range(problem.n_cells + 1):
        for combo in itertools.combinations(range(len(cand.points)), k):
            ev = evaluate(problem, cand.points[list(combo)].reshape(-1, 2))
            if ev.feasible and ev.value >= need - 1e-9:
                return k
    return None


@settings(max_examples=10, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 10_000), share=st.sampled_from([0.2, 0.4, 0.6, 1.0]), weighted=st.booleans())
def test_min_fleet_equals_brute_force(seed, share, weighted):
    rng = np.random.default_rng(seed)
    users = rng.uniform(-3.5, 3.5, size=(6, 2))
    weights = rng.integers(1, 4, len(users)).astype(float) if weighted else None
    p = CellProblem(users, [[0.0, 0.0]], 3, **RADII, weights=weights)
    total = float(p.target_weights.sum())
    res = dp.cells.min_fleet(p, coverage=share, time_limit=60)
    fewest = _fewest_by_enumeration(p, np.ceil(share * total - 1e-9))
    if fewest is None:
        assert res.status is Status.INFEASIBLE
        assert res.info["best_share"] == pytest.approx(_best_value_by_enumeration(p) / total)
    else:
        assert res.status is Status.OPTIMAL
        assert res.objective == fewest == len(res.x) and res.bound == fewest
        assert evaluate(p, res.x).feasible and res.info["covered_share"] >= share - 1e-9


def test_min_fleet_refuses_a_share_outside_0_1():
    p = CellProblem(_users(0, 5), [[0.0, 0.0]], 2, **RADII)
    for bad in (0.0, 1.5, float("nan")):
        with pytest.raises(ValueError, match="coverage"):
            dp.cells.min_fleet(p, coverage=bad)


# ------------------------------------------------------------------------ heuristics
@settings(max_examples=10, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 10_000), capacity=st.sampled_from([None, 1, 2]), zone=st.booleans())
def test_greedy_on_a_variant_is_feasible_and_below_the_optimum(seed, capacity, zone):
    rng = np.random.default_rng(seed)
    users = _users(seed, 7)
    no_fly = [box(0.5, 0.5, 2.5, 2.5)] if zone else ()
    p = CellProblem(
        users, [[0.0, 0.0]], 2, **RADII, weights=rng.uniform(0, 3, 7), capacity=capacity, no_fly=no_fly
    )
    plan = dp.cells.greedy_placement(p)
    ev = evaluate(p, plan)
    assert ev.feasible
    assert ev.value <= _best_value_by_enumeration(p) + 1e-9


def test_greedy_follows_the_weights_and_the_capacity():
    """Two groups a relay apart from each other, one drone-cell: the heavier group wins; with a
    capacity of one the single heaviest user decides."""
    users = [[2.5, 0.0], [2.6, 0.1], [2.6, -0.1], [-2.5, 0.0]]
    light_group = CellProblem(users, [[0.0, 0.0]], 1, **RADII, weights=[1.0, 1.0, 1.0, 5.0])
    assert evaluate(light_group, dp.cells.greedy_placement(light_group)).value == pytest.approx(5.0)
    capped = CellProblem(users, [[0.0, 0.0]], 1, **RADII, weights=[3.0, 3.0, 3.0, 4.0], capacity=1)
    assert evaluate(capped, dp.cells.greedy_placement(capped)).value == pytest.approx(4.0)


@pytest.mark.parametrize("method", ["genetic", "exhaustive"])
def test_thesis_heuristics_refuse_a_variant_naming_what_solves_it(method):
    p = CellProblem(_users(4, 5), [[0.0, 0.0]], 2, **RADII, weights=np.ones(5))
    with pytest.raises(ValueError, match=r"thesis model only.*weights.*greedy_placement"):
        getattr(dp.cells, method)(p)


# ------------------------------------------------------------------------ altitude levels
from droneplan.scenarios.air_to_ground import URBAN, AirToGround  # noqa: E402

LEVEL_RADII = {"R_d": 300.0, "R_g": 300.0, "r1": 1500.0, "r2": 1400.0}


def test_air_to_ground_path_loss_is_the_published_formula():
    ch = AirToGround()
    assert (ch.a, ch.b, ch.eta_los_db, ch.eta_nlos_db, ch.frequency_hz) == (*URBAN, 2.0e9)
    r, h = 400.0, 300.0
    theta = np.degrees(np.arctan(h / r))
    p_los = 1.0 / (1.0 + 9.61 * np.exp(-0.16 * (theta - 9.61)))
    fspl = 20 * np.log10(4 * np.pi * 2.0e9 * 500.0 / 299_792_458.0)
    assert float(ch.path_loss_db(r, h)) == pytest.approx(fspl + 1.0 * p_los + 20.0 * (1 - p_los))


@given(h=st.floats(20.0, 1000.0), budget=st.floats(85.0, 120.0))
@settings(max_examples=40, deadline=None)
def test_coverage_radius_is_where_the_loss_meets_the_budget(h, budget):
    ch = AirToGround(max_path_loss_db=budget)
    radius = ch.coverage_radius(h)
    if radius == 0.0:
        assert float(ch.path_loss_db(0.0, h)) > budget
        return
    assert float(ch.path_loss_db(radius * (1 - 1e-6), h)) <= budget
    assert float(ch.path_loss_db(radius * (1 + 1e-5) + 1e-3, h)) > budget


def _level_problem(seed: int, m: int, levels=(100.0, 300.0), **extra) -> CellProblem:
    users = np.random.default_rng(seed).uniform(-1500.0, 1500.0, size=(9, 2))
    return CellProblem(
        users, [[0.0, 0.0]], m, **LEVEL_RADII, altitudes=levels, channel=AirToGround(), **extra
    )


def _best_level_value(problem: CellProblem) -> float:
    cand = candidate_sites(problem)
    best = 0.0
    for k in range(1, problem.n_cells + 1):
        for combo in itertools.combinations(range(len(cand.points)), k):
            ev = evaluate(problem, cand.plan(list(combo)))
            if ev.feasible and ev.value > best:
                best = ev.value
    return best


@settings(max_examples=8, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 10_000), m=st.integers(1, 2), weighted=st.booleans())
def test_altitude_levels_milp_equals_brute_force(seed, m, weighted):
    weights = np.random.default_rng(seed).integers(1, 4, 9).astype(float) if weighted else None
    p = _level_problem(seed, m, weights=weights)
    res = solve_exact(p, time_limit=60)
    assert res.status is Status.OPTIMAL and res.x.shape[1] == 3
    assert res.objective == pytest.approx(_best_level_value(p))
    ev = evaluate(p, res.x)
    assert ev.feasible and ev.value == pytest.approx(res.objective)
    greedy = dp.cells.greedy_placement(p)
    assert evaluate(p, greedy).feasible and evaluate(p, greedy).value <= res.objective + 1e-9


def test_one_altitude_level_is_the_thesis_model_with_its_radius():
    """At one level h, R_d = R(h) and a direct reach of sqrt(r1^2 - h^2) on the ground give the same
    optimum as the thesis model with those radii (drone-drone links are level)."""
    h = 200.0
    for seed in range(3):
        p3 = _level_problem(seed, 2, levels=(h,))
        R = float(p3.level_radii[0])
        flat = CellProblem(p3.users, p3.gbs, 2, R, 300.0, float(np.sqrt(1500.0**2 - h**2)), 1400.0)
        assert solve_exact(p3, time_limit=60).objective == solve_exact(flat, time_limit=60).objective


def test_evaluate_checks_levels_radii_and_3d_links():
    p = _level_problem(0, 2)
    R_low, R_high = (float(r) for r in p.level_radii)
    assert not evaluate(p, [[800.0, 0.0, 150.0]]).feasible  # not a level
    assert "altitude level" in evaluate(p, [[800.0, 0.0, 150.0]]).violations[0]
    gap = R_low + R_high - 1.0  # ground distance just below the two radii
    assert not evaluate(p, [[700.0, 0.0, 100.0], [700.0, gap, 300.0]]).feasible
    assert evaluate(p, [[700.0, 0.0, 100.0], [700.0, gap + 2.0, 300.0]]).feasible
    # a direct link in 3-D: ground 1480 m at 300 m is 1510 m > r1
    assert not evaluate(p, [[1480.0, 0.0, 300.0]]).connected[0]
    assert evaluate(p, [[1480.0, 0.0, 100.0]]).connected[0]


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"altitudes": [100.0, -5.0], "channel": AirToGround()}, "altitudes"),
        ({"altitudes": [100.0]}, "channel"),
        ({"channel": AirToGround()}, "altitudes"),
        ({"altitudes": [100.0], "channel": AirToGround(max_path_loss_db=60.0)}, "channel"),
        ({"altitudes": [100.0], "channel": "urban"}, "channel"),
    ],
)
def test_bad_altitude_input_is_a_one_line_error_naming_the_field(kwargs, field):
    with pytest.raises((ValueError, TypeError)) as err:
        CellProblem([[800.0, 0.0]], [[0.0, 0.0]], 2, **LEVEL_RADII, **kwargs)
    assert field in str(err.value) and "\n" not in str(err.value)


@pytest.mark.parametrize(
    "kwargs",
    [{"a": -1.0}, {"b": 0.0}, {"eta_los_db": -1.0}, {"eta_los_db": 30.0}, {"frequency_hz": float("nan")}],
)
def test_bad_channel_parameters_are_refused_naming_them(kwargs):
    with pytest.raises(ValueError, match=next(iter(kwargs)).split("_")[0]):
        AirToGround(**kwargs)


# ------------------------------------------------------------------------ moving users
def _best_mobile_by_enumeration(mp) -> float:
    """The best summed weight over every sequence of per-epoch candidate placements of one fleet
    size whose drone-cells (in some order) move within max_move (tiny instances only)."""
    per_epoch = []
    for t, epoch in enumerate(mp.epochs):
        cand = mp.candidates(t)
        options = {}
        for k in range(epoch.n_cells + 1):
            for combo in itertools.combinations(range(len(cand.points)), k):
                plan = cand.plan(list(combo))
                ev = evaluate(epoch, plan)
                if ev.feasible:
                    options.setdefault(k, []).append((plan, ev.value))
        per_epoch.append(options)
    best = -np.inf
    for k in set.intersection(*(set(o) for o in per_epoch)):
        # dynamic programming over epochs: best value ending in each placement
        layer = [(plan, value) for plan, value in per_epoch[0][k]]
        for options in per_epoch[1:]:
            nxt = []
            for plan, value in options[k]:
                reach = [
                    v
                    for p, v in layer
                    if any(
                        np.all(np.hypot(*(p[list(perm), :2] - plan[:, :2]).T) <= mp.max_move + 1e-6)
                        for perm in itertools.permutations(range(k))
                    )
                ]
                if reach:
                    nxt.append((plan, max(reach) + value))
            layer = nxt
        if layer:
            best = max(best, max(v for _, v in layer))
    return best


@settings(max_examples=5, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 10_000), max_move=st.sampled_from([0.0, 0.5, 1.5, 10.0]))
def test_joint_mobile_model_equals_brute_force_and_beats_myopic(seed, max_move):
    rng = np.random.default_rng(seed)
    start = rng.uniform(-3.0, 3.0, size=(3, 2))
    drift = rng.normal(0.0, 0.8, size=(3, 2))
    snapshots = np.stack([start, start + drift, start + 2 * drift])
    base = CellProblem(start, [[0.0, 0.0]], 2, **RADII)
    mp = dp.cells.MobileProblem(base, snapshots, max_move)
    joint = dp.cells.solve_mobile(mp, time_limit=60)
    assert joint.status is Status.OPTIMAL
    assert joint.objective == pytest.approx(_best_mobile_by_enumeration(mp))
    assert dp.cells.evaluate_mobile(mp, joint.x).feasible
    baseline = dp.cells.myopic(mp, time_limit=60)
    assert dp.cells.evaluate_mobile(mp, baseline.x).feasible
    assert baseline.objective <= joint.objective + 1e-9


def test_evaluate_mobile_flags_a_move_too_long():
    base = CellProblem([[2.5, 0.0]], [[0.0, 0.0]], 1, **RADII)
    mp = dp.cells.MobileProblem(base, [[[2.5, 0.0]], [[0.0, 2.5]]], max_move=1.0)
    ev = dp.cells.evaluate_mobile(mp, [[[2.5, 0.0]], [[0.0, 2.5]]])
    assert not ev.feasible and "moves" in ev.violations[0] and ev.value == 2.0


@pytest.mark.parametrize(
    ("snapshots", "max_move", "field"),
    [
        (np.zeros((2, 3)), 1.0, "snapshots"),
        (np.zeros((2, 3, 2)), -1.0, "max_move"),
        ([[[np.nan, 0.0]]], 1.0, "snapshots"),
    ],
)
def test_bad_mobile_input_names_the_field(snapshots, max_move, field):
    base = CellProblem([[2.5, 0.0]], [[0.0, 0.0]], 1, **RADII)
    with pytest.raises(ValueError, match=field):
        dp.cells.MobileProblem(base, snapshots, max_move)


def test_read_user_tracks_from_metres_and_degrees(tmp_path):
    metres = tmp_path / "tracks.csv"
    metres.write_text("id,t,x,y\n2,0,10,0\n1,0,0,0\n1,60,5,0\n2,60,10,5\n")
    times, ids, snaps = dp.cells.read_user_tracks(metres)
    assert times.tolist() == [0, 60] and ids.tolist() == [1, 2]
    assert snaps.tolist() == [[[0, 0], [10, 0]], [[5, 0], [10, 5]]]
    degrees = tmp_path / "geo.csv"
    degrees.write_text("id,t,lon,lat\n1,0,0.0,0.0\n1,1,0.001,0.0\n")
    _, _, geo = dp.cells.read_user_tracks(degrees, origin=(0.0, 0.0))
    # along the equator, a circle of the WGS 84 semi-major axis (6 378 137 m)
    assert geo[1, 0, 0] == pytest.approx(6_378_137.0 * np.radians(0.001), rel=1e-9)
    gappy = tmp_path / "gappy.csv"
    gappy.write_text("id,t,x,y\n1,0,0,0\n2,0,1,1\n1,1,0,0\n")
    with pytest.raises(ValueError, match="every id needs a row at every time"):
        dp.cells.read_user_tracks(gappy)


def test_a_capacity_bounds_the_objective_by_the_heaviest_users_the_fleet_can_serve():
    """Eight users in one spot, capacity 2, one drone-cell: the bound is the two heaviest at once."""
    users = np.tile([[2.5, 0.0]], (8, 1)) + np.linspace(0.0, 0.1, 8)[:, None]
    p = CellProblem(users, [[0.0, 0.0]], 1, **RADII, weights=np.arange(1.0, 9.0), capacity=2)
    res = solve_exact(p, time_limit=30)
    assert res.status is Status.OPTIMAL and res.objective == pytest.approx(15.0)
    assert res.bound <= 15.0 + 1e-6


@settings(max_examples=60, deadline=None)
@given(
    seed=st.integers(0, 10_000),
    n=st.integers(2, 40),
    radii=st.lists(st.floats(0.3, 2.0), min_size=1, max_size=3),
)
def test_overlap_cliques_are_cliques_and_hold_every_conflicting_pair(seed, n, radii):
    """Sites of several radii: every pair inside one clique row conflicts, and every conflicting
    pair sits in at least one row (so the rows say exactly what the pair rows said)."""
    from droneplan.formulations.cells._levels import _conflicting_pairs, _overlap_cliques

    rng = np.random.default_rng(seed)
    pts = rng.uniform(-3.0, 3.0, (n, 2))
    level = rng.integers(0, len(radii), n)
    radius, heights = np.asarray(radii)[level], 100.0 * level
    gap = np.hypot(*(pts[:, None, :] - pts[None, :, :]).transpose(2, 0, 1))
    conflict = gap < radius[:, None] + radius[None, :] - 1e-6
    np.fill_diagonal(conflict, False)
    pairs = _conflicting_pairs(pts, radius)
    expected = {(i, j) for i, j in zip(*np.nonzero(conflict), strict=True) if i < j}
    assert {tuple(p) for p in pairs.tolist()} == expected
    held = set()
    for clique in _overlap_cliques(pts, radius, heights, pairs):
        for i, j in itertools.combinations(clique.tolist(), 2):
            assert conflict[i, j], (i, j)
            held.add((min(i, j), max(i, j)))
    assert {tuple(p) for p in pairs.tolist()} <= held


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 10_000), n=st.integers(2, 25))
def test_user_clique_rows_with_site_radii_hold_only_pairwise_overlapping_sites(seed, n):
    """A user's at-most-one row over its covering sites is written only when those sites overlap
    pairwise under their own radii; a user left out has two covering sites that may both stand."""
    from droneplan.formulations.cells._core import coverage_lists
    from droneplan.formulations.cells._model import _user_clique_sites

    rng = np.random.default_rng(seed)
    users = rng.uniform(-2.0, 2.0, (6, 2))
    pts = rng.uniform(-3.0, 3.0, (n, 2))
    radius = rng.choice([0.6, 1.4], n)
    cover = [coverage_lists(pts[i : i + 1], users, float(radius[i]))[0] for i in range(n)]
    rows = _user_clique_sites(pts, cover, users, radius)
    for u in range(len(users)):
        sites = [i for i in range(n) if u in cover[i].tolist()]
        if len(sites) < 2:
            assert u not in rows
            continue
        overlap = all(
            np.hypot(*(pts[i] - pts[j])) < radius[i] + radius[j] - 1e-6
            for i, j in itertools.combinations(sites, 2)
        )
        assert (u in rows) == overlap, u
        if overlap:
            assert sorted(rows[u]) == sites


def test_a_variant_out_of_time_while_its_model_is_built_returns_the_greedy_plan():
    """Table 4.2 with altitude levels (thousands of sites): a 0.5 s limit ends inside the model's
    build, which stops there; the greedy plan comes back FEASIBLE, without a bound."""
    from droneplan.scenarios.cell_variants import thesis_variant_problem

    problem = thesis_variant_problem("3d", 2, 1)
    res = solve_exact(problem, time_limit=0.5)
    assert res.status is Status.FEASIBLE and res.bound is None
    assert "while the model was built" in res.message
    greedy = dp.cells.greedy_placement(problem)
    assert np.array_equal(res.x, greedy)
    assert res.objective == evaluate(problem, greedy).value


def test_a_capacity_start_that_fills_every_cell_is_proven_by_the_capacity_bound():
    """m = 1, C = 20 on Table 4.2 seed 0: the greedy cell serves 20 users, as many as one cell
    may, so the plan is optimal whatever the time limit left to the model."""
    from droneplan.scenarios.cell_variants import thesis_variant_problem

    problem = thesis_variant_problem("capacity", 1, 0)
    res = solve_exact(problem, time_limit=0.5)
    assert res.objective == res.bound == 20.0 and res.status is Status.OPTIMAL
    assert evaluate(problem, res.x).value == 20.0


def test_the_joint_model_out_of_time_while_built_says_so_and_myopic_still_answers():
    """The moving-users world of the library, 3 epochs: a 0.2 s limit ends inside the joint
    model's build (NO_SOLUTION, saying so); the baseline still returns a feasible plan."""
    from droneplan.studies.cells_variants import mobile_problem

    mp = mobile_problem(2, 0, 3)
    joint = dp.cells.solve_mobile(mp, time_limit=0.2)
    assert joint.status is Status.NO_SOLUTION and "while the joint model" in joint.message
    base = dp.cells.myopic(mp, time_limit=0.2)
    assert base.status is Status.FEASIBLE
    assert dp.cells.evaluate_mobile(mp, base.x).feasible


@settings(max_examples=5, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 10_000), max_move=st.sampled_from([0.0, 0.5, 1.5]))
def test_the_joint_model_warm_started_from_myopic_is_still_the_brute_force_optimum(seed, max_move):
    rng = np.random.default_rng(seed)
    start = rng.uniform(-3.0, 3.0, size=(3, 2))
    drift = rng.normal(0.0, 0.8, size=(3, 2))
    snapshots = np.stack([start, start + drift, start + 2 * drift])
    mp = dp.cells.MobileProblem(CellProblem(start, [[0.0, 0.0]], 2, **RADII), snapshots, max_move)
    baseline = dp.cells.myopic(mp, time_limit=60)
    joint = dp.cells.solve_mobile(mp, time_limit=60, warm_start=baseline)
    assert joint.status is Status.OPTIMAL and dp.cells.evaluate_mobile(mp, joint.x).feasible
    assert joint.objective == pytest.approx(_best_mobile_by_enumeration(mp))
    assert joint.info["warm_start"]["value"] == baseline.objective <= joint.objective + 1e-9
    assert joint.info["warm_start"]["took"] is True  # CP-SAT takes the start


def test_a_warm_start_is_returned_when_the_joint_model_ends_below_it_or_without_a_plan():
    """The moving-users world, 3 epochs: cut short inside the build, the joint model has no plan,
    so the myopic plan it was given comes back, FEASIBLE and said so."""
    from droneplan.studies.cells_variants import mobile_problem

    mp = mobile_problem(2, 0, 3)
    base = dp.cells.myopic(mp, time_limit=60)
    joint = dp.cells.solve_mobile(mp, time_limit=0.2, warm_start=base.x)
    assert joint.status is Status.FEASIBLE and joint.objective == base.objective
    assert np.array_equal(joint.x, base.x) and joint.info["warm_start"]["returned"] is True
    assert "warm start" in joint.message and joint.info["evaluation"].feasible


def test_an_infeasible_warm_start_is_refused_naming_the_violation():
    base = CellProblem([[2.5, 0.0]], [[0.0, 0.0]], 1, **RADII)
    mp = dp.cells.MobileProblem(base, [[[2.5, 0.0]], [[0.0, 2.5]]], max_move=1.0)
    with pytest.raises(ValueError, match="warm_start must be a feasible plan: drone-cell 0 moves"):
        dp.cells.solve_mobile(mp, warm_start=[[[2.5, 0.0]], [[0.0, 2.5]]])
    with pytest.raises(ValueError, match="warm_start: the SolveResult holds no plan"):
        dp.cells.solve_mobile(mp, warm_start=dp.SolveResult(Status.NO_SOLUTION))
