"""The branch and bound's bound and pruning rules one at a time, on small hand-built states,
against brute force over the same candidate sites (the rule functions of the ``_bnb_*`` modules,
called on a ``_bnb.BranchAndBoundSearch``)."""

import math

import numpy as np
from hypothesis import assume, example, given, settings
from hypothesis import strategies as st

from droneplan.formulations.cells import CellProblem, candidate_sites, evaluate
from droneplan.formulations.cells._bnb import BranchAndBoundSearch
from droneplan.formulations.cells._bnb_bounds import (
    clique_values,
    linkable_weight,
    node_bound,
    unreached_bounds,
)
from droneplan.formulations.cells._bnb_dual import _lazy_gains, greedy_dual
from droneplan.formulations.cells._bnb_elimination import drop_dominated, eliminate_sites, site_can_improve
from droneplan.formulations.cells._bnb_groups import separated_bound
from droneplan.formulations.cells._bnb_relaxed import free_completion
from droneplan.formulations.cells._bnb_relays import relay_filter
from droneplan.formulations.cells._bnb_siblings import replaced_by_sibling
from droneplan.formulations.cells._core import TOL


def _problem(users, m):
    return CellProblem(
        users=np.asarray(users, float),
        gbs=np.array([[0.0, 0.0]]),
        n_cells=m,
        R_d=1.0,
        R_g=1.0,
        r1=3.0,
        r2=2.5,
    )


def _scattered(seed, n, m):
    rng = np.random.default_rng(seed)
    return _problem(rng.uniform(-6, 6, size=(n, 2)), m)


def _clustered(seed, n_clusters, m):
    rng = np.random.default_rng(seed)
    centres = rng.uniform(-5, 5, size=(n_clusters, 2))
    return _problem(np.concatenate([rng.normal(c, 0.35, size=(3, 2)) for c in centres]), m)


class _Oracle:
    """Every pairwise non-overlapping set of at most m sites (indices in the search's order,
    sorted), with the users it covers when ``evaluate`` finds it feasible. Overlap is tested
    on the coordinates, independently of the search's conflict matrix."""

    def __init__(self, problem, s):
        self.s = s
        q = s.pts
        apart = np.hypot(*(q[:, None, :] - q[None, :, :]).transpose(2, 0, 1)) >= 2 * problem.R_d - TOL
        self.sets: list[tuple[int, ...]] = []
        self.feasible: dict[tuple[int, ...], int] = {}

        def grow(chosen, start):
            if chosen:
                key = tuple(chosen)
                self.sets.append(key)
                ev = evaluate(problem, q[list(chosen)])
                if ev.feasible:
                    self.feasible[key] = int(ev.covered)
            if len(chosen) == problem.n_cells:
                return
            for i in range(start, len(q)):
                if all(apart[i, j] for j in chosen):
                    grow([*chosen, i], i + 1)

        grow([], 0)

    def completions(self, P, cmask, *, feasible=True):
        """(Q, covered by P + Q) for the non-empty Q from ``cmask`` (after P's sites: the
        search's children) with P + Q in the list; covered is None when not feasible."""
        P = tuple(sorted(P))
        out = []
        for key in self.sets:
            if key[: len(P)] != P or len(key) == len(P):
                continue
            Q = key[len(P) :]
            if not all(cmask[q] for q in Q):
                continue
            if feasible and key not in self.feasible:
                continue
            out.append((Q, self.feasible.get(key)))
        return out


def _partial_placements(oracle, m):
    """The root and every non-overlapping P with at least 2 free slots (at most 40)."""
    return [(), *[k for k in oracle.sets if len(k) <= m - 2]][:40]


@settings(max_examples=12, deadline=None)
@given(st.integers(0, 10_000), st.integers(5, 8), st.integers(3, 4))
def test_each_bound_rule_holds_for_every_completion(seed, n, m):
    p = _scattered(seed, n, m)
    s = BranchAndBoundSearch(p, candidate_sites(p), -1)  # incumbent -1: nothing is cut by value
    oracle = _Oracle(p, s)
    checked = 0
    for P in _partial_placements(oracle, m):
        node = s.node(list(P))
        r = m - len(P)
        C = np.flatnonzero(node.cmask)
        feas = oracle.completions(P, node.cmask)
        weights = [int(s.w[list(Q)].sum()) for Q, _ in feas]
        # items 1, 2 (cliques) on every non-overlapping completion, feasible or not
        tops_all = clique_values(s, C, r, 0)
        for Q, _ in oracle.completions(P, node.cmask, feasible=False):
            assert s.w[list(Q)].sum() <= sum(tops_all)
        kids = relay_filter(s, node, C)
        if not feas:
            continue
        checked += 1
        best = max(v for _, v in feas)
        # item 3: every site of a feasible completion passes the relay filter
        assert kids is not None
        passed = set(kids.C[kids.ok].tolist())
        assert all(set(Q) <= passed for Q, _ in feas)
        # item 7: greedy dual of coverage
        assert node.val + greedy_dual(s, list(P), C, node.dist, node.reach, r) >= best
        # item 6: one slot holds a linkable site
        tops = clique_values(s, kids.C[kids.ok], r, 0)
        wg = linkable_weight(s, kids, 0)
        assert max(weights) <= wg + sum(tops[: r - 1])
        # items 5, 8, 12 when P has unreached sites
        if not node.reach.all():
            b, b_sep = unreached_bounds(s, node, kids, tops, 0, wg, math.inf)
            assert node.val + max(weights) <= min(b, b_sep)
        # every rule combined
        combined = node_bound(s, node, math.inf)
        assert combined is not None and combined.bound >= best
    assert checked or not oracle.feasible


@settings(max_examples=10, deadline=None)
@given(st.integers(0, 10_000), st.integers(5, 8), st.integers(3, 4))
@example(1, 5, 4)  # the optimum is one site: its probe finds it, and every site is then cleared
def test_site_elimination_keeps_every_site_of_a_better_placement(seed, n, m):
    p = _scattered(seed, n, m)
    s = BranchAndBoundSearch(p, candidate_sites(p), 0)
    oracle = _Oracle(p, s)
    assume(oracle.feasible)
    opt = max(oracle.feasible.values())
    z = opt - 1
    alive = np.ones(s.n, dtype=bool)
    cleared, found = 0, z
    for c in range(s.n):
        s.best_val = z  # a probe may raise the incumbent (to {c} itself): compare with it after
        if not site_can_improve(s, c, alive):
            cleared += 1
            assert all(v <= s.best_val for key, v in oracle.feasible.items() if c in key)
        found = max(found, s.best_val)
    # the sites of an optimal placement stay, unless a probe found the optimum itself
    assert cleared < s.n or found == opt


@settings(max_examples=15, deadline=None)
@given(st.integers(0, 10_000), st.integers(2, 3))
def test_sibling_replacement_drops_nothing_better_than_the_earlier_siblings(seed, n_clusters):
    # item 11 at the root: a child b that an earlier sibling replaces (True), or replaces
    # outside E (a mask), holds no placement avoiding E that beats the earlier siblings' subtrees
    p = _clustered(seed, n_clusters, 3)
    s = BranchAndBoundSearch(p, candidate_sites(p), 0)
    oracle = _Oracle(p, s)
    explored: list[int] = []
    used = 0
    for j in range(s.n):
        cm = s.compatible([j])
        cm[: j + 1] = False
        replace = replaced_by_sibling(s, [], 0, j, cm, explored)
        if replace is not None:
            used += 1
            avoid = np.zeros(s.n, dtype=bool) if replace is True else replace
            mine = [v for key, v in oracle.feasible.items() if key[0] == j and not avoid[list(key)].any()]
            earlier = [v for key, v in oracle.feasible.items() if key[0] in explored]
            assert max(mine, default=0) <= max(earlier, default=0)
        explored.append(j)
    assert used > 0 or s.n < 2


def test_the_node_of_a_hand_built_relay_chain():
    # users at 2.5 and 5 m from the GBS at the origin (r1 = 3, r2 = 2.5): the site on the far
    # pair alone needs a relay, so it is unreached and the rules must leave a bridge slot
    p = _problem([[2.5, 0.0], [5.0, 0.0], [5.2, 0.0]], 3)
    s = BranchAndBoundSearch(p, candidate_sites(p), -1)
    far = int(np.argmin(np.hypot(*(s.pts - [5.0, 0.0]).T)))
    node = s.node([far])
    assert not node.reach.all() and node.dist[0] >= 1
    kids = relay_filter(s, node, np.flatnonzero(node.cmask))
    assert kids is not None
    oracle = _Oracle(p, s)
    feas = oracle.completions((far,), node.cmask)
    assert feas  # a relay between the GBS and the far site exists
    combined = node_bound(s, node, math.inf)
    assert combined is not None and combined.bound >= max(v for _, v in feas)
    assert max(v for _, v in feas) == 3  # the relay over the near user completes it
    # item 5: the bridge slot holds a site within r2 of the far site
    assert all(any(math.dist(s.pts[q], s.pts[far]) <= p.r2 + TOL for q in Q) for Q, _ in feas)


def test_dominated_sites_leave_the_optimum_unchanged():
    # item 13: clearing the dominated sites keeps the optimum over the alive sites, on
    # clustered users (near-identical sites) and scattered ones; some instances lose sites
    dropped_total = 0
    for seed in range(10):
        for p in (_clustered(seed, 3, 3), _scattered(seed, 7, 3)):
            s = BranchAndBoundSearch(p, candidate_sites(p), -1)
            oracle = _Oracle(p, s)
            alive = np.ones(s.n, dtype=bool)
            dropped = drop_dominated(s, alive)
            assert dropped == s.n - int(alive.sum())
            dropped_total += dropped
            full = max(oracle.feasible.values(), default=0)
            kept = max((v for key, v in oracle.feasible.items() if alive[list(key)].all()), default=0)
            assert kept == full
            # a dominated site keeps a dominating one alive: never every site of the optimum
            assert dropped < s.n
    assert dropped_total > 0


def test_links_to_many_bridges_found_by_tree_include_every_exact_link():
    # item 12's link test past _LINK_ROWS_MAX bridge candidates (a KD-tree, range widened by
    # 1e-6 m) returns every site the exact rows link, and here no other
    from droneplan.formulations.cells._bnb_groups import _LINK_ROWS_MAX, _linked_to
    from droneplan.formulations.cells._bnb_sites import LinkRows

    rng = np.random.default_rng(5)
    pts = rng.uniform(0, 40, size=(400, 2))
    links = LinkRows(pts, 3.0)
    sites = np.arange(400)
    q = rng.choice(400, size=_LINK_ROWS_MAX + 20, replace=False)
    exact = np.unpackbits(np.bitwise_or.reduce(links[q], axis=0), count=400, bitorder="little").astype(bool)
    got = _linked_to(links, sites, q)
    assert np.array_equal(got, exact)
    assert 0 < exact.sum() < 400


@settings(max_examples=12, deadline=None)
@given(st.integers(0, 10_000), st.integers(5, 8), st.integers(3, 4), st.booleans())
def test_backhaul_free_completion_answers_like_brute_force(seed, n, m, clustered):
    # item 14: the relaxed search below P finds a placement above z exactly when some
    # non-overlapping P + Q (connected or not) covers more than z; when it finds none, no
    # feasible placement below P beats z either (the node may be cut)
    p = _clustered(seed, 3, m) if clustered else _scattered(seed, n, m)
    s = BranchAndBoundSearch(p, candidate_sites(p), 0)
    oracle = _Oracle(p, s)
    answers = set()
    for P in _partial_placements(oracle, m):
        node = s.node(list(P))
        relaxed_sets = oracle.completions(P, node.cmask, feasible=False)
        relaxed = max([node.val] + [s.bits_of([*P, *Q]).bit_count() for Q, _ in relaxed_sets])
        feasible = max((v for _, v in oracle.completions(P, node.cmask)), default=0)
        for z in (relaxed - 1, relaxed):
            s.best_val = z
            found = free_completion(s, node)
            answers.add(found)
            assert found is (relaxed > z)
            assert found or feasible <= z
    assert answers == {True, False}


def test_lazy_greedy_gains_hold_every_value_of_the_full_scan():
    # item 7 reads the gains of a weight-ordered prefix only (``_lazy_gains``): its r largest
    # gains, its largest under each mask and its largest of all equal those of every site
    from droneplan.formulations.cells._bnb_sites import _popcount_rows

    p = _scattered(3, 60, 4)
    s = BranchAndBoundSearch(p, candidate_sites(p), 0)
    assert s.n > 256  # more than the first prefix block
    rng = np.random.default_rng(0)
    C = np.arange(s.n)
    short = 0
    for _ in range(40):
        covered = np.bitwise_or.reduce(s.packed[rng.choice(s.n, size=int(rng.integers(0, 4)))], axis=0)
        masks = [rng.random(s.n) < q for q in (0.5, 0.02)]
        r = int(rng.integers(1, 5))
        gain, end = _lazy_gains(s, C, covered, masks, r, 0)
        full = _popcount_rows(s.packed & ~covered)
        assert np.array_equal(gain, full[:end])
        assert np.sort(gain)[-r:].sum() == np.sort(full)[-r:].sum()
        assert gain.max() == full.max()
        for mask in masks:
            assert (gain[mask[:end]].max(initial=-1)) == full[mask].max(initial=-1)
        short += end < s.n
    assert short > 0  # the prefix was shorter than the scan in some cases


def test_successor_sites_from_a_short_prefix_keep_item_12_valid():
    # item 12 tests the successor links on a prefix of the heaviest sites only and counts the
    # later ones as linked: a superset of the exact successors, so its bound stays above every
    # feasible completion (checked here with a prefix of 1 site, against the oracle, on relay
    # chains)
    from droneplan.formulations.cells import _bnb_groups

    checked = widened = 0
    saved = _bnb_groups._SUCCESSOR_PREFIX
    try:
        for seed in range(12):
            rng = np.random.default_rng(seed)
            # two arms of users out from the GBS (relay chains) and two stray users
            arm = np.array([[2.4, 0.0], [4.8, 0.0], [7.2, 0.0]])
            users = np.concatenate([arm, arm[:, ::-1], rng.uniform(-8, 8, size=(2, 2))])
            p = _problem(users + rng.normal(0, 0.3, size=users.shape), 4)
            s = BranchAndBoundSearch(p, candidate_sites(p), -1)
            oracle = _Oracle(p, s)
            for P in _partial_placements(oracle, 4):
                node = s.node(list(P))
                if node.reach.all():
                    continue
                full = np.flatnonzero(node.cmask)
                in_l = s.dg[full] <= s.r1t
                d = np.hypot(*(s.pts[full] - s.pts[P[0]]).T)
                _bnb_groups._SUCCESSOR_PREFIX = 10**6
                exact = _bnb_groups._successor_sites(s.link_rows(), full, d, in_l, s.r2t)
                _bnb_groups._SUCCESSOR_PREFIX = 1
                short = _bnb_groups._successor_sites(s.link_rows(), full, d, in_l, s.r2t)
                assert np.all(short | ~exact)  # a superset
                widened += int(np.any(short & ~exact))
                feas = oracle.completions(P, node.cmask)
                kids = relay_filter(s, node, np.flatnonzero(node.cmask))
                if not feas or kids is None:
                    continue
                r = 4 - len(P)
                tops = clique_values(s, kids.C[kids.ok], r, 0)
                best = max(int(s.w[list(Q)].sum()) for Q, _ in feas)
                assert separated_bound(s, node, r, tops) >= best
                b, b_sep = unreached_bounds(s, node, kids, tops, 0, linkable_weight(s, kids, 0), math.inf)
                assert node.val + best <= min(b, b_sep)
                checked += 1
    finally:
        _bnb_groups._SUCCESSOR_PREFIX = saved
    assert checked > 0 and widened > 0


@settings(max_examples=10, deadline=None)
@given(st.integers(0, 10_000), st.integers(5, 8), st.integers(3, 4), st.booleans())
def test_site_elimination_keeps_an_optimal_placement(brute_force, seed, n, m, no_dual):
    # items 9-10 as the search runs them (the first test, then probe rounds that re-probe only
    # the sites near the incumbent; item 7 in the probes or not): with the incumbent one below
    # the optimum, the alive sites still hold an optimal placement, or a probe found one
    p = _clustered(seed, 3, m) if n % 2 else _scattered(seed, n, m)
    opt = brute_force(p)
    assume(opt > 0)
    s = BranchAndBoundSearch(p, candidate_sites(p), opt - 1)
    if no_dual:
        s.dual_from = math.inf
    oracle = _Oracle(p, s)
    alive = np.ones(s.n, dtype=bool)
    eliminate_sites(s, alive)
    kept = max((v for key, v in oracle.feasible.items() if alive[list(key)].all()), default=0)
    assert kept == opt or s.best_val == opt
    assert s.best_val <= opt


def test_kept_conflict_rows_match_the_packed_relation():
    # BitRows keeps unpacked rows (read-only) up to its byte budget; a kept row equals a fresh
    # unpack, and relating more sites drops the kept rows
    from droneplan.formulations.cells._bnb_sites import BitRows

    rng = np.random.default_rng(1)
    n = 70
    dense = rng.random((n, n)) < 0.2
    rows = BitRows(np.zeros((n, (n + 7) // 8), dtype=np.uint8), n)
    i, j = np.nonzero(dense)
    rows.set(i, j)
    for k in (3, 3, 41):
        got = rows.row(k)
        assert np.array_equal(got, dense[k]) and not got.flags.writeable
    rows.set(np.array([3]), np.array([0]))
    dense[3, 0] = True
    assert np.array_equal(rows.row(3), dense[3])


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 10_000), st.integers(2, 12), st.sampled_from([0.5, 1.0, 2.0]))
def test_conflict_rows_are_every_pair_closer_than_two_discs(seed, n_clusters, R_d):
    """The grid-cell build of the conflict relation equals the brute-force one: every pair of
    distinct sites closer than 2 R_d - TOL, and no other (clustered users put many sites in a
    few cells, scattered ones spread them over many)."""
    rng = np.random.default_rng(seed)
    centres = rng.uniform(-6, 6, size=(n_clusters, 2))
    users = np.concatenate([rng.normal(c, 0.4 * R_d, size=(4, 2)) for c in centres])
    p = CellProblem(users=users, gbs=np.zeros((1, 2)), n_cells=3, R_d=R_d, R_g=R_d, r1=3 * R_d, r2=2.5 * R_d)
    s = BranchAndBoundSearch(p, candidate_sites(p), 0)
    d = np.hypot(*(s.pts[:, None, :] - s.pts[None, :, :]).transpose(2, 0, 1))
    expected = (d < 2 * R_d - TOL) & ~np.eye(s.n, dtype=bool)
    got = np.stack([s.conflict.row(i) for i in range(s.n)]) if s.n else np.zeros((0, 0), bool)
    assert np.array_equal(got, expected)


def test_search_stopped_while_building_its_relations_returns_the_start_unproven(monkeypatch):
    """A time limit that passes while the site relations are built stops the search there: the
    start comes back, not proven, with the given upper bound, and ``built`` says nothing ran."""
    from droneplan.formulations.cells import _bnb

    p = _clustered(3, 8, 3)
    cand = candidate_sites(p)
    monkeypatch.setattr(_bnb.BranchAndBoundSearch, "out_of_time", lambda self: True)
    start = cand.points[:1]
    out = _bnb.search(p, cand, start, 1, upper=99.0, time_limit=1.0)
    assert not out.built and not out.proven and out.nodes == 0
    assert out.value == 1 and out.bound == 99.0 and np.array_equal(out.positions, start)
