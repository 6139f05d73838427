import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
import pytest

from droneplan.formulations.cells import CellProblem
from droneplan.studies.thesis import cells as study


def test_study_entry_points_exist():
    for name in ("reproduce", "gap", "bench"):
        assert callable(getattr(study, name))


def test_plot_map_draws_every_range_and_the_backhaul_links():
    p = CellProblem(
        users=[[2.5, 0.0], [7.0, 0.0]], gbs=[[0.0, 0.0]], n_cells=2, R_d=1.0, R_g=1.0, r1=3.0, r2=2.5
    )
    fig, ax = plt.subplots()
    assert study.plot_map(p, np.array([[2.5, 0.0], [4.5, 0.0]]), ax=ax, title="t", ranges=True) is fig
    # GBS cell + r1 range as patches
    assert len(ax.patches) == 2
    from matplotlib.colors import to_rgba

    def polylines(color):
        """The NaN-separated polylines (arrays of points) of the lines drawn in ``color``."""
        out = []
        for line in ax.lines:
            if to_rgba(line.get_color()) != to_rgba(color):
                continue
            xy = line.get_xydata()
            breaks = np.flatnonzero(np.isnan(xy[:, 0]))
            out += [part for part in np.split(xy, breaks) if len(part[~np.isnan(part[:, 0])]) > 1]
        return [part[~np.isnan(part[:, 0])] for part in out]

    # the coverage disk of each drone-cell: closed rings of radius R_d around the two drone-cells
    rings = polylines("k")
    assert len(rings) == 2
    for ring, centre in zip(rings, ([2.5, 0.0], [4.5, 0.0]), strict=True):
        np.testing.assert_allclose(np.linalg.norm(ring - centre, axis=1), 1.0)
    # links: drone 0 - GBS (2.5 <= r1), drone 0 - drone 1 (2 <= r2); drone 1 - GBS is 4.5 > r1
    links = sorted(tuple(map(tuple, seg)) for seg in polylines("tab:green"))
    assert links == [((2.5, 0.0), (0.0, 0.0)), ((2.5, 0.0), (4.5, 0.0))]
    plt.close(fig)


def test_plot_map_draws_coincident_drone_cells_once():
    """A thousand drone-cells at one spot draw one ring and one link, not half a million links."""
    p = CellProblem(users=[[2.5, 0.0]], gbs=[[0.0, 0.0]], n_cells=1000, R_d=1.0, R_g=1.0, r1=3.0, r2=2.5)
    fig, ax = plt.subplots()
    study.plot_map(p, np.tile([[2.5, 0.0]], (1000, 1)), ax=ax)
    drawn = [line.get_xydata() for line in ax.lines]
    pieces = sum(int(np.isnan(xy[:, 0]).sum()) for xy in drawn)  # one NaN closes each polyline
    assert pieces == 2  # the coverage ring and the drone-GBS link
    plt.close(fig)


def test_reproduce_tasks_emit_schema_rows_within_the_bounds():
    task = {"problem": "cells", "instance": "table4.3:m=1,seed=0", "kind": "exact", "m": 1, "seed": 0}
    exact = {r["method"]: r for r in study.reproduce_task({**task, "exact_limit": 60.0})}
    bnb = exact["bnb"]  # the row is named after the engine that made it
    assert bnb["bound_kind"] == "candidate-set" and bnb["objective"] <= bnb["bound"]
    assert bnb["objective"] <= exact["continuous-bound"]["bound"]
    with pytest.raises(ValueError, match="kind"):  # GA runs are gap rows now, not tasks
        study.reproduce_task({**task, "kind": "ga", "exact_limit": 60.0})


def test_ga_ablation_rows_respect_the_exact_optimum(tmp_path):
    from droneplan.studies.common import make_executor
    from droneplan.studies.store import ResultStore

    variants = ["thesis", "noSA", "no-restarts"]
    kw = {"seeds": [0], "ms": (1,), "runs": 2, "variants": variants, "es_limit": 60, "exact_limit": 60}
    df = study.ga_ablation(**kw, out=tmp_path)
    assert list(df["variant"]) == [*variants, "clusters-only"]
    # the clusters-only instance is the same snapshot without its background users
    th, cl = df.iloc[0], df.iloc[-1]
    assert cl["users"] == "clusters-only" and cl["active_users"] < th["active_users"]
    assert cl["exact_obj"] <= th["exact_obj"] and cl["clusters_in_reach"] == th["clusters_in_reach"]
    assert (df["exact_status"] == "OPTIMAL").all()
    # every GA plan and the exhaustive-search plan are feasible placements: never above the optimum
    assert (df["best_obj"] <= df["exact_obj"]).all() and (df["es_obj"] <= df["exact_obj"]).all()
    assert df["p_es"].between(0, 1).all() and df["p_exact"].between(0, 1).all()
    assert (df["best_share"].isna() | df["best_share"].between(0, 1)).all()
    assert (df["users_direct_reach"] <= df["users_in_reach"]).all()
    assert (df["users_in_reach"] <= df["active_users"]).all()
    assert (df["clusters_direct_reach"] <= df["clusters_in_reach"]).all()
    assert "m=1: the faithful GA" in df.attrs["finding"]
    # every run and reference is a row of droneplan.gap in the store: a rerun computes nothing
    with ResultStore(tmp_path / "results.sqlite") as st:
        rows = st.frame()
        assert set(rows["study"]) == {"gap"}
        by = rows.groupby("family")["method"].agg(list)
        # Table 4.2 users: the certified library row, exhaustive search, 3 variants x 2 runs
        assert sorted(by["table4.2"]) == sorted(
            ["library", "exhaustive@60s"] + [f"ga-{v}" for v in variants for _ in range(2)]
        )
        # clusters only (no library entry): the branch and bound, exhaustive search, 2 thesis GA runs
        assert sorted(by["table4.2-clusters"]) == sorted(["bnb", "exhaustive@60s", "ga-thesis", "ga-thesis"])
        # run r of every variant on an instance has one seed (paired runs)
        ga = rows[rows["method"].str.startswith("ga-") & (rows["family"] == "table4.2")]
        assert (ga.groupby("run")["run_seed"].nunique() == 1).all()
        with make_executor(1) as ex:
            again = study.ga_ablation(**kw, executor=ex, store=st)
        assert len(st.frame()) == len(rows)
    pd.testing.assert_frame_equal(again, df)


def test_ablation_parts_run_each_variant_as_a_method():
    parts = study.ablation_parts(seeds=[0, 1], ms=(1, 2), runs=3, ablation_runs=2, es_limit=5, exact_limit=5)
    methods = {(p.family, p.m, m.name): (p.runs, p.seeds, m.deterministic) for p in parts for m in p.methods}
    for m in (1, 2):
        assert methods[("table4.2", m, "ga-thesis")] == (3, (0, 1), False)
        for v in study.GA_VARIANTS:
            if v != "thesis":
                assert methods[("table4.2", m, f"ga-{v}")] == (2, (0, 1), False)
        assert methods[("table4.2-clusters", m, "ga-thesis")] == (2, (0, 1), False)
        for family in ("table4.2", "table4.2-clusters"):  # deterministic: one run whatever the part's runs
            assert methods[(family, m, "exhaustive@5s")][1:] == ((0, 1), True)
        # the library proves the Table 4.2 optima; the clusters-only instances get the branch and bound
        assert ("table4.2", m, "bnb") not in methods
        assert methods[("table4.2-clusters", m, "bnb")][1:] == ((0, 1), True)
    with pytest.raises(ValueError, match="instances"):
        study.ablation_parts(seeds=[0], ms=(1,), runs=1, instances=["nope"], es_limit=5, exact_limit=5)
    with pytest.raises(ValueError, match="variants"):
        study.ablation_parts(seeds=[0], ms=(1,), runs=1, variants=["nope"], es_limit=5, exact_limit=5)


def test_instance_features_checks_the_centres_and_counts_them_against_the_reach():
    from droneplan.scenarios.cells import thesis_problem

    p = thesis_problem(1, 0)
    for bad in (1e12, 1e-300, 10**12):
        with pytest.raises((ValueError, TypeError), match=r"^centres"):
            study.instance_features(p, bad)
    with pytest.raises(ValueError, match=r"^centres"):
        study.instance_features(p, [[np.nan, 0.0]])
    # a centre on the first GBS is within direct reach; one a million metres away is in neither
    far = p.gbs[0] + 1e6
    feats = study.instance_features(p, np.array([p.gbs[0], far]))
    assert feats["clusters_direct_reach"] == 1 and feats["clusters_in_reach"] == 1


@pytest.mark.parametrize(
    ("kw", "name"),
    [
        ({"runs": 10**12}, "runs"),
        ({"runs": 10**6}, "runs"),
        ({"runs": 1, "ablation_runs": 10**12}, "ablation_runs"),
        ({"runs": 10**6, "variants": ["noSA"]}, r"runs \(the default ablation_runs\)"),
    ],
)
def test_ga_ablation_refuses_runs_beyond_the_solves_budget_up_front(kw, name, tmp_path):
    from droneplan.core.validation import MAX_SOLVES

    kw = {"seeds": [0], "ms": (1,), "variants": ["thesis"], "es_limit": 5.0, "exact_limit": 5.0, **kw}
    refusal = rf"^{name} asks for \d+ solver calls, more than the limit of {MAX_SOLVES}"
    with pytest.raises(ValueError, match=refusal):
        study.ga_ablation(**kw, out=tmp_path)
    assert not list(tmp_path.iterdir())  # refused before any store was opened


def test_ablation_budget_counts_every_run_and_reference():
    from droneplan.core.validation import work_limits

    kw = {"seeds": [0, 1], "ms": (1, 2), "runs": 3, "ablation_runs": 2, "es_limit": 5, "exact_limit": 5}
    n = 4  # (seed, m) pairs
    others = sum(4 if v == "restarts-x4" else 1 for v in study.GA_VARIANTS if v != "thesis")
    # thesis GA runs, the other variants' runs and the clusters-only runs, two references per instance
    cost = n * 3 + n * 2 * (others + 1) + 2 * n * 2
    with work_limits(solves=cost):
        assert study.ablation_parts(**kw)
    with work_limits(solves=cost - 1), pytest.raises(ValueError, match="solver calls"):
        study.ablation_parts(**kw)


@pytest.mark.parametrize("param", ["executor", "store", "out"])
def test_ga_ablation_checks_executor_store_and_out(param):
    kw = {"seeds": [0], "ms": (1,), "runs": 1, "variants": ["thesis"], "es_limit": 5.0, "exact_limit": 5.0}
    with pytest.raises(TypeError, match=f"^{param} must be"):
        study.ga_ablation(**kw, **{param: 10**12})


@pytest.mark.parametrize("engine", ["bnb", "milp"])
def test_warm_start_effect_rows(engine):
    """The GA's plan as warm start: the warm run starts from at least the GA's users, both runs
    to proof agree on the optimum, and the row says whether the plan became the incumbent."""
    df = study.warm_start_effect(2, [0, 1], engine=engine, time_limit=60.0, short_limit=1.0, progress=False)
    assert list(df["seed"]) == [0, 1] and (df["engine"] == engine).all()
    assert (df["warm_short"] >= df["ga"]).all()
    assert (df["cold_status"] == "OPTIMAL").all() and (df["warm_status"] == "OPTIMAL").all()
    assert (df["cold_objective"] == df["warm_objective"]).all()
    assert (df["warm_objective"] >= df["ga"]).all()
    assert all(r.warm_reason for r in df.itertuples())
    with pytest.raises(ValueError, match=r"^engine must be one of"):
        study.warm_start_effect(2, [0], engine="gurobi", progress=False)


def test_the_deployment_region_of_coincident_drone_cells_is_drawn_once():
    """A thousand drone-cells at one spot: two keep-out circles and two reach circles, and the region
    of one placed drone-cell."""
    p = CellProblem(users=[[2.5, 0.0]], gbs=[[0.0, 0.0]], n_cells=1001, R_d=1.0, R_g=1.0, r1=3.0, r2=2.5)
    _, ax = plt.subplots()
    study.plot_deployment_region(p, np.tile([[2.5, 0.0]], (1000, 1)), ax=ax)
    circles = sum(int(np.isnan(line.get_xydata()[:, 0]).sum()) for line in ax.lines)
    assert circles == 4
    one = study.plot_deployment_region(p, [[2.5, 0.0]])
    assert ax.get_title() == one.axes[0].get_title()  # the same region area
    plt.close("all")
