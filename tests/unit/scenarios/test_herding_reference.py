"""Herding runs against trajectories saved from an earlier version of the code.

The speed work on the simulator and the herders (the hull prefilter and tracker, the per-animal
split of the animal step) must leave every trajectory unchanged for the same seeds. The saved file
``data/herding_reference.npz`` was computed with the code of commit 271a262 (before that work),
by running this module as a script on a checkout of that commit::

    python tests/unit/scenarios/test_herding_reference.py tests/unit/scenarios/data/herding_reference.npz

The runs cover the proposed herder (exact and collision-blind allocation), the benchmark herder,
gathering and driving, herds of 5 to 1000 animals.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

from droneplan.planners.herding import BenchmarkHerder, HerderSettings, ProposedHerder
from droneplan.scenarios.herding import simulate, thesis_scenario

DATA = Path(__file__).parent / "data" / "herding_reference.npz"

# name: (n_animals, scenario seed, herder, allocation, t_max (s), simulation seed, field size (m))
RUNS: dict[str, tuple[int, int, str, str, float, int, tuple[float, float] | None]] = {
    "p60": (60, 3, "proposed", "exact", 150.0, 5, (300.0, 200.0)),
    "b60": (60, 3, "benchmark", "exact", 150.0, 5, (300.0, 200.0)),
    "b200": (200, 0, "benchmark", "exact", 30.0, 1, None),
    "cb200": (200, 2, "proposed", "collision-blind", 30.0, 7, None),
    "p1000": (1000, 0, "proposed", "exact", 20.0, 1, None),
    "p5": (5, 1, "proposed", "exact", 60.0, 2, (100.0, 60.0)),
}


def run(name: str) -> dict[str, np.ndarray]:
    """The recorded arrays of one reference run (drone positions every 4th step)."""
    n, s0, kind, alloc, t_max, s1, field_size = RUNS[name]
    kw = {} if field_size is None else {"field_size": field_size}
    scenario = thesis_scenario(n, seed=s0, **kw)
    herder = ProposedHerder(HerderSettings(allocation=alloc)) if kind == "proposed" else BenchmarkHerder()
    trace = simulate(scenario, herder, t_max=t_max, seed=s1, snapshot_times=(t_max / 2,))
    mid = next(iter(trace.snapshots.values()))
    return {
        "t": trace.t,
        "drones": trace.drones[::4],
        "centroid": trace.centroid,
        "radius": trace.footprint_radius,
        "mid": mid.animals,
        "final": trace.final.animals,
        "final_headings": trace.final.headings,
        "gather_time": np.array(np.nan if trace.gather_time is None else trace.gather_time),
    }


@pytest.mark.parametrize("name", sorted(RUNS))
def test_same_seeds_give_the_saved_trajectories(name, recorded_blas_kernel):
    saved = np.load(DATA)
    got = run(name)
    for key, value in got.items():
        ref = saved[f"{name}/{key}"]
        assert value.shape == ref.shape, key
        # bit-identical on the machine that saved them; a libm differing in the last bit
        # elsewhere may move the drones' headings by rounding only
        np.testing.assert_allclose(value, ref, rtol=0, atol=1e-9, equal_nan=True, err_msg=key)


@pytest.mark.parametrize("hull", ["prefilter", "tracker"])
@pytest.mark.parametrize("name", ["p60", "cb200", "p1000"])
def test_the_size_dependent_paths_give_the_saved_trajectories_too(
    name, hull, monkeypatch, recorded_blas_kernel
):
    """The split animal step and the hull prefilter, which only large herds take, and the hull
    tracker, which mid-size herds take, forced on for every run."""
    from droneplan.planners.herding import geometry
    from droneplan.scenarios import herding

    monkeypatch.setattr(herding, "_SPLIT_MIN", 2)
    monkeypatch.setattr(herding, "_BALL_MIN", 2)
    if hull == "prefilter":
        monkeypatch.setattr(geometry, "_PREFILTER_MIN", 3)
    else:
        monkeypatch.setattr(geometry, "_PREFILTER_MIN", 10**9)
        monkeypatch.setattr(geometry, "_TRACK_MIN", 3)
    saved = np.load(DATA)
    for key, value in run(name).items():
        np.testing.assert_allclose(
            value, saved[f"{name}/{key}"], rtol=0, atol=1e-9, equal_nan=True, err_msg=key
        )


if __name__ == "__main__":
    out = {f"{name}/{key}": value for name in RUNS for key, value in run(name).items()}
    np.savez_compressed(sys.argv[1], **out)
