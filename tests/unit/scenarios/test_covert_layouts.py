"""Case 1's two layouts: the reconstructed one ("figures") meets what §3.5 states about Figs 3.9
and 3.11 (paths, distances, phase times), and today's ("ours") stays as it was."""

import math

import numpy as np
import pytest

from droneplan.planners.covert import SlidingModeObserver
from droneplan.scenarios.covert import LAYOUTS, CovertScenario, simulate, thesis_case, two_target_layout
from droneplan.studies.thesis.fidelity_covert import figure_checks

T = np.arange(0.0, 120.0 + 1e-9, 0.5)


@pytest.fixture(scope="module")
def figures():
    sc = thesis_case(1, layout="figures")
    return sc, simulate(sc, SlidingModeObserver())


def test_layouts_are_named():
    assert LAYOUTS == ("ours", "figures")
    assert thesis_case(1).name == "case 1"
    assert thesis_case(1, layout="figures").name == "case 1 (figures layout)"


def test_figures_targets_walk_240_m(figures):
    sc, _ = figures
    A = sc.targets_at(T)
    walked = np.sum(np.linalg.norm(np.diff(A, axis=0), axis=2), axis=0)
    np.testing.assert_allclose(walked, 240.0, rtol=1e-3)  # V_T = 2 m/s for 120 s, in 3-D


def test_figures_statements_met_and_the_one_not(figures):
    """Every statement the study checks holds but one, which the preset's docstring names."""
    sc, tr = figures
    checks = figure_checks(sc, tr)
    assert {k for k, ok in checks.items() if not ok} == {"in_zone"}
    ours = thesis_case(1)
    checks = figure_checks(ours, simulate(ours, SlidingModeObserver()))
    assert {k for k, ok in checks.items() if not ok} == {"away", "t_f"}


def test_figures_target_1_walks_an_s_and_target_2_a_line(figures):
    sc, _ = figures
    A = sc.targets_at(T)[..., :2]
    chord = (A[-1, 0] - A[0, 0]) / np.linalg.norm(A[-1, 0] - A[0, 0])
    side = (A[:, 0] - A[0, 0]) @ np.array([-chord[1], chord[0]])
    signs = np.sign(side[np.abs(side) > 1.0])
    assert np.count_nonzero(np.diff(signs)) >= 1  # crosses its chord: an S, not an arc
    d2 = A[:, 1] - A[0, 1]
    lateral = np.abs(d2[:, 0] * d2[-1, 1] - d2[:, 1] * d2[-1, 0]) / np.linalg.norm(d2[-1])
    assert lateral.max() < 1e-6  # straight on the ground


def test_figures_targets_approach_then_drift_and_target_1_climbs(figures):
    sc, _ = figures
    A = sc.targets_at(T)
    sep = np.linalg.norm(A[:, 0] - A[:, 1], axis=1)
    k = int(np.argmin(sep))
    assert 40.0 <= T[k] <= 80.0 and sep[0] > sep[k] < sep[-1]
    k60 = int(np.searchsorted(T, 60.0))
    assert A[-1, 0, 2] - A[k60, 0, 2] >= 5.0  # target 1 climbs in its second half
    dz = np.abs(A[:, 0, 2] - A[:, 1, 2])
    assert dz[-1] > dz[k60]  # and the height difference grows


def test_figures_phase_times_and_distances(figures):
    sc, tr = figures
    assert tr.t_a == pytest.approx(7.4, abs=0.5)  # Fig. 3.11: t_a = 7.4 s
    assert tr.t_f == pytest.approx(113.2, abs=1.0)  # t_f = 113.2 s
    on = (tr.t >= tr.t_a) & (tr.t <= tr.t_f)
    np.testing.assert_allclose(tr.distance_to_F[on], sc.params.L_u, atol=1.0)  # on the sphere
    ka, kf = (int(np.searchsorted(tr.t, x)) for x in (tr.t_a, tr.t_f))
    dist = np.linalg.norm(tr.targets - tr.drone[:, None, :], axis=2)
    assert np.all(dist[kf] > dist[ka])  # the targets move away from the drone after t_a


def test_figures_beta_falls_then_rises_more_slowly(figures):
    _, tr = figures
    t, b = tr.t, tr.beta_m
    k1, k60, k2 = (int(np.searchsorted(t, x)) for x in (tr.t_a + 1.0, 60.0, tr.t_f - 1.0))
    assert b[k60] < b[k1] and b[k60] < b[k2]
    assert (b[k1] - b[k60]) / (t[k60] - t[k1]) > (b[k2] - b[k60]) / (t[k2] - t[k60])


def test_ours_layout_unchanged():
    a = thesis_case(1)
    b = thesis_case(1, layout="ours")
    for p, q in zip(a.paths, b.paths, strict=True):
        np.testing.assert_array_equal(p.points, q.points)
    assert a.paths[0].points[0, :2].tolist() == pytest.approx([30.0, 150.0])
    assert a.paths[1].points[0, :2].tolist() == pytest.approx([190.0, 15.0])


@pytest.mark.parametrize(
    ("kwargs", "exc", "match"),
    [
        ({"layout": "thesis"}, ValueError, "layout"),
        ({"layout": 1}, TypeError, "layout"),
        ({"layout": None}, TypeError, "layout"),
        ({"layout": "figures", "occlusion": "obstacle"}, ValueError, "layout"),
    ],
)
def test_bad_layout(kwargs, exc, match):
    with pytest.raises(exc, match=match):
        thesis_case(1, **kwargs)
    with pytest.raises((ValueError, TypeError), match="layout"):
        thesis_case(2, layout="figures")


@pytest.mark.parametrize(
    ("name", "value", "exc"),
    [
        ("centre_angle_deg", 120.0, ValueError),
        ("heading_deg", math.nan, ValueError),
        ("crossing_deg", -1.0, ValueError),
        ("closest_m", -1.0, ValueError),
        ("hill_m", "tall", TypeError),
        ("centre_dist_m", -5.0, ValueError),
    ],
)
def test_two_target_layout_bad_input(name, value, exc):
    with pytest.raises(exc, match=name):
        two_target_layout(**{name: value})


def test_two_target_layout_geometry():
    sc = two_target_layout(
        centre_dist_m=85.0, crossing_deg=60.0, closest_m=20.0, s_amplitude_m=0.0, hill_m=0.0
    )
    assert isinstance(sc, CovertScenario) and sc.n_targets == 2
    A = sc.targets_at(np.array([60.0]))[0]
    mid = A.mean(axis=0)[:2]
    F, D_s = np.asarray(sc.params.F[:2]), np.asarray(sc.params.D_s[:2])
    towards = (D_s - F) / np.linalg.norm(D_s - F)
    np.testing.assert_allclose(mid, F + 85.0 * towards, atol=1e-6)  # the pair's centre at mid-mission
    np.testing.assert_allclose(np.linalg.norm(A[0] - A[1]), 20.0, atol=1e-6)  # closest_m apart
    d0 = sc.paths[0].points[-1, :2] - sc.paths[0].points[0, :2]
    d1 = sc.paths[1].points[-1, :2] - sc.paths[1].points[0, :2]
    cosang = d0 @ d1 / np.linalg.norm(d0) / np.linalg.norm(d1)
    assert math.degrees(math.acos(cosang)) == pytest.approx(60.0, abs=1e-6)
