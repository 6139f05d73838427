import itertools

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from droneplan.formulations.cells import (
    CellProblem,
    build_milp,
    candidate_sites,
    circle_intersections,
    coverage_upper_bound,
    evaluate,
    greedy_placement,
    solve_exact,
    solve_milp,
)
from droneplan.formulations.cells._bnb import search
from droneplan.formulations.cells._exact import POLISH_EXCHANGE_SIZES, polish_exchange_sizes
from droneplan.formulations.cells._prepare import prepare
from droneplan.solvers.result import Status


def small(users, m=2, gbs=((0.0, 0.0),), R_d=1.0, R_g=1.0, r1=2.5, r2=2.5, bounds=None):
    return CellProblem(
        users=np.asarray(users, float),
        gbs=np.asarray(gbs, float),
        n_cells=m,
        R_d=R_d,
        R_g=R_g,
        r1=r1,
        r2=r2,
        bounds=bounds,
    )


# ----------------------------------------------------------------- evaluate on hand-built cases
def test_evaluate_direct_cell():
    p = small([[2.5, 0.0], [2.9, 0.3], [0.5, 0.0]], m=1)  # third user is served by the GBS
    ev = evaluate(p, [[2.5, 0.0]])
    assert ev.feasible and ev.covered == 2 and ev.connected.tolist() == [True]
    assert not p.active[2]


def test_evaluate_overlap_between_cells():
    p = small([[2.5, 0.0], [0.0, 2.5]], m=2)
    ev = evaluate(p, [[2.5, 0.0], [2.5, 1.5]])  # 1.5 < 2 R_d
    assert not ev.feasible and any("overlap" in v for v in ev.violations)
    assert evaluate(p, [[2.5, 0.0], [2.5, 2.0]]).feasible  # touching discs are allowed


def test_evaluate_overlap_with_gbs_cell():
    p = small([[1.9, 0.0]], m=1)
    ev = evaluate(p, [[1.9, 0.0]])
    assert not ev.feasible and any("GBS" in v for v in ev.violations) and ev.covered == 1


def test_evaluate_chain_of_relays():
    users = [[2.5, 0.0], [7.5, 0.0]]
    p = small(users, m=3)
    chain = [[2.5, 0.0], [5.0, 0.0], [7.5, 0.0]]  # links 2.5 <= r2, first within r1
    ev = evaluate(p, chain)
    assert ev.feasible and ev.covered == 2 and ev.connected.all()
    ev2 = evaluate(p, [[2.5, 0.0], [7.5, 0.0]])  # relay missing: 5.0 > r2
    assert not ev2.feasible and ev2.connected.tolist() == [True, False]


def test_evaluate_unreachable_cell():
    p = small([[10.0, 0.0]], m=1)
    ev = evaluate(p, [[10.0, 0.0]])
    assert not ev.feasible and "no backhaul" in ev.violations[0] and ev.covered == 1


def test_evaluate_too_many_and_bounds():
    p = small([[2.5, 0.0]], m=1, bounds=(-3, 3, -3, 3))
    assert not evaluate(p, [[2.5, 0.0], [-2.5, 0.0]]).feasible
    assert not evaluate(p, [[3.5, 0.0]]).feasible
    with pytest.raises(ValueError, match="positions"):
        evaluate(p, [[1.0, np.nan]])
    assert evaluate(p, np.zeros((0, 2))).feasible


@settings(max_examples=30, deadline=None)
@given(
    st.floats(-3, 3),
    st.floats(-3, 3),
    st.floats(0.2, 2.5),
    st.floats(-3, 3),
    st.floats(-3, 3),
    st.floats(0.2, 2.5),
)
def test_circle_intersections_lie_on_both_circles(x1, y1, r1, x2, y2, r2):
    pts = circle_intersections(np.array([x1, y1]), r1, np.array([x2, y2]), r2)
    for p in pts:
        assert abs(np.hypot(p[0] - x1, p[1] - y1) - r1) < 1e-6
        assert abs(np.hypot(p[0] - x2, p[1] - y2) - r2) < 1e-6


# ----------------------------------------------------------------- MILP vs brute force (same candidates)
def random_small(seed, n, m):
    rng = np.random.default_rng(seed)
    users = rng.uniform(-6, 6, size=(n, 2))
    return small(users, m=m, r1=3.0, r2=2.5)


@pytest.mark.parametrize("seed", range(4))
@pytest.mark.parametrize(("backend", "engine"), [("cp-sat", "milp"), ("highs", "milp"), ("cp-sat", "bnb")])
def test_milp_equals_brute_force_m2(brute_force, seed, backend, engine):
    p = random_small(seed, 14, 2)
    res = solve_exact(p, backend=backend, time_limit=60, engine=engine)
    assert res.status is Status.OPTIMAL
    assert res.objective == brute_force(p)
    ev = evaluate(p, res.x)
    assert ev.feasible and ev.covered == res.objective
    assert res.objective <= res.bound <= res.info["continuous_bound"]


@pytest.mark.parametrize(("connectivity", "engine"), [("lazy", "milp"), ("hops", "milp"), ("lazy", "bnb")])
@pytest.mark.parametrize("seed", range(6))
def test_milp_equals_brute_force_m3(brute_force, seed, connectivity, engine):
    p = random_small(seed, 9, 3)
    res = solve_exact(p, time_limit=60, connectivity=connectivity, engine=engine)
    assert res.status is Status.OPTIMAL and res.objective == brute_force(p)
    assert evaluate(p, res.x).feasible


@pytest.mark.parametrize("engine", ["milp", "bnb"])
@pytest.mark.parametrize("connectivity", ["lazy", "hops"])
@pytest.mark.parametrize("backend", ["cp-sat", "highs"])
def test_relay_chain_needs_three_hop_levels(backend, connectivity, engine):
    # users 2.5, 5 and 7.5 from the GBS: the last is covered only at the end of a chain of
    # three drone-cells (levels 1, 2, 3), which the hop-level model must admit
    p = small([[2.5, 0.0], [5.0, 0.0], [7.5, 0.0]], m=3, r1=2.5, r2=2.5)
    res = solve_exact(p, backend=backend, time_limit=60, connectivity=connectivity, engine=engine)
    assert res.status is Status.OPTIMAL and res.objective == 3 and len(res.x) == 3
    assert evaluate(p, res.x).feasible
    # with two drone-cells the third user is out of reach (levels stop at m = 2)
    r2 = solve_exact(
        p.with_cells(2), backend=backend, time_limit=60, connectivity=connectivity, engine=engine
    )
    assert r2.status is Status.OPTIMAL and r2.objective == 2 and evaluate(p, r2.x).feasible


def test_warm_start_is_kept_and_used():
    p = random_small(3, 7, 2)
    res = solve_exact(p, backend="highs", engine="milp")
    warm = solve_exact(p, backend="scip", warm_start=res.x, engine="milp")
    assert warm.status is Status.OPTIMAL and warm.objective == res.objective


def test_no_users_and_no_feasible_site():
    p = small(np.zeros((0, 2)), m=2)
    r = solve_milp(p)
    assert r.status is Status.OPTIMAL and r.objective == 0 and len(r.x) == 0
    far = small([[50.0, 50.0]], m=1)  # beyond r1 + (m-1) r2
    r = solve_milp(far)
    assert r.status is Status.OPTIMAL and r.objective == 0 and len(r.x) == 0


def test_continuous_bound_is_valid_against_a_dense_grid():
    p = random_small(5, 8, 1)
    b = coverage_upper_bound(p).bound
    g = np.linspace(-7, 7, 141)
    xx, yy = np.meshgrid(g, g)
    pts = np.column_stack([xx.ravel(), yy.ravel()])
    d = np.hypot(pts[:, None, 0] - p.targets[None, :, 0], pts[:, None, 1] - p.targets[None, :, 1])
    assert (d <= p.R_d).sum(1).max() <= b


def test_build_milp_rejects_backend():
    with pytest.raises(ValueError, match="backend"):
        build_milp(random_small(0, 3, 1), backend="no-such-solver")
    with pytest.raises(ValueError, match="backend"):
        solve_milp(random_small(0, 3, 1), backend="x")
    with pytest.raises(ValueError, match="time_limit"):
        solve_milp(random_small(0, 3, 1), time_limit=-1)


# ----------------------------------------------------------------- robustness
def test_infeasible_warm_start_returns_within_the_time_limit():
    # a warm start inside the GBS cell once made solve_milp loop forever; run it in a
    # subprocess so that a regression fails here instead of hanging the suite
    import subprocess
    import sys

    code = (
        "from droneplan.formulations.cells import CellProblem, solve_milp\n"
        "p = CellProblem([[2000,0],[2100,50]], [[0,0]], 1, 500, 1000, 3500, 3000, "
        "bounds=(-2500,2500,-2500,2500))\n"
        "for w in ([[0, 0]], [[3000, 0]], [[2000, 0], [2100, 0], [0, 0]]):\n"
        "    r = solve_milp(p, warm_start=w, time_limit=1)\n"
        "    print(r.status.name, r.objective, r.info['warm_start']['used'])\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    lines = out.stdout.split()
    assert lines[0::3] == ["OPTIMAL"] * 3 and lines[1::3] == ["2.0"] * 3
    # inside the GBS cell / outside bounds: nothing left to use; the feasible part of the third is used
    assert lines[2::3] == ["False", "False", "True"]


def test_warm_start_fate_is_reported():
    p = random_small(3, 7, 2)
    best = solve_milp(p)
    used = solve_milp(p, warm_start=best.x)
    assert used.warm_started and used.info["warm_start"]["used"]
    assert used.info["warm_start"]["value"] == best.objective
    # a start that is the incumbent from the outset and then polished (greedy's plan, 4 users,
    # polished to the optimum 5): the reason tells each part once
    q = random_small(3, 14, 3)
    start = greedy_placement(q)
    for warm, dropped in ((start, 0), (np.vstack([start, [[50.0, 50.0]]]), 1)):
        ws = solve_milp(q, warm_start=warm).info["warm_start"]
        assert ws["used"] and ws["reason"].count("its feasible part") == 1 and "polished to 5" in ws["reason"]
        assert ws["reason"].count("dropped") == dropped and ws["reason"].count("is the incumbent") == 1
    # a start with nothing feasible in it is not the incumbent, and the result says why
    poor = solve_milp(p, warm_start=[[50.0, 50.0]])
    ws = poor.info["warm_start"]
    assert not poor.warm_started and not ws["used"] and "dropped" in ws["reason"] and "greedy" in ws["reason"]
    assert poor.objective == best.objective


def _failing_backends(monkeypatch, names):
    """Make the registry hand out, for ``names``, models whose solve reports an ERROR status
    (as HiGHS does when another package in the process loaded its library globally)."""
    import droneplan.formulations.cells._prepare as prepare
    from droneplan.solvers.registry import get_backend
    from droneplan.solvers.result import SolveResult

    class Failing:
        def __init__(self, real):
            self.real = real

        def new_model(self):
            model = self.real.new_model()
            model.solve = lambda **kw: SolveResult(
                Status.ERROR, backend=self.real.name, backend_status="ABNORMAL", message="forced failure"
            )
            return model

    def lookup(name, kind=None):
        real = get_backend(name, kind)
        return Failing(real) if name in names else real

    monkeypatch.setattr(prepare, "get_backend", lookup)


def test_continuous_bound_falls_back_to_cp_sat_when_the_relaxation_fails(monkeypatch):
    p = random_small(1, 14, 2)
    good = coverage_upper_bound(p)
    ref = solve_milp(p)
    _failing_backends(monkeypatch, {"highs"})
    fb = coverage_upper_bound(p)
    assert fb.bound == good.bound and fb.backend == "cp-sat" and "highs: ERROR" in fb.message
    res = solve_milp(p)
    assert res.info["continuous_bound"] == ref.info["continuous_bound"]
    assert res.status is Status.OPTIMAL and res.objective == ref.objective


def test_continuous_bound_is_none_with_a_message_when_every_backend_fails(monkeypatch):
    import droneplan.formulations.cells._milp as milp
    import droneplan.formulations.cells._prepare as prepare

    p = random_small(1, 14, 2)
    ref = solve_milp(p)
    _failing_backends(monkeypatch, {"highs", "cp-sat"})
    b = coverage_upper_bound(p)
    assert b.bound is None and "not computed" in b.message
    # the candidate model is still solved, and the result says the continuous bound is
    # missing instead of reporting a stand-in such as the user count
    monkeypatch.undo()
    monkeypatch.setattr(milp, "coverage_upper_bound", lambda *a, **k: b)
    monkeypatch.setattr(prepare, "coverage_upper_bound", lambda *a, **k: b)
    res = solve_milp(p)
    assert res.info["continuous_bound"] is None and "not available" in res.message
    assert res.status is Status.OPTIMAL and res.objective == ref.objective
    assert res.bound == ref.objective and not res.info["global_optimal"]


def test_time_limit_covers_model_building():
    # At thesis scale, building the model takes seconds; the limit covers it (a deadline already
    # passed builds nothing) and the best plan and bound found by then come back. How close the
    # wall time stays to the limit is measured by `droneplan bench cells`, not here: on a shared
    # machine a wall-clock margin fails for reasons that are not the code's (6.6 s for a 2 s limit
    # was seen with two test runs on two cores); the generous bound below only catches a limit
    # that is ignored altogether.
    import time

    from droneplan.scenarios.cells import thesis_problem

    p = thesis_problem(4, 3)
    assert build_milp(p, deadline=time.perf_counter()) is None
    for limit in (0.5, 2.0):
        res = solve_milp(p, time_limit=limit)
        assert res.solve_time <= limit + 30.0
        assert res.status in (Status.FEASIBLE, Status.OPTIMAL) and evaluate(p, res.x).feasible
        assert res.objective == evaluate(p, res.x).covered and (
            res.bound is None or res.objective <= res.bound
        )


# ----------------------------------------------------------------- exact branch and bound
@settings(max_examples=25, deadline=None)
@given(st.integers(0, 10_000), st.integers(3, 10), st.integers(1, 3))
def test_bnb_equals_brute_force(brute_force, seed, n, m):
    # same candidate set, every placement enumerated: the B&B optimum must match, stay below
    # the continuous bound, and be a feasible placement worth what it says
    p = random_small(seed, n, m)
    res = solve_exact(p, engine="bnb", time_limit=60)
    assert res.status is Status.OPTIMAL and res.objective == brute_force(p) == res.bound
    ev = evaluate(p, res.x)
    assert ev.feasible and ev.covered == res.objective
    assert res.info["continuous_bound"] is None or res.bound <= res.info["continuous_bound"]


def brute_force_pruned(problem, *, backhaul=True, runner_up=False):
    """Brute force over the same candidates, enumerating only pairwise non-overlapping
    site sets (the others are infeasible), so m = 4-5 stays affordable; with
    backhaul=False the backhaul test is dropped (the relaxation of _bnb items 9-10)."""
    from droneplan.formulations.cells._core import TOL

    cand = candidate_sites(problem)
    q = cand.points
    apart = np.hypot(q[:, None, 0] - q[None, :, 0], q[:, None, 1] - q[None, :, 1]) >= 2 * problem.R_d - TOL
    best = 0
    values = []

    def grow(chosen, start):
        nonlocal best
        if chosen:
            ev = evaluate(problem, q[chosen])
            ok = ev.feasible or (not backhaul and all("backhaul" in v for v in ev.violations))
            if ok:
                values.append((ev.covered, list(chosen)))
                best = max(best, ev.covered)
        if len(chosen) == problem.n_cells:
            return
        for i in range(start, len(q)):
            if all(apart[i, j] for j in chosen):
                grow([*chosen, i], i + 1)

    grow([], 0)
    if runner_up:  # the best feasible placement below the optimum (positions, value)
        below = [(v, c) for v, c in values if v < best] or [(0, [])]
        v, c = max(below, key=lambda t: t[0])
        return best, q[c].reshape(-1, 2), v
    return best


@settings(max_examples=30, deadline=None)
@given(st.integers(0, 10_000), st.integers(4, 9), st.integers(3, 5))
def test_bnb_with_site_elimination_equals_brute_force(seed, n, m):
    # m >= 3 switches on items 9-10 of _bnb (backhaul-free bounds, site elimination). The
    # search starts, heuristics off, from the runner-up placement (one step below the
    # optimum), so a site cleared one unit too eagerly loses the optimum

    p = random_small(seed, n, m)
    best, runner_up, value = brute_force_pruned(p, runner_up=True)
    res = search(p, candidate_sites(p), runner_up, value, heuristics=False)
    assert res.proven and res.value == best == res.bound
    ev = evaluate(p, res.positions)
    assert ev.feasible and ev.covered == best
    assert solve_exact(p, engine="bnb", time_limit=60).objective == best


def _check_bnb_on_clusters(seed, n_clusters, m, *, half_width, spread, per_cluster, eliminate=True):
    """Branch and bound on users in Gaussian clusters equals brute force; started from the
    runner-up placement with heuristics off (as above)."""

    rng = np.random.default_rng(seed)
    centres = rng.uniform(-half_width, half_width, size=(n_clusters, 2))
    users = np.concatenate([rng.normal(c, spread, size=(per_cluster, 2)) for c in centres])
    p = small(users, m=m, r1=3.0, r2=2.5)
    best, runner_up, value = brute_force_pruned(p, runner_up=True)
    res = search(p, candidate_sites(p), runner_up, value, heuristics=False, eliminate=eliminate)
    assert res.proven and res.value == best == res.bound
    assert evaluate(p, res.positions).feasible


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 10_000), st.integers(2, 4), st.integers(3, 4))
def test_bnb_on_clustered_users_equals_brute_force(seed, n_clusters, m):
    # clustered users give many near-identical candidate sites, the case of _bnb item 11
    # (a child skipped or restricted because an explored sibling can replace it)
    _check_bnb_on_clusters(seed, n_clusters, m, half_width=5, spread=0.35, per_cluster=3)


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 10_000), st.integers(2, 3), st.integers(3, 4))
def test_bnb_on_wide_clusters_equals_brute_force(seed, n_clusters, m):
    # wide clusters: sibling sites cover different subsets of a cluster and share users
    # with sites just outside it, the case of item 11's count test (a sibling that keeps as
    # many users outside the lens replaces b) and of its branching on the E sites
    _check_bnb_on_clusters(seed, n_clusters, m, half_width=4, spread=0.7, per_cluster=4, eliminate=False)


def test_sibling_count_test_discounts_the_lens():
    # item 11's count test: sibling a (3 users) may replace b (2 users) only if a keeps 2
    # users that no completion site reaches. Here s, touching a's disc without overlapping
    # it, covers a's 2 edge users, so a keeps 1: P + b + s (4 users) beats P + a + s (3).
    # Without the lens term b would be skipped and the search would return 3.
    from droneplan.formulations.cells._core import Candidates, coverage_lists

    users = [[10.0, 0.0], [11.0, 0.0], [11.0, 0.0], [8.0, 0.0], [8.0, 0.0]]
    p = small(users, m=2, gbs=((10.0, 5.0),), r1=20.0, r2=20.0)
    a, b, s = [10.0, 0.0], [8.5, 0.0], [12.0, 0.0]  # a, b overlap; s is 2 R_d from a
    pts = np.array([a, b, s])
    cand = Candidates(
        points=pts, cover=coverage_lists(pts, p.targets, p.R_d), direct=np.ones(3, bool), n_generated=3
    )
    assert [len(c) for c in cand.cover] == [3, 2, 2]
    brute = max(
        evaluate(p, pts[list(x)]).covered
        for k in (1, 2)
        for x in itertools.combinations(range(3), k)
        if evaluate(p, pts[list(x)]).feasible
    )
    res = search(p, cand, np.array([a]), 3, heuristics=False, eliminate=False)
    assert brute == 4
    assert res.proven and res.value == 4 == res.bound
    assert sorted(map(tuple, res.positions.tolist())) == sorted([tuple(b), tuple(s)])


@settings(max_examples=15, deadline=None)
@given(st.integers(0, 10_000), st.integers(3, 9), st.integers(1, 4))
def test_backhaul_free_relaxation_is_exact(seed, n, k):
    # item 9's bounds come from searches on _without_backhaul(problem): every candidate
    # links to every GBS and to every other, so the search must return the best k
    # pairwise non-overlapping candidates with backhaul ignored
    from droneplan.formulations.cells._bnb import search
    from droneplan.formulations.cells._bnb_relaxed import _without_backhaul

    p = random_small(seed, n, k)
    cand = candidate_sites(p)
    if len(cand.points) == 0:
        return
    res = search(_without_backhaul(p, cand.points)(k), cand, np.zeros((0, 2)), 0, eliminate=False)
    assert res.proven and res.value == res.bound == brute_force_pruned(p, backhaul=False)


def _far_groups_case(seed):
    """Item 12 of _bnb on a random node: 1-3 unreached groups of placed sites in different
    directions beyond the GBS's reach, sites along their way in, between them and anywhere.
    Returns (item 12's bound, brute-force best weight of a completion), or None when the
    drawn placement is already reached or overlaps."""
    from droneplan.formulations.cells._bnb_groups import _separated_groups

    rng = np.random.default_rng(seed)
    r1t, r2t, gap = 3.0, 2.5, 1.0  # link ranges; sites closer than ``gap`` overlap
    k = int(rng.integers(1, 4))
    spread = 2 * np.pi / k if rng.random() < 0.5 else rng.uniform(0.3, 1.5)
    angles = rng.uniform(0, 2 * np.pi) + spread * np.arange(k) + rng.uniform(-0.3, 0.3, k)
    heads = np.c_[np.cos(angles), np.sin(angles)] * rng.uniform(r1t + 0.3, r1t + 1.8 * r2t, k)[:, None]
    along = [
        h * t + rng.normal(0, 0.8, 2) for h in heads for t in rng.uniform(0.2, 1.1, int(rng.integers(3, 6)))
    ]
    between = [
        (heads[a] + heads[b]) / 2 + rng.normal(0, 1.5, 2) for a in range(k) for b in range(a) for _ in "ab"
    ]
    anywhere = rng.uniform(-9, 9, size=(int(rng.integers(2, 5)), 2))
    pts = np.concatenate([heads, np.array(along), np.array(between).reshape(-1, 2), anywhere])
    w = rng.integers(0, 10, size=len(pts))
    dg = np.hypot(*pts.T)
    dall = np.hypot(pts[:, None, 0] - pts[None, :, 0], pts[:, None, 1] - pts[None, :, 1])

    def reached(sites):
        reach = dg[sites] <= r1t
        link = dall[np.ix_(sites, sites)] <= r2t
        for _ in sites:
            reach = reach | np.any(link & reach[None, :], axis=1)
        return reach

    P = list(range(k))
    dpp = dall[np.ix_(P, P)]
    reach = reached(P)
    if (dpp + 99 * np.eye(k) < gap).any() or reach.all():
        return None
    cmask = ~np.any(dall[P] < gap, axis=0) & (rng.random(len(pts)) < 0.9)
    cmask[P] = False
    r = int(rng.integers(2, 5))
    tops = sorted(w[cmask].tolist(), reverse=True)[:r]  # any r distinct sites weigh at most these
    tops += [0] * (r - len(tops))
    bound = _separated_groups(pts, w, dg, P, dpp, reach, cmask, r, tops, r1t, r2t)
    best = -np.inf
    for size in range(1, r + 1):
        for Q in itertools.combinations(np.flatnonzero(cmask).tolist(), size):
            if all(dall[a, b] >= gap for a, b in itertools.combinations(Q, 2)) and reached([*P, *Q]).all():
                best = max(best, float(w[list(Q)].sum()))
    return bound, best


@settings(max_examples=300, deadline=None)
@given(st.integers(0, 100_000))
def test_separated_groups_bound_holds_for_every_completion(seed):
    # item 12 must bound the weight of every completion that connects the node (brute force
    # over the completions); an overestimate of the slots it charges would prune the optimum
    case = _far_groups_case(seed)
    if case is not None:
        bound, best = case
        assert bound >= best


def test_separated_groups_bound_is_often_attained():
    # the oracle above compares real numbers: on a fixed sample, item 12 applies to many
    # nodes with a feasible completion and equals the best one on some (so a bound one
    # unit too low there fails the test above)
    cases = [c for c in map(_far_groups_case, range(400)) if c is not None]
    finite = [(b, best) for b, best in cases if b < np.inf and best > -np.inf]
    assert len(finite) > 50
    assert sum(b == best for b, best in finite) > 10
    assert all(b >= best for b, best in cases)


@settings(max_examples=30, deadline=None)
@given(st.integers(0, 10_000), st.integers(3, 4))
def test_bnb_with_far_apart_groups_equals_brute_force(seed, m):
    # clusters in different directions beyond the GBS's reach, so nodes hold far-apart
    # unreached groups (item 12); started from the runner-up with heuristics off

    rng = np.random.default_rng(seed)
    centres = rng.uniform(-9, 9, size=(3, 2))
    users = np.concatenate([rng.normal(c, 0.35, size=(3, 2)) for c in centres] + [rng.uniform(-9, 9, (4, 2))])
    p = small(users, m=m, r1=3.0, r2=2.5)
    best, runner_up, value = brute_force_pruned(p, runner_up=True)
    res = search(p, candidate_sites(p), runner_up, value, heuristics=False)
    assert res.proven and res.value == best == res.bound
    assert evaluate(p, res.positions).feasible


def _node_limited(problem, limit, workers=1):
    """branch_and_bound from an empty start, heuristics and site elimination off, stopped
    after ``limit`` nodes (the limits checked at every node)."""
    from droneplan.formulations.cells import _bnb

    every = _bnb._CHECK_EVERY
    _bnb._CHECK_EVERY = 1
    try:
        return _bnb.search(
            problem,
            candidate_sites(problem),
            np.zeros((0, 2)),
            0,
            heuristics=False,
            eliminate=False,
            workers=workers,
            node_limit=limit,
        )
    finally:
        _bnb._CHECK_EVERY = every


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 10_000), st.integers(8, 14), st.integers(2, 4), st.integers(2, 40))
@example(42, 14, 3, 20)
@example(48, 14, 4, 12)
@example(55, 14, 4, 8)
@example(59, 14, 3, 8)
def test_bnb_stopped_early_returns_a_valid_bound(seed, n, m, limit):
    # a search stopped by its limit reports the bound of what it has not searched: the
    # largest of the level bounds on the path (a node's bound, or the order bound of its
    # current child). The examples are cases where the smallest one is below the optimum.
    p = random_small(seed, n, m)
    best = brute_force_pruned(p)
    res = _node_limited(p, limit)
    assert res.value <= best <= res.bound
    if res.proven:
        assert res.value == best == res.bound
    if len(res.positions):
        ev = evaluate(p, res.positions)
        assert ev.feasible and ev.covered == res.value


def test_bnb_bound_when_stopped_tightens_as_the_search_advances():
    # before, a stopped search reported ``upper`` (here inf) whatever it had searched
    bounds = np.array(
        [[_node_limited(random_small(seed, 14, 4), limit).bound for limit in (2, 16)] for seed in range(8)]
    )
    assert np.all(np.isfinite(bounds))
    assert np.all(bounds[:, 1] <= bounds[:, 0]) and np.any(bounds[:, 1] < bounds[:, 0])


@pytest.mark.parametrize("seed", range(6))
def test_bnb_split_stopped_early_returns_a_valid_bound(seed, monkeypatch):
    from droneplan.formulations.cells import _bnb

    monkeypatch.setattr(_bnb, "_SPLIT_MIN_SITES", 0)
    p = random_small(seed, 12, 3 + seed % 2)
    best = brute_force_pruned(p)
    res = _node_limited(p, 6, workers=2)
    assert res.value <= best <= res.bound < np.inf


@pytest.mark.parametrize("seed", range(30))
def test_bnb_split_over_two_processes_equals_brute_force(seed, monkeypatch):
    # workers=2 deals the children of the root (m = 3) or of its children (m = 4) out to
    # two forked processes (the split is switched on for these small instances); started
    # from the runner-up with heuristics and site elimination off, so the optimum must
    # come back from a worker. (Searching only one share loses it on 3 of these seeds.)
    from droneplan.formulations.cells import _bnb

    monkeypatch.setattr(_bnb, "_SPLIT_MIN_SITES", 0)
    p = random_small(seed, 9, 3 + seed % 2)
    best, runner_up, value = brute_force_pruned(p, runner_up=True)
    res = _bnb.search(p, candidate_sites(p), runner_up, value, heuristics=False, eliminate=False, workers=2)
    assert res.proven and res.value == best == res.bound
    ev = evaluate(p, res.positions)
    assert ev.feasible and ev.covered == best


def test_bnb_counts_a_shared_lens_user_once(brute_force):
    # two drone-cells exactly 2 R_d apart both cover the user midway (a lens user): the
    # additive bound counts it twice, the value must count it once
    users = [[4.0, 0.0], [5.0, 0.0], [6.0, 0.0], [4.0, 0.3], [6.0, 0.3]]
    p = small(users, m=2, r1=6.5, r2=2.5)
    res = solve_exact(p, engine="bnb")
    assert res.status is Status.OPTIMAL and res.objective == brute_force(p) == 5
    assert evaluate(p, res.x).covered == 5


def test_bnb_with_relays_and_two_gbs(brute_force):
    # two GBSs; clusters reachable only through relays on either side
    rng = np.random.default_rng(7)
    users = np.concatenate([rng.normal([7.0, 0.0], 0.3, (5, 2)), rng.normal([-9.0, 0.0], 0.3, (3, 2))])
    p = small(users, m=3, gbs=((0.0, 0.0), (-4.0, 0.0)), r1=3.0, r2=2.5)
    res = solve_exact(p, engine="bnb")
    assert res.status is Status.OPTIMAL and res.objective == brute_force(p)
    assert evaluate(p, res.x).feasible


def test_bnb_time_limit_gives_a_valid_bound():
    from droneplan.scenarios.cells import thesis_problem

    p = thesis_problem(4, 1)
    ref = solve_exact(p, engine="bnb", time_limit=0.5)
    assert ref.status in (Status.FEASIBLE, Status.OPTIMAL) and evaluate(p, ref.x).feasible
    assert ref.objective <= ref.bound <= ref.info["continuous_bound"]


def test_user_clique_rows_are_cliques():
    # item 5 of the model: every at-most-one row over the sites covering a user must hold
    # only pairwise overlapping sites (a lens user, covered by two compatible sites, gets none)
    from droneplan.formulations.cells._core import TOL
    from droneplan.formulations.cells._model import _user_clique_sites

    for seed in range(3):
        p = random_small(seed, 14, 2)
        cand = candidate_sites(p)
        rows = _user_clique_sites(cand.points, cand.cover, p.targets, p.R_d)
        for sites in rows.values():
            q = cand.points[sites]
            d = np.hypot(q[:, None, 0] - q[None, :, 0], q[:, None, 1] - q[None, :, 1])
            assert np.all(d[np.triu_indices(len(q), 1)] < 2 * p.R_d - TOL)
    lens = small([[4.0, 0.0], [5.0, 0.0], [6.0, 0.0]], m=2, r1=6.5)
    cand = candidate_sites(lens)
    assert 1 not in _user_clique_sites(cand.points, cand.cover, lens.targets, lens.R_d)


@pytest.mark.parametrize("block", range(4))
def test_relay_bound_through_a_new_site_is_the_shortest_path(block):
    # item 3 of _bnb: the relay lower bounds of P + j must be shortest paths over the
    # complete graph (a path may enter j and go on through other P sites); an overestimate
    # would prune feasible branches. The one-step update used first was wrong on ~0.3 % of
    # such random cases, hence many of them.
    for seed in range(block * 500, (block + 1) * 500):
        _check_relay_bound(seed)


def _check_relay_bound(seed):
    from droneplan.formulations.cells._bnb_relays import _close, _relay_cost, _through

    rng = np.random.default_rng(seed)
    r1, r2 = 3.0, 2.5
    k, c = int(rng.integers(1, 5)), int(rng.integers(1, 5))
    pp, cc = rng.uniform(-12, 12, (k, 2)), rng.uniform(-12, 12, (c, 2))

    def cost(a, b):
        return _relay_cost(np.hypot(a[:, None, 0] - b[None, :, 0], a[:, None, 1] - b[None, :, 1]), r2, r2)

    cg = lambda q: _relay_cost(np.hypot(q[:, 0], q[:, 1]), r1, r2)  # noqa: E731
    dist = _close(pp, cg(pp), r2)
    gj, newd = _through(dist, gj_direct=cg(cc), ej=cost(pp, cc), epp=cost(pp, pp))
    for j in range(c):
        nodes = np.concatenate([pp, cc[j : j + 1]])
        d = cg(nodes)
        e = cost(nodes, nodes)
        for _ in range(len(nodes)):  # Bellman-Ford from the GBS
            d = np.minimum(d, np.min(d[:, None] + e, axis=0))
        assert gj[j] == d[-1] and np.array_equal(newd[:, j], d[:-1])


# ----------------------------------------------------------------- the public entries
def test_entries_name_their_engine_and_agree(brute_force):
    from droneplan.formulations.cells import branch_and_bound

    p = random_small(2, 14, 3)
    bb = branch_and_bound(p, workers=1)
    ex = solve_exact(p, engine="bnb", workers=1)
    mi = solve_milp(p, workers=1)
    assert bb.info["engine"] == ex.info["engine"] == "bnb" and bb.backend == "bnb"
    assert mi.info["engine"] == "milp" and mi.backend == "cp-sat" and "engine 'milp'" in mi.message
    assert bb.status is ex.status is mi.status is Status.OPTIMAL
    assert bb.objective == ex.objective == mi.objective == brute_force(p)


def test_entries_reject_bad_engine_and_workers():
    p = random_small(0, 3, 1)
    with pytest.raises(ValueError, match=r"engine.*bnb.*milp"):
        solve_exact(p, engine="cplex")
    with pytest.raises(ValueError, match="workers"):
        solve_exact(p, workers=0)
    with pytest.raises(ValueError, match="connectivity"):
        solve_exact(p, engine="milp", connectivity="flow")
    with pytest.warns(DeprecationWarning, match="solve_exact"):
        assert solve_milp(p, engine="bnb").info["engine"] == "bnb"


@pytest.mark.parametrize(
    ("entry", "engine", "expected"),
    [(solve_exact, "bnb", 2), (solve_exact, "milp", 1), (solve_milp, "milp", 1), (solve_exact, "milp", 2)],
)
def test_default_workers_per_engine(monkeypatch, entry, engine, expected):
    """workers=None resolves per engine (DEFAULT_WORKERS); an explicit count is passed on."""
    from droneplan.formulations.cells import _exact

    assert _exact.DEFAULT_WORKERS == {"bnb": 2, "milp": 1, "auto": 2}
    seen, result = [], object()

    def bnb(prep, workers, peer=None):
        seen.append(workers)
        return result

    def model(prep, *, workers, **kw):
        seen.append(workers)
        return result

    monkeypatch.setattr(_exact, "_solve_bnb", bnb)
    monkeypatch.setattr(_exact, "solve_prepared", model)
    monkeypatch.setattr(_exact, "_early_exit", lambda *a: None)
    p = random_small(0, 3, 1)
    kwargs = {} if expected == _exact.DEFAULT_WORKERS[engine] else {"workers": expected}
    if entry is solve_exact:
        kwargs["engine"] = engine
    assert entry(p, **kwargs) is result
    assert seen == [expected]


def _save_disagreement(directory, problem, found: dict) -> str:
    """Write the instance and what each method found to a JSON file; return its path."""
    import json

    path = directory / f"cells_disagreement_{abs(hash(problem.users.tobytes())) % 10**8}.json"
    path.write_text(
        json.dumps(
            {
                "users": problem.users.tolist(),
                "gbs": problem.gbs.tolist(),
                "n_cells": problem.n_cells,
                "R_d": problem.R_d,
                "R_g": problem.R_g,
                "r1": problem.r1,
                "r2": problem.r2,
                "bounds": problem.bounds,
                "found": found,
            },
            indent=1,
        )
    )
    return str(path)


@settings(max_examples=40, deadline=None)
@given(
    seed=st.integers(0, 10_000),
    n=st.integers(3, 9),
    m=st.integers(1, 4),
    backend=st.sampled_from(["cp-sat", "highs"]),
    connectivity=st.sampled_from(["hops", "lazy"]),
)
def test_branch_and_bound_equals_milp_equals_brute_force(seed, n, m, backend, connectivity, tmp_path_factory):
    # the two exact engines and brute force over the same candidates must agree; a
    # disagreement fails loudly and leaves the instance in a file for a regression test
    from droneplan.formulations.cells import branch_and_bound

    p = random_small(seed, n, m)
    bb = branch_and_bound(p, workers=1, time_limit=60)
    mi = solve_milp(p, backend=backend, connectivity=connectivity, workers=1, time_limit=60)
    brute = brute_force_pruned(p)
    found = {
        "brute_force": brute,
        "bnb": [bb.status.value, bb.objective, bb.bound],
        f"milp/{backend}/{connectivity}": [mi.status.value, mi.objective, mi.bound],
    }
    agree = bb.status is mi.status is Status.OPTIMAL and bb.objective == mi.objective == brute
    for r in (bb, mi):
        ev = evaluate(p, r.x)
        agree = agree and ev.feasible and ev.covered == r.objective and r.objective == r.bound
    if not agree:
        path = _save_disagreement(tmp_path_factory.mktemp("cells"), p, found)
        pytest.fail(f"the exact engines disagree ({found}); instance saved to {path}")


@pytest.mark.parametrize("engine", ["bnb", "milp"])
def test_a_weak_warm_start_is_polished_and_its_fate_reported(engine):
    # a one-site start (1 user) beside a greedy start of 4: the start is always polished (to 5
    # here, the optimum), becomes the incumbent and the result says so
    p = random_small(3, 14, 3)
    cand = candidate_sites(p)
    direct = np.flatnonzero(cand.direct)
    w = cand.points[direct[np.argmin([len(cand.cover[i]) for i in direct])]][None]
    r = solve_exact(p, engine=engine, warm_start=w, workers=1)
    ws, inc = r.info["warm_start"], r.info["incumbent"]
    assert ws["value"] == 1 and ws["greedy_value"] == inc["greedy"] == 4
    assert ws["polished_value"] == 5 == r.objective == brute_force_pruned(p) and ws["used"] and r.warm_started
    assert inc["from"] == "warm_start" and "polished to 5, is the incumbent" in ws["reason"]


def test_branch_and_bound_refuses_matrices_beyond_memory(monkeypatch):
    import os

    p = random_small(1, 12, 2)
    cand = candidate_sites(p)
    n = len(cand.points)
    need = 2 * n * ((n + 7) // 8)  # two relations as packed bit rows
    monkeypatch.setattr(os, "sysconf", lambda name: 1 if name == "SC_PAGE_SIZE" else need - 1)
    with pytest.raises(ValueError, match=rf"problem: .*{n} x {n}.*GiB"):
        search(p, cand, np.zeros((0, 2)), 0)
    monkeypatch.undo()
    assert search(p, cand, np.zeros((0, 2)), 0).value == brute_force_pruned(p)


# the polish of the shared start: its exchange search also takes sets of three sites out of a start,
# which leaves local optima of sets of one and two


def _polished_value(problem, sizes):
    """Users covered by the greedy start after the heuristics with exchange ``sizes``."""
    prep = prepare(problem)
    bb = search(
        problem,
        prep.cand,
        prep.greedy,
        prep.greedy_val,
        upper=prep.ub,
        time_limit=30,
        workers=1,
        main=False,
        exchange_sizes=sizes,
    )
    ev = evaluate(problem, bb.positions)
    assert ev.feasible and ev.covered == bb.value
    return int(ev.covered)


@pytest.mark.parametrize(("seed", "one_two", "optimum"), [(8, 9, 10), (15, 6, 8), (22, 9, 10)])
def test_sets_of_three_leave_a_local_optimum_of_one_and_two(seed, one_two, optimum):
    p = random_small(seed, 20, 4)
    assert _polished_value(p, (1, 2)) == one_two
    # the optimum as both engines prove it (each checked against brute force above)
    assert _polished_value(p, (1, 2, 3)) == optimum == solve_exact(p, engine="bnb", workers=1).objective
    # the start the engines share is polished with sets of three
    res = solve_exact(p, engine="milp")
    assert res.info["incumbent"]["greedy_polished"] == optimum == res.objective


@settings(max_examples=10, deadline=None)
@given(st.integers(0, 10_000), st.integers(4, 5))
def test_sets_of_three_never_end_lower(seed, m):
    # the passes run as with sets of one and two until those stop, then go on
    p = random_small(seed, 12, m)
    assert _polished_value(p, (1, 2)) <= _polished_value(p, (1, 2, 3)) <= brute_force_pruned(p)


def test_the_polish_takes_sets_of_three_only_below_m():
    assert POLISH_EXCHANGE_SIZES == (1, 2, 3)
    assert polish_exchange_sizes(2) == polish_exchange_sizes(3) == (1, 2)
    assert polish_exchange_sizes(4) == polish_exchange_sizes(8) == (1, 2, 3)
