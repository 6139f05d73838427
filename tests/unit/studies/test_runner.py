"""The forked job runner: every way user code can end becomes one outcome, and no process outlives it."""

from __future__ import annotations

import _thread
import atexit
import math
import os
import signal
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from droneplan.studies.runner import OUTCOME_STATUSES, CallOutcome, IsolatedCall, run_calls, run_isolated

pytestmark = pytest.mark.skipif(not hasattr(os, "fork"), reason="the runner is POSIX-only")


# --------------------------------------------------------------------------- helpers
def _alive(pid: int) -> bool:
    """Whether ``pid`` is a running process (a zombie waiting for init counts as dead)."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # the pid was reused by someone else's process
        return False
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return True
    return stat.rsplit(")", 1)[1].split()[0] != "Z"


def _gone_within(pid: int, seconds: float = 3.0) -> bool:
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        if not _alive(pid):
            return True
        time.sleep(0.02)
    return not _alive(pid)


def _children() -> set[int]:
    psutil = pytest.importorskip("psutil")
    return {p.pid for p in psutil.Process().children(recursive=True)}


def _reaped(pid: int) -> bool:
    """A direct child that was reaped has no process table entry left (not even a zombie)."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return True
    return False


def _record_pid_then_sleep(path: str) -> None:
    tmp = path + ".tmp"
    Path(tmp).write_text(str(os.getpid()))
    os.replace(tmp, path)
    time.sleep(60)


def _wait_for(paths: list[str]) -> str:
    end = time.monotonic() + 10
    while not all(os.path.exists(p) for p in paths):
        if time.monotonic() > end:
            raise TimeoutError("the sleeping jobs did not start")
        time.sleep(0.01)
    return "started"


def _leave_a_helper(path: str, then: str) -> int:
    """Fork a helper that sleeps for a minute (in the job's process group), then go on as told."""
    helper = os.fork()
    if helper == 0:
        time.sleep(60)
        os._exit(0)
    Path(path).write_text(str(helper))
    if then == "hang":
        time.sleep(60)
    elif then == "exit":
        os._exit(5)  # the helper keeps the result pipe open: the end is seen by waiting, not by EOF
    return helper


def _raise_value_error(x: int) -> None:
    raise ValueError(f"bad input:\n  {x}")


def _fail_on_load() -> None:
    raise RuntimeError("no unpickling here")


class _LoadsBadly:
    def __reduce__(self):
        return (_fail_on_load, ())


def _spin(seconds: float) -> float:
    start = time.process_time()
    while time.process_time() - start < seconds:
        pass
    return time.process_time() - start


def _spin_in_a_grandchild(seconds: float) -> int:
    pid = os.fork()
    if pid == 0:
        _spin(seconds)
        os._exit(0)
    _, status = os.waitpid(pid, 0)
    return os.waitstatus_to_exitcode(status)


# --------------------------------------------------------------------------- outcomes
def test_ok_returns_the_value_and_measures_the_child():
    out = run_isolated(IsolatedCall(("inst", 3), np.arange, (10,), {"dtype": np.int32}))
    assert isinstance(out, CallOutcome)
    assert out.key == ("inst", 3) and out.status == "ok" and out.error == "" and out.traceback == ""
    np.testing.assert_array_equal(out.value, np.arange(10, dtype=np.int32))
    assert out.value.dtype == np.int32
    assert out.wall_s > 0 and out.cpu_s >= 0
    assert out.status in OUTCOME_STATUSES


def test_a_result_of_many_megabytes_arrives_whole():
    n = 3_000_000  # 24 MB: hundreds of pipe buffers
    out = run_isolated(IsolatedCall("big", np.arange, (n,), {"dtype": np.float64}))
    assert out.status == "ok"
    np.testing.assert_array_equal(out.value, np.arange(n, dtype=np.float64))


def test_an_exception_is_an_error_with_message_and_traceback():
    out = run_isolated(IsolatedCall("v", _raise_value_error, (7,)))
    assert out.status == "error" and out.value is None
    assert out.error == "ValueError: bad input: 7"  # one line
    assert "Traceback (most recent call last)" in out.traceback
    assert "_raise_value_error" in out.traceback and "ValueError: bad input:" in out.traceback


def test_system_exit_is_an_error_and_the_parents_atexit_handlers_never_run_in_the_child(tmp_path):
    marker = tmp_path / "atexit-ran"
    handler = marker.touch
    atexit.register(handler)
    try:
        out = run_isolated(IsolatedCall("exit", sys.exit, (2,)))
        interrupted = run_isolated(
            IsolatedCall("kbd", _thread.interrupt_main)
        )  # SIGINT is ignored in the child
    finally:
        atexit.unregister(handler)
    assert (out.status, out.error) == ("error", "SystemExit: 2")
    assert interrupted.status == "ok"  # the child ignores SIGINT
    assert not marker.exists()


def test_a_sleeping_job_is_killed_after_limit_plus_grace():
    start = time.monotonic()
    out = run_isolated(IsolatedCall("s", time.sleep, (60,), time_limit=0.5), grace=0.5)
    elapsed = time.monotonic() - start
    assert out.status == "timeout" and out.value is None
    assert "time limit 0.5 s" in out.error and out.error.startswith("killed after ")
    assert 1.0 <= out.wall_s <= elapsed < 5.0  # never before limit + grace; generous bound on the kill


def test_a_job_that_returns_within_the_grace_period_is_ok():
    out = run_isolated(IsolatedCall("late", time.sleep, (0.4,), time_limit=0.1), grace=3.0)
    assert out.status == "ok" and out.wall_s >= 0.4


@pytest.mark.parametrize(
    ("fn", "args", "expected"),
    [
        (os._exit, (3,), "died: exit code 3"),
        (os._exit, (0,), "died: exit code 0 without a result"),
        (os.kill, "self-segv", "died: signal 11 (SIGSEGV)"),
    ],
)
def test_a_child_that_dies_without_a_result_crashed(fn, args, expected):
    if args == "self-segv":
        fn, args = (lambda: os.kill(os.getpid(), signal.SIGSEGV)), ()
    out = run_isolated(IsolatedCall("c", fn, args))
    assert (out.status, out.error, out.value) == ("crashed", expected, None)


def test_an_unpicklable_return_value_is_an_error_naming_its_type():
    out = run_isolated(IsolatedCall("l", lambda: lambda x: x))
    assert out.status == "error"
    assert "(function) cannot be pickled" in out.error
    assert "\n" not in out.error and "pickle" in out.traceback


def test_a_return_value_that_fails_to_unpickle_is_an_error():
    out = run_isolated(IsolatedCall("u", _LoadsBadly))
    assert out.status == "error" and "could not be unpickled" in out.error
    assert "no unpickling here" in out.error


def test_closures_and_local_functions_run_without_pickling():
    secret = np.array([1.5, 2.5])

    class Local:  # not importable by name: could never be pickled
        factor = 4.0

    def scaled(offset):
        return float((secret * Local.factor).sum() + offset)

    out = run_isolated(IsolatedCall("closure", scaled, kwargs={"offset": 1.0}))
    assert (out.status, out.value) == ("ok", 17.0)


def test_printed_output_reaches_the_parents_descriptors_once(capfd):
    print("parent text before the fork", end="")  # buffered: must not be printed again by the child

    def noisy():
        print("hello from the job")
        print("job warning", file=sys.stderr)
        return 1

    out = run_isolated(IsolatedCall("p", noisy))
    captured = capfd.readouterr()
    assert out.status == "ok"
    assert captured.out.count("hello from the job") == 1
    assert captured.out.count("parent text before the fork") == 1
    assert "job warning" in captured.err


def test_cpu_time_counts_the_child_and_the_processes_it_waited_for():
    own = run_isolated(IsolatedCall("cpu", _spin, (0.3,)))
    assert own.status == "ok" and own.value >= 0.3
    assert own.cpu_s >= 0.25  # rusage may round to the scheduler tick
    waited = run_isolated(IsolatedCall("cpu2", _spin_in_a_grandchild, (0.3,)))
    assert (waited.status, waited.value) == ("ok", 0)
    assert waited.cpu_s >= 0.25


def _run_inside_a_pool_worker(n: int) -> tuple[bool, str, object]:
    import multiprocessing

    outcome = run_isolated(IsolatedCall("in-pool", lambda: n + 1))  # a lambda: a pool could not even send it
    return multiprocessing.current_process().daemon, outcome.status, outcome.value


def test_jobs_run_inside_a_daemonic_pool_worker():
    import multiprocessing

    with multiprocessing.get_context("fork").Pool(1) as pool:
        daemon, status, value = pool.apply(_run_inside_a_pool_worker, (41,))
    assert daemon  # where multiprocessing itself refuses to start children
    assert (status, value) == ("ok", 42)


# --------------------------------------------------------------------------- process groups
@pytest.mark.parametrize(
    ("then", "limit", "status"), [("hang", 0.3, "timeout"), ("return", None, "ok"), ("exit", None, "crashed")]
)
def test_helpers_a_job_started_die_with_it(tmp_path, then, limit, status):
    path = tmp_path / "helper.pid"
    before = _children()
    out = run_isolated(IsolatedCall("g", _leave_a_helper, (str(path), then), time_limit=limit), grace=0.2)
    assert out.status == status
    if then == "exit":
        assert out.error == "died: exit code 5"
    helper = int(path.read_text())
    assert _gone_within(helper)
    assert _children() <= before


# --------------------------------------------------------------------------- several jobs
def test_two_workers_run_two_sleeping_jobs_at_once():
    start = time.monotonic()
    outs = list(run_calls([IsolatedCall(i, time.sleep, (1.5,)) for i in range(2)], workers=2))
    elapsed = time.monotonic() - start
    assert sorted(o.key for o in outs) == [0, 1] and {o.status for o in outs} == {"ok"}
    assert elapsed < 2.6  # one after the other would take 3 s


def test_outcomes_come_in_the_order_jobs_finish():
    outs = list(
        run_calls([IsolatedCall("slow", time.sleep, (1.0,)), IsolatedCall("fast", int, ("7",))], workers=2)
    )
    assert [o.key for o in outs] == ["fast", "slow"]
    assert outs[0].value == 7


def test_many_jobs_from_a_generator_are_all_collected_once():
    n = 24
    jobs = (IsolatedCall(("sq", i), lambda i=i: i * i) for i in range(n))  # not a Sequence: total unknown
    outs = list(run_calls(jobs, workers=2, progress="squares"))
    assert len(outs) == n
    assert {o.key: o.value for o in outs} == {("sq", i): i * i for i in range(n)}
    mixed = list(
        run_calls(
            [
                IsolatedCall("a", abs, (-2,)),
                IsolatedCall("b", _raise_value_error, (1,)),
                IsolatedCall("c", os._exit, (1,)),
            ],
            workers=3,
            progress="mixed",
        )
    )
    assert {o.key: o.status for o in mixed} == {"a": "ok", "b": "error", "c": "crashed"}


def test_memory_limit_turns_a_huge_allocation_into_an_error():
    psutil = pytest.importorskip("psutil")
    limit = psutil.Process().memory_info().vms + 2**30  # what the fork inherits + 1 GiB
    huge = run_isolated(IsolatedCall("huge", np.empty, (8 * 2**30,), {"dtype": np.uint8}), memory_limit=limit)
    assert huge.status == "error" and huge.error.startswith("MemoryError: ")
    small = run_isolated(IsolatedCall("small", np.ones, (10**6,)), memory_limit=limit)
    assert small.status == "ok" and small.value.sum() == 10**6


# --------------------------------------------------------------------------- interrupts
def test_keyboard_interrupt_in_the_consumer_kills_and_reaps_every_child(tmp_path):
    paths = [str(tmp_path / f"pid{i}") for i in range(3)]
    jobs = [IsolatedCall(i, _record_pid_then_sleep, (p,)) for i, p in enumerate(paths)]
    jobs.append(IsolatedCall("fast", _wait_for, (paths,)))
    before = _children()
    seen: list[tuple[object, str]] = []

    def consume():  # a loop over the outcomes whose body is interrupted by Ctrl-C
        for outcome in run_calls(jobs, workers=4):
            seen.append((outcome.key, outcome.status))
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        consume()
    assert seen == [("fast", "ok")]
    for p in paths:
        assert _reaped(int(Path(p).read_text()))
    assert _children() == before


def test_keyboard_interrupt_while_waiting_kills_and_reaps_every_child(tmp_path):
    paths = [str(tmp_path / f"pid{i}") for i in range(2)]
    it = run_calls(
        [IsolatedCall(i, _record_pid_then_sleep, (p,), time_limit=30) for i, p in enumerate(paths)], workers=2
    )
    before = _children()

    def interrupt_once_started():
        _wait_for(paths)
        _thread.interrupt_main()

    threading.Thread(target=interrupt_once_started, daemon=True).start()
    start = time.monotonic()
    with pytest.raises(KeyboardInterrupt):
        next(it)  # `it` stays referenced: the runner cleans up without waiting for garbage collection
    assert time.monotonic() - start < 10
    for p in paths:
        assert _reaped(int(Path(p).read_text()))
    assert _children() == before


def test_closing_the_iterator_early_kills_the_rest(tmp_path):
    paths = [str(tmp_path / f"pid{i}") for i in range(2)]
    jobs = [IsolatedCall(i, _record_pid_then_sleep, (p,)) for i, p in enumerate(paths)]
    it = run_calls([*jobs, IsolatedCall("fast", _wait_for, (paths,))], workers=3)
    assert next(it).key == "fast"
    it.close()
    for p in paths:
        assert _reaped(int(Path(p).read_text()))


# --------------------------------------------------------------------------- validation
@pytest.mark.parametrize(
    ("kwargs", "error", "name"),
    [
        ({"workers": 0}, ValueError, "workers"),
        ({"workers": 1.5}, TypeError, "workers"),
        ({"workers": True}, TypeError, "workers"),
        ({"grace": -1.0}, ValueError, "grace"),
        ({"grace": math.nan}, ValueError, "grace"),
        ({"memory_limit": 0}, ValueError, "memory_limit"),
        ({"progress": 3}, TypeError, "progress"),
    ],
)
def test_bad_runner_arguments_are_refused_by_name(kwargs, error, name):
    with pytest.raises(error, match=name):
        run_calls([IsolatedCall(0, int)], **kwargs)


@pytest.mark.parametrize(
    ("kwargs", "error", "name"),
    [
        ({"time_limit": 0}, ValueError, "time_limit"),
        ({"time_limit": -1.0}, ValueError, "time_limit"),
        ({"time_limit": math.inf}, ValueError, "time_limit"),
        ({"time_limit": True}, TypeError, "time_limit"),
        ({"fn": 3}, TypeError, "fn"),
        ({"key": [1]}, TypeError, "key"),
        ({"args": [1]}, TypeError, "args"),
        ({"kwargs": [("a", 1)]}, TypeError, "kwargs"),
    ],
)
def test_bad_jobs_are_refused_by_name(kwargs, error, name):
    with pytest.raises(error, match=name):
        IsolatedCall(**{"key": 0, "fn": int, **kwargs})


def test_something_that_is_not_a_job_is_refused_with_its_position():
    before = _children()
    with pytest.raises(TypeError, match=r"jobs\[1\] must be an IsolatedCall"):
        list(run_calls([IsolatedCall(0, int), (1, int)], workers=1))
    with pytest.raises(TypeError, match="job must be IsolatedCall"):
        run_isolated((0, int))  # type: ignore[arg-type]
    with pytest.raises(TypeError, match="jobs"):
        run_calls(None)  # type: ignore[arg-type]
    assert _children() == before


def test_a_platform_without_fork_gets_a_clear_error(monkeypatch):
    monkeypatch.delattr(os, "fork")
    with pytest.raises(RuntimeError, match=r"needs os\.fork"):
        run_calls([IsolatedCall(0, int)])


# ------------------------------------------------------------- jobs of code droneplan does not control
_UNPICKLED: list[str] = []


def _record_unpickling() -> str:
    _UNPICKLED.append("ran")
    return "ran"


class _RecordsItsUnpickling:
    def __reduce__(self):
        return (_record_unpickling, ())


def _open_files() -> set[tuple[int, int]]:
    found = set()
    for fd in range(256):
        try:
            st = os.fstat(fd)
        except OSError:
            continue
        found.add((st.st_dev, st.st_ino))
    return found


def _writes_a_forged_pickle_result(before: set[tuple[int, int]]):
    """Skips the return path and writes a framed pickle result message to every pipe it holds
    that the test process did not have open before (its result pipe)."""
    import pickle
    import stat
    import struct

    body = b"P" + pickle.dumps(_RecordsItsUnpickling())
    for fd in range(3, 256):
        try:
            st = os.fstat(fd)
            if stat.S_ISFIFO(st.st_mode) and (st.st_dev, st.st_ino) not in before:
                os.write(fd, struct.pack(">Q", len(body)) + body)
        except OSError:
            continue
    os._exit(0)


def test_a_bytes_job_never_unpickles_what_its_child_writes():
    """With returns="pickle" the same forged message runs __reduce__ here (the last lines)."""
    out = run_isolated(
        IsolatedCall("forged", _writes_a_forged_pickle_result, (_open_files(),), returns="bytes"), grace=1.0
    )
    assert _UNPICKLED == []
    assert out.status == "error" and "kind b'P'" in out.error
    trusted = run_isolated(
        IsolatedCall("forged", _writes_a_forged_pickle_result, (_open_files(),), returns="pickle"), grace=1.0
    )
    assert trusted.status == "ok" and trusted.value == "ran" and _UNPICKLED == ["ran"]
    _UNPICKLED.clear()


def test_a_bytes_job_hands_its_bytes_over_untouched_and_refuses_other_values():
    assert run_isolated(IsolatedCall("b", lambda: b"\x00raw", returns="bytes")).value == b"\x00raw"
    out = run_isolated(IsolatedCall("s", lambda: "text", returns="bytes"))
    assert out.status == "error" and "returned str, not bytes" in out.error


def test_a_result_past_its_cap_is_an_error_naming_the_size():
    out = run_isolated(IsolatedCall("big", lambda: bytes(1 << 20), returns="bytes", max_result_bytes=1000))
    assert out.status == "error" and "more than the cap of 1000" in out.error
