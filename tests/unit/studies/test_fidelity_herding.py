"""The R_b = 140 m herding study: the variant animal step is the scenario's step, and the traced
mechanism (far-side barking by bunched drones translates the herd instead of gathering it)."""

import math

import numpy as np
import pytest

from droneplan.scenarios.herding import HerdingParams, animal_step, barking_mask, thesis_scenario
from droneplan.studies.thesis.fidelity_herding import (
    RULES,
    drone_repulsion,
    stalled_state,
    trace_gathering,
    variant_animal_step,
)


def _small_herd():
    sc = thesis_scenario(120, seed=3, R_b=140.0, field_size=(150.0, 150.0))
    drones = np.array([[75.0, -40.0], [190.0, 75.0], [75.0, 190.0], [-40.0, 75.0]])
    return sc, drones


def test_rule_sum_is_the_scenario_step_bit_for_bit():
    sc, drones = _small_herd()
    a1 = a2 = sc.animals
    h1 = h2 = np.zeros_like(sc.animals)
    r1, r2 = np.random.default_rng(5), np.random.default_rng(5)
    for _ in range(25):
        a1, h1, m1 = animal_step(a1, h1, drones, sc.params, r1)
        a2, h2, m2 = variant_animal_step(a2, h2, drones, sc.params, r2, "sum")
        assert np.array_equal(a1, a2) and np.array_equal(h1, h2) and np.array_equal(m1, m2)


def test_rules_against_a_loop_over_the_drones():
    sc, drones = _small_herd()
    c = sc.animals.mean(axis=0)
    cone = barking_mask(sc.animals, drones, c, sc.params.R_b, sc.params.beta)
    got = {rule: drone_repulsion(sc.animals, drones, c, sc.params, rule)[0] for rule in RULES}
    for i, a in enumerate(sc.animals):
        units = [(a - d) / np.linalg.norm(a - d) for d, inside in zip(drones, cone[i], strict=True) if inside]
        if not units:
            for rule in RULES:
                assert np.all(got[rule][i] == 0)
            continue
        total = np.sum(units, axis=0)
        np.testing.assert_allclose(got["unnormalised"][i], total, atol=1e-12)
        np.testing.assert_allclose(got["sum"][i], total / np.linalg.norm(total), atol=1e-9)
        near = min(
            (d for d, inside in zip(drones, cone[i], strict=True) if inside),
            key=lambda d: np.linalg.norm(a - d),
        )
        np.testing.assert_allclose(got["nearest"][i], (a - near) / np.linalg.norm(a - near), atol=1e-12)


def test_far_side_barking_needs_the_drone_within_R_b_of_the_centroid():
    rng = np.random.default_rng(0)
    p = HerdingParams(R_b=140.0)
    seen = 0
    for _ in range(50):
        animals = rng.normal(scale=60.0, size=(80, 2))
        drones = rng.normal(scale=120.0, size=(4, 2))
        c = animals.mean(axis=0)
        cone = barking_mask(animals, drones, c, p.R_b, p.beta)
        across = ((animals - c) @ (drones - c).T) < 0
        hit = cone & across
        seen += int(hit.sum())
        dist_c = np.linalg.norm(drones - c, axis=1)
        assert np.all(dist_c[np.nonzero(hit)[1]] < p.R_b)
    assert seen > 0  # the property was exercised


def test_stalled_herd_translates_instead_of_gathering_at_R_b_140():
    """The mechanism on a short run: every step some animals are barked at from across C_o by
    drones bunched within half a turn, the groups do not merge, and the centroid moves more than
    the footprint shrinks; at R_b = 100 m, or with every animal as a neighbour, it gathers."""
    tr = trace_gathering(stalled_state(HerdingParams(R_b=140.0), seed=1), t_max=60.0, seed=3)
    assert tr["gather_time"] is None
    assert np.all(tr["barked_across"] > 0)
    assert np.all(tr["drone_arc"] < math.pi)
    assert np.all(tr["groups"] >= 2)
    drift = np.linalg.norm(tr["centroid"][-1] - tr["centroid"][0])
    assert drift > tr["r"][0] - tr["r"][-1] + 50.0
    for params in (HerdingParams(R_b=100.0), HerdingParams(R_b=140.0, n_neighbours=199)):
        assert trace_gathering(stalled_state(params, seed=1), t_max=60.0, seed=3)["gather_time"] is not None


@pytest.mark.parametrize("bad", ["mean", 3, None])
def test_bad_rule(bad):
    sc, drones = _small_herd()
    with pytest.raises(ValueError, match="rule"):
        drone_repulsion(sc.animals, drones, sc.animals.mean(axis=0), sc.params, bad)


def test_bad_arguments():
    sc, _ = _small_herd()
    with pytest.raises(TypeError, match="scenario"):
        trace_gathering("not a scenario")
    with pytest.raises(ValueError, match="t_max"):
        trace_gathering(sc, t_max=float("nan"))
    with pytest.raises(TypeError, match="params"):
        stalled_state({"R_b": 140.0})
