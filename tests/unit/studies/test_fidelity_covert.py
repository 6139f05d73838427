"""The covert layout study: the whole-mission bound lies below the sliding-mode run it is computed
for, the sweep's scenes vary only the named feature, and bad input is refused."""

import pytest

from droneplan.planners.covert import SlidingModeObserver
from droneplan.scenarios.covert import simulate, thesis_case
from droneplan.studies.thesis.fidelity_covert import (
    BASE,
    consistent_layouts,
    feature_sweep,
    figure_checks,
    margin_row,
    two_target_scene,
)


def test_bound_below_the_sliding_mode_run():
    row = margin_row(two_target_scene(**BASE), bound_step=2.0)
    assert row["bound_deg"] <= row["sliding_deg"] + 1e-6  # sliding mode is in the bound's class
    assert row["max_margin_pct"] >= row["margin_pct"] - 1e-9
    assert 0.0 < row["hover_deg"] < 90.0


def test_sweep_changes_one_feature():
    rows = feature_sweep({"hill_m": (0.0, 25.0)})
    assert [r["value"] for r in rows] == [0.0, 25.0]
    flat, base = rows
    # the hill only lifts target 1's second half: hover sees the same first half, and the base row
    # is the BASE scene itself
    assert base["sliding_deg"] == pytest.approx(margin_row(two_target_scene(**BASE))["sliding_deg"])
    assert flat["t_a"] == pytest.approx(base["t_a"], abs=0.5)


def test_consistent_layouts_keep_exactly_the_layouts_that_pass():
    import numpy as np

    from droneplan.studies.thesis.fidelity_covert import SEARCH_RANGES

    rows = consistent_layouts(n_samples=3, seed=7, ignore=("in_zone", "t_a", "t_f", "beta_down_up"))
    rng = np.random.default_rng(7)
    expected = []
    for _ in range(3):  # the same draws, filtered here
        kw = {k: round(float(rng.uniform(lo, hi)), 1) for k, (lo, hi) in SEARCH_RANGES.items()}
        sc = two_target_scene(**kw)
        checks = figure_checks(sc, simulate(sc, SlidingModeObserver()))
        if checks["approach_then_drift"] and checks["climb"] and checks["away"]:
            expected.append(kw)
    assert [{k: r[k] for k in SEARCH_RANGES} for r in rows] == expected


def test_bad_input():
    with pytest.raises(ValueError, match="features"):
        feature_sweep({"colour": (1.0,)})
    with pytest.raises(TypeError, match="scenario"):
        margin_row("case 1")
    with pytest.raises(ValueError, match="bound_step"):
        margin_row(thesis_case(1), bound_step=0.0)
    with pytest.raises(ValueError, match="two targets"):
        figure_checks(thesis_case(2), None)
    with pytest.raises(ValueError, match="V_T"):
        two_target_scene(V_T=-1.0)
    with pytest.raises(ValueError, match="n_samples"):
        consistent_layouts(n_samples=0)
