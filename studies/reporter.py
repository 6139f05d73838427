"""The ``report`` callable a method of a gap study receives (in the job's child process).

It stamps each call with the time since the method started and sends the report, as plain data
(:mod:`~droneplan.studies.wire`), to the study; :mod:`droneplan.studies.traces` scores what
arrives. Kept apart from the scoring so that the harness, which hands it to the method, and
the scoring import it from below.
"""

from __future__ import annotations

import time
from typing import Any

from droneplan.solvers.result import SolveResult, Status

__all__ = ["MAX_REPORT_CALLS", "Reporter"]

MAX_REPORT_CALLS = 1_000_000
"""Reports a method may make in one run; a call beyond it is dropped, and the trace gets one
``invalid`` entry saying so."""


class Reporter:
    """The ``report`` callable a method receives (it runs in the job's child process).

    send: where each report goes, as plain-data bytes (the runner's
    :func:`~droneplan.studies.runner.send_report`).
    """

    def __init__(self, send: Any) -> None:
        self._send = send
        self.started = time.perf_counter()
        self.calls = 0

    def __call__(self, plan: Any, *, objective: Any = None, bound: Any = None) -> None:
        """Report an incumbent.

        plan: the plan, in the form the method returns (or a SolveResult).
        objective: what the method claims the plan is worth (optional).
        bound: the best bound the method knows at this moment (optional; recorded as a bound
            only for droneplan's exact engines).
        """
        from droneplan.studies import wire

        self.calls += 1
        if self.calls > MAX_REPORT_CALLS:
            if self.calls == MAX_REPORT_CALLS + 1:
                self._send(
                    wire.encode({"t": self._now(), "invalid": f"more than {MAX_REPORT_CALLS} reports"})
                )
            return
        entry: dict[str, Any] = {"t": self._now(), "plan": plan}
        if objective is not None or bound is not None:
            entry["plan"] = SolveResult(Status.FEASIBLE, objective=objective, bound=bound, x=plan)
        try:
            payload = wire.encode(entry)
        except wire.NotPlainError as exc:
            payload = wire.encode({"t": entry["t"], "invalid": f"a report that is not plain data: {exc}"})
        self._send(payload)

    def _now(self) -> float:
        return time.perf_counter() - self.started
