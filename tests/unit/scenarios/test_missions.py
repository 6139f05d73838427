"""Mission files (scenarios/missions.py, ``dp.export_mission``): every ``.wpl`` read back with
pymavlink's waypoint loader, every ``.plan`` checked against QGroundControl's plan-file fields,
every ``.kml`` parsed as XML; positions round-trip to local metres within 0.1 m."""

from __future__ import annotations

import dataclasses
import itertools
import json
import os
import tempfile
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from pymavlink import mavwp

import droneplan as dp
from droneplan.scenarios import missions
from droneplan.scenarios.geo import LocalFrame
from droneplan.scenarios.missions import (
    DO_CHANGE_SPEED,
    NAV_LOITER_UNLIM,
    NAV_TAKEOFF,
    NAV_WAYPOINT,
    douglas_peucker,
)

ORIGIN = (-33.86, 151.21, 25.0)  # south and east: negative latitudes are written right too
FRAME = LocalFrame.from_origin(*ORIGIN)
ROUND_TRIP = 0.1  # m


def read_wpl(path):
    """(command, frame, params, local xyz) of every item after home, read by pymavlink."""
    loader = mavwp.MAVWPLoader()
    count = loader.load(str(path))
    items = [loader.wp(i) for i in range(count)]
    home = items[0]
    assert (home.x, home.y, home.z) == ORIGIN  # line 0: home, absolute altitude
    out = []
    for w in items[1:]:
        if w.frame == 3:
            x, y = FRAME.to_local(w.x, w.y)
            xyz = np.array([float(x), float(y), w.z])
        else:
            xyz = None
        out.append((w.command, w.frame, (w.param1, w.param2, w.param3, w.param4), xyz))
    return out


PLAN_FIELDS = {"fileType", "version", "groundStation", "mission", "geoFence", "rallyPoints"}
MISSION_FIELDS = {
    "version",
    "firmwareType",
    "vehicleType",
    "cruiseSpeed",
    "hoverSpeed",
    "items",
    "plannedHomePosition",
}
ITEM_FIELDS = {"autoContinue", "command", "doJumpId", "frame", "params", "type"}


def read_plan(path):
    """The same tuples from a QGroundControl .plan file, after checking its required fields."""
    doc = json.loads(path.read_text())
    assert set(doc) >= PLAN_FIELDS and doc["fileType"] == "Plan"
    mission = doc["mission"]
    assert set(mission) >= MISSION_FIELDS and mission["plannedHomePosition"] == list(ORIGIN)
    assert mission["cruiseSpeed"] > 0 and mission["hoverSpeed"] > 0
    assert {"circles", "polygons", "version"} <= set(doc["geoFence"]) and "points" in doc["rallyPoints"]
    out = []
    for jump, item in enumerate(mission["items"], start=1):
        assert set(item) >= ITEM_FIELDS and item["type"] == "SimpleItem" and item["doJumpId"] == jump
        assert item["autoContinue"] is True and len(item["params"]) == 7
        p = item["params"]
        if item["frame"] == 3:
            x, y = FRAME.to_local(p[4], p[5])
            xyz = np.array([float(x), float(y), p[6]])
        else:
            xyz = None
        out.append((item["command"], item["frame"], tuple(p[:4]), xyz))
    return out


def read_kml(path):
    """Local xyz of the placemarks (one per navigation item) and of the path's vertices."""
    ns = {"k": "http://www.opengis.net/kml/2.2"}
    root = ET.parse(path).getroot()

    def xyz(text):
        pts = np.array([[float(v) for v in c.split(",")] for c in text.split()])
        x, y = FRAME.to_local(pts[:, 1], pts[:, 0])
        return np.column_stack([x, y, pts[:, 2] - ORIGIN[2]])

    line = root.find(".//k:LineString/k:coordinates", ns)
    points = [xyz(p.text)[0] for p in root.findall(".//k:Point/k:coordinates", ns)]
    return xyz(line.text), np.array(points)


# --------------------------------------------------------------------------- cells


@pytest.mark.parametrize("fmt", ["wpl", "plan"])
def test_a_cells_plan_gives_one_mission_per_cell(tmp_path, cells, fmt):
    problem, plan = cells
    paths = dp.export_mission(
        plan, tmp_path / f"m.{fmt}", fmt, origin=ORIGIN, problem=problem, altitude=120.0
    )
    assert paths == [tmp_path / f"m_cell{j}.{fmt}" for j in range(len(plan))]
    assert sorted(os.listdir(tmp_path)) == sorted(p.name for p in paths)  # no temporary file left
    for j, path in enumerate(paths):
        items = read_wpl(path) if fmt == "wpl" else read_plan(path)
        assert [c for c, *_ in items] == [NAV_TAKEOFF, DO_CHANGE_SPEED, NAV_WAYPOINT, NAV_LOITER_UNLIM]
        takeoff, speed, fly, loiter = items
        assert np.allclose(takeoff[3], [0.0, 0.0, 120.0], atol=ROUND_TRIP)  # up from home
        assert speed[2][:3] == (1.0, missions.DEFAULT_SPEED, -1.0)
        site = np.array([*plan[j], 120.0])
        assert np.allclose(fly[3], site, atol=ROUND_TRIP) and np.allclose(loiter[3], site, atol=ROUND_TRIP)


def test_one_cell_goes_to_the_path_itself_and_kml_holds_its_flight(tmp_path, cells):
    problem, plan = cells
    one = plan[:1]
    (path,) = dp.export_mission(one, tmp_path / "one.kml", "kml", origin=ORIGIN, problem=problem)
    assert path == tmp_path / "one.kml"
    line, points = read_kml(path)
    site = np.array([*one[0], missions.DEFAULT_ALTITUDE])
    assert np.allclose(line, [[0.0, 0.0, site[2]], site, site], atol=ROUND_TRIP)
    assert np.allclose(points, line, atol=ROUND_TRIP)


def test_a_solve_result_and_a_projected_problem_are_accepted(tmp_path, cells):
    problem, plan = cells
    result = dp.SolveResult(status=dp.Status.FEASIBLE, objective=1.0, x=plan[:1], backend="greedy")
    (path,) = dp.export_mission(result, tmp_path / "r.wpl", origin=FRAME, problem=problem)
    assert np.allclose(read_wpl(path)[2][3][:2], plan[0], atol=ROUND_TRIP)


@settings(max_examples=40, deadline=None)
@given(
    origin=st.tuples(st.floats(-80, 80), st.floats(-180, 180), st.floats(-100, 4000)),
    sites=st.lists(st.tuples(st.floats(-5e4, 5e4), st.floats(-5e4, 5e4)), min_size=1, max_size=3),
    altitude=st.floats(0.0, 500.0),
    fmt=st.sampled_from(["wpl", "plan"]),
)
def test_sites_anywhere_round_trip_through_the_files(origin, sites, altitude, fmt):
    problem = dp.cells.CellProblem([[0.0, 0.0]], [[0.0, 0.0]], len(sites), 100.0, 100.0, 200.0, 200.0)
    plan = np.array(sites)
    frame = LocalFrame.from_origin(*origin)
    with tempfile.TemporaryDirectory() as folder:
        paths = dp.export_mission(
            plan, Path(folder) / f"m.{fmt}", fmt, origin=frame, problem=problem, altitude=altitude
        )
        for site, path in zip(plan, paths, strict=True):
            if fmt == "wpl":
                loader = mavwp.MAVWPLoader()
                loader.load(str(path))
                item = loader.wp(loader.count() - 1)
                lat, lon, alt = item.x, item.y, item.z
            else:
                lat, lon, alt = json.loads(path.read_text())["mission"]["items"][-1]["params"][4:]
            x, y = frame.to_local(lat, lon)
            assert np.allclose([x, y, alt], [*site, altitude], rtol=0, atol=ROUND_TRIP)


# --------------------------------------------------------------------------- traces


def distance_to_polyline(points, line):
    """Distance (m) of each point to the nearest segment of a polyline (3-D)."""
    if len(line) == 1:
        return np.linalg.norm(points - line[0], axis=1)
    a, b = line[:-1], line[1:]
    ab = b - a
    length2 = np.maximum((ab * ab).sum(axis=1), 1e-300)
    s = np.clip(((points[:, None, :] - a[None]) * ab[None]).sum(axis=2) / length2[None], 0.0, 1.0)
    nearest = a[None] + s[..., None] * ab[None]
    return np.linalg.norm(points[:, None, :] - nearest, axis=2).min(axis=1)


@pytest.mark.parametrize(("problem", "tolerance"), [("covert", 0.5), ("shark", 1.0), ("shark", 5.0)])
@pytest.mark.parametrize("fmt", ["wpl", "plan", "kml"])
def test_a_3d_trace_gives_thinned_waypoints_with_speeds(tmp_path, traces, problem, tolerance, fmt):
    trace = traces[problem]
    flown = trace.drone if problem == "covert" else trace.operator
    (path,) = dp.export_mission(trace, tmp_path / f"t.{fmt}", fmt, origin=ORIGIN, tolerance=tolerance)
    if fmt == "kml":
        line, points = read_kml(path)
        assert np.allclose(points, line, atol=ROUND_TRIP)  # one placemark per navigation item
        waypoints = line[1:]  # after the take-off
    else:
        items = read_wpl(path) if fmt == "wpl" else read_plan(path)
        assert items[0][0] == NAV_TAKEOFF and np.allclose(items[0][3], flown[0], atol=ROUND_TRIP)
        waypoints = np.array([xyz for c, _, _, xyz in items if c == NAV_WAYPOINT])
        speeds = [p[1] for c, _, p, _ in items if c == DO_CHANGE_SPEED]
        assert speeds and all(missions.MIN_SPEED <= s <= missions.MAX_SPEED for s in speeds)
        # the first leg's speed is the recorded path length over its duration
        kept = douglas_peucker(flown, tolerance)
        leg = np.linalg.norm(np.diff(flown[kept[0] : kept[1] + 1], axis=0), axis=1).sum()
        assert speeds[0] == pytest.approx(
            max(leg / (trace.t[kept[1]] - trace.t[kept[0]]), missions.MIN_SPEED)
        )
    # waypoints are recorded positions, first and last included, within 0.1 m after the round trip
    gaps = np.linalg.norm(waypoints[:, None, :] - flown[None, :, :], axis=2).min(axis=1)
    assert np.all(gaps <= ROUND_TRIP)
    assert np.allclose(waypoints[0], flown[0], atol=ROUND_TRIP) and np.allclose(
        waypoints[-1], flown[-1], atol=ROUND_TRIP
    )
    # every recorded position lies within the tolerance of the waypoints' line
    assert np.all(distance_to_polyline(flown, waypoints) <= tolerance + ROUND_TRIP)
    assert len(waypoints) < len(flown)


def test_a_trace_that_starts_on_the_ground_takes_off_to_a_metre(tmp_path, traces):
    trace = traces["covert"]
    low = trace.drone - np.array([0.0, 0.0, trace.drone[0, 2] - 0.2])  # starts 0.2 m above home
    (path,) = dp.export_mission(dataclasses.replace(trace, drone=low), tmp_path / "low.wpl", origin=ORIGIN)
    items = read_wpl(path)
    assert items[0][0] == NAV_TAKEOFF
    assert np.allclose(items[0][3], [*low[0, :2], missions.MIN_TAKEOFF_ALTITUDE], atol=ROUND_TRIP)
    assert items[1][0] == NAV_WAYPOINT and np.allclose(items[1][3], low[0], atol=ROUND_TRIP)


def test_a_herding_trace_gives_one_file_per_drone(tmp_path, traces):
    trace = traces["herding"]
    n = trace.drones.shape[1]
    paths = dp.export_mission(trace, tmp_path / "h.wpl", origin=ORIGIN, tolerance=2.0, altitude=25.0)
    assert paths == [tmp_path / f"h_drone{i}.wpl" for i in range(n)]
    for i, path in enumerate(paths):
        waypoints = np.array([xyz for c, _, _, xyz in read_wpl(path) if c == NAV_WAYPOINT])
        assert np.allclose(waypoints[:, 2], 25.0)
        flown = np.column_stack([trace.drones[:, i], np.full(len(trace.t), 25.0)])
        assert np.all(distance_to_polyline(flown, waypoints) <= 2.0 + ROUND_TRIP)


# --------------------------------------------------------------------------- Douglas-Peucker


walks = st.integers(1, 60).flatmap(
    lambda n: st.lists(st.tuples(*(st.floats(-50, 50),) * 3), min_size=n, max_size=n)
)


@settings(max_examples=150, deadline=None)
@given(steps=walks, tolerance=st.floats(0.01, 30.0))
def test_douglas_peucker_keeps_every_point_within_the_tolerance(steps, tolerance):
    points = np.cumsum(np.array(steps), axis=0)
    kept = douglas_peucker(points, tolerance)
    assert kept[0] == 0 and kept[-1] == len(points) - 1 and np.all(np.diff(kept) > 0)
    for a, b in itertools.pairwise(kept):  # each point against its own segment
        inner = points[a : b + 1]
        assert np.all(distance_to_polyline(inner, points[[a, b]]) <= tolerance + 1e-9)


def test_douglas_peucker_drops_points_on_a_line():
    line = np.column_stack([np.linspace(0, 100, 11), np.zeros(11), np.zeros(11)])
    assert douglas_peucker(line, 1e-6).tolist() == [0, 10]
    corner = np.array([[0.0, 0, 0], [5, 0, 0], [10, 0, 0], [10, 5, 0], [10, 10, 0]])
    assert douglas_peucker(corner, 0.1).tolist() == [0, 2, 4]


# --------------------------------------------------------------------------- bad input, no file


def _bad_calls(tmp_path, plan, problem, trace):
    target = tmp_path / "out" / "m.wpl"
    target.parent.mkdir()
    (tmp_path / "file").write_text("")
    return target, [
        (
            (plan, target),
            {"format": "gpx", "origin": ORIGIN, "problem": problem},
            ValueError,
            "format must be one of",
        ),
        ((plan, target), {"origin": (95.0, 0.0, 0.0), "problem": problem}, ValueError, "origin latitude"),
        ((plan, target), {"origin": (0.0, 200.0, 0.0), "problem": problem}, ValueError, "origin longitude"),
        (
            (plan, target),
            {"origin": (0.0, 0.0, float("nan")), "problem": problem},
            ValueError,
            "origin altitude",
        ),
        (
            (plan[:0], target),
            {"origin": ORIGIN, "problem": problem},
            ValueError,
            "plan_or_trace: the mission has no waypoint",
        ),
        (
            (plan, tmp_path / "nowhere" / "m.wpl"),
            {"origin": ORIGIN, "problem": problem},
            ValueError,
            "path: the folder",
        ),
        (
            (plan, tmp_path / "file" / "m.wpl"),
            {"origin": ORIGIN, "problem": problem},
            ValueError,
            "path: the folder",
        ),
        (
            (plan, target.parent),
            {"origin": ORIGIN, "problem": problem},
            ValueError,
            "path: .* is a directory",
        ),
        ((plan, 3), {"origin": ORIGIN, "problem": problem}, TypeError, "path must be a str"),
        ((trace, target), {"origin": ORIGIN, "tolerance": 0.0}, ValueError, "tolerance must be > 0"),
        ((trace, target), {"origin": ORIGIN, "altitude": 1e5}, ValueError, "altitude must be in"),
        (
            (plan, target),
            {"origin": ORIGIN, "problem": problem, "speed": 0.0},
            ValueError,
            "speed must be in",
        ),
        ((plan, target), {"origin": ORIGIN}, ValueError, "problem: a cells placement needs"),
    ]


def test_bad_input_raises_one_line_naming_the_field_and_writes_nothing(tmp_path, cells, traces):
    problem, plan = cells
    target, calls = _bad_calls(tmp_path, plan, problem, traces["shark"])
    for args, kwargs, error, message in calls:
        with pytest.raises(error, match=message) as info:
            dp.export_mission(*args, **kwargs)
        assert "\n" not in str(info.value)
        assert os.listdir(target.parent) == []


def test_a_failed_write_leaves_no_partial_file(tmp_path, cells, monkeypatch):
    problem, plan = cells
    real = os.fdopen
    opened = []

    def fail_on_second(fd, *args, **kwargs):
        opened.append(fd)
        if len(opened) == 2:
            os.close(fd)
            raise OSError(28, "No space left on device")
        return real(fd, *args, **kwargs)

    monkeypatch.setattr(missions.os, "fdopen", fail_on_second)
    with pytest.raises(ValueError, match=r"path: cannot write .*m_cell1\.wpl: No space left on device"):
        dp.export_mission(plan, tmp_path / "m.wpl", origin=ORIGIN, problem=problem)
    assert os.listdir(tmp_path) == []
