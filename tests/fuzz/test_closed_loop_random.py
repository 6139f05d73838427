"""Random valid closed-loop scenarios through the public simulators, for a short horizon.

Hypothesis draws small herds on small fields, shark paths (straight, curved, random family),
repelling beaches and covert target groups; each runs through ``dp.herding.simulate``,
``dp.shark.simulate``, ``dp.shark.simulate_repelling`` or ``dp.covert.simulate`` for a few
seconds of simulated time. Every result must be finite and respect what the models promise:
speeds under their limits, the operator inside its altitude band, bearing changes in
[0, pi], times inside the run, fractions in [0, 1].
"""

from __future__ import annotations

import math

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import droneplan as dp

FAST = settings(max_examples=15, deadline=None, suppress_health_check=[HealthCheck.too_slow])
SLACK = 1e-6  # relative slack on a speed limit (floating-point rounding of the integrators)

coord = st.floats(-40.0, 40.0, allow_nan=False)


def _speeds(positions: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Displacement per recorded step over its duration, for (T, ..., d) positions (m/s)."""
    step = np.linalg.norm(np.diff(positions, axis=0), axis=-1)
    return step / np.diff(t).reshape((-1,) + (1,) * (step.ndim - 1))


# ---------------------------------------------------------------------------- herding
@st.composite
def herds(draw):
    n_animals = draw(st.integers(1, 6))
    n_drones = draw(st.integers(1, 2))
    animals = np.array(draw(st.lists(st.tuples(coord, coord), min_size=n_animals, max_size=n_animals)))
    offset = np.array([draw(st.floats(60.0, 120.0)), 0.0])
    drones = np.array(draw(st.lists(st.tuples(coord, coord), min_size=n_drones, max_size=n_drones))) + offset
    headings = np.array(draw(st.lists(st.floats(-3.0, 3.0), min_size=n_drones, max_size=n_drones)))
    goal = np.array([draw(st.floats(-200.0, -80.0)), draw(st.floats(-50.0, 50.0))])
    params = dp.herding.HerdingParams(n_drones=n_drones)
    return dp.herding.HerdingScenario(
        params, animals, drones, headings, goal, field=(-60.0, -60.0, 60.0, 60.0)
    )


@FAST
@given(herds(), st.sampled_from(["proposed", "benchmark"]), st.integers(0, 2**16))
def test_random_herds_run_finite_and_within_the_speed_limits(scenario, herder, seed):
    controller = dp.herding.ProposedHerder() if herder == "proposed" else dp.herding.BenchmarkHerder()
    tr = dp.herding.simulate(scenario, controller, t_max=6.0, seed=seed)
    p = scenario.params
    assert np.all(np.diff(tr.t) > 0) and 0.0 <= tr.t[-1] <= 6.0 + 1e-9
    for arr in (tr.drones, tr.centroid, tr.footprint_radius, tr.final.animals, tr.final.drones):
        assert np.all(np.isfinite(arr))
    assert np.all(_speeds(tr.drones, tr.t) <= p.V_max * (1 + SLACK))
    assert 0.0 <= tr.max_animal_speed <= p.V_animal * (1 + SLACK)
    assert np.all(tr.footprint_radius >= 0.0)
    final = tr.final.animals
    assert np.allclose(tr.centroid[-1], final.mean(axis=0), atol=1e-9)
    spread = float(np.max(np.linalg.norm(final - tr.centroid[-1], axis=1)))
    assert math.isclose(tr.footprint_radius[-1], spread, rel_tol=1e-9, abs_tol=1e-9)
    assert np.all((tr.delivered >= 0.0) & (tr.delivered <= 1.0))
    for time_ in (tr.gather_time, tr.total_time):
        assert time_ is None or 0.0 <= time_ <= tr.t[-1]


# ---------------------------------------------------------------------------- shark
@st.composite
def shark_paths(draw):
    kind = draw(st.sampled_from(["straight", "curved", "random"]))
    duration = draw(st.floats(3.0, 8.0))
    if kind == "random":
        return dp.shark.random_trajectory(draw(st.integers(0, 2**16)), duration=duration)
    heading = draw(st.floats(-math.pi, math.pi))
    speed = draw(st.floats(0.5, 6.0))
    depth = draw(st.floats(-6.0, -0.5))
    if kind == "straight":
        return dp.shark.make_trajectory(heading, speed, depth, duration=duration)
    rate = draw(st.floats(-0.3, 0.3))
    return dp.shark.make_trajectory(lambda t: heading + rate * t, speed, depth, duration=duration)


@FAST
@given(
    shark_paths(),
    st.sampled_from(["classical", "virtual-shark"]),
    st.floats(-180.0, 180.0),
)
def test_random_shark_paths_keep_the_operator_in_its_envelope(path, method, bearing):
    p = dp.shark.THESIS_TABLE_5_1
    controller = dp.shark.ClassicalPursuit() if method == "classical" else dp.shark.VirtualSharkInterceptor()
    tr = dp.shark.simulate(dp.shark.InterceptionScenario(path, p, bearing_deg=bearing), controller)
    for arr in (tr.t, tr.operator, tr.shark, tr.operator_vel, tr.eps, tr.D_h):
        assert np.all(np.isfinite(arr))
    assert np.all(np.diff(tr.t) > 0) and tr.t[-1] <= path.duration + 1e-9
    assert np.all(np.hypot(tr.operator_vel[:, 0], tr.operator_vel[:, 1]) <= p.VoMxy * (1 + SLACK))
    assert np.all(np.abs(tr.operator_vel[:, 2]) <= p.VoMz * (1 + SLACK))
    assert np.all((tr.operator[:, 2] >= p.lmin - 1e-9) & (tr.operator[:, 2] <= p.le + 1e-9))
    if tr.intercept_time is None:
        assert not tr.frontal
    else:
        assert 0.0 <= tr.intercept_time <= tr.t[-1] + 1e-9
        assert tr.interception_distance is not None and math.isfinite(tr.interception_distance)


@FAST
@given(
    st.lists(st.tuples(st.floats(20.0, 80.0), st.floats(-40.0, 40.0)), min_size=1, max_size=2),
    st.lists(st.tuples(st.floats(-10.0, 10.0), st.floats(0.0, 20.0)), min_size=1, max_size=3),
    st.integers(0, 2**16),
)
def test_random_repelling_beaches_run_finite(sharks, swimmers, seed):
    operators = [[0.0, -30.0 - 5.0 * i, 2.0] for i in range(len(sharks))]
    controllers = [dp.shark.RepellingOperator(i) for i in range(len(sharks))]
    behaviour = dp.shark.SharkBehaviour()
    tr = dp.shark.simulate_repelling(sharks, operators, swimmers, controllers, t_max=5.0, seed=seed)
    for arr in (tr.t, tr.sharks, tr.operators):
        assert np.all(np.isfinite(arr))
    assert 0.0 <= tr.end_time <= 5.0 + 1e-9 and tr.t[-1] <= 5.0 + 1e-9
    assert tr.sharks.shape[1:] == (len(sharks), 3) and tr.operators.shape[1:] == (len(sharks), 3)
    horizontal = _speeds(tr.sharks[:, :, :2], tr.t)
    assert np.all(horizontal <= behaviour.speed * (1 + SLACK) + 1e-9)
    p = dp.shark.THESIS_TABLE_5_1
    assert np.all(_speeds(tr.operators[:, :, :2], tr.t) <= p.VoMxy * (1 + SLACK) + 1e-9)


# ---------------------------------------------------------------------------- covert
@FAST
@given(
    st.integers(1, 4),
    st.integers(0, 2**16),
    st.sampled_from(["sliding", "hover"]),
    st.floats(0.0, 0.5),
)
def test_random_covert_target_groups_give_bearing_changes_in_range(n_targets, seed, method, noise):
    case = dp.covert.random_case(n_targets, seed, n_hills=2)
    controller = dp.covert.SlidingModeObserver() if method == "sliding" else dp.covert.HoverBenchmark()
    tr = dp.covert.simulate(case, controller, t_max=4.0, noise=noise, seed=seed)
    p = case.params
    assert np.all(np.isfinite(tr.drone)) and np.all(np.isfinite(tr.targets)) and np.all(np.isfinite(tr.t))
    assert tr.targets.shape[1] == n_targets and tr.t[-1] <= 4.0 + 1e-9
    assert np.all(_speeds(tr.drone, tr.t) <= p.V_max * (1 + SLACK))
    seen = tr.beta[np.isfinite(tr.beta)]
    assert np.all((seen >= 0.0) & (seen <= math.pi))
    if seen.size:
        assert math.isclose(tr.beta_max, float(seen.max()), rel_tol=1e-12, abs_tol=1e-15)
    for time_ in (tr.t_a, tr.t_f):
        assert time_ is None or 0.0 <= time_ <= tr.t[-1] + 1e-9
