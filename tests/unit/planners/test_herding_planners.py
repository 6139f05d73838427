"""Herding planners: extended hull, guidance laws, steering points, no-crossing (Theorem 6.4.1)."""

import math

import numpy as np
import pytest
import shapely
from hypothesis import given, settings
from hypothesis import strategies as st

from droneplan.formulations.herding import solve_allocation
from droneplan.planners.herding import (
    ExtendedHull,
    F,
    HerderSettings,
    allocate_collision_blind,
    convex_hull,
    extended_hull_vertices,
    fly_on_edge,
    fly_to_edge,
    g,
    min_enclosing_circle,
    steering_points,
)
from droneplan.scenarios.herding import drone_step, thesis_scenario

clouds = st.lists(st.tuples(st.floats(-500, 500), st.floats(-500, 500)), min_size=3, max_size=40).map(
    np.array
)


@settings(max_examples=40, deadline=None)
@given(clouds, st.floats(1.0, 60.0))
def test_extended_hull_edges_parallel_at_distance_ds(pts, ds):
    P = convex_hull(pts)
    if len(P) < 3:
        return
    E, _ = extended_hull_vertices(P, ds, mitre_limit=float("inf"))  # Definition 6.3.1 as written
    assert len(E) == len(P)  # one-to-one edges (Definition 6.3.1)
    if np.max(np.linalg.norm(E - P, axis=1)) > 100 * ds:
        return  # needle-sharp corner (mitre spike): the float comparisons below lose precision
    for i in range(len(P)):
        p0, p1 = P[i], P[(i + 1) % len(P)]
        e0, e1 = E[i], E[(i + 1) % len(P)]
        u = (p1 - p0) / np.linalg.norm(p1 - p0)
        w = e1 - e0
        assert abs(u[0] * w[1] - u[1] * w[0]) <= 1e-6 * max(1.0, np.linalg.norm(w))  # parallel
        nrm = np.array([u[1], -u[0]])  # outward for a ccw polygon
        assert np.dot(e0 - p0, nrm) == pytest.approx(ds, rel=1e-6, abs=1e-6)
        assert np.dot(e1 - p0, nrm) == pytest.approx(ds, rel=1e-6, abs=1e-6)
    # the same polygon as shapely's mitre buffer (the documented corner rule) when no mitre is clipped
    buf = shapely.Polygon(P).buffer(ds, join_style="mitre", mitre_limit=1e6)
    ours = shapely.Polygon(E)
    # Hausdorff distance, not the symmetric-difference area: GEOS overlay of two
    # polygons equal to 1e-13 can return both whole polygons (seen with 4-point hulls).
    assert ours.hausdorff_distance(buf) <= 1e-6 * max(1.0, buf.length)


@pytest.mark.parametrize(
    "pts",
    [
        np.zeros((5, 2)),
        np.array([[0.0, 0.0], [10.0, 0.0], [20.0, 0.0], [5.0, 0.0]]),
        np.array([[3.0, 4.0]]),
        np.array([[0.0, 0.0], [0.0, 7.0]]),
    ],
)
def test_degenerate_herds_give_a_valid_extended_hull(pts):
    hull = ExtendedHull.from_points(pts, 30.0)
    assert len(hull.vertices) == 4
    poly = shapely.Polygon(hull.vertices)
    assert poly.is_valid and poly.exterior.is_ccw
    # every animal is at least d_s inside the extended hull
    assert np.all([poly.exterior.distance(shapely.Point(p)) >= 30.0 - 1e-9 for p in pts])
    assert all(poly.contains(shapely.Point(p)) for p in pts)
    s = steering_points(hull, pts.mean(axis=0), 4)
    assert len(s) == 4 and np.all((s >= 0) & (s < hull.perimeter))


@settings(max_examples=30, deadline=None)
@given(clouds)
def test_projection_and_arc_length_roundtrip(pts):
    hull = ExtendedHull.from_points(pts, 20.0)
    s = np.linspace(0, hull.perimeter, 17, endpoint=False)
    q = hull.point_at(s)
    s2, close, _ = hull.project(q)
    assert np.allclose(close, q, atol=1e-6)
    d = np.abs(s2 - s)
    assert np.all(np.minimum(d, hull.perimeter - d) <= 1e-6 * hull.perimeter + 1e-9)


def test_F_and_g_match_6_7_and_6_8():
    rng = np.random.default_rng(0)
    a = rng.normal(size=(50, 2))
    a /= np.linalg.norm(a, axis=1, keepdims=True)
    b = rng.normal(size=(50, 2))
    f = F(a, b)
    assert np.allclose(np.sum(f * a, axis=1), 0, atol=1e-12)  # orthogonal to w1
    assert np.all(np.sum(f * b, axis=1) >= -1e-12)  # towards w2
    assert np.allclose(np.linalg.norm(f, axis=1), 1.0)
    assert np.allclose(F(a[:1], 3 * a[:1]), 0.0)  # f = 0 case
    assert list(g(a[:2], np.stack([a[0], -a[1]]))) == [1.0, -1.0]
    assert g(np.array([[1.0, 0.0]]), np.array([[0.0, 1.0]]))[0] == -1.0  # (w1, w2) = 0 -> -1


def test_fly_on_edge_stays_on_hull_and_reaches_target():
    """A drone on a (static) extended hull reaches a target 3/4 of the way round.

    Tolerance stated: it never leaves the hull by more than one step plus the minimum turning
    radius, V_max*dt + V_max/U_max (the literal law (6.8) reverses for a step at a right-angle
    corner), and it stops within 1 m of the target.
    """
    p = thesis_scenario(10, seed=0).params
    square = np.array([[0.0, 0.0], [300.0, 0.0], [300.0, 200.0], [0.0, 200.0]])
    hull = ExtendedHull.from_vertices(square)
    for direction in (1, -1):
        d = hull.point_at(np.array([10.0]))
        heading = np.array([0.0 if direction > 0 else math.pi])
        target = np.array([(10.0 + direction * 0.75 * hull.perimeter) % hull.perimeter])
        worst = 0.0
        for _ in range(300):  # 60 s: the trip is 750 m at 25 m/s
            v, w, _ = fly_on_edge(d, heading, hull, target, np.array([direction]), p.V_max, p.U_max, p.delta)
            d, heading = drone_step(d, heading, v, w, p, p.delta)
            _, close, _ = hull.project(d)
            worst = max(worst, float(np.linalg.norm(close - d)))
        assert worst <= p.V_max * p.delta + p.V_max / p.U_max
        assert np.linalg.norm(d[0] - hull.point_at(target)[0]) < 1.0


def _simulate_perimeter_travel(d, alloc, M, speed, dt):
    """Drones fly along the perimeter at equal speed to their destinations (Assumption 6.4.1);
    returns False as soon as two drones meet or pass each other."""
    pos = d.astype(float).copy()
    remaining = alloc.travel.astype(float).copy()
    start_order = np.argsort(pos, kind="stable")
    cyc0 = [int(i) for i in start_order]
    n = len(d)
    for _ in range(int(np.ceil(max(remaining.max(), 0) / (speed * dt))) + 2):
        step = np.minimum(remaining, speed * dt)
        pos = np.mod(pos + alloc.direction * step, M)
        remaining -= step
        order = [int(i) for i in np.argsort(pos, kind="stable")]
        k = order.index(cyc0[0])
        if order[k:] + order[:k] != cyc0:
            return False
        gaps = np.diff(np.sort(pos))
        if n > 1 and (np.any(gaps <= 1e-9) or (M - (pos.max() - pos.min())) <= 1e-9):
            return False
    return True


@settings(max_examples=40, deadline=None)
@given(st.integers(2, 6), st.integers(0, 10_000))
def test_exact_allocation_never_lets_drones_cross(n, seed):
    rng = np.random.default_rng(seed)
    M = 1000.0
    d = np.sort(rng.choice(np.arange(0, 1000, 7.0), n, replace=False))
    s = rng.choice(np.arange(3, 1000, 11.0), n, replace=False)
    res = solve_allocation(d, s, M)
    assert _simulate_perimeter_travel(d, res.x, M, speed=25.0, dt=0.01)


def test_collision_blind_allocation_does_cross_in_simulation():
    rng = np.random.default_rng(3)
    crossings = 0
    for _ in range(100):
        d = np.sort(rng.choice(np.arange(0, 1000, 7.0), 4, replace=False))
        s = rng.choice(np.arange(3, 1000, 11.0), 4, replace=False)
        cb = allocate_collision_blind(d, s, 1000.0)
        ok = _simulate_perimeter_travel(d, cb.x, 1000.0, speed=25.0, dt=0.01)
        assert ok == (not cb.info["crosses"])  # the order test and the simulation agree
        crossings += not ok
    assert crossings > 0


def test_steering_points_are_farthest_vertices():
    pts = np.array([[0.0, 0.0], [100.0, 0.0], [100.0, 10.0], [0.0, 10.0], [50.0, 80.0], [50.0, 5.0]])
    hull = ExtendedHull.from_points(pts, 10.0)
    c = pts.mean(axis=0)
    s = steering_points(hull, c, 2)
    far = hull.animals[np.isin(hull.vertex_s, s)]
    dist_all = np.sort(np.linalg.norm(hull.animals - c, axis=1))[::-1]
    assert np.allclose(np.sort(np.linalg.norm(far - c, axis=1))[::-1], dist_all[:2])


@settings(max_examples=40, deadline=None)
@given(st.lists(st.tuples(st.floats(-100, 100), st.floats(-100, 100)), min_size=1, max_size=12).map(np.array))
def test_min_enclosing_circle_against_brute_force(pts):
    c, r = min_enclosing_circle(pts)
    assert np.all(np.linalg.norm(pts - c, axis=1) <= r + 1e-6)
    # brute force over circles through 2 or 3 points: none smaller encloses all
    best = 0.0 if len(pts) == 1 else math.inf
    idx = range(len(pts))
    for i in idx:
        for j in idx:
            if j <= i:
                continue
            cc = (pts[i] + pts[j]) / 2
            rr = np.linalg.norm(pts[i] - cc)
            if np.all(np.linalg.norm(pts - cc, axis=1) <= rr + 1e-7):
                best = min(best, rr)
            for k in idx:
                if k <= j:
                    continue
                A, B, C = pts[i], pts[j], pts[k]
                dd = 2 * (A[0] * (B[1] - C[1]) + B[0] * (C[1] - A[1]) + C[0] * (A[1] - B[1]))
                if abs(dd) < 1e-9:
                    continue
                ux = (A @ A * (B[1] - C[1]) + B @ B * (C[1] - A[1]) + C @ C * (A[1] - B[1])) / dd
                uy = (A @ A * (C[0] - B[0]) + B @ B * (A[0] - C[0]) + C @ C * (B[0] - A[0])) / dd
                cc = np.array([ux, uy])
                rr = np.linalg.norm(A - cc)
                if np.all(np.linalg.norm(pts - cc, axis=1) <= rr + 1e-7):
                    best = min(best, rr)
    assert r <= best + 1e-6


def test_herder_settings_validate():
    with pytest.raises(ValueError, match="arrive_tol"):
        HerderSettings(arrive_tol=0.0)
    with pytest.raises(ValueError, match="allocation"):
        HerderSettings(allocation="greedy")


def _b_6_11(d, E_next, E_j):
    """(6.9)-(6.11) literally: vector from the drone to the closest point of edge E_{j+1}E_j."""
    q = E_j - E_next
    p = d - E_next
    pq = float(np.dot(p, q))
    if pq < 0:
        return -p
    o_len = pq / np.linalg.norm(q)  # (6.9)
    if o_len <= np.linalg.norm(q):
        return o_len * q / np.linalg.norm(q) - p  # (6.10)
    return q - p


@settings(max_examples=40, deadline=None)
@given(clouds, st.tuples(st.floats(-900, 900), st.floats(-900, 900)))
def test_fly_to_edge_vector_matches_6_11_and_remark_6_4_2(pts, drone):
    hull = ExtendedHull.from_points(pts, 30.0)
    d = np.array(drone)
    E = hull.vertices
    # Remark 6.4.2: the closest edge is the one of minimum |b| over all edges
    bs = [_b_6_11(d, E[(i + 1) % len(E)], E[i]) for i in range(len(E))]
    best = min(bs, key=np.linalg.norm)
    _, close, _ = hull.project(d[None, :])
    assert np.linalg.norm(close[0] - d) == pytest.approx(np.linalg.norm(best), rel=1e-9, abs=1e-7)
    v, w, b = fly_to_edge(d[None, :], np.array([0.3]), hull, 25.0, 5.0, 0.2)
    # same length (the closest point may be tied between two edges), and it lands on the hull
    assert np.linalg.norm(b[0]) == pytest.approx(np.linalg.norm(best), rel=1e-9, abs=1e-7)
    assert hull.project((d + b[0])[None, :])[1] == pytest.approx((d + b[0])[None, :], abs=1e-6)
    assert abs(v[0]) <= 25.0 and abs(w[0]) <= 5.0


def _welzl_point_by_point(points):  # noqa: C901
    """The deterministic Welzl loops, one point at a time (the form before the scans were vectorised)."""
    P = list(np.asarray(points, dtype=float))

    def circ2(a, b):
        c = (a + b) / 2
        return c, float(np.linalg.norm(a - c))

    def circ3(a, b, c):
        (ax, ay), (bx, by), (cx, cy) = a, b, c
        d = 2 * (ax * (by - cy) + bx * (cy - ay) + cx * (ay - by))
        if abs(d) < 1e-12:
            return max((circ2(a, b), circ2(a, c), circ2(b, c)), key=lambda t: t[1])
        s2a, s2b, s2c = ax * ax + ay * ay, bx * bx + by * by, cx * cx + cy * cy
        u = np.array(
            [
                (s2a * (by - cy) + s2b * (cy - ay) + s2c * (ay - by)) / d,
                (s2a * (cx - bx) + s2b * (ax - cx) + s2c * (bx - ax)) / d,
            ]
        )
        return u, float(np.linalg.norm(a - u))

    def inside(circle, p):
        return np.linalg.norm(p - circle[0]) <= circle[1] * (1 + 1e-12) + 1e-9

    c = (P[0], 0.0)
    for i in range(1, len(P)):
        if inside(c, P[i]):
            continue
        c = (P[i], 0.0)
        for j in range(i):
            if inside(c, P[j]):
                continue
            c = circ2(P[i], P[j])
            for k in range(j):
                if not inside(c, P[k]):
                    c = circ3(P[i], P[j], P[k])
    return np.asarray(c[0], dtype=float), float(c[1])


@pytest.mark.parametrize("kind", ["uniform", "hull", "grid", "circle"])
def test_min_enclosing_circle_bit_identical_to_point_by_point_loops(kind):
    """The vectorised scans change the speed only: the same circle to the last bit (reproducible runs)."""
    rng = np.random.default_rng(11)
    for _ in range(60):
        n = int(rng.integers(1, 50))
        if kind == "uniform":
            pts = rng.uniform(-300, 300, (n, 2))
        elif kind == "hull":  # what the driving herders pass: ccw hull vertices, the slow order for Welzl
            pts = convex_hull(rng.normal(0, 80, (10 * n + 3, 2)))
        elif kind == "grid":  # duplicates and exact ties
            pts = np.round(rng.uniform(-4, 4, (n, 2)))
        else:  # cocircular points
            ang = np.sort(rng.uniform(0, 2 * math.pi, n))
            pts = 40 * np.column_stack([np.cos(ang), np.sin(ang)])
        c, r = min_enclosing_circle(pts)
        c_ref, r_ref = _welzl_point_by_point(pts)
        assert np.array_equal(c, c_ref) and r == r_ref


@pytest.mark.parametrize("large", [False, True])
@pytest.mark.parametrize("kind", ["uniform", "clustered", "jumps", "degenerate"])
def test_hull_tracker_gives_convex_hull_of_every_herd(kind, large, monkeypatch):
    """HullTracker follows a herd that moves a little each call (and sometimes a lot) and must
    return exactly convex_hull of each herd: the same vertices in the same order (``large``: the
    herd counts as large, so convex_hull prefilters it and the tracker's rebuild measures depths
    only near the prefilter's octagon)."""
    from droneplan.planners.herding import geometry

    monkeypatch.setattr(geometry, "_TRACK_MIN", 3)  # track the small herds of this test too
    if large:
        monkeypatch.setattr(geometry, "_PREFILTER_MIN", 50)
    rng = np.random.default_rng(len(kind))
    n = 300
    if kind == "clustered":
        pts = rng.normal(0, 40, (n, 2)) + np.where(rng.random((n, 1)) < 0.5, 0.0, 150.0)
    elif kind == "degenerate":
        pts = np.column_stack([np.linspace(0, 100, n), np.zeros(n)])
    else:
        pts = rng.uniform(0, 400, (n, 2))
    tracker = geometry.HullTracker(margin=10.0)
    rebuilt = 0
    for step in range(120):
        movers = rng.random(n) < 0.3
        step_size = 60.0 if kind == "jumps" and step % 17 == 5 else 0.8
        pts = pts + movers[:, None] * rng.normal(0, step_size / 2, (n, 2))
        if kind == "degenerate" and step % 40 == 20:
            pts = np.column_stack([pts[:, 0], np.zeros(n)])  # back to collinear
        before = tracker._moved
        got = tracker(pts)
        rebuilt += tracker._moved == 0.0 and before != 0.0
        np.testing.assert_array_equal(got, geometry.convex_hull(pts))
    if kind != "degenerate":
        assert rebuilt >= 2  # the candidates were renewed while the herd moved
    with pytest.raises(ValueError, match="margin"):
        geometry.HullTracker(margin=0.0)
    with pytest.raises(ValueError, match="points"):
        tracker(np.full((5, 2), np.nan))


def test_the_octagon_band_holds_every_animal_near_the_hull_boundary():
    """The large-herd rebuild keeps the animals within margin of the octagon of extremes; since the
    octagon lies inside the hull, that must include every animal within margin of the hull's
    boundary (exact depths, brute force over the hull edges), and leave deep animals out."""
    from droneplan.planners.herding import geometry

    rng = np.random.default_rng(21)
    for trial in range(40):
        pts = rng.normal(0, 100, (2000, 2)) if trial % 2 else rng.uniform(0, 500, (2000, 2))
        margin = float(rng.uniform(1.0, 40.0))
        V = convex_hull(pts)
        e = np.roll(V, -1, axis=0) - V
        normal = np.column_stack([e[:, 1], -e[:, 0]]) / np.linalg.norm(e, axis=1)[:, None]
        depth = np.min(np.sum(normal * V, axis=1)[None, :] - pts @ normal.T, axis=1)
        band = set(geometry._octagon_band(pts, margin).tolist())
        assert set(np.flatnonzero(depth < margin).tolist()) <= band
        assert len(band) < len(pts)  # deep animals are left out
