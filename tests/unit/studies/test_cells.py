import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from droneplan.formulations.cells import CellProblem
from droneplan.studies import cells as study


def test_study_entry_points_exist():
    for name in ("reproduce", "gap", "bench"):
        assert callable(getattr(study, name))


def test_plot_map_draws_every_range_and_the_backhaul_links():
    p = CellProblem(
        users=[[2.5, 0.0], [7.0, 0.0]], gbs=[[0.0, 0.0]], n_cells=2, R_d=1.0, R_g=1.0, r1=3.0, r2=2.5
    )
    fig, ax = plt.subplots()
    assert study.plot_map(p, np.array([[2.5, 0.0], [4.5, 0.0]]), ax=ax, title="t", ranges=True) is fig
    # GBS cell + r1 range, and the coverage disk of each drone-cell
    assert len(ax.patches) == 2 + 2
    # links: drone 0 - GBS (2.5 <= r1), drone 0 - drone 1 (2 <= r2); drone 1 - GBS is 4.5 > r1
    links = [ln for ln in ax.lines if ln.get_color() == "tab:green" and len(ln.get_xdata()) == 2]
    assert len(links) == 2
    plt.close(fig)


def test_reproduce_tasks_emit_schema_rows_within_the_bounds():
    exact = {
        r["method"]: r
        for r in study.reproduce_task(
            {
                "problem": "cells",
                "instance": "table4.3:m=1,seed=0",
                "kind": "exact",
                "m": 1,
                "seed": 0,
                "milp_limit": 60.0,
                "es_limit": 20.0,
            }
        )
    }
    ga = study.reproduce_task(
        {
            "problem": "cells",
            "instance": "table4.3-ga:m=1,run=3,seed=0",
            "kind": "ga",
            "m": 1,
            "seed": 0,
            "run_seed": 3,
            "pop_size": 20,
            "restarts": 3,
        }
    )[0]
    milp = exact["milp"]
    assert milp["bound_kind"] == "candidate-set" and milp["objective"] <= milp["bound"]
    assert exact["exhaustive"]["objective"] <= exact["continuous-bound"]["bound"]
    assert ga["objective"] <= exact["continuous-bound"]["bound"]
    assert ga["objective"] <= ga["cells_polished"]  # polishing never loses users


def test_ga_ablation_rows_respect_the_milp_optimum():
    variants = {
        "thesis": {},
        "no SA (improvements only)": {"settings": {"T": 1e-9}},
        "no restarts (1 run, same generations)": {"no_restarts": True},
    }
    df = study.ga_ablation(
        seeds=[0], ms=(1,), runs=2, variants=variants, es_limit=60, milp_limit=60, progress=False
    )
    assert list(df["variant"]) == list(variants)
    assert (df["milp_status"] == "OPTIMAL").all()
    # every GA plan and the exhaustive-search plan are feasible placements: never above the optimum
    assert (df["best_obj"] <= df["milp_obj"]).all() and (df["es_obj"] <= df["milp_obj"]).all()
    assert df["p_es"].between(0, 1).all() and df["p_milp"].between(0, 1).all()
    assert (df["users_direct_reach"] <= df["users_in_reach"]).all()
    assert (df["users_in_reach"] <= df["active_users"]).all()
