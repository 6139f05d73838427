"""scenarios.covert: geometry against hand computations, the plant, the thesis cases."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from droneplan.scenarios.covert import (
    THESIS_TABLE_3_2,
    CovertCommand,
    CovertPhase,
    CovertScenario,
    Obstacle,
    Terrain,
    bearing_changes,
    measure,
    nearest_on_line,
    rotate_heading,
    simulate,
    step_drone,
    thesis_case,
)

coord = st.floats(-300, 300, allow_nan=False, allow_infinity=False)
vec3 = st.tuples(coord, coord, coord).map(np.array)


def test_table_3_2_values():
    p = THESIS_TABLE_3_2
    assert (p.V_max, p.U_max, p.L_u, p.V_T, p.duration) == (10.0, 5.0, 200.0, 2.0, 120.0)
    assert (
        np.allclose(p.F, [200, 200, 0])
        and np.allclose(p.R, [10, 10, 40])
        and np.allclose(p.D_s, [20, 20, 38])
    )


def test_bearing_changes_hand_geometry():
    R = np.zeros(3)
    A = np.array([[10.0, 0.0, 0.0]])
    # angle at A between A->R = (-1,0,0) and A->D
    cases = {
        (10, 10, 0): 90.0,
        (5, 0, 0): 0.0,
        (20, 0, 0): 180.0,
        (0, 10, 0): 45.0,
        (10, 0, 7): 90.0,
        (0, 0, 10): 45.0,
    }
    for D, expected in cases.items():
        b = bearing_changes(np.array(D, float), A, R)
        assert b.shape == (1,)
        assert math.degrees(b[0]) == pytest.approx(expected, abs=1e-9)


def test_bearing_changes_vectorised_shapes():
    R = np.array([10.0, 10.0, 40.0])
    D = np.random.default_rng(0).uniform(0, 200, (7, 3))
    A = np.random.default_rng(1).uniform(0, 200, (7, 4, 3))
    b = bearing_changes(D, A, R)
    assert b.shape == (7, 4)
    for t in range(7):
        assert np.allclose(b[t], bearing_changes(D[t], A[t], R))


@settings(max_examples=60, deadline=None)
@given(vec3, vec3, vec3)
def test_bearing_changes_matches_eq_3_6(D, A, R):
    a = A - D
    r = R - D
    if np.linalg.norm(a) < 1e-3 or np.linalg.norm(a - r) < 1e-3:
        return
    cos = a @ (a - r) / (np.linalg.norm(a) * np.linalg.norm(a - r))
    expected = math.acos(max(-1.0, min(1.0, cos)))
    assert bearing_changes(D, A[None], R)[0] == pytest.approx(expected, abs=1e-6)


@settings(max_examples=60, deadline=None)
@given(vec3, vec3, vec3)
def test_nearest_on_line_is_the_perpendicular_foot(D, A, R):
    a, r = A - D, R - D
    if np.linalg.norm(A - R) < 1e-2:
        return
    p = nearest_on_line(a, r)
    foot = D + p
    d = (A - R) / np.linalg.norm(A - R)
    scale = max(1.0, np.linalg.norm(a), np.linalg.norm(r))
    # the foot is on the line through A and R, and p is orthogonal to the line
    assert np.linalg.norm(np.cross(foot - R, d)) <= 1e-7 * scale
    assert abs(p @ d) <= 1e-7 * scale
    # no point of the line is nearer (sampled)
    lam = np.linspace(-3, 3, 61)[:, None]
    pts = R + lam * (A - R)
    assert np.linalg.norm(p) <= np.min(np.linalg.norm(pts - D, axis=1)) + 1e-7 * scale


def test_bearing_changes_bad_input():
    with pytest.raises(ValueError, match="coincides with the reference point"):
        bearing_changes(np.zeros(3), np.array([[1.0, 2.0, 3.0]]), [1.0, 2.0, 3.0])
    with pytest.raises(ValueError, match="drone must be finite"):
        bearing_changes(np.array([np.nan, 0, 0]), np.ones((1, 3)), np.zeros(3))
    with pytest.raises(ValueError, match="coincides with the drone"):
        bearing_changes(np.ones(3), np.ones((1, 3)), np.zeros(3))


@settings(max_examples=40, deadline=None)
@given(st.floats(0.0, 5.0), st.floats(0.01, 0.5), st.integers(0, 10_000))
def test_rotate_heading_exact(rate, dt, seed):
    rng = np.random.default_rng(seed)
    h = rng.normal(size=3)
    h /= np.linalg.norm(h)
    u = rng.normal(size=3)
    u -= (u @ h) * h
    u *= rate / np.linalg.norm(u)
    h1, integral = rotate_heading(h, u, dt)
    assert np.linalg.norm(h1) == pytest.approx(1.0, abs=1e-12)
    assert h1 @ h == pytest.approx(math.cos(rate * dt), abs=1e-9)
    # integral of h(t) by fine quadrature of the rotation
    ts = np.linspace(0, dt, 2001)
    e = u / rate if rate > 0 else np.zeros(3)
    hs = np.cos(rate * ts)[:, None] * h + np.sin(rate * ts)[:, None] * e
    assert np.allclose(integral, np.trapezoid(hs, ts, axis=0), atol=1e-7)


def test_step_drone_enforces_bounds():
    p = THESIS_TABLE_3_2
    h = np.array([1.0, 0.0, 0.0])
    D1, h1, u, v = step_drone(np.zeros(3), h, np.array([3.0, 30.0, 0.0]), 50.0, p.dt, p)
    assert v == p.V_max
    assert u @ h == pytest.approx(0.0) and np.linalg.norm(u) == pytest.approx(p.U_max)
    assert np.linalg.norm(h1) == pytest.approx(1.0)
    assert np.linalg.norm(D1) <= p.V_max * p.dt + 1e-12


@pytest.mark.parametrize(
    ("field", "value"),
    [
        ("V_max", 0.0),
        ("U_max", -1.0),
        ("L_u", 0.0),
        ("duration", 0.0),
        ("V_max", math.nan),
        ("F", (0.0, math.inf, 0.0)),
        ("D_s", (200.0, 200.0, 10.0)),
    ],
)
def test_params_reject_bad_values(field, value):
    with pytest.raises(ValueError, match=field):
        replace(THESIS_TABLE_3_2, **{field: value})


@pytest.mark.parametrize(("case", "n"), [(1, 2), (2, 10)])
def test_thesis_cases_walk_on_the_terrain_at_V_T(case, n):
    sc = thesis_case(case, 3)
    assert sc.n_targets == n
    t = np.arange(0.0, sc.params.duration + 1e-9, 0.5)
    A = sc.targets_at(t)
    assert A.shape == (t.size, n, 3)
    assert np.allclose(A[..., 2], sc.terrain.height(A[..., 0], A[..., 1]), atol=0.05)
    speed = np.linalg.norm(np.diff(A, axis=0), axis=-1) / 0.5
    assert speed.max() <= sc.params.V_T + 1e-6
    assert speed.mean() > 0.9 * sc.params.V_T
    assert (A[..., :2] >= 0).all() and (A[..., :2] <= 200).all()


def test_case1_target1_climbs_a_hill_in_the_second_half():
    sc = thesis_case(1)
    z = sc.targets_at(np.array([0.0, 60.0, 120.0]))[:, 0, 2]
    assert z[2] - z[1] > 10.0
    # the targets approach each other in the first half and drift apart in the second
    A = sc.targets_at(np.array([0.0, 60.0, 120.0]))
    gap = np.linalg.norm(A[:, 0] - A[:, 1], axis=1)
    assert gap[1] < gap[0] and gap[2] > gap[1]


def test_case_speed_and_occlusion():
    sc = thesis_case(1, V_T=5.0, occlusion="scripted")
    assert sc.params.duration == pytest.approx(48.0)
    assert sc.observable_at(35.0).tolist() == [True, True]
    assert sc.observable_at(36.5).tolist() == [True, False]
    assert thesis_case(1, occlusion="scripted").observable_at(89.9).all()
    assert not thesis_case(1, occlusion="scripted").observable_at(90.0)[1]
    # line of sight against the hedge: target 2 walks into it at t = 90 s
    ob = thesis_case(1, occlusion=True)
    D = np.array([55.0, 63.0, 20.0])
    assert ob.observable_at(89.0, D).tolist() == [True, True]
    assert ob.observable_at(90.5, D).tolist() == [True, False]
    with pytest.raises(ValueError, match="drone"):
        ob.observable_at(90.0)
    with pytest.raises(ValueError, match="occlusion"):
        thesis_case(1, occlusion="sometimes")
    assert thesis_case(2, 5).targets_at(10.0).tolist() == thesis_case(2, 5).targets_at(10.0).tolist()
    with pytest.raises(ValueError, match="case must be 1 or 2"):
        thesis_case(3)


def test_measurement_noise_amplitude():
    rng = np.random.default_rng(0)
    a = rng.uniform(-100, 100, (500, 3))
    assert np.array_equal(measure(a, 0.0, rng), a)
    m = measure(a, 0.1, rng)
    assert np.all(np.abs(m - a) <= 0.1 * np.abs(a) + 1e-12)
    assert np.max(np.abs(m - a) / np.abs(a)) > 0.09


class _Circle:
    """Constant turn at U_max and V_max for 10 s: a circle of radius V/U."""

    phase = CovertPhase.TO_SPHERE
    finished = False

    def reset(self, scenario, *, seed=None):
        self.p = scenario.params

    def command(self, obs):
        w = np.cross(obs.heading, [0.0, 0.0, 1.0])
        return CovertCommand(self.p.U_max * w / np.linalg.norm(w), self.p.V_max)


def test_simulate_heading_stays_unit_and_circle_radius():
    p = replace(THESIS_TABLE_3_2, duration=10.0)
    sc = CovertScenario(p, Terrain(), ())
    with pytest.warns(UserWarning, match="no target"):  # a target-less run is allowed, never silent
        tr = simulate(sc, _Circle(), t_max=10.0, initial_heading=[1.0, 0.0, 0.0])
    assert np.allclose(np.linalg.norm(tr.heading, axis=1), 1.0, atol=1e-12)
    centre = p.D_s_arr + np.array([0.0, -p.V_max / p.U_max, 0.0])
    assert np.allclose(np.linalg.norm(tr.drone - centre, axis=1), p.V_max / p.U_max, atol=1e-9)
    assert tr.beta.shape == (tr.t.size, 0) and math.isnan(tr.beta_max)


# ---------------------------------------------------------------- line of sight (shapely vs numpy)


def _random_obstacle(rng):
    from shapely.geometry import MultiPoint

    pts = rng.uniform(0, 100, (int(rng.integers(3, 9)), 2))
    hull = MultiPoint(pts).convex_hull
    if hull.geom_type != "Polygon" or hull.area < 1.0:
        return None
    return Obstacle(tuple(map(tuple, np.asarray(hull.exterior.coords)[:-1])), float(rng.uniform(0, 30)))


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 10**6))
def test_vectorised_line_of_sight_matches_shapely(seed):
    rng = np.random.default_rng(seed)
    ob = _random_obstacle(rng)
    if ob is None:
        return
    D = rng.uniform(-20, 120, (200, 3)) * np.array([1, 1, 0.4])
    A = rng.uniform(-20, 120, (200, 3)) * np.array([1, 1, 0.4])
    fast = ob.blocks(D, A)
    ref = np.array([ob.blocks_shapely(d, a) for d, a in zip(D, A, strict=True)])
    assert np.array_equal(fast, ref)


def test_line_of_sight_simple_cases_and_validation():
    ob = Obstacle(((0, 0), (10, 0), (10, 10), (0, 10)), 5.0)
    assert ob.blocks([-5, 5, 1.0], [15, 5, 1.0])  # low segment through the block
    assert not ob.blocks([-5, 5, 6.0], [15, 5, 6.0])  # above its top
    assert not ob.blocks([-5, 20, 1.0], [15, 20, 1.0])  # beside it
    assert ob.blocks([5, 5, 1.0], [20, 20, 40.0])  # starts inside
    assert ob.blocks_shapely([-5, 5, 1.0], [15, 5, 1.0]) and not ob.blocks_shapely(
        [-5, 20, 1.0], [15, 20, 1.0]
    )
    with pytest.raises(ValueError, match="convex"):
        Obstacle(((0, 0), (10, 0), (5, 1), (10, 10), (0, 10)), 5.0)
    with pytest.raises(ValueError, match="footprint"):
        Obstacle(((0, 0), (1, 1)), 5.0)


@pytest.mark.parametrize("speed", [1e12, 10**12, 1e-300, 1e-3])
def test_thesis_case_refuses_a_target_speed_outside_its_range_naming_V_T(speed):
    from droneplan.scenarios.covert.world import V_T_MIN

    with pytest.raises(ValueError, match=r"^V_T"):
        thesis_case(1, V_T=speed)
    # both ends of the documented range are accepted: the period follows 240 m / V_T
    assert thesis_case(1, V_T=V_T_MIN).params.duration == pytest.approx(240.0 / V_T_MIN)
    fastest = thesis_case(1, V_T=THESIS_TABLE_3_2.V_max)
    assert fastest.params.duration == pytest.approx(240.0 / THESIS_TABLE_3_2.V_max)
