"""Argument checks and seeds shared by every layer (misuse raises; solver failures do not).

One place for the checks every settings dataclass and public entry needs: a number
that is not a bool, finite, positive, non-negative, an int, inside a range, an array
of a given shape with finite entries, a size that fits in memory; and one seed
helper. Each check raises ``TypeError`` (wrong type) or ``ValueError`` (wrong value)
whose message starts with the parameter's name and states the violated condition,
and returns the value converted (``float``, ``int``, ``numpy.ndarray``).

Work budgets: ``check_work``/``check_size`` refuse, before any work starts, a call whose
size, resolution, step, horizon or count implies more array elements, evaluations or
solver calls than the budget in force; the message names the parameter, the size asked
for and the limit, and the caller raises the limit with ``work_limits``. Array entries
and scalars are also refused beyond ``MAX_COORDINATE`` in magnitude (their squares would
overflow); ``max_abs=None`` lifts that limit where a caller needs it.

This module knows nothing of drones or solvers and imports nothing else of droneplan: it is
the base layer (``droneplan.core``) that every other layer may import.
"""

from __future__ import annotations

import contextlib
import math
import numbers
import os
from collections.abc import Iterator, Sequence
from contextvars import ContextVar
from typing import Any, TypeVar

import numpy as np

__all__ = [
    "MAX_ELEMENTS",
    "MAX_EVALUATIONS",
    "MAX_SOLVES",
    "MAX_COORDINATE",
    "work_limits",
    "current_limit",
    "check_work",
    "machine_memory",
    "machine_load",
    "check_real",
    "check_positive",
    "check_nonneg",
    "check_in_range",
    "check_int",
    "check_bool",
    "check_array",
    "check_typed_array",
    "check_sequence",
    "check_size",
    "check_time_limit",
    "check_methods",
    "check_instance",
    "require_set",
    "resolve_seed",
    "as_generator",
    "run_seed",
]

MAX_ELEMENTS = 50_000_000
"""Largest number of array elements a public entry agrees to allocate (400 MB of float64)."""

MAX_EVALUATIONS = 100_000
"""Largest number of Python-level steps a public entry agrees to take (function evaluations
of a search, each tens of microseconds to a millisecond: seconds of work)."""

MAX_SOLVES = 20_000
"""Largest number of optimisation programs (each a solver call of milliseconds to seconds)
a public entry agrees to solve in one call."""

MAX_COORDINATE = 1e15
"""Largest magnitude (m, s, ...) an array entry may have. Squares, products of squares and
norms of cross products of such numbers stay far from the float64 overflow at 1.8e308, and
1e15 m is still resolved to 0.125 m; beyond it distances silently overflow to inf or lose
every digit (a target 1e200 m away made the bearing oracle report a wrong "proven" bound)."""

_DEFAULT_LIMITS = (("elements", MAX_ELEMENTS), ("evaluations", MAX_EVALUATIONS), ("solves", MAX_SOLVES))
_LIMITS: ContextVar[tuple[tuple[str, int], ...]] = ContextVar("droneplan_limits", default=_DEFAULT_LIMITS)

_UNITS = {"elements": "array elements", "evaluations": "evaluations", "solves": "solver calls"}


@contextlib.contextmanager
def work_limits(
    *, elements: int | None = None, evaluations: int | None = None, solves: int | None = None
) -> Iterator[dict[str, int]]:
    """Raise (or lower) the work budgets of the public entries inside a ``with`` block.

    elements: array elements one call may allocate (default ``MAX_ELEMENTS``); evaluations:
    cheap steps one call may take (default ``MAX_EVALUATIONS``); solves: optimisation programs
    one call may solve (default ``MAX_SOLVES``). None keeps the current value. The budgets are
    per thread/context and restored on exit. Example::

        with work_limits(elements=10**9):
            big = dp.shark.interception_time_bound(shark, op, t_max=1e5)
    """
    new = dict(_LIMITS.get())
    for kind, value in (("elements", elements), ("evaluations", evaluations), ("solves", solves)):
        if value is not None:
            new[kind] = check_int(kind, value, min_value=1)
    token = _LIMITS.set(tuple(new.items()))
    try:
        yield dict(new)
    finally:
        _LIMITS.reset(token)


def current_limit(kind: str) -> int:
    """The budget in force for ``kind`` ("elements", "evaluations" or "solves"); see ``work_limits``."""
    if kind not in _UNITS:
        raise ValueError(f"kind must be one of {sorted(_UNITS)}, got {kind!r}")
    return dict(_LIMITS.get())[kind]


def machine_memory() -> float | None:
    """This machine's physical memory, bytes (None where the system does not say)."""
    try:
        return float(os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES"))
    except (AttributeError, ValueError, OSError):
        return None


def machine_load() -> float | None:
    """This machine's 1-minute load average, runnable processes (None where the system does not say)."""
    try:
        return float(os.getloadavg()[0])
    except (AttributeError, OSError):
        return None


def check_work(name: str, asked: float, kind: str = "elements", *, limit: float | None = None) -> None:
    """Refuse up front a call whose parameter ``name`` implies more than the budget of ``kind``.

    asked: the work the call would do (array elements, evaluations or solver calls; a float
    so that a huge or infinite request is compared without overflow); limit: None for the
    budget in force (``current_limit(kind)``, raised with ``work_limits``). The ValueError
    names the parameter, the size asked for and the limit, and says how to raise it.
    """
    lim = current_limit(kind) if limit is None else limit
    if not asked <= lim:  # also refuses NaN
        shown = str(math.ceil(asked)) if math.isfinite(asked) and asked <= 1e18 else f"{asked:.3g}"
        raise ValueError(
            f"{name} asks for {shown} {_UNITS[kind]}, more than the limit of {int(lim)}; raise the limit "
            f"with droneplan.core.validation.work_limits({kind}=...) if the work is intended"
        )


def _describe(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def check_real(
    name: str, value: Any, *, finite: bool = True, max_abs: float | None = MAX_COORDINATE
) -> float:
    """``value`` as a float; TypeError unless it is a real number (bools are refused),
    ValueError if ``finite`` and it is NaN or infinite, or if it is finite and larger than
    ``max_abs`` in magnitude (default ``MAX_COORDINATE``, 1e15: beyond it squares and products of
    lengths, times or speeds overflow or lose every digit; None: no limit)."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Real):
        raise TypeError(f"{name} must be a real number, got {type(value).__name__} {_describe(value)}")
    out = float(value)
    if math.isnan(out) or (finite and not math.isfinite(out)):
        raise ValueError(f"{name} must be finite, got {out}")
    if max_abs is not None and math.isfinite(out) and abs(out) > max_abs:
        raise ValueError(
            f"{name} has magnitude {abs(out):.3g}, more than {max_abs:.3g} (beyond it squares and products "
            "overflow or lose every digit)"
        )
    return out


def check_positive(name: str, value: Any) -> float:
    """``value`` as a float; it must be a finite real number > 0."""
    out = check_real(name, value)
    if out <= 0:
        raise ValueError(f"{name} must be > 0, got {out}")
    return out


def check_nonneg(name: str, value: Any) -> float:
    """``value`` as a float; it must be a finite real number >= 0."""
    out = check_real(name, value)
    if out < 0:
        raise ValueError(f"{name} must be >= 0, got {out}")
    return out


def check_in_range(
    name: str,
    value: Any,
    lo: float | None = None,
    hi: float | None = None,
    *,
    lo_open: bool = False,
    hi_open: bool = False,
) -> float:
    """``value`` as a float inside [lo, hi] (``lo_open``/``hi_open`` exclude the end; None: no end)."""
    out = check_real(name, value)
    if lo is not None and (out < lo or (lo_open and out == lo)):
        raise ValueError(f"{name} must be {'>' if lo_open else '>='} {lo}, got {out}")
    if hi is not None and (out > hi or (hi_open and out == hi)):
        raise ValueError(f"{name} must be {'<' if hi_open else '<='} {hi}, got {out}")
    return out


def check_int(name: str, value: Any, *, min_value: int | None = None, max_value: int | None = None) -> int:
    """``value`` as an int (Python or numpy integer; bools and floats are refused) in
    [min_value, max_value]."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Integral):
        raise TypeError(f"{name} must be an int, got {type(value).__name__} {_describe(value)}")
    out = int(value)
    if min_value is not None and out < min_value:
        raise ValueError(f"{name} must be >= {min_value}, got {out}")
    if max_value is not None and out > max_value:
        raise ValueError(f"{name} must be <= {max_value}, got {out}")
    return out


def check_bool(name: str, value: Any) -> bool:
    """``value`` as a bool; TypeError unless it is a Python or numpy bool."""
    if not isinstance(value, (bool, np.bool_)):
        raise TypeError(f"{name} must be a bool, got {type(value).__name__} {_describe(value)}")
    return bool(value)


def check_size(name: str, n_elements: float, limit: int | None = None) -> None:
    """Refuse up front (before allocating) a request for more than ``limit`` array elements
    (None: the budget in force, ``MAX_ELEMENTS`` unless raised with ``work_limits``)."""
    check_work(name, n_elements, "elements", limit=limit)


def check_typed_array(name: str, value: Any, kinds: str, what: str) -> np.ndarray:
    """``value`` as an ndarray of its own dtype, which must be of a numpy kind in ``kinds``
    (``"b"``: bool flags, ``"iu"``: integer indices); nothing is converted.

    what: how messages describe the array (``"a bool array"``). Strings, None, ragged nesting and
    another dtype raise TypeError naming ``name``; an empty list takes the first kind.
    """
    if isinstance(value, (str, bytes)) or value is None:
        raise TypeError(f"{name} must be {what}, got {type(value).__name__}")
    try:
        arr = np.asarray(value)
    except (ValueError, TypeError) as exc:  # ragged nesting
        raise TypeError(f"{name} must be {what} ({exc})") from None
    if arr.size == 0 and arr.dtype.kind in "fO":  # an empty list has no dtype of its own
        arr = arr.astype(bool if kinds[0] == "b" else np.int64)
    if arr.dtype.kind not in kinds:
        raise TypeError(f"{name} must be {what}, got dtype {arr.dtype}")
    return arr


def check_array(  # noqa: C901
    name: str,
    value: Any,
    *,
    shape: Sequence[int | None] | None = None,
    finite: bool = True,
    min_rows: int = 0,
    ndim: int | None = None,
    max_abs: float | None = MAX_COORDINATE,
) -> np.ndarray:
    """``value`` as a float ndarray (a copy), checked for type, shape, finiteness and magnitude.

    shape: expected shape, ``None`` entries match any length (e.g. ``(None, 2)`` for an
    (n, 2) array of points); ndim: expected number of dimensions when ``shape`` is not
    given; min_rows: least length of the first axis; finite: refuse NaN/inf; max_abs:
    largest magnitude of a finite entry (default ``MAX_COORDINATE``: beyond it squares and
    distances overflow or lose every digit; None: no limit).
    Bools, strings, objects and ragged nesting raise TypeError naming ``name``.
    """
    if isinstance(value, (str, bytes)) or value is None:
        raise TypeError(f"{name} must be an array of numbers, got {type(value).__name__}")
    try:
        raw = np.asarray(value)
    except (ValueError, TypeError) as exc:  # ragged nesting
        raise TypeError(f"{name} must be a rectangular array of numbers ({exc})") from None
    if raw.dtype == bool or raw.dtype.kind not in "iuf":
        if raw.size == 0 and raw.dtype.kind in "Of":
            raw = raw.astype(float)
        else:
            raise TypeError(f"{name} must be an array of real numbers, got dtype {raw.dtype}")
    arr = np.array(raw, dtype=float)
    if shape is not None:
        if arr.ndim == 1 and arr.size == 0 and len(shape) == 2 and shape[0] is None:
            arr = arr.reshape(0, shape[1] if shape[1] is not None else 0)
        wanted = "(" + ", ".join("n" if s is None else str(s) for s in shape) + ")"
        if arr.ndim != len(shape) or any(
            s is not None and s != a for s, a in zip(shape, arr.shape, strict=True)
        ):
            raise ValueError(f"{name} must have shape {wanted}, got {arr.shape}")
    elif ndim is not None and arr.ndim != ndim:
        raise ValueError(f"{name} must be a {ndim}-D array, got shape {arr.shape}")
    if arr.ndim and arr.shape[0] < min_rows:
        raise ValueError(f"{name} must have at least {min_rows} row(s), got {arr.shape[0]}")
    # the common case in one pass each: every entry within +-max_abs (NaN fails both
    # comparisons, inf the finite bound); otherwise the tests below name the fault
    bound = max_abs if finite and max_abs is not None and math.isfinite(max_abs) and arr.size else None
    if bound is not None and -bound <= float(arr.min()) and float(arr.max()) <= bound:
        return arr
    if finite and not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must be finite (no NaN or inf)")
    if max_abs is not None and arr.size:
        big = np.abs(arr[np.isfinite(arr)]) if not finite else np.abs(arr)
        if big.size and float(big.max()) > max_abs:
            raise ValueError(
                f"{name} has an entry of magnitude {float(big.max()):.3g}, more than {max_abs:.3g} "
                "(beyond it squared distances overflow or lose every digit)"
            )
    return arr


def check_sequence(name: str, value: Any, *, min_len: int = 1) -> list[Any]:
    """``value`` as a list (any iterable but a string, bytes or mapping), with at least
    ``min_len`` items; TypeError naming ``name`` otherwise, ValueError when too short."""
    if isinstance(value, (str, bytes, dict)) or value is None or not hasattr(value, "__iter__"):
        raise TypeError(f"{name} must be a list or another sequence, got {type(value).__name__}")
    out = list(value)
    if len(out) < min_len:
        raise ValueError(f"{name} must hold at least {min_len} item(s), got {len(out)}")
    return out


def check_time_limit(time_limit: Any, name: str = "time_limit") -> float | None:
    """None, or a finite number of seconds > 0 (bools refused) as a float."""
    if time_limit is None:
        return None
    if isinstance(time_limit, (bool, np.bool_)) or not isinstance(time_limit, numbers.Real):
        raise TypeError(f"{name} must be a number of seconds or None, got {type(time_limit).__name__}")
    if not math.isfinite(time_limit) or time_limit <= 0:
        raise ValueError(f"{name} must be a finite number of seconds > 0, got {time_limit}")
    return float(time_limit)


def check_methods(name: str, obj: Any, methods: Sequence[str]) -> None:
    """TypeError unless ``obj`` has every callable in ``methods`` (e.g. a controller protocol)."""
    missing = [m for m in methods if not callable(getattr(obj, m, None))]
    if missing:
        raise TypeError(
            f"{name} must provide {', '.join(methods)}(); {type(obj).__name__} lacks {', '.join(missing)}"
        )


def check_instance(name: str, value: Any, cls: type | tuple[type, ...], *, optional: bool = False) -> Any:
    """``value`` itself; TypeError naming ``name`` unless it is an instance of ``cls``
    (or None when ``optional``)."""
    if optional and value is None:
        return value
    if not isinstance(value, cls):
        wanted = cls.__name__ if isinstance(cls, type) else " or ".join(c.__name__ for c in cls)
        raise TypeError(
            f"{name} must be {wanted}{' or None' if optional else ''}, got {type(value).__name__}"
        )
    return value


_T = TypeVar("_T")


def require_set(value: _T | None, what: str) -> _T:
    """``value`` itself, known not to be None; RuntimeError naming ``what`` when it is None.

    For internal invariants (a value set by an earlier step) where ``assert x is not None``
    would be stripped by ``python -O``: the check stays, and a type checker narrows the type.
    """
    if value is None:
        raise RuntimeError(f"internal invariant broken: {what} (please report this as a bug)")
    return value


def resolve_seed(seed: Any, name: str = "seed") -> tuple[np.random.Generator, int | None]:
    """The random generator for ``seed`` and the seed to record, so a run can be repeated.

    seed: an int >= 0 (the generator is ``numpy.random.default_rng(seed)``, recorded as
    is), a ``numpy.random.Generator`` (used as is; its state belongs to the caller, so
    the recorded seed is None) or None (a fresh seed is drawn from the OS's entropy,
    used and recorded). Anything else raises TypeError naming ``name``.
    """
    if isinstance(seed, np.random.Generator):
        return seed, None
    if seed is None:
        seed = int(np.random.SeedSequence().generate_state(1, dtype=np.uint64)[0] >> np.uint64(1))
    seed = check_int(name, seed, min_value=0)
    return np.random.default_rng(seed), seed


def as_generator(seed: Any, name: str = "seed") -> np.random.Generator:
    """The random generator for ``seed`` (int >= 0, Generator or None); see ``resolve_seed``."""
    return resolve_seed(seed, name)[0]


def run_seed(seed: int, run: int) -> int:
    """The seed of repetition ``run`` of a job whose own seed is ``seed`` (both ints >= 0).

    seed: the job's seed; run: the repetition index (0, 1, ...). Run 0 gets ``seed`` itself, so
    one run is the job as it always was; run r >= 1 gets a 32-bit seed drawn from
    ``numpy.random.SeedSequence(seed, spawn_key=(r,))``, independent of the other runs' seeds.
    """
    seed = check_int("seed", seed, min_value=0)
    run = check_int("run", run, min_value=0)
    if run == 0:
        return seed
    return int(np.random.SeedSequence(seed, spawn_key=(run,)).generate_state(1, dtype=np.uint32)[0])
