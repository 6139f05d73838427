"""docs/architecture.md names what the code has, and nothing the code lacks.

The page lists the layers (section 1) and, under fixed headings of its last section, the instance
kinds, the families, the library families, the built-in methods, the fields of ``Method`` and the
backends, each as a table whose first column is the name in backticks. Each table is compared with
the code both ways, so a new kind, family, method, field or backend fails here until the page
names it, and a row whose name the code dropped fails too.
"""

from __future__ import annotations

import dataclasses
import re
from pathlib import Path

import pytest

from droneplan._layers import LAYERS

PAGE = Path(__file__).resolve().parents[1] / "docs" / "architecture.md"
NAME = re.compile(r"`([^`]+)`")
TABLES = (
    "Instance kinds",
    "Instance families",
    "Library families",
    "Built-in methods",
    "`Method` fields",
    "Backends",
)
"""The headings of the last section's tables."""


def _heading(line: str) -> str | None:
    """The text of a Markdown heading line, without its number (``## 1. Layers`` -> ``Layers``)."""
    match = re.fullmatch(r"#{1,6}\s+(?:\d+\.\s+)?(.*?)\s*", line)
    return match.group(1) if match else None


def _table(heading: str) -> list[list[str]]:
    """The data rows (cells stripped) of the first table under ``heading``, before the next heading."""
    lines = PAGE.read_text(encoding="utf-8").splitlines()
    starts = [i for i, line in enumerate(lines) if _heading(line) == heading]
    assert len(starts) == 1, f"docs/architecture.md has {len(starts)} headings {heading!r}; want one"
    rows: list[list[str]] = []
    for line in lines[starts[0] + 1 :]:
        if _heading(line) is not None:
            break
        if line.startswith("|"):
            rows.append([cell.strip() for cell in line.strip().strip("|").split("|")])
        elif rows:
            break
    assert len(rows) > 2, f"no table under {heading!r} in docs/architecture.md"
    return rows[2:]  # the header and the |---| line


def _names(cell: str) -> list[str]:
    return NAME.findall(cell)


def _first_column(heading: str) -> list[str]:
    names = []
    for row in _table(heading):
        match = NAME.fullmatch(row[0])
        assert match, f"{heading!r}: the first cell of {row} is not one name in backticks"
        names.append(match.group(1))
    assert len(names) == len(set(names)), f"{heading!r} names a row twice: {names}"
    return names


def _same(heading: str, page: list[str], code: list[str] | tuple[str, ...]) -> None:
    missing = [n for n in code if n not in page]
    extra = [n for n in page if n not in code]
    assert not missing, f"docs/architecture.md, {heading!r}: add rows for {missing}"
    assert not extra, f"docs/architecture.md, {heading!r}: the code has no {extra}; remove them"


def test_the_layers_are_the_layers_in_order():
    heading = "Layers and one-way imports"
    page = _first_column(heading)
    _same(heading, page, LAYERS)
    assert page == list(LAYERS), "list the layers lowest first, as droneplan/_layers.py does"


def test_the_instance_kinds():
    from droneplan.studies.instances import KINDS, PROBLEM_OF_KIND

    rows = {r[0].strip("`"): r for r in _table("Instance kinds")}
    _same("Instance kinds", _first_column("Instance kinds"), KINDS)
    for kind, row in rows.items():
        assert _names(row[1]) == [PROBLEM_OF_KIND[kind]], f"kind {kind}: problem {row[1]}"


def test_the_instance_families():
    from droneplan.studies.instances import FAMILIES

    _same("Instance families", _first_column("Instance families"), list(FAMILIES))
    for row in _table("Instance families"):
        family = FAMILIES[row[0].strip("`")]
        assert _names(row[1]) == [family.problem], f"family {family.name}: problem {row[1]}"
        assert _names(row[2]) == [family.kind], f"family {family.name}: kind {row[2]}"


def test_the_library_families():
    from droneplan.studies.library import LIBRARY_FAMILIES

    _same("Library families", _first_column("Library families"), list(LIBRARY_FAMILIES))


def test_the_built_in_methods_and_their_trusted_bounds():
    from droneplan.studies.methods import BUILTIN

    heading = "Built-in methods"
    _same(heading, _first_column(heading), list(BUILTIN))
    for row in _table(heading):
        method = BUILTIN[row[0].strip("`")]
        assert _names(row[1]) == list(method.kinds), f"method {method.name}: kinds {row[1]}"
        assert row[2] == method.role, f"method {method.name}: role {row[2]!r}, code {method.role!r}"
        trusted = {"yes": True, "no": False}.get(row[3])
        assert trusted is method.trusted_bound, (
            f"method {method.name}: trusted bound {row[3]!r}, code {method.trusted_bound}"
        )
    counts = re.findall(r"`BUILTIN` holds (\d+) methods", PAGE.read_text(encoding="utf-8"))
    assert counts == [str(len(BUILTIN))], f"the page says BUILTIN holds {counts}; it holds {len(BUILTIN)}"


def test_the_method_fields_in_order():
    from droneplan.studies.methods import Method

    fields = [f.name for f in dataclasses.fields(Method)]
    page = _first_column("`Method` fields")
    _same("`Method` fields", page, fields)
    assert page == fields, "list the fields of Method in their order"


def test_the_backends_their_kinds_and_requirements():
    from droneplan.solvers import registry

    table = registry._builtin()  # the registry's one table of built-in adapter classes
    _same("Backends", _first_column("Backends"), list(table))
    for row in _table("Backends"):
        cls = table[row[0].strip("`")]
        assert sorted(_names(row[2])) == sorted(cls.kinds), f"backend {cls.name}: kinds {row[2]}"
        assert sorted(_names(row[3])) == sorted(cls.requires), f"backend {cls.name}: requires {row[3]}"
        assert cls.__name__ in _names(row[1]), f"backend {cls.name}: adapter {row[1]}"


@pytest.mark.parametrize("heading", TABLES)
def test_a_name_the_code_gains_fails_until_the_page_names_it(heading):
    """The comparison is not vacuous: one name more on the code side is reported as missing."""
    page = _first_column(heading)
    with pytest.raises(AssertionError, match="add rows for"):
        _same(heading, page, [*page, "a-new-name"])
    with pytest.raises(AssertionError, match="remove them"):
        _same(heading, [*page, "a-new-name"], page)
