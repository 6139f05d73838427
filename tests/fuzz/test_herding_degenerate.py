"""Degenerate herds: collinear and coincident herds gather (the mitred corners of a nearly
collinear herd used to run hundreds of metres off)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import droneplan as dp
from droneplan.planners.herding.geometry import MITRE_LIMIT, extended_hull_vertices


@settings(max_examples=40, deadline=None)
@given(st.integers(3, 40), st.floats(0.0, 1e-3), st.floats(0, np.pi), st.integers(0, 2**32 - 1))
def test_extended_hull_of_a_thin_herd_stays_near_the_animals(n, thickness, angle, seed):
    """The mitred corners of a nearly collinear herd ran hundreds of metres off."""
    rng = np.random.default_rng(seed)
    along = rng.uniform(0.0, 600.0, n)
    across = rng.uniform(-thickness, thickness, n)
    u = np.array([np.cos(angle), np.sin(angle)])
    pts = along[:, None] * u + across[:, None] * np.array([-u[1], u[0]])
    hull = dp.herding.convex_hull(pts)
    E, P = extended_hull_vertices(hull, 30.0)
    assert np.all(np.linalg.norm(E - P, axis=1) <= MITRE_LIMIT * 30.0 + 1e-6)


@pytest.mark.parametrize("line", ["horizontal", "vertical"])
def test_a_collinear_herd_gathers(line):
    """30 animals on a horizontal (or vertical) line never gathered in 900 s (the
    drones parked beyond the herd's ends, on the runaway mitre corners)."""
    base = dp.herding.thesis_scenario(30, seed=0)
    if line == "horizontal":
        animals = np.column_stack([np.linspace(0.0, 1200.0, 30), np.full(30, 300.0)])
    else:
        animals = np.column_stack([np.full(30, 600.0), np.linspace(0.0, 600.0, 30)])
    trace = dp.herding.simulate(
        replace(base, animals=animals),
        dp.herding.ProposedHerder(),
        t_max=900.0,
        seed=0,
        stop_after_gathering=True,
    )
    assert trace.gather_time is not None
    assert trace.footprint_radius[-1] <= base.params.R_c


def test_coincident_animals_and_one_drone_give_a_result():
    """Degenerate but valid: every animal at one point, and a single drone."""
    sc = dp.herding.thesis_scenario(20, seed=1, n_drones=1)
    sc = replace(sc, animals=np.full((20, 2), 500.0))
    trace = dp.herding.simulate(sc, dp.herding.ProposedHerder(), t_max=5.0, seed=0, stop_after_gathering=True)
    assert trace.gather_time == 0.0
