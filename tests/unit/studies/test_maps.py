"""The interactive maps (``droneplan.<problem>.map``): what each layer holds, the popups' numbers,
the coordinate frames, thinning, and the HTML they render to. Rendering in a browser is
tests/integration/test_maps_browser.py."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest

import droneplan as dp
from droneplan.scenarios.geo import LocalFrame
from droneplan.studies.plots.maps import LEAFLET_CSS, LEAFLET_JS, embed_html, map_html
from droneplan.studies.plots.maps.cells import backhaul_tree, placement_report_html


def _problem(**extra) -> dp.cells.CellProblem:
    """One GBS at the origin, three users near (1600, 0) and one far west (m)."""
    return dp.cells.CellProblem(
        [[1500.0, 0.0], [1600.0, 100.0], [1700.0, -100.0], [-1700.0, 50.0]],
        [[0.0, 0.0]],
        2,
        500.0,
        1000.0,
        3500.0,
        3000.0,
        bounds=(-2500.0, 2500.0, -2500.0, 2500.0),
        **extra,
    )


def _classes(page: str) -> dict[str, int]:
    """How many folium markers of each droneplan CSS class a page's script creates."""
    return {
        name: len(re.findall(rf'"className": "{name}"', page))
        for name in (
            "dp-cell",
            "dp-gbs",
            "dp-link",
            "dp-no-fly",
            "dp-drone",
            "dp-animal",
            "dp-shark",
            "dp-target",
        )
    }


def _cloud_points(page: str, class_name: str) -> list:
    """The coordinates of the point cloud whose markers carry ``class_name``."""
    for match in re.finditer(
        r"(\[\[.*?\]\])\.forEach\(function \(p\) \{\s*L\.circleMarker\(p, (\{.*?\})\)", page
    ):
        if json.loads(match.group(2))["className"] == class_name:
            return json.loads(match.group(1))
    return []


def test_cells_map_draws_every_drone_cell_gbs_link_and_user():
    problem = _problem()
    plan = np.array([[1600.0, 0.0]])
    page = map_html(dp.cells.map(problem, plan))
    counts = _classes(page)
    assert (counts["dp-cell"], counts["dp-gbs"], counts["dp-link"], counts["dp-no-fly"]) == (1, 1, 1, 0)
    assert len(_cloud_points(page, "dp-user-covered")) == 3
    assert len(_cloud_points(page, "dp-user-uncovered")) == 1
    assert "users covered: 3" in page and "1 hop(s) to a GBS, next GBS 0 at 1600 m" in page
    assert "users covered (3)" in page and "drone-cells (1)" in page  # layer names with counts
    assert "L.tileLayer" not in page  # no background by default: nothing to fetch


def test_cells_map_takes_a_solve_result_and_refuses_one_without_a_plan():
    problem = _problem()
    result = dp.cells.solve_exact(problem, time_limit=30)
    assert _classes(map_html(dp.cells.map(problem, result)))["dp-cell"] == len(result.x)
    empty = dp.SolveResult(status=dp.Status.NO_SOLUTION, objective=None, bound=None, x=None, backend="test")
    with pytest.raises(ValueError, match=r"^result has no plan"):
        dp.cells.map(problem, empty)


def test_cells_map_refuses_a_plan_of_the_wrong_width():
    with pytest.raises(ValueError, match=r"^result"):
        dp.cells.map(_problem(), [[1600.0, 0.0, 200.0]])


def test_a_relay_route_is_counted_in_hops():
    problem = _problem()
    plan = np.array([[3000.0, 0.0], [5500.0, 0.0]])  # the second reaches no GBS (r1 3500 m), only the first
    assert backhaul_tree(problem, plan) == [("gbs", 0, 1, 3000.0), ("cell", 0, 2, 2500.0)]
    far = np.array([[9000.0, 0.0]])
    assert backhaul_tree(problem, far)[0][:3] == ("none", -1, -1)


def test_no_fly_zones_and_altitude_levels_are_shown():
    zone = np.array([[100.0, -500.0], [900.0, -500.0], [900.0, 500.0], [100.0, 500.0], [100.0, -500.0]])
    page = map_html(dp.cells.map(_problem(no_fly=[zone]), [[1600.0, 0.0]]))
    assert _classes(page)["dp-no-fly"] == 1 and "area 0.800 km2" in page
    problem = _problem(altitudes=[200.0, 400.0], channel=dp.cells.AirToGround())
    page = map_html(dp.cells.map(problem, [[1600.0, 0.0, 400.0]]))
    assert "altitude h = 400 m" in page
    assert f"coverage radius {problem.level_radii[1]:.0f} m" in page


def test_an_origin_puts_the_map_on_wgs84_through_the_local_frame():
    origin = (47.5, 8.5)
    page = map_html(dp.cells.map(_problem(), [[1600.0, 0.0]], origin=origin))
    lat, lon = LocalFrame.from_origin(*origin).to_wgs84(np.array([1600.0]), np.array([0.0]))
    assert f"[{round(float(lat[0]), 7)}, {round(float(lon[0]), 7)}]" in page
    assert "L.CRS.Simple" not in page
    assert "L.CRS.Simple" in map_html(dp.cells.map(_problem(), [[1600.0, 0.0]]))
    with pytest.raises(ValueError, match=r"^origin latitude"):
        dp.cells.map(_problem(), [[1600.0, 0.0]], origin=(91.0, 0.0))


def test_trace_maps_thin_the_instants_and_keep_the_first_and_the_last():
    trace = dp.covert.simulate(dp.covert.thesis_case(1), dp.covert.HoverBenchmark(), t_max=5.0)
    page = map_html(dp.covert.map(trace, max_steps=10))
    times = json.loads(re.search(r"var times = (\[.*?\]);", page).group(1))
    assert len(times) == 10 < len(trace.t)
    assert times[0] == pytest.approx(trace.t[0]) and times[-1] == pytest.approx(trace.t[-1], abs=1e-3)
    assert _classes(page)["dp-drone"] == 1 and _classes(page)["dp-target"] == trace.targets.shape[1]


def test_shark_map_states_the_contact():
    trace = dp.shark.simulate(dp.shark.thesis_trajectories(duration=3.0)["a"], dp.shark.ClassicalPursuit())
    page = map_html(dp.shark.map(trace))
    assert (_classes(page)["dp-shark"], _classes(page)["dp-drone"]) == (1, 1)
    assert (f"contact at t = {trace.intercept_time:.1f} s" in page) == trace.intercepted


def test_herding_map_samples_the_animals():
    scenario = dp.herding.thesis_scenario(6, seed=0, n_drones=2)
    trace = dp.herding.simulate(scenario, dp.herding.ProposedHerder(), t_max=2.0, seed=0, frame_every=0.5)
    page = map_html(dp.herding.map(trace, max_animals=3))
    assert _classes(page)["dp-animal"] == 3 and _classes(page)["dp-drone"] == 2
    assert "animals (3 of 6 drawn)" in page


def test_a_herding_run_without_frames_moves_the_drones_and_shows_the_final_herd():
    scenario = dp.herding.thesis_scenario(6, seed=0, n_drones=2)
    trace = dp.herding.simulate(scenario, dp.herding.ProposedHerder(), t_max=2.0, seed=0)
    page = map_html(dp.herding.map(trace, max_steps=5))
    times = json.loads(re.search(r"var times = (\[.*?\]);", page).group(1))
    assert not trace.frames and len(times) == 5 and _classes(page)["dp-animal"] == 6
    tracks = re.search(r"var tracks = \[(.*?)\];\n", page).group(1)
    assert tracks.count("circle_marker_") == 2 + 1  # the drones and the centroid; the animals stay


def test_trace_maps_refuse_other_objects():
    with pytest.raises(TypeError, match=r"^trace must be"):
        dp.herding.map(dp.herding.thesis_scenario(6, seed=0, n_drones=2))


def test_the_page_inlines_a_local_leaflet_and_embeds_in_an_iframe(tmp_path):
    fmap = dp.cells.map(_problem(), [[1600.0, 0.0]])
    online = map_html(fmap)
    assert LEAFLET_JS in online and LEAFLET_CSS in online and "jquery" not in online.lower()
    with pytest.raises(ValueError, match=r"^leaflet"):
        map_html(fmap, leaflet=tmp_path)
    # stand-ins for the npm package's dist/ files: the page must carry them, not the CDN's links
    (tmp_path / "leaflet.js").write_text(
        'window.L = {version: "stand-in"}; // </script> inside', encoding="utf-8"
    )
    (tmp_path / "leaflet.css").write_text(".leaflet-container { color: #123456; }", encoding="utf-8")
    offline = map_html(fmap, leaflet=tmp_path)
    assert LEAFLET_JS not in offline and LEAFLET_CSS not in offline
    assert 'version: "stand-in"' in offline and "#123456" in offline and "// <\\/script> inside" in offline
    frame = embed_html(fmap, height_px=300)
    assert frame.startswith("<iframe srcdoc=") and "height: 300px" in frame and "<script" not in frame


def test_the_report_map_shows_the_thesis_instance():
    section = placement_report_html()
    assert "<iframe srcdoc=" in section and "users covered" in section


def test_the_reproduction_report_embeds_the_placement_map(tmp_path):
    from droneplan.studies.thesis.report import write_report

    (tmp_path / "cells").mkdir()
    (tmp_path / "shark").mkdir()
    page = write_report(tmp_path, problems=["cells", "shark"]).read_text(encoding="utf-8")
    assert page.count("<iframe srcdoc=") == 1 and "Interactive placement map" in page


def test_the_documentation_page_embeds_a_small_committed_map():
    root = Path(__file__).resolve().parents[3]
    page = root / "docs" / "maps" / "placement.html"
    assert page.stat().st_size < 300_000
    assert _classes(page.read_text(encoding="utf-8"))["dp-cell"] == 2
    assert 'src="maps/placement.html"' in (root / "docs" / "maps.md").read_text(encoding="utf-8")
