"""Closed-loop herding: gathering finishes, degenerate herds do not crash, the allocators agree."""

import numpy as np
import pytest

from droneplan.planners.herding import BenchmarkHerder, HerderSettings, ProposedHerder
from droneplan.scenarios.herding import HerdingScenario, simulate, thesis_scenario


def _small(n=50, seed=0):
    # a 300 m x 150 m field keeps the run short; R_c per Table 6.2's rule for 50 animals
    return thesis_scenario(n, seed=seed, field_size=(300.0, 150.0), goal=(-200.0, 75.0))


@pytest.mark.parametrize("herder", [ProposedHerder(), BenchmarkHerder()], ids=["proposed", "benchmark"])
def test_50_animal_gathering_and_driving_finish(herder):
    sc = _small()
    tr = simulate(sc, herder, t_max=900.0, seed=1)
    assert tr.gather_time is not None, "gathering did not finish"
    i = int(np.searchsorted(tr.t, tr.gather_time))
    assert tr.footprint_radius[i] <= sc.params.R_c
    assert np.all(tr.footprint_radius[:i] > sc.params.R_c)
    assert tr.total_time is not None and tr.total_time > tr.gather_time
    assert np.linalg.norm(tr.centroid[-1] - sc.goal) <= sc.params.goal_radius
    assert tr.max_animal_speed <= sc.params.V_animal * (1 + 1e-9)


def test_closed_loop_allocations_never_cross_but_collision_blind_ones_do():
    """Every allocation the proposed herder makes during a run keeps (6.22)-(6.23) (Theorem
    6.4.1: no drone passes another), while the collision-blind bottleneck, used in the same
    closed loop, regularly sends drones past each other."""
    sc = _small(seed=2)
    exact = ProposedHerder(HerderSettings(allocation="exact"))
    simulate(sc, exact, t_max=600.0, seed=2, stop_after_gathering=True)
    assert exact.n_allocations > 50
    assert exact.n_crossing_allocations == 0
    blind = ProposedHerder(HerderSettings(allocation="collision-blind"))
    simulate(sc, blind, t_max=600.0, seed=2, stop_after_gathering=True)
    assert blind.n_allocations > 50
    assert blind.n_crossing_allocations > 0


def test_allocators_drive_identical_runs():
    """The exact allocator and Algorithm 3 return the same optimum, so the closed-loop runs coincide."""
    sc = thesis_scenario(20, seed=4, field_size=(120.0, 60.0), goal=(-100.0, 30.0))
    tr_a = simulate(sc, ProposedHerder(HerderSettings(allocation="exact")), t_max=30.0, seed=5)
    tr_b = simulate(sc, ProposedHerder(HerderSettings(allocation="bruteforce")), t_max=30.0, seed=5)
    assert np.allclose(tr_a.footprint_radius, tr_b.footprint_radius)


@pytest.mark.parametrize(
    "animals",
    [
        np.full((30, 2), 100.0),
        np.column_stack([np.linspace(0, 200, 30), np.full(30, 50.0)]),
        np.array([[50.0, 50.0]]),
        np.array([[0.0, 0.0], [40.0, 30.0]]),
        np.array([[-300.0, 0.0], [0.0, 0.0], [-150.0, 200.0]]),
    ],
    ids=["one-point", "collinear", "single", "two", "triangle-3-vertices-4-drones"],
)
@pytest.mark.parametrize("cls", [ProposedHerder, BenchmarkHerder])
def test_degenerate_herds_do_not_crash(animals, cls):
    base = thesis_scenario(5, seed=0)
    sc = HerdingScenario(
        base.params,
        animals,
        np.array([[300.0, 0], [300, 50], [300, 100], [300, 150]]),
        base.headings,
        np.array([-300.0, 0.0]),
    )
    herder = cls()
    tr = simulate(sc, herder, t_max=40.0, seed=0)
    assert np.all(np.isfinite(tr.footprint_radius)) and np.all(np.isfinite(tr.drones))
    if cls is ProposedHerder and len(animals) == 3:
        assert herder.n_allocations > 0  # steering points padded to 4 (fewer hull vertices than drones)


@pytest.mark.slow
def test_cli_reproduce_quick_writes_tables_and_figures(tmp_path):
    from droneplan.studies.cli import main

    assert main(["reproduce", "herding", "--quick", "--out", str(tmp_path)]) == 0
    out = tmp_path / "herding"
    for name in (
        "fig_6_7.csv",
        "fig_6_7a_footprint.png",
        "fig_6_7bf_snapshots.png",
        "fig_6_8_to_6_10.csv",
        "fig_6_8_to_6_10_sweeps.png",
        "fig_6_7_runs.csv",
    ):
        assert (out / name).exists(), name
    import pandas as pd

    runs = pd.read_csv(out / "fig_6_7_runs.csv")
    assert runs["gather_time"].notna().all()
    assert (runs["max_animal_speed"] <= 4.0 + 1e-9).all()


def test_simulation_is_reproducible_from_its_seed():
    sc = thesis_scenario(30, seed=1, field_size=(150.0, 100.0))
    a = simulate(sc, ProposedHerder(), t_max=20.0, seed=9)
    b = simulate(sc, ProposedHerder(), t_max=20.0, seed=9)
    c = simulate(sc, ProposedHerder(), t_max=20.0, seed=10)
    assert np.array_equal(a.footprint_radius, b.footprint_radius) and np.array_equal(a.drones, b.drones)
    assert not np.array_equal(a.footprint_radius, c.footprint_radius)
