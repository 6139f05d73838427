"""Plans and traces in real coordinates: GeoJSON and GeoDataFrames in WGS 84.

:func:`to_geojson` (no geopandas needed) and :func:`to_geodataframe` (geopandas: ``pip install -e
".[geo]"``) turn

* a drone-cell placement (a ``SolveResult`` of ``dp.cells.*`` or a (k, 2)/(k, 3) plan array, with
  its ``CellProblem``) into points (drone-cells, GBSs, users), coverage circles (polygons) and
  backhaul links (line strings);
* a closed-loop trace of ``dp.covert.simulate``, ``dp.shark.simulate`` or ``dp.herding.simulate``
  into one line string per moving body (drone, targets, operator, shark, herd centroid), each
  with its times in seconds;

mapping local metres to WGS 84 longitude/latitude through a :class:`LocalFrame`. Every feature
has a ``kind`` property. Heights (a third coordinate, where the body moves in 3-D) are metres
above mean sea level: the origin's altitude plus the local z.

The functions here also give :mod:`droneplan.scenarios.missions` the drone-cell sites and the
flown paths it writes. This module imports only the scenario layer and the shared checks.
"""

from __future__ import annotations

import importlib
import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from droneplan.core.validation import check_array, check_real
from droneplan.scenarios.cells import CellProblem
from droneplan.scenarios.geo import LocalFrame, check_origin
from droneplan.scenarios.loaders import ProjectedCells

__all__ = [
    "DEFAULT_ALTITUDE",
    "MAX_ALTITUDE",
    "CellSites",
    "BodyPath",
    "resolve_frame",
    "cell_sites",
    "trace_paths",
    "to_geojson",
    "to_geodataframe",
]

DEFAULT_ALTITUDE = 100.0
"""Flight altitude (m above the origin) of a drone whose plan or trace is planar: drone-cells of a
plan without altitude levels and herding drones."""

MAX_ALTITUDE = 10_000.0
"""Largest flight altitude accepted (m above the origin)."""

CIRCLE_VERTICES = 64
"""Vertices of a coverage circle's polygon (its chord error is R (1 - cos(pi / 64)), 0.12 % of R)."""

LINK_TOL = 1e-6
"""Slack (m) on the backhaul ranges when listing links."""


@dataclass(frozen=True)
class CellSites:
    """The drone-cells of a placement, in local metres.

    xyz: (k, 3) positions (x east, y north, h altitude above the origin; m).
    radius: (k,) coverage radii on the ground (m).
    problem: the CellProblem the plan solves.
    """

    xyz: NDArray[np.float64]
    radius: NDArray[np.float64]
    problem: CellProblem


@dataclass(frozen=True)
class BodyPath:
    """One moving body of a trace: its name, whether a drone flies it, times and positions.

    name: "drone", "drone 2", "operator", "shark", "target 0", "herd centroid".
    flown: True for a drone of the plan (a mission flies it), False for what it observes.
    t: (T,) times (s). xyz: (T, 3) positions (m, local frame; z above the origin).
    """

    name: str
    flown: bool
    t: NDArray[np.float64]
    xyz: NDArray[np.float64]


def resolve_frame(origin: Any, problem: Any = None) -> LocalFrame:
    """The :class:`LocalFrame` that ``origin`` names.

    origin: a LocalFrame, a :class:`ProjectedCells` (its frame), (lat, lon) or (lat, lon, alt) in
        degrees and metres above mean sea level (an azimuthal equidistant frame about it), or None
        when ``problem`` is a ProjectedCells.
    problem: the plan's problem (a ProjectedCells supplies the frame when ``origin`` is None).
    """
    if origin is None:
        if isinstance(problem, ProjectedCells):
            return problem.frame
        raise ValueError("origin must be given as (lat, lon, alt) or a LocalFrame (got None)")
    if isinstance(origin, LocalFrame):
        return origin
    if isinstance(origin, ProjectedCells):
        return origin.frame
    lat, lon, alt = check_origin(origin)
    return LocalFrame.from_origin(lat, lon, alt)


def check_altitude(name: str, value: Any) -> float:
    """``value`` (m above the origin) in [0, MAX_ALTITUDE]."""
    out = check_real(name, value)
    if not 0.0 <= out <= MAX_ALTITUDE:
        raise ValueError(f"{name} must be in [0, {MAX_ALTITUDE:g}] m above the origin, got {out}")
    return out


def _is_result(value: Any) -> bool:
    return hasattr(value, "x") and hasattr(value, "status") and hasattr(value, "has_solution")


def is_cells_plan(value: Any) -> bool:
    """Whether ``value`` is a cells placement: a SolveResult or an array, not a trace."""
    return _is_result(value) or isinstance(value, (np.ndarray, list, tuple))


def cell_sites(
    plan: Any, problem: Any, altitude: float = DEFAULT_ALTITUDE, name: str = "plan_or_trace"
) -> CellSites:
    """The drone-cells of a placement.

    plan: a SolveResult of ``dp.cells`` (its ``x``) or a (k, 2) / (k, 3) array of positions (m;
        (x, y, h) for a problem with altitude levels).
    problem: its CellProblem, or a ProjectedCells holding it.
    altitude: flight altitude (m above the origin) of drone-cells of a (k, 2) plan.
    name: the plan's parameter name, for error messages.
    """
    if isinstance(problem, ProjectedCells):
        problem = problem.problem
    if not isinstance(problem, CellProblem):
        raise TypeError(
            "problem must be the CellProblem (or ProjectedCells) of the placement, "
            f"got {type(problem).__name__}"
        )
    altitude = check_altitude("altitude", altitude)
    if _is_result(plan):
        if not plan.has_solution or plan.x is None:
            raise ValueError(f"{name}: the result has no solution (status {plan.status.name})")
        plan = plan.x
    width = problem.plan_width
    arr = check_array(name, plan)
    if arr.size == 0:
        arr = arr.reshape(0, width)
    if arr.ndim != 2 or arr.shape[1] != width:
        raise ValueError(
            f"{name}: a placement of this problem is a (k, {width}) array, got shape {arr.shape}"
        )
    if width == 2:
        xyz = np.column_stack([arr, np.full(len(arr), altitude)])
        radius = np.full(len(arr), float(problem.R_d))
    else:
        xyz = arr.copy()
        levels = np.asarray(problem.altitudes, dtype=float)
        radii = np.asarray(problem.level_radii, dtype=float)
        idx = np.abs(xyz[:, 2:3] - levels[None, :]).argmin(axis=1) if len(arr) else np.zeros(0, int)
        if len(arr) and not np.allclose(levels[idx], xyz[:, 2], rtol=0, atol=1e-6):
            raise ValueError(f"{name}: an altitude is not one of the problem's levels {list(levels)} m")
        radius = radii[idx]
    if np.any(np.abs(xyz[:, :2]) > 1e9):
        raise ValueError(f"{name}: a position lies more than 1e9 m from the origin")
    return CellSites(xyz, radius, problem)


def trace_paths(
    trace: Any, altitude: float = DEFAULT_ALTITUDE, name: str = "plan_or_trace"
) -> list[BodyPath]:
    """The moving bodies of a closed-loop trace (covert, shark interception or herding).

    trace: a CovertTrace, InterceptionTrace or HerdingTrace.
    altitude: flight altitude (m above the origin) of the herding drones (their trace is planar).
    name: the trace's parameter name, for error messages.
    """
    from droneplan.scenarios.covert.dynamics import CovertTrace
    from droneplan.scenarios.herding import HerdingTrace
    from droneplan.scenarios.shark.simulate import InterceptionTrace

    altitude = check_altitude("altitude", altitude)
    t = np.asarray(getattr(trace, "t", np.zeros(0)), dtype=float)
    if isinstance(trace, CovertTrace):
        bodies = [BodyPath("drone", True, t, np.asarray(trace.drone, float))]
        targets = np.asarray(trace.targets, float)
        bodies += [BodyPath(f"target {i}", False, t, targets[:, i]) for i in range(targets.shape[1])]
        return bodies
    if isinstance(trace, InterceptionTrace):
        return [
            BodyPath("operator", True, t, np.asarray(trace.operator, float)),
            BodyPath("shark", False, t, np.asarray(trace.shark, float)),
        ]
    if isinstance(trace, HerdingTrace):
        drones = np.asarray(trace.drones, float)
        lift = np.full((len(t), 1), altitude)
        bodies = [
            BodyPath(f"drone {i}", True, t, np.hstack([drones[:, i], lift])) for i in range(drones.shape[1])
        ]
        centroid = np.asarray(trace.centroid, float)
        bodies.append(BodyPath("herd centroid", False, t, np.hstack([centroid, np.zeros((len(t), 1))])))
        return bodies
    raise TypeError(
        f"{name} must be a cells placement (SolveResult or array, with problem=...) or a trace of "
        f"dp.covert/shark/herding.simulate, got {type(trace).__name__}"
    )


# --------------------------------------------------------------------------- GeoJSON


def _positions(frame: LocalFrame, xyz: NDArray[np.float64], height: bool) -> list[list[float]]:
    lat, lon = frame.to_wgs84(xyz[:, 0], xyz[:, 1])
    if height:
        alt = frame.origin[2] + xyz[:, 2]
        return [[float(a), float(b), float(c)] for a, b, c in zip(lon, lat, alt, strict=True)]
    return [[float(a), float(b)] for a, b in zip(lon, lat, strict=True)]


def _feature(geometry: dict[str, Any], **properties: Any) -> dict[str, Any]:
    return {"type": "Feature", "geometry": geometry, "properties": properties}


def _cells_features(frame: LocalFrame, sites: CellSites) -> list[dict[str, Any]]:
    problem = sites.problem
    xyz, radius = sites.xyz, sites.radius
    out: list[dict[str, Any]] = []
    users = np.asarray(problem.users, float)
    gbs = np.asarray(problem.gbs, float)
    zeros = np.zeros((len(users), 1))
    user_pos = _positions(frame, np.hstack([users, zeros]), False)
    if len(xyz):
        gap = np.hypot(users[:, None, 0] - xyz[None, :, 0], users[:, None, 1] - xyz[None, :, 1])
        covered: NDArray[np.bool_] = np.asarray((gap <= radius[None, :] + LINK_TOL).any(axis=1))
    else:
        covered = np.zeros(len(users), dtype=bool)
    for i, pos in enumerate(user_pos):
        out.append(
            _feature({"type": "Point", "coordinates": pos}, kind="user", index=i, covered=bool(covered[i]))
        )
    gbs_pos = _positions(frame, np.hstack([gbs, np.zeros((len(gbs), 1))]), False)
    for i, pos in enumerate(gbs_pos):
        out.append(
            _feature({"type": "Point", "coordinates": pos}, kind="gbs", index=i, radius_m=float(problem.R_g))
        )
    cell_pos = _positions(frame, xyz, True)
    angles = np.linspace(0.0, 2 * math.pi, CIRCLE_VERTICES + 1)
    angles[-1] = 0.0  # close the ring exactly
    for j, pos in enumerate(cell_pos):
        props = {"cell": j, "altitude_m": float(xyz[j, 2]), "radius_m": float(radius[j])}
        out.append(_feature({"type": "Point", "coordinates": pos}, kind="drone_cell", **props))
        ring = np.column_stack(
            [
                xyz[j, 0] + radius[j] * np.cos(angles),
                xyz[j, 1] + radius[j] * np.sin(angles),
                np.zeros(len(angles)),
            ]
        )
        out.append(
            _feature(
                {"type": "Polygon", "coordinates": [_positions(frame, ring, False)]}, kind="coverage", **props
            )
        )
    three_d = problem.altitudes is not None
    ground = np.column_stack([xyz[:, :2], xyz[:, 2] if three_d else np.zeros(len(xyz))])
    for j in range(len(xyz)):
        for i in range(len(gbs)):
            length = float(np.linalg.norm(ground[j] - np.array([gbs[i, 0], gbs[i, 1], 0.0])))
            if length <= problem.r1 + LINK_TOL:
                line = np.array([[gbs[i, 0], gbs[i, 1], 0.0], xyz[j]])
                out.append(_link(frame, line, f"gbs {i}", f"cell {j}", length))
        for k in range(j + 1, len(xyz)):
            length = float(np.linalg.norm(ground[j] - ground[k]))
            if length <= problem.r2 + LINK_TOL:
                out.append(_link(frame, xyz[[j, k]], f"cell {j}", f"cell {k}", length))
    return out


def _link(frame: LocalFrame, line: NDArray[np.float64], a: str, b: str, length: float) -> dict[str, Any]:
    geometry = {"type": "LineString", "coordinates": _positions(frame, line, True)}
    return _feature(geometry, kind="backhaul", **{"from": a, "to": b, "length_m": length})


def _trace_features(frame: LocalFrame, bodies: list[BodyPath], goal: Any) -> list[dict[str, Any]]:
    out: list[dict[str, Any]] = []
    for body in bodies:
        if len(body.t) == 0:
            continue
        coords = _positions(frame, body.xyz, True)
        geometry = (
            {"type": "LineString", "coordinates": coords}
            if len(coords) > 1
            else {"type": "Point", "coordinates": coords[0]}
        )
        out.append(
            _feature(
                geometry,
                kind="path",
                name=body.name,
                flown=body.flown,
                times_s=[float(v) for v in body.t],
                start_s=float(body.t[0]),
                end_s=float(body.t[-1]),
            )
        )
    if goal is not None:
        g = np.asarray(goal, float).reshape(1, -1)[:, :2]
        pos = _positions(frame, np.hstack([g, np.zeros((1, 1))]), False)[0]
        out.append(_feature({"type": "Point", "coordinates": pos}, kind="goal", name="goal"))
    return out


def to_geojson(
    plan_or_trace: Any,
    *,
    origin: Any = None,
    problem: Any = None,
    altitude: float = DEFAULT_ALTITUDE,
) -> dict[str, Any]:
    """A plan or trace as a GeoJSON ``FeatureCollection`` (a dict) in WGS 84 longitude/latitude.

    plan_or_trace: a drone-cell placement (a SolveResult of ``dp.cells`` or a (k, 2) / (k, 3) plan
        array in metres, with ``problem``) or a trace of ``dp.covert.simulate``,
        ``dp.shark.simulate`` or ``dp.herding.simulate`` (positions in metres, times in s).
    origin: what the local frame's (0, 0, 0) stands for: (lat, lon) or (lat, lon, alt) in degrees
        and metres above mean sea level (an azimuthal equidistant frame about it, see
        :class:`LocalFrame`), a LocalFrame, or a ProjectedCells; None when ``problem`` is a
        ProjectedCells.
    problem: the CellProblem (or ProjectedCells) of a placement; not used for a trace.
    altitude: flight altitude (m above the origin) of drone-cells of a (k, 2) plan and of herding
        drones, in [0, 10 000] m (default 100 m).

    Features (``properties.kind``): a placement gives ``user`` points (``covered``), ``gbs``
    points, ``drone_cell`` points (``altitude_m``, ``radius_m``), ``coverage`` polygons (a circle
    of the cell's radius on the ground, 64 vertices) and ``backhaul`` line strings (every
    drone-GBS pair within r1 and drone-drone pair within r2, ``length_m``); a trace gives one
    ``path`` line string per body (``name``, ``flown``, ``times_s`` one time per vertex, in s)
    and, for herding, the ``goal`` point. Positions are [lon, lat] or [lon, lat, height] (degrees,
    and metres above mean sea level). Needs pyproj, not geopandas.
    """
    frame = resolve_frame(origin, problem)
    if is_cells_plan(plan_or_trace):
        if problem is None:
            raise ValueError("problem: a cells placement needs its CellProblem (problem=...)")
        features = _cells_features(frame, cell_sites(plan_or_trace, problem, altitude))
    else:
        bodies = trace_paths(plan_or_trace, altitude)
        features = _trace_features(frame, bodies, getattr(plan_or_trace, "goal", None))
    return {
        "type": "FeatureCollection",
        "features": features,
        "properties": {"frame": frame.description, "origin_lat_lon_alt": list(frame.origin)},
    }


def to_geodataframe(
    plan_or_trace: Any,
    *,
    origin: Any = None,
    problem: Any = None,
    altitude: float = DEFAULT_ALTITUDE,
) -> Any:
    """A plan or trace as a geopandas ``GeoDataFrame`` in WGS 84 (EPSG:4326).

    plan_or_trace: a drone-cell placement (SolveResult or (k, 2) / (k, 3) array in metres, with
        ``problem``) or a covert, shark or herding trace (see :func:`to_geojson`).
    origin: (lat, lon[, alt]) in degrees and metres above mean sea level, a LocalFrame or a
        ProjectedCells (see :func:`to_geojson`).
    problem: the CellProblem (or ProjectedCells) of a placement.
    altitude: flight altitude (m above the origin) of planar drones, in [0, 10 000] m.

    One row per feature of :func:`to_geojson`: a ``geometry`` column and one column per property
    (``kind``, ...). Needs geopandas (``pip install -e ".[geo]"``); raises ImportError saying so.
    """
    try:
        geopandas = importlib.import_module("geopandas")  # optional: untyped, imported on use
    except ImportError:
        raise ImportError('to_geodataframe needs geopandas: pip install -e ".[geo]"') from None
    doc = to_geojson(plan_or_trace, origin=origin, problem=problem, altitude=altitude)
    return geopandas.GeoDataFrame.from_features(doc["features"], crs="EPSG:4326")
