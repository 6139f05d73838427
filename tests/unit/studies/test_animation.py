"""The animate helpers of the closed-loop problems (covert, shark, herding) and their shared GIF writer."""

from __future__ import annotations

import math

import matplotlib

matplotlib.use("Agg")
import numpy as np
import pytest
from PIL import Image

import droneplan as dp
from droneplan.studies.plots._animation import MAX_FRAMES, frame_indices, save_gif

NAN = float("nan")


@pytest.fixture(scope="module")
def covert_run():
    return dp.covert.simulate(dp.covert.thesis_case(1), dp.covert.HoverBenchmark(), t_max=3.0)


@pytest.fixture(scope="module")
def shark_run():
    return dp.shark.simulate(dp.shark.thesis_trajectories()["a"], dp.shark.ClassicalPursuit())


@pytest.fixture(scope="module")
def herding_run():
    return dp.herding.simulate(
        dp.herding.thesis_scenario(6, seed=0, n_drones=2),
        dp.herding.ProposedHerder(),
        t_max=3.0,
        seed=0,
        frame_every=0.5,
    )


def _frames(path) -> int:
    with Image.open(path) as im:
        assert im.format == "GIF"
        return im.n_frames


@pytest.mark.parametrize(("n", "stride"), [(1, 1), (10, 1), (10, 3), (10, 9), (10, 10), (31, 4), (7, 100)])
def test_frame_indices_take_every_stride_th_instant_and_end_on_the_last(n, stride):
    idx = frame_indices(n, stride)
    expected = sorted(set(range(0, n, stride)) | {n - 1})
    assert idx == expected
    assert len(idx) == math.ceil(n / stride) + (0 if (n - 1) % stride == 0 else 1)


def test_frame_indices_refuse_more_frames_than_the_cap_naming_stride():
    with pytest.raises(ValueError, match="stride"):
        frame_indices(MAX_FRAMES + 5, 1)
    assert len(frame_indices(MAX_FRAMES + 5, 2)) <= MAX_FRAMES


@pytest.mark.parametrize("view", ["top", "3d"])
def test_covert_animation_has_one_frame_per_stride(covert_run, tmp_path, view):
    n = len(covert_run.t)
    path = dp.covert.animate(covert_run, tmp_path / "sub" / "c.gif", fps=5, stride=7, view=view)
    assert path == tmp_path / "sub" / "c.gif"
    assert _frames(path) == len(frame_indices(n, 7))


def test_shark_animation_has_one_frame_per_stride(shark_run, tmp_path):
    path = dp.shark.animate(shark_run, str(tmp_path / "s.gif"), stride=5)
    assert _frames(path) == len(frame_indices(len(shark_run.t), 5))


def test_herding_animation_and_write_gif_share_the_writer(herding_run, tmp_path):
    n = len(herding_run.frames)
    assert n >= 3
    a = dp.herding.animate(herding_run, tmp_path / "h.gif", stride=2)
    assert _frames(a) == len(frame_indices(n, 2))
    b = dp.herding.write_gif(herding_run, tmp_path / "w.gif")
    assert _frames(b) == n


def _moving_point_figure():
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(3, 2.5))
    ax.plot([0, 1], [0, 1], color="0.5", label="static track")
    (point,) = ax.plot([], [], "o", ms=20, color="tab:blue", label="moving")
    ax.set_xlim(-0.1, 1.1)
    ax.set_ylim(-0.1, 1.1)
    ax.legend(loc="upper left")
    title = ax.set_title("")
    xs = np.linspace(0.3, 1.0, 6)

    def update(k: int):  # the point stays clear of the legend (a changing artist is drawn on top)
        point.set_data([xs[k]], [0.15])
        title.set_text(f"frame {k}")
        return point, title

    return fig, update


def test_blitted_frames_match_a_full_redraw_of_the_same_state(tmp_path):
    """The GIF writer draws the static part once and only the changed artists per frame; each
    frame must look like the whole figure drawn at that state."""
    import io

    fig, update = _moving_point_figure()
    path = save_gif(fig, update, list(range(6)), tmp_path / "m.gif", 5)
    with Image.open(path) as im:
        assert im.n_frames == 6
        for k in range(6):
            im.seek(k)
            got = np.asarray(im.convert("RGB"), dtype=int)
            ref_fig, ref_update = _moving_point_figure()
            ref_update(k)
            buf = io.BytesIO()
            ref_fig.savefig(buf, format="png")
            matplotlib.pyplot.close(ref_fig)
            ref = np.asarray(Image.open(buf).convert("RGB"), dtype=int)
            assert got.shape == ref.shape
            # GIF frames are palette images: allow small colour shifts, not a missing or stale artist
            differs = np.abs(got - ref).sum(axis=2) > 60
            assert differs.mean() < 0.001, (k, differs.mean())


CASES = ["covert", "shark", "herding"]


def _run(name, request):
    return request.getfixturevalue(f"{name}_run")


@pytest.mark.parametrize("door", CASES)
@pytest.mark.parametrize(
    ("param", "value", "kind"),
    [
        ("fps", NAN, TypeError),
        ("fps", 0, ValueError),
        ("fps", -4, ValueError),
        ("fps", 8.0, TypeError),
        ("fps", "8", TypeError),
        ("fps", True, TypeError),
        ("stride", NAN, TypeError),
        ("stride", 0, ValueError),
        ("stride", -1, ValueError),
        ("stride", 1.5, TypeError),
        ("stride", None, TypeError),
    ],
)
def test_bad_options_name_the_parameter_and_write_nothing(door, param, value, kind, request, tmp_path):
    fn = getattr(dp, door).animate
    path = tmp_path / "x.gif"
    with pytest.raises(kind, match=param):
        fn(_run(door, request), path, **{param: value})
    assert not path.exists()


@pytest.mark.parametrize("door", CASES)
def test_wrong_trace_or_path_is_refused(door, request, tmp_path):
    fn = getattr(dp, door).animate
    with pytest.raises(TypeError, match="trace"):
        fn("not a trace", tmp_path / "x.gif")
    with pytest.raises(TypeError, match="path"):
        fn(_run(door, request), 3)
    with pytest.raises(ValueError, match="path"):
        fn(_run(door, request), tmp_path / "x.png")


def test_covert_view_is_checked(covert_run, tmp_path):
    with pytest.raises(ValueError, match="view"):
        dp.covert.animate(covert_run, tmp_path / "x.gif", view="side")


def test_nan_positions_are_refused_naming_the_trace(covert_run, shark_run, tmp_path):
    import copy

    c = copy.deepcopy(covert_run)
    c.drone[1, 0] = NAN
    with pytest.raises(ValueError, match="trace"):
        dp.covert.animate(c, tmp_path / "c.gif")
    s = copy.deepcopy(shark_run)
    s.eps[0] = np.inf
    with pytest.raises(ValueError, match="trace"):
        dp.shark.animate(s, tmp_path / "s.gif")
    assert not list(tmp_path.iterdir())


def test_the_report_shows_a_problem_s_gif_beside_its_figures(shark_run, tmp_path):
    from droneplan.studies.thesis.report import write_report

    dp.shark.animate(shark_run, tmp_path / "shark" / "run.gif", stride=10)
    text = write_report(tmp_path).read_text()
    assert '<img src="shark/run.gif"' in text
