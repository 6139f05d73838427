"""Fuzz of every plot helper and animation writer: wrong axes, empty and one-sample runs,
runs with a NaN instant, bad titles and GIF paths, and the study plots on empty or NaN tables.

Each call draws (returns a Figure or the GIF's path) or refuses with a ValueError/TypeError
naming the parameter; never an error from inside matplotlib, PIL or pandas. The front doors'
helpers get their valid calls from ``test_public_api.SPECS``.
"""

from __future__ import annotations

import copy
import dataclasses
import importlib.util
import inspect
import sys
import tempfile
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
import pytest

import droneplan as dp
import droneplan.studies.plots as plots
from droneplan.studies.plots import profiles


def _load_public_api():
    name = "droneplan_fuzz_public_api"
    if name in sys.modules:
        return sys.modules[name]
    spec = importlib.util.spec_from_file_location(name, Path(__file__).with_name("test_public_api.py"))
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    spec.loader.exec_module(module)
    return module


API = _load_public_api()

HELPERS = ["plot_map", "plot_deployment_region", "plot_path", "plot_bearing", "plot_stealth_front"]
HELPERS += ["plot_top_view", "plot_time_series", "plot_state", "plot_final", "plot_footprint"]
WRITERS = ["animate@covert", "animate@shark", "animate@herding", "write_gif"]
TRACE_HELPERS = {  # helper -> the argument that holds the run(s)
    "plot_path": "traces",
    "plot_bearing": "traces",
    "plot_top_view": "traces",
    "plot_time_series": "traces",
    "plot_footprint": "traces",
    "animate@covert": "trace",
    "animate@shark": "trace",
}


@pytest.fixture(autouse=True)
def _close_figures():
    yield
    plt.close("all")


def test_every_plot_helper_and_writer_is_fuzzed_here():
    assert set(plots.__all__) == set(HELPERS)
    public_profiles = {
        n for n, f in vars(profiles).items() if inspect.isfunction(f) and not n.startswith("_")
    }
    public_profiles = {n for n in public_profiles if vars(profiles)[n].__module__ == profiles.__name__}
    # write_study_outputs (summary, figures and rows of a study) is exercised by test_analysis and
    # the open-study tests, which check every file it writes
    assert public_profiles == {"plot_performance_profile", "plot_gap_distribution", "write_study_outputs"}
    doors = {n for door in (dp.cells, dp.covert, dp.shark, dp.herding) for n in door.__all__}
    assert {w.split("@")[0] for w in WRITERS} <= doors


def _call(name: str, **changes: Any):
    fn = API.CALLABLES[name]
    args, kwargs = API.SPECS[name].call()
    bound = inspect.signature(fn).bind_partial(*args, **kwargs)
    bound.arguments.update(changes)
    return fn(*bound.args, **bound.kwargs)


def _outcome(fn, *args, **kwargs) -> tuple[str, str]:
    """("drew", type) or ("refused", message); any other exception propagates (a failure)."""
    try:
        out = fn(*args, **kwargs)
    except (ValueError, TypeError) as exc:
        return "refused", str(exc)
    return "drew", type(out).__name__


# ---------------------------------------------------------------------------- axes and titles
@pytest.mark.parametrize("name", HELPERS)
@pytest.mark.parametrize("ax", ["x", 3, np.zeros(2), "figure", "closed"])
def test_a_wrong_ax_is_a_type_error_naming_ax(name, ax):
    if isinstance(ax, str) and ax == "figure":
        ax = plt.figure()  # a Figure is not an Axes
    elif isinstance(ax, str) and ax == "closed":
        ax = plt.figure().add_subplot(projection="polar")  # an Axes, of a projection no helper draws on
    kind = ValueError if hasattr(ax, "name") else TypeError
    with pytest.raises(kind, match="ax must be"):
        _call(name, ax=ax)


@pytest.mark.parametrize(
    "name", [h for h in HELPERS if "title" in inspect.signature(API.CALLABLES[h]).parameters]
)
@pytest.mark.parametrize("title", [3, 1e12, ["a"], b"x"])
def test_a_title_that_is_not_a_str_names_title(name, title):
    figures = len(plt.get_fignums())
    with pytest.raises(TypeError, match="title"):
        _call(name, title=title)
    assert len(plt.get_fignums()) == figures  # refused before a figure was made


# ---------------------------------------------------------------------------- empty, short and NaN runs
def _cut(trace: Any, n: int) -> Any:
    """``trace`` with only its first ``n`` recorded instants (every per-instant array cut)."""
    changes = {
        f.name: getattr(trace, f.name)[:n]
        for f in dataclasses.fields(trace)
        if isinstance(getattr(trace, f.name), np.ndarray)
        and getattr(trace, f.name).shape[:1] == trace.t.shape
    }
    return dataclasses.replace(trace, **changes)


def _run_of(name: str) -> Any:
    args, kwargs = API.SPECS[name].call()
    bound = inspect.signature(API.CALLABLES[name]).bind_partial(*args, **kwargs)
    return bound.arguments[TRACE_HELPERS[name]]


@pytest.mark.parametrize("name", sorted(TRACE_HELPERS))
def test_a_run_with_no_recorded_instant_is_refused_naming_it(name):
    param = TRACE_HELPERS[name]
    with pytest.raises(ValueError, match=f"{param}.*no recorded instants"):
        _call(name, **{param: _cut(_run_of(name), 0)})


@pytest.mark.parametrize("name", sorted(TRACE_HELPERS))
def test_a_run_with_one_recorded_instant_is_drawn(name):
    param = TRACE_HELPERS[name]
    out = _call(name, **{param: _cut(_run_of(name), 1)})
    assert isinstance(out, (matplotlib.figure.Figure, Path))
    if isinstance(out, Path):
        assert out.read_bytes()[:4] == b"GIF8"


def _one_nan_instant(trace: Any) -> Any:
    """A deep copy of ``trace`` whose float per-instant arrays are NaN at one instant."""
    out = copy.deepcopy(trace)
    k = len(out.t) // 2
    for f in dataclasses.fields(out):
        value = getattr(out, f.name)
        if (
            f.name != "t"
            and isinstance(value, np.ndarray)
            and value.dtype.kind == "f"
            and value.shape[:1] == out.t.shape
        ):
            value[k] = np.nan
    return out


@pytest.mark.parametrize("name", sorted(TRACE_HELPERS))
def test_a_run_with_one_nan_instant_is_refused_naming_it_or_drawn(name):
    param = TRACE_HELPERS[name]
    kind, detail = _outcome(lambda: _call(name, **{param: _one_nan_instant(_run_of(name))}))
    if kind == "refused":
        assert param in detail and "NaN" in detail, detail


def test_herding_writers_with_one_nan_frame_refuse_naming_the_frames():
    tr = copy.deepcopy(_run_of_herding())
    tr.frames[1].animals[0] = np.nan
    for name in ("animate@herding", "write_gif"):
        with pytest.raises(ValueError, match="frames"):
            _call(name, trace=tr)


def _run_of_herding():
    args, _ = API.SPECS["write_gif"].call()
    return args[0]


def test_herding_writers_without_frames_name_frame_every():
    tr = dataclasses.replace(_run_of_herding(), frames=[])
    for name in ("animate@herding", "write_gif"):
        with pytest.raises(ValueError, match="frame_every"):
            _call(name, trace=tr)


# ---------------------------------------------------------------------------- GIF paths
@pytest.mark.parametrize("name", WRITERS)
def test_writers_refuse_a_path_that_is_no_gif_file(name):
    d = Path(tempfile.mkdtemp(prefix="droneplan-fuzz-path-"))
    for bad in (d, d / "x.png", str(d / "x")):
        with pytest.raises(ValueError, match="path"):
            _call(name, path=bad)
    assert not list(d.iterdir())  # nothing written


@pytest.mark.parametrize("name", WRITERS)
def test_writers_create_the_missing_folders_of_a_gif_path(name):
    target = Path(tempfile.mkdtemp(prefix="droneplan-fuzz-path-")) / "a" / "b" / "run.gif"
    out = _call(name, path=target, **({"stride": 10} if name != "write_gif" else {}))
    assert Path(out) == target and target.read_bytes()[:4] == b"GIF8"


# ---------------------------------------------------------------------------- study plots
_DF: list[pd.DataFrame] = []


def _results() -> pd.DataFrame:
    """The rows of a small gap study (greedy and GA on two Table 4.2 instances), run once."""
    if not _DF:
        out = tempfile.mkdtemp(prefix="droneplan-fuzz-profiles-")
        dp.gap("cells", methods=["greedy", "ga"], instances="table4.2", out=out, progress=False, m=1, seeds=2)
        _DF.append(dp.load_results(out))
    return _DF[0].copy()


STUDY_PLOTS = [profiles.plot_performance_profile, profiles.plot_gap_distribution]


@pytest.mark.parametrize("fn", STUDY_PLOTS, ids=lambda f: f.__name__)
def test_study_plots_check_ax_and_df(fn):
    df = _results()
    assert isinstance(fn(df), matplotlib.figure.Figure)
    for ax in ("x", 3, plt.figure()):
        with pytest.raises(TypeError, match="ax must be"):
            fn(df, ax=ax)
    with pytest.raises(ValueError, match="ax must be"):
        fn(df, ax=plt.figure().add_subplot(projection="3d"))
    for bad in ({}, None, [1, 2], "results.csv"):
        with pytest.raises(TypeError, match="df"):
            fn(bad)
    with pytest.raises(ValueError, match=r"df|column"):
        fn(pd.DataFrame({"a": [1.0]}))


@pytest.mark.parametrize("fn", STUDY_PLOTS, ids=lambda f: f.__name__)
@pytest.mark.parametrize(
    "change",
    ["empty", "nan objective", "nan bound", "nan time", "inf objective"],
)
def test_study_plots_on_empty_or_nan_tables_draw(fn, change):
    df = _results()
    if change == "empty":
        df = df.iloc[:0]
    elif change == "nan objective":
        df = df.assign(objective=np.nan)
    elif change == "nan bound":
        df = df.assign(bound=np.nan, gap_to_bound=np.nan)
    elif change == "nan time":
        df = df.assign(time_s=np.nan)
    else:
        df = df.assign(objective=np.inf)
    kind, detail = _outcome(fn, df)
    assert kind == "drew" or "df" in detail, detail
