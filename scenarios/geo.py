"""Real coordinates: a local metric frame about an origin, through pyproj.

Every problem of droneplan works in a local planar frame in metres (east = +x, north = +y).
:class:`LocalFrame` ties that frame to the Earth: it maps WGS 84 latitude/longitude (degrees)
to local metres and back, vectorised over numpy arrays, with pyproj doing the geodesy.

Two projections are built in:

* ``"aeqd"`` (the default): the azimuthal equidistant projection on the WGS 84 ellipsoid
  centred on the origin. Distances and bearings from the origin are the geodesic ones; within
  :data:`AEQD_MAX_DISTANCE` (1000 km) of the origin the scale error across the radius stays
  below 0.5 %, and within 10 km of it below 0.0001 %. Points farther away are refused.
* ``"utm"``: the UTM zone of the origin (EPSG:326zz north of the equator, 327zz south; the
  Norway and Svalbard zone exceptions are not applied), shifted so that the origin is (0, 0).
  Its x/y axes follow the zone's grid, whose north differs from true north by the meridian
  convergence (up to about 2 degrees at the zone's edge). Usable band: latitudes in
  [-80, 84] degrees and longitudes within :data:`UTM_MAX_OFFSET_DEG` (6 degrees) of the zone's
  central meridian (scale error below 0.6 %); points outside are refused.

Any other projected CRS that pyproj knows (an EPSG code such as ``"EPSG:2056"``, a WKT or PROJ
string) is accepted too, if its axes are in metres; it is also shifted so the origin is
(0, 0), and points outside its area of use (when pyproj knows one) are refused.

Positions are exact to a millimetre: PROJ's azimuthal equidistant projection snaps a point within
0.6 mm of its centre onto the centre, and a centre within 1.1 mm of the equator is put on it.

The origin's altitude ``alt`` (m above mean sea level) is the height of the local frame's
z = 0; mission files use it as the home altitude.

pyproj is imported when a frame is built, not when this module is imported. This module
imports only the shared argument checks of droneplan.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from droneplan.core.validation import check_real

__all__ = [
    "AEQD_MAX_DISTANCE",
    "UTM_MAX_OFFSET_DEG",
    "LocalFrame",
    "check_origin",
    "check_lat_lon",
    "spherical_centroid",
]

AEQD_MAX_DISTANCE = 1_000_000.0
"""Farthest point from the origin an ``"aeqd"`` frame maps (m): 1000 km, where the scale
across the radius (c / sin c for central angle c) exceeds 1 by 0.4 %."""

UTM_MAX_OFFSET_DEG = 6.0
"""Farthest longitude from the zone's central meridian a ``"utm"`` frame maps (degrees): twice
the zone's half-width, where the scale error reaches about 0.6 % at the equator."""

UTM_LAT_RANGE = (-80.0, 84.0)
"""Latitudes (degrees) UTM covers; the polar regions use UPS instead."""


def _check_lat(name: str, value: Any) -> float:
    lat = check_real(name, value)
    if not -90.0 <= lat <= 90.0:
        raise ValueError(f"{name} must be a latitude in [-90, 90] degrees, got {lat}")
    return lat


def _check_lon(name: str, value: Any) -> float:
    lon = check_real(name, value)
    if not -180.0 <= lon <= 180.0:
        raise ValueError(f"{name} must be a longitude in [-180, 180] degrees, got {lon}")
    return lon


def check_origin(origin: Any, name: str = "origin") -> tuple[float, float, float]:
    """``origin`` as (lat, lon, alt): a :class:`LocalFrame` (its origin) or a sequence (lat, lon) or
    (lat, lon, alt).

    origin: latitude in [-90, 90] degrees, longitude in [-180, 180] degrees, altitude in metres
        above mean sea level (default 0 m); all finite.
    name: the parameter's name, used in error messages.

    Raises a one-line ValueError (TypeError for a wrong type) naming ``name``.
    """
    if isinstance(origin, LocalFrame):
        return origin.origin
    if isinstance(origin, (str, bytes)) or not hasattr(origin, "__len__"):
        raise TypeError(f"{name} must be (lat, lon) or (lat, lon, alt) in degrees and metres, got {origin!r}")
    if len(origin) not in (2, 3):
        raise ValueError(f"{name} must be (lat, lon) or (lat, lon, alt), got {len(origin)} values")
    lat = _check_lat(f"{name} latitude", origin[0])
    lon = _check_lon(f"{name} longitude", origin[1])
    alt = check_real(f"{name} altitude", origin[2]) if len(origin) == 3 else 0.0
    return lat, lon, alt


def check_lat_lon(lat: ArrayLike, lon: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """``lat`` and ``lon`` as float arrays of one shape, finite and in range (degrees).

    lat: latitudes in [-90, 90] degrees (a scalar or an array of any shape).
    lon: longitudes in [-180, 180] degrees, of the same shape as ``lat``.
    """
    la = _float_array("lat", lat)
    lo = _float_array("lon", lon)
    if la.shape != lo.shape:
        raise ValueError(f"lat and lon must have the same shape, got {la.shape} and {lo.shape}")
    if np.any(np.abs(la) > 90.0):
        raise ValueError(f"lat must be in [-90, 90] degrees, got {la[np.abs(la) > 90.0].flat[0]}")
    if np.any(np.abs(lo) > 180.0):
        raise ValueError(f"lon must be in [-180, 180] degrees, got {lo[np.abs(lo) > 180.0].flat[0]}")
    return la, lo


def _float_array(name: str, value: Any) -> NDArray[np.float64]:
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise TypeError(f"{name} must be real numbers, got {type(value).__name__}") from None
    if arr.dtype == object or np.asarray(value).dtype.kind in "bUSO":
        raise TypeError(f"{name} must be real numbers, got {np.asarray(value).dtype}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must be finite, got {arr[~np.isfinite(arr)].flat[0]}")
    return arr


def _aeqd_latitude(lat: float) -> float:
    """The latitude (degrees) of an aeqd projection's centre: PROJ takes a centre within 1e-10 rad
    (6e-9 degrees, 0.6 mm) of the equator for the equator in some formulas and not in others, so a
    centre within 1e-8 degrees (1.1 mm) of it is put on it for all of them."""
    return 0.0 if abs(lat) < 1e-8 else lat


def _utm_zone(lon: float) -> int:
    return min(int((lon + 180.0) // 6.0) + 1, 60)


def _wrap_degrees(d: NDArray[np.float64]) -> NDArray[np.float64]:
    return np.asarray((d + 180.0) % 360.0 - 180.0, dtype=np.float64)


@dataclass(frozen=True)
class LocalFrame:
    """A local metric frame (metres, east = +x, north = +y, origin at (0, 0)) tied to WGS 84.

    Build one with :meth:`from_origin` or :meth:`for_points`; the module docstring states what
    each projection supports.

    origin: (lat, lon, alt) of the point (0, 0, 0): degrees, degrees, metres above mean sea level.
    crs: the pyproj ``CRS`` of the projection.
    kind: ``"aeqd"``, ``"utm"`` or ``"crs"`` (another projected CRS given by the caller).
    description: one line stating the projection and the extent it supports.
    """

    origin: tuple[float, float, float]
    crs: Any = field(repr=False)
    kind: str
    description: str
    offset: tuple[float, float] = (0.0, 0.0)
    """Projected coordinates (m) of the origin, subtracted so that the origin maps to (0, 0)."""
    _forward: Any = field(default=None, repr=False, compare=False)
    _inverse: Any = field(default=None, repr=False, compare=False)

    def __post_init__(self) -> None:
        if self._forward is None or self._inverse is None:  # built directly: make the transformers
            import pyproj

            forward = pyproj.Transformer.from_crs("EPSG:4326", self.crs, always_xy=True)
            inverse = pyproj.Transformer.from_crs(self.crs, "EPSG:4326", always_xy=True)
            object.__setattr__(self, "_forward", forward)
            object.__setattr__(self, "_inverse", inverse)

    @classmethod
    def from_origin(cls, lat: float, lon: float, alt: float = 0.0, crs: Any = "aeqd") -> LocalFrame:
        """The local frame about (lat, lon, alt).

        lat: latitude of the origin in [-90, 90] degrees (WGS 84).
        lon: longitude of the origin in [-180, 180] degrees (WGS 84).
        alt: altitude of the origin (m above mean sea level), the frame's z = 0.
        crs: ``"aeqd"`` (default: azimuthal equidistant on the WGS 84 ellipsoid about the origin),
            ``"utm"`` (the origin's UTM zone) or any projected CRS with metre axes pyproj knows
            (``"EPSG:32632"``, a WKT or PROJ string, a ``pyproj.CRS``).

        Raises a one-line ValueError naming the field for an origin out of range or not finite,
        a CRS pyproj does not know, a geographic CRS, or a CRS whose axes are not in metres.
        """
        lat = _check_lat("lat", lat)
        lon = _check_lon("lon", lon)
        alt = check_real("alt", alt)
        import pyproj

        if isinstance(crs, str) and crs.strip().lower() == "aeqd":
            proj = pyproj.CRS.from_proj4(
                f"+proj=aeqd +lat_0={_aeqd_latitude(lat)!r} +lon_0={lon!r} "
                "+x_0=0 +y_0=0 +datum=WGS84 +units=m +no_defs"
            )
            text = (
                f"azimuthal equidistant on WGS 84 about ({lat:.6f}, {lon:.6f}); "
                f"points up to {AEQD_MAX_DISTANCE / 1000:.0f} km from the origin"
            )
            return cls._build((lat, lon, alt), proj, "aeqd", text)
        if isinstance(crs, str) and crs.strip().lower() == "utm":
            if not UTM_LAT_RANGE[0] <= lat <= UTM_LAT_RANGE[1]:
                raise ValueError(f"lat: UTM covers latitudes in [-80, 84] degrees, got {lat}")
            zone = _utm_zone(lon)
            code = (32600 if lat >= 0 else 32700) + zone
            text = (
                f"UTM zone {zone}{'N' if lat >= 0 else 'S'} (EPSG:{code}) shifted to "
                f"({lat:.6f}, {lon:.6f}); longitudes within {UTM_MAX_OFFSET_DEG:g} degrees "
                f"of {zone * 6 - 183} E, latitudes in [-80, 84]"
            )
            return cls._build((lat, lon, alt), pyproj.CRS.from_epsg(code), "utm", text)
        try:
            proj = pyproj.CRS.from_user_input(crs)
        except (pyproj.exceptions.CRSError, TypeError, ValueError):
            raise ValueError(
                f"crs: pyproj does not know {crs!r} (use 'aeqd', 'utm' or a projected CRS)"
            ) from None
        if not proj.is_projected:
            raise ValueError(f"crs: {proj.name!r} is not a projected CRS (local frames are in metres)")
        units = {axis.unit_name for axis in proj.axis_info[:2]}
        if units != {"metre"}:
            raise ValueError(f"crs: {proj.name!r} has axes in {sorted(units)}, not metres")
        text = f"{proj.name} shifted to ({lat:.6f}, {lon:.6f}); points in its area of use"
        return cls._build((lat, lon, alt), proj, "crs", text)

    @classmethod
    def for_points(cls, lat: ArrayLike, lon: ArrayLike, alt: float = 0.0) -> LocalFrame:
        """A frame that holds every point: ``"aeqd"`` about their centroid when they lie within
        :data:`AEQD_MAX_DISTANCE` of it, else ``"utm"`` about it when they lie in its zone's usable
        band; ``description`` states the choice.

        lat: latitudes of the points (degrees, any shape, at least one point).
        lon: longitudes of the points (degrees, same shape).
        alt: altitude of the origin (m above mean sea level).

        The centroid is the mean of the points' unit vectors on the sphere, which is the mean
        lat/lon for a local data set and also works across the antimeridian. Raises ValueError
        when no built-in projection holds the points.
        """
        la, lo = check_lat_lon(lat, lon)
        if la.size == 0:
            raise ValueError("lat: no points")
        c_lat, c_lon = spherical_centroid(la.ravel(), lo.ravel())
        frame = cls.from_origin(c_lat, c_lon, alt)
        reach = frame.distance_from_origin(la, lo)
        if float(reach.max()) <= AEQD_MAX_DISTANCE:
            return frame.with_description(
                f"{frame.description} (chosen: the points lie within "
                f"{float(reach.max()) / 1000:.3g} km of their centroid)"
            )
        if UTM_LAT_RANGE[0] <= c_lat <= UTM_LAT_RANGE[1]:
            utm = cls.from_origin(c_lat, c_lon, alt, crs="utm")
            if utm._outside(la, lo) is None:
                return utm.with_description(
                    f"{utm.description} (chosen: the points reach "
                    f"{float(reach.max()) / 1000:.4g} km from their centroid)"
                )
        raise ValueError(
            f"lat, lon: the points reach {float(reach.max()) / 1000:.4g} km from their centroid, beyond "
            f"{AEQD_MAX_DISTANCE / 1000:.0f} km (aeqd) and the centroid's UTM band; split the data set"
        )

    @classmethod
    def _build(cls, origin: tuple[float, float, float], proj: Any, kind: str, text: str) -> LocalFrame:
        import pyproj

        forward = pyproj.Transformer.from_crs("EPSG:4326", proj, always_xy=True)
        inverse = pyproj.Transformer.from_crs(proj, "EPSG:4326", always_xy=True)
        x0, y0 = forward.transform(origin[1], origin[0], errcheck=False)
        if not (math.isfinite(x0) and math.isfinite(y0)):
            raise ValueError(f"crs: the origin ({origin[0]}, {origin[1]}) lies outside {proj.name!r}")
        # aeqd maps the origin to (0, 0) up to PROJ's snapping of a latitude within 1e-10 rad of the
        # equator onto it; subtracting the origin's image makes (0, 0) exact for every projection
        offset = (float(x0), float(y0))
        return cls(origin, proj, kind, text, offset, forward, inverse)

    def with_description(self, description: str) -> LocalFrame:
        """The same frame with another ``description`` (one line of text)."""
        return LocalFrame(
            self.origin, self.crs, self.kind, description, self.offset, self._forward, self._inverse
        )

    def distance_from_origin(self, lat: ArrayLike, lon: ArrayLike) -> NDArray[np.float64]:
        """Geodesic distances (m, on the WGS 84 ellipsoid) from the origin to points (lat, lon) in degrees."""
        import pyproj

        la, lo = check_lat_lon(lat, lon)
        geod = pyproj.Geod(ellps="WGS84")
        _, _, dist = geod.inv(np.full(la.shape, self.origin[1]), np.full(la.shape, self.origin[0]), lo, la)
        return np.asarray(dist, dtype=np.float64)

    def _outside(self, lat: NDArray[np.float64], lon: NDArray[np.float64]) -> str | None:
        """Why some point (degrees) lies beyond what the frame supports, or None."""
        if lat.size == 0:
            return None
        if self.kind == "aeqd":
            dist = self.distance_from_origin(lat, lon)
            if float(dist.max()) > AEQD_MAX_DISTANCE:
                return (
                    f"a point is {float(dist.max()) / 1000:.6g} km from the origin, more than the "
                    f"{AEQD_MAX_DISTANCE / 1000:.0f} km an aeqd frame supports"
                )
            return None
        if self.kind == "utm":
            zone = _utm_zone(self.origin[1])
            off = np.abs(_wrap_degrees(lon - (zone * 6.0 - 183.0)))
            if float(off.max()) > UTM_MAX_OFFSET_DEG:
                return (
                    f"a point is {float(off.max()):.6g} degrees of longitude from the central meridian "
                    f"of UTM zone {zone}, more than {UTM_MAX_OFFSET_DEG:g}"
                )
            if float(lat.min()) < UTM_LAT_RANGE[0] or float(lat.max()) > UTM_LAT_RANGE[1]:
                return "a point lies outside UTM's latitudes [-80, 84] degrees"
            return None
        area = self.crs.area_of_use
        if area is None:
            return None
        inside = (
            (lat >= area.south - 1e-9)
            & (lat <= area.north + 1e-9)
            & (
                (lon >= area.west - 1e-9) & (lon <= area.east + 1e-9)
                if area.west <= area.east
                else (lon >= area.west - 1e-9) | (lon <= area.east + 1e-9)
            )
        )
        if not inside.all():
            return f"a point lies outside the area of use of {self.crs.name!r} ({area.name})"
        return None

    def to_local(self, lat: ArrayLike, lon: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Local coordinates (x east, y north; metres) of points given in WGS 84 degrees.

        lat: latitudes in [-90, 90] degrees (a scalar or an array of any shape).
        lon: longitudes in [-180, 180] degrees, same shape as ``lat``.

        Returns (x, y), float arrays of the shape of ``lat``. Raises ValueError (naming lat, lon)
        for points outside the extent the frame supports (module docstring).
        """
        la, lo = check_lat_lon(lat, lon)
        why = self._outside(la, lo)
        if why is not None:
            raise ValueError(f"lat, lon: {why}")
        x, y = self._forward.transform(lo, la, errcheck=False)
        x = np.asarray(x, dtype=np.float64) - self.offset[0]
        y = np.asarray(y, dtype=np.float64) - self.offset[1]
        if not (np.all(np.isfinite(x)) and np.all(np.isfinite(y))):
            raise ValueError(f"lat, lon: a point has no image in {self.crs.name!r}")
        return x, y

    def to_wgs84(self, x: ArrayLike, y: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """WGS 84 (lat, lon) in degrees of local points (x east, y north; metres).

        x: east coordinates (m, a scalar or an array of any shape).
        y: north coordinates (m), same shape as ``x``.

        Returns (lat, lon), float arrays of the shape of ``x``, lon in [-180, 180]. Raises
        ValueError (naming x, y) for points beyond the extent the frame supports.
        """
        xs = _float_array("x", x)
        ys = _float_array("y", y)
        if xs.shape != ys.shape:
            raise ValueError(f"x and y must have the same shape, got {xs.shape} and {ys.shape}")
        if self.kind == "aeqd" and xs.size and float(np.hypot(xs, ys).max()) > AEQD_MAX_DISTANCE:
            raise ValueError(
                f"x, y: a point is {float(np.hypot(xs, ys).max()) / 1000:.6g} km from the origin, more than "
                f"the {AEQD_MAX_DISTANCE / 1000:.0f} km an aeqd frame supports"
            )
        lo, la = self._inverse.transform(xs + self.offset[0], ys + self.offset[1], errcheck=False)
        la = np.asarray(la, dtype=np.float64)
        lo = np.asarray(lo, dtype=np.float64)
        if not (np.all(np.isfinite(la)) and np.all(np.isfinite(lo))):
            raise ValueError(f"x, y: a point has no position in {self.crs.name!r}")
        lo = _wrap_degrees(lo)
        if self.kind != "aeqd":
            why = self._outside(la, lo)
            if why is not None:
                raise ValueError(f"x, y: {why}")
        return la, lo


def spherical_centroid(lat: NDArray[np.float64], lon: NDArray[np.float64]) -> tuple[float, float]:
    """(lat, lon) in degrees of the mean of the points' unit vectors on the sphere.

    lat: (n,) latitudes in degrees. lon: (n,) longitudes in degrees.

    Raises ValueError when the points are spread over the globe so that the mean vanishes.
    """
    lam, phi = np.radians(lon), np.radians(lat)
    v = np.stack([np.cos(phi) * np.cos(lam), np.cos(phi) * np.sin(lam), np.sin(phi)], axis=-1).reshape(-1, 3)
    mean = v.mean(axis=0)
    norm = float(np.linalg.norm(mean))
    if norm < 1e-9:
        raise ValueError(
            "lat, lon: the points are spread over the globe and have no centroid; pass an origin"
        )
    return (
        math.degrees(math.atan2(mean[2], math.hypot(mean[0], mean[1]))),
        math.degrees(math.atan2(mean[1], mean[0])),
    )
