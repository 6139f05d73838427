"""How many animals a bark reaches, and sweep points beyond the thesis's axes: the measurements
behind the traced herding findings of Figs 6.10a and 6.10b (docs/problems/herding.md).

In (6.1) a barking drone moves every animal inside its cone (radius ``R_b``, opening ``beta``,
axis towards the herd's centroid) at ``V_animal``, whatever the animal's distance; so what
``R_b`` and the stand-off ``d_s`` change is which animals the cones hold. :func:`bark_reach` runs
the proposed herder and counts them at regular instants. :func:`run_sweep_points` runs more
points of a Figs 6.8-6.10 sweep, as the full reproduction runs its own (same task function,
same instance ids, same store schema). Units: metres, seconds.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import numpy as np

from droneplan.core.validation import check_int, check_positive, check_sequence
from droneplan.planners.herding import ProposedHerder
from droneplan.scenarios.herding import barking_mask, simulate, thesis_scenario

__all__ = ["bark_reach", "run_sweep_points"]


def bark_reach(
    n_animals: int, *, seed: int = 0, t_max: float = 2400.0, every: float = 10.0, **overrides: Any
) -> dict[str, Any]:
    """Run the proposed herder on :func:`~droneplan.scenarios.herding.thesis_scenario` until it
    gathers and count, every ``every`` seconds, the animals inside at least one drone's barking
    cone (every drone barking, axis at the centroid, as in the simulator).

    n_animals: herd size (>= 1); seed: the scenario's seed (the run's is seed + 10000, as in the
    reproduction); t_max: simulated seconds at most (> 0); every: seconds between counts (> 0);
    overrides: HerdingParams fields (e.g. ``R_b=60.0``, ``d_s=70.0``, in m).

    Returns ``gather_time`` (s, None when not gathered), ``frames`` (counts made), and the mean and
    median number of animals in a cone per count (``mean_reached``, ``median_reached``) with the
    mean as a share of the herd (``share_reached``).
    """
    n_animals = check_int("n_animals", n_animals, min_value=1)
    t_max = check_positive("t_max", t_max)
    every = check_positive("every", every)
    scenario = thesis_scenario(n_animals, seed=seed, **overrides)
    trace = simulate(
        scenario,
        ProposedHerder(),
        t_max=t_max,
        seed=int(seed) + 10_000,
        stop_after_gathering=True,
        frame_every=every,
    )
    p = scenario.params
    reached = np.array(
        [
            barking_mask(f.animals, f.drones, f.animals.mean(axis=0), p.R_b, p.beta).any(axis=1).sum()
            for f in trace.frames
        ],
        dtype=float,
    )
    mean = float(reached.mean()) if len(reached) else 0.0
    return {
        "gather_time": trace.gather_time,
        "frames": len(reached),
        "mean_reached": mean,
        "median_reached": float(np.median(reached)) if len(reached) else 0.0,
        "share_reached": mean / n_animals,
    }


def run_sweep_points(
    out: str | os.PathLike, sweep: str, values: Any, *, n_animals: int = 200, seeds: int = 20
) -> Any:
    """Run points of a Figs 6.8-6.10 sweep (both herders, ``seeds`` seeds each) into the results
    store ``out/results.sqlite``, as the full reproduction runs its own points (a rerun resumes).

    out: folder of the store; sweep: a key of ``herding.SWEEPS`` (e.g. ``"d_s"``); values: the
    swept parameter's values (e.g. ``[70.0, 90.0]`` m); n_animals: herd size; seeds: runs per
    point (seeds 0 .. seeds - 1). Returns the rows of those points (a DataFrame).
    """
    from droneplan.studies.common import make_executor
    from droneplan.studies.jobs import map_rows
    from droneplan.studies.store import ResultStore
    from droneplan.studies.thesis import herding

    if sweep not in herding.SWEEPS:
        raise ValueError(f"sweep must be one of {', '.join(herding.SWEEPS)}, got {sweep!r}")
    values = check_sequence("values", values, min_len=1)
    n_animals = check_int("n_animals", n_animals, min_value=1)
    seeds = check_int("seeds", seeds, min_value=1)
    key = herding.SWEEPS[sweep][4]
    t_max = herding._sweep_t_max(False)
    tasks = [herding._sweep_task(sweep, key, v, n_animals, s, t_max) for s in range(seeds) for v in values]
    tasks = list({t["instance"]: t for t in tasks}.values())
    folder = Path(out)
    folder.mkdir(parents=True, exist_ok=True)
    with ResultStore(folder / "results.sqlite") as store, make_executor(1) as executor:
        return map_rows(herding.run_pair, tasks, executor=executor, store=store, desc=f"{sweep} sweep points")
