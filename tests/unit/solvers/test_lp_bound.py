"""The safe LP dual bound (``solvers.lp_bound``) against enumeration of small 0/1 models.

The bound must be at least the best integer point, and the bound with x_j = 1 at least the
best integer point with x_j = 1 (else reduced-cost fixing would drop an optimum); with the
LP solved to optimality it must also be the LP optimum up to its small safety margin.
"""

import itertools

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from droneplan.solvers.lp_bound import lp_dual_bound
from droneplan.solvers.registry import get_backend


def _random_model(seed: int, n: int):
    """A random 0/1 maximisation model with <=, >= and ranged rows; returns (solver, x, rows)
    where rows = [(coefficients, lo, hi)] for the enumeration."""
    rng = np.random.default_rng(seed)
    lin = get_backend("highs", kind="linear").new_model()
    s = lin.native
    x = [s.BoolVar(f"x{j}") for j in range(n)]
    rows = []
    for _ in range(rng.integers(2, 6)):
        a = rng.integers(-3, 6, size=n).astype(float)
        total = float(np.abs(a).sum())
        kind = rng.integers(0, 3)
        lo = -np.inf if kind == 0 else float(rng.uniform(-total / 4, total / 4))
        hi = np.inf if kind == 1 else float(rng.uniform(total / 4, total / 2))
        expr = s.Sum([float(a[j]) * x[j] for j in range(n)])
        if np.isfinite(hi):
            s.Add(expr <= hi)
        if np.isfinite(lo):
            s.Add(expr >= lo)
        rows.append((a, lo, hi))
    c = rng.integers(-2, 9, size=n).astype(float)
    s.Maximize(s.Sum([float(c[j]) * x[j] for j in range(n)]))
    return s, x, rows, c


def _enumerate(rows, c, n):
    """Best objective overall and with each x_j = 1 (-inf when no feasible point has it)."""
    best, best_at = -np.inf, np.full(n, -np.inf)
    for bits in itertools.product((0, 1), repeat=n):
        v = np.array(bits, dtype=float)
        if all(lo - 1e-9 <= a @ v <= hi + 1e-9 for a, lo, hi in rows):
            val = float(c @ v)
            best = max(best, val)
            best_at = np.where(v > 0, np.maximum(best_at, val), best_at)
    return best, best_at


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 100_000), st.integers(3, 9), st.sampled_from(["simplex", "ipm"]))
def test_bound_is_above_every_integer_point(seed, n, method):
    s, x, rows, c = _random_model(seed, n)
    out = lp_dual_bound(s, x, time_limit=30, method=method)
    best, best_at = _enumerate(rows, c, n)
    assert out.bound >= best - 1e-9
    assert np.all(out.at_one >= best_at - 1e-9)
    assert np.all(out.at_one <= out.bound + 1e-9)
    if out.lp_value is not None:  # an optimal LP: the bound is its value, up to the margin
        assert out.lp_value - 1e-6 <= out.bound <= out.lp_value + 1e-4


@pytest.mark.parametrize("method", ["simplex", "ipm"])
def test_fixing_bound_excludes_a_variable_that_cannot_be_one(method):
    # max 3a + 2b + c, 2a + 2b + 2c <= 3: the LP takes a = 1, b = 1/2 (basic, so the row's dual
    # is 1 and unique), bound 4; with c = 1 the duals give 4 - 1 = 3, so a point better than
    # the integer optimum 3 (a alone) never has c = 1, while a and b keep the bound 4
    lin = get_backend("highs", kind="linear").new_model()
    s = lin.native
    a, b, c = (s.BoolVar(n) for n in "abc")
    s.Add(2 * a + 2 * b + 2 * c <= 3)
    s.Maximize(3 * a + 2 * b + c)
    out = lp_dual_bound(s, [a, b, c], method=method)
    assert out.status == "Optimal" and out.bound == pytest.approx(4, abs=1e-4)
    assert out.at_one == pytest.approx([4, 4, 3], abs=1e-4)


def test_bad_input_is_refused_by_name():
    lin = get_backend("highs", kind="linear").new_model()
    s = lin.native
    a = s.BoolVar("a")
    s.Minimize(a)
    with pytest.raises(ValueError, match="maximise"):
        lp_dual_bound(s, [a])
    s.Maximize(a)
    with pytest.raises(TypeError, match="solver"):
        lp_dual_bound(lin, [a])
    with pytest.raises(ValueError, match="time_limit"):
        lp_dual_bound(s, [a], time_limit=-1)
    with pytest.raises(ValueError, match="method"):
        lp_dual_bound(s, [a], method="barrier")
    free = s.NumVar(0.0, s.infinity(), "free")
    s.Add(a <= free)
    with pytest.raises(ValueError, match="bound every variable"):
        lp_dual_bound(s, [a])
    s2 = get_backend("highs", kind="linear").new_model().native
    t = s2.IntVar(0, 3, "t")
    s2.Maximize(t)
    with pytest.raises(ValueError, match="0/1 variables"):
        lp_dual_bound(s2, [t])


def test_a_swamped_bound_is_solved_again_without_presolve(monkeypatch):
    """When the bound from the presolved LP exceeds its optimum by more than PRESOLVE_RETRY_GAP
    (huge postsolve duals), the LP is solved again without presolve and each bound is the
    smaller of the two; a sane bound is not solved again."""
    from droneplan.solvers import lp_bound

    s, x, rows, c = _random_model(7, 6)
    best, best_at = _enumerate(rows, c, 6)
    real = lp_bound._solve_and_bound
    calls = []

    def swamped_first(highs, lp, cols, method, time_limit, *, presolve):
        calls.append(presolve)
        status, value, bound, at_one = real(highs, lp, cols, method, time_limit, presolve=presolve)
        if presolve:  # what HiGHS's postsolve returned on a degenerate cells LP: valid, useless
            return status, value, bound + 2000.0, at_one + np.arange(len(at_one)) * 1000.0
        return status, value, bound, at_one

    monkeypatch.setattr(lp_bound, "_solve_and_bound", swamped_first)
    out = lp_dual_bound(s, x)
    assert calls == [True, False]
    assert out.lp_value is not None and out.bound <= out.lp_value + 1e-4 * max(1.0, abs(out.lp_value))
    assert out.bound >= best - 1e-6
    assert np.all(out.at_one >= best_at - 1e-6)
    calls.clear()

    def counted(*a, **k):
        calls.append(k["presolve"])
        return real(*a, **k)

    monkeypatch.setattr(lp_bound, "_solve_and_bound", counted)
    lp_dual_bound(s, x)
    assert calls == [True]


def test_a_stopped_simplex_hands_the_rest_of_the_time_to_ipm(monkeypatch):
    """With ``ipm_after``, a simplex that has not ended in that time leaves the LP to IPM for the
    rest of ``time_limit``; each bound is the smaller of the two (both stay above enumeration)."""
    from droneplan.solvers import lp_bound

    s, x, rows, c = _random_model(11, 6)
    best, best_at = _enumerate(rows, c, 6)
    real = lp_bound._solve_and_bound
    calls = []

    def stopped_simplex(highs, lp, cols, method, time_limit, *, presolve):
        calls.append((method, time_limit))
        status, value, bound, at_one = real(highs, lp, cols, method, time_limit, presolve=presolve)
        if method == "simplex":  # what a simplex stopped at its limit leaves: valid, weak duals
            return "Time limit reached", None, bound + 50.0, at_one + 50.0
        return status, value, bound, at_one

    monkeypatch.setattr(lp_bound, "_solve_and_bound", stopped_simplex)
    out = lp_dual_bound(s, x, time_limit=20, ipm_after=2)
    assert [m for m, _ in calls] == ["simplex", "ipm"]
    assert calls[0][1] == 2 and 2 < calls[1][1] <= 20
    assert out.method == "simplex, then ipm" and out.status == "Optimal"
    assert out.lp_value is not None and out.bound <= out.lp_value + 1e-4 * max(1.0, abs(out.lp_value))
    assert out.bound >= best - 1e-6 and np.all(out.at_one >= best_at - 1e-6)


def test_a_simplex_that_ends_in_time_is_not_solved_again():
    s, x, rows, c = _random_model(12, 5)
    out = lp_dual_bound(s, x, ipm_after=30)
    assert out.method == "simplex" and out.status == "Optimal"
    assert out.bound >= _enumerate(rows, c, 5)[0] - 1e-9


def test_ipm_after_is_checked_by_name():
    s, x, _, _ = _random_model(13, 3)
    with pytest.raises(ValueError, match="ipm_after"):
        lp_dual_bound(s, x, ipm_after=0)
    with pytest.raises(ValueError, match="ipm_after"):
        lp_dual_bound(s, x, method="ipm", ipm_after=5)
    with pytest.raises(TypeError, match="ipm_after"):
        lp_dual_bound(s, x, ipm_after="5")
