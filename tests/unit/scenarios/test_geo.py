"""LocalFrame (scenarios/geo.py): pyproj projections checked against the ellipsoid's geodesics
(pyproj.Geod, Karney's algorithm), published distances, the former hand-written spherical
projection of the loaders, and round trips."""

from __future__ import annotations

import math

import numpy as np
import pyproj
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from droneplan.scenarios.geo import (
    AEQD_MAX_DISTANCE,
    UTM_MAX_OFFSET_DEG,
    LocalFrame,
    check_origin,
    spherical_centroid,
)

GEOD = pyproj.Geod(ellps="WGS84")
EARTH_RADIUS = 6_371_008.8  # the sphere of the former hand-written projection (m)


def sphere_aeqd(lat, lon, lat0, lon0):
    """The loaders' former hand-written projection: azimuthal equidistant on a sphere of radius
    EARTH_RADIUS (kept here as the reference it is compared with)."""
    lam0, phi0 = math.radians(lon0), math.radians(lat0)
    o = np.array([math.cos(phi0) * math.cos(lam0), math.cos(phi0) * math.sin(lam0), math.sin(phi0)])
    e = np.array([-math.sin(lam0), math.cos(lam0), 0.0])
    n = np.array([-math.sin(phi0) * math.cos(lam0), -math.sin(phi0) * math.sin(lam0), math.cos(phi0)])
    lam, phi = np.radians(lon), np.radians(lat)
    p = np.stack([np.cos(phi) * np.cos(lam), np.cos(phi) * np.sin(lam), np.sin(phi)], axis=-1)
    east, north, along = p @ e, p @ n, p @ o
    s = np.hypot(east, north)
    c = np.arctan2(s, along)
    scale = np.divide(c, s, out=np.ones_like(s), where=s > 0)
    return EARTH_RADIUS * scale * east, EARTH_RADIUS * scale * north


def place(lat0, lon0, azimuth_deg, dist):
    """(lat, lon) of points at geodesic distances ``dist`` (m) and azimuths (degrees) from the origin."""
    az = np.atleast_1d(np.asarray(azimuth_deg, dtype=float))
    d = np.broadcast_to(np.asarray(dist, dtype=float), az.shape)
    lon, lat, _ = GEOD.fwd(np.full(az.shape, lon0), np.full(az.shape, lat0), az, d)
    return np.asarray(lat), np.asarray(lon)


# --------------------------------------------------------------------------- published distances


def test_one_degree_along_a_meridian_and_the_equator_matches_published_lengths():
    # WGS 84 lengths of one degree (the classic table): 110 574 m of latitude at the equator,
    # 111 320 m of longitude along the equator, 111 132 m of latitude centred on 45 degrees
    frame = LocalFrame.from_origin(0.0, 0.0)
    x, y = frame.to_local(np.array([1.0, 0.0]), np.array([0.0, 1.0]))
    assert abs(y[0] - 110_574.0) < 1.0 and abs(x[0]) < 1e-6
    assert abs(x[1] - 111_320.0) < 1.0 and abs(y[1]) < 1e-6
    mid = LocalFrame.from_origin(44.5, 10.0)
    _, y = mid.to_local(np.array([45.5]), np.array([10.0]))
    assert abs(y[0] - 111_132.0) < 1.5


def test_distances_from_the_origin_are_geodesic_up_to_the_limit():
    lat0, lon0 = 51.5, -0.13
    az = np.linspace(0.0, 350.0, 36)
    for dist in (1.0, 1_000.0, 100_000.0, AEQD_MAX_DISTANCE * 0.999):
        lat, lon = place(lat0, lon0, az, dist)
        x, y = LocalFrame.from_origin(lat0, lon0).to_local(lat, lon)
        assert np.allclose(np.hypot(x, y), dist, rtol=1e-9, atol=1e-6)
        assert np.allclose(
            np.column_stack([x, y]) / dist,
            np.column_stack([np.sin(np.radians(az)), np.cos(np.radians(az))]),
            atol=1e-7,
        )


@settings(max_examples=100, deadline=None)
@given(
    lat0=st.floats(-85, 85),
    lon0=st.floats(-180, 180),
    az=st.lists(st.floats(0, 360), min_size=2, max_size=6),
    dist=st.lists(st.floats(1.0, 20_000.0), min_size=2, max_size=6),
)
def test_pairwise_distances_within_20_km_match_the_geodesic_to_1e_5(lat0, lon0, az, dist):
    k = min(len(az), len(dist))
    lat, lon = place(lat0, lon0, az[:k], dist[:k])
    x, y = LocalFrame.from_origin(lat0, lon0).to_local(lat, lon)
    i, j = np.triu_indices(k, 1)
    planar = np.hypot(x[i] - x[j], y[i] - y[j])
    geodesic = np.asarray(GEOD.inv(lon[i], lat[i], lon[j], lat[j])[2])
    # the scale error across the radius is c^2 / 6 for central angle c: 1.7e-6 at 20 km
    assert np.all(np.abs(planar - geodesic) <= 1e-5 * geodesic + 1e-6)


# --------------------------------------------------------------------------- the former projection


@settings(max_examples=100, deadline=None)
@given(
    lat0=st.floats(-85, 85),
    lon0=st.floats(-180, 180),
    az=st.lists(st.floats(0, 360), min_size=1, max_size=6),
    dist=st.floats(1.0, 50_000.0),
)
def test_agrees_with_the_former_spherical_projection_within_0_6_percent(lat0, lon0, az, dist):
    # the sphere of radius R1 and the WGS 84 ellipsoid differ in radius of curvature by at most
    # 0.56 % (meridian radius 6 335 km at the equator, 6 400 km at the poles), so a position
    # differs by at most 0.6 % of its distance from the origin
    lat, lon = place(lat0, lon0, az, dist)
    x, y = LocalFrame.from_origin(lat0, lon0).to_local(lat, lon)
    xs, ys = sphere_aeqd(lat, lon, lat0, lon0)
    assert np.all(np.hypot(x - xs, y - ys) <= 0.006 * np.hypot(xs, ys) + 1e-6)


def test_the_loaders_project_through_local_frame():
    from droneplan.scenarios.loaders import project_local, unproject_local

    lat, lon = place(47.0, 8.0, [10.0, 200.0], [500.0, 3000.0])
    x, y = LocalFrame.from_origin(47.0, 8.0).to_local(lat, lon)
    assert np.array_equal(project_local(lon, lat, (8.0, 47.0)), np.column_stack([x, y]))
    back_lon, back_lat = unproject_local(np.column_stack([x, y]), (8.0, 47.0))
    assert np.allclose(back_lat, lat, atol=1e-10) and np.allclose(back_lon, lon, atol=1e-10)


# --------------------------------------------------------------------------- round trips

origins = st.tuples(st.floats(-89.9, 89.9), st.floats(-180, 180))


@settings(max_examples=150, deadline=None)
@given(
    origin=origins,
    pts=st.lists(st.tuples(st.floats(-6e5, 6e5), st.floats(-6e5, 6e5)), min_size=1, max_size=8),
)
def test_aeqd_local_to_wgs84_and_back_round_trips_to_a_millimetre(origin, pts):
    frame = LocalFrame.from_origin(*origin)
    xy = np.array(pts)
    lat, lon = frame.to_wgs84(xy[:, 0], xy[:, 1])
    assert np.all(np.abs(lat) <= 90) and np.all(np.abs(lon) <= 180)
    x, y = frame.to_local(lat, lon)
    # PROJ snaps a point within 0.7 mm of the origin onto it
    assert np.allclose(np.column_stack([x, y]), xy, rtol=0, atol=1e-3)


@settings(max_examples=100, deadline=None)
@given(
    origin=st.tuples(st.floats(-70, 70), st.floats(-180, 180)),
    pts=st.lists(st.tuples(st.floats(-1e5, 1e5), st.floats(-1e5, 1e5)), min_size=1, max_size=8),
)
def test_utm_local_to_wgs84_and_back_round_trips(origin, pts):
    # within 70 degrees of the equator, 100 km stays within 2.7 degrees of longitude of the origin,
    # so inside the zone's usable band (the origin is at most 3 degrees from the central meridian)
    frame = LocalFrame.from_origin(*origin, crs="utm")
    xy = np.array(pts)
    lat, lon = frame.to_wgs84(xy[:, 0], xy[:, 1])
    x, y = frame.to_local(lat, lon)
    assert np.allclose(np.column_stack([x, y]), xy, rtol=0, atol=1e-3)


def test_an_origin_next_to_the_equator_is_exact_to_a_millimetre():
    # PROJ puts an aeqd centre within 1e-10 rad of the equator on it in some formulas only;
    # the frame puts it there for all of them
    for lat0 in (1e-9, -3e-10, 5e-9):
        frame = LocalFrame.from_origin(lat0, 0.0)
        lat, lon = place(lat0, 0.0, [0.0, 90.0, 225.0], [0.0, 10.0, 5000.0])
        x, y = frame.to_local(lat, lon)
        assert np.allclose(np.hypot(x, y), [0.0, 10.0, 5000.0], rtol=0, atol=1e-3)
        back_lat, back_lon = frame.to_wgs84(x, y)
        assert np.all(np.asarray(GEOD.inv(lon, lat, back_lon, back_lat)[2]) <= 1e-3)


def test_utm_frame_is_the_zone_shifted_to_the_origin():
    frame = LocalFrame.from_origin(47.0, 8.0, 400.0, crs="utm")
    assert frame.crs.to_epsg() == 32632 and frame.origin == (47.0, 8.0, 400.0) and frame.kind == "utm"
    utm = pyproj.Transformer.from_crs("EPSG:4326", "EPSG:32632", always_xy=True)
    e0, n0 = utm.transform(8.0, 47.0)
    e1, n1 = utm.transform(8.1, 47.05)
    x, y = frame.to_local(47.05, 8.1)
    assert abs(float(x) - (e1 - e0)) < 1e-6 and abs(float(y) - (n1 - n0)) < 1e-6
    rebuilt = LocalFrame(frame.origin, frame.crs, frame.kind, frame.description, frame.offset)
    assert rebuilt == frame and rebuilt.to_local(47.05, 8.1) == (x, y)  # transformers made on the spot
    south = LocalFrame.from_origin(-33.9, 18.4, crs="utm")
    assert south.crs.to_epsg() == 32734
    assert np.allclose(south.to_local(-33.9, 18.4), 0.0, atol=1e-6)


def test_a_named_projected_crs_is_shifted_to_the_origin():
    frame = LocalFrame.from_origin(46.95, 7.45, crs="EPSG:2056")  # Swiss LV95, metres
    assert frame.kind == "crs" and np.allclose(frame.to_local(46.95, 7.45), 0.0, atol=1e-6)
    lat, lon = place(46.95, 7.45, [45.0], [1000.0])
    x, y = frame.to_local(lat, lon)
    assert abs(math.hypot(float(x[0]), float(y[0])) - 1000.0) < 1.0  # LV95's scale error is tiny here
    with pytest.raises(ValueError, match="lat, lon: a point lies outside the area of use"):
        frame.to_local(40.0, 7.45)


def test_arrays_keep_their_shape():
    frame = LocalFrame.from_origin(10.0, 20.0)
    lat = np.full((2, 3), 10.01)
    lon = np.full((2, 3), 20.0)
    x, y = frame.to_local(lat, lon)
    assert x.shape == (2, 3) and y.shape == (2, 3)
    back = frame.to_wgs84(x, y)
    assert back[0].shape == (2, 3) and np.allclose(back[0], lat, atol=1e-12)


# --------------------------------------------------------------------------- choosing a frame


def test_for_points_chooses_aeqd_for_a_local_set_and_utm_for_a_long_one():
    local = LocalFrame.for_points([47.0, 47.1, 46.9], [8.0, 8.2, 7.9])
    assert local.kind == "aeqd" and "chosen" in local.description
    assert abs(local.origin[0] - 47.0) < 0.1 and abs(local.origin[1] - 8.03) < 0.1
    long = LocalFrame.for_points([40.0, 60.0], [8.0, 9.0])  # 2200 km north-south, in one zone
    assert long.kind == "utm" and "UTM zone 32N" in long.description
    with pytest.raises(ValueError, match="lat, lon: the points reach"):
        LocalFrame.for_points([0.0, 0.0], [0.0, 40.0])
    with pytest.raises(ValueError, match="lat, lon: the points are spread over the globe"):
        spherical_centroid(np.array([0.0, 0.0]), np.array([0.0, 180.0]))


# --------------------------------------------------------------------------- refusals


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"lat": 91.0, "lon": 0.0}, "lat must be a latitude in"),
        ({"lat": 0.0, "lon": -181.0}, "lon must be a longitude in"),
        ({"lat": float("nan"), "lon": 0.0}, "lat must be finite"),
        ({"lat": 0.0, "lon": float("inf")}, "lon must be finite"),
        ({"lat": 0.0, "lon": 0.0, "alt": float("nan")}, "alt must be finite"),
        ({"lat": 0.0, "lon": 0.0, "crs": "EPSG:999999"}, "crs: pyproj does not know"),
        ({"lat": 0.0, "lon": 0.0, "crs": "no such projection"}, "crs: pyproj does not know"),
        ({"lat": 0.0, "lon": 0.0, "crs": "EPSG:4326"}, "crs: 'WGS 84' is not a projected CRS"),
        ({"lat": 0.0, "lon": 0.0, "crs": "EPSG:2263"}, "crs: .* has axes in"),  # US survey feet
        ({"lat": 85.0, "lon": 0.0, "crs": "utm"}, "lat: UTM covers latitudes"),
    ],
)
def test_from_origin_refuses_bad_input_in_one_line_naming_the_field(kwargs, message):
    with pytest.raises(ValueError, match=message) as info:
        LocalFrame.from_origin(**kwargs)
    assert "\n" not in str(info.value)


def test_data_beyond_the_projection_is_refused():
    frame = LocalFrame.from_origin(0.0, 0.0)
    with pytest.raises(
        ValueError, match=r"lat, lon: a point is .* km from the origin, more than the 1000 km"
    ):
        frame.to_local([0.0, 10.0], [0.0, 0.0])
    with pytest.raises(ValueError, match=r"x, y: a point is .* more than the 1000 km"):
        frame.to_wgs84([0.0], [AEQD_MAX_DISTANCE * 1.01])
    utm = LocalFrame.from_origin(0.0, 8.0, crs="utm")
    with pytest.raises(ValueError, match=r"lat, lon: a point is .* degrees of longitude"):
        utm.to_local([0.0], [9.0 + UTM_MAX_OFFSET_DEG + 0.5])
    with pytest.raises(ValueError, match="lat must be in"):
        frame.to_local([95.0], [0.0])
    with pytest.raises(ValueError, match="lat and lon must have the same shape"):
        frame.to_local([0.0, 0.1], [0.0])
    with pytest.raises(TypeError, match="lat must be real numbers"):
        frame.to_local(["a"], [0.0])


def test_check_origin_names_the_field():
    assert check_origin((47.0, 8.0)) == (47.0, 8.0, 0.0)
    assert check_origin(LocalFrame.from_origin(1.0, 2.0, 3.0)) == (1.0, 2.0, 3.0)
    with pytest.raises(ValueError, match="origin latitude must be a latitude"):
        check_origin((95.0, 0.0, 0.0))
    with pytest.raises(ValueError, match="origin must be"):
        check_origin((1.0,))
    with pytest.raises(TypeError, match="origin must be"):
        check_origin("47,8")
