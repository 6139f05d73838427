"""Instance kinds: one class per kind, registered here (``KINDS``), and the families they own.

A kind (:class:`~droneplan.studies.kinds.base.Kind`) holds everything a study does with one kind
of instance: its codec, sense, method-call contract, ``execute``, ``score``, ``certify`` and its
families. The study engine reads an instance's kind from this registry and never branches on kind
names. Adding a kind is one class (a module here) plus its registration: its line in
``_REGISTERED``, or :func:`register_kind` for a kind defined outside droneplan.

Kinds, in order: ``cells``, ``cells-mobile``, ``cells-fleet`` (drone-cell placement, ch. 4),
``allocation`` (steering-point allocation, §6.4), ``shark-path``, ``shark-fleet`` (interception,
ch. 5), ``herding-run`` (ch. 6), ``covert-run`` (ch. 3).
"""

from __future__ import annotations

from typing import Any

from droneplan.studies.kinds.base import ClosedLoopKind, Family, Kind
from droneplan.studies.kinds.cells import CellsFleetKind, CellsKind, CellsMobileKind
from droneplan.studies.kinds.covert import CovertRunKind
from droneplan.studies.kinds.herding import AllocationKind, HerdingRunKind
from droneplan.studies.kinds.shark import SharkFleetKind, SharkPathKind

__all__ = [
    "Kind",
    "ClosedLoopKind",
    "Family",
    "KINDS",
    "FAMILIES",
    "kind_named",
    "kind_of_data",
    "register_kind",
]

_REGISTERED: list[Kind] = [
    CellsKind(),
    CellsMobileKind(),
    CellsFleetKind(),
    AllocationKind(),
    SharkPathKind(),
    SharkFleetKind(),
    HerdingRunKind(),
    CovertRunKind(),
]

KINDS: dict[str, Kind] = {kind.name: kind for kind in _REGISTERED}
"""Every instance kind by name."""

FAMILIES: dict[str, Family] = {family.name: family for kind in _REGISTERED for family in kind.families()}
"""Every instance family by name (each declared by its kind)."""


def kind_named(name: str) -> Kind:
    """The registered kind called ``name``; a ValueError naming the known kinds otherwise.

    name: a kind's name (``StudyInstance.kind``).
    """
    try:
        return KINDS[name]
    except (KeyError, TypeError):
        raise ValueError(f"kind must be one of {tuple(KINDS)}, got {name!r}") from None


def kind_of_data(data: Any) -> Kind:
    """The kind whose data ``data`` is (a user's own object); a TypeError listing them otherwise.

    data: a CellProblem, MobileProblem, FleetSizeInstance, AllocationInstance, InterceptionScenario,
    FleetInstance, HerdingScenario or covert scenario.
    """
    for kind in _REGISTERED:
        if kind.holds(data):
            return kind
    raise TypeError(
        "an instance must be a CellProblem, MobileProblem, FleetSizeInstance, AllocationInstance, "
        "InterceptionScenario, FleetInstance, HerdingScenario or "
        f"covert scenario (or a StudyInstance), got {type(data).__name__}"
    )


def register_kind(kind: Kind) -> Kind:
    """Register one more instance kind and its families (a kind's name and its families' names
    must be new); returns it. The engine then runs studies on its instances like any other's.

    kind: an instance of a :class:`~droneplan.studies.kinds.base.Kind` subclass.
    """
    if not isinstance(kind, Kind):
        raise TypeError(f"kind must be an instance of a Kind subclass, got {type(kind).__name__}")
    for attribute in ("name", "problem", "sense"):
        if not isinstance(getattr(kind, attribute, None), str):
            raise ValueError(f"kind.{attribute} must be a string")
    if kind.sense not in ("max", "min"):
        raise ValueError(f"kind.sense must be 'max' or 'min', got {kind.sense!r}")
    if kind.name in KINDS:
        raise ValueError(f"kind.name {kind.name!r} is registered already")
    families = kind.families()
    taken = sorted(f.name for f in families if f.name in FAMILIES)
    if taken:
        raise ValueError(f"kind.families: {taken} are registered already")
    wrong = sorted(f.name for f in families if (f.kind, f.problem) != (kind.name, kind.problem))
    if wrong:
        raise ValueError(f"kind.families: {wrong} do not name this kind and its problem")
    _REGISTERED.append(kind)
    KINDS[kind.name] = kind
    FAMILIES.update({f.name: f for f in families})
    return kind
