"""The lazy-cut loop of the cells MILP (``_milp`` item 3a) on an instance that needs a cut.

Two clusters of three users lie 5 and 7.2 from the GBS (reach r1 = r2 = 2.5), two more users
sit next to the GBS off to the side, one user halfway out. The model without cuts (one
neighbour row per non-direct site) takes both far clusters and the side pair: 8 users, but
the far pair links only to each other. The connected optimum (a relay halfway out, then the
two clusters) covers 7. So the loop must separate at least one connectivity cut to prove it.
"""

import numpy as np

from droneplan.formulations.cells import CellProblem, build_milp, evaluate, solve_exact
from droneplan.solvers.result import Status

_USERS = [
    [5.0, 0.2],
    [5.0, -0.2],
    [5.2, 0.0],  # far cluster A (3 users)
    [7.2, 0.2],
    [7.2, -0.2],
    [7.4, 0.0],  # farther cluster B (3 users), linked to A only
    [0.0, 2.5],
    [0.2, 2.6],  # side pair next to the GBS (2 users)
    [2.6, 0.0],  # halfway out (1 user): where the relay goes
]


def _problem() -> CellProblem:
    return CellProblem(
        users=np.array(_USERS),
        gbs=np.array([[0.0, 0.0]]),
        n_cells=3,
        R_d=1.0,
        R_g=1.0,
        r1=2.5,
        r2=2.5,
    )


def test_model_without_cuts_is_disconnected(brute_force):
    # the premise: the first lazy model's optimum is not a feasible placement and beats the optimum
    p = _problem()
    mdl = build_milp(p, connectivity="lazy")
    res = mdl.model.solve(variables=mdl.x, time_limit=30, workers=1)
    assert res.status is Status.OPTIMAL
    chosen = mdl.points[np.flatnonzero(np.asarray(res.x) > 0.5)]
    ev = evaluate(p, chosen)
    assert not ev.feasible and not ev.connected.all()
    assert res.objective == ev.covered > brute_force(p)


def test_cut_loop_is_exercised(brute_force):
    # the solve must add cuts to get from the disconnected relaxation to the optimum
    p = _problem()
    res = solve_exact(p, engine="milp", connectivity="lazy", time_limit=60, workers=1)
    assert res.status is Status.OPTIMAL
    assert res.info["model_stats"]["lazy_cuts"] >= 1
    assert res.info["rounds"] >= 2
    assert res.objective == brute_force(p)
    ev = evaluate(p, res.x)
    assert ev.feasible and ev.covered == res.objective
