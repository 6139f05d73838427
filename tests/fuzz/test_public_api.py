"""Fuzz suite over the whole public API.

Every public callable of the front doors (``droneplan.cells/covert/shark/herding``,
enumerated from ``__all__``) has an entry in ``SPECS``: a valid call and the kind of
each parameter that is checked. The bad-input test swaps one parameter for a bad value
of its kind (NaN/inf, negative, zero, bool for a number, wrong type, wrong shape, empty,
ragged, absurd size) and requires a ``ValueError``/``TypeError`` whose message names the
parameter. ``test_every_public_callable_has_a_strategy`` fails when a new public name
has no entry. Result and protocol types that a user receives rather than calls with
data are listed in ``RESULT_TYPES`` with the reason.
"""

from __future__ import annotations

import inspect
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import droneplan as dp

DOORS = {"cells": dp.cells, "covert": dp.covert, "shark": dp.shark, "herding": dp.herding}

# -------------------------------------------------------------------------- bad values per kind
NAN, INF = float("nan"), float("inf")
BAD = {
    "positive": [NAN, INF, -1.0, 0.0, True, "1"],
    "nonneg": [NAN, INF, -1.0, True, "1"],
    "finite": [NAN, INF, True, "1"],
    "int>=1": [True, 1.5, "2", 0, -3],
    "int>=0": [True, 1.5, "2", -1],
    "size": [True, 1.5, "2", 0, -3, 10**12],  # a count that sizes arrays: absurd sizes are refused up front
    "seed": ["abc", 1.5, -1, True],
    "time_limit": [True, -1.0, 0.0, NAN, "1"],
    "points2": [[[NAN, 0.0]], [[0.0, 0.0, 0.0]], "abc", [[0.0, 0.0], [1.0]], [[True, False]]],
    "points2+": [[[NAN, 0.0]], [[0.0, 0.0, 0.0]], "abc", [[0.0, 0.0], [1.0]], np.zeros((0, 2))],
    "points3": [[[NAN, 0.0, 0.0]], [[0.0, 0.0]], "abc", [[0.0, 0.0, 0.0], [1.0]]],
    "vec2": [[NAN, 0.0], [0.0, 0.0, 0.0], "ab", [[0.0, 0.0]]],
    "vec3": [[NAN, 0.0, 0.0], [0.0, 0.0], "abc", [[0.0, 0.0, 0.0]]],
    "arcs": [[NAN], [[1.0]], "abc", [-1.0]],
    "matrix": [[[NAN, 1.0]], [[-1.0, 1.0]], "abc", [1.0, 2.0], [[1.0], [2.0, 3.0]]],
    "object": [None, "x", 3],
    "object?": ["x", 3],  # None is valid (the default)
    # plot helpers: a matplotlib axes (None: a new figure), runs as a trace or {label: trace}, tables
    "ax": ["x", 3, np.zeros(2)],
    "traces": [None, "x", 3, {}, {"a": 3}],
    # interactive maps: the (lat, lon) the local origin stands for (None: local metres)
    "origin": [[NAN, 0.0], [95.0, 0.0], [0.0, 200.0], "ab", [1.0]],
    "frame": [None, {}, "x", pd.DataFrame()],
}


@dataclass
class Spec:
    """How to call one public callable: ``call()`` -> (args, kwargs) valid; ``checked`` maps a
    parameter name to its kind in BAD."""

    call: Callable[[], tuple[tuple, dict]]
    checked: dict[str, str] = field(default_factory=dict)


def _model_file(suffix: str) -> str:
    """A model file's path (``suffix`` .mps or .lp) in a fresh temporary folder."""
    import tempfile
    from pathlib import Path

    return str(Path(tempfile.mkdtemp(prefix="droneplan-fuzz-model-")) / f"model{suffix}")


def _cells_problem():
    return dp.cells.CellProblem(
        [[1500.0, 0.0], [1600.0, 100.0], [-1700.0, 50.0]],
        [[0.0, 0.0]],
        2,
        500.0,
        1000.0,
        3500.0,
        3000.0,
        bounds=(-2500.0, 2500.0, -2500.0, 2500.0),
    )


def _small_params():
    return dp.cells.CellParams(half_width=2000.0, n_clusters=2)


def _covert_case():
    return dp.covert.thesis_case(1)


_HOVER: list = []


def _hover_run():
    """One hover-benchmark run on thesis case 1 (cached: it takes seconds)."""
    if not _HOVER:
        _HOVER.append(dp.covert.simulate(_covert_case(), dp.covert.HoverBenchmark()))
    return _HOVER[0]


def _path_a():
    return dp.shark.thesis_trajectories(duration=3.0)["a"]


def _herd():
    return dp.herding.thesis_scenario(6, seed=0, n_drones=2)


def _hull():
    return dp.herding.ExtendedHull.from_points(np.array([[0.0, 0.0], [10.0, 0.0], [0.0, 10.0]]), 5.0)


_RUNS: dict[str, Any] = {}


def _covert_short():
    """A 2 s hover run on thesis case 1 (for the plot helpers)."""
    if "covert" not in _RUNS:
        _RUNS["covert"] = dp.covert.simulate(_covert_case(), dp.covert.HoverBenchmark(), t_max=2.0)
    return _RUNS["covert"]


def _shark_run():
    if "shark" not in _RUNS:
        _RUNS["shark"] = dp.shark.simulate(_path_a(), dp.shark.ClassicalPursuit())
    return _RUNS["shark"]


def _herding_run():
    """A 2 s herding run with frames every 0.5 s (for the plot helpers and write_gif)."""
    if "herding" not in _RUNS:
        _RUNS["herding"] = dp.herding.simulate(
            _herd(), dp.herding.ProposedHerder(), t_max=2.0, seed=0, frame_every=0.5
        )
    return _RUNS["herding"]


def _front_frames():
    points = pd.DataFrame([{"method": "hover", "t_a": 10.0, "t_f": 50.0, "beta_max_deg": 3.0}])
    bound = pd.DataFrame([{"t_a": 10.0, "bound_deg": 1.0, "attained_at_s": 5.0, "class_t_f": 50.0}])
    return points, bound


def _optimised_front_frames():
    points = pd.DataFrame(
        [
            {"arrival_limit_s": 8.0, "beta_max_deg": 21.2, "bound_deg": 20.7, "certified_within_deg": 0.5},
            {"arrival_limit_s": 12.0, "beta_max_deg": 20.6, "bound_deg": 18.0, "certified_within_deg": 2.6},
        ]
    )
    curve = pd.DataFrame([{"t_a": 7.0, "bound_deg": 20.8}, {"t_a": 12.0, "bound_deg": 18.0}])
    return points, curve


def _gif_path() -> str:
    import tempfile
    from pathlib import Path

    return str(Path(tempfile.mkdtemp(prefix="droneplan-fuzz-gif-")) / "run.gif")


@pytest.fixture(autouse=True)
def _close_figures():
    yield
    plt.close("all")


P = _cells_problem

_DATA: dict[str, str] = {}


def _snapshots() -> np.ndarray:
    """Two epochs of the users of ``P()``, the second 100 m east."""
    users = np.asarray(P().users)
    return np.stack([users, users + np.array([100.0, 0.0])])


def _mobile():
    return dp.cells.MobileProblem(P(), _snapshots(), 150.0)


def _data_file(name: str) -> str:
    """A small data file of the users' formats (written once per session) for the loaders."""
    if not _DATA:
        import tempfile
        from pathlib import Path

        d = Path(tempfile.mkdtemp(prefix="droneplan-fuzz-"))
        (d / "points.csv").write_text("x,y\n1500,0\n1600,100\n-1700,50\n")
        (d / "track.csv").write_text("t,x,y\n0,0,0\n1,1,0\n2,2,0.5\n3,3,1\n")
        (d / "users.csv").write_text("id,t,x,y\n1,0,1500,0\n2,0,1600,100\n1,60,1550,0\n2,60,1600,150\n")
        (d / "points.geojson").write_text(
            '{"type": "FeatureCollection", "features": [{"type": "Feature", "properties": {}, '
            '"geometry": {"type": "MultiPoint", "coordinates": [[10.0, 47.0], [10.01, 47.01]]}}]}'
        )
        _DATA.update({p.name: str(p) for p in d.iterdir()})
    return _DATA[name]


SPECS: dict[str, Spec] = {
    # ---- cells
    "CellParams": Spec(
        lambda: ((), {}),
        {
            "half_width": "positive",
            "R_d": "positive",
            "lambda_c": "nonneg",
            "n_clusters": "int>=0",
            "gbs": "points2+",
        },
    ),
    "CellProblem": Spec(
        lambda: (([[1500.0, 0.0]], [[0.0, 0.0]], 1, 500.0, 1000.0, 3500.0, 3000.0), {}),
        {
            "users": "points2",
            "gbs": "points2+",
            "n_cells": "size",
            "R_d": "positive",
            "R_g": "positive",
            "r1": "positive",
            "r2": "positive",
        },
    ),
    "matern_users": Spec(lambda: ((0, _small_params()), {}), {"seed": "seed", "params": "object"}),
    "uniform_users": Spec(
        lambda: ((0, _small_params()), {"mean_count": 5.0}),
        {"seed": "seed", "mean_count": "nonneg", "params": "object"},
    ),
    "thesis_instance": Spec(lambda: ((0, _small_params()), {}), {"seed": "seed", "params": "object"}),
    "thesis_problem": Spec(
        lambda: ((1, 0), {"params": _small_params()}), {"n_cells": "int>=1", "seed": "seed"}
    ),
    "problem_from_instance": Spec(
        lambda: ((dp.cells.thesis_instance(0, _small_params()), 1), {}),
        {"inst": "object", "n_cells": "int>=1"},
    ),
    "evaluate": Spec(lambda: ((P(), [[1600.0, 0.0]]), {}), {"problem": "object", "positions": "points2"}),
    "connected_mask": Spec(
        lambda: ((P(), np.array([[1600.0, 0.0]])), {}), {"problem": "object", "positions": "points2"}
    ),
    "candidate_sites": Spec(lambda: ((P(),), {}), {"problem": "object"}),
    "build_milp": Spec(lambda: ((P(),), {}), {"problem": "object"}),
    "AirToGround": Spec(
        lambda: ((), {}),
        {"a": "positive", "b": "positive", "frequency_hz": "positive", "eta_los_db": "nonneg"},
    ),
    "pad_steering_points": Spec(
        lambda: (([0.0, 40.0], 4, 100.0), {}),
        {"steer_s": "arcs", "n": "int>=0", "perimeter": "positive"},
    ),
    "MobileProblem": Spec(
        lambda: ((P(), _snapshots(), 100.0), {}), {"problem": "object", "max_move": "nonneg"}
    ),
    "evaluate_mobile": Spec(lambda: ((_mobile(), _snapshots()[:, :1]), {}), {"mp": "object"}),
    "solve_mobile": Spec(
        lambda: ((_mobile(),), {"time_limit": 5.0}),
        {"mp": "object", "time_limit": "time_limit", "workers": "int>=1", "warm_start": "object?"},
    ),
    "myopic": Spec(
        lambda: ((_mobile(),), {"time_limit": 5.0}),
        {"mp": "object", "time_limit": "time_limit", "workers": "int>=1"},
    ),
    "read_user_tracks": Spec(lambda: ((_data_file("users.csv"),), {}), {"origin": "object?"}),
    "min_fleet": Spec(
        lambda: ((P(),), {"coverage": 0.5, "time_limit": 5.0}),
        {"problem": "object", "time_limit": "time_limit", "coverage": "positive"},
    ),
    "solve_model": Spec(
        lambda: ((dp.cells.build_milp(P()),), {"time_limit": 5.0}),
        {"model": "object", "time_limit": "time_limit", "workers": "int>=1"},
    ),
    "write_model": Spec(
        lambda: ((P(), _model_file(".mps")), {}), {"problem_or_model": "object", "path": "object"}
    ),
    "load_cells_csv": Spec(
        lambda: ((_data_file("points.csv"),), {"n_cells": 2}), {"n_cells": "int>=1", "params": "object?"}
    ),
    "load_cells_geojson": Spec(
        lambda: ((_data_file("points.geojson"),), {"n_cells": 2}),
        {"n_cells": "int>=1", "origin": "vec2", "no_fly": "object?"},
    ),
    # a file name that is no file is reported with the file's name, and dt=None (keep the file's own
    # times) is valid: the loaders' tests check those
    "load_herd_csv": Spec(lambda: ((_data_file("points.csv"),), {}), {}),
    "herding_scenario_from_csv": Spec(
        lambda: ((_data_file("points.csv"),), {"n_drones": 2}), {"n_drones": "int>=1"}
    ),
    "load_shark_track_csv": Spec(lambda: ((_data_file("track.csv"),), {}), {"depth": "finite"}),
    "solve_exact": Spec(
        lambda: ((P(),), {"time_limit": 5.0}), {"problem": "object", "time_limit": "time_limit"}
    ),
    "branch_and_bound": Spec(
        lambda: ((P(),), {"time_limit": 5.0}), {"problem": "object", "time_limit": "time_limit"}
    ),
    "solve_milp": Spec(
        lambda: ((P(),), {"time_limit": 5.0}), {"problem": "object", "time_limit": "time_limit"}
    ),
    "coverage_upper_bound": Spec(
        lambda: ((P(),), {"time_limit": 5.0}), {"problem": "object", "time_limit": "time_limit"}
    ),
    "greedy_placement": Spec(lambda: ((P(), dp.cells.candidate_sites(P())), {}), {"problem": "object"}),
    "GASettings": Spec(lambda: ((), {}), {"T": "positive", "alpha": "positive", "p_m": "nonneg"}),
    "genetic": Spec(
        lambda: ((P(),), {"pop_size": 4, "iter_max": 2, "restarts": 1, "seed": 0}),
        {"problem": "object", "pop_size": "size", "restarts": "size", "iter_max": "int>=0", "seed": "seed"},
    ),
    "genetic_polished": Spec(
        lambda: ((P(),), {"pop_size": 4, "iter_max": 2, "restarts": 1, "seed": 0}),
        {"problem": "object", "pop_size": "int>=1", "seed": "seed"},
    ),
    "polish": Spec(
        lambda: ((P(), [[1600.0, 0.0]]), {}),
        {"problem": "object", "positions": "points2", "max_passes": "int>=0"},
    ),
    "fitness": Spec(
        lambda: ((P(), np.zeros((3, 2, 2))), {}), {"problem": "object", "pop": "points2", "chunk": "int>=1"}
    ),
    "exhaustive": Spec(
        lambda: ((P(),), {"time_limit": 5.0}), {"problem": "object", "time_limit": "time_limit"}
    ),
    "max_coverage_in_region": Spec(
        lambda: ((np.array([[1500.0, 0.0]]), 500.0, dp.cells.deployment_region(P(), np.zeros((0, 2)))), {}),
        {"users": "points2", "R_d": "positive", "region": "object"},
    ),
    "thesis_ga_settings": Spec(lambda: ((2,), {}), {"m": "int>=1"}),
    "deployment_region": Spec(
        lambda: ((P(), [[1600.0, 0.0]]), {}), {"problem": "object", "placed": "points2"}
    ),
    "instance_features": Spec(lambda: ((P(),), {}), {"problem": "object"}),
    "ga_ablation": Spec(
        lambda: (
            (),
            {
                "seeds": [0],
                "ms": (1,),
                "runs": 1,
                "variants": ["thesis"],
                "es_limit": 5.0,
                "exact_limit": 5.0,
            },
        ),
        {"runs": "int>=1", "es_limit": "positive", "exact_limit": "positive"},
    ),
    # ---- covert
    "CovertParams": Spec(
        lambda: ((), {}),
        {
            "V_max": "positive",
            "U_max": "positive",
            "L_u": "positive",
            "dt": "positive",
            "F": "vec3",
            "D_s": "vec3",
        },
    ),
    "CovertScenario": Spec(
        lambda: ((dp.covert.THESIS_TABLE_3_2, dp.covert.Terrain(), ()), {}),
        {"params": "object", "terrain": "object"},
    ),
    "Terrain": Spec(lambda: ((), {"hills": ((0.0, 0.0, 1.0, 5.0),)}), {}),
    "TargetPath": Spec(lambda: (([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]],), {}), {"points": "points3"}),
    "Occlusion": Spec(lambda: ((0, 1.0), {}), {"target": "int>=0", "start": "finite"}),
    "thesis_case": Spec(lambda: ((1,), {}), {"seed": "seed", "V_T": "positive", "params": "object?"}),
    "random_case": Spec(lambda: ((1, 0), {}), {"n_targets": "size", "seed": "seed", "n_hills": "int>=0"}),
    "bearing_changes": Spec(
        lambda: (([0.0, 0.0, 10.0], [[5.0, 5.0, 0.0]], [10.0, 10.0, 40.0]), {}),
        {"drone": "points3", "R": "vec3"},
    ),
    "simulate@covert": Spec(
        lambda: ((_covert_case(), dp.covert.HoverBenchmark()), {"t_max": 1.0}),
        {
            "scenario": "object",
            "controller": "object",
            "noise": "nonneg",
            "t_max": "positive",
            "seed": "seed",
        },
    ),
    "MPCSettings": Spec(
        lambda: ((), {}), {"horizon": "int>=1", "step": "positive", "replan_every": "int>=1"}
    ),
    "build_bearing_mpc": Spec(
        lambda: ((dp.covert.THESIS_TABLE_3_2, 1), {}), {"params": "object", "n_targets": "int>=0"}
    ),
    "sphere_minmax_bearing": Spec(
        lambda: ((dp.covert.THESIS_TABLE_3_2, [[150.0, 150.0, 0.0]]), {}),
        {"params": "object", "targets": "points3"},
    ),
    "sphere_minmax_bearing_bnb": Spec(
        lambda: ((dp.covert.THESIS_TABLE_3_2, [[150.0, 150.0, 0.0]]), {}),
        {"params": "object", "targets": "points3"},
    ),
    "Obstacle": Spec(
        lambda: ((((0.0, 0.0), (10.0, 0.0), (10.0, 10.0), (0.0, 10.0)), 5.0), {}),
        {"footprint": "points2", "height": "finite"},
    ),
    "mission_lower_bound": Spec(
        lambda: ((_covert_case(), 8.0), {"times": [0.0, 8.0, 60.0]}),
        {"scenario": "object", "t_a": "nonneg", "sphere_tol": "nonneg"},
    ),
    "mission_front": Spec(
        lambda: ((_covert_case(), [8.0, 12.0]), {"times": [0.0, 8.0, 60.0]}),
        {"scenario": "object", "sphere_tol": "nonneg", "t_end": "positive"},
    ),
    "stealth_front": Spec(
        lambda: ((_covert_case(), {"hover": _hover_run()}), {"n_arrivals": 2, "step": 20.0}),
        {"scenario": "object", "n_arrivals": "int>=1", "step": "positive"},
    ),
    "optimised_front": Spec(
        # a limit below the earliest possible arrival: only the sliding-mode run is made
        lambda: ((_covert_case(), [3.0]), {"tries": 1, "step": 20.0}),
        {
            "scenario": "object",
            "arrival_times": "arcs",
            "tries": "int>=1",
            "slack": "nonneg",
            "step": "positive",
            "margin_deg": "positive",
            "n_curve": "int>=1",
        },
    ),
    "SlidingSettings": Spec(lambda: ((), {}), {"eps_line": "positive", "home_radius": "positive"}),
    "SlidingModeObserver": Spec(lambda: ((), {}), {"settings": "object?"}),
    "HoverBenchmark": Spec(lambda: ((), {}), {"settings": "object?"}),
    "MPCObserver": Spec(lambda: ((), {}), {"settings": "object?"}),
    "MPCObserverSettings": Spec(lambda: ((), {}), {"progress": "positive", "window": "int>=1"}),
    "SafeguardSettings": Spec(lambda: ((), {}), {"margin": "nonneg", "envelope_speed": "positive"}),
    "SafeguardedMPCObserver": Spec(lambda: ((), {}), {"settings": "object?"}),
    # ---- shark
    "SharkParams": Spec(
        lambda: ((), {}),
        {"lmin": "positive", "eps_o": "positive", "Ts": "positive", "gamma": "positive", "le": "finite"},
    ),
    "field_radius": Spec(lambda: (([1.0, 4.0],), {}), {"h": "finite", "params": "object"}),
    "touches": Spec(
        lambda: (([0.0, 0.0, -3.0], [0.0, 0.0, 2.0]), {}),
        {"shark": "points3", "operator": "points3", "params": "object"},
    ),
    "SharkTrajectory": Spec(
        lambda: (([0.0, 0.1], np.zeros((2, 3)), np.zeros((2, 3))), {}),
        {"t": "finite", "pos": "points3", "vel": "points3"},
    ),
    "make_trajectory": Spec(
        lambda: ((0.0, 5.0, -3.0), {"duration": 2.0}),
        {"duration": "positive", "dt": "positive", "start": "vec2", "speed": "finite"},
    ),
    "thesis_trajectories": Spec(lambda: ((), {"duration": 2.0}), {"duration": "positive", "dt": "positive"}),
    "random_trajectory": Spec(
        lambda: ((0,), {"duration": 2.0}), {"seed": "seed", "duration": "positive", "params": "object"}
    ),
    "constant_velocity_trajectory": Spec(
        lambda: (([0.0, 0.0, -3.0], [5.0, 0.0, 0.0]), {"duration": 2.0}),
        {"pos": "vec3", "vel": "vec3", "duration": "positive", "dt": "positive"},
    ),
    "operator_start": Spec(
        lambda: ((_path_a(),), {}), {"trajectory": "object", "params": "object", "bearing_deg": "finite"}
    ),
    "InterceptionScenario": Spec(
        lambda: ((_path_a(),), {}),
        {"trajectory": "object", "params": "object", "operator0": "vec3", "bearing_deg": "finite"},
    ),
    "simulate@shark": Spec(
        lambda: ((_path_a(), dp.shark.ClassicalPursuit()), {}),
        {
            "scenario": "object",
            "controller": "object",
            "params": "object?",
            "operator0": "vec3",
            "t_max": "positive",
            "substeps": "int>=1",
        },
    ),
    "SharkBehaviour": Spec(
        lambda: ((), {}), {"speed": "positive", "turn_rate": "positive", "flee_time": "positive"}
    ),
    "simulate_repelling": Spec(
        lambda: (
            ([[20.0, 0.0]], [[0.0, 5.0, 2.0]], [[0.0, 0.0]], [dp.shark.RepellingOperator(0)]),
            {"t_max": 1.0},
        ),
        {
            "params": "object",
            "behaviour": "object",
            "seed": "seed",
            "t_max": "positive",
            "observer": "object?",
        },
    ),
    "ObserverDrone": Spec(
        lambda: ((), {}),
        {"altitude": "positive", "speed": "positive", "near_radius": "positive", "start": "vec2"},
    ),
    "alarm_level": Spec(
        lambda: (([[20.0, 0.0]], [[0.0, 0.0]], 1, 50.0), {}),
        {"sharks": "object", "swimmers": "object", "n_operators": "int>=0", "near_radius": "positive"},
    ),
    "sharks_to_repel": Spec(
        lambda: (([[20.0, 0.0], [5.0, 5.0]], [[0.0, 0.0]], 1), {}),
        {"sharks": "object", "swimmers": "object", "n_operators": "int>=0"},
    ),
    "optimal_altitude": Spec(lambda: ((-3.0,), {}), {"z_s": "finite", "params": "object"}),
    "InterceptionOCP": Spec(lambda: ((), {}), {"params": "object"}),
    "build_interception_nlp": Spec(lambda: ((), {}), {"params": "object"}),
    "interception_time_bound": Spec(
        lambda: ((([0.0, 0.0, -3.0], [3.0, 0.0]), [-10.0, 5.0, 2.0]), {}),
        {"operator0": "vec3", "params": "object", "t_max": "positive", "t0": "nonneg"},
    ),
    "solve_interception": Spec(
        lambda: ((([0.0, 0.0, -3.0], [3.0, 0.0]), [-10.0, 5.0, 2.0]), {"N": 10}),
        {"operator0": "vec3", "params": "object"},
    ),
    "build_assignment_model": Spec(lambda: ((np.ones((2, 2)), [0, 1]), {}), {"cost": "matrix"}),
    "solve_assignment": Spec(
        lambda: ((np.ones((2, 2)),), {}), {"cost": "matrix", "time_limit": "time_limit"}
    ),
    "greedy_assignment": Spec(
        lambda: (([[0.0, 0.0, 2.0]], [[10.0, 0.0, -3.0]], [0], np.ones((1, 1))), {}),
        {"operators": "points3", "sharks_pos": "points3"},
    ),
    "thesis_altitude": Spec(lambda: ((-3.0,), {}), {"z_s": "finite", "params": "object"}),
    "ClassicalPursuit": Spec(lambda: ((), {}), {"params": "object"}),
    "VirtualSharkInterceptor": Spec(lambda: ((), {}), {"params": "object"}),
    "OCPInterceptor": Spec(lambda: ((), {}), {"params": "object"}),
    "optimal_interception": Spec(
        lambda: ((_path_a(), [-10.0, 5.0, 2.0]), {}),
        {"trajectory": "object", "operator0": "vec3", "params": "object"},
    ),
    "virtual_shark_plan": Spec(
        lambda: ((_path_a(), [-10.0, 5.0, 2.0]), {}),
        {"trajectory": "object", "operator0": "vec3", "params": "object"},
    ),
    "allocate_operators": Spec(
        lambda: (([[0.0, 0.0, 2.0]], [[10.0, 0.0, -3.0]], [[1.0, 0.0, 0.0]], [[30.0, 0.0]]), {}),
        {"operators": "points3", "sharks_pos": "points3", "sharks_vel": "points3", "params": "object"},
    ),
    "interception_time_matrix": Spec(
        lambda: (([[0.0, 0.0, 2.0]], [[10.0, 0.0, -3.0]], [[1.0, 0.0, 0.0]]), {}),
        {"operators": "points3", "sharks_pos": "points3", "sharks_vel": "points3", "params": "object"},
    ),
    "RepellingOperator": Spec(lambda: ((0,), {}), {"shark": "int>=0", "params": "object"}),
    # ---- herding
    "HerdingParams": Spec(
        lambda: ((), {}),
        {
            "V_max": "positive",
            "delta": "positive",
            "eta_d": "nonneg",
            "n_drones": "int>=1",
            "beta": "positive",
            "goal_radius": "positive",
        },
    ),
    "HerdingScenario": Spec(
        lambda: ((_herd().params, _herd().animals, _herd().drones, _herd().headings, _herd().goal), {}),
        {"params": "object", "animals": "points2+", "drones": "points2+", "goal": "vec2"},
    ),
    "thesis_scenario": Spec(
        lambda: ((6, 0), {"n_drones": 2}),
        {"n_animals": "size", "seed": "seed", "n_drones": "int>=1", "field_size": "vec2", "goal": "vec2"},
    ),
    "with_params": Spec(lambda: ((_herd(),), {"V_max": 20.0}), {"V_max": "positive"}),
    "simulate@herding": Spec(
        lambda: ((_herd(), dp.herding.ProposedHerder()), {"t_max": 1.0, "seed": 0}),
        {"scenario": "object", "controller": "object", "t_max": "positive", "seed": "seed"},
    ),
    "footprint_radius": Spec(lambda: ((np.zeros((3, 2)),), {}), {"animals": "points2+"}),
    "build_allocation_model": Spec(
        lambda: (([1.0, 5.0], [2.0], 10.0), {}),
        {"drone_s": "arcs", "steer_s": "arcs", "perimeter": "positive"},
    ),
    "write_allocation_model": Spec(
        lambda: (([1.0, 5.0], [2.0], 10.0, _model_file(".lp")), {}),
        {"drone_s": "arcs", "steer_s": "arcs", "perimeter": "positive", "path": "object"},
    ),
    "solve_allocation": Spec(
        lambda: (([1.0, 5.0], [2.0], 10.0), {}),
        {"drone_s": "arcs", "steer_s": "arcs", "perimeter": "positive"},
    ),
    "check_allocation": Spec(
        lambda: (([1.0, 5.0], [2.0], 10.0, dp.herding.solve_allocation([1.0, 5.0], [2.0], 10.0).x), {}),
        {"drone_s": "arcs", "perimeter": "positive"},
    ),
    "allocate_bruteforce": Spec(
        lambda: (([1.0, 5.0], [2.0], 10.0), {}),
        {"drone_s": "arcs", "steer_s": "arcs", "perimeter": "positive"},
    ),
    "allocate_collision_blind": Spec(
        lambda: (([1.0, 5.0], [2.0], 10.0), {}),
        {"drone_s": "arcs", "steer_s": "arcs", "perimeter": "positive"},
    ),
    "convex_hull": Spec(
        lambda: ((np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]),), {}), {"points": "points2+"}
    ),
    "min_enclosing_circle": Spec(lambda: ((np.array([[0.0, 0.0], [1.0, 0.0]]),), {}), {"points": "points2+"}),
    "steering_points": Spec(
        lambda: ((_hull(), np.array([3.0, 3.0]), 2), {}),
        {"hull": "object", "centroid": "vec2", "n_drones": "int>=1"},
    ),
    "HerderSettings": Spec(lambda: ((), {}), {"arrive_tol": "positive", "turn_tol": "positive"}),
    # ---- plot helpers and animation writers
    "plot_map": Spec(
        lambda: ((P(), [[1600.0, 0.0]]), {}), {"problem": "object", "positions": "points2", "ax": "ax"}
    ),
    "plot_deployment_region": Spec(
        lambda: ((P(), [[1600.0, 0.0]]), {}),
        {"problem": "object", "placed": "points2", "ax": "ax", "quad_segs": "size"},
    ),
    "plot_path": Spec(
        lambda: ((_covert_case(), _covert_short()), {}),
        {"scenario": "object", "traces": "traces", "ax": "ax"},
    ),
    "plot_bearing": Spec(lambda: ((_covert_short(),), {}), {"traces": "traces", "ax": "ax"}),
    "plot_stealth_front": Spec(
        lambda: (_front_frames(), {}), {"points": "frame", "bound": "frame", "ax": "ax"}
    ),
    "plot_optimised_front": Spec(
        lambda: (_optimised_front_frames(), {}),
        {"points": "frame", "curve": "frame", "ax": "ax", "margin_deg": "positive"},
    ),
    "plot_top_view": Spec(lambda: ((_shark_run(),), {}), {"traces": "traces", "ax": "ax"}),
    "plot_time_series": Spec(
        lambda: ((_shark_run(),), {}), {"traces": "traces", "quantity": "object", "ax": "ax"}
    ),
    "plot_state": Spec(
        lambda: ((_herding_run(), 1.0), {}), {"source": "object", "t": "finite", "goal": "vec2", "ax": "ax"}
    ),
    "plot_final": Spec(lambda: ((_herding_run(),), {}), {"trace": "object", "ax": "ax"}),
    "plot_footprint": Spec(
        lambda: ((_herding_run(),), {}), {"traces": "traces", "R_c": "positive", "ax": "ax"}
    ),
    "write_gif": Spec(
        lambda: ((_herding_run(), _gif_path()), {"fps": 4}),
        {"trace": "object", "path": "object", "fps": "int>=1", "goal": "vec2"},
    ),
    "run_times_table": Spec(lambda: (({"proposed": _herding_run()},), {}), {"traces": "traces"}),
    "animate@covert": Spec(
        lambda: ((_covert_short(), _gif_path()), {"stride": 5}),
        {"trace": "object", "path": "object", "fps": "int>=1", "stride": "int>=1"},
    ),
    "animate@shark": Spec(
        lambda: ((_shark_run(), _gif_path()), {"stride": 10}),
        {"trace": "object", "path": "object", "fps": "int>=1", "stride": "int>=1"},
    ),
    "animate@herding": Spec(
        lambda: ((_herding_run(), _gif_path()), {}),
        {"trace": "object", "path": "object", "fps": "int>=1", "stride": "int>=1", "goal": "vec2"},
    ),
    # ---- interactive maps (folium)
    "map@cells": Spec(
        lambda: ((P(), [[1600.0, 0.0]]), {}),
        {"problem": "object", "result": "points2", "origin": "origin", "max_users": "int>=1"},
    ),
    "map@covert": Spec(
        lambda: ((_covert_short(),), {}), {"trace": "object", "origin": "origin", "max_steps": "int>=1"}
    ),
    "map@shark": Spec(
        lambda: ((_shark_run(),), {}), {"trace": "object", "origin": "origin", "max_steps": "int>=1"}
    ),
    "map@herding": Spec(
        lambda: ((_herding_run(),), {}),
        {"trace": "object", "origin": "origin", "max_steps": "int>=1", "max_animals": "int>=1"},
    ),
    "ProposedHerder": Spec(lambda: ((), {}), {"settings": "object?"}),
    "BenchmarkHerder": Spec(lambda: ((), {}), {"settings": "object?"}),
    # the Gymnasium environments and the policy controllers (a policy: obs_vector -> action)
    "HerdingEnv": Spec(
        lambda: ((), {"n_animals": 5, "n_drones": 2, "t_max": 2.0}),
        {"scenario": "object?", "n_animals": "size", "n_drones": "int>=1", "t_max": "positive"},
    ),
    "InterceptionEnv": Spec(
        lambda: ((), {"duration": 3.0}),
        {"scenario": "object?", "duration": "positive", "t_max": "positive", "substeps": "int>=1"},
    ),
    "CovertEnv": Spec(
        lambda: ((), {}),
        {"scenario": "object", "noise": "nonneg", "t_max": "positive", "home_radius": "positive"},
    ),
    "policy_controller@herding": Spec(lambda: ((np.zeros,), {}), {"policy": "object"}),
    "policy_controller@shark": Spec(lambda: ((np.zeros,), {}), {"policy": "object"}),
    "policy_controller@covert": Spec(
        lambda: ((np.zeros,), {}), {"policy": "object", "home_radius": "positive"}
    ),
}

PLOTTING: set[str] = set()  # every plot helper and animation writer has a spec above

RESULT_TYPES = {
    # returned to the user, not called with user data (their fields are produced by the library)
    "MobileEvaluation",
    "ProjectedCells",
    "Instance",
    "Evaluation",
    "Candidates",
    "CellModel",
    "SolveResult",
    "Status",
    "Controller",
    "CovertTrace",
    "MPCData",
    "MPCPlan",
    "BearingMPC",
    "RecedingBearingMPC",
    "solve_bearing_mpc",
    "rollout_sliding",
    "InterceptionController",
    "InterceptionTrace",
    "RepellingTrace",
    "InterceptionPlan",
    "Assignment",
    "HerdingTrace",
    "Allocation",
    "AllocationModel",
    "ExtendedHull",
    "MissionBound",
    # the closed-loop contract's records and phase enums (built by the simulators and controllers)
    "CovertCommand",
    "CovertFrame",
    "CovertObservation",
    "CovertPhase",
    "HerdingCommand",
    "HerdingFrame",
    "HerdingObservation",
    "HerdingPhase",
    "SharkCommand",
    "SharkFrame",
    "SharkObservation",
    "SharkPhase",
    "RepellingMode",
    "AlarmLevel",
    "RepellingObservation",
    "RepellingScenario",
    "Region",  # a deployment region as built by deployment_region
}


def _public_callables() -> dict[str, Any]:
    out = {}
    for door_name, door in DOORS.items():
        for name in door.__all__:
            obj = getattr(door, name)
            if callable(obj) and not inspect.ismodule(obj):
                key = f"{name}@{door_name}" if f"{name}@{door_name}" in SPECS else name
                out[key] = obj
    return out


CALLABLES = _public_callables()


def test_every_public_callable_has_a_strategy():
    missing = sorted(set(CALLABLES) - set(SPECS) - RESULT_TYPES - PLOTTING)
    assert not missing, (
        f"public callables without a fuzz strategy in tests/fuzz/test_public_api.py: {missing}"
    )
    stale = sorted((set(SPECS) | RESULT_TYPES | PLOTTING) - set(CALLABLES))
    assert not stale, f"fuzz strategies for names that are no longer public: {stale}"


def _bound(fn, args, kwargs):
    sig = inspect.signature(fn)
    return sig, sig.bind_partial(*args, **kwargs)


BAD_CASES = [
    (name, param, kind, i)
    for name, spec in sorted(SPECS.items())
    for param, kind in spec.checked.items()
    for i in range(len(BAD[kind]))
]


@pytest.mark.parametrize(
    ("name", "param", "kind", "i"), BAD_CASES, ids=[f"{n}-{p}-{k}{i}" for n, p, k, i in BAD_CASES]
)
def test_bad_input_raises_a_clear_error_naming_the_parameter(name, param, kind, i):
    fn = CALLABLES[name]
    args, kwargs = SPECS[name].call()
    sig, bound = _bound(fn, args, kwargs)
    value = BAD[kind][i]
    if param in sig.parameters and sig.parameters[param].kind is not inspect.Parameter.VAR_KEYWORD:
        bound.arguments[param] = value
        call_args, call_kwargs = bound.args, bound.kwargs
    else:  # a keyword passed through **kwargs (dataclass fields, with_params overrides)
        call_args, call_kwargs = bound.args, {**bound.kwargs, param: value}
    with pytest.raises((ValueError, TypeError)) as info:
        fn(*call_args, **call_kwargs)
    assert param.split("@")[0] in str(info.value), f"{name}({param}={value!r}): {info.value}"


@pytest.mark.parametrize("name", sorted(SPECS))
def test_the_valid_call_works_and_gives_finite_numbers(name):
    args, kwargs = SPECS[name].call()
    result = CALLABLES[name](*args, **kwargs)
    if isinstance(result, np.ndarray) and name in FINITE_EXEMPT:
        result = np.where(np.isposinf(result), 0.0, result)
    _assert_finite(result)


FINITE_EXEMPT = {
    "interception_time_matrix": "inf marks an operator-shark pair that cannot intercept (documented)"
}


def _assert_finite(result):
    if isinstance(result, dp.SolveResult):
        assert isinstance(result.status, dp.Status)
        for v in (result.objective, result.bound):
            assert v is None or math.isfinite(v)
        if result.x is not None and isinstance(result.x, np.ndarray) and result.x.dtype.kind == "f":
            assert np.all(np.isfinite(result.x))
    elif isinstance(result, np.ndarray) and result.dtype.kind in "fc":
        assert np.all(np.isfinite(result))
    elif isinstance(result, float):
        assert math.isfinite(result)
    elif isinstance(result, tuple):
        for part in result:
            _assert_finite(part)


# -------------------------------------------------------------------------- random valid inputs
points = st.lists(st.tuples(st.floats(-1e3, 1e3), st.floats(-1e3, 1e3)), min_size=1, max_size=30).map(
    np.array
)


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(points)
def test_geometry_on_random_herds_is_finite_and_encloses(pts):
    centre, radius = dp.herding.min_enclosing_circle(pts)
    assert np.all(np.isfinite(centre)) and math.isfinite(radius)
    assert np.all(np.linalg.norm(pts - centre, axis=1) <= radius * (1 + 1e-9) + 1e-6)
    hull = dp.herding.convex_hull(pts)
    assert np.all(np.isfinite(hull)) and 1 <= len(hull) <= len(pts)
    assert math.isfinite(dp.herding.footprint_radius(pts))


@settings(max_examples=30, deadline=None)
@given(
    st.lists(st.integers(0, 990).map(lambda k: k / 10), min_size=1, max_size=6),
    st.lists(st.integers(0, 990).map(lambda k: k / 10), min_size=1, max_size=6),
)
def test_allocation_on_random_positions_has_a_valid_status(drones, steer):
    steer = steer[: len(drones)]
    res = dp.herding.solve_allocation(drones, steer, 100.0)
    if len(set(steer)) < len(steer):  # coincident steering points: (6.22)-(6.23) cannot both hold
        assert res.status is dp.Status.INFEASIBLE and "coincident" in res.message
        return
    assert res.status is dp.Status.OPTIMAL and math.isfinite(res.objective)
    assert dp.herding.check_allocation(drones, steer, 100.0, res.x) == pytest.approx(res.objective)


@settings(max_examples=40, deadline=None)
@given(st.floats(-10.0, -0.1))
def test_altitudes_on_random_depths_are_in_the_band(z_s):
    params = dp.shark.THESIS_TABLE_5_1
    for fn in (dp.shark.optimal_altitude, dp.shark.thesis_altitude):
        z_o, eps = fn(z_s, params)
        assert math.isfinite(float(z_o)) and math.isfinite(float(eps))


# -------------------------------------------------------------------------- deeper profile (-m slow)
NUMBER_CASES = [
    (name, param, kind)
    for name, spec in sorted(SPECS.items())
    for param, kind in spec.checked.items()
    if kind in ("positive", "nonneg", "finite")
]


def _bad_number(kind: str):
    floats = st.floats(allow_nan=True, allow_infinity=True)
    if kind == "positive":
        floats = floats.filter(lambda x: not (math.isfinite(x) and x > 0))
    elif kind == "nonneg":
        floats = floats.filter(lambda x: not (math.isfinite(x) and x >= 0))
    else:
        floats = floats.filter(lambda x: not math.isfinite(x))
    return st.one_of(floats, st.booleans(), st.text(max_size=3), st.none())


@pytest.mark.slow
@settings(max_examples=400, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.data())
def test_deep_bad_numbers_raise_a_clear_error(data):
    name, param, kind = data.draw(st.sampled_from(NUMBER_CASES), label="entry")
    value = data.draw(_bad_number(kind), label="value")
    fn = CALLABLES[name]
    args, kwargs = SPECS[name].call()
    sig, bound = _bound(fn, args, kwargs)
    if value is None and param in sig.parameters and sig.parameters[param].default is None:
        return  # None is the documented default of this parameter
    if param in sig.parameters and sig.parameters[param].kind is not inspect.Parameter.VAR_KEYWORD:
        bound.arguments[param] = value
        call_args, call_kwargs = bound.args, bound.kwargs
    else:
        call_args, call_kwargs = bound.args, {**bound.kwargs, param: value}
    with pytest.raises((ValueError, TypeError)) as info:
        fn(*call_args, **call_kwargs)
    assert param in str(info.value), f"{name}({param}={value!r}): {info.value}"


users = st.lists(st.tuples(st.floats(-2500, 2500), st.floats(-2500, 2500)), min_size=0, max_size=12).map(
    lambda u: np.array(u, dtype=float).reshape(-1, 2)
)


@pytest.mark.slow
@settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(users, st.integers(1, 2))
def test_deep_random_cells_instances_agree_with_the_bound(u, m):
    problem = dp.cells.CellProblem(
        u, [[0.0, 0.0]], m, 500.0, 1000.0, 3500.0, 3000.0, bounds=(-2500.0, 2500.0, -2500.0, 2500.0)
    )
    milp = dp.cells.solve_milp(problem, time_limit=15)
    assert milp.status in (dp.Status.OPTIMAL, dp.Status.FEASIBLE)
    ev = dp.cells.evaluate(problem, milp.x)
    assert ev.feasible and ev.covered == milp.objective <= milp.bound
    ga = dp.cells.genetic(problem, pop_size=6, iter_max=3, restarts=1, seed=0)
    assert dp.cells.evaluate(problem, ga.x).feasible and ga.objective <= milp.bound


# -------------------------------------------------------------------------- plot helpers: axes and NaN data
PLOT_2D = ["plot_map", "plot_deployment_region", "plot_bearing", "plot_stealth_front", "plot_top_view"]
PLOT_2D += ["plot_time_series", "plot_state", "plot_final", "plot_footprint", "plot_optimised_front"]


@pytest.mark.parametrize("name", [*PLOT_2D, "plot_path"])
def test_plot_helpers_refuse_axes_of_the_wrong_projection(name):
    args, kwargs = SPECS[name].call()
    wrong = plt.figure().add_subplot(projection="rectilinear" if name == "plot_path" else "3d")
    with pytest.raises(ValueError, match="ax must be"):
        CALLABLES[name](*args, **{**kwargs, "ax": wrong})


@pytest.mark.parametrize("name", [*PLOT_2D, "plot_path"])
def test_plot_helpers_draw_on_a_given_axes(name):
    args, kwargs = SPECS[name].call()
    ax = plt.figure().add_subplot(projection="3d" if name == "plot_path" else None)
    fig = CALLABLES[name](*args, **{**kwargs, "ax": ax})
    assert fig is ax.get_figure() and (ax.lines or ax.collections or ax.patches)


def _with_nan(trace):
    """A deep copy of ``trace`` whose float arrays (and frames' positions) are all NaN."""
    import copy

    out = copy.deepcopy(trace)
    for value in vars(out).values():
        if isinstance(value, np.ndarray) and value.dtype.kind == "f":
            value[...] = np.nan
    for frame in [*getattr(out, "frames", []), getattr(out, "final", None)]:
        if isinstance(frame, dp.herding.HerdingFrame):
            frame.animals[...] = np.nan
    return out


NAN_RUNS = {
    "plot_path": lambda: ((_covert_case(), _with_nan(_covert_short())), {}),
    "plot_bearing": lambda: ((_with_nan(_covert_short()),), {}),
    "plot_top_view": lambda: ((_with_nan(_shark_run()),), {}),
    "plot_time_series": lambda: ((_with_nan(_shark_run()),), {}),
    "plot_state": lambda: ((_with_nan(_herding_run()),), {}),
    "plot_final": lambda: ((_with_nan(_herding_run()),), {}),
    "plot_footprint": lambda: ((_with_nan(_herding_run()),), {}),
    "write_gif": lambda: ((_with_nan(_herding_run()), _gif_path()), {}),
    "animate@covert": lambda: ((_with_nan(_covert_short()), _gif_path()), {}),
    "animate@shark": lambda: ((_with_nan(_shark_run()), _gif_path()), {}),
    "animate@herding": lambda: ((_with_nan(_herding_run()), _gif_path()), {}),
    "map@covert": lambda: ((_with_nan(_covert_short()),), {}),
    "map@shark": lambda: ((_with_nan(_shark_run()),), {}),
    "map@herding": lambda: ((_with_nan(_herding_run()),), {}),
    "run_times_table": lambda: (({"a": _with_nan(_herding_run())},), {}),
    "plot_stealth_front": lambda: (tuple(f.assign(t_a=np.nan) for f in _front_frames()), {}),
    "plot_optimised_front": lambda: (
        tuple(f.assign(bound_deg=np.nan) for f in _optimised_front_frames()),
        {},
    ),
}


@pytest.mark.parametrize("name", sorted(NAN_RUNS))
def test_plot_helpers_on_nan_runs_refuse_clearly_or_draw(name):
    # NaN in a run's data either gives a ValueError that says where, or a figure/table (matplotlib
    # leaves NaN points out); never an error from inside matplotlib, PIL or pandas
    args, kwargs = NAN_RUNS[name]()
    message = None
    try:
        out = CALLABLES[name](*args, **kwargs)
    except ValueError as exc:
        message, out = str(exc), None
    if message is not None:
        assert any(w in message for w in ("trace", "source", "NaN")), message
    else:
        assert out is not None


@pytest.mark.parametrize("name", ["plot_bearing", "plot_top_view", "plot_time_series", "plot_footprint"])
def test_plot_helpers_refuse_empty_runs(name):
    with pytest.raises(TypeError, match="traces"):
        CALLABLES[name]({})
