"""The ``droneplan`` command line: ``reproduce``, ``gap`` and ``bench``.

A problem is available when its study module ``droneplan.studies.<problem>`` exists; such
a module defines ``reproduce(*, quick, out)`` (optionally taking ``executor`` and ``store``),
``gap(*, seeds, executor, out, store)`` and ``bench(*, quick, out)``. Problems whose
module has not landed are listed as unavailable rather than answered with placeholder output.

Every study writes its rows to one store, ``<--out>/results.sqlite`` (schema and store:
:mod:`droneplan.studies.store`), exported to ``<--out>/results.csv`` after each problem;
``droneplan.load_results(out)`` reads it back. Exit codes: 0 done, 1 some task ended in an
error row (rerun to retry it), 2 bad input (unwritable ``--out``, unreachable ``--dask``,
a store of another schema), 130 interrupted by Ctrl-C (finished rows kept; rerun to resume).
"""

from __future__ import annotations

import argparse
import contextlib
import importlib
import importlib.util
import inspect
import os
import sys
from pathlib import Path
from types import ModuleType

from droneplan.studies import common
from droneplan.studies.common import StudyError, make_executor
from droneplan.studies.store import STORE_NAME, ResultStore, StoreError

__all__ = ["PROBLEMS", "available_problems", "run_gap", "main"]

PROBLEMS = ("covert", "cells", "shark", "herding")
"""The four problems, in thesis chapter order (ch. 3-6)."""

_CHAPTER = {"covert": 3, "cells": 4, "shark": 5, "herding": 6}


def available_problems() -> list[str]:
    """Problems whose study module is installed, in chapter order."""
    return [p for p in PROBLEMS if importlib.util.find_spec(f"droneplan.studies.{p}") is not None]


def _load(problem: str) -> ModuleType:
    return importlib.import_module(f"droneplan.studies.{problem}")


def _resolve(problem: str) -> list[str]:
    avail = available_problems()
    if problem == "all":
        if not avail:
            raise SystemExit("droneplan: no problem is available yet")
        return avail
    if problem not in PROBLEMS:
        raise SystemExit(f"droneplan: unknown problem {problem!r}; choose from {', '.join(PROBLEMS)} or all")
    if problem not in avail:
        raise SystemExit(
            f"droneplan: problem {problem!r} (thesis ch. {_CHAPTER[problem]}) is not implemented yet; "
            f"available: {', '.join(avail) or 'none'}"
        )
    return [problem]


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
        "--out",
        type=Path,
        default=Path("results"),
        help="directory for the store results.sqlite, results.csv and per-problem summaries/figures "
        "(default: results)",
    )

    bench = sub.add_parser("bench", help="performance ratios measured in one run", epilog=epilog)
    bench.add_argument("problem", nargs="?", default="all", choices=choices)
    bench.add_argument("--quick", action="store_true", help="smaller instances")
    bench.add_argument(
        "--out", type=Path, default=Path("results"), help="directory for the CSV (default: results)"
    )
    return parser


def run_gap(
    problem: str = "all",
    *,
    seeds: int,
    out: str | os.PathLike,
    workers: int | None = 1,
    dask_address: str | None = None,
    first_seed: int = 0,
):
    """Run the gap study of ``problem`` (or ``"all"``) from Python, like ``droneplan gap``.

    seeds: number of instances per problem (per size for herding); out: the ``--out``
    directory (store ``out/results.sqlite``, per-problem summaries and figures); workers:
    local processes (1: serial in this process; None: one per core); dask_address: a Dask
    scheduler instead; first_seed: seed of the first instance. Resumes like the CLI.
    Returns the rows of the problems run (:func:`droneplan.load_results` of ``out``).
    """
    if isinstance(seeds, bool) or not isinstance(seeds, int) or seeds < 1:
        raise ValueError(f"seeds must be an int >= 1, got {seeds!r}")
    if isinstance(first_seed, bool) or not isinstance(first_seed, int) or first_seed < 0:
        raise ValueError(f"first_seed must be an int >= 0, got {first_seed!r}")
    out = Path(out)
    problems = _resolve(problem)
    _writable_out(out)
    with ResultStore(out / STORE_NAME) as store, make_executor(workers, dask_address) as executor:
        for name in problems:
            _load(name).gap(
                seeds=seeds, executor=executor, out=out / name, store=store, first_seed=first_seed
            )
        store.export(out / "results.csv")
        df = store.frame()
    return df[df["problem"].isin(problems)].reset_index(drop=True)


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


def _writable_out(out: Path) -> None:
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise StudyError(f"cannot create --out {out}: {exc.strerror or exc}") from None
    if not os.access(out, os.W_OK | os.X_OK):
        raise StudyError(f"cannot write to --out {out}: permission denied")


def _run(args) -> int:
    problems = _resolve(args.problem)
    if args.command == "gap" and args.seeds < 1:
        raise SystemExit(f"droneplan: --seeds must be >= 1, got {args.seeds}")
    if args.command == "gap" and args.first_seed < 0:
        raise SystemExit(f"droneplan: --first-seed must be >= 0, got {args.first_seed}")
    workers = getattr(args, "workers", None)
    if workers is not None and workers < 1:
        raise SystemExit(f"droneplan: --workers must be >= 1, got {workers}")
    _writable_out(args.out)
    if args.command == "bench":
        for problem in problems:
            out = args.out / problem
            out.mkdir(parents=True, exist_ok=True)
            print(f"### bench {problem} (thesis ch. {_CHAPTER[problem]}) -> {out}", flush=True)
            _load(problem).bench(quick=args.quick, out=out)
        return 0
    with contextlib.ExitStack() as stack:
        store = stack.enter_context(ResultStore(args.out / STORE_NAME))
        executor = stack.enter_context(make_executor(workers, args.dask))
        for problem in problems:
            module = _load(problem)
            out = args.out / problem
            out.mkdir(parents=True, exist_ok=True)
            print(f"### {args.command} {problem} (thesis ch. {_CHAPTER[problem]}) -> {out}", flush=True)
            try:
                if args.command == "reproduce":
                    accepted = inspect.signature(module.reproduce).parameters
                    extra = {k: v for k, v in (("executor", executor), ("store", store)) if k in accepted}
                    module.reproduce(quick=args.quick, out=out, **extra)
                else:
                    module.gap(
                        seeds=args.seeds, executor=executor, out=out, store=store, first_seed=args.first_seed
                    )
            finally:
                store.export(args.out / "results.csv")
        errors = store.frame()
        errors = errors[errors["status"] == "error"]
    if args.command == "reproduce" and args.report:
        # written even when some tasks errored: the report shows what finished, and the error
        # rows' tables say so; the exit code below still reports the errors
        from droneplan.studies.report import write_report

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


def main(argv: list[str] | None = None) -> int:
    """Run the command line; returns the exit code (see the module docstring)."""
    args = _parser().parse_args(argv)
    import matplotlib

    matplotlib.use("Agg")  # the CLI only writes figures to files; notebooks keep their own backend
    common.INTERRUPT_GRACE_S = 3.0  # a solve stuck in C code after Ctrl-C: exit 130 anyway
    try:
        return _run(args)
    except (StudyError, StoreError) as exc:
        print(f"droneplan: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(
            f"\ndroneplan: interrupted; finished rows are in {args.out / STORE_NAME}: rerun the same command "
            "to resume",
            file=sys.stderr,
        )
        return 130
    finally:
        common.INTERRUPT_GRACE_S = None


if __name__ == "__main__":
    sys.exit(main())
