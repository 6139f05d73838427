"""Every public name documents itself, with units (modelled on python-control's docstrings_test).

Public = every entry of ``__all__`` of the front doors (``droneplan``, ``droneplan.cells``,
``.covert``, ``.shark``, ``.herding``), so a name added there is checked automatically.

- functions and classes have their own docstring (not one inherited from ``dict``/``Protocol``);
- every parameter of a public function, and of a public class's constructor, is named in the
  docstring (this project's docstrings write ``name: meaning (unit)`` lines);
- every field of a settings/parameters dataclass (``*Settings``, ``*Params``, ``*Behaviour``) has
  its own attribute docstring stating a unit (m, s, rad, m/s, ...) or saying ``dimensionless`` /
  ``count``; booleans, strings, enums and callables need a docstring but no unit;
- every field of any other public dataclass is documented (its own docstring, or named in the
  class docstring);
- public constants (thesis tables, backend lists) have an attribute docstring where defined.
"""

from __future__ import annotations

import ast
import dataclasses
import enum
import importlib
import inspect
import re
import textwrap
import typing
from functools import cache
from pathlib import Path

import pytest

FRONT_DOORS = ("droneplan", "droneplan.cells", "droneplan.covert", "droneplan.shark", "droneplan.herding")
SETTINGS_SUFFIXES = ("Settings", "Params", "Behaviour")

# A unit, or an explicit statement that the quantity has none. Matched as whole words.
UNIT_PATTERN = re.compile(
    r"(?<![\w^'’-])("
    r"m|s|rad|deg|Hz|%|m/s|m/s\^?2|m/s²|rad/s|m\^?2|m²|km|\w+/m\^?2|\w+/m²|users|"
    r"(?i:metres?|meters?|seconds?|radians?|degrees?|dimensionless|count|number of|probability|fraction)"
    r")(?![\w^²])"
)
# Field types that carry no physical unit: a docstring is enough.
UNITLESS_TYPES = ("bool", "str", "Literal", "Callable", "Generator", "Enum")


# Gaps found on main when this test was added (2026-11-22), while six other branches were
# still editing these modules. Each is a strict xfail: fixing the docstring makes the test pass
# and then fail as XPASS until its entry is removed here, so the list can only shrink.
KNOWN_GAPS: dict[str, set[str]] = {}


def _public_names() -> list[tuple[str, str, object]]:
    names = []
    for door in FRONT_DOORS:
        module = importlib.import_module(door)
        for name in module.__all__:
            obj = getattr(module, name)
            if inspect.ismodule(obj) or name.startswith("__"):
                continue
            names.append((door, name, obj))
    return names


PUBLIC = _public_names()
FUNCTIONS = [p for p in PUBLIC if inspect.isfunction(p[2])]
CLASSES = [p for p in PUBLIC if inspect.isclass(p[2])]
CONSTANTS = [p for p in PUBLIC if not inspect.isfunction(p[2]) and not inspect.isclass(p[2])]
SETTINGS = [
    p for p in CLASSES if dataclasses.is_dataclass(p[2]) and p[2].__name__.endswith(SETTINGS_SUFFIXES)
]
OTHER_DATACLASSES = [p for p in CLASSES if dataclasses.is_dataclass(p[2]) and p not in SETTINGS]
PLAIN_CLASSES = [p for p in CLASSES if not dataclasses.is_dataclass(p[2]) and not issubclass(p[2], enum.Enum)]


def _params(items, test_name: str):
    gaps = KNOWN_GAPS.get(test_name, set())
    reason = "known docstring gap (KNOWN_GAPS)"
    return [
        pytest.param(
            *item,
            id=f"{item[0]}.{item[1]}",
            marks=[pytest.mark.xfail(strict=True, reason=reason)] if f"{item[0]}.{item[1]}" in gaps else [],
        )
        for item in items
    ]


def _mentions(doc: str, name: str) -> bool:
    return re.search(rf"(?<![\w.]){re.escape(name)}(?!\w)", doc) is not None


@cache
def _attribute_docs(cls: type) -> dict[str, str]:
    """Attribute docstrings (a string right after ``name: type = value``) of ``cls`` and its bases."""
    docs: dict[str, str] = {}
    for klass in reversed(cls.__mro__):
        if klass is object or not klass.__module__.startswith("droneplan"):
            continue
        try:
            source = textwrap.dedent(inspect.getsource(klass))
        except (OSError, TypeError):
            continue
        body = ast.parse(source).body[0].body  # type: ignore[attr-defined]  # a def statement (parsed from a function), which has a body
        for stmt, nxt in zip(body, [*body[1:], None], strict=True):
            target = stmt.target if isinstance(stmt, ast.AnnAssign) else None
            if (
                isinstance(target, ast.Name)
                and isinstance(nxt, ast.Expr)
                and isinstance(nxt.value, ast.Constant)
                and isinstance(nxt.value.value, str)
            ):
                docs[target.id] = nxt.value.value
    return docs


def _own_doc(obj: object) -> str:
    doc = obj.__dict__.get("__doc__") if inspect.isclass(obj) else getattr(obj, "__doc__", None)
    return inspect.cleandoc(doc) if isinstance(doc, str) else ""


def _signature_params(func) -> list[str]:
    try:
        sig = inspect.signature(func)
    except (TypeError, ValueError):
        return []
    return [p.name for p in sig.parameters.values() if p.name not in ("self", "cls")]


def _type_text(cls: type, field: dataclasses.Field) -> str:
    try:
        hints = typing.get_type_hints(cls)
    except Exception:  # noqa: BLE001 - fall back to the annotation string when hints do not resolve
        hints = {}
    hint = hints.get(field.name, field.type)
    text = hint if isinstance(hint, str) else repr(hint)
    if inspect.isclass(hint) and issubclass(hint, enum.Enum):
        text += " Enum"
    return text


def test_known_gaps_name_public_things():
    ids = {f"{door}.{name}" for door, name, _ in PUBLIC}
    stale = {t: sorted(g - ids) for t, g in KNOWN_GAPS.items() if g - ids}
    assert not stale, f"KNOWN_GAPS names that are no longer public: {stale}"


def test_there_are_public_names_to_check():
    # Guards the parametrisations below against silently checking nothing.
    assert len(FUNCTIONS) > 20 and len(SETTINGS) > 5 and len(OTHER_DATACLASSES) > 5


@pytest.mark.parametrize(
    ("door", "name", "obj"), _params(FUNCTIONS + CLASSES, "test_public_name_has_its_own_docstring")
)
def test_public_name_has_its_own_docstring(door, name, obj):
    assert len(_own_doc(obj)) >= 10, f"{door}.{name} has no docstring of its own"


@pytest.mark.parametrize(
    ("door", "name", "func"), _params(FUNCTIONS, "test_function_documents_every_parameter")
)
def test_function_documents_every_parameter(door, name, func):
    doc = _own_doc(func)
    missing = [p for p in _signature_params(func) if not _mentions(doc, p)]
    assert not missing, f"{door}.{name}: parameters {missing} are not documented in its docstring"


@pytest.mark.parametrize(
    ("door", "name", "cls"), _params(PLAIN_CLASSES, "test_class_documents_its_constructor_parameters")
)
def test_class_documents_its_constructor_parameters(door, name, cls):
    if getattr(cls, "_is_protocol", False) or "__init__" not in vars(cls):
        pytest.skip("a protocol, or no constructor of its own")
    doc = _own_doc(cls) + "\n" + _own_doc(cls.__init__)
    missing = [p for p in _signature_params(cls.__init__) if not _mentions(doc, p)]
    assert not missing, f"{door}.{name}: constructor parameters {missing} are not documented"


@pytest.mark.parametrize(
    ("door", "name", "cls"), _params(SETTINGS, "test_settings_field_has_a_docstring_with_its_unit")
)
def test_settings_field_has_a_docstring_with_its_unit(door, name, cls):
    docs = _attribute_docs(cls)
    undocumented, unitless = [], []
    for field in dataclasses.fields(cls):
        if not field.init or field.name.startswith("_"):
            continue
        doc = docs.get(field.name, "")
        if not doc.strip():
            undocumented.append(field.name)
        elif not any(t in _type_text(cls, field) for t in UNITLESS_TYPES) and not UNIT_PATTERN.search(doc):
            unitless.append(field.name)
    assert not undocumented, (
        f"{door}.{name}: fields {undocumented} have no docstring (a string under the field)"
    )
    assert not unitless, (
        f"{door}.{name}: the docstrings of fields {unitless} state no unit "
        "(write it, e.g. '(m)', '(s)', '(rad)', or say 'dimensionless' / 'count')"
    )


@pytest.mark.parametrize(
    ("door", "name", "cls"), _params(OTHER_DATACLASSES, "test_dataclass_documents_every_field")
)
def test_dataclass_documents_every_field(door, name, cls):
    docs = _attribute_docs(cls)
    class_doc = _own_doc(cls)
    missing = [
        f.name
        for f in dataclasses.fields(cls)
        if not f.name.startswith("_")
        and not docs.get(f.name, "").strip()
        and not _mentions(class_doc, f.name)
    ]
    assert not missing, (
        f"{door}.{name}: fields {missing} are documented neither below the field nor in the class"
    )


@cache
def _front_door_sources(door: str) -> dict[str, str]:
    """name -> defining module, from the ``from X import a, b`` statements of a front door (also
    those under ``if TYPE_CHECKING:``, where a front door declares the names it loads on first use)."""
    tree = ast.parse(Path(importlib.import_module(door).__file__).read_text())
    body = list(tree.body)
    for node in tree.body:
        if isinstance(node, ast.If) and getattr(node.test, "id", None) == "TYPE_CHECKING":
            body += node.body
    return {
        alias.asname or alias.name: node.module
        for node in body
        if isinstance(node, ast.ImportFrom) and node.module
        for alias in node.names
    }


def _constant_doc(module_name: str, name: str, depth: int = 0) -> str:
    """The attribute docstring of ``name`` where it is assigned, following re-exports."""
    tree = ast.parse(Path(importlib.import_module(module_name).__file__).read_text())
    for stmt, nxt in zip(tree.body, [*tree.body[1:], None], strict=True):
        targets = stmt.targets if isinstance(stmt, ast.Assign) else [getattr(stmt, "target", None)]
        if any(isinstance(t, ast.Name) and t.id == name for t in targets):
            is_doc = isinstance(nxt, ast.Expr) and isinstance(nxt.value, ast.Constant)
            return nxt.value.value if is_doc and isinstance(nxt.value.value, str) else ""
    for stmt in tree.body:  # re-exported: look where it comes from
        names = [a.asname or a.name for a in stmt.names] if isinstance(stmt, ast.ImportFrom) else []
        if name in names and stmt.module and depth < 5:
            return _constant_doc(stmt.module, name, depth + 1)
    return ""


@pytest.mark.parametrize(
    ("door", "name", "value"), _params(CONSTANTS, "test_constant_has_an_attribute_docstring")
)
def test_constant_has_an_attribute_docstring(door, name, value):
    if dataclasses.is_dataclass(value):
        pytest.skip("an instance of a documented settings class")
    module_name = _front_door_sources(door).get(name)
    assert module_name, f"{door}.{name} is not imported with `from ... import` in {door}"
    assert _constant_doc(module_name, name).strip(), (
        f"{door}.{name}: add a docstring (a string literal on the line after the assignment) in {module_name}"
    )


def test_unit_pattern_accepts_units_and_rejects_prose():
    for text in (
        "Radius (m).",
        "speed in m/s",
        "Heading rate (rad/s)",
        "weight, dimensionless",
        "a count",
        "density (users/m^2)",
        "Number of drones",
        "Probability per step",
    ):
        assert UNIT_PATTERN.search(text), text
    for text in ("Mutation rate of the GA.", "the msg is shown", "The model's name"):
        assert not UNIT_PATTERN.search(text), text
