"""The speed goals beside their measured values, measured in one process (the summary of
``droneplan bench all --quick``).

Rows:

- ``import droneplan`` in a fresh interpreter (goal: 0.5 s wall), and the same import followed by
  touching every front door (``droneplan.cells``, ``.covert``, ``.shark``, ``.herding``), with the
  heavy libraries (cvxpy, casadi, ortools, matplotlib, pandas) each import left loaded;
- herding, simulated seconds per CPU second of the proposed herder over the first ``t_max``
  seconds of the thesis set-up (goals: 200 at 1000 animals, 50 at 10^4; 200 animals has none).

Every row records its wall time, its CPU time and the 1-minute load average when it started, so
a figure taken on a shared machine can be judged: the herding ratios use CPU time (what other
processes disturb least); an import row's CPU time is the whole child interpreter's.
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

__all__ = [
    "HEAVY_MODULES",
    "HERDING_GOALS",
    "IMPORT_GOAL_S",
    "BenchRow",
    "measure_import",
    "measure_herding",
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


def _load_average() -> float:
    return os.getloadavg()[0] if hasattr(os, "getloadavg") else math.nan


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
    load = _load_average()
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
    load = _load_average()
    best: tuple[float, float, float] | None = None
    for _ in range(repeats):
        c0, w0 = time.process_time(), time.perf_counter()
        trace = simulate(scenario, ProposedHerder(), t_max=t_max, seed=1)
        cpu, wall = time.process_time() - c0, time.perf_counter() - w0
        if best is None or cpu < best[0]:
            best = (cpu, wall, float(trace.t[-1]))
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


def bench_summary(*, quick: bool = True, sizes: Sequence[int] = tuple(HERDING_GOALS)) -> list[BenchRow]:
    """Measure every goal of this summary in this process, one after another.

    quick: one run per herding size and 3 fresh interpreters per import row (False: 3 herding runs
        and 5 interpreters, the fastest kept).
    sizes: herd sizes for the herding rows (counts of animals).
    """
    herds = [check_int(f"sizes[{i}]", n, min_value=1) for i, n in enumerate(sizes)]
    runs, interpreters = (1, 3) if quick else (3, 5)
    rows = [measure_import(repeats=interpreters), measure_import(doors=True, repeats=interpreters)]
    rows += [measure_herding(n, repeats=runs) for n in herds]
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
