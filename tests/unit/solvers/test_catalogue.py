"""Reference catalogue: small problems with known optima, run against every adapter
that can take them. Optima come from hand-derived KKT points or from brute force."""

from __future__ import annotations

import itertools

import casadi as ca
import numpy as np
import pytest
import scipy.sparse as sp
from ortools.sat.python import cp_model

from droneplan.solvers.cpsat import solve_cpsat
from droneplan.solvers.mip_models import new_mip, solve_mip
from droneplan.solvers.nlp import IpoptSolver
from droneplan.solvers.qp import OsqpSolver
from droneplan.solvers.result import SolveResult, Status

MIP_BACKENDS = ["highs", "scip"]

# ----------------------------------------------------------------------------- LP
# max 3x + 2y  s.t.  x + y <= 4, x + 3y <= 6, 0 <= x <= 3, y >= 0  ->  (3, 1), 11.


@pytest.mark.parametrize("backend", MIP_BACKENDS)
def test_lp_known_optimum(backend):
    s = new_mip(backend)
    x, y = s.NumVar(0, 3, "x"), s.NumVar(0, s.infinity(), "y")
    s.Add(x + y <= 4)
    s.Add(x + 3 * y <= 6)
    s.Maximize(3 * x + 2 * y)
    res = solve_mip(s, variables=[x, y])
    assert res.status is Status.OPTIMAL
    assert res.objective == pytest.approx(11.0, abs=1e-7)
    np.testing.assert_allclose(res.x, [3.0, 1.0], atol=1e-7)
    assert res.objective <= res.bound + 1e-7


# ----------------------------------------------------------------------------- MILP knapsack
VALUES = [10, 13, 7, 8, 9, 4, 11]
WEIGHTS = [3, 4, 2, 3, 4, 1, 5]
CAPACITY = 11


def _knapsack_bruteforce() -> tuple[int, tuple[int, ...]]:
    best = (-1, ())
    for pick in itertools.product([0, 1], repeat=len(VALUES)):
        if np.dot(pick, WEIGHTS) <= CAPACITY:
            best = max(best, (int(np.dot(pick, VALUES)), pick))
    return best


def _knapsack_cpsat():
    m = cp_model.CpModel()
    x = [m.new_bool_var(f"x{i}") for i in range(len(VALUES))]
    m.add(sum(w * v for w, v in zip(WEIGHTS, x, strict=True)) <= CAPACITY)
    m.maximize(sum(c * v for c, v in zip(VALUES, x, strict=True)))
    return m, x


def _knapsack_mip(backend):
    s = new_mip(backend)
    x = [s.BoolVar(f"x{i}") for i in range(len(VALUES))]
    s.Add(sum(w * v for w, v in zip(WEIGHTS, x, strict=True)) <= CAPACITY)
    s.Maximize(sum(c * v for c, v in zip(VALUES, x, strict=True)))
    return s, x


def _check_knapsack(res: SolveResult):
    best, _ = _knapsack_bruteforce()
    assert res.status is Status.OPTIMAL
    assert res.objective == pytest.approx(best)
    assert res.objective <= res.bound + 1e-6  # maximisation: objective <= bound
    assert res.gap == pytest.approx(0.0, abs=1e-6)
    pick = np.round(res.x).astype(int)
    assert np.dot(pick, WEIGHTS) <= CAPACITY
    assert np.dot(pick, VALUES) == best


def test_knapsack_cpsat():
    m, x = _knapsack_cpsat()
    _check_knapsack(solve_cpsat(m, variables=x, workers=1))


@pytest.mark.parametrize("backend", MIP_BACKENDS)
def test_knapsack_mip(backend):
    s, x = _knapsack_mip(backend)
    _check_knapsack(solve_mip(s, variables=x))


FEASIBLE_START = [1, 0, 1, 0, 0, 1, 0]  # weight 6, value 21: feasible, not optimal


def test_knapsack_cpsat_with_parameters():
    m, x = _knapsack_cpsat()
    res = solve_cpsat(
        m, variables=x, workers=2, parameters={"subsolvers": ["max_lp", "core"], "linearization_level": 2}
    )
    _check_knapsack(res)
    with pytest.raises(ValueError, match="unknown CP-SAT parameter"):
        solve_cpsat(m, parameters={"no_such_field": 1})
    with pytest.raises(ValueError, match="linearization_level"):
        solve_cpsat(m, parameters={"linearization_level": "high"})


def test_knapsack_cpsat_warm_start_used_and_optimum_unchanged():
    m, x = _knapsack_cpsat()
    res = solve_cpsat(m, variables=x, workers=1, hint=dict(zip(x, FEASIBLE_START, strict=True)))
    assert res.warm_started
    _check_knapsack(res)


def test_knapsack_scip_warm_start_used_and_optimum_unchanged():
    s, x = _knapsack_mip("scip")
    res = solve_mip(s, variables=x, warm_start=dict(zip(x, FEASIBLE_START, strict=True)))
    assert res.warm_started
    _check_knapsack(res)


def test_highs_warm_start_used_and_optimum_unchanged():
    s, x = _knapsack_mip("highs")
    res = solve_mip(s, variables=x, warm_start=dict(zip(x, FEASIBLE_START, strict=True)))
    assert res.warm_started and "warm start not passed" not in res.message
    _check_knapsack(res)


# ----------------------------------------------------------------------------- MILP minimisation (set cover)
SETS = [{0, 1, 2}, {2, 3}, {3, 4, 5}, {0, 5}, {1, 4}, {0, 1, 2, 3}]
COSTS = [3, 2, 3, 2, 2, 5]
UNIVERSE = range(6)


def _setcover_bruteforce() -> int:
    best = None
    for pick in itertools.product([0, 1], repeat=len(SETS)):
        covered = set().union(*(S for S, p in zip(SETS, pick, strict=True) if p))
        if covered >= set(UNIVERSE):
            cost = int(np.dot(pick, COSTS))
            best = cost if best is None else min(best, cost)
    return best


def test_setcover_minimisation_bound_semantics_cpsat_and_mip():
    best = _setcover_bruteforce()
    m = cp_model.CpModel()
    x = [m.new_bool_var(f"s{i}") for i in range(len(SETS))]
    for e in UNIVERSE:
        m.add(sum(x[i] for i, S in enumerate(SETS) if e in S) >= 1)
    m.minimize(sum(c * v for c, v in zip(COSTS, x, strict=True)))
    results = [solve_cpsat(m, variables=x, workers=1)]
    for backend in MIP_BACKENDS:
        s = new_mip(backend)
        y = [s.BoolVar(f"s{i}") for i in range(len(SETS))]
        for e in UNIVERSE:
            s.Add(sum(y[i] for i, S in enumerate(SETS) if e in S) >= 1)
        s.Minimize(sum(c * v for c, v in zip(COSTS, y, strict=True)))
        results.append(solve_mip(s, variables=y))
    for res in results:
        assert res.status is Status.OPTIMAL, res
        assert res.objective == pytest.approx(best)
        assert res.objective >= res.bound - 1e-6  # minimisation: objective >= bound


# ----------------------------------------------------------------------------- infeasible
def test_infeasible_cpsat():
    m = cp_model.CpModel()
    a, b = m.new_bool_var("a"), m.new_bool_var("b")
    m.add(a + b >= 3)
    m.maximize(a)
    res = solve_cpsat(m, variables=[a, b], workers=1)
    assert res.status is Status.INFEASIBLE
    assert res.x is None and res.objective is None and not res.has_solution


@pytest.mark.parametrize("backend", MIP_BACKENDS)
def test_infeasible_mip(backend):
    s = new_mip(backend)
    x = s.IntVar(0, 10, "x")
    s.Add(x >= 2)
    s.Add(x <= 1)
    s.Maximize(x)
    res = solve_mip(s, variables=[x])
    assert res.status is Status.INFEASIBLE
    assert res.x is None and res.objective is None


def test_infeasible_qp():
    qp = OsqpSolver(sp.eye(1), [0.0], sp.csc_matrix([[1.0], [1.0]]), [2.0, -np.inf], [np.inf, 1.0])
    res = qp.solve()
    assert res.status is Status.INFEASIBLE and res.x is None


def test_infeasible_nlp():
    x = ca.SX.sym("x", 2)
    nlp = IpoptSolver({"x": x, "f": ca.sumsqr(x), "g": ca.sumsqr(x)})
    res = nlp.solve(x0=[2.5, 0.0], lbx=[2.0, -10.0], ubx=[10.0, 10.0], lbg=-np.inf, ubg=1.0)
    assert res.status in (Status.INFEASIBLE, Status.NO_SOLUTION)
    assert res.x is None and not res.has_solution


# ----------------------------------------------------------------------------- time limit
def _market_split(seed: int = 0, m: int = 5, n: int = 40):
    """Cornuejols-Dawande market split: minimise total slack; hard for branch and bound."""
    rng = np.random.default_rng(seed)
    a = rng.integers(0, 100, (m, n))
    return a, a.sum(axis=1) // 2


def test_time_limit_cpsat_returns_feasible_or_nothing():
    a, b = _market_split()
    mdl = cp_model.CpModel()
    x = [mdl.new_bool_var(f"x{j}") for j in range(a.shape[1])]
    slack = []
    for i in range(a.shape[0]):
        sp_, sm = mdl.new_int_var(0, 10_000, ""), mdl.new_int_var(0, 10_000, "")
        mdl.add(sum(int(a[i, j]) * x[j] for j in range(a.shape[1])) + sp_ - sm == int(b[i]))
        slack += [sp_, sm]
    mdl.minimize(sum(slack))
    res = solve_cpsat(mdl, variables=x, time_limit=0.2, workers=1)
    assert res.status in (Status.FEASIBLE, Status.NO_SOLUTION)
    if res.has_solution:
        assert res.objective >= res.bound
        # the slack pair need not be tight at an incumbent: |deviation| <= slack sum
        assert np.abs(a @ res.x - b).sum() <= res.objective + 1e-9


@pytest.mark.parametrize("backend", MIP_BACKENDS)
def test_time_limit_mip_returns_feasible_or_nothing(backend):
    a, b = _market_split()
    s = new_mip(backend)
    x = [s.BoolVar(f"x{j}") for j in range(a.shape[1])]
    slack = []
    for i in range(a.shape[0]):
        sp_, sm = s.NumVar(0, 1e4, ""), s.NumVar(0, 1e4, "")
        s.Add(sum(int(a[i, j]) * x[j] for j in range(a.shape[1])) + sp_ - sm == int(b[i]))
        slack += [sp_, sm]
    s.Minimize(sum(slack))
    res = solve_mip(s, variables=x, time_limit=0.2)
    assert res.status in (Status.FEASIBLE, Status.NO_SOLUTION)
    if res.has_solution:
        assert res.objective >= res.bound - 1e-6
        assert np.abs(a @ np.round(res.x) - b).sum() <= res.objective + 1e-6


def test_iteration_limit_osqp_no_solution():
    qp = OsqpSolver(*_qp_data(), settings={"max_iter": 1, "eps_abs": 1e-12, "eps_rel": 1e-12})
    res = qp.solve()
    assert res.status is Status.NO_SOLUTION and res.x is None


def test_iteration_limit_ipopt():
    x = ca.SX.sym("x", 2)
    rosen = (1 - x[0]) ** 2 + 100 * (x[1] - x[0] ** 2) ** 2
    res = IpoptSolver({"x": x, "f": rosen}, options={"max_iter": 2}).solve(x0=[-1.2, 1.0])
    assert res.backend_status == "Maximum_Iterations_Exceeded"
    assert res.status is Status.FEASIBLE  # unconstrained: every point is feasible
    assert not res.info["local_optimum"] and not res.converged  # stopped at a limit
    assert res.objective > 1e-3  # not yet at the optimum


# ----------------------------------------------------------------------------- QP
# min 1/2 x'Px + q'x, P=[[4,1],[1,2]], q=[1,1], x1+x2=1, 0<=x<=0.7.
# KKT: with x2=0.7 at its bound, x1=0.3; objective 1.88.
def _qp_data():
    P = sp.csc_matrix([[4.0, 1.0], [1.0, 2.0]])
    A = sp.csc_matrix([[1.0, 1.0], [1.0, 0.0], [0.0, 1.0]])
    return P, np.array([1.0, 1.0]), A, np.array([1.0, 0.0, 0.0]), np.array([1.0, 0.7, 0.7])


def test_qp_known_optimum_osqp_and_warm_start():
    qp = OsqpSolver(*_qp_data())
    cold = qp.solve()
    assert cold.status is Status.OPTIMAL
    np.testing.assert_allclose(cold.x, [0.3, 0.7], atol=1e-5)
    assert cold.objective == pytest.approx(1.88, abs=1e-5)
    assert not cold.warm_started
    warm = qp.solve(warm_start=cold)
    assert warm.warm_started and warm.status is Status.OPTIMAL
    assert warm.objective == pytest.approx(cold.objective, abs=1e-6)
    assert warm.iterations <= cold.iterations


def test_qp_update_changes_optimum():
    qp = OsqpSolver(*_qp_data())
    qp.update(u=[1.0, 1.0, 1.0])  # x2 bound relaxed: unconstrained along x1+x2=1
    res = qp.solve()
    # stationarity: 4x1 + x2 + 1 = x1 + 2x2 + 1  with x1 + x2 = 1  ->  x1 = 0.25
    np.testing.assert_allclose(res.x, [0.25, 0.75], atol=1e-5)


def test_qp_same_optimum_through_ipopt():
    x = ca.SX.sym("x", 2)
    P, q, A, l, u = _qp_data()
    f = 0.5 * ca.mtimes([x.T, ca.DM(P.toarray()), x]) + ca.dot(ca.DM(q), x)
    res = IpoptSolver({"x": x, "f": f, "g": ca.mtimes(ca.DM(A.toarray()), x)}).solve(
        x0=[0.5, 0.5], lbg=l, ubg=u
    )
    # IPOPT proves no optimality, even on a convex QP: a converged solve is a local optimum
    assert res.status is Status.FEASIBLE and res.info["local_optimum"] and res.converged
    assert res.objective == pytest.approx(1.88, abs=1e-6)


# ----------------------------------------------------------------------------- NLP
# min (x-1)^2 + (y-2)^2 s.t. x + y <= 1: KKT point (0, 1), f = 2, multiplier 2.
def _nlp():
    x = ca.SX.sym("x", 2)
    return IpoptSolver({"x": x, "f": (x[0] - 1) ** 2 + (x[1] - 2) ** 2, "g": x[0] + x[1]})


def test_nlp_known_kkt_point():
    res = _nlp().solve(x0=[0.0, 0.0], ubg=1.0)
    assert res.status is Status.FEASIBLE and res.info["local_optimum"] and res.bound is None
    np.testing.assert_allclose(res.x, [0.0, 1.0], atol=1e-6)
    assert res.objective == pytest.approx(2.0, abs=1e-7)
    np.testing.assert_allclose(res.info["lam_g"], [2.0], atol=1e-6)
    assert res.iterations > 0


def test_nlp_dual_warm_start_used_and_optimum_unchanged():
    solver = _nlp()
    cold = solver.solve(x0=[5.0, -3.0], ubg=1.0)
    warm = solver.solve(ubg=1.0, warm_start=cold)
    assert warm.warm_started and not cold.warm_started
    assert warm.status is Status.FEASIBLE and warm.info["local_optimum"]
    np.testing.assert_allclose(warm.x, cold.x, atol=1e-6)
    assert warm.iterations <= cold.iterations


def test_nlp_parametric():
    x, p = ca.SX.sym("x"), ca.SX.sym("p")
    solver = IpoptSolver({"x": x, "f": (x - p) ** 2, "p": p})
    for target in (-3.0, 0.5, 7.0):
        assert solver.solve(x0=0.0, p=target).x[0] == pytest.approx(target, abs=1e-7)


# ----------------------------------------------------------------------------- misuse raises
def test_bad_input_raises():
    with pytest.raises(ValueError, match="unknown MIP backend"):
        new_mip("gurobi")
    s, x = _knapsack_mip("scip")
    with pytest.raises(ValueError, match="time_limit"):
        solve_mip(s, variables=x, time_limit=-1)
    m, y = _knapsack_cpsat()
    with pytest.raises(ValueError, match="time_limit"):
        solve_cpsat(m, variables=y, time_limit=0)
    with pytest.raises(TypeError):
        solve_cpsat("not a model")
    with pytest.raises(ValueError, match="workers"):
        solve_cpsat(m, workers=0)
    qp = OsqpSolver(*_qp_data())
    with pytest.raises(ValueError, match="warm_start x has 3 entries"):
        qp.solve(warm_start=(np.zeros(3), None))
    P, q, A, _, u = _qp_data()
    with pytest.raises(ValueError, match="l must be <= u"):
        OsqpSolver(P, q, A, u + 1, u)
    with pytest.raises(ValueError, match="x0 has 3 entries"):
        _nlp().solve(x0=[0, 0, 0])
    with pytest.raises(ValueError, match="unknown keys"):
        _nlp_bad = IpoptSolver({"x": ca.SX.sym("x"), "f": 0, "h": 1})
    with pytest.raises(TypeError, match="warm_start"):
        _nlp().solve(x0=[0, 0], warm_start=(1, 2))


def test_solveresult_contract():
    with pytest.raises(TypeError):
        SolveResult("optimal")
    r = SolveResult(Status.FEASIBLE, objective=90.0, bound=100.0)
    assert r.gap == pytest.approx(10 / 90)
    assert SolveResult(Status.OPTIMAL, objective=0.0, bound=0.0).gap == 0.0
    assert SolveResult(Status.ERROR).gap is None and not SolveResult(Status.ERROR).has_solution
