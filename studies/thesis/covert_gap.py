"""Covert observation (thesis ch. 3): the gap study over random target groups.

Per random target group, hover / sliding / MPC / safeguarded MPC maximum recorded bearing change,
the exact instantaneous optimum on the sphere at every control instant
(:func:`formulations.covert.sphere_minmax_bearing`, a convex program) as a lower bound for any
controller that keeps the sphere during the observation, and the whole-mission lower bound
(:func:`formulations.covert_bounds.mission_lower_bound`) for any controller arriving by the
sliding mode's arrival time. ``droneplan gap covert`` runs :func:`gap`, an open study
(:func:`droneplan.studies.study.gap`) of the registered controllers and the bound engine
:func:`~droneplan.studies.bound_engines.onsphere_bounds` (defined there, below the method
registry, and imported here): every (group, method) is a job of its own with a time limit.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from droneplan.studies.bound_engines import MISSION_BOUND_CLASS, onsphere_bounds
from droneplan.studies.common import ComparisonTable, report_study

__all__ = [
    "GAP_THESIS",
    "MISSION_BOUND_CLASS",
    "gap",
    "gap_instances",
    "onsphere_bounds",
]


GAP_THESIS = {("covert", "sliding"): "-28.9 % / -33.1 % vs hover (cases 1, 2; Figs. 3.10, 3.14)"}


def gap_instances(seeds: int, first_seed: int = 0) -> list[Any]:
    """The covert gap's random target groups: seed s has 2 + s % 5 targets (``random-group`` family).

    seeds: number of groups; first_seed: seed of the first (seeds first_seed .. first_seed + seeds - 1).
    """
    from droneplan.studies.instances import family_instances

    return [
        inst
        for s in range(first_seed, first_seed + seeds)
        for inst in family_instances("random-group", n_targets=2 + s % 5, seeds=[s])
    ]


def gap(*, seeds: int, executor=None, out: Path, store=None, first_seed: int = 0):
    """Sliding mode vs MPC vs hover over random target groups (2-6 targets), with the on-sphere bound:
    an open study (:func:`droneplan.studies.study.gap`) of the covert run's default methods.

    seeds: number of groups; executor: where the jobs run (from ``make_executor``; default: one per
    core); out: directory for the summary and figure; store: the results store (default
    ``out/results.sqlite``). Returns the rows.
    first_seed: seed of the first instance (instances first_seed .. first_seed + seeds - 1).
    """
    from droneplan.studies.study import gap as open_gap

    out = Path(out)
    df = open_gap(
        "covert",
        instances=gap_instances(seeds, first_seed),
        out=out,
        store=store,
        executor=executor,
    )
    report_study(df, out, "covert", thesis=GAP_THESIS, title="covert: max recorded bearing change (deg)")
    obj = df.pivot(index="instance", columns="method", values="objective")
    tab = ComparisonTable(f"Covert gap over {len(obj)} random target groups (2-6 targets)")
    if {"hover", "sliding", "mpc", "mpc-safeguarded"} <= set(obj.columns):
        tab.add(
            "median sliding vs hover (%)",
            "-28.9 / -33.1 (cases 1, 2)",
            float((100 * (obj.sliding - obj.hover) / obj.hover).median()),
            "(sliding - hover) / hover",
        )
        tab.add(
            "median MPC vs sliding (%)",
            None,
            float((100 * (obj.mpc - obj.sliding) / obj.sliding).median()),
            "(MPC - sliding) / sliding",
        )
        tab.add(
            "groups where MPC <= sliding",
            None,
            f"{int((obj.mpc <= obj.sliding).sum())}/{len(obj)}",
            "max recorded beta",
        )
        safe = obj["mpc-safeguarded"]
        tab.add(
            "groups where safeguarded MPC <= sliding",
            None,
            f"{int((safe <= obj.sliding).sum())}/{len(obj)}",
            "max recorded beta",
        )
    tab.emit(out, "gap_table")
    return df
