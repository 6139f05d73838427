"""The instance kinds: one class each, registered in one place, and enough to add a kind.

A toy kind is added the way the architecture page says (one class plus its registration), and a
gap study then runs on its instances: instance files, the method contract, droneplan's scoring and
the store, with no other edit to the engine.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
import pytest

import droneplan as dp
from droneplan.studies import kinds
from droneplan.studies.instances import (
    FAMILIES,
    KINDS,
    PROBLEM_OF_KIND,
    load_instance,
    save_instance,
)
from droneplan.studies.kinds.base import Family, InstanceLike, Kind, MethodLike, MethodRunner
from droneplan.studies.scoring import Scored, number, unwrap


def test_every_kind_is_one_registered_class_with_its_families():
    assert list(kinds.KINDS) == list(KINDS)
    for name, kind in kinds.KINDS.items():
        assert isinstance(kind, Kind) and kind.name == name
        assert (
            kind.problem in ("cells", "herding", "shark", "covert") and PROBLEM_OF_KIND[name] == kind.problem
        )
        assert kind.sense in ("max", "min")
        for family in kind.families():
            held = FAMILIES[family.name]
            assert (held.kind, held.version, held.describe) == (family.kind, family.version, family.describe)
            assert (family.kind, family.problem) == (kind.name, kind.problem)
    owned = [f.name for k in kinds.KINDS.values() for f in k.families()]
    assert sorted(owned) == sorted(FAMILIES), "every family belongs to exactly one kind"


def test_the_views_of_the_kind_classes_agree_with_them():
    from droneplan.studies.harness import SENSE_OF_KIND, STATIC_KINDS
    from droneplan.studies.methods import CLOSED_LOOP_KINDS, default_methods

    assert {n: k.sense for n, k in kinds.KINDS.items()} == SENSE_OF_KIND
    assert set(STATIC_KINDS) | set(CLOSED_LOOP_KINDS) == set(kinds.KINDS)
    assert not set(STATIC_KINDS) & set(CLOSED_LOOP_KINDS)
    assert default_methods("shark-fleet") == ["bottleneck", "greedy-nearest"]


def test_a_user_object_is_recognised_by_its_kind_and_others_are_refused():
    problem = dp.cells.thesis_problem(n_cells=1, seed=0)
    assert kinds.kind_of_data(problem).name == "cells"
    with pytest.raises(TypeError, match="an instance must be"):
        kinds.kind_of_data(object())
    with pytest.raises(ValueError, match="kind must be one of"):
        kinds.kind_named("no-such-kind")


@pytest.mark.parametrize(
    ("bad", "words"),
    [
        (object(), "kind must be an instance of a Kind subclass"),
        ("cells", "kind must be an instance"),
    ],
)
def test_register_kind_refuses_what_is_not_a_kind(bad, words):
    with pytest.raises(TypeError, match=words):
        kinds.register_kind(bad)


def test_register_kind_refuses_a_taken_name():
    with pytest.raises(ValueError, match="registered already"):
        kinds.register_kind(type(kinds.KINDS["cells"])())


# --------------------------------------------------------------------------- a kind added from outside
@dataclass(frozen=True)
class Prizes:
    """Prizes (values) to pick one of; the toy kind's data."""

    values: np.ndarray


class PickKind(Kind):
    """Pick the index of the largest prize: methods are called ``fn(values, *, seed, time_limit)``."""

    name = "toy-pick"
    problem = "herding"
    sense = "max"
    data_type = Prizes
    objective = "the prize picked"

    def encode(self, data: Any) -> dict | None:
        return {"values": np.asarray(data.values, dtype=float).tolist()}

    def decode(self, payload: Mapping[str, Any]) -> Any:
        return Prizes(np.asarray(payload["values"], dtype=float))

    def size(self, data: Any) -> int:
        return len(data.values)

    def arguments(self, data: Any) -> tuple[Any, ...]:
        return (data.values.copy(),)

    def score(self, instance: InstanceLike, returned: Any, method: MethodLike) -> Scored:
        scored = Scored("feasible")
        plan, has = unwrap(returned, method, scored)
        if not has:
            return scored
        index = number(plan)
        values = instance.data.values
        if index is None or index != int(index) or not 0 <= index < len(values):
            return Scored("invalid", message=f"an index in 0..{len(values) - 1} is expected, got {plan!r}")
        scored.objective = float(values[int(index)])
        return scored

    def certify(
        self, instance: InstanceLike, *, time_limit: float | None, run: MethodRunner
    ) -> dict[str, Any]:
        values = instance.data.values
        best = float(values.max())
        return {
            "value": best,
            "bound": best,
            "bound_kind": "proven-global",
            "status": "optimal",
            "sense": "max",
            "plan": int(values.argmax()),
            "engine": "max",
            "time_s": 0.0,
            "message": "",
        }

    def families(self) -> tuple[Family, ...]:
        def build(n: int, seed: int) -> Prizes:
            return Prizes(np.random.default_rng(seed).uniform(0, 10, n))

        return (self.family("toy-prizes", 1, {"n": (3,)}, build, "n uniform prizes in [0, 10)"),)


def first(values, *, seed, time_limit):
    return 0


def best(values, *, seed, time_limit):
    return int(np.argmax(values))


@pytest.fixture
def toy_kind(monkeypatch):
    monkeypatch.setattr(kinds, "_REGISTERED", list(kinds._REGISTERED))
    monkeypatch.setattr(kinds, "KINDS", dict(kinds.KINDS))
    monkeypatch.setattr(kinds, "FAMILIES", dict(kinds.FAMILIES))
    import droneplan.studies.instances as instances
    import droneplan.studies.methods as methods

    monkeypatch.setattr(instances, "_KIND_CLASSES", kinds.KINDS)
    monkeypatch.setattr(instances, "FAMILIES", kinds.FAMILIES)
    monkeypatch.setattr(methods, "KINDS", kinds.KINDS)
    return kinds.register_kind(PickKind())


def test_a_kind_added_by_one_class_and_its_registration_runs_a_gap_study(toy_kind, tmp_path):
    from droneplan.studies.instances import family_instances

    insts = family_instances("toy-prizes", n=[4], seeds=2)
    assert [i.kind for i in insts] == ["toy-pick", "toy-pick"] and insts[0].size == 4
    path = save_instance(insts[0], tmp_path / "one.json")
    assert load_instance(path).fingerprint() == insts[0].fingerprint()
    rows = dp.gap(
        "herding",
        methods=[first, best],
        instances=insts,
        out=tmp_path / "out",
        workers=1,
        progress=False,
        reference="none",
    )
    got = rows.set_index(["instance", "method"])["objective"]
    for inst in insts:
        values = inst.data.values
        assert got[(inst.id, "best")] == pytest.approx(values.max())
        assert got[(inst.id, "first")] == pytest.approx(values[0])


def test_register_kind_refuses_a_family_name_that_is_taken(toy_kind):
    class Clash(PickKind):
        name = "toy-clash"

    with pytest.raises(ValueError, match=r"kind\.families"):
        kinds.register_kind(Clash())
