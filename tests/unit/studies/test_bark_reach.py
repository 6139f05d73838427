"""The measurements behind the traced herding findings: barked animals per count, sweep points."""

from __future__ import annotations

import pytest

from droneplan.studies.store import load_results
from droneplan.studies.thesis.bark_reach import bark_reach, run_sweep_points


def test_bark_reach_counts_animals_in_the_cones_and_a_wider_cone_reaches_more_at_the_start():
    short = dict(t_max=30.0, every=10.0)
    narrow = bark_reach(40, R_b=40.0, **short)
    wide = bark_reach(40, R_b=400.0, **short)
    for r in (narrow, wide):
        assert r["frames"] >= 3 and 0.0 <= r["mean_reached"] <= 40.0
        assert r["share_reached"] == pytest.approx(r["mean_reached"] / 40)
    # a 400 m cone from the extended hull holds every animal in front of the drones
    assert wide["mean_reached"] > narrow["mean_reached"]


@pytest.mark.parametrize(
    ("kwargs", "error"),
    [
        ({"n_animals": 0}, "n_animals"),
        ({"n_animals": 10, "t_max": 0.0}, "t_max"),
        ({"n_animals": 10, "every": -1.0}, "every"),
    ],
)
def test_bark_reach_refuses_bad_input_by_name(kwargs, error):
    n = kwargs.pop("n_animals")
    with pytest.raises(ValueError, match=error):
        bark_reach(n, **kwargs)


def test_sweep_points_go_to_the_store_under_the_reproductions_ids_and_resume(tmp_path):
    rows = run_sweep_points(tmp_path, "d_s", [70.0], n_animals=30, seeds=1)
    assert sorted(rows["method"]) == ["benchmark", "proposed"]
    assert (
        rows["instance"].str.startswith("fig6.8-6.10:").all()
        and rows["instance"].str.contains("d_s=70").all()
    )
    again = run_sweep_points(tmp_path, "d_s", [70.0], n_animals=30, seeds=1)
    assert len(load_results(tmp_path)) == 2 and list(again["objective"]) == list(rows["objective"])
    with pytest.raises(ValueError, match="sweep must be one of"):
        run_sweep_points(tmp_path, "wind", [1.0])
