"""Instance families, stable ids, fingerprints and the one-file JSON format."""

from __future__ import annotations

import json

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from droneplan.scenarios.cells import CellProblem, thesis_problem
from droneplan.studies.instances import (
    FAMILIES,
    AllocationInstance,
    InstanceFileError,
    as_instance,
    family_instances,
    load_instance,
    load_instances,
    resolve_instances,
    save_instance,
)


def test_family_ids_are_stable_and_data_matches_the_generator():
    (inst,) = family_instances("table4.2", m=4, seeds=[3])
    assert inst.id == "table4.2@1:m=4,seed=3"
    assert inst.size == 4 and inst.seed == 3
    direct = thesis_problem(4, 3)
    np.testing.assert_array_equal(inst.data.users, direct.users)
    again = family_instances("table4.2", m=4, seeds=[3])[0]
    assert again.fingerprint() == inst.fingerprint()


def test_family_grid_and_seed_count():
    insts = family_instances("allocation", n=[2, 8], seeds=3, first_seed=5)
    assert [i.id for i in insts] == [f"allocation@1:n={n},seed={s}" for n in (2, 8) for s in (5, 6, 7)]
    assert {i.problem for i in insts} == {"herding"} and {i.kind for i in insts} == {"allocation"}


def test_other_families_build():
    dense = family_instances("table4.2-dense", m=3, seeds=[0])[0].data
    base = thesis_problem(3, 0)
    assert len(dense.users) > 1.5 * len(base.users)  # twice the densities
    clusters = family_instances("table4.2-clusters", m=2, seeds=[0])[0].data
    assert isinstance(clusters, CellProblem)
    paths = family_instances("table5.1")
    assert [p.id for p in paths] == [f"table5.1@1:path={k}" for k in "abcd"]


def test_unknown_family_and_size_names():
    with pytest.raises(ValueError, match="unknown instance family 'nope'"):
        family_instances("nope")
    with pytest.raises(ValueError, match="has no size parameter n"):
        family_instances("table4.2", n=3)
    with pytest.raises(ValueError, match="neither an instance family"):
        resolve_instances("cells", "no-such-family-or-file")


@pytest.mark.parametrize("family", ["table4.2", "allocation", "table5.1"])
def test_json_round_trip(tmp_path, family):
    inst = family_instances(family)[0]
    path = save_instance(inst, tmp_path / "one.json")
    back = load_instance(path)
    assert back.id == inst.id and back.fingerprint() == inst.fingerprint() and back.kind == inst.kind
    gz = save_instance(inst, tmp_path / "one.json.gz")
    assert load_instance(gz).fingerprint() == inst.fingerprint()
    assert [i.id for i in load_instances(tmp_path)] == [inst.id, inst.id]  # one.json and one.json.gz


def test_directory_of_instances_and_user_ids(tmp_path):
    p = thesis_problem(2, 1)
    user = as_instance(p, name="my-town")
    assert user.id == f"user:my-town#{user.fingerprint()[:8]}" and user.family == "user"
    anon = as_instance(p)
    assert anon.id == f"user:{anon.fingerprint()}"
    save_instance(user, tmp_path / "a.json")
    save_instance(family_instances("table4.2", m=1)[0], tmp_path / "b.json")
    loaded = resolve_instances("cells", tmp_path)
    assert [i.id for i in loaded] == [user.id, "table4.2@1:m=1,seed=0"]
    np.testing.assert_array_equal(loaded[0].data.users, p.users)


def test_bad_instance_files(tmp_path):
    (tmp_path / "junk.json").write_text("{not json")
    with pytest.raises(InstanceFileError, match="not a readable instance file"):
        load_instance(tmp_path / "junk.json")
    (tmp_path / "foreign.json").write_text(json.dumps({"format": "other"}))
    with pytest.raises(InstanceFileError, match="not a droneplan instance"):
        load_instance(tmp_path / "foreign.json")
    inst = family_instances("allocation", n=4)[0]
    d = inst.to_dict()
    d["data"]["perimeter"] = d["data"]["perimeter"] * 2  # edited data, stale fingerprint
    (tmp_path / "edited.json").write_text(json.dumps(d))
    with pytest.raises(InstanceFileError, match="does not match its fingerprint"):
        load_instance(tmp_path / "edited.json")
    d = inst.to_dict()
    d["data"]["drone_s"] = ["x"] * 4
    d.pop("fingerprint")
    (tmp_path / "bad.json").write_text(json.dumps(d))
    with pytest.raises(InstanceFileError, match="bad allocation data"):
        load_instance(tmp_path / "bad.json")
    (tmp_path / "nan.json").write_text(json.dumps(inst.to_dict()).replace("0.", "NaN", 1))
    with pytest.raises(InstanceFileError):
        load_instance(tmp_path / "nan.json")


def test_mixed_problems_and_duplicates_are_refused():
    a = family_instances("allocation", n=4)[0]
    with pytest.raises(ValueError, match="another problem"):
        resolve_instances("cells", [a])
    with pytest.raises(ValueError, match="repeat ids"):
        resolve_instances("herding", [a, a])


def test_allocation_instance_validation():
    with pytest.raises(ValueError, match="drone_s must lie in"):
        AllocationInstance(np.array([0.0, 12.0]), np.array([1.0]), 10.0)
    with pytest.raises(ValueError, match="only 1 drones"):
        AllocationInstance(np.array([0.0]), np.array([1.0, 2.0]), 10.0)


@settings(max_examples=25, deadline=None)
@given(st.lists(st.floats(0, 99.999), min_size=1, max_size=8), st.data())
def test_fingerprint_tracks_the_data(drones, data):
    steer = data.draw(st.lists(st.floats(0, 99.999), min_size=1, max_size=len(drones)))
    inst = as_instance(AllocationInstance(np.array(drones), np.array(steer), 100.0))
    back = as_instance(AllocationInstance(np.array(drones), np.array(steer), 100.0))
    assert inst.fingerprint() == back.fingerprint()
    moved = as_instance(AllocationInstance(np.array(drones), np.array(steer), 100.5))
    assert moved.fingerprint() != inst.fingerprint()


def test_every_family_is_documented():
    for fam in FAMILIES.values():
        assert fam.describe and fam.version >= 1 and fam.problem in ("cells", "herding", "shark", "covert")
