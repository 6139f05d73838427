import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from droneplan.formulations.cells import CellProblem  # noqa: E402
from droneplan.studies import cells as study  # noqa: E402


def test_study_entry_points_exist():
    for name in ("reproduce", "gap", "bench"):
        assert callable(getattr(study, name))


def test_plot_map_draws_every_range():
    p = CellProblem(users=[[2.5, 0.0], [7.0, 0.0]], gbs=[[0.0, 0.0]], n_cells=2, R_d=1.0, R_g=1.0, r1=3.0, r2=2.5)
    fig, ax = plt.subplots()
    study.plot_map(ax, p, np.array([[2.5, 0.0], [4.5, 0.0]]), "t")
    # GBS cell + r1 range, and coverage + r2 range per drone-cell
    assert len(ax.patches) == 2 + 2 * 2
    plt.close(fig)
