"""studies.covert: the stealth front refuses budgets it cannot meet."""

from __future__ import annotations

import pytest

import droneplan.studies.covert as sc


def test_stealth_front_budget_names_the_parameter_that_made_it_large():
    import droneplan as dp

    case = dp.covert.thesis_case(1)
    trace = dp.covert.simulate(case, dp.covert.HoverBenchmark(), max_time=1.0)
    # many arrival times on few instants: the arrival count is to blame
    with pytest.raises(ValueError, match=r"^n_arrivals asks for \d+ solver calls, more than the limit"):
        sc.stealth_front(case, {"hover": trace}, n_arrivals=10**6, step=0.5)
    # few arrival times on a fine grid of instants: the step is to blame
    with pytest.raises(ValueError, match=r"^step asks for \d+ solver calls, more than the limit"):
        sc.stealth_front(case, {"hover": trace}, n_arrivals=2, step=1e-6)
