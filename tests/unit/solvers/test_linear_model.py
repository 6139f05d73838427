"""LinearModel: one model text, every "linear" backend, checked against brute force."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from droneplan.solvers import Status, available_backends, get_backend

LINEAR = available_backends("linear")

# maximum coverage: choose at most K of the sets, maximise the number of covered elements
SETS = [[0, 1, 2], [2, 3], [3, 4, 5], [0, 5], [1, 4], [6], [5, 6, 7]]
N_ELEMENTS = 8
K = 2


def _max_coverage_bruteforce() -> int:
    return max(
        len(set().union(*(SETS[i] for i in pick)))
        for r in range(K + 1)
        for pick in itertools.combinations(range(len(SETS)), r)
    )


def _build(backend):
    lin = get_backend(backend, kind="linear").new_model()
    x = [lin.bool_var(f"x{i}") for i in range(len(SETS))]
    y = [lin.unit_var(f"y{e}") for e in range(N_ELEMENTS)]
    for e in range(N_ELEMENTS):
        lin.add(y[e] <= lin.sum(x[i] for i, s in enumerate(SETS) if e in s))
    lin.add(lin.sum(x) <= K)
    lin.maximize(lin.sum(y))
    return lin, x


@pytest.mark.parametrize("backend", LINEAR)
def test_max_coverage_matches_bruteforce(backend):
    lin, x = _build(backend)
    res = lin.solve(variables=x, time_limit=10, workers=1)
    best = _max_coverage_bruteforce()
    assert res.status is Status.OPTIMAL and res.backend == backend
    assert res.objective == pytest.approx(best) and res.bound == pytest.approx(best)
    chosen = np.flatnonzero(np.asarray(res.x) > 0.5)
    assert len(chosen) <= K
    assert len(set().union(*(SETS[i] for i in chosen))) == best


@pytest.mark.parametrize("backend", LINEAR)
def test_hint_is_reported_truthfully(backend):
    lin, x = _build(backend)
    res = lin.solve(variables=x, hint={v: int(i in (0, 2)) for i, v in enumerate(x)})
    assert res.warm_started is lin.takes_hint
    assert res.objective == pytest.approx(_max_coverage_bruteforce())


@pytest.mark.parametrize("backend", LINEAR)
def test_integers_cliques_and_minimise(backend):
    # min z s.t. z >= 3 a + 2 b + 4 c, exactly one of (a, b, c), at most one of (a, b), n in [2, 5], z >= n
    lin = get_backend(backend, kind="linear").new_model()
    a, b, c = (lin.bool_var(s) for s in "abc")
    n = lin.int_var(2, 5, "n")
    z = lin.int_var(0, 100, "z")
    lin.add_exactly_one([a, b, c])
    lin.add_at_most_one([a, b])
    lin.add(z >= 3 * a + 2 * b + 4 * c)
    lin.add(z >= n)
    lin.minimize(z)
    res = lin.solve(variables=[a, b, c, n, z])
    assert res.status is Status.OPTIMAL
    assert res.objective == pytest.approx(2.0)
    np.testing.assert_allclose(res.x[:3], [0, 1, 0])


@pytest.mark.parametrize("backend", LINEAR)
def test_infeasible_is_a_status(backend):
    lin = get_backend(backend, kind="linear").new_model()
    a, b = lin.bool_var("a"), lin.bool_var("b")
    lin.add(a + b >= 3)
    lin.maximize(a)
    res = lin.solve(variables=[a, b])
    assert res.status is Status.INFEASIBLE and res.x is None


@pytest.mark.parametrize("backend", LINEAR)
def test_bad_arguments_raise(backend):
    lin, x = _build(backend)
    with pytest.raises(ValueError, match="time_limit"):
        lin.solve(variables=x, time_limit=-1)
    with pytest.raises(ValueError, match="no_such_option"):
        lin.solve(variables=x, options={"no_such_option": 1})
