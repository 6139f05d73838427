"""studies.shark gap: the random paths run as an open study (closed-loop contact times) with the
offline OCP and its proven bound as extras of the bound engine's row."""

from __future__ import annotations

import numpy as np
import pytest

from droneplan.planners.shark import VirtualSharkInterceptor, optimal_interception
from droneplan.scenarios.shark import operator_start, random_trajectory, simulate
from droneplan.studies import shark as study
from droneplan.studies.common import make_executor
from droneplan.studies.methods import BUILTIN, DEFAULT_METHODS, resolve_methods


def test_shark_defaults_and_engine_are_registered():
    assert [m.name for m in resolve_methods("shark-path", None)] == list(DEFAULT_METHODS["shark-path"])
    assert BUILTIN["interception-bound"].is_bound_engine
    with pytest.raises(ValueError, match="name at least one method"):
        resolve_methods("cells", None)


def test_path_rows_match_the_direct_runs_and_solves(tmp_path):
    with make_executor(2) as ex:
        df = study.gap(seeds=1, first_seed=3, executor=ex, out=tmp_path)
    assert (df["status"] != "error").all(), df["message"].tolist()
    paths = df[df["instance"].str.startswith("random-path@")].set_index("method")
    assert {"virtual-shark", "ocp", "interception-bound"} <= set(paths.index)
    engine = paths.loc["interception-bound"]
    # the bound is about reaching the frontal point, not first contact: it is no ranked bound
    assert engine["role"] == "bound" and engine["bound_kind"] == "none" and engine["bound"] != engine["bound"]
    assert engine["shark_bound_metric"] == study.BOUND_METRIC
    # the same path, start and solves made directly (path seed 3, its random start bearing)
    tr = random_trajectory(3)
    bearing = float(np.random.default_rng(3).uniform(-180, 180))
    vs_ctl = VirtualSharkInterceptor()
    vs = simulate(tr, vs_ctl, bearing_deg=bearing)
    assert paths.loc["virtual-shark", "shark_capture_time"] == pytest.approx(vs_ctl.capture_time)
    assert paths.loc["virtual-shark", "objective"] == pytest.approx(vs.intercept_time)
    res = optimal_interception(tr, operator_start(tr, bearing_deg=bearing), N=50)
    assert engine["shark_ocp_time_s"] == pytest.approx(res.objective, rel=1e-6)
    lb = res.bound
    assert engine["shark_capture_time_bound_s"] == pytest.approx(lb, rel=1e-9)
    # what the bound is proven for: the OCP's T and the virtual shark's capture time
    assert lb <= engine["shark_ocp_time_s"] + 1e-6 and lb <= paths.loc["virtual-shark", "shark_capture_time"]
    assert (df["instance"] == "gap-assign:seed=3").sum() == 2
    assert (tmp_path / "gap_table.csv").exists()
