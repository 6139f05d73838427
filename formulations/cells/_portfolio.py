"""Both exact engines side by side on one candidate problem (``solve_exact(engine="auto")``).

The model (``_milp``) runs in a forked child process on one CP-SAT worker while the branch and
bound (``_bnb``) searches in this process (with the workers left). Both start from the same
prepared candidates, incumbent and continuous bound (``_prepare.Prepared``, copied by the fork).

What passes between them:

- the model's incumbents go to the search: the child sends each feasible placement it finds
  through a pipe and then raises a shared value, which the search reads every ``_CHECK_EVERY``
  nodes and prunes against (``_bnb.Peer``). The search never holds the placement behind that
  value; the placement is read from the pipe when the search ends, so the result is always a
  placement droneplan evaluated.
- the search's incumbents do not reach the model: CP-SAT takes a start only before it solves.
- the first proof ends both: the child sets a shared flag that stops the search, and a proof of
  the search kills the child.

The result is the better placement of the two, with the tighter of the two bounds (both are
bounds of the same candidate problem); ``info["portfolio"]`` names the engine that proved it
(or ``None``) and each engine's wall time, status and bound.
"""

from __future__ import annotations

import contextlib
import dataclasses
import multiprocessing
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from droneplan.formulations.cells._core import evaluate
from droneplan.formulations.cells._prepare import Prepared
from droneplan.solvers.result import SolveResult, Status

__all__ = ["ModelPeer", "solve_portfolio", "CHILD_GRACE_S"]

CHILD_GRACE_S = 10.0
"""How long the search waits past the time limit for the model's result before killing it (s)."""


@dataclass
class ModelPeer:
    """The search's view of the model running in the child (``_bnb.Peer``), and the messages
    the child sent (its placements, its result or its error)."""

    prep: Prepared
    value: Any
    done: Any
    receive: Any
    send: Any
    best: np.ndarray | None = None
    best_val: int = -1
    result: SolveResult | None = None
    error: str | None = None
    times: dict[str, float] = field(default_factory=dict)

    @classmethod
    def start(cls, prep: Prepared) -> ModelPeer:
        """Shared value, flag and pipe of a portfolio on ``prep`` (before the fork)."""
        ctx = multiprocessing.get_context("fork")
        receive, send = ctx.Pipe(duplex=False)
        return cls(
            prep, ctx.Value("i", int(prep.inc_val), lock=False), ctx.Value("b", 0, lock=False), receive, send
        )

    def best_value(self) -> int:
        """Users covered by the model's best placement so far (the shared value)."""
        return int(self.value.value)

    def finished(self) -> bool:
        """True once the model has proved its placement optimal."""
        return bool(self.done.value)

    # ---------------------------------------------------------------- the child's side
    def child_report(self, positions: np.ndarray, bound: float) -> None:
        """The model's ``report``: send the placement, then raise the shared value (in that
        order, so a value the search reads always has its placement in the pipe)."""
        covered = int(evaluate(self.prep.problem, positions).covered)
        self.send.send(("placement", np.asarray(positions, dtype=float)))
        if covered > self.value.value:
            self.value.value = covered

    # ---------------------------------------------------------------- the parent's side
    def drain(self, timeout: float = 0.0) -> None:
        """Read what the child has sent (waiting up to ``timeout`` s for its result)."""
        deadline = time.perf_counter() + timeout
        while True:
            wait = max(0.0, deadline - time.perf_counter())
            try:
                if not self.receive.poll(wait if self.result is None and self.error is None else 0.0):
                    return
                kind, payload = self.receive.recv()
            except (EOFError, OSError):
                return
            if kind == "placement":
                covered = int(evaluate(self.prep.problem, payload).covered)
                if evaluate(self.prep.problem, payload).feasible and covered > self.best_val:
                    self.best, self.best_val = payload, covered
                    self.prep.offer_report(payload)
            elif kind == "result":
                self.result = payload
            else:
                self.error = str(payload)

    def better(self, positions: np.ndarray) -> np.ndarray:
        """``positions`` or the model's best placement, whichever covers more users."""
        self.drain()
        mine = int(evaluate(self.prep.problem, positions).covered)
        return self.best if self.best is not None and self.best_val > mine else positions


def _child(peer: ModelPeer, run_model: Callable[[Prepared], SolveResult]) -> None:
    """The forked child: the model from the copied preparation, its placements and result sent."""
    peer.receive.close()
    peer.prep.report = peer.child_report
    peer.prep.reported_val = -1
    try:
        res = run_model(peer.prep)
        peer.send.send(("result", res))
        if res.status is Status.OPTIMAL:
            peer.done.value = 1
    except BaseException as exc:  # noqa: BLE001 - the parent reports any failure of the model
        with contextlib.suppress(OSError):
            peer.send.send(("error", f"{type(exc).__name__}: {exc}"[:300]))
    finally:
        peer.send.close()


def solve_portfolio(
    prep: Prepared,
    *,
    run_model: Callable[[Prepared], SolveResult],
    run_search: Callable[[Prepared, ModelPeer], SolveResult],
) -> SolveResult:
    """Run the model (``run_model(prep)``, in a forked child) and the search
    (``run_search(prep, peer)``, here) on ``prep`` until the first proof or the time limit.

    prep: the prepared candidate problem (its clock and time limit cover both). run_model: the
    model's solve from a preparation. run_search: the branch and bound's solve, taking the peer
    it reads the model's incumbents from. Returns the better result with the tighter bound
    (module docstring).
    """
    peer = ModelPeer.start(prep)
    proc = multiprocessing.get_context("fork").Process(target=_child, args=(peer, run_model), daemon=True)
    t0 = time.perf_counter()
    proc.start()
    peer.send.close()
    try:
        searched = run_search(prep, peer)
        search_s = time.perf_counter() - t0
        if searched.status is not Status.OPTIMAL:
            left = prep.left()
            peer.drain(timeout=CHILD_GRACE_S + (left or 0.0) if not peer.finished() else CHILD_GRACE_S)
        else:
            peer.drain()
    finally:
        if proc.is_alive():
            proc.kill()
        proc.join()
        peer.receive.close()
    return _combine(prep, searched, peer, search_s, time.perf_counter() - t0)


def _combine(
    prep: Prepared, searched: SolveResult, peer: ModelPeer, search_s: float, wall_s: float
) -> SolveResult:
    """The portfolio's result: the better placement, the tighter bound, who proved it."""
    model = peer.result
    plans = [np.asarray(searched.x, dtype=float)]
    plans += [
        np.asarray(p, dtype=float) for p in (peer.best, None if model is None else model.x) if p is not None
    ]
    scored = [(evaluate(prep.problem, p), p) for p in plans]
    x = max((sp for sp in scored if sp[0].feasible), key=lambda sp: sp[0].covered, default=scored[0])[1]
    obj = float(evaluate(prep.problem, x).covered)
    bounds = [float(b) for b in (searched.bound, None if model is None else model.bound) if b is not None]
    proved = (
        "bnb"
        if searched.status is Status.OPTIMAL
        else "milp"
        if model is not None and model.status is Status.OPTIMAL
        else None
    )
    bound = obj if proved is not None else (max(min(bounds), obj) if bounds else None)
    status = Status.OPTIMAL if bound is not None and obj >= bound else Status.FEASIBLE
    base = model if proved == "milp" and model is not None else searched
    portfolio = {
        "proved_by": proved,
        "wall_s": wall_s,
        "bnb": {"status": searched.status.value, "bound": searched.bound, "wall_s": search_s},
        "milp": (
            {"status": "error" if peer.error else "stopped", "message": peer.error}
            if model is None
            else {"status": model.status.value, "bound": model.bound, "wall_s": model.solve_time}
        ),
    }
    who = {"bnb": "the branch and bound", "milp": "the MILP", None: "neither engine"}[proved]
    res = prep.result(
        status,
        objective=obj,
        bound=bound,
        x=x,
        backend=base.backend,
        message=f"portfolio (branch and bound beside the MILP): {who} proved it; {base.message}",
        engine="auto",
        iterations=searched.iterations,
        backend_status=base.backend_status,
        rounds=int(base.info.get("rounds", 0) or 0),
        model_stats=dict(base.info.get("model_stats") or {}),
    )
    return dataclasses.replace(res, info={**res.info, "portfolio": portfolio})
