"""The registered bound engines of the closed-loop kinds, below the method registry.

A bound engine is droneplan's own function ``fn(scenario, *, ...)`` that
:mod:`droneplan.studies.methods` registers with role ``bound`` and a trusted bound; it returns
the engine result ``{"status", "bound", "bound_kind", "message", "extras"}``.

- :func:`onsphere_bounds` (``onsphere-optimum``, covert runs): the proven per-instant optimum on
  the sphere along the sliding mode's run, with the whole-mission bound of its class as an extra.
- :func:`interception_bounds` (``interception-bound``, shark paths): the offline OCP on the known
  path and its proven lower bound on the capture time, as extras.

This module imports no per-problem study module (:mod:`droneplan.studies.thesis.covert`,
:mod:`~droneplan.studies.thesis.covert_gap`, :mod:`~droneplan.studies.thesis.shark` import from it), so the
method registry reaches the engines without an import circle.
"""

from __future__ import annotations

import math
import time
from typing import Any

import numpy as np
from numpy.typing import NDArray

from droneplan.core.validation import require_set
from droneplan.formulations.covert import sphere_minmax_bearing
from droneplan.planners.covert import SlidingModeObserver
from droneplan.scenarios.covert import CovertTrace, simulate

__all__ = [
    "DEG",
    "MISSION_BOUND_CLASS",
    "BOUND_METRIC",
    "onsphere_bounds",
    "interception_bounds",
]

DEG = 180.0 / math.pi


# --------------------------------------------------------------------------- covert
def _on_sphere(tr: CovertTrace) -> NDArray[np.bool_]:
    if tr.t_a is None:
        return np.zeros(tr.t.size, bool)
    end = tr.t_f if tr.t_f is not None else tr.t[-1]
    return (tr.t >= tr.t_a) & (tr.t <= end)


def _instant_optima(
    tr: CovertTrace, scenario, part: int = 0, parts: int = 1
) -> tuple[NDArray[np.int_], NDArray[np.float64], NDArray[np.float64]]:
    """(k, bound, best): at every control instant k of tr's time on the sphere, the certified lower
    bound and the value of min over the sphere of max_j beta_j over the observable targets (rad).
    part, parts: only the ``part``-th of ``parts`` consecutive slices of those instants (each slice
    can run on its own core)."""
    ks, lbs, best = [], [], []
    c = None
    for k in np.array_split(np.nonzero(_on_sphere(tr))[0], parts)[part]:
        obs = scenario.observable_at(tr.t[k], tr.drone[k])  # the targets tr's drone could see
        if not obs.any():
            continue
        r = sphere_minmax_bearing(scenario.params, tr.targets[k][obs], c_start=c)
        if not r.has_solution:
            continue
        c = max(math.cos(require_set(r.objective, "a result with a solution has an optimum")) - 1e-3, 0.0)
        ks.append(k)
        lbs.append(r.bound)
        best.append(r.objective)
    return np.asarray(ks, int), np.asarray(lbs), np.asarray(best)


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


# --------------------------------------------------------------------------- shark
def _finite_or_none(v):
    return float(v) if v is not None and np.isfinite(v) else None


BOUND_METRIC = (
    "time to reach the frontal point G(T) within gamma (the offline OCP's T, the virtual shark's capture); "
    "not a bound on the time of first contact"
)
"""What the shark bound engine's proven bound is a bound on (kept as an extra of its row)."""


def interception_bounds(scenario: Any, *, time_limit: float | None = None) -> dict[str, Any]:
    """The shark bound engine (registered as ``interception-bound``): the offline OCP on the known
    path (:func:`planners.shark.optimal_interception`, N = 50) and its proven lower bound on T.

    scenario: an ``InterceptionScenario``; time_limit: wall-clock limit per IPOPT solve (s).
    Returns the engine result of :mod:`droneplan.studies.methods`. The bound is proven for the
    time to reach the frontal point G(T) (within gamma), i.e. for the OCP's T and the virtual
    shark's capture time, but a study scores the closed-loop time of first contact, which can come
    earlier (the field touches the shark as soon as D_h <= eps(h) at any frontal point, before the
    operator is at G(T)). So the row ranks no bound: ``capture_time_bound_s``, ``ocp_time_s`` and
    the metric they are about (``bound_metric``) are extras.
    """
    from droneplan.planners.shark import optimal_interception  # the shark controllers load on use

    tr = scenario.trajectory
    res = optimal_interception(tr, scenario.operator, scenario.params, N=50, time_limit=time_limit)
    extras = {
        "ocp_time_s": _finite_or_none(res.objective),
        "ocp_status": res.status.value,
        "ocp_local_optimum": bool(res.info.get("local_optimum", False)),
        "capture_time_bound_s": _finite_or_none(res.bound),
        "bound_metric": BOUND_METRIC,
        "start_won": res.info.get("start_won"),
        "bearing_deg": float(scenario.bearing_deg),
    }
    return {
        "status": "optimal" if res.bound is not None else "no_solution",
        "bound": None,
        "message": str(res.info.get("bound_message", "")),
        "extras": extras,
    }
