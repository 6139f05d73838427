"""Shared oracle of the cells engines' tests."""

from __future__ import annotations

import itertools

import pytest

from droneplan.formulations.cells import candidate_sites, evaluate


def _best_coverage_by_enumeration(problem) -> int:
    """The most users any feasible placement of 1..m candidate sites covers, by trying every one
    (small instances only: the engines work on the same candidate sites)."""
    cand = candidate_sites(problem)
    best = 0
    for k in range(1, problem.n_cells + 1):
        for combo in itertools.combinations(range(len(cand.points)), k):
            ev = evaluate(problem, cand.points[list(combo)])
            if ev.feasible and ev.covered > best:
                best = ev.covered
    return best


@pytest.fixture(scope="session")
def brute_force():
    """The brute-force oracle: ``brute_force(problem)`` is the optimum over the candidate sites."""
    return _best_coverage_by_enumeration
