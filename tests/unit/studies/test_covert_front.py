"""The optimised stealth-vs-arrival front: every point is a closed-loop run that arrived by its limit
and lies on or above the whole-mission lower bound of its class, the bound curve lies below every
point's own bound, the front is never worse than the thesis's sliding mode where that arrives in
time, and bad input is refused naming the parameter."""

import math

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
import pytest

from droneplan.core.validation import work_limits
from droneplan.planners.covert import SlidingModeObserver
from droneplan.scenarios.covert import simulate, thesis_case
from droneplan.studies.plots.covert import plot_optimised_front
from droneplan.studies.thesis.covert_front import optimised_front

DEG = 180.0 / math.pi


@pytest.fixture(scope="module")
def case1():
    return thesis_case(1)


@pytest.fixture(scope="module")
def front(case1):
    # 3 s: before any controller can reach the sphere (57 m at V_max = 10 m/s); 12 s: after the
    # sliding mode's arrival, so the MPC search must beat or equal it
    return optimised_front(case1, [3.0, 12.0], tries=1, step=2.0, n_curve=3)


def test_points_arrive_in_time_and_lie_on_or_above_their_bound(front):
    points, _ = front
    found = points.dropna(subset=["beta_max_deg"])
    assert len(found) == 1
    assert (found.t_a <= found.arrival_limit_s + 1e-9).all()
    assert (found.beta_max_deg >= found.bound_deg - 1e-6).all()
    assert np.allclose(found.certified_within_deg, found.beta_max_deg - found.bound_deg)


def test_unreachable_limit_has_no_point(front, case1):
    points, _ = front
    row = points[points.arrival_limit_s == 3.0].iloc[0]
    p = case1.params
    assert (np.linalg.norm(p.D_s_arr - p.F_arr) - p.L_u) / p.V_max > 3.0  # no controller can make it
    assert pd.isna(row.method) and math.isnan(row.beta_max_deg)


def test_front_no_worse_than_sliding_mode_when_it_arrives_in_time(front, case1):
    points, _ = front
    sliding = simulate(case1, SlidingModeObserver())
    row = points[points.arrival_limit_s == 12.0].iloc[0]
    assert sliding.t_a is not None and sliding.t_a <= 12.0
    assert row.beta_max_deg <= sliding.beta_max * DEG + 1e-9


def test_curve_lies_below_each_points_bound(front):
    points, curve = front
    found = points.dropna(subset=["beta_max_deg"])
    for _, r in found.iterrows():
        at = curve.bound_deg[np.isclose(curve.t_a, r.arrival_limit_s)]
        assert len(at) == 1 and float(at.iloc[0]) <= r.bound_deg + 1e-6
    # later arrival admits more controllers: the curve is non-increasing
    assert (np.diff(curve.bound_deg.to_numpy()) <= 1e-6).all()


def test_plot_draws_points_and_curve(front):
    points, curve = front
    fig = plot_optimised_front(points, curve, title="case 1")
    ax = fig.axes[0]
    assert len(ax.lines) >= 4 and any("+" in t.get_text() for t in ax.texts)
    plt.close(fig)


@pytest.mark.parametrize(
    ("limits", "exc"),
    [
        ([math.nan], ValueError),
        ([-1.0], ValueError),
        ([0.0], ValueError),
        ([], ValueError),
        ("10", TypeError),
        (None, TypeError),
        ([True], TypeError),
    ],
)
def test_bad_arrival_times_refused(case1, limits, exc):
    with pytest.raises(exc, match="arrival_times"):
        optimised_front(case1, limits)


@pytest.mark.parametrize(
    ("kw", "exc"),
    [
        ({"tries": 0}, ValueError),
        ({"tries": 1.5}, TypeError),
        ({"step": 0.0}, ValueError),
        ({"step": math.nan}, ValueError),
        ({"slack": -1.0}, ValueError),
        ({"margin_deg": 0.0}, ValueError),
        ({"n_curve": 0}, ValueError),
        ({"backend": 3}, TypeError),
    ],
)
def test_bad_settings_refused(case1, kw, exc):
    with pytest.raises(exc, match=next(iter(kw))):
        optimised_front(case1, [12.0], **kw)


def test_scenario_type_checked():
    with pytest.raises(TypeError, match="scenario"):
        optimised_front("case 1", [12.0])


def test_section_refuses_bad_flags(tmp_path):
    from droneplan.studies.thesis.covert_front import optimised_front_section

    with pytest.raises(TypeError, match="quick"):
        optimised_front_section(1, tmp_path, quick="yes")
    with pytest.raises(TypeError, match="out"):
        optimised_front_section(1, None, quick=True)
    with pytest.raises(ValueError, match="case"):
        optimised_front_section(3, tmp_path, quick=True)


def test_a_search_beyond_the_evaluations_budget_is_refused_up_front():
    scenario = thesis_case(1)
    with pytest.raises(ValueError, match=r"^arrival_times asks for \d+ evaluations, more than the limit"):
        optimised_front(scenario, np.arange(8.0, 108.0, 1.0), tries=2)
    with work_limits(evaluations=10), pytest.raises(ValueError, match="arrival_times"):
        optimised_front(scenario, [3.0], tries=1)
