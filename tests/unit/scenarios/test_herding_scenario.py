"""Herding world: animal model limits and cones, drone model, scenario, bad input."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial import cKDTree

from droneplan.scenarios.herding import (
    HerdingParams,
    HerdingScenario,
    animal_step,
    barking_mask,
    drone_step,
    footprint_radius,
    simulate,
    table_6_2_for,
    thesis_scenario,
)
from droneplan.scenarios.herding import _unit as unit


def test_thesis_scenario_layout():
    sc = thesis_scenario(200, seed=3)
    assert sc.animals.shape == (200, 2)
    assert np.all((sc.animals >= 0) & (sc.animals <= [1200, 600]))
    assert np.allclose(sc.drones[:, 0], 1280.0)  # 80 m right of the field
    assert np.allclose(np.diff(sc.drones[:, 1]), 50.0)  # 50 m apart
    assert sc.params.R_c == 60.0 and sc.params.V_driving == 3.8
    big = thesis_scenario(1000, seed=3)
    assert big.params.R_c == 110.0 and big.params.V_driving == 1.9
    assert table_6_2_for(600) == pytest.approx((85.0, 2.85))
    # reproducible
    assert np.array_equal(thesis_scenario(50, seed=7).animals, thesis_scenario(50, seed=7).animals)
    assert not np.array_equal(thesis_scenario(50, seed=7).animals, thesis_scenario(50, seed=8).animals)


def test_barking_cone_matches_scalar_definition():
    rng = np.random.default_rng(0)
    animals = rng.uniform(-150, 150, (400, 2))
    drones = rng.uniform(-150, 150, (3, 2))
    c = animals.mean(axis=0)
    mask = barking_mask(animals, drones, c, 100.0, 2 * math.pi / 3)
    for i in range(0, 400, 7):
        for j in range(3):
            rel = animals[i] - drones[j]
            axis = c - drones[j]
            ang = math.acos(np.clip(rel @ axis / (np.linalg.norm(rel) * np.linalg.norm(axis)), -1, 1))
            expect = np.linalg.norm(rel) <= 100.0 and ang <= math.pi / 3
            assert mask[i, j] == expect


@settings(max_examples=25, deadline=None)
@given(st.integers(1, 120), st.integers(0, 10_000), st.floats(0.5, 6.0))
def test_no_animal_exceeds_V_animal(n, seed, v_animal):
    rng = np.random.default_rng(seed)
    p = HerdingParams(V_animal=v_animal, graze_speed=min(1.0, v_animal), V_driving=min(3.8, v_animal))
    animals = rng.uniform(0, 200, (n, 2))
    if n > 3:
        animals[:3] = animals[3]  # coincident animals
    heading = np.zeros_like(animals)
    drones = rng.uniform(-50, 250, (4, 2))
    moved_any = False
    for _ in range(5):
        new, heading, affected = animal_step(animals, heading, drones, p, rng)
        step = np.linalg.norm(new - animals, axis=1)
        assert np.all(step <= p.V_animal * p.delta * (1 + 1e-9))
        # animals in a cone move at exactly V_animal (the unit direction is never 0 here)
        assert np.all(np.isfinite(new))
        moved_any |= bool(affected.any())
        animals = new
    assert np.allclose(np.linalg.norm(heading, axis=1)[np.linalg.norm(heading, axis=1) > 0], 1.0)


def test_repulsed_animals_move_away_from_a_lone_drone():
    p = HerdingParams(eta_L=0.0, eta_r=0.0, eta_i=0.0, eta_e=0.0)
    animals = np.array([[0.0, 0.0], [5.0, 1.0], [-5.0, -1.0], [-300.0, 0.0]])
    drones = np.array([[60.0, 0.0], [900, 0], [900, 10], [900, 20]])
    new, _, aff = animal_step(animals, np.zeros_like(animals), drones, p, np.random.default_rng(0))
    assert aff[:3].all() and not aff[3]  # the far animal is outside R_b
    assert np.all(new[:3, 0] < animals[:3, 0])  # pushed away from the drone (to -x)
    assert np.allclose(np.linalg.norm(new[:3] - animals[:3], axis=1), p.V_animal * p.delta)


def test_drone_step_limits_and_unit_heading():
    p = HerdingParams()
    d, h = drone_step(
        np.zeros((4, 2)), np.zeros(4), np.array([100.0, -100, 10, 0]), np.array([50.0, -50, 1, 0]), p, 0.2
    )
    assert np.allclose(np.linalg.norm(d, axis=1), [5.0, 5.0, 2.0, 0.0])  # |v| clipped to V_max
    assert np.allclose(h, [1.0, -1.0, 0.2, 0.0])  # |omega| clipped to U_max


def test_footprint_radius():
    assert footprint_radius(np.array([[0.0, 0.0], [2.0, 0.0]])) == pytest.approx(1.0)


@pytest.mark.parametrize(
    ("kw", "match"),
    [
        ({"V_max": 0.0}, "V_max"),
        ({"U_max": -1.0}, "U_max"),
        ({"R_b": float("nan")}, "R_b"),
        ({"d_s": 0}, "d_s"),
        ({"V_animal": -4.0}, "V_animal"),
        ({"beta": 0.0}, "beta"),
        ({"n_drones": 0}, "n_drones"),
        ({"V_driving": 5.0}, "V_driving"),
        ({"graze_prob": 1.5}, "graze_prob"),
        ({"R_c": 0.0}, "R_c"),
        ({"delta": -0.2}, "delta"),
    ],
)
def test_params_bad_input(kw, match):
    with pytest.raises(ValueError, match=match):
        HerdingParams(**kw)


def test_scenario_bad_input():
    with pytest.raises(ValueError, match="n_animals"):
        thesis_scenario(0)
    with pytest.raises(ValueError, match="n_drones"):
        thesis_scenario(10, n_drones=0)
    sc = thesis_scenario(10, seed=0)
    with pytest.raises(ValueError, match="mismatched lengths"):
        HerdingScenario(sc.params, sc.animals, sc.drones, sc.headings[:2], sc.goal)
    with pytest.raises(ValueError, match="animals"):
        HerdingScenario(sc.params, np.zeros((0, 2)), sc.drones, sc.headings, sc.goal)
    with pytest.raises(ValueError, match="finite"):
        HerdingScenario(sc.params, sc.animals + np.nan, sc.drones, sc.headings, sc.goal)
    with pytest.raises(ValueError, match="field width"):
        thesis_scenario(10, field_size=(0.0, 10.0))


@pytest.mark.parametrize(
    ("field", "error", "match"),
    [
        ((0.0, 0.0, np.nan, 600.0), ValueError, "field must be finite"),
        ((0.0, 0.0, 1e200, 600.0), ValueError, "field has an entry of magnitude"),
        ((), ValueError, r"field must have shape \(4\)"),
        ((0.0, 0.0, 1200.0), ValueError, r"field must have shape \(4\)"),
        ((0.0, 0.0, 0.0, 600.0), ValueError, "xmin < xmax"),
        ((0.0, 600.0, 1200.0, 0.0), ValueError, "ymin < ymax"),
        ("field", TypeError, "field must be an array"),
    ],
)
def test_scenario_field_is_checked(field, error, match):
    sc = thesis_scenario(10, seed=0)
    with pytest.raises(error, match=match):
        HerdingScenario(sc.params, sc.animals, sc.drones, sc.headings, sc.goal, field)
    ok = HerdingScenario(sc.params, sc.animals, sc.drones, sc.headings, sc.goal, [-1, -2, 3, 4])
    assert ok.field == (-1.0, -2.0, 3.0, 4.0) and all(type(v) is float for v in ok.field)


class _Idle:
    """A herder that never moves (the flag check refuses before it is used)."""

    def reset(self, scenario, seed=None):
        pass

    def command(self, *args, **kwargs):
        raise AssertionError("simulate ran with an unchecked flag")


@pytest.mark.parametrize("flag", ["yes", 1, None])
def test_simulate_stop_after_gathering_must_be_a_bool(flag):
    with pytest.raises(TypeError, match="stop_after_gathering must be a bool"):
        simulate(thesis_scenario(10, seed=0), _Idle(), t_max=1.0, stop_after_gathering=flag)


@pytest.mark.parametrize("split", [False, True])
@pytest.mark.parametrize("n", [2, 30, 400])
def test_animal_step_bit_identical_to_einsum_and_mean_formulation(n, split, monkeypatch):
    """animal_step sums over neighbours slice by slice; the step equals the (m, k, 2) einsum / mean
    formulation of the model to the last bit, so the faster layout leaves every trajectory unchanged.
    split: the per-animal split of the work that large herds take (cone test near the drones only,
    bounded neighbour search for grazing animals), forced on here."""
    import droneplan.scenarios.herding as herding_module

    monkeypatch.setattr(herding_module, "_SPLIT_MIN", 2 if split else 10**9)
    monkeypatch.setattr(herding_module, "_BALL_MIN", 2 if split else 10**9)
    rng = np.random.default_rng(n)
    p = HerdingParams(graze_prob=0.5)
    side = 3 * math.sqrt(n) + 1  # dense: many neighbours closer than r_a
    animals = rng.uniform(0, side, (n, 2))
    heading = unit(rng.normal(size=(n, 2)))
    drones = np.array([[side + 90.0, side / 2], [-500.0, -500.0]])  # one reaches 10 m into the herd
    new, new_head, affected = animal_step(animals, heading, drones, p, seed=5)
    # the reference formulation of the module docstring, with the same random draws
    r = np.random.default_rng(5)
    c = animals.mean(axis=0)
    cone = barking_mask(animals, drones, c, p.R_b, p.beta)
    aff = cone.any(axis=1)
    movers = np.flatnonzero(aff | (r.random(n) < p.graze_prob))
    assert np.array_equal(affected, aff)
    if n > 2:  # the case covers barked-at, grazing and standing animals
        assert 0 < aff.sum() < movers.size < n
    pos = animals[movers]
    eps = unit(r.normal(size=(movers.size, 2)))
    k = min(p.n_neighbours, n - 1) + 1
    dist, idx = cKDTree(animals).query(pos, k=k)
    dist, idx = dist[:, 1:], idx[:, 1:]
    nb = animals[idx]
    w = np.where(dist < p.r_a, 1.0 / np.maximum(dist, 1e-12), 0.0)
    R_a = unit(np.einsum("mk,mkc->mc", w, pos[:, None, :] - nb))
    C = unit(nb.mean(axis=1) - pos)
    rel = pos[:, None, :] - drones[None, :, :]
    R_d = unit(np.einsum("md,mdc->mc", cone[movers] / np.sqrt(np.sum(rel * rel, axis=2)), rel))
    herd = p.eta_d * R_d + p.eta_L * C + p.eta_r * R_a + p.eta_i * heading[movers] + p.eta_e * eps
    direction = unit(np.where(aff[movers, None], herd, p.eta_r * R_a + p.eta_e * eps))
    speed = np.where(aff[movers], p.V_animal, p.graze_speed)
    expected = animals.copy()
    expected[movers] = pos + (speed * p.delta)[:, None] * direction
    assert np.array_equal(new, expected)
    assert np.array_equal(new_head[movers], direction)
