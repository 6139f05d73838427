"""The plotting helpers: a figure with labelled axes (units) and a legend, with and without ``ax``."""

import re

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
import pytest
from matplotlib.figure import Figure

import droneplan as dp

UNIT = re.compile(r"\((m|s|min|deg|m/s)\)")


@pytest.fixture(scope="module")
def runs():
    cells_problem = dp.cells.CellProblem(
        [[1500.0, 0.0], [1600.0, 100.0], [-2000.0, 0.0], [300.0, 200.0]],
        [[0.0, 0.0]],
        2,
        500,
        1000,
        3500,
        3000,
    )
    covert_sc = dp.covert.thesis_case(1, seed=0)
    covert_tr = {
        "sliding": dp.covert.simulate(covert_sc, dp.covert.SlidingModeObserver(), t_max=6.0),
        "hover": dp.covert.simulate(covert_sc, dp.covert.HoverBenchmark(), t_max=6.0),
    }
    path = dp.shark.thesis_trajectories()["a"]
    shark_tr = {
        "pursuit": dp.shark.simulate(path, dp.shark.ClassicalPursuit()),
        "virtual shark": dp.shark.simulate(path, dp.shark.VirtualSharkInterceptor()),
    }
    herd_sc = dp.herding.thesis_scenario(20, seed=0, field_size=(150.0, 100.0), goal=(-200.0, 50.0))
    herd_tr = dp.herding.simulate(herd_sc, dp.herding.ProposedHerder(), t_max=4.0, seed=1, frame_every=2.0)
    return dict(
        cells=(cells_problem, [[1550.0, 50.0], [1550.0, -1500.0]]),
        covert=(covert_sc, covert_tr),
        shark=shark_tr,
        herding=(herd_sc, herd_tr),
    )


def _calls(r):
    problem, pos = r["cells"]
    sc, ctr = r["covert"]
    hsc, htr = r["herding"]
    return {
        "cells.plot_map": (dp.cells.plot_map, (problem, pos), {}),
        "covert.plot_path": (dp.covert.plot_path, (sc, ctr), {}),
        "covert.plot_bearing": (dp.covert.plot_bearing, (ctr,), {}),
        "shark.plot_top_view": (dp.shark.plot_top_view, (r["shark"],), {}),
        "shark.plot_time_series": (dp.shark.plot_time_series, (r["shark"],), {}),
        "shark.plot_time_series altitude": (dp.shark.plot_time_series, (r["shark"], "altitude"), {}),
        "shark.plot_time_series speed": (dp.shark.plot_time_series, (r["shark"]["pursuit"], "speed"), {}),
        "herding.plot_state trace": (dp.herding.plot_state, (htr, 2.0), {}),
        "herding.plot_state scenario": (dp.herding.plot_state, (hsc,), {}),
        "herding.plot_final": (dp.herding.plot_final, (htr,), {}),
        "herding.plot_footprint": (dp.herding.plot_footprint, ({"proposed": htr},), {"R_c": 60.0}),
    }


def _check(fig, ax):
    assert isinstance(fig, Figure) and ax.figure is fig
    labels = [ax.get_xlabel(), ax.get_ylabel()] + ([ax.get_zlabel()] if ax.name == "3d" else [])
    for lab in labels:
        assert UNIT.search(lab), f"axis label without a unit: {lab!r}"
    legend = ax.get_legend()
    assert legend is not None and len(legend.get_texts()) >= 2


NAMES = list(
    _calls(
        {"cells": (None, None), "covert": (None, None), "shark": {"pursuit": None}, "herding": (None, None)}
    )
)


@pytest.mark.parametrize("name", NAMES)
def test_helper_without_ax_makes_a_figure(runs, name):
    fn, args, kw = _calls(runs)[name]
    fig = fn(*args, **kw)
    try:
        assert len(fig.axes) >= 1
        _check(fig, fig.axes[0])
    finally:
        plt.close(fig)


@pytest.mark.parametrize("name", NAMES)
def test_helper_draws_on_the_given_ax(runs, name):
    fn, args, kw = _calls(runs)[name]
    fig = plt.figure()
    ax = fig.add_subplot(1, 2, 2, projection="3d" if name == "covert.plot_path" else None)
    try:
        assert fn(*args, ax=ax, **kw) is fig
        _check(fig, ax)
    finally:
        plt.close(fig)


def test_goal_and_targets_stay_in_view(runs):
    _, htr = runs["herding"]
    fig = dp.herding.plot_final(htr)
    ax = fig.axes[0]
    (x0, x1), (y0, y1) = ax.get_xlim(), ax.get_ylim()
    try:
        assert x0 < htr.goal[0] < x1 and y0 < htr.goal[1] < y1
        for d in htr.final.drones:
            assert x0 < d[0] < x1 and y0 < d[1] < y1
    finally:
        plt.close(fig)
    sc, ctr = runs["covert"]
    fig = dp.covert.plot_path(sc, ctr)
    ax = fig.axes[0]
    try:
        for lo_hi, k in ((ax.get_xlim(), 0), (ax.get_ylim(), 1), (ax.get_zlim(), 2)):
            for pt in (sc.params.F_arr, sc.params.R_arr, sc.params.D_s_arr):
                assert lo_hi[0] <= pt[k] <= lo_hi[1]
    finally:
        plt.close(fig)


def test_cells_map_shows_the_covered_users(runs):
    problem, pos = runs["cells"]
    fig = dp.cells.plot_map(problem, pos)
    try:
        texts = [t.get_text() for t in fig.axes[0].get_legend().get_texts()]
        covered = dp.cells.evaluate(problem, pos).covered
        assert f"covered users ({covered})" in texts and covered >= 2
    finally:
        plt.close(fig)


def test_helpers_refuse_bad_axes_and_inputs(runs):
    sc, ctr = runs["covert"]
    fig, ax2d = plt.subplots()
    try:
        with pytest.raises(ValueError, match="ax"):
            dp.covert.plot_path(sc, ctr, ax=ax2d)
        with pytest.raises(TypeError, match="ax"):
            dp.shark.plot_top_view(runs["shark"], ax="left")
        with pytest.raises(TypeError, match="traces"):
            dp.covert.plot_bearing({})
        with pytest.raises(ValueError, match="quantity"):
            dp.shark.plot_time_series(runs["shark"], "depth")
        with pytest.raises(TypeError, match="source"):
            dp.herding.plot_state(np.zeros((3, 2)))
    finally:
        plt.close(fig)
