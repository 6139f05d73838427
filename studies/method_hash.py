"""What identifies a user's method for a study's configuration hash: all of its code, its parameters by value.

A study reuses a stored row only when the row was computed the same way, so the configuration
hash of a method must change whenever anything that decides its output changes, and must not
change otherwise (a row that never resumes is as wrong as a stale one). droneplan's own code is
covered by its code hash (:mod:`droneplan.studies.provenance`); this module covers the user's:

:func:`code_fingerprint`
    The source text of the method's own module and of every module of the user's tree it
    imports, directly or through the functions, classes and modules it names (a module whose
    file lies outside the standard library, the installed packages and droneplan). A function
    without a module file (a notebook cell, ``python -c``) is hashed by its own source plus,
    for each global name it uses, that function's or class's source or that value.
:func:`params_value`
    The parameters as plain JSON values: numbers, strings, None, bools, lists, tuples and str-keyed
    dicts of them, numpy arrays (dtype, shape and a hash of their bytes), enums, dataclasses
    (their fields), ``functools.partial`` (its function's code and its arguments), functions and
    classes (their code), callable instances (their class's code and their attributes), and
    objects with a ``__droneplan_hash__()`` method (its plain return value). Anything else has no
    stable value (its ``repr`` holds a memory address, say): a one-line :class:`TypeError` says
    how to name it instead.
"""

from __future__ import annotations

import dataclasses
import enum
import functools
import hashlib
import inspect
import math
import sys
import sysconfig
import types
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["MAX_MODULES", "code_fingerprint", "params_value"]

MAX_MODULES = 500
"""Most user modules one method's code hash follows (a larger tree raises ValueError)."""

_MAX_DEPTH = 32


def _library_roots() -> tuple[Path, ...]:
    roots = {sysconfig.get_paths()[k] for k in ("stdlib", "platstdlib", "purelib", "platlib")}
    roots.update({sys.prefix, sys.base_prefix, sys.exec_prefix})
    return tuple(Path(r).resolve() for r in roots if r)


_ROOTS = _library_roots()


def _user_file(module: types.ModuleType | None) -> Path | None:
    """The source file of ``module`` if it is the user's (not stdlib, installed or droneplan)."""
    if module is None or module.__name__.split(".")[0] == "droneplan":
        return None
    file = getattr(module, "__file__", None)
    if not file or not str(file).endswith(".py"):
        return None
    path = Path(file).resolve()
    if any(path.is_relative_to(root) for root in _ROOTS):
        return None
    return path


def _from_library(cls: type) -> bool:
    """Whether ``cls`` comes from the standard library or an installed package (not the user's code)."""
    module = sys.modules.get(cls.__module__)
    file = getattr(module, "__file__", None)
    if module is None or cls.__module__ == "builtins":
        return True
    if not file:
        return cls.__module__ != "__main__"
    return any(Path(file).resolve().is_relative_to(root) for root in _ROOTS)


def _digest(text: str) -> str:
    return hashlib.sha256(text.encode("utf-8", "replace")).hexdigest()[:16]


def _source(obj: Any) -> str:
    try:
        return inspect.getsource(obj)
    except (OSError, TypeError):
        code = getattr(obj, "__code__", None)
        return (
            repr(code.co_code) + repr(code.co_consts)
            if code is not None
            else repr(getattr(obj, "__qualname__", obj))
        )


def _named_modules(module: types.ModuleType) -> list[types.ModuleType]:
    """The modules ``module`` refers to: imported modules and the modules of imported objects."""
    found: list[types.ModuleType | None] = []
    for value in list(vars(module).values()):
        if isinstance(value, types.ModuleType):
            found.append(value)
        elif isinstance(value, (types.FunctionType, type)):
            found.append(sys.modules.get(getattr(value, "__module__", "") or ""))
    return [m for m in found if m is not None]


def _user_tree(start: types.ModuleType) -> dict[str, str]:
    """Module name -> source hash of ``start`` and every user module reachable from it."""
    seen: dict[str, str] = {}
    todo = [start]
    while todo:
        module = todo.pop()
        path = _user_file(module)
        if path is None or module.__name__ in seen:
            continue
        if len(seen) >= MAX_MODULES:
            raise ValueError(
                f"method code: more than {MAX_MODULES} user modules to hash from {start.__name__}"
            )
        seen[module.__name__] = _digest(path.read_text(encoding="utf-8", errors="replace"))
        todo.extend(_named_modules(module))
    return seen


def _code_names(code: types.CodeType) -> set[str]:
    names = set(code.co_names)
    for const in code.co_consts:
        if isinstance(const, types.CodeType):
            names |= _code_names(const)
    return names


def _globals_used(fn: Any) -> dict[str, str]:
    """For a function without a module file: name -> hash of each global it uses (code or value)."""
    code = getattr(fn, "__code__", None)
    glob = getattr(fn, "__globals__", None)
    if code is None or glob is None:
        return {}
    used = {}
    for name in sorted(_code_names(code)):
        if name not in glob:
            continue
        value = glob[name]
        if isinstance(value, types.ModuleType):
            tree = _user_tree(value)
            used[name] = _digest(repr(sorted(tree.items()))) if tree else value.__name__
        elif isinstance(value, (types.FunctionType, type)):
            used[name] = _digest(_source(value))
        else:
            try:
                used[name] = _digest(repr(params_value({name: value})))
            except TypeError:
                used[name] = type(value).__qualname__
    return used


def code_fingerprint(target: Any) -> str:
    """``"<module>:<qualname>#<16 hex>"``: a hash of the user's code that ``target`` runs."""
    if isinstance(target, functools.partial):
        return "partial:" + _digest(
            repr(
                (
                    code_fingerprint(target.func),
                    params_value({"args": list(target.args), "keywords": dict(target.keywords)}),
                )
            )
        )
    mod_name = getattr(target, "__module__", "") or ""
    qual = getattr(target, "__qualname__", None) or type(target).__qualname__
    parts: dict[str, Any] = {"source": _digest(_source(target if not _is_instance(target) else type(target)))}
    module = sys.modules.get(mod_name)
    tree = _user_tree(module) if module is not None else {}
    if tree:
        parts["modules"] = sorted(tree.items())
    elif _user_file(module) is None and not mod_name.startswith("droneplan"):
        parts["globals"] = sorted(_globals_used(target).items())
    return f"{mod_name}:{qual}#" + _digest(repr(sorted(parts.items())))


def _is_instance(obj: Any) -> bool:
    return not isinstance(obj, (types.FunctionType, types.BuiltinFunctionType, type, functools.partial))


def params_value(params: Any) -> Any:
    """The plain JSON value that stands for ``params`` in the configuration hash (module docstring)."""
    return _value(params, "params", 0)


def _value(v: Any, where: str, depth: int) -> Any:
    if depth > _MAX_DEPTH:
        raise TypeError(f"{where}: nested deeper than {_MAX_DEPTH} levels")
    if v is None or type(v) in (bool, str, int):
        return v
    if type(v) is float:
        return v if math.isfinite(v) else repr(v)
    if isinstance(v, (np.bool_, np.integer, np.floating)):
        return _value(v.item(), where, depth)
    if isinstance(v, np.ndarray) and not v.dtype.hasobject:
        return {
            "ndarray": v.dtype.str,
            "shape": list(v.shape),
            "sha256": hashlib.sha256(v.tobytes()).hexdigest(),
        }
    if type(v) in (list, tuple):
        return [_value(x, f"{where}[{i}]", depth + 1) for i, x in enumerate(v)]
    if type(v) is dict:
        return {
            str(k): _value(x, f"{where}[{k!r}]", depth + 1)
            for k, x in sorted(v.items(), key=lambda kv: str(kv[0]))
        }
    return _object_value(v, where, depth)


def _object_value(v: Any, where: str, depth: int) -> Any:
    if isinstance(v, enum.Enum):
        return {"enum": type(v).__qualname__, "value": _value(v.value, where, depth + 1)}
    own = getattr(type(v), "__droneplan_hash__", None)
    if own is not None:
        return {
            "object": type(v).__qualname__,
            "value": _value(own(v), f"{where}.__droneplan_hash__()", depth + 1),
        }
    if dataclasses.is_dataclass(v) and not isinstance(v, type):
        fields = {f.name: getattr(v, f.name) for f in dataclasses.fields(v)}
        return {"dataclass": type(v).__qualname__, "fields": _value(fields, where, depth + 1)}
    if isinstance(v, (functools.partial, types.FunctionType, type)):
        return {"code": code_fingerprint(v)}
    if callable(v) and hasattr(v, "__dict__") and not _from_library(type(v)):
        return {"callable": code_fingerprint(v), "state": _value(dict(vars(v)), where, depth + 1)}
    raise TypeError(
        f"{where}: an object of type {type(v).__qualname__} has no stable value to hash; pass its "
        "parameters instead, make it a dataclass, or give its class a __droneplan_hash__() method "
        "returning plain values"
    )
