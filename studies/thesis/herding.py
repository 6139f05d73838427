"""Herding with barking drones (thesis ch. 6): reproduction, allocation gap and benchmarks.

`droneplan reproduce herding` — Fig. 6.7 (footprint radius vs time, 200 and 1000 animals,
proposed vs benchmark; gathering/total times beside the thesis), snapshots like Fig. 6.7(b-f),
and the sweeps of Figs. 6.8-6.10 (field size, n_d, V_max, V_animal, R_b, d_s) in reduced form.
`droneplan gap herding` — steering-point allocation: thesis Algorithm 3 (the benchmark
allocator), CP-SAT and the collision-blind bottleneck against the exact O(n^2) optimum.
`droneplan bench herding` — exact allocation at n = 64, Algorithm 3 / exact at n = 7,
simulated seconds per CPU second of whole runs (1000 animals to delivery, the first seconds at
10^5 animals) and of 60 s of gathering, proposed vs benchmark gathering.
"""

from __future__ import annotations

import contextlib
import dataclasses
import functools
import json
import os
import subprocess
import sys
import time
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd

from droneplan.core.deprecation import deprecated_names
from droneplan.formulations.herding import solve_allocation
from droneplan.planners.herding import (
    BenchmarkHerder,
    ProposedHerder,
    allocate_bruteforce,
)
from droneplan.scenarios.herding import (
    HerdingFrame,
    HerdingParams,
    HerdingPhase,
    HerdingTrace,
    simulate,
    table_6_2_for,
    thesis_scenario,
)
from droneplan.studies.common import (
    ComparisonTable,
    load_average,
    make_executor,
    measured,
    report_study,
    timed,
)
from droneplan.studies.common import open_store as _store
from droneplan.studies.instances import random_allocation_instance
from droneplan.studies.jobs import Job, map_rows, run_reproduction
from droneplan.studies.plots.herding import animate, plot_state
from droneplan.studies.store import Outcome, ResultStore, build_rows, instance_id
from droneplan.studies.thesis.report import flag_reasons

__all__ = [
    "FIG_6_7",
    "SWEEPS",
    "run_once",
    "run_pair",
    "reproduce",
    "reproduce_jobs",
    "random_allocation_instance",
    "GAP_SIZES",
    "GAP_THESIS",
    "GAP_METHODS",
    "gap",
    "bench",
    "write_gif",
    "animate",
    "run_times_table",
]

FIG_6_7 = {
    200: {"gather": 11.1, "total": 15.0, "bench_extra": 3.3},
    1000: {"gather": 10.1, "total": 18.2, "bench_extra": 4.1},
}
"""Thesis §6.5 (Fig. 6.7a): proposed gathering / total time (min) and the benchmark's extra minutes."""

SWEEPS = {
    # name: (parameter, full values, quick values, thesis statement, scenario keyword); the quick
    # values show each statement with the fewest runs: both ends, and the middle where the thesis
    # finds an optimum there; the set-up's own value (n_d = 4, V_max = 25, R_b = 100, d_s = 30) is
    # one run shared by every sweep it appears in
    "field": (
        "square field side (m)",
        [400, 800, 1200],
        [400, 1000],
        "Fig 6.8a: gathering time grows strongly with the field side; benchmark more sensitive",
        "field",
    ),
    "n_drones": (
        "n_d",
        [2, 3, 4, 6, 8],
        [2, 4],
        "Fig 6.8b: gathering time falls with n_d; gap grows for n_d >= 4",
        "n_drones",
    ),
    "V_max": (
        "V_max (m/s)",
        [10, 15, 25, 35],
        [10, 25],
        "Fig 6.9a: slower drones gather slower; benchmark fails for V_max <= 10",
        "V_max",
    ),
    "V_animal": (
        "V_animal (m/s)",
        [2, 3, 4, 5],
        [2, 5],
        "Fig 6.9b: proposed 14.7 -> 9.1 min, benchmark 20.8 -> 12.7 min for V_animal 2 -> 5",
        "V_animal",
    ),
    "R_b": ("R_b (m)", [60, 100, 140], [60, 100, 140], "Fig 6.10a: fastest near R_b = 100 m", "R_b"),
    "d_s": ("d_s (m)", [10, 30, 50], [10, 30, 50], "Fig 6.10b: fastest near d_s = 30 m", "d_s"),
}


def _workers() -> int:
    return max(1, min(2, os.cpu_count() or 1))


# --------------------------------------------------------------------------- one run
def run_once(task: dict) -> dict:
    """One closed-loop run (module-level so process pools can pickle it).

    task keys: n (animals), seed, method ("proposed"/"benchmark"), t_max (s), and optionally
    field (square side, m), params (dict of HerdingParams overrides), n_drones,
    gather_only (bool), snapshots (list of s), curve_every (s).
    """
    return _run_traced(task)[0]


def _run_traced(task: Mapping[str, Any], frame_every: float | None = None) -> tuple[dict, HerdingTrace]:
    """:func:`run_once`'s record and the run's trace (with a frame every ``frame_every`` s, if
    given: recording frames does not change the run)."""
    kw = dict(task.get("params", {}))
    n_drones = int(task.get("n_drones", 4))
    field = task.get("field")
    size = (float(field), float(field)) if field else (1200.0, 600.0)
    sc = thesis_scenario(int(task["n"]), seed=int(task["seed"]), field_size=size, n_drones=n_drones, **kw)
    herder = ProposedHerder() if task["method"] == "proposed" else BenchmarkHerder()
    c0 = time.process_time()
    tr = simulate(
        sc,
        herder,
        t_max=float(task["t_max"]),
        seed=int(task["seed"]) + 10_000,
        snapshot_times=task.get("snapshots", ()),
        stop_after_gathering=bool(task.get("gather_only")),
        frame_every=frame_every,
    )
    cpu = time.process_time() - c0
    every = max(1, round(float(task.get("curve_every", 5.0)) / sc.params.delta))
    hull_t = herder.all_on_hull_time
    record = {
        **{k: task[k] for k in task if k not in ("params", "snapshots")},
        "params": json.dumps(kw, sort_keys=True),
        "gather_time": tr.gather_time,
        "total_time": tr.total_time,
        "on_hull_time": hull_t,
        "gather_after_hull": (tr.gather_time - hull_t)
        if (tr.gather_time is not None and hull_t is not None)
        else None,
        "sim_time": float(tr.t[-1]),
        "wall_time": tr.wall_time,
        "cpu_time": cpu,
        "max_animal_speed": tr.max_animal_speed,
        "R_c": sc.params.R_c,
        "curve_t": tr.t[::every],
        "curve_r": tr.footprint_radius[::every],
        "snapshots": {float(k): f for k, f in tr.snapshots.items()},
        "goal": tuple(float(g) for g in sc.goal),
        "n_crossing_allocations": herder.n_crossing_allocations,
    }
    return record, tr


def _mean(values) -> float | None:
    vals = [v for v in values if v is not None and np.isfinite(v)]
    return float(np.mean(vals)) if vals else None


def _minutes(v) -> float | None:
    return None if v is None else v / 60.0


# --------------------------------------------------------------------------- reproduce
def run_pair(task: Mapping[str, Any]) -> list[dict]:
    """One reproduce instance: the proposed and the benchmark herder on the same scenario,
    as two rows of the results schema (objective = total time for Fig. 6.7, gathering time
    for the sweeps, s; status ``no_solution`` when the run did not finish within t_max).
    Every field of :func:`run_once` is kept as a ``herding_<name>`` extra."""
    return _pair_rows(task, {m: _method_run(task, m) for m in ("proposed", "benchmark")})


def _method_run(task: Mapping[str, Any], method: str, frame_every: float | None = None):
    """:func:`run_once` of one herder on a reproduce task's scenario; with ``frame_every`` (s),
    ``(record, trace with frames)`` so an animation can reuse the run."""
    record, trace = _run_traced(
        {**{k: v for k, v in task.items() if k not in ("problem", "instance")}, "method": method}, frame_every
    )
    return record if frame_every is None else (record, trace)


def _pair_job(task: Mapping[str, Any], proposed, benchmark) -> list[dict]:
    """:func:`run_pair`'s rows from the two runs made as separate jobs (a run given as
    ``(record, trace)`` counts by its record)."""
    runs = {"proposed": proposed, "benchmark": benchmark}
    return _pair_rows(task, {m: r[0] if isinstance(r, tuple) else r for m, r in runs.items()})


def _pair_rows(task: Mapping[str, Any], runs: Mapping[str, dict]) -> list[dict]:
    """The two result-schema rows of a reproduce task from its runs by method."""
    rows = []
    for method, r in runs.items():
        objective = r["gather_time"] if task.get("gather_only") else r["total_time"]
        extras = {k: v for k, v in r.items() if k not in ("method",)}
        extras["snapshots"] = {
            str(t): {
                "t": f.t,
                "animals": f.animals,
                "drones": f.drones,
                "headings": f.headings,
                "phase": f.phase.name,
            }
            for t, f in r["snapshots"].items()
        }
        rows.append(
            Outcome(
                method,
                "heuristic",
                "feasible" if objective is not None else "no_solution",
                objective=objective,
                time_s=r["wall_time"],
                extras=extras,
                message="closed-loop simulate(); objective = "
                + ("gathering time" if task.get("gather_only") else "total time")
                + " (s)",
            )
        )
    return build_rows(
        "herding", task["instance"], seed=int(task["seed"]), size=int(task["n"]), sense="min", outcomes=rows
    )


def _run_records(df: pd.DataFrame) -> list[dict]:
    """The run_once records of reproduce rows (extras without their prefix, arrays restored)."""
    recs = []
    for _, row in df.iterrows():
        r = {k[len("herding_") :]: v for k, v in row.items() if k.startswith("herding_")}
        r = {k: (None if (isinstance(v, float) and np.isnan(v)) else v) for k, v in r.items()}
        r["method"], r["instance"] = row["method"], row["instance"]
        r["curve_t"], r["curve_r"] = np.asarray(r["curve_t"], float), np.asarray(r["curve_r"], float)
        r["snapshots"] = {
            float(t): HerdingFrame(
                t=float(f["t"]),
                animals=np.asarray(f["animals"], float),
                drones=np.asarray(f["drones"], float),
                headings=np.asarray(f["headings"], float),
                phase=HerdingPhase[f["phase"]],
            )
            for t, f in (r.get("snapshots") or {}).items()
        }
        r["goal"] = tuple(r["goal"]) if r.get("goal") is not None else None
        for k in ("n", "seed", "n_drones"):
            if r.get(k) is not None:
                r[k] = int(r[k])
        recs.append(r)
    return recs


def _run_all(tasks: list[dict], executor, store, desc: str) -> list[dict]:
    df = map_rows(run_pair, tasks, executor=executor, store=store, desc=desc)
    return _run_records(df)


def _seed_range(seconds, thesis: float) -> str:
    """Per-seed spread of ``seconds`` (s) in min, and whether the thesis's single run (``thesis``, min)
    lies inside it; ``""`` when no value is finite."""
    vals = [v / 60.0 for v in seconds if v is not None and np.isfinite(v)]
    if not vals:
        return ""
    if len(vals) == 1:
        return f"one seed: {vals[0]:.1f} min, no spread measured"
    lo, hi = min(vals), max(vals)
    where = "inside" if lo <= thesis <= hi else "outside"
    return f"per seed {lo:.1f} to {hi:.1f} min over {len(vals)} seeds, the thesis's {thesis:g} {where}"


def _fig_6_7_plan(quick: bool) -> dict[int, list[int]]:
    """Seeds per herd size of Fig. 6.7: quick, one run per herd size as in the thesis (one illustrative
    run each, §6.5); full, 20 seeds each for the spread the thesis does not give."""
    return {200: [0], 1000: [0]} if quick else {200: list(range(20)), 1000: list(range(20))}


def _fig_6_7_tasks(quick: bool) -> list[dict[str, Any]]:
    """The store tasks of Fig. 6.7 (seed-major: a partial run has both herd sizes)."""
    snaps = [0.0, 300.0, 480.0]
    tasks = [
        {
            "problem": "herding",
            "instance": instance_id("fig6.7", n=n, seed=s),
            "n": n,
            "seed": s,
            "t_max": 2700.0,
            "snapshots": snaps if (n == 1000 and s == 0) else [],
        }
        for n, seeds in _fig_6_7_plan(quick).items()
        for s in seeds
    ]
    tasks.sort(key=lambda t: (t["seed"], t["n"]))
    return tasks


def _fig_6_7_proposed(table: ComparisonTable, n: int, rs: list[dict]) -> None:
    """The proposed herder's Fig. 6.7 rows for ``n`` animals."""
    g = [r["gather_time"] for r in rs]
    tot = [r["total_time"] for r in rs]
    how = (
        f"mean over {len(rs)} seeds of simulate(); gathering ends when every animal is within "
        f"R_c = {rs[0]['R_c']:.0f} m of the centroid; "
        f"{sum(v is None for v in g)} runs did not gather within 45 min"
    )
    table.add(
        f"{n} animals: proposed gathering time (min)",
        FIG_6_7[n]["gather"],
        _minutes(_mean(g)),
        how,
        why=_seed_range(g, FIG_6_7[n]["gather"]),
    )
    table.add(
        f"{n} animals: proposed total time (min)",
        FIG_6_7[n]["total"],
        _minutes(_mean(tot)),
        "gathering + driving until every animal is within goal_radius = 50 m of G (900 m away), "
        "regathering first if the herd spreads beyond 1.5 R_c; the thesis does not state its end "
        "criterion (a centroid-at-G rule would count a split herd as delivered)",
        why=_seed_range(tot, FIG_6_7[n]["total"]),
    )


def _fig_6_7_benchmark(table: ComparisonTable, n: int, rs: list[dict], rows: list[dict]) -> None:
    """The benchmark-minus-proposed rows of Fig. 6.7 for ``n`` animals (paired by seed)."""
    prop = {r["seed"]: r for r in rows if r["n"] == n and r["method"] == "proposed"}
    both = [(b, prop[b["seed"]]) for b in rs if b["seed"] in prop]
    pairs = [
        (b["total_time"], p["total_time"])
        for b, p in both
        if b["total_time"] is not None and p["total_time"] is not None
    ]
    extra = _minutes(_mean([b - p for b, p in pairs])) if pairs else None
    table.add(
        f"{n} animals: benchmark minus proposed, total (min)",
        FIG_6_7[n]["bench_extra"],
        extra,
        f"paired by seed over {len(pairs)} seeds where both finished",
        why=_seed_range([b - p for b, p in pairs], FIG_6_7[n]["bench_extra"]),
    )
    gpairs = [
        (b["gather_time"], p["gather_time"])
        for b, p in both
        if b["gather_time"] is not None and p["gather_time"] is not None
    ]
    table.add(
        f"{n} animals: benchmark minus proposed, gathering (min)",
        "—",
        _minutes(_mean([b - p for b, p in gpairs])) if gpairs else None,
        f"paired by seed over {len(gpairs)} seeds",
    )


_RUN_COLUMNS = (
    "n",
    "seed",
    "method",
    "gather_time",
    "total_time",
    "on_hull_time",
    "wall_time",
    "max_animal_speed",
)


def _fig_6_7_footprint(out: Path, table: ComparisonTable, rows: list[dict], sizes) -> list[dict]:
    """Fig. 6.7a (mean footprint radius against time) and the table rows per size and method;
    returns the per-run CSV rows."""
    fig, ax = plt.subplots(figsize=(7, 4.5))
    csv_rows: list[dict[str, Any]] = []
    for n in sizes:
        for m, style in (("proposed", "-"), ("benchmark", "--")):
            rs = [r for r in rows if r["n"] == n and r["method"] == m]
            if m == "proposed":
                _fig_6_7_proposed(table, n, rs)
            else:
                _fig_6_7_benchmark(table, n, rs, rows)
            # mean footprint curve (runs end at different times: hold the last value)
            T = max(len(r["curve_r"]) for r in rs)
            curves = np.array([np.pad(r["curve_r"], (0, T - len(r["curve_r"])), mode="edge") for r in rs])
            t = max((r["curve_t"] for r in rs), key=len)
            ax.plot(t / 60.0, curves.mean(axis=0), style, label=f"{n} animals, {m}")
            csv_rows.extend({k: r[k] for k in _RUN_COLUMNS} for r in rs)
    ax.set_xlabel("t (min)")
    ax.set_ylabel("footprint radius (m)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    ax.set_title("Fig. 6.7a: animals' footprint radius vs time")
    fig.tight_layout()
    fig.savefig(out / "fig_6_7a_footprint.png", dpi=120)
    plt.close(fig)
    return csv_rows


def _fig_6_7_snapshots(out: Path, rows: list[dict]) -> None:
    """Fig. 6.7 b-f: the 1000-animal herd of seed 0 at 0, 5 and 8 min under both herders."""
    snap = {r["method"]: r["snapshots"] for r in rows if r["n"] == 1000 and r["seed"] == 0}
    fig, axes = plt.subplots(1, 5, figsize=(22, 4.5))
    panels = [
        ("proposed", 0.0, "(b) t = 0"),
        ("proposed", 300.0, "(c) 5 min, proposed"),
        ("proposed", 480.0, "(d) 8 min, proposed"),
        ("benchmark", 300.0, "(e) 5 min, benchmark"),
        ("benchmark", 480.0, "(f) 8 min, benchmark"),
    ]
    goal = next((r["goal"] for r in rows if r["n"] == 1000 and r["seed"] == 0), None)
    for a, (m, t, title) in zip(axes, panels, strict=True):  # 5 axes for 5 panels
        if t in snap.get(m, {}):
            plot_state(snap[m][t], goal=goal, ax=a, title=title)
        else:
            a.text(0.5, 0.5, "run ended before this time", ha="center", transform=a.transAxes)
            a.set_title(title)
            a.set_axis_off()
    fig.tight_layout()
    fig.savefig(out / "fig_6_7bf_snapshots.png", dpi=100)
    plt.close(fig)


def _fig_6_7(out: Path, quick: bool, executor, store) -> None:
    """Fig. 6.7: times beside the thesis, the footprint curves and the snapshots (CSV + PNG)."""
    rows = _run_all(_fig_6_7_tasks(quick), executor, store, "Fig. 6.7 runs")
    table = ComparisonTable(
        "Fig. 6.7: gathering and total herding time (4 drones, 1200 m x 600 m field)",
        explain=flag_reasons("herding"),
    )
    csv_rows = _fig_6_7_footprint(out, table, rows, _fig_6_7_plan(quick))
    prop_rows = [r for r in rows if r["method"] == "proposed"]
    table.add(
        "proposed runs: allocations that let drones pass each other",
        "0 (Theorem 6.4.1)",
        sum(r["n_crossing_allocations"] for r in prop_rows),
        f"every Delta-allocation of {len(prop_rows)} runs checked against (6.22)-(6.23)",
    )
    table.add(
        "max animal speed over all runs (m/s)",
        "V_animal = 4",
        max(r["max_animal_speed"] for r in rows),
        "largest per-step displacement / Delta",
    )
    pd.DataFrame(csv_rows).to_csv(out / "fig_6_7_runs.csv", index=False)
    table.emit(out, "fig_6_7")
    _fig_6_7_snapshots(out, rows)


def _sweep_task(name: str, key: str, value: Any, n: int, seed: int, t_max: float = 2400.0) -> dict[str, Any]:
    """The store task of one sweep point (``key``: the scenario keyword the sweep varies).

    The task holds only the settings that differ from the §6.5 set-up (:func:`_sweep_settings`), and
    its instance id names only those: the points of different sweeps that fall on the default
    scenario (n_d = 4, V_max = 25 m/s, V_animal = 4 m/s, R_b = 100 m, d_s = 30 m) are one task, run
    once per seed and herd size and shown in each of those sweeps.
    """
    field, n_drones, params = _sweep_settings(key, value, n)
    named: dict[str, Any] = dict(params)
    if field is not None:
        named["field"] = field
    if n_drones is not None:
        named["n_drones"] = n_drones
    t: dict[str, Any] = {
        "problem": "herding",
        "instance": instance_id("fig6.8-6.10", n=n, seed=seed, **named),
        "n": n,
        "seed": seed,
        "t_max": t_max,
        "gather_only": True,
        "curve_every": 30.0,
    }
    if field is not None:
        t["field"] = field
    if n_drones is not None:
        t["n_drones"] = n_drones
    if params:
        t["params"] = params
    return t


def _sweep_settings(key: str, value: Any, n: int) -> tuple[Any, int | None, dict[str, float]]:
    """(square field side or None, drone count or None, HerdingParams overrides) of a sweep point
    on ``n`` animals, each None or left out where it equals the thesis set-up's value."""
    if key == "field":
        return value, None, {}
    if key == "n_drones":
        return None, (None if int(value) == _DEFAULT_DRONES else int(value)), {}
    if key == "V_animal":  # keep V_driving <= V_animal and grazing <= V_animal valid
        params = {
            "V_animal": float(value),
            "V_driving": min(table_6_2_for(n)[1], float(value)),
            "graze_speed": min(1.0, float(value)),
        }
    else:
        params = {key: float(value)}
    defaults = _default_params(n)
    return None, None, {k: v for k, v in params.items() if v != defaults[k]}


_DEFAULT_DRONES = HerdingParams().n_drones


@functools.cache
def _default_params(n: int) -> dict[str, Any]:
    """The HerdingParams of :func:`thesis_scenario` on ``n`` animals, by field name."""
    return dataclasses.asdict(thesis_scenario(n, seed=0).params)


SWEEP_SEEDS = 20
"""Runs per sweep point in the full reproduction, as in the thesis (§6.5: "each simulation runs for 20
times")."""


def _sweep_sizes(quick: bool) -> list[int]:
    """Herd sizes of the Figs. 6.8-6.10 sweeps: 100 animals quick; 200 and 1000 full, as in the thesis."""
    return [100] if quick else [200, 1000]


def _sweep_tasks(quick: bool) -> list[dict[str, Any]]:
    """The store tasks of Figs. 6.8-6.10 (quick: 100 animals, 1 seed, the quick values of :data:`SWEEPS`;
    full: 200 and 1000 animals, :data:`SWEEP_SEEDS` seeds per point)."""
    seeds = range(1) if quick else range(SWEEP_SEEDS)
    tasks = (
        _sweep_task(name, key, value, n, s, _sweep_t_max(quick))
        for name, (_label, full, qv, _, key) in SWEEPS.items()
        for value in (qv if quick else full)
        for s in seeds
        for n in _sweep_sizes(quick)
    )
    return list({t["instance"]: t for t in tasks}.values())  # points on the default scenario: once


def _sweep_t_max(quick: bool) -> float:
    """Simulated time a sweep run may take to gather, s: 40 min full; 30 min quick, where every
    run that gathers does so within 28 min (the quick points' slowest, n_d = 2 with the benchmark)."""
    return 1800.0 if quick else 2400.0


def _sweeps(out: Path, quick: bool, executor, store) -> None:
    size_text = " and ".join(str(n) for n in _sweep_sizes(quick))
    seeds = 1 if quick else SWEEP_SEEDS
    tasks = _sweep_tasks(quick)
    rows = _run_all(tasks, executor, store, "Figs. 6.8-6.10 runs")
    table = ComparisonTable(
        f"Figs. 6.8-6.10 ({size_text} animals, {seeds} seed(s) per point): "
        "gathering time after the drones reach the hull (min)"
    )
    fig, axes = plt.subplots(2, 3, figsize=(13, 7))
    import pandas as pd

    flat: list[dict[str, Any]] = []
    by_run = {(r["instance"], r["method"]): r for r in rows}
    sizes = _sweep_sizes(quick)
    for a, (name, (label, full, qv, statement, key)) in zip(
        axes.flat, SWEEPS.items(), strict=True
    ):  # 2 x 3 axes, 6 sweeps
        values = qv if quick else full
        cells: dict[Any, list[str]] = {v: [] for v in values}
        for n_sw, (m, style) in [
            (n_sw, ms) for n_sw in sizes for ms in (("proposed", "o-"), ("benchmark", "s--"))
        ]:
            ys = []
            for v in values:
                runs = (by_run.get((_sweep_task(name, key, v, n_sw, s)["instance"], m)) for s in range(seeds))
                rs = [r for r in runs if r is not None]
                g = [r["gather_after_hull"] for r in rs]
                ys.append(_minutes(_mean(g)))
                fails = sum(x is None for x in g)
                tag = m[0] if len(sizes) == 1 else f"{m[0]}{n_sw}"
                cells[v].append(f"{tag} {'—' if ys[-1] is None else f'{ys[-1]:.1f}'}{'*' * fails}")
                flat.extend(
                    {
                        "sweep": name,
                        "value": v,
                        "n": n_sw,
                        "method": m,
                        "seed": r["seed"],
                        "gather_after_hull": r["gather_after_hull"],
                        "gather_time": r["gather_time"],
                    }
                    for r in rs
                )
            a.plot(
                values,
                [np.nan if y is None else y for y in ys],
                style,
                label=m if len(sizes) == 1 else f"{m}, {n_sw} animals",
            )
        a.set_xlabel(label if "(" in label else f"{label} (count)")
        a.set_ylabel("gathering time after reaching the hull (min)")
        a.grid(alpha=0.3)
        a.legend(fontsize=7)
        table.add(
            label,
            statement,
            "; ".join(f"{v}: {' / '.join(c)}" for v, c in cells.items()),
            "value: p = proposed / b = benchmark mean; * = a run that did not gather in "
            f"{_sweep_t_max(quick) / 60:g} min",
        )
    fig.suptitle(
        f"Figs. 6.8-6.10 ({size_text} animals, {seeds} seed(s) per point"
        f"{', reduced sweeps' if quick else ''})"
    )
    fig.tight_layout()
    fig.savefig(out / "fig_6_8_to_6_10_sweeps.png", dpi=110)
    plt.close(fig)
    pd.DataFrame(flat).to_csv(out / "sweeps_runs.csv", index=False)
    table.emit(out, "fig_6_8_to_6_10")


def reproduce(*, quick: bool, out: Path, executor=None, store: ResultStore | None = None) -> None:
    """Fig. 6.7 (footprint, times, snapshots; 20 seeds at 200 and 1000 animals) and the Figs.
    6.8-6.10 sweeps (200 and 1000 animals, 20 seeds per point); CSV + PNG in ``out``.

    quick: one seed per herd size for Fig. 6.7 and reduced sweeps at 100 animals. executor: from
    ``make_executor`` (default: up to 2 local processes); store: the results store every
    run is written to as it finishes (default ``out/results.sqlite``), so a rerun resumes.
    """
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    with contextlib.ExitStack() as stack:
        ex = executor or stack.enter_context(make_executor(_workers()))
        st = stack.enter_context(_store(store, out))
        run_reproduction(reproduce_jobs(quick=quick, out=out, store_path=st.path), executor=ex, store=st)


def _from_store(step, out: Path, quick: bool, store_path: Path) -> None:
    """Run a figure step (``_fig_6_7`` or ``_sweeps``) on the rows already in the store."""
    with make_executor(1) as ex, ResultStore(store_path) as st:
        step(out, quick, ex, st)


def _run_cost(task: Mapping[str, Any], method: str = "proposed") -> float:
    """Estimated CPU seconds of one herder's run of a task (the scheduler starts long ones first)."""
    n = max(1, int(task["n"]))  # a bad size fails in its run, with a clear message
    per_sim_s = 0.004 * (n / 100.0) ** 0.8  # CPU s per simulated s, roughly
    horizon = 900.0 if task.get("gather_only") else float(task["t_max"]) / 2.0
    return per_sim_s * horizon * (1.3 if method == "benchmark" else 1.0)


def _pair_jobs(
    tasks: list[dict[str, Any]], section: str, frames: Mapping[str, float] | None = None
) -> list[Job]:
    """Per task: one job per herder and a store task joining them into :func:`run_pair`'s rows.
    frames: {instance: s}: the proposed run of that instance also keeps a frame every s seconds
    (its job returns ``(record, trace)``, for an animation)."""
    jobs = []
    for t in tasks:
        key = f"herding/{t['instance']}"
        runs = {}
        # both herders' runs of a scenario get the pair's mean estimate, so the scheduler starts them
        # together and their join writes the scenario's rows early (a long run keeps them if stopped)
        cost = (_run_cost(t, "proposed") + _run_cost(t, "benchmark")) / 2.0
        for m in ("proposed", "benchmark"):
            runs[m] = f"{key}/{m}"
            kwargs: dict[str, Any] = {"task": t, "method": m}
            if m == "proposed" and frames and t["instance"] in frames:
                kwargs["frame_every"] = frames[t["instance"]]
            jobs.append(Job(runs[m], section, _method_run, kwargs, cost=cost))
        jobs.append(Job(key, section, _pair_job, {"task": t}, runs, cost=0.05, task=t))
    return jobs


def reproduce_jobs(*, quick: bool, out: Path, store_path: Path) -> list[Job]:
    """The herding reproduction as jobs (:mod:`droneplan.studies.jobs`): each herder's run of
    each Fig. 6.7 and sweep scenario its own job (the two of a scenario join into one store
    task), the figures from the store at ``store_path``, and the GIF, drawn from the proposed
    herder's Fig. 6.7 run at 200 animals, seed 0 (a frame every 30 s quick, 10 s full).

    quick: see :func:`reproduce`; out: directory for the CSV, PNG and GIF files.
    """
    out = Path(out)
    kws = {"out": out, "quick": quick, "store_path": Path(store_path)}
    jobs: list[Job] = []
    gif = instance_id("fig6.7", n=200, seed=0)  # its proposed run is also the GIF
    frames = {gif: 30.0 if quick else 10.0}
    for name, tasks, step in (
        ("fig 6.7", _fig_6_7_tasks(quick), _fig_6_7),
        ("figs 6.8-6.10", _sweep_tasks(quick), _sweeps),
    ):
        section = f"herding {name}"
        made = _pair_jobs(tasks, section, frames)
        jobs += made
        after = tuple(j.key for j in made if j.task is not None)
        jobs.append(
            Job(
                f"herding/{name}",
                section,
                _from_store,
                {"step": step, **kws},
                after=after,
                cost=2.0,
                local=True,
            )
        )
    run = {"run": f"herding/{gif}/proposed"}
    jobs.append(
        Job("herding/animation", "herding animation", _animation_job, {"out": out}, run, cost=3.0, local=True)
    )
    return jobs


def _animation_job(out: Path, run: tuple[dict, HerdingTrace]) -> None:
    """The GIF of a Fig. 6.7 run of the proposed herder (made with frames by its job)."""
    record, trace = run
    animate(trace, out / f"proposed_{record['n']}_animals.gif", fps=8)


# --------------------------------------------------------------------------- gap
GAP_SIZES = (2, 4, 6, 7, 8, 16, 64)
"""Numbers of drones in the allocation gap study (Algorithm 3 up to 7, CP-SAT up to 16)."""

GAP_METHODS = (
    ((2, 4, 6, 7), ("exact", "alg3", "cp-sat", "collision-blind")),
    ((8, 16), ("exact", "cp-sat", "collision-blind")),
    ((64,), ("exact", "collision-blind")),
)
"""Which registered methods the built-in study runs at which sizes (Alg. 3 is n!·2^n, the
CP-SAT model grows with n^2 wraps)."""

GAP_THESIS = {("herding", "alg3"): "exact (Alg. 3 enumerates all n!·2^n allocations)"}


def gap(
    *, seeds: int, executor=None, out: Path, store: ResultStore | None = None, first_seed: int = 0
) -> pd.DataFrame:
    """Allocation gap on the ``allocation`` family: Algorithm 3, CP-SAT and the collision-blind
    relaxation vs the exact algorithm (an open study of registered methods, ``droneplan.gap``).

    seeds: instances per size (``GAP_SIZES``); executor: where the jobs run (from
    ``make_executor``; default: one per core); out: directory for the summary and figure; store:
    the results store (default ``out/results.sqlite``). Returns the rows of these instances.
    first_seed: seed of the first instance (instances first_seed .. first_seed + seeds - 1).
    """
    from droneplan.studies.study import gap as open_gap

    out = Path(out)
    frames = [
        open_gap(
            "herding",
            methods=list(methods),
            instances="allocation",
            n=list(sizes),
            seeds=seeds,
            first_seed=first_seed,
            out=out,
            store=store,
            executor=executor,
            time_limit=30.0,
        )
        for sizes, methods in GAP_METHODS
    ]
    df = pd.concat(frames, ignore_index=True)
    report_study(
        df, out, "herding", thesis=GAP_THESIS, title="herding: steering-point allocation, max travel (m)"
    )
    table = ComparisonTable("Steering-point allocation vs the exact optimum (max travel, m)")
    for n in GAP_SIZES:
        sub = df[df["size"] == n]
        if sub.empty:
            continue
        for method, thesis in (("alg3", "Alg. 3 is exact (n!·2^n)"), ("cp-sat", "—")):
            m = sub[sub["method"] == method]
            if len(m):
                agree = (m["gap_to_best"].abs() <= 1e-9).mean()
                table.add(
                    f"n={n}: {method} = exact",
                    thesis,
                    f"{agree:.0%} of {len(m)}",
                    f"median time {m['time_s'].median() * 1e3:.2f} ms (in its own process)",
                )
        blind = sub[sub["method"] == "collision-blind"]
        if len(blind):
            crosses = (blind["status"] == "infeasible").mean()
            table.add(
                f"n={n}: collision-blind allocation crosses",
                "— (thesis requires no crossing)",
                f"{crosses:.0%} of {len(blind)}",
                "bottleneck assignment without (6.22)-(6.23); droneplan's check rejects crossing plans",
            )
            ex = sub[sub["method"] == "exact"].set_index("instance")["objective"]
            relaxed = blind.set_index("instance")["claimed_objective"]
            same = np.isclose(relaxed, ex.reindex(relaxed.index), rtol=1e-9).mean()
            table.add(
                f"n={n}: cost of the order constraints",
                "—",
                f"exact = collision-blind max travel in {same:.0%} of {len(blind)}",
                "the relaxation's value is a lower bound; equality means no-crossing costs nothing in (6.21)",
            )
    table.emit(out, "gap_allocation_summary")
    return df


# --------------------------------------------------------------------------- bench
def bench(*, quick: bool, out: Path) -> None:
    """Allocation timings (exact n=64, Alg.3/exact n=7), simulation speed (simulated seconds per
    CPU second: whole runs at 1000 animals and the first seconds at 10^5, :func:`whole_run_rate`;
    60 s of gathering at 200, 1000 and 10^4 animals), the import time, proposed vs benchmark;
    a comparison table in ``out``.

    quick: smaller instances and shorter horizons; out: folder of the table.
    """
    out = Path(out)
    table = ComparisonTable("Herding benchmarks (measured in this run)")
    d, s, M = random_allocation_instance(64, 0)
    _, t64 = timed(solve_allocation, d, s, M, repeat=50)
    table.add(
        "exact allocation, n = 64 (ms)",
        "target < 10",
        t64.wall_s * 1e3,
        f"median of 50 solves, random hull instance; one solve {t64.note}",
    )
    d, s, M = random_allocation_instance(7, 1)
    _, t_bf = timed(allocate_bruteforce, d, s, M, repeat=3)
    _, t_ex = timed(solve_allocation, d, s, M, repeat=50)
    table.add(
        "Algorithm 3 / exact CPU-time ratio, n = 7",
        "n!·2^n = 645120 allocations",
        t_bf.cpu_s / t_ex.cpu_s,
        f"medians: Alg. 3 {t_bf.note}; exact {t_ex.cpu_s * 1e3:.3f} ms CPU",
    )
    d, s, M = random_allocation_instance(12, 2)
    _, t_cp = timed(solve_allocation, d, s, M, method="cp-sat", repeat=3)
    table.add(
        "CP-SAT / exact CPU-time ratio, n = 12",
        "—",
        t_cp.cpu_s / t_ex.cpu_s,
        f"CP-SAT (1 worker) median {t_cp.note}",
    )
    _bench_whole_runs(table, quick=quick)
    _bench_speed(table)
    seeds = 4 if quick else 20
    tasks = [
        {"n": 200, "seed": k, "method": m, "t_max": 2400.0, "gather_only": True}
        for k in range(seeds)
        for m in ("proposed", "benchmark")
    ]
    with make_executor(_workers()) as ex:
        rows = list(ex.map(run_once, tasks))
    gp = [r["gather_time"] for r in rows if r["method"] == "proposed"]
    gb = [r["gather_time"] for r in rows if r["method"] == "benchmark"]
    pairs = [(p, b) for p, b in zip(gp, gb, strict=True) if p is not None and b is not None]  # task order
    faster = (1 - np.mean([p for p, _ in pairs]) / np.mean([b for _, b in pairs])) if pairs else None
    table.add(
        f"proposed gathers faster than benchmark ({seeds} seeds, 200 animals)",
        "~25% (11.1 vs ~14.4 min)",
        None if faster is None else f"{faster:.0%}",
        f"1 - mean(proposed)/mean(benchmark) gathering time over {len(pairs)} paired seeds; "
        f"proposed faster in {sum(p < b for p, b in pairs)}/{len(pairs)}",
    )
    table.emit(out, "bench")


WHOLE_RUN_HORIZONS = {1000: (2400.0, 2400.0), 100_000: (4.0, 10.0)}
"""Herd size -> (quick, full) simulated horizon of the bench's whole-run rows, s: 1000 animals
run to delivery (seed 0 is delivered at 1323 s; 2400 s is the limit), 10^5 animals only the
first seconds of gathering (a whole run would take hours)."""


def whole_run_rate(n: int, t_max: float, *, seed: int = 0) -> dict:
    """One run of the proposed herder on the thesis set-up, timed: simulated s per CPU s.

    n: herd size (count); t_max: simulated time limit, s (the run stops earlier when the herd is
    delivered); seed: scenario seed (the animals' noise uses seed + 10000, as the reproduction).
    Returns {"n", "sim_s", "cpu_s", "wall_s", "load", "rate", "gather_s", "total_s",
    "driving_steps"}: CPU s of this process, wall s, the 1-minute load average at the start.
    """
    scenario = thesis_scenario(n, seed=seed)
    with measured() as run:
        trace = simulate(scenario, ProposedHerder(), t_max=t_max, seed=seed + 10_000)
    sim = float(trace.t[-1])
    return {
        "n": n,
        "sim_s": sim,
        "cpu_s": run.cpu_s,
        "wall_s": run.wall_s,
        "load": run.load,
        "rate": sim / run.cpu_s,
        "gather_s": trace.gather_time,
        "total_s": trace.total_time,
        "driving_steps": int(np.sum(trace.phase == HerdingPhase.DRIVING)),
    }


def _bench_whole_runs(table: ComparisonTable, *, quick: bool) -> None:
    """Rows: simulated seconds per CPU second of whole runs (gathering, driving and delivery) at
    1000 animals, and of the first seconds at 10^5 animals (:data:`WHOLE_RUN_HORIZONS`), each
    with its CPU time, wall time and the load average."""
    for n, goal in ((1000, "target >= 200"), (100_000, "target >= 5")):
        horizon = WHOLE_RUN_HORIZONS[n][0 if quick else 1]
        r = whole_run_rate(n, horizon)
        span = (
            f"whole run to delivery at {r['total_s']:.0f} s (gathered at {r['gather_s']:.0f} s)"
            if r["total_s"] is not None
            else f"{r['sim_s']:.0f} s of {'a whole run' if n <= 1000 else 'gathering'}"
        )
        table.add(
            f"simulation, {n} animals + 4 drones, whole run (sim s / CPU s)",
            goal,
            r["rate"],
            f"{span}: {r['cpu_s']:.2f} CPU-s, {r['wall_s']:.2f} s wall, load average "
            f"{r['load']:.1f} on {os.cpu_count()} cores",
        )


def _bench_speed(table: ComparisonTable) -> None:
    """Rows: simulated seconds per CPU second at 200, 1000 and 10^4 animals (60 s of gathering
    by the proposed herder, thesis set-up), and the time of ``import droneplan`` in a fresh
    interpreter. CPU time is this process's (or the child's): the figure other processes on a
    shared machine disturb least; wall time and the load average stand beside it."""
    for n, goal in ((200, "—"), (1000, "target >= 200"), (10_000, "target >= 50")):
        scenario = thesis_scenario(n, seed=0)
        with measured() as run:
            trace = simulate(scenario, ProposedHerder(), t_max=60.0, seed=1)
        sim = float(trace.t[-1])
        table.add(
            f"simulation, {n} animals + 4 drones, 60 s gathering (sim s / CPU s)",
            goal,
            sim / run.cpu_s,
            f"{sim:.0f} s simulated: {run.note}",
        )
    try:
        import resource
    except ImportError:  # not on this platform: no child CPU time
        resource = None  # type: ignore[assignment]
    load = load_average()
    before = resource.getrusage(resource.RUSAGE_CHILDREN) if resource else None
    w0 = time.perf_counter()
    subprocess.run([sys.executable, "-c", "import droneplan"], check=True)
    wall = time.perf_counter() - w0
    cpu_note = ""
    if resource is not None and before is not None:
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        cpu = (after.ru_utime + after.ru_stime) - (before.ru_utime + before.ru_stime)
        cpu_note = f"{cpu:.2f} CPU-s, "
    table.add(
        "import droneplan, fresh interpreter (s wall)",
        "target <= 0.5",
        wall,
        f"{cpu_note}interpreter start-up included; load average {load:.1f} on {os.cpu_count()} cores",
    )


# --------------------------------------------------------------------------- notebook helpers
def write_gif(trace, path, *, fps: int = 8, goal=None) -> Path:
    """Write an animated GIF of a run's frames (needs ``simulate(..., frame_every=...)``); returns the path.

    trace: a HerdingTrace with frames; path: the GIF file (str or os.PathLike ending in .gif;
    its folder is created). goal: G (2,) in m, kept in view (default: the trace's goal). fps: frames per
    second of the GIF (an int, 1 to 100). The same as ``animate(trace, path, fps=fps, goal=goal)``.
    """
    return animate(trace, path, fps=fps, goal=goal)


def run_times_table(traces: dict):
    """Gathering and total time per run of {label: HerdingTrace}, as a DataFrame with units in the
    column names (times in min, speeds in m/s; the traces themselves hold seconds).

    traces: a non-empty dict {label: HerdingTrace}.
    """
    import pandas as pd

    if not isinstance(traces, Mapping):
        raise TypeError(f"traces must be a dict {{label: HerdingTrace}}, got {type(traces).__name__}")
    if not traces:
        raise ValueError("traces must hold at least one run, got an empty dict")
    for k, tr in traces.items():
        if not isinstance(tr, HerdingTrace):
            raise TypeError(f"traces[{k!r}] must be a HerdingTrace, got {type(tr).__name__}")
    return pd.DataFrame(
        [
            {
                "method": k,
                "gather (min)": _minutes(tr.gather_time),
                "total (min)": _minutes(tr.total_time),
                "max animal speed (m/s)": tr.max_animal_speed,
            }
            for k, tr in traces.items()
        ]
    ).set_index("method")


__getattr__ = deprecated_names(__name__, {"summary_table": "run_times_table"}, globals())
