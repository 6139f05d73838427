"""Backends by name: formulations ask the registry, never ``if backend == ...``.

The built-in backends are one table, :func:`_builtin` (name -> adapter class, the name taken
from the class). Each adapter class says on itself what the registry needs to list it: its
``kinds`` (from the capability mixins it inherits) and the packages it ``requires``; it
imports its solver library inside its methods, so the adapter modules are light and
:func:`available_backends` lists a built-in backend whose packages are installed without
loading any solver library. A built-in adapter is instantiated only by :func:`get_backend`,
which then makes the full check (``is_available``, e.g. that OR-Tools was built with SCIP), and by
:func:`unavailable_backends` for a backend whose packages are installed (to ask it, e.g., whether
Gurobi's licence lets it start); a backend that cannot run is named with the reason.
The table is built on first use, so importing droneplan loads none of the adapter modules.

Adding a backend is one adapter class plus one registration: its class in the table of
:func:`_builtin` or, from user code, one :func:`register_backend` call with an instance.
"""

from __future__ import annotations

import functools
from typing import Any

from droneplan.solvers.base import KINDS, BackendAdapter, missing_packages_reason

__all__ = [
    "available_backends",
    "get_backend",
    "register_backend",
    "registered_backends",
    "unavailable_backends",
    "unregister_backend",
]


@functools.cache
def _builtin() -> dict[str, type[BackendAdapter]]:
    """The built-in backends, name -> adapter class: the registry's one table."""
    from droneplan.solvers.cpsat import CpSatAdapter
    from droneplan.solvers.gurobi import GurobiAdapter
    from droneplan.solvers.mip import HighsAdapter, ScipAdapter
    from droneplan.solvers.nlp import IpoptAdapter
    from droneplan.solvers.qp import OsqpAdapter
    from droneplan.solvers.scip import PyScipOptAdapter

    adapters = (
        CpSatAdapter,
        HighsAdapter,
        ScipAdapter,
        PyScipOptAdapter,
        GurobiAdapter,
        IpoptAdapter,
        OsqpAdapter,
    )
    return {cls.name: cls for cls in adapters}


_LOADED: dict[str, BackendAdapter] = {}
_USER: dict[str, BackendAdapter] = {}


def _check_kind(kind: str | None) -> None:
    if kind is not None and kind not in KINDS:
        raise ValueError(f"kind must be one of {KINDS} or None, got {kind!r}")


def register_backend(name: str, adapter: BackendAdapter, *, replace: bool = False) -> None:
    """Make ``adapter`` available as ``name``.

    name: registry name (lower case; must equal ``adapter.name``).
    adapter: an instance of a :class:`BackendAdapter` subclass.
    replace: allow replacing an existing entry (default: a clash raises ValueError).
    """
    if not isinstance(name, str) or not name:
        raise TypeError(f"name must be a non-empty str, got {name!r}")
    if not isinstance(adapter, BackendAdapter):
        raise TypeError(f"adapter must be a BackendAdapter instance, got {type(adapter).__name__}")
    if adapter.name != name:
        raise ValueError(f"adapter.name is {adapter.name!r} but it is registered as {name!r}")
    if not adapter.kinds:
        raise ValueError(
            f"adapter {name!r} implements no capability (LinearBackend, CpBackend, NlpBackend, QpBackend)"
        )
    if not replace and (name in _USER or name in _builtin()):
        raise ValueError(f"a backend named {name!r} is already registered (pass replace=True)")
    _USER[name] = adapter


def unregister_backend(name: str) -> None:
    """Remove a backend added by :func:`register_backend` (built-in entries cannot be removed;
    a user entry that replaced a built-in one is removed and the built-in one returns)."""
    if name not in _USER:
        raise ValueError(f"{name!r} was not added by register_backend; user-registered: {sorted(_USER)}")
    del _USER[name]


def _load(name: str) -> BackendAdapter:
    if name in _USER:
        return _USER[name]
    if name not in _LOADED:
        _LOADED[name] = _builtin()[name]()
    return _LOADED[name]


def registered_backends() -> list[str]:
    """Every registered name, available in this installation or not."""
    return sorted(set(_builtin()) | set(_USER))


def get_backend(name: str, kind: str | None = None) -> Any:
    """The adapter registered as ``name``.

    kind: if given, the adapter must offer this capability ("linear", "cp", "nlp", "qp").
    Raises ValueError for an unknown name (listing the known ones), a missing
    capability, or a backend that is not available in this installation.
    """
    _check_kind(kind)
    if not isinstance(name, str):
        raise TypeError(f"backend must be a str, got {type(name).__name__}")
    key = name.lower()
    if key not in _builtin() and key not in _USER:
        known = available_backends(kind) if kind else registered_backends()
        raise ValueError(f"unknown backend {name!r}; known{f' {kind}' if kind else ''} backends: {known}")
    adapter = _load(key)
    if kind is not None and kind not in adapter.kinds:
        raise ValueError(
            f"backend {name!r} does not offer {kind!r} (it offers {sorted(adapter.kinds)}); "
            f"{kind} backends: {available_backends(kind)}"
        )
    if not adapter.is_available():
        raise ValueError(
            f"backend {name!r} is not available in this installation ({adapter.unavailable_reason()}); "
            f"available{f' {kind}' if kind else ''} backends: {available_backends(kind)}"
        )
    return adapter


def _listed(name: str, kind: str | None) -> bool:
    """Whether ``name`` offers ``kind`` and can run here; a built-in adapter not loaded yet is
    judged from its class (``kinds``, ``requires``), without instantiating it or importing its
    library."""
    if name in _USER or name in _LOADED:
        adapter = _load(name)
        return (kind is None or kind in adapter.kinds) and adapter.is_available()
    cls = _builtin()[name]
    return (kind is None or kind in cls.kinds) and cls.requires_installed()


def available_backends(kind: str | None = None) -> list[str]:
    """Names of the backends usable here, optionally only those offering ``kind``.

    kind: if given, only the backends offering this capability ("linear", "cp", "nlp", "qp").

    Built-in backends are listed from their classes without importing their solver library
    (its packages are looked up on the path); :func:`get_backend` loads one and checks it fully.
    """
    _check_kind(kind)
    return [name for name in registered_backends() if _listed(name, kind)]


def unavailable_backends(kind: str | None = None) -> dict[str, str]:
    """The registered backends that cannot run here, each with the reason in one line (the
    packages it needs and how to install them, or a licence its library refused).

    kind: if given, only the backends offering this capability ("linear", "cp", "nlp", "qp").

    A built-in backend whose packages are missing is judged from its class, without importing
    anything; one whose packages are present is loaded and asked (``is_available``), so a
    library that is installed but refuses to start (no licence) is listed too.
    """
    _check_kind(kind)
    out: dict[str, str] = {}
    for name in registered_backends():
        if name not in _USER and name not in _LOADED:
            cls = _builtin()[name]
            if kind is not None and kind not in cls.kinds:
                continue
            reason = missing_packages_reason(cls)
            if reason:
                out[name] = reason
                continue
        adapter = _load(name)
        if (kind is None or kind in adapter.kinds) and not adapter.is_available():
            out[name] = adapter.unavailable_reason() or "its adapter reports it unavailable"
    return out
