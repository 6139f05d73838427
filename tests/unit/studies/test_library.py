"""The certified reference library shipped in the package: every stored plan re-evaluated by
droneplan's evaluator to its stored value, and a sample re-proven (slow)."""

from __future__ import annotations

import numpy as np
import pytest

from droneplan.formulations.cells import evaluate
from droneplan.formulations.herding import Allocation, check_allocation, pad_steering_points
from droneplan.studies.instances import family_instances
from droneplan.studies.library import (
    LIBRARY_FAMILIES,
    certify_instance,
    library_instances,
    load_library,
    lookup,
    save_library,
)
from droneplan.studies.library.certify import certify

SHIPPED = [f for f in LIBRARY_FAMILIES if load_library(f)]


VARIANT_FAMILIES = ("table4.2-weighted", "table4.2-nofly", "table4.2-capacity", "table4.2-3d")
MODEL_FAMILIES = (*VARIANT_FAMILIES, "table4.2-mobile", "min-fleet")
"""The cells families certified by a model on one worker (variants, moving users, fleet size)."""


def test_the_package_ships_a_library():
    assert {"table4.2", "allocation", *MODEL_FAMILIES} <= set(SHIPPED)


@pytest.mark.parametrize("family", MODEL_FAMILIES)
def test_each_model_family_holds_every_instance_it_lists(family):
    """Every size and seed ``LIBRARY_FAMILIES`` lists has an entry (proven or with its bound)."""
    entries = load_library(family)
    wanted = {inst.id for inst in library_instances(family)}
    assert len(wanted) >= 40 and wanted <= set(entries)


def _check_cells(inst, entry):
    """The plan ((k, 2), or (k, 3) with altitude levels) is feasible and worth the entry's value
    (covered users; a variant's covered or served weight)."""
    ev = evaluate(inst.data, np.asarray(entry.plan, dtype=float).reshape(-1, inst.data.plan_width))
    assert ev.feasible, (entry.id, ev.violations)
    assert ev.value == pytest.approx(entry.value, abs=1e-9), entry.id
    if not inst.data.variants:
        assert ev.covered == entry.value, entry.id


def _check_by_the_harness(inst, entry):
    """A moving-users or fleet-size plan, scored as a study scores a method's plan."""
    from droneplan.studies.harness import score
    from droneplan.studies.methods import Method

    verdict = score(inst, Method("stored", lambda *a, **k: None), np.asarray(entry.plan, dtype=float))
    assert verdict.status == "feasible", (entry.id, verdict.message)
    assert verdict.objective == pytest.approx(entry.value, abs=1e-9), entry.id


def _check_allocation(inst, entry):
    d = inst.data
    n = d.n
    points = pad_steering_points(d.steer_s, n, d.perimeter)
    target, direction = np.asarray(entry.plan["target"]), np.asarray(entry.plan["direction"])
    dest = points[target]
    travel = np.where(
        direction > 0, np.mod(dest - d.drone_s, d.perimeter), np.mod(d.drone_s - dest, d.perimeter)
    )
    value = check_allocation(d.drone_s, d.steer_s, d.perimeter, Allocation(target, direction, travel, points))
    assert value == pytest.approx(entry.value, abs=1e-9 * d.perimeter), entry.id


@pytest.mark.parametrize("family", SHIPPED)
def test_every_stored_plan_re_evaluates_to_its_value(family):
    entries = load_library(family)
    checked = 0
    for inst in library_instances(family):
        entry = entries.get(inst.id)
        if entry is None:
            continue
        assert lookup(inst) == entry  # the fingerprint matches the regenerated data
        assert entry.status in ("optimal", "feasible")
        if entry.bound is not None:
            worse = (
                entry.value > entry.bound + 1e-9 if entry.sense == "max" else entry.value < entry.bound - 1e-9
            )
            assert not worse, f"{entry.id}: value {entry.value} beats its own bound {entry.bound}"
            assert (entry.status == "optimal") == (entry.gap is not None and abs(entry.gap) <= 1e-9)
        if inst.kind == "cells":
            _check_cells(inst, entry)
        elif inst.kind in ("cells-mobile", "cells-fleet"):
            _check_by_the_harness(inst, entry)
        elif inst.kind == "allocation":
            _check_allocation(inst, entry)
        checked += 1
    assert checked == len(entries)


def test_lookup_refuses_other_data_under_the_same_id(tmp_path):
    inst = family_instances("allocation", n=3, seeds=[0])[0]
    fields = certify_instance(inst, time_limit=10)
    from droneplan.studies.library import entry_from

    entry = entry_from(inst, fields, time_limit=10, prov={"droneplan_version": "x", "git_commit": None})
    save_library("allocation", {inst.id: entry}, tmp_path)
    assert lookup(inst, tmp_path) == entry
    forged = entry.__class__(**{**entry.__dict__, "fingerprint": "0" * 16})
    save_library("allocation", {inst.id: forged}, tmp_path)
    assert lookup(inst, tmp_path) is None


def test_certify_resumes_and_records_provenance(tmp_path):
    s1 = certify(
        "allocation", n=[3, 4], seeds=2, directory=tmp_path, workers=1, progress=False, time_limit=10
    )
    assert s1["certified"] == 4 and s1["proven"] == 4 and not s1["failed"]
    s2 = certify(
        "allocation", n=[3, 4], seeds=2, directory=tmp_path, workers=1, progress=False, time_limit=10
    )
    assert s2["certified"] == 0 and s2["entries"] == 4
    e = next(iter(load_library("allocation", tmp_path).values()))
    assert e.droneplan_version and e.certified_at and "exact" in e.engine
    with pytest.raises(ValueError, match="no certified library"):
        certify("table6.2", directory=tmp_path)


RE_PROVE_ALL_UP_TO = {
    "table4.2": ("m", 2),
    "allocation": ("n", 12),
}
"""Every entry up to this size is re-proven by the slow test; a rotating sample of the rest."""

SAMPLED = {"table4.2": 6, "allocation": 6}
"""Larger entries the slow test re-proves per family."""

MODEL_SAMPLE = 1
"""Entries of the smallest size of each model family the slow test re-proves (a rotating draw)."""


def _size_of(entry_id: str, key: str) -> int:
    return int(entry_id.split(f"{key}=")[1].split(",")[0])


@pytest.mark.slow
@pytest.mark.parametrize("family", [f for f in RE_PROVE_ALL_UP_TO if f in SHIPPED])
def test_entries_are_re_proven_all_small_and_a_rotating_sample(family):
    """Re-certify every entry up to the size budget and ``SAMPLED`` larger ones drawn with a seed that
    changes every day (``DRONEPLAN_LIBRARY_SEED`` repeats a draw); a forged entry (a worse plan
    marked optimal) fails here, wherever it sits, within a few days."""
    import os
    import time

    from droneplan.studies.library.certify import entry_disagrees

    key, budget = RE_PROVE_ALL_UP_TO[family]
    entries = load_library(family)
    seed = int(os.environ.get("DRONEPLAN_LIBRARY_SEED", int(time.time() // 86400)))
    print(f"\nlibrary re-proof of {family}: sample seed {seed} (DRONEPLAN_LIBRARY_SEED={seed} repeats it)")
    small = [i for i in library_instances(family) if i.id in entries and _size_of(i.id, key) <= budget]
    large = [i for i in library_instances(family) if i.id in entries and _size_of(i.id, key) > budget]
    rng = np.random.default_rng(seed)
    size = min(SAMPLED.get(family, 1), len(large))
    sample = [large[k] for k in rng.choice(len(large), size=size, replace=False)]
    assert small
    for inst in [*small, *sample]:
        why = entry_disagrees(entries[inst.id], certify_instance(inst, time_limit=120))
        assert not why, f"{inst.id}: {why} (sample seed {seed})"


@pytest.mark.slow
@pytest.mark.parametrize("family", [f for f in ("table5.1", "random-path") if f in SHIPPED])
def test_shark_entries_replay_to_their_contact_time(family):
    from droneplan.studies.harness import execute, score
    from droneplan.studies.methods import BUILTIN

    entries = load_library(family)
    for inst in library_instances(family):
        entry = entries.get(inst.id)
        if entry is None:
            continue
        assert entry.bound is None and entry.status == "feasible"  # no bound is proven for the closed loop
        method = BUILTIN[entry.plan["controller"]]
        verdict = score(inst, method, execute(inst, method, 0, None))
        assert verdict.status == "feasible" and verdict.objective == pytest.approx(entry.value, abs=1e-9), (
            inst.id
        )


@pytest.mark.slow
@pytest.mark.parametrize("family", [f for f in MODEL_FAMILIES if f in SHIPPED])
def test_model_family_entries_are_re_proven_in_a_rotating_sample(family):
    """``MODEL_SAMPLE`` entries of the family's smallest size, drawn with a seed that changes every day
    (``DRONEPLAN_LIBRARY_SEED`` repeats a draw), re-certified: a fresh plan never beats a stored
    bound, and a proven optimum is the one stored."""
    import os
    import time

    from droneplan.studies.library.certify import entry_disagrees

    entries = load_library(family)
    seed = int(os.environ.get("DRONEPLAN_LIBRARY_SEED", int(time.time() // 86400)))
    held = [i for i in library_instances(family) if i.id in entries]
    assert held
    small = [i for i in held if i.size == min(j.size for j in held)]
    rng = np.random.default_rng(seed)
    for k in rng.choice(len(small), size=min(MODEL_SAMPLE, len(small)), replace=False):
        inst = small[int(k)]
        why = entry_disagrees(entries[inst.id], certify_instance(inst, time_limit=60))
        assert not why, f"{inst.id}: {why} (sample seed {seed})"
