"""The GA readings study and the Table 4.3 rows of T_ES as written and P_save."""

import pandas as pd
import pytest

from droneplan.planners.cells import GA_READINGS
from droneplan.studies.common import ComparisonTable
from droneplan.studies.thesis import cells as study
from droneplan.studies.thesis.report import flag_reasons


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


def test_readings_are_gap_methods_with_paired_runs(tmp_path):
    from droneplan.studies.store import ResultStore

    study.ga_readings(seeds=[0], ms=[1], runs=2, readings=["ours", "no-annealing"], out=tmp_path)
    with ResultStore(tmp_path / "results.sqlite") as st:
        rows = st.frame()
    ga = rows[rows["method"].str.startswith("ga-reading-")]
    assert set(ga["method"]) == {"ga-reading-ours", "ga-reading-no-annealing"} and len(ga) == 4
    assert (ga.groupby("run")["run_seed"].nunique() == 1).all()  # run r: one seed for every reading
    assert list(rows[rows["method"] == "library"]["status"]) == ["optimal"]  # the reference
    with pytest.raises(ValueError, match="readings"):
        study.ga_readings(seeds=[0], ms=[1], runs=1, readings=["nope"])
    assert len(GA_READINGS) > 2


def test_proven_optimum_comes_from_the_library():
    assert study.proven_optimum(1, 0) == 24.0  # table4.2 m=1 seed 0, certified


def test_readings_markdown_of_nothing():
    assert study.readings_markdown(pd.DataFrame()) == "(no runs)\n"


def test_table_4_3_has_t_es_as_written_and_p_save(tmp_path):
    from droneplan.studies.methods import BUILTIN
    from droneplan.studies.store import ResultStore
    from droneplan.studies.thesis.cells_ga import GapPart, es_method, gap_rows, run_seconds

    task = {"problem": "cells", "instance": "table4.3:m=1,seed=0,test", "kind": "exact", "m": 1, "seed": 0}
    exact = pd.DataFrame(study.reproduce_task({**task, "exact_limit": 60.0}))
    methods = (BUILTIN["ga"], BUILTIN["ga-polished"], es_method(20.0), es_method(20.0, prune=False))
    with ResultStore(tmp_path / "results.sqlite") as st:
        rows = gap_rows([GapPart("table4.2", 1, (0,), methods, 2)], store=st)
    by = rows[rows["run"] == 0].set_index("method")
    assert by.loc["exhaustive-plain@20s", "objective"] == by.loc["exhaustive@20s", "objective"]
    tab = ComparisonTable("Table 4.3 - test", explain=flag_reasons("cells"))
    raw = study._table_4_3_row(tab, 1, rows, exact, 20.0)
    ga_s, clock = run_seconds(rows[rows["method"] == "ga"])
    es_s, es_clock = run_seconds(rows[(rows["method"] == "exhaustive-plain@20s") & (rows["run"] == 0)])
    assert clock == es_clock == "the method's own clock"  # the rows carry the methods' solve times
    t_ga, t_es = float(ga_s.mean()), float(es_s.iloc[0])
    assert raw["p_save"] == pytest.approx(1.0 - t_ga / t_es)
    assert raw["exact_obj"] == 24.0  # the certified optimum of table4.2 m=1 seed 0
    # the polished runs are the GA's runs (same seeds), polishing never loses users
    ga, pol = (
        rows[rows["method"] == n].sort_values("run")["objective"].to_numpy() for n in ("ga", "ga-polished")
    )
    assert (pol >= ga).all()
    quantities = [r["quantity"] for r in tab.rows]
    assert "m=1 T_ES, Algorithm 2 as written (s)" in quantities
    assert "m=1 T_ES, bound-pruned (s)" in quantities
    assert "m=1 P_save (1 - GA time / ES time)" in quantities
    assert not tab.unexplained()
