"""The ``droneplan`` command line: ``reproduce``, ``gap`` and ``bench``.

A problem is available when its study module ``droneplan.studies.<problem>`` exists; such
a module defines ``reproduce(*, quick, out)``, ``gap(*, seeds, executor, out)``
and ``bench(*, quick, out)``. Problems whose module has not landed are listed
as unavailable rather than answered with placeholder output.
"""

from __future__ import annotations

import argparse
import importlib
import importlib.util
import sys
from pathlib import Path
from types import ModuleType

from droneplan.studies.common import make_executor

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

    rep = sub.add_parser("reproduce", help="reproduce the thesis tables and figures (thesis | this run | how)",
                         epilog=epilog)
    rep.add_argument("problem", nargs="?", default="all", choices=choices)
    rep.add_argument("--quick", action="store_true", help="reduced sizes/seeds; finishes in minutes on 2 cores")
    rep.add_argument("--out", type=Path, default=Path("results"), help="directory for CSV and PNG (default: results)")
    rep.add_argument("--report", action="store_true", help="also write OUT/report.html (tables beside the thesis, figures)")

    gap = sub.add_parser("gap", help="heuristic vs solver optimum per instance (resumable CSV)", epilog=epilog)
    gap.add_argument("problem", nargs="?", default="all", choices=choices)
    gap.add_argument("--seeds", type=int, default=10, help="number of random instances (default 10)")
    grp = gap.add_mutually_exclusive_group()
    grp.add_argument("--workers", type=int, default=None, help="local worker processes (default: cores)")
    grp.add_argument("--dask", metavar="ADDRESS", default=None, help="Dask scheduler address")
    gap.add_argument("--out", type=Path, default=Path("results"), help="directory for the CSV (default: results)")

    bench = sub.add_parser("bench", help="performance ratios measured in one run", epilog=epilog)
    bench.add_argument("problem", nargs="?", default="all", choices=choices)
    bench.add_argument("--quick", action="store_true", help="smaller instances")
    bench.add_argument("--out", type=Path, default=Path("results"), help="directory for the CSV (default: results)")
    return parser


def main(argv: list[str] | None = None) -> int:
    args = _parser().parse_args(argv)
    problems = _resolve(args.problem)
    if args.command == "gap" and args.seeds < 1:
        raise SystemExit(f"droneplan: --seeds must be >= 1, got {args.seeds}")
    if args.command == "gap" and args.workers is not None and args.workers < 1:
        raise SystemExit(f"droneplan: --workers must be >= 1, got {args.workers}")
    for problem in problems:
        module = _load(problem)
        out = args.out / problem
        out.mkdir(parents=True, exist_ok=True)
        print(f"### {args.command} {problem} (thesis ch. {_CHAPTER[problem]}) -> {out}", flush=True)
        if args.command == "reproduce":
            module.reproduce(quick=args.quick, out=out)
        elif args.command == "gap":
            with make_executor(args.workers, args.dask) as executor:
                module.gap(seeds=args.seeds, executor=executor, out=out)
        else:
            module.bench(quick=args.quick, out=out)
    if args.command == "reproduce" and args.report:
        from droneplan.studies.report import write_report

        print(f"report: {write_report(args.out, problems=problems)}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
