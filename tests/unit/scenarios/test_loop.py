"""The closed-loop contract shared by covert, shark and herding (scenarios/loop.py)."""

import enum
import inspect

import numpy as np
import pytest

import droneplan as dp
from droneplan.scenarios.loop import Controller, Frame, LoopTrace, controller_counters

CONTROLLERS = [
    (dp.covert, dp.covert.SlidingModeObserver),
    (dp.covert, dp.covert.HoverBenchmark),
    (dp.covert, dp.covert.MPCObserver),
    (dp.covert, dp.covert.SafeguardedMPCObserver),
    (dp.shark, dp.shark.ClassicalPursuit),
    (dp.shark, dp.shark.VirtualSharkInterceptor),
    (dp.shark, dp.shark.OCPInterceptor),
    (dp.herding, dp.herding.ProposedHerder),
    (dp.herding, dp.herding.BenchmarkHerder),
]


@pytest.mark.parametrize(("module", "cls"), CONTROLLERS, ids=lambda x: getattr(x, "__name__", ""))
def test_every_controller_has_the_same_methods(module, cls):
    for name in ("reset", "command"):
        assert callable(getattr(cls, name, None)), f"{cls.__name__} has no {name}"
    reset = inspect.signature(cls.reset)
    assert list(reset.parameters)[:2] == ["self", "scenario"]
    assert reset.parameters["seed"].kind is inspect.Parameter.KEYWORD_ONLY
    assert list(inspect.signature(cls.command).parameters) == ["self", "obs"]
    for old in ("step", "observe", "control"):
        assert not hasattr(cls, old), f"{cls.__name__} still has the old verb {old}"
    # one simulate under the same name, seed keyword-only
    sim = inspect.signature(module.simulate)
    assert list(sim.parameters)[:2] == ["scenario", "controller"]
    assert sim.parameters["seed"].kind is inspect.Parameter.KEYWORD_ONLY


def _runs():
    covert_sc = dp.covert.thesis_case(1, seed=0)
    path = dp.shark.thesis_trajectories()["a"]
    herd_sc = dp.herding.thesis_scenario(15, seed=0, field_size=(100.0, 100.0), goal=(-100.0, 50.0))
    return {
        "covert": (
            dp.covert.simulate(covert_sc, dp.covert.SlidingModeObserver(), seed=3, t_max=8.0),
            dp.covert.SlidingModeObserver,
            dp.covert.CovertPhase,
            dp.covert.CovertFrame,
        ),
        "shark": (
            dp.shark.simulate(
                dp.shark.InterceptionScenario(path), dp.shark.VirtualSharkInterceptor(), seed=3
            ),
            dp.shark.VirtualSharkInterceptor,
            dp.shark.SharkPhase,
            dp.shark.SharkFrame,
        ),
        "herding": (
            dp.herding.simulate(herd_sc, dp.herding.ProposedHerder(), t_max=6.0, seed=3, frame_every=2.0),
            dp.herding.ProposedHerder,
            dp.herding.HerdingPhase,
            dp.herding.HerdingFrame,
        ),
    }


@pytest.fixture(scope="module")
def runs():
    return _runs()


@pytest.mark.parametrize("problem", ["covert", "shark", "herding"])
def test_traces_share_the_base(runs, problem):
    trace, ctl, phase_enum, frame_type = runs[problem]
    assert isinstance(ctl(), Controller)
    assert isinstance(trace, LoopTrace) and trace.seed == 3
    assert issubclass(phase_enum, enum.Enum) and issubclass(frame_type, Frame)
    # times in s, increasing; the final state is a frame at the last time
    assert np.all(np.diff(trace.t) > 0) and trace.t[0] == 0.0
    assert isinstance(trace.final, frame_type) and trace.final.t == pytest.approx(trace.t[-1])
    assert isinstance(trace.final.phase, phase_enum)
    assert all(isinstance(p, phase_enum) for p in trace.phase)
    assert len(trace.frames) >= 2 and all(isinstance(f, frame_type) for f in trace.frames)
    assert trace.fallbacks == 0 and isinstance(trace.status_counts, dict)


def test_final_states_match_the_sampled_series(runs):
    cov = runs["covert"][0]
    assert np.array_equal(cov.final.drone, cov.drone[-1]) and np.array_equal(
        cov.final.targets, cov.targets[-1]
    )
    sh = runs["shark"][0]
    assert np.array_equal(sh.final.operator, sh.operator[-1]) and sh.final.phase is sh.phase[-1]
    # herding samples animals only in frames: the final state is stored on its own
    he = runs["herding"][0]
    a = he.final.animals
    assert a.shape == (15, 2) and np.array_equal(he.final.drones, he.drones[-1])
    assert np.max(np.linalg.norm(a - a.mean(axis=0), axis=1)) == pytest.approx(he.footprint_radius[-1])
    # the herder's allocation solves are counted per status
    assert he.status_counts and set(he.status_counts) <= {s.name for s in dp.Status}


def test_controller_counters_normalise_status_names():
    class C:
        fallbacks = 2
        statuses = ("optimal", "OPTIMAL", dp.Status.NO_SOLUTION)
        solve_times = np.array([0.1, 0.2, 0.3])

    c = controller_counters(C())
    assert c["fallbacks"] == 2 and c["status_counts"] == {"OPTIMAL": 2, "NO_SOLUTION": 1}
    assert c["solve_times"].tolist() == [0.1, 0.2, 0.3]
    assert controller_counters(object()) == {
        "fallbacks": 0,
        "status_counts": {},
        "solve_times": pytest.approx([]),
    }
