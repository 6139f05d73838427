"""Write the interactive maps the documentation embeds (``docs/maps/*.html``).

Run it after changing the maps (``studies/plots/maps/``)::

    python docs/make_maps.py

``placement.html`` is the drone-cell placement of the thesis instance (Table 4.2, seed 0) with two
drone-cells, as the greedy placement puts them; the page loads Leaflet from its CDN.
"""

from __future__ import annotations

from pathlib import Path

OUT = Path(__file__).resolve().parent / "maps"


def main() -> list[Path]:
    """Write the maps; returns their paths."""
    import droneplan as dp
    from droneplan.studies.plots.maps import map_html

    problem = dp.cells.thesis_problem(n_cells=2, seed=0)
    plan = dp.cells.greedy_placement(problem)
    OUT.mkdir(exist_ok=True)
    page = OUT / "placement.html"
    page.write_text(map_html(dp.cells.map(problem, plan)), encoding="utf-8")
    return [page]


if __name__ == "__main__":
    for path in main():
        print(f"wrote {path} ({path.stat().st_size / 1000:.0f} kB)")
