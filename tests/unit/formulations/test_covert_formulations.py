"""formulations.covert: the min-max bearing MPC against the plant and its own epigraph."""

from __future__ import annotations

import math
from dataclasses import replace

import casadi as ca
import numpy as np
import pytest

from droneplan.formulations.covert import (
    MPCData,
    MPCSettings,
    RecedingBearingMPC,
    build_bearing_mpc,
    cos_bearing_symbolic,
    rollout_guess,
    solve_bearing_mpc,
)
from droneplan.scenarios.covert import THESIS_TABLE_3_2, bearing_changes, step_drone

P = THESIS_TABLE_3_2
SET = MPCSettings(horizon=5, step=0.5, replan_every=2)


def _data(on_sphere: bool, targets: np.ndarray, n_nodes: int) -> MPCData:
    F = P.F_arr
    if on_sphere:
        d = np.array([-1.0, -1.0, 0.45])
        D0 = F + P.L_u * d / np.linalg.norm(d)
        e = np.cross(D0 - F, [0, 0, 1.0])
        h0 = e / np.linalg.norm(e)
        lo = hi = np.full(n_nodes, P.L_u)
    else:
        D0 = P.D_s_arr
        h0 = (F - D0) / np.linalg.norm(F - D0)
        lo = np.full(n_nodes, P.L_u)
        hi = np.full(n_nodes, np.linalg.norm(F - D0))
    A = np.broadcast_to(targets, (n_nodes, *targets.shape)).copy()
    tangent = np.zeros(n_nodes, bool)
    if on_sphere:
        tangent[1:] = True
    return MPCData(D0, h0, A, np.ones(targets.shape[0], bool), lo, hi, np.full(n_nodes, np.inf), tangent)


TARGETS = np.array([[120.0, 150.0, 5.0], [150.0, 110.0, 10.0]])


def test_symbolic_cosine_is_the_twin_of_bearing_changes():
    rng = np.random.default_rng(1)
    D = ca.SX.sym("D", 3)
    A = ca.SX.sym("A", 3)
    f = ca.Function("c", [D, A], [cos_bearing_symbolic(D, A, P.R_arr, eps=0.0)])
    for _ in range(20):
        d, a = rng.uniform(0, 200, 3), rng.uniform(0, 200, 3)
        assert float(f(d, a)) == pytest.approx(math.cos(bearing_changes(d, a[None], P.R)[0]), abs=1e-9)


def test_model_dynamics_are_the_plant():
    """A rollout through the plant's step is feasible for the model's dynamics rows."""
    model = build_bearing_mpc(P, 2, SET)
    data = _data(False, TARGETS, SET.horizon)
    rng = np.random.default_rng(0)
    u = rng.normal(size=(SET.horizon, 3)) * 3
    v = rng.uniform(-10, 10, SET.horizon)
    x = rollout_guess(model, data, u, v)
    g = ca.Function("g", [model.nlp["x"], model.nlp["p"]], [model.nlp["g"]])(x, model.pack_params(data))
    g = np.asarray(g).ravel()
    assert np.max(np.abs(g[model.gidx["dyn"]])) < 1e-9
    assert np.max(np.abs(g[model.gidx["orth"]])) < 1e-9
    # and the plant itself, stepped with the same commands in sub-steps, lands on the model's nodes
    plan = model.unpack(x, data)
    D, h = data.D0, data.h0
    for k, dur in enumerate(model.durations):
        D, h, _, _ = step_drone(D, h, plan.u[k], plan.v[k], float(dur), replace(P, dt=min(float(dur), P.dt)))
        assert np.allclose(D, plan.D[k + 1], atol=1e-9) and np.allclose(h, plan.h[k + 1], atol=1e-9)


@pytest.mark.parametrize("on_sphere", [False, True])
def test_ipopt_plan_is_admissible_and_epigraph_tight(on_sphere):
    data = _data(on_sphere, TARGETS, SET.horizon)
    res = solve_bearing_mpc(P, data, SET)
    assert res.has_solution, res.message
    plan = res.x
    assert np.all(np.linalg.norm(plan.u, axis=1) <= P.U_max + 1e-6)
    assert np.all(np.abs(plan.v) <= P.V_max + 1e-9)
    assert np.allclose(np.linalg.norm(plan.h, axis=1), 1.0, atol=1e-5)
    assert np.all(np.abs(np.sum(plan.h[:-1] * plan.u, axis=1)) <= 1e-5)
    dist = np.linalg.norm(plan.D[1:] - P.F_arr, axis=1)
    if on_sphere:
        assert np.allclose(dist, P.L_u, atol=1e-5)
    else:
        assert np.all(dist >= P.L_u - 1e-5)
    # objective = predicted max bearing change over the nodes (epigraph tight at the optimum)
    beta = bearing_changes(plan.D[1:], data.targets, P.R)
    assert res.objective == pytest.approx(beta.max(), abs=2e-3)
    # it is no worse than its starting point (zero commands: hover/coast)
    x0 = rollout_guess(
        RecedingBearingMPC(build_bearing_mpc(P, 2, SET)).model,
        data,
        np.zeros((SET.horizon, 3)),
        np.zeros(SET.horizon),
    )
    D0_nodes = np.vstack([data.D0] * SET.horizon)
    assert res.objective <= bearing_changes(D0_nodes, data.targets, P.R).max() + 1e-6
    assert x0.shape == (build_bearing_mpc(P, 2, SET).n_x,)


def test_single_static_target_on_sphere_reaches_its_camouflage_line():
    """Oracle: one target, the line R-A crosses the sphere, so the optimum is beta = 0 once
    the drone can get there; from 3 m away the plan gets within a fraction of a degree."""
    A = np.array([[140.0, 140.0, 0.0]])
    R, F = P.R_arr, P.F_arr
    # point of the line R->A on the sphere
    d = (A[0] - R) / np.linalg.norm(A[0] - R)
    b = 2 * d @ (R - F)
    c = (R - F) @ (R - F) - P.L_u**2
    lam = (-b - math.sqrt(b * b - 4 * c)) / 2
    X = R + lam * d
    assert abs(np.linalg.norm(X - F) - P.L_u) < 1e-9
    e = np.cross(X - F, [0, 0, 1.0])
    e /= np.linalg.norm(e)
    D0 = F + P.L_u * (X + 3.0 * e - F) / np.linalg.norm(X + 3.0 * e - F)
    N = SET.horizon
    data = MPCData(
        D0,
        -e,
        np.broadcast_to(A, (N, 1, 3)).copy(),
        np.array([True]),
        np.full(N, P.L_u),
        np.full(N, P.L_u),
        np.full(N, np.inf),
        np.r_[False, np.ones(N - 1, bool)],
    )
    res = solve_bearing_mpc(P, data, SET)
    assert res.has_solution
    beta_end = bearing_changes(res.x.D[-1], A, P.R)[0]
    assert bearing_changes(D0, A, P.R)[0] > math.radians(0.5)
    assert beta_end < math.radians(0.1)


def test_sqp_backend_returns_admissible_plan():
    model = build_bearing_mpc(P, 2, SET)
    solver = RecedingBearingMPC(model, backend="osqp")
    data = _data(False, TARGETS, SET.horizon)
    res = solver.solve(data)
    assert res.has_solution
    # iterates are re-simulated through the plant: dynamics exact, commands admissible
    assert np.all(np.linalg.norm(res.x.u, axis=1) <= P.U_max + 1e-9)
    assert np.all(np.abs(res.x.v) <= P.V_max + 1e-9)
    assert res.backend == "osqp-sqp"


def test_settings_and_inputs_validation():
    with pytest.raises(ValueError, match="horizon"):
        MPCSettings(horizon=0)
    with pytest.raises(ValueError, match="step"):
        MPCSettings(step=-1.0)
    with pytest.raises(ValueError, match="backend"):
        RecedingBearingMPC(build_bearing_mpc(P, 1, SET), backend="cplex")
    with pytest.raises(ValueError, match="U_max"):
        build_bearing_mpc(P, 1, MPCSettings(step=2.0))
    model = build_bearing_mpc(P, 2, SET)
    bad = _data(False, TARGETS, SET.horizon)
    bad = replace(bad, targets=np.full_like(bad.targets, np.nan))
    with pytest.raises(ValueError, match="finite"):
        model.pack_params(bad)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_sphere_minmax_bound_against_dense_sampling(seed):
    from droneplan.formulations.covert import sphere_minmax_bearing

    rng = np.random.default_rng(seed)
    A = np.column_stack([rng.uniform(90, 190, 4), rng.uniform(90, 190, 4), rng.uniform(0, 20, 4)])
    res = sphere_minmax_bearing(P, A)
    assert res.has_solution and res.bound <= res.objective
    assert abs(np.linalg.norm(res.x - P.F_arr) - P.L_u) < 1e-9
    assert res.objective == pytest.approx(bearing_changes(res.x, A, P.R).max())
    # brute force: many random points of the sphere, densest near the best one
    d = rng.normal(size=(200_000, 3))
    pts = P.F_arr + P.L_u * d / np.linalg.norm(d, axis=1, keepdims=True)
    local = res.x + rng.normal(scale=3.0, size=(50_000, 3))
    local = P.F_arr + P.L_u * (local - P.F_arr) / np.linalg.norm(local - P.F_arr, axis=1, keepdims=True)
    pts = np.vstack([pts, local])
    vals = bearing_changes(pts, np.broadcast_to(A, (len(pts), 4, 3)), P.R).max(axis=1)
    assert vals.min() >= res.bound - 1e-12  # the bound is valid
    assert res.objective <= vals.min() + 1e-3  # and the search found (nearly) the best


def test_receding_mpc_reports_its_start():
    model = build_bearing_mpc(P, 2, SET)
    solver = RecedingBearingMPC(model)
    data = _data(False, TARGETS, SET.horizon)
    cold = solver.solve(data)
    assert not cold.warm_started and cold.info["start"] == "straight-flight" and not cold.info["duals_reused"]
    x0 = rollout_guess(model, data, np.zeros((SET.horizon, 3)), np.full(SET.horizon, 3.0))
    warm = solver.solve(data, x0=x0, warm=cold, start="sliding-rollout")
    assert warm.warm_started and warm.info["start"] == "sliding-rollout"
    assert warm.info["duals_reused"] == cold.has_solution
