"""The MILP engine refuses a model too large for the machine before it builds anything of it:
``refuse_before_polish`` projects the hop rows of the smallest first round the polish could
lead to (incumbent at the continuous bound) before the polish; ``_ModelSolve`` projects the
first round's hop rows (``_projected_model_terms``, the build's own first projection) right
after the polish, before the bounds of the light-site rows, the LP fixing and the model's rows;
and each refuses only when nothing later could make that model smaller."""

import numpy as np
import pytest

from droneplan.formulations.cells import _milp, build_milp, candidate_sites, solve_exact
from droneplan.scenarios.cells import thesis_problem
from droneplan.solvers.result import Status


def _must_not_run(name):
    def fail(*a, **k):
        raise AssertionError(f"{name} ran before the model-size refusal")

    return fail


@pytest.fixture
def no_model_work(monkeypatch):
    """Every step after the refusal point fails the test if it runs."""
    for name in ("_disc_bounds", "lp_fixing", "build_milp"):
        monkeypatch.setattr(_milp, name, _must_not_run(name))
    monkeypatch.setattr(_milp, "model_term_cap", lambda: 1000)


@pytest.mark.parametrize("backend", ["cp-sat", "highs"])
def test_refused_before_any_model_is_built(backend, no_model_work, monkeypatch):
    """With a small cap the call is refused naming the projected terms, and neither the
    light-site bounds, the LP fixing nor any model build has run. On CP-SAT the first round
    is the final one and the LP fixing could drop sites, so its own cap is lowered below level
    2's projection (its build would stop there and drop nothing)."""
    if backend not in _milp.BACKENDS:
        pytest.skip(f"{backend} not installed")
    monkeypatch.setattr(_milp, "LP_FIXING_MAX_TERMS", 100)
    p = thesis_problem(4, 0)
    with pytest.raises(
        ValueError, match=r"more than 1,000 terms.*memory.*about [\d,]+ terms \([\d.]+ GiB\), projected"
    ):
        solve_exact(p, engine="milp", backend=backend, workers=1, time_limit=120)


def test_not_refused_early_while_the_lp_fixing_may_shrink_the_model(monkeypatch):
    """CP-SAT, first round final, LP fixing on and its model possibly under its cap: the early
    check leaves the decision to the build (which then refuses, counting while building)."""
    p = thesis_problem(4, 0)
    monkeypatch.setattr(_milp, "model_term_cap", lambda: 1000)
    monkeypatch.setattr(_milp, "LP_FIXING_MIN_SITES", 1)
    with pytest.raises(ValueError, match=r"more than 1,000 terms.*while the model was built"):
        solve_exact(p, engine="milp", workers=1, time_limit=120)


@pytest.mark.parametrize(("connectivity", "max_rounds"), [("hops", 0), ("lazy", 1)])
def test_no_refusal_when_no_hop_model_is_built(connectivity, max_rounds, monkeypatch):
    """No hop rows (lazy cuts) or no model at all (max_rounds 0): nothing to refuse."""
    monkeypatch.setattr(_milp, "model_term_cap", lambda: 1000)
    monkeypatch.setattr(_milp, "_projected_model_terms", _must_not_run("_projected_model_terms"))
    p = thesis_problem(3, 0)
    res = solve_exact(
        p, engine="milp", workers=1, time_limit=60, connectivity=connectivity, max_rounds=max_rounds
    )
    assert res.status in (Status.OPTIMAL, Status.FEASIBLE)
    assert res.objective is not None and res.objective >= res.info["incumbent"]["value"]


def test_a_normal_instance_is_not_refused():
    """Table 4.2 m = 4 seed 0 with this machine's cap: proven, to the branch and bound's value."""
    p = thesis_problem(4, 0)
    res = solve_exact(p, engine="milp", workers=1, time_limit=120)
    ref = solve_exact(p, engine="bnb", workers=1, time_limit=120)
    assert res.status is Status.OPTIMAL and ref.status is Status.OPTIMAL
    assert res.objective == ref.objective


def test_early_projection_is_the_builds_first_check(hop_term_calls):
    """The projection of ``_projected_model_terms`` is the figure the build's first check uses:
    with ``max_terms`` just below it over ``PROJECTION_MARGIN`` the build stops before writing a
    row (only the sample is counted), just above it the build writes level 2's rows."""
    p = thesis_problem(4, 0)
    cand = candidate_sites(p)
    keep = np.arange(0, len(cand.points), 3)
    total, level2 = _milp._projected_model_terms(p, cand, keep, "cp-sat")
    assert total == level2 * (p.n_cells - 1) and level2 > 1000
    calls = hop_term_calls
    calls["n"] = 0  # the projection above sampled rows too
    edge = total / _milp.PROJECTION_MARGIN
    below = build_milp(
        p, candidates=cand, keep=keep, lifted_hops=False, max_terms=int(edge) - 1, project_terms=True
    )
    assert below is None and calls["n"] <= _milp._PROJECTION_SAMPLE
    calls["n"] = 0
    build_milp(p, candidates=cand, keep=keep, lifted_hops=False, max_terms=int(edge) + 1, project_terms=True)
    assert calls["n"] > 2 * _milp._PROJECTION_SAMPLE  # level 2's rows were written after its sample


def assert_proven_from_the_greedy_start(res, expected, polish):
    """The model proved the branch and bound's optimum from the unpolished greedy start, and its
    info says why the polish left it (``polish``: how that reason begins)."""
    assert res.info["incumbent"]["polish"].startswith(polish)
    assert res.info["incumbent"]["value"] == res.info["incumbent"]["greedy"]
    assert res.status is Status.OPTIMAL and expected.status is Status.OPTIMAL
    assert res.objective == expected.objective


def test_polish_skipped_when_the_site_relations_would_not_fit(monkeypatch):
    """The polish holds the branch and bound's site relations; past POLISH_MEMORY_SHARE of the
    machine's memory the starts are used unpolished (said in info), and the model still proves
    the branch and bound's optimum from the greedy start."""
    from droneplan.formulations.cells import _bnb, _exact

    p = thesis_problem(3, 0)
    n = len(candidate_sites(p).points)
    need = _bnb.relation_bytes(n)
    expected = solve_exact(p, engine="bnb", workers=1, time_limit=120)
    monkeypatch.setattr(_bnb, "machine_memory", lambda: need / _exact.POLISH_MEMORY_SHARE - 1.0)
    monkeypatch.setattr(_exact, "search", _must_not_run("the polish"))
    res = solve_exact(p, engine="milp", workers=1, time_limit=120)
    assert_proven_from_the_greedy_start(res, expected, "skipped: the site relations would take")


def test_polish_runs_when_the_site_relations_fit(monkeypatch):
    """At exactly POLISH_MEMORY_SHARE of the memory the polish runs."""
    from droneplan.formulations.cells import _bnb, _exact

    p = thesis_problem(3, 0)
    need = _bnb.relation_bytes(len(candidate_sites(p).points))
    monkeypatch.setattr(_bnb, "machine_memory", lambda: need / _exact.POLISH_MEMORY_SHARE)
    res = solve_exact(p, engine="milp", workers=1, time_limit=120)
    assert res.info["incumbent"]["polish"] == "run"
    assert res.info["incumbent"]["greedy_polished"] >= res.info["incumbent"]["greedy"]


def test_no_early_refusal_when_the_time_limit_stopped_the_polish(monkeypatch):
    """When the polish's share of the time passed while the search's relations were built, the
    incumbent could still rise with more time, so the projection after the polish does not
    refuse; the model's build (with its own count) and the time limit answer instead. (The
    check before the polish is switched off here: it would refuse first, from the best case.)"""
    from droneplan.formulations.cells import _bnb, _exact

    monkeypatch.setattr(_exact, "refuse_before_polish", lambda *a, **k: None)

    monkeypatch.setattr(_bnb.BranchAndBoundSearch, "out_of_time", lambda self: True)
    monkeypatch.setattr(_milp, "model_term_cap", lambda: 1000)
    monkeypatch.setattr(_milp, "LP_FIXING_MAX_TERMS", 100)
    p = thesis_problem(4, 0)
    # the refusal named is the build's count, not the projection made before the model
    with pytest.raises(ValueError, match=r"more than 1,000 terms.*while the model was built"):
        solve_exact(p, engine="milp", workers=1, time_limit=120)


def test_a_stopped_polish_is_said_and_the_model_still_proves(monkeypatch):
    """The polish stopped by its time share (its search built nothing) leaves the greedy start
    as the incumbent, says so in info, and the model still proves the branch and bound's
    optimum."""
    from droneplan.formulations.cells import _bnb

    p = thesis_problem(3, 0)
    expected = solve_exact(p, engine="bnb", workers=1, time_limit=120)
    monkeypatch.setattr(_bnb.BranchAndBoundSearch, "out_of_time", lambda self: True)
    res = solve_exact(p, engine="milp", workers=1, time_limit=120)
    assert_proven_from_the_greedy_start(res, expected, "stopped: its share of the time limit passed")


def test_lp_fixing_skipped_before_its_model_when_level_2_alone_is_over_its_cap(monkeypatch):
    """The LP fixing's lifted model holds at least level 2's hop rows of the final model: when
    those alone are projected past its cap, no LP model is built (the skip is said in the
    model's stats) and the final model still proves the branch and bound's optimum."""
    p = thesis_problem(4, 0)
    expected = solve_exact(p, engine="bnb", workers=1, time_limit=120)
    monkeypatch.setattr(_milp, "LP_FIXING_MIN_SITES", 1)
    monkeypatch.setattr(_milp, "LP_FIXING_MAX_TERMS", 10)
    monkeypatch.setattr(_milp, "lp_fixing", _must_not_run("the LP fixing's model"))
    res = solve_exact(p, engine="milp", workers=1, time_limit=120)
    assert res.info["model_stats"]["lp_fixing"].startswith("skipped (level 2's hop rows projected at")
    assert res.status is Status.OPTIMAL and res.objective == expected.objective


def test_refused_before_the_polish_when_even_the_best_incumbent_leaves_too_large_a_model(monkeypatch):
    """With a small cap the refusal comes before the polish has run (its search fails the test),
    naming the projected terms."""
    from droneplan.formulations.cells import _exact

    monkeypatch.setattr(_milp, "model_term_cap", lambda: 1000)
    monkeypatch.setattr(_milp, "LP_FIXING_MAX_TERMS", 100)
    monkeypatch.setattr(_exact, "search", _must_not_run("the polish"))
    with pytest.raises(ValueError, match=r"more than 1,000 terms.*projected from a sample of level 2"):
        solve_exact(thesis_problem(4, 0), engine="milp", workers=1, time_limit=120)


@pytest.mark.parametrize(("m", "seed"), [(3, 0), (4, 0), (4, 3), (5, 1)])
def test_the_sites_projected_before_the_polish_are_a_subset_of_every_first_round(m, seed):
    """Soundness of the check before the polish: the sites it projects (the incumbent at the
    continuous bound) are among the first round's sites for the incumbent the polish does reach,
    and among those of every incumbent value up to the bound, so its projection never exceeds
    the one the later check makes (same sample rule, fewer rows)."""
    from droneplan.formulations.cells._exact import _polish
    from droneplan.formulations.cells._prepare import prepare

    p = thesis_problem(m, seed)
    prep = prepare(p, time_limit=120)
    b_best = prep.bound_m_minus_1()
    none = np.zeros((0, p.plan_width))
    best = set(_milp.reduce_candidates(p, prep.cand, float(prep.ub), none, b_best).tolist())
    _polish(prep)
    b_later = _milp._bound_m_minus_1(prep)
    assert b_best <= b_later + 1e-9
    for g in np.linspace(prep.inc_val, prep.ub, 5):
        later = set(_milp.reduce_candidates(p, prep.cand, float(g), prep.inc, b_later).tolist())
        assert best <= later
