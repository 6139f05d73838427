"""Every instance kind gives the same ids, fingerprints, rows and certified entries as recorded.

The record (``tests/data/kinds_record.json``) was written by this module's ``__main__`` before the
study engine's kind dispatch was rewritten as one class per kind; a refactor of the engine must
leave it unchanged. Regenerate it only for an intended change of results, and say so in the
CHANGELOG: ``python tests/unit/studies/test_results_unchanged.py``.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest

STATIC_KINDS = ("cells", "cells-mobile", "cells-fleet", "allocation", "shark-fleet")
RECORD = Path(__file__).resolve().parents[2] / "data" / "kinds_record.json"

# (family, params, methods run on it, certified too)
CASES: list[tuple[str, dict[str, Any], tuple[str, ...], bool]] = [
    ("table4.2", {"m": 2, "seed": 0}, ("greedy", "bnb", "milp"), True),
    ("table4.2-weighted", {"m": 1, "seed": 1}, ("greedy", "milp"), True),
    ("table4.2-nofly", {"m": 1, "seed": 2}, ("greedy", "milp"), False),
    ("table4.2-mobile", {"m": 2, "seed": 0}, ("myopic",), False),
    ("min-fleet", {"m": 3, "coverage": 0.1, "seed": 0}, ("greedy-fleet",), False),
    ("allocation", {"n": 4, "seed": 3}, ("alg3", "collision-blind", "cp-sat", "exact"), True),
    ("random-fleet", {"seed": 1}, ("greedy-nearest", "bottleneck"), True),
    ("table5.1", {"path": "a"}, ("virtual-shark",), False),
    ("random-group", {"n_targets": 2, "seed": 0}, ("sliding",), False),
    ("table6.2", {"n_animals": 10, "seed": 0}, ("proposed",), False),
]

# what each static kind's scorer says of a malformed return value
MALFORMED = {"table4.2": np.full((2, 2), np.nan), "allocation": (np.zeros(3), np.zeros(3))}


def _digest(value: Any) -> str:
    """A short hash of a plan (rounded to 1e-6, so that the last bits of a platform do not count)."""
    if value is None:
        return "none"
    if hasattr(value, "target") and hasattr(value, "direction"):
        value = (value.target, value.direction)
    if isinstance(value, tuple):
        return "|".join(_digest(v) for v in value)
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        value = dataclasses.asdict(value)
    if isinstance(value, dict):
        return "|".join(f"{k}={_digest(value[k])}" for k in sorted(value))
    arr = np.round(np.asarray(value, dtype=float), 6) + 0.0
    return hashlib.sha256(arr.tobytes() + str(arr.shape).encode()).hexdigest()[:16]


def _num(v: Any) -> float | None:
    return None if v is None or (isinstance(v, float) and math.isnan(v)) else round(float(v), 6)


def _case(family: str, params: dict[str, Any], methods: tuple[str, ...], certify: bool) -> dict[str, Any]:
    from droneplan.solvers.result import SolveResult
    from droneplan.studies.harness import execute, score
    from droneplan.studies.instances import FAMILIES, StudyInstance
    from droneplan.studies.methods import BUILTIN

    fam = FAMILIES[family]
    instance = StudyInstance(fam.problem, fam.kind, fam.name, fam.version, params, fam.build(**params))
    out: dict[str, Any] = {
        "id": instance.id,
        "kind": instance.kind,
        "problem": instance.problem,
        "fingerprint": instance.fingerprint(),
        "size": instance.size,
        "round_trip": StudyInstance.from_dict(json.loads(json.dumps(instance.to_dict()))).fingerprint(),
        "rows": {},
    }
    for name in methods:
        method = BUILTIN[name]
        returned = execute(instance, method, 0, 120.0)
        verdict = score(instance, method, returned)
        plan = returned.x if isinstance(returned, SolveResult) else returned
        out["rows"][name] = {
            "status": verdict.status,
            "objective": _num(verdict.objective),
            "bound": _num(verdict.bound),
            "bound_kind": verdict.bound_kind,
            "flags": sorted(verdict.flags),
            "plan": _digest(plan) if instance.kind in STATIC_KINDS else None,
            "extras": {
                k: _num(v) if isinstance(v, (int, float)) and not isinstance(v, bool) else v
                for k, v in sorted(verdict.extras.items())
                if not k.endswith("time_s")
            },
        }
    if family in MALFORMED:
        verdict = score(instance, BUILTIN[methods[0]], MALFORMED[family])
        out["malformed"] = {"status": verdict.status, "message": verdict.message}
    if certify:
        from droneplan.studies.library import certify_instance

        entry = certify_instance(instance, time_limit=120.0)
        out["certified"] = {
            k: (_num(entry[k]) if k in ("value", "bound") else entry[k])
            for k in ("value", "bound", "bound_kind", "status", "sense")
        }
        out["certified"]["plan"] = _digest(entry["plan"])
    return out


def _observe() -> dict[str, Any]:
    import time

    out = {}
    for family, params, methods, certify in CASES:
        t0 = time.perf_counter()
        out[f"{family}:{json.dumps(params, sort_keys=True)}"] = _case(family, params, methods, certify)
        print(f"{family}: {time.perf_counter() - t0:.1f} s")
    return out


@pytest.mark.slow
@pytest.mark.parametrize("case", CASES, ids=[c[0] for c in CASES])
def test_results_unchanged(case):
    family, params, methods, certify = case
    record = json.loads(RECORD.read_text(encoding="utf-8"))
    key = f"{family}:{json.dumps(params, sort_keys=True)}"
    assert _case(family, params, methods, certify) == record[key]


if __name__ == "__main__":
    RECORD.write_text(json.dumps(_observe(), indent=1, sort_keys=True) + "\n", encoding="utf-8")
    print(f"wrote {RECORD}")
