"""studies.methods: what a study accepts as its methods."""

from __future__ import annotations

import pytest

from droneplan.studies.methods import resolve_methods


@pytest.mark.parametrize("methods", [10**12, 2.5, object()])
def test_methods_of_a_wrong_type_are_refused_by_name(methods):
    with pytest.raises(TypeError, match=r"^methods must be a method .* got "):
        resolve_methods("cells", methods)


def test_a_list_a_single_name_and_a_mapping_resolve_alike():
    one = resolve_methods("cells", "greedy")
    listed = resolve_methods("cells", ["greedy"])
    assert [m.name for m in one] == [m.name for m in listed] == ["greedy"]
    mapped = resolve_methods("cells", {"mine": one[0].target})
    assert [m.name for m in mapped] == ["mine"]
