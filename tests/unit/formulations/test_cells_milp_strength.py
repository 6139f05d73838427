"""The lifted hop rows of the cells MILP (``_milp`` item 8) keep the optimum.

The rows leave out of a site's hop row the sources that overlap it and add one row per
user clique; both are exact only if no connected placement is cut off, so the model with
them must reach the brute-force optimum of the candidate problem (and the branch and
bound's on larger instances), on either backend.
"""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from droneplan.formulations.cells import branch_and_bound, build_milp, evaluate
from droneplan.scenarios.cells import CellProblem
from droneplan.solvers.result import Status


def clustered(seed, n_clusters, per_cluster, m, half_width=6.0):
    """Users in tight clusters (many overlapping sites per cluster, so user cliques with
    several sites) spread far enough that the clusters need relays (r1 = 3, r2 = 2.5)."""
    rng = np.random.default_rng(seed)
    centres = rng.uniform(-half_width, half_width, size=(n_clusters, 2))
    users = np.concatenate([rng.normal(c, 0.3, size=(per_cluster, 2)) for c in centres])
    return CellProblem(
        users=users, gbs=np.zeros((1, 2)), n_cells=m, R_d=1.0, R_g=1.0, r1=3.0, r2=2.5, bounds=None
    )


def model_optimum(problem, backend, lifted):
    mdl = build_milp(problem, backend=backend, lifted_hops=lifted)
    res = mdl.model.solve(variables=mdl.x, time_limit=60, workers=1)
    assert res.status is Status.OPTIMAL
    chosen = mdl.points[np.asarray(res.x) > 0.5]
    ev = evaluate(problem, chosen)
    assert ev.feasible and ev.covered == round(res.objective)
    return round(res.objective), mdl.stats


@settings(max_examples=15, deadline=None)
@given(st.integers(0, 10_000), st.integers(2, 3), st.sampled_from(["highs", "cp-sat"]))
def test_lifted_model_equals_brute_force(brute_force, seed, n_clusters, backend):
    p = clustered(seed, n_clusters, 3, m=3)
    value, _ = model_optimum(p, backend, lifted=True)
    assert value == brute_force(p)


@pytest.mark.parametrize("seed", range(4))
def test_lifted_model_equals_branch_and_bound_m4(seed):
    p = clustered(seed, 4, 3, m=4, half_width=7.0)
    bb = branch_and_bound(p, time_limit=60, workers=1)
    assert bb.status is Status.OPTIMAL
    lifted, stats = model_optimum(p, "highs", lifted=True)
    plain, plain_stats = model_optimum(p, "highs", lifted=False)
    assert lifted == plain == bb.objective
    # the lifted model is a different model (its rows are there), not the plain one again
    assert stats["connectivity_terms"] != plain_stats["connectivity_terms"]


def test_lifted_rows_default_per_backend():
    p = clustered(1, 4, 3, m=4, half_width=7.0)
    for backend, lifted in (("highs", True), ("cp-sat", False)):
        default = build_milp(p, backend=backend).stats["connectivity_terms"]
        assert default == build_milp(p, backend=backend, lifted_hops=lifted).stats["connectivity_terms"]


def test_lifted_hops_bad_input():
    p = clustered(0, 2, 3, m=2)
    with pytest.raises(TypeError, match="lifted_hops"):
        build_milp(p, lifted_hops="yes")
