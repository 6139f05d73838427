"""The lazy-constraint loop on a toy problem: symmetric TSP with subtour cuts added lazily,
checked against brute force over all tours."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from droneplan.solvers import Status, get_backend
from droneplan.solvers.lazy import lazy_constraint_loop


def _instance(seed: int, n: int):
    rng = np.random.default_rng(seed)
    pts = rng.integers(0, 100, size=(n, 2))
    d = np.rint(np.hypot(*(pts[:, None, :] - pts[None, :, :]).transpose(2, 0, 1))).astype(int)
    return d


def _bruteforce(d) -> int:
    n = len(d)
    return min(
        sum(d[t[i], t[(i + 1) % n]] for i in range(n))
        for perm in itertools.permutations(range(1, n))
        for t in [(0, *perm)]
    )


def _subtours(n, edges):
    adj = {i: [] for i in range(n)}
    for i, j in edges:
        adj[i].append(j)
        adj[j].append(i)
    seen, comps = set(), []
    for s in range(n):
        if s in seen:
            continue
        comp, stack = {s}, [s]
        while stack:
            for j in adj[stack.pop()]:
                if j not in comp:
                    comp.add(j)
                    stack.append(j)
        seen |= comp
        comps.append(frozenset(comp))
    return comps if len(comps) > 1 else []


def _tsp(d, backend, **kw):
    n = len(d)
    pairs = list(itertools.combinations(range(n), 2))
    log = []

    def solve_relaxation(cuts, time_left):
        lin = get_backend(backend, kind="linear").new_model()
        x = {e: lin.bool_var(f"x{e}") for e in pairs}
        for i in range(n):
            lin.add(lin.sum(x[e] for e in pairs if i in e) == 2)
        for S in cuts:  # at least two edges leave every proper subset
            lin.add(lin.sum(x[(i, j)] for (i, j) in pairs if (i in S) != (j in S)) >= 2)
        lin.minimize(lin.sum(int(d[e]) * x[e] for e in pairs))
        res = lin.solve(variables=[x[e] for e in pairs], time_limit=time_left, workers=1)
        log.append(res)
        return res

    def separate(res):
        return _subtours(n, [e for e, v in zip(pairs, res.x, strict=False) if v > 0.5])

    return lazy_constraint_loop(solve_relaxation, separate, sense="min", **kw), log, pairs


@pytest.mark.parametrize("backend", ["cp-sat", "highs"])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_tsp_matches_bruteforce(backend, seed):
    d = _instance(seed, 7)
    res, log, pairs = _tsp(d, backend)
    best = _bruteforce(d)
    assert res.status is Status.OPTIMAL
    assert res.objective == pytest.approx(best)
    assert res.bound == pytest.approx(best)
    chosen = [e for e, v in zip(pairs, res.x, strict=False) if v > 0.5]
    assert len(chosen) == 7 and not _subtours(7, chosen)
    # every relaxation's bound is a valid lower bound
    assert all(r.bound <= best + 1e-9 for r in log if r.bound is not None)
    assert res.iterations == len(log) == res.info["rounds"]


def test_round_limit_keeps_a_valid_bound():
    d = _instance(3, 8)
    full, _, _ = _tsp(d, "cp-sat")
    assert full.status is Status.OPTIMAL and full.iterations > 1  # this instance needs cuts
    res, _log, _ = _tsp(d, "cp-sat", max_rounds=1)
    assert res.status is Status.NO_SOLUTION and res.x is None and res.iterations == 1
    assert res.bound <= full.objective + 1e-9
    assert res.info["cuts"]  # the violated subtours of round 1 are returned for reuse


def test_infeasible_relaxation_and_bad_arguments():
    from droneplan.solvers import SolveResult

    res = lazy_constraint_loop(lambda cuts, t: SolveResult(Status.INFEASIBLE), lambda r: [], sense="max")
    assert res.status is Status.INFEASIBLE
    with pytest.raises(ValueError, match="sense"):
        lazy_constraint_loop(lambda c, t: None, lambda r: [], sense="up")
    with pytest.raises(ValueError, match="max_rounds"):
        lazy_constraint_loop(lambda c, t: None, lambda r: [], sense="max", max_rounds=0)
    with pytest.raises(TypeError, match="SolveResult"):
        lazy_constraint_loop(lambda c, t: None, lambda r: [], sense="max")
