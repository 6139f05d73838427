"""Loaders for users' own data: point files (CSV, GeoJSON), a local map projection, and the
scenarios built from them (drone-cell problems, herds, shark tracks).

File formats:

* **CSV** (``read_points_csv``): UTF-8 text (a byte-order mark is accepted), comma-separated,
  a header row naming the columns, then one row per point. Columns are found by name; extra
  columns are ignored and their order does not matter. Blank lines are skipped. Every value of
  a requested column must be a finite number written as Python's ``float`` reads it
  (``12.5``, ``-3e2``). Planar coordinates are metres in a local frame (east = +x,
  north = +y), times are seconds, depths are metres (<= 0, below the surface).
* **GeoJSON** (``read_geojson_points``, RFC 7946): a ``FeatureCollection`` of ``Point`` and
  ``MultiPoint`` features, a single ``Feature``, or a bare ``Point``/``MultiPoint`` geometry.
  Positions are ``[longitude, latitude]`` in decimal degrees (WGS 84); a third value (height)
  is ignored.

Geographic positions become metres through :func:`project_local`: pyproj's azimuthal
equidistant projection on the WGS 84 ellipsoid (``+proj=aeqd +datum=WGS84``) about a stated
origin, through :class:`droneplan.scenarios.geo.LocalFrame`. Distances and azimuths from the
origin are the geodesic ones; other distances within a few tens of kilometres of it agree with
geodesic distances to better than 0.01 %. Points farther than 1000 km from the origin are refused.
:func:`load_cells_geojson` also takes GeoDataFrames (geopandas, optional: ``pip install -e
".[geo]"``) in any CRS: points for users and stations, polygons for no-fly zones; they are
reprojected to WGS 84 (EPSG:4326) and then to the local frame.

Every error on bad input is a one-line ``ValueError`` (``TypeError`` for an argument of the
wrong type) that starts with the file's path and says where the problem is (line number as in
the file, column name, feature index).

This module imports no other layer of droneplan (only the scenarios it builds and the shared
argument checks); pandas is not needed.
"""

from __future__ import annotations

import csv
import dataclasses
import importlib
import io
import json
import math
import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from droneplan.core.validation import (
    check_array,
    check_instance,
    check_int,
    check_positive,
    check_real,
    check_size,
)
from droneplan.scenarios.cells import THESIS_TABLE_4_2, CellParams, CellProblem
from droneplan.scenarios.geo import LocalFrame, spherical_centroid
from droneplan.scenarios.herding import HerdingParams, HerdingScenario, thesis_scenario
from droneplan.scenarios.shark.params import THESIS_TABLE_5_1
from droneplan.scenarios.shark.trajectories import SharkTrajectory

__all__ = [
    "EARTH_RADIUS",
    "DEFAULT_SHARK_DEPTH",
    "read_points_csv",
    "write_points_csv",
    "load_cells_csv",
    "read_geojson_points",
    "project_local",
    "unproject_local",
    "ProjectedCells",
    "load_cells_geojson",
    "load_herd_csv",
    "herding_scenario_from_csv",
    "load_shark_track_csv",
    "read_user_tracks",
]

EARTH_RADIUS = 6_371_008.8
"""The IUGG mean Earth radius R1 (m), for spherical estimates such as great-circle distances;
:func:`project_local` projects on the WGS 84 ellipsoid through pyproj."""

DEFAULT_SHARK_DEPTH = -3.0
"""Depth of a shark track without a z column (m, below the surface): the constant depth of the
thesis example paths a and c (``thesis_trajectories``)."""

PathLike = str | os.PathLike[str]


# --------------------------------------------------------------------------- CSV


def _as_path(path: Any, name: str = "path") -> Path:
    if not isinstance(path, (str, os.PathLike)):
        raise TypeError(f"{name} must be a str or os.PathLike file path, got {type(path).__name__}")
    return Path(path)


def _check_columns(columns: Any) -> tuple[str, ...]:
    if isinstance(columns, str) or not isinstance(columns, Sequence):
        raise TypeError(f"columns must be a sequence of column names, got {type(columns).__name__}")
    cols = tuple(columns)
    if not cols:
        raise ValueError("columns must name at least one column")
    for c in cols:
        if not isinstance(c, str) or not c.strip():
            raise TypeError(f"columns must hold non-empty strings, got {c!r}")
    if len(set(cols)) != len(cols):
        raise ValueError(f"columns must be distinct, got {list(cols)}")
    return cols


def _read_text(path: Path, what: str) -> str:
    if not path.exists():
        raise ValueError(f"{path}: no such {what} file")
    if not path.is_file():
        raise ValueError(f"{path}: not a file")
    try:
        with path.open(encoding="utf-8-sig", newline="") as fh:
            text = fh.read()
    except UnicodeDecodeError as exc:
        raise ValueError(f"{path}: not UTF-8 text ({exc.reason} at byte {exc.start})") from None
    if not text.strip():
        raise ValueError(f"{path}: the file is empty")
    return text


def _read_table(  # noqa: C901
    path: PathLike, columns: Sequence[str], optional: Sequence[str] = ()
) -> tuple[NDArray[np.float64], list[int], tuple[str, ...]]:
    """The requested columns (then those of ``optional`` the header has) of a CSV file, the line
    number of each data row, and the columns read."""
    file = _as_path(path)
    cols = _check_columns(columns)
    reader = csv.reader(io.StringIO(_read_text(file, "CSV"), newline=""))
    header: list[str] = []
    try:
        for row in reader:
            if any(cell.strip() for cell in row):
                header = [cell.strip() for cell in row]
                break
        missing = [c for c in cols if c not in header]
        if missing:
            raise ValueError(
                f"{file}: missing column(s) {', '.join(repr(c) for c in missing)}; "
                f"the header has {', '.join(repr(h) for h in header)}"
            )
        cols += tuple(c for c in optional if c in header and c not in cols)
        doubled = [c for c in cols if header.count(c) > 1]
        if doubled:
            raise ValueError(f"{file}: column {doubled[0]!r} appears more than once in the header")
        index = [header.index(c) for c in cols]
        rows: list[list[float]] = []
        lines: list[int] = []
        for row in reader:
            if not any(cell.strip() for cell in row):
                continue
            line = reader.line_num
            if len(row) > len(header) and any(cell.strip() for cell in row[len(header) :]):
                raise ValueError(
                    f"{file}: line {line}: {len(row)} fields, the header has {len(header)} "
                    "(decimal commas? write decimals with '.', or quote the field)"
                )
            values = []
            for c, i in zip(cols, index, strict=True):
                if i >= len(row):
                    raise ValueError(
                        f"{file}: line {line}, column {c!r}: missing value (the row is too short)"
                    )
                cell = row[i].strip()
                try:
                    value = float(cell)
                except ValueError:
                    raise ValueError(f"{file}: line {line}, column {c!r}: not a number: {cell!r}") from None
                if not math.isfinite(value):
                    raise ValueError(f"{file}: line {line}, column {c!r}: {cell!r} is not finite")
                values.append(value)
            rows.append(values)
            lines.append(line)
            check_size(f"{file} (rows x columns)", len(rows) * len(cols))
    except csv.Error as exc:
        raise ValueError(f"{file}: line {reader.line_num}: malformed CSV ({exc})") from None
    if not rows:
        raise ValueError(f"{file}: no data rows after the header")
    return np.array(rows, dtype=np.float64).reshape(len(rows), len(cols)), lines, cols


def read_points_csv(path: PathLike, *, columns: Sequence[str] = ("x", "y")) -> NDArray[np.float64]:
    """The numeric ``columns`` of a CSV file with a header row, as an (n, k) float array.

    path: the CSV file (str or path-like). Format: UTF-8, comma-separated, a header row with the
        column names (surrounding spaces are ignored), then one row per point; blank lines are
        skipped; columns not in ``columns`` are ignored.
    columns: names of the k columns to read, in the order of the output's columns (default
        ``("x", "y")``: planar positions in metres, east and north). Units are the file's; the
        loaders below state theirs.

    Returns an (n, k) float64 array, n >= 1, every entry finite.

    Raises ValueError (one line, starting with the path) when the file is missing or empty,
    a requested column is missing (the message lists the columns found), a cell is not a number
    (line number in the file, column and text), a value is NaN or infinite, or there are no data
    rows; TypeError when ``columns`` is not a sequence of names.
    """
    return _read_table(path, columns)[0]


def write_points_csv(path: PathLike, points: ArrayLike, columns: Sequence[str] = ("x", "y")) -> Path:
    """Write an (n, k) array of points as a CSV file that :func:`read_points_csv` reads back exactly.

    path: the file to write (str or path-like; overwritten if it exists; its folder must exist).
    points: (n, k) finite numbers, n >= 1, in the units the columns stand for (metres for
        positions, seconds for times).
    columns: the k column names of the header row (default ``("x", "y")``).

    Values are written in Python's shortest round-trip form, so reading the file gives the same
    float64 values. Returns the path written.
    """
    file = _as_path(path)
    cols = _check_columns(columns)
    for c in cols:
        if any(ch in c for ch in ',"\r\n') or c != c.strip():
            raise ValueError(f"columns: {c!r} holds a comma, quote, line break or surrounding space")
    pts = check_array("points", points, shape=(None, len(cols)), min_rows=1)
    with file.open("w", encoding="utf-8", newline="") as fh:
        writer = csv.writer(fh, lineterminator="\n")
        writer.writerow(cols)
        writer.writerows([repr(float(v)) for v in row] for row in pts)
    return file


# --------------------------------------------------------------------------- drone cells


def _cell_problem(
    users: NDArray[np.float64], gbs: NDArray[np.float64], n_cells: int, params: CellParams
) -> CellProblem:
    return CellProblem(users, gbs, n_cells, params.R_d, params.R_g, params.r1, params.r2, bounds=None)


def load_cells_csv(
    users: PathLike,
    gbs: PathLike | None = None,
    *,
    n_cells: int,
    params: CellParams = THESIS_TABLE_4_2,
) -> CellProblem:
    """A drone-cell placement problem (thesis ch. 4) from CSV files of positions in metres.

    users: CSV file of user positions, columns ``x``, ``y`` in metres (a local planar frame;
        see :func:`read_points_csv` for the format). At least one user.
    gbs: CSV file of ground base station positions, columns ``x``, ``y`` in metres, in the
        same frame; None: ``params.gbs`` (Table 4.2: one GBS at (0, 0)).
    n_cells: number m of drone-cells available (count, >= 1).
    params: the radii (R_d, R_g in metres) and backhaul ranges (r1, r2 in metres) of the
        problem (default: THESIS_TABLE_4_2); its densities and area are not used.

    Returns a :class:`CellProblem` with ``bounds=None`` (drone-cells may go anywhere).
    """
    check_instance("params", params, CellParams)
    n_cells = check_int("n_cells", n_cells, min_value=1)
    users = _as_path(users, "users")
    gbs = None if gbs is None else _as_path(gbs, "gbs")
    pts = read_points_csv(users)
    stations = np.asarray(params.gbs, dtype=float) if gbs is None else read_points_csv(gbs)
    return _cell_problem(pts, stations, n_cells, params)


# --------------------------------------------------------------------------- GeoJSON and projection

_POINT_TYPES = ("Point", "MultiPoint")


def _geometry_positions(file: Path, geom: Any, where: str) -> list[Any]:
    if not isinstance(geom, dict):
        raise ValueError(f"{file}: {where}: geometry must be a JSON object, got {_json_kind(geom)}")
    kind = geom.get("type")
    if kind not in _POINT_TYPES:
        raise ValueError(f"{file}: {where}: geometry type {kind!r} is not supported (only Point, MultiPoint)")
    coords = geom.get("coordinates")
    if kind == "Point":
        return [coords]
    if not isinstance(coords, list):
        raise ValueError(f"{file}: {where}: MultiPoint coordinates must be a list of positions")
    return list(coords)


def _json_kind(value: Any) -> str:
    return "null" if value is None else type(value).__name__


_WGS84_NAMES = (
    "urn:ogc:def:crs:OGC:1.3:CRS84",
    "urn:ogc:def:crs:OGC::CRS84",
    "EPSG:4326",
    "urn:ogc:def:crs:EPSG::4326",
)


def _check_crs(file: Path, crs: Any) -> None:
    """Refuse a (pre-RFC 7946) ``crs`` member that names anything but WGS 84 longitude/latitude."""
    if crs is None:
        return
    name = crs.get("properties", {}).get("name") if isinstance(crs, dict) else None
    if not isinstance(name, str) or name not in _WGS84_NAMES:
        raise ValueError(
            f"{file}: the 'crs' member names {name if isinstance(name, str) else crs!r}; droneplan reads "
            "WGS 84 longitude/latitude (RFC 7946): reproject the file or drop a 'crs' that is WGS 84"
        )


def read_geojson_points(path: PathLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:  # noqa: C901
    """Longitudes and latitudes (degrees) of the points of a GeoJSON file.

    path: the GeoJSON file (str or path-like, UTF-8). Accepted: a ``FeatureCollection`` whose
        features all have ``Point`` or ``MultiPoint`` geometries, a single such ``Feature``, or
        a bare ``Point``/``MultiPoint`` geometry. Positions are ``[lon, lat]`` or
        ``[lon, lat, height]`` in decimal degrees (WGS 84, RFC 7946); the height is ignored.
        Properties are ignored.

    Returns (lon, lat): two (n,) float64 arrays in degrees, n >= 1, in file order (a MultiPoint's
    points in their order). Raises ValueError (starting with the path) for invalid JSON (line and
    column), another GeoJSON type, a feature with another geometry type or no geometry (its index
    in ``features``), a malformed position, longitude outside [-180, 180] or latitude outside
    [-90, 90] (feature index and value), or no points at all.
    """
    file = _as_path(path)
    text = _read_text(file, "GeoJSON")
    try:
        doc = json.loads(text)
    except json.JSONDecodeError as exc:
        raise ValueError(
            f"{file}: invalid JSON at line {exc.lineno}, column {exc.colno}: {exc.msg}"
        ) from None
    except RecursionError:
        raise ValueError(f"{file}: JSON nested too deeply to read") from None
    if not isinstance(doc, dict):
        raise ValueError(f"{file}: the top level must be a GeoJSON object, got {_json_kind(doc)}")
    _check_crs(file, doc.get("crs"))
    kind = doc.get("type")
    located: list[tuple[str, list[Any]]] = []
    if kind == "FeatureCollection":
        features = doc.get("features")
        if not isinstance(features, list):
            raise ValueError(f"{file}: a FeatureCollection needs a 'features' list")
        for i, feature in enumerate(features):
            where = f"feature {i}"
            if not isinstance(feature, dict) or feature.get("type") != "Feature":
                raise ValueError(f"{file}: {where} is not a GeoJSON Feature object")
            if feature.get("geometry") is None:
                raise ValueError(f"{file}: {where} has no geometry (null)")
            located.append((where, _geometry_positions(file, feature["geometry"], where)))
    elif kind == "Feature":
        if doc.get("geometry") is None:
            raise ValueError(f"{file}: the feature has no geometry (null)")
        located.append(("the feature", _geometry_positions(file, doc["geometry"], "the feature")))
    elif kind in _POINT_TYPES:
        located.append(("the geometry", _geometry_positions(file, doc, "the geometry")))
    else:
        raise ValueError(
            f"{file}: GeoJSON type {kind!r} is not supported "
            "(a FeatureCollection or Feature of Point/MultiPoint, or a bare Point/MultiPoint)"
        )
    lon: list[float] = []
    lat: list[float] = []
    for where, positions in located:
        for pos in positions:
            if (
                not isinstance(pos, list)
                or len(pos) not in (2, 3)
                or not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in pos)
            ):
                raise ValueError(
                    f"{file}: {where}: a position must be [lon, lat] or [lon, lat, height], got {pos!r}"
                )
            x, y = float(pos[0]), float(pos[1])
            if not (math.isfinite(x) and -180.0 <= x <= 180.0):
                raise ValueError(f"{file}: {where}: longitude {pos[0]!r} is outside [-180, 180] degrees")
            if not (math.isfinite(y) and -90.0 <= y <= 90.0):
                raise ValueError(f"{file}: {where}: latitude {pos[1]!r} is outside [-90, 90] degrees")
            lon.append(x)
            lat.append(y)
            check_size(f"{file} (points)", 2 * len(lon))
    if not lon:
        raise ValueError(f"{file}: no points (the file holds no Point or MultiPoint positions)")
    return np.array(lon, dtype=np.float64), np.array(lat, dtype=np.float64)


def _check_origin(origin: Any) -> tuple[float, float]:
    o = check_array("origin (lon0, lat0)", origin, shape=(2,))
    lon0, lat0 = float(o[0]), float(o[1])
    if not -180.0 <= lon0 <= 180.0:
        raise ValueError(f"origin longitude must be in [-180, 180] degrees, got {lon0}")
    if not -90.0 <= lat0 <= 90.0:
        raise ValueError(f"origin latitude must be in [-90, 90] degrees, got {lat0}")
    return lon0, lat0


def _local_frame(lon0: float, lat0: float) -> LocalFrame:
    """The :class:`LocalFrame` (azimuthal equidistant on WGS 84) about (lon0, lat0) degrees."""
    return LocalFrame.from_origin(lat0, lon0)


def project_local(lon: ArrayLike, lat: ArrayLike, origin: ArrayLike) -> NDArray[np.float64]:
    """Local planar coordinates (m) of geographic points: azimuthal equidistant about ``origin``.

    lon: (n,) longitudes in degrees, in [-180, 180].
    lat: (n,) latitudes in degrees, in [-90, 90].
    origin: (lon0, lat0) in degrees, the point that maps to (0, 0).

    Returns (n, 2) metres, east = +x, north = +y. The projection is pyproj's azimuthal
    equidistant one on the WGS 84 ellipsoid (``+proj=aeqd +datum=WGS84`` about the origin,
    through :class:`droneplan.scenarios.geo.LocalFrame`): a point at geodesic distance ``d`` (m)
    and azimuth ``b`` (clockwise from north) from the origin maps to ``(d sin b, d cos b)``.
    Distances from the origin are the geodesic ones on the ellipsoid; between two points within
    10 km of the origin the planar distance differs from the geodesic one by less than 0.001 %.
    Points farther than ``AEQD_MAX_DISTANCE`` (1000 km) from the origin are refused
    (ValueError). Inverse: :func:`unproject_local`.
    """
    lon0, lat0 = _check_origin(origin)
    lo = check_array("lon", lon, ndim=1)
    la = check_array("lat", lat, ndim=1)
    if lo.shape != la.shape:
        raise ValueError(f"lon and lat must have the same length, got {lo.shape[0]} and {la.shape[0]}")
    x, y = _local_frame(lon0, lat0).to_local(la, lo)
    return np.column_stack([x, y])


def unproject_local(xy: ArrayLike, origin: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Geographic coordinates (degrees) of local planar points: the inverse of :func:`project_local`.

    xy: (n, 2) metres, east = +x, north = +y, from the origin; each at most
        ``AEQD_MAX_DISTANCE`` (1000 km) from (0, 0).
    origin: (lon0, lat0) in degrees, the point (0, 0) stands for.

    Returns (lon, lat): two (n,) arrays in degrees, lon in [-180, 180], lat in [-90, 90].
    """
    lon0, lat0 = _check_origin(origin)
    pts = check_array("xy", xy, shape=(None, 2))
    lat, lon = _local_frame(lon0, lat0).to_wgs84(pts[:, 0], pts[:, 1])
    return lon, lat


def _spherical_centroid(lon: NDArray[np.float64], lat: NDArray[np.float64]) -> tuple[float, float]:
    """(lon, lat) degrees of the points' centroid on the sphere (:func:`spherical_centroid`)."""
    try:
        c_lat, c_lon = spherical_centroid(lat, lon)
    except ValueError:
        raise ValueError(
            "users: the points are spread over the globe and have no centroid; pass origin"
        ) from None
    return c_lon, c_lat


@dataclass(frozen=True)
class ProjectedCells:
    """A drone-cell problem built from geographic data, with the origin of its projection.

    problem: the CellProblem, positions in metres in the local frame of :func:`project_local`.
    origin: (lon0, lat0) in degrees, the point the local frame's (0, 0) stands for.
    """

    problem: CellProblem
    origin: tuple[float, float]

    @property
    def frame(self) -> LocalFrame:
        """The :class:`LocalFrame` of the problem (origin given as (lat, lon, 0 m)), for
        ``to_geojson`` and ``export_mission``."""
        return _local_frame(*self.origin)

    def to_lonlat(self, xy: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """(lon, lat) in degrees of local points ``xy`` (n, 2) in metres (e.g. drone-cell positions)."""
        return unproject_local(xy, self.origin)


def load_cells_geojson(
    users: PathLike | Any,
    gbs: PathLike | Any | None = None,
    *,
    n_cells: int,
    origin: ArrayLike | None = None,
    params: CellParams = THESIS_TABLE_4_2,
    no_fly: Any = None,
) -> ProjectedCells:
    """A drone-cell placement problem (thesis ch. 4) from GeoJSON files or GeoDataFrames of points.

    users: GeoJSON file of user positions (format: :func:`read_geojson_points`; degrees), or a
        geopandas GeoDataFrame/GeoSeries of Point/MultiPoint geometries in any CRS (reprojected
        to WGS 84; it must have a CRS).
    gbs: ground base station positions, a GeoJSON file (degrees) or a GeoDataFrame of points as
        for ``users``; None: ``params.gbs`` taken as metres in the local frame (Table 4.2: one
        GBS at the origin).
    n_cells: number m of drone-cells available (count, >= 1).
    origin: (lon0, lat0) in degrees, the centre of the local projection. Default: the first
        GBS of the ``gbs`` file when one is given, else the centroid of the users (the mean of
        their unit vectors on the sphere, which for a local data set is the mean lon/lat and
        also works across the antimeridian).
    params: the radii (R_d, R_g in metres) and backhaul ranges (r1, r2 in metres) (default:
        THESIS_TABLE_4_2).
    no_fly: None, or a GeoDataFrame/GeoSeries of Polygon/MultiPolygon no-fly zones in any CRS
        (reprojected to WGS 84, then to the local frame in metres); no drone-cell centre may lie
        in one (:class:`CellProblem`'s ``no_fly``).

    Every position is projected with :func:`project_local` about the origin (metres, east = +x,
    north = +y). Returns a :class:`ProjectedCells` holding the :class:`CellProblem`
    (``bounds=None``) and the origin used, whose ``to_lonlat`` maps planned positions back.
    geopandas is needed only for GeoDataFrame inputs.
    """
    check_instance("params", params, CellParams)
    n_cells = check_int("n_cells", n_cells, min_value=1)
    users = users if _is_geodata(users) else _as_path(users, "users")
    gbs = gbs if gbs is None or _is_geodata(gbs) else _as_path(gbs, "gbs")
    u_lon, u_lat = _points_lonlat(users, "users")
    g_lonlat = None if gbs is None else _points_lonlat(gbs, "gbs")
    if origin is not None:
        lon0, lat0 = _check_origin(origin)
    elif g_lonlat is not None:
        lon0, lat0 = float(g_lonlat[0][0]), float(g_lonlat[1][0])
    else:
        lon0, lat0 = _spherical_centroid(u_lon, u_lat)
    o = (lon0, lat0)
    pts = project_local(u_lon, u_lat, o)
    stations = np.asarray(params.gbs, dtype=float) if g_lonlat is None else project_local(*g_lonlat, o)
    problem = _cell_problem(pts, stations, n_cells, params)
    if no_fly is not None:
        zones = _polygons_local(no_fly, _local_frame(*o))
        problem = CellProblem(
            pts, stations, n_cells, params.R_d, params.R_g, params.r1, params.r2, bounds=None, no_fly=zones
        )
    return ProjectedCells(problem, o)


def _is_geodata(value: Any) -> bool:
    """Whether ``value`` is a geopandas GeoDataFrame or GeoSeries (without importing geopandas)."""
    return type(value).__module__.split(".")[0] == "geopandas"


def _geometries_wgs84(value: Any, name: str) -> list[Any]:
    """The shapely geometries of a GeoDataFrame/GeoSeries, reprojected to WGS 84 (EPSG:4326)."""
    try:
        importlib.import_module("geopandas")  # optional; the GeoDataFrame's own methods need it
    except ImportError:
        raise ImportError(
            f'{name}: reading a GeoDataFrame needs geopandas: pip install -e ".[geo]"'
        ) from None
    if value.crs is None:
        raise ValueError(f"{name}: the GeoDataFrame has no CRS; set one with .set_crs(...)")
    series = value.geometry if hasattr(value, "geometry") else value
    geoms = list(series.to_crs(4326))
    if not geoms:
        raise ValueError(f"{name}: the GeoDataFrame has no rows")
    return geoms


def _points_lonlat(value: Any, name: str) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(lon, lat) degrees of the points of a GeoJSON file or a GeoDataFrame of points."""
    if not _is_geodata(value):
        return read_geojson_points(_as_path(value, name))
    lon: list[float] = []
    lat: list[float] = []
    for i, geom in enumerate(_geometries_wgs84(value, name)):
        kind = None if geom is None else geom.geom_type
        if kind == "Point":
            parts = [geom]
        elif kind == "MultiPoint":
            parts = list(geom.geoms)
        else:
            raise ValueError(
                f"{name}: row {i}: geometry type {kind!r} is not supported (only Point, MultiPoint)"
            )
        for p in parts:
            lon.append(float(p.x))
            lat.append(float(p.y))
    check_size(f"{name} (points)", 2 * len(lon))
    return np.array(lon, dtype=np.float64), np.array(lat, dtype=np.float64)


def _polygons_local(value: Any, frame: LocalFrame) -> list[Any]:
    """Shapely polygons in local metres from a GeoDataFrame/GeoSeries of (Multi)Polygons."""
    from shapely.geometry import Polygon

    if not _is_geodata(value):
        raise TypeError(
            f"no_fly must be a geopandas GeoDataFrame or GeoSeries of polygons, got {type(value).__name__}"
        )

    def ring(coords: Any) -> NDArray[np.float64]:
        lonlat = np.asarray(coords, dtype=np.float64)[:, :2]
        x, y = frame.to_local(lonlat[:, 1], lonlat[:, 0])
        return np.column_stack([x, y])

    zones: list[Any] = []
    for i, geom in enumerate(_geometries_wgs84(value, "no_fly")):
        kind = None if geom is None else geom.geom_type
        if kind not in ("Polygon", "MultiPolygon"):
            raise ValueError(
                f"no_fly: row {i}: geometry type {kind!r} is not supported (only Polygon, MultiPolygon)"
            )
        parts = [geom] if kind == "Polygon" else list(geom.geoms)
        zones.extend(Polygon(ring(p.exterior.coords), [ring(r.coords) for r in p.interiors]) for p in parts)
    return zones


# --------------------------------------------------------------------------- herding


def load_herd_csv(path: PathLike) -> NDArray[np.float64]:
    """Animal positions of a herd from a CSV file.

    path: CSV file with columns ``x``, ``y``: one animal per row, metres in a local planar frame
        (format: :func:`read_points_csv`; other columns are ignored).

    Returns (n, 2) positions in metres, n >= 1.
    """
    return read_points_csv(path, columns=("x", "y"))


def herding_scenario_from_csv(
    path: PathLike,
    *,
    goal: ArrayLike | None = None,
    n_drones: int = 4,
    **overrides: Any,
) -> HerdingScenario:
    """A herding scenario (thesis ch. 6) whose animals start where a CSV file puts them.

    path: CSV file of animal positions, columns ``x``, ``y`` in metres (:func:`load_herd_csv`);
        at least 2 animals.
    goal: designated location G (m, in the file's frame). Default as in ``thesis_scenario``:
        900 m to the left (-x) of the field centre.
    n_drones: number of barking drones (count; thesis: 4).
    overrides: any HerdingParams field; R_c and V_driving default to Table 6.2's values for the
        herd size, as in ``thesis_scenario``.

    The field is the herd's bounding box (each side widened to at least 1 m, about its centre);
    the drones start as in ``thesis_scenario``: lined up 80 m to the right of the field, 50 m
    apart, centred on it and facing -x.
    """
    known = {f.name for f in dataclasses.fields(HerdingParams)}
    unknown = sorted(set(overrides) - known)
    if unknown:
        raise TypeError(f"overrides: {', '.join(unknown)} not HerdingParams field(s)")
    animals = load_herd_csv(path)
    if animals.shape[0] < 2:
        raise ValueError(f"{_as_path(path)}: a herd needs at least 2 animals, got {animals.shape[0]}")
    goal_xy = None if goal is None else check_array("goal", goal, shape=(2,))
    lo, hi = animals.min(axis=0), animals.max(axis=0)
    centre = (lo + hi) / 2
    size = np.maximum(hi - lo, 1.0)
    corner = centre - size / 2
    # thesis_scenario lays out drones and goal in a field at (0, 0); shift its layout to the herd
    base = thesis_scenario(
        animals.shape[0],
        0,
        field_size=(float(size[0]), float(size[1])),
        goal=None if goal_xy is None else (float(goal_xy[0] - corner[0]), float(goal_xy[1] - corner[1])),
        n_drones=n_drones,
        **overrides,
    )
    x0, y0 = float(corner[0]), float(corner[1])
    return HerdingScenario(
        base.params,
        animals,
        base.drones + corner,
        base.headings,
        base.goal + corner,
        (x0, y0, x0 + float(size[0]), y0 + float(size[1])),
    )


# --------------------------------------------------------------------------- shark


def load_shark_track_csv(  # noqa: C901
    path: PathLike,
    *,
    dt: float | None = THESIS_TABLE_5_1.Ts,
    depth: float = DEFAULT_SHARK_DEPTH,
    name: str | None = None,
) -> SharkTrajectory:
    """A shark path (thesis ch. 5) from a CSV track of timed positions.

    path: CSV file with columns ``t`` (s), ``x``, ``y`` (m, local planar frame) and optionally
        ``z`` (m, depth, <= 0 below the surface); format: :func:`read_points_csv`. Times must be
        strictly increasing; at least 2 samples.
    dt: sampling step of the returned path (s, > 0; default Table 5.1's Ts = 0.1 s, which the
        interception simulator requires). The track is linearly interpolated at
        ``t0, t0 + dt, ...`` up to its last time (t0 = first time), so a track already sampled
        every ``dt`` keeps its positions exactly. None keeps the file's own times.
    depth: depth used when the file has no ``z`` column (m, <= 0; default
        ``DEFAULT_SHARK_DEPTH`` = -3 m, the constant depth of the thesis paths).
    name: label of the path (default: the file's stem).

    Times are shifted to start at 0 (``SharkTrajectory.t`` starts at 0). Velocities (m/s) are the
    finite differences of the sampled positions (``numpy.gradient``: central inside, one-sided at
    the ends). Raises ValueError naming the first line whose time is not after the previous one,
    a positive depth, or a track shorter than ``dt``.
    """
    file = _as_path(path)
    if dt is not None:
        dt = check_positive("dt", dt)
    depth = check_real("depth", depth)
    if depth > 0:
        raise ValueError(f"depth must be <= 0 m (below the surface), got {depth}")
    if name is not None and not isinstance(name, str):
        raise TypeError(f"name must be a str or None, got {type(name).__name__}")
    data, lines, cols = _read_table(file, ("t", "x", "y"), optional=("z",))
    t = data[:, 0]
    if len(t) < 2:
        raise ValueError(f"{file}: a shark track needs at least 2 samples, got {len(t)}")
    bad = np.flatnonzero(np.diff(t) <= 0)
    if bad.size:
        k = int(bad[0]) + 1
        raise ValueError(
            f"{file}: line {lines[k]}, column 't': times must be strictly increasing, "
            f"{t[k]!r} s follows {t[k - 1]!r} s"
        )
    if "z" in cols:
        above = np.flatnonzero(data[:, 3] > 0)
        if above.size:
            k = int(above[0])
            raise ValueError(
                f"{file}: line {lines[k]}, column 'z': depth {data[k, 3]!r} m is above the surface (> 0)"
            )
        pos = data[:, 1:4]
    else:
        pos = np.column_stack([data[:, 1:3], np.full(len(t), depth)])
    rel = t - t[0]
    if dt is None:
        ts, ps = rel, pos
    else:
        steps = rel[-1] / dt * (1 + 1e-12) + 1e-9  # a float: a tiny dt may ask for inf steps
        check_size(f"dt = {dt} s (the resampled track of {file})", 6 * (steps + 1))
        n = math.floor(steps) + 1
        if n < 2:
            raise ValueError(f"{file}: the track lasts {rel[-1]!r} s, shorter than dt = {dt} s")
        ts = np.arange(n, dtype=np.float64) * dt
        ps = np.column_stack([np.interp(ts, rel, pos[:, i]) for i in range(3)])
        on_grid = np.isclose(rel, np.round(rel / dt) * dt, rtol=0, atol=1e-9 * max(dt, 1.0))
        if on_grid.all() and len(rel) == n:  # sampled every dt already: keep the file's values
            ps = pos.copy()
    vel = np.gradient(ps, ts, axis=0)
    return SharkTrajectory(ts, ps, vel, name=file.stem if name is None else name)


def read_user_tracks(
    path: Any, *, origin: ArrayLike | None = None
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """User tracks from a CSV file with the columns ``id, t, x, y`` (metres) or ``id, t, lon, lat``
    (degrees), or from a GeoDataFrame of Point rows with ``id`` and ``t`` columns in any CRS
    (reprojected to WGS 84; geopandas is the optional ``[geo]`` extra). Degrees are projected about
    ``origin`` = (lon0, lat0) by :func:`project_local`, pyproj's azimuthal equidistant projection on
    the WGS 84 ellipsoid (``origin`` None: the tracks' spherical centroid). Every id needs a row at
    every time.

    path: the CSV file, or a GeoDataFrame. origin: (lon0, lat0) degrees, or None.

    Returns (times (T,) s, sorted; ids (n,), sorted; snapshots (T, n, 2) m), the snapshots of
    :class:`droneplan.cells.MobileProblem`.
    """
    given_origin = None if origin is None else _check_origin(origin)
    if _is_geodata(path):
        source = "tracks"
        missing = [c for c in ("id", "t") if c not in getattr(path, "columns", ())]
        if missing:
            raise ValueError(f"path: the GeoDataFrame has no column {', '.join(missing)} (needs id, t)")
        lon, lat = _points_lonlat(path, "path")
        if len(lon) != len(path):
            raise ValueError("path: every row of a GeoDataFrame of tracks must be one Point")
        table = np.column_stack(
            [np.asarray(path["id"], dtype=np.float64), np.asarray(path["t"], dtype=np.float64), lon, lat]
        )
        geographic = True
    else:
        file = _as_path(path)
        source = str(file)
        header = _csv_header(file)
        geographic = "lon" in header and "lat" in header and not ("x" in header and "y" in header)
        columns = ("id", "t", "lon", "lat") if geographic else ("id", "t", "x", "y")
        table, _, _ = _read_table(file, columns)
    if not np.all(np.isfinite(table[:, :2])):
        raise ValueError(f"{source}: id and t must be finite numbers")
    ids, id_index = np.unique(table[:, 0], return_inverse=True)
    times, t_index = np.unique(table[:, 1], return_inverse=True)
    cell = t_index * len(ids) + id_index
    if len(np.unique(cell)) != len(cell):
        raise ValueError(f"{source}: an id appears twice at one time")
    if len(cell) != len(ids) * len(times):
        raise ValueError(
            f"{source}: {len(cell)} rows for {len(ids)} ids at {len(times)} times: "
            "every id needs a row at every time"
        )
    xy = table[:, 2:4]
    if geographic:
        lon, lat = xy[:, 0], xy[:, 1]
        centre = _spherical_centroid(lon, lat) if given_origin is None else given_origin
        xy = project_local(lon, lat, centre)
    snapshots = np.zeros((len(times), len(ids), 2))
    snapshots[t_index, id_index] = xy
    return times, ids, snapshots


def _csv_header(file: Path) -> list[str]:
    """The header row (first non-blank line) of a CSV file."""
    reader = csv.reader(io.StringIO(_read_text(file, "CSV"), newline=""))
    for row in reader:
        if any(cell.strip() for cell in row):
            return [cell.strip() for cell in row]
    raise ValueError(f"{file}: empty CSV file")
