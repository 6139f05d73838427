"""A reference for every instance: studies solve what the certified library lacks, keep it, and use it."""

from __future__ import annotations

import math

import numpy as np
import pytest

import droneplan as dp
from droneplan.formulations.cells import evaluate, solve_exact
from droneplan.planners.cells import exhaustive
from droneplan.studies import references
from droneplan.studies.instances import family_instances
from droneplan.studies.library import load_library
from droneplan.studies.store import REFERENCE_METHOD

pytestmark = pytest.mark.slow

OFF_LIBRARY = {"m": 2, "seeds": 2, "first_seed": 7100}
"""Table 4.2 instances the shipped library does not hold (it has seeds 0-99)."""


def _study(tmp_path, methods=("greedy",), **kw):
    return dp.gap("cells", methods=list(methods), out=tmp_path, progress=False, **OFF_LIBRARY, **kw)


def test_an_instance_outside_the_library_gets_a_solved_reference_that_the_other_engine_confirms(tmp_path):
    df = _study(tmp_path)
    ref = df[df["method"] == REFERENCE_METHOD].set_index("instance")
    greedy = df[df["method"] == "greedy"].set_index("instance")
    assert len(ref) == 2 and set(ref["role"]) == {"bound"} and set(ref["status"]) == {"optimal"}
    for inst in family_instances("table4.2", **OFF_LIBRARY):
        # oracles: the MILP (the other exact engine) proves the same optimum; the thesis's
        # exhaustive search never covers more
        milp = solve_exact(inst.data, engine="milp", workers=1)
        row = ref.loc[inst.id]
        assert milp.status.name == "OPTIMAL" and row["objective"] == milp.objective == row["bound"]
        assert evaluate(inst.data, exhaustive(inst.data).x).value <= row["objective"]
        g = greedy.loc[inst.id]
        assert g["gap_to_bound"] == pytest.approx((row["bound"] - g["objective"]) / row["bound"])
    table = dp.summary_table(df)
    assert list(table["method"]) == ["greedy"]  # the reference is no method of the study
    assert table["target_kind"].iloc[0] == "proven"
    hits = (greedy["objective"] >= ref.loc[greedy.index, "objective"]).mean()
    assert table["success_rate"].iloc[0] == pytest.approx(hits)


def test_a_solved_reference_is_kept_under_out_and_read_back_without_solving(tmp_path, monkeypatch):
    _study(tmp_path)
    kept = load_library("table4.2", tmp_path / references.LOCAL_LIBRARY)
    assert len(kept) == 2 and {e.status for e in kept.values()} == {"optimal"}

    def no_solve(*args, **kwargs):
        raise AssertionError("the reference was solved again")

    monkeypatch.setattr("droneplan.studies.library.certify.certifications", no_solve)
    again = _study(tmp_path, methods=("greedy", "ga"))
    assert (again["method"] == REFERENCE_METHOD).sum() == 2


def test_reference_none_solves_nothing_and_counts_the_unproven(tmp_path, capsys):
    df = _study(tmp_path, reference="none")
    assert REFERENCE_METHOD not in set(df["method"])
    assert df["gap_to_bound"].isna().all()
    assert "2 of 2 instances have no proven reference" in capsys.readouterr().err
    assert not (tmp_path / references.LOCAL_LIBRARY).exists()


def test_a_study_running_the_exact_engine_or_on_library_instances_solves_no_reference(tmp_path):
    with_engine = _study(tmp_path / "a", methods=("greedy", "bnb"))
    assert REFERENCE_METHOD not in set(with_engine["method"])
    assert with_engine[with_engine["method"] == "greedy"]["gap_to_bound"].notna().all()
    lib = dp.gap("cells", methods=["greedy"], m=2, seeds=1, out=tmp_path / "b", progress=False)
    assert set(lib["method"]) == {"greedy", "library"}


@pytest.mark.parametrize(
    ("problem", "family", "size", "method"),
    [
        ("herding", "allocation", {"n": 5, "first_seed": 100}, "alg3"),
        ("shark", "random-fleet", {}, "greedy-nearest"),
    ],
)
def test_allocation_and_shark_fleets_get_proven_references(tmp_path, problem, family, size, method):
    df = dp.gap(problem, methods=[method], instances=family, seeds=2, out=tmp_path, progress=False, **size)
    ref = df[df["method"] == REFERENCE_METHOD]
    assert len(ref) == 2 and set(ref["bound_kind"]) == {"proven-global"}
    rows = df[df["method"] == method].set_index("instance")
    for _, r in ref.iterrows():  # a minimisation: no method beats the proven optimum
        assert rows.loc[r["instance"], "objective"] >= r["bound"] - 1e-9
        assert math.isfinite(rows.loc[r["instance"], "gap_to_bound"])
    assert dp.summary_table(df)["target_kind"].iloc[0] == "proven"


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"reference": "maybe"}, "reference must be one of 'auto', 'none'"),
        ({"reference": True}, "reference must be one of"),
        ({"reference_time_limit": 0}, "reference_time_limit must be"),
        ({"reference_time_limit": float("nan")}, "reference_time_limit must be"),
        ({"reference_time_limit": "10"}, "reference_time_limit must be"),
        ({"methods": [("reference", lambda problem, *, seed, time_limit: np.zeros((1, 2)))]}, "reserved"),
    ],
)
def test_bad_reference_settings_are_refused_in_one_line(tmp_path, kwargs, message):
    kw = {"methods": ["greedy"], **kwargs}
    with pytest.raises((ValueError, TypeError)) as err:
        dp.gap("cells", out=tmp_path, progress=False, m=1, seeds=1, first_seed=7100, **kw)
    assert message in str(err.value) and "\n" not in str(err.value)
    assert not (tmp_path / references.LOCAL_LIBRARY).exists()
