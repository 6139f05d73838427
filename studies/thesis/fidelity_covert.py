"""Which features of the covert scene set the hover-versus-sliding-mode margin (thesis §3.5).

The thesis reports that its sliding-mode laws lower the largest recorded bearing change
beta_max by 28.9 % against hover on case 1 (15.5 deg against 21.8 deg, Fig. 3.10) and 33.1 % on
case 2 (22.2 deg against 32.2 deg, Fig. 3.14), but gives no coordinates of its terrain or
target paths. Here a family of two-target scenes (:func:`two_target_scene`) is varied one
feature at a time around a base (:func:`feature_sweep`), and each scene gets

* hover: beta_max of the thesis's benchmark (fly towards F, hover, fly back);
* sliding: beta_max of the thesis's sliding-mode laws;
* bound: the whole-mission lower bound (``formulations.covert_bounds.mission_lower_bound``) for
  every controller that leaves D_s at t = 0, is on the sphere from the sliding-mode run's
  arrival t_a to its departure t_f and is back at D_s when that run ends;
* margin = (hover - sliding) / hover and the largest margin any such controller could have,
  (hover - bound) / hover.

:func:`run_fidelity_covert` adds the two presets of ``scenarios.covert.thesis_case`` (our
layout and the one reconstructed from Figs 3.9 and 3.11) and writes the table.
Units: metres, seconds; angles in degrees in the tables.
"""

from __future__ import annotations

import math
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from droneplan.core.validation import check_int, check_positive
from droneplan.formulations.covert_bounds import mission_lower_bound
from droneplan.planners.covert import HoverBenchmark, SlidingModeObserver
from droneplan.scenarios.covert import (
    THESIS_TABLE_3_2,
    CovertScenario,
    simulate,
    thesis_case,
    two_target_layout,
)

__all__ = [
    "BASE",
    "FEATURES",
    "FIGURE_FACTS",
    "two_target_scene",
    "figure_checks",
    "SEARCH_RANGES",
    "consistent_layouts",
    "margin_row",
    "feature_sweep",
    "run_fidelity_covert",
]

DEG = 180.0 / math.pi

BASE = {
    "centre_dist_m": 85.0,
    "centre_angle_deg": 0.0,
    "heading_deg": 0.0,
    "crossing_deg": 60.0,
    "closest_m": 20.0,
    "s_amplitude_m": 15.0,
    "hill_m": 25.0,
    "V_T": 2.0,
    "L_u": 200.0,
}
"""The base scene of the sweep (m, deg, m/s): two targets that pass closest (``closest_m`` apart)
at t = 60 s, their paths crossing at ``crossing_deg``; target 1 walks
an S (lateral amplitude ``s_amplitude_m``) and climbs a hill of ``hill_m`` in its second half;
``heading_deg`` turns their mean walking direction away from D_s.
The pair's centre lies ``centre_dist_m`` from F towards D_s, turned by ``centre_angle_deg`` about
F's vertical; the base puts it at (140, 140) on the zone's diagonal, so both targets stay at least
50 m inside the observation sphere."""

FEATURES = {
    "centre_dist_m": (40.0, 85.0, 120.0),
    "centre_angle_deg": (-30.0, 0.0, 30.0),
    "heading_deg": (-45.0, 0.0, 45.0),
    "crossing_deg": (0.0, 60.0, 120.0),
    "closest_m": (0.0, 20.0, 50.0),
    "s_amplitude_m": (0.0, 15.0, 30.0),
    "hill_m": (0.0, 25.0, 50.0),
    "V_T": (1.0, 2.0, 3.0),
    "L_u": (170.0, 200.0, 240.0),
}
"""The values each feature takes in :func:`feature_sweep` (the others stay at :data:`BASE`).
centre_dist_m/centre_angle_deg place the pair (the hover point is fixed by D_s and F, so moving
the pair moves it relative to the hover point); crossing_deg and closest_m set their separation over time;
s_amplitude_m their turn rate; hill_m the terrain; V_T the target speed; L_u the sphere radius."""


def two_target_scene(
    *,
    centre_dist_m: float = 85.0,
    centre_angle_deg: float = 0.0,
    heading_deg: float = 0.0,
    crossing_deg: float = 60.0,
    closest_m: float = 20.0,
    s_amplitude_m: float = 15.0,
    hill_m: float = 25.0,
    V_T: float = 2.0,
    L_u: float = 200.0,
) -> CovertScenario:
    """A two-target scene of the sweep: ``scenarios.covert.two_target_layout`` with the target
    speed V_T (m/s, > 0; each walks V_T * 120 s) and the sphere radius L_u (m, > 0, D_s outside)
    set in Table 3.2. centre_dist_m, centre_angle_deg, heading_deg, crossing_deg, closest_m,
    s_amplitude_m, hill_m: the layout (m and deg; see two_target_layout).
    """
    p = replace(THESIS_TABLE_3_2, V_T=check_positive("V_T", V_T), L_u=check_positive("L_u", L_u))
    return two_target_layout(
        centre_dist_m=centre_dist_m,
        centre_angle_deg=centre_angle_deg,
        heading_deg=heading_deg,
        crossing_deg=crossing_deg,
        closest_m=closest_m,
        s_amplitude_m=s_amplitude_m,
        hill_m=hill_m,
        params=p,
    )


FIGURE_FACTS = {"t_a": 7.4, "t_f": 113.2, "hover_deg": 21.8, "sliding_deg": 15.5}
"""What §3.5 states about case 1 in numbers (s, deg): the sliding-mode run arrives on the sphere at
t_a = 7.4 s and leaves it at t_f = 113.2 s (Fig. 3.11); beta_max 21.8 deg hover, 15.5 deg sliding."""


def figure_checks(scenario: CovertScenario, sliding, *, tol_t_a: float = 0.5, tol_t_f: float = 1.0) -> dict:
    """Which statements of Figs 3.9 and 3.11 and their text a case 1 scene and its sliding-mode run meet.

    scenario: a two-target scene; sliding: its ``CovertTrace`` under the sliding-mode laws;
    tol_t_a, tol_t_f: accepted distance of the run's t_a and t_f to 7.4 s and 113.2 s (s, > 0).
    Returns {check: bool} for: ``t_a``, ``t_f``; ``in_zone`` (both targets stay inside the 200 m x
    200 m zone of §3.5, to 1 m); ``approach_then_drift`` (the targets' distance is
    smallest between 40 and 80 s and larger at both ends); ``climb`` (target 1 rises >= 5 m over its
    second half, and the targets' height difference grows over it); ``away`` (both targets are
    farther from the drone at t_f than at t_a); ``beta_down_up`` (the run's beta_m at 60 s is below
    its values 1 s after t_a and 1 s before t_f, and it falls faster before 60 s than it rises after).
    """
    if not isinstance(scenario, CovertScenario) or scenario.n_targets != 2:
        raise ValueError("scenario must be a CovertScenario with two targets")
    tol_t_a, tol_t_f = check_positive("tol_t_a", tol_t_a), check_positive("tol_t_f", tol_t_f)
    t = np.asarray(sliding.t)
    A = scenario.targets_at(t)
    sep = np.linalg.norm(A[:, 0] - A[:, 1], axis=1)
    k_min = int(np.argmin(sep))
    out = {
        "t_a": sliding.t_a is not None and abs(sliding.t_a - FIGURE_FACTS["t_a"]) <= tol_t_a,
        "t_f": sliding.t_f is not None and abs(sliding.t_f - FIGURE_FACTS["t_f"]) <= tol_t_f,
        "in_zone": bool(np.all((A[..., :2] >= -1.0) & (A[..., :2] <= 201.0))),
        "approach_then_drift": bool(40.0 <= t[k_min] <= 80.0 and sep[0] > sep[k_min] < sep[-1]),
    }
    k60 = int(np.searchsorted(t, 60.0))
    z = A[:, :, 2]
    dz = np.abs(z[:, 0] - z[:, 1])
    out["climb"] = bool(z[-1, 0] - z[k60, 0] >= 5.0 and dz[-1] > dz[k60])
    if sliding.t_a is None or sliding.t_f is None:
        return {**out, "away": False, "beta_down_up": False}
    ka, kf = int(np.searchsorted(t, sliding.t_a)), int(np.searchsorted(t, sliding.t_f))
    dist = np.linalg.norm(A - sliding.drone[:, None, :], axis=2)
    out["away"] = bool(np.all(dist[kf] > dist[ka]))
    b = sliding.beta_m
    k1, k2 = int(np.searchsorted(t, sliding.t_a + 1.0)), int(np.searchsorted(t, sliding.t_f - 1.0))
    fall = (b[k1] - b[k60]) / max(t[k60] - t[k1], 1e-9)
    rise = (b[k2] - b[k60]) / max(t[k2] - t[k60], 1e-9)
    out["beta_down_up"] = bool(b[k60] < b[k1] and b[k60] < b[k2] and fall > rise)
    return out


def margin_row(scenario: CovertScenario, *, bound_step: float = 1.0) -> dict:
    """Hover, sliding mode and the whole-mission bound on one scene (deg, %, s, CPU s).

    scenario: the scene; bound_step: spacing of the bound's instants, s (> 0; a subset of the
    control instants is still a valid bound).
    Returns {hover_deg, sliding_deg, bound_deg, margin_pct, max_margin_pct, t_a, t_f, cpu_s};
    the bound is for controllers on the sphere from the sliding-mode run's t_a to its t_f.
    """
    if not isinstance(scenario, CovertScenario):
        raise TypeError(f"scenario must be a CovertScenario, got {type(scenario).__name__}")
    bound_step = check_positive("bound_step", bound_step)
    c0 = time.process_time()
    hover = simulate(scenario, HoverBenchmark())
    sliding = simulate(scenario, SlidingModeObserver())
    t_end = float(sliding.t[-1])
    bound = math.nan
    if sliding.t_a is not None:
        mb = mission_lower_bound(
            scenario,
            sliding.t_a,
            sliding.t_f,
            times=np.arange(0.0, t_end + 1e-9, bound_step),
            t_end=t_end,
            sphere_tol=max(1.0, float(sliding.sphere_error)),
        )
        bound = mb.value * DEG
    h, s = hover.beta_max * DEG, sliding.beta_max * DEG
    return {
        "hover_deg": h,
        "sliding_deg": s,
        "bound_deg": bound,
        "margin_pct": 100.0 * (h - s) / h,
        "max_margin_pct": 100.0 * (h - bound) / h,
        "t_a": sliding.t_a,
        "t_f": sliding.t_f,
        "cpu_s": time.process_time() - c0,
    }


def feature_sweep(features: dict | None = None, *, base: dict | None = None) -> list[dict]:
    """One feature at a time around ``base``: a :func:`margin_row` per (feature, value).

    features: {feature: values} (default :data:`FEATURES`); base: the other features' values
    (default :data:`BASE`). Returns rows {feature, value, **margin_row}.
    """
    features = FEATURES if features is None else features
    base = BASE if base is None else base
    if not isinstance(features, dict) or not isinstance(base, dict):
        raise TypeError("features and base must be dicts of two_target_scene keywords")
    unknown = (set(features) | set(base)) - set(BASE)
    if unknown:
        raise ValueError(f"features: unknown feature(s) {sorted(unknown)}; known: {sorted(BASE)}")
    rows = []
    for name, values in features.items():
        for value in values:
            kw = {**BASE, **base, name: float(value)}
            rows.append({"feature": name, "value": float(value), **margin_row(two_target_scene(**kw))})
    return rows


SEARCH_RANGES = {
    "centre_dist_m": (40.0, 110.0),
    "centre_angle_deg": (-30.0, 30.0),
    "heading_deg": (40.0, 90.0),
    "crossing_deg": (5.0, 120.0),
    "closest_m": (0.0, 30.0),
    "s_amplitude_m": (5.0, 30.0),
    "hill_m": (10.0, 40.0),
}
"""Uniform ranges (m, deg) of the random layouts of :func:`consistent_layouts` (two_target_layout
keywords; each value rounded to 0.1)."""


def consistent_layouts(n_samples: int = 160, seed: int = 7, *, ignore: tuple = ("in_zone",)) -> list[dict]:
    """Random case 1 layouts that meet the statements of Figs 3.9 and 3.11, with their margins.

    Draws ``n_samples`` layouts from :data:`SEARCH_RANGES` (numpy generator ``seed``), keeps those
    whose sliding-mode run passes every :func:`figure_checks` check except those in ``ignore``, and
    returns {**layout, **margin_row} for each (deg, %, s). n_samples: count (>= 1); seed: int >= 0.
    """
    n_samples = check_int("n_samples", n_samples, min_value=1)
    rng = np.random.default_rng(check_int("seed", seed, min_value=0))
    rows = []
    for _ in range(n_samples):
        kw: dict[str, float] = {
            k: round(float(rng.uniform(lo, hi)), 1) for k, (lo, hi) in SEARCH_RANGES.items()
        }
        sc = two_target_scene(**kw)
        checks = figure_checks(sc, simulate(sc, SlidingModeObserver()))
        if all(ok for k, ok in checks.items() if k not in ignore):
            rows.append({**kw, **margin_row(sc)})
    return rows


def _fmt(rows: list[dict], key: str) -> str:
    head = (
        f"| {key} | hover | sliding | bound | margin | max margin | t_a | t_f | CPU |\n"
        "|---|---|---|---|---|---|---|---|---|\n"
    )
    body = "".join(
        f"| {r[key]} | {r['hover_deg']:.2f} | {r['sliding_deg']:.2f} | {r['bound_deg']:.2f} | "
        f"{r['margin_pct']:.1f} % | {r['max_margin_pct']:.1f} % | {r['t_a']:.1f} | {r['t_f']:.1f} | "
        f"{r['cpu_s']:.1f} s |\n"
        for r in rows
    )
    return head + body


def run_fidelity_covert(out, *, features: dict | None = None) -> dict:
    """The layout study: the feature sweep, case 1's two layouts and case 2 (seeds 0-2).

    out: folder for ``covert_layout_study.txt`` (created); features: as in :func:`feature_sweep`.
    Also runs :func:`consistent_layouts` with its defaults.
    Returns {"sweep": rows, "presets": rows (keyed by "scene"), "consistent": rows, "path": the
    table's path}.
    """
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    rows = feature_sweep(features)
    presets = []
    for name, sc in (
        ("case 1, layout 'ours'", thesis_case(1)),
        ("case 1, layout 'figures'", thesis_case(1, layout="figures")),
        *((f"case 2, seed {k}", thesis_case(2, k)) for k in range(3)),
    ):
        presets.append({"scene": name, **margin_row(sc)})
    found = consistent_layouts()
    for r in found:
        r["layout"] = ", ".join(f"{k} {r[k]:g}" for k in SEARCH_RANGES)
    text = "# Covert layout study\n\nFeature sweep (one at a time around BASE; angles in deg):\n\n"
    for r in rows:
        r["feature = value"] = f"{r['feature']} = {r['value']:g}"
    text += _fmt(rows, "feature = value") + "\nPresets:\n\n" + _fmt(presets, "scene")
    text += "\nRandom layouts meeting the statements of Figs 3.9 and 3.11 (but the zone):\n\n"
    text += _fmt(found, "layout")
    path = out / "covert_layout_study.txt"
    path.write_text(text)
    return {"sweep": rows, "presets": presets, "consistent": found, "path": path}
