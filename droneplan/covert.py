"""Covert observation of moving animals with motion camouflage (thesis ch. 3): the world
and simulator (line of sight against obstacles), the min-max bearing MPC, the exact
per-instant optimum and the whole-mission lower bound (convex programs), the sliding-mode
laws and the hover benchmark. Metres, seconds, radians.

    import droneplan as dp
    scenario = dp.covert.thesis_case(1, seed=0)
    trace = dp.covert.simulate(scenario, dp.covert.SlidingModeObserver())
    print(trace.beta_max)
"""

from typing import TYPE_CHECKING

from droneplan import _lazy_names

if TYPE_CHECKING:  # the names for type checkers and the docs; at run time __getattr__ imports them
    from droneplan.formulations.covert import (
        BearingMPC,
        MPCData,
        MPCPlan,
        MPCSettings,
        RecedingBearingMPC,
        build_bearing_mpc,
        solve_bearing_mpc,
        sphere_minmax_bearing,
        sphere_minmax_bearing_bnb,
    )
    from droneplan.formulations.covert_bounds import MissionBound, mission_front, mission_lower_bound
    from droneplan.planners.covert import (
        HoverBenchmark,
        MPCObserver,
        MPCObserverSettings,
        SafeguardedMPCObserver,
        SafeguardSettings,
        SlidingModeObserver,
        SlidingSettings,
        rollout_sliding,
    )
    from droneplan.scenarios.covert import (
        FIG_3_13_OBSTACLE,
        THESIS_TABLE_3_2,
        Controller,
        CovertCommand,
        CovertFrame,
        CovertObservation,
        CovertParams,
        CovertPhase,
        CovertScenario,
        CovertTrace,
        Obstacle,
        Occlusion,
        TargetPath,
        Terrain,
        bearing_changes,
        random_case,
        simulate,
        thesis_case,
    )
    from droneplan.scenarios.envs.covert import CovertEnv, policy_controller
    from droneplan.solvers.result import SolveResult, Status
    from droneplan.studies.plots import plot_bearing, plot_path, plot_stealth_front
    from droneplan.studies.plots.covert import animate, plot_optimised_front
    from droneplan.studies.plots.maps.covert import map
    from droneplan.studies.thesis.covert import stealth_front
    from droneplan.studies.thesis.covert_front import optimised_front

__all__ = [
    # world, presets, simulator
    "CovertParams",
    "THESIS_TABLE_3_2",
    "CovertScenario",
    "Terrain",
    "TargetPath",
    "Occlusion",
    "Obstacle",
    "FIG_3_13_OBSTACLE",
    "thesis_case",
    "random_case",
    "bearing_changes",
    "CovertObservation",
    "CovertCommand",
    "CovertPhase",
    "CovertFrame",
    "Controller",
    "CovertTrace",
    "simulate",
    # learned controllers: the Gymnasium environment and a policy as a controller
    "CovertEnv",
    "policy_controller",
    # the model
    "MPCSettings",
    "MPCData",
    "MPCPlan",
    "BearingMPC",
    "build_bearing_mpc",
    "solve_bearing_mpc",
    "RecedingBearingMPC",
    "sphere_minmax_bearing",
    "sphere_minmax_bearing_bnb",
    "MissionBound",
    "mission_lower_bound",
    "mission_front",
    # thesis laws and solver-backed controllers
    "SlidingSettings",
    "SlidingModeObserver",
    "HoverBenchmark",
    "rollout_sliding",
    "MPCObserver",
    "MPCObserverSettings",
    "SafeguardSettings",
    "SafeguardedMPCObserver",
    # results and plots
    "SolveResult",
    "Status",
    "plot_path",
    "plot_bearing",
    "stealth_front",
    "optimised_front",
    "plot_optimised_front",
    "plot_stealth_front",
    "animate",
    "map",
]

_SOURCES: dict[str, tuple[str, ...]] = {
    "droneplan.formulations.covert": (
        "BearingMPC",
        "MPCData",
        "MPCPlan",
        "MPCSettings",
        "RecedingBearingMPC",
        "build_bearing_mpc",
        "solve_bearing_mpc",
        "sphere_minmax_bearing",
        "sphere_minmax_bearing_bnb",
    ),
    "droneplan.formulations.covert_bounds": (
        "MissionBound",
        "mission_front",
        "mission_lower_bound",
    ),
    "droneplan.planners.covert": (
        "HoverBenchmark",
        "MPCObserver",
        "MPCObserverSettings",
        "SafeguardedMPCObserver",
        "SafeguardSettings",
        "SlidingModeObserver",
        "SlidingSettings",
        "rollout_sliding",
    ),
    "droneplan.scenarios.covert": (
        "FIG_3_13_OBSTACLE",
        "THESIS_TABLE_3_2",
        "Controller",
        "CovertCommand",
        "CovertFrame",
        "CovertObservation",
        "CovertParams",
        "CovertPhase",
        "CovertScenario",
        "CovertTrace",
        "Obstacle",
        "Occlusion",
        "TargetPath",
        "Terrain",
        "bearing_changes",
        "random_case",
        "simulate",
        "thesis_case",
    ),
    "droneplan.scenarios.envs.covert": (
        "CovertEnv",
        "policy_controller",
    ),
    "droneplan.solvers.result": (
        "SolveResult",
        "Status",
    ),
    "droneplan.studies.thesis.covert": ("stealth_front",),
    "droneplan.studies.thesis.covert_front": ("optimised_front",),
    "droneplan.studies.plots": (
        "plot_bearing",
        "plot_path",
        "plot_stealth_front",
    ),
    "droneplan.studies.plots.covert": ("animate", "plot_optimised_front"),
    "droneplan.studies.plots.maps.covert": ("map",),
}

"""The module each public name comes from; a name is imported on first use, so importing this
front door loads no solver library, cvxpy, matplotlib or pandas."""

if not TYPE_CHECKING:  # type checkers see the imports above (and flag a misspelt name)
    __getattr__, __dir__ = _lazy_names(globals(), _SOURCES)
