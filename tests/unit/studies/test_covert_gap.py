"""studies.thesis.covert_gap: the covert gap study is an open study of the registered controllers and the
on-sphere bound engine, resumable, and equal to the runs and oracle made directly."""

from __future__ import annotations

import pytest

import droneplan.studies.thesis.covert_gap as cg
from droneplan.planners.covert import HoverBenchmark, SlidingModeObserver
from droneplan.scenarios.covert import random_case, simulate
from droneplan.studies.bound_engines import DEG, _instant_optima
from droneplan.studies.common import make_executor
from droneplan.studies.methods import BUILTIN, DEFAULT_METHODS, Method, resolve_methods
from droneplan.studies.store import load_results


def test_gap_instances_cycle_through_two_to_six_targets():
    insts = cg.gap_instances(6, first_seed=3)
    assert [i.seed for i in insts] == [3, 4, 5, 6, 7, 8]
    assert [i.size for i in insts] == [2 + s % 5 for s in range(3, 9)]
    assert {i.family for i in insts} == {"random-group"}


def test_bound_engines_are_registered_and_users_cannot_pose_as_one():
    engine = BUILTIN["onsphere-optimum"]
    assert engine.is_bound_engine and engine.role == "bound" and "covert-run" in engine.kinds
    assert [m.name for m in resolve_methods("covert-run", None)] == list(DEFAULT_METHODS["covert-run"])

    def mine(scenario, *, seed, time_limit):
        return {"status": "optimal", "bound": 0.0, "bound_kind": "proven-global"}

    # a user's function is no controller class, and it cannot claim the bound role
    with pytest.raises(TypeError, match="take a controller class"):
        resolve_methods("covert-run", [mine])
    with pytest.raises(ValueError, match="role 'bound' is for droneplan's exact engines"):
        Method("mine", mine, "bound")


def test_gap_rows_match_the_task_function_and_resume(tmp_path):
    with make_executor(2) as ex:
        df = cg.gap(seeds=1, executor=ex, out=tmp_path)
        first = load_results(tmp_path)
        cg.gap(seeds=1, executor=ex, out=tmp_path)  # resumes: every row reused
    again = load_results(tmp_path)
    assert sorted(again["finished_at"]) == sorted(first["finished_at"])
    assert (df["status"] != "error").all(), df["message"].tolist()
    new = df.set_index("method")
    assert set(new.index) == {"hover", "sliding", "mpc", "mpc-safeguarded", "onsphere-optimum"}
    assert (new["size"] == 2).all()
    # the same runs and oracle made directly (the old task function's steps) on the same group
    sc = random_case(2, 0)
    for name, ctl in (("hover", HoverBenchmark()), ("sliding", SlidingModeObserver())):
        assert new.loc[name, "objective"] == pytest.approx(simulate(sc, ctl).beta_max * DEG, rel=1e-9)
    _, lbs, _ = _instant_optima(simulate(sc, SlidingModeObserver()), sc)
    assert new.loc["onsphere-optimum", "bound"] == pytest.approx(lbs.max() * DEG, rel=1e-9)
    # the proven on-sphere optimum is below what the sliding mode recorded on the sphere, which is
    # at most its whole-run maximum
    onsphere = new.loc["onsphere-optimum", "covert_sliding_onsphere_max_deg"]
    assert new.loc["onsphere-optimum", "bound"] <= onsphere + 1e-9
    assert onsphere <= new.loc["sliding", "objective"] + 1e-9
    assert new.loc["sliding", "gap_bound_kind"] == "instantaneous"
    assert new.loc["onsphere-optimum", "role"] == "bound" and new.loc["onsphere-optimum", "bound_kind"] == (
        "instantaneous"
    )
    assert (tmp_path / "gap_summary.csv").exists() and (tmp_path / "gap_covert.png").exists()
