"""Covert observation (thesis ch. 3): the gap study over random target groups.

Per random target group, hover / sliding / MPC / safeguarded MPC maximum recorded bearing change,
the exact instantaneous optimum on the sphere at every control instant
(:func:`formulations.covert.sphere_minmax_bearing`, a convex program) as a lower bound for any
controller that keeps the sphere during the observation, and the whole-mission lower bound
(:func:`formulations.covert_bounds.mission_lower_bound`) for any controller arriving by the
sliding mode's arrival time. ``droneplan gap covert`` runs :func:`gap`.
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from droneplan.planners.covert import (
    HoverBenchmark,
    MPCObserver,
    MPCObserverSettings,
    SafeguardedMPCObserver,
    SlidingModeObserver,
)
from droneplan.scenarios.covert import random_case, simulate
from droneplan.studies.common import ComparisonTable, map_rows, open_store, report_study
from droneplan.studies.covert import DEG, ORACLE_COST, ORACLE_PARTS, _instant_optima, _on_sphere
from droneplan.studies.jobs import Job, run_jobs
from droneplan.studies.store import Outcome, build_rows, instance_id

__all__ = [
    "GAP_THESIS",
    "GAP_COST",
    "MISSION_BOUND_CLASS",
    "gap_task",
    "gap_jobs",
    "gap",
    "gap_instances",
    "onsphere_bounds",
]


def _controllers(backend: str = "ipopt") -> dict:
    return {
        "hover": HoverBenchmark(),
        "sliding": SlidingModeObserver(),
        "mpc": MPCObserver(observer=MPCObserverSettings(backend=backend)),
    }


GAP_THESIS = {("covert", "sliding"): "-28.9 % / -33.1 % vs hover (cases 1, 2; Figs. 3.10, 3.14)"}


_GAP_ROLES = {"hover": "heuristic", "sliding": "heuristic", "mpc": "model", "mpc-safeguarded": "model"}


def _gap_controller(name: str):
    return SafeguardedMPCObserver() if name == "mpc-safeguarded" else _controllers()[name]


def _gap_run(task: Mapping[str, Any], method: str) -> dict[str, Any]:
    """One method's closed-loop run on a gap instance: its trace, wall time (s) and the extras of
    its row."""
    sc = random_case(int(task["n_targets"]), int(task["seed"]))
    ctl = _gap_controller(method)
    t0 = time.perf_counter()
    tr = simulate(sc, ctl)
    elapsed = time.perf_counter() - t0
    extras: dict[str, Any] = {"t_a_s": tr.t_a, "fallbacks": int(getattr(tr, "fallbacks", 0) or 0)}
    if method == "mpc":
        extras["predicted_max_deg"] = max(ctl.predicted_beta) * DEG if ctl.predicted_beta else None
        extras["solve_median_s"] = float(np.median(tr.solve_times)) if tr.solve_times.size else None
    if method == "sliding":
        on = _on_sphere(tr)
        extras["onsphere_max_deg"] = float(np.nanmax(tr.beta_m[on])) * DEG if on.any() else None
    # the MPCs take the sliding-mode rollout as the start of their first solve (and after a failure)
    starts = list(getattr(ctl, "starts", []))
    if method.startswith("mpc"):
        extras["starts_sliding_rollout"] = starts.count("sliding-rollout")
    return {"trace": tr, "time_s": elapsed, "extras": extras, "warm": "sliding-rollout" in starts}


def _gap_oracle_part(task: Mapping[str, Any], part: int, parts: int, sliding: dict) -> tuple:
    """One slice of the per-instant on-sphere oracle of the sliding run, with its wall time (s)."""
    t0 = time.perf_counter()
    sc = random_case(int(task["n_targets"]), int(task["seed"]))
    found = _instant_optima(sliding["trace"], sc, part, parts)
    return (*found, time.perf_counter() - t0)


def _gap_mission(task: Mapping[str, Any], sliding: dict) -> float | None:
    """The whole-mission lower bound (deg) of the sliding mode's class, or None."""
    sl = sliding["trace"]
    if sl.t_a is None or sl.t_f is None:
        return None
    from droneplan.formulations.covert_bounds import mission_lower_bound

    sc = random_case(int(task["n_targets"]), int(task["seed"]))
    times = np.arange(0.0, sl.t[-1] + 1e-9, 0.5)
    mb = mission_lower_bound(sc, sl.t_a, sl.t_f, t_end=float(sl.t[-1]), times=times)
    return mb.value * DEG if np.isfinite(mb.value) else None


def _gap_rows(task: Mapping[str, Any], runs: Mapping[str, dict], slices: list[tuple], mission) -> list[dict]:
    """The rows of one gap instance from its runs, oracle slices and mission bound."""
    outcomes = []
    for name, r in runs.items():
        extras = dict(r["extras"])
        if name == "sliding" and mission is not False:
            # a bound for the sliding mode's class only (on the sphere from its t_a to its t_f, home by
            # its end): kept as an extra of its row, not as a bound row for every method of the instance
            extras["mission_bound_deg"] = mission
        outcomes.append(
            Outcome(
                name,
                _GAP_ROLES[name],
                "feasible",
                objective=r["trace"].beta_max * DEG,
                time_s=r["time_s"],
                warm_started=name.startswith("mpc") and r["warm"],
                message="closed-loop simulate(); beta_max over the whole run",
                extras=extras,
            )
        )
    lbs = np.concatenate([v[1] for v in slices])
    outcomes.append(
        Outcome(
            "onsphere-optimum",
            "bound",
            "optimal",
            bound=float(lbs.max()) * DEG if lbs.size else math.nan,
            bound_kind="instantaneous",
            time_s=float(sum(v[3] for v in slices)),
            message="max over every control instant of sliding's on-sphere phase of the exact min "
            "over the sphere of max_j beta_j (convex program): a bound for controllers "
            "on the sphere at those instants",
        )
    )
    return build_rows(
        "covert",
        task["instance"],
        seed=int(task["seed"]),
        size=int(task["n_targets"]),
        sense="min",
        outcomes=outcomes,
    )


def gap_task(task: Mapping[str, Any]) -> list[dict]:
    """One random target group in the results schema: hover, sliding mode, MPC and safeguarded
    MPC (objective = max recorded bearing change beta_max, deg, minimised) and the proven
    on-sphere instantaneous optimum as a bound (:func:`gap` runs the same steps as separate jobs)."""
    runs = {name: _gap_run(task, name) for name in _GAP_ROLES}
    slices = [_gap_oracle_part(task, part, ORACLE_PARTS, runs["sliding"]) for part in range(ORACLE_PARTS)]
    mission = _gap_mission(task, runs["sliding"])
    return _gap_rows(task, runs, slices, False if mission is None else mission)


def _gap_join(task: Mapping[str, Any], mission: float | None, **parts: Any) -> list[dict]:
    runs = {name: parts[name.replace("-", "_")] for name in _GAP_ROLES}
    slices = [v for k, v in sorted(parts.items()) if k.startswith("oracle")]
    return _gap_rows(task, runs, slices, False if mission is None else mission)


GAP_COST = {"hover": 0.5, "sliding": 1.0, "mpc": 20.0, "mpc-safeguarded": 25.0}
"""Estimated CPU seconds of one gap run per method (the scheduler starts long chains first)."""


def gap_jobs(tasks: list[dict[str, Any]]) -> list[Job]:
    """The covert gap as jobs: per instance one job per method's run, the per-instant oracle in
    ``ORACLE_PARTS`` slices and the mission bound on the sliding run, and a store task joining them
    into :func:`gap_task`'s rows."""
    jobs: list[Job] = []
    for t in tasks:
        key = f"covert/{t['instance']}"
        needs = {}
        for name in _GAP_ROLES:
            needs[name.replace("-", "_")] = k = f"{key}/{name}"
            jobs.append(Job(k, "covert gap", _gap_run, {"task": t, "method": name}, cost=GAP_COST[name]))
        sliding = {"sliding": f"{key}/sliding"}
        for part in range(ORACLE_PARTS):
            needs[f"oracle{part}"] = k = f"{key}/oracle/{part}"
            kwargs = {"task": t, "part": part, "parts": ORACLE_PARTS}
            jobs.append(
                Job(k, "covert gap", _gap_oracle_part, kwargs, sliding, cost=ORACLE_COST / ORACLE_PARTS)
            )
        needs["mission"] = k = f"{key}/mission"
        jobs.append(Job(k, "covert gap", _gap_mission, {"task": t}, sliding, cost=5.0))
        jobs.append(Job(key, "covert gap", _gap_join, {"task": t}, needs, cost=0.01, task=t))
    return jobs


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


def _old_gap(*, seeds: int, executor, out: Path, store=None, first_seed: int = 0):
    """Sliding mode vs MPC vs hover over random target groups (2-6 targets), with the on-sphere bound.

    seeds: number of groups; executor: from ``make_executor``; out: directory for the summary
    and figure; store: the results store (default ``out/results.sqlite``). Returns the rows.
    first_seed: seed of the first instance (instances first_seed .. first_seed + seeds - 1).
    """
    out = Path(out)
    tasks = [
        {
            "problem": "covert",
            "instance": instance_id("gap", n_targets=2 + s % 5, seed=s),
            "seed": s,
            "n_targets": 2 + s % 5,
            "size": 2 + s % 5,
        }
        for s in range(first_seed, first_seed + seeds)
    ]
    with open_store(store, out) as st:
        run_jobs(gap_jobs(tasks), executor=executor, store=st, progress=False)
        df = map_rows(gap_task, tasks, executor=executor, store=st, desc="covert gap")  # reads the rows
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
