"""The thesis GA's alternative readings (GASettings fields, GA_READINGS): each changes what it
claims to change, and the defaults are droneplan's reading, unchanged."""

import dataclasses

import numpy as np
import pytest

from droneplan.formulations.cells import CellProblem, evaluate
from droneplan.planners.cells import (
    GA_READINGS,
    GASettings,
    _crossover,
    _fitness,
    _mutate,
    ga_reading,
    genetic,
)
from droneplan.scenarios.cells import thesis_problem


def small(users, m=2, r1=3.0, r2=2.5, bounds=(-6, 6, -6, 6)):
    return CellProblem(
        users=np.asarray(users, float),
        gbs=np.zeros((1, 2)),
        n_cells=m,
        R_d=1.0,
        R_g=1.0,
        r1=r1,
        r2=r2,
        bounds=bounds,
    )


def random_small(seed, n, m):
    rng = np.random.default_rng(seed)
    return small(rng.uniform(-6, 6, size=(n, 2)), m=m)


THESIS_READING = GASettings(
    crossover="cell",
    mutation="gene",
    f_best="generation",
    result="final",
    carry_best=False,
    fitness="contributing",
)
"""Droneplan's reading of §4.3.2 spelled out field by field."""


def _same(a, b):
    assert a.objective == b.objective
    assert a.info["restart_bests"] == b.info["restart_bests"]
    assert a.info["final_best_share"] == b.info["final_best_share"]
    np.testing.assert_array_equal(a.info["chromosome"], b.info["chromosome"])
    assert a.info["evaluations"] == b.info["evaluations"]


@pytest.mark.parametrize("m", [1, 2, 3])
def test_defaults_are_the_thesis_reading(m):
    p = thesis_problem(m, 1)
    kw = {"pop_size": 8, "restarts": 3, "iter_max": 6, "seed": 5}
    base = genetic(p, **kw)
    _same(base, genetic(p, settings=THESIS_READING, **kw))
    _same(base, genetic(p, settings=ga_reading("ours"), **kw))
    assert GASettings() == THESIS_READING == ga_reading("ours")


def test_readings_table_is_well_formed():
    fields = {f.name for f in dataclasses.fields(GASettings)}
    assert "ours" in GA_READINGS and "favourable" in GA_READINGS
    for name, entry in GA_READINGS.items():
        assert set(entry) == {"settings", "label", "reads"}, name
        assert set(entry["settings"]) <= fields, name
        assert entry["label"] and entry["reads"], name
        assert isinstance(ga_reading(name), GASettings)
    assert GA_READINGS["ours"]["settings"] == {}
    with pytest.raises(ValueError, match="GA_READINGS"):
        ga_reading("nope")


@pytest.mark.parametrize(
    ("field", "value"),
    [("crossover", "row"), ("mutation", "pair"), ("f_best", "ever"), ("result", "last"), ("fitness", "f0")],
)
def test_unknown_reading_is_refused(field, value):
    with pytest.raises(ValueError, match=field):
        GASettings(**{field: value})
    with pytest.raises(TypeError, match="carry_best"):
        GASettings(carry_best=1)


def _pair(m, seed=0):
    rng = np.random.default_rng(seed)
    return rng.uniform(-5, 5, size=(1, 2, m, 2)), np.array([[3, 3]])


@pytest.mark.parametrize("m", [1, 3])
def test_column_crossover_swaps_every_y(m):
    pop, f = _pair(m)
    before = pop.copy()
    s = GASettings(crossover="column", p_c1=1.0, p_c2=1.0)
    rr, _, _ = _crossover(pop, f, s, np.random.default_rng(1))
    assert len(rr) == 1
    np.testing.assert_array_equal(pop[0, :, :, 0], before[0, :, :, 0])  # x untouched
    np.testing.assert_array_equal(pop[0, 0, :, 1], before[0, 1, :, 1])  # every y swapped
    np.testing.assert_array_equal(pop[0, 1, :, 1], before[0, 0, :, 1])


def test_cell_crossover_swaps_one_y():
    pop, f = _pair(3)
    before = pop.copy()
    _crossover(pop, f, GASettings(p_c1=1.0, p_c2=1.0), np.random.default_rng(1))
    np.testing.assert_array_equal(pop[..., 0], before[..., 0])
    moved = np.flatnonzero(pop[0, 0, :, 1] != before[0, 0, :, 1])
    assert len(moved) == 1
    k = moved[0]
    assert pop[0, 0, k, 1] == before[0, 1, k, 1] and pop[0, 1, k, 1] == before[0, 0, k, 1]


def _mutated(mode, seed=0):
    p = random_small(0, 10, 3)
    rng = np.random.default_rng(seed)
    pop = rng.uniform(-5, 5, size=(1, 40, 3, 2))
    f = np.zeros((1, 40), dtype=np.int64)
    fbest = np.ones((1, 1))  # every chromosome below f_best: a full-size step
    box = (np.array([-6.0, -6.0]), np.array([6.0, 6.0]))
    cand, changed = _mutate(p, pop, f, fbest, box, GASettings(mutation=mode, p_m=0.5), rng)
    return pop, cand, changed


def test_chromosome_mutation_moves_all_genes_of_a_chosen_chromosome():
    pop, cand, changed = _mutated("chromosome")
    moved = cand != pop
    assert changed.any() and not changed.all()
    assert np.all(moved[changed])  # a chosen chromosome: every gene
    assert not np.any(moved[~changed])  # the others: none


def test_gene_mutation_moves_some_genes():
    pop, cand, _ = _mutated("gene")
    moved = (cand != pop).reshape(40, -1)
    partial = moved.any(axis=1) & ~moved.all(axis=1)
    assert partial.any()  # per gene: chromosomes with only some genes moved


def test_f_best_scales_the_mutation():
    """At f = the population's best the (4.10) step is zero; against a higher f_best (the
    run's best so far, the "run" reading) the same chromosome moves."""
    p = random_small(0, 10, 2)
    pop = np.random.default_rng(0).uniform(-5, 5, size=(1, 6, 2, 2))
    f = np.full((1, 6), 4, dtype=np.int64)
    box = (np.array([-6.0, -6.0]), np.array([6.0, 6.0]))
    s = GASettings(p_m=1.0)
    same, _ = _mutate(p, pop, f, np.full((1, 1), 4.0), box, s, np.random.default_rng(1))
    moved, _ = _mutate(p, pop, f, np.full((1, 1), 8.0), box, s, np.random.default_rng(1))
    np.testing.assert_array_equal(same, pop)
    assert np.all(moved != pop)


@pytest.mark.parametrize("m", [1, 2])
def test_best_ever_is_at_least_the_final_best(m):
    p = thesis_problem(m, 2)
    kw = {"pop_size": 8, "restarts": 6, "iter_max": 10, "seed": 3}
    final = genetic(p, **kw)
    ever = genetic(p, settings=GASettings(result="best_ever"), **kw)  # same random draws
    assert all(e >= f for e, f in zip(ever.info["restart_bests"], final.info["restart_bests"], strict=True))
    assert ever.objective >= final.objective


def test_f_best_over_the_run_runs_and_returns_a_feasible_plan():
    p = thesis_problem(2, 2)
    r = genetic(p, pop_size=8, restarts=3, iter_max=8, seed=0, settings=GASettings(f_best="run"))
    assert evaluate(p, r.x).feasible and r.objective == evaluate(p, r.x).covered


def test_carry_best_never_loses_the_best_between_restarts():
    p = thesis_problem(2, 4)
    s = GASettings(carry_best=True, result="best_ever")
    r = genetic(p, pop_size=6, restarts=5, iter_max=4, seed=1, settings=s)
    bests = r.info["restart_bests"]
    assert len(bests) == 5 and bests == sorted(bests)  # each restart starts from the best so far
    assert r.iterations == 5 * 4 and evaluate(p, r.x).feasible


def test_fitness_readings():
    """One drone-cell in reach of the GBS over 2 users, one far out of reach over 3 users."""
    users = [[2.0, 0.0], [2.2, 0.3], [8.0, 8.0], [8.2, 8.0], [8.0, 8.2]]
    p = small(users, m=2, bounds=(-10, 10, -10, 10))
    chrom = np.array([[[2.1, 0.1], [8.1, 8.1]]])
    assert _fitness(p, chrom, None, mode="contributing")[0] == 2  # ours: the contributing cell's users
    assert _fitness(p, chrom, None, mode="all_or_nothing")[0] == 0  # one cell breaks (4.7)-(4.8)
    assert _fitness(p, chrom, None, mode="unfiltered")[0] == 5  # (4.9) alone
    ok = np.array([[[2.1, 0.1], [4.1, 0.1]]])
    assert _fitness(p, ok, None, mode="all_or_nothing")[0] == _fitness(p, ok, None)[0] == 2


@pytest.mark.parametrize("name", [n for n in GA_READINGS if n != "ours"])
def test_every_reading_returns_a_feasible_plan(name):
    p = thesis_problem(2, 0)
    r = genetic(p, pop_size=6, restarts=2, iter_max=3, seed=0, settings=ga_reading(name))
    ev = evaluate(p, r.x)
    assert ev.feasible and r.objective == ev.covered
