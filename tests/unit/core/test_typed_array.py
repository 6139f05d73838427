"""check_typed_array: bool masks and integer index arrays kept in their own dtype."""

from __future__ import annotations

import numpy as np
import pytest

from droneplan.core.validation import check_typed_array


def test_accepts_its_kinds_without_converting():
    mask = check_typed_array("usable", [True, False], "b", "a bool array")
    assert mask.dtype == bool and mask.tolist() == [True, False]
    idx = check_typed_array("keep", np.array([3, 1], dtype=np.int32), "iu", "an index array")
    assert idx.dtype == np.int32 and idx.tolist() == [3, 1]


def test_an_empty_list_takes_the_first_kind():
    assert check_typed_array("usable", [], "b", "a bool array").dtype == bool
    assert check_typed_array("keep", [], "iu", "an index array").dtype == np.int64


@pytest.mark.parametrize("value", [None, "ab", b"ab", [0.5, 1.0], [[1, 2], [3]], [True]])
def test_other_values_raise_a_type_error_naming_the_parameter(value):
    with pytest.raises(TypeError, match=r"^keep must be an index array"):
        check_typed_array("keep", value, "iu", "an index array")
