import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from droneplan.core.validation import MAX_ELEMENTS, MAX_EVALUATIONS, work_limits
from droneplan.formulations.cells import CellProblem, circle_intersections, evaluate, solve_milp
from droneplan.planners.cells import (
    GASettings,
    Region,
    _check_ga_work,
    exhaustive,
    fitness,
    genetic,
    max_coverage_in_region,
    thesis_ga_settings,
)


def small(users, m=2, r1=3.0, r2=2.5, bounds=None):
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


def random_small(seed, n, m, bounds=(-6, 6, -6, 6)):
    rng = np.random.default_rng(seed)
    return small(rng.uniform(-6, 6, size=(n, 2)), m=m, bounds=bounds)


# ----------------------------------------------------------------- GA
def test_fitness_matches_evaluate_of_contributing_cells():
    p = random_small(0, 25, 3)
    rng = np.random.default_rng(1)
    pop = rng.uniform(-5, 5, size=(200, 3, 2))
    f = fitness(p, pop)
    for chrom, fv in zip(pop, f, strict=True):
        # brute force: the largest feasible subset of cells that the fitness rule keeps
        ev = evaluate(p, chrom)
        if ev.feasible:
            assert fv == ev.covered
        else:
            assert fv <= ev.covered
    assert f.max() > 0


def test_ga_reproducible_and_feasible():
    p = random_small(2, 20, 2)
    a = genetic(p, pop_size=12, iter_max=10, restarts=4, seed=7)
    b = genetic(p, pop_size=12, iter_max=10, restarts=4, seed=7)
    assert a.objective == b.objective and np.array_equal(a.x, b.x)
    assert a.info["restart_bests"] == b.info["restart_bests"] and len(a.info["restart_bests"]) == 4
    assert max(a.info["restart_bests"]) == a.objective
    ev = evaluate(p, a.x)
    assert ev.feasible and ev.covered == a.objective


@pytest.mark.parametrize("seed", range(3))
def test_milp_at_least_ga_and_exhaustive(seed):
    p = random_small(seed, 20, 2)
    ga = genetic(p, pop_size=20, iter_max=20, restarts=5, seed=seed)
    es = exhaustive(p)
    milp = solve_milp(p, backend="highs")
    for h in (ga, es):
        assert evaluate(p, h.x).feasible
        assert h.objective <= milp.info["continuous_bound"]
        warm = solve_milp(p, backend="highs", warm_start=h.x)
        assert warm.objective >= h.objective and warm.objective <= warm.bound


def test_ga_settings_validation():
    with pytest.raises(ValueError, match="alpha"):
        GASettings(alpha=1.5)
    with pytest.raises(ValueError, match="p_m"):
        GASettings(p_m=-0.1)
    with pytest.raises(ValueError, match="pop_size"):
        genetic(random_small(0, 5, 1), pop_size=1, restarts=1)
    with pytest.raises(ValueError, match="restarts"):
        genetic(random_small(0, 5, 1), pop_size=4, restarts=0)


# ----------------------------------------------------------------- GA work budgets
def test_ga_refuses_too_many_generations_naming_iter_max():
    with pytest.raises(ValueError, match=r"^iter_max .*1000000 evaluations.* limit of 100000"):
        genetic(random_small(0, 5, 2), pop_size=4, iter_max=10**6, restarts=1, seed=0)
    p = random_small(0, 5, 2)
    with work_limits(evaluations=10):
        assert genetic(p, pop_size=4, iter_max=10, restarts=1, seed=0).iterations == 10
        with pytest.raises(ValueError, match=r"^iter_max .*11 evaluations.* limit of 10\b"):
            genetic(p, pop_size=4, iter_max=11, restarts=1, seed=0)


def test_ga_budgets_its_fitness_evaluations_naming_the_largest_factor():
    p = random_small(0, 5, 2)  # Table 4.3 m = 2: P = 50, N = 50
    asked = 4 * 1 * (200 + 1)  # pop_size x restarts x (iter_max + 1)
    with work_limits(elements=asked):
        assert genetic(p, pop_size=4, iter_max=200, restarts=1, seed=0).iterations == 200
    with work_limits(elements=asked - 1), pytest.raises(ValueError, match=rf"^iter_max .*{asked} array"):
        genetic(p, pop_size=4, iter_max=200, restarts=1, seed=0)
    q = random_small(0, 5, 1)  # Table 4.3 m = 1: P = 20, N = 30
    asked = 2 * 3000 * (100 + 1)  # restarts is 100 times its table value, iter_max twice
    with work_limits(elements=asked - 1), pytest.raises(ValueError, match=rf"^restarts .*{asked} array"):
        genetic(q, pop_size=2, iter_max=100, restarts=3000, seed=0)
    asked = 5000 * 2 * (10 + 1)
    with work_limits(elements=asked - 1), pytest.raises(ValueError, match=rf"^pop_size .*{asked} array"):
        genetic(q, pop_size=5000, iter_max=10, restarts=2, seed=0)


def test_ga_refuses_working_arrays_beyond_the_memory_budget():
    # restarts=10**6 x pop_size=4 x m=2 x 2 coordinates x 10 working arrays = 1.6e8 elements
    with pytest.raises(ValueError, match=r"^restarts x pop_size .*160000000 array elements"):
        genetic(random_small(0, 5, 2), pop_size=4, iter_max=2, restarts=10**6, seed=0)


@pytest.mark.parametrize(
    ("m", "P", "iter_max", "N", "share"),
    [(m, thesis_ga_settings(m)[0], 50, thesis_ga_settings(m)[1], 10) for m in (1, 2, 3, 4)]
    + [
        (2, 100, 2000, 1, 10),  # Fig. 4.3 without restarts
        (2, 100, 50, 40, 10),  # Fig. 4.3 with restarts
        (3, 200, 50, 80, 10),  # the largest Fig. 4.5 cell
        (3, 100, 50, 4 * 60, 10),  # ablation "restarts-x4" at m = 3 (droneplan reproduce)
        (3, 100, 50 * 60, 1, 10),  # ablation "no-restarts" at m = 3
        (4, 200, 50 * 200, 1, 10),  # "no-restarts" at m = 4 (ga_ablation allows m <= 4)
        (4, 200, 50, 4 * 200, 3),  # "restarts-x4" at m = 4: 8.2e6 evaluations, 1.3e7 array elements
    ],
)
def test_thesis_and_study_ga_settings_fit_well_within_the_default_budgets(m, P, iter_max, N, share):
    """Every GA setting of the thesis (Table 4.3) and of the studies passes the budgets even
    when they are cut to 1/share of their defaults (``share`` = 10 for everything droneplan
    reproduce runs)."""
    evaluations = P * N * (iter_max + 1)
    assert evaluations <= MAX_ELEMENTS // share and iter_max <= MAX_EVALUATIONS // share
    with work_limits(elements=MAX_ELEMENTS // share, evaluations=MAX_EVALUATIONS // share):
        _check_ga_work(random_small(0, 5, m), P, iter_max, N)  # raises if a budget is exceeded


# ----------------------------------------------------------------- sweep
def brute_region(users, R_d, region):
    circles = [(u[0], u[1], R_d) for u in users] + region.circles()
    pts = [np.asarray(users).reshape(-1, 2)]
    for i in range(len(circles)):
        ci = circles[i]
        pts.append(np.array([[ci[0] + ci[2], ci[1]]]))
        for j in range(i + 1, len(circles)):
            cj = circles[j]
            pts.append(circle_intersections(np.array(ci[:2]), ci[2], np.array(cj[:2]), cj[2]))
    if region.box is not None:
        xmin, xmax, ymin, ymax = region.box
        pts.append(np.array([[xmin, ymin], [xmin, ymax], [xmax, ymin], [xmax, ymax]]))
        for cx, cy, r in circles:
            for xv in (xmin, xmax):
                if abs(xv - cx) <= r:
                    h = np.sqrt(r**2 - (xv - cx) ** 2)
                    pts.append(np.array([[xv, cy + h], [xv, cy - h]]))
            for yv in (ymin, ymax):
                if abs(yv - cy) <= r:
                    h = np.sqrt(r**2 - (yv - cy) ** 2)
                    pts.append(np.array([[cx + h, yv], [cx - h, yv]]))
    pts = np.concatenate(pts)
    ok = region.contains(pts)
    if not ok.any():
        return 0
    pts = pts[ok]
    d = np.hypot(pts[:, None, 0] - users[None, :, 0], pts[:, None, 1] - users[None, :, 1])
    return int((d <= R_d + 1e-6).sum(1).max()) if len(users) else 0


@settings(max_examples=30, deadline=None)
@given(st.integers(0, 10_000), st.integers(3, 14), st.integers(0, 2), st.booleans())
def test_sweep_equals_brute_force(seed, n, n_placed, boxed):
    rng = np.random.default_rng(seed)
    users = rng.uniform(-5, 5, size=(n, 2))
    placed = rng.uniform(-4, 4, size=(n_placed, 2))
    box = tuple(rng.uniform(-4, -1, 2).tolist() + rng.uniform(1, 4, 2).tolist()) if boxed else None
    box = None if box is None else (box[0], box[2], box[1], box[3])
    region = Region(
        exclude=((0.0, 0.0, 2.0), *((x, y, 2.0) for x, y in placed)),
        link=((0.0, 0.0, 3.0), *((x, y, 2.5) for x, y in placed)),
        box=box,
    )
    c, p = max_coverage_in_region(users, 1.0, region)
    assert c == brute_region(users, 1.0, region)
    if p is not None:
        assert region.contains(p)[0]
        assert (np.hypot(*(users - p).T) <= 1.0 + 1e-6).sum() == c
    # a dense grid of feasible points never beats it
    g = np.linspace(-6, 6, 97)
    xx, yy = np.meshgrid(g, g)
    grid = np.column_stack([xx.ravel(), yy.ravel()])
    grid = grid[region.contains(grid)]
    if len(grid):
        d = np.hypot(grid[:, None, 0] - users[None, :, 0], grid[:, None, 1] - users[None, :, 1])
        assert (d <= 1.0).sum(1).max() <= c


# ----------------------------------------------------------------- exhaustive
def test_exhaustive_single_cell_is_optimal():
    # m = 1: Algorithm 2 is exactly the constrained single-disc maximum coverage
    for seed in range(3):
        p = random_small(seed, 15, 1, bounds=None)
        es = exhaustive(p)
        region = Region(exclude=((0.0, 0.0, 2.0),), link=((0.0, 0.0, 3.0),))
        assert es.objective == brute_region(p.targets, 1.0, region)
        assert solve_milp(p).objective == es.objective  # both optimal for one cell


def test_exhaustive_time_limit_reports_incomplete():
    p = random_small(0, 40, 3)
    r = exhaustive(p, time_limit=1e-6)  # stops at its first check, whatever the speed
    assert r.info["complete"] is False and evaluate(p, r.x).feasible


def test_polish_keeps_feasibility_and_never_loses():
    from droneplan.planners.cells import genetic_polished, polish

    for seed in range(3):
        p = random_small(seed, 20, 2)
        ga = genetic(p, pop_size=10, iter_max=5, restarts=2, seed=seed)
        x = polish(p, ga.x)
        ev = evaluate(p, x)
        assert ev.feasible and ev.covered >= ga.objective
        gp = genetic_polished(p, pop_size=10, iter_max=5, restarts=2, seed=seed)
        assert gp.objective == ev.covered and gp.info["ga_objective"] == ga.objective
    with pytest.raises(ValueError, match="feasible"):
        polish(small([[2.5, 0.0]], m=1), [[0.0, 0.0]])


# ----------------------------------------------------------------- Fig. 4.2: deployment regions as geometry
@settings(max_examples=25, deadline=None)
@given(
    st.lists(st.tuples(st.floats(-6000, 6000), st.floats(-6000, 6000)), min_size=0, max_size=3),
    st.integers(0, 2**31 - 1),
)
def test_region_geometry_agrees_with_contains(placed, seed):
    from shapely import points as shp_points

    from droneplan.planners.cells import deployment_region
    from droneplan.scenarios.cells import thesis_problem

    p = thesis_problem(2, 0)
    region = deployment_region(p, placed)
    geom = region.geometry(quad_segs=32)
    err = region.geometry_error(quad_segs=32)
    rng = np.random.default_rng(seed)
    q = rng.uniform(-5500, 5500, size=(400, 2))
    inside = region.contains(q)
    # classify only points clearly away from every boundary circle and box edge
    far = np.ones(len(q), dtype=bool)
    for cx, cy, r in region.circles():
        far &= np.abs(np.hypot(q[:, 0] - cx, q[:, 1] - cy) - r) > 2 * err + 1e-3
    xmin, xmax, ymin, ymax = p.bounds
    far &= (
        np.minimum.reduce(
            [np.abs(q[:, 0] - xmin), np.abs(q[:, 0] - xmax), np.abs(q[:, 1] - ymin), np.abs(q[:, 1] - ymax)]
        )
        > 1e-3
    )
    covered = geom.covers(shp_points(q[far])) if not geom.is_empty else np.zeros(far.sum(), bool)
    assert np.array_equal(covered, inside[far])


def test_region_geometry_of_the_thesis_example():
    # Fig. 4.2: one GBS and one deployed drone-cell D_1; the region is the r1 or r2 reach
    # minus the two keep-out discs
    from droneplan.planners.cells import deployment_region
    from droneplan.scenarios.cells import thesis_problem
    from droneplan.studies.plots import plot_deployment_region

    p = thesis_problem(2, 0)
    d1 = np.array([[2500.0, 0.0]])
    g = deployment_region(p, d1).geometry(quad_segs=256)
    # exact area by inclusion-exclusion is awkward; check it against a fine grid instead
    xs = np.linspace(-5000, 5000, 801)
    xx, yy = np.meshgrid(xs, xs)
    grid = np.column_stack([xx.ravel(), yy.ravel()])
    frac = deployment_region(p, d1).contains(grid).mean()
    assert abs(g.area - frac * 1e8) / (frac * 1e8) < 0.01
    assert (
        not g.contains(shp_point(0, 0))
        and not g.contains(shp_point(2500, 0))
        and g.contains(shp_point(-2500, 0))
    )
    fig = plot_deployment_region(p, d1)
    assert fig.axes[0].get_xlabel() == "x (m)"


def shp_point(x, y):
    from shapely.geometry import Point

    return Point(x, y)


# ----------------------------------------------------------------- speed-ups vs plain references
def reference_fitness(p, pop):
    """The GA fitness written plainly, one chromosome at a time: keep the drone-cells inside
    the area, clear of every GBS cell and of every other drone-cell, and linked to a GBS
    through such cells; count the users evaluate() sees covered by them."""
    from droneplan.formulations.cells import TOL, connected_mask
    from droneplan.planners.cells import _area

    xmin, xmax, ymin, ymax = _area(p)
    out = []
    for chrom in np.asarray(pop, float).reshape(-1, p.n_cells, 2):
        ok = np.array(
            [
                xmin - TOL <= x <= xmax + TOL
                and ymin - TOL <= y <= ymax + TOL
                and all(np.hypot(x - g[0], y - g[1]) >= p.R_g + p.R_d - TOL for g in p.gbs)
                and all(
                    np.hypot(x - o[0], y - o[1]) >= 2 * p.R_d - TOL for k, o in enumerate(chrom) if k != i
                )
                for i, (x, y) in enumerate(chrom)
            ]
        )
        keep = connected_mask(p, chrom, usable=ok)
        out.append(evaluate(p, chrom[keep]).covered)
    return np.array(out)


def test_fitness_equals_the_plain_formulation():
    from droneplan.scenarios.cells import thesis_problem

    rng = np.random.default_rng(3)
    cases = [(random_small(s, 30, m), 6.5) for s, m in ((0, 1), (1, 2), (2, 3))]
    cases += [(thesis_problem(m, seed=s), 5200.0) for s, m in ((0, 2), (4, 3))]
    for p, half in cases:
        pop = rng.uniform(-half, half, size=(300, p.n_cells, 2))
        pop[:40] = np.clip(pop[:40], -half * 0.8, half * 0.8)  # some on the area's edge
        # drone-cells on users and exactly 2 R_d apart: the boundary cases of the distance tests
        t = p.targets
        pop[40:60, 0] = t[rng.integers(0, len(t), 20)]
        pop[40:60, -1] = pop[40:60, 0] + [2 * p.R_d, 0.0]
        assert np.array_equal(fitness(p, pop), reference_fitness(p, pop))
        assert np.array_equal(fitness(p, pop.reshape(30, 10, p.n_cells, 2)), fitness(p, pop).reshape(30, 10))


def reference_ga(p, N, P, iter_max, s, seed):
    """The GA generation loop written plainly (the whole population re-evaluated after the
    crossover, the fitness by reference_fitness): the same random draws, so the same result."""
    from droneplan.planners.cells import _area

    rng = np.random.default_rng(seed)
    m = p.n_cells
    xmin, xmax, ymin, ymax = _area(p)
    lo, hi = np.array([xmin, ymin]), np.array([xmax, ymax])
    origin = p.gbs[0]

    def fit(x):
        return reference_fitness(p, x).reshape(x.shape[:-2])

    pop = rng.uniform(lo, hi, size=(N, P, m, 2))
    f = fit(pop)
    T = s.T
    n_rep = int(np.floor(s.replace_frac * P))
    for _ in range(iter_max):
        fbest = f.max(axis=1, keepdims=True).astype(float)
        scale = np.where(fbest > 0, (1.0 - f / np.maximum(fbest, 1e-12)) ** 2, 1.0)
        mask = rng.random((N, P, m, 2)) < s.p_m
        sign = rng.choice([-1.0, 1.0], size=(N, P, m, 2))
        step = sign * rng.random((N, P, m, 2)) * scale[..., None, None]
        moved = (
            origin + (pop - origin) * (1.0 + step)
            if s.mutation_step is None
            else pop + step * s.mutation_step
        )
        cand = np.clip(np.where(mask, moved, pop), lo, hi)
        changed = mask.any(axis=(2, 3))
        fc = f.copy()
        if changed.any():
            fc[changed] = fit(cand[changed][:, None])[:, 0]
        delta = fc - f
        accept = changed & ((delta >= 0) | (rng.random((N, P)) < np.exp(np.minimum(delta, 0) / T)))
        pop = np.where(accept[..., None, None], cand, pop)
        f = np.where(accept, fc, f)
        perm = np.argsort(rng.random((N, P)), axis=1)
        half = P // 2
        a, b = perm[:, 0 : 2 * half : 2], perm[:, 1 : 2 * half : 2]
        fmax = f.max(axis=1, keepdims=True).astype(float)
        favg = f.mean(axis=1, keepdims=True)
        fp = np.maximum(np.take_along_axis(f, a, 1), np.take_along_axis(f, b, 1))
        spread = fmax - favg
        pc = np.where(
            fp >= favg, s.p_c1 - (s.p_c1 - s.p_c2) * (fp - favg) / np.where(spread > 0, spread, 1.0), s.p_c1
        )
        pc = np.where(spread > 0, pc, s.p_c2)
        do = rng.random((N, half)) < pc
        rows = rng.integers(0, m, size=(N, half))
        for n_, c_ in zip(*np.nonzero(do), strict=True):
            i, j, r = a[n_, c_], b[n_, c_], rows[n_, c_]
            pop[n_, i, r, 1], pop[n_, j, r, 1] = pop[n_, j, r, 1], pop[n_, i, r, 1]
        f = fit(pop)
        if n_rep:
            for n_ in range(N):
                order = np.argsort(f[n_], kind="stable")
                pop[n_, order[:n_rep]] = pop[n_, order[-1]]
                f[n_, order[:n_rep]] = f[n_, order[-1]]
        T *= s.alpha
    i = np.argmax(f, axis=1)
    return pop[np.arange(N), i], f[np.arange(N), i]


@pytest.mark.parametrize(
    ("seed", "m", "settings"),
    [
        (0, 1, GASettings()),
        (1, 2, GASettings()),
        (2, 3, GASettings(T=1e-9, replace_frac=0.5)),
        (3, 2, GASettings(mutation_step=1.5)),
    ],
)
def test_ga_equals_the_plain_generation_loop(seed, m, settings):
    p = random_small(seed, 30, m)
    r = genetic(p, pop_size=12, iter_max=15, restarts=3, seed=seed, settings=settings)
    chroms, fvals = reference_ga(p, 3, 12, 15, settings, seed)
    assert r.info["restart_bests"] == [int(v) for v in fvals]
    assert np.array_equal(r.info["chromosome"], chroms[int(np.argmax(fvals))])


def plain_exhaustive_value(p):
    """Algorithm 2 by brute force: every sequence of user points for drone-cells 1..k (k < m),
    each in its deployment region, counts; after m - 1 of them the constrained single-disc
    sweep places the last one. The best covered count."""
    from itertools import product

    from droneplan.planners.cells import deployment_region

    t = p.targets
    best = 0
    for k in range(p.n_cells):  # placements of k + 1 cells (prefixes count too)
        for combo in product(range(len(t)), repeat=k):
            pl = t[list(combo)].reshape(-1, 2)
            if any(not deployment_region(p, pl[:i]).contains(pl[i])[0] for i in range(len(pl))):
                continue
            cov = np.zeros(len(t), bool)
            for q in pl:
                cov |= np.hypot(*(t - q).T) <= p.R_d + 1e-6
            best = max(best, int(cov.sum()))
            if k < p.n_cells - 1:
                continue
            c, q = max_coverage_in_region(t[~cov], p.R_d, deployment_region(p, pl))
            if q is not None:
                best = max(best, int(cov.sum()) + c)
    return best


@pytest.mark.parametrize(("seed", "m"), [(0, 2), (1, 2), (2, 3), (3, 3), (4, 2)])
def test_pruned_exhaustive_equals_the_plain_enumeration(seed, m):
    p = random_small(seed, 14 if m == 3 else 22, m)
    pruned, plain = exhaustive(p), exhaustive(p, prune=False)
    assert pruned.objective == plain.objective == plain_exhaustive_value(p)
    assert np.array_equal(pruned.x, plain.x)  # strict improvements only: the same plan too
    assert plain.info["last_cell_skipped"] == 0 and plain.info["subtrees_pruned"] == 0
    assert pruned.info["last_cell_searches"] <= plain.info["last_cell_searches"]
