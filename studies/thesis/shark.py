"""Shark interception (thesis ch. 5): reproduction, optimality gap and benchmarks.

`droneplan reproduce shark` — Fig. 5.10 (z_o*, eps* vs z_s: thesis formula beside the exact
optimum), Fig. 5.11 (classical pursuit), Table 5.2 (interception distance for paths a-d:
thesis, virtual shark, OCP), Fig. 5.12 panels, repelling episodes.
`droneplan gap shark` — virtual shark vs the online OCP (closed-loop time of first contact) on
random paths, with the offline OCP and its proven bound beside them, and the optimal operator-shark
assignment vs greedy nearest-operator on random fleets.
`droneplan bench shark` — online OCP replan time vs Ts, OCP/virtual-shark time ratios.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import matplotlib.pyplot as plt
import numpy as np

from droneplan.formulations.shark import optimal_altitude
from droneplan.planners.shark import (
    ClassicalPursuit,
    OCPInterceptor,
    RepellingOperator,
    VirtualSharkInterceptor,
    allocate_operators,
    optimal_interception,
    thesis_altitude,
)
from droneplan.scenarios.shark import (
    THESIS_TABLE_5_1,
    AlarmLevel,
    SharkBehaviour,
    operator_start,
    random_trajectory,
    simulate,
    simulate_repelling,
    thesis_trajectories,
)
from droneplan.studies.bound_engines import BOUND_METRIC, interception_bounds
from droneplan.studies.common import ComparisonTable, measured, report_study
from droneplan.studies.jobs import Job, run_reproduction
from droneplan.studies.plots.shark import animate, plot_time_series, plot_top_view
from droneplan.studies.thesis.report import flag_reasons

if TYPE_CHECKING:
    import pandas as pd

__all__ = [
    "P",
    "TABLE_5_2",
    "BOUND_METRIC",
    "reproduce",
    "reproduce_jobs",
    "gap",
    "interception_bounds",
    "bench",
]


P = THESIS_TABLE_5_1
TABLE_5_2 = {"a": (5.34, 29.70), "b": (5.48, 30.50), "c": (5.55, 19.79), "d": (5.78, 21.26)}
"""Thesis Table 5.2: average shark speed (m/s), interception distance (m)."""


# --------------------------------------------------------------------------- reproduce
def _fig_5_10(out: Path, table: ComparisonTable) -> None:
    z = np.linspace(-11.5, 0, 2301)
    zt, et = thesis_altitude(z)
    zx, ex = optimal_altitude(z)
    bad = (zt > P.le + 1e-12) | (zt < P.lmin - 1e-12)
    fig, ax = plt.subplots(1, 2, figsize=(10, 4))
    for a, yt, yx, lab in ((ax[0], zt, zx, "z_o* (m)"), (ax[1], et, ex, "eps* (m)")):
        a.plot(z, yt, "--", label="Prop. 5.3.1 (thesis)")
        a.plot(z, yx, label="exact maximiser")
        a.axvspan(z[bad].min(), z[bad].max(), color="red", alpha=0.15, label="thesis z_o* outside [lmin, le]")
        a.set_xlabel("z_s (m)")
        a.set_ylabel(lab)
        a.grid(alpha=0.3)
    ax[0].axhline(P.le, color="k", lw=0.5)
    ax[0].axhline(P.lmin, color="k", lw=0.5)
    ax[0].legend(fontsize=7)
    fig.suptitle("Fig. 5.10: optimal operator altitude and interception radius")
    fig.tight_layout()
    fig.savefig(out / "fig_5_10.png", dpi=120)
    plt.close(fig)
    np.savetxt(
        out / "fig_5_10.csv",
        np.c_[z, zt, et, zx, ex],
        delimiter=",",
        header="z_s,zo_thesis,eps_thesis,zo_exact,eps_exact",
        comments="",
    )
    table.add(
        "Fig 5.10: z_s range where Prop. 5.3.1 puts z_o* outside [lmin, le]",
        "not noted",
        f"({z[bad].min():.2f}, {z[bad].max():.2f}) m",
        "grid of 2301 z_s values, eqs. 5.6 verbatim",
    )
    table.add(
        "Fig 5.10: min exact eps* on that range (thesis claims eps_o)",
        P.eps_o,
        float(ex[bad].min()),
        "exact maximiser over lmin <= z_o <= le (two-ball field)",
    )
    table.add(
        "Fig 5.10: z_o* jump (thesis at z_s = -3.5 m)",
        "z_s+l2 -> z_s+l1 at -3.5",
        f"exact: 2 -> 1 m at z_s = {z[1:][np.abs(np.diff(zx)) > 0.5][0]:.2f} m",
        "exact maximiser",
    )


def _fig_5_11(out: Path, table: ComparisonTable) -> None:
    tr = thesis_trajectories()["a"]
    cp = simulate(tr, ClassicalPursuit())
    lit = simulate(tr, ClassicalPursuit(aim="shark"), t_max=20)
    fig, ax = plt.subplots(1, 2, figsize=(11, 4.5))
    plot_top_view({"classical pursuit": cp}, ax=ax[0], title="top view")
    plot_time_series({"classical pursuit": cp}, ax=ax[1], title="clearance D_h - eps(h)")
    fig.suptitle("Fig. 5.11: classical pursuit touches the shark from behind")
    fig.tight_layout()
    fig.savefig(out / "fig_5_11.png", dpi=120)
    plt.close(fig)
    table.add(
        "Fig 5.11: classical pursuit first contact (path a)",
        "from behind",
        f"angle {cp.frontal_angle:.0f} deg from the heading at t={cp.intercept_time:.2f} s",
        "eq. 5.5 aimed above the shark; 0 deg = frontal",
    )
    table.add(
        "Fig 5.11: eq. 5.5 literally (aim at the submerged shark)",
        "—",
        "never touches" if not lit.intercepted else f"touches at {lit.intercept_time:.2f} s",
        f"stalls at D_h={lit.D_h[-1]:.2f} m > eps={lit.eps[-1]:.2f} m (altitude floor)",
    )


def _path_job(name: str, quick: bool) -> tuple[tuple, list[dict], dict]:
    """Table 5.2 on thesis path ``name``: the virtual shark, the online and the offline OCP runs
    and the offline OCP's optimum. Returns ((virtual-shark, online, offline) traces, the table
    rows, the CSV row)."""
    table = ComparisonTable("Shark ch. 5: Table 5.2 (interception distance)", explain=flag_reasons("shark"))
    tr = thesis_trajectories()[name]
    O0 = operator_start(tr)
    vs_ctl = VirtualSharkInterceptor()
    vs = simulate(tr, vs_ctl)
    on_ctl = OCPInterceptor(N=20)
    on = simulate(tr, on_ctl)
    off = optimal_interception(tr, O0, N=40 if quick else 60)
    off_ctl = OCPInterceptor(N=30 if quick else 40, path=tr)
    offsim = simulate(tr, off_ctl)
    # the thesis paths: the OCP solves and the virtual shark reaches its interception point
    if off.objective is None or vs_ctl.capture_time is None:
        raise RuntimeError(f"path {name}: the OCP found no interception or the virtual shark no capture")
    sp, dist = TABLE_5_2[name]
    table.add(
        f"Table 5.2 ({name}): average shark speed (m/s)",
        sp,
        tr.average_speed(vs.intercept_time),
        "our path, mean |v_s| until the virtual-shark contact",
    )
    table.add(
        f"Table 5.2 ({name}): interception distance, virtual shark (m)",
        dist,
        vs.interception_distance,
        f"|S(contact) - S(0)|, start {P.Di} m at -105 deg; frontal={vs.frontal}, early={vs.touched_early}",
        why=""
        if vs.intercept_time is None
        else f"contact after {vs.intercept_time:.2f} s and "
        f"{tr.average_speed(vs.intercept_time) * vs.intercept_time:.1f} m along our path "
        f"for {vs.interception_distance:.2f} m of displacement",
    )
    table.add(
        f"Table 5.2 ({name}): interception distance, online OCP (m)",
        "—",
        on.interception_distance,
        f"receding horizon, constant-velocity prediction; frontal={on.frontal}, early={on.touched_early}",
    )
    table.add(
        f"Table 5.2 ({name}): interception distance, offline OCP (m)",
        "—",
        offsim.interception_distance,
        f"receding horizon on the known path; frontal={offsim.frontal}, early={offsim.touched_early}",
    )
    table.add(
        f"Table 5.2 ({name}): time to the interception point OCP / virtual shark",
        "—",
        off.objective / vs_ctl.capture_time,
        f"OCP T={off.objective:.2f} s (IPOPT "
        f"{'local optimum' if off.converged else off.status.name}) vs {vs_ctl.capture_time:.2f} s",
    )
    table.add(
        f"Table 5.2 ({name}): proven lower bound on T / OCP T / virtual-shark T (s)",
        "—",
        f"{off.bound:.2f} / {off.objective:.2f} / {vs_ctl.capture_time:.2f}"
        if off.bound is not None
        else f"none / {off.objective:.2f} / {vs_ctl.capture_time:.2f}",
        "bound: earliest T reachable at the speed limits (OCP relaxation); "
        f"OCP best start: {off.info.get('start_won')}",
    )
    row = dict(
        path=name,
        thesis_speed=sp,
        speed=tr.average_speed(vs.intercept_time),
        thesis_distance=dist,
        vs_distance=vs.interception_distance,
        vs_time=vs.intercept_time,
        online_ocp_distance=on.interception_distance,
        online_ocp_time=on.intercept_time,
        offline_ocp_distance=offsim.interception_distance,
        offline_ocp_time=offsim.intercept_time,
        ocp_T=off.objective,
        vs_capture=vs_ctl.capture_time,
    )
    return (vs, on, offsim), table.rows, row


def _table_5_2_job(out: Path, quick: bool, **paths: tuple) -> None:
    """Table 5.2, Fig. 5.12 and path (d)'s GIF from the :func:`_path_job` results (by path name)."""
    import pandas as pd

    table = ComparisonTable("Shark ch. 5: Table 5.2 (interception distance)", explain=flag_reasons("shark"))
    trajectories = thesis_trajectories()
    runs = {}
    for name, (traces, rows, _) in paths.items():
        table.rows.extend(rows)
        runs[name] = (trajectories[name], *traces)
    table.emit(out, "table_5_2")
    pd.DataFrame([row for _, _, row in paths.values()]).to_csv(out / "table_5_2_runs.csv", index=False)
    _fig_5_12(out, runs)
    name = "d" if "d" in runs else next(iter(runs))  # path (d): the virtual shark's run as a GIF
    vs_run = runs[name][1]
    stride = max(1, len(vs_run.t) // (40 if quick else 120))
    animate(vs_run, out / f"path_{name}_virtual_shark.gif", fps=8, stride=stride)


def _fig_5_12(out: Path, runs: dict) -> None:
    fig, ax = plt.subplots(4, 4, figsize=(17, 14))
    for r, (name, (_, vs, _, off)) in enumerate(runs.items()):
        a = ax[r]
        pair = {"virtual shark": vs, "offline OCP": off}
        plot_top_view(pair, ax=a[0], title=f"({name}) top view")
        plot_time_series({"virtual shark": vs}, "altitude", ax=a[1], title=f"({name}) altitudes")
        plot_time_series(pair, ax=a[2], title=f"({name}) eps(h) vs D_h")
        plot_time_series({"virtual shark": vs}, "speed", ax=a[3], title=f"({name}) speeds")
        for x in a:
            x.title.set_fontsize(9)
            x.legend(fontsize=6)
    fig.suptitle("Fig. 5.12: virtual-shark interception on paths a-d (offline OCP dashed)")
    fig.tight_layout()
    fig.savefig(out / "fig_5_12.png", dpi=100)
    plt.close(fig)


def _fig_5_10_5_11_job(out: Path) -> None:
    """Figs. 5.10 and 5.11 and their table."""
    t1 = ComparisonTable("Shark ch. 5: Fig. 5.10 / 5.11", explain=flag_reasons("shark"))
    _fig_5_10(out, t1)
    _fig_5_11(out, t1)
    t1.emit(out, "fig_5_10_5_11")


def _repelling_plan(quick: bool) -> list[tuple[int, str]]:
    """(sharks, interceptor) groups of the repelling episodes."""
    return [
        (k, kind)
        for k in (1, 2)
        for kind in (("virtual-shark",) if quick and k == 2 else ("virtual-shark", "ocp"))
    ]


def _repel_group(n_sharks: int, interceptor: str, n: int) -> list[dict]:
    """Episodes with ``n_sharks`` sharks and ``interceptor``, seeds 0 .. n - 1."""
    return [_repel_episode(n_sharks, s, interceptor, 4.0) for s in range(n)]


def _repelling_job(out: Path, **groups: list[dict]) -> None:
    """The repelling table and CSV from the :func:`_repel_group` results."""
    table = ComparisonTable(
        "Shark ch. 5: repelling episodes (procedure 1-5 of §5.3.1)", explain=flag_reasons("shark")
    )
    _repelling(out, table, [row for rows in groups.values() for row in rows])
    table.emit(out, "repelling")


PATH_COST = 6.0
"""Estimated CPU seconds of one Table 5.2 path (the scheduler starts long chains first)."""


def reproduce_jobs(*, quick: bool, out: Path, store_path: Path | None = None) -> list[Job]:
    """The shark reproduction as jobs (:mod:`droneplan.studies.jobs`): Figs. 5.10-5.11, one job
    per Table 5.2 path, groups of repelling episodes, and the tables and figures they feed.

    quick: coarser offline OCP (N = 40 / 30 instead of 60 / 40), 6 repelling episodes per group
    (full: 30) and no OCP group with 2 sharks; out: directory for the CSV, PNG and GIF files;
    store_path: not used (the shark jobs write their tables, no store rows), taken so that every
    problem's ``reproduce_jobs`` has one signature.
    """
    out = Path(out)
    jobs = [
        Job(
            "shark/fig5.10-5.11",
            "shark figs 5.10-5.11",
            _fig_5_10_5_11_job,
            {"out": out},
            cost=2.0,
            local=True,
        )
    ]
    paths = {}
    for name in thesis_trajectories():
        paths[name] = key = f"shark/table5.2/{name}"
        jobs.append(Job(key, "shark table 5.2", _path_job, {"name": name, "quick": quick}, cost=PATH_COST))
    kwargs = {"out": out, "quick": quick}
    jobs.append(Job("shark/table5.2", "shark table 5.2", _table_5_2_job, kwargs, paths, cost=4.0, local=True))
    n = 6 if quick else 30
    groups = {}
    for k, kind in _repelling_plan(quick):
        groups[f"g{k}_{kind.replace('-', '_')}"] = key = f"shark/repelling/{k}/{kind}"
        cost = n * (0.3 if kind == "virtual-shark" else 1.0) * k
        jobs.append(
            Job(key, "shark repelling", _repel_group, {"n_sharks": k, "interceptor": kind, "n": n}, cost=cost)
        )
    jobs.append(
        Job("shark/repelling", "shark repelling", _repelling_job, {"out": out}, groups, cost=0.2, local=True)
    )
    return jobs


def reproduce(*, quick: bool, out: Path, executor=None) -> None:
    """Fig. 5.10, 5.11, Table 5.2, Fig. 5.12 and repelling episodes; tables on stdout, CSV/PNG in
    ``out``. quick: see :func:`reproduce_jobs`; executor: from ``make_executor`` (default: serial
    in this process), where the runs and solves go."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    run_reproduction(reproduce_jobs(quick=quick, out=out), executor=executor)


def _repel_episode(n_sharks: int, seed: int, interceptor: str, T_w: float) -> dict:
    """One episode: sharks start 80-150 m from a group of swimmers, operators near the beach."""
    g = np.random.default_rng(seed)
    H = g.uniform(-15, 15, (4, 2))
    ang = g.uniform(0, np.pi, n_sharks)
    r = g.uniform(80, 150, n_sharks)
    S0 = np.c_[r * np.cos(ang), r * np.sin(ang), np.full(n_sharks, -3.0)]
    O0 = np.c_[np.linspace(-20, 20, n_sharks), np.full(n_sharks, -40.0), np.full(n_sharks, 2.0)]
    beh = SharkBehaviour()
    near = np.array([H[np.argmin(np.linalg.norm(H - S0[j, :2], axis=1))] for j in range(n_sharks)])
    d = near - S0[:, :2]
    V0 = np.c_[d / np.linalg.norm(d, axis=1)[:, None] * beh.speed, np.zeros(n_sharks)]
    alloc = allocate_operators(O0, S0, V0, H)
    ctls = [RepellingOperator(0, interceptor=interceptor, T_w=T_w) for _ in range(n_sharks)]
    for j, i in zip(alloc.x.sharks, alloc.x.operator, strict=True):  # one operator per selected shark
        ctls[i] = RepellingOperator(int(j), interceptor=interceptor, T_w=T_w)
    tr = simulate_repelling(S0, O0, H, ctls, behaviour=beh, seed=seed, t_max=600)
    return dict(
        n_sharks=n_sharks,
        seed=seed,
        interceptor=interceptor,
        T_w=T_w,
        attacked=tr.attacked,
        all_left=bool(tr.left.all()),
        interceptions=float(tr.reactions.mean()),
        ignored=int(tr.ignored.sum()),
        end_time=tr.end_time,
        observer_alarm=AlarmLevel(int(tr.alarm[0])).name.lower(),  # raised when the sharks are spotted
        alarm_peak=AlarmLevel(int(tr.alarm.max())).name.lower(),
        speaker_alerted=int(np.sum(~np.isnan(tr.alerted_at))),  # swimmers the observer's speakers warned
    )


def _repelling(out: Path, table: ComparisonTable, rows: list[dict]) -> None:
    import pandas as pd

    df = pd.DataFrame(rows).sort_values(["n_sharks", "seed", "interceptor"], kind="stable")
    df.to_csv(out / "repelling_episodes.csv", index=False)
    for (k, kind), grp in df.groupby(["n_sharks", "interceptor"]):
        table.add(
            f"{k} shark(s), {kind}: interceptions per shark until it leaves (mean)",
            "—",
            float(grp["interceptions"].mean()),
            f"{len(grp)} episodes; shark model: flees 8 s after a contact, returns w.p. 0.6; T_w = 4 s",
        )
        table.add(
            f"{k} shark(s), {kind}: episodes with an attack / all sharks left",
            "0 attacks",
            f"{int(grp['attacked'].sum())}/{len(grp)} attacks, {int(grp['all_left'].sum())}/{len(grp)} left",
            "safety distance 300 m, not the thesis's example 3 km: on the quick episodes 3 km gives the "
            "same attacks and interceptions per episode and only adds ~540 s of the shark swimming away "
            "(past the 600 s limit); operators allocated by the bottleneck model",
        )


# --------------------------------------------------------------------------- gap
def gap(*, seeds: int, executor=None, out: Path, store=None, first_seed: int = 0):
    """Virtual shark vs the online OCP in closed loop on ``seeds`` random paths (with the offline OCP
    and its proven bound as extras), and greedy vs optimal assignment on ``seeds`` random fleets: two
    open studies (:func:`droneplan.studies.study.gap`) of the registered methods.

    executor: where the jobs run (from ``make_executor``; default: one per core); out: directory for
    the summary and figure; store: the results store (default ``out/results.sqlite``). Returns the
    rows of these instances.
    first_seed: seed of the first instance (instances first_seed .. first_seed + seeds - 1).
    """
    import pandas as pd

    from droneplan.studies.study import gap as open_gap

    out = Path(out)
    paths, fleets = (
        open_gap(
            "shark",
            instances=family,
            seeds=seeds,
            first_seed=first_seed,
            out=out,
            store=store,
            executor=executor,
        )
        for family in ("random-path", "random-fleet")
    )
    df = pd.concat([paths, fleets], ignore_index=True)
    report_study(
        df, out, "shark", title="shark: time of first contact (s; paths) and latest interception (s; fleets)"
    )
    t = ComparisonTable("Shark ch. 5: optimality gap")
    _path_table(t, paths)
    obj = fleets.pivot(index="instance", columns="method", values="objective")
    if {"bottleneck", "greedy-nearest"} <= set(obj.columns):
        r = (obj["greedy-nearest"] / obj["bottleneck"]).dropna()
        t.add(
            "greedy nearest operator / optimal bottleneck, latest interception (median)",
            "—",
            float(r.median()) if len(r) else None,
            f"{len(r)} random fleets with both assignments feasible; predicted virtual-shark capture times",
        )
    t.emit(out, "gap_table")
    return df


def _path_table(t: ComparisonTable, paths: pd.DataFrame) -> None:
    """The path rows' comparisons: closed-loop contact times, and the capture times against the bound."""
    obj = paths.pivot(index="instance", columns="method", values="objective")
    if {"ocp", "virtual-shark"} <= set(obj.columns):
        r = (obj["ocp"] / obj["virtual-shark"]).dropna()
        t.add(
            "online OCP / virtual-shark time of first contact (mean)",
            "—",
            float(r.mean()) if len(r) else None,
            f"{len(r)} random paths with both contacts frontal; closed loop; 1 = no gain",
        )
    by = paths.set_index(["instance", "method"])
    if ("shark_capture_time_bound_s" in by) and ("shark_capture_time" in by):
        idx = paths["instance"].unique()
        lb = by["shark_capture_time_bound_s"].xs("interception-bound", level="method").reindex(idx)
        for name, col, how in (
            ("offline OCP T", "shark_ocp_time_s", "interception-bound"),
            ("virtual-shark capture time", "shark_capture_time", "virtual-shark"),
        ):
            if how not in set(paths["method"]):
                continue
            g = (by[col].xs(how, level="method").reindex(idx).astype(float) / lb.astype(float) - 1).dropna()
            t.add(
                f"{name} / proven lower bound - 1 (median, %)",
                "—",
                100 * float(g.median()) if len(g) else None,
                f"{len(g)} paths; bound on reaching the frontal point (relaxation without the no-early-touch "
                "constraint), not on first contact",
            )
    vs = paths[paths["method"] == "virtual-shark"]
    if len(vs) and "shark_touched_early" in vs:
        early = vs["shark_touched_early"].fillna(False).astype(bool).sum()
        t.add(
            "virtual shark touches early (Prop. 5.3.3 violated)",
            "never",
            f"{int(early)}/{len(vs)}",
            "curvy random paths, random start bearing",
        )


# --------------------------------------------------------------------------- bench
def bench(*, quick: bool, out: Path) -> None:
    """Online OCP replan time vs Ts; OCP / virtual-shark interception-time ratios on a-d and random paths."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    t = ComparisonTable("Shark ch. 5: bench")
    paths = dict(thesis_trajectories())
    n_rand = 10 if quick else 50
    for s in range(n_rand):
        paths[f"r{s}"] = random_trajectory(1000 + s)
    solve_times: list[float] = []
    warm_times: list[float] = []
    ratios_abcd: list[float] = []
    ratios_rand: list[float] = []
    missing: list[str] = []
    with measured() as run:  # the whole bench loop: wall, CPU and load beside the ratios
        for name, tr in paths.items():
            if name in "abcd" or (not quick and name in ("r0", "r1", "r2", "r3")) or (quick and name == "r0"):
                ctl = OCPInterceptor(N=20)
                simulate(tr, ctl)
                solve_times += ctl.solve_times
                warm_times += ctl.solve_times[2:]  # after the two cold starts
            O0 = operator_start(tr)
            res = optimal_interception(tr, O0, N=50)
            vsT = res.info["virtual_shark_T"]
            if res.status.has_solution and vsT:
                (ratios_abcd if name in "abcd" else ratios_rand).append(res.objective / vsT)
            else:
                vs = simulate(tr, VirtualSharkInterceptor())
                why = (
                    f"touched early at {vs.intercept_time:.1f} s in step {vs.phase[-1]}"
                    if vs.touched_early
                    else "no contact"
                    if not vs.intercepted
                    else "no capture"
                )
                missing.append(f"{name}: virtual shark {why}, OCP {res.status.name}")
    st = np.array(solve_times)
    t.add(
        "online OCP replan time / Ts (median)",
        "< 1 (target)",
        float(np.median(st) / P.Ts),
        f"N=20 constant-velocity OCP, IPOPT, {len(st)} replans over a-d and random paths, all solves "
        f"(solver wall time); the whole bench loop {run.note}",
    )
    t.add("online OCP replan time / Ts (95th percentile)", "—", float(np.percentile(st, 95) / P.Ts), "same")
    t.add(
        "online OCP warm replan time / Ts (median)",
        "—",
        float(np.median(warm_times) / P.Ts),
        "warm-started from the shifted previous plan and duals",
    )
    t.add("OCP T / virtual-shark T on a-d (mean)", "—", float(np.mean(ratios_abcd)), "path known, N=50")
    t.add("OCP T / virtual-shark T on a-d (worst)", "—", float(np.max(ratios_abcd)), "")
    t.add(
        f"OCP T / virtual-shark T on {len(ratios_rand)} random paths (mean)",
        "—",
        float(np.mean(ratios_rand)),
        f"{n_rand} random curvy paths, start -105 deg",
    )
    t.add("OCP T / virtual-shark T on random paths (worst)", "—", float(np.max(ratios_rand)), "")
    t.add(
        "paths without both times (virtual shark never reached S2)",
        "—",
        len(missing),
        "; ".join(missing) or "none",
    )
    t.emit(out, "bench_shark")
