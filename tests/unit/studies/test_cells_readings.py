"""The GA readings study and the Table 4.3 rows of T_ES as written and P_save."""

import pandas as pd
import pytest

from droneplan.planners.cells import GA_READINGS
from droneplan.studies import cells as study
from droneplan.studies.common import ComparisonTable
from droneplan.studies.report import flag_reasons


def test_readings_study_on_a_small_instance(tmp_path):
    frame = study.ga_readings(seeds=[0], ms=[1], runs=2, readings=["ours", "best-ever"], out=tmp_path)
    assert list(frame["reading"]) == ["ours", "best-ever"]
    assert set(frame.columns) >= {"m", "reading", "label", "reads", "seeds", "runs", "p_global", "mean_gap"}
    assert (frame["runs"] == 2).all() and (frame["seeds"] == 1).all()
    assert frame["p_global"].between(0, 1).all() and (frame["mean_gap"] >= 0).all()
    # paired runs: the best-ever result is never below the final one, so neither is its P_Global
    p = frame.set_index("reading")["p_global"]
    assert p["best-ever"] >= p["ours"]
    csv = pd.read_csv(tmp_path / "ga_readings.csv")
    assert len(csv) == 2
    md = (tmp_path / "ga_readings.md").read_text()
    assert md.startswith("| reading | P_Global m=1 (runs / seeds) |")
    assert "| ours | " in md and "(2 / 1)" in md
    assert frame.attrs["markdown"] == md


def test_readings_tasks_are_paired_and_checked():
    tasks = study.readings_tasks(seeds=[0, 1], ms=[1, 2], runs=3)
    assert len(tasks) == 2 * 2 * 3 * len(GA_READINGS)
    seeds_of = {}
    for t in tasks:
        seeds_of.setdefault((t["m"], t["seed"], t["run_seed"]), set()).add(t["reading"])
    assert all(v == set(GA_READINGS) for v in seeds_of.values())  # run r: one seed for every reading
    with pytest.raises(ValueError, match="readings"):
        study.readings_tasks(seeds=[0], ms=[1], runs=1, readings=["nope"])


def test_proven_optimum_comes_from_the_library():
    assert study.proven_optimum(1, 0) == 24.0  # table4.2 m=1 seed 0, certified


def test_readings_markdown_of_nothing():
    assert study.readings_markdown(pd.DataFrame()) == "(no runs)\n"


def test_table_4_3_has_t_es_as_written_and_p_save():
    task = {
        "problem": "cells",
        "instance": "table4.3:m=1,seed=0,test",
        "kind": "exact",
        "m": 1,
        "seed": 0,
        "exact_limit": 60.0,
        "es_limit": 20.0,
    }
    rows = study.reproduce_task(task)
    ga_task = {
        "problem": "cells",
        "instance": "table4.3-ga:m=1,run=0,seed=0,test",
        "kind": "ga",
        "m": 1,
        "seed": 0,
        "run_seed": 0,
        "pop_size": 20,
        "restarts": 3,
    }
    rows += study.reproduce_task(ga_task)
    df = pd.DataFrame(rows)
    by = df.set_index("method")
    assert by.loc["exhaustive-plain", "objective"] == by.loc["exhaustive", "objective"]
    tab = ComparisonTable("Table 4.3 - test", explain=flag_reasons("cells"))
    raw = study._table_4_3_row(tab, 1, df, task, [ga_task], 20.0)
    t_ga, t_es = float(by.loc["ga", "time_s"]), float(by.loc["exhaustive-plain", "time_s"])
    assert raw["p_save"] == pytest.approx(1.0 - t_ga / t_es)
    quantities = [r["quantity"] for r in tab.rows]
    assert "m=1 T_ES, Algorithm 2 as written (s)" in quantities
    assert "m=1 T_ES, bound-pruned (s)" in quantities
    assert "m=1 P_save (1 - GA time / ES time)" in quantities
    assert not tab.unexplained()
