"""Moving users (thesis §4.2 names the case): drone-cells that follow users over T epochs, each
moving at most ``max_move`` metres between consecutive epochs.

Joint model (:func:`solve_mobile`): one placement block per epoch (``_levels.SiteBlock``: the
candidate points of every epoch, so that a drone-cell may stay where it was, with that epoch's
coverage, non-overlap and backhaul rows) in one linear model, and
between consecutive epochs t, t + 1 a transport of the chosen sites::

    max  sum_t covered (served) weight of epoch t
    s.t. sum_d f_{t,c,d} = x_{t,c},   sum_c f_{t,c,d} = x_{t+1,d},   f >= 0
         f_{t,c,d} only for |c - d| <= max_move (on the ground)

Each drone-cell keeps its index, so it exists in every epoch: the same number of drone-cells in
each, and a perfect matching of epoch t's sites to epoch t + 1's along arcs of at most
``max_move``. The transport rows admit a fractional f exactly when such a matching exists (the
bipartite matching polytope is integral), so f needs no integrality. The plan's drone-cells are
then chained epoch to epoch by a maximum bipartite matching on those arcs.

Baseline (:func:`myopic`): each epoch solved exactly on its own (``solve_exact``), kept when it
can be matched to the previous epoch's drone-cells within ``max_move``; otherwise repaired by
the exact re-solve of that epoch with the previous one fixed (the joint model on two epochs), or,
when that finds no plan in the time left, the previous placement kept.
"""

from __future__ import annotations

import dataclasses
import itertools
import time
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import maximum_bipartite_matching
from scipy.spatial import cKDTree

from droneplan.core.validation import check_array, check_instance, check_int, check_nonneg, check_time_limit
from droneplan.formulations.cells._core import TOL, Candidates, candidate_sites, evaluate
from droneplan.formulations.cells._exact import solve_exact
from droneplan.formulations.cells._levels import SiteBlock
from droneplan.formulations.cells._model import _new_model
from droneplan.formulations.cells._open import MAX_WORKERS
from droneplan.scenarios.cells import CellProblem
from droneplan.solvers.result import SolveResult, Status

__all__ = ["MobileProblem", "MobileEvaluation", "evaluate_mobile", "solve_mobile", "myopic"]


class MobileProblem:
    """Drone-cell placement over T epochs of moving users.

    problem: the CellProblem of the GBSs, radii, n_cells, bounds and variants (its own users are
    not used; weights, when given, follow the users by index). snapshots: (T, n, 2) user
    positions (m), one row of n users per epoch, T >= 1. max_move: the most a drone-cell moves
    on the ground between consecutive epochs (m, >= 0).
    """

    def __init__(self, problem: CellProblem, snapshots: Any, max_move: float) -> None:
        check_instance("problem", problem, CellProblem)
        arr = check_array("snapshots", snapshots)
        if arr.ndim != 3 or arr.shape[2] != 2 or arr.shape[0] < 1:
            raise ValueError(f"snapshots must have shape (T, n, 2) with T >= 1, got {arr.shape}")
        if problem.weights is not None and arr.shape[1] != len(problem.weights):
            raise ValueError(
                f"snapshots hold {arr.shape[1]} users per epoch but the problem has "
                f"{len(problem.weights)} weights"
            )
        arr.setflags(write=False)
        self.problem = problem
        self.snapshots = arr
        self.max_move = check_nonneg("max_move", max_move)
        self.epochs = tuple(problem.with_users(users) for users in arr)
        self._points: np.ndarray | None = None

    def candidates(self, epoch: int, extra: Any = None) -> Candidates:
        """The candidate sites of ``epoch`` in the joint model: every epoch's candidate points
        (so that a drone-cell may stay where it was), plus ``extra`` ((q, w) m), kept where a
        drone-cell may stand, with their coverage of this epoch's users."""
        if self._points is None:
            self._points = np.concatenate([candidate_sites(e).plan(slice(None)) for e in self.epochs])
        points = self._points if extra is None else np.concatenate([np.asarray(extra, float), self._points])
        return candidate_sites(self.epochs[epoch], extra=points)

    @property
    def n_epochs(self) -> int:
        """T, the number of epochs."""
        return len(self.epochs)

    def __repr__(self) -> str:
        return (
            f"MobileProblem(epochs={self.n_epochs}, users={self.snapshots.shape[1]}, "
            f"max_move={self.max_move}, problem={self.problem!r})"
        )


@dataclass(frozen=True)
class MobileEvaluation:
    """Outcome of :func:`evaluate_mobile`."""

    value: float
    """The covered (served) weight summed over the epochs."""
    per_epoch: tuple[float, ...]
    """Each epoch's covered (served) weight."""
    feasible: bool
    """Every epoch's placement is feasible and no drone-cell moves more than ``max_move``."""
    violations: tuple[str, ...]
    """What breaks feasibility, epoch by epoch."""


def evaluate_mobile(mp: MobileProblem, plan: Any) -> MobileEvaluation:
    """Check a plan of moving drone-cells.

    mp: the :class:`MobileProblem`. plan: (T, k, w) positions (m; w = 2, or 3 with altitude
    levels), drone-cell i at ``plan[t, i]`` in epoch t."""
    check_instance("mp", mp, MobileProblem)
    arr = check_array("plan", plan)
    width = mp.problem.plan_width
    if arr.size == 0:
        arr = arr.reshape(mp.n_epochs, 0, width)
    if arr.ndim != 3 or arr.shape[0] != mp.n_epochs or arr.shape[2] != width:
        raise ValueError(f"plan must have shape ({mp.n_epochs}, k, {width}), got {arr.shape}")
    violations: list[str] = []
    values = []
    for t, epoch in enumerate(mp.epochs):
        ev = evaluate(epoch, arr[t])
        values.append(ev.value)
        violations += [f"epoch {t}: {v}" for v in ev.violations]
    moves = (
        np.hypot(*(arr[1:, :, :2] - arr[:-1, :, :2]).transpose(2, 0, 1)) if len(arr) > 1 else np.zeros((0, 0))
    )
    for t, i in zip(*np.nonzero(moves > mp.max_move + TOL), strict=True):
        violations.append(f"drone-cell {i} moves {moves[t, i]:.3f} m from epoch {t} to {t + 1} > max_move")
    return MobileEvaluation(
        value=float(sum(values)),
        per_epoch=tuple(values),
        feasible=not violations,
        violations=tuple(violations),
    )


def solve_mobile(
    mp: MobileProblem,
    *,
    time_limit: float | None = None,
    backend: str = "cp-sat",
    workers: int | None = None,
    warm_start: Any = None,
) -> SolveResult:
    """The joint model of all epochs (module docstring), proven over each epoch's candidate sites.

    mp: the :class:`MobileProblem`. time_limit: wall-clock limit (s), None: none. backend:
    "cp-sat", "highs" or "scip" (CP-SAT takes integer weights only). workers: backend threads.
    warm_start: a feasible plan of moving drone-cells ((T, k, w) m, e.g. ``myopic(mp).x``) or a
        SolveResult holding one, None: none. Its positions join every epoch's candidate sites, it
        is handed to the backend as a start solution where the backend takes one, and the result
        is never worse than it: when the backend ends below its weight (or with no plan), the
        warm start is the returned plan, FEASIBLE, with the backend's bound.

    Returns a SolveResult: ``x`` the plan (T, k, w), ``objective`` the covered weight summed over
    the epochs, ``bound`` the backend's proven bound; ``info["evaluation"]`` is
    :func:`evaluate_mobile` of the plan, ``info["per_epoch"]`` each epoch's weight, and with a warm
    start ``info["warm_start"]`` its ``value``, whether the backend ``took`` it as a start and
    whether it was ``returned``.
    """
    check_instance("mp", mp, MobileProblem)
    workers = _check_workers(workers)
    limit = check_time_limit(time_limit)
    warm = _warm_plan(mp, warm_start)
    res = _joint(mp, fixed_first=None, time_limit=limit, backend=backend, workers=workers, warm=warm)
    return res if warm is None else _no_worse_than(mp, res, warm)


def _warm_plan(mp: MobileProblem, warm_start: Any) -> np.ndarray | None:
    """``warm_start`` as a feasible (T, k, w) plan of ``mp``, or None; a plan that breaks a rule
    is refused naming the first violation."""
    if warm_start is None:
        return None
    plan = warm_start.x if isinstance(warm_start, SolveResult) else warm_start
    if plan is None:
        raise ValueError("warm_start: the SolveResult holds no plan")
    arr = check_array("warm_start", plan)
    width = mp.problem.plan_width
    if arr.ndim != 3 or arr.shape[0] != mp.n_epochs or arr.shape[2] != width:
        raise ValueError(f"warm_start must have shape ({mp.n_epochs}, k, {width}), got {arr.shape}")
    ev = evaluate_mobile(mp, arr)
    if not ev.feasible:
        raise ValueError(f"warm_start must be a feasible plan: {ev.violations[0]}")
    return arr


def _no_worse_than(mp: MobileProblem, res: SolveResult, warm: np.ndarray) -> SolveResult:
    """``res``, or the warm start when the joint model's plan covers less (or there is none)."""
    value = evaluate_mobile(mp, warm).value
    ours = res.objective if res.has_solution and res.objective is not None else -np.inf
    returned = ours < value - 1e-9
    info = {**res.info, "warm_start": {"value": value, "took": res.warm_started, "returned": returned}}
    if not returned:
        return dataclasses.replace(res, info=info)
    ev = evaluate_mobile(mp, warm)
    info.update(evaluation=ev, per_epoch=ev.per_epoch)
    return dataclasses.replace(
        res,
        status=Status.OPTIMAL if res.bound is not None and value >= res.bound - 1e-9 else Status.FEASIBLE,
        objective=value,
        x=warm,
        message=f"{res.message}; the warm start ({value:g}) is better than the model's plan and is returned",
        info=info,
    )


def _joint(
    mp: MobileProblem,
    *,
    fixed_first: np.ndarray | None,
    time_limit: float | None,
    backend: str,
    workers: int | None,
    warm: np.ndarray | None = None,
) -> SolveResult:
    """The joint model; with ``fixed_first`` ((k, w) positions) epoch 0 is that placement; with
    ``warm`` ((T, k, w) plan) its positions are candidate sites and it is the backend's start."""
    t0 = time.perf_counter()
    lin = _new_model(backend)
    width = mp.problem.plan_width
    extra = None if fixed_first is None else np.asarray(fixed_first, float).reshape(-1, width)
    if warm is not None:
        extra = warm.reshape(-1, width) if extra is None else np.concatenate([extra, warm.reshape(-1, width)])

    def late() -> bool:
        return time_limit is not None and time.perf_counter() - t0 > time_limit

    blocks = []
    for t, epoch in enumerate(mp.epochs):
        blocks.append(SiteBlock(lin, epoch, mp.candidates(t, extra), late=late))
        if not blocks[-1].complete or late():
            return _built_too_late(mp, backend, t0)
    if fixed_first is not None:
        _fix(lin, blocks[0], fixed_first)
    arcs = [_transport_rows(lin, a, b, mp.max_move) for a, b in itertools.pairwise(blocks)]
    lin.maximize(lin.sum([b.objective for b in blocks]))
    variables = [v for b in blocks for v in b.x]
    left = None if time_limit is None else time_limit - (time.perf_counter() - t0)
    if left is not None and left <= 0.0:
        return _built_too_late(mp, backend, t0)
    hint = None if warm is None else _hint(blocks, warm)
    raw = lin.solve(variables=variables, time_limit=left, workers=workers, hint=hint)
    if not raw.has_solution:
        return SolveResult(
            raw.status,
            bound=raw.bound,
            backend=backend,
            backend_status=raw.backend_status,
            message=raw.message or f"the joint model of {mp.n_epochs} epochs: {raw.status.value}",
            solve_time=time.perf_counter() - t0,
            info={"engine": "milp"},
        )
    values = np.asarray(raw.x, dtype=float) > 0.5
    chosen, start = [], 0
    for b in blocks:
        chosen.append(np.flatnonzero(values[start : start + len(b.x)]))
        start += len(b.x)
    plan = _chain(blocks, chosen, arcs)
    ev = evaluate_mobile(mp, plan)
    status = raw.status if ev.feasible else Status.ERROR
    message = f"the joint model of {mp.n_epochs} epochs on {backend}"
    message += (
        ": proven optimal over the candidate sites" if status is Status.OPTIMAL else f" ({status.value})"
    )
    if not ev.feasible:
        message += "; its plan breaks: " + "; ".join(ev.violations[:3])
    return SolveResult(
        status,
        objective=float(raw.objective) if raw.objective is not None else None,
        bound=raw.bound,
        x=plan,
        backend=backend,
        backend_status=raw.backend_status,
        message=message,
        solve_time=time.perf_counter() - t0,
        warm_started=raw.warm_started,
        info={"engine": "milp", "evaluation": ev, "per_epoch": ev.per_epoch},
    )


def _built_too_late(mp: MobileProblem, backend: str, t0: float) -> SolveResult:
    """NO_SOLUTION: the time limit passed while the joint model was built (its build stops)."""
    return SolveResult(
        Status.NO_SOLUTION,
        backend=backend,
        message=f"the time limit was reached while the joint model of {mp.n_epochs} epochs was built",
        solve_time=time.perf_counter() - t0,
        info={"engine": "milp"},
    )


def _site_indices(block: SiteBlock, positions: np.ndarray) -> set[int]:
    """The candidate sites of ``block`` at ``positions`` (each must be one, within 1e-6 m)."""
    sites = block.cand.plan(np.arange(len(block.x)))
    found = set()
    for p in np.asarray(positions, dtype=float):
        i = int(np.argmin(np.abs(sites - p).max(axis=1)))
        if np.abs(sites[i] - p).max() > 1e-6:
            raise ValueError(f"the drone-cell at {p} is no candidate site")
        found.add(i)
    return found


def _hint(blocks: list[SiteBlock], warm: np.ndarray) -> dict:
    """The start solution of ``warm``: each epoch's site variables at 1 on its sites, 0 elsewhere."""
    hint = {}
    for block, positions in zip(blocks, warm, strict=True):
        chosen = _site_indices(block, positions)
        hint.update({var: 1.0 if i in chosen else 0.0 for i, var in enumerate(block.x)})
    return hint


def _fix(lin, block: SiteBlock, positions: np.ndarray) -> None:
    """Epoch 0 of ``block`` is exactly the placement ``positions`` (each a candidate site)."""
    fixed = _site_indices(block, positions)
    for i, var in enumerate(block.x):
        lin.add(var == (1 if i in fixed else 0))


def _transport_rows(lin, a: SiteBlock, b: SiteBlock, max_move: float) -> np.ndarray:
    """The transport rows from block ``a`` to block ``b`` (module docstring); returns the arcs."""
    pa, pb = a.cand.points, b.cand.points
    if not len(pa) or not len(pb):
        arcs = np.zeros((0, 2), dtype=np.int64)
    else:
        near = cKDTree(pb).query_ball_point(pa, max_move + TOL)
        arcs = np.array([(i, j) for i, js in enumerate(near) for j in js], dtype=np.int64).reshape(-1, 2)
    flow = [lin.unit_var(f"f{i}_{j}") for i, j in arcs.tolist()]
    out: list[list] = [[] for _ in pa]
    into: list[list] = [[] for _ in pb]
    for f, (i, j) in zip(flow, arcs.tolist(), strict=True):
        out[i].append(f)
        into[j].append(f)
    for i, var in enumerate(a.x):
        lin.add(lin.sum(out[i]) == var)
    for j, var in enumerate(b.x):
        lin.add(lin.sum(into[j]) == var)
    return arcs


def _chain(blocks: list[SiteBlock], chosen: list[np.ndarray], arcs: list[np.ndarray]) -> np.ndarray:
    """The (T, k, w) plan: epoch 0's sites in order, each later epoch's matched to the one before
    along the arcs (a maximum bipartite matching, perfect when the model's rows hold)."""
    order = chosen[0]
    plans = [blocks[0].cand.plan(order)]
    for t in range(1, len(blocks)):
        now = chosen[t]
        pos = {int(s): r for r, s in enumerate(now.tolist())}
        prev = {int(s): r for r, s in enumerate(order.tolist())}
        rows, cols = [], []
        for i, j in arcs[t - 1].tolist():
            if i in prev and j in pos:
                rows.append(prev[i])
                cols.append(pos[j])
        graph = csr_matrix((np.ones(len(rows)), (rows, cols)), shape=(len(order), len(now)))
        match = maximum_bipartite_matching(graph, perm_type="column") if len(order) else np.zeros(0, int)
        if len(order) != len(now) or np.any(match < 0):
            raise RuntimeError("the joint model's plan has no matching of drone-cells between epochs")
        order = now[match]
        plans.append(blocks[t].cand.plan(order))
    return np.stack(plans)


def myopic(
    mp: MobileProblem, *, time_limit: float | None = None, backend: str = "cp-sat", workers: int | None = None
) -> SolveResult:
    """The myopic baseline (module docstring): each epoch's exact optimum, repaired where the
    drone-cells cannot reach it within ``max_move``.

    mp: the :class:`MobileProblem`. time_limit: wall-clock limit (s) shared by the epochs, None:
    none. backend: the linear backend of the repairs ("cp-sat", "highs" or "scip"). workers:
    backend threads of the repairs (None: the backend's default).

    Returns a SolveResult (FEASIBLE: a heuristic for the joint problem) with the (T, k, w) plan
    and ``info["repaired"]``, the epochs re-solved with their predecessor fixed (``info["stayed"]``:
    those whose repair found no plan in the time left, where the drone-cells stay put, feasible
    since a placement's constraints do not involve the users).
    """
    check_instance("mp", mp, MobileProblem)
    limit = check_time_limit(time_limit)
    workers = _check_workers(workers)
    t0 = time.perf_counter()

    def left() -> float | None:
        return None if limit is None else max(limit - (time.perf_counter() - t0), 1.0)

    first = solve_exact(mp.epochs[0], time_limit=left())
    plans = [np.asarray(first.x, dtype=float).reshape(-1, mp.problem.plan_width)]
    repaired: list[int] = []
    stayed: list[int] = []
    for t in range(1, mp.n_epochs):
        alone = solve_exact(mp.epochs[t], time_limit=left())
        follow = _match_within(plans[-1], np.asarray(alone.x, dtype=float), mp.max_move)
        if follow is None:
            two = MobileProblem(mp.problem, mp.snapshots[t - 1 : t + 1], mp.max_move)
            step = _joint(two, fixed_first=plans[-1], time_limit=left(), backend=backend, workers=workers)
            if step.has_solution:
                follow = _match_within(plans[-1], step.x[1], mp.max_move)
                repaired.append(t)
            else:  # out of time: the drone-cells stay (a placement's constraints do not involve users)
                follow = plans[-1].copy()
                stayed.append(t)
        if follow is None:
            raise RuntimeError(f"myopic: epoch {t}'s repaired placement cannot follow epoch {t - 1}")
        plans.append(follow)
    plan = np.stack(plans)
    ev = evaluate_mobile(mp, plan)
    return SolveResult(
        Status.FEASIBLE if ev.feasible else Status.ERROR,
        objective=ev.value,
        x=plan,
        backend="myopic",
        message=f"each epoch solved alone; {len(repaired)} repaired with the previous epoch fixed"
        + (f", {len(stayed)} kept the previous placement (no repair in time)" if stayed else ""),
        solve_time=time.perf_counter() - t0,
        info={
            "evaluation": ev,
            "per_epoch": ev.per_epoch,
            "repaired": tuple(repaired),
            "stayed": tuple(stayed),
        },
    )


def _check_workers(workers: Any) -> int | None:
    return None if workers is None else check_int("workers", workers, min_value=1, max_value=MAX_WORKERS)


def _match_within(previous: np.ndarray, current: np.ndarray, max_move: float) -> np.ndarray | None:
    """``current`` reordered so that drone-cell i moves from ``previous[i]`` within ``max_move``, or
    None when no such order exists (or the counts differ)."""
    if len(previous) != len(current):
        return None
    if not len(current):
        return current
    d = np.hypot(*(previous[:, None, :2] - current[None, :, :2]).transpose(2, 0, 1))
    graph = csr_matrix((d <= max_move + TOL).astype(np.int8))
    match = maximum_bipartite_matching(graph, perm_type="column")
    if np.any(match < 0):
        return None
    return current[match]
