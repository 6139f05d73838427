"""A policy wrapped by ``policy_controller`` runs in a gap study like any controller class."""

from __future__ import annotations

import numpy as np

import droneplan as dp
from droneplan.studies.methods import Method


def pursue(obs):
    """Full horizontal speed towards the shark, at the top of the altitude band (m/s)."""
    v_xy = 7.5 * obs[:2] / max(float(np.hypot(obs[0], obs[1])), 1e-9)
    return np.array([v_xy[0], v_xy[1], np.clip(2.0 - obs[6], -2.7, 2.7)])


def test_a_policy_controller_is_scored_in_a_gap_study(tmp_path):
    scenario = dp.shark.InterceptionScenario(dp.shark.thesis_trajectories(duration=10.0)["a"])
    method = Method("pursue", dp.shark.policy_controller, params={"policy": pursue})
    df = dp.gap("shark", methods=[method], instances=[scenario], out=tmp_path, workers=1, reference="none")
    row = df.loc[df["method"] == "pursue"].iloc[0]
    # the pursuit touches the shark from behind: scored, and refused as not frontal
    trace = dp.shark.simulate(scenario, dp.shark.policy_controller(pursue))
    assert trace.intercepted and not trace.frontal
    assert row["status"] == "infeasible" and "not frontal" in row["message"]
