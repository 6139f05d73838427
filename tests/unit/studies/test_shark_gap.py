"""studies.thesis.shark gap: the random paths run as an open study (closed-loop contact times) with the
offline OCP and its proven bound as extras of the bound engine's row."""

from __future__ import annotations

import numpy as np
import pytest

from droneplan.planners.shark import VirtualSharkInterceptor, allocate_operators, optimal_interception
from droneplan.scenarios.shark import operator_start, random_trajectory, simulate
from droneplan.studies.common import make_executor
from droneplan.studies.harness import execute, score
from droneplan.studies.instances import FleetInstance, family_instances, load_instance, save_instance
from droneplan.studies.methods import BUILTIN, DEFAULT_METHODS, Method, resolve_methods
from droneplan.studies.thesis import shark as study


def test_shark_defaults_and_engine_are_registered():
    assert [m.name for m in resolve_methods("shark-path", None)] == list(DEFAULT_METHODS["shark-path"])
    assert BUILTIN["interception-bound"].is_bound_engine
    with pytest.raises(ValueError, match="name at least one method"):
        resolve_methods("cells", None)


def test_path_rows_match_the_direct_runs_and_solves(tmp_path):
    with make_executor(2) as ex:
        df = study.gap(seeds=1, first_seed=3, executor=ex, out=tmp_path)
    assert (df["status"] != "error").all(), df["message"].tolist()
    paths = df[df["instance"].str.startswith("random-path@")].set_index("method")
    assert {"virtual-shark", "ocp", "interception-bound"} <= set(paths.index)
    engine = paths.loc["interception-bound"]
    # the bound is about reaching the frontal point, not first contact: it is no ranked bound
    assert engine["role"] == "bound" and engine["bound_kind"] == "none" and engine["bound"] != engine["bound"]
    assert engine["shark_bound_metric"] == study.BOUND_METRIC
    # the same path, start and solves made directly (path seed 3, its random start bearing)
    tr = random_trajectory(3)
    bearing = float(np.random.default_rng(3).uniform(-180, 180))
    vs_ctl = VirtualSharkInterceptor()
    vs = simulate(tr, vs_ctl, bearing_deg=bearing)
    assert paths.loc["virtual-shark", "shark_capture_time"] == pytest.approx(vs_ctl.capture_time)
    assert paths.loc["virtual-shark", "objective"] == pytest.approx(vs.intercept_time)
    res = optimal_interception(tr, operator_start(tr, bearing_deg=bearing), N=50)
    assert engine["shark_ocp_time_s"] == pytest.approx(res.objective, rel=1e-6)
    lb = res.bound
    assert engine["shark_capture_time_bound_s"] == pytest.approx(lb, rel=1e-9)
    # what the bound is proven for: the OCP's T and the virtual shark's capture time
    assert lb <= engine["shark_ocp_time_s"] + 1e-6 and lb <= paths.loc["virtual-shark", "shark_capture_time"]
    fleet = df[df["instance"] == "random-fleet@1:seed=3"].set_index("method")
    assert set(fleet.index) == {"bottleneck", "greedy-nearest"}
    # the same fleet assigned directly: droneplan's scoring gives the engines' own latest times
    data = family_instances("random-fleet", seeds=[3])[0].data
    args = (data.operators, data.sharks_pos, data.sharks_vel, data.humans)
    opt, greedy = allocate_operators(*args), allocate_operators(*args, greedy=True)
    assert fleet.loc["bottleneck", "status"] == "optimal"
    assert fleet.loc["bottleneck", "objective"] == pytest.approx(opt.objective, rel=1e-12)
    assert fleet.loc["greedy-nearest", "objective"] == pytest.approx(greedy.objective, rel=1e-12)
    assert fleet.loc["bottleneck", "objective"] <= fleet.loc["greedy-nearest", "objective"] + 1e-9
    # the proven bound (CP-SAT's, less the 0.5 ms of its rounding) lies below both
    assert fleet.loc["bottleneck", "bound"] <= fleet.loc["bottleneck", "objective"]
    assert fleet.loc["greedy-nearest", "gap_to_bound"] >= 0
    assert fleet.loc["greedy-nearest", "gap_bound_kind"] == "proven-global"
    assert (tmp_path / "gap_table.csv").exists()


def _two_by_two() -> FleetInstance:
    # two operators, two sharks, each shark next to one operator
    ops = np.array([[0.0, -30.0, 2.0], [40.0, -30.0, 2.0]])
    sharks = np.array([[0.0, -10.0, -2.0], [40.0, -10.0, -2.0]])
    return FleetInstance(ops, sharks, np.array([[1.0, 0.0, 0.0], [1.0, 0.0, 0.0]]), np.zeros((1, 2)))


def _scored(instance, plan):
    def mine(operators, sharks_pos, sharks_vel, humans, *, seed, time_limit):
        return plan

    method = Method("mine", mine)
    return score(instance, method, execute(instance, method, 0, None))


def test_a_fleet_plan_is_scored_by_droneplans_interception_times(tmp_path):
    inst = family_instances("random-fleet", seeds=[0])[0]
    assert inst.size == len(inst.data.operators) and inst.id == "random-fleet@1:seed=0"
    save_instance(inst, tmp_path / "fleet.json")
    assert load_instance(tmp_path / "fleet.json").fingerprint() == inst.fingerprint()
    from droneplan.studies.instances import as_instance

    two = as_instance(_two_by_two())
    near = _scored(two, (np.array([0, 1]), np.array([0, 1])))
    far = _scored(two, (np.array([1, 0]), np.array([0, 1])))
    assert near.status == far.status == "feasible" and near.objective < far.objective
    cases = [
        ((np.array([0]), np.array([0])), "infeasible", "the sharks to serve are [0, 1]"),
        ((np.array([0, 1]), np.array([1, 1])), "infeasible", "an operator is sent to two sharks"),
        ((np.array([0, 1]), np.array([0, 2])), "invalid", "operator indexes must lie in 0..1"),
        ((np.array([0.0, 1.0]), np.array([0, 1])), "invalid", "sharks must be a 1-D array of integers"),
        ("nonsense", "invalid", "a fleet method returns (sharks, operator)"),
    ]
    for plan, status, message in cases:
        got = _scored(two, plan)
        assert (got.status, got.objective) == (status, None) and got.message.startswith(message), got
