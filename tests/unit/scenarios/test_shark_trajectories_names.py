"""A trajectory keeps the name it was made with."""

import droneplan as dp
from droneplan.scenarios.shark.trajectories import make_trajectory


def test_a_trajectory_keeps_its_name():
    assert dp.shark.random_trajectory(9).name == "random-9"
    assert make_trajectory(0.0, 1.0, -3.0, duration=1.0, name="straight").name == "straight"
