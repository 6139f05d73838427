"""The shared machinery of the interactive maps: the coordinate frame, the Leaflet map itself,
point clouds, moving markers with a time slider, thinning, and the HTML the maps render to."""

from __future__ import annotations

import html
import json
import os
import re
from pathlib import Path
from typing import Any

import folium
import numpy as np
from branca.element import MacroElement
from jinja2 import Template

from droneplan.core.validation import check_int
from droneplan.scenarios.geo import LocalFrame, check_origin

__all__ = [
    "MAX_STEPS",
    "MAX_ANIMALS",
    "LEAFLET_JS",
    "LEAFLET_CSS",
    "Projection",
    "new_map",
    "check_tiles",
    "thin",
    "PointCloud",
    "TimeSlider",
    "TextPopup",
    "popup",
    "check_positions",
    "add_track",
    "map_html",
    "embed_html",
]

MAX_STEPS = 200
"""Default number of recorded instants a trace map keeps for its time slider (count); the
instants are thinned evenly, always keeping the first and the last."""

MAX_ANIMALS = 100
"""Default number of animals a herding map draws (count); a larger herd is sampled evenly."""

LEAFLET_JS = "https://cdn.jsdelivr.net/npm/leaflet@1.9.3/dist/leaflet.js"
"""Where a map loads Leaflet's script from, unless :func:`map_html` inlines a local copy."""

LEAFLET_CSS = "https://cdn.jsdelivr.net/npm/leaflet@1.9.3/dist/leaflet.css"
"""Where a map loads Leaflet's style sheet from, unless :func:`map_html` inlines a local copy."""


class Projection:
    """Local metres (east x, north y) to Leaflet coordinates.

    origin: None for Leaflet's simple CRS, where a map unit is a metre and a point is [y, x];
    otherwise the point the local (0, 0) stands for, as (lat, lon) or (lat, lon, alt) in degrees
    and metres, or a :class:`~droneplan.scenarios.geo.LocalFrame`: points become WGS 84
    [lat, lon] through that frame.
    """

    def __init__(self, origin: Any = None) -> None:
        self.frame: LocalFrame | None = None
        if origin is not None:
            if isinstance(origin, LocalFrame):
                self.frame = origin
            else:
                lat, lon, alt = check_origin(origin)
                self.frame = LocalFrame.from_origin(lat, lon, alt)

    @property
    def simple(self) -> bool:
        """True when the map uses the simple CRS (metres as map units, no geographic position)."""
        return self.frame is None

    def points(self, xy: Any) -> list[list[float]]:
        """[[lat, lon], ...] (or [[y, x], ...] in the simple CRS) of (n, 2+) local points (m);
        rounded to 1e-7 degrees (about 1 cm) or to 1 cm."""
        arr = np.asarray(xy, dtype=float)
        pts = arr.reshape(-1, arr.shape[-1])[:, :2]
        if self.frame is None:
            return np.round(pts[:, ::-1], 2).tolist()
        lat, lon = self.frame.to_wgs84(pts[:, 0], pts[:, 1])
        return np.round(np.stack([np.atleast_1d(lat), np.atleast_1d(lon)], axis=1), 7).tolist()

    def point(self, xy: Any) -> list[float]:
        """[lat, lon] (or [y, x]) of one local point (m)."""
        return self.points(np.asarray(xy, dtype=float).reshape(1, -1))[0]


def check_tiles(tiles: Any) -> str | None:
    """``tiles`` checked: None (no background, works offline) or a folium tile set name or URL (str)."""
    if tiles is not None and not isinstance(tiles, str):
        raise TypeError(f"tiles must be None or a folium tile name or URL (str), got {type(tiles).__name__}")
    return tiles


def new_map(projection: Projection, extent_xy: Any, *, tiles: str | None = None) -> folium.Map:
    """An empty Leaflet map fitted to the local points ``extent_xy`` ((n, 2) m).

    projection: the coordinate frame; tiles: a folium tile set (None: no background; tiles need
    the network and an origin: a ValueError naming ``tiles`` on the simple CRS). The map loads
    Leaflet alone (none of folium's default jQuery, Bootstrap or Font Awesome assets, which these
    maps do not use), so a local copy of Leaflet is all :func:`map_html` needs to make the page
    work offline.
    """
    if tiles is not None and projection.simple:
        raise ValueError("tiles need an origin=(lat, lon): without one the map is in local metres")
    pts = np.asarray(extent_xy, dtype=float).reshape(-1, 2)
    pts = pts[np.all(np.isfinite(pts), axis=1)]
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    pad = 0.05 * np.maximum(hi - lo, 50.0)
    corners = projection.points(np.array([lo - pad, hi + pad]))
    options: dict[str, Any] = {"tiles": tiles, "control_scale": True, "zoom_snap": 0.25}
    if projection.simple:
        options.update(crs="Simple", minZoom=-20, maxZoom=8)  # Map(min_zoom=) only reaches tile layers
    fmap = folium.Map(location=projection.point((lo + hi) / 2), **options)
    fmap.default_js = [("leaflet", LEAFLET_JS)]
    fmap.default_css = [("leaflet_css", LEAFLET_CSS)]
    fmap.fit_bounds(
        [
            [min(c[0] for c in corners), min(c[1] for c in corners)],
            [max(c[0] for c in corners), max(c[1] for c in corners)],
        ]
    )
    return fmap


def thin(n: int, most: int) -> np.ndarray:
    """Indices of at most ``most`` of ``n`` items, evenly spread, with the first and the last."""
    if n <= most:
        return np.arange(n)
    return np.unique(np.round(np.linspace(0, n - 1, most)).astype(int))


class TextPopup(folium.Popup):
    """A popup of plain-text lines, bound with Leaflet alone (folium's own popup builds its content
    with jQuery, which these maps do not load).

    lines: the popup's lines (plain text; escaped).
    """

    _template = Template("{{ this._parent.get_name() }}.bindPopup({{ this.text_js }}, {maxWidth: 320});\n")

    def __init__(self, lines: tuple[str, ...]) -> None:
        MacroElement.__init__(self)
        self._name = "Popup"
        self.text_js = _js("<br>".join(html.escape(line) for line in lines))


def popup(*lines: str) -> TextPopup:
    """A popup of the given lines (plain text, escaped)."""
    return TextPopup(lines)


def check_positions(name: str, values: Any) -> np.ndarray:
    """``values`` (an array of positions in m) as floats, refused with a ValueError naming ``name``
    when it is empty or holds NaN or inf."""
    arr = np.asarray(values, dtype=float)
    if arr.size == 0:
        raise ValueError(f"{name} holds no recorded position: there is nothing to map")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} holds NaN or inf positions")
    return arr


def add_track(
    group: folium.FeatureGroup,
    proj: Projection,
    path: np.ndarray,
    *,
    color: str,
    class_name: str,
    label: str,
    lines: tuple[str, ...],
    radius: float = 6.0,
) -> tuple[folium.CircleMarker, list[list[float]]]:
    """A path ((T, 2+) local m) drawn as a line, and a marker at its first point that a
    :class:`TimeSlider` moves along it; returns (marker, the path's map points).

    group: the layer both go in; color: CSS colour; class_name: the marker's CSS class;
    label: the tooltip; lines: the popup's lines; radius: the marker's radius (pixels).
    """
    pts = proj.points(path)
    folium.PolyLine(pts, color=color, weight=2, opacity=0.7, tooltip=label).add_to(group)
    marker = folium.CircleMarker(
        pts[0],
        radius=radius,
        color=color,
        fill=True,
        fill_opacity=1.0,
        class_name=class_name,
        popup=popup(*lines),
        tooltip=label,
    )
    marker.add_to(group)
    return marker, pts


def _js(value: Any) -> str:
    """``value`` as JSON that is safe inside a <script> element."""
    return json.dumps(value, separators=(",", ":")).replace("<", "\\u003c").replace(">", "\\u003e")


class PointCloud(folium.map.Layer):
    """Many small circle markers in one layer, drawn from a compact coordinate list (a few bytes a
    point instead of a folium element each). Each marker's SVG path carries ``class_name``.

    points: [[lat, lon], ...]; name: the layer's name in the layer control; color: CSS colour;
    radius: marker radius (pixels); class_name: the CSS class of every marker's path.
    """

    _template = Template(
        """
        {% macro script(this, kwargs) %}
        var {{ this.get_name() }} = L.featureGroup();
        {{ this.points_js }}.forEach(function (p) {
            L.circleMarker(p, {{ this.options_js }}).addTo({{ this.get_name() }});
        });
        {{ this.get_name() }}.addTo({{ this._parent.get_name() }});
        {% endmacro %}
        """
    )

    def __init__(self, points: list[list[float]], name: str, *, color: str, radius: float, class_name: str):
        super().__init__(name=name, overlay=True, control=True, show=True)
        self._name = "PointCloud"
        self.points_js = _js(points)
        self.options_js = _js(
            {
                "radius": radius,
                "color": color,
                "weight": 1,
                "fill": True,
                "fillColor": color,
                "fillOpacity": 0.8,
                "className": class_name,
            }
        )


class TimeSlider(MacroElement):
    """A slider (bottom left) that moves markers along their recorded paths.

    times: the T instants (s) the slider steps through; tracks: (marker, T [lat, lon]) pairs, each
    marker a folium CircleMarker (or Marker) already on the map, moved to its k-th point when
    the slider is at instant k.
    """

    _template = Template(
        """
        {% macro script(this, kwargs) %}
        (function () {
            var times = {{ this.times_js }};
            var tracks = [{% for marker, path in this.tracks %}[{{ marker }}, {{ path }}],{% endfor %}];
            var control = L.control({position: "bottomleft"});
            control.onAdd = function () {
                var div = L.DomUtil.create("div", "leaflet-bar dp-time-slider");
                div.style.background = "white";
                div.style.padding = "4px 8px";
                var input = L.DomUtil.create("input", "", div);
                input.type = "range";
                input.min = 0;
                input.max = times.length - 1;
                input.value = 0;
                input.style.width = "260px";
                var label = L.DomUtil.create("span", "", div);
                function show(k) {
                    tracks.forEach(function (t) { t[0].setLatLng(t[1][k]); });
                    label.textContent = " t = " + times[k].toFixed(1) + " s";
                }
                input.addEventListener("input", function () { show(parseInt(input.value, 10)); });
                L.DomEvent.disableClickPropagation(div);
                show(0);
                return div;
            };
            control.addTo({{ this._parent.get_name() }});
        })();
        {% endmacro %}
        """
    )

    def __init__(self, times: Any, tracks: list[tuple[Any, list[list[float]]]]):
        super().__init__()
        self._name = "TimeSlider"
        self.times_js = _js(np.round(np.asarray(times, dtype=float), 3).tolist())
        self.tracks = [(marker.get_name(), _js(path)) for marker, path in tracks]


def _leaflet_files(leaflet: Any) -> tuple[str, str]:
    """The text of leaflet.js and leaflet.css in the folder ``leaflet``."""
    if isinstance(leaflet, bool) or not isinstance(leaflet, (str, os.PathLike)):
        raise TypeError(
            f"leaflet must be a folder (str or os.PathLike) or None, got {type(leaflet).__name__}"
        )
    folder = Path(leaflet)
    missing = [f for f in ("leaflet.js", "leaflet.css") if not (folder / f).is_file()]
    if missing:
        raise ValueError(f"leaflet: {folder} holds no {' or '.join(missing)}")
    return (folder / "leaflet.js").read_text(encoding="utf-8"), (folder / "leaflet.css").read_text(
        encoding="utf-8"
    )


def map_html(fmap: folium.Map, *, leaflet: Any = None) -> str:
    """The whole HTML page of a map (what ``fmap.save`` writes), as a string.

    fmap: a map from one of the ``map`` functions (a folium Map).
    leaflet: None to load Leaflet from its CDN when the page opens (network needed), or a folder
        holding ``leaflet.js`` and ``leaflet.css`` (version 1.9, from the ``leaflet`` npm package's
        ``dist/``), which are then written into the page: it works offline, from disk, and is about
        160 kB larger.
    """
    if not isinstance(fmap, folium.Map):
        raise TypeError(f"fmap must be a folium Map, got {type(fmap).__name__}")
    page = fmap.get_root().render()
    if leaflet is None:
        return page
    script, style = _leaflet_files(leaflet)
    script_tag = re.compile(r'<script src="' + re.escape(LEAFLET_JS) + r'"></script>')
    style_tag = re.compile(r'<link rel="stylesheet" href="' + re.escape(LEAFLET_CSS) + r'"/>')
    if not (script_tag.search(page) and style_tag.search(page)):
        raise ValueError("fmap: the page loads no Leaflet from the CDN to replace (not a droneplan map?)")
    page = script_tag.sub(lambda _: "<script>" + script.replace("</script", "<\\/script") + "</script>", page)
    return style_tag.sub(lambda _: "<style>" + style + "</style>", page)


def embed_html(fmap: folium.Map, *, height_px: int = 480, title: str = "interactive map") -> str:
    """An ``<iframe>`` holding the whole map page in its ``srcdoc``: drop it into any HTML page
    (a report, a documentation page); the map keeps its own scripts and styles.

    fmap: a map from one of the ``map`` functions (a folium Map).
    height_px: the frame's height (pixels, 100 to 4000); its width is 100 %.
    title: the frame's accessible title (text).
    """
    height_px = check_int("height_px", height_px, min_value=100, max_value=4000)
    if not isinstance(title, str):
        raise TypeError(f"title must be a str, got {type(title).__name__}")
    page = map_html(fmap)
    return (
        f'<iframe srcdoc="{html.escape(page, quote=True)}" title="{html.escape(title, quote=True)}" '
        f'style="width: 100%; height: {height_px}px; border: 1px solid #ddd;" loading="lazy"></iframe>'
    )
