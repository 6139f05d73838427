"""Deprecated names kept for one release: old keyword names of public functions and old public
names, each answered with a ``DeprecationWarning`` that names the new one (the CHANGELOG lists
them; the glossary of argument names is in docs/architecture.md)."""

from __future__ import annotations

import functools
import warnings
from collections.abc import Callable, Mapping
from typing import Any, TypeVar

__all__ = ["renamed_keywords", "warn_renamed", "deprecated_names"]

F = TypeVar("F", bound=Callable[..., Any])


def warn_renamed(old: str, new: str, *, where: str, stacklevel: int = 3) -> None:
    """Warn (``DeprecationWarning``) that ``old`` is the deprecated name of ``new``.

    old, new: the names. where: what they belong to (``"droneplan.covert.simulate"``).
    stacklevel: how far up the stack the warning points (the caller's caller by default).
    """
    warnings.warn(
        f"{where}: {old!r} is deprecated and will be removed in the next release; use {new!r}",
        DeprecationWarning,
        stacklevel=stacklevel,
    )


def renamed_keywords(**renames: str) -> Callable[[F], F]:
    """A decorator that accepts each old keyword name (``old="new"``) for one release: a call that
    uses it gets a ``DeprecationWarning`` and passes the value under the new name; a call that
    gives both is a ``TypeError``. The function's signature (``inspect.signature``) shows only the
    new names.

    renames: old keyword name -> new keyword name.
    """

    def decorate(fn: F) -> F:
        where = f"{fn.__module__}.{fn.__qualname__}"

        @functools.wraps(fn)
        def wrapper(*args: Any, **kwargs: Any) -> Any:
            for old, new in renames.items():
                if old in kwargs:
                    if new in kwargs:
                        raise TypeError(f"{new}: given twice (as {new!r} and as its deprecated name {old!r})")
                    warn_renamed(old, new, where=where)
                    kwargs[new] = kwargs.pop(old)
            return fn(*args, **kwargs)

        wrapper.__deprecated_keywords__ = dict(renames)  # type: ignore[attr-defined]
        return wrapper  # type: ignore[return-value]

    return decorate


def deprecated_names(
    module: str, renames: Mapping[str, str], namespace: Mapping[str, Any]
) -> Callable[[str], Any]:
    """A module ``__getattr__`` that answers each old public name with the new one's value and a
    ``DeprecationWarning``.

    module: the module's name. renames: old name -> new name (the new one in ``namespace``).
    namespace: the module's ``globals()``.
    """

    def __getattr__(name: str) -> Any:
        if name in renames:
            warn_renamed(name, renames[name], where=module)
            return namespace[renames[name]]
        raise AttributeError(f"module {module!r} has no attribute {name!r}")

    return __getattr__
