"""Renamed public names keep working for one release, each with a DeprecationWarning naming the new
name (the glossary of argument names is in docs/architecture.md)."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import droneplan as dp
from droneplan.core.deprecation import renamed_keywords


@renamed_keywords(old="new")
def _echo(*, new=None):
    return new


def test_an_old_keyword_warns_and_reaches_the_new_one():
    with pytest.warns(DeprecationWarning, match=r"'old' is deprecated.*use 'new'"):
        assert _echo(old=3) == 3
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert _echo(new=4) == 4
    with pytest.raises(TypeError, match=r"^new: given twice"):
        _echo(old=1, new=2)


def test_the_renamed_allocation_keywords():
    d, s, M = np.array([0.0, 40.0, 80.0]), np.array([10.0, 50.0, 90.0]), 120.0
    new = dp.herding.solve_allocation(d, s, M, engine="cp-sat")
    with pytest.warns(DeprecationWarning, match="'method' is deprecated"):
        old = dp.herding.solve_allocation(d, s, M, method="cp-sat")
    assert old.objective == pytest.approx(new.objective)
    with pytest.warns(DeprecationWarning, match="'hint' is deprecated"):
        hinted = dp.herding.solve_allocation(d, s, M, engine="cp-sat", hint=new.x)
    assert hinted.objective == pytest.approx(new.objective)


def test_the_covert_horizon_is_t_max():
    case = dp.covert.thesis_case(1, seed=0)
    new = dp.covert.simulate(case, dp.covert.HoverBenchmark(), t_max=1.0)
    with pytest.warns(DeprecationWarning, match="'max_time' is deprecated.*'t_max'"):
        old = dp.covert.simulate(case, dp.covert.HoverBenchmark(), max_time=1.0)
    assert np.array_equal(old.t, new.t)


def test_renamed_public_names():
    from droneplan.scenarios import shark

    with pytest.warns(DeprecationWarning, match="'simulate_interception' is deprecated"):
        assert shark.simulate_interception is shark.simulate
    with pytest.warns(DeprecationWarning, match="'summary_table' is deprecated.*'run_times_table'"):
        assert dp.herding.summary_table is dp.herding.run_times_table
    assert "summary_table" not in dir(dp.herding)
    with pytest.warns(DeprecationWarning, match="'simulate_interception' is deprecated"):
        assert dp.shark.simulate_interception is dp.shark.simulate
    assert "simulate_interception" not in dp.shark.__all__
