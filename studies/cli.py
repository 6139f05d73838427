"""The ``droneplan`` command line: ``reproduce``, ``gap`` and ``bench``.

A problem is available when its study module ``droneplan.studies.thesis.<problem>`` exists; such
a module follows :class:`~droneplan.studies.thesis.problem_studies.ProblemStudies`:
``reproduce_jobs(*, quick, out, store_path)`` (``droneplan reproduce`` runs the jobs of every
problem asked for together, see :func:`run_reproduce`), ``gap(*, seeds, executor, out, store,
first_seed)`` and ``bench(*, quick, out)``. This module only parses and dispatches; the gap study
of a problem is :func:`~droneplan.studies.thesis.problem_studies.run_gap`.

Every study writes its rows to one store, ``<--out>/results.sqlite`` (schema and store:
:mod:`droneplan.studies.store`), exported to ``<--out>/results.csv`` after each problem;
``droneplan.load_results(out)`` reads it back. Exit codes: 0 done, 1 some task ended in an
error row (rerun to retry it), 2 bad input (unwritable ``--out``, unreachable ``--dask``,
a store of another schema), 130 interrupted by Ctrl-C, 143 stopped by SIGTERM and 129 by SIGHUP
(each handled as Ctrl-C is: jobs killed, finished rows kept; rerun to resume).
"""

from __future__ import annotations

import argparse
import contextlib
import os
import signal
import sys
import tempfile
import threading
import time
from pathlib import Path
from typing import TYPE_CHECKING, Any

from droneplan.core.files import JsonFileError
from droneplan.core.validation import check_positive
from droneplan.studies import common
from droneplan.studies.common import StudyError, make_executor, render_frame
from droneplan.studies.library import LibraryFileError
from droneplan.studies.problems import PROBLEMS
from droneplan.studies.store import STORE_NAME, ResultStore, StoreError
from droneplan.studies.thesis.problem_studies import CHAPTER as _CHAPTER
from droneplan.studies.thesis.problem_studies import (
    ProblemStudies,
    available_problems,
    resolve_problems,
    run_gap,
)
from droneplan.studies.thesis.problem_studies import problem_studies as _load
from droneplan.studies.thesis.problem_studies import writable_out as _writable_out

if TYPE_CHECKING:
    import pandas as pd

    from droneplan.studies.thesis import cells, covert, herding, shark

    # mypy checks that the four study modules follow the one protocol
    _STUDY_MODULES: tuple[ProblemStudies, ...] = (covert, cells, shark, herding)

__all__ = ["PROBLEMS", "available_problems", "run_gap", "run_reproduce", "main"]


def _resolve(problem: str) -> list[str]:
    try:
        return resolve_problems(problem)
    except ValueError as exc:
        raise SystemExit(f"droneplan: {exc}") from None


def _certify_arguments(cert: argparse.ArgumentParser) -> None:
    """The options of ``droneplan certify``."""
    cert.add_argument("family", help="a family with a library: " + ", ".join(_library_families()))
    cert.add_argument("--m", default=None, help="cells: number(s) of drone-cells (default: the library's)")
    cert.add_argument("--n", default=None, help="allocation: number(s) of drones (default: the library's)")
    cert.add_argument("--seeds", type=int, default=None, help="number of seeds (default: the library's)")
    cert.add_argument("--first-seed", type=int, default=0, help="first seed (default 0)")
    cert.add_argument(
        "--time-limit", type=float, default=300.0, metavar="S", help="per instance (default 300 s)"
    )
    where = cert.add_mutually_exclusive_group()
    where.add_argument("--workers", type=int, default=None, help="instances at once (default: cores)")
    where.add_argument(
        "--dask",
        metavar="ADDRESS",
        default=None,
        help="address of a running Dask scheduler to certify on, e.g. tcp://10.0.0.1:8786 (the library "
        "file is written here)",
    )
    cert.add_argument("--force", action="store_true", help="recertify every entry")
    cert.add_argument("--improve", action="store_true", help="recertify the entries not proven optimal")
    cert.add_argument(
        "--verify", action="store_true", help="re-prove the stored entries and report any that do not hold"
    )
    cert.add_argument(
        "--ids",
        nargs="+",
        default=None,
        metavar="ID",
        help="with --verify: re-prove only these entries (ids as 'droneplan list' shows them)",
    )
    cert.add_argument(
        "--sample", type=int, default=None, metavar="N", help="with --verify: re-prove N entries at random"
    )
    cert.add_argument(
        "--sample-seed", type=int, default=None, metavar="S", help="with --sample: the draw's seed"
    )
    cert.add_argument(
        "--library-dir", type=Path, default=None, help="where the library files are (default: the package's)"
    )


def _parser() -> argparse.ArgumentParser:
    avail = available_problems()
    status = ", ".join(f"{p} (ch. {_CHAPTER[p]})" for p in avail) or "none yet"
    missing = [p for p in PROBLEMS if p not in avail]
    epilog = f"available problems: {status}."
    if missing:
        epilog += f" Not implemented yet: {', '.join(missing)}."
    parser = argparse.ArgumentParser(
        prog="droneplan",
        description="Drone planning problems as optimisation models versus the thesis heuristics.",
        epilog=epilog,
    )
    sub = parser.add_subparsers(dest="command", required=True)
    choices = [*PROBLEMS, "all"]

    rep = sub.add_parser(
        "reproduce", help="reproduce the thesis tables and figures (thesis | this run | how)", epilog=epilog
    )
    rep.add_argument("problem", nargs="?", default="all", choices=choices)
    rep.add_argument(
        "--quick", action="store_true", help="reduced sizes/seeds; finishes in minutes on 2 cores"
    )
    rep.add_argument(
        "--out", type=Path, default=Path("results"), help="directory for CSV and PNG (default: results)"
    )
    rep.add_argument(
        "--report", action="store_true", help="also write OUT/report.html (tables beside the thesis, figures)"
    )
    _executor_options(rep)

    gap = sub.add_parser(
        "gap", help="heuristic vs solver optimum per instance (resumable store)", epilog=epilog
    )
    gap.add_argument("problem", nargs="?", default="all", choices=choices)
    gap.add_argument("--seeds", type=int, default=10, help="number of random instances (default 10)")
    gap.add_argument(
        "--first-seed",
        type=int,
        default=0,
        help="seed of the first instance (default 0): seeds first-seed .. first-seed + seeds - 1",
    )
    _executor_options(gap)
    gap.add_argument(
        "--method",
        dest="methods",
        action="append",
        metavar="NAME|MODULE:FUNCTION",
        help="run an open study of these methods (repeat the option): a registered name (droneplan "
        "list) or the user's function or controller class as module:attribute",
    )
    gap.add_argument(
        "--instances",
        metavar="FAMILY|PATH",
        default=None,
        help="open study instances: a family name (droneplan list) or an instance file or directory",
    )
    gap.add_argument("--m", default=None, help="cells families: number(s) of drone-cells, e.g. 4 or 3,4")
    gap.add_argument("--n", default=None, help="allocation family: number(s) of drones, e.g. 8 or 8,16")
    gap.add_argument(
        "--size",
        action="append",
        default=[],
        metavar="KEY=VALUES",
        help="another size parameter of the family, e.g. path=a,b or n_targets=3 (repeatable)",
    )
    gap.add_argument(
        "--time-limit",
        type=float,
        default=None,
        metavar="S",
        help="open study: wall-time limit per method and instance in seconds (default 300); a method "
        "still running is stopped and recorded as timeout",
    )
    gap.add_argument(
        "--memory-limit",
        type=float,
        default=None,
        metavar="GIB",
        help="open study: address space each job may use beyond the study's own, in GiB (default 8); "
        "an allocation past it fails in the method (an error row)",
    )
    gap.add_argument(
        "--runs",
        default=None,
        metavar="R",
        help="open study: runs per instance and method, each with its own seed (default 1, at most "
        "1000); a deterministic method runs once",
    )
    gap.add_argument(
        "--cpu-limit",
        default=None,
        metavar="S",
        help="open study: CPU seconds per method and instance (a budget that does not shrink with "
        "the machine's load; a method past it is stopped and recorded as timeout)",
    )
    gap.add_argument(
        "--max-evaluations",
        default=None,
        metavar="N",
        help="open study: an evaluation budget per method and instance, for the methods that take "
        "one (the GA: fitness evaluations; exhaustive search: last-cell searches)",
    )
    gap.add_argument(
        "--reference",
        choices=("auto", "none"),
        default=None,
        help="open study: 'auto' (default) solves the reference of every instance the certified "
        "library lacks by its kind's exact engine (kept under --out/library, a row 'reference'); "
        "'none' solves none and says how many instances have no proven reference",
    )
    gap.add_argument(
        "--reference-time-limit",
        type=float,
        default=None,
        metavar="S",
        help="open study: wall seconds per reference solve (default 300)",
    )
    gap.add_argument(
        "--warm-starts",
        action="store_true",
        help="cells or herding: run each exact engine that takes a start cold and warm-started from each "
        "heuristic (ENGINE<HEURISTIC; --method picks engines and heuristics), to proof (--time-limit, "
        "default 120) and at a 5 s limit, and write the paired table OUT/PROBLEM/warm_starts.csv/.md",
    )
    gap.add_argument(
        "--out",
        type=Path,
        default=Path("results"),
        help="directory for the store results.sqlite, results.csv and per-problem summaries/figures "
        "(default: results)",
    )

    _certify_arguments(
        sub.add_parser(
            "certify",
            help="certify a family's instances (best plan, proven bound) into the reference library",
        )
    )

    from droneplan.studies.library import cross

    cross.add_arguments(sub.add_parser("cross-certify", help=cross.HELP))

    sub.add_parser("list", help="instance families (with their library entries) and registered methods")

    bench = sub.add_parser("bench", help="performance ratios measured in one run", epilog=epilog)
    bench.add_argument("problem", nargs="?", default="all", choices=choices)
    bench.add_argument("--quick", action="store_true", help="smaller instances")
    bench.add_argument(
        "--out", type=Path, default=Path("results"), help="directory for the CSV (default: results)"
    )
    bench.add_argument(
        "--reproduce-times",
        type=Path,
        default=None,
        metavar="PATH",
        help="summary: read the reproduce --quick row from this run's reproduce_times.csv (or its "
        "folder) instead of running it",
    )
    bench.add_argument(
        "--summary-only", action="store_true", help="with 'all': only the summary table of the speed goals"
    )
    bench.add_argument(
        "--variants",
        action="store_true",
        help="cells: the model's variants instead of the scale grid (time to proof, fleet size, moving "
        "users; Table 4.2 m = 4 seeds 0-9, or m = 2 seed 0 with --quick)",
    )
    bench.add_argument(
        "--time-limit",
        type=float,
        default=None,
        metavar="S",
        help="cells: seconds per row of the scale grid (default 600, 60 with --quick)",
    )
    return parser


def _executor_options(parser: argparse.ArgumentParser) -> None:
    grp = parser.add_mutually_exclusive_group()
    grp.add_argument(
        "--workers",
        type=int,
        default=None,
        help="local worker processes (default: cores; 1 = serial in this process)",
    )
    grp.add_argument(
        "--dask",
        metavar="ADDRESS",
        default=None,
        help="address of a running Dask scheduler, e.g. tcp://10.0.0.1:8786",
    )


def _library_families() -> list[str]:
    from droneplan.studies.library import LIBRARY_FAMILIES

    return list(LIBRARY_FAMILIES)


def _sizes(args) -> dict:
    """The family size options (--m, --n, --size KEY=VALUES) as keyword arguments."""
    out: dict = {}
    pairs = [("m", args.m), ("n", args.n)]
    for item in getattr(args, "size", []) or []:
        key, sep, value = item.partition("=")
        if not sep or not key or not value:
            raise SystemExit(f"droneplan: --size takes KEY=VALUES, got {item!r}")
        pairs.append((key.strip(), value))
    for key, value in pairs:
        if value is None:
            continue
        values: list[int | str] = []
        for text in str(value).split(","):
            text = text.strip()
            try:
                values.append(int(text))
            except ValueError:
                values.append(text)
        out[key] = values if len(values) > 1 else values[0]
    return out


def _run_list() -> int:
    from droneplan.studies.instances import FAMILIES, KINDS
    from droneplan.studies.library import load_library
    from droneplan.studies.methods import builtin_methods

    print("instance families (name@version: problem, kind, size parameters; library entries):")
    for fam in FAMILIES.values():
        n_lib = len(load_library(fam.name))
        grid = ", ".join(f"{k} in {list(fam.defaults.get(k, ()))}" for k in fam.grid) or "-"
        print(f"  {fam.name}@{fam.version}: {fam.problem}, {fam.kind}; {grid}; {n_lib} certified")
        print(f"      {fam.describe}")
    print("registered methods by instance kind:")
    for kind in KINDS:
        print(f"  {kind}: {', '.join(builtin_methods(kind))}")
    return 0


def _run_verify(args) -> int:
    from droneplan.studies.library.certify import option_message, verify

    try:
        summary = verify(
            args.family,
            time_limit=args.time_limit,
            workers=args.workers,
            directory=args.library_dir,
            ids=args.ids,
            sample=args.sample,
            seed=args.sample_seed,
            dask=args.dask,
        )
    except (ValueError, StudyError) as exc:
        raise StudyError(option_message(exc)) from None
    print(
        f"verify {summary['family']}: {summary['checked']} entries re-proven (sample seed "
        f"{summary['seed']}), {len(summary['failed'])} do not hold",
        flush=True,
    )
    for line in summary["failed"]:
        print(f"  {line}", file=sys.stderr)
    return 1 if summary["failed"] else 0


def _usable_library_dir(directory: Path | None) -> None:
    """Refuse, before any work, a ``--library-dir`` that cannot hold library files."""
    if directory is None:
        return
    try:
        directory.mkdir(parents=True, exist_ok=True)
        tempfile.TemporaryFile(dir=directory, prefix=".droneplan-check-").close()  # can a file be made?
    except OSError as exc:
        raise StudyError(
            f"--library-dir {directory} is not a writable directory ({exc.strerror or exc})"
        ) from None


def _run_certify(args) -> int:
    from droneplan.studies.library.certify import certify, option_message

    if args.verify:
        return _run_verify(args)
    _usable_library_dir(args.library_dir)

    size = _sizes(args)
    if args.seeds is not None:
        size["seeds"] = args.seeds
    if args.first_seed:
        size["first_seed"] = args.first_seed
    try:
        summary = certify(  # a bad size (--n abc) is a TypeError naming it
            args.family,
            time_limit=args.time_limit,
            workers=args.workers,
            directory=args.library_dir,
            force=args.force,
            improve=args.improve,
            dask=args.dask,
            **size,
        )
    except (ValueError, TypeError, StudyError) as exc:
        raise StudyError(option_message(exc)) from None
    print(
        f"certify {summary['family']}: {summary['certified']} certified now, {summary['entries']} entries "
        f"({summary['proven']} proven optimal) in {summary['path'] or 'the library (unchanged)'}",
        flush=True,
    )
    for line in summary["failed"]:
        print(f"  failed: {line}", file=sys.stderr)
    return 1 if summary["failed"] else 0


def _gib(value: float | None) -> int | None:
    """``--memory-limit`` in bytes (None: the study's default)."""
    if value is None:
        return None
    if not value > 0:
        raise SystemExit(f"droneplan: --memory-limit must be > 0 GiB, got {value}")
    return int(value * (1 << 30))


def _runs(value: str | None) -> int:
    """``--runs`` as a number of runs (1 when not given); a one-line SystemExit when it is not one."""
    from droneplan.studies.study import MAX_RUNS, check_runs

    if value is None:
        return 1
    try:
        return check_runs(int(value))
    except ValueError:
        shown = value if len(value) <= 40 and value.isprintable() else "that"
        raise SystemExit(f"droneplan: --runs must be an int from 1 to {MAX_RUNS}, got {shown}") from None


def _write_anytime_outputs(df, out: Path, folder: Path) -> dict[str, Path]:
    """The anytime figures and table of a study whose methods reported incumbents (none else)."""
    from droneplan.studies.trace_store import load_traces

    traces = load_traces(out)
    traces = traces[traces["instance"].isin(set(df["instance"])) & traces["method"].isin(set(df["method"]))]
    if traces.empty:
        return {}
    import matplotlib.pyplot as plt

    from droneplan.studies.plots.anytime import plot_anytime, plot_anytime_ecdf
    from droneplan.studies.traces import anytime_summary

    folder.mkdir(parents=True, exist_ok=True)
    paths = {"anytime_table": folder / "gap_anytime.csv"}
    anytime_summary(df, traces).to_csv(paths["anytime_table"], index=False)
    for name, plot in (("anytime", plot_anytime), ("anytime_ecdf", plot_anytime_ecdf)):
        fig = plot(df, traces)
        paths[name] = folder / f"gap_{name}.png"
        fig.savefig(paths[name], dpi=120, bbox_inches="tight")
        plt.close(fig)
    return paths


def _refuse_open_study_flags(args) -> None:
    """A one-line SystemExit for a flag of an open study given to a built-in one."""
    for flag, given in (
        ("--runs", args.runs),
        ("--cpu-limit", args.cpu_limit),
        ("--max-evaluations", args.max_evaluations),
        ("--reference", args.reference),
        ("--reference-time-limit", args.reference_time_limit),
    ):
        if given is not None:
            raise SystemExit(f"droneplan: {flag} goes with an open study (--method or --instances)")


def _budgets(args) -> tuple[float | None, int | None]:
    """``--cpu-limit`` and ``--max-evaluations`` as numbers; a one-line SystemExit naming the flag."""
    from droneplan.studies.study import check_budgets

    parsed: list[float | int | None] = []
    for flag, raw, kind in (
        ("--cpu-limit", args.cpu_limit, float),
        ("--max-evaluations", args.max_evaluations, int),
    ):
        try:
            parsed.append(None if raw is None else kind(raw))
        except ValueError:
            raise SystemExit(f"droneplan: {flag} must be a number, got {raw[:40]}") from None
    try:
        return check_budgets(*parsed)
    except ValueError as exc:
        flag = "--cpu-limit" if str(exc).startswith("cpu_limit") else "--max-evaluations"
        raise SystemExit(f"droneplan: {flag}: {exc}") from None


def _run_open_gap(args) -> int:
    from droneplan.studies.analysis import summary_markdown
    from droneplan.studies.plots.profiles import write_study_outputs
    from droneplan.studies.study import gap as open_gap

    runs = _runs(args.runs)
    cpu_limit, max_evaluations = _budgets(args)
    if args.problem == "all":
        raise SystemExit("droneplan: --method/--instances need one problem (cells, herding, shark or covert)")
    if not args.methods:
        _default_methods(args.problem)
    size = _sizes(args)
    if args.instances is None or args.instances in _families():
        size.update(seeds=args.seeds, first_seed=args.first_seed)
    try:
        df = open_gap(
            args.problem,
            methods=args.methods or None,  # None: the kind's registered defaults
            instances=args.instances,
            out=args.out,
            workers=args.workers,
            dask=args.dask,
            time_limit=args.time_limit,
            memory_limit=_gib(args.memory_limit),
            runs=runs,
            cpu_limit=cpu_limit,
            max_evaluations=max_evaluations,
            reference=args.reference or "auto",
            reference_time_limit=args.reference_time_limit,
            **size,
        )
    except (ValueError, TypeError, FileNotFoundError) as exc:
        raise StudyError(str(exc).splitlines()[0]) from None
    paths = write_study_outputs(df, args.out / args.problem, stem="gap")
    paths.update(_write_anytime_outputs(df, args.out, args.out / args.problem))
    print(summary_markdown(df), flush=True)
    print(
        f"rows: {args.out / STORE_NAME} (results.csv, results.parquet); summary and figures: "
        f"{', '.join(str(p) for p in paths.values())}",
        flush=True,
    )
    errors = df[df["status"] == "error"]
    if len(errors):
        first = errors.iloc[0]
        print(
            f"droneplan: {len(errors)} job(s) ended in an error row (first: {first['method']} on "
            f"{first['instance']}: {first['message']}); rerun the same command to retry them",
            file=sys.stderr,
        )
        return 1
    return 0


def _run_warm_starts(args) -> int:
    """``droneplan gap cells|herding --warm-starts``: the paired table of warm starts
    (:func:`~droneplan.studies.warm_starts.warm_start_study`)."""
    from droneplan.studies.warm_starts import warm_start_markdown, warm_start_study

    if args.problem not in ("cells", "herding"):
        raise SystemExit("droneplan: --warm-starts goes with 'gap cells' or 'gap herding'")
    runs = _runs(args.runs)
    cpu_limit, max_evaluations = _budgets(args)
    size = _sizes(args)
    if args.instances is None or args.instances in _families():
        size.update(seeds=args.seeds, first_seed=args.first_seed)
    try:
        given = {name: getattr(args, name) for name in ("instances", "workers", "dask", "time_limit")}
        budgets: dict[str, Any] = {
            "runs": runs,
            "cpu_limit": cpu_limit,
            "max_evaluations": max_evaluations,
            "reference": args.reference or "auto",
            "reference_time_limit": args.reference_time_limit,
        }
        _, table = warm_start_study(
            args.problem,
            out=args.out,
            methods=args.methods or None,
            memory_limit=_gib(args.memory_limit),
            **given,
            **budgets,
            **size,
        )
    except (ValueError, TypeError, FileNotFoundError) as exc:
        raise StudyError(str(exc).splitlines()[0]) from None
    print(warm_start_markdown(table), flush=True)
    print(f"paired table: {args.out / args.problem / 'warm_starts.csv'} (and warm_starts.md)", flush=True)
    return 0


def _families() -> set[str]:
    from droneplan.studies.instances import FAMILIES

    return set(FAMILIES)


def _default_methods(problem: str) -> None:
    """Covert and shark studies run their kind's registered defaults without ``--method``; the
    others exit naming the option."""
    if problem not in ("covert", "shark"):
        raise SystemExit(
            "droneplan: name the methods with --method (droneplan list shows the registered ones)"
        )


def _report_times(jobs, timings, wall: float, own: float, executor, out: Path) -> pd.DataFrame:
    """Print and write (``reproduce_times.csv``, ``reproduce_job_times.csv``: the names
    :data:`~droneplan.studies.jobs.TIMES_NAME`, ``JOB_TIMES_NAME``) where the time went."""
    import dataclasses

    import pandas as pd

    from droneplan.studies.jobs import JOB_TIMES_NAME, TIMES_NAME, idle_estimate, time_table

    table = time_table(timings)
    if not timings:
        return table
    slots = max(2, executor.slots)
    path, idle = idle_estimate(jobs, timings, slots)
    print("\n== time per section (CPU s where the jobs ran; span = first start to last end, s) ==")
    print(render_frame(table.round(1)))
    print(
        f"wall {wall:.1f} s; jobs' CPU {table['cpu_s'].iloc[-1]:.1f} s + this process {own:.1f} s; "
        f"longest chain {path:.1f} CPU s; estimated wall on {slots} idle cores {idle:.1f} s",
        flush=True,
    )
    table.to_csv(out / TIMES_NAME, index=False)
    per_job = pd.DataFrame([dataclasses.asdict(t) for t in timings])
    per_job.to_csv(out / JOB_TIMES_NAME, index=False)
    return table


def run_reproduce(
    problems: list[str], *, quick: bool, out: Path, executor, store: ResultStore
) -> pd.DataFrame:
    """Reproduce ``problems`` together: every problem's jobs (``reproduce_jobs``) on one
    executor, the longest chains first, so the cores stay busy across problems; then print the
    per-section time table (CPU and wall seconds). quick: reduced sizes; out: the directory
    (one subdirectory per problem); executor: from ``make_executor``; store: the open results
    store. Returns the time table (:func:`droneplan.studies.jobs.time_table`)."""
    from droneplan.studies.jobs import JobsFailed, run_jobs

    jobs = []
    for problem in problems:
        sub = out / problem
        sub.mkdir(parents=True, exist_ok=True)
        jobs += _load(problem).reproduce_jobs(quick=quick, out=sub, store_path=store.path)
    print(
        f"### reproduce {', '.join(problems)}: {len(jobs)} jobs on {executor.slots} {executor.kind} slot(s) "
        f"-> {out}",
        flush=True,
    )
    w0, c0 = time.perf_counter(), time.process_time()
    failure = None
    try:
        timings = run_jobs(jobs, executor=executor, store=store)
    except JobsFailed as exc:  # the table of what ran, then the error
        timings, failure = exc.timings, exc
    table = _report_times(jobs, timings, time.perf_counter() - w0, time.process_time() - c0, executor, out)
    if failure is not None:
        raise failure
    return table


def _run_studies(args, problems: list[str], executor, store: ResultStore) -> None:
    """``reproduce`` (every problem's jobs together) or ``gap`` (problem by problem) into ``store``."""
    if args.command == "reproduce":
        try:
            run_reproduce(problems, quick=args.quick, out=args.out, executor=executor, store=store)
        finally:
            store.export(args.out / "results.csv")
            store.export(args.out / "results.parquet")
        return
    for problem in problems:
        out = args.out / problem
        out.mkdir(parents=True, exist_ok=True)
        print(f"### {args.command} {problem} (thesis ch. {_CHAPTER[problem]}) -> {out}", flush=True)
        try:
            _load(problem).gap(
                seeds=args.seeds, executor=executor, out=out, store=store, first_seed=args.first_seed
            )
        finally:
            store.export(args.out / "results.csv")
            store.export(args.out / "results.parquet")


def _run(args) -> int:
    if args.command == "list":
        return _run_list()
    if args.command == "certify":
        return _run_certify(args)
    if args.command == "cross-certify":
        from droneplan.studies.library.cross import run as run_cross_certify

        try:
            return run_cross_certify(args)
        except ValueError as exc:
            raise StudyError(str(exc)) from None
    if args.command == "gap" and (args.warm_starts or args.methods or args.instances):
        _writable_out(args.out)
        return _run_warm_starts(args) if args.warm_starts else _run_open_gap(args)
    if args.command == "gap":
        _refuse_open_study_flags(args)
    problems = _resolve(args.problem)
    workers = _checked_counts(args)
    _writable_out(args.out)
    if args.command == "bench":
        return _run_bench(args, problems)
    with contextlib.ExitStack() as stack:
        store = stack.enter_context(ResultStore(args.out / STORE_NAME))
        executor = stack.enter_context(make_executor(workers, args.dask))
        _run_studies(args, problems, executor, store)
        errors = store.frame()
        errors = errors[errors["status"] == "error"]
    if args.command == "reproduce" and args.report:
        # written even when some tasks errored: the report shows what finished, and the error
        # rows' tables say so; the exit code below still reports the errors
        from droneplan.studies.thesis.report import write_report

        print(f"report: {write_report(args.out, problems=problems)}", flush=True)
    if len(errors):
        first = errors.iloc[0]
        print(
            f"droneplan: {len(errors)} task(s) ended in an error row (first: {first['problem']} "
            f"{first['instance']}: {first['message']}); rerun the same command to retry them",
            file=sys.stderr,
        )
        return 1
    return 0


def _checked_counts(args) -> int | None:
    """``--workers`` (None: one per core) after checking it and gap's ``--seeds``/``--first-seed``;
    a bad value exits with a message naming the option."""
    if args.command == "gap" and args.seeds < 1:
        raise SystemExit(f"droneplan: --seeds must be >= 1, got {args.seeds}")
    if args.command == "gap" and args.first_seed < 0:
        raise SystemExit(f"droneplan: --first-seed must be >= 0, got {args.first_seed}")
    workers = getattr(args, "workers", None)
    most = common.WORKERS_PER_CORE * (os.cpu_count() or 1)
    if workers is not None and not 1 <= workers <= most:
        raise SystemExit(
            f"droneplan: --workers must be in [1, {most}] ({common.WORKERS_PER_CORE} per core), got {workers}"
        )
    return workers


def _run_bench_variants(args, problems: list[str]) -> int:
    """``droneplan bench cells --variants``: the variant rows of ``studies.cells_variants``."""
    if problems != ["cells"]:
        raise SystemExit("droneplan: --variants goes with 'bench cells'")
    from droneplan.studies.cells_variants import bench_variants, variants_summary

    limit = args.time_limit if args.time_limit is not None else (60.0 if args.quick else 600.0)
    seeds, m = ([0], 2) if args.quick else (list(range(10)), 4)
    out = args.out / "cells"
    try:
        rows = bench_variants(seeds=seeds, m=m, time_limit=check_positive("--time-limit", limit), out=out)
    except ValueError as exc:
        raise SystemExit(f"droneplan: {exc}") from None
    for row in rows:
        print(
            f"{row['variant']:>16} seed {row['seed']}: {row['status']:>10} "
            f"{row['objective']} / {row['bound']}  {row['cpu_s']:.1f} CPU-s, "
            f"{row['wall_s']:.1f} s wall, load {row['load_1min']:.2f}"
        )
    print(variants_summary(rows))
    print(f"rows in {out / 'bench_variants.csv'}")
    return 0


def _run_bench(args, problems: list[str]) -> int:
    """``droneplan bench``: each problem's benchmark, then (for "all") the summary table."""
    if args.time_limit is not None and "cells" not in problems:
        raise SystemExit("droneplan: --time-limit applies to 'bench cells' (its scale grid)")
    if args.summary_only and args.problem != "all":
        raise SystemExit("droneplan: --summary-only goes with 'bench all'")
    if args.reproduce_times is not None and args.problem != "all":
        raise SystemExit("droneplan: --reproduce-times goes with 'bench all' (it feeds the summary)")
    if args.variants:
        return _run_bench_variants(args, problems)
    for problem in [] if args.summary_only else problems:
        out = args.out / problem
        out.mkdir(parents=True, exist_ok=True)
        print(f"### bench {problem} (thesis ch. {_CHAPTER[problem]}) -> {out}", flush=True)
        extra = {"time_limit": args.time_limit} if problem == "cells" else {}
        try:
            _load(problem).bench(quick=args.quick, out=out, **extra)
        except ValueError as exc:  # a bad option value, named by the check that refused it
            raise SystemExit(f"droneplan: {exc}") from None
    if args.problem == "all":
        from droneplan.studies.bench_summary import bench_summary, summary_markdown, write_summary

        try:
            rows = bench_summary(quick=args.quick, reproduce_times=args.reproduce_times)
        except (OSError, ValueError) as exc:  # a missing or foreign reproduce_times file
            raise SystemExit(f"droneplan: {exc}") from None
        print(summary_markdown(rows), flush=True)
        print(f"summary: {write_summary(rows, args.out)}", flush=True)
    return 0


def main(argv: list[str] | None = None) -> int:
    """Run the command line; returns the exit code (see the module docstring)."""
    args = _parser().parse_args(argv)
    import matplotlib

    matplotlib.use("Agg")  # the CLI only writes figures to files; notebooks keep their own backend
    common.INTERRUPT_GRACE_S = 3.0  # a solve stuck in C code after Ctrl-C: exit 130 anyway
    # Ctrl-C always stops a run with exit code 130, also when the process was started with SIGINT
    # ignored (a shell without job control starts background commands that way)
    main_thread = threading.current_thread() is threading.main_thread()
    previous = {sig: signal.getsignal(sig) for sig in (signal.SIGINT, *_STOP_SIGNALS)}
    if main_thread:
        signal.signal(signal.SIGINT, signal.default_int_handler)
        for sig in _STOP_SIGNALS:  # SIGTERM and SIGHUP stop a run the way Ctrl-C does
            signal.signal(sig, _stop)
    try:
        return _run(args)
    except (StudyError, StoreError, JsonFileError, LibraryFileError) as exc:
        print(f"droneplan: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt as exc:
        how = f"stopped by {exc.signal.name}" if isinstance(exc, Stopped) else "interrupted"
        print(f"\ndroneplan: {how}; {_kept(args)}: rerun the same command to resume", file=sys.stderr)
        return 128 + exc.signal if isinstance(exc, Stopped) else 130
    finally:
        common.INTERRUPT_GRACE_S = None
        if main_thread:
            for sig, handler in previous.items():
                if handler is not None:
                    signal.signal(sig, handler)


_STOP_SIGNALS = (signal.SIGTERM, signal.SIGHUP)


def _kept(args) -> str:
    """Where a stopped command's finished work is (the store of ``--out``, or the library)."""
    if getattr(args, "out", None) is not None:
        return f"finished rows are in {args.out / STORE_NAME}"
    library = getattr(args, "library_dir", None)
    return f"certified entries are in {library or 'the package library'}"


class Stopped(KeyboardInterrupt):
    """SIGTERM or SIGHUP, handled as Ctrl-C is: the jobs are killed and the finished rows kept."""

    def __init__(self, sig: signal.Signals) -> None:
        super().__init__(sig.name)
        self.signal = sig


def _stop(signum: int, frame: object) -> None:
    raise Stopped(signal.Signals(signum))


if __name__ == "__main__":
    sys.exit(main())
