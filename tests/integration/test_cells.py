import pandas as pd
import pytest

from droneplan.studies import cells as study


@pytest.mark.slow
def test_reproduce_quick_writes_tables_and_orders_methods(tmp_path):
    study.reproduce(quick=True, out=tmp_path)
    raw = pd.read_csv(tmp_path / "table_4_3_raw.csv")
    for name in ("table_4_3.csv", "fig_4_3.csv", "fig_4_5.csv", "fig_4_6.csv", "fig_4_4_maps.png"):
        assert (tmp_path / name).exists()
    # the continuous-valid bound holds for both heuristics (their plans are feasible placements)
    assert (raw["continuous_bound"] >= raw["es_obj"]).all()
    assert (raw["continuous_bound"] >= raw["ga_best"]).all()
    assert (raw["continuous_bound"] >= raw["milp_obj"]).all()
    assert (raw["milp_obj"] <= raw["milp_bound"]).all()


@pytest.mark.slow
@pytest.mark.parametrize(("m", "backend"), [(3, "cp-sat"), (4, "cp-sat"), (4, "highs")])
def test_thesis_scale_milp_proven_optimal(m, backend):
    from droneplan.formulations.cells import evaluate, solve_milp
    from droneplan.scenarios.cells import thesis_problem
    from droneplan.solvers.result import Status

    p = thesis_problem(m, study.INSTANCE_SEED)
    r = solve_milp(p, backend=backend, time_limit=900)
    assert r.status is Status.OPTIMAL and r.objective == r.bound
    assert evaluate(p, r.x).feasible and evaluate(p, r.x).covered == r.objective
