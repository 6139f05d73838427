"""End to end: the online OCP interceptor keeps the Prop. 5.3.2-5.3.4 guarantees where the thesis
algorithm loses them."""

import numpy as np
import pytest

from droneplan.planners.shark import OCPInterceptor, VirtualSharkInterceptor
from droneplan.scenarios.shark import random_trajectory, simulate


def test_online_ocp_fixes_the_curvy_counterexample():
    tr = random_trajectory(9)
    vs = simulate(tr, VirtualSharkInterceptor(), bearing_deg=133)
    assert vs.touched_early  # the thesis algorithm touches the shark before its interception point
    ctl = OCPInterceptor(N=20)
    oc = simulate(tr, ctl, bearing_deg=133)
    assert oc.intercepted and oc.frontal and not oc.touched_early
    assert ctl.solve_times and all(s in ("OPTIMAL", "FEASIBLE") for s in ctl.statuses)


@pytest.mark.parametrize("seed", [11, 12, 13])
def test_online_ocp_frontal_without_early_touch_on_random_curvy_paths(seed):
    tr = random_trajectory(seed)
    bearing = float(np.random.default_rng(seed).uniform(-180, 180))
    oc = simulate(tr, OCPInterceptor(N=20), bearing_deg=bearing)
    assert oc.intercepted and oc.frontal and not oc.touched_early


@pytest.mark.slow
def test_reproduce_shark_quick_cli(tmp_path):
    from droneplan.studies.cli import main

    assert main(["reproduce", "shark", "--quick", "--out", str(tmp_path)]) == 0
    for f in ("fig_5_10.png", "fig_5_11.png", "fig_5_12.png", "table_5_2.csv", "repelling.csv"):
        assert (tmp_path / "shark" / f).exists()
