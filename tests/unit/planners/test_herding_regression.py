"""Herding runs give the trajectories recorded before the speed work on the same seeds.

The reference numbers were recorded with the herders and the animal step as they were before the
hull, allocation and neighbour-search speed-ups (the same scenario, herder and seeds); the
simulation must reproduce them to 1e-9 m. The three herds take the three code paths of the
animal step and the hull (small: one pass and the hull tracker; 1000: the per-animal split of
the step; 2000: the prefiltered hull), each with both herders, through gathering into driving
for the small herd.
"""

from __future__ import annotations

import numpy as np
import pytest

import droneplan as dp

CASES = {
    "small": (150, (300.0, 150.0), 240.0),
    "split": (1000, (1200.0, 600.0), 16.0),
    "prefilter": (2000, (1200.0, 600.0), 6.0),
}
"""name -> (animals, field size (m), t_max (s)); scenario seed 3, simulation seed 5."""

RECORDED = {
    "small-proposed": {
        "steps": 1201,
        "gather": 42.0,
        "total": None,
        "allocations": 193,
        "drones": [
            [[380.0, 0.0], [380.0, 50.0], [380.0, 100.0], [380.0, 150.0]],
            [
                [-9.335832479996, 29.948555980699],
                [24.178571722965, -3.308278210171],
                [252.186191143729, 91.854085060791],
                [-7.387146317714, 161.03457639799],
            ],
            [
                [167.637173039256, 35.5772476084],
                [202.349731723314, 75.929207561293],
                [184.200358445844, 150.004710280431],
                [175.764283371977, 156.365401489629],
            ],
            [
                [127.434847761253, 52.036316092293],
                [156.234348284575, 95.108995688974],
                [147.200392263621, 146.202755718416],
                [99.902454496767, 179.582805009242],
            ],
            [
                [54.272928559069, 45.792475155479],
                [101.655801503216, 76.038663190452],
                [112.962661834887, 133.141625914321],
                [50.550510517236, 188.886208693403],
            ],
            [
                [42.161634163555, 70.253193999698],
                [75.309902278953, 128.786923351359],
                [57.049359771803, 174.462797653734],
                [40.452865457026, 191.397339541262],
            ],
            [
                [-15.517998226023, 75.970241593039],
                [14.311042176439, 98.119883946003],
                [25.172168717742, 159.736295956696],
                [-46.391635822631, 215.569566084133],
            ],
            [
                [-32.793728586871, 104.699182786299],
                [-14.935795207243, 149.270771717828],
                [-43.660451479993, 214.174403600276],
                [-55.995025511407, 219.164292043965],
            ],
            [
                [-107.330173301035, 94.406009104396],
                [-66.972367086064, 134.254464897334],
                [-68.762830291154, 191.66883739813],
                [-143.970391476847, 238.683117616231],
            ],
            [
                [-132.67445324548, 116.854623221679],
                [-105.391869085967, 176.261093141485],
                [-124.64596265779, 218.046235529615],
                [-154.037669398756, 238.432752177826],
            ],
            [
                [-200.623177908293, 110.838080213497],
                [-158.854003365701, 148.191886831743],
                [-154.755628925791, 202.545030350904],
                [-231.956025641583, 254.005544618675],
            ],
        ],
        "centroid": [-238.67225348101852, 175.3991374209996],
        "radius": 58.54892912727054,
        "first": [
            [-263.2588975298215, 162.55490353413083],
            [-192.27719828372395, 206.36859726981476],
            [-261.40930575009423, 152.7844300793033],
        ],
        "sums": [-35800.83802215279, 26309.870613149942],
    },
    "small-benchmark": {
        "steps": 1201,
        "gather": 83.80000000000001,
        "total": None,
        "allocations": 0,
        "drones": [
            [[380.0, 0.0], [380.0, 50.0], [380.0, 100.0], [380.0, 150.0]],
            [
                [-3.6512085441, 11.356834649554],
                [289.337114635497, 55.138736835359],
                [281.73146604134, 79.679424754778],
                [-7.682355788845, 73.46020738211],
            ],
            [
                [61.144331703797, 45.431036975276],
                [137.674383095629, 33.12453357432],
                [146.809739081881, 134.339883758552],
                [9.885365331288, 136.075751233531],
            ],
            [
                [146.370405133484, 30.701580883411],
                [177.036437562183, 40.382561831558],
                [226.850419466642, 123.396218701673],
                [67.466257239048, 127.489635880412],
            ],
            [
                [158.042564740978, 16.840157644099],
                [217.087467803506, 75.620110945141],
                [209.837271356855, 128.688771215408],
                [159.688431506028, 167.758397746712],
            ],
            [
                [148.245552163077, 39.582798182431],
                [170.459511122087, 74.776711882507],
                [160.655512395296, 140.809519335176],
                [126.288676060724, 163.017949397027],
            ],
            [
                [67.64847113684, 22.959175968935],
                [115.313393172325, 52.833246013267],
                [123.531772287615, 115.3420506638],
                [72.107682467681, 162.452403237862],
            ],
            [
                [39.729850415131, 35.342286376594],
                [74.142023713005, 78.785672290783],
                [64.511584518455, 134.793635689798],
                [27.531124957845, 162.509022257289],
            ],
            [
                [-7.762771361123, 40.797621116913],
                [21.285414735346, 77.015094820918],
                [14.209726179941, 136.687176880063],
                [-35.143299905159, 168.051081897087],
            ],
            [
                [-81.844896462026, 31.557398054091],
                [-37.619292610908, 55.835542578006],
                [-24.021936267863, 110.138799027954],
                [-60.493277712845, 161.00415053487],
            ],
            [
                [-118.44144009916, 39.956016487779],
                [-74.711389519117, 81.9705650244],
                [-80.077265326032, 141.195645381195],
                [-101.446391591063, 163.024753351415],
            ],
        ],
        "centroid": [-151.47772178010104, 99.82989949658483],
        "radius": 52.81427972159697,
        "first": [
            [-176.84487968774653, 92.58037083776814],
            [-110.27128492174559, 116.5468461507779],
            [-172.6499200778602, 95.2988662331],
        ],
        "sums": [-22721.658267015147, 14974.484924487722],
    },
    "split-proposed": {
        "steps": 81,
        "gather": None,
        "total": None,
        "allocations": 69,
        "drones": [
            [[1280.0, 225.0], [1280.0, 275.0], [1280.0, 325.0], [1280.0, 375.0]],
            [
                [1227.731837662255, 185.587173822036],
                [1230.720714998724, 313.988070009324],
                [1230.318042786551, 363.982158123152],
                [1229.808351019262, 413.971141255657],
            ],
            [
                [1225.873738753809, 86.093728982103],
                [1228.114259460072, 413.947128447735],
                [1227.187372280599, 463.914022350887],
                [1224.943064646346, 513.676740556197],
            ],
            [
                [1213.319546809456, 33.953960609568],
                [1208.785573781093, 511.784504058604],
                [1198.295657857724, 557.896267108978],
                [1179.383720243884, 602.088696644378],
            ],
            [
                [1176.494695409658, 15.698552200957],
                [1163.798199175399, 597.191864533718],
                [1126.590672217616, 608.034175984919],
                [1083.157717006183, 612.791860333904],
            ],
        ],
        "centroid": [590.7026365958027, 297.4305161347661],
        "radius": 654.8570272518681,
        "first": [
            [102.93734904247196, 142.20847499354718],
            [961.3314435188166, 349.3260271953835],
            [112.9425488858293, 260.0510087196174],
        ],
        "sums": [590702.6365958034, 297430.51613476616],
    },
    "split-benchmark": {
        "steps": 81,
        "gather": None,
        "total": None,
        "allocations": 0,
        "drones": [
            [[1280.0, 225.0], [1280.0, 275.0], [1280.0, 325.0], [1280.0, 375.0]],
            [
                [1227.717678308157, 185.586611735151],
                [1226.07747200012, 281.948764246082],
                [1230.316129950351, 363.982098951104],
                [1229.806503739743, 413.971069338605],
            ],
            [
                [1226.195799419332, 86.04247615829],
                [1228.111898652238, 181.983118215871],
                [1227.324384698292, 463.920113208141],
                [1225.211304698896, 513.703323716905],
            ],
            [
                [1192.612358852878, 8.248931618015],
                [1219.212906416953, 82.498945895994],
                [1198.543933312114, 557.52153073411],
                [1179.130880678957, 601.901813708315],
            ],
            [
                [1099.355430448953, -11.980566289174],
                [1166.626969320736, 6.780870876877],
                [1125.522378155059, 605.328374644053],
                [1083.286653260386, 611.527367327414],
            ],
        ],
        "centroid": [590.6853646944611, 297.5197074376608],
        "radius": 654.7565493845519,
        "first": [
            [103.01787309926614, 141.6936231187547],
            [961.1490310691928, 349.4029971462915],
            [113.1534838753718, 259.894977403308],
        ],
        "sums": [590685.3646944601, 297519.70743766107],
    },
    "prefilter-proposed": {
        "steps": 31,
        "gather": None,
        "total": None,
        "allocations": 19,
        "drones": [
            [[1280.0, 225.0], [1280.0, 275.0], [1280.0, 325.0], [1280.0, 375.0]],
            [
                [1227.939723080122, 185.709429166088],
                [1227.344522286526, 314.087437055005],
                [1227.547688877476, 364.075892842679],
                [1228.136393010689, 414.037891624951],
            ],
        ],
        "centroid": [593.9224253818844, 299.47393800130493],
        "radius": 660.511958653015,
        "first": [
            [102.60643993841656, 141.98519595789347],
            [961.3495492448192, 349.85185725022063],
            [113.14675310589254, 259.9308359396426],
        ],
        "sums": [1187844.8507637675, 598947.876002609],
    },
    "prefilter-benchmark": {
        "steps": 31,
        "gather": None,
        "total": None,
        "allocations": 0,
        "drones": [
            [[1280.0, 225.0], [1280.0, 275.0], [1280.0, 325.0], [1280.0, 375.0]],
            [
                [1227.939723080122, 185.709429166088],
                [1231.008995479198, 283.506954524044],
                [1227.547688877476, 364.075892842679],
                [1228.136393010689, 414.037891624951],
            ],
        ],
        "centroid": [593.9111640174311, 299.50419386323694],
        "radius": 660.3131445184049,
        "first": [
            [102.60643993841656, 141.98519595789347],
            [961.3495492448192, 349.85185725022063],
            [113.14675310589254, 259.9308359396426],
        ],
        "sums": [1187822.3280348624, 599008.3877264736],
    },
}


@pytest.mark.parametrize("key", sorted(RECORDED))
def test_a_run_reproduces_the_recorded_trajectory(key, recorded_blas_kernel):
    name, herder = key.split("-")
    n, field, t_max = CASES[name]
    ref = RECORDED[key]
    scenario = dp.herding.thesis_scenario(n_animals=n, seed=3, field_size=field)
    h = dp.herding.ProposedHerder() if herder == "proposed" else dp.herding.BenchmarkHerder()
    trace = dp.herding.simulate(scenario, h, t_max=t_max, seed=5)
    assert len(trace.t) == ref["steps"]
    assert (trace.gather_time, trace.total_time) == (ref["gather"], ref["total"])
    assert h.n_allocations == ref["allocations"]
    every = 12 if name == "small" else 2
    np.testing.assert_allclose(trace.drones[:: 10 * every], ref["drones"], rtol=0, atol=1e-9)
    np.testing.assert_allclose(trace.centroid[-1], ref["centroid"], rtol=0, atol=1e-9)
    assert trace.footprint_radius[-1] == pytest.approx(ref["radius"], abs=1e-9)
    final = trace.final.animals
    np.testing.assert_allclose(final[:3], ref["first"], rtol=0, atol=1e-9)
    np.testing.assert_allclose(final.sum(axis=0), ref["sums"], rtol=1e-12, atol=1e-9)


def test_the_scalar_allocation_equals_the_vectorised_one():
    """A few drones take the plain-Python O(n^2) allocation; it must match the numpy one to the
    bit, ties (coincident drones, steering points on a grid) included."""
    from droneplan.formulations.herding import _exact_numpy, _exact_scalar

    rng = np.random.default_rng(11)
    checked = infeasible = 0
    for trial in range(3000):
        n = int(rng.integers(1, 9))
        M = float(rng.uniform(1.0, 1000.0))
        d = rng.uniform(0.0, M, n)
        s = rng.uniform(0.0, M, n)
        if trial % 3 == 0:
            d = np.mod(np.round(d / M * 8) * M / 8, M)
        if trial % 5 == 0:
            s = np.mod(np.round(s / M * 6) * M / 6, M)
        a, b = _exact_scalar(d, s, M), _exact_numpy(d, s, M)
        assert (a is None) == (b is None)
        if a is None:
            infeasible += 1
            continue
        (x, worst_a), (y, worst_b) = a, b
        assert worst_a == worst_b
        for field in ("target", "direction", "travel", "points"):
            assert np.array_equal(getattr(x, field), getattr(y, field)), field
        checked += 1
    assert checked > 2000 and infeasible > 0


def test_the_scalar_crossing_test_equals_the_vectorised_one():
    """``crosses`` of a few drones runs in plain Python; on random allocations (crossing or not,
    ties included) it gives the numpy version's answer."""
    from droneplan.formulations.herding import Allocation
    from droneplan.planners.herding import allocation as mod

    rng = np.random.default_rng(12)
    answers = set()
    for trial in range(3000):
        n = int(rng.integers(2, 9))
        M = float(rng.uniform(1.0, 1000.0))
        d = rng.uniform(0.0, M, n)
        if trial % 3 == 0:
            d = np.mod(np.round(d / M * 8) * M / 8, M)
        pts = rng.uniform(0.0, M, n)
        alloc = Allocation(rng.permutation(n), rng.choice([-1, 1], n), np.zeros(n), pts)
        scalar = mod.crosses(d, M, alloc)
        limit = mod._SCALAR_MAX
        try:
            mod._SCALAR_MAX = 0
            vectorised = mod.crosses(d, M, alloc)
        finally:
            mod._SCALAR_MAX = limit
        assert scalar == vectorised
        answers.add(scalar)
    assert answers == {True, False}


def test_the_delivered_share_skips_only_herds_clear_of_the_goal():
    """The simulator's delivered share equals the per-animal test, whether the herd's footprint
    disc is clear of the goal region (answered without the test), touches it or covers it."""
    from droneplan.scenarios.herding import _delivered

    rng = np.random.default_rng(13)
    shares = set()
    for _ in range(2000):
        animals = rng.normal(size=(int(rng.integers(1, 60)), 2)) * rng.uniform(1.0, 80.0)
        c = animals.mean(axis=0)
        r = float(np.sqrt(np.max(np.sum((animals - c) ** 2, axis=1))))
        goal = c + rng.normal(size=2) * rng.uniform(0.0, 200.0)
        radius = float(rng.uniform(1.0, 100.0))
        brute = float(np.mean(np.sum((animals - goal) ** 2, axis=1) <= radius**2))
        assert _delivered(animals, c, r, goal, radius) == brute
        shares.add(0.0 if brute == 0 else 1.0 if brute == 1 else 0.5)
    assert shares == {0.0, 0.5, 1.0}


def _random_hull_and_arc_positions(rng, *, min_points: int, max_n: int, span: tuple[float, float]):
    """An extended hull of min_points..39 random animals and 1..max_n arc positions drawn in
    span (in perimeters), a third of them on vertices."""
    hull = dp.herding.ExtendedHull.from_points(
        rng.uniform(0.0, 300.0, (int(rng.integers(min_points, 40)), 2)), 30.0
    )
    M, n_e = hull.perimeter, len(hull.vertices)
    n = int(rng.integers(1, max_n + 1))
    s = rng.uniform(span[0] * M, span[1] * M, n)
    s[: n // 3] = hull.vertex_s[rng.integers(0, n_e, n // 3)]  # on a vertex
    return hull, s


def test_the_scalar_waypoint_equals_the_vectorised_one(monkeypatch):
    """O* of a few drones is picked in plain Python; on random hulls, positions and targets (drones
    on vertices and targets just behind included) it is the numpy version's point to the bit."""
    from droneplan.planners.herding import guidance

    rng = np.random.default_rng(14)
    checked = 0
    for _ in range(400):
        hull, s = _random_hull_and_arc_positions(rng, min_points=3, max_n=8, span=(0.0, 1.0))
        M, n = hull.perimeter, s.size
        target = np.mod(s + rng.choice([-0.5, 1.0, 50.0, -80.0], n) * rng.uniform(0.0, 1.0, n), M)
        edge = hull.project(hull.point_at(s))[2]
        direction = rng.choice([-1, 1], n)
        scalar = guidance.next_waypoint(hull, s, edge, target, direction)
        monkeypatch.setattr(guidance, "_SCALAR_MAX", 0)
        vectorised = guidance.next_waypoint(hull, s, edge, target, direction)
        monkeypatch.setattr(guidance, "_SCALAR_MAX", 12)
        assert np.array_equal(scalar, vectorised)
        checked += n
    assert checked > 1000


def test_the_scalar_point_at_equals_the_vectorised_one(monkeypatch):
    """Points at a few arc positions are found in plain Python; on random hulls and positions
    (vertices, the perimeter itself, negative and beyond-a-lap positions included) they are the
    numpy version's points to the bit."""
    from droneplan.planners.herding import geometry

    rng = np.random.default_rng(15)
    checked = 0
    for _ in range(400):
        hull, s = _random_hull_and_arc_positions(rng, min_points=1, max_n=12, span=(-1.0, 2.0))
        M, n = hull.perimeter, s.size
        if n > 1:
            s[-1] = M
        scalar = hull.point_at(s)
        monkeypatch.setattr(geometry, "_POINT_AT_SCALAR_MAX", 0)
        vectorised = hull.point_at(s)
        monkeypatch.setattr(geometry, "_POINT_AT_SCALAR_MAX", 12)
        assert scalar.shape == vectorised.shape == (n, 2)
        assert np.array_equal(scalar, vectorised)
        checked += n
    assert checked > 1000


def test_the_scalar_steering_law_equals_the_vectorised_one(monkeypatch):
    """The sliding-mode law of a few drones runs in plain Python; on random headings and target
    vectors (zero vectors, vectors along and against the heading included) it gives the numpy
    version's speeds and turn rates to the bit."""
    from droneplan.planners.herding import guidance

    rng = np.random.default_rng(16)
    kinds = set()
    for trial in range(2000):
        n = int(rng.integers(1, 13))
        headings = rng.uniform(-4.0, 4.0, n)
        b = rng.normal(size=(n, 2)) * rng.uniform(0.0, 30.0)
        if trial % 4 == 0:  # along or against the heading, or no vector at all
            a = np.column_stack([np.cos(headings), np.sin(headings)])
            b = a * rng.choice([-2.0, 0.0, 3.0], (n, 1))
        dt = float(rng.choice([0.05, 0.1, 1.0]))
        scalar = guidance.steer(headings, b, 3.0, 1.5, dt)
        monkeypatch.setattr(guidance, "_SCALAR_MAX", 0)
        vectorised = guidance.steer(headings, b, 3.0, 1.5, dt)
        monkeypatch.setattr(guidance, "_SCALAR_MAX", 12)
        for x, y in zip(scalar, vectorised, strict=True):
            assert np.array_equal(x, y)
        kinds.update(np.sign(scalar[1]).tolist())
    assert kinds == {-1.0, 0.0, 1.0}


def test_the_lean_qhull_call_gives_convexhulls_answer():
    """The herders' hull runs scipy's qhull wrapper without ConvexHull's facet arrays; on random,
    rounded (duplicate points) and collinear herds it returns ConvexHull's vertices, area and
    perimeter to the bit, and refuses the same flat inputs."""
    from scipy.spatial import ConvexHull, QhullError

    from droneplan.planners.herding import geometry

    assert geometry._QHULL is not None  # the lean path is the one under test
    rng = np.random.default_rng(17)
    outcomes = {"hull": 0, "flat": 0}
    for trial in range(1500):
        pts = rng.normal(size=(int(rng.integers(3, 150)), 2)) * rng.uniform(0.01, 100.0)
        if trial % 5 == 0:
            pts = np.round(pts)
        if trial % 7 == 0:
            pts[:, 1] = 2.0 * pts[:, 0]
        try:
            hull = ConvexHull(pts)
        except QhullError:
            with pytest.raises(QhullError):
                geometry._qhull_2d(pts)
            outcomes["flat"] += 1
            continue
        vertices, volume, area = geometry._qhull_2d(pts)
        assert np.array_equal(vertices, hull.vertices)
        assert (volume, area) == (hull.volume, hull.area)
        outcomes["hull"] += 1
    assert min(outcomes.values()) > 50


def test_the_repulsion_stops_at_the_last_close_neighbour_without_changing_the_sum():
    """The animals' repulsion sums only the leading neighbour columns that hold a neighbour closer
    than r_a in some row; on random sorted neighbour lists (missing neighbours at infinity, rows
    with none close) it equals the sum over every column."""
    from droneplan.scenarios.herding import _repulsion, _unit

    rng = np.random.default_rng(18)
    ks = set()
    for _ in range(1500):
        m, K = int(rng.integers(1, 30)), int(rng.integers(1, 22))
        pos = rng.uniform(0.0, 50.0, (m, 2))
        nb = pos[None, :, :] + rng.normal(size=(K, m, 2)) * rng.uniform(0.2, 5.0)
        dist = np.sort(np.hypot(*(nb - pos[None]).transpose(2, 0, 1)).T, axis=1)
        dist[rng.random((m, K)) < 0.1] = np.inf
        dist = np.sort(dist, axis=1)
        r_a = float(rng.uniform(0.5, 6.0))
        close = dist < r_a
        w = np.where(close, 1.0 / np.maximum(dist, 1e-12), 0.0).T
        every_column = _unit((w[:, :, None] * (pos - nb)).sum(axis=0))
        assert np.array_equal(_repulsion(nb, pos, dist, r_a), every_column)
        ks.add(int(close.sum(axis=1).max()) == K)
    assert ks == {True, False}
