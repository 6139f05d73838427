"""Operator-shark assignment (thesis §5.3.1): one operator per shark, minimise the latest interception.

The thesis allocates one operator to each spotted shark (s <= n); when s > n sharks are spotted
it raises the highest alert and sends all n operators to the n sharks closest to humans.
Here the allocation is an explicit bottleneck assignment model solved by CP-SAT:

    min  Z * M + sum_ij c_ij x_ij
    s.t. sum_i x_ij = 1 for every selected shark j, sum_j x_ij <= 1 for every operator i,
         Z >= c_ij x_ij  (Z = latest interception),  x binary,

with c_ij the interception time (s) of operator i on shark j (quantised to 1 ms) and M large
enough that the latest interception is minimised first and the total second.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray
from ortools.sat.python import cp_model

from droneplan.core.validation import check_array, check_int, check_time_limit
from droneplan.solvers.registry import get_backend
from droneplan.solvers.result import SolveResult, Status

__all__ = [
    "Assignment",
    "select_sharks",
    "build_assignment_model",
    "solve_assignment",
    "greedy_assignment",
    "assignment_cost",
]

_SCALE = 1000  # ms

MAX_WORKERS = 256
"""Most CP-SAT search workers a call may ask for (one thread each)."""


@dataclass(frozen=True)
class Assignment:
    """operator[j]: index of the operator sent to selected shark sharks[j]; latest, total: s."""

    sharks: NDArray[np.integer[Any]]
    operator: NDArray[np.integer[Any]]
    latest: float
    total: float


def _check_cost(cost) -> NDArray[np.float64]:
    c = check_array("cost", cost, finite=False)
    if c.ndim != 2 or c.size == 0:
        raise ValueError("cost must be a non-empty (n_operators, n_sharks) matrix")
    if np.isnan(c).any() or (c < 0).any():
        raise ValueError("cost entries must be >= 0 (inf allowed for 'cannot intercept')")
    return c


def _check_distances(shark_to_human: Any, s: int | None = None) -> NDArray[np.float64]:
    """``shark_to_human`` as an (s,) array of finite distances >= 0 (m)."""
    d = check_array("shark_to_human", shark_to_human, shape=(s,))
    if (d < 0).any():
        raise ValueError("shark_to_human must hold distances >= 0 (m)")
    return d


def _check_indices(sharks: Any, n_columns: int) -> NDArray[np.int64]:
    """``sharks`` as distinct integer column indices in [0, n_columns)."""
    raw = check_array("sharks", sharks, ndim=1)
    idx = raw.astype(np.int64)
    if not np.array_equal(idx, raw) or (idx < 0).any() or (idx >= n_columns).any():
        raise ValueError(f"sharks must hold integer column indices of cost in [0, {n_columns}), got {raw}")
    if len(np.unique(idx)) != len(idx):
        raise ValueError("sharks must not repeat a shark")
    return idx


def select_sharks(shark_to_human, n_operators: int) -> NDArray[np.integer[Any]]:
    """Indices of the sharks to serve: all if s <= n, else the n closest to humans (thesis §5.3.1).

    shark_to_human: (s,) distance (m) from each shark to its nearest human.
    """
    d = _check_distances(shark_to_human)
    if not isinstance(n_operators, (int, np.integer)) or n_operators < 1:
        raise ValueError("n_operators must be a positive int")
    order = np.argsort(d, kind="stable")
    return np.sort(order[:n_operators])


def assignment_cost(cost, sharks, operator) -> tuple[float, float]:
    """(latest, total) interception time (s) of an assignment."""
    c = _check_cost(cost)
    v = c[np.asarray(operator, int), np.asarray(sharks, int)]
    return float(v.max()), float(v.sum())


def build_assignment_model(cost, sharks):
    """Build (only) the CP-SAT model for the selected sharks; returns (model, ``x[i][j]`` vars, Z).

    cost: (n_operators, n_sharks) interception times (s); inf where impossible.
    sharks: indices of the selected sharks (columns of ``cost``).
    """
    c = _check_cost(cost)
    n = c.shape[0]
    sharks = _check_indices(sharks, c.shape[1])
    if len(sharks) > n:
        raise ValueError(f"{len(sharks)} sharks selected for {n} operators: select at most n (select_sharks)")
    finite = np.isfinite(c[:, sharks])
    big = int(np.ceil(_SCALE * (c[:, sharks][finite].max() if finite.any() else 1.0))) + 1
    q = np.where(finite, np.round(_SCALE * np.where(finite, c[:, sharks], 0)).astype(np.int64), -1)
    m = cp_model.CpModel()
    x = [
        [m.new_bool_var(f"x_{i}_{j}") if q[i, j] >= 0 else None for j in range(len(sharks))] for i in range(n)
    ]
    Z = m.new_int_var(0, big, "Z")
    for j in range(len(sharks)):
        m.add_exactly_one([v for v in (x[i][j] for i in range(n)) if v is not None])
    for i in range(n):
        row = [v for v in x[i] if v is not None]
        if row:
            m.add_at_most_one(row)
        for j, v in enumerate(x[i]):
            if v is not None:
                m.add(int(q[i, j]) <= Z).only_enforce_if(v)
    M = big * len(sharks) + 1
    m.minimize(
        M * Z + sum(int(q[i, j]) * v for i, row in enumerate(x) for j, v in enumerate(row) if v is not None)
    )
    return m, x, Z


def solve_assignment(
    cost, *, shark_to_human=None, time_limit: float | None = 10.0, workers: int = 1, backend: str = "cp-sat"
) -> SolveResult:
    """Minimise the latest interception time over one-to-one operator-shark assignments.

    cost: (n_operators, n_sharks) interception times (s), inf where impossible.
    shark_to_human: (s,) distances (m) to the nearest human; required when s > n to pick the
    n sharks closest to humans (thesis); ignored otherwise.
    backend: a registered "cp" backend (solves the CP-SAT model; "cp-sat").
    Returns x = `Assignment`, objective = latest interception (s), bound = CP-SAT's bound on it.

    time_limit: CP-SAT wall-clock limit (s), None: none.
    workers: CP-SAT search workers (count).
    """
    c = _check_cost(cost)
    n, s = c.shape
    time_limit = check_time_limit(time_limit)
    workers = check_int("workers", workers, min_value=1, max_value=MAX_WORKERS)
    if s > n:
        if shark_to_human is None:
            raise ValueError(f"s={s} > n={n}: pass shark_to_human to select the n sharks closest to humans")
        sharks = select_sharks(shark_to_human, n)
    else:
        sharks = np.arange(s)
    model, x, _ = build_assignment_model(c, sharks)
    flat = [v for row in x for v in row if v is not None]
    idx = [(i, j) for i, row in enumerate(x) for j, v in enumerate(row) if v is not None]
    res = get_backend(backend, kind="cp").solve_cp(
        model, variables=flat, time_limit=time_limit, workers=workers
    )
    if not res.has_solution:
        return dataclasses.replace(res, message=f"assignment: {res.message}")
    op = np.full(len(sharks), -1)
    for (i, j), val in zip(idx, res.x, strict=True):  # one value per variable of ``flat``
        if val:
            op[j] = i
    latest, total = assignment_cost(c, sharks, op)
    M = int(np.ceil(_SCALE * np.nanmax(np.where(np.isfinite(c[:, sharks]), c[:, sharks], 0)))) + 1
    M = M * len(sharks) + 1
    bound = None if res.bound is None else float(np.floor(res.bound / M)) / _SCALE
    return dataclasses.replace(
        res,
        x=Assignment(sharks, op, latest, total),
        objective=latest,
        bound=bound,
        message=f"bottleneck assignment of {len(sharks)} sharks to {n} operators (times quantised to 1 ms)",
    )


def greedy_assignment(operators, sharks_pos, shark_to_human, cost) -> SolveResult:
    """Baseline: sharks in order of distance to humans each take the nearest free operator.

    operators (n,3), sharks_pos (s,3) in m; cost as in `solve_assignment` (used only to score).

    shark_to_human: (s,) distance of each shark to its nearest human (m); closer sharks choose first.
    """
    c = _check_cost(cost)
    O = check_array("operators", operators, shape=(None, 3), min_rows=1)
    Sp = check_array("sharks_pos", sharks_pos, shape=(None, 3), min_rows=1)
    n = len(O)
    if c.shape != (n, len(Sp)):
        raise ValueError(
            f"cost must have shape (len(operators), len(sharks_pos)) = {(n, len(Sp))}, got {c.shape}"
        )
    dist = _check_distances(shark_to_human, len(Sp))
    sel = select_sharks(dist, n) if len(Sp) > n else np.arange(len(Sp))
    order = sel[np.argsort(dist[sel], kind="stable")]
    free = list(range(n))
    op = {}
    for j in order:
        d = [np.linalg.norm(O[i, :2] - Sp[j, :2]) for i in free]
        op[j] = free.pop(int(np.argmin(d)))
    ops = np.array([op[j] for j in sel])
    latest, total = assignment_cost(c, sel, ops)
    return SolveResult(
        Status.FEASIBLE,
        objective=latest,
        x=Assignment(sel, ops, latest, total),
        backend="greedy",
        message="greedy nearest-operator assignment (heuristic)",
    )
