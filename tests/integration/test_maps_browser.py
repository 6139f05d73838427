"""The interactive maps render in a real browser, offline: headless Chromium opens a map page with
Leaflet written into it and the DOM it builds holds one SVG marker per drone-cell, GBS, user,
drone and animal drawn.

Leaflet is not part of droneplan: the test takes the ``dist/`` files of the ``leaflet`` npm
package at folium's version, fetched once with ``npm pack`` into ``.cache/`` (or from the folder
in ``DRONEPLAN_LEAFLET_DIR``), and skips with the reason when neither is there."""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import tarfile
from pathlib import Path

import numpy as np
import pytest

import droneplan as dp
from droneplan.studies.plots.maps import map_html

LEAFLET_VERSION = "1.9.3"  # the version folium's pages load
CACHE = Path(__file__).resolve().parents[2] / ".cache" / f"leaflet-{LEAFLET_VERSION}"
CHROMIUM = next(
    (path for path in map(shutil.which, ("chromium", "chromium-browser", "google-chrome")) if path), None
)

pytestmark = [
    pytest.mark.slow,
    pytest.mark.skipif(
        CHROMIUM is None, reason="no headless Chromium on this machine (apt-get install chromium)"
    ),
]


def _leaflet_dir() -> Path:
    """A folder with ``leaflet.js`` and ``leaflet.css``: ``DRONEPLAN_LEAFLET_DIR``, or the npm
    package's ``dist/`` unpacked into ``.cache/`` (fetched once with ``npm pack``)."""
    given = os.environ.get("DRONEPLAN_LEAFLET_DIR")
    folder = Path(given) if given else CACHE
    if (folder / "leaflet.js").is_file():
        return folder
    npm = shutil.which("npm")
    if given or npm is None:
        pytest.skip(f"Leaflet {LEAFLET_VERSION} is not in {folder} and npm is not there to fetch it")
    folder.mkdir(parents=True, exist_ok=True)
    done = subprocess.run(
        [npm, "pack", f"leaflet@{LEAFLET_VERSION}", "--pack-destination", str(folder)],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    packs = sorted(folder.glob("leaflet-*.tgz"))
    if done.returncode != 0 or not packs:
        pytest.skip(f"npm could not fetch leaflet@{LEAFLET_VERSION}: {done.stderr.strip()[-300:]}")
    with tarfile.open(packs[0]) as pack:
        for name in ("leaflet.js", "leaflet.css"):
            member = pack.extractfile(f"package/dist/{name}")
            if member is None:
                pytest.skip(f"the leaflet package has no dist/{name}")
            (folder / name).write_bytes(member.read())
    return folder


def _rendered(tmp_path: Path, fmap) -> str:
    """The DOM headless Chromium builds from the map page (Leaflet inlined, no network)."""
    page = tmp_path / "map.html"
    page.write_text(map_html(fmap, leaflet=_leaflet_dir()), encoding="utf-8")
    command = [
        str(CHROMIUM),
        "--headless",
        "--no-sandbox",
        "--disable-gpu",
        "--disable-quic",
        "--no-first-run",
        "--disable-background-networking",
        "--disable-component-update",
        "--disable-sync",
        f"--user-data-dir={tmp_path / 'profile'}",
        "--virtual-time-budget=5000",
        "--dump-dom",
        page.as_uri(),
    ]
    done = subprocess.run(command, capture_output=True, text=True, timeout=120, check=False)
    assert done.returncode == 0, done.stderr[-2000:]
    return done.stdout


def _markers(dom: str, class_name: str) -> int:
    """How many rendered elements carry the CSS class ``class_name``."""
    return len(re.findall(rf'class="[^"]*\b{re.escape(class_name)}(?=[ "])', dom))


def test_a_cells_map_renders_every_marker(tmp_path):
    problem = dp.cells.thesis_problem(n_cells=2, seed=0)
    plan = dp.cells.greedy_placement(problem)
    ev = dp.cells.evaluate(problem, plan)
    dom = _rendered(tmp_path, dp.cells.map(problem, plan))
    assert _markers(dom, "leaflet-container") == 1
    assert _markers(dom, "dp-cell") == len(plan) == 2
    assert _markers(dom, "dp-gbs") == len(problem.gbs)
    assert _markers(dom, "dp-link") == int(ev.connected.sum())
    assert _markers(dom, "dp-user-covered") == ev.covered
    served = int(np.sum(~problem.active))
    assert _markers(dom, "dp-user-uncovered") == len(problem.users) - ev.covered - served
    assert _markers(dom, "dp-user-gbs") == served


def test_a_herding_map_renders_the_sampled_herd_and_the_slider(tmp_path):
    scenario = dp.herding.thesis_scenario(12, seed=0, n_drones=2)
    trace = dp.herding.simulate(scenario, dp.herding.ProposedHerder(), t_max=3.0, seed=0, frame_every=0.5)
    dom = _rendered(tmp_path, dp.herding.map(trace, max_animals=5, origin=(-33.9, 18.4)))
    assert _markers(dom, "dp-animal") == 5
    assert _markers(dom, "dp-drone") == 2
    assert _markers(dom, "dp-goal") == 1
    assert _markers(dom, "dp-time-slider") == 1
