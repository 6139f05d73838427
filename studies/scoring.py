"""Scoring primitives every instance kind shares: the verdict (:class:`Scored`), what a method's
``SolveResult`` claims (recorded beside droneplan's own numbers, never in their place), and the
checks of plain numbers and plan arrays.

A kind's scorer (:meth:`droneplan.studies.kinds.base.Kind.score`) builds on these; the rules of a
row (statuses, claims, ``said_`` extras) are in :mod:`droneplan.studies.harness`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from droneplan.solvers.result import SolveResult, Status

__all__ = [
    "Scored",
    "COMPOSITE_INFO",
    "SAID",
    "MAX_SAID",
    "number",
    "is_scalar",
    "describe",
    "record_claims",
    "check_claim",
    "unwrap",
    "numeric_plan",
    "mark_infeasible",
]


@dataclass
class Scored:
    """Droneplan's verdict on one job (the method-independent part of its row)."""

    status: str
    objective: float | None = None
    bound: float | None = None
    bound_kind: str = "none"
    claimed_objective: float | None = None
    flags: list[str] = field(default_factory=list)
    message: str = ""
    warm_started: bool = False
    extras: dict[str, Any] = field(default_factory=dict)


COMPOSITE_INFO = "composite"
"""The entry of a warm-started composite's ``SolveResult.info`` that holds its row's extras (both
parts' times, the heuristic's verified objective, the warm start's fate)."""

_CLAIM_TOL = 1e-6


def number(v: Any) -> float | None:
    """A finite float from a Python or numpy number; None otherwise."""
    if isinstance(v, (bool, np.bool_)) or v is None:
        return None
    if isinstance(v, (int, float, np.integer, np.floating)):
        f = float(v)
        return f if math.isfinite(f) else None
    if isinstance(v, np.ndarray) and v.shape == () and v.dtype.kind in "iuf":
        return number(v.item())
    return None


def is_scalar(v: Any) -> bool:
    """Whether ``v`` is a value a row's extra column holds (None, a bool, a finite number, a str)."""
    return v is None or isinstance(v, (bool, str)) or number(v) is not None


def describe(v: Any) -> str:
    text = repr(v)
    return text if len(text) <= 60 else text[:57] + "..."


SAID = "said_"
"""The prefix of the row extras a method reports about its own run (``SolveResult.info["extras"]``
and its ``solve_time``): claims, recorded as such."""

MAX_SAID = 32
"""The most ``info["extras"]`` entries of one result kept on its row."""


def record_claims(scored: Scored, result: SolveResult, method: Any) -> None:
    """Record what a SolveResult claims beside droneplan's own numbers."""
    claimed = result.objective
    if claimed is not None:
        num = number(claimed)
        if num is None:
            scored.flags.append("claim-invalid")
            scored.extras["claimed_objective_text"] = describe(claimed)
        else:
            scored.claimed_objective = num
    status = result.status
    scored.extras["claimed_status"] = status.value if isinstance(status, Status) else describe(status)
    if not isinstance(status, Status):
        scored.flags.append("claim-invalid")
    scored.warm_started = bool(getattr(result, "warm_started", False))
    info = result.info if isinstance(result.info, Mapping) else {}
    evaluations = number(info.get("evaluations"))
    if evaluations is not None:
        scored.extras["evaluations"] = evaluations
    if result.bound is not None and not method.trusted_bound:
        scored.extras["claimed_bound"] = number(result.bound)
    if method.trusted_bound:  # droneplan's engines: their own solve time and search nodes
        scored.extras["solve_time_s"] = number(result.solve_time)
        stats = info.get("model_stats")
        places = (info, stats if isinstance(stats, Mapping) else {})
        found = (number(d.get(k)) for d in places for k in ("nodes", "num_branches"))
        nodes = next((n for n in found if n is not None), None)
        if nodes is not None:  # the branch and bound's search nodes, CP-SAT's branches
            scored.extras["nodes"] = nodes
        composite = info.get(COMPOSITE_INFO) if getattr(method, "heuristic", None) is not None else None
        if isinstance(composite, Mapping):
            scored.extras.update({str(k): v for k, v in composite.items() if is_scalar(v)})
    # what a method says about its run (``info["extras"]``, its own clock) is kept under ``said_``
    # names beside droneplan's numbers, never in their place
    said = info.get("extras")
    if isinstance(said, Mapping):
        kept = list(said.items())[:MAX_SAID]
        scored.extras.update({f"{SAID}{str(k)[:40]}": v for k, v in kept if is_scalar(v)})
    scored.extras.setdefault(f"{SAID}solve_time_s", number(result.solve_time))


def check_claim(scored: Scored) -> None:
    if scored.claimed_objective is None or scored.objective is None:
        return
    if abs(scored.claimed_objective - scored.objective) > _CLAIM_TOL * max(1.0, abs(scored.objective)):
        scored.flags.append("claim-mismatch")
        scored.message = (
            f"the method claims {scored.claimed_objective:g}, droneplan measures {scored.objective:g}; "
            + scored.message
        ).rstrip("; ")


def unwrap(returned: Any, method: Any, scored: Scored) -> tuple[Any, bool]:
    """The plan inside ``returned`` and whether there is one (a SolveResult may carry none)."""
    if isinstance(returned, SolveResult):
        record_claims(scored, returned, method)
        if returned.x is None:
            scored.status = "no_solution"
            scored.message = f"the method returned no plan (its status: {scored.extras['claimed_status']})"
            return None, False
        return returned.x, True
    return returned, True


def numeric_plan(plan: Any, tail: tuple[int, ...], lead: int | None = None) -> np.ndarray | str:
    """``plan`` as a float array of shape (k, *tail), or (lead, k, *tail) when ``lead`` is given
    (one placement per epoch); a one-line reason when it is not one."""
    try:
        raw = np.asarray(plan)
    except (TypeError, ValueError):
        raw = np.asarray(None)
    if raw.dtype.kind not in "iuf" and raw.size:
        return f"positions must be numbers (reals), got {describe(plan)}"
    pos = raw.astype(float)
    head = () if lead is None else (lead,)
    if pos.size == 0:
        pos = pos.reshape(*head, 0, *tail)
    if lead is None and pos.ndim == 1 and pos.shape == tail:
        pos = pos.reshape(1, *tail)
    shape = pos.shape[: len(head)] + pos.shape[len(head) + 1 :]
    if pos.ndim != len(head) + 1 + len(tail) or shape != head + tail:
        want = ", ".join(str(d) for d in (*head, "k", *tail))
        return f"positions must have shape ({want}), got {pos.shape}"
    if not np.all(np.isfinite(pos)):
        return "positions contain NaN or inf"
    return pos


def mark_infeasible(scored: Scored, violations: Any) -> None:
    """Mark ``scored`` infeasible with the first three ``violations`` in its message."""
    more = f" (+{len(violations) - 3} more)" if len(violations) > 3 else ""
    scored.status = "infeasible"
    scored.message = "; ".join(violations[:3]) + more
