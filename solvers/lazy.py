"""Lazy constraints: solve a relaxation, add the constraints its solution violates, repeat.

The caller supplies two functions:

- ``solve_relaxation(cuts, time_left)`` builds and solves the model with the
  constraints found so far (``cuts``, in the caller's own representation) and
  returns a :class:`SolveResult`. Each such model must be a *relaxation* of the
  full problem (it drops some constraints, never adds invalid ones), so its proven
  bound bounds the full problem too.
- ``separate(result)`` returns the constraints of the full problem that
  ``result.x`` violates (empty: ``result.x`` is feasible for the full problem).

The loop stops with a proof when a relaxation is solved to optimality and its
solution violates nothing: that solution is optimal for the full problem.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import replace
from typing import Any

from droneplan.core.validation import check_time_limit, require_set
from droneplan.solvers.result import SolveResult, Status

__all__ = ["lazy_constraint_loop"]


def lazy_constraint_loop(  # noqa: C901
    solve_relaxation: Callable[[list[Any], float | None], SolveResult],
    separate: Callable[[SolveResult], Sequence[Any]],
    *,
    sense: str,
    max_rounds: int = 200,
    time_limit: float | None = None,
    cuts: Sequence[Any] = (),
) -> SolveResult:
    """Run the lazy-constraint loop (module docstring).

    sense: "max" or "min", the direction of the objective (which way bounds tighten).
    max_rounds: relaxations solved at most.
    time_limit: wall-clock limit (s) for the whole loop; ``time_left`` handed to
        ``solve_relaxation`` is what remains (at least 0.01 s), None without a limit.
    cuts: constraints known before the first round.

    Returns a SolveResult:
    - OPTIMAL: ``x``/``objective`` of the last relaxation, feasible and optimal for the full problem;
    - FEASIBLE: the last relaxation stopped early (e.g. time limit) at a solution that violates
      nothing: feasible for the full problem, not proven optimal;
    - INFEASIBLE: a relaxation is infeasible, so is the full problem;
    - NO_SOLUTION: stopped (time, round limit, or a relaxation stopped early at a solution that
      still violates constraints) without a feasible solution of the full problem; ``x`` None;
    - ERROR: the backend failed.
    ``bound`` is the tightest proven bound over all rounds (valid for the full problem);
    ``iterations`` the number of rounds; ``info`` = {"rounds", "cuts" (all cuts, in order),
    "last" (the last relaxation's result)}; ``solve_time`` covers the whole loop.
    """
    if sense not in ("max", "min"):
        raise ValueError(f"sense must be 'max' or 'min', got {sense!r}")
    if isinstance(max_rounds, bool) or not isinstance(max_rounds, int) or max_rounds < 1:
        raise ValueError(f"max_rounds must be an int >= 1, got {max_rounds!r}")
    check_time_limit(time_limit)
    t0 = time.perf_counter()
    found = list(cuts)
    tighter = min if sense == "max" else max
    bound = math.inf if sense == "max" else -math.inf

    def time_left() -> float | None:
        return None if time_limit is None else max(time_limit - (time.perf_counter() - t0), 0.01)

    def finish(res: SolveResult, status: Status, rounds: int, message: str, solution: bool) -> SolveResult:
        return replace(
            res,
            status=status,
            x=res.x if solution else None,
            objective=res.objective if solution else None,
            bound=bound if math.isfinite(bound) else None,
            iterations=rounds,
            solve_time=time.perf_counter() - t0,
            message=message,
            info={"rounds": rounds, "cuts": found, "last": res},
        )

    res: SolveResult | None = None
    for rounds in range(1, max_rounds + 1):
        res = solve_relaxation(list(found), time_left())
        if not isinstance(res, SolveResult):
            raise TypeError(f"solve_relaxation must return a SolveResult, got {type(res).__name__}")
        if res.bound is not None:
            bound = tighter(bound, res.bound)
        if res.status is Status.INFEASIBLE:
            return finish(res, Status.INFEASIBLE, rounds, "a relaxation is infeasible", False)
        if not res.has_solution:
            return finish(
                res,
                res.status if res.status is Status.ERROR else Status.NO_SOLUTION,
                rounds,
                f"round {rounds}: relaxation returned {res.status.value} ({res.message})",
                False,
            )
        new = list(separate(res))
        if not new:
            if res.status is Status.OPTIMAL and res.objective is not None:
                bound = tighter(bound, res.objective)
                return finish(
                    res,
                    Status.OPTIMAL,
                    rounds,
                    f"optimal after {rounds} round(s), {len(found)} lazy constraint(s)",
                    True,
                )
            return finish(
                res,
                Status.FEASIBLE,
                rounds,
                f"round {rounds} stopped early at a solution that violates no constraint",
                True,
            )
        found.extend(new)
        if res.status is not Status.OPTIMAL:
            return finish(
                res,
                Status.NO_SOLUTION,
                rounds,
                f"round {rounds} stopped early at a solution that violates {len(new)} constraint(s)",
                False,
            )
        if time_limit is not None and time.perf_counter() - t0 >= time_limit:
            return finish(res, Status.NO_SOLUTION, rounds, f"time limit after {rounds} round(s)", False)
    res = require_set(res, "max_rounds >= 1 solves at least once")
    return finish(res, Status.NO_SOLUTION, max_rounds, f"round limit {max_rounds} reached", False)
