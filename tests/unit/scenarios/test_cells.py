import numpy as np
import pytest

from droneplan.scenarios.cells import (
    THESIS_TABLE_4_2,
    CellParams,
    CellProblem,
    expected_user_count,
    matern_users,
    thesis_instance,
    thesis_problem,
    uniform_users,
)


def test_table_4_2_preset():
    p = THESIS_TABLE_4_2
    assert p.gbs == ((0.0, 0.0),) and p.bounds == (-5000, 5000, -5000, 5000)
    assert (p.lambda_c, p.lambda_nc, p.n_clusters, p.R_c) == (9e-5, 3e-6, 15, 250)
    assert (p.R_d, p.R_g, p.r1, p.r2) == (500, 1000, 3500, 3000)


def test_matern_reproducible_and_in_area():
    a, ca = matern_users(3, return_centres=True)
    b = matern_users(3)
    assert np.array_equal(a, b)
    assert not np.array_equal(a, matern_users(4))
    assert np.all(np.abs(a) <= 5000) and len(ca) == 15


def test_matern_users_lie_in_cluster_discs_or_background():
    params = CellParams(lambda_nc=0.0)
    users, centres = matern_users(1, params, return_centres=True)
    d = np.hypot(users[:, None, 0] - centres[None, :, 0], users[:, None, 1] - centres[None, :, 1]).min(1)
    assert len(users) > 0 and np.all(d <= params.R_c + 1e-9)


def test_mean_counts_match_expectation():
    counts_c = [len(matern_users(s)) for s in range(40)]
    counts_u = [len(uniform_users(s)) for s in range(40)]
    e = expected_user_count()
    # border losses only lower the clustered count slightly; 40 draws give a standard error ~ 5
    assert abs(np.mean(counts_u) - e) < 20
    assert abs(np.mean(counts_c) - e) < 35


def test_thesis_problem():
    p = thesis_problem(3, seed=0)
    assert isinstance(p, CellProblem) and p.n_cells == 3
    g = np.hypot(*p.users.T)
    assert np.array_equal(p.active, g > 1000)


@pytest.mark.parametrize(
    ("field", "kw"),
    [
        ("r1", dict(r1=1.3)),
        ("r2", dict(r2=1.9)),
        ("R_d", dict(R_d=0.0)),
        ("R_g", dict(R_g=-1.0)),
        ("n_cells", dict(n_cells=0)),
        ("users", dict(users=[[0.0, np.nan]])),
        ("users", dict(users=[[1, 2, 3]])),
        ("gbs", dict(gbs=[[np.inf, 0]])),
        ("gbs", dict(gbs=np.zeros((0, 2)))),
        ("bounds", dict(bounds=(1, 0, 0, 1))),
        ("r1", dict(r1=float("nan"))),
    ],
)
def test_validation_errors_name_the_field(field, kw):
    args = dict(users=[[3.0, 0.0]], gbs=[[0.0, 0.0]], n_cells=1, R_d=1.0, R_g=0.4, r1=2.0, r2=2.0)
    args.update(kw)
    with pytest.raises(ValueError, match=field):
        CellProblem(**args)


def test_params_validation():
    with pytest.raises(ValueError, match="R_c"):
        CellParams(R_c=0)
    with pytest.raises(ValueError, match="n_clusters"):
        CellParams(n_clusters=-1)


def test_cell_problem_pickles_through_its_constructor():
    import pickle

    from droneplan.scenarios.cells import CellProblem

    p = CellProblem(
        [[1500.0, 0.0], [10.0, 0.0]], [[0.0, 0.0]], 2, 500.0, 1000.0, 3500.0, 3000.0, bounds=(-1, 1, -1, 1)
    )
    q = pickle.loads(pickle.dumps(p))
    assert repr(q) == repr(p)
    np.testing.assert_array_equal(q.users, p.users)
    np.testing.assert_array_equal(q.active, p.active)


@pytest.mark.parametrize(
    ("field", "value", "named"),
    [
        ("half_width", 1e12, "lambda_nc, half_width (expected background users)"),
        ("R_c", 1e12, "n_clusters, lambda_c, R_c (expected clustered users)"),
        ("lambda_nc", 1e3, "lambda_nc, half_width (expected background users)"),
        ("lambda_c", 1e6, "n_clusters, lambda_c, R_c (expected clustered users)"),
    ],
)
def test_user_budget_names_the_part_that_asks_for_the_users(field, value, named):
    with pytest.raises(ValueError, match="more than the limit") as info:
        CellParams(**{field: value})
    assert named in str(info.value)


def test_flags_must_be_bools():
    for flag in ("poisson_clusters", "return_centres"):
        with pytest.raises(TypeError, match=f"{flag} must be a bool"):
            matern_users(0, **{flag: "yes"})
    with pytest.raises(TypeError, match="clustered must be a bool"):
        thesis_instance(0, clustered="yes")  # type: ignore[arg-type]
    with pytest.raises(TypeError, match="clustered must be a bool"):
        thesis_problem(2, 0, clustered=1)  # type: ignore[arg-type]
