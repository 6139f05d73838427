"""Covert observation (thesis ch. 3): the gap study over random target groups.

Per random target group, hover / sliding / MPC / safeguarded MPC maximum recorded bearing change,
the exact instantaneous optimum on the sphere at every control instant
(:func:`formulations.covert.sphere_minmax_bearing`, a convex program) as a lower bound for any
controller that keeps the sphere during the observation, and the whole-mission lower bound
(:func:`formulations.covert_bounds.mission_lower_bound`) for any controller arriving by the
sliding mode's arrival time. ``droneplan gap covert`` runs :func:`gap`, an open study
(:func:`droneplan.studies.study.gap`) of the registered controllers and the bound engine
:func:`onsphere_bounds`: every (group, method) is a job of its own with a time limit.
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

import numpy as np

from droneplan.planners.covert import SlidingModeObserver
from droneplan.scenarios.covert import simulate
from droneplan.studies.common import ComparisonTable, report_study
from droneplan.studies.covert import DEG, _instant_optima, _on_sphere

__all__ = [
    "GAP_THESIS",
    "MISSION_BOUND_CLASS",
    "gap",
    "gap_instances",
    "onsphere_bounds",
]


GAP_THESIS = {("covert", "sliding"): "-28.9 % / -33.1 % vs hover (cases 1, 2; Figs. 3.10, 3.14)"}


def onsphere_bounds(scenario: Any, *, seed: int = 0) -> dict[str, Any]:
    """The covert bound engine (registered as ``onsphere-optimum``): the proven per-instant optimum
    on the sphere along the sliding mode's run, and the whole-mission lower bound of its class.

    scenario: a covert scenario; seed: the noise seed of the sliding-mode run. Returns the engine
    result of :mod:`droneplan.studies.methods` (deg): ``bound`` = max over every control instant of
    the sliding run's on-sphere phase of the certified lower bound on min over the sphere of
    max_j beta_j (kind ``instantaneous``: a bound for any controller on the sphere at those
    instants); extras ``mission_bound_deg`` (kind named in ``mission_bound_class``: only for
    controllers on the sphere from the sliding mode's arrival t_a to its departure t_f and home by
    its end, so it is not ranked as a bound of the instance), the sliding run's own on-sphere
    maximum ``sliding_onsphere_max_deg`` (>= bound), and the instants solved.
    """
    sl = simulate(scenario, SlidingModeObserver(), seed=seed)
    t0 = time.process_time()
    ks, lbs, _ = _instant_optima(sl, scenario)
    extras: dict[str, Any] = {"instants": int(ks.size), "oracle_cpu_s": time.process_time() - t0}
    on = _on_sphere(sl)
    extras["sliding_onsphere_max_deg"] = float(np.nanmax(sl.beta_m[on])) * DEG if on.any() else None
    extras["mission_bound_deg"] = _mission_bound(scenario, sl)
    extras["mission_bound_class"] = MISSION_BOUND_CLASS
    if not ks.size:
        return {
            "status": "no_solution",
            "bound": None,
            "message": "the sliding run never reached the sphere: no instant to bound",
            "extras": extras,
        }
    return {
        "status": "optimal",
        "bound": float(lbs.max()) * DEG,
        "bound_kind": "instantaneous",
        "message": "max over every control instant of sliding's on-sphere phase of the exact min over the "
        "sphere of max_j beta_j (convex program): a bound for controllers on the sphere at those instants",
        "extras": extras,
    }


MISSION_BOUND_CLASS = "sliding-class: on the sphere from the sliding mode's t_a to its t_f, home by its end"
"""What the whole-mission lower bound of a covert row's ``mission_bound_deg`` holds for."""


def _mission_bound(scenario: Any, sl: Any) -> float | None:
    """The whole-mission lower bound (deg) of the sliding mode's class, or None."""
    if sl.t_a is None or sl.t_f is None:
        return None
    from droneplan.formulations.covert_bounds import mission_lower_bound

    times = np.arange(0.0, sl.t[-1] + 1e-9, 0.5)
    mb = mission_lower_bound(scenario, sl.t_a, sl.t_f, t_end=float(sl.t[-1]), times=times)
    return mb.value * DEG if np.isfinite(mb.value) else None


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
