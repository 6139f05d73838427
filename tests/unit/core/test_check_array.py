"""check_array accepts exactly the arrays whose entries are finite and within max_abs."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from droneplan.core.validation import MAX_COORDINATE, check_array

ENTRIES = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from([MAX_COORDINATE, -MAX_COORDINATE, math.nextafter(MAX_COORDINATE, math.inf), -0.0]),
)


@settings(max_examples=400, deadline=None)
@given(
    st.lists(ENTRIES, min_size=1, max_size=12),
    st.sampled_from([MAX_COORDINATE, 1.0, math.inf, None]),
)
@example([math.inf], math.inf)
@example([1.0, -math.inf], math.inf)
@example([math.nan, 0.5], 1.0)
@example([2.0, -0.5], 1.0)
def test_check_array_refuses_exactly_the_non_finite_or_too_large_entries(values, max_abs):
    arr = np.array(values, dtype=float)
    finite = bool(np.all(np.isfinite(arr)))
    small = max_abs is None or not finite or bool(np.all(np.abs(arr) <= max_abs))
    if finite and small:
        out = check_array("x", arr, max_abs=max_abs)
        assert np.array_equal(out, arr) and out is not arr
    else:
        with pytest.raises(ValueError, match="must be finite" if not finite else "magnitude"):
            check_array("x", arr, max_abs=max_abs)
