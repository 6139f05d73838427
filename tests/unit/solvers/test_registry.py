"""The backend registry and the adapter shape: one adapter per backend, found by name."""

from __future__ import annotations

import re
from typing import ClassVar

import numpy as np
import pytest

from droneplan.solvers import (
    BackendAdapter,
    NativeReadout,
    SolveResult,
    Status,
    available_backends,
    get_backend,
    register_backend,
    registered_backends,
    run_native,
    unregister_backend,
)
from droneplan.solvers.base import KINDS, LinearBackend, QpBackend

OPTIONAL_LINEAR = {"gurobi", "pyscipopt"}
"""The linear backends of the optional extras ``gurobi`` and ``scip``."""


def test_unknown_name_lists_the_known_ones():
    with pytest.raises(ValueError, match="unknown backend 'no-such-solver'") as err:
        get_backend("no-such-solver")
    for name in registered_backends():
        assert repr(name) in str(err.value)
    with pytest.raises(ValueError, match=re.escape(f"known linear backends: {available_backends('linear')}")):
        get_backend("no-such-solver", kind="linear")


def test_missing_capability_and_bad_kind():
    with pytest.raises(ValueError, match="does not offer 'linear'"):
        get_backend("ipopt", kind="linear")
    with pytest.raises(ValueError, match="kind must be one of"):
        available_backends("milp")
    with pytest.raises(TypeError):
        get_backend(3)


def test_builtin_kinds():
    core_linear = ["cp-sat", "highs", "scip"]  # the optional extras add "gurobi", "pyscipopt"
    assert [b for b in available_backends("linear") if b in core_linear] == core_linear
    assert set(available_backends("linear")) - set(core_linear) <= OPTIONAL_LINEAR
    assert available_backends("cp") == ["cp-sat"]
    assert "ipopt" in available_backends("nlp")
    assert available_backends("qp") == ["osqp"]
    assert available_backends("nlp") == ["ipopt", "osqp"]
    for name in available_backends():
        adapter = get_backend(name)
        assert adapter.name == name
        assert adapter.kinds and adapter.kinds <= set(KINDS)


@pytest.mark.parametrize("name", available_backends())
def test_every_adapter_maps_an_unknown_code_to_error(name):
    adapter = get_backend(name)
    assert adapter.map_status("surely not a native status code") is Status.ERROR
    assert adapter.map_status(123456789) is Status.ERROR
    assert adapter.map_status([1, 2]) is Status.ERROR  # unhashable
    # and every listed code maps to a Status
    assert all(isinstance(s, Status) for s in adapter.status_map.values())


class _DiagonalQp:
    """min 1/2 x'Px + q'x for diagonal P > 0, constraints ignored: x = -q / diag(P)."""

    def __init__(self, adapter, P, q):
        self.adapter, self.d, self.q = adapter, np.diag(np.asarray(P, float)), np.asarray(q, float)

    def solve(self, *, warm_start=None) -> SolveResult:
        def call():
            return ("done" if np.all(self.d > 0) else "nonconvex"), -self.q / self.d

        def read(code, x, status, elapsed):
            obj = float(0.5 * x @ (self.d * x) + self.q @ x)
            return NativeReadout(objective=obj, x=x) if status.has_solution else NativeReadout()

        return run_native(self.adapter, call, read)


class ToyQpAdapter(BackendAdapter, QpBackend):
    name = "toy-qp"
    status_map: ClassVar[dict[str, Status]] = {"done": Status.OPTIMAL, "nonconvex": Status.ERROR}

    def create_qp(self, P, q, A, l, u, *, settings=None, time_limit=None, verbose=False):
        return _DiagonalQp(self, P, q)


@pytest.fixture
def toy():
    register_backend("toy-qp", ToyQpAdapter())
    yield
    unregister_backend("toy-qp")


def test_registered_toy_adapter_is_found_and_used(toy):
    assert "toy-qp" in available_backends("qp")
    adapter = get_backend("toy-qp", kind="qp")
    res = adapter.create_qp(np.diag([2.0, 4.0]), [-2.0, 4.0], np.zeros((0, 2)), [], []).solve()
    assert res.status is Status.OPTIMAL and res.backend == "toy-qp" and res.backend_status == "done"
    np.testing.assert_allclose(res.x, [1.0, -1.0])
    assert res.objective == pytest.approx(-3.0)
    assert res.solve_time >= 0
    bad = adapter.create_qp(np.diag([-1.0, 1.0]), [0.0, 0.0], np.zeros((0, 2)), [], []).solve()
    assert bad.status is Status.ERROR and bad.x is None
    with pytest.raises(ValueError, match="already registered"):
        register_backend("toy-qp", ToyQpAdapter())
    with pytest.raises(ValueError, match="already registered"):
        register_backend("osqp", type("X", (ToyQpAdapter,), {"name": "osqp"})())


def test_register_checks_its_arguments():
    with pytest.raises(TypeError):
        register_backend("x", object())
    with pytest.raises(ValueError, match="registered as"):
        register_backend("other-name", ToyQpAdapter())
    with pytest.raises(ValueError, match="was not added"):
        unregister_backend("cp-sat")


def test_run_native_turns_an_exception_into_error():
    def call():
        raise RuntimeError("library crashed")

    res = run_native(ToyQpAdapter(), call, lambda *a: NativeReadout(), warm_started=True)
    assert res.status is Status.ERROR and "library crashed" in res.message
    assert res.backend_status == "exception" and res.warm_started and res.x is None


def test_builtin_table_is_one_table_of_classes():
    """The registry's one table maps each name to its adapter class; the class itself carries
    what the registry lists it by (its kinds and the packages it requires)."""
    from droneplan.solvers import registry

    table = registry._builtin()
    assert sorted(table) == registered_backends()
    for name, cls in table.items():
        assert issubclass(cls, BackendAdapter) and cls.name == name
        assert cls.kinds and cls.kinds <= set(KINDS), name
        assert cls.requires, name
        if name in OPTIONAL_LINEAR:  # an optional extra: installed, or its install command is known
            assert cls.install_hint.startswith("pip install"), name
            if name not in available_backends():
                continue
        assert cls.requires_installed(), name
        assert get_backend(name).kinds == cls.kinds, name
    assert table["cp-sat"].kinds == {"cp", "linear"}
    assert table["osqp"].kinds == {"nlp", "qp"}
    assert table["highs"].requires == ("ortools", "highspy")


def test_status_codes_written_as_numbers_are_the_libraries_own():
    """The adapter modules load without their library, so their status maps spell the native
    codes as numbers; they must be the library's constants."""
    from ortools.linear_solver import pywraplp
    from ortools.sat.python import cp_model

    from droneplan.solvers import cpsat, mip

    assert cpsat.STATUS_MAP == {
        cp_model.OPTIMAL: Status.OPTIMAL,
        cp_model.FEASIBLE: Status.FEASIBLE,
        cp_model.INFEASIBLE: Status.INFEASIBLE,
        cp_model.UNKNOWN: Status.NO_SOLUTION,
        cp_model.MODEL_INVALID: Status.ERROR,
    }
    assert get_backend("cp-sat").map_status(cp_model.OPTIMAL) is Status.OPTIMAL
    codes = {n: getattr(pywraplp.Solver, n) for n in mip._STATUS_NAME.values()}
    assert {code: name for name, code in codes.items()} == mip._STATUS_NAME
    assert mip.STATUS_MAP[pywraplp.Solver.OPTIMAL] is Status.OPTIMAL
    assert mip.STATUS_MAP[pywraplp.Solver.NOT_SOLVED] is Status.NO_SOLUTION
    assert mip.STATUS_MAP[pywraplp.Solver.ABNORMAL] is Status.ERROR


class _EchoModel:
    """A stand-in linear model: it only remembers which backend made it."""

    def __init__(self, backend: str) -> None:
        self.backend = backend


class FakeLinearAdapter(BackendAdapter, LinearBackend):
    """A backend added the documented way: one class (kinds from its mixins, its requirements,
    its library imported inside its methods) plus one registration."""

    name = "fake-linear"
    status_map: ClassVar[dict[str, Status]] = {"ok": Status.OPTIMAL}
    requires = ("numpy",)

    def new_model(self):
        import numpy  # noqa: F401 - the library loads in the method, as the built-in adapters do

        return _EchoModel(self.name)


class FakeMissingLibraryAdapter(FakeLinearAdapter):
    """The same backend on a library this installation does not have."""

    name = "fake-missing"
    requires = ("droneplan_no_such_solver_library",)


@pytest.fixture
def fake_backends():
    register_backend("fake-linear", FakeLinearAdapter())
    register_backend("fake-missing", FakeMissingLibraryAdapter())
    try:
        yield
    finally:
        unregister_backend("fake-linear")
        unregister_backend("fake-missing")


def test_a_fake_backend_is_one_class_plus_one_registration(fake_backends):
    assert FakeLinearAdapter.kinds == {"linear"}  # on the class, no instance needed
    assert "fake-linear" in available_backends("linear")
    assert "fake-linear" in available_backends()
    assert "fake-linear" not in available_backends("qp")
    model = get_backend("fake-linear", kind="linear").new_model()
    assert isinstance(model, _EchoModel) and model.backend == "fake-linear"
    with pytest.raises(ValueError, match="does not offer 'nlp'"):
        get_backend("fake-linear", kind="nlp")
    # a missing requirement keeps a registered backend out of the listings and the lookup
    assert "fake-missing" in registered_backends()
    assert "fake-missing" not in available_backends("linear")
    with pytest.raises(ValueError, match="not available in this installation"):
        get_backend("fake-missing", kind="linear")


def test_the_fake_backends_do_not_leak():
    """The fixture above unregisters them: no other test sees them."""
    assert not {"fake-linear", "fake-missing"} & set(registered_backends())


def test_listing_backends_imports_no_solver_library():
    """available_backends answers from the adapter classes: the adapter modules load (they are
    light), no solver library does."""
    import subprocess
    import sys

    code = (
        "import sys\n"
        "import droneplan.solvers\n"
        "print(sorted(m for m in sys.modules if m.startswith('droneplan.solvers.') and m.split('.')[-1]"
        " in ('cpsat', 'mip', 'nlp', 'qp')))\n"
        "from droneplan.solvers.registry import available_backends\n"
        "print(available_backends('linear'), available_backends())\n"
        "libraries = ('ortools', 'casadi', 'osqp', 'cvxpy', 'highspy', 'scipy', 'pyscipopt', 'gurobipy')\n"
        "print(sorted(m for m in libraries if m in sys.modules))\n"
        "print(sorted(m for m in sys.modules if m.startswith('droneplan.solvers.') and m.split('.')[-1]"
        " in ('cpsat', 'mip', 'nlp', 'qp')))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    before, listed, libraries, adapters = out.strip().splitlines()
    assert before == "[]"  # importing the package loads no adapter module
    extras = [name for name in ("gurobi", "pyscipopt") if name in available_backends()]  # optional
    linear = sorted(["cp-sat", "highs", "scip", *extras])
    assert listed == f"{linear} {sorted([*linear, 'ipopt', 'osqp'])}"
    assert libraries == "[]"
    assert adapters == str([f"droneplan.solvers.{m}" for m in ("cpsat", "mip", "nlp", "qp")])
