"""planners.covert: W/g properties, the sliding-mode laws against the hover benchmark."""

from __future__ import annotations

import math
from dataclasses import replace
from functools import cache

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from droneplan.planners.covert import (
    HoverBenchmark,
    MPCObserver,
    MPCObserverSettings,
    SafeguardedMPCObserver,
    SafeguardSettings,
    SlidingModeObserver,
    SlidingSettings,
    W,
    g,
    rollout_sliding,
    selection_weights,
)
from droneplan.scenarios.covert import (
    THESIS_TABLE_3_2,
    CovertPhase,
    CovertScenario,
    Terrain,
    simulate,
    thesis_case,
)
from droneplan.solvers.result import SolveResult, Status

coord = st.floats(-100, 100, allow_nan=False, allow_infinity=False)
vec3 = st.tuples(coord, coord, coord).map(np.array)


@settings(max_examples=80, deadline=None)
@given(vec3, vec3)
def test_W_is_unit_orthogonal_and_towards_mu2(m1, m2):
    if np.linalg.norm(m1) < 1e-3:
        return
    w = W(m1, m2)
    e1 = m1 / np.linalg.norm(m1)
    perp = m2 - (e1 @ m2) * e1
    if np.linalg.norm(perp) > 1e-6 * max(1.0, np.linalg.norm(m2)):
        assert np.linalg.norm(w) == pytest.approx(1.0, abs=1e-9)
        assert abs(w @ e1) <= 1e-9
        assert w @ m2 > 0  # directed towards mu2
        # in the plane of mu1 and mu2
        assert abs(np.linalg.det(np.vstack([w, m1, m2]))) <= 1e-6 * np.linalg.norm(m1) * max(
            1, np.linalg.norm(m2)
        )


@settings(max_examples=30, deadline=None)
@given(vec3, st.floats(-10, 10))
def test_W_zero_when_collinear(m1, lam):
    if np.linalg.norm(m1) < 1e-3:
        return
    assert np.all(W(m1, lam * m1) == 0)


def test_W_vectorised_and_g():
    m1 = np.array([[1.0, 0, 0], [0, 2.0, 0]])
    m2 = np.array([[1.0, 1.0, 0], [3.0, 1.0, 0]])
    assert np.allclose(W(m1, m2), [[0, 1, 0], [1, 0, 0]])
    assert g([1, 0, 0], [1, 5, 0]) == 1 and g([1, 0, 0], [0, 1, 0]) == -1 and g([1, 0, 0], [-1, 0, 0]) == -1
    with pytest.raises(ValueError, match="non-zero finite mu1"):
        W(np.zeros(3), np.ones(3))


def test_selection_weights():
    lit = SlidingSettings(saturation=False)
    assert selection_weights(np.array([0.1, 0.3, 0.2]), lit).tolist() == [0, 1, 0]
    sat = SlidingSettings(delta_beta=0.1)
    w = selection_weights(np.array([0.3, 0.3, 0.0, 0.25]), sat)
    assert w.sum() == pytest.approx(1.0) and w[2] == 0 and w[0] == w[1] > w[3] > 0


@cache
def _run(case: int, which: str):
    sc = thesis_case(case, 0)
    ctl = SlidingModeObserver() if which == "sliding" else HoverBenchmark()
    return sc, simulate(sc, ctl)


@pytest.mark.parametrize("case", [1, 2])
def test_sliding_beats_hover_and_keeps_the_sphere(case):
    sc, sl = _run(case, "sliding")
    _, hv = _run(case, "hover")
    assert sl.beta_max < hv.beta_max
    # stays on the observation sphere (Theorem 3.4.1) within 1 m
    assert sl.t_a is not None and sl.t_f is not None and sl.t_a < sl.t_f
    assert sl.sphere_error <= 1.0
    on = (sl.t >= sl.t_a) & (sl.t <= sl.t_f)
    assert np.all(np.abs(sl.distance_to_F[on] - sc.params.L_u) <= 1.0)
    # ends back at D_s, around the end of the period
    for tr in (sl, hv):
        assert tr.finished
        assert np.linalg.norm(tr.drone[-1] - sc.params.D_s_arr) <= 0.05 + 1e-9
        assert abs(tr.t[-1] - sc.params.duration) <= 5.0
    # heading stays unit and commands within bounds
    assert np.allclose(np.linalg.norm(sl.heading, axis=1), 1.0, atol=1e-9)
    ok = ~np.isnan(sl.v)
    assert np.all(np.abs(sl.v[ok]) <= sc.params.V_max + 1e-9)
    assert np.all(np.linalg.norm(sl.u[ok], axis=1) <= sc.params.U_max + 1e-9)


def test_hover_stays_put_on_the_sphere():
    sc, hv = _run(1, "hover")
    on = (hv.t >= hv.t_a + 0.2) & (hv.t < hv.t_f)
    assert np.ptp(hv.drone[on], axis=0).max() < 1e-9
    assert abs(hv.distance_to_F[on][0] - sc.params.L_u) <= 0.05


def test_sliding_equalises_the_two_bearing_changes_on_the_sphere():
    """Fig. 3.11: beta_1 and beta_2 almost the same during the observation (min-max)."""
    _, sl = _run(1, "sliding")
    on = (sl.t >= sl.t_a + 5) & (sl.t <= sl.t_f)
    diff = np.abs(sl.beta[on, 0] - sl.beta[on, 1])
    assert np.degrees(np.median(diff)) < 1.0


def test_occlusion_tracks_the_visible_target():
    """Fig. 3.13: after target 2 is hidden (t >= 90 s), beta_1 is close to zero."""
    sc = thesis_case(1, occlusion=True)
    tr = simulate(sc, SlidingModeObserver())
    late = (tr.t >= 95) & (tr.t <= tr.t_f)
    assert np.all(np.isnan(tr.beta[tr.t >= 90, 1]))
    assert np.degrees(np.nanmax(tr.beta[late, 0])) < 2.0


def test_no_targets_flies_the_benchmark_path():
    p = replace(THESIS_TABLE_3_2, duration=40.0)
    sc = CovertScenario(p, Terrain(), ())
    with pytest.warns(UserWarning, match="no target"):
        a = simulate(sc, SlidingModeObserver())
    with pytest.warns(UserWarning, match="beta_max is NaN"):
        b = simulate(sc, HoverBenchmark())
    assert a.finished and b.finished
    assert a.drone.shape == b.drone.shape and np.allclose(a.drone, b.drone, atol=1e-9)


def test_settings_validation():
    with pytest.raises(ValueError, match="eps_line"):
        SlidingSettings(eps_line=0.0)
    with pytest.raises(ValueError, match="cos_sat"):
        SlidingSettings(cos_sat=2.0)


# --------------------------------------------------------------------------- MPC observer


@pytest.mark.parametrize("backend", ["ipopt", "osqp"])
def test_mpc_commands_within_plant_bounds(backend):
    sc = thesis_case(1)
    ctl = MPCObserver(observer=MPCObserverSettings(backend=backend))
    tr = simulate(sc, ctl, t_max=14.0)
    ok = ~np.isnan(tr.v)
    assert np.all(np.abs(tr.v[ok]) <= sc.params.V_max + 1e-9)
    assert np.all(np.linalg.norm(tr.u[ok], axis=1) <= sc.params.U_max + 1e-9)
    # the commands respect (3.5): orthogonal to the heading they were issued for
    assert np.all(np.abs(np.sum(tr.u[ok] * tr.heading[ok], axis=1)) <= 1e-9)
    assert len(tr.solve_times) > 0 and tr.fallbacks == ctl.fallbacks
    assert tr.t_a is not None  # reached the sphere on its approach schedule
    on = tr.t >= tr.t_a
    assert np.all(np.abs(tr.distance_to_F[on] - sc.params.L_u) <= 1.0)


def test_mpc_warm_starts_are_reported_as_what_they_were(monkeypatch):
    import droneplan.formulations.covert as fc

    seen = []
    real = fc.RecedingBearingMPC.solve

    def spy(self, data, **kw):
        res = real(self, data, **kw)
        seen.append((kw.get("x0") is not None, kw.get("start"), res))
        return res

    monkeypatch.setattr(fc.RecedingBearingMPC, "solve", spy)
    ctl = MPCObserver()
    simulate(thesis_case(1), ctl, t_max=6.0)
    assert seen and seen[0][1] == "sliding-rollout"  # the first solve starts from the sliding rollout
    for handed, label, res in seen:
        # warm_started is True exactly when a start was handed over, and info names it
        assert res.warm_started == handed and res.info["start"] == label
        assert isinstance(res.info["duals_reused"], bool)
    # later solves start from the previous plan shifted by one period, reusing its duals
    later = [r for g, lab, r in seen[1:] if lab == "shifted-plan"]
    assert later and any(r.info["duals_reused"] for r in later)
    assert len(ctl.starts) == len(ctl.statuses)
    assert set(ctl.starts) <= {"sliding-rollout", "shifted-plan", ""}


def test_mpc_falls_back_to_sliding_mode_and_counts(monkeypatch):
    import droneplan.formulations.covert as fc

    def failing(self, data, **kw):
        return SolveResult(Status.ERROR, backend="stub", message="forced failure")

    monkeypatch.setattr(fc.RecedingBearingMPC, "solve", failing)
    p = replace(THESIS_TABLE_3_2)
    sc = thesis_case(1)
    ctl = MPCObserver()
    tr = simulate(sc, ctl, t_max=20.0)
    ref = simulate(sc, SlidingModeObserver(), t_max=20.0)
    assert np.allclose(tr.drone, ref.drone)
    assert tr.fallbacks == len(tr.solve_times) > 100
    assert p == THESIS_TABLE_3_2


def test_mpc_observer_settings_validation():
    with pytest.raises(ValueError, match="backend"):
        MPCObserverSettings(backend="gurobi")
    with pytest.raises(ValueError, match="progress"):
        MPCObserverSettings(progress=0.0)


# --------------------------------------------------------------------------- safeguarded MPC


def test_rollout_sliding_reproduces_the_closed_loop_on_true_targets():
    """Fed the true target positions, the open-loop rollout is the closed-loop sliding observer
    (approach, arrival switch and on-sphere law) up to rounding."""
    sc = thesis_case(1)
    tr = simulate(sc, SlidingModeObserver(), t_max=15.0)
    K = tr.t.size - 1
    D, h, phases = rollout_sliding("to-sphere", tr.drone[0], tr.heading[0], tr.targets[:K], sc.params)
    assert np.allclose(D, tr.drone, atol=1e-7)
    assert np.allclose(h, tr.heading, atol=1e-9)
    assert phases[0] == "to-sphere" and phases[-1] == "on-sphere"
    assert list(tr.phase[:K]) == phases
    with pytest.raises(ValueError, match="targets"):
        rollout_sliding("to-sphere", tr.drone[0], tr.heading[0], tr.targets[0], sc.params)
    # the phases come back as CovertPhase members; an unknown phase name is refused
    assert all(isinstance(ph, CovertPhase) for ph in phases)
    with pytest.raises(ValueError, match="sideways"):
        rollout_sliding("sideways", tr.drone[0], tr.heading[0], tr.targets[:K], sc.params)


def test_controller_params_need_a_reset():
    ctl = SlidingModeObserver()
    with pytest.raises(RuntimeError, match="reset"):
        _ = ctl.params
    sc = thesis_case(1)
    ctl.reset(sc)
    assert ctl.params is sc.params


def test_safeguard_with_a_huge_margin_is_the_sliding_mode():
    """If the MPC plan must beat the sliding rollout by more than any angle, every replan flies
    the sliding-mode law: the trajectory is the sliding observer's."""
    sc = thesis_case(1)
    ctl = SafeguardedMPCObserver(safeguard=SafeguardSettings(margin=10.0))
    tr = simulate(sc, ctl, t_max=12.0)
    ref = simulate(sc, SlidingModeObserver(), t_max=12.0)
    assert len(ctl.choices) > 10 and set(ctl.choices) == {"sliding"}
    assert np.allclose(tr.drone, ref.drone, atol=1e-9)


def test_safeguarded_mpc_bounds_deadline_and_choice_rule():
    sc = thesis_case(1)
    ctl = SafeguardedMPCObserver()
    tr = simulate(sc, ctl, t_max=16.0)
    p = sc.params
    ok = ~np.isnan(tr.v)
    assert np.all(np.abs(tr.v[ok]) <= p.V_max + 1e-9)
    assert np.all(np.linalg.norm(tr.u[ok], axis=1) <= p.U_max + 1e-9)
    # arrives by its deadline (+ one replan interval), which is at most tolerance + the
    # predicted sliding arrival, and keeps the sphere once there
    assert ctl.arrival_deadline is not None and tr.t_a is not None
    assert tr.t_a <= ctl.arrival_deadline + 0.5
    assert np.all(np.abs(tr.distance_to_F[tr.t >= tr.t_a] - p.L_u) <= 1.0)
    # every executed candidate has a predicted score no worse than the other one (minus the margin)
    assert len(ctl.choices) == len(ctl.predicted_scores) > 10
    for (s_mpc, s_sl), c in zip(ctl.predicted_scores, ctl.choices, strict=True):
        assert (c == "mpc") == (s_mpc <= s_sl - ctl.safeguard.margin)


def test_safeguard_settings_validation():
    with pytest.raises(ValueError, match="arrival_tolerance"):
        SafeguardSettings(arrival_tolerance=-1.0)
    with pytest.raises(ValueError, match="margin"):
        SafeguardSettings(margin=math.nan)
    with pytest.raises(ValueError, match="score_horizon"):
        SafeguardSettings(score_horizon=0.0)
    with pytest.raises(ValueError, match="envelope_speed"):
        SafeguardSettings(envelope_speed=1.5)
    with pytest.raises(TypeError):
        SafeguardedMPCObserver(safeguard=MPCObserverSettings())
