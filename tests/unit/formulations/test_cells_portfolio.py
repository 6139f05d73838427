"""engine="auto": both exact engines side by side, the model's incumbents pruning the search."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pytest

from droneplan.formulations.cells import evaluate, solve_exact
from droneplan.formulations.cells._exact import ENGINE_CHOICES, ONE_CORE_ENGINE, _run_bnb, available_cores
from droneplan.formulations.cells._portfolio import ModelPeer
from droneplan.formulations.cells._prepare import prepare
from droneplan.scenarios.cells import thesis_problem


@pytest.mark.skipif(available_cores() < 2, reason="the portfolio runs on two cores or more")
@pytest.mark.parametrize(("m", "seed"), [(2, 0), (3, 1), (3, 4)])
def test_the_portfolio_proves_the_optimum_both_engines_prove(m, seed):
    problem = thesis_problem(m, seed)
    auto = solve_exact(problem, engine="auto", workers=2, time_limit=120)
    bnb = solve_exact(problem, engine="bnb", workers=1, time_limit=120)
    milp = solve_exact(problem, engine="milp", workers=1, time_limit=120)
    assert bnb.status.name == milp.status.name == auto.status.name == "OPTIMAL"
    assert auto.objective == bnb.objective == milp.objective == auto.bound
    assert evaluate(problem, auto.x).feasible and evaluate(problem, auto.x).covered == auto.objective
    portfolio = auto.info["portfolio"]
    assert auto.info["engine"] == "auto" and portfolio["proved_by"] in ("bnb", "milp")
    assert {"bnb", "milp", "wall_s"} <= set(portfolio) and portfolio["bnb"]["wall_s"] > 0


@dataclass
class _Oracle:
    """A peer that already holds a placement (and may have proved it)."""

    positions: np.ndarray
    value: int
    proved: bool = False

    def best_value(self) -> int:
        return self.value

    def finished(self) -> bool:
        return self.proved

    def better(self, positions):
        mine = evaluate_covered(self.problem, positions)
        return self.positions if self.value > mine else positions


def evaluate_covered(problem, positions) -> int:
    return int(evaluate(problem, positions).covered)


@pytest.mark.parametrize(("m", "seed"), [(3, 0), (3, 2), (4, 1)])
def test_a_peer_value_only_prunes_the_search_never_loses_the_optimum(m, seed):
    problem = thesis_problem(m, seed)
    cold = solve_exact(problem, engine="bnb", workers=1, time_limit=120)
    assert cold.status.name == "OPTIMAL"
    oracle = _Oracle(np.asarray(cold.x), int(cold.objective))
    oracle.problem = problem  # type: ignore[attr-defined]
    helped = _run_bnb(prepare(problem, time_limit=120), 1, oracle)  # type: ignore[arg-type]
    assert helped.status.name == "OPTIMAL" and helped.objective == cold.objective == helped.bound
    assert evaluate(problem, helped.x).covered == cold.objective
    assert helped.iterations <= cold.iterations  # the search holds the optimum's value from the start


def test_a_peer_that_proved_stops_the_search_unproven_with_a_valid_bound():
    problem = thesis_problem(4, 0)
    optimum = solve_exact(problem, engine="bnb", workers=1, time_limit=120).objective
    start = np.zeros((0, 2))
    stopper = _Oracle(start, 0, proved=True)
    stopper.problem = problem  # type: ignore[attr-defined]
    res = _run_bnb(prepare(problem, time_limit=120), 1, stopper)  # type: ignore[arg-type]
    if res.status.name == "FEASIBLE":  # stopped at the first checkpoint
        assert res.objective <= optimum <= res.bound
    else:  # the start already met the bound: no search node was needed
        assert res.objective == optimum


def test_the_model_peer_keeps_the_best_feasible_placement_it_was_sent():
    problem = thesis_problem(2, 0)
    prep = prepare(problem, time_limit=60)
    peer = ModelPeer.start(prep)
    good = np.asarray(solve_exact(problem, engine="bnb", workers=1).x)
    for placement in (good[:1], good, good[:1]):
        peer.child_report(placement, bound=0.0)
    assert peer.best_value() == evaluate_covered(problem, good)
    assert np.array_equal(peer.better(good[:1]), good)
    peer.send.close()
    peer.receive.close()


def test_one_worker_runs_the_one_core_engine_and_bad_engines_are_named():
    problem = thesis_problem(2, 0)
    res = solve_exact(problem, engine="auto", workers=1, time_limit=60)
    assert res.info["engine"] == ONE_CORE_ENGINE and "portfolio" not in res.info
    with pytest.raises(ValueError, match="engine must be one of") as err:
        solve_exact(problem, engine="both")
    assert all(choice in str(err.value) for choice in ENGINE_CHOICES)
