"""A user's closed-loop controller in a process of its own, flown by droneplan's simulator in this one.

In a study of a closed-loop kind the simulator is droneplan's, and so is the score it computes;
only the controller is the user's. :class:`ControllerProcess` keeps them apart. It follows the
closed-loop contract (:mod:`droneplan.scenarios.loop`), so any simulator flies it, and forks the
controller's process at ``reset``: the controller is built (its ``__init__`` runs) and reset
there, and each ``command`` sends that process the observation and reads back its reply. So
whatever the controller does to droneplan's modules in its own process (patching the simulator,
the contact test, the metrics) changes nothing in the process that simulates and scores.

What crosses, and how:

- to the controller's process: the request (``reset`` with its seed, or ``command`` with the
  observation), pickled (that process may unpickle what droneplan sends it);
- back: a :mod:`droneplan.studies.wire` message, never unpickled: the command (one of the
  problem's command types, an array or a tuple of arrays), the controller's ``phase`` (the
  problem's phase enum), ``finished`` and its optional counters (``fallbacks``, new ``statuses``
  names and ``solve_times``, the shark's ``capture_time``). A reply that is not plain data, too
  large or malformed ends the run with :class:`ControllerFailed`.

The controller's process dies with this one (``PR_SET_PDEATHSIG`` on Linux), stays in its process
group (so a job runner that kills the group kills it) and inherits its memory limit. The time
spent waiting for replies is the controller's own time (:attr:`ControllerProcess.method_time_s`).
"""

from __future__ import annotations

import contextlib
import os
import pickle
import signal
import struct
import sys
import time
from collections.abc import Callable
from typing import Any

from droneplan.studies import wire
from droneplan.studies.runner import die_with_parent

__all__ = ["ControllerFailed", "ControllerProcess", "MAX_REPLY_BYTES"]

MAX_REPLY_BYTES = 16 << 20
"""The largest reply a controller's process may send for one request (bytes)."""

_LENGTH = struct.Struct(">Q")
_COUNTERS = ("fallbacks", "capture_time")


class ControllerFailed(RuntimeError):
    """The controller raised or died (``status`` ``"error"``), or sent a reply that is not a plain,
    well-formed command (``status`` ``"invalid"``); the message is one line."""

    def __init__(self, message: str, status: str = "error") -> None:
        super().__init__(message)
        self.status = status


class ControllerProcess:
    """A controller built by ``make()`` in a forked process, behind the closed-loop contract.

    make: builds the controller (called in the controller's process, at each ``reset``).
    The attributes a simulator reads (``phase``, ``finished``, ``fallbacks``, ``statuses``,
    ``solve_times``, ``capture_time``) mirror the controller's after its last reply. Call
    :meth:`close` when the run is over (it is also a context manager).
    """

    def __init__(self, make: Callable[[], Any]) -> None:
        self._make = make
        self._pid = 0
        self._to_child = self._from_child = -1
        self._phase: Any = None
        self.finished = False
        self.fallbacks = 0
        self.statuses: list[str] = []
        self.solve_times: list[float] = []
        self.capture_time: float | None = None
        self.method_time_s = 0.0
        """Wall time spent waiting for the controller's replies (s)."""

    # ----------------------------------------------------------------- the contract
    @property
    def phase(self) -> Any:
        """The controller's phase after its last reply (AttributeError if it has none, as for
        the controller itself, so ``getattr(controller, "phase", default)`` works)."""
        if self._phase is None:
            raise AttributeError("the controller has no phase")
        return self._phase

    def reset(self, scenario: Any, *, seed: Any = None) -> None:
        """Start the controller's process, build the controller there and reset it on ``scenario``."""
        self.close()
        self._start(scenario)
        self._ask(("reset", seed))

    def command(self, obs: Any) -> Any:
        """The controller's command for observation ``obs`` (computed in its process)."""
        return self._ask(("command", obs))

    # ----------------------------------------------------------------- the process
    def _start(self, scenario: Any) -> None:
        for stream in (sys.stdout, sys.stderr):
            with contextlib.suppress(Exception):
                stream.flush()
        req_r, req_w = os.pipe()
        rep_r, rep_w = os.pipe()
        parent = os.getpid()
        pid = os.fork()
        if pid == 0:  # pragma: no cover - the controller's process
            os.close(req_w)
            os.close(rep_r)
            _serve(self._make, scenario, req_r, rep_w, parent)
        os.close(req_r)
        os.close(rep_w)
        self._pid, self._to_child, self._from_child = pid, req_w, rep_r

    def _ask(self, request: tuple[Any, ...]) -> Any:
        if not self._pid:
            raise ControllerFailed("the controller was not reset")
        t0 = time.perf_counter()
        try:
            _send(self._to_child, pickle.dumps(request, protocol=pickle.HIGHEST_PROTOCOL))
            data = _receive(self._from_child, MAX_REPLY_BYTES)
        except OSError as exc:
            raise ControllerFailed(f"the controller's process is gone ({exc.strerror or exc})") from None
        finally:
            self.method_time_s += time.perf_counter() - t0
        if data is None:
            raise ControllerFailed(f"the controller's process ended without a reply ({self._exit_text()})")
        try:
            reply = wire.decode(data, max_bytes=MAX_REPLY_BYTES)
        except wire.WireError as exc:
            raise ControllerFailed(f"the controller's reply is not plain data: {exc}", "invalid") from None
        return self._take(reply)

    def _take(self, reply: Any) -> Any:
        if not isinstance(reply, dict) or not isinstance(reply.get("ok"), bool):
            raise ControllerFailed("the controller's process sent a malformed reply", "invalid")
        if not reply["ok"]:
            message = str(reply.get("error", "the controller failed"))[:300]
            raise ControllerFailed(message, "invalid" if reply.get("invalid") else "error")
        phase = reply.get("phase")
        if phase is not None and not isinstance(phase, wire.phase_types()):
            raise ControllerFailed(
                f"the controller's phase is a {type(phase).__name__}, not a phase enum", "invalid"
            )
        self._phase = phase
        self.finished = bool(reply.get("finished", False))
        self.fallbacks = _count(reply.get("fallbacks"))
        self.statuses.extend(str(s) for s in reply.get("statuses") or ())
        self.solve_times.extend(
            float(s) for s in reply.get("solve_times") or () if isinstance(s, (int, float))
        )
        cap = reply.get("capture_time")
        self.capture_time = (
            float(cap) if isinstance(cap, (int, float)) and not isinstance(cap, bool) else None
        )
        return reply.get("command")

    def _exit_text(self) -> str:
        with contextlib.suppress(ChildProcessError):
            pid, status = os.waitpid(self._pid, 0)
            if pid:
                self._pid = 0
                if os.WIFSIGNALED(status):
                    return f"signal {os.WTERMSIG(status)}"
                return f"exit code {os.waitstatus_to_exitcode(status)}"
        return "exit status unknown"

    def close(self) -> None:
        """Kill and reap the controller's process (if any) and close the pipes."""
        for fd in (self._to_child, self._from_child):
            if fd >= 0:
                with contextlib.suppress(OSError):
                    os.close(fd)
        self._to_child = self._from_child = -1
        if self._pid:
            with contextlib.suppress(ProcessLookupError, PermissionError):
                os.kill(self._pid, signal.SIGKILL)
            with contextlib.suppress(ChildProcessError):
                os.waitpid(self._pid, 0)
            self._pid = 0

    def __enter__(self) -> ControllerProcess:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def _count(v: Any) -> int:
    return int(v) if isinstance(v, int) and not isinstance(v, bool) and 0 <= v < 2**62 else 0


# --------------------------------------------------------------------------- pipes
def _send(fd: int, payload: bytes) -> None:
    data = memoryview(_LENGTH.pack(len(payload)) + payload)
    while data:
        data = data[os.write(fd, data) :]


def _read_exactly(fd: int, n: int) -> bytes | None:
    chunks, got = [], 0
    while got < n:
        chunk = os.read(fd, min(n - got, 1 << 20))
        if not chunk:
            return None
        chunks.append(chunk)
        got += len(chunk)
    return b"".join(chunks)


def _receive(fd: int, max_bytes: int) -> bytes | None:
    """One length-prefixed message (None at the end of the stream); refuses one beyond ``max_bytes``."""
    head = _read_exactly(fd, _LENGTH.size)
    if head is None:
        return None
    (n,) = _LENGTH.unpack(head)
    if n > max_bytes:
        raise ControllerFailed(
            f"the controller's reply has {n} bytes, more than the cap of {max_bytes}", "invalid"
        )
    return _read_exactly(fd, n)


# --------------------------------------------------------------------------- the controller's process
def _serve(
    make: Callable[[], Any], scenario: Any, req: int, rep: int, parent: int
) -> None:  # pragma: no cover
    """The controller's process: answer requests until the pipe closes; never returns."""
    code = 0
    try:
        die_with_parent(parent)
        signal.signal(signal.SIGINT, signal.SIG_IGN)
        controller: Any = None
        sent = [0, 0]
        while True:
            data = _receive(req, 1 << 40)
            if data is None:
                break
            kind, arg = pickle.loads(data)
            try:
                if kind == "reset":
                    controller = make()
                    controller.reset(scenario, seed=arg)
                    cmd = None
                else:
                    cmd = controller.command(arg)
                reply = _reply(controller, cmd, sent)
            except BaseException as exc:  # noqa: BLE001 - the controller's failure is its reply
                reply = {"ok": False, "error": f"{type(exc).__name__}: {' '.join(str(exc).split())}"[:300]}
            try:
                message = wire.encode(reply)
            except wire.NotPlainError as exc:
                why = f"the controller's reply is not plain data: {exc}"
                message = wire.encode({"ok": False, "invalid": True, "error": why})
            _send(rep, message)
    except BaseException:  # noqa: BLE001 - nothing may escape into the simulator's code
        code = 1
    finally:
        for stream in (sys.stdout, sys.stderr):
            with contextlib.suppress(BaseException):
                stream.flush()
        os._exit(code)


def _reply(controller: Any, cmd: Any, sent: list[int]) -> dict[str, Any]:  # pragma: no cover
    """The reply to one request: the command and what the simulator reads from the controller."""
    statuses = list(getattr(controller, "statuses", None) or ())
    times = list(getattr(controller, "solve_times", None) or ())
    new_statuses = [str(getattr(s, "name", s)) for s in statuses[sent[0] :]]
    new_times = [float(s) for s in times[sent[1] :]]
    sent[0], sent[1] = len(statuses), len(times)
    if isinstance(cmd, tuple) and not wire.is_registered(cmd):  # a user's own named tuple: its fields
        cmd = tuple(cmd)
    return {
        "ok": True,
        "command": cmd,
        "phase": getattr(controller, "phase", None),
        "finished": bool(getattr(controller, "finished", False)),
        "statuses": new_statuses,
        "solve_times": new_times,
        **{name: getattr(controller, name, None) for name in _COUNTERS},
    }
