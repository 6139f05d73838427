"""The cells variants measured at Table 4.2 scale: time to proof of each variant, the fleet size
against the coverage share, and the myopic-against-joint gap for moving users.

``droneplan bench cells --variants`` runs :func:`bench_variants` (``--quick``: one seed, m = 2,
60 s a row). The variant instances are the Table 4.2 instance of each seed with:

- ``weighted``: an integer demand of 1-5 per user, drawn with the seed + 1000;
- ``nofly``: a 2 km x 3 km no-fly zone east of the GBS, [1.5, 3.5] x [-1.5, 1.5] km;
- ``capacity``: 20 users per drone-cell;
- ``3d``: altitude levels 200 and 400 m with the default :class:`AirToGround` channel
  (R(h) = 402 and 605 m);
- ``mobile``: T epochs, each user drifting by a velocity drawn per user (N(0, 1.5 m/s) per axis)
  for 60 s an epoch, drone-cells moving at most 300 m between epochs;
- ``min-fleet``: the fewest drone-cells (at most ``m``) covering 10 %, 20 % and 30 % of the users.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
from shapely.geometry import box

from droneplan.formulations.cells import MobileProblem, min_fleet, myopic, solve_exact, solve_mobile
from droneplan.scenarios.air_to_ground import AirToGround
from droneplan.scenarios.cells import CellProblem, thesis_problem
from droneplan.studies.common import measured

__all__ = ["VARIANTS", "variant_problem", "bench_variants"]

VARIANTS = ("weighted", "nofly", "capacity", "3d")
"""The single-epoch variants :func:`bench_variants` proves."""

EPOCH_S = 60.0
"""Seconds between the epochs of the moving-users rows."""

MAX_MOVE = 300.0
"""Metres a drone-cell moves at most between epochs in the moving-users rows."""


def variant_problem(name: str, m: int, seed: int) -> CellProblem:
    """The Table 4.2 instance of ``seed`` with ``m`` drone-cells and the variant ``name`` (module
    docstring)."""
    base = thesis_problem(m, seed)
    extra: dict[str, Any]
    if name == "weighted":
        extra = {"weights": np.random.default_rng(seed + 1000).integers(1, 6, len(base.users)).astype(float)}
    elif name == "nofly":
        extra = {"no_fly": [box(1500.0, -1500.0, 3500.0, 1500.0)]}
    elif name == "capacity":
        extra = {"capacity": 20}
    elif name == "3d":
        extra = {"altitudes": [200.0, 400.0], "channel": AirToGround()}
    else:
        raise ValueError(f"variant must be one of {VARIANTS}, got {name!r}")
    return base.with_cells(m)._replace(**extra)


def mobile_problem(m: int, seed: int, epochs: int) -> MobileProblem:
    """The moving-users instance of ``seed`` (module docstring)."""
    base = thesis_problem(m, seed)
    velocity = np.random.default_rng(seed + 2000).normal(0.0, 1.5, size=base.users.shape)
    snapshots = np.stack([base.users + velocity * EPOCH_S * t for t in range(epochs)])
    return MobileProblem(base, snapshots, MAX_MOVE)


def bench_variants(
    *, seeds: list[int], m: int, time_limit: float, out: Path, epochs: int = 6
) -> list[dict[str, Any]]:
    """Run the variant rows (module docstring) and write them to ``out/bench_variants.csv``;
    returns them. Each row: variant, seed, m, status, objective, bound, wall_s, cpu_s, load_1min."""
    import pandas as pd

    rows = []
    for seed in seeds:
        for name in VARIANTS:
            problem = variant_problem(name, m, seed)
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
