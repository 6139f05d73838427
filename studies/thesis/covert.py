"""Covert observation (thesis ch. 3): reproduction of Figs. 3.9-3.15, gap and bench.

- ``reproduce``: the thesis figures as tables "thesis | this run | how", each with
  the hover benchmark, the sliding-mode laws and the min-max bearing MPC, plus PNGs
  (3D trajectories, bearing changes, noise).
- ``gap``: hover / sliding / MPC per random target group against the proven bounds; it lives in
  :mod:`droneplan.studies.thesis.covert_gap` and is imported here, where ``droneplan gap covert`` finds it.
- ``reproduce`` also draws the stealth-versus-arrival-time front (:func:`stealth_front`), and in
  full mode the optimised front beside it (:mod:`droneplan.studies.thesis.covert_front`).
- ``bench``: MPC solve time per replan vs its control period (IPOPT and the OSQP
  real-time iteration), and the MPC-vs-sliding margin on both cases, for the MPC and
  the safeguarded MPC (MPC plan or sliding rollout per replan, with its arrival times).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

import matplotlib.pyplot as plt
import numpy as np

from droneplan.formulations.covert import MPCSettings
from droneplan.planners.covert import (
    HoverBenchmark,
    MPCObserver,
    MPCObserverSettings,
    SafeguardedMPCObserver,
    SlidingModeObserver,
)
from droneplan.scenarios.covert import CovertTrace, simulate, thesis_case
from droneplan.studies.bound_engines import DEG, _instant_optima, _on_sphere
from droneplan.studies.common import ComparisonTable, measured
from droneplan.studies.jobs import Job, run_reproduction
from droneplan.studies.plots.covert import animate, plot_bearing, plot_path, plot_stealth_front
from droneplan.studies.thesis.covert_front import optimised_front_section
from droneplan.studies.thesis.covert_gap import GAP_THESIS, gap
from droneplan.studies.thesis.report import flag_reasons

__all__ = ["DEG", "stealth_front", "reproduce", "reproduce_jobs", "gap", "GAP_THESIS", "bench"]


def _pct(a: float, b: float) -> float:
    """Relative change of a with respect to b (%)."""
    return 100.0 * (a - b) / b


def _oracle_on_sphere(tr: CovertTrace, scenario) -> tuple[float, float, float]:
    """(max over on-sphere instants of the proven lower bound, of the optimum, and max over those
    instants of tr's beta_m minus the optimum) in rad, at every control instant."""
    ks, lbs, best = _instant_optima(tr, scenario)
    if not ks.size:
        return math.nan, math.nan, math.nan
    return float(lbs.max()), float(best.max()), float(np.nanmax(tr.beta_m[ks] - best))


# --------------------------------------------------------------------------- plots
def _plot_3d(scenario, traces: dict[str, CovertTrace], path: Path, title: str) -> None:
    fig = plot_path(scenario, traces, title=title)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def _plot_beta(traces: dict[str, CovertTrace], path: Path, title: str, per_target: str | None = None) -> None:
    fig, ax = plt.subplots(1, 2 if per_target else 1, figsize=(11 if per_target else 6, 4), squeeze=False)
    plot_bearing(traces, ax=ax[0, 0], title=title)
    if per_target:
        tr = traces[per_target]
        for j in range(tr.beta.shape[1]):
            ax[0, 1].plot(tr.t, tr.beta[:, j] * DEG, label=f"beta_{j + 1}")
        ax2 = ax[0, 1].twinx()
        ax2.plot(tr.t, tr.distance_to_F, "k--", linewidth=0.8, label="|D-F|")
        ax2.set_ylabel("|D - F| (m)")
        ax[0, 1].set_xlabel("t (s)")
        ax[0, 1].set_ylabel("beta_j (deg)")
        ax[0, 1].set_title(f"{per_target}: per-target bearing changes")
        lines = ax[0, 1].get_lines() + ax2.get_lines()
        ax[0, 1].legend(
            lines, [ln.get_label() for ln in lines], fontsize=6, ncol=2 if tr.beta.shape[1] > 3 else 1
        )
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


# --------------------------------------------------------------------------- reproduce
def _case_table(case: int, traces, oracle: tuple[float, float, float], thesis: dict, out: Path, safe) -> dict:
    """The case table from its runs (the MPC variants' rows only for the variants that ran: see
    :func:`_case_runs`); returns the values the summary shows (``safe`` None without that run)."""
    h, s, m, g = traces["hover"], traces["sliding"], traces["mpc"], traces.get("mpc-safe")
    lb, _, excess = oracle
    tab = ComparisonTable(
        f"Case {case}: maximum recorded bearing change (Fig. 3.{10 if case == 1 else 14})",
        explain=flag_reasons("covert"),
    )
    _thesis_rows(tab, traces, thesis, lb)
    _mpc_rows(tab, traces, safe)
    _arrival_rows(tab, traces, thesis, safe)
    _oracle_rows(tab, traces, lb, excess)
    tab.emit(out, f"case{case}")
    return {
        "hover": h.beta_max,
        "sliding": s.beta_max,
        "mpc": m.beta_max,
        "oracle_lb": lb,
        "safe": None if g is None else g.beta_max,
        "t_a_safe": None if g is None else g.t_a,
        "t_a_sliding": s.t_a,
    }


def _thesis_rows(tab: ComparisonTable, traces, thesis: dict, lb: float) -> None:
    """The rows the thesis reports: hover and sliding-mode beta_max and the reduction."""
    h, s = traces["hover"], traces["sliding"]
    tab.add(
        "beta_max hover benchmark (deg)",
        thesis["hover"],
        h.beta_max * DEG,
        "max over run of max_j beta_j, true positions",
    )
    tab.add(
        "beta_max sliding mode (deg)",
        thesis["sliding"],
        s.beta_max * DEG,
        "saturated sliding-mode laws (§3.5)",
        why=f"no controller on the sphere over [t_a, t_f] gets below {lb * DEG:.2f} deg here (bound row)",
    )
    tab.add(
        "reduction sliding vs hover (%)",
        thesis["red"],
        _pct(s.beta_max, h.beta_max),
        "(sliding - hover) / hover",
        why=f"on the sphere over [t_a, t_f] no controller reduces by more than {-_pct(lb, h.beta_max):.1f} %",
    )


def _mpc_rows(tab: ComparisonTable, traces, safe) -> None:
    """The MPC observers' rows (IPOPT, and the OSQP, slow-approach and safeguarded variants that
    ran) against the sliding mode."""
    s, m = traces["sliding"], traces["mpc"]
    tab.add(
        "beta_max MPC, IPOPT (deg)",
        None,
        m.beta_max * DEG,
        "min-max tan-epigraph MPC, replan 0.5 s, horizon 4 s",
    )
    tab.add("MPC vs sliding (%)", None, _pct(m.beta_max, s.beta_max), "(MPC - sliding) / sliding")
    tab.add("MPC fallbacks to sliding mode", None, m.fallbacks, "failed solves (counted in the trace)")
    if "mpc-osqp" in traces:
        mo = traces["mpc-osqp"]
        tab.add(
            "beta_max MPC, OSQP SQP (deg)",
            None,
            mo.beta_max * DEG,
            f"one QP per replan; {mo.fallbacks} fallbacks",
        )
    if "mpc-slow" in traces:
        ms = traces["mpc-slow"]
        tab.add(
            "beta_max MPC, approach at 0.3 V_max (deg)",
            None,
            ms.beta_max * DEG,
            f"IPOPT; later arrival t_a = {ms.t_a:.1f} s",
        )
    if "mpc-safe" not in traces:
        return
    g = traces["mpc-safe"]
    tab.add(
        "beta_max safeguarded MPC (deg)",
        None,
        g.beta_max * DEG,
        f"per replan: MPC plan or sliding rollout, lower predicted max beta (margin "
        f"{safe.safeguard.margin * DEG:.2f} deg); MPC executed at "
        f"{safe.choices.count('mpc')}/{len(safe.choices)} replans",
    )
    tab.add(
        "safeguarded MPC vs sliding (%)",
        None,
        _pct(g.beta_max, s.beta_max),
        "(safeguarded - sliding) / sliding",
    )


def _arrival_rows(tab: ComparisonTable, traces, thesis: dict, safe) -> None:
    """Arrival and retreat times, and how well the runs keep to the sphere."""
    s, m, g = traces["sliding"], traces["mpc"], traces.get("mpc-safe")
    if g is not None:
        tab.add(
            "t_a safeguarded MPC / its arrival deadline (s)",
            thesis.get("t_a"),
            f"{g.t_a:.1f} / {safe.arrival_deadline:.1f}",
            f"deadline = predicted sliding arrival + {safe.safeguard.arrival_tolerance:.1f} s; "
            f"{g.fallbacks} fallbacks, {safe.late_sliding} late sliding steps",
        )
    tab.add(
        "t_a sliding / MPC (s)", thesis.get("t_a"), f"{s.t_a:.1f} / {m.t_a:.1f}", "first time on the sphere"
    )
    tab.add("t_f sliding / MPC (s)", thesis.get("t_f"), f"{s.t_f:.1f} / {m.t_f:.1f}", "start of the retreat")
    tab.add(
        "sphere error sliding / MPC (m)",
        0.0,
        f"{s.sphere_error:.3f} / {m.sphere_error:.3f}",
        "max | |D-F| - L_u | for t_a <= t <= t_f",
    )


def _oracle_rows(tab: ComparisonTable, traces, lb: float, excess: float) -> None:
    """The convex-program oracle's rows and whether the runs end back at D_s."""
    s, m = traces["sliding"], traces["mpc"]
    tab.add(
        "lower bound, any controller on the sphere over [t_a, t_f] of sliding (deg)",
        None,
        lb * DEG,
        "max over every control instant of the exact min over the sphere of max_j beta_j (convex program)",
    )
    tab.add(
        "sliding on-sphere beta_m minus instantaneous optimum (deg)",
        None,
        excess * DEG,
        "max over every on-sphere control instant of beta_m(sliding) - optimum",
    )
    tab.add(
        "back at D_s (sliding / MPC)", True, f"{s.finished} / {m.finished}", "|D - D_s| <= 5 cm at the end"
    )


def stealth_front(scenario, traces: dict[str, CovertTrace], *, n_arrivals: int = 6, step: float = 0.5):
    """beta_max against arrival time: one point per run, and the whole-mission lower bound.

    traces: {name: trace} of runs on ``scenario`` (each with an arrival t_a). The bound
    (:func:`formulations.covert_bounds.mission_front`) is computed for ``n_arrivals`` arrival
    times from the earliest possible (straight at V_max) to 5 s after the latest run's, plus each
    run's own arrival, for controllers that stay on the sphere (within the runs' largest sphere
    error, at least 1 m) until the earliest departure t_f among the runs and are back at D_s by the
    latest end among them, at instants every ``step`` s (a subset of the control instants: still a
    valid bound; instants times arrival times beyond the solves budget of
    ``core.validation.work_limits`` are refused up front). Returns (points, bound)
    DataFrames (angles in deg); each run's beta_max is >= the bound at its own arrival time.
    """
    import pandas as pd

    from droneplan.core.validation import check_instance, check_int, check_positive, check_work
    from droneplan.formulations.covert_bounds import mission_front
    from droneplan.scenarios.covert import CovertScenario

    check_instance("scenario", scenario, CovertScenario)
    n_arrivals = check_int("n_arrivals", n_arrivals, min_value=1)
    step = check_positive("step", step)
    if not isinstance(traces, dict):
        raise TypeError(f"traces must be a {{name: CovertTrace}} dict, got {type(traces).__name__}")
    if not traces:
        raise ValueError("traces must hold at least one run, got an empty dict")
    for name, tr in traces.items():
        check_instance(f"traces[{name!r}]", tr, CovertTrace)
    t_end = max((float(tr.t[-1]) for tr in traces.values() if len(tr.t)), default=0.0)
    # one convex program per instant and arrival time at worst (before the grid is allocated)
    # the refusal names the factor that made the count large: instants (step) or arrival times
    n_instants, n_times = t_end / step + 1, 1.0 + n_arrivals + len(traces)
    check_work("n_arrivals" if n_times > n_instants else "step", n_instants * n_times, "solves")
    if all(tr.t_a is None for tr in traces.values()):
        raise ValueError("traces: no run reached the sphere (no arrival time to place)")
    p = scenario.params
    pts = pd.DataFrame(
        [
            {"method": k, "t_a": tr.t_a, "t_f": tr.t_f, "beta_max_deg": tr.beta_max * DEG}
            for k, tr in traces.items()
            if tr.t_a is not None
        ]
    )
    t_min = (float(np.linalg.norm(p.D_s_arr - p.F_arr)) - p.L_u) / p.V_max
    # the grid holds every run's own arrival time: a run arriving at t_a belongs to the class of
    # every arrival time >= t_a, and the bound is non-increasing in it
    arrivals = np.unique(np.r_[np.linspace(t_min + 0.5, float(pts.t_a.max()) + 5.0, n_arrivals), pts.t_a])
    t_f = float(pts.t_f.dropna().min())
    tol = max([1.0] + [float(tr.sphere_error) for tr in traces.values() if np.isfinite(tr.sphere_error)])
    times = np.arange(0.0, t_end + 1e-9, step)
    fronts = mission_front(scenario, arrivals, t_f, times=times, t_end=t_end, sphere_tol=tol)
    bound = pd.DataFrame(
        [
            {"t_a": f.t_a, "bound_deg": f.value * DEG, "attained_at_s": f.argmax, "class_t_f": t_f}
            for f in fronts
        ]
    )
    return pts, bound


def _front_section(case: int, scenario, traces: dict[str, CovertTrace], out: Path, quick: bool) -> None:
    names = {
        "sliding": "sliding mode",
        "mpc": "MPC (approach 0.7 V_max)",
        "mpc-slow": "MPC (approach 0.3 V_max)",
        "mpc-safe": "safeguarded MPC",
    }
    runs = {label: traces[k] for k, label in names.items() if k in traces}
    if not quick:  # two more approach speeds (reproduce_jobs runs them as jobs named mpc-p<f>)
        for prog in (0.5, 1.0):
            tr = traces.get(f"mpc-p{prog:g}")
            if tr is None:
                tr = simulate(scenario, MPCObserver(observer=MPCObserverSettings(progress=prog)))
            runs[f"MPC (approach {prog:g} V_max)"] = tr
    pts, bound = stealth_front(scenario, runs, n_arrivals=5 if quick else 10, step=1.0 if quick else 0.2)
    pts.to_csv(out / f"case{case}_stealth_front_points.csv", index=False)
    bound.to_csv(out / f"case{case}_stealth_front_bound.csv", index=False)
    fig = plot_stealth_front(pts, bound, title=f"Case {case}: stealth vs arrival time")
    fig.tight_layout()
    fig.savefig(out / f"case{case}_stealth_front.png", dpi=110)
    plt.close(fig)
    tab = ComparisonTable(f"Case {case}: stealth vs arrival time (whole-mission lower bound)")
    for _, r in pts.iterrows():
        lb = float(bound.bound_deg[np.isclose(bound.t_a, r.t_a)].iloc[0])
        tab.add(
            f"{r.method}: beta_max / bound for its arrival (deg)",
            None,
            f"{r.beta_max_deg:.2f} / {lb:.2f}",
            f"t_a = {r.t_a:.1f} s; bound: any controller on the sphere by then",
        )
    tab.add(
        "bound at the earliest / latest arrival of the grid (deg)",
        None,
        f"{bound.bound_deg.iloc[0]:.2f} / {bound.bound_deg.iloc[-1]:.2f}",
        f"t_a = {bound.t_a.iloc[0]:.1f} / {bound.t_a.iloc[-1]:.1f} s; on the sphere until t_f = "
        f"{bound.class_t_f.iloc[0]:.1f} s, instants every {1.0 if quick else 0.2} s",
    )
    tab.emit(out, f"case{case}_stealth_front")


def _peak_from(tr: CovertTrace, start: float, n: int) -> float:
    """Largest beta_m (rad) of ``tr`` over its first ``n`` instants from time ``start`` (s) on."""
    bm = tr.beta_m[:n][tr.t[:n] >= start - 1e-9]
    return float(np.nanmax(bm)) if np.isfinite(bm).any() else math.nan


def _noise_errors(case: int, level: float, runs: int, base: CovertTrace) -> dict[str, Any]:
    """``runs`` sliding-mode runs of case ``case`` at noise ``level`` (seeds 1000 case + r),
    against the noiseless run ``base``: the signed errors ``err`` = beta_max(noisy) -
    beta_max(exact) (rad, the thesis's error of beta_m is their magnitude), the noisy runs'
    arrival times ``t_a`` (s, NaN: never on the sphere), ``err_on_sphere`` = the same difference
    of the largest beta_m from the later of the two arrivals on (rad), and the exact run's
    ``base_t_a`` and ``base_peak_t`` (the instant of its beta_max, s)."""
    sc = thesis_case(case, 0)
    err, t_a, on_sphere = [], [], []
    for r in range(runs):
        tr = simulate(sc, SlidingModeObserver(), noise=level, seed=1000 * case + r)
        err.append(tr.beta_max - base.beta_max)
        t_a.append(math.nan if tr.t_a is None else tr.t_a)
        if tr.t_a is None or base.t_a is None:
            on_sphere.append(math.nan)
            continue
        start, n = max(tr.t_a, base.t_a), min(tr.t.size, base.t.size)
        on_sphere.append(_peak_from(tr, start, n) - _peak_from(base, start, n))
    return {
        "err": err,
        "t_a": t_a,
        "err_on_sphere": on_sphere,
        "base_t_a": math.nan if base.t_a is None else base.t_a,
        "base_peak_t": float(base.t[int(np.nanargmax(base.beta_m))]),
    }


def _mpc_noise_error(case: int, base: CovertTrace) -> float:
    """Largest |beta_max(noisy) - beta_max(exact)| (rad) of 3 MPC runs of case ``case`` at 10 % noise."""
    sc = thesis_case(case, 0)
    errs = [
        abs(simulate(sc, MPCObserver(), noise=0.10, seed=77 + r).beta_max - base.beta_max) for r in range(3)
    ]
    return max(errs)


_NOISE_THESIS = {0.02: 0.3, 0.10: 2.0}
"""Fig. 3.15's bounds on the error of beta_m (deg) at 2 % and 10 % noise (§3.5, both cases)."""


def _noise_why(res: dict[str, Any]) -> str:
    """The measured reason of a Fig. 3.15 row beyond the thesis's bound, from :func:`_noise_errors`."""
    err, t_a = np.degrees(res["err"]), np.asarray(res["t_a"], float)
    on = np.abs(np.degrees(res["err_on_sphere"]))
    base_t_a = res["base_t_a"]
    facts = (
        f"measured: the exact run's beta_max is at t = {res['base_peak_t']:.1f} s (arrival t_a = "
        f"{base_t_a:.1f} s); the noisy runs arrive at {np.nanmean(t_a):.1f} s on average "
        f"({np.nanmin(t_a):.1f}-{np.nanmax(t_a):.1f} s), signed errors {err.min():+.2f} to "
        f"{err.max():+.2f} deg; from the later arrival on, the error is at most {np.nanmax(on):.2f} deg"
    )
    if np.nanmin(t_a) > res["base_peak_t"] and err.max() < 0.0:
        cause = (
            "the noise slows the To-sphere leg (there the targets' bearing changes tie and their "
            "steering vectors nearly cancel, so the noise turns their sum and the drone goes back and "
            "forth), so the drone reaches the sphere after the instant where the exact run peaks, and "
            "every noisy run peaks lower"
        )
        return f"{cause}; {facts}"
    return facts


def _noise_table(out: Path, levels: list[float], runs: int, **errors: Any) -> None:
    """Fig. 3.15 from the noise runs: ``errors`` maps ``e<case>_<i>`` (level index i) to the
    results of :func:`_noise_errors`, and ``mpc<case>`` to :func:`_mpc_noise_error`'s (full runs).

    The thesis bounds the error (< 0.3 deg at 2 %, < 2 deg at 10 %): a value within the bound is
    shown against the bound as a statement (no deviation); one beyond it is compared with the
    bound as a number, so it is flagged past the threshold, with the measured reason of
    :func:`_noise_why`."""
    import pandas as pd

    rows = []
    tab = ComparisonTable(f"Fig. 3.15: impact of measurement noise ({runs} runs per level, sliding mode)")
    for case in (1, 2):
        for i, lvl in enumerate(levels):
            res = errors[f"e{case}_{i}"]
            errs = np.abs(res["err"])
            rows.append(
                {
                    "case": case,
                    "noise": lvl,
                    "mean_err_deg": np.mean(errs) * DEG,
                    "max_err_deg": np.max(errs) * DEG,
                    "mean_signed_err_deg": np.mean(res["err"]) * DEG,
                    "max_err_on_sphere_deg": np.nanmax(np.abs(res["err_on_sphere"])) * DEG,
                    "mean_t_a_s": np.nanmean(res["t_a"]),
                    "exact_t_a_s": res["base_t_a"],
                }
            )
            bound = _NOISE_THESIS.get(lvl)
            if bound is None:
                continue
            worst = rows[-1]["max_err_deg"]
            tab.add(
                f"case {case}: max error of beta_max at {lvl:.0%} (deg)",
                bound if worst > bound else f"< {bound:g}",
                worst,
                f"|beta_max(noisy) - beta_max(exact)|, each component of a_j x (1 + {lvl:g} U(-1,1)) at "
                f"every step; thesis: < {bound:g} (a value beyond it is compared with the bound)",
                why=_noise_why(res),
            )
        at = {r["noise"]: r for r in rows if r["case"] == case}
        tab.add(
            f"case {case}: max error of beta_max from the later arrival on, "
            + " / ".join(f"{lvl:.0%}" for lvl in levels)
            + " (deg)",
            None,
            " / ".join(f"{at[lvl]['max_err_on_sphere_deg']:.2f}" for lvl in levels),
            "largest beta_m from max(t_a noisy, t_a exact) on, noisy minus exact",
        )
        tab.add(
            f"case {case}: t_a exact / mean noisy at " + " / ".join(f"{lvl:.0%}" for lvl in levels) + " (s)",
            None,
            " / ".join(
                [f"{rows[-1]['exact_t_a_s']:.1f}"] + [f"{at[lvl]['mean_t_a_s']:.1f}" for lvl in levels]
            ),
            "first time on the sphere",
        )
    for case in (1, 2):
        if f"mpc{case}" in errors:
            tab.add(
                f"case {case}: MPC max error of beta_max at 10% (deg)",
                None,
                errors[f"mpc{case}"] * DEG,
                "3 runs",
            )
    tab.emit(out, "fig3_15_noise")
    df = pd.DataFrame(rows)
    df.to_csv(out / "fig3_15_noise_rows.csv", index=False)
    fig, ax = plt.subplots(figsize=(6, 4))
    for case in (1, 2):
        d = df[df.case == case]
        ax.plot(d.noise * 100, d.max_err_deg, "o-", label=f"case {case} max")
        ax.plot(d.noise * 100, d.mean_err_deg, "x--", label=f"case {case} mean")
    ax.set_xlabel("noise amplitude (%)")
    ax.set_ylabel("error of max recorded beta_m (deg)")
    ax.legend()
    fig.tight_layout()
    fig.savefig(out / "fig3_15_noise.png", dpi=110)
    plt.close(fig)


_CASE_THESIS = {
    1: {"hover": 21.8, "sliding": 15.5, "red": -28.9, "t_a": 7.4, "t_f": 113.2},
    2: {"hover": 32.2, "sliding": 22.2, "red": -33.1},
}
_VARIANTS: dict[str, dict[str, Any]] = {
    "base": {},
    "speed": {"V_T": 5.0},
    "occlusion": {"occlusion": "obstacle"},
}


def _controller(name: str):
    """A fresh controller of reproduce's run ``name`` (``mpc-p<f>``: MPC approaching at f V_max)."""
    if name.startswith("mpc-p"):
        return MPCObserver(observer=MPCObserverSettings(progress=float(name[5:])))
    ctls: dict[str, Callable[[], Any]] = {
        "hover": HoverBenchmark,
        "sliding": SlidingModeObserver,
        "mpc": lambda: MPCObserver(observer=MPCObserverSettings(backend="ipopt")),
        "mpc-osqp": lambda: MPCObserver(observer=MPCObserverSettings(backend="osqp")),
        "mpc-slow": lambda: MPCObserver(observer=MPCObserverSettings(progress=0.3)),
        "mpc-safe": SafeguardedMPCObserver,
    }
    return ctls[name]()


def _run_job(case: int, controller: str, variant: str = "base"):
    """One closed-loop run of a thesis case (``variant``: a key of ``_VARIANTS``); the safeguarded
    MPC's run comes with a picklable summary of its choices, as ``(trace, summary)``."""
    ctl = _controller(controller)
    tr = simulate(thesis_case(case, 0, **_VARIANTS[variant]), ctl)
    if not isinstance(ctl, SafeguardedMPCObserver):
        return tr
    from types import SimpleNamespace

    guard = SimpleNamespace(margin=ctl.safeguard.margin, arrival_tolerance=ctl.safeguard.arrival_tolerance)
    summary = SimpleNamespace(
        safeguard=guard,
        choices=list(ctl.choices),
        arrival_deadline=ctl.arrival_deadline,
        late_sliding=ctl.late_sliding,
    )
    return tr, summary


def _oracle_part(case: int, part: int, parts: int, sliding: CovertTrace):
    """:func:`_instant_optima` of the sliding-mode run of ``case`` on one slice of its instants."""
    return _instant_optima(sliding, thesis_case(case, 0), part, parts)


def _oracle_join(sliding: CovertTrace, **slices: tuple) -> tuple[float, float, float]:
    """:func:`_oracle_on_sphere`'s values from the slices of :func:`_oracle_part`."""
    ks = np.concatenate([v[0] for v in slices.values()]).astype(int)
    if not ks.size:
        return math.nan, math.nan, math.nan
    lbs = np.concatenate([v[1] for v in slices.values()])
    best = np.concatenate([v[2] for v in slices.values()])
    return float(lbs.max()), float(best.max()), float(np.nanmax(sliding.beta_m[ks] - best))


def _traces(named: dict[str, Any]) -> dict[str, CovertTrace]:
    """Job inputs (``mpc_slow``, ``mpc_p0_5``, ``safe``) back under their run names."""
    runs = {}
    for k, v in named.items():
        name = "mpc-safe" if k == "safe" else k.replace("_", "-")
        if name.startswith("mpc-p"):
            name = "mpc-p" + name[5:].replace("-", ".")
        runs[name] = v[0] if name == "mpc-safe" else v
    return runs


def _case_job(case: int, out: Path, quick: bool, oracle: tuple[float, float, float], **named: Any) -> dict:
    """The case table, the 3-D and bearing figures (and case 1's GIF) from the runs."""
    sc = thesis_case(case, 0)
    traces = _traces(named)
    safe = named["safe"][1] if "safe" in named else None
    result = _case_table(case, traces, oracle, _CASE_THESIS[case], out, safe)
    main = {k: traces[k] for k in ("hover", "sliding", "mpc")}
    fig_no = 9 if case == 1 else 14
    _plot_3d(sc, main, out / f"case{case}_3d.png", f"Case {case}: drone paths (Fig. 3.{fig_no}a)")
    _plot_beta(main, out / f"case{case}_beta.png", f"Case {case}: beta_m", per_target="sliding")
    if case == 1:  # the sliding-mode run as a GIF: a few dozen frames in quick mode
        sl = traces["sliding"]
        animate(sl, out / "case1_sliding.gif", fps=8, stride=max(1, len(sl.t) // (40 if quick else 150)))
    return result


def _front_job(case: int, out: Path, quick: bool, **named: Any) -> None:
    """The stealth-versus-arrival-time front of ``case`` from its runs."""
    _front_section(case, thesis_case(case, 0), _traces(named), out, quick)


def _speed_job(out: Path, sliding: CovertTrace, mpc: CovertTrace) -> None:
    """Fig. 3.12: target speed 5 m/s on case 1's paths."""
    tr5 = {"sliding": sliding, "mpc": mpc}
    tab = ComparisonTable("Fig. 3.12: case 1 with V_T = 5 m/s (period 48 s)")
    for name, tr in tr5.items():
        on = _on_sphere(tr)
        gap = np.nanmedian(np.abs(tr.beta[on, 0] - tr.beta[on, 1])) * DEG if on.any() else math.nan
        tab.add(f"{name}: beta_max (deg)", None, tr.beta_max * DEG, "max recorded beta_m")
        tab.add(
            f"{name}: median |beta_1 - beta_2| on the sphere (deg)",
            "~0 (curves overlap)",
            gap,
            "min-max equalises the two",
        )
    tab.emit(out, "fig3_12_speed")
    _plot_beta(tr5, out / "fig3_12_beta.png", "Case 1, V_T = 5 m/s", per_target="sliding")


def _occlusion_job(out: Path, sliding: CovertTrace, mpc: CovertTrace) -> None:
    """Fig. 3.13: target 2 hidden by an obstacle (line of sight) from t = 90 s."""
    tro = {"sliding": sliding, "mpc": mpc}
    tab = ComparisonTable("Fig. 3.13: case 1, target 2 behind an obstacle from t = 90 s (line of sight)")
    for name, tr in tro.items():
        hidden = np.isnan(tr.beta[:, 1]) & (tr.t >= 60.0)
        tab.add(
            f"{name}: target 2 hidden from (s)",
            90.0,
            float(tr.t[hidden][0]) if hidden.any() else math.nan,
            "first instant after 60 s where the drone-target segment crosses the hedge (FIG_3_13_OBSTACLE)",
        )
        late = (tr.t >= 95.0) & _on_sphere(tr)
        tab.add(
            f"{name}: max beta_1 on the sphere for t >= 95 s (deg)",
            "close to 0",
            np.nanmax(tr.beta[late, 0]) * DEG if late.any() else math.nan,
            "drone sits on target 1's camouflage line",
        )
    tab.emit(out, "fig3_13_occlusion")
    _plot_beta(tro, out / "fig3_13_beta.png", "Case 1 with occlusion", per_target="sliding")


def _summary_job(out: Path, case1: dict, case2: dict) -> None:
    """The covert summary table from the two case tables' results."""
    summary = ComparisonTable("Covert summary")
    for case, r in ((1, case1), (2, case2)):
        summary.add(
            f"case {case}: MPC margin over sliding (%)",
            None,
            -_pct(r["mpc"], r["sliding"]),
            "positive = MPC lower max recorded beta",
        )
        if r["safe"] is None:  # not run for this case (quick)
            continue
        summary.add(
            f"case {case}: safeguarded MPC margin over sliding (%)",
            None,
            -_pct(r["safe"], r["sliding"]),
            f"positive = lower max recorded beta; arrives {r['t_a_safe']:.1f} s vs {r['t_a_sliding']:.1f} s",
        )
    summary.emit(out, "summary")


RUN_COST = {"hover": 1.0, "sliding": 1.5, "mpc": 8.0, "mpc-osqp": 4.0, "mpc-slow": 8.0, "mpc-safe": 10.0}
"""Estimated CPU seconds of one reproduce run per controller (the scheduler starts long chains first)."""


ORACLE_PARTS = 3
"""Slices of the on-sphere instants the per-instant oracle of a case is cut into (one job each)."""
ORACLE_COST = 25.0
"""Estimated CPU seconds of the per-instant oracle of one case."""


def _case_runs(case: int, quick: bool) -> tuple[str, ...]:
    """The runs of a case's table: every controller of :data:`RUN_COST`, except in a quick
    reproduction of case 2, which runs the thesis's comparison (hover, sliding mode) and the MPC;
    the MPC variants (OSQP, slow approach, safeguarded) are compared on case 1 there."""
    if quick and case == 2:
        return ("hover", "sliding", "mpc")
    return tuple(RUN_COST)


def _case_jobs(case: int, out: Path, quick: bool, jobs: list[Job]) -> str:
    """Append the runs, oracle, table and front of ``case`` to ``jobs``; returns the table's key."""
    section = f"covert case {case}"

    def run(name: str, sec: str = section) -> str:
        key = f"covert/base/case{case}/{name}"
        kwargs = {"case": case, "controller": name}
        jobs.append(Job(key, sec, _run_job, kwargs, cost=RUN_COST.get(name, RUN_COST["mpc"])))
        return key

    keys = {name: run(name) for name in _case_runs(case, quick)}
    if not quick:  # the front's two extra approach speeds
        keys.update({f"mpc-p{p:g}": run(f"mpc-p{p:g}", "covert stealth front") for p in (0.5, 1.0)})
    arg = {k: k.replace("-", "_").replace(".", "_") for k in keys}
    arg["mpc-safe"] = "safe"
    oracle = f"covert/base/case{case}/oracle"
    sliding = {"sliding": keys["sliding"]}
    slices = {}
    for part in range(ORACLE_PARTS):
        slices[f"p{part}"] = key = f"{oracle}/{part}"
        piece = {"case": case, "part": part, "parts": ORACLE_PARTS}
        jobs.append(Job(key, section, _oracle_part, piece, sliding, cost=ORACLE_COST / ORACLE_PARTS))
    jobs.append(Job(oracle, section, _oracle_join, {}, {**sliding, **slices}, cost=0.01))
    table = f"covert/base/case{case}/table"
    needs = {arg[k]: keys[k] for k in _case_runs(case, quick)}
    kwargs = {"case": case, "out": out, "quick": quick}
    jobs.append(Job(table, section, _case_job, kwargs, {**needs, "oracle": oracle}, cost=3.0, local=True))
    if case == 1 or not quick:
        front = {
            arg[k]: v for k, v in keys.items() if k in ("sliding", "mpc", "mpc-slow", "mpc-safe") or "-p" in k
        }
        jobs.append(
            Job(
                f"covert/base/case{case}/front",
                "covert stealth front",
                _front_job,
                kwargs,
                front,
                cost=15.0,
                local=True,
            )
        )
    return table


def reproduce_jobs(*, quick: bool, out: Path, store_path: Path | None = None) -> list[Job]:
    """The covert reproduction as jobs (:mod:`droneplan.studies.jobs`): every closed-loop run,
    the per-instant oracle and each table or figure, so they share one executor with the
    other problems; each run is made once and handed to every table that shows it.

    quick: 3 noise runs at 2 levels (full: 20 at 5), the MPC variants on case 1 only (case 2:
    hover, sliding mode and MPC, see :func:`_case_runs`), the stealth front of case 1 only, at 1 s
    instants (full: both cases at 0.2 s, two more MPC approach speeds, and the optimised front of
    :mod:`droneplan.studies.thesis.covert_front` for both cases); out: directory for the CSV, PNG and GIF
    files; store_path: not used (the covert jobs write their tables, no store rows), taken so that
    every problem's ``reproduce_jobs`` has one signature.
    """
    out = Path(out)
    jobs: list[Job] = []
    tables = {case: _case_jobs(case, out, quick, jobs) for case in (1, 2)}
    for variant, fn, section in (
        ("speed", _speed_job, "covert fig 3.12"),
        ("occlusion", _occlusion_job, "covert fig 3.13"),
    ):
        needs = {}
        for name in ("sliding", "mpc"):
            needs[name] = key = f"covert/{variant}/case1/{name}"
            run = {"case": 1, "controller": name, "variant": variant}
            jobs.append(Job(key, section, _run_job, run, cost=RUN_COST[name]))
        jobs.append(Job(f"covert/{variant}/table", section, fn, {"out": out}, needs, cost=1.0, local=True))
    levels = [0.02, 0.10] if quick else [0.02, 0.04, 0.06, 0.08, 0.10]
    runs = 3 if quick else 20
    noise: dict[str, str] = {}
    for case in (1, 2):
        base = {"base": f"covert/base/case{case}/sliding"}
        for i, lvl in enumerate(levels):
            noise[f"e{case}_{i}"] = key = f"covert/noise/case{case}/{lvl:g}"
            kwargs = {"case": case, "level": lvl, "runs": runs}
            jobs.append(
                Job(key, "covert fig 3.15", _noise_errors, kwargs, base, cost=RUN_COST["sliding"] * runs)
            )
        if not quick:
            noise[f"mpc{case}"] = key = f"covert/noise/case{case}/mpc"
            mpc = {"base": f"covert/base/case{case}/mpc"}
            jobs.append(
                Job(key, "covert fig 3.15", _mpc_noise_error, {"case": case}, mpc, cost=3 * RUN_COST["mpc"])
            )
    jobs.append(
        Job(
            "covert/noise/table",
            "covert fig 3.15",
            _noise_table,
            {"out": out, "levels": levels, "runs": runs},
            noise,
            cost=1.0,
            local=True,
        )
    )
    summary = {"case1": tables[1], "case2": tables[2]}
    jobs.append(
        Job("covert/summary", "covert case 1", _summary_job, {"out": out}, summary, cost=0.1, local=True)
    )
    if not quick:
        for case in (1, 2):
            front = {"case": case, "out": out, "quick": False}
            key = f"covert/optimised-front/case{case}"
            jobs.append(
                Job(key, "covert stealth front", optimised_front_section, front, cost=120.0, local=True)
            )
    return jobs


def reproduce(*, quick: bool, out: Path, executor=None) -> None:
    """Figs. 3.9-3.15 with the thesis value beside ours (and an MPC column); CSV, PNG and GIF in
    ``out``. quick: see :func:`reproduce_jobs`; executor: from ``make_executor`` (default:
    serial in this process), where the runs and solves go."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    run_reproduction(reproduce_jobs(quick=quick, out=out), executor=executor)


# --------------------------------------------------------------------------- bench
def bench(*, quick: bool, out: Path) -> None:
    """MPC solve time per replan vs control period (IPOPT, OSQP-SQP) and MPC-vs-sliding margins;
    the convex per-instant and whole-mission programs, direct Clarabel against cvxpy (CPU and
    wall-time ratios measured in one run, with the load; rows in ``bench_convex_rows.csv``)."""
    out = Path(out)
    tab = ComparisonTable("Covert MPC bench (one run)")
    rows = []
    # (backend, replan_every, cases): replanning every 5 periods (0.5 s, the default) and at the
    # plant's period (0.1 s)
    configs: list[tuple[str, int, tuple[int, ...]]] = [
        ("ipopt", 5, (1, 2)),
        ("osqp", 5, (1, 2)),
        ("osqp", 1, (1, 2)),
    ]
    if not quick:
        configs.append(("ipopt", 1, (1,)))
    sliding = {}
    for case in (1, 2):
        sliding[case] = simulate(thesis_case(case, 0), SlidingModeObserver())
    for backend, every, cases in configs:
        for case in cases:
            sc = thesis_case(case, 0)
            sl = sliding[case]
            ctl = MPCObserver(
                mpc=MPCSettings(replan_every=every), observer=MPCObserverSettings(backend=backend)
            )
            with measured() as run:
                tr = simulate(sc, ctl)
            period = every * sc.params.dt
            st = tr.solve_times
            med, p90 = float(np.median(st)), float(np.quantile(st, 0.9))
            rows.append(
                {
                    "case": case,
                    "backend": backend,
                    "period_s": period,
                    "median_s": med,
                    "p90_s": p90,
                    "fallbacks": tr.fallbacks,
                    "solves": st.size,
                    "beta_mpc_deg": tr.beta_max * DEG,
                    "beta_sliding_deg": sl.beta_max * DEG,
                    "wall_s": run.wall_s,
                    "cpu_s": run.cpu_s,
                    "load_1min": run.load,
                }
            )
            target = "<= 1" if backend == "ipopt" else "<= 0.1"
            name = f"case {case} {backend} @ {period:.1f} s"
            tab.add(
                f"{name}: median solve / period",
                target,
                med / period,
                f"median {med * 1e3:.1f} ms, p90 {p90 * 1e3:.1f} ms over {st.size} solves; run {run.note}",
            )
            tab.add(
                f"{name}: fallbacks", None, f"{tr.fallbacks}/{st.size}", "failed solves -> sliding command"
            )
            tab.add(
                f"{name}: MPC margin over sliding (%)",
                ">= 15 (aim)",
                -_pct(tr.beta_max, sl.beta_max),
                f"beta_max {tr.beta_max * DEG:.2f} vs {sl.beta_max * DEG:.2f} deg",
            )
    # the safeguarded MPC: MPC plan or sliding rollout per replan (its solve time includes both scores)
    for case in (1, 2):
        sc = thesis_case(case, 0)
        ctl = SafeguardedMPCObserver()
        with measured() as run:
            tr = simulate(sc, ctl)
        sl = sliding[case]
        tab.add(
            f"case {case} safeguarded ipopt @ 0.5 s: MPC margin over sliding (%)",
            ">= 15 (aim)",
            -_pct(tr.beta_max, sl.beta_max),
            f"beta_max {tr.beta_max * DEG:.2f} vs {sl.beta_max * DEG:.2f} deg; MPC plan executed at "
            f"{ctl.choices.count('mpc')}/{len(ctl.choices)} replans",
        )
        tab.add(
            f"case {case} safeguarded: arrival t_a (s)",
            "7.4 (case 1)",
            f"{tr.t_a:.1f} (deadline {ctl.arrival_deadline:.1f}, sliding {sl.t_a:.1f})",
            "deadline = predicted sliding arrival + tolerance",
        )
        med = float(np.median(tr.solve_times))
        tab.add(
            f"case {case} safeguarded @ 0.5 s: median (solve + scoring) / period",
            "<= 1",
            med / 0.5,
            f"median {med * 1e3:.1f} ms over {tr.solve_times.size} replans; run {run.note}",
        )
        tab.add(
            f"case {case} safeguarded: CPU time / simulated time",
            None,
            run.cpu_s / tr.t[-1],
            f"whole closed loop incl. both candidates' scoring; {run.note}",
        )
        rows.append(
            {
                "case": case,
                "backend": "ipopt-safeguarded",
                "period_s": 0.5,
                "median_s": float(np.median(tr.solve_times)),
                "p90_s": float(np.quantile(tr.solve_times, 0.9)),
                "fallbacks": tr.fallbacks,
                "solves": tr.solve_times.size,
                "beta_mpc_deg": tr.beta_max * DEG,
                "beta_sliding_deg": sl.beta_max * DEG,
                "wall_s": run.wall_s,
                "cpu_s": run.cpu_s,
                "load_1min": run.load,
            }
        )
    # what a later arrival buys (the margin's only lever, see the on-sphere bound in reproduce)
    for case in (1, 2):
        sc = thesis_case(case, 0)
        with measured() as run:
            tr = simulate(sc, MPCObserver(observer=MPCObserverSettings(progress=0.3)))
        tab.add(
            f"case {case} ipopt, approach at 0.3 V_max: margin over sliding (%)",
            None,
            -_pct(tr.beta_max, sliding[case].beta_max),
            f"arrives at t_a = {tr.t_a:.1f} s vs {sliding[case].t_a:.1f} s; run {run.note}",
        )
    sc = thesis_case(2, 0)
    with measured() as run:
        tr = simulate(sc, SlidingModeObserver())
    tab.add(
        "sliding mode: CPU time per control step / dt",
        None,
        run.cpu_s / tr.t.size / sc.params.dt,
        f"whole closed loop incl. simulation, case 2; {run.note}",
    )
    convex_rows = _bench_convex(tab, quick)
    tab.emit(out, "bench")
    import pandas as pd

    pd.DataFrame(rows).to_csv(out / "bench_rows.csv", index=False)
    pd.DataFrame(convex_rows).to_csv(out / "bench_convex_rows.csv", index=False)


def _bench_convex(tab: ComparisonTable, quick: bool) -> list[dict]:
    """The convex programs of :func:`bench`: the direct Clarabel layout against the cvxpy models
    (DPP, compiled once per shape before the timed runs), on the same instances in one run; adds
    the ratios to ``tab`` and returns the rows of ``bench_convex_rows.csv``."""
    from droneplan.formulations.covert_bounds import instant_minmax_bearing, mission_lower_bound
    from droneplan.scenarios.covert import THESIS_TABLE_3_2, random_case

    rng = np.random.default_rng(0)
    convex_rows = []
    sizes = (3, 10) if quick else (3, 10, 30)
    groups = {
        n: [
            np.column_stack([rng.uniform(80, 195, n), rng.uniform(80, 195, n), rng.uniform(0, 25, n)])
            for _ in range(10 if quick else 30)
        ]
        for n in sizes
    }
    for n, group in groups.items():
        runs, results = {}, {}
        for backend in ("clarabel", "cvxpy"):
            instant_minmax_bearing(THESIS_TABLE_3_2, group[0], backend=backend)  # compile / warm up
            with measured() as run:
                results[backend] = [
                    instant_minmax_bearing(THESIS_TABLE_3_2, A, backend=backend) for A in group
                ]
            runs[backend] = run
        diff = max(
            math.nan if a.objective is None or b.objective is None else abs(a.objective - b.objective)
            for a, b in zip(results["clarabel"], results["cvxpy"], strict=True)
        )
        fast, slow = runs["clarabel"], runs["cvxpy"]
        tab.add(
            f"per-instant optimum, {n} targets: cvxpy / direct Clarabel, CPU time",
            None,
            slow.cpu_s / fast.cpu_s,
            f"{len(group)} random groups; wall ratio {slow.wall_s / fast.wall_s:.2f}; direct "
            f"{fast.note}; cvxpy {slow.note}; max |optimum difference| {diff:.1e} rad",
        )
        for backend, run in runs.items():
            convex_rows.append(
                {
                    "program": "instant",
                    "size": n,
                    "backend": backend,
                    "instances": len(group),
                    "wall_s": run.wall_s,
                    "cpu_s": run.cpu_s,
                    "load_1min": run.load,
                    "max_abs_diff_rad": diff,
                }
            )
    sc = random_case(3, 5)
    times = np.arange(0.0, sc.params.duration + 1e-9, 2.0 if quick else 0.5)
    mission_lower_bound(sc, 10.0, times=times[::8], backend="cvxpy")  # compile most shapes first
    runs, values = {}, {}
    for backend in ("clarabel", "cvxpy"):
        with measured() as run:
            values[backend] = mission_lower_bound(sc, 10.0, times=times, backend=backend).value
        runs[backend] = run
    diff = abs(values["clarabel"] - values["cvxpy"])
    fast, slow = runs["clarabel"], runs["cvxpy"]
    tab.add(
        "whole-mission bound: cvxpy / direct Clarabel, CPU time",
        None,
        slow.cpu_s / fast.cpu_s,
        f"random_case(3, 5), t_a = 10 s, {times.size} instants; wall ratio "
        f"{slow.wall_s / fast.wall_s:.2f}; direct {fast.note}; cvxpy {slow.note}; "
        f"|bound difference| {diff:.1e} rad",
    )
    for backend, run in runs.items():
        convex_rows.append(
            {
                "program": "mission",
                "size": times.size,
                "backend": backend,
                "instances": 1,
                "wall_s": run.wall_s,
                "cpu_s": run.cpu_s,
                "load_1min": run.load,
                "max_abs_diff_rad": diff,
            }
        )
    return convex_rows
