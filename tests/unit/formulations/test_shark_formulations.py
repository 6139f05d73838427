import math

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from formulations.shark import optimal_altitude
from scenarios.shark import THESIS_TABLE_5_1 as P, field_radius


@settings(max_examples=80, deadline=None)
@given(st.floats(-12.0, 0.0))
def test_optimal_altitude_equals_dense_grid(z_s):
    zo, eps = optimal_altitude(z_s)
    grid = np.linspace(P.lmin, P.le, 20001)
    vals = field_radius(grid - z_s)
    assert P.lmin <= zo <= P.le
    assert math.isclose(eps, float(field_radius(zo - z_s)), abs_tol=1e-12)
    assert eps >= vals.max() - 1e-9  # no grid point is better
    assert eps <= vals.max() + 1e-3  # and it is attained (grid step 5e-5 m)


def test_optimal_altitude_vectorised_and_bad_input():
    z = np.linspace(-11, 0, 50)
    zo, eps = optimal_altitude(z)
    assert zo.shape == z.shape and np.all(eps >= 0)
    assert optimal_altitude(-20.0) == (P.lmin, 0.0)  # out of reach: wait at lmin
    with pytest.raises(ValueError):
        optimal_altitude(float("nan"))
    with pytest.raises(ValueError):
        optimal_altitude(0.5)
