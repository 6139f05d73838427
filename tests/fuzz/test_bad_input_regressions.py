"""Regressions of bad input: each is refused with a clear ValueError/TypeError naming the
parameter (each test failed on the code before its fix; its docstring says what happened
before)."""

from __future__ import annotations

import numpy as np
import pytest

import droneplan as dp
from droneplan.core.validation import MAX_ELEMENTS, resolve_seed


@pytest.fixture(scope="module")
def tiny_cells():
    return dp.cells.CellProblem(
        [[1500.0, 0.0], [1600.0, 100.0]],
        [[0.0, 0.0]],
        1,
        500.0,
        1000.0,
        3500.0,
        3000.0,
        bounds=(-2500.0, 2500.0, -2500.0, 2500.0),
    )


def test_bools_are_not_numbers(tiny_cells):
    """Bools were taken as numbers (R_d=True, n_animals=True, time_limit=True)."""
    with pytest.raises(TypeError, match="R_d"):
        dp.cells.CellProblem([[0.0, 0.0]], [[0.0, 0.0]], 1, True, 1000, 3500, 3000)
    with pytest.raises(TypeError, match="n_animals"):
        dp.herding.thesis_scenario(n_animals=True)
    with pytest.raises(TypeError, match="time_limit"):
        dp.cells.solve_milp(tiny_cells, time_limit=True)
    with pytest.raises(TypeError, match="V_max"):
        dp.herding.HerdingParams(V_max=True)


def test_negative_limits_are_refused(tiny_cells):
    """exhaustive(time_limit=-1) returned FEASIBLE with 0 users."""
    with pytest.raises(ValueError, match="time_limit"):
        dp.cells.exhaustive(tiny_cells, time_limit=-1)
    with pytest.raises(ValueError, match="t_max"):
        dp.herding.simulate(dp.herding.thesis_scenario(5, seed=0), dp.herding.ProposedHerder(), t_max=-1)


def test_nan_is_not_passed_through():
    """min_enclosing_circle returned (nan, nan); touches returned False for a NaN shark."""
    with pytest.raises(ValueError, match="points"):
        dp.herding.min_enclosing_circle(np.array([[0.0, 0.0], [np.nan, 1.0]]))
    with pytest.raises(ValueError, match="shark"):
        dp.shark.touches([np.nan, 0.0, -3.0], [0.0, 0.0, 2.0])
    with pytest.raises(ValueError, match="operator"):
        dp.shark.touches([0.0, 0.0, -3.0], [0.0, np.inf, 2.0])


def test_operator_start_outside_the_altitude_band_is_refused():
    """An operator starting at z = 50 m was recorded descending at -480 m/s."""
    path = dp.shark.thesis_trajectories(duration=5.0)["a"]
    start = path.pos[0] + np.array([0.0, -13.0, 0.0])
    start[2] = 50.0
    with pytest.raises(ValueError, match="operator0"):
        dp.shark.simulate(path, dp.shark.ClassicalPursuit(), operator0=start)
    start[2] = 2.0  # inside [lmin, le]: the recorded vertical speed stays within the limit
    trace = dp.shark.simulate(path, dp.shark.ClassicalPursuit(), operator0=start)
    assert np.all(np.abs(trace.operator_vel[:, 2]) <= dp.shark.THESIS_TABLE_5_1.VoMz + 1e-9)


def test_a_target_path_shorter_than_the_mission_is_refused_unless_asked_for():
    """A covert target path shorter than the mission silently stopped the target."""
    params = dp.covert.THESIS_TABLE_3_2
    short = dp.covert.TargetPath(np.array([[100.0, 100.0, 0.0], [150.0, 100.0, 0.0]]))  # 50 m < 240 m
    with pytest.raises(ValueError, match=r"paths\[0\].*shorter than the mission"):
        dp.covert.CovertScenario(params, dp.covert.Terrain(), (short,))
    sc = dp.covert.CovertScenario(params, dp.covert.Terrain(), (short,), targets_stop=True)
    assert np.allclose(sc.targets_at(params.duration)[0], [150.0, 100.0, 0.0])


def test_generated_covert_paths_last_the_whole_mission():
    """The generated case-2 paths were up to 0.4 m shorter than V_T * duration."""
    sc = dp.covert.thesis_case(2, seed=3)
    mission = sc.params.V_T * sc.params.duration
    assert all(abs(p.length - mission) < 1e-6 for p in sc.paths)


@pytest.mark.parametrize(
    "call",
    [
        lambda: dp.cells.thesis_problem(1, seed="abc"),
        lambda: dp.cells.genetic(
            dp.cells.CellProblem([[1500.0, 0.0]], [[0.0, 0.0]], 1, 500, 1000, 3500, 3000), seed="abc"
        ),
        lambda: dp.herding.thesis_scenario(5, seed="abc"),
        lambda: dp.covert.thesis_case(1, seed="abc"),
        lambda: dp.covert.random_case(2, seed="abc"),
        lambda: dp.shark.random_trajectory(seed="abc"),
    ],
    ids=["thesis_problem", "genetic", "thesis_scenario", "thesis_case", "random_case", "random_trajectory"],
)
def test_seed_of_the_wrong_type_is_a_type_error_naming_seed(call):
    """seed='abc' failed inside numpy (or was silently accepted by thesis_case)."""
    with pytest.raises(TypeError, match="seed"):
        call()


def test_seed_none_is_drawn_and_recorded():
    """None draws a seed and records it, so the run can be repeated."""
    rng, seed = resolve_seed(None)
    assert isinstance(seed, int) and seed >= 0
    assert rng.random() == np.random.default_rng(seed).random()
    sc = dp.covert.random_case(2, seed=None)
    assert sc.seed is not None
    again = dp.covert.random_case(2, seed=sc.seed)
    assert np.array_equal(sc.paths[0].points, again.paths[0].points)


@pytest.mark.parametrize(
    ("simulate", "scenario"),
    [
        (dp.herding.simulate, lambda: dp.herding.thesis_scenario(5, seed=0)),
        (dp.covert.simulate, lambda: dp.covert.thesis_case(1)),
        (dp.shark.simulate, lambda: dp.shark.thesis_trajectories(duration=5.0)["a"]),
    ],
    ids=["herding", "covert", "shark"],
)
def test_controller_none_is_a_type_error(simulate, scenario):
    """Controller None gave an AttributeError from inside the simulator."""
    with pytest.raises(TypeError, match=r"controller|herder"):
        simulate(scenario(), None)


def test_fitness_with_a_population_of_3_d_points_names_pop(tiny_cells):
    """Fitness with a (5, 2, 3) population gave a numpy broadcast error."""
    with pytest.raises(ValueError, match="pop"):
        dp.cells.fitness(tiny_cells, np.zeros((5, 2, 3)))


def test_make_trajectory_takes_constants():
    """make_trajectory with floats gave "'float' object is not callable"."""
    path = dp.shark.make_trajectory(0.0, 5.0, -3.0, duration=2.0)
    assert np.allclose(path.vel[:, 0], 5.0) and np.allclose(path.pos[:, 2], -3.0)
    with pytest.raises(TypeError, match="speed"):
        dp.shark.make_trajectory(0.0, "fast", -3.0, duration=2.0)


def test_thesis_scenario_n_drones_bool_names_n_drones():
    """thesis_scenario(n_drones=True) gave a numpy TypeError."""
    with pytest.raises(TypeError, match="n_drones"):
        dp.herding.thesis_scenario(10, n_drones=True)


@pytest.mark.parametrize(
    ("call", "name"),
    [
        (lambda: dp.herding.thesis_scenario(n_animals=10**12), "n_animals"),
        (lambda: dp.cells.CellParams(n_clusters=10**12), "n_clusters"),
        (lambda: dp.cells.uniform_users(0, mean_count=1e15), "mean_count"),
        (lambda: dp.shark.make_trajectory(0.0, 5.0, -3.0, duration=1e12), "duration"),
        (lambda: dp.shark.constant_velocity_trajectory([0, 0, -3], [1, 0, 0], duration=1e12), "duration"),
    ],
    ids=["herd", "clusters", "users", "make_trajectory", "constant_velocity"],
)
def test_absurd_sizes_are_refused_up_front(call, name):
    """Absurd sizes gave a numpy MemoryError after trying to allocate."""
    with pytest.raises(ValueError, match=name) as info:
        call()
    assert str(MAX_ELEMENTS) in str(info.value)


def test_size_guard_admits_the_thesis_ga_settings_and_refuses_absurd_ones():
    """The GA's work and size guards count the fitness evaluations and what it allocates
    (population arrays; coverage is evaluated in blocks), so Table 4.3's m=4 settings (P=200,
    N_start=200, 382 users) run, as the thesis did; an absurd population is still refused up front,
    naming the parameter furthest above its thesis value."""
    problem = dp.cells.thesis_problem(4, seed=0)
    ga = dp.cells.genetic(problem, iter_max=0, seed=0)  # thesis settings, no generations
    assert ga.info["pop_size"] == 200 and ga.info["restarts"] == 200
    assert ga.objective == dp.cells.evaluate(problem, ga.x).covered
    with pytest.raises(ValueError, match=r"^pop_size .*fitness evaluations") as info:
        dp.cells.genetic(problem, pop_size=10**6, restarts=10**4, iter_max=1, seed=0)
    assert str(MAX_ELEMENTS) in str(info.value)
