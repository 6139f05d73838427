"""The four problems' study modules behind one typed protocol, and the built-in gap study of any
of them (:func:`run_gap`, what ``droneplan gap <problem>`` runs).

Each problem's study module ``droneplan.studies.thesis.<problem>`` follows :class:`ProblemStudies`: the
same signatures for ``reproduce_jobs`` (its reproduction as a graph of jobs), ``gap`` (its
built-in gap study) and ``bench``. The command line only parses and dispatches to these.

The three "gap" routes are: :func:`droneplan.gap` (an open study of any methods on any instances,
:func:`droneplan.studies.study.gap`), :func:`run_gap` here (each problem's built-in gap study of
the registered methods) and ``droneplan gap`` (the command line of both).
"""

from __future__ import annotations

import importlib
import importlib.util
import os
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol, cast

from droneplan.core.validation import check_int
from droneplan.studies import common
from droneplan.studies.common import StudyError, make_executor
from droneplan.studies.problems import PROBLEMS
from droneplan.studies.store import STORE_NAME, ResultStore

if TYPE_CHECKING:
    import pandas as pd

    from droneplan.studies.jobs import Job

__all__ = [
    "ProblemStudies",
    "CHAPTER",
    "available_problems",
    "problem_studies",
    "resolve_problems",
    "run_gap",
]

CHAPTER = {"covert": 3, "cells": 4, "shark": 5, "herding": 6}
"""The thesis chapter of each problem."""


class ProblemStudies(Protocol):
    """What every problem's study module offers (the module ``droneplan.studies.thesis.<problem>``)."""

    def reproduce_jobs(self, *, quick: bool, out: Path, store_path: Path) -> list[Job]:
        """The problem's reproduction as jobs (``droneplan reproduce`` runs every problem's
        together). quick: the reduced sizes; out: its output directory; store_path: the results
        store its jobs write rows to and its figures read them from."""
        ...

    def gap(
        self, *, seeds: int, executor: Any = None, out: Path, store: Any = None, first_seed: int = 0
    ) -> pd.DataFrame:
        """The problem's built-in gap study. seeds: instances (per size); executor: where the jobs
        run; out: its output directory; store: the results store; first_seed: the first seed."""
        ...

    def bench(self, *, quick: bool, out: Path) -> None:
        """The problem's benchmarks (timings with CPU seconds and the load). quick: fewer rows;
        out: its output directory."""
        ...


def available_problems() -> list[str]:
    """Problems whose study module is installed, in chapter order."""
    return [p for p in PROBLEMS if importlib.util.find_spec(f"droneplan.studies.thesis.{p}") is not None]


def problem_studies(problem: str) -> ProblemStudies:
    """The study module of ``problem`` (:class:`ProblemStudies`).

    problem: one of ``PROBLEMS``.
    """
    if problem not in PROBLEMS:
        raise ValueError(f"problem must be one of {', '.join(PROBLEMS)}, got {problem!r}")
    return cast(ProblemStudies, importlib.import_module(f"droneplan.studies.thesis.{problem}"))


def resolve_problems(problem: str) -> list[str]:
    """The problems ``problem`` names: itself, or every available one for ``"all"``.

    problem: a problem name or ``"all"``; anything else, or a problem whose module is not
        installed, is a one-line ValueError.
    """
    avail = available_problems()
    if problem == "all":
        if not avail:
            raise ValueError("problem: no problem is available yet")
        return avail
    if problem not in PROBLEMS:
        raise ValueError(f"problem: unknown problem {problem!r}; choose from {', '.join(PROBLEMS)} or all")
    if problem not in avail:
        raise ValueError(
            f"problem: {problem!r} (thesis ch. {CHAPTER[problem]}) is not implemented yet; "
            f"available: {', '.join(avail) or 'none'}"
        )
    return [problem]


def writable_out(out: Path) -> None:
    """Refuse, as a :class:`StudyError`, an output directory that cannot be created or written.

    out: the directory (created when missing).
    """
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise StudyError(f"cannot create --out {out}: {exc.strerror or exc}") from None
    if not os.access(out, os.W_OK | os.X_OK):
        raise StudyError(f"cannot write to --out {out}: permission denied")


def run_gap(
    problem: str = "all",
    *,
    seeds: int,
    out: str | os.PathLike,
    workers: int | None = 1,
    dask_address: str | None = None,
    first_seed: int = 0,
) -> pd.DataFrame:
    """Run the built-in gap study of ``problem`` (or ``"all"``) from Python, like ``droneplan gap``.

    problem: ``covert``, ``cells``, ``shark``, ``herding`` or ``"all"``.
    seeds: number of instances per problem (per size for herding).
    out: the ``--out`` directory (store ``out/results.sqlite``, per-problem summaries and figures).
    workers: local processes (1: serial in this process; None: one per core; at most
        ``common.WORKERS_PER_CORE`` per core).
    dask_address: a Dask scheduler address (a string such as ``"tcp://host:8786"``) instead.
    first_seed: seed of the first instance. Resumes like the command line.

    Returns the rows of the problems run (:func:`droneplan.load_results` of ``out``).
    """
    check_int("seeds", seeds, min_value=1)
    check_int("first_seed", first_seed, min_value=0)
    common.check_executor_options(workers, dask_address)
    folder = Path(out)
    problems = resolve_problems(problem)
    writable_out(folder)
    with ResultStore(folder / STORE_NAME) as store, make_executor(workers, dask_address) as executor:
        for name in problems:
            problem_studies(name).gap(
                seeds=seeds, executor=executor, out=folder / name, store=store, first_seed=first_seed
            )
        store.export(folder / "results.csv")
        df = store.frame()
    return df[df["problem"].isin(problems)].reset_index(drop=True)
