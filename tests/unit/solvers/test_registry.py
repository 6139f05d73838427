"""The backend registry and the adapter shape: one adapter per backend, found by name."""

from __future__ import annotations

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
from droneplan.solvers.base import KINDS, QpBackend


def test_unknown_name_lists_the_known_ones():
    with pytest.raises(ValueError, match="unknown backend 'no-such-solver'") as err:
        get_backend("no-such-solver")
    for name in registered_backends():
        assert repr(name) in str(err.value)
    with pytest.raises(ValueError, match=r"known linear backends: \['cp-sat', 'highs', 'scip'\]"):
        get_backend("no-such-solver", kind="linear")


def test_missing_capability_and_bad_kind():
    with pytest.raises(ValueError, match="does not offer 'linear'"):
        get_backend("ipopt", kind="linear")
    with pytest.raises(ValueError, match="kind must be one of"):
        available_backends("milp")
    with pytest.raises(TypeError):
        get_backend(3)


def test_builtin_kinds():
    assert available_backends("linear") == ["cp-sat", "highs", "scip"]
    assert available_backends("cp") == ["cp-sat"]
    assert "ipopt" in available_backends("nlp")
    assert available_backends("qp") == ["osqp"]
    assert available_backends("nlp") == ["ipopt", "osqp"]
    for name in registered_backends():
        adapter = get_backend(name)
        assert adapter.name == name
        assert adapter.kinds and adapter.kinds <= set(KINDS)


@pytest.mark.parametrize("name", registered_backends())
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


def test_builtin_tables_match_the_adapters():
    """The registry lists built-in backends from its tables; each table entry is the adapter's own."""
    from droneplan.solvers import registry

    assert set(registry._BUILTIN_KINDS) == set(registry._BUILTIN) == set(registry._BUILTIN_REQUIRES)
    for name in registry._BUILTIN:
        adapter = get_backend(name)
        assert adapter.kinds == registry._BUILTIN_KINDS[name], name
        module = type(adapter).__module__
        assert registry._BUILTIN_REQUIRES[name] in _imported_by(module), name


def _imported_by(module: str) -> set[str]:
    import sys

    source = sys.modules[module]
    return {v.__name__.split(".")[0] for v in vars(source).values() if hasattr(v, "__name__")} | {
        getattr(v, "__module__", "").split(".")[0] for v in vars(source).values()
    }


def test_listing_backends_imports_no_solver_library():
    """available_backends answers from the registry's tables: no adapter and no solver library loads."""
    import subprocess
    import sys

    code = (
        "import sys\n"
        "from droneplan.solvers.registry import available_backends\n"
        "print(available_backends('linear'), available_backends())\n"
        "print(sorted(m for m in ('ortools', 'casadi', 'osqp', 'cvxpy', 'highspy') if m in sys.modules))\n"
        "print(sorted(m for m in sys.modules if m.startswith('droneplan.solvers.') and m.split('.')[-1]"
        " in ('cpsat', 'mip', 'nlp', 'qp')))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    listed, libraries, adapters = out.strip().splitlines()
    assert listed == "['cp-sat', 'highs', 'scip'] ['cp-sat', 'highs', 'ipopt', 'osqp', 'scip']"
    assert libraries == "[]"
    assert adapters == "[]"
