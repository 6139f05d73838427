"""studies.shark gap: the random paths run as an open study (closed-loop contact times) with the
offline OCP and its proven bound as extras of the bound engine's row."""

from __future__ import annotations

import pytest

from droneplan.studies import shark as study
from droneplan.studies.common import make_executor
from droneplan.studies.methods import BUILTIN, DEFAULT_METHODS, resolve_methods


def test_shark_defaults_and_engine_are_registered():
    assert [m.name for m in resolve_methods("shark-path", None)] == list(DEFAULT_METHODS["shark-path"])
    assert BUILTIN["interception-bound"].is_bound_engine
    with pytest.raises(ValueError, match="name at least one method"):
        resolve_methods("cells", None)


def test_path_rows_match_the_task_function(tmp_path):
    with make_executor(2) as ex:
        df = study.gap(seeds=1, first_seed=3, executor=ex, out=tmp_path)
    assert (df["status"] != "error").all(), df["message"].tolist()
    paths = df[df["instance"].str.startswith("random-path@")].set_index("method")
    assert {"virtual-shark", "ocp", "interception-bound"} <= set(paths.index)
    engine = paths.loc["interception-bound"]
    # the bound is about reaching the frontal point, not first contact: it is no ranked bound
    assert engine["role"] == "bound" and engine["bound_kind"] == "none" and engine["bound"] != engine["bound"]
    assert engine["shark_bound_metric"] == study.BOUND_METRIC
    # the same path and start as the task function the open study replaced (path seed 3)
    old = {
        r["method"]: r
        for r in study.gap_task(dict(problem="shark", instance="gap-path:seed=3", kind="path", seed=3))
    }
    assert paths.loc["virtual-shark", "shark_capture_time"] == pytest.approx(
        old["virtual-shark"]["objective"]
    )
    assert paths.loc["virtual-shark", "objective"] == pytest.approx(old["virtual-shark"]["shark_contact_s"])
    assert engine["shark_ocp_time_s"] == pytest.approx(old["ocp"]["objective"], rel=1e-6)
    lb = old["interception-time-bound"]["bound"]
    assert engine["shark_capture_time_bound_s"] == pytest.approx(lb, rel=1e-9)
    # what the bound is proven for: the OCP's T and the virtual shark's capture time
    assert lb <= engine["shark_ocp_time_s"] + 1e-6 and lb <= paths.loc["virtual-shark", "shark_capture_time"]
    assert (df["instance"] == "gap-assign:seed=3").sum() == 2
    assert (tmp_path / "gap_table.csv").exists()
