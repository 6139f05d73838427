"""Machinery shared by the per-problem studies: executors, resumable CSV rows,
"thesis value | this run | how measured" tables, and timing helpers for bench.
"""

from __future__ import annotations

import concurrent.futures as cf
import contextlib
import csv
import os
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Iterable, Iterator, Mapping, Sequence

import pandas as pd
from tqdm.auto import tqdm


# --------------------------------------------------------------------------- executors
class _SerialExecutor(cf.Executor):
    """Runs each task at submit time in this process (workers=1, easy to debug)."""

    def submit(self, fn, /, *args, **kwargs):  # noqa: D102 - Executor API
        future: cf.Future = cf.Future()
        try:
            future.set_result(fn(*args, **kwargs))
        except BaseException as exc:  # the caller sees it through future.result()
            future.set_exception(exc)
        return future


@contextlib.contextmanager
def make_executor(workers: int | None = None, dask_address: str | None = None) -> Iterator[cf.Executor]:
    """A ``concurrent.futures``-style executor for mapping over instances.

    workers: local worker processes (None: number of cores; 1: run serially in
        this process). Ignored when ``dask_address`` is given.
    dask_address: address of a running Dask scheduler (``tcp://host:8786``); needs
        the ``distributed`` extra.
    """
    if workers is not None and workers < 1:
        raise ValueError(f"workers must be >= 1, got {workers}")
    if dask_address:
        try:
            from distributed import Client
        except ImportError as exc:  # pragma: no cover - depends on the extra
            raise RuntimeError("--dask needs the optional extra: pip install 'droneplan[distributed]'") from exc
        client = Client(dask_address)
        try:
            yield client.get_executor()
        finally:
            client.close()
        return
    n = workers if workers is not None else (os.cpu_count() or 1)
    if n == 1:
        yield _SerialExecutor()
        return
    with cf.ProcessPoolExecutor(max_workers=n) as pool:
        yield pool


# --------------------------------------------------------------------------- resumable rows
class ResumableCSV:
    """A CSV file that rows are appended to as they finish, keyed for resuming.

    path: the CSV file (created with a header on the first append).
    key: the columns that identify a row; rows whose key is already in the file
        are reported by :meth:`done_keys` so a rerun can skip them.
    """

    def __init__(self, path: str | os.PathLike, key: Sequence[str]):
        self.path = Path(path)
        self.key = tuple(key)
        if not self.key:
            raise ValueError("key must name at least one column")

    def rows(self) -> pd.DataFrame:
        """All rows written so far (an empty frame when the file does not exist)."""
        if not self.path.exists() or self.path.stat().st_size == 0:
            return pd.DataFrame()
        return pd.read_csv(self.path)

    def done_keys(self) -> set[tuple[str, ...]]:
        """Keys of the rows already on disk, as tuples of strings."""
        df = self.rows()
        if df.empty:
            return set()
        missing = [k for k in self.key if k not in df.columns]
        if missing:
            raise ValueError(f"{self.path} lacks key columns {missing}; delete it or choose another --out")
        return {tuple(str(v) for v in r) for r in df[list(self.key)].itertuples(index=False)}

    def key_of(self, row: Mapping[str, Any]) -> tuple[str, ...]:
        return tuple(str(row[k]) for k in self.key)

    def append(self, row: Mapping[str, Any]) -> None:
        """Append one row (flushes to disk). The first row fixes the header."""
        self.path.parent.mkdir(parents=True, exist_ok=True)
        new = not self.path.exists() or self.path.stat().st_size == 0
        if new:
            header = list(row)
        else:
            with self.path.open(newline="") as fh:
                header = next(csv.reader(fh))
            extra = [k for k in row if k not in header]
            if extra:
                raise ValueError(f"row has columns {extra} not in the header of {self.path}")
        with self.path.open("a", newline="") as fh:
            writer = csv.DictWriter(fh, fieldnames=header)
            if new:
                writer.writeheader()
            writer.writerow({k: row.get(k, "") for k in header})
            fh.flush()


def map_rows(
    fn: Callable[[Mapping[str, Any]], Mapping[str, Any] | list[Mapping[str, Any]]],
    tasks: Iterable[Mapping[str, Any]],
    *,
    executor: cf.Executor,
    store: ResumableCSV,
    desc: str = "",
) -> pd.DataFrame:
    """Run ``fn(task)`` for every task whose key is not yet in ``store``.

    Each task is a dict holding at least the key columns of ``store``; ``fn`` must be
    picklable (a module-level function) and return a row dict (or a list of rows)
    that repeats the key columns. Rows are appended as they finish, with a progress
    bar; the function returns every row in the file (old and new).
    """
    done = store.done_keys()
    todo = [t for t in tasks if store.key_of(t) not in done]
    futures = [executor.submit(fn, t) for t in todo]
    with tqdm(total=len(futures), desc=desc, disable=not futures) as bar:
        for fut in cf.as_completed(futures):
            out = fut.result()
            for row in out if isinstance(out, list) else [out]:
                store.append(row)
            bar.update(1)
    return store.rows()


# --------------------------------------------------------------------------- comparison tables
@dataclass
class ComparisonTable:
    """A table "quantity | thesis value | this run | how measured" for one figure or table."""

    title: str
    rows: list[dict[str, str]] = field(default_factory=list)

    def add(self, quantity: str, thesis: Any, ours: Any, how: str) -> None:
        self.rows.append(
            {"quantity": quantity, "thesis": _fmt(thesis), "this run": _fmt(ours), "how measured": how}
        )

    def frame(self) -> pd.DataFrame:
        return pd.DataFrame(self.rows, columns=["quantity", "thesis", "this run", "how measured"])

    def render(self) -> str:
        df = self.frame()
        if df.empty:
            return f"== {self.title} ==\n(no rows)"
        widths = {c: max(len(c), *(len(str(v)) for v in df[c])) for c in df.columns}
        line = " | ".join(c.ljust(widths[c]) for c in df.columns)
        sep = "-+-".join("-" * widths[c] for c in df.columns)
        body = [" | ".join(str(r[c]).ljust(widths[c]) for c in df.columns) for r in df.to_dict("records")]
        return "\n".join([f"== {self.title} ==", line, sep, *body])

    def emit(self, out: Path, stem: str) -> None:
        """Print the table and write it to ``out/stem.csv``."""
        out.mkdir(parents=True, exist_ok=True)
        print(self.render(), flush=True)
        print(flush=True)
        self.frame().to_csv(out / f"{stem}.csv", index=False)


def _fmt(value: Any) -> str:
    if value is None:
        return "—"
    if isinstance(value, float):
        return f"{value:.4g}"
    return str(value)


# --------------------------------------------------------------------------- timing
def timed(fn: Callable[..., Any], *args, repeat: int = 1, **kwargs) -> tuple[Any, float]:
    """Call ``fn`` ``repeat`` times; return the last result and the median wall time (s)."""
    if repeat < 1:
        raise ValueError(f"repeat must be >= 1, got {repeat}")
    times = []
    result = None
    for _ in range(repeat):
        t0 = time.perf_counter()
        result = fn(*args, **kwargs)
        times.append(time.perf_counter() - t0)
    times.sort()
    return result, times[len(times) // 2]
