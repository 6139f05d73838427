"""Shared oracle of the cells engines' tests."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from droneplan.formulations.cells import candidate_sites, evaluate
from droneplan.scenarios.cells import CellProblem


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


def _clustered_problem(seed, n_clusters, per_cluster, m, half_width=6.0, background=0) -> CellProblem:
    """Users in tight clusters (many overlapping sites per cluster) spread far enough apart that
    the clusters need relays (R_d = R_g = 1, r1 = 3, r2 = 2.5), plus ``background`` users drawn
    uniformly over the square of half-side ``half_width``."""
    rng = np.random.default_rng(seed)
    centres = rng.uniform(-half_width, half_width, size=(n_clusters, 2))
    users = np.concatenate([rng.normal(c, 0.3, size=(per_cluster, 2)) for c in centres])
    users = np.concatenate([users, rng.uniform(-half_width, half_width, size=(background, 2))])
    return CellProblem(
        users=users, gbs=np.zeros((1, 2)), n_cells=m, R_d=1.0, R_g=1.0, r1=3.0, r2=2.5, bounds=None
    )


@pytest.fixture(scope="session")
def clustered():
    """``clustered(seed, n_clusters, per_cluster, m, half_width=6.0, background=0)``: a small
    clustered cells instance whose clusters need relays."""
    return _clustered_problem


@pytest.fixture
def hop_term_calls(monkeypatch):
    """Counts the calls of ``_LevelSources.terms`` (one per hop row written or sampled) in
    ``calls["n"]``; returns that dict."""
    from droneplan.formulations.cells import _milp

    calls = {"n": 0}
    real_terms = _milp._LevelSources.terms

    def counting_terms(self, *a, **k):
        calls["n"] += 1
        return real_terms(self, *a, **k)

    monkeypatch.setattr(_milp._LevelSources, "terms", counting_terms)
    return calls
