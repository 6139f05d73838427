"""The MIP backends driven through their own Python interface: SCIP through pyscipopt ("pyscipopt")
and Gurobi through gurobipy ("gurobi"). Each solves the LinearModel of the other backends to the
same optimum as HiGHS, CP-SAT and brute force; OPTIMAL comes with a closed gap, a stop at a limit
with a solution is FEASIBLE with a valid dual bound, an infeasible model is INFEASIBLE, and a
model beyond Gurobi's size-limited licence is an ERROR result that says so (then the Gurobi
tests that need a solve are skipped with that reason)."""

from __future__ import annotations

import itertools
import subprocess
import sys

import numpy as np
import pytest

from droneplan.solvers import Status, available_backends, get_backend
from droneplan.solvers.gurobi import STATUS_MAP as GUROBI_STATUS_MAP
from droneplan.solvers.gurobi import STATUS_NAMES as GUROBI_STATUS_NAMES
from droneplan.solvers.gurobi import GurobiAdapter
from droneplan.solvers.native_mip import MipRun, check_solve_settings, mip_readout
from droneplan.solvers.registry import unavailable_backends
from droneplan.solvers.scip import STATUS_MAP as SCIP_STATUS_MAP

NATIVE = ["pyscipopt", "gurobi"]
REFERENCE = ["highs", "cp-sat"]

VALUES = [10, 13, 7, 8, 11, 4, 9]
WEIGHTS = [5, 7, 3, 4, 6, 2, 5]
CAPACITY = 15
CONFLICTS = [(0, 1), (2, 4)]  # at most one of each pair


def _native(backend: str):
    """The backend's adapter, or a skip naming why it cannot run here."""
    if backend not in available_backends("linear"):
        pytest.skip(f"{backend}: {unavailable_backends('linear').get(backend, 'not registered')}")
    return get_backend(backend, kind="linear")


def _solved(result):
    """``result``, or a skip when Gurobi's size-limited licence refused the model."""
    if result.status is Status.ERROR and "size-limited" in result.message:
        pytest.skip(f"{result.backend}: the licence refused the model: {result.message}")
    return result


def _knapsack(backend: str):
    """The knapsack with conflicts on ``backend``: (model, item variables)."""
    lin = get_backend(backend, kind="linear").new_model()
    x = [lin.bool_var(f"item{i}") for i in range(len(VALUES))]
    lin.add(lin.sum(w * v for w, v in zip(WEIGHTS, x, strict=True)) <= CAPACITY)
    for i, j in CONFLICTS:
        lin.add_at_most_one([x[i], x[j]])
    lin.maximize(lin.sum(c * v for c, v in zip(VALUES, x, strict=True)))
    return lin, x


def _knapsack_brute_force() -> int:
    best = 0
    for pick in itertools.product((0, 1), repeat=len(VALUES)):
        fits = np.dot(WEIGHTS, pick) <= CAPACITY and all(pick[i] + pick[j] <= 1 for i, j in CONFLICTS)
        if fits:
            best = max(best, int(np.dot(VALUES, pick)))
    return best


@pytest.mark.parametrize("backend", NATIVE)
def test_knapsack_optimum_equals_brute_force_highs_and_cpsat(backend):
    _native(backend)
    lin, x = _knapsack(backend)
    res = _solved(lin.solve(variables=x, time_limit=60, workers=1))
    best = _knapsack_brute_force()
    assert res.status is Status.OPTIMAL and res.backend == backend
    assert res.objective == pytest.approx(best) and res.bound == pytest.approx(best)
    pick = np.round(res.x).astype(int)
    assert np.dot(WEIGHTS, pick) <= CAPACITY and np.dot(VALUES, pick) == best
    for other in REFERENCE:
        ref_model, ref_x = _knapsack(other)
        assert ref_model.solve(variables=ref_x, time_limit=60).objective == pytest.approx(res.objective)


@pytest.mark.parametrize("backend", NATIVE)
def test_stop_at_first_solution_is_feasible_with_a_valid_bound(backend):
    """A solution limit of one stops the search at a limit: FEASIBLE, never OPTIMAL, and the dual
    bound is an upper bound of the true optimum (a maximisation)."""
    _native(backend)
    lin, x = _knapsack(backend)
    first = {"pyscipopt": {"limits/solutions": 1}, "gurobi": {"SolutionLimit": 1}}[backend]
    res = _solved(lin.solve(variables=x, options=first))
    assert res.status is Status.FEASIBLE and "not proven optimal" in res.message
    assert res.objective <= _knapsack_brute_force()
    assert res.bound is None or res.bound >= _knapsack_brute_force() - 1e-9  # None: stopped before an LP


@pytest.mark.parametrize("backend", NATIVE)
def test_stop_at_a_relative_gap_keeps_a_valid_bound(backend):
    """Allowed a relative gap of one half, the backend may stop with a gap open: then FEASIBLE;
    OPTIMAL only with the gap closed; the bound is finite and valid either way."""
    _native(backend)
    lin, x = _knapsack(backend)
    res = _solved(lin.solve(variables=x, options={"relative_gap": 0.5}))
    best = _knapsack_brute_force()
    assert res.has_solution and res.objective <= best <= res.bound + 1e-9
    assert (res.status is Status.OPTIMAL) is (res.bound == pytest.approx(res.objective))


@pytest.mark.parametrize("backend", NATIVE)
def test_infeasible_and_changed_after_a_solve(backend):
    """The model is solved, changed, solved again: a row that no point meets makes it INFEASIBLE."""
    _native(backend)
    lin, x = _knapsack(backend)
    assert _solved(lin.solve(variables=x)).status is Status.OPTIMAL
    lin.add(lin.sum(x) >= len(x))  # every item: far over the capacity
    res = _solved(lin.solve(variables=x))
    assert res.status is Status.INFEASIBLE and res.objective is None and res.x is None


@pytest.mark.parametrize("backend", NATIVE)
def test_hint_reaches_the_solver_and_integers_and_unit_variables(backend):
    _native(backend)
    lin = get_backend(backend, kind="linear").new_model()
    x = [lin.bool_var(f"x{i}") for i in range(4)]
    k = lin.int_var(0, 3, "k")
    y = lin.unit_var("y")
    lin.add(y <= x[0] + x[1])
    lin.add(lin.sum(x) + k <= 4)
    lin.maximize(y + 2 * x[2] + x[3] + 0.5 * k)  # optimum 4.5: y = 1 (x0), x2, x3, k = 1
    res = _solved(lin.solve(variables=[*x, k], hint={x[0]: 1, x[2]: 1}, workers=2))
    assert lin.takes_hint and res.warm_started
    assert res.status is Status.OPTIMAL and res.objective == pytest.approx(4.5)
    assert res.x[2] == pytest.approx(1.0) and res.x[3] == pytest.approx(1.0)


@pytest.mark.parametrize("backend", NATIVE)
def test_settings_reach_the_solver_and_bad_ones_are_refused(backend):
    _native(backend)
    lin, x = _knapsack(backend)
    _solved(lin.solve(variables=x, time_limit=30.0, workers=1))
    if backend == "gurobi":
        assert lin.native.Params.TimeLimit == 30.0 and lin.native.Params.Threads == 1
        assert lin.native.Params.MIPGap == 0.0  # Gurobi's default 1e-4 would not be a proof
    else:
        assert lin.native.getParam("limits/time") == 30.0 and lin.native.getParam("limits/gap") == 0.0
    with pytest.raises(ValueError, match="time_limit"):
        lin.solve(variables=x, time_limit=-1)
    with pytest.raises(ValueError, match="workers"):
        lin.solve(variables=x, workers=0)
    with pytest.raises(ValueError, match="relative_gap"):
        lin.solve(variables=x, options={"relative_gap": 2})
    with pytest.raises(ValueError, match="no_such_parameter"):
        lin.solve(variables=x, options={"no_such_parameter": 1})


@pytest.mark.parametrize("backend", NATIVE)
def test_written_model_has_the_same_optimum_in_highs(tmp_path, backend):
    import highspy

    _native(backend)
    lin, _ = _knapsack(backend)
    for suffix in (".mps", ".lp"):
        path = lin.write(tmp_path / f"knapsack{suffix}")
        assert path == tmp_path / f"knapsack{suffix}"
        h = highspy.Highs()
        h.silent()
        assert h.readModel(str(path)) == highspy.HighsStatus.kOk
        h.run()
        assert h.getModelStatus() == highspy.HighsModelStatus.kOptimal
        assert h.getInfo().objective_function_value == pytest.approx(_knapsack_brute_force())
    assert sorted(p.name for p in tmp_path.iterdir()) == ["knapsack.lp", "knapsack.mps"]  # no temporary left


@pytest.mark.parametrize("backend", NATIVE)
def test_droneplans_mps_file_reads_into_the_backend_with_the_same_optimum(tmp_path, backend):
    """A model that droneplan writes (here the HiGHS backend's knapsack) is read by the backend's
    own reader and solved to the same optimum."""
    adapter = _native(backend)
    lin, _ = _knapsack("highs")
    read = adapter.read_model(lin.write(tmp_path / "knapsack.mps"))
    res = _solved(read.solve(variables=read.native.getVars()))
    assert res.status is Status.OPTIMAL and res.objective == pytest.approx(_knapsack_brute_force())
    with pytest.raises(ValueError, match="path"):
        adapter.read_model(tmp_path / "missing.mps")


def test_gurobi_model_beyond_the_licence_is_an_error_result_not_a_crash():
    """The pip wheel's licence refuses a model of 2,100 variables: an ERROR result naming the
    licence (with a full licence the same model solves to its optimum, 3)."""
    _native("gurobi")
    lin = get_backend("gurobi", kind="linear").new_model()
    x = [lin.bool_var() for _ in range(2100)]
    lin.add(lin.sum(x) <= 3)
    lin.maximize(lin.sum(x))
    res = lin.solve(variables=x[:2])
    if res.status is Status.ERROR:
        assert "size-limited" in res.message and "licence" in res.message and res.x is None
    else:
        assert res.status is Status.OPTIMAL and res.objective == pytest.approx(3.0)


def test_status_codes_written_as_numbers_are_gurobis_own():
    gurobipy = pytest.importorskip("gurobipy")
    names = {getattr(gurobipy.GRB.Status, name): name for name in dir(gurobipy.GRB.Status) if name.isupper()}
    assert names == GUROBI_STATUS_NAMES
    assert GUROBI_STATUS_MAP[gurobipy.GRB.OPTIMAL] is Status.OPTIMAL
    assert GUROBI_STATUS_MAP[gurobipy.GRB.TIME_LIMIT] is Status.NO_SOLUTION  # FEASIBLE with a solution
    assert gurobipy.GRB.NUMERIC not in GUROBI_STATUS_MAP  # a numerical failure is an ERROR


def test_scip_maps_only_optimal_to_optimal_and_unknown_to_error():
    assert [code for code, status in SCIP_STATUS_MAP.items() if status is Status.OPTIMAL] == ["optimal"]
    assert "unknown" not in SCIP_STATUS_MAP and SCIP_STATUS_MAP["timelimit"] is Status.NO_SOLUTION


@pytest.mark.parametrize(
    ("code", "status", "count", "bound", "expected"),
    [
        ("optimal", Status.OPTIMAL, 1, 5.0, Status.OPTIMAL),
        ("optimal", Status.OPTIMAL, 1, 5.5, Status.FEASIBLE),  # a gap left open is no proof
        ("timelimit", Status.NO_SOLUTION, 1, 7.0, Status.FEASIBLE),
        ("timelimit", Status.NO_SOLUTION, 0, 7.0, Status.NO_SOLUTION),
        ("optimal", Status.OPTIMAL, 0, 5.0, Status.ERROR),  # optimal but no solution held
    ],
)
def test_readout_rules(code, status, count, bound, expected):
    run = MipRun(
        code_name=code,
        solution_count=count,
        objective=lambda: 5.0,
        values=lambda vs: np.ones(len(vs)),
        dual_bound=bound,
        nodes=3,
    )
    out = mip_readout(run, status, ["a", "b"], "test-backend")
    assert out.status is expected
    assert (out.objective == 5.0) is expected.has_solution
    assert out.bound == bound and (out.message == "") is (expected is Status.OPTIMAL)


def test_infinite_dual_bound_is_no_bound():
    run = MipRun("timelimit", 0, lambda: 0.0, lambda vs: np.zeros(0), 1e20, None)
    assert mip_readout(run, Status.NO_SOLUTION, [], "test-backend").bound is None


def test_solve_settings_split_the_gap_from_the_backend_options():
    assert check_solve_settings(5.0, 2, {"relative_gap": 0.1, "Presolve": 0}) == (0.1, {"Presolve": 0})
    with pytest.raises(TypeError, match="options"):
        check_solve_settings(None, None, ["relative_gap"])


def test_a_backend_whose_package_is_missing_is_omitted_with_the_reason(monkeypatch):
    monkeypatch.setattr(GurobiAdapter, "requires", ("droneplan_no_such_gurobi_package",))
    assert "gurobi" not in available_backends("linear")
    reason = unavailable_backends("linear")["gurobi"]
    assert "droneplan_no_such_gurobi_package" in reason and 'pip install "droneplan[gurobi]"' in reason
    with pytest.raises(ValueError, match=r"not available in this installation \(needs the Python package"):
        get_backend("gurobi", kind="linear")


def test_listed_when_installed_and_listing_loads_no_solver_library():
    code = (
        "import sys\n"
        "from droneplan.solvers import available_backends\n"
        "print(sorted(set(available_backends('linear')) & {'gurobi', 'pyscipopt'}))\n"
        "print(sorted(m for m in ('gurobipy', 'pyscipopt') if m in sys.modules))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    installed = sorted(name for name in NATIVE if name not in unavailable_backends())
    assert out.stdout.split("\n")[:2] == [str(installed), "[]"]


def test_solves_print_nothing_in_a_fresh_process():
    """Gurobi's licence banner and SCIP's log come once per process: a fresh interpreter that
    solves on both prints nothing."""
    code = (
        "from droneplan.solvers import available_backends, get_backend\n"
        "for name in set(available_backends('linear')) & {'gurobi', 'pyscipopt'}:\n"
        "    lin = get_backend(name, kind='linear').new_model()\n"
        "    x = [lin.bool_var(f'x{i}') for i in range(3)]\n"
        "    lin.add(lin.sum(x) <= 2)\n"
        "    lin.maximize(3 * x[0] + 2 * x[1] + x[2])\n"
        "    assert lin.solve(variables=x).objective == 5.0, name\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=False)
    assert out.returncode == 0, out.stderr
    assert out.stdout == ""


@pytest.mark.parametrize("backend", NATIVE)
def test_on_solution_gets_the_final_solution_and_its_errors_propagate(backend):
    _native(backend)
    lin, x = _knapsack(backend)
    seen = []
    res = _solved(lin.solve(variables=x, on_solution=lambda *s: seen.append(s)))
    assert len(seen) == 1 and seen[0][1] == res.objective == _knapsack_brute_force()
    np.testing.assert_array_equal(seen[0][0], res.x)

    def refuse(*_solution):
        raise RuntimeError("stop here")

    with pytest.raises(RuntimeError, match="stop here"):
        lin.solve(variables=x, on_solution=refuse)


@pytest.mark.parametrize("backend", NATIVE)
def test_verbose_reaches_stdout(backend, capfd):
    """The counterpart of the quiet default: with verbose=True the solver's log is printed."""
    _native(backend)
    lin, x = _knapsack(backend)
    _solved(lin.solve(variables=x, verbose=True))
    out, _ = capfd.readouterr()
    assert out.strip()
    _solved(lin.solve(variables=x))
    out, _ = capfd.readouterr()
    assert out == ""
