"""The observer drone and its alarm in the repelling procedure (thesis §5.3.1), one test per stated
property: it leaves the formation when the sharks are spotted and stays at an altitude over them;
it raises the alarm at once (speakers for swimmers near a shark, the lifeguards otherwise); with
more sharks than operators it sends the highest alert and the n sharks closest to swimmers are served.
"""

from __future__ import annotations

import numpy as np
import pytest

import droneplan as dp
from droneplan.planners.shark import RepellingOperator, allocate_operators
from droneplan.scenarios.shark import (
    AlarmLevel,
    ObserverDrone,
    alarm_level,
    sharks_to_repel,
    simulate_repelling,
)

H = np.array([[0.0, 0.0], [10.0, 5.0]])
O0 = np.array([[0.0, -30.0, 2.0]])


def _run(S0, O0=O0, H=H, observer=None, t_max=60.0, controllers=None):
    ctls = controllers or [RepellingOperator(0) for _ in range(len(O0))]
    return simulate_repelling(S0, O0, H, ctls, seed=0, t_max=t_max, observer=observer)


def test_the_observer_leaves_the_formation_at_t0_and_flies_at_its_altitude():
    obs = ObserverDrone(altitude=25.0, speed=8.0)
    tr = _run(np.array([[100.0, 60.0]]), observer=obs)
    assert tr.observer.shape == (len(tr.t), 3)
    assert np.allclose(tr.observer[0, :2], O0[:, :2].mean(axis=0))  # from the formation (operators)
    assert np.all(tr.observer[:, 2] == 25.0)
    step = np.linalg.norm(np.diff(tr.observer[:, :2], axis=0), axis=1)
    assert step.max() <= 8.0 * dp.shark.THESIS_TABLE_5_1.Ts + 1e-9  # at most its speed


def test_the_observer_stays_over_the_sharks_it_monitors():
    # one shark heading for the swimmers at 5 m/s, an observer twice as fast from 130 m away
    S0 = np.array([[100.0, 60.0]])
    tr = _run(S0, observer=ObserverDrone(speed=10.0, start=(-20.0, -20.0)))
    Ts = dp.shark.THESIS_TABLE_5_1.Ts
    gap = np.linalg.norm(tr.observer[:, :2] - tr.sharks[:, 0, :2], axis=1)
    assert np.all(np.diff(gap[:40]) < 0)  # closing in from the start
    caught = int(np.argmax(gap <= 10.0 * Ts + 1e-9))
    assert caught > 0 and np.all(gap[caught:] <= 10.0 * Ts + 1e-9)  # then it keeps above the shark


def test_the_alarm_is_raised_when_the_sharks_are_spotted():
    tr = _run(np.array([[100.0, 60.0]]))
    assert tr.alarm.shape == tr.t.shape
    assert tr.alarm[0] in (AlarmLevel.LIFEGUARD, AlarmLevel.SPEAKER, AlarmLevel.CLOSE_BEACH)
    assert np.all(tr.alarm >= AlarmLevel.LIFEGUARD)  # never silent during the episode


def test_speakers_alarm_the_swimmers_near_a_shark_at_once():
    far = np.array([[300.0, 0.0]])
    S0 = np.array([[30.0, 20.0]])  # 36 m from swimmer 0, 25 m from swimmer 1
    Hs = np.vstack([H, far])
    tr = _run(S0, H=Hs, observer=ObserverDrone(near_radius=40.0))
    assert tr.alarm[0] == AlarmLevel.SPEAKER
    assert tr.alerted_at[0] == 0.0 and tr.alerted_at[1] == 0.0  # told to leave the water immediately
    assert np.isnan(tr.alerted_at[2])  # the distant swimmer is not near the shark: not told by speaker


def test_with_no_swimmer_near_the_shark_the_warning_goes_through_the_lifeguards():
    tr = _run(np.array([[200.0, 120.0]]), observer=ObserverDrone(near_radius=50.0), t_max=5.0)
    assert tr.alarm[0] == AlarmLevel.LIFEGUARD
    assert np.all(np.isnan(tr.alerted_at))
    assert alarm_level([[200.0, 120.0]], H, 1, 50.0) == AlarmLevel.LIFEGUARD
    assert alarm_level([[20.0, 10.0]], H, 1, 50.0) == AlarmLevel.SPEAKER


def test_the_speaker_alarm_starts_when_a_hunting_shark_comes_near():
    # the shark starts 117 m away and swims at 5 m/s straight for swimmer 0
    tr = _run(np.array([[100.0, 60.0]]), observer=ObserverDrone(near_radius=50.0), controllers=[_Idle()])
    first = int(np.argmax(tr.alarm == AlarmLevel.SPEAKER))
    assert tr.alarm[0] == AlarmLevel.LIFEGUARD and first > 0
    d = np.linalg.norm(tr.sharks[:, 0, None, :2] - H[None], axis=2).min(axis=1)
    assert d[first] <= 50.0 < d[first - 1]


class _Idle:
    phase = None

    def reset(self, scenario, *, seed=None):
        """An idle operator keeps no state."""

    def command(self, obs):
        return np.zeros(3)


def test_more_sharks_than_operators_close_the_beach_and_serve_the_closest():
    S0 = np.array([[150.0, 0.0, -3.0], [40.0, 30.0, -3.0], [-90.0, 60.0, -3.0]])
    ops = np.array([[-10.0, -20.0, 2.0], [10.0, -20.0, 2.0]])
    tr = _run(S0, O0=ops, t_max=5.0)
    assert np.all(tr.alarm == AlarmLevel.CLOSE_BEACH)
    # distances to the nearest swimmer: 150, 50, 108 m -> the two closest are sharks 1 and 2
    assert tr.to_repel.tolist() == [1, 2]
    V0 = np.zeros((3, 3))
    alloc = allocate_operators(ops, S0, V0, H)
    assert sorted(int(j) for j in alloc.x.sharks) == tr.to_repel.tolist()  # the allocation serves them


def test_enough_operators_serve_every_shark_at_the_alarm_of_their_distance():
    S0 = np.array([[150.0, 0.0, -3.0], [40.0, 30.0, -3.0]])
    ops = np.array([[-10.0, -20.0, 2.0], [10.0, -20.0, 2.0]])
    tr = _run(S0, O0=ops, t_max=5.0, observer=ObserverDrone(near_radius=60.0))
    assert tr.to_repel.tolist() == [0, 1]
    assert tr.alarm[0] == AlarmLevel.SPEAKER  # shark 1 is 38 m from swimmer 1


def test_the_observer_changes_nothing_the_operators_or_sharks_do():
    S0 = np.array([[100.0, 60.0]])
    a = _run(S0, observer=ObserverDrone(altitude=10.0, speed=3.0, near_radius=5.0))
    b = _run(S0, observer=ObserverDrone())
    assert np.array_equal(a.sharks, b.sharks) and np.array_equal(a.operators, b.operators)
    assert a.reactions.tolist() == b.reactions.tolist()


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [
        ({"altitude": float("nan")}, "altitude"),
        ({"altitude": 0.0}, "altitude"),
        ({"speed": -1.0}, "speed"),
        ({"speed": "10"}, "speed"),
        ({"near_radius": 0.0}, "near_radius"),
        ({"start": (float("nan"), 0.0)}, "start"),
        ({"start": (0.0, 0.0, 1.0)}, "start"),
    ],
)
def test_observer_settings_are_checked(kwargs, name):
    with pytest.raises((ValueError, TypeError), match=name):
        ObserverDrone(**kwargs)


def test_observer_argument_and_helpers_are_checked():
    with pytest.raises(TypeError, match="observer"):
        _run(np.array([[100.0, 60.0]]), observer="high")
    with pytest.raises(TypeError, match="n_operators"):
        sharks_to_repel([[0.0, 1.0]], H, 1.5)
    with pytest.raises(ValueError, match="near_radius"):
        alarm_level([[0.0, 1.0]], H, 1, -2.0)
    for bad in ([[float("nan"), 0.0]], [[0.0, 0.0, 0.0, 0.0]], [0.0, 1.0], "abc"):  # (k, 2|3) finite
        with pytest.raises((ValueError, TypeError), match="sharks"):
            alarm_level(bad, H, 1, 50.0)
        with pytest.raises((ValueError, TypeError), match="sharks"):
            sharks_to_repel(bad, H, 1)
    with pytest.raises(ValueError, match="swimmers"):
        sharks_to_repel([[0.0, 1.0]], np.zeros((0, 2)), 1)
