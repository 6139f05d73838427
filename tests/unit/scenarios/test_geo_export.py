"""Plans and traces as GeoJSON / GeoDataFrames in WGS 84 (scenarios/geo_export.py), and the
loaders' GeoDataFrame inputs (users, stations, no-fly polygons in any CRS)."""

from __future__ import annotations

import json
import sys

import numpy as np
import pyproj
import pytest
from shapely.geometry import Point, Polygon

import droneplan as dp
from droneplan.scenarios.geo import LocalFrame
from droneplan.scenarios.geo_export import CIRCLE_VERTICES, DEFAULT_ALTITUDE
from droneplan.scenarios.loaders import load_cells_geojson

ORIGIN = (47.0, 8.0, 400.0)
FRAME = LocalFrame.from_origin(*ORIGIN)
GEOD = pyproj.Geod(ellps="WGS84")


def local(coords):
    """Local (x, y) metres of GeoJSON positions [lon, lat(, h)]."""
    c = np.asarray(coords, dtype=float)
    x, y = FRAME.to_local(c[:, 1], c[:, 0])
    return np.column_stack([x, y])


def by_kind(doc, kind):
    return [f for f in doc["features"] if f["properties"]["kind"] == kind]


# --------------------------------------------------------------------------- cells


def test_a_cells_placement_gives_points_circles_and_backhaul_links(cells):
    problem, plan = cells
    doc = dp.to_geojson(plan, origin=ORIGIN, problem=problem)
    json.dumps(doc, allow_nan=False)  # valid JSON: no NaN anywhere
    assert doc["type"] == "FeatureCollection"
    sites = by_kind(doc, "drone_cell")
    assert len(sites) == len(plan)
    for j, site in enumerate(sites):
        lon, lat, height = site["geometry"]["coordinates"]
        assert np.allclose(local([[lon, lat]]), plan[j], atol=1e-6)
        assert height == pytest.approx(ORIGIN[2] + DEFAULT_ALTITUDE)
        assert site["properties"]["radius_m"] == problem.R_d
    for j, circle in enumerate(by_kind(doc, "coverage")):
        ring = circle["geometry"]["coordinates"][0]
        assert len(ring) == CIRCLE_VERTICES + 1 and ring[0] == ring[-1]
        # every vertex is R_d from the cell's centre, in local metres and along the ellipsoid
        assert np.allclose(np.hypot(*(local(ring) - plan[j]).T), problem.R_d, atol=1e-6)
        c_lat, c_lon = FRAME.to_wgs84(plan[j, 0], plan[j, 1])
        ring_arr = np.array(ring)
        dist = GEOD.inv(np.full(len(ring), c_lon), np.full(len(ring), c_lat), ring_arr[:, 0], ring_arr[:, 1])[
            2
        ]
        assert np.allclose(dist, problem.R_d, rtol=1e-4)
    links = by_kind(doc, "backhaul")
    ground = np.asarray(problem.gbs)
    expected = sum(np.linalg.norm(plan[j] - g) <= problem.r1 for j in range(len(plan)) for g in ground)
    expected += sum(
        np.linalg.norm(plan[j] - plan[k]) <= problem.r2
        for j in range(len(plan))
        for k in range(j + 1, len(plan))
    )
    assert len(links) == expected >= 1
    for link in links:
        ends = local(link["geometry"]["coordinates"])
        assert np.linalg.norm(ends[1] - ends[0]) == pytest.approx(link["properties"]["length_m"], abs=1e-6)
    users = by_kind(doc, "user")
    assert len(users) == len(problem.users) and len(by_kind(doc, "gbs")) == len(problem.gbs)
    covered = sum(u["properties"]["covered"] for u in users)
    within = (
        np.hypot(*(problem.users[:, None, :] - plan[None, :, :]).transpose(2, 0, 1)) <= problem.R_d
    ).any(axis=1)
    assert covered == int(within.sum())


def test_a_solve_result_exports_like_its_plan(cells):
    problem, plan = cells
    result = dp.SolveResult(status=dp.Status.FEASIBLE, objective=1.0, x=plan, backend="greedy")
    assert dp.to_geojson(result, origin=ORIGIN, problem=problem) == dp.to_geojson(
        plan, origin=ORIGIN, problem=problem
    )
    failed = dp.SolveResult(status=dp.Status.NO_SOLUTION, objective=None, x=None, backend="greedy")
    with pytest.raises(ValueError, match="plan_or_trace: the result has no solution"):
        dp.to_geojson(failed, origin=ORIGIN, problem=problem)


def test_altitude_levels_give_each_cell_its_height_and_radius():
    channel = dp.cells.AirToGround()
    problem = dp.cells.thesis_problem(n_cells=2, seed=0)
    levels = [100.0, 300.0]
    leveled = dp.cells.CellProblem(
        problem.users,
        problem.gbs,
        2,
        problem.R_d,
        problem.R_g,
        problem.r1,
        problem.r2,
        altitudes=levels,
        channel=channel,
    )
    plan = np.array([[800.0, -3000.0, 100.0], [2500.0, -800.0, 300.0]])
    doc = dp.to_geojson(plan, origin=ORIGIN, problem=leveled)
    sites = by_kind(doc, "drone_cell")
    assert [s["properties"]["altitude_m"] for s in sites] == levels
    assert [s["geometry"]["coordinates"][2] for s in sites] == [ORIGIN[2] + h for h in levels]
    assert [s["properties"]["radius_m"] for s in sites] == list(leveled.level_radii)
    with pytest.raises(ValueError, match="plan_or_trace: an altitude is not one of the problem's levels"):
        dp.to_geojson(np.array([[0.0, 0.0, 150.0]]), origin=ORIGIN, problem=leveled)


def test_cells_export_refuses_bad_input(cells):
    problem, plan = cells
    with pytest.raises(ValueError, match="problem: a cells placement needs its CellProblem"):
        dp.to_geojson(plan, origin=ORIGIN)
    with pytest.raises(TypeError, match="problem must be the CellProblem"):
        dp.to_geojson(plan, origin=ORIGIN, problem="x")
    with pytest.raises(ValueError, match=r"plan_or_trace: a placement of this problem is a \(k, 2\) array"):
        dp.to_geojson(np.zeros((2, 3)), origin=ORIGIN, problem=problem)
    with pytest.raises(ValueError, match="origin latitude must be a latitude"):
        dp.to_geojson(plan, origin=(91.0, 0.0, 0.0), problem=problem)
    with pytest.raises(ValueError, match="origin must be given"):
        dp.to_geojson(plan, problem=problem)
    with pytest.raises(ValueError, match="altitude must be in"):
        dp.to_geojson(plan, origin=ORIGIN, problem=problem, altitude=-1.0)
    with pytest.raises(TypeError, match="plan_or_trace must be a cells placement"):
        dp.to_geojson(object(), origin=ORIGIN)


# --------------------------------------------------------------------------- traces


@pytest.mark.parametrize(
    ("problem", "names", "positions"),
    [
        ("covert", ["drone", "target 0"], lambda tr: [tr.drone, tr.targets[:, 0]]),
        ("shark", ["operator", "shark"], lambda tr: [tr.operator, tr.shark]),
    ],
)
def test_a_3d_trace_gives_one_timed_line_string_per_body(traces, problem, names, positions):
    trace = traces[problem]
    doc = dp.to_geojson(trace, origin=ORIGIN)
    json.dumps(doc, allow_nan=False)
    paths = by_kind(doc, "path")
    assert [p["properties"]["name"] for p in paths][: len(names)] == names
    for path, xyz in zip(paths, positions(trace), strict=False):
        coords = np.array(path["geometry"]["coordinates"])
        assert path["geometry"]["type"] == "LineString" and coords.shape == (len(trace.t), 3)
        assert np.allclose(local(coords), xyz[:, :2], atol=1e-6)
        assert np.allclose(coords[:, 2], ORIGIN[2] + xyz[:, 2])
        assert path["properties"]["times_s"] == [float(t) for t in trace.t]
    assert paths[0]["properties"]["flown"] and not paths[1]["properties"]["flown"]


def test_a_herding_trace_gives_each_drone_the_centroid_and_the_goal(traces):
    trace = traces["herding"]
    doc = dp.to_geojson(trace, origin=ORIGIN, altitude=30.0)
    paths = by_kind(doc, "path")
    n_drones = trace.drones.shape[1]
    assert [p["properties"]["name"] for p in paths] == [f"drone {i}" for i in range(n_drones)] + [
        "herd centroid"
    ]
    for i in range(n_drones):
        coords = np.array(paths[i]["geometry"]["coordinates"])
        assert np.allclose(local(coords), trace.drones[:, i], atol=1e-6)
        assert np.allclose(coords[:, 2], ORIGIN[2] + 30.0)
    (goal,) = by_kind(doc, "goal")
    assert np.allclose(local([goal["geometry"]["coordinates"]]), trace.goal, atol=1e-6)


def test_geodataframes_hold_the_same_features_in_wgs84(cells, traces):
    problem, plan = cells
    gdf = dp.to_geodataframe(plan, origin=ORIGIN, problem=problem)
    assert gdf.crs.to_epsg() == 4326
    doc = dp.to_geojson(plan, origin=ORIGIN, problem=problem)
    assert list(gdf["kind"]) == [f["properties"]["kind"] for f in doc["features"]]
    sites = gdf[gdf["kind"] == "drone_cell"]
    assert np.allclose(local(np.column_stack([sites.geometry.x, sites.geometry.y])), plan, atol=1e-6)
    tracks = dp.to_geodataframe(traces["shark"], origin=FRAME)
    assert list(tracks.geom_type) == ["LineString", "LineString"]
    assert len(tracks.iloc[0]["times_s"]) == len(traces["shark"].t)


# --------------------------------------------------------------------------- geopandas optional


def test_the_core_works_without_geopandas(monkeypatch, tmp_path, cells):
    problem, plan = cells
    monkeypatch.setitem(sys.modules, "geopandas", None)  # `import geopandas` now fails
    path = tmp_path / "users.geojson"
    path.write_text(json.dumps({"type": "MultiPoint", "coordinates": [[8.0, 47.0], [8.01, 47.01]]}))
    assert load_cells_geojson(path, n_cells=1).problem.users.shape == (2, 2)
    assert by_kind(dp.to_geojson(plan, origin=ORIGIN, problem=problem), "drone_cell")
    assert dp.export_mission(plan, tmp_path / "m.wpl", origin=ORIGIN, problem=problem)
    with pytest.raises(ImportError, match=r'pip install -e "\.\[geo\]"'):
        dp.to_geodataframe(plan, origin=ORIGIN, problem=problem)


# --------------------------------------------------------------------------- GeoDataFrame inputs


def test_loaders_read_geodataframes_in_any_crs(tmp_path):
    geopandas = pytest.importorskip("geopandas")
    lonlat = np.array([[8.0, 47.0], [8.02, 47.01], [7.99, 46.98]])
    path = tmp_path / "users.geojson"
    path.write_text(json.dumps({"type": "MultiPoint", "coordinates": lonlat.tolist()}))
    from_file = load_cells_geojson(path, n_cells=2, origin=(8.0, 47.0))
    mercator = geopandas.GeoDataFrame(geometry=[Point(*p) for p in lonlat], crs="EPSG:4326").to_crs(3857)
    gbs = geopandas.GeoSeries([Point(8.0, 47.0)], crs="EPSG:4326").to_crs(2056)
    zone = Polygon([(8.005, 47.005), (8.01, 47.005), (8.01, 47.01), (8.005, 47.01)])
    no_fly = geopandas.GeoDataFrame(geometry=[zone], crs="EPSG:4326").to_crs(32632)
    out = load_cells_geojson(mercator, gbs, n_cells=2, origin=(8.0, 47.0), no_fly=no_fly)
    assert np.allclose(out.problem.users, from_file.problem.users, atol=1e-4)
    assert np.allclose(out.problem.gbs, [[0.0, 0.0]], atol=5e-3)  # LV95's datum shift, there and back
    (poly,) = out.problem.no_fly
    x, y = FRAME.to_local(np.array([47.005, 47.01]), np.array([8.005, 8.01]))
    assert np.allclose(poly.bounds, [x[0], y[0], x[1], y[1]], atol=0.5)  # edges bend slightly in UTM
    with pytest.raises(ValueError, match="users: the GeoDataFrame has no CRS"):
        load_cells_geojson(geopandas.GeoDataFrame(geometry=[Point(8.0, 47.0)]), n_cells=1)
    with pytest.raises(ValueError, match="users: row 0: geometry type 'Polygon' is not supported"):
        load_cells_geojson(no_fly, n_cells=1)
    with pytest.raises(ValueError, match="no_fly: row 0: geometry type 'Point' is not supported"):
        load_cells_geojson(mercator, n_cells=1, no_fly=mercator)
    with pytest.raises(TypeError, match="no_fly must be a geopandas GeoDataFrame"):
        load_cells_geojson(mercator, n_cells=1, no_fly=[zone])


def test_projected_cells_give_their_frame(tmp_path):
    path = tmp_path / "users.geojson"
    path.write_text(json.dumps({"type": "MultiPoint", "coordinates": [[8.0, 47.0], [8.01, 47.01]]}))
    projected = load_cells_geojson(path, n_cells=1, origin=(8.0, 47.0))
    assert projected.frame.origin == (47.0, 8.0, 0.0)
    plan = np.array([[300.0, 400.0]])
    doc = dp.to_geojson(plan, problem=projected)  # the origin comes from the ProjectedCells
    lon, lat, _ = by_kind(doc, "drone_cell")[0]["geometry"]["coordinates"]
    assert np.allclose(projected.to_lonlat(plan), ([lon], [lat]), atol=1e-12)


def test_user_tracks_read_from_a_geodataframe_in_any_crs_equal_the_csv_in_degrees(tmp_path):
    geopandas = pytest.importorskip("geopandas")
    rng = np.random.default_rng(5)
    rows = [
        (i, t, 8.0 + rng.uniform(-0.02, 0.02), 47.0 + rng.uniform(-0.02, 0.02))
        for t in (0, 60, 120)
        for i in (3, 7)
    ]
    csv = tmp_path / "tracks.csv"
    csv.write_text(
        "id,t,lon,lat\n" + "".join(f"{i},{t},{lon!r},{lat!r}\n" for i, t, lon, lat in rows), encoding="utf-8"
    )
    frame = geopandas.GeoDataFrame(
        {"id": [r[0] for r in rows], "t": [r[1] for r in rows]},
        geometry=[Point(r[2], r[3]) for r in rows],
        crs="EPSG:4326",
    ).to_crs(2056)  # the Swiss grid: another CRS, in metres
    expected = dp.cells.read_user_tracks(csv, origin=(8.0, 47.0))
    got = dp.cells.read_user_tracks(frame, origin=(8.0, 47.0))
    assert np.array_equal(got[0], expected[0]) and np.array_equal(got[1], expected[1])
    assert np.allclose(got[2], expected[2], atol=1e-3)  # metres, after two reprojections
    with pytest.raises(ValueError, match=r"^path: the GeoDataFrame has no column t"):
        dp.cells.read_user_tracks(frame.drop(columns=["t"]))
