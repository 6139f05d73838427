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
from droneplan.solvers.result import Status


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
def test_lifted_model_equals_brute_force(clustered, brute_force, seed, n_clusters, backend):
    p = clustered(seed, n_clusters, 3, m=3)
    value, _ = model_optimum(p, backend, lifted=True)
    assert value == brute_force(p)


@pytest.mark.parametrize("seed", range(4))
def test_lifted_model_equals_branch_and_bound_m4(clustered, seed):
    p = clustered(seed, 4, 3, m=4, half_width=7.0)
    bb = branch_and_bound(p, time_limit=60, workers=1)
    assert bb.status is Status.OPTIMAL
    lifted, stats = model_optimum(p, "highs", lifted=True)
    plain, plain_stats = model_optimum(p, "highs", lifted=False)
    assert lifted == plain == bb.objective
    # the lifted model is a different model (its rows are there), not the plain one again
    assert stats["connectivity_terms"] != plain_stats["connectivity_terms"]


def test_lifted_rows_default_per_backend(clustered):
    p = clustered(1, 4, 3, m=4, half_width=7.0)
    for backend, lifted in (("highs", True), ("cp-sat", False)):
        default = build_milp(p, backend=backend).stats["connectivity_terms"]
        assert default == build_milp(p, backend=backend, lifted_hops=lifted).stats["connectivity_terms"]


def test_lifted_hops_bad_input(clustered):
    p = clustered(0, 2, 3, m=2)
    with pytest.raises(TypeError, match="lifted_hops"):
        build_milp(p, lifted_hops="yes")
