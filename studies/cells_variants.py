"""The cells variants measured at Table 4.2 scale: time to proof of each variant, the fleet size
against the coverage share, and the myopic-against-joint gap for moving users.

``droneplan bench cells --variants`` runs :func:`bench_variants` (``--quick``: one seed, m = 2,
60 s a row). The variant instances are those of the library families ``table4.2-<variant>``
(:mod:`droneplan.scenarios.cell_variants`: demand weights, a no-fly zone, a capacity, altitude
levels), moving users drifting over T epochs (the smaller world of ``table4.2-mobile``: the joint model
cold, the myopic baseline, and ``mobile joint warm``, the joint model started from the myopic
plan, whose time includes the myopic run), and
``min-fleet``: the fewest drone-cells (at most ``m``) covering 10 %, 20 % and 30 % of the users.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from droneplan.formulations.cells import MobileProblem, min_fleet, myopic, solve_exact, solve_mobile
from droneplan.scenarios.cell_variants import (
    MOBILE_MAX_MOVE_M,
    MOBILE_PARAMS,
    VARIANTS,
    drifting_snapshots,
    thesis_variant_problem,
)
from droneplan.scenarios.cells import thesis_problem
from droneplan.studies.common import measured

__all__ = ["mobile_problem", "bench_variants", "variants_summary"]


def mobile_problem(m: int, seed: int, epochs: int) -> MobileProblem:
    """The moving-users instance of ``seed`` over ``epochs`` epochs: the world of the
    ``table4.2-mobile`` family (:func:`~droneplan.scenarios.cell_variants.mobile_instance`;
    the joint model is too large at the full Table 4.2 scale) with ``m`` drone-cells."""
    base = thesis_problem(m, seed, params=MOBILE_PARAMS)
    return MobileProblem(base, drifting_snapshots(base.users, seed, epochs), MOBILE_MAX_MOVE_M)


def bench_variants(
    *, seeds: list[int], m: int, time_limit: float, out: Path, epochs: int = 6
) -> list[dict[str, Any]]:
    """Run the variant rows (module docstring) and write them to ``out/bench_variants.csv``;
    returns them. Each row: variant, seed, m, time_limit (s), status, objective, bound, wall_s,
    cpu_s, load_1min.

    The file is rewritten after every row, and a row already in it (same variant, seed, m, time
    limit and epochs) is kept, not run again: an interrupted grid resumes where it stopped."""
    import pandas as pd

    path = Path(out) / "bench_variants.csv"
    path.parent.mkdir(parents=True, exist_ok=True)
    rows = _previous_rows(path)
    done = {_row_key(row) for row in rows}

    def run(name: str, seed: int, solve: Any, extra: dict[str, Any]) -> None:
        key = _row_key({"variant": name, "seed": seed, "m": m, "time_limit": time_limit, **extra})
        if key in done:
            return
        with measured() as measure:
            res = solve()
        rows.append({**_result_row(name, seed, m, res, measure), "time_limit": time_limit, **extra})
        done.add(key)
        pd.DataFrame(rows).to_csv(path, index=False)

    for seed in seeds:
        for name in VARIANTS:
            problem = thesis_variant_problem(name, m, seed)
            run(name, seed, lambda p=problem: solve_exact(p, time_limit=time_limit), {})
        for share in (0.1, 0.2, 0.3):
            base = thesis_problem(m, seed)
            run(
                f"min-fleet {share:.0%}",
                seed,
                lambda b=base, c=share: min_fleet(b, coverage=c, time_limit=time_limit),
                {"share": share},
            )
        mp = mobile_problem(m, seed, epochs)
        for name, solve in (("mobile joint", solve_mobile), ("mobile myopic", myopic)):
            run(name, seed, lambda s=solve, p=mp: s(p, time_limit=time_limit), {"epochs": epochs})
        run(
            "mobile joint warm",
            seed,
            lambda p=mp: solve_mobile(p, time_limit=time_limit, warm_start=myopic(p, time_limit=time_limit)),
            {"epochs": epochs},
        )
    if not path.exists():
        pd.DataFrame(rows).to_csv(path, index=False)
    wanted = set(seeds)
    return [row for row in rows if row["seed"] in wanted and row["m"] == m]


def _previous_rows(path: Path) -> list[dict[str, Any]]:
    """The rows of an earlier (perhaps interrupted) run of the grid, or none."""
    import pandas as pd

    if not path.exists():
        return []
    frame = pd.read_csv(path)
    if "time_limit" not in frame.columns:
        return []
    return [{k: None if pd.isna(v) else v for k, v in row.items()} for row in frame.to_dict("records")]


def _row_key(row: dict[str, Any]) -> tuple:
    """What identifies a row of the grid: a row with the same key is not run again."""
    return (
        str(row["variant"]),
        int(row["seed"]),
        int(row["m"]),
        float(row["time_limit"]),
        float(row.get("share") or 0.0),
        int(row.get("epochs") or 0),
    )


def _result_row(name: str, seed: int, m: int, res: Any, run: Any) -> dict[str, Any]:
    return {
        "variant": name,
        "seed": seed,
        "m": m,
        "status": res.status.value,
        "objective": res.objective,
        "bound": res.bound,
        "wall_s": run.wall_s,
        "cpu_s": run.cpu_s,
        "load_1min": run.load,
    }


_SETTLED = ("optimal", "infeasible")
"""Statuses that answer a row for good: proven optimal, or proven infeasible (a min-fleet share
that m drone-cells cannot reach)."""


def variants_summary(rows: list[dict[str, Any]]) -> str:
    """A markdown table of the grid's rows, one line per variant: seeds run, how many settled
    within the time limit (proven optimal or proven infeasible), the median CPU seconds of those,
    the unsettled seeds with their objective / bound, and the largest 1-minute load of its rows.

    rows: the rows of :func:`bench_variants` (or its CSV's records)."""
    by_variant: dict[str, list[dict[str, Any]]] = {}
    for row in rows:
        by_variant.setdefault(str(row["variant"]), []).append(row)
    lines = [
        "| variant | seeds | settled | median CPU-s (settled) "
        "| not settled: seed objective / bound | max load |",
        "|---|---|---|---|---|---|",
    ]
    for name, rs in by_variant.items():
        rs = sorted(rs, key=lambda r: int(r["seed"]))
        settled = [r for r in rs if r["status"] in _SETTLED]
        cpu = [float(r["cpu_s"]) for r in settled]
        median = f"{float(np.median(cpu)):.0f}" if cpu else "-"
        open_rows = ", ".join(
            f"{int(r['seed'])}: {_number(r['objective'])} / {_number(r['bound'])}"
            for r in rs
            if r["status"] not in _SETTLED
        )
        load = max(float(r["load_1min"]) for r in rs)
        lines.append(f"| {name} | {len(rs)} | {len(settled)} | {median} | {open_rows or '-'} | {load:.1f} |")
    return "\n".join(lines)


def _number(value: Any) -> str:
    """A row's objective or bound as printed: an integer without decimals, '-' when missing."""
    if value is None or value != value:
        return "-"
    v = float(value)
    return f"{v:.0f}" if v.is_integer() else f"{v:.1f}"
