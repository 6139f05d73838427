"""Mission files for autopilots: a plan or trace as MAVLink waypoints (``dp.export_mission``).

Three formats:

* ``"wpl"``: MAVLink mission text ``QGC WPL 110`` (ArduPilot, Mission Planner, MAVProxy,
  pymavlink's ``MAVWPLoader``): a header line, then one tab-separated line per item (index,
  current, frame, command, param1-4, latitude, longitude, altitude, autocontinue). Line 0 is the
  home position (the origin, altitude above mean sea level).
* ``"plan"``: a QGroundControl ``.plan`` JSON file (``fileType`` "Plan", mission version 2,
  ``SimpleItem`` items, empty geofence and rally points).
* ``"kml"``: a KML 2.2 document with the flight path (a line string) and one placemark per
  waypoint, altitudes absolute (metres above mean sea level).

What is written:

* a drone-cell placement (thesis ch. 4): one mission per drone-cell: take off at the origin to
  the cell's altitude (``MAV_CMD_NAV_TAKEOFF``), set the speed (``MAV_CMD_DO_CHANGE_SPEED``), fly
  to the site (``MAV_CMD_NAV_WAYPOINT``) and loiter there (``MAV_CMD_NAV_LOITER_UNLIM``);
* a covert, shark interception or herding trace: the path of each drone it flies (the covert
  drone, the shark operator, every herding drone), thinned by Douglas-Peucker in 3-D to
  ``tolerance`` metres (every recorded position lies within ``tolerance`` of the line through the
  waypoints kept; the first and last are always kept): a take-off at the first position to its
  altitude (at least ``MIN_TAKEOFF_ALTITUDE``, 1 m), then a waypoint per kept position, each
  preceded by a speed change when its speed differs from the previous one by more than 0.01 m/s.
  A leg's speed is the length of the recorded path between two waypoints over its duration (m/s,
  at least ``MIN_SPEED``). The mission ends at the last recorded position; what the vehicle does
  then (hover, return, land) is the autopilot's end-of-mission setting.

Waypoint altitudes are metres above the home position (``MAV_FRAME_GLOBAL_RELATIVE_ALT``): the
local z of the plan or trace. Latitudes and longitudes are written with every digit of a float64
(Python's shortest round-trip form), so positions read back map to the local frame within a
millimetre.

Several missions (several drone-cells, several herding drones) go to several files: the stem of
``path`` gets ``_cell{j}`` or ``_drone{i}`` before the suffix (``m.wpl`` -> ``m_cell0.wpl``,
``m_cell1.wpl``); one mission goes to ``path`` itself. Every file is written to a temporary file
beside it and renamed once all are written, so bad input or a failed write leaves no file.

This module imports only the scenario layer and the shared checks.
"""

from __future__ import annotations

import contextlib
import json
import os
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any
from xml.sax.saxutils import escape

import numpy as np
from numpy.typing import NDArray

from droneplan.core.validation import check_real
from droneplan.scenarios.geo import LocalFrame
from droneplan.scenarios.geo_export import (
    DEFAULT_ALTITUDE,
    BodyPath,
    cell_sites,
    check_altitude,
    is_cells_plan,
    resolve_frame,
    trace_paths,
)

__all__ = [
    "FORMATS",
    "MIN_SPEED",
    "MAX_SPEED",
    "MIN_TAKEOFF_ALTITUDE",
    "DEFAULT_SPEED",
    "MissionItem",
    "douglas_peucker",
    "export_mission",
]

FORMATS = ("wpl", "plan", "kml")
"""Mission file formats :func:`export_mission` writes."""

DEFAULT_SPEED = 10.0
"""Cruise speed (m/s) of a drone-cell's flight to its site."""

MIN_SPEED = 0.1
"""Slowest leg speed written (m/s): a drone that hovered between two waypoints flies the leg at it."""

MAX_SPEED = 100.0
"""Fastest speed accepted (m/s)."""

MIN_TAKEOFF_ALTITUDE = 1.0
"""Lowest take-off altitude written (m above home): a trace that starts on the ground climbs to it."""

# MAVLink commands and frames (common.xml)
NAV_WAYPOINT, NAV_LOITER_UNLIM, NAV_TAKEOFF, DO_CHANGE_SPEED = 16, 17, 22, 178
FRAME_GLOBAL, FRAME_MISSION, FRAME_GLOBAL_RELATIVE_ALT = 0, 2, 3
_NAMES = {
    NAV_WAYPOINT: "WAYPOINT",
    NAV_LOITER_UNLIM: "LOITER_UNLIM",
    NAV_TAKEOFF: "TAKEOFF",
    DO_CHANGE_SPEED: "CHANGE_SPEED",
}


@dataclass(frozen=True)
class MissionItem:
    """One mission item: a MAVLink command with its four parameters and position.

    command: MAV_CMD number. frame: MAV_FRAME number (3: altitude above home; 2: no position).
    params: param1-4 (command-specific; for DO_CHANGE_SPEED: speed type 1 = ground, speed m/s,
    throttle -1 = unchanged, 0). lat, lon: degrees (0 without position). alt: m above home.
    """

    command: int
    frame: int
    params: tuple[float, float, float, float]
    lat: float = 0.0
    lon: float = 0.0
    alt: float = 0.0

    @property
    def is_nav(self) -> bool:
        """Whether the item has a position (a navigation command)."""
        return self.frame == FRAME_GLOBAL_RELATIVE_ALT


@dataclass(frozen=True)
class _Mission:
    suffix: str
    items: list[MissionItem]
    cruise: float


def douglas_peucker(points: NDArray[np.float64], tolerance: float) -> NDArray[np.intp]:
    """Indices of the points kept by Douglas-Peucker: every point lies within ``tolerance`` of
    the segment between the kept points around it.

    points: (n, d) positions (m), n >= 1.
    tolerance: largest distance (m, >= 0) of a dropped point from the simplified line.

    Returns the sorted kept indices; the first and last point are always kept.
    """
    n = len(points)
    if n <= 2:
        return np.arange(n, dtype=np.intp)
    keep = np.zeros(n, dtype=bool)
    keep[0] = keep[-1] = True
    stack = [(0, n - 1)]
    while stack:
        i, j = stack.pop()
        if j - i < 2:
            continue
        a, b = points[i], points[j]
        inner = points[i + 1 : j]
        ab = b - a
        length2 = float(ab @ ab)
        if length2 > 0.0:
            s = np.clip((inner - a) @ ab / length2, 0.0, 1.0)
            dist = np.linalg.norm(inner - (a + s[:, None] * ab), axis=1)
        else:
            dist = np.linalg.norm(inner - a, axis=1)
        k = int(np.argmax(dist))
        if dist[k] > tolerance:
            m = i + 1 + k
            keep[m] = True
            stack += [(i, m), (m, j)]
    return np.flatnonzero(keep).astype(np.intp)


def _speed_item(speed: float) -> MissionItem:
    return MissionItem(DO_CHANGE_SPEED, FRAME_MISSION, (1.0, speed, -1.0, 0.0))


def _nav(
    frame: LocalFrame, command: int, xyz: NDArray[np.float64], params: tuple[float, ...] = (0.0,) * 4
) -> MissionItem:
    lat, lon = frame.to_wgs84(xyz[0], xyz[1])
    p = (float(params[0]), float(params[1]), float(params[2]), float(params[3]))
    return MissionItem(command, FRAME_GLOBAL_RELATIVE_ALT, p, float(lat), float(lon), float(xyz[2]))


def _cell_missions(frame: LocalFrame, xyz: NDArray[np.float64], speed: float) -> list[_Mission]:
    home = np.zeros(3)
    out = []
    for j, site in enumerate(xyz):
        items = [
            _nav(frame, NAV_TAKEOFF, np.array([home[0], home[1], site[2]])),
            _speed_item(speed),
            _nav(frame, NAV_WAYPOINT, site),
            _nav(frame, NAV_LOITER_UNLIM, site),
        ]
        out.append(_Mission(f"cell{j}", items, speed))
    return out


def _path_mission(frame: LocalFrame, body: BodyPath, tolerance: float) -> _Mission:
    xyz, t = body.xyz, body.t
    if not np.all(np.isfinite(xyz)) or not np.all(np.isfinite(t)):
        raise ValueError(f"plan_or_trace: the path of the {body.name} holds a non-finite position or time")
    kept = douglas_peucker(xyz, tolerance)
    step = np.linalg.norm(np.diff(xyz, axis=0), axis=1)
    along = np.concatenate([[0.0], np.cumsum(step)])
    lift = np.array([xyz[0, 0], xyz[0, 1], max(float(xyz[0, 2]), MIN_TAKEOFF_ALTITUDE)])
    items = [_nav(frame, NAV_TAKEOFF, lift)]
    speeds: list[float] = []
    last_speed = None
    for n, k in enumerate(kept):
        if n > 0:
            prev = kept[n - 1]
            duration = float(t[k] - t[prev])
            dist = float(along[k] - along[prev])
            speed = min(max(dist / duration if duration > 0 else MIN_SPEED, MIN_SPEED), MAX_SPEED)
            speeds.append(speed)
            if last_speed is None or abs(speed - last_speed) > 0.01:
                items.append(_speed_item(speed))
                last_speed = speed
        items.append(_nav(frame, NAV_WAYPOINT, xyz[k]))
    cruise = float(np.median(speeds)) if speeds else DEFAULT_SPEED
    suffix = body.name.replace(" ", "")
    return _Mission(suffix, items, cruise)


# --------------------------------------------------------------------------- formats


def _num(value: float) -> str:
    """A float in Python's shortest round-trip form (every digit of a float64)."""
    return repr(float(value))


def _wpl(frame: LocalFrame, mission: _Mission) -> str:
    lat0, lon0, alt0 = frame.origin
    lines = [
        "QGC WPL 110",
        "\t".join(
            ["0", "1", str(FRAME_GLOBAL), str(NAV_WAYPOINT)]
            + ["0"] * 4
            + [_num(lat0), _num(lon0), _num(alt0), "1"]
        ),
    ]
    for seq, item in enumerate(mission.items, start=1):
        fields = [str(seq), "0", str(item.frame), str(item.command)]
        fields += [_num(p) for p in item.params] + [_num(item.lat), _num(item.lon), _num(item.alt), "1"]
        lines.append("\t".join(fields))
    return "\n".join(lines) + "\n"


def _plan(frame: LocalFrame, mission: _Mission) -> str:
    items = []
    for jump, item in enumerate(mission.items, start=1):
        entry: dict[str, Any] = {
            "autoContinue": True,
            "command": item.command,
            "doJumpId": jump,
            "frame": item.frame,
            "params": [*item.params, item.lat, item.lon, item.alt]
            if item.is_nav
            else [*item.params, 0, 0, 0],
            "type": "SimpleItem",
        }
        if item.is_nav:
            entry.update({"AMSLAltAboveTerrain": None, "Altitude": item.alt, "AltitudeMode": 1})
        items.append(entry)
    doc = {
        "fileType": "Plan",
        "version": 1,
        "groundStation": "QGroundControl",
        "mission": {
            "version": 2,
            "firmwareType": 0,
            "vehicleType": 2,
            "cruiseSpeed": mission.cruise,
            "hoverSpeed": mission.cruise,
            "items": items,
            "plannedHomePosition": list(frame.origin),
        },
        "geoFence": {"circles": [], "polygons": [], "version": 2},
        "rallyPoints": {"points": [], "version": 2},
    }
    return json.dumps(doc, indent=2) + "\n"


def _kml(frame: LocalFrame, mission: _Mission, title: str) -> str:
    alt0 = frame.origin[2]
    nav = [item for item in mission.items if item.is_nav]
    coords = " ".join(f"{_num(i.lon)},{_num(i.lat)},{_num(alt0 + i.alt)}" for i in nav)
    marks = []
    speed = None
    for n, item in enumerate(mission.items):
        if not item.is_nav:
            speed = item.params[1]
            continue
        text = f"{_NAMES[item.command]}, {_num(item.alt)} m above home"
        if speed is not None:
            text += f", {_num(speed)} m/s"
        marks.append(
            f"    <Placemark><name>{n + 1}: {_NAMES[item.command]}</name>"
            f"<description>{escape(text)}</description>"
            f"<Point><altitudeMode>absolute</altitudeMode><coordinates>{_num(item.lon)},{_num(item.lat)},"
            f"{_num(alt0 + item.alt)}</coordinates></Point></Placemark>"
        )
    return (
        '<?xml version="1.0" encoding="UTF-8"?>\n'
        '<kml xmlns="http://www.opengis.net/kml/2.2">\n'
        f"  <Document>\n    <name>{escape(title)}</name>\n"
        f"    <Placemark><name>path</name><LineString><altitudeMode>absolute</altitudeMode>"
        f"<coordinates>{coords}</coordinates></LineString></Placemark>\n"
        + "\n".join(marks)
        + "\n  </Document>\n</kml>\n"
    )


# --------------------------------------------------------------------------- writing


def _check_target(path: Any) -> Path:
    if not isinstance(path, (str, os.PathLike)):
        raise TypeError(f"path must be a str or os.PathLike file path, got {type(path).__name__}")
    target = Path(path)
    if target.is_dir():
        raise ValueError(f"path: {target} is a directory, not a file")
    parent = target.parent
    if not parent.is_dir():
        raise ValueError(f"path: the folder {parent} does not exist")
    if not os.access(parent, os.W_OK):
        raise ValueError(f"path: the folder {parent} is not writable")
    return target


def _write_all(files: list[tuple[Path, str]]) -> None:
    """Write every (path, text) to a temporary file beside it, then rename all: no partial output."""
    temps: list[tuple[str, Path]] = []
    try:
        for target, text in files:
            fd, tmp = tempfile.mkstemp(dir=target.parent, prefix=f".{target.name}.", suffix=".tmp")
            temps.append((tmp, target))
            with os.fdopen(fd, "w", encoding="utf-8", newline="\n") as fh:
                fh.write(text)
    except OSError as exc:
        for tmp, _ in temps:
            with contextlib.suppress(OSError):
                os.unlink(tmp)
        raise ValueError(f"path: cannot write {files[len(temps) - 1][0]}: {exc.strerror or exc}") from None
    for tmp, target in temps:
        os.replace(tmp, target)


def export_mission(
    plan_or_trace: Any,
    path: str | os.PathLike[str],
    format: str = "wpl",
    *,
    origin: Any = None,
    problem: Any = None,
    tolerance: float = 1.0,
    altitude: float = DEFAULT_ALTITUDE,
    speed: float = DEFAULT_SPEED,
) -> list[Path]:
    """Write a plan or trace as autopilot mission file(s); returns the paths written.

    plan_or_trace: a drone-cell placement (a SolveResult of ``dp.cells`` or a (k, 2) / (k, 3)
        plan array in metres, with ``problem``): one mission per drone-cell (take off, fly to the
        site at its altitude, loiter); or a trace of ``dp.covert.simulate``, ``dp.shark.simulate``
        or ``dp.herding.simulate``: one mission per drone it flies (waypoints thinned to
        ``tolerance``, with speeds and altitudes).
    path: the file to write (str or path-like; its folder must exist; overwritten). Several
        missions go to ``<stem>_cell{j}<suffix>`` / ``<stem>_drone{i}<suffix>`` beside it.
    format: ``"wpl"`` (MAVLink ``QGC WPL 110`` text), ``"plan"`` (QGroundControl JSON) or
        ``"kml"`` (KML 2.2).
    origin: the home position, which the local frame's (0, 0, 0) stands for: (lat, lon, alt) in
        degrees and metres above mean sea level (an azimuthal equidistant frame about it), a
        :class:`LocalFrame` or a ProjectedCells; None when ``problem`` is a ProjectedCells.
    problem: the CellProblem (or ProjectedCells) of a placement; not used for a trace.
    tolerance: Douglas-Peucker tolerance (m, > 0): every recorded position of a trace lies within
        it of the line through the waypoints kept (default 1 m).
    altitude: flight altitude (m above home, in [0, 10 000]) of drone-cells of a (k, 2) plan and
        of herding drones (default 100 m).
    speed: cruise speed (m/s, in [0.1, 100]) of a drone-cell's flight to its site (default 10
        m/s); a trace's legs fly at its own speeds.

    Returns the list of files written (one per mission). Raises a one-line ValueError naming the
    field, with no file written, for an unknown format, an origin out of range, a mission with no
    waypoint (a placement with no drone-cell, an empty trace) or a path that cannot be written.
    """
    if not isinstance(format, str) or format not in FORMATS:
        raise ValueError(f"format must be one of {', '.join(repr(f) for f in FORMATS)}, got {format!r}")
    target = _check_target(path)
    tolerance = check_real("tolerance", tolerance)
    if tolerance <= 0:
        raise ValueError(f"tolerance must be > 0 m, got {tolerance}")
    altitude = check_altitude("altitude", altitude)
    speed = check_real("speed", speed)
    if not MIN_SPEED <= speed <= MAX_SPEED:
        raise ValueError(f"speed must be in [{MIN_SPEED}, {MAX_SPEED}] m/s, got {speed}")
    frame = resolve_frame(origin, problem)
    if is_cells_plan(plan_or_trace):
        if problem is None:
            raise ValueError("problem: a cells placement needs its CellProblem (problem=...)")
        sites = cell_sites(plan_or_trace, problem, altitude)
        missions = _cell_missions(frame, sites.xyz, speed)
        what = "the placement holds no drone-cell"
    else:
        bodies = [b for b in trace_paths(plan_or_trace, altitude) if b.flown and len(b.t)]
        missions = [_path_mission(frame, body, tolerance) for body in bodies]
        what = "the trace holds no recorded position"
    if not missions:
        raise ValueError(f"plan_or_trace: the mission has no waypoint ({what})")
    files = []
    for mission in missions:
        out = (
            target
            if len(missions) == 1
            else target.with_name(f"{target.stem}_{mission.suffix}{target.suffix}")
        )
        if format == "wpl":
            text = _wpl(frame, mission)
        elif format == "plan":
            text = _plan(frame, mission)
        else:
            text = _kml(frame, mission, f"{target.stem} {mission.suffix}")
        files.append((out, text))
    _write_all(files)
    return [f for f, _ in files]
