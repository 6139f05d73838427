"""Candidate sites dropped before the branch and bound (``Prepared.prune_candidates``): the
optimum over the kept sites equals the optimum over every site, by brute force."""

import itertools

import numpy as np

from droneplan.formulations.cells import CellProblem, evaluate
from droneplan.formulations.cells._prepare import prepare


def _problem(seed, n, m):
    rng = np.random.default_rng(seed)
    return CellProblem(
        users=rng.uniform(-6, 6, size=(n, 2)),
        gbs=np.array([[0.0, 0.0]]),
        n_cells=m,
        R_d=1.0,
        R_g=1.0,
        r1=3.0,
        r2=2.5,
    )


def _best(problem, points):
    best = 0
    for k in range(1, problem.n_cells + 1):
        for combo in itertools.combinations(range(len(points)), k):
            ev = evaluate(problem, points[list(combo)])
            if ev.feasible:
                best = max(best, int(ev.covered))
    return best


def test_pruned_sites_leave_the_optimum_and_the_incumbent():
    dropped_total = 0
    for seed in range(8):
        p = _problem(seed, 10, 3)
        prep = prepare(p)
        before = prep.cand.points
        dropped = prep.prune_candidates()
        assert dropped == len(before) - len(prep.cand.points) == prep.info["pruned_sites"]
        dropped_total += dropped
        # the incumbent's sites stay candidates, and the optimum over the kept sites is the optimum
        for site in prep.inc:
            assert np.min(np.hypot(*(prep.cand.points - site).T)) <= 1e-3
        assert _best(p, prep.cand.points) == _best(p, before)
        assert prep.bound_m_minus_1() >= _best(CellProblem(**{**_kwargs(p), "n_cells": 2}), before)
    assert dropped_total > 0


def _kwargs(p):
    return {
        "users": p.users,
        "gbs": p.gbs,
        "n_cells": p.n_cells,
        "R_d": p.R_d,
        "R_g": p.R_g,
        "r1": p.r1,
        "r2": p.r2,
    }
