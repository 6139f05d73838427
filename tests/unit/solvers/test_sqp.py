"""SQP over OSQP (solvers.sqp) on small NLPs with known optima, also reached through the registry."""

from __future__ import annotations

import math

import casadi as ca
import numpy as np
import pytest

from droneplan.solvers import Status, get_backend
from droneplan.solvers.sqp import SqpSolver, SqpStructure

OSQP = get_backend("osqp", kind="qp")


def _nlp(constraint: str):
    x = ca.SX.sym("x", 2)
    p = ca.SX.sym("p", 2)
    f = (x[0] - p[0]) ** 2 + (x[1] - p[1]) ** 2
    g = x[0] + x[1] if constraint == "linear" else x[0] ** 2 + x[1] ** 2
    return {"x": x, "f": f, "g": g, "p": p}


def test_one_step_solves_a_linearly_constrained_qp_exactly():
    # min |x - (1, 2)|^2 s.t. x0 + x1 <= 2  ->  (0.5, 1.5), f = 0.5
    solver = get_backend("osqp", kind="nlp").create_nlp(
        _nlp("linear"), options={"qp_settings": {"eps_abs": 1e-9, "eps_rel": 1e-9}}
    )
    res = solver.solve(x0=[5.0, -3.0], lbg=-np.inf, ubg=2.0, p=[1.0, 2.0])
    assert res.status is Status.FEASIBLE and res.backend == "osqp-sqp"
    np.testing.assert_allclose(res.x, [0.5, 1.5], atol=1e-6)
    assert res.objective == pytest.approx(0.5, abs=1e-6)
    assert res.info["violation"] < 1e-6


def test_iterations_converge_on_a_curved_constraint():
    # min |x - (2, 2)|^2 s.t. |x|^2 <= 1  ->  (1, 1)/sqrt 2, the same point IPOPT finds
    nlp = _nlp("circle")
    sqp = get_backend("osqp", kind="nlp").create_nlp(
        nlp,
        options={"iterations": 100, "qp_settings": {"eps_abs": 1e-9, "eps_rel": 1e-9}},
        structure=SqpStructure(prox=[1.0, 1.0]),
    )
    res = sqp.solve(x0=[1.0, 0.0], lbg=-np.inf, ubg=1.0, p=[2.0, 2.0])
    ref = (
        get_backend("ipopt", kind="nlp")
        .create_nlp(nlp)
        .solve(x0=[1.0, 0.0], lbg=-np.inf, ubg=1.0, p=[2.0, 2.0])
    )
    assert ref.status is Status.FEASIBLE and ref.info["local_optimum"]
    assert res.status is Status.FEASIBLE and res.info["local_optimum"] and res.converged
    np.testing.assert_allclose(res.x, [1 / math.sqrt(2)] * 2, atol=1e-5)
    np.testing.assert_allclose(res.x, ref.x, atol=1e-5)
    assert res.info["violation"] < 1e-6


def test_projection_is_applied_after_every_step():
    seen = []

    def project(z):
        seen.append(np.array(z))
        return np.clip(z, -0.25, 0.25)

    solver = SqpSolver(_nlp("linear"), iterations=3, qp_backend=OSQP)
    res = solver.solve(x0=[3.0, 3.0], lbg=-np.inf, ubg=2.0, p=[1.0, 2.0], project=project)
    assert len(seen) == 4  # x0 and three steps
    np.testing.assert_allclose(res.x, [0.25, 0.25])


def test_soft_rows_keep_an_inconsistent_linearisation_solvable():
    # x0 + x1 = 3 and x0 + x1 = 1 cannot both hold; made soft, the QP splits the difference
    x = ca.SX.sym("x", 2)
    nlp = {"x": x, "f": 0.5 * ca.dot(x, x), "g": ca.vertcat(x[0] + x[1], x[0] + x[1])}
    hard = SqpSolver(nlp, qp_backend=OSQP).solve(x0=[0, 0], lbg=[3, 1], ubg=[3, 1])
    assert not hard.has_solution
    soft = SqpSolver(nlp, structure=SqpStructure(soft_rows=[0, 1], soft_weight=1e3), qp_backend=OSQP).solve(
        x0=[0, 0], lbg=[3, 1], ubg=[3, 1]
    )
    assert soft.status is Status.FEASIBLE
    assert soft.x.sum() == pytest.approx(2.0, abs=1e-2)
    assert soft.info["violation"] == pytest.approx(1.0, abs=1e-2)


def test_bad_input():
    x = ca.SX.sym("x")
    with pytest.raises(ValueError, match="quadratic"):
        SqpSolver({"x": x, "f": x**4}, qp_backend=OSQP)
    with pytest.raises(ValueError, match="iterations"):
        SqpSolver(_nlp("linear"), iterations=0, qp_backend=OSQP)
    with pytest.raises(ValueError, match="soft_rows"):
        SqpSolver(_nlp("linear"), structure=SqpStructure(soft_rows=[3]), qp_backend=OSQP)
    with pytest.raises(ValueError, match="pass p"):
        SqpSolver(_nlp("linear"), qp_backend=OSQP).solve(x0=[0, 0])
    with pytest.raises(ValueError, match="unknown osqp NLP options"):
        get_backend("osqp", kind="nlp").create_nlp(_nlp("linear"), options={"max_iter": 3})
