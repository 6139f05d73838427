"""Warm starts as a study: the ``ENGINE<HEURISTIC`` composite, its isolation, and the paired table."""

from __future__ import annotations

import dataclasses
import textwrap

import numpy as np
import pandas as pd
import pytest

import droneplan as dp
from droneplan.studies.harness import run_warm_started
from droneplan.studies.instances import family_instances
from droneplan.studies.library import lookup
from droneplan.studies.methods import (
    BUILTIN,
    Method,
    WarmStarted,
    resolve_methods,
    warm_start_engines,
    warm_started,
)
from droneplan.studies.warm_starts import (
    warm_start_markdown,
    warm_start_methods,
    warm_start_table,
)

USER_HEURISTICS = '''
import os

import numpy as np


def far(problem, *, seed, time_limit):
    """A plan of one drone-cell far outside the area (infeasible), claimed as a good one."""
    return np.array([[1e7, 1e7]])


def boom(problem, *, seed, time_limit):
    raise RuntimeError("the heuristic broke")


def vanish(problem, *, seed, time_limit):
    os._exit(3)


def saboteur(problem, *, seed, time_limit):
    """Patches droneplan's exact solver in its own process, then returns a fine plan."""
    import droneplan.formulations.cells as cells
    from droneplan.formulations.cells import greedy_placement

    def fake(*args, **kwargs):
        raise RuntimeError("sabotaged")

    cells.solve_exact = fake
    return greedy_placement(problem)


def sleepy(problem, *, seed, time_limit):
    import time

    time.sleep(60)
'''


@pytest.fixture(scope="module")
def user_module(tmp_path_factory):
    folder = tmp_path_factory.mktemp("warm_user")
    (folder / "warm_user_heuristics.py").write_text(textwrap.dedent(USER_HEURISTICS), encoding="utf-8")
    mp = pytest.MonkeyPatch()
    mp.syspath_prepend(str(folder))
    yield "warm_user_heuristics"
    mp.undo()


# --------------------------------------------------------------------------- parsing
@pytest.mark.parametrize(
    ("kind", "spec", "engine", "heuristic"),
    [
        ("cells", "milp<ga", "milp", "ga"),
        ("cells", "bnb<greedy", "bnb", "greedy"),
        ("cells", " bnb < greedy ", "bnb", "greedy"),
        ("allocation", "cp-sat<alg3", "cp-sat", "alg3"),
        ("allocation", "cp-sat<collision-blind", "cp-sat", "collision-blind"),
    ],
)
def test_composite_spellings(kind, spec, engine, heuristic):
    (m,) = resolve_methods(kind, [spec])
    assert isinstance(m, WarmStarted)
    assert m.name == f"{engine}<{heuristic}"
    assert m.engine is BUILTIN[engine] and m.heuristic is BUILTIN[heuristic]
    assert m.role == "model" and m.trusted_bound and m.kinds == BUILTIN[engine].kinds
    assert m.deterministic == BUILTIN[heuristic].deterministic


def test_warm_start_engines():
    assert warm_start_engines("cells") == ["bnb", "milp"]
    assert warm_start_engines("allocation") == ["cp-sat"]
    assert warm_start_engines("cells-mobile") == []  # the joint model takes no start


@pytest.mark.parametrize(
    ("kind", "spec", "names"),
    [
        ("cells", "foo<ga", ["'foo'", "bnb, milp"]),
        ("cells", "ga<greedy", ["'ga'", "bnb, milp"]),
        ("cells", "bnb<foo", ["'foo'", "ga", "greedy"]),
        ("cells", "bnb<", ["ENGINE<HEURISTIC", "greedy"]),
        ("cells", "bnb<milp<ga", ["ENGINE<HEURISTIC"]),
        ("cells", "bnb<alg3", ["'alg3'", "allocation", "greedy"]),
        ("allocation", "exact<alg3", ["'exact'", "cp-sat"]),
        ("cells-mobile", "joint<myopic", ["'joint'", "none"]),
        ("cells", "bnb<no_such_module_xyz:fn", ["no_such_module_xyz"]),
    ],
)
def test_bad_composites_one_line(kind, spec, names):
    with pytest.raises(ValueError, match=r"^method ") as err:
        resolve_methods(kind, [spec])
    text = str(err.value)
    assert "\n" not in text
    for name in names:
        assert name in text


def test_user_heuristic_and_fingerprints(user_module):
    (m,) = resolve_methods("cells", [f"bnb<{user_module}:far"])
    assert m.heuristic is not None and m.heuristic.name == f"{user_module}:far"
    assert not m.builtin and m.trusted_bound  # the engine's bound; the heuristic is the user's
    prints = {s: warm_started(s, "cells").fingerprint() for s in ("bnb<ga", "bnb<greedy", "milp<ga")}
    assert len(set(prints.values())) == 3
    assert BUILTIN["bnb"].fingerprint() in prints["bnb<ga"]
    assert BUILTIN["ga"].fingerprint() in prints["bnb<ga"]


def test_forged_composite_refused():
    def engine(problem, *, seed, time_limit, warm_start=None):
        return None

    fake = dataclasses.replace(warm_started("bnb<greedy", "cells"), engine=Method("bnb2", engine))
    with pytest.raises(ValueError, match="registered engines"):
        resolve_methods("cells", [fake])
    renamed = dataclasses.replace(warm_started("bnb<greedy", "cells"), name="bnb<ga")
    with pytest.raises(ValueError, match="warm_started"):
        resolve_methods("cells", [renamed])


def test_composite_target_not_called_directly():
    m = warm_started("bnb<greedy", "cells")
    with pytest.raises(TypeError, match="inside a study"):
        m.call(None, seed=0, time_limit=1.0)


# --------------------------------------------------------------------------- the composite in a study
def _extra(row, problem, name):
    return row[f"{problem}_{name}"]


def test_cells_composite_row(tmp_path):
    inst = family_instances("table4.2", m=2, seeds=[0])[0]
    df = dp.gap(
        "cells",
        methods=["bnb<greedy", "greedy"],
        instances=[inst],
        out=tmp_path,
        time_limit=60,
        workers=1,
        progress=False,
    )
    row = df[df["method"] == "bnb<greedy"].iloc[0]
    greedy = df[df["method"] == "greedy"].iloc[0]
    assert row["status"] == "optimal" and row["bound_kind"] != "none"
    assert row["objective"] == lookup(inst).value
    assert row["objective"] >= _extra(row, "cells", "heuristic_objective") == greedy["objective"]
    for name in ("heuristic_time_s", "engine_time_s", "heuristic_time_limit_s", "engine_time_limit_s"):
        assert _extra(row, "cells", name) > 0
    assert _extra(row, "cells", "heuristic_time_limit_s") == pytest.approx(30.0)
    assert _extra(row, "cells", "warm_start") in ("used", "not used")
    assert _extra(row, "cells", "warm_start_reason")
    assert _extra(row, "cells", "heuristic_status") == "feasible"
    assert _extra(row, "cells", "kept") == "engine"
    assert bool(row["warm_started"]) == (_extra(row, "cells", "warm_start") == "used")


def test_allocation_composite_row():
    inst = family_instances("allocation", n=4, seeds=[0])[0]
    res = run_warm_started(inst, warm_started("cp-sat<alg3", "allocation"), 0, 30.0)
    facts = res.info["composite"]
    assert res.has_solution and facts["heuristic_status"] == "feasible"
    assert res.objective <= facts["heuristic_objective"] + 1e-9  # the allocation minimises
    assert facts["warm_start"] == "used" and "hint" in facts["warm_start_reason"]
    assert facts["heuristic_time_s"] > 0 and facts["engine_time_s"] > 0


def test_allocation_composite_in_study(tmp_path):
    df = dp.gap(
        "herding",
        methods=["cp-sat", "cp-sat<alg3"],
        instances="allocation",
        n=4,
        seeds=1,
        out=tmp_path,
        time_limit=30,
        workers=1,
        progress=False,
    )
    row = df[df["method"] == "cp-sat<alg3"].iloc[0]
    assert row["status"] == "optimal"
    assert row["objective"] <= _extra(row, "herding", "heuristic_objective") + 1e-9
    assert _extra(row, "herding", "warm_start") == "used"
    assert _extra(row, "herding", "engine_time_s") > 0
    cold = df[df["method"] == "cp-sat"].iloc[0]
    assert _extra(row, "herding", "nodes") >= 0 and _extra(cold, "herding", "nodes") >= 0  # CP-SAT's branches
    assert _extra(cold, "herding", "solve_time_s") > 0


@pytest.mark.parametrize(
    ("fn", "status", "why"),
    [
        ("far", "infeasible", "infeasible"),
        ("boom", "error", "the heuristic broke"),
        ("vanish", "crashed", "exit code 3"),
        ("saboteur", "feasible", None),
    ],
)
def test_bad_heuristic_leaves_the_engine_row_intact(user_module, fn, status, why):
    inst = family_instances("table4.2", m=2, seeds=[1])[0]
    method = warm_started(f"bnb<{user_module}:{fn}", "cells")
    res = run_warm_started(inst, method, 0, 60.0)
    facts = res.info["composite"]
    assert res.status is dp.Status.OPTIMAL and res.objective == lookup(inst).value
    assert facts["heuristic_status"] == status
    if why is None:  # the saboteur's patch stayed in its own process: the engine ran, warm
        assert facts["warm_start"] in ("used", "not used")
    else:
        assert facts["warm_start"] == "cold" and why in facts["warm_start_reason"]
        assert facts["heuristic_objective"] is None


def test_slow_heuristic_times_out_and_the_engine_runs_cold(user_module):
    inst = family_instances("table4.2", m=2, seeds=[1])[0]
    res = run_warm_started(inst, warm_started(f"bnb<{user_module}:sleepy", "cells"), 0, 4.0)
    facts = res.info["composite"]
    assert facts["heuristic_status"] == "timeout" and facts["warm_start"] == "cold"
    assert facts["heuristic_time_s"] < 4.0
    assert res.has_solution


# --------------------------------------------------------------------------- the paired table
def _frame() -> pd.DataFrame:
    """Six instances; cold and warm ("bnb<ga") rows at 60 s, and at a short limit of 5 s."""
    rows = []
    cold_t = [1.0, 2.0, 3.0, 4.0, 5.0, 6.0]
    warm_t = [2.0, 3.0, 4.0, 5.0, 1.0, 6.0]  # faster on 1 pair, slower on 4, one tie
    nodes_c = [10, 20, 30, 40, 50, 60]
    nodes_w = [5, 10, 15, 20, 25, 70]  # fewer on 5 pairs, more on 1
    for i in range(6):
        base = {"problem": "cells", "instance": f"i{i}", "sense": "max", "run": 0, "time_limit_s": 60.0}
        rows.append(
            {**base, "method": "bnb", "status": "optimal", "objective": 50.0, "time_s": cold_t[i] + 0.5}
            | {"cells_solve_time_s": cold_t[i], "cells_nodes": nodes_c[i]}
        )
        rows.append(
            {**base, "method": "bnb<ga", "status": "optimal", "objective": 50.0, "time_s": warm_t[i] + 1.5}
            | {"cells_engine_time_s": warm_t[i], "cells_heuristic_time_s": 1.0, "cells_nodes": nodes_w[i]}
            | {"cells_warm_start": "used" if i else "cold", "cells_heuristic_objective": 45.0}
        )
        short = {**base, "time_limit_s": 5.0}
        rows.append(
            {**short, "method": "bnb", "status": "feasible", "objective": 40.0 + i, "time_s": 5.0}
            | {"cells_solve_time_s": 5.0}
        )
        rows.append(
            {**short, "method": "bnb<ga", "status": "feasible", "objective": 42.0, "time_s": 5.0}
            | {"cells_engine_time_s": 4.0, "cells_heuristic_time_s": 1.0, "cells_warm_start": "used"}
        )
    rows.append({**rows[0], "method": "greedy", "objective": 1.0})  # other methods are ignored
    return pd.DataFrame(rows)


def test_paired_table_by_hand():
    table = warm_start_table(_frame())
    assert list(table["time_limit_s"]) == [5.0, 60.0]
    long = table[table["time_limit_s"] == 60.0].iloc[0]
    assert (long["engine"], long["heuristic"], long["pairs"]) == ("bnb", "ga", 6)
    assert (long["cold_proven"], long["warm_proven"], long["start_used"], long["start_cold"]) == (6, 6, 5, 1)
    # engine time: ratios 2, 1.5, 4/3, 1.25, 0.2, 1 -> median (1.25 + 4/3) / 2
    assert long["engine_time_ratio_median"] == pytest.approx((1.25 + 4 / 3) / 2)
    assert (long["engine_faster"], long["engine_slower"]) == (1, 4)
    # two-sided sign test, 1 of 5: 2 * (C(5,0) + C(5,1)) / 2**5 = 12 / 32
    assert long["engine_time_sign_p"] == pytest.approx(12 / 32)
    # total (heuristic 1 s + engine): 3, 4, 5, 6, 2, 7 against 1..6: slower on 5 of 6 pairs
    assert (long["total_faster"], long["total_slower"]) == (1, 5)
    assert long["total_time_sign_p"] == pytest.approx(2 * (1 + 6) / 64)
    assert long["cold_time_median_s"] == pytest.approx(3.5)
    assert long["warm_total_time_median_s"] == pytest.approx(4.5)
    # nodes: fewer on 5, more on 1; ratios 0.5 x 5 and 70/60
    assert (long["fewer_nodes"], long["more_nodes"]) == (5, 1)
    assert long["nodes_ratio_median"] == pytest.approx(0.5)
    assert long["nodes_sign_p"] == pytest.approx(14 / 64)
    assert long["objective_sign_p"] is None or np.isnan(long["objective_sign_p"])  # all tied
    short = table[table["time_limit_s"] == 5.0].iloc[0]
    # objectives 40..45 cold against 42 warm: warm better on 2 (40, 41), worse on 3 (43, 44, 45)
    assert (short["warm_better"], short["warm_worse"]) == (2, 3)
    assert short["objective_sign_p"] == pytest.approx(1.0)
    assert short["cold_proven"] == 0 and short["warm_proven"] == 0
    assert np.isinf(short["cold_time_median_s"])  # nothing proven: time to proof not reached
    text = warm_start_markdown(table)
    assert text.count("\n") == 3 and "| bnb | ga |" in text


def test_paired_table_unproven_counts_at_the_limit():
    df = _frame()
    df = df[df["time_limit_s"] == 60.0].copy()
    df.loc[(df["method"] == "bnb") & (df["instance"] == "i5"), "status"] = "feasible"
    long = warm_start_table(df).iloc[0]
    assert (long["engine_faster"], long["engine_slower"]) == (2, 4)  # the tie became a warm win
    # ratios 2, 1.5, 4/3, 1.25, 0.2, 6/60 -> median (4/3 + 1.25) / 2 is unchanged
    assert long["engine_time_ratio_median"] == pytest.approx((1.25 + 4 / 3) / 2)


def test_paired_table_refuses_other_input():
    with pytest.raises(TypeError, match="DataFrame"):
        warm_start_table([1, 2])
    with pytest.raises(ValueError, match="time_limit_s"):
        warm_start_table(pd.DataFrame({"method": ["bnb"]}))
    assert warm_start_table(_frame().query("method != 'bnb<ga'")).empty


def test_warm_start_methods():
    assert warm_start_methods("cells", ["bnb", "ga", "greedy"]) == ["bnb", "bnb<ga", "bnb<greedy"]
    assert warm_start_methods("allocation") == ["cp-sat", "cp-sat<alg3", "cp-sat<collision-blind"]
    assert warm_start_methods("cells", ["ga"])[:2] == ["bnb", "milp"]
    with pytest.raises(ValueError, match="heuristic"):
        warm_start_methods("cells", ["bnb"])
    with pytest.raises(ValueError, match="apart"):
        warm_start_methods("cells", ["bnb<ga"])
    with pytest.raises(ValueError, match="warm start"):
        warm_start_methods("shark-fleet")


def test_cli_refuses_warm_starts_elsewhere(tmp_path):
    from droneplan.studies.cli import main

    with pytest.raises(SystemExit, match="warm-starts"):
        main(["gap", "shark", "--warm-starts", "--out", str(tmp_path)])


def test_the_start_is_kept_when_the_engine_stops_worse():
    from droneplan.studies.harness import Scored, _better_of

    start = np.array([[0.0, 0.0]])
    stopped = dp.SolveResult(dp.Status.FEASIBLE, objective=10.0, bound=30.0, x=np.array([[1.0, 1.0]]))
    facts: dict = {}
    kept = _better_of("cells", stopped, start, Scored("feasible", objective=20.0), facts)
    assert facts["kept"] == "heuristic" and kept.objective == 20.0 and kept.bound == 30.0
    assert kept.status is dp.Status.FEASIBLE and kept.x is start
    same = _better_of("cells", stopped, start, Scored("feasible", objective=10.0 - 1e-12), facts)
    assert facts["kept"] == "engine" and same is stopped  # a last-bit difference is a tie


def test_warm_start_study_writes_the_table(tmp_path):
    from droneplan.studies.warm_starts import warm_start_study

    df, table = warm_start_study(
        "cells",
        out=tmp_path,
        methods=["bnb", "greedy"],
        time_limit=30.0,
        short_limit=3.0,
        m=2,
        seeds=1,
        workers=1,
        progress=False,
    )
    assert set(df["method"]) >= {"bnb", "bnb<greedy"}
    assert list(table["time_limit_s"]) == [3.0, 30.0]
    assert (table["pairs"] == 1).all()
    assert (tmp_path / "cells" / "warm_starts.csv").exists()
    assert "| bnb | greedy |" in (tmp_path / "cells" / "warm_starts.md").read_text(encoding="utf-8")
