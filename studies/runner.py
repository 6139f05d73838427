"""Run user code in forked child processes with a hard wall-time limit.

A study calls code it does not control: a method a user wrote in a notebook, a solver
binding that may hang in C, segfault, print, sleep, raise, or return something that is
not a plan. :func:`run_calls` runs each :class:`IsolatedCall` in a child process of its own and
turns whatever happens into one :class:`CallOutcome`:

- ``"ok"``: ``fn`` returned; ``value`` is its return value: pickled in the child and
  unpickled here for a job of droneplan's own code (``IsolatedCall.returns == "pickle"``), or the
  bytes ``fn`` returned, untouched, for a job running code droneplan does not control
  (``"bytes"``: nothing the child writes is ever unpickled; see :mod:`droneplan.studies.wire`);
- ``"error"``: ``fn`` raised (any exception, ``SystemExit`` and ``KeyboardInterrupt``
  included), its return value cannot be pickled, or an allocation went beyond
  ``memory_limit`` (``MemoryError``); ``error`` is one line ``"Type: message"`` and
  ``traceback`` the child's formatted traceback;
- ``"timeout"``: the child was still running ``time_limit + grace`` seconds after it
  started and was killed with its whole process group;
- ``"crashed"``: the child ended without sending a complete result (a segfault,
  ``os._exit`` in the job, the kernel's out-of-memory killer); ``error`` names the exit
  code or signal.

A job may also be given a CPU-time limit (:attr:`IsolatedCall.cpu_limit`, the child's ``RLIMIT_CPU``: a
budget that does not shrink when other work shares the machine), and may send reports while it
runs (:func:`send_report`, e.g. each new incumbent of an anytime method); the parent keeps a
thinned list of them (:attr:`IsolatedCall.max_reports`) and returns it with the outcome, whatever the
outcome is.

Why ``os.fork`` and not :mod:`multiprocessing` or :mod:`concurrent.futures`:

- the child is a copy of this process, so ``fn`` and its arguments are never pickled:
  lambdas, closures and functions defined in a notebook or a ``__main__`` script run as
  they are (only the return value travels back, through a pipe);
- ``multiprocessing`` refuses to start children from a daemonic process, and the
  workers of a process pool and of Dask are daemonic; a plain fork works anywhere;
- a child that hangs can be killed (SIGKILL to its process group, so the processes it
  started die with it) without losing a pool worker or the rest of the study.

The cost: forking a process that runs threads copies only the forking thread, so a lock
another thread held at that moment stays locked in the child (a job that then takes the
same lock, e.g. through ``logging``, would wait until it is killed at its time limit),
and a child should not use an OpenMP runtime that the parent already started. The
runner is therefore POSIX-only (Linux, macOS); on a platform without ``os.fork``
:func:`run_calls` raises :class:`RuntimeError`.

What the child does: it moves into its own process group (Ctrl-C in a terminal reaches
only the parent, which then kills every child), asks the kernel to kill it when the parent
dies (``PR_SET_PDEATHSIG`` on Linux, so a study killed with SIGKILL leaves no job running),
ignores SIGINT, disables core dumps,
applies ``memory_limit`` as its address-space limit (``RLIMIT_AS``), runs
``fn(*args, **kwargs)``, flushes its stdout and stderr (printed output goes to the
parent's file descriptors), sends its length-prefixed result message (a kind byte, then the
pickle or the bytes; an error as JSON) through a pipe and leaves with ``os._exit``: never
through the parent's ``atexit`` handlers, finalizers or ``finally`` blocks, whatever ``fn`` did.

What the parent does: it keeps at most ``workers`` children alive, waits on their pipes
(reading results of any size as they arrive), kills a child that overran its limit,
reaps every child with ``os.wait4`` (which gives the CPU time of the child and of the
processes it waited for) and kills the child's process group when it ends, so helpers a
job left behind do not outlive it. Processes that leave the group on purpose
(``setsid``, daemons) are not followed. If anything interrupts the parent (Ctrl-C, an
exception in the loop consuming the outcomes, closing the iterator), every child's
process group is killed and reaped before the exception propagates.
"""

from __future__ import annotations

import contextlib
import ctypes
import json
import math
import os
import pickle
import selectors
import signal
import struct
import sys
import threading
import time
import traceback as tb_module
import warnings
from collections.abc import Callable, Generator, Hashable, Iterable, Iterator, Mapping, Sized
from dataclasses import dataclass, field
from typing import Any

from tqdm.auto import tqdm

if sys.platform != "win32":  # imported here, not in the child: an import after a fork can deadlock
    import resource


from droneplan.core.deprecation import deprecated_names
from droneplan.core.validation import check_instance, check_int, check_nonneg, check_time_limit

_PR_SET_PDEATHSIG = 1  # prctl option (linux/prctl.h): a signal the kernel sends when the parent dies
_PRCTL: Any = None
if sys.platform.startswith("linux"):
    with contextlib.suppress(OSError, AttributeError):
        _PRCTL = ctypes.CDLL(None, use_errno=True).prctl

__all__ = [
    "OUTCOME_STATUSES",
    "RESULT_MODES",
    "IsolatedCall",
    "CallOutcome",
    "die_with_parent",
    "run_isolated",
    "run_calls",
    "send_report",
]

OUTCOME_STATUSES = ("ok", "error", "timeout", "crashed")
RESULT_MODES = ("pickle", "bytes")
"""The values of :attr:`IsolatedCall.returns`."""
"""The values of :attr:`CallOutcome.status`, in this order of how far the job got."""

_TICK_S = 0.2  # longest wait between two looks at the children (s)
_FAST_TICK_S = 0.01  # wait while a child has closed its pipe but not yet exited (s)
_HEADER = struct.Struct(">Q")  # length prefix of a result message (bytes)
_OK_PICKLE, _OK_BYTES, _ERROR = b"P", b"B", b"E"  # the first byte of a message: what follows
_REPORT = b"R"  # a report (send_report): the job goes on; any number of them before the result
_READ_CHUNK = 1 << 20  # bytes per read from a child's pipe
_MESSAGE_CHARS = 300  # longest message kept in CallOutcome.error (characters)
_END = object()  # end of the jobs

# Python 3.12+ warns on every fork of a process that runs threads (a Dask worker, a
# progress bar's monitor thread). Forking is this module's purpose and its hazards are
# documented above, so the warning is silenced for the fork below only (warnings name
# the module that called os.fork).
warnings.filterwarnings(
    "ignore", message=r".*multi-threaded.*fork", category=DeprecationWarning, module=__name__
)


@dataclass(frozen=True)
class IsolatedCall:
    """One call ``fn(*args, **kwargs)`` to run in a child process.

    key: any hashable value naming the job; returned unchanged in its :class:`CallOutcome`.
    fn: the callable to run (any callable: a lambda or closure is fine, it is not pickled).
    args: positional arguments of ``fn`` (a tuple).
    kwargs: keyword arguments of ``fn`` (a mapping of str).
    time_limit: wall time the job may take (s); None: no limit. The child is killed
        ``grace`` seconds after the limit (see :func:`run_calls`).
    returns: how the result travels back. ``"pickle"``: any picklable value, unpickled in the
        parent; only for droneplan's own code, since unpickling runs whatever the bytes name.
        ``"bytes"``: ``fn`` returns ``bytes`` (e.g. a :mod:`droneplan.studies.wire` message) and
        the parent hands them over untouched, never unpickling anything the child wrote: the
        mode for a child that runs code droneplan does not control.
    max_result_bytes: the largest result the parent reads (bytes); a child that announces or
        sends more is killed and its outcome is ``"error"``. None: no cap. It applies to each
        report as well.
    cpu_limit: CPU time the child process may use (s, user + system, all its threads); None: no
        limit. It is the child's ``RLIMIT_CPU``, ``grace`` seconds above the limit, so the kernel
        stops a child that overran it; its outcome is then ``"timeout"``. Processes the job
        starts get a limit of their own each (the rlimit is per process).
    max_reports: how many of the job's reports (:func:`send_report`) the parent keeps (>= 2 when
        reports are wanted): the first, the last, and between them every k-th, k doubling each
        time the list fills up, so a job that reports a million times still costs a bounded
        memory. 0: reports are not wanted, and a job that sends one gets an ``"error"`` outcome.
    """

    key: Hashable
    fn: Callable[..., Any]
    args: tuple[Any, ...] = ()
    kwargs: Mapping[str, Any] = field(default_factory=dict)
    time_limit: float | None = None
    returns: str = "pickle"
    max_result_bytes: int | None = None
    cpu_limit: float | None = None
    max_reports: int = 0

    def __post_init__(self) -> None:
        try:
            hash(self.key)
        except TypeError:
            raise TypeError(f"key must be hashable, got {type(self.key).__name__}") from None
        if not callable(self.fn):
            raise TypeError(f"fn must be callable, got {type(self.fn).__name__}")
        check_instance("args", self.args, tuple)
        check_instance("kwargs", self.kwargs, Mapping)
        object.__setattr__(self, "time_limit", check_time_limit(self.time_limit))
        if self.returns not in RESULT_MODES:
            raise ValueError(f"returns must be one of {', '.join(RESULT_MODES)}, got {self.returns!r}")
        if self.max_result_bytes is not None:
            object.__setattr__(
                self, "max_result_bytes", check_int("max_result_bytes", self.max_result_bytes, min_value=1)
            )
        object.__setattr__(self, "cpu_limit", check_time_limit(self.cpu_limit, "cpu_limit"))
        max_reports = check_int("max_reports", self.max_reports, min_value=0)
        if max_reports == 1:
            raise ValueError("max_reports must be 0 (no reports) or >= 2 (the first and the last)")
        object.__setattr__(self, "max_reports", max_reports)


@dataclass(frozen=True)
class CallOutcome:
    """What became of one :class:`IsolatedCall`.

    key: the job's key, unchanged.
    status: ``"ok"``, ``"error"``, ``"timeout"`` or ``"crashed"`` (see the module docstring).
    value: ``fn``'s return value when ``status == "ok"``, else None.
    error: one line: ``"ValueError: ..."`` (error), ``"killed after 3.0 s (time limit 1.0 s)"``
        (timeout), ``"died: signal 11 (SIGSEGV)"`` or ``"died: exit code 3"`` (crashed);
        ``""`` when ok.
    traceback: the child's formatted traceback when ``status == "error"``, else ``""``.
    wall_s: wall time of the child from its start to its end (s).
    cpu_s: user + system CPU time of the child and of the processes it waited for (s).
    reports: the reports the parent kept (:attr:`IsolatedCall.max_reports`), in the order they were sent:
        bytes for a job with ``returns="bytes"``, unpickled values otherwise.
    n_reports: how many reports the job sent in all.
    """

    key: Hashable
    status: str
    value: Any = None
    error: str = ""
    traceback: str = ""
    wall_s: float = 0.0
    cpu_s: float = 0.0
    reports: tuple[Any, ...] = ()
    n_reports: int = 0


def run_isolated(job: IsolatedCall, *, grace: float = 2.0, memory_limit: int | None = None) -> CallOutcome:
    """Run one job in a child process and return its outcome (see :func:`run_calls`).

    job: the :class:`IsolatedCall` to run.
    grace: time the job may overrun its ``time_limit`` before it is killed (s).
    memory_limit: address-space limit of the child (bytes); None: no limit.
    """
    check_instance("job", job, IsolatedCall)
    with contextlib.closing(run_calls([job], workers=1, grace=grace, memory_limit=memory_limit)) as outcomes:
        return next(outcomes)


def run_calls(
    jobs: Iterable[IsolatedCall],
    *,
    workers: int = 1,
    grace: float = 2.0,
    memory_limit: int | None = None,
    progress: str | None = None,
) -> Generator[CallOutcome, None, None]:
    """Run every job in a forked child process; yield their outcomes as they finish.

    jobs: the :class:`IsolatedCall` s to run (any iterable; consumed lazily, ``workers`` at a time).
    workers: number of children alive at once (count, >= 1).
    grace: time a job may overrun its ``time_limit`` before its process group is killed
        with SIGKILL (s, >= 0); its outcome is then ``"timeout"``. A job that returns
        within the grace period is ``"ok"`` (compare ``wall_s`` with the limit).
    memory_limit: address-space limit of each child (bytes, ``RLIMIT_AS``), so that an
        allocation beyond it raises MemoryError in the job (an ``"error"`` outcome)
        instead of exhausting the machine; None: no limit. The child's address space
        starts as a copy of this process's, so the limit must exceed this process's
        virtual size (``VmSize``), not only what the job allocates.
    progress: description of a progress bar over the jobs (its total is known when
        ``jobs`` has a length); None: no bar.

    Outcomes come in the order the jobs finish, not the order they were given. The
    arguments are checked when this is called; the children start when the returned
    iterator is first advanced. Closing the iterator, or an exception while it runs
    (KeyboardInterrupt included), kills and reaps every child it started.
    """
    _require_fork()
    check_instance("jobs", jobs, Iterable)
    workers = check_int("workers", workers, min_value=1)
    grace = check_nonneg("grace", grace)
    if memory_limit is not None:
        memory_limit = check_int("memory_limit", memory_limit, min_value=1)
    check_instance("progress", progress, str, optional=True)
    return _run(jobs, workers, grace, memory_limit, progress)


def _require_fork() -> None:
    if not hasattr(os, "fork") or not hasattr(os, "wait4") or not hasattr(os, "killpg"):
        raise RuntimeError(
            f"the job runner needs os.fork, os.wait4 and os.killpg (POSIX: Linux, macOS); "
            f"this platform ({sys.platform}) lacks them"
        )


# --------------------------------------------------------------------------- the parent
def _run(  # noqa: C901
    jobs: Iterable[IsolatedCall], workers: int, grace: float, memory_limit: int | None, progress: str | None
) -> Generator[CallOutcome, None, None]:
    total = len(jobs) if isinstance(jobs, Sized) else None
    source = iter(jobs)
    running: dict[int, _Child] = {}  # by the read end of the child's pipe
    bar = tqdm(total=total, desc=progress) if progress is not None else None
    index, exhausted = 0, False
    try:
        with selectors.DefaultSelector() as selector:  # not select.select: fds may exceed 1024
            while True:
                while not exhausted and len(running) < workers:
                    job = next(source, _END)
                    if job is _END:
                        exhausted = True
                        break
                    if not isinstance(job, IsolatedCall):
                        raise TypeError(f"jobs[{index}] must be an IsolatedCall, got {type(job).__name__}")
                    _Child.start(job, memory_limit, grace, running, selector)
                    index += 1
                if not running:
                    return
                for outcome in _step(running, selector, grace):
                    if bar is not None:
                        bar.update(1)
                    yield outcome
    finally:  # normal end, exception, KeyboardInterrupt, or the consumer closed the iterator
        for child in running.values():  # every group first: a slow reap must not spare the others
            child.kill()
        for child in running.values():
            child.kill_and_reap()
        if bar is not None:
            bar.close()


def _step(running: dict[int, _Child], selector: selectors.BaseSelector, grace: float) -> list[CallOutcome]:
    """Wait (at most one tick) for the children, and return the outcomes of those that ended."""
    now = time.monotonic()
    timeout = _FAST_TICK_S if any(c.eof for c in running.values()) else _TICK_S
    for child in running.values():
        if child.job.time_limit is not None:
            timeout = min(timeout, max(0.0, child.started + child.job.time_limit + grace - now))
    for key, _ in selector.select(timeout):
        child = running[key.fd]
        child.read()
        if child.eof:  # an ended stream stays readable: watching it would spin
            child.unwatch(selector)
    finished = []
    for fd, child in list(running.items()):
        outcome = child.poll(grace)
        if outcome is not None:
            child.unwatch(selector)
            del running[fd]
            finished.append(outcome)
    return finished


class _Child:
    """A forked child running one job, seen from the parent."""

    def __init__(self, job: IsolatedCall, pid: int, fd: int, started: float):
        self.job, self.pid, self.fd, self.started = job, pid, fd, started
        self.buffer = bytearray()
        self.eof = False
        self.status: int | None = None  # wait status, once reaped
        self.cpu_s = 0.0
        self.ended: float | None = None
        self.reaped = self.closed = self.watched = False
        self.reports: list[bytes] = []  # payloads kept: every ``report_stride``-th from the first
        self.report_stride = 1
        self.n_reports = 0
        self.last_report: bytes | None = None
        self.unwanted_report = False

    @classmethod
    def start(
        cls,
        job: IsolatedCall,
        memory_limit: int | None,
        grace: float,
        running: dict[int, _Child],
        selector: selectors.BaseSelector,
    ) -> None:
        """Fork a child for ``job`` and add it to ``running`` (by its pipe) and ``selector``."""
        for stream in (sys.stdout, sys.stderr):  # else the child would print our buffered text again
            with contextlib.suppress(Exception):
                stream.flush()
        r, w = os.pipe()
        parent, pid, started = os.getpid(), 0, time.monotonic()
        try:
            with _sigint_deferred():
                pid = os.fork()
                if pid == 0:  # pragma: no cover - runs in the child (coverage does not follow os._exit)
                    _child_main(job, w, [r, *running], (memory_limit, grace), parent)
                os.close(w)
                w = -1
                running[r] = cls(job, pid, r, started)
            with contextlib.suppress(OSError):  # also here: a kill may come before the child's own call
                os.setpgid(pid, pid)
            os.set_blocking(r, False)
            selector.register(r, selectors.EVENT_READ)
            running[r].watched = True
        except BaseException:
            if os.getpid() != parent:  # pragma: no cover - an interrupt in the child before _child_main
                os._exit(1)
            if r not in running:
                if pid > 0:
                    cls(job, pid, r, started).kill_and_reap()
                else:
                    os.close(r)
                if w >= 0:
                    os.close(w)
            raise

    def unwatch(self, selector: selectors.BaseSelector) -> None:
        if self.watched:
            self.watched = False
            selector.unregister(self.fd)

    # ----------------------------------------------------------------- reading
    def read(self) -> None:
        """Read what the pipe holds now (non-blocking); note the end of the stream."""
        while not self.eof:
            try:
                data = os.read(self.fd, _READ_CHUNK)
            except (BlockingIOError, InterruptedError):
                return
            if not data:
                self.eof = True
                return
            self.buffer += data
            self._take_reports()
            if self.oversized() is not None or self.unwanted_report:  # read no further: poll() kills it
                return

    def _take_reports(self) -> None:
        """Move the complete report messages at the front of the buffer into ``reports``."""
        while self.message_complete() and self.buffer[_HEADER.size : _HEADER.size + 1] == _REPORT:
            if self.oversized() is not None:
                return
            (n,) = _HEADER.unpack_from(self.buffer)
            payload = bytes(memoryview(self.buffer)[_HEADER.size + 1 : _HEADER.size + n])
            del self.buffer[: _HEADER.size + n]
            if self.job.max_reports == 0:
                self.unwanted_report = True
                return
            self._keep_report(payload)

    def _keep_report(self, payload: bytes) -> None:
        """Keep the first report and every ``report_stride``-th after it; when the list is full,
        drop every other one and double the stride. The last report is kept apart."""
        if self.n_reports % self.report_stride == 0:
            self.reports.append(payload)
            if len(self.reports) > self.job.max_reports - 1:
                self.reports = self.reports[::2]
                self.report_stride *= 2
        self.n_reports += 1
        self.last_report = payload

    def kept_reports(self) -> list[bytes]:
        """The reports kept: at most ``max_reports``, the first and the last among them."""
        kept = list(self.reports)
        if self.n_reports and (self.n_reports - 1) % self.report_stride != 0:
            kept.append(self.last_report)  # type: ignore[arg-type]
        return kept

    def message_complete(self) -> bool:
        if len(self.buffer) < _HEADER.size:
            return False
        (n,) = _HEADER.unpack_from(self.buffer)
        return len(self.buffer) >= _HEADER.size + n

    def oversized(self) -> int | None:
        """The announced or received size of a result beyond the job's cap (bytes), else None."""
        cap = self.job.max_result_bytes
        if cap is None:
            return None
        if len(self.buffer) >= _HEADER.size:
            (n,) = _HEADER.unpack_from(self.buffer)
            if n > cap + 1:  # + the message's kind byte
                return n - 1
        return len(self.buffer) if len(self.buffer) > cap + 1 + _HEADER.size else None

    # ----------------------------------------------------------------- life and death
    def exited(self) -> bool:
        """Whether the child has ended (without reaping it where the platform allows, so its
        pid, and thus its process group id, stays reserved until the group is killed)."""
        if self.reaped:
            return True
        if hasattr(os, "waitid"):
            try:
                return os.waitid(os.P_PID, self.pid, os.WEXITED | os.WNOHANG | os.WNOWAIT) is not None
            except ChildProcessError:  # reaped behind our back (SIGCHLD ignored): it has ended
                return True
        return self._reap(block=False)

    def _reap(self, block: bool) -> bool:
        try:
            pid, status, usage = os.wait4(self.pid, 0 if block else os.WNOHANG)
        except ChildProcessError:  # someone else reaped it (SIGCHLD set to SIG_IGN)
            pid, status, usage = self.pid, None, None
        if pid == 0:
            return False
        self.reaped, self.ended, self.status = True, time.monotonic(), status
        if usage is not None:
            self.cpu_s = usage.ru_utime + usage.ru_stime
        return True

    def kill(self) -> None:
        """SIGKILL the child's process group, and the child itself if it has not joined it yet."""
        with contextlib.suppress(ProcessLookupError, PermissionError):
            os.killpg(self.pid, signal.SIGKILL)
        if not self.reaped:
            with contextlib.suppress(ProcessLookupError, PermissionError):
                os.kill(self.pid, signal.SIGKILL)

    def kill_and_reap(self) -> None:
        """SIGKILL the child's process group (helpers it started included), reap it, close the pipe."""
        self.kill()
        if not self.reaped:
            self._reap(block=True)
        if not self.closed:
            self.closed = True
            os.close(self.fd)

    # ----------------------------------------------------------------- outcome
    def poll(self, grace: float) -> CallOutcome | None:
        """The outcome if the child is done (it is then reaped), else None."""
        if self.unwanted_report:
            self.kill_and_reap()
            return self._outcome("error", error="the job sent a report; this job takes none (max_reports=0)")
        too_big = self.oversized()
        if too_big is not None:
            self.kill_and_reap()
            self.buffer = bytearray()
            return self._outcome(
                "error",
                error=f"the result has {too_big} bytes, more than the cap of {self.job.max_result_bytes}",
            )
        if self.message_complete():
            self.kill_and_reap()  # it has nothing left to do; this also ends helpers it left behind
            return self._from_message()
        if self.exited():
            self.read()  # what it wrote before it ended is in the pipe
            self.kill_and_reap()
            return self._from_message() if self.message_complete() else self._crashed()
        limit = self.job.time_limit
        if limit is not None and time.monotonic() >= self.started + limit + grace:
            self.read()
            self.kill_and_reap()
            if self.message_complete():  # it made it in the last moment
                return self._from_message()
            return self._outcome(
                "timeout", error=f"killed after {_secs(self.wall_s)} s (time limit {_secs(limit)} s)"
            )
        return None

    @property
    def wall_s(self) -> float:
        return (self.ended if self.ended is not None else time.monotonic()) - self.started

    def _outcome(self, status: str, **fields: Any) -> CallOutcome:
        reports: list[Any] = self.kept_reports()
        if self.job.returns == "pickle":
            reports = [_unpickled_report(r) for r in reports]
        return CallOutcome(
            self.job.key,
            status,
            wall_s=self.wall_s,
            cpu_s=self.cpu_s,
            reports=tuple(reports),
            n_reports=self.n_reports,
            **fields,
        )

    def _from_message(self) -> CallOutcome:
        (n,) = _HEADER.unpack_from(self.buffer)
        body = bytes(memoryview(self.buffer)[_HEADER.size : _HEADER.size + n])
        self.buffer = bytearray()
        kind, payload = body[:1], body[1:]
        if kind == _ERROR:
            try:
                error, traceback = json.loads(payload.decode("utf-8"))
                return self._outcome("error", error=str(error)[:_MESSAGE_CHARS], traceback=str(traceback))
            except Exception:  # noqa: BLE001 - whatever the child wrote
                return self._outcome("error", error="the child sent an unreadable error message")
        if kind == _OK_BYTES and self.job.returns == "bytes":
            return self._outcome("ok", value=payload)
        if kind == _OK_PICKLE and self.job.returns == "pickle":
            try:
                return self._outcome("ok", value=pickle.loads(payload))
            except Exception as exc:  # noqa: BLE001 - e.g. a class whose unpickling fails
                return self._outcome(
                    "error",
                    error=f"the return value could not be unpickled: {_one_line(exc)}",
                    traceback=tb_module.format_exc(),
                )
        return self._outcome(
            "error",
            error=f"the child sent a message of kind {kind!r}, not a result of kind {self.job.returns!r}",
        )

    def _crashed(self) -> CallOutcome:
        status = self.status
        limit = self.job.cpu_limit
        killed_by = os.WTERMSIG(status) if status is not None and os.WIFSIGNALED(status) else None
        over_cpu = killed_by == signal.SIGXCPU or (limit is not None and self.cpu_s >= limit)
        if limit is not None and killed_by is not None and over_cpu:
            return self._outcome(
                "timeout", error=f"stopped after {_secs(self.cpu_s)} CPU-s (CPU limit {_secs(limit)} s)"
            )
        if status is None:
            why = "died: exit status unknown (reaped elsewhere)"
        elif os.WIFSIGNALED(status):
            sig = os.WTERMSIG(status)
            try:
                name = signal.Signals(sig).name
            except ValueError:
                name = "unknown signal"
            hint = "; out of memory?" if sig == signal.SIGKILL else ""
            why = f"died: signal {sig} ({name}{hint})"
        else:
            code = os.waitstatus_to_exitcode(status)
            why = f"died: exit code {code}" + (" without a result" if code == 0 else "")
        if self.buffer:
            why += f" after sending {len(self.buffer)} of the result's bytes"
        return self._outcome("crashed", error=why)


@contextlib.contextmanager
def _sigint_deferred() -> Iterator[None]:
    """Hold back a Ctrl-C that arrives while a child is forked and recorded, then deliver it.

    ``os.fork`` runs Python's at-fork hooks (``logging``, ``random``, ``threading``); an
    exception raised inside one is printed and dropped, so a KeyboardInterrupt raised there
    would be lost, and one raised between the fork and the bookkeeping would orphan the
    child. The SIGINT handler is therefore replaced by one that only notes the signal, and
    the original handler is called once the child is known (and killed if it must be).
    """
    current = signal.getsignal(signal.SIGINT)
    if threading.current_thread() is not threading.main_thread() or not callable(current):
        yield  # handlers run only in the main thread; SIG_IGN/SIG_DFL need no help
        return
    arrived: list[Any] = []
    signal.signal(signal.SIGINT, lambda signum, frame: arrived.append(frame))
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, current)
    if arrived:
        current(signal.SIGINT, arrived[0])


def _secs(x: float) -> str:
    return f"{x:.1f}" if abs(x - round(x, 1)) < 1e-9 or x >= 1 else f"{x:.2g}"


def _one_line(exc: BaseException) -> str:
    """``"Type: message"`` on one line (whitespace runs collapsed, long messages cut)."""
    try:
        text = " ".join(str(exc).split())
    except Exception:  # noqa: BLE001 - a broken __str__ must not lose the outcome
        text = "<message unavailable>"
    if len(text) > _MESSAGE_CHARS:
        text = text[: _MESSAGE_CHARS - 3] + "..."
    # the first public class: numpy raises a private _ArrayMemoryError for MemoryError
    name = next((c.__name__ for c in type(exc).__mro__ if not c.__name__.startswith("_")), "Exception")
    return f"{name}: {text}" if text else name


# --------------------------------------------------------------------------- the child
def die_with_parent(parent: int) -> None:  # pragma: no cover - runs in children
    """Make the calling (forked) process get SIGKILL when its parent dies (Linux: ``prctl
    PR_SET_PDEATHSIG``), and leave now if the parent ``parent`` (pid) is already gone.

    So a job does not outlive a study killed with SIGKILL, which no handler can see. The kernel
    sends the signal when the parent's forking *thread* ends; the job runner forks from the
    thread that drives it, which lives as long as its jobs. Elsewhere than Linux only the check
    is made.
    """
    if _PRCTL is not None:
        _PRCTL(_PR_SET_PDEATHSIG, int(signal.SIGKILL), 0, 0, 0)
    if os.getppid() != parent:
        os._exit(1)


def send_report(value: Any) -> None:
    """Send a report to the parent from inside a job (see :attr:`IsolatedCall.max_reports`): ``bytes`` in a
    job with ``returns="bytes"``, any picklable value otherwise. The job goes on; the parent
    keeps a thinned list of the reports and hands it over in the job's :class:`CallOutcome`.

    value: the report. Raises RuntimeError outside a job of :func:`run_calls`.
    """
    if _CHILD is None or os.getpid() != _CHILD[0]:
        raise RuntimeError("send_report is for a job running under droneplan's job runner")
    _, w, returns = _CHILD
    if returns == "bytes":
        if not isinstance(value, (bytes, bytearray)):
            raise TypeError(f"a report of a bytes job must be bytes, got {type(value).__name__}")
        payload = bytes(value)
    else:
        payload = pickle.dumps(value, protocol=pickle.HIGHEST_PROTOCOL)
    _write_message(w, _REPORT + payload)


_CHILD: tuple[int, int, str] | None = (
    None  # in a child: (its pid, the pipe's write end, IsolatedCall.returns)
)


def _write_message(w: int, message: bytes) -> None:
    """Write one length-prefixed message to the pipe ``w`` (blocking until it is all written)."""
    data = memoryview(_HEADER.pack(len(message)) + message)
    while data:
        data = data[os.write(w, data) :]


def _unpickled_report(payload: bytes) -> Any:
    try:
        return pickle.loads(payload)
    except Exception as exc:  # noqa: BLE001 - a report the parent cannot read is kept as what it says
        return f"unreadable report: {_one_line(exc)}"


def _set_limits(job: IsolatedCall, memory_limit: int | None, grace: float) -> None:  # pragma: no cover
    """The child's resource limits: no core dumps, the address space, the CPU time."""
    with contextlib.suppress(ValueError, OSError):
        resource.setrlimit(resource.RLIMIT_CORE, (0, 0))
    if memory_limit is not None:
        _, hard = resource.getrlimit(resource.RLIMIT_AS)
        soft = memory_limit if hard == resource.RLIM_INFINITY else min(memory_limit, hard)
        resource.setrlimit(resource.RLIMIT_AS, (soft, hard))
    if job.cpu_limit is not None:  # SIGXCPU at the soft limit, SIGKILL one second later
        _, hard = resource.getrlimit(resource.RLIMIT_CPU)
        soft = math.ceil(job.cpu_limit + grace)
        if hard != resource.RLIM_INFINITY:
            soft = min(soft, hard)
        resource.setrlimit(resource.RLIMIT_CPU, (soft, soft + 1 if hard == resource.RLIM_INFINITY else hard))


def _child_main(  # pragma: no cover
    job: IsolatedCall, w: int, close_fds: list[int], limits: tuple[int | None, float], parent: int
) -> None:
    """Everything the child does; it never returns (``os._exit`` in every path). ``limits``:
    the address-space limit (bytes or None) and the grace (s) over the job's CPU limit."""
    global _CHILD
    code = 1
    try:
        os.setpgid(0, 0)
        die_with_parent(parent)
        signal.signal(signal.SIGINT, signal.SIG_IGN)
        with contextlib.suppress(ValueError, OSError):  # the parent's Ctrl-C watcher is not ours
            signal.set_wakeup_fd(-1)
        for fd in close_fds:
            with contextlib.suppress(OSError):
                os.close(fd)
        _set_limits(job, *limits)
        me = os.getpid()
        _CHILD = (me, w, job.returns)
        payload = _call(job)
        if os.getpid() != me:  # a process that fn forked returned here: it has no result to send
            os._exit(0)
        for stream in (sys.stdout, sys.stderr):
            with contextlib.suppress(BaseException):
                stream.flush()
        _write_message(w, payload)
        code = 0
    except BaseException:  # noqa: BLE001 - nothing may escape into the parent's code
        code = 1  # the parent reports a child that ends without a result as crashed
    finally:
        os._exit(code)


def _call(job: IsolatedCall) -> bytes:
    """Run the job; its result message (a kind byte, then the payload)."""
    try:
        value = job.fn(*job.args, **job.kwargs)
    except BaseException as exc:  # noqa: BLE001 - SystemExit and KeyboardInterrupt are the job's errors too
        return _error_message(_one_line(exc), tb_module.format_exc())
    if job.returns == "bytes":
        if isinstance(value, (bytes, bytearray)):
            return _OK_BYTES + bytes(value)
        return _error_message(f"TypeError: the job returned {type(value).__qualname__}, not bytes", "")
    try:
        return _OK_PICKLE + pickle.dumps(value, protocol=pickle.HIGHEST_PROTOCOL)
    except BaseException as exc:  # noqa: BLE001 - whatever pickling raises
        error = f"{type(exc).__name__}: the return value ({type(value).__qualname__}) cannot be pickled"
        detail = _one_line(exc).partition(": ")[2]
        return _error_message(f"{error}: {detail}" if detail else error, tb_module.format_exc())


def _error_message(error: str, traceback: str) -> bytes:
    return _ERROR + json.dumps([error, traceback]).encode("utf-8", "replace")


# the names of the previous release: a reproduction's graph node is now the only ``Job``
# (:class:`droneplan.studies.jobs.Job`)
__getattr__ = deprecated_names(
    __name__, {"Job": "IsolatedCall", "JobOutcome": "CallOutcome", "run_jobs": "run_calls"}, globals()
)
