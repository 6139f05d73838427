"""The dominance rows of the cells MILP (``_milp`` item 12) cut off placements, but never the
optimal placement that comes first in the site order, so the model keeps the optimum.

Checked against brute force on small clustered instances, where near-identical sites abound:
every feasible placement is enumerated, and the optimal one whose sites, sorted by the order
(weight |S(c)| descending, then index), come first must meet every row.
"""

import itertools

import numpy as np
from hypothesis import assume, given, settings
from hypothesis import strategies as st
from scipy.spatial import cKDTree

from droneplan.formulations.cells import _milp, build_milp, candidate_sites, evaluate, solve_exact
from droneplan.formulations.cells._core import pairwise_distances
from droneplan.formulations.cells._milp import _private_users, dominance_row_sets, dominance_rows
from droneplan.scenarios.cells import CellProblem
from droneplan.solvers.result import Status


def _feasible_placements(problem, points):
    """(sites, covered) of every feasible placement of 1..m of ``points``."""
    out = []
    for k in range(1, problem.n_cells + 1):
        for combo in itertools.combinations(range(len(points)), k):
            ev = evaluate(problem, points[list(combo)])
            if ev.feasible:
                out.append((combo, ev.covered))
    return out


def _first_optimal(mdl, placements):
    """The optimal placement whose order ranks, sorted, are lexicographically first."""
    weight = np.array([len(c) for c in mdl.cover])
    order = sorted(range(len(weight)), key=lambda i: (-weight[i], i))
    rank = {site: r for r, site in enumerate(order)}
    best = max(cov for _, cov in placements)
    return min((combo for combo, cov in placements if cov == best), key=lambda c: sorted(rank[i] for i in c))


def _breaks(on: np.ndarray, row) -> bool:
    b, e = row
    return bool(on[b]) and not on[e].any()


@settings(max_examples=15, deadline=None)
@given(st.integers(0, 10_000), st.integers(2, 3))
def test_the_first_optimal_placement_meets_every_row(clustered, seed, n_clusters):
    p = clustered(seed, n_clusters, 3, m=3, background=3)
    mdl = build_milp(p)
    rows, complete = dominance_row_sets(mdl, np.zeros(len(mdl.x), dtype=bool))
    assert complete
    placements = _feasible_placements(p, mdl.points)
    assume(placements)  # some draws have no site linked to the GBS
    first = np.zeros(len(mdl.x), dtype=bool)
    first[list(_first_optimal(mdl, placements))] = True
    assert not any(_breaks(first, row) for row in rows)


def test_rows_cut_off_feasible_placements_on_clustered_instances(clustered):
    # the rows are not vacuous: they exclude feasible (non-first) placements, some optimal ones
    rows_seen = cut_off = zero_rows = 0
    for seed in range(4):
        p = clustered(seed, 3, 3, m=3, background=3)
        mdl = build_milp(p)
        rows, _ = dominance_row_sets(mdl, np.zeros(len(mdl.x), dtype=bool))
        rows_seen += len(rows)
        zero_rows += sum(len(e) == 0 for _, e in rows)
        for combo, _ in _feasible_placements(p, mdl.points):
            on = np.zeros(len(mdl.x), dtype=bool)
            on[list(combo)] = True
            cut_off += any(_breaks(on, row) for row in rows)
    assert rows_seen > 0 and zero_rows > 0 and cut_off > 0


@settings(max_examples=10, deadline=None)
@given(st.integers(0, 10_000), st.sampled_from(["cp-sat", "highs"]))
def test_model_with_the_rows_keeps_the_optimum(clustered, brute_force, seed, backend):
    p = clustered(seed, 3, 3, m=3, background=4)
    opt = brute_force(p)
    mdl = build_milp(p, backend=backend)
    stats = dominance_rows(mdl, np.zeros(len(mdl.x), dtype=bool))
    assert stats["dominance_complete"]
    res = mdl.model.solve(variables=mdl.x, time_limit=60, workers=1)
    assert res.status is Status.OPTIMAL
    chosen = mdl.points[np.asarray(res.x) > 0.5]
    ev = evaluate(p, chosen)
    assert ev.feasible and ev.covered == round(res.objective) == opt


@settings(max_examples=10, deadline=None)
@given(st.integers(0, 10_000))
def test_rows_the_incumbent_breaks_are_left_out(clustered, seed):
    p = clustered(seed, 3, 3, m=3, background=3)
    mdl = build_milp(p)
    placements = _feasible_placements(p, mdl.points)
    assume(placements)
    every, _ = dominance_row_sets(mdl, np.zeros(len(mdl.x), dtype=bool))
    # the last feasible placement in enumeration order: rarely the first optimal one
    combo = placements[-1][0]
    on = np.zeros(len(mdl.x), dtype=bool)
    on[list(combo)] = True
    kept, _ = dominance_row_sets(mdl, on)
    assert not any(_breaks(on, row) for row in kept)
    assert len(kept) == len(every) - sum(_breaks(on, row) for row in every)


def test_solve_exact_writes_the_rows_and_proves_the_brute_force_optimum(clustered, brute_force):
    written = 0
    for seed in range(6):
        p = clustered(seed, 3, 3, m=3, background=4)
        res = solve_exact(p, engine="milp", time_limit=60)
        assert res.status is Status.OPTIMAL and res.objective == brute_force(p)
        assert evaluate(p, res.x).covered == res.objective
        written += res.info["model_stats"].get("dominance_rows", 0)
    assert written > 0


def test_a_model_without_dominated_sites_gets_no_rows(clustered):
    p = clustered(0, 3, 3, m=3, background=3)
    cand = candidate_sites(p)
    far = np.flatnonzero(np.hypot(*(cand.points - cand.points[0]).T) > 2 * p.R_d)[:1]
    mdl = build_milp(p, candidates=cand, keep=np.r_[0, far])  # two sites, no overlapping pair
    rows, complete = dominance_row_sets(mdl, np.zeros(len(mdl.x), dtype=bool))
    assert len(mdl.x) == 2 and rows == [] and complete
    assert dominance_rows(mdl, np.zeros(2, dtype=bool))["dominance_rows"] == 0


def _cover_entries(mdl):
    """(site, user) of every cover entry of the model, as two index arrays."""
    weight = np.array([len(s) for s in mdl.cover])
    return np.repeat(np.arange(len(weight)), weight), np.concatenate(mdl.cover)


def _touching_sites_instance():
    """Sites a = (5, 0) and c = (7 + 1e-7, 0) do not overlap but share the user u = (6, 0) on
    both edges. b = (4.7, 0.3) overlaps a and covers as many users as a does, trading u for
    q = (4, 0.6). The optimum is b + c (6 users): a + c counts u once and covers 5."""
    users = np.array([[6, 0], [5, 0.2], [4.8, 0], [4.0, 0.6], [7.5, 0], [7, 0.5]], dtype=float)
    p = CellProblem(
        users=users, gbs=np.array([[2.5, 0.0]]), n_cells=2, R_d=1.0, R_g=1.0, r1=3.0, r2=2.5, bounds=None
    )
    cand = candidate_sites(p, extra=np.array([[5, 0], [4.7, 0.3], [7.0000001, 0]]))
    return p, build_milp(p, candidates=cand)


def test_a_user_shared_by_touching_sites_is_not_private(monkeypatch):
    p, mdl = _touching_sites_instance()
    a, b, c = (
        int(np.flatnonzero(np.hypot(*(mdl.points - q).T) < 1e-6)[0]) for q in ([5, 0], [4.7, 0.3], [7, 0])
    )
    rows, cols = _cover_entries(mdl)
    private = _private_users(mdl, rows, cols)
    # brute force: an entry (site s, user u) is private unless a site >= 2 R_d - TOL from s covers u
    far = pairwise_distances(mdl.points, mdl.points) >= 2 * p.R_d - 2e-6
    expect = [
        not any(u in mdl.cover[t] for t in np.flatnonzero(far[s])) for s, u in zip(rows, cols, strict=True)
    ]
    assert private.tolist() == expect and not all(expect)
    assert not private[(rows == a) & (cols == 0)].any() and not private[(rows == c) & (cols == 0)].any()
    placements = _feasible_placements(p, mdl.points)
    first = np.zeros(len(mdl.x), dtype=bool)
    first[list(_first_optimal(mdl, placements))] = True
    assert first[b] and first[c] and max(cov for _, cov in placements) == 6
    rows_kept, _ = dominance_row_sets(mdl, np.zeros(len(mdl.x), dtype=bool))
    assert not any(_breaks(first, row) for row in rows_kept)
    # counting u as a's own would let a replace b and cut the optimum off
    monkeypatch.setattr(_milp, "_private_users", lambda mdl, rows, cols: np.ones(len(rows), dtype=bool))
    rows_counted, _ = dominance_row_sets(mdl, np.zeros(len(mdl.x), dtype=bool))
    assert any(_breaks(first, row) for row in rows_counted)


def test_private_users_do_not_depend_on_the_block_size(clustered, monkeypatch):
    p = clustered(3, 3, 4, m=3, background=6)
    mdl = build_milp(p)
    rows, cols = _cover_entries(mdl)
    whole = _private_users(mdl, rows, cols)
    monkeypatch.setattr(_milp, "DOMINANCE_BLOCK", 3)
    assert _private_users(mdl, rows, cols).tolist() == whole.tolist()
    _, tmdl = _touching_sites_instance()
    rows, cols = _cover_entries(tmdl)
    assert not _private_users(tmdl, rows, cols).all()  # blocks of 3 still see the touching site


@settings(max_examples=10, deadline=None)
@given(st.integers(0, 10_000))
def test_the_rows_hold_the_smallest_sets_e(clustered, seed):
    # each site's rows are the sets E of its dominating sites with the fewest members (ties: the
    # smaller index), E computed here from every pairwise distance
    p = clustered(seed, 3, 4, m=3, background=6)
    mdl = build_milp(p)
    pts, on = mdl.points, np.zeros(len(mdl.x), dtype=bool)
    rows, _ = dominance_row_sets(mdl, on)
    b_all, a_all = _milp._dominating_pairs(mdl, cKDTree(pts))
    d = pairwise_distances(pts, pts)
    r_conf, r_link, eps = 2 * p.R_d - 1e-6, p.r2 + 1e-6, 1e-6
    expect = []
    for b in np.unique(b_all):
        sets = []
        for a in a_all[b_all == b]:
            in_e = ((d[a] < r_conf + eps) & (d[b] > r_conf - eps)) | (
                (d[b] <= r_link + eps) & (d[a] > r_link - eps)
            )
            in_e[[a, b]] = False
            sets.append((int(in_e.sum()), int(a), np.flatnonzero(in_e)))
        expect += [(int(b), e) for _, _, e in sorted(sets, key=lambda t: t[:2])[: _milp.DOMINANCE_PER_SITE]]
    assert len(rows) == len(expect)
    assert all(rb == eb and np.array_equal(re, ee) for (rb, re), (eb, ee) in zip(rows, expect, strict=True))
