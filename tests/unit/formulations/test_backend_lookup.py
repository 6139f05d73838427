"""Formulations find their backends in the registry: a backend registered under a new name is
used without touching the formulation, and unknown or unsuitable names fail with the known ones."""

from __future__ import annotations

import numpy as np
import pytest

from droneplan.formulations.covert import RecedingBearingMPC, build_bearing_mpc
from droneplan.formulations.herding import solve_allocation
from droneplan.formulations.shark.assignment import solve_assignment
from droneplan.formulations.shark.ocp import InterceptionOCP
from droneplan.scenarios.covert import thesis_case
from droneplan.solvers import register_backend, unregister_backend
from droneplan.solvers.cpsat import CpSatAdapter


class RenamedCpSat(CpSatAdapter):
    name = "cp-sat-renamed"


@pytest.fixture
def renamed():
    register_backend("cp-sat-renamed", RenamedCpSat())
    yield "cp-sat-renamed"
    unregister_backend("cp-sat-renamed")


def test_a_new_cp_backend_is_used_by_shark_and_herding(renamed):
    cost = np.array([[3.0, 9.0], [4.0, 2.0], [8.0, 8.0]])
    ref = solve_assignment(cost)
    res = solve_assignment(cost, backend=renamed)
    assert res.backend == renamed and ref.backend == "cp-sat"
    assert res.objective == ref.objective == pytest.approx(3.0)
    d, s = [0.0, 10.0, 20.0], [5.0, 30.0, 60.0]
    a = solve_allocation(d, s, 100.0, engine="exact")
    b = solve_allocation(d, s, 100.0, engine=renamed)
    assert b.backend == renamed and b.objective == pytest.approx(a.objective)


def test_unknown_or_unsuitable_backends_are_refused():
    scen = thesis_case(1, 0)
    model = build_bearing_mpc(scen.params, scen.n_targets)
    with pytest.raises(ValueError, match=r"known nlp backends: \['ipopt', 'osqp'\]"):
        RecedingBearingMPC(model, backend="snopt")
    with pytest.raises(ValueError, match="does not offer 'nlp'"):
        RecedingBearingMPC(model, backend="cp-sat")
    with pytest.raises(ValueError, match="does not solve to a local optimum"):
        InterceptionOCP(N=10, backend="osqp")
    with pytest.raises(ValueError, match="known cp backends"):
        solve_assignment(np.ones((2, 2)), backend="no-such-solver")


def test_formulation_solves_print_nothing(capfd):
    """Silent solves end to end: the cells MILP on CP-SAT (whose relaxation bound runs on HiGHS,
    which printed its banner before), the covert MPC on both NLP backends, the shark OCP and
    assignment, the herding CP-SAT model: nothing reaches stdout."""
    from droneplan.formulations.cells import CellProblem, solve_milp
    from droneplan.formulations.covert import MPCData
    from droneplan.formulations.shark.ocp import solve_interception

    cells = CellProblem(
        users=np.array([[2.5, 0.0], [2.9, 0.3], [4.0, 1.0], [-3.0, 0.5]]),
        gbs=np.array([[0.0, 0.0]]),
        n_cells=2,
        R_d=1.0,
        R_g=1.0,
        r1=2.5,
        r2=2.5,
    )
    assert solve_milp(cells, backend="cp-sat", time_limit=20).has_solution
    scen = thesis_case(1, 0)
    model = build_bearing_mpc(scen.params, scen.n_targets)
    N = model.settings.horizon
    data = MPCData(
        D0=np.array([0.0, 0.0, 20.0]),
        h0=np.array([1.0, 0.0, 0.0]),
        targets=np.tile(scen.params.F_arr + np.array([5.0, 0.0, 0.0]), (N, scen.n_targets, 1)),
        mask=np.ones(scen.n_targets, bool),
        sphere_lo=np.zeros(N),
        sphere_hi=np.full(N, 1e4),
        home_hi=np.full(N, 1e4),
        tangent=np.zeros(N, bool),
    )
    for backend in ("ipopt", "osqp"):
        assert RecedingBearingMPC(model, backend=backend).solve(data).has_solution
    assert solve_interception(
        (np.array([0, 0, -3.0]), np.array([5.0, 0.0])), np.array([40.0, 0, 2.0]), N=20
    ).has_solution
    assert solve_assignment(np.array([[3.0, 9.0], [4.0, 2.0]])).has_solution
    assert solve_allocation([0.0, 10.0, 20.0], [5.0, 30.0, 60.0], 100.0, engine="cp-sat").has_solution
    out, _ = capfd.readouterr()
    assert out == ""
