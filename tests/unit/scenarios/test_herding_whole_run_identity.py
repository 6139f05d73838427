"""Whole herding runs of the fast simulator and herder against a slow reference, to the last bit.

The reference animal step is the model of :mod:`droneplan.scenarios.herding` written out plainly:
the barking cones tested for every animal, the full neighbour search (scipy's default k-d tree)
for every moving animal, and the sums over neighbours taken one neighbour after another in
increasing distance. The reference minimum enclosing circle is Welzl's point-by-point loops.
A run that gathers and then drives, with each piece swapped for its reference, must give the
same drone and animal trajectories exactly: the speed work (queries in the tree's order, the
neighbours' coordinates apart, the scalar scans of the circle) changes no value.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.spatial import cKDTree

from droneplan.core.validation import as_generator
from droneplan.planners.herding import ProposedHerder, herders
from droneplan.scenarios import herding
from droneplan.scenarios.herding import HerdingPhase, barking_mask, simulate, thesis_scenario


def _unit(v: np.ndarray) -> np.ndarray:
    n = np.sqrt(v[:, 0] * v[:, 0] + v[:, 1] * v[:, 1])
    return v / np.maximum(n, 1e-12)[:, None]


def _reference_step(animals, heading, drones, p, seed, dt, barking, centroid):
    """One animal step of the model, every moving animal alike (module docstring)."""
    dt = p.delta if dt is None else dt
    rng = as_generator(seed)
    n = animals.shape[0]
    cone = barking_mask(animals, drones, centroid, p.R_b, p.beta, barking)
    affected = cone.any(axis=1)
    movers = np.flatnonzero(affected | (~affected & (rng.random(n) < p.graze_prob)))
    new_pos, new_head = animals.copy(), heading.copy()
    if movers.size == 0:
        return new_pos, new_head, affected, movers
    pos = animals[movers]
    eps = _unit(rng.normal(size=(movers.size, 2)))
    K = min(p.n_neighbours, n - 1)
    R_a = np.zeros((movers.size, 2))
    C = np.zeros((movers.size, 2))
    if K > 0:
        dist, idx = cKDTree(animals).query(pos, k=K + 1)
        dist, idx = dist[:, 1:], idx[:, 1:]  # the animal itself ranks first
        away = np.zeros((movers.size, 2))
        total = np.zeros((movers.size, 2))
        for r in range(K):  # neighbours in increasing distance
            nb = animals[idx[:, r]]
            w = np.where(dist[:, r] < p.r_a, 1.0 / np.maximum(dist[:, r], 1e-12), 0.0)
            away = away + w[:, None] * (pos - nb)
            total = total + nb
        R_a = _unit(away)
        C = _unit(total / K - pos)
    rel = pos[:, None, :] - drones[None, :, :]
    R_d = _unit(np.einsum("md,mdc->mc", cone[movers] / np.sqrt(np.sum(rel * rel, axis=2)), rel))
    herd = p.eta_d * R_d + p.eta_L * C + p.eta_r * R_a + p.eta_i * heading[movers] + p.eta_e * eps
    aff = affected[movers]
    direction = _unit(np.where(aff[:, None], herd, p.eta_r * R_a + p.eta_e * eps))
    speed = np.where(aff, p.V_animal, p.graze_speed)
    new_pos[movers] = pos + (speed * dt)[:, None] * direction
    new_head[movers] = direction
    return new_pos, new_head, affected, movers


def _norm(v: np.ndarray) -> float:
    return math.sqrt(v.dot(v))


def _inside(c: tuple[np.ndarray, float], q: np.ndarray) -> bool:
    return _norm(q - c[0]) <= c[1] * (1 + 1e-12) + 1e-9


def _circ2(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, float]:
    c = (a + b) / 2
    return c, _norm(a - c)


def _circ3(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> tuple[np.ndarray, float]:
    ax, ay = a
    bx, by = b
    cx, cy = c
    d = 2 * (ax * (by - cy) + bx * (cy - ay) + cx * (ay - by))
    if abs(d) < 1e-12:  # collinear: the widest pair
        return max((_circ2(a, b), _circ2(a, c), _circ2(b, c)), key=lambda t: t[1])
    na, nb, nc = ax * ax + ay * ay, bx * bx + by * by, cx * cx + cy * cy
    u = np.array(
        [
            (na * (by - cy) + nb * (cy - ay) + nc * (ay - by)) / d,
            (na * (cx - bx) + nb * (ax - cx) + nc * (bx - ax)) / d,
        ]
    )
    return u, _norm(a - u)


def _reference_circle(arr: np.ndarray) -> tuple[np.ndarray, float]:
    """Welzl's loops over the points in order, one point at a time."""
    P = list(arr)
    c = (P[0], 0.0)
    for i in range(1, len(P)):
        if _inside(c, P[i]):
            continue
        c = (P[i], 0.0)
        for j in range(i):
            if _inside(c, P[j]):
                continue
            c = _circ2(P[i], P[j])
            for k in range(j):
                if not _inside(c, P[k]):
                    c = _circ3(P[i], P[j], P[k])
    return np.asarray(c[0], dtype=float), float(c[1])


def _run():
    scenario = thesis_scenario(200, seed=0, field_size=(200.0, 150.0), n_drones=2)
    return simulate(scenario, ProposedHerder(), t_max=100.0, seed=7, snapshot_times=(50.0,))


@pytest.mark.parametrize("split", [False, True])
def test_a_whole_run_equals_the_reference_to_the_last_bit(split, monkeypatch):
    """split: the per-animal split of the step that herds of 1000 or more take (and the cone
    test near the drones only, of 3000 or more), forced on."""
    monkeypatch.setattr(herding, "_SPLIT_MIN", 2 if split else 10**9)
    monkeypatch.setattr(herding, "_BALL_MIN", 2 if split else 10**9)
    fast = _run()
    with monkeypatch.context() as m:
        m.setattr(herding, "_animal_step", _reference_step)
        m.setattr(herders, "_min_enclosing_circle", _reference_circle)
        slow = _run()
    phases = {HerdingPhase(p) for p in fast.phase}
    assert phases == {HerdingPhase.GATHERING, HerdingPhase.DRIVING}  # gathers, then drives
    for name in ("t", "drones", "centroid", "footprint_radius", "delivered"):
        assert np.array_equal(getattr(fast, name), getattr(slow, name)), name
    assert np.array_equal(fast.snapshots[50.0].animals, slow.snapshots[50.0].animals)
    assert np.array_equal(fast.final.animals, slow.final.animals)
    assert np.array_equal(fast.final.headings, slow.final.headings)
    assert fast.gather_time == slow.gather_time
    assert list(fast.phase) == list(slow.phase)
