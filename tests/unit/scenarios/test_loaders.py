"""Loaders of users' data: CSV/GeoJSON reading, the local projection, and the scenarios built
from files, checked against hand-made files, independent formulas and direct constructions."""

from __future__ import annotations

import json

import numpy as np
import pyproj
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from droneplan.scenarios.cells import THESIS_TABLE_4_2, CellParams, CellProblem
from droneplan.scenarios.herding import HerdingScenario, thesis_scenario
from droneplan.scenarios.loaders import (
    DEFAULT_SHARK_DEPTH,
    ProjectedCells,
    herding_scenario_from_csv,
    load_cells_csv,
    load_cells_geojson,
    load_herd_csv,
    load_shark_track_csv,
    project_local,
    read_geojson_points,
    read_points_csv,
    unproject_local,
    write_points_csv,
)
from droneplan.scenarios.shark.trajectories import make_trajectory, thesis_trajectories


def write(tmp_path, name, text):
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


def feature_collection(*geometries):
    return {
        "type": "FeatureCollection",
        "features": [
            {"type": "Feature", "properties": {"i": i}, "geometry": g} for i, g in enumerate(geometries)
        ],
    }


def write_json(tmp_path, name, doc):
    return write(tmp_path, name, json.dumps(doc))


# --------------------------------------------------------------------------- CSV


def test_write_read_round_trip_is_exact(tmp_path):
    rng = np.random.default_rng(0)
    pts = rng.normal(scale=1e4, size=(50, 3))
    pts[0] = (0.1, -1e-300, 123456789.123456789)
    path = write_points_csv(tmp_path / "p.csv", pts, columns=("a", "b", "c"))
    back = read_points_csv(path, columns=("a", "b", "c"))
    assert back.dtype == np.float64 and np.array_equal(back, pts)
    # columns come back in the order asked for
    assert np.array_equal(read_points_csv(path, columns=("c", "a")), pts[:, [2, 0]])


def test_read_ignores_extra_columns_spaces_blank_lines_and_bom(tmp_path):
    path = tmp_path / "u.csv"
    path.write_bytes('\ufeffid , y, x ,note\n7, 2.5 ,1,hello\n\n8,-4e3,3,"a, b"\n'.encode())
    assert np.array_equal(read_points_csv(path), [[1.0, 2.5], [3.0, -4000.0]])


def test_read_accepts_crlf_line_ends(tmp_path):
    path = tmp_path / "w.csv"
    path.write_bytes(b"x,y\r\n1,2\r\n3,4\r\n")
    assert np.array_equal(read_points_csv(path), [[1.0, 2.0], [3.0, 4.0]])


@pytest.mark.parametrize(
    ("text", "pieces"),
    [
        ("", ["empty"]),
        ("  \n\n", ["empty"]),
        ("x,y\n", ["no data rows"]),
        ("x,y\n\n\n", ["no data rows"]),
        ("a,x,b\n1,2,3\n", ["missing column(s) 'y'", "'a', 'x', 'b'"]),
        ("u,v\n1,2\n", ["'x', 'y'", "'u', 'v'"]),
        ("x,y\n1,2\n3,abc\n", ["line 3", "column 'y'", "'abc'"]),
        ("x,y\n1,2\n\n,4\n", ["line 4", "column 'x'", "''"]),
        ("x,y\n1,2\n3\n", ["line 3", "column 'y'", "missing value"]),
        ("x,y\n1,nan\n", ["line 2", "column 'y'", "'nan'", "not finite"]),
        ("x,y\n-inf,1\n", ["line 2", "column 'x'", "'-inf'", "not finite"]),
        ("x,y,x\n1,2,3\n", ["'x'", "more than once"]),
    ],
)
def test_read_errors_name_the_file_line_and_column(tmp_path, text, pieces):
    path = write(tmp_path, "bad.csv", text)
    with pytest.raises(ValueError, match=r"bad\.csv") as info:
        read_points_csv(path)
    message = str(info.value)
    assert "\n" not in message
    for piece in pieces:
        assert piece in message, (piece, message)


def test_read_errors_for_missing_file_and_directory(tmp_path):
    with pytest.raises(ValueError, match=r"nothere\.csv: no such CSV file"):
        read_points_csv(tmp_path / "nothere.csv")
    with pytest.raises(ValueError, match="not a file"):
        read_points_csv(tmp_path)


def test_read_and_write_refuse_bad_arguments(tmp_path):
    path = write(tmp_path, "p.csv", "x,y\n1,2\n")
    with pytest.raises(TypeError, match="columns"):
        read_points_csv(path, columns="x")
    with pytest.raises(ValueError, match="columns must be distinct"):
        read_points_csv(path, columns=("x", "x"))
    with pytest.raises(TypeError, match="path"):
        read_points_csv(3)
    with pytest.raises(ValueError, match="points must have shape"):
        write_points_csv(tmp_path / "o.csv", np.zeros((2, 3)))
    with pytest.raises(ValueError, match="points must be finite"):
        write_points_csv(tmp_path / "o.csv", [[1.0, np.nan]])
    with pytest.raises(ValueError, match="comma"):
        write_points_csv(tmp_path / "o.csv", [[1.0, 2.0]], columns=("x", "a,b"))


# --------------------------------------------------------------------------- cells from CSV


def test_csv_cell_problem_equals_the_direct_one(tmp_path):
    rng = np.random.default_rng(1)
    users = rng.uniform(-4000, 4000, size=(80, 2))
    gbs = np.array([[0.0, 0.0], [1500.0, -200.0]])
    params = CellParams(R_d=400.0, R_g=900.0, r1=3000.0, r2=2500.0)
    from_files = load_cells_csv(
        write_points_csv(tmp_path / "users.csv", users),
        write_points_csv(tmp_path / "gbs.csv", gbs),
        n_cells=3,
        params=params,
    )
    direct = CellProblem(users, gbs, 3, 400.0, 900.0, 3000.0, 2500.0)
    for name in ("users", "gbs", "active"):
        assert np.array_equal(getattr(from_files, name), getattr(direct, name)), name
    assert (from_files.n_cells, from_files.R_d, from_files.R_g, from_files.r1, from_files.r2) == (
        3,
        400.0,
        900.0,
        3000.0,
        2500.0,
    )
    assert from_files.bounds is None and repr(from_files) == repr(direct)
    # some users are served by a GBS, some are not: the mask was really computed
    assert 0 < from_files.active.sum() < len(users)


def test_csv_cell_problem_defaults_to_the_table_4_2_gbs(tmp_path):
    users = np.array([[100.0, 0.0], [3000.0, 0.0]])
    problem = load_cells_csv(write_points_csv(tmp_path / "u.csv", users), n_cells=2)
    assert np.array_equal(problem.gbs, np.array(THESIS_TABLE_4_2.gbs))
    assert problem.R_d == THESIS_TABLE_4_2.R_d and problem.r2 == THESIS_TABLE_4_2.r2
    assert problem.active.tolist() == [False, True]  # 100 m from the GBS (R_g = 1000 m)


def test_csv_cell_problem_checks_its_arguments(tmp_path):
    path = write_points_csv(tmp_path / "u.csv", [[1.0, 2.0]])
    with pytest.raises(ValueError, match="n_cells must be >= 1"):
        load_cells_csv(path, n_cells=0)
    with pytest.raises(TypeError, match="params must be CellParams"):
        load_cells_csv(path, n_cells=1, params={"R_d": 1})
    with pytest.raises(ValueError, match=r"g\.csv: no such CSV file"):
        load_cells_csv(path, tmp_path / "g.csv", n_cells=1)
    for load in (load_cells_csv, load_cells_geojson):
        with pytest.raises(TypeError, match=r"gbs must be a str or os\.PathLike"):
            load(path, 1e12, n_cells=1)  # type: ignore[operator]
        with pytest.raises(TypeError, match=r"users must be a str or os\.PathLike"):
            load(3, n_cells=1)  # type: ignore[operator]


# --------------------------------------------------------------------------- projection
# project_local is pyproj's azimuthal equidistant projection on the WGS 84 ellipsoid; the
# oracle is pyproj.Geod's geodesic solution (Karney's algorithm), independent of the projection


GEOD = pyproj.Geod(ellps="WGS84")


def geodesic(lon1, lat1, lon2, lat2):
    """Geodesic distance (m) on the WGS 84 ellipsoid (the oracle)."""
    lon1, lat1, lon2, lat2 = np.broadcast_arrays(
        *(np.asarray(v, dtype=float) for v in (lon1, lat1, lon2, lat2))
    )
    return np.asarray(GEOD.inv(lon1, lat1, lon2, lat2)[2])


def place(origin, azimuth_deg, dist):
    """(lon, lat) degrees of the points at geodesic distances ``dist`` (m) and azimuths from ``origin``."""
    az = np.asarray(azimuth_deg, dtype=float)
    lon, lat, _ = GEOD.fwd(
        np.full(az.shape, origin[0]), np.full(az.shape, origin[1]), az, np.asarray(dist, float)
    )
    return np.asarray(lon), np.asarray(lat)


def test_a_point_1_km_north_and_east_of_the_origin():
    lon, lat = place((8.0, 47.0), [0.0], [1000.0])
    assert np.allclose(project_local(lon, lat, (8.0, 47.0)), [[0.0, 1000.0]], atol=1e-6)
    # east along the equator, and west, and south
    lon, lat = place((30.0, 0.0), [90.0, 270.0, 180.0], [1000.0] * 3)
    xy = project_local(lon, lat, (30.0, 0.0))
    assert np.allclose(xy, [[1000.0, 0.0], [-1000.0, 0.0], [0.0, -1000.0]], atol=1e-6)
    # the origin itself maps to (0, 0)
    assert np.allclose(project_local([8.0], [47.0], (8.0, 47.0)), 0.0, atol=1e-6)


def test_distance_from_the_origin_is_the_geodesic_distance_far_away():
    # azimuthal equidistant: exact along every line through the origin, up to the 1000 km limit
    lon = np.array([2.35, -1.9, 4.9, -6.26])
    lat = np.array([48.85, 52.48, 52.37, 53.35])
    origin = (-0.13, 51.5)
    xy = project_local(lon, lat, origin)
    assert np.allclose(np.hypot(xy[:, 0], xy[:, 1]), geodesic(origin[0], origin[1], lon, lat), rtol=1e-9)
    # Paris is south-east of London: x > 0, y < 0
    assert xy[0, 0] > 0 and xy[0, 1] < 0


def test_projection_across_the_antimeridian():
    lon, lat = place((180.0, 0.0), [90.0, 270.0], [1000.0, 1000.0])
    xy = project_local(lon, lat, (180.0, 0.0))
    assert np.allclose(xy, [[1000.0, 0.0], [-1000.0, 0.0]], atol=1e-6)


origins = st.tuples(st.floats(-180, 180), st.floats(-89, 89))


@settings(max_examples=150, deadline=None)
@given(
    origin=origins, xy=st.lists(st.tuples(st.floats(-7e5, 7e5), st.floats(-7e5, 7e5)), min_size=1, max_size=8)
)
def test_unproject_then_project_round_trips(origin, xy):
    pts = np.array(xy)
    lon, lat = unproject_local(pts, origin)
    assert np.all(np.abs(lon) <= 180) and np.all(np.abs(lat) <= 90)
    # PROJ's aeqd snaps points within 0.7 mm of the origin onto it: round trips hold to 1 mm
    assert np.allclose(project_local(lon, lat, origin), pts, rtol=0, atol=1e-3)


@settings(max_examples=150, deadline=None)
@given(
    origin=origins,
    offsets=st.lists(st.tuples(st.floats(-0.5, 0.5), st.floats(-0.5, 0.5)), min_size=1, max_size=8),
)
def test_project_then_unproject_round_trips(origin, offsets):
    lon0, lat0 = origin
    d = np.array(offsets)
    lat = np.clip(lat0 + d[:, 1], -90, 90)
    lon = (lon0 + d[:, 0] + 180.0) % 360.0 - 180.0
    back_lon, back_lat = unproject_local(project_local(lon, lat, origin), origin)
    # to a millimetre: PROJ snaps points within 0.6 mm of the centre onto it, and a centre within
    # 0.6 mm of the equator onto the equator
    assert np.all(geodesic(lon, lat, back_lon, back_lat) <= 1e-3)


@settings(max_examples=150, deadline=None)
@given(
    origin=st.tuples(st.floats(-180, 180), st.floats(-80, 80)),
    bearing=st.lists(st.floats(0, 360), min_size=2, max_size=6),
    dist=st.lists(st.floats(10.0, 10_000.0), min_size=2, max_size=6),
)
def test_pairwise_distances_within_20_km_match_the_geodesic(origin, bearing, dist):
    # points within 10 km of the origin (so pairs within 20 km), placed with the ellipsoid's
    # direct geodesic solution, independent of the projection's code
    k = min(len(bearing), len(dist))
    b, r = np.array(bearing[:k]), np.array(dist[:k])
    lon, lat = place(origin, b, r)
    xy = project_local(lon, lat, origin)
    # from the origin: exact distance and azimuth
    # exact up to the millimetre by which PROJ may move a centre next to the equator onto it
    assert np.allclose(np.hypot(xy[:, 0], xy[:, 1]), r, rtol=1e-9, atol=1e-3)
    direction = np.column_stack([np.sin(np.radians(b)), np.cos(np.radians(b))])
    assert np.allclose(xy, direction * r[:, None], rtol=0, atol=1e-3)
    i, j = np.triu_indices(k, 1)
    planar = np.hypot(*(xy[i] - xy[j]).T)
    ellipsoid = geodesic(lon[i], lat[i], lon[j], lat[j])
    # 0.001 % as project_local's docstring states (the requirement was 0.1 %)
    assert np.all(np.abs(planar - ellipsoid) <= 1e-5 * ellipsoid + 1e-6)


def test_projection_refuses_bad_input():
    with pytest.raises(ValueError, match="lat must be in"):
        project_local([0.0], [91.0], (0.0, 0.0))
    with pytest.raises(ValueError, match="lon must be in"):
        project_local([181.0], [0.0], (0.0, 0.0))
    with pytest.raises(ValueError, match="same length"):
        project_local([0.0, 1.0], [0.0], (0.0, 0.0))
    with pytest.raises(ValueError, match="origin latitude"):
        project_local([0.0], [0.0], (0.0, 95.0))
    with pytest.raises(ValueError, match="origin"):
        project_local([0.0], [0.0], (0.0,))
    with pytest.raises(ValueError, match="more than the 1000 km"):
        project_local([180.0], [0.0], (0.0, 0.0))
    with pytest.raises(ValueError, match="more than the 1000 km"):
        unproject_local([[0.0, 1.1e6]], (0.0, 0.0))


# --------------------------------------------------------------------------- GeoJSON


def test_read_geojson_points_features_multipoints_and_heights(tmp_path):
    doc = feature_collection(
        {"type": "Point", "coordinates": [8.5, 47.4]},
        {"type": "MultiPoint", "coordinates": [[8.6, 47.3, 410.0], [-0.1, 51.5]]},
    )
    lon, lat = read_geojson_points(write_json(tmp_path, "u.geojson", doc))
    assert lon.tolist() == [8.5, 8.6, -0.1] and lat.tolist() == [47.4, 47.3, 51.5]
    bare = write_json(tmp_path, "p.geojson", {"type": "Point", "coordinates": [1, 2]})
    assert [a.tolist() for a in read_geojson_points(bare)] == [[1.0], [2.0]]
    single = write_json(
        tmp_path,
        "f.geojson",
        {"type": "Feature", "properties": None, "geometry": {"type": "MultiPoint", "coordinates": [[3, 4]]}},
    )
    assert [a.tolist() for a in read_geojson_points(single)] == [[3.0], [4.0]]


@pytest.mark.parametrize(
    ("doc", "pieces"),
    [
        (
            feature_collection(
                {"type": "Point", "coordinates": [0, 0]},
                {"type": "LineString", "coordinates": [[0, 0], [1, 1]]},
            ),
            ["feature 1", "'LineString'", "not supported"],
        ),
        (feature_collection({"type": "Point", "coordinates": [0, 0]}, None), ["feature 1", "no geometry"]),
        (
            feature_collection({"type": "Point", "coordinates": [200.0, 10.0]}),
            ["feature 0", "longitude 200.0"],
        ),
        (feature_collection({"type": "Point", "coordinates": [10.0, -91]}), ["feature 0", "latitude -91"]),
        (feature_collection({"type": "Point", "coordinates": [10.0]}), ["feature 0", "[lon, lat]"]),
        (feature_collection({"type": "Point", "coordinates": ["1", "2"]}), ["feature 0", "[lon, lat]"]),
        (feature_collection(), ["no points"]),
        ({"type": "Polygon", "coordinates": []}, ["'Polygon'", "not supported"]),
        ({"type": "FeatureCollection"}, ["'features' list"]),
        ([1, 2], ["top level", "list"]),
    ],
)
def test_geojson_errors(tmp_path, doc, pieces):
    path = write_json(tmp_path, "bad.geojson", doc)
    with pytest.raises(ValueError, match=r"bad\.geojson") as info:
        read_geojson_points(path)
    for piece in pieces:
        assert piece in str(info.value), (piece, str(info.value))


def test_geojson_invalid_json_names_line_and_column(tmp_path):
    path = write(tmp_path, "bad.geojson", '{"type": "Point",\n "coordinates": [1, 2,]}')
    with pytest.raises(ValueError, match=r"bad\.geojson: invalid JSON at line 2, column"):
        read_geojson_points(path)
    with pytest.raises(ValueError, match="no such GeoJSON file"):
        read_geojson_points(tmp_path / "missing.geojson")


def test_cells_from_geojson_with_a_gbs_file(tmp_path):
    lon0, lat0 = 8.0, 0.0
    (n_lon, e_lon, w_lon), (n_lat, e_lat, w_lat) = place(
        (lon0, lat0), [0.0, 90.0, 270.0], [2000.0, 3000.0, 500.0]
    )
    users = feature_collection(
        {"type": "MultiPoint", "coordinates": [[n_lon, n_lat], [e_lon, e_lat]]},
        {"type": "Point", "coordinates": [w_lon, w_lat]},
    )
    gbs = feature_collection({"type": "Point", "coordinates": [lon0, lat0]})
    out = load_cells_geojson(
        write_json(tmp_path, "users.geojson", users), write_json(tmp_path, "gbs.geojson", gbs), n_cells=2
    )
    assert isinstance(out, ProjectedCells) and out.origin == (lon0, lat0)  # the first GBS
    problem = out.problem
    assert np.allclose(problem.users, [[0.0, 2000.0], [3000.0, 0.0], [-500.0, 0.0]], atol=1e-6)
    assert np.allclose(problem.gbs, [[0.0, 0.0]], atol=1e-6)
    assert problem.active.tolist() == [True, True, False] and problem.bounds is None
    assert problem.n_cells == 2 and problem.R_d == THESIS_TABLE_4_2.R_d
    lon, lat = out.to_lonlat(problem.users)
    assert np.allclose(lon, [n_lon, e_lon, w_lon], atol=1e-9)
    assert np.allclose(lat, [n_lat, e_lat, w_lat], atol=1e-9)


def test_cells_from_geojson_origin_defaults_and_override(tmp_path):
    users = feature_collection({"type": "MultiPoint", "coordinates": [[10.0, 45.0], [10.02, 45.02]]})
    path = write_json(tmp_path, "users.geojson", users)
    out = load_cells_geojson(path, n_cells=1)
    # the centroid of two nearby points is their midpoint (to well under a metre)
    lon0, lat0 = out.origin
    assert geodesic(lon0, lat0, 10.01, 45.01) < 1.0
    assert np.allclose(out.problem.users[0], -out.problem.users[1], atol=1e-3)
    assert np.array_equal(out.problem.gbs, np.array(THESIS_TABLE_4_2.gbs))  # GBS at the origin, in metres
    given = load_cells_geojson(path, n_cells=1, origin=(10.0, 45.0))
    assert given.origin == (10.0, 45.0) and np.allclose(given.problem.users[0], 0.0, atol=1e-6)
    # across the antimeridian the centroid stays near the points, not at lon 0
    across = write_json(
        tmp_path, "a.geojson", {"type": "MultiPoint", "coordinates": [[179.99, 0.0], [-179.99, 0.0]]}
    )
    assert abs(abs(load_cells_geojson(across, n_cells=1).origin[0]) - 180.0) < 1e-9
    with pytest.raises(ValueError, match="origin latitude"):
        load_cells_geojson(path, n_cells=1, origin=(0.0, 100.0))


def test_projected_cells_is_frozen(tmp_path):
    path = write_json(tmp_path, "u.geojson", {"type": "Point", "coordinates": [1.0, 2.0]})
    out = load_cells_geojson(path, n_cells=1)
    with pytest.raises(AttributeError):
        out.origin = (0.0, 0.0)  # type: ignore[misc]


# --------------------------------------------------------------------------- herding


def test_herd_round_trip_and_scenario_layout(tmp_path):
    rng = np.random.default_rng(2)
    animals = rng.uniform((300.0, -100.0), (700.0, 100.0), size=(30, 2))
    path = write_points_csv(tmp_path / "herd.csv", animals)
    assert np.array_equal(load_herd_csv(path), animals)
    sc = herding_scenario_from_csv(path, V_max=20.0)
    assert isinstance(sc, HerdingScenario) and np.array_equal(sc.animals, animals)
    # same layout and parameters as thesis_scenario on the herd's bounding box, shifted there
    lo, hi = animals.min(0), animals.max(0)
    ref = thesis_scenario(30, 0, field_size=tuple(hi - lo), V_max=20.0)
    assert sc.params == ref.params and sc.params.V_max == 20.0
    assert np.allclose(sc.drones, ref.drones + lo) and np.allclose(sc.goal, ref.goal + lo)
    assert np.array_equal(sc.headings, ref.headings)
    assert np.allclose(sc.field, (lo[0], lo[1], hi[0], hi[1]))
    assert np.allclose(sc.drones[:, 0], hi[0] + 80.0)  # 80 m to the right of the herd
    assert np.allclose(sc.goal, ((lo[0] + hi[0]) / 2 - 900.0, (lo[1] + hi[1]) / 2))


def test_herd_scenario_goal_drones_and_degenerate_box(tmp_path):
    path = write_points_csv(tmp_path / "line.csv", [[5.0, 0.0], [5.0, 40.0], [5.0, 20.0]])
    sc = herding_scenario_from_csv(path, goal=(-100.0, 7.0), n_drones=2)
    assert np.array_equal(sc.goal, [-100.0, 7.0]) and sc.drones.shape == (2, 2)
    assert sc.field == pytest.approx((4.5, 0.0, 5.5, 40.0))  # widened to 1 m about the herd


def test_herd_scenario_errors(tmp_path):
    one = write_points_csv(tmp_path / "one.csv", [[1.0, 2.0]])
    with pytest.raises(ValueError, match=r"one\.csv: a herd needs at least 2 animals, got 1"):
        herding_scenario_from_csv(one)
    two = write_points_csv(tmp_path / "two.csv", [[1.0, 2.0], [3.0, 4.0]])
    with pytest.raises(TypeError, match="field_size"):
        herding_scenario_from_csv(two, field_size=(1.0, 1.0))
    with pytest.raises(ValueError, match="V_max"):
        herding_scenario_from_csv(two, V_max=-1.0)
    with pytest.raises(ValueError, match=r"herd\.csv: line 2, column 'x'"):
        load_herd_csv(write(tmp_path, "herd.csv", "x,y\nfoo,1\n"))


# --------------------------------------------------------------------------- shark


def test_shark_track_reproduces_a_trajectory_at_its_sample_times(tmp_path):
    for path_name, traj in thesis_trajectories(duration=10.0).items():
        table = np.column_stack([traj.t, traj.pos])
        path = write_points_csv(tmp_path / f"{path_name}.csv", table, columns=("t", "x", "y", "z"))
        got = load_shark_track_csv(path)
        assert np.array_equal(got.t, traj.t) and np.array_equal(got.pos, traj.pos), path_name
        assert got.name == path_name and got.dt == pytest.approx(0.1)
        # finite-difference velocities: close to the path's exact ones (its speed varies slowly)
        assert np.abs(got.vel - traj.vel).max() < 0.1, path_name


def test_shark_track_resampling_and_defaults(tmp_path):
    # a straight track at 5 m/s sampled every 0.5 s from t = 100 s, no z column
    t = 100.0 + 0.5 * np.arange(9)
    path = write_points_csv(
        tmp_path / "track.csv", np.column_stack([t, 5.0 * (t - 100.0), 0 * t]), ("t", "x", "y")
    )
    got = load_shark_track_csv(path, name="mine")
    assert got.name == "mine" and got.t[0] == 0.0 and got.duration == pytest.approx(4.0)
    assert len(got.t) == 41 and got.dt == pytest.approx(0.1)
    assert np.allclose(got.pos[:, 0], 5.0 * got.t) and np.all(got.pos[:, 2] == DEFAULT_SHARK_DEPTH)
    assert np.allclose(got.vel, [5.0, 0.0, 0.0])
    # the file's own times, and another depth
    raw = load_shark_track_csv(path, dt=None, depth=-1.0)
    assert np.array_equal(raw.t, 0.5 * np.arange(9)) and np.all(raw.pos[:, 2] == -1.0)


def test_shark_track_interpolates_a_known_path(tmp_path):
    # a path sampled every 0.1 s, thinned to every 3rd sample: resampling at 0.1 s reproduces the
    # kept samples exactly and the dropped ones to the path's curvature over 0.3 s
    traj = make_trajectory(lambda t: 0.2 * t, 5.0, -2.0, duration=6.0, dt=0.1)
    keep = np.arange(0, len(traj.t), 3)
    path = write_points_csv(
        tmp_path / "thin.csv", np.column_stack([traj.t[keep], traj.pos[keep]]), ("t", "x", "y", "z")
    )
    got = load_shark_track_csv(path)
    assert np.array_equal(got.t, traj.t)
    assert np.allclose(got.pos[keep], traj.pos[keep], atol=1e-12)
    # chord error of a circle of radius v / omega = 25 m over arcs of 1.5 m: < 1.5^2 / (8 * 25)
    assert np.abs(got.pos - traj.pos).max() < 1.5**2 / (8 * 25.0)


@pytest.mark.parametrize(
    ("text", "pieces"),
    [
        ("t,x,y\n0,0,0\n1,1,0\n1,2,0\n", ["line 4", "column 't'", "strictly increasing"]),
        ("t,x,y\n0,0,0\n\n2,1,0\n1,2,0\n", ["line 5", "column 't'"]),
        ("t,x,y\n0,0,0\n", ["at least 2 samples"]),
        ("t,x,y,z\n0,0,0,-1\n1,1,0,0.5\n", ["line 3", "column 'z'", "above the surface"]),
        ("t,x\n0,0\n1,1\n", ["missing column(s) 'y'"]),
        ("t,x,y\n0,0,0\n0.05,1,0\n", ["shorter than dt"]),
    ],
)
def test_shark_track_errors(tmp_path, text, pieces):
    path = write(tmp_path, "track.csv", text)
    with pytest.raises(ValueError, match=r"track\.csv") as info:
        load_shark_track_csv(path)
    for piece in pieces:
        assert piece in str(info.value), (piece, str(info.value))


def test_shark_track_argument_checks(tmp_path):
    path = write(tmp_path, "track.csv", "t,x,y\n0,0,0\n1,1,0\n")
    with pytest.raises(ValueError, match="dt must be > 0"):
        load_shark_track_csv(path, dt=0.0)
    # a positive dt so small that the resampled track would not fit: the budget names dt
    for tiny in (1e-300, 1e-12):
        with pytest.raises(ValueError, match=r"dt = .* asks for .* more than the limit"):
            load_shark_track_csv(path, dt=tiny)
    with pytest.raises(ValueError, match="depth must be <= 0"):
        load_shark_track_csv(path, depth=1.0)
    with pytest.raises(TypeError, match="name"):
        load_shark_track_csv(path, name=3)  # type: ignore[arg-type]
