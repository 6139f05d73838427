"""Machinery shared by the per-problem studies: executors (serial, process pool, Dask),
the recording of task rows with clean interrupts (:func:`droneplan.studies.jobs.map_rows` runs
the tasks), the numeric summary and
gap figure of a study, "thesis value | this run | how measured" tables, and timing helpers.

The results schema and the store are in :mod:`droneplan.studies.store` (its docstring
says how a problem's study emits rows).
"""

from __future__ import annotations

import concurrent.futures as cf
import contextlib
import math
import os
import shutil
import signal
import sys
import textwrap
import threading
import time
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Self

import numpy as np
import pandas as pd

from droneplan.studies.provenance import config_hash, provenance, provenance_columns
from droneplan.studies.store import COLUMNS, STORE_NAME, ResultStore, error_row

__all__ = [
    "StudyExecutor",
    "StudyError",
    "make_executor",
    "WORKERS_PER_CORE",
    "check_executor_options",
    "INTERRUPT_GRACE_S",
    "open_store",
    "task_config",
    "DEVIATION_THRESHOLD",
    "ComparisonTable",
    "ROW_KINDS",
    "render_frame",
    "summarize",
    "report_study",
    "gap_figure",
    "timed",
    "load_average",
    "Measured",
    "measured",
]


# --------------------------------------------------------------------------- executors
class StudyExecutor(cf.Executor):
    """A ``concurrent.futures`` executor that also says how to run and stop it.

    kind: ``"serial"`` (tasks run in this process, one at a time, as they are consumed),
    ``"processes"`` (a local process pool) or ``"dask"`` (a Dask cluster).
    slots: how many tasks run at once (tasks in flight are kept to twice this).
    """

    def __init__(self, kind: str, slots: int, inner: cf.Executor | None = None, client: Any = None):
        self.kind, self.slots, self._inner, self._client = kind, int(slots), inner, client

    def submit(self, fn, /, *args, **kwargs):
        if self._inner is not None:
            return self._inner.submit(fn, *args, **kwargs)
        future: cf.Future = cf.Future()
        try:  # serial: run now; an interrupt propagates instead of hiding in the future
            future.set_result(fn(*args, **kwargs))
        except Exception as exc:  # noqa: BLE001 - any failure belongs in the future, as in a pool
            future.set_exception(exc)
        return future

    def map(self, fn, *iterables, timeout=None, chunksize=1):
        if self._inner is None:  # serial: lazily, one call per item consumed
            return (fn(*args) for args in zip(*iterables, strict=False))
        return self._inner.map(fn, *iterables, timeout=timeout, chunksize=chunksize)

    def shutdown(self, wait: bool = True, *, cancel_futures: bool = False) -> None:
        if self._inner is None:
            return
        if self.kind == "dask":
            self._inner.shutdown(wait=wait and not cancel_futures)
        else:
            self._inner.shutdown(wait=wait, cancel_futures=cancel_futures)

    def kill(self) -> None:
        """Stop now: cancel queued tasks and end the worker processes this executor started."""
        if self._inner is None:
            return
        if self.kind == "processes":
            procs = list(
                (getattr(self._inner, "_processes", None) or {}).values()
            )  # no public handle on workers
            self._inner.shutdown(wait=False, cancel_futures=True)
            for p in procs:
                if p.is_alive():
                    p.kill()
        elif self.kind == "dask":  # the client executor cancels its futures on shutdown(wait=False)
            with contextlib.suppress(Exception):
                self._inner.shutdown(wait=False)


def _ignore_sigint() -> None:
    """Pool worker initializer: Ctrl-C is the parent's business (it kills the workers)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)


class StudyError(RuntimeError):
    """A study cannot run as asked (unreachable Dask scheduler, unusable --out ...)."""


WORKERS_PER_CORE = 4
"""Most local worker processes per core :func:`make_executor` starts (``workers`` beyond
``WORKERS_PER_CORE * os.cpu_count()`` is refused: each process holds a copy of the solvers, and
far more processes than cores only add memory and switching)."""


def check_executor_options(workers: object, dask_address: object) -> None:
    """Refuse, naming the parameter, a ``workers`` that is not an int in
    [1, ``WORKERS_PER_CORE`` x cores] (None: one per core) or a ``dask_address`` that is not a
    string (None: no Dask)."""
    from droneplan.core.validation import check_instance, check_int

    if workers is not None:
        check_int("workers", workers, min_value=1, max_value=WORKERS_PER_CORE * (os.cpu_count() or 1))
    check_instance("dask_address", dask_address, str, optional=True)


def _first_line(exc: BaseException) -> str:
    return " ".join(str(exc).split())[:160] or type(exc).__name__


def _probe_scheduler(address: str, timeout: float) -> None:
    """Check, within ``timeout`` seconds in all (connection and handshake), that a Dask scheduler
    answers at ``address``; a :class:`StudyError` of one line otherwise.

    The probe asks the peer for its identity over Dask's own protocol, in a thread of its own with
    its own event loop, so a peer that accepts the connection and then stays silent, answers
    HTTP or sends garbage costs the timeout and no more, and leaves no half-built client behind.
    """
    import asyncio

    outcome: list[Any] = []

    async def identity() -> Any:
        from distributed.core import rpc

        async with rpc(address, timeout=timeout) as peer:
            return await peer.identity()

    def run() -> None:
        try:
            outcome.append(asyncio.run(asyncio.wait_for(identity(), timeout)))
        except BaseException as exc:  # noqa: BLE001 - whatever the peer made the client raise
            outcome.append(exc)

    thread = threading.Thread(target=run, name="droneplan-dask-probe", daemon=True)
    thread.start()
    thread.join(timeout + 1.0)
    answer = outcome[0] if outcome else TimeoutError(f"no answer within {timeout:g} s")
    if isinstance(answer, (TimeoutError, asyncio.TimeoutError)):
        raise StudyError(f"cannot reach the Dask scheduler at {address}: no answer within {timeout:g} s")
    if isinstance(answer, OSError):
        raise StudyError(f"cannot reach the Dask scheduler at {address}: {_first_line(answer)}")
    if isinstance(answer, BaseException):
        raise StudyError(
            f"{address} does not answer as a Dask scheduler (reading its reply failed: {_first_line(answer)})"
        )
    if not isinstance(answer, dict) or answer.get("type") != "Scheduler":
        raise StudyError(f"{address} is not a Dask scheduler (it answered {str(answer)[:80]!r})")


@contextlib.contextmanager
def make_executor(
    workers: int | None = None, dask_address: str | None = None, *, connect_timeout: float = 5.0
) -> Iterator[StudyExecutor]:
    """A :class:`StudyExecutor` for mapping over instances.

    workers: local worker processes (None: number of cores; 1: run serially in this
        process, each task when it is consumed; at most ``WORKERS_PER_CORE`` per core).
        Ignored when ``dask_address`` is given.
    dask_address: address of a running Dask scheduler (``tcp://host:8786``); needs
        ``distributed``. connect_timeout: seconds to wait for it before
        :class:`StudyError`.
    """
    check_executor_options(workers, dask_address)
    if dask_address:
        try:
            from distributed import Client
        except ImportError as exc:  # pragma: no cover - depends on the extra
            raise StudyError("--dask needs distributed: pip install 'droneplan[distributed]'") from exc
        _probe_scheduler(dask_address, connect_timeout)
        try:
            client = Client(dask_address, timeout=f"{connect_timeout}s", set_as_default=False)
        except (OSError, TimeoutError, ValueError) as exc:
            raise StudyError(
                f"cannot reach the Dask scheduler at {dask_address}: "
                f"{str(exc).splitlines()[0] if str(exc) else type(exc).__name__}"
            ) from None
        try:
            slots = max(1, sum(client.nthreads().values()))
            yield StudyExecutor("dask", slots, client.get_executor(), client)
        finally:
            client.close()
        return
    n = workers if workers is not None else (os.cpu_count() or 1)
    if n == 1:
        yield StudyExecutor("serial", 1)
        return
    pool = cf.ProcessPoolExecutor(max_workers=n, initializer=_ignore_sigint)
    ex = StudyExecutor("processes", n, pool)
    try:
        yield ex
    except BaseException:
        ex.kill()
        raise
    finally:
        pool.shutdown(wait=True, cancel_futures=True)


# --------------------------------------------------------------------------- interrupts
INTERRUPT_GRACE_S: float | None = None
"""When set (the CLI sets 3 s), a Ctrl-C that the running task does not turn into a
KeyboardInterrupt within this many seconds (a solver inside C code) ends the process with
exit code 130 after killing the workers; finished rows are already in the store. None
(the default, e.g. in notebooks) never ends the process."""


class _InterruptGuard:
    """Notices Ctrl-C even while a solver holds the main thread in C code.

    A Python SIGINT handler sets a flag (and raises KeyboardInterrupt as usual); the
    signal's wakeup fd is read by a watcher thread, so the flag is set the moment the
    signal arrives. A task result that comes back after the flag is set is discarded:
    a solve cut short by Ctrl-C is never recorded as finished.
    """

    def __init__(self, executor: StudyExecutor):
        self.executor = executor
        self.flag = threading.Event()
        self._left = threading.Event()
        self.active = threading.current_thread() is threading.main_thread()

    def _handler(self, signum, frame):
        self.flag.set()
        raise KeyboardInterrupt

    def __enter__(self) -> Self:
        if not self.active:
            return self
        self._prev = signal.signal(signal.SIGINT, self._handler)
        self._r, self._w = os.pipe()
        os.set_blocking(self._w, False)
        self._prev_fd = signal.set_wakeup_fd(self._w, warn_on_full_buffer=False)
        threading.Thread(target=self._watch, name="droneplan-interrupt-watch", daemon=True).start()
        return self

    def _watch(self) -> None:
        while True:
            try:
                data = os.read(self._r, 64)
            except OSError:
                return
            if not data:
                return
            if signal.SIGINT in data:
                self.flag.set()
                grace = INTERRUPT_GRACE_S
                if grace is not None and not self._left.wait(grace):
                    with contextlib.suppress(Exception):
                        self.executor.kill()
                    sys.stderr.write(
                        "\ndroneplan: interrupted; a solve did not stop within "
                        f"{grace:g} s, exiting. Finished rows are in the store: rerun to resume.\n"
                    )
                    sys.stderr.flush()
                    os._exit(130)

    def rearm(self) -> None:
        """Reinstall the handler (a native library may have reset SIGINT to its default)."""
        if self.active and signal.getsignal(signal.SIGINT) is not self._handler:
            signal.signal(signal.SIGINT, self._handler)

    def check(self) -> None:
        """Raise KeyboardInterrupt if Ctrl-C arrived (even if a library swallowed it)."""
        if self.flag.is_set():
            raise KeyboardInterrupt

    def __exit__(self, *exc) -> None:
        self._left.set()
        if not self.active:
            return
        signal.set_wakeup_fd(self._prev_fd)
        signal.signal(signal.SIGINT, self._prev)
        os.close(self._w)
        os.close(self._r)


# --------------------------------------------------------------------------- stores
@contextlib.contextmanager
def open_store(store: ResultStore | None, out: str | os.PathLike) -> Iterator[ResultStore]:
    """``store`` itself, or the store ``out/results.sqlite`` opened for the duration."""
    if store is not None:
        yield store
        return
    with ResultStore(Path(out) / STORE_NAME) as opened:
        yield opened


# --------------------------------------------------------------------------- mapping tasks to rows
TaskFn = Callable[[Mapping[str, Any]], Mapping[str, Any] | list[dict]]
"""A study task: takes one task mapping and returns its rows (a list, or one row)."""


def _call_task(fn: TaskFn, task: Mapping[str, Any]) -> list[dict]:
    """Run one task; an exception becomes the task's error row (an interrupt propagates)."""

    def failed(message: str) -> list[dict]:
        return [
            error_row(
                task["problem"], task["instance"], message, seed=task.get("seed"), size=task.get("size")
            )
        ]

    try:
        returned = fn(task)
    except Exception as exc:  # noqa: BLE001 - recorded, the study goes on
        return failed(f"{type(exc).__name__}: {exc}")
    rows = [dict(returned)] if isinstance(returned, Mapping) else list(returned)
    for r in rows:
        if (r.get("problem"), r.get("instance")) != (task["problem"], task["instance"]):
            return failed(f"task function returned a row of {r.get('problem')}/{r.get('instance')}")
    return rows


def task_config(task: Mapping[str, Any]) -> str:
    """The ``config`` of a task's rows: a hash of the task's settings and droneplan's source.

    task: the task mapping; everything but ``problem`` and ``instance`` counts, together
    with :func:`~droneplan.studies.provenance.provenance`'s ``code_hash``, so changing a
    setting or the code gives new rows instead of resuming old ones. Raises TypeError when
    the task holds a value that is not JSON-like.
    """
    settings = {k: v for k, v in task.items() if k not in ("problem", "instance")}
    try:
        return config_hash({"task": settings, "code_hash": provenance()["code_hash"]})
    except TypeError as exc:
        raise TypeError(f"task {task.get('instance')!r}: {exc}") from None


class _Recorder:
    """Stamps each task's rows with its config and the provenance columns, writes them, counts."""

    def __init__(self, store: ResultStore, configs: Mapping[tuple[str, str], str], bar: Any):
        self.store, self.configs, self.bar = store, configs, bar
        self.superseded = 0

    def write(self, task: Mapping[str, Any], rows: list[dict]) -> None:
        config = self.configs[(task["problem"], task["instance"])]
        stamped = []
        for r in rows:
            r = dict(r)
            r["config"] = config
            for k, v in provenance_columns().items():
                if r.get(k) is None:
                    r[k] = v
            stamped.append(r)
        self.superseded += self.store.write(stamped)
        if self.superseded:
            self.bar.set_postfix_str(f"{self.superseded} older rows set aside", refresh=False)
        self.bar.update(1)


# --------------------------------------------------------------------------- comparison tables
DEVIATION_THRESHOLD = 0.25
"""Relative deviation |this run - thesis| / |thesis| above which a reproduce row is flagged."""

ROW_KINDS = ("fidelity", "speed")
"""Kinds of comparison rows: ``fidelity`` (a value the thesis reports; beyond the threshold the
row is flagged ``!`` and needs a reason) and ``speed`` (a computing time: reported as a speed-up,
never flagged, since running faster than the thesis is no fidelity problem)."""

_TABLE_COLUMNS = ["quantity", "thesis", "this run", "deviation", "flag", "how measured", "why"]

Explainer = Callable[[str, str], str]
"""``explain(table_title, quantity)``: the reason for a flagged row, or ``""`` when none is known."""


@dataclass
class ComparisonTable:
    """A table "quantity | thesis | this run | deviation | flag | how measured | why" for one
    figure or table of the thesis.

    The deviation column is ``(this run - thesis) / |thesis|`` where both are numbers; fidelity
    rows whose deviation exceeds ``threshold`` (default ``DEVIATION_THRESHOLD``) are flagged
    ``!`` and carry a one-line reason in the ``why`` column. Speed rows (``kind="speed"``, the
    thesis value a computing time in s) show the speed-up instead ("13x faster") and are never
    flagged. ``explain`` (optional) supplies the reason of a flagged or speed row from a
    registry (e.g. :func:`droneplan.studies.thesis.report.flag_reasons`); :meth:`unexplained` lists
    the flagged rows that still have none.
    """

    title: str
    rows: list[dict[str, str]] = field(default_factory=list)
    threshold: float = DEVIATION_THRESHOLD
    explain: Explainer | None = None

    def add(
        self, quantity: str, thesis: Any, ours: Any, how: str, *, why: str = "", kind: str = "fidelity"
    ) -> None:
        """Add one row.

        quantity: what is compared (with its unit). thesis: the thesis's value (a number, a
        statement, or None when the thesis states none). ours: this run's value. how: how it
        was measured. why: a measured detail backing the reason of a flagged or speed row
        (appended to the registry's reason; ignored on rows that are within the threshold).
        kind: ``"fidelity"`` or ``"speed"`` (see :data:`ROW_KINDS`).
        """
        if kind not in ROW_KINDS:
            raise ValueError(f"kind must be one of {ROW_KINDS}, got {kind!r}")
        if not isinstance(why, str):
            raise TypeError(f"why must be a str, got {type(why).__name__}")
        dev = _deviation(thesis, ours)
        if kind == "speed":
            shown, flag = _speedup(thesis, ours), ""
        else:
            shown = "" if dev is None else f"{dev:+.0%}"
            flag = "" if dev is None else ("!" if abs(dev) > self.threshold else "ok")
        reason = ""
        if flag == "!" or kind == "speed":
            base = self.explain(self.title, quantity) if self.explain is not None else ""
            reason = "; ".join(r for r in (base.strip(), why.strip()) if r)
        self.rows.append(
            {
                "quantity": quantity,
                "thesis": _fmt(thesis),
                "this run": _fmt(ours),
                "deviation": shown,
                "flag": flag,
                "how measured": how,
                "why": reason,
            }
        )

    def unexplained(self) -> list[str]:
        """The quantities of the flagged (``!``) rows without a reason."""
        return [r["quantity"] for r in self.rows if r["flag"] == "!" and not r["why"].strip()]

    def frame(self) -> pd.DataFrame:
        return pd.DataFrame(self.rows, columns=_TABLE_COLUMNS)

    def render(self, width: int | None = None) -> str:
        """Plain text that fits ``width`` columns (default: the terminal's), long cells wrapped."""
        df = self.frame()
        note = f"(deviation = (this run - thesis) / |thesis|; ! beyond {self.threshold:.0%}, reason in 'why')"
        if df.empty:
            return f"== {self.title} ==\n(no rows)"
        if not df["why"].astype(bool).any():
            df = df.drop(columns=["why"])
        if not df["deviation"].astype(bool).any():  # nothing to compare: keep the width for the rest
            df, note = df.drop(columns=["deviation", "flag"]), ""
        notes = [note] if note else []
        missing = self.unexplained()
        if missing:
            notes.append("! WITHOUT A REASON: " + "; ".join(missing))
        return "\n".join([f"== {self.title} ==", render_frame(df, width=width), *notes])

    def markdown(self) -> str:
        """The table as GitHub Markdown."""
        df = self.frame()
        esc = [[str(v).replace("|", "\\|") for v in r] for r in df.itertuples(index=False)]
        lines = [
            f"**{self.title}**",
            "",
            "| " + " | ".join(df.columns) + " |",
            "|" + "---|" * len(df.columns),
            *("| " + " | ".join(r) + " |" for r in esc),
        ]
        return "\n".join(lines)

    def emit(self, out: Path, stem: str) -> None:
        """Print the table and write it to ``out/stem.csv`` and ``out/stem.md``."""
        out.mkdir(parents=True, exist_ok=True)
        print(self.render(), flush=True)
        print(flush=True)
        self.frame().to_csv(out / f"{stem}.csv", index=False)
        (out / f"{stem}.md").write_text(self.markdown() + "\n")


def _speedup(thesis: Any, ours: Any) -> str:
    """``"13x faster"`` / ``"2.0x slower"`` for computing times (s), ``""`` when not both numbers."""
    t, o = _number(thesis), _number(ours)
    if t is None or o is None or t <= 0 or o < 0:
        return ""
    if o == 0:
        return "faster (0 s)"
    ratio = t / o
    if ratio >= 1:
        return f"{ratio:.2g}x faster" if ratio < 10 else f"{ratio:.0f}x faster"
    return f"{1 / ratio:.2g}x slower" if 1 / ratio < 10 else f"{1 / ratio:.0f}x slower"


def _number(v: Any) -> float | None:
    if isinstance(v, bool) or v is None:
        return None
    if isinstance(v, (int, float)) and math.isfinite(v):
        return float(v)
    if hasattr(v, "item") and getattr(v, "ndim", 1) == 0:
        return _number(v.item())
    return None


def _deviation(thesis: Any, ours: Any) -> float | None:
    t, o = _number(thesis), _number(ours)
    if t is None or o is None or t == 0:
        return None
    return (o - t) / abs(t)


def _fmt(value: Any) -> str:
    if value is None:
        return "—"
    if isinstance(value, float):
        return f"{value:.4g}"
    return str(value)


def render_frame(df: pd.DataFrame, *, width: int | None = None, max_cell: int = 60) -> str:
    """Plain-text table of ``df`` that fits ``width`` columns: wide text columns wrap onto more lines."""
    width = width or shutil.get_terminal_size((120, 24)).columns
    cells = [
        [
            ""
            if v is None or (isinstance(v, float) and math.isnan(v))
            else (f"{v:.3g}" if isinstance(v, float) else str(v))
            for v in r
        ]
        for r in df.itertuples(index=False)
    ]
    cols = [str(c) for c in df.columns]
    natural = [max([len(c)] + [len(r[j]) for r in cells]) for j, c in enumerate(cols)]
    widths = [min(w, max_cell) for w in natural]
    # a column never gets narrower than its longest header word or its values (up to 12 chars)
    floor = [
        max(max(len(w) for w in c.split()), min(12, max([0] + [len(r[j]) for r in cells])))
        for j, c in enumerate(cols)
    ]
    sep = 3 * (len(cols) - 1)
    while sum(widths) + sep > width:
        slack = [w - f for w, f in zip(widths, floor, strict=False)]
        if max(slack) <= 0:
            break
        widths[slack.index(max(slack))] -= 1

    def lines_of(values):
        wrapped = [textwrap.wrap(v, w) or [""] for v, w in zip(values, widths, strict=False)]
        return [
            " | ".join(
                (col[k] if k < len(col) else "").ljust(w) for col, w in zip(wrapped, widths, strict=False)
            ).rstrip()
            for k in range(max(len(c) for c in wrapped))
        ]

    out = [*lines_of(cols), "-+-".join("-" * w for w in widths)]
    for r in cells:
        out += lines_of(r)
    return "\n".join(out)


# --------------------------------------------------------------------------- study summaries and figures
def summarize(df: pd.DataFrame, thesis: Mapping[tuple[str, str], str] | None = None) -> pd.DataFrame:
    """Numeric summary per (problem, method) of rows in the results schema.

    Columns: problem, method, role, count, success_rate (fraction with a solution),
    errors, best_rate (fraction with gap_to_best <= 1e-6), median/mean/p95 of gap_to_bound
    and gap_to_best (within ``analysis.GAP_ZERO_TOL`` of 0: exactly 0), gap_bound_kind (the
    bound kinds the gaps were measured against), median_time_s and ``thesis`` (the thesis's
    value for that method where it states one, from ``thesis[(problem, method)]``).
    """
    from droneplan.studies.analysis import snap_gap

    thesis = thesis or {}
    df = _with_columns(df)
    out = []
    for (problem, method), g in df.groupby(["problem", "method"], sort=False):
        solved = g["status"].isin(["optimal", "feasible"])
        rec = {
            "problem": problem,
            "method": method,
            "role": g["role"].iloc[0],
            "count": len(g),
            "success_rate": float(solved.mean()),
            "errors": int((g["status"] == "error").sum()),
            "best_rate": float((g["gap_to_best"] <= 1e-6).sum() / len(g)),
        }
        for col in ("gap_to_bound", "gap_to_best"):
            v = g[col].dropna()
            rec[f"median_{col}"] = snap_gap(float(v.median())) if len(v) else None
            rec[f"mean_{col}"] = snap_gap(float(v.mean())) if len(v) else None
            rec[f"p95_{col}"] = snap_gap(float(v.quantile(0.95))) if len(v) else None
        kinds = sorted(set(g["gap_bound_kind"].dropna()))
        rec["gap_bound_kind"] = ",".join(kinds)
        t = g["time_s"].dropna()
        rec["median_time_s"] = float(t.median()) if len(t) else None
        rec["thesis"] = thesis.get((problem, method), "")
        out.append(rec)
    return pd.DataFrame(out, columns=_SUMMARY_COLUMNS)


_SUMMARY_COLUMNS = [
    "problem",
    "method",
    "role",
    "count",
    "success_rate",
    "errors",
    "best_rate",
    *(f"{stat}_{col}" for col in ("gap_to_bound", "gap_to_best") for stat in ("median", "mean", "p95")),
    "gap_bound_kind",
    "median_time_s",
    "thesis",
]


def _with_columns(df: pd.DataFrame) -> pd.DataFrame:
    """``df`` with every schema column present (a frame of error rows may lack the gap columns)."""
    missing = [c for c in COLUMNS if c not in df.columns]
    df = df.assign(**dict.fromkeys(missing)) if missing else df.copy()
    for c in ("objective", "bound", "gap_to_bound", "gap_to_best", "time_s"):
        df[c] = pd.to_numeric(df[c], errors="coerce").astype(float)
    return df


def report_study(
    df: pd.DataFrame,
    out: Path,
    problem: str,
    *,
    thesis: Mapping[tuple[str, str], str] | None = None,
    title: str = "",
) -> pd.DataFrame:
    """Print the numeric summary of ``df``, write it to ``out/gap_summary.csv`` and draw
    ``out/gap_<problem>.png`` (gap distribution per method); returns the summary."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    df = _with_columns(df)
    summary = summarize(df, thesis)
    summary.to_csv(out / "gap_summary.csv", index=False)
    shown = summary[
        [
            "method",
            "role",
            "count",
            "success_rate",
            "errors",
            "best_rate",
            "median_gap_to_bound",
            "p95_gap_to_bound",
            "median_gap_to_best",
            "p95_gap_to_best",
            "median_time_s",
            "thesis",
        ]
    ]
    shown = shown.set_axis(
        [
            "method",
            "role",
            "n",
            "solved",
            "errors",
            "at best",
            "gap→bound median",
            "gap→bound p95",
            "gap→best median",
            "gap→best p95",
            "time (s) median",
            "thesis",
        ],
        axis=1,
    )
    print(
        f"== {title or problem + ' gap study'} ({df['instance'].nunique()} instances; gaps relative, "
        f"full summary in {out / 'gap_summary.csv'}) =="
    )
    print(render_frame(shown), flush=True)
    print(flush=True)
    gap_figure(df, out / f"gap_{problem}.png", title=title or f"{problem}: gap per method")
    return summary


def gap_figure(df: pd.DataFrame, path: Path, *, title: str = "") -> Path:
    """Box plots of gap_to_bound and gap_to_best per method (one dot per instance)."""
    import matplotlib.pyplot as plt

    df = _with_columns(df)
    rows = df[df["role"] != "bound"]
    methods = list(dict.fromkeys(rows["method"]))
    fig, axes = plt.subplots(1, 2, figsize=(max(6.0, 1.3 * len(methods) + 3), 3.8), squeeze=False)
    for ax, col in zip(axes[0], ("gap_to_bound", "gap_to_best"), strict=False):
        data = [rows.loc[rows["method"] == m, col].dropna().to_numpy() for m in methods]
        keep = [(m, d) for m, d in zip(methods, data, strict=False) if len(d)]
        if keep:
            ax.boxplot([d for _, d in keep], showfliers=False)
            for k, (_, d) in enumerate(keep, start=1):
                ax.plot(np.full(len(d), k) + np.linspace(-0.15, 0.15, len(d)), d, ".", ms=3, alpha=0.6)
            ax.set_xticks(range(1, len(keep) + 1), [m for m, _ in keep], rotation=30, ha="right", fontsize=8)
        else:
            ax.text(0.5, 0.5, "no values", ha="center", transform=ax.transAxes)
        kinds = ",".join(sorted(set(rows["gap_bound_kind"].dropna()))) if col == "gap_to_bound" else ""
        ax.set_title(col + (f" ({kinds})" if kinds else ""), fontsize=9)
        ax.grid(alpha=0.3)
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


# --------------------------------------------------------------------------- timing
def load_average() -> float:
    """The 1-minute load average of the machine (NaN where the platform has none)."""
    from droneplan.core.validation import machine_load

    load = machine_load()
    return math.nan if load is None else load


@dataclass
class Measured:
    """What a bench row records about the work it timed (filled in by :func:`measured`)."""

    wall_s: float = math.nan
    """Wall time, s."""
    cpu_s: float = math.nan
    """CPU time of this process, s (the figure other processes on a shared machine disturb least)."""
    load: float = math.nan
    """1-minute load average when the work started."""

    @property
    def note(self) -> str:
        """``"1.23 s wall, 1.20 CPU-s, load average 0.6 on 2 cores"``: the text a bench row shows."""
        load = f"load average {self.load:.1f} on {os.cpu_count()} cores"
        return f"{self.wall_s:.2f} s wall, {self.cpu_s:.2f} CPU-s, {load}"


@contextlib.contextmanager
def measured() -> Iterator[Measured]:
    """Time the ``with`` block: wall time, this process's CPU time and the load average at its start.

    ``with measured() as m: work()`` then ``m.wall_s``, ``m.cpu_s``, ``m.load``, ``m.note``. Ratios
    of two methods run in one process are to be taken from ``cpu_s``.
    """
    m = Measured(load=load_average())
    c0, w0 = time.process_time(), time.perf_counter()
    try:
        yield m
    finally:
        m.wall_s, m.cpu_s = time.perf_counter() - w0, time.process_time() - c0


def timed(fn: Callable[..., Any], *args, repeat: int = 1, **kwargs) -> tuple[Any, Measured]:
    """Call ``fn(*args, **kwargs)`` ``repeat`` times; return the last result and a :class:`Measured`
    holding the median wall time and the median CPU time of one call (s) and the load average at
    the start."""
    if repeat < 1:
        raise ValueError(f"repeat must be >= 1, got {repeat}")
    walls, cpus = [], []
    result = None
    load = load_average()
    for _ in range(repeat):
        with measured() as one:
            result = fn(*args, **kwargs)
        walls.append(one.wall_s)
        cpus.append(one.cpu_s)
    return result, Measured(wall_s=float(np.median(walls)), cpu_s=float(np.median(cpus)), load=load)
