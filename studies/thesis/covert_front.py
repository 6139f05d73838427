"""Covert observation: the optimised stealth-versus-arrival-time front.

For each arrival-time limit T (s), :func:`optimised_front` runs closed-loop controllers on the
scenario and keeps the lowest beta_max among the runs that reached the observation sphere by T.
The candidates are the thesis's sliding-mode law (its own arrival time) and the min-max bearing MPC
(:class:`planners.covert.MPCObserver`) whose approach schedule is set to arrive by T: the MPC closes
the distance to the sphere at ``progress * V_max`` after one second to turn, so
``progress = d / ((T - 1 - slack) V_max)`` (d: the distance from D_s to the sphere) is the slowest
approach that still arrives by T; ``tries`` raises it by 25 % steps (capped at 1) in case the run
arrives late. Every run is a candidate for every limit it meets, so the search is shared.

Each kept point stands beside the whole-mission lower bound of its class
(:func:`formulations.covert_bounds.mission_lower_bound` at t_a = T, with the run's own departure
t_f, end time and sphere error): no controller that arrives by T and keeps the same observation
window can record less. ``certified_within_deg`` is beta_max minus that bound: the point is proved
within this many degrees of the best possible. Since the bound holds for every controller of the
class, every point lies on or above it.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from droneplan.core.validation import (
    check_array,
    check_instance,
    check_int,
    check_nonneg,
    check_positive,
    check_work,
)

__all__ = [
    "QUICK_LIMITS",
    "FULL_LIMITS",
    "optimised_front",
    "optimised_front_section",
]

DEG = 180.0 / math.pi
_TURN_S = 1.0  # the MPC's approach schedule starts after one second to turn


def _check_limits(arrival_times: Any) -> np.ndarray:
    if isinstance(arrival_times, (int, float)) and not isinstance(arrival_times, bool):
        arrival_times = [arrival_times]
    arr = check_array("arrival_times", arrival_times, ndim=1, min_rows=1)
    if np.any(arr <= 0):
        raise ValueError(f"arrival_times must be > 0 (s), got {arr.tolist()}")
    return np.unique(arr)


def _progress_for(p: Any, limit: float, slack: float) -> float | None:
    """Slowest MPC approach fraction of V_max that arrives by ``limit`` (s), None if none can."""
    d = float(np.linalg.norm(p.D_s_arr - p.F_arr)) - p.L_u
    room = limit - _TURN_S - slack
    if room <= 0 or d / (room * p.V_max) > 1.0:
        return None
    return d / (room * p.V_max)


def _runs(scenario: Any, limits: np.ndarray, tries: int, slack: float, backend: str) -> list[tuple]:
    """Closed-loop runs (label, trace) of the search, shared by every limit."""
    from droneplan.planners.covert import MPCObserver, MPCObserverSettings, SlidingModeObserver
    from droneplan.scenarios.covert import simulate

    runs = [("sliding mode", simulate(scenario, SlidingModeObserver()))]
    seen: set[float] = set()
    for limit in limits:
        base = _progress_for(scenario.params, float(limit), slack)
        if base is None:
            continue
        for k in range(tries):
            prog = round(min(1.0, base * (1.0 + 0.25 * k)), 3)
            if prog in seen:
                continue
            seen.add(prog)
            obs = MPCObserverSettings(backend=backend, progress=prog)
            tr = simulate(scenario, MPCObserver(observer=obs))
            runs.append((f"MPC (approach {prog:g} V_max)", tr))
            if tr.t_a is not None and tr.t_a <= limit:
                break  # arrived in time: faster approaches only observe longer from closer in
    return runs


def _tol(tr: Any) -> float:
    return max(1.0, float(tr.sphere_error)) if np.isfinite(tr.sphere_error) else 1.0


def _point_row(scenario: Any, limit: float, runs: list[tuple], step: float, margin_deg: float) -> dict:
    from droneplan.formulations.covert_bounds import mission_lower_bound

    ok = [(lab, tr) for lab, tr in runs if tr.t_a is not None and tr.t_f is not None and tr.t_a <= limit]
    row: dict[str, Any] = {"arrival_limit_s": limit, "tried": len(runs)}
    if not ok:
        return row | {"method": None, "t_a": math.nan, "beta_max_deg": math.nan, "bound_deg": math.nan}
    lab, tr = min(ok, key=lambda r: r[1].beta_max)
    t_end = float(tr.t[-1])
    bound = mission_lower_bound(
        scenario,
        limit,
        tr.t_f,
        times=np.arange(0.0, t_end + 1e-9, step),
        t_end=t_end,
        sphere_tol=_tol(tr),
    )
    beta, lb = tr.beta_max * DEG, bound.value * DEG
    gap = beta - lb
    return row | {
        "method": lab,
        "t_a": tr.t_a,
        "t_f": tr.t_f,
        "t_end": t_end,
        "observed_s": tr.t_f - tr.t_a,
        "beta_max_deg": beta,
        "bound_deg": lb,
        "gap_pct": 100.0 * gap / lb if lb > 0 else math.nan,
        "certified_within_deg": gap,
        "certified": bool(gap <= margin_deg),
    }


def optimised_front(
    scenario: Any,
    arrival_times: Any,
    *,
    tries: int = 2,
    slack: float = 0.5,
    step: float = 1.0,
    margin_deg: float = 1.0,
    n_curve: int = 6,
    backend: str = "ipopt",
):
    """The best closed-loop plan found for each arrival-time limit, beside the whole-mission bound.

    scenario: a covert scenario without obstacles (the bound needs a fixed visible set).
    arrival_times: the arrival-time limits T (s, each finite and > 0); a run counts for T if it
    reached the sphere at t_a <= T. The closed-loop steps of the search (one sliding-mode run and up to
    ``tries`` MPC runs per distinct limit) are checked up front against the evaluations budget.
    tries: MPC approach speeds tried per limit (int >= 1; each is
    one closed-loop run, about 5 CPU s on thesis case 1). slack: time (s, >= 0) kept in hand when
    the MPC approach is scheduled to arrive by T. step: spacing (s, > 0) of the instants where
    the bound is evaluated (a subset of the control instants still gives a valid, weaker bound).
    margin_deg: a point is flagged ``certified`` when beta_max is within this many degrees
    (> 0) of its bound. n_curve: arrival times (int >= 1) of the bound curve drawn beside the
    points, from the earliest possible arrival to the latest limit. backend: the MPC's "nlp"
    backend ("ipopt" or "osqp").

    Returns (points, curve) DataFrames. points: one row per limit: arrival_limit_s, method
    (missing when no run arrived in time), t_a, t_f, t_end, observed_s (t_f - t_a) (s),
    beta_max_deg, bound_deg (the bound for controllers arriving by the limit and keeping the
    run's t_f, t_end and sphere error), gap_pct, certified_within_deg (beta_max - bound, deg),
    certified, tried (runs searched, shared by the limits). The MPC's slower approaches also
    retreat on a slower schedule, so later-arriving points leave earlier (observed_s shrinks).
    curve: t_a (s), bound_deg for the class with the points' earliest t_f, latest t_end and
    largest sphere error: it lies on or below every point's own bound.
    """
    import pandas as pd

    from droneplan.formulations.covert_bounds import mission_front
    from droneplan.scenarios.covert import CovertScenario

    check_instance("scenario", scenario, CovertScenario)
    limits = _check_limits(arrival_times)
    tries = check_int("tries", tries, min_value=1, max_value=10)
    slack = check_nonneg("slack", slack)
    step = check_positive("step", step)
    margin_deg = check_positive("margin_deg", margin_deg)
    n_curve = check_int("n_curve", n_curve, min_value=1, max_value=100)
    if not isinstance(backend, str):
        raise TypeError(f"backend must be a str, got {type(backend).__name__}")
    if getattr(scenario, "obstacles", ()):
        raise ValueError("scenario has obstacles: the whole-mission bound needs a fixed visible set")
    p = scenario.params
    # at most one sliding-mode run and ``tries`` MPC runs per limit, each a control step per dt
    steps = math.ceil((p.duration + 60.0) / p.dt)
    check_work("arrival_times", (1 + limits.size * tries) * steps, "evaluations")
    runs = _runs(scenario, limits, tries, slack, backend)
    points = pd.DataFrame([_point_row(scenario, float(T), runs, step, margin_deg) for T in limits])
    found = points.dropna(subset=["t_f"]) if "t_f" in points else points.iloc[:0]
    if found.empty:
        return points, pd.DataFrame(columns=["t_a", "bound_deg"])
    t_min = (float(np.linalg.norm(p.D_s_arr - p.F_arr)) - p.L_u) / p.V_max
    grid = np.unique(np.r_[np.linspace(t_min + 0.5, float(limits.max()), n_curve), found.arrival_limit_s])
    t_end = float(found.t_end.max())
    tol = max(_tol(tr) for _, tr in runs)
    fronts = mission_front(
        scenario,
        grid,
        float(found.t_f.min()),
        times=np.arange(0.0, t_end + 1e-9, step),
        t_end=t_end,
        sphere_tol=tol,
    )
    curve = pd.DataFrame([{"t_a": f.t_a, "bound_deg": f.value * DEG} for f in fronts])
    return points, curve


QUICK_LIMITS = (8.0, 9.0, 12.0, 16.0, 20.0)
"""Arrival-time limits (s) of the quick setting: from just after the earliest a closed loop arrives
on thesis case 1 (about 7 s: 57 m at V_max after a turn) to 20 s."""
FULL_LIMITS = tuple(float(t) for t in np.arange(8.0, 30.5, 2.0))
"""Arrival-time limits (s) of the full setting: every 2 s from 8 s to 30 s."""


def optimised_front_section(case: int, out: Any, *, quick: bool) -> Any:
    """The optimised front of thesis case ``case`` (1 or 2, seed 0) written under ``out``.

    quick: limits QUICK_LIMITS, one MPC approach per limit, bound at instants every 1 s, 5-point
    curve (about 40 CPU s on case 1); full: FULL_LIMITS, up to 3 approaches per limit, instants
    every 0.2 s, 12-point curve. out: directory (str or Path) for ``case{case}_optimised_front``
    .csv (the points), ``_bound.csv`` (the curve), ``.png`` and the comparison table
    (.csv, .md). Returns the points DataFrame.
    """
    from pathlib import Path

    import matplotlib.pyplot as plt

    from droneplan.core.validation import check_bool
    from droneplan.scenarios.covert import thesis_case
    from droneplan.studies.common import ComparisonTable

    case = check_int("case", case, min_value=1, max_value=2)
    quick = check_bool("quick", quick)
    out = Path(check_instance("out", out, (str, Path)))
    step = 1.0 if quick else 0.2
    points, curve = optimised_front(
        thesis_case(case, 0),
        QUICK_LIMITS if quick else FULL_LIMITS,
        tries=1 if quick else 3,
        step=step,
        n_curve=5 if quick else 12,
    )
    out.mkdir(parents=True, exist_ok=True)
    stem = f"case{case}_optimised_front"
    points.to_csv(out / f"{stem}.csv", index=False)
    curve.to_csv(out / f"{stem}_bound.csv", index=False)
    from droneplan.studies.plots.covert import plot_optimised_front

    fig = plot_optimised_front(points, curve, title=f"Case {case}: optimised stealth vs arrival front")
    fig.tight_layout()
    fig.savefig(out / f"{stem}.png", dpi=110)
    plt.close(fig)
    tab = ComparisonTable(f"Case {case}: optimised front (best closed loop per arrival limit vs bound)")
    for _, r in points.iterrows():
        if math.isnan(float(r.beta_max_deg)):
            tab.add(
                f"arrive by {r.arrival_limit_s:g} s: beta_max / bound (deg)", None, "none", "no run arrived"
            )
            continue
        tab.add(
            f"arrive by {r.arrival_limit_s:g} s: beta_max / bound (deg)",
            None,
            f"{r.beta_max_deg:.2f} / {r.bound_deg:.2f}",
            f"{r.method}, t_a = {r.t_a:.1f} s, t_f = {r.t_f:.1f} s; certified within "
            f"{r.certified_within_deg:.2f} deg (instants every {step:g} s)",
        )
    tab.emit(out, stem)
    return points
