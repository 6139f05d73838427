"""The speed goals beside their measured values, measured in one process (the summary of
``droneplan bench all --quick``).

Rows:

- ``import droneplan`` in a fresh interpreter (goal: 0.5 s wall), and the same import followed by
  touching every front door (``droneplan.cells``, ``.covert``, ``.shark``, ``.herding``), with the
  heavy libraries (cvxpy, casadi, ortools, matplotlib, pandas) each import left loaded;
- herding, simulated seconds per CPU second of the proposed herder over the first ``t_max``
  seconds of the thesis set-up (goals: 200 at 1000 animals, 50 at 10^4; 200 animals has none);
- gap seconds per instance of each problem's built-in study (``droneplan gap <problem>`` on a
  small fixed number of seeds, in a child process: cells m = 3 on library instances, herding
  allocation, shark paths and fleets, covert random groups; goal: 30 for covert), wall and CPU;
- ``droneplan reproduce --quick`` (goal: 120 s wall), run in a child process into a temporary
  directory, or read from the ``reproduce_times.csv`` of a run already made.

Every row records its wall time, its CPU time and the 1-minute load average when it started, so
a figure taken on a shared machine can be judged: the herding ratios use CPU time (what other
processes disturb least); an import row's CPU time is the whole child interpreter's, and a gap or
reproduce row's that of the child and every process it waited for (its job processes).
"""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
import time
from collections.abc import Iterable, Sequence
from dataclasses import asdict, dataclass
from pathlib import Path

from droneplan.core.validation import check_int, check_positive
from droneplan.studies.common import load_average, measured

__all__ = [
    "HEAVY_MODULES",
    "HERDING_GOALS",
    "IMPORT_GOAL_S",
    "BenchRow",
    "measure_import",
    "measure_herding",
    "GAP_GOALS",
    "GAP_SEEDS",
    "REPRODUCE_GOAL_S",
    "gap_row",
    "measure_gap",
    "reproduce_row",
    "reproduce_row_from_times",
    "measure_reproduce",
    "bench_summary",
    "summary_markdown",
    "write_summary",
]

HEAVY_MODULES = ("cvxpy", "casadi", "ortools", "matplotlib", "pandas")
"""Libraries ``import droneplan`` must not load (they load with the first name that needs them)."""

IMPORT_GOAL_S = 0.5
"""Goal for ``import droneplan`` in a fresh interpreter on an idle machine, s (wall)."""

HERDING_GOALS: dict[int, float | None] = {200: None, 1000: 200.0, 10_000: 50.0}
"""Goal per herd size (count of animals): simulated seconds per CPU second (None: no goal)."""

_FRONT_DOORS = ("cells", "covert", "shark", "herding")

GAP_GOALS: dict[str, float | None] = {"cells": None, "herding": None, "shark": None, "covert": 30.0}
"""Goal per problem: wall seconds per instance of its built-in gap study (None: no goal)."""

GAP_SEEDS: dict[str, tuple[int, int]] = {
    "cells": (1, 3),
    "herding": (1, 3),
    "shark": (2, 10),
    "covert": (2, 5),
}
"""Seeds of the gap study measured per problem: (quick, full)."""

REPRODUCE_GOAL_S = 120.0
"""Goal for ``droneplan reproduce --quick`` on an idle 2-core machine, s (wall)."""


@dataclass(frozen=True)
class BenchRow:
    """One measured quantity beside its goal."""

    quantity: str
    """What is measured, with its unit."""
    goal: str
    """The goal as text (e.g. ``"<= 0.5"``; ``"—"`` when there is none)."""
    value: float
    """The measured value, in the unit of ``quantity``."""
    met: bool | None
    """Whether ``value`` meets the goal (None: no goal)."""
    wall: float
    """Wall-clock time of the measurement, s."""
    cpu: float
    """CPU time of the measurement, s (for an import row: the whole child interpreter's)."""
    load: float
    """1-minute load average when the measurement started (NaN where the platform has none)."""
    note: str = ""
    """How it was measured."""


def _children_cpu() -> float:
    """CPU time of this process's finished children, s (NaN where the platform cannot tell)."""
    try:
        import resource
    except ImportError:
        return math.nan
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def _import_probe(doors: bool) -> str:
    touch = "".join(f"droneplan.{d}\n" for d in _FRONT_DOORS) if doors else ""
    return (
        "import time, sys, json\n"
        "w0, c0 = time.perf_counter(), time.process_time()\n"
        "import droneplan\n"
        f"{touch}"
        "w, c = time.perf_counter() - w0, time.process_time() - c0\n"
        f"heavy = [m for m in {HEAVY_MODULES!r} if m in sys.modules]\n"
        "print(json.dumps({'wall': w, 'cpu': c, 'heavy': heavy, 'modules': len(sys.modules)}))\n"
    )


def measure_import(*, doors: bool = False, repeats: int = 3) -> BenchRow:
    """Time ``import droneplan`` in fresh interpreters; the fastest of ``repeats`` runs counts.

    doors: also touch every front door after the import (their names still load lazily).
    repeats: number of fresh interpreters (count, >= 1); the row keeps the one with the least
        wall time, interpreter start-up included (the value and ``wall``, s) and its CPU time.
    """
    repeats = check_int("repeats", repeats, min_value=1)
    load = load_average()
    best: tuple[float, float, dict] | None = None
    for _ in range(repeats):
        before = _children_cpu()
        w0 = time.perf_counter()
        out = subprocess.run(
            [sys.executable, "-c", _import_probe(bool(doors))], capture_output=True, text=True, check=True
        )
        wall = time.perf_counter() - w0
        cpu = _children_cpu() - before
        child = json.loads(out.stdout.strip().splitlines()[-1])
        if best is None or wall < best[0]:
            best = (wall, child["cpu"] if math.isnan(cpu) else cpu, child)
    if best is None:  # repeats >= 1: cannot happen
        raise RuntimeError("no import was measured")
    wall, cpu, child = best
    what = "import droneplan + every front door" if doors else "import droneplan"
    return BenchRow(
        quantity=f"{what}, fresh interpreter (s wall)",
        goal=f"<= {IMPORT_GOAL_S}",
        value=wall,
        met=wall <= IMPORT_GOAL_S,
        wall=wall,
        cpu=cpu,
        load=load,
        note=(
            f"best of {repeats}, interpreter start-up included; the import itself {child['wall']:.3f} s "
            f"wall, {child['cpu']:.3f} CPU-s, {child['modules']} modules; heavy libraries loaded: "
            f"{', '.join(child['heavy']) or 'none'}"
        ),
    )


def measure_herding(n_animals: int, *, t_max: float = 60.0, repeats: int = 1) -> BenchRow:
    """Simulated seconds per CPU second of the proposed herder on the thesis set-up.

    n_animals: herd size (count, >= 1); scenario seed 0, simulation seed 1, 4 drones.
    t_max: simulated time, s (> 0): the first ``t_max`` seconds of gathering.
    repeats: runs (count, >= 1); the row keeps the one with the least CPU time.
    """
    from droneplan.planners.herding import ProposedHerder
    from droneplan.scenarios.herding import simulate, thesis_scenario

    n_animals = check_int("n_animals", n_animals, min_value=1)
    t_max = check_positive("t_max", t_max)
    repeats = check_int("repeats", repeats, min_value=1)
    scenario = thesis_scenario(n_animals, seed=0)
    load = load_average()
    best: tuple[float, float, float] | None = None
    for _ in range(repeats):
        with measured() as run:
            trace = simulate(scenario, ProposedHerder(), t_max=t_max, seed=1)
        if best is None or run.cpu_s < best[0]:
            best = (run.cpu_s, run.wall_s, float(trace.t[-1]))
    if best is None:  # repeats >= 1: cannot happen
        raise RuntimeError("no run was measured")
    cpu, wall, simulated = best
    ratio = simulated / max(cpu, 1e-9)
    goal = HERDING_GOALS.get(n_animals)
    return BenchRow(
        quantity=f"herding, {n_animals} animals + 4 drones (simulated s per CPU s)",
        goal="—" if goal is None else f">= {goal:g}",
        value=ratio,
        met=None if goal is None else ratio >= goal,
        wall=wall,
        cpu=cpu,
        load=load,
        note=f"proposed herder, first {simulated:g} s of gathering, thesis set-up; best of {repeats}",
    )


def _cli(args: Sequence[str]) -> tuple[float, float, float]:
    """Run ``droneplan <args>`` in a child interpreter: (wall s, CPU s of it and every process it
    waited for, 1-minute load average at the start). A failing command raises RuntimeError."""
    load = load_average()
    before = _children_cpu()
    w0 = time.perf_counter()
    done = subprocess.run(
        [sys.executable, "-m", "droneplan.studies.cli", *args], capture_output=True, text=True, check=False
    )
    wall = time.perf_counter() - w0
    if done.returncode != 0:
        tail = (done.stderr or done.stdout).strip().splitlines()[-1:] or ["no output"]
        raise RuntimeError(f"droneplan {' '.join(args)} exited with {done.returncode}: {tail[0]}")
    return wall, _children_cpu() - before, load


def gap_row(
    problem: str, *, instances: int, wall: float, cpu: float, load: float, note: str = ""
) -> BenchRow:
    """The "gap seconds per instance" row of ``problem`` from a measured study.

    problem: a key of ``GAP_GOALS``; instances: instances the study ran (count, >= 1); wall, cpu:
    the study's wall and CPU seconds (all its processes); load: 1-minute load average at its start;
    note: how it was run. The value is wall seconds per instance; the note gives CPU per instance.
    """
    if problem not in GAP_GOALS:
        raise ValueError(f"problem must be one of {', '.join(GAP_GOALS)}, got {problem!r}")
    instances = check_int("instances", instances, min_value=1)
    goal = GAP_GOALS[problem]
    value = wall / instances
    return BenchRow(
        quantity=f"gap, {problem} (s wall per instance)",
        goal="—" if goal is None else f"<= {goal:g}",
        value=value,
        met=None if goal is None else value <= goal,
        wall=wall,
        cpu=cpu,
        load=load,
        note=f"{instances} instances, {cpu / instances:.1f} CPU-s per instance; {note}".rstrip("; "),
    )


def measure_gap(problem: str, *, seeds: int, out: Path, workers: int | None = None) -> BenchRow:
    """Time ``droneplan gap <problem> --seeds <seeds>`` in a child process into a fresh store.

    problem: ``cells`` (m = 3, library instances), ``herding``, ``shark`` or ``covert``; seeds:
    instances per size (count, >= 1); out: a scratch directory (the study's ``--out``; must not
    hold a store of an earlier run, or rows would be reused); workers: ``--workers`` (None: one per
    core).
    """
    from droneplan.studies.store import load_results

    if problem not in GAP_GOALS:
        raise ValueError(f"problem must be one of {', '.join(GAP_GOALS)}, got {problem!r}")
    seeds = check_int("seeds", seeds, min_value=1)
    out = Path(out)
    if (out / "results.sqlite").exists():
        raise ValueError(f"out must not hold a results store already (its rows would be reused): {out}")
    args = ["gap", problem, "--seeds", str(seeds), "--out", str(out)]
    if workers is not None:
        args += ["--workers", str(check_int("workers", workers, min_value=1))]
    wall, cpu, load = _cli(args)
    df = load_results(out)
    n = int(df.loc[df["problem"] == problem, "instance"].nunique())
    cores = workers if workers is not None else os.cpu_count()
    return gap_row(
        problem,
        instances=n,
        wall=wall,
        cpu=cpu,
        load=load,
        note=f"droneplan {' '.join(args[:4])}, {cores} workers",
    )


def reproduce_row(*, wall: float, cpu: float, load: float, note: str) -> BenchRow:
    """The ``reproduce --quick`` row from its wall and CPU seconds, the load at its start and how it
    was measured (``note``)."""
    return BenchRow(
        quantity="droneplan reproduce --quick (s wall)",
        goal=f"<= {REPRODUCE_GOAL_S:g}",
        value=wall,
        met=wall <= REPRODUCE_GOAL_S,
        wall=wall,
        cpu=cpu,
        load=load,
        note=note,
    )


def reproduce_row_from_times(path: Path) -> BenchRow:
    """The ``reproduce --quick`` row read from a run's ``reproduce_times.csv`` (its ``total`` row:
    ``span_s``, first job start to last job end, as the wall time; ``cpu_s``, the jobs' CPU seconds).

    path: the CSV file, or the run's ``--out`` directory holding it. The load of that run is not
    recorded there (NaN).
    """
    import pandas as pd

    from droneplan.studies.jobs import TIMES_NAME

    path = Path(path)
    if path.is_dir():
        path = path / TIMES_NAME
    table = pd.read_csv(path)
    missing = {"section", "jobs", "cpu_s", "span_s"} - set(table.columns)
    if missing:
        raise ValueError(f"path: {path} lacks the columns {sorted(missing)} (not a {TIMES_NAME})")
    total = table[table["section"] == "total"]
    if total.empty:
        raise ValueError(f"path: {path} has no 'total' row (not a reproduce_times.csv)")
    row = total.iloc[0]
    problems = sorted({str(sec).split()[0] for sec in table["section"] if sec != "total"})
    return reproduce_row(
        wall=float(row["span_s"]),
        cpu=float(row["cpu_s"]),
        load=math.nan,
        note=f"read from {path}: first job start to last job end, {int(row['jobs'])} jobs of "
        f"{', '.join(problems)}; load not recorded",
    )


def measure_reproduce(out: Path, *, workers: int | None = None) -> BenchRow:
    """Time ``droneplan reproduce --quick --out <out>`` in a child process (wall, CPU of it and its
    job processes, load at the start).

    out: a scratch directory without an earlier run's store; workers: ``--workers`` (None: one per core).
    """
    out = Path(out)
    if (out / "results.sqlite").exists():
        raise ValueError(f"out must not hold a results store already (its rows would be reused): {out}")
    args = ["reproduce", "--quick", "--out", str(out)]
    if workers is not None:
        args += ["--workers", str(check_int("workers", workers, min_value=1))]
    wall, cpu, load = _cli(args)
    cores = workers if workers is not None else os.cpu_count()
    return reproduce_row(wall=wall, cpu=cpu, load=load, note=f"child process, every problem, {cores} workers")


def bench_summary(
    *,
    quick: bool = True,
    sizes: Sequence[int] = tuple(HERDING_GOALS),
    gap_problems: Sequence[str] = tuple(GAP_GOALS),
    reproduce_times: Path | None = None,
) -> list[BenchRow]:
    """Measure every goal of this summary, one after another.

    quick: the best of 3 runs per herding size (a single first run reads 20-30 % low), 3 fresh
        interpreters per import row and the quick seeds of ``GAP_SEEDS`` (False: best of 5 runs,
        5 interpreters, the full seeds).
    sizes: herd sizes for the herding rows (counts of animals).
    gap_problems: problems whose gap study is timed (empty: none).
    reproduce_times: a run's ``reproduce_times.csv`` (or its directory) to read the reproduce row
        from; None: run ``droneplan reproduce --quick`` here (in a temporary directory).
    """
    import tempfile

    herds = [check_int(f"sizes[{i}]", n, min_value=1) for i, n in enumerate(sizes)]
    problems = list(gap_problems)
    for i, problem in enumerate(problems):
        if problem not in GAP_GOALS:
            raise ValueError(f"gap_problems[{i}] must be one of {', '.join(GAP_GOALS)}, got {problem!r}")
    # a given run's time table is read first, so a missing or foreign file fails before the measuring
    earlier = None if reproduce_times is None else reproduce_row_from_times(reproduce_times)
    runs, interpreters = (3, 3) if quick else (5, 5)  # a single herding run reads 20-30 % low
    rows = [measure_import(repeats=interpreters), measure_import(doors=True, repeats=interpreters)]
    rows += [measure_herding(n, repeats=runs) for n in herds]
    with tempfile.TemporaryDirectory(prefix="droneplan-bench-") as tmp:
        for problem in problems:
            seeds = GAP_SEEDS[problem][0 if quick else 1]
            rows.append(measure_gap(problem, seeds=seeds, out=Path(tmp) / f"gap-{problem}"))
        rows.append(measure_reproduce(Path(tmp) / "reproduce") if earlier is None else earlier)
    return rows


def _shown(value: float) -> str:
    return f"{value:.3f}" if abs(value) < 10 else f"{value:.1f}"


def summary_markdown(rows: Iterable[BenchRow]) -> str:
    """The rows as a Markdown table: quantity | goal | measured | met | wall (s) | CPU (s) | load | how."""
    lines = [
        "| quantity | goal | measured | met | wall (s) | CPU (s) | load (1 min) | how measured |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        met = "—" if r.met is None else ("yes" if r.met else "NO")
        lines.append(
            f"| {r.quantity} | {r.goal} | {_shown(r.value)} | {met} | {r.wall:.2f} | {r.cpu:.2f} "
            f"| {r.load:.2f} | {r.note} |"
        )
    return "\n".join(lines) + "\n"


def write_summary(rows: Sequence[BenchRow], out: Path) -> Path:
    """Write ``bench_summary.md`` and ``bench_summary.json`` (one object per row) to ``out``.

    rows: the measured rows (:func:`bench_summary`). out: directory (created if missing).
    Returns the Markdown file's path.
    """
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    (out / "bench_summary.json").write_text(json.dumps([asdict(r) for r in rows], indent=1) + "\n")
    path = out / "bench_summary.md"
    path.write_text(summary_markdown(rows))
    return path
