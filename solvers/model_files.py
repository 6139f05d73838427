"""Models written as MPS or LP files, the formats every MIP solver reads.

A CP-SAT model whose constraints are linear (linear rows, at-most-one, exactly-one, clauses, with
or without an enforcement literal on a clause) is translated row by row into a HiGHS model, which
highspy then writes; a pywraplp model (HiGHS, SCIP) goes to HiGHS through its model proto. The file
format follows the suffix: ``.mps`` (free MPS) or ``.lp`` (CPLEX LP). Variable and row names
are the model's own.

A literal of CP-SAT is a variable x or its negation, written ``1 - x``. CP-SAT minimises
``scaling_factor * (sum c x + offset)``; a negative scaling factor is a maximisation, so the
file says ``max`` with the original coefficients, and its objective value is the model's.

Files are written to a temporary name in the target folder and renamed into place, so a
failure leaves no partial file.
"""

from __future__ import annotations

import contextlib
import os
import tempfile
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

__all__ = [
    "MODEL_SUFFIXES",
    "check_model_path",
    "check_model_file",
    "write_through_temp",
    "write_cp_model",
    "write_highs",
]

MODEL_SUFFIXES = (".mps", ".lp")
"""The model file formats, by suffix."""


def check_model_path(path: Any) -> Path:
    """``path`` as a Path ending in ``.mps`` or ``.lp`` whose folder exists and is writable; a
    one-line ValueError or TypeError naming ``path`` otherwise."""
    if not isinstance(path, (str, os.PathLike)):
        raise TypeError(f"path must be a file path (str or os.PathLike), got {type(path).__name__}")
    p = Path(path)
    if p.suffix.lower() not in MODEL_SUFFIXES:
        raise ValueError(
            f"path must end in {' or '.join(MODEL_SUFFIXES)} (the file format), got {str(p)[-80:]!r}"
        )
    folder = p.parent if str(p.parent) else Path(".")
    if not folder.is_dir():
        raise ValueError(f"path: folder {str(folder)[-80:]!r} does not exist")
    if not os.access(folder, os.W_OK):
        raise ValueError(f"path: folder {str(folder)[-80:]!r} is not writable")
    return p


def write_highs(highs: Any, path: str | os.PathLike[str]) -> Path:
    """Write a HiGHS model to ``path`` (``.mps`` or ``.lp``, HiGHS picks the format by suffix).

    highs: a ``highspy.Highs`` holding the model. path: the file (checked by
    :func:`check_model_path`). Returns the path; a failure leaves no partial file.
    """
    import highspy  # type: ignore[import-untyped]

    def write(tmp: str) -> None:
        if highs.writeModel(tmp) != highspy.HighsStatus.kOk:
            raise OSError(f"HiGHS could not write {path}")

    return write_through_temp(path, write)


def write_through_temp(path: str | os.PathLike[str], write: Callable[[str], Any]) -> Path:
    """Write a model file with ``write(temporary_name)`` and rename it to ``path``.

    path: the file, ``.mps`` or ``.lp`` (checked by
    :func:`~droneplan.solvers.model_files.check_model_path`); the temporary file sits in the
    same folder with the same suffix (the solvers choose the format by suffix). write: the
    solver's own writer. Returns the path; a failure leaves no partial file.
    """
    target = check_model_path(path)
    fd, tmp = tempfile.mkstemp(dir=target.parent, prefix=f".{target.stem}.", suffix=target.suffix.lower())
    os.close(fd)
    try:
        write(tmp)
        if not os.path.getsize(tmp):
            raise OSError(f"the solver wrote nothing to {target}")
        os.replace(tmp, target)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise
    return target


def check_model_file(path: Any) -> str:
    """An existing model file to read, as a string path; a one-line error otherwise.

    path: a ``str`` or ``os.PathLike`` naming an existing ``.mps`` or ``.lp`` file.
    """
    if not isinstance(path, (str, os.PathLike)):
        raise TypeError(f"path must be a file path (str or os.PathLike), got {type(path).__name__}")
    if not Path(path).is_file():
        raise ValueError(f"path: no file {str(path)[-80:]!r}")
    return os.fspath(path)


class _Rows:
    """Rows being collected as ``lo <= sum coef * var + constant <= hi``."""

    def __init__(self) -> None:
        self.lo: list[float] = []
        self.hi: list[float] = []
        self.index: list[np.ndarray] = []
        self.value: list[np.ndarray] = []
        self.names: list[str] = []

    def add(self, terms: dict[int, float], constant: float, lo: float, hi: float, name: str) -> None:
        keys = np.fromiter(terms, dtype=np.int32, count=len(terms))
        vals = np.fromiter((terms[k] for k in terms), dtype=float, count=len(terms))
        self.index.append(keys)
        self.value.append(vals)
        self.lo.append(lo - constant)
        self.hi.append(hi - constant)
        self.names.append(name)


def _literal_terms(literals: Sequence[int]) -> tuple[dict[int, float], float]:
    """The linear form of a sum of literals: a variable x counts +x, its negation 1 - x."""
    terms: dict[int, float] = {}
    constant = 0.0
    for ref in literals:
        if ref >= 0:
            terms[ref] = terms.get(ref, 0.0) + 1.0
        else:
            terms[-ref - 1] = terms.get(-ref - 1, 0.0) - 1.0
            constant += 1.0
    return terms, constant


def _interval(domain: Sequence[int], what: str) -> tuple[float, float]:
    """A one-interval CP-SAT domain as (lo, hi), infinite ends for CP-SAT's int64 limits."""
    if len(domain) != 2:
        raise ValueError(f"{what} has a domain of several intervals, which no MPS row can state")
    big = 2**62
    lo = -np.inf if domain[0] <= -big else float(domain[0])
    hi = np.inf if domain[1] >= big else float(domain[1])
    return lo, hi


_KINDS = (
    "linear", "at_most_one", "exactly_one", "bool_or", "bool_and", "bool_xor", "all_diff", "element",
    "int_div", "int_mod", "int_prod", "lin_max", "table", "automaton", "inverse", "circuit", "routes",
    "interval", "no_overlap", "no_overlap_2d", "cumulative", "reservoir",
)  # fmt: skip


def _kind(c: Any) -> str | None:
    """Which constraint ``c`` is (the C++-backed proto of recent OR-Tools, or protobuf's)."""
    if hasattr(c, "WhichOneof"):
        return str(c.WhichOneof("constraint") or "") or None
    return next((k for k in _KINDS if getattr(c, f"has_{k}")()), None)


def _has(proto: Any, field: str) -> bool:
    """Whether ``proto`` holds ``field`` (either proto flavour)."""
    return bool(proto.HasField(field) if hasattr(proto, "HasField") else getattr(proto, f"has_{field}")())


def _add_constraint(rows: _Rows, c: Any, k: int) -> None:
    """One CP-SAT constraint as linear rows (refused in one line when it has no linear form)."""
    name = c.name or f"c{k}"
    kind = _kind(c)
    enforced = list(c.enforcement_literal)
    if kind == "linear" and not enforced:
        lo, hi = _interval(list(c.linear.domain), f"constraint {name!r}")
        terms: dict[int, float] = {}
        for v, a in zip(c.linear.vars, c.linear.coeffs, strict=True):
            terms[int(v)] = terms.get(int(v), 0.0) + float(a)
        rows.add(terms, 0.0, lo, hi, name)
    elif kind in ("at_most_one", "exactly_one") and not enforced:
        lits = c.at_most_one.literals if kind == "at_most_one" else c.exactly_one.literals
        terms, constant = _literal_terms(lits)
        rows.add(terms, constant, -np.inf if kind == "at_most_one" else 1.0, 1.0, name)
    elif kind == "bool_or":
        # (e_1 and ... and e_k) => (l_1 or ... or l_n):  sum l + sum (1 - e) >= 1
        terms, constant = _literal_terms([*c.bool_or.literals, *(-e - 1 for e in enforced)])
        rows.add(terms, constant, 1.0, np.inf, name)
    elif kind == "bool_and" and len(enforced) <= 1:
        for j, lit in enumerate(c.bool_and.literals):  # e => l:  l + (1 - e) >= 1
            terms, constant = _literal_terms([lit, *(-e - 1 for e in enforced)])
            rows.add(terms, constant, 1.0, np.inf, f"{name}_{j}")
    else:
        what = kind if not enforced else f"enforced {kind}"
        raise ValueError(f"constraint {name!r} is a CP-SAT {what} constraint, which has no linear form here")


def write_cp_model(model: Any, path: str | os.PathLike[str]) -> Path:
    """Write a CP-SAT model with linear constraints as an MPS or LP file (module docstring).

    model: an ``ortools.sat.python.cp_model.CpModel`` (or its ``CpModelProto``). path: the file,
    ending in ``.mps`` or ``.lp``. Returns the path. A constraint without a linear form (an
    all-different, a multiplication, a multi-interval domain ...) is refused in one line naming
    it, and nothing is written.
    """
    import highspy

    target = check_model_path(path)
    proto = model.Proto() if hasattr(model, "Proto") else model
    n = len(proto.variables)
    lower = np.empty(n)
    upper = np.empty(n)
    for i, v in enumerate(proto.variables):
        domain = list(v.domain)  # a list: the C++-backed container does not index from the end
        lower[i], upper[i] = _interval([domain[0], domain[-1]], f"variable {v.name or i!r}")
    rows = _Rows()
    for k, c in enumerate(proto.constraints):
        _add_constraint(rows, c, k)
    h = highspy.Highs()
    h.silent()
    inf = highspy.kHighsInf
    h.addVars(n, np.where(np.isfinite(lower), lower, -inf), np.where(np.isfinite(upper), upper, inf))
    if n:
        h.changeColsIntegrality(n, np.arange(n, dtype=np.int32), np.full(n, highspy.HighsVarType.kInteger))
    for i, v in enumerate(proto.variables):
        h.passColName(i, v.name or f"v{i}")
    for lo, hi, idx, val, name in zip(rows.lo, rows.hi, rows.index, rows.value, rows.names, strict=True):
        h.addRow(lo if np.isfinite(lo) else -inf, hi if np.isfinite(hi) else inf, len(idx), idx, val)
        h.passRowName(h.getNumRow() - 1, name)
    _objective(h, proto, highspy)
    return write_highs(h, target)


def _objective(h: Any, proto: Any, highspy: Any) -> None:
    """The proto's objective on ``h``: maximise when CP-SAT's scaling factor is negative."""
    if _has(proto, "floating_point_objective"):
        obj = proto.floating_point_objective
        coeffs, offset, maximize = list(obj.coeffs), float(obj.offset), bool(obj.maximize)
    elif _has(proto, "objective"):
        obj = proto.objective
        scale = float(obj.scaling_factor) or 1.0
        coeffs, offset, maximize = [scale * a for a in obj.coeffs], scale * float(obj.offset), scale < 0
    else:
        return
    variables = np.asarray(list(obj.vars), dtype=np.int32)
    if len(variables):
        h.changeColsCost(len(variables), variables, np.asarray(coeffs, dtype=float))
    h.changeObjectiveOffset(offset)
    h.changeObjectiveSense(highspy.ObjSense.kMaximize if maximize else highspy.ObjSense.kMinimize)
