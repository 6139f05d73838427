"""Bad input found by trying the public entries as a new user would: huge magnitudes, extreme
resolutions and steps, empty collections, NaN tolerances. Each case used to hang, allocate
without bound, fail deep inside a third-party library or return a result that looked valid;
each must now refuse up front with a ValueError/TypeError naming the parameter (and, for a
work budget, the size asked for and the limit), or finish within seconds."""

from __future__ import annotations

import math
import time

import numpy as np
import pytest

import droneplan as dp
from droneplan.core.validation import (
    MAX_COORDINATE,
    MAX_ELEMENTS,
    check_array,
    check_sequence,
    check_size,
    check_work,
    current_limit,
    work_limits,
)
from droneplan.solvers.search import first_root_lipschitz

NAN = float("nan")


def _quick(fn, *args, seconds: float = 10.0, **kwargs):
    """Run ``fn`` and require that it refuses within ``seconds``; return the exception."""
    start = time.perf_counter()
    with pytest.raises((ValueError, TypeError)) as info:
        fn(*args, **kwargs)
    assert time.perf_counter() - start < seconds, f"took {time.perf_counter() - start:.1f} s to refuse"
    return info.value


# ----------------------------------------------------------------------------- shared helpers
def test_budget_message_names_parameter_size_and_limit_and_the_limit_can_be_raised():
    with pytest.raises(ValueError, match="t_max") as info:
        check_size("t_max", 10 * MAX_ELEMENTS)
    msg = str(info.value)
    assert str(10 * MAX_ELEMENTS) in msg and str(MAX_ELEMENTS) in msg and "work_limits" in msg
    with work_limits(elements=20 * MAX_ELEMENTS) as limits:
        assert limits["elements"] == 20 * MAX_ELEMENTS == current_limit("elements")
        check_size("t_max", 10 * MAX_ELEMENTS)  # within the raised limit: no error
    assert current_limit("elements") == MAX_ELEMENTS  # restored on exit


def test_budget_refuses_infinite_and_nan_requests():
    for asked in (math.inf, NAN):
        with pytest.raises(ValueError, match="step"):
            check_work("step", asked, "solves")
    with pytest.raises(ValueError, match="elements"), work_limits(elements=0):
        pass
    with pytest.raises(ValueError, match="kind"):
        current_limit("bytes")


def test_magnitudes_whose_squares_overflow_are_refused():
    with pytest.raises(ValueError, match="targets"):
        check_array("targets", [[1e200, 0.0, 0.0]], shape=(None, 3))
    ok = check_array("targets", [[MAX_COORDINATE, 0.0, 0.0]], shape=(None, 3))
    assert ok[0, 0] == MAX_COORDINATE
    assert check_array("big", [1e200], max_abs=None)[0] == 1e200  # the limit can be lifted


def test_check_sequence():
    assert check_sequence("seeds", (0, 1)) == [0, 1]
    with pytest.raises(ValueError, match="seeds"):
        check_sequence("seeds", [])
    for bad in (3, "abc", None, {"a": 1}):
        with pytest.raises(TypeError, match="seeds"):
            check_sequence("seeds", bad)


# ----------------------------------------------------------------------------- covert
@pytest.mark.parametrize("fn", [dp.covert.sphere_minmax_bearing, dp.covert.sphere_minmax_bearing_bnb])
def test_a_target_far_enough_to_overflow_is_refused_not_proven(fn):
    # 1e200 m used to pass the finiteness check and give OPTIMAL 45 deg with a "proven" bound
    err = _quick(fn, dp.covert.THESIS_TABLE_3_2, [[1e200, 0.0, 0.0]])
    assert "targets" in str(err)


def test_far_but_representable_target_gives_a_tiny_bearing_change():
    res = dp.covert.sphere_minmax_bearing_bnb(dp.covert.THESIS_TABLE_3_2, [[1e12, 0.0, 0.0]])
    assert res.bound is not None and res.objective < 1e-3  # the true value is about 0


@pytest.mark.parametrize(
    ("param", "value"), [("tol", NAN), ("tol", -1.0), ("max_cells", 0), ("max_cells", 10**12)]
)
def test_sphere_bnb_settings_are_checked(param, value):
    err = _quick(
        dp.covert.sphere_minmax_bearing_bnb,
        dp.covert.THESIS_TABLE_3_2,
        [[150.0, 150.0, 0.0]],
        **{param: value},
    )
    assert param in str(err)


def _short_covert_trace():
    return dp.covert.simulate(dp.covert.thesis_case(1), dp.covert.HoverBenchmark(), t_max=1.0)


def test_stealth_front_with_a_tiny_step_is_refused_up_front():
    err = _quick(
        dp.covert.stealth_front, dp.covert.thesis_case(1), {"hover": _short_covert_trace()}, step=1e-6
    )
    assert "step" in str(err) and "work_limits" in str(err)


def test_stealth_front_with_no_runs_names_traces():
    err = _quick(dp.covert.stealth_front, dp.covert.thesis_case(1), {})
    assert "traces" in str(err)


def test_mission_front_with_too_many_instants_is_refused():
    case = dp.covert.thesis_case(1)
    err = _quick(
        dp.covert.mission_front, case, np.linspace(10.0, 20.0, 50), 40.0, times=np.arange(0.0, 60.0, 1e-3)
    )
    assert "times" in str(err)


# ----------------------------------------------------------------------------- shark
SHARK = ([0.0, 0.0, -3.0], [3.0, 0.0])
OPERATOR = [-10.0, 5.0, 2.0]


def test_interception_bound_with_an_absurd_resolution_is_refused():
    err = _quick(dp.shark.interception_time_bound, SHARK, OPERATOR, resolution=1e-300, seconds=2.0)
    assert "resolution" in str(err)


def test_interception_bound_with_a_huge_horizon_is_refused_before_allocating():
    err = _quick(dp.shark.interception_time_bound, SHARK, OPERATOR, t_max=1e9, seconds=2.0)
    assert "t_max" in str(err) and "work_limits" in str(err)


def test_interception_bound_at_the_finest_resolution_still_agrees():
    coarse = dp.shark.interception_time_bound(SHARK, OPERATOR)
    fine = dp.shark.interception_time_bound(SHARK, OPERATOR, resolution=1e-12)
    assert coarse.objective <= fine.objective <= coarse.objective + 1e-3


def test_lipschitz_scan_stops_when_steps_fall_below_the_float_spacing():
    # f = t - 1 - 1e-300 has no root reachable in float64 steps beyond t = 1; the scan used to
    # spin until max_evaluations with t + step == t
    calls = []

    def f(t: float) -> float:
        calls.append(t)
        return max(1.0 - t, 0.0) + 1e-300

    root = first_root_lipschitz(f, 0.0, 2.0, 1.0, resolution=1e-320, max_evaluations=10**6)
    assert root.lower is not None and root.lower <= 1.0 and len(calls) < 100


# ----------------------------------------------------------------------------- cells
def _region():
    problem = dp.cells.CellProblem([[1500.0, 0.0]], [[0.0, 0.0]], 2, 500.0, 1000.0, 3500.0, 3000.0)
    return dp.cells.deployment_region(problem, np.zeros((0, 2)))


def test_max_coverage_with_20000_users_is_refused_quickly():
    users = np.random.default_rng(0).uniform(-1000.0, 1000.0, (20_000, 2))
    err = _quick(dp.cells.max_coverage_in_region, users, 500.0, _region(), seconds=5.0)
    assert "users" in str(err) and "work_limits" in str(err)


@pytest.mark.parametrize(
    ("param", "value"), [("R_d", NAN), ("R_d", -1.0), ("region", None), ("users", "abc")]
)
def test_max_coverage_checks_its_arguments(param, value):
    kwargs = {"users": np.array([[1500.0, 0.0]]), "R_d": 500.0, "region": _region(), param: value}
    err = _quick(dp.cells.max_coverage_in_region, **kwargs)
    assert param in str(err)


def test_max_coverage_valid_call_agrees_with_a_count():
    users = np.array([[1500.0, 0.0], [1600.0, 100.0], [5000.0, 5000.0]])
    count, centre = dp.cells.max_coverage_in_region(users, 500.0, _region())
    assert count == 2 and centre is not None
    assert np.sum(np.hypot(*(users - centre).T) <= 500.0 + 1e-6) == 2


@pytest.mark.parametrize("param", ["seeds", "ms", "variants", "instances"])
def test_ga_ablation_with_an_empty_list_names_it(param):
    kwargs = {"seeds": [0], "ms": (1,), "runs": 1, "variants": ["thesis"]}
    kwargs |= {"es_limit": 5.0, "exact_limit": 5.0}
    kwargs[param] = []
    err = _quick(dp.cells.ga_ablation, **kwargs)
    assert param in str(err)


# ----------------------------------------------------------------------------- herding
def _herding_trace(frames: bool = True):
    return dp.herding.simulate(
        dp.herding.thesis_scenario(6, seed=0, n_drones=2),
        dp.herding.ProposedHerder(),
        t_max=2.0,
        seed=0,
        frame_every=0.5 if frames else None,
    )


@pytest.mark.parametrize("fps", [0, NAN, -3, True, "8"])
def test_write_gif_checks_fps_before_matplotlib(fps, tmp_path):
    err = _quick(dp.herding.write_gif, _herding_trace(), tmp_path / "x.gif", fps=fps)
    assert "fps" in str(err)
    assert not (tmp_path / "x.gif").exists()


def test_write_gif_refuses_nan_frames_and_wrong_types(tmp_path):
    tr = _herding_trace()
    tr.frames[0].animals[0, 0] = NAN
    assert "frames" in str(_quick(dp.herding.write_gif, tr, tmp_path / "x.gif"))
    assert "trace" in str(_quick(dp.herding.write_gif, "not a trace", tmp_path / "x.gif"))
    assert "path" in str(_quick(dp.herding.write_gif, _herding_trace(), 3))
    assert "goal" in str(_quick(dp.herding.write_gif, _herding_trace(), tmp_path / "x.gif", goal=[NAN, 0.0]))


def test_write_gif_valid_call_writes_a_gif(tmp_path):
    path = dp.herding.write_gif(_herding_trace(), tmp_path / "x.gif", fps=4)
    assert path.read_bytes()[:4] == b"GIF8"


@pytest.mark.parametrize(("traces", "kind"), [({}, ValueError), ([], TypeError), ({"a": 3}, TypeError)])
def test_run_times_table_checks_traces(traces, kind):
    with pytest.raises(kind, match="traces"):
        dp.herding.run_times_table(traces)


@pytest.mark.parametrize("tol", [NAN, -1.0, math.inf])
def test_check_allocation_refuses_a_nan_tolerance(tol):
    d, s, M = [1.0, 5.0], [2.0], 10.0
    alloc = dp.herding.solve_allocation(d, s, M).x
    err = _quick(dp.herding.check_allocation, d, s, M, alloc, tol=tol)
    assert "tol" in str(err)


# ----------------------------------------------------------------------------- checks under python -O
def test_require_set_raises_where_an_assert_would_be_stripped():
    from droneplan.core.validation import require_set

    assert require_set(0, "zero is set") == 0
    with pytest.raises(RuntimeError, match="the solver"):
        require_set(None, "the solver")


def test_the_same_verdicts_under_python_dash_O(tmp_path):
    import subprocess
    import sys

    code = """
import math, droneplan as dp
def verdict(fn, *a, **k):
    try:
        fn(*a, **k)
    except (ValueError, TypeError) as e:
        return type(e).__name__
    return "accepted"
d, s, M = [1.0, 5.0], [2.0], 10.0
alloc = dp.herding.solve_allocation(d, s, M).x
bad = type(alloc)(alloc.target, alloc.direction, alloc.travel * 2, alloc.points)
print(verdict(dp.herding.check_allocation, d, s, M, bad),
      verdict(dp.herding.check_allocation, d, s, M, alloc, tol=math.nan),
      verdict(dp.covert.sphere_minmax_bearing, dp.covert.THESIS_TABLE_3_2, [[1e200, 0.0, 0.0]]),
      verdict(dp.shark.interception_time_bound, ([0.0, 0.0, -3.0], [3.0, 0.0]), [-10.0, 5.0, 2.0], t_max=1e9))
"""
    out = {
        flag: subprocess.run(
            [sys.executable, *([flag] if flag else []), "-c", code],
            capture_output=True,
            text=True,
            check=True,
            timeout=120,
        ).stdout.split()
        for flag in ("", "-O")
    }
    assert out[""] == out["-O"] == ["ValueError"] * 4


# ----------------------------------------------------------------------------- round two (every public entry)
def test_a_shark_path_whose_step_exceeds_its_horizon_names_dt():
    # used to fail inside numpy (IndexError) or with "t must have at least 2 row(s)"
    for fn, args in (
        (dp.shark.make_trajectory, (0.0, 5.0, -3.0)),
        (dp.shark.constant_velocity_trajectory, ([0.0, 0.0, -3.0], [5.0, 0.0, 0.0])),
        (dp.shark.random_trajectory, (0,)),
    ):
        err = _quick(fn, *args, duration=1.0, dt=5.0)
        assert "dt" in str(err) and "duration" in str(err)
    assert (
        len(dp.shark.make_trajectory(0.0, 5.0, -3.0, duration=1.0, dt=1.0).t) == 2
    )  # dt == duration: 2 samples


def test_a_shark_above_the_surface_or_beyond_the_magnitude_limit_is_refused():
    with pytest.raises(ValueError, match="depth"):
        dp.shark.make_trajectory(0.0, 5.0, lambda t: 0.5 + 0 * t, duration=2.0)
    with pytest.raises(ValueError, match="heading"):
        dp.shark.make_trajectory(lambda t: 1e200 + 0 * t, 5.0, -3.0, duration=2.0)


def test_interception_ocp_checks_its_horizon_margin_and_start_time():
    err = _quick(dp.shark.InterceptionOCP, t_max=1e12, seconds=5.0)  # was a 29 TiB allocation
    assert "t_max" in str(err) and "work_limits" in str(err)
    assert "margin" in str(_quick(dp.shark.InterceptionOCP, margin=1e200))  # was OverflowError
    assert "max_iter" in str(_quick(dp.shark.InterceptionOCP, max_iter=NAN))
    err = _quick(dp.shark.solve_interception, SHARK, OPERATOR, N=10, t0=NAN)  # was accepted
    assert "t0" in str(err)


def test_the_bound_names_t_max_when_its_float_spacing_exceeds_the_resolution():
    err = _quick(dp.shark.interception_time_bound, SHARK, OPERATOR, t_max=1e12)
    assert "t_max" in str(err) and "resolution" in str(err)


def test_fleet_budgets_name_the_horizon_and_the_fleet():
    op, sp, sv = [[0.0, -30.0, 2.0]], [[10.0, 0.0, -3.0]], [[3.0, 0.0, 0.0]]
    assert "t_max" in str(_quick(dp.shark.interception_time_matrix, op, sp, sv, t_max=1e-6))
    assert "t_max" in str(_quick(dp.shark.interception_time_matrix, op, sp, sv, t_max=1e200))
    many = np.tile(op, (1000, 1))
    err = _quick(dp.shark.interception_time_matrix, many, np.tile(sp, (1000, 1)), np.tile(sv, (1000, 1)))
    assert "operators" in str(err) and "sharks_pos" in str(err)
    assert "greedy" in str(_quick(dp.shark.allocate_operators, op, sp, sv, [[0.0, 0.0]], greedy="yes"))


def test_assignment_checks_indices_distances_and_workers():
    cost = np.ones((2, 2))
    assert "sharks" in str(_quick(dp.shark.build_assignment_model, cost, [NAN, 0.0]))  # was IndexError
    assert "sharks" in str(_quick(dp.shark.build_assignment_model, cost, [0, 0]))
    assert "workers" in str(_quick(dp.shark.solve_assignment, cost, workers=10**12))
    ops, sharks = [[0.0, 0.0, 2.0]], [[10.0, 0.0, -3.0]]
    for bad in ([NAN], [1e200], [-1.0], [1.0, 2.0]):
        assert "shark_to_human" in str(_quick(dp.shark.greedy_assignment, ops, sharks, bad, np.ones((1, 1))))


def test_repelling_names_each_position_table_and_budgets_its_horizon():
    ok = ([[20.0, 0.0]], [[0.0, 5.0, 2.0]], [[0.0, 0.0]])
    for i, name in enumerate(("sharks0", "operators0", "swimmers")):
        for bad in (np.zeros((0, 2 if i != 1 else 3)), [[NAN] * (2 if i != 1 else 3)]):
            args = list(ok)
            args[i] = bad
            err = _quick(dp.shark.simulate_repelling, *args, [dp.shark.RepellingOperator(0)], t_max=1.0)
            assert name in str(err)
    err = _quick(dp.shark.simulate_repelling, *ok, [dp.shark.RepellingOperator(0)], t_max=1e9)
    assert "t_max" in str(err) and "work_limits" in str(err)


def test_the_mpc_model_refuses_a_target_count_beyond_memory():
    err = _quick(dp.covert.build_bearing_mpc, dp.covert.THESIS_TABLE_3_2, 10**12)  # was std::bad_alloc
    assert "n_targets" in str(err)


def test_the_sphere_program_refuses_more_targets_than_its_budget():
    targets = np.tile([[150.0, 150.0, 0.0]], (1000, 1))  # used to run for minutes
    err = _quick(dp.covert.sphere_minmax_bearing, dp.covert.THESIS_TABLE_3_2, targets, seconds=5.0)
    assert "targets" in str(err) and "work_limits" in str(err)


def test_mission_bounds_name_the_arrival_time_and_the_horizon():
    case = dp.covert.thesis_case(1)
    assert "t_a" in str(_quick(dp.covert.mission_lower_bound, case, 1e200))  # named arrival_times
    err = _quick(dp.covert.mission_lower_bound, case, 1e12, times=[0.0, 8.0])  # named t_f only
    assert "t_a" in str(err) and "t_end" in str(err)


def test_study_entries_check_counts_and_options(tmp_path):
    assert "seeds" in str(_quick(dp.family_instances, "table4.2", seeds=10**12, m=1))  # was MemoryError
    common = {"methods": ["greedy"], "instances": "table4.2", "out": tmp_path, "m": 1, "seeds": 1}
    for param, value in (("progress", "yes"), ("store", 3), ("executor", 3), ("dask", 3), ("workers", 0)):
        assert param in str(_quick(dp.gap, "cells", **{**common, param: value}))
    assert not (tmp_path / "results.sqlite").exists()  # refused before the store was opened
    assert "include_superseded" in str(_quick(dp.load_results, tmp_path, include_superseded="yes"))


def test_scalar_magnitudes_beyond_the_coordinate_limit_are_refused():
    from droneplan.core.validation import check_in_range, check_nonneg, check_positive, check_real

    for check in (check_real, check_positive, check_nonneg):
        with pytest.raises(ValueError, match="R_d has magnitude"):
            check("R_d", 1e200)
        assert check("R_d", MAX_COORDINATE) == MAX_COORDINATE
    with pytest.raises(ValueError, match="t_max"):
        check_in_range("t_max", 2e15, 0.0)
    assert check_real("end", math.inf, finite=False) == math.inf  # inf stays allowed where asked for
    assert check_real("big", 1e200, max_abs=None) == 1e200  # the limit can be lifted
    # a cell half-width of 1e200 m used to overflow inside the user generator (OverflowError)
    assert "half_width" in str(_quick(dp.cells.CellParams, half_width=1e200))


def test_the_interception_ocp_budgets_its_intervals():
    # N = 10^4 took 7 s to build and N = 3000 25 s to solve; N up to 10^5 was admitted
    for fn, args in ((dp.shark.build_interception_nlp, ()), (dp.shark.solve_interception, (SHARK, OPERATOR))):
        err = _quick(fn, *args, N=10_000, seconds=5.0)
        assert "N" in str(err) and "work_limits" in str(err)
    assert dp.shark.build_interception_nlp(N=50)["N"] == 50


def test_the_bearing_mpc_budgets_its_horizon_times_its_targets():
    # horizon 1000 with 2 targets took 5 s to build; horizon 10^5 was admitted
    long = dp.covert.MPCSettings(horizon=100_000)
    err = _quick(dp.covert.build_bearing_mpc, dp.covert.THESIS_TABLE_3_2, 2, long, seconds=5.0)
    assert "horizon" in str(err) and "work_limits" in str(err)
    model = dp.covert.build_bearing_mpc(dp.covert.THESIS_TABLE_3_2, 3)
    assert model.n_targets == 3 and model.settings.horizon == dp.covert.MPCSettings().horizon


_Z = [0.0, 0.0, -3.0]
BAD_SHARKS = [5, None, "abc", (_Z,), (_Z, [1e200, 0.0]), (_Z, [3.0])]


@pytest.mark.parametrize("shark", BAD_SHARKS)
def test_solve_interception_checks_the_predicted_shark(shark):
    # an int or None ended in "object of type 'int' has no len()"; a velocity of 1e200 was accepted
    assert "shark" in str(_quick(dp.shark.solve_interception, shark, OPERATOR, N=10))


def test_solve_interception_checks_its_warm_starts():
    for bad in (3, "plan", ["x"]):  # ["x"] ended in AttributeError: 'str' object has no attribute 'resample'
        err = _quick(dp.shark.solve_interception, SHARK, OPERATOR, N=10, warm_starts=bad)
        assert "warm_starts" in str(err)


def test_the_sphere_branch_and_bound_budgets_cells_times_targets():
    # 300 targets at the default max_cells and a tiny tol ran for 26 s of CPU
    targets = np.c_[np.random.default_rng(1).uniform(100.0, 180.0, (300, 2)), np.zeros(300)]
    err = _quick(dp.covert.sphere_minmax_bearing_bnb, dp.covert.THESIS_TABLE_3_2, targets, tol=1e-12)
    assert "max_cells" in str(err) and "targets" in str(err) and "work_limits" in str(err)
    fewer = dp.covert.sphere_minmax_bearing_bnb(dp.covert.THESIS_TABLE_3_2, targets, max_cells=2000)
    assert fewer.bound is not None and fewer.bound <= fewer.objective
