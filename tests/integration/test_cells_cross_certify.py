"""Cross-certification of the two exact cells engines (``studies.library.cross``) on a CI-sized
subset of the library, and its loud failure (with the instance saved) on a disagreement."""

import json

import numpy as np
import pytest

from droneplan.studies.instances import load_instance
from droneplan.studies.library import cross
from droneplan.studies.library.cross import CrossCertificationError, cross_certify


def test_both_engines_agree_with_each_other_the_checker_and_the_library(tmp_path):
    log = tmp_path / "log.jsonl"
    s = cross_certify("table4.2", m=[1, 2, 3], seeds=2, time_limit=60, directory=tmp_path / "bad", log=log)
    assert s["instances"] == 6 and not s["disagreements"] and not (tmp_path / "bad").exists()
    assert s["both_proven"] == s["bnb_proven"] == s["milp_proven"] == 6
    # every library entry at m <= 3 is proven: each optimum was compared with it
    assert s["library_matched"] == 6
    recs = [json.loads(line) for line in log.read_text().splitlines()]
    assert [r["id"] for r in recs] == [f"table4.2@1:m={m},seed={k}" for m in (1, 2, 3) for k in (0, 1)]
    for r in recs:
        values = {r["engines"][e]["checked"] for e in ("bnb", "milp")} | {r["library"]["value"]}
        assert len(values) == 1


def _lying_milp(monkeypatch, how):
    real = cross._run_engine

    def run(problem, engine, time_limit, backend, workers):
        out = real(problem, engine, time_limit, backend, workers)
        if engine == "milp":
            how(out)
        return out

    monkeypatch.setattr(cross, "_run_engine", run)


@pytest.mark.parametrize(
    ("how", "message"),
    [
        (lambda o: o.update(checked=o["checked"] + 1, objective=o["objective"] + 1), "proven optima differ"),
        (lambda o: o.update(objective=o["objective"] + 1), "the checker counts"),
        (lambda o: o.update(bound=o["checked"] - 1, proven=False), "bound"),
    ],
)
def test_a_disagreement_fails_loudly_and_saves_the_instance(tmp_path, monkeypatch, how, message):
    _lying_milp(monkeypatch, how)
    with pytest.raises(CrossCertificationError, match=message):
        cross_certify("table4.2", m=2, seeds=[3], time_limit=30, directory=tmp_path)
    saved = load_instance(tmp_path / "table4.2_1_m=2_seed=3.json")
    assert saved.id == "table4.2@1:m=2,seed=3"
    results = json.loads((tmp_path / "table4.2_1_m=2_seed=3.results.json").read_text())
    assert any(message in d for d in results["disagreements"])
    # the saved data is the instance itself: the engines find the library's value on it again
    plan = np.asarray(results["engines"]["bnb"]["plan"])
    from droneplan.formulations.cells import evaluate

    assert evaluate(saved.data, plan).covered == results["library"]["value"]


def test_an_infeasible_plan_is_a_disagreement_and_strict_false_only_reports(tmp_path, monkeypatch):
    def infeasible(o):
        o.update(checked=None, violations=["backhaul: cell 0 unreachable"])

    _lying_milp(monkeypatch, infeasible)
    s = cross_certify("table4.2", m=1, seeds=[0], time_limit=30, directory=tmp_path, strict=False)
    assert list(s["disagreements"]) == ["table4.2@1:m=1,seed=0"]
    assert "milp: its plan is infeasible" in s["disagreements"]["table4.2@1:m=1,seed=0"][0]
    assert s["saved"] and load_instance(s["saved"][0]).id == "table4.2@1:m=1,seed=0"


def test_bad_arguments_name_the_parameter():
    with pytest.raises(ValueError, match="cells family"):
        cross_certify("allocation", m=1, seeds=1)
    with pytest.raises(ValueError, match="workers"):
        cross_certify("table4.2", m=1, seeds=1, workers=0)
    with pytest.raises(ValueError, match="time_limit"):
        cross_certify("table4.2", m=1, seeds=1, time_limit=-1)


def test_the_command_line_entry(tmp_path, capsys, monkeypatch):
    import argparse

    parser = cross.add_arguments(argparse.ArgumentParser())
    args = parser.parse_args(["--m", "1,2", "--seeds", "1", "--time-limit", "30", "--out", str(tmp_path)])
    assert cross.run(args) == 0
    out = capsys.readouterr().out
    assert "2 instances; both engines proved 2" in out and "0 disagreements" in out
    _lying_milp(monkeypatch, lambda o: o.update(objective=o["objective"] + 1))
    assert cross.run(parser.parse_args(["--m", "1", "--seeds", "1", "--out", str(tmp_path)])) == 1
    assert "DISAGREEMENT table4.2@1:m=1,seed=0" in capsys.readouterr().err
    with pytest.raises(ValueError, match="--m"):
        cross.run(parser.parse_args(["--m", "a,b"]))


def test_droneplan_cross_certify_command(tmp_path, capsys):
    from droneplan.studies import cli

    code = cli.main(
        ["cross-certify", "--m", "1", "--seeds", "1", "--time-limit", "10", "--out", str(tmp_path)]
    )
    assert code == 0
    assert "0 disagreements" in capsys.readouterr().out
    assert cli.main(["cross-certify", "no-such-family"]) == 2
    assert "family must be a cells family" in capsys.readouterr().err
