"""Where a result row came from: package version, code, libraries, machine, and configuration hashes.

Every row a study writes carries the provenance columns of :func:`provenance_columns` (the
droneplan version and git commit, a hash of droneplan's own source, the versions of the
numerical libraries, the CPU) and a ``config`` hash (:func:`config_hash`) of everything that
decides what the row's numbers are. Two rows with the same key and the same ``config`` were
computed the same way; a rerun after a code or settings change has another ``config`` and
computes new rows instead of resuming old ones.

Nothing here imports the numerical libraries: their versions come from the installed package
metadata (:mod:`importlib.metadata`).
"""

from __future__ import annotations

import contextlib
import copy
import datetime as dt
import functools
import hashlib
import importlib.metadata
import importlib.util
import json
import math
import os
import platform
import re
import subprocess
import sys
from collections.abc import Mapping
from pathlib import Path
from typing import Any

__all__ = ["PACKAGES", "CODE_PACKAGES", "provenance", "config_hash", "provenance_columns"]

PACKAGES = (
    "numpy",
    "scipy",
    "pandas",
    "ortools",
    "casadi",
    "cvxpy",
    "highspy",
    "osqp",
    "shapely",
    "matplotlib",
)
"""Distributions whose installed versions are recorded (``None`` when not installed)."""

CODE_PACKAGES = (
    "droneplan",
    "droneplan.scenarios",
    "droneplan.formulations",
    "droneplan.solvers",
    "droneplan.planners",
    "droneplan.studies",
)
"""Packages whose ``.py`` files (subpackages included) make up :func:`code_hash`."""

_GIT_TIMEOUT_S = 0.1  # per git call; two calls at most, so the commit costs <= ~0.2 s


def provenance() -> dict[str, Any]:
    """The provenance of this process, computed once per process (a fresh copy each call).

    Keys: ``droneplan_version`` (installed version), ``git_commit`` (``git rev-parse HEAD``
    of the checkout holding droneplan's source, ``-dirty`` appended when tracked files are
    modified; None when the source is not in a git checkout or git is unavailable or slow),
    ``code_hash`` (16 hex digits of sha256 over droneplan's ``.py`` files, see
    :data:`CODE_PACKAGES`), ``packages`` (distribution name -> version or None, for
    :data:`PACKAGES`), ``cpu`` (CPU model name), ``cores`` (``os.cpu_count()``).
    """
    return copy.deepcopy(_provenance())


@functools.cache
def _provenance() -> dict[str, Any]:
    return {
        "droneplan_version": _droneplan_version(),
        "git_commit": _git_commit(Path(__file__).resolve().parent, Path(__file__).name),
        "code_hash": _code_hash(),
        "packages": {name: _version(name) for name in PACKAGES},
        "cpu": _cpu_model(),
        "cores": os.cpu_count(),
    }


def _version(name: str) -> str | None:
    try:
        return importlib.metadata.version(name)
    except importlib.metadata.PackageNotFoundError:
        return None


def _droneplan_version() -> str:
    found = _version("droneplan")
    if found is not None:
        return found
    module = sys.modules.get("droneplan")  # running from a source tree that is not installed
    return str(getattr(module, "__version__", "unknown"))


def _git(args: list[str], cwd: Path) -> str | None:
    """stdout of ``git args`` run in ``cwd``, or None on any failure (never raises)."""
    env = {**os.environ, "GIT_OPTIONAL_LOCKS": "0", "LC_ALL": "C"}  # never take the index lock
    try:
        done = subprocess.run(
            ["git", *args],
            cwd=cwd,
            capture_output=True,
            text=True,
            timeout=_GIT_TIMEOUT_S,
            env=env,
            check=False,
        )
    except (OSError, subprocess.SubprocessError, ValueError):
        return None
    return done.stdout if done.returncode == 0 else None


def _git_commit(source: Path, probe: str) -> str | None:
    """HEAD of the checkout holding ``source``, ``-dirty`` appended when tracked files are modified.

    probe: a file in ``source`` that the checkout must track. None when it is not tracked
    (an installed wheel, even one inside a checkout's virtual environment), git is missing,
    or git takes too long.
    """
    try:
        tracked = _git(["ls-files", "--error-unmatch", "--", probe], source)
        if tracked is None or not tracked.strip():
            return None
        # one call gives both the commit (header "# branch.oid") and the modified tracked files
        status = _git(["status", "--porcelain=v2", "--branch", "--untracked-files=no"], source)
        if status is None:
            return None
        lines = status.splitlines()
        oid = next((ln.split()[2] for ln in lines if ln.startswith("# branch.oid ")), None)
        if oid is None or not re.fullmatch(r"[0-9a-f]{40}|[0-9a-f]{64}", oid):
            return None  # no commit yet ("(initial)") or an unexpected answer
        dirty = any(not ln.startswith("#") for ln in lines if ln.strip())
        return oid + ("-dirty" if dirty else "")
    except Exception:  # noqa: BLE001 - provenance must never stop a study
        return None


def _package_dirs() -> dict[str, Path]:
    dirs = {}
    for name in CODE_PACKAGES:
        try:
            spec = importlib.util.find_spec(name)
        except (ImportError, ValueError):
            spec = None
        if spec is None or not spec.submodule_search_locations:
            continue
        dirs[name] = Path(next(iter(spec.submodule_search_locations)))
    return dirs


def _code_hash() -> str:
    """sha256 (16 hex) over droneplan's ``.py`` files, keyed by their path in the installed namespace.

    Each file contributes its path as the package sees it (``droneplan/studies/store.py``),
    whatever folder holds it, so an editable install and a wheel of the same source agree.
    """
    files: dict[str, Path] = {}
    for name, folder in _package_dirs().items():
        prefix = name.replace(".", "/")
        for f in folder.rglob("*.py"):
            rel = f.relative_to(folder)
            if any(part.startswith(".") or part == "__pycache__" for part in rel.parts):
                continue
            files.setdefault(f"{prefix}/{rel.as_posix()}", f)
    h = hashlib.sha256()
    for key in sorted(files):
        try:
            data = files[key].read_bytes()
        except OSError:
            data = b""
        h.update(key.encode() + b"\0" + str(len(data)).encode() + b"\0" + data)
    return h.hexdigest()[:16]


def _cpu_model() -> str:
    # no /proc (not Linux): the platform's own word below
    with contextlib.suppress(OSError), open("/proc/cpuinfo", encoding="utf-8", errors="replace") as fh:
        for line in fh:
            key, _, value = line.partition(":")
            if key.strip() in ("model name", "Model", "Hardware") and value.strip():
                return value.strip()
    return platform.processor() or platform.machine() or "unknown"


# --------------------------------------------------------------------------- configuration hashes
def _canonical(obj: Any, where: str) -> Any:
    """``obj`` as plain JSON types (numpy to lists/scalars, tuples to lists); TypeError otherwise."""
    if obj is None or isinstance(obj, (str, bool)):
        return obj
    if isinstance(obj, int):
        return int(obj)
    if isinstance(obj, float):
        return float(obj)
    if type(obj).__module__ == "numpy" and hasattr(obj, "tolist"):  # numpy scalars and arrays
        return _canonical(obj.tolist(), where)
    if isinstance(obj, (list, tuple)):
        return [_canonical(v, f"{where}[{k}]") for k, v in enumerate(obj)]
    if isinstance(obj, Mapping):
        out = {}
        for k, v in obj.items():
            if not isinstance(k, str):
                raise TypeError(
                    f"config_hash: key {k!r} at {where or 'top level'} is a {type(k).__name__}, not a str"
                )
            out[k] = _canonical(v, f"{where}.{k}" if where else k)
        return out
    raise TypeError(
        f"config_hash: unsupported type {type(obj).__module__}.{type(obj).__qualname__} "
        f"at {where or 'top level'} (use JSON types, tuples or numpy values)"
    )


def _dumps(obj: Any) -> str:
    def enc(v: Any) -> str:
        if isinstance(v, float):  # repr: the shortest string that round-trips
            return repr(v) if math.isfinite(v) else json.dumps(v)
        if isinstance(v, list):
            return "[" + ",".join(enc(x) for x in v) + "]"
        if isinstance(v, dict):
            return "{" + ",".join(json.dumps(k) + ":" + enc(v[k]) for k in sorted(v)) + "}"
        return json.dumps(v)

    return enc(obj)


def config_hash(obj: Any) -> str:
    """16 hex digits of sha256 over the canonical JSON of ``obj``.

    obj: any structure of dicts (str keys), lists, tuples (hashed as lists), str, int,
    float (written by ``repr``; NaN/inf as ``NaN``/``Infinity``), bool, None, numpy scalars
    and arrays (as their ``tolist()``). Keys are sorted, so the order of a dict does not
    matter. Raises TypeError naming any other type and where it sits.
    """
    return hashlib.sha256(_dumps(_canonical(obj, "")).encode()).hexdigest()[:16]


def provenance_columns(**extra: Any) -> dict[str, Any]:
    """The provenance columns of a result row (schema v2), ``finished_at`` set to now.

    Returns ``droneplan_version``, ``git_commit``, ``code_hash``, ``packages`` (a JSON
    string, name -> version), ``cpu``, ``cores`` and ``finished_at`` (ISO 8601, UTC).
    extra: further columns, or values that replace these (e.g. a ``finished_at`` taken
    when the job ended).
    """
    p = _provenance()
    cols = {
        "droneplan_version": p["droneplan_version"],
        "git_commit": p["git_commit"],
        "code_hash": p["code_hash"],
        "packages": json.dumps(p["packages"], sort_keys=True),
        "cpu": p["cpu"],
        "cores": p["cores"],
        "finished_at": dt.datetime.now(dt.UTC).isoformat(timespec="seconds"),
    }
    cols.update(extra)
    return cols
