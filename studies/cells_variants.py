"""The cells variants measured at Table 4.2 scale: time to proof of each variant, the fleet size
against the coverage share, and the myopic-against-joint gap for moving users.

``droneplan bench cells --variants`` runs :func:`bench_variants` (``--quick``: one seed, m = 2,
60 s a row). The variant instances are those of the library families ``table4.2-<variant>``
(:mod:`droneplan.scenarios.cell_variants`: demand weights, a no-fly zone, a capacity, altitude
levels), moving users drifting over T epochs (the smaller world of ``table4.2-mobile``), and
``min-fleet``: the fewest drone-cells (at most ``m``) covering 10 %, 20 % and 30 % of the users.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

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

__all__ = ["mobile_problem", "bench_variants"]


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
    returns them. Each row: variant, seed, m, status, objective, bound, wall_s, cpu_s, load_1min."""
    import pandas as pd

    rows = []
    for seed in seeds:
        for name in VARIANTS:
            problem = thesis_variant_problem(name, m, seed)
            with measured() as run:
                res = solve_exact(problem, time_limit=time_limit)
            rows.append(_result_row(name, seed, m, res, run))
        for share in (0.1, 0.2, 0.3):
            with measured() as run:
                res = min_fleet(thesis_problem(m, seed), coverage=share, time_limit=time_limit)
            rows.append({**_result_row(f"min-fleet {share:.0%}", seed, m, res, run), "share": share})
        mp = mobile_problem(m, seed, epochs)
        for name, solve in (("mobile joint", solve_mobile), ("mobile myopic", myopic)):
            with measured() as run:
                res = solve(mp, time_limit=time_limit)
            rows.append({**_result_row(name, seed, m, res, run), "epochs": epochs})
    Path(out).mkdir(parents=True, exist_ok=True)
    pd.DataFrame(rows).to_csv(Path(out) / "bench_variants.csv", index=False)
    return rows


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
