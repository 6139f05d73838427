"""Shark interception with an electric-field repellent (thesis ch. 5): Table 5.1, shark
paths, the simulator, the exact optimal altitude, the time-optimal interception OCP,
operator-to-shark assignment, and the thesis controllers. Metres, seconds.

    import droneplan as dp
    paths = dp.shark.thesis_trajectories()
    scenario = dp.shark.InterceptionScenario(paths["a"], dp.shark.THESIS_TABLE_5_1)
    trace = dp.shark.simulate(scenario, dp.shark.VirtualSharkInterceptor())
    print(trace.intercept_time, trace.frontal)
"""

from typing import TYPE_CHECKING

from droneplan import _lazy_names

if TYPE_CHECKING:  # the names for type checkers and the docs; at run time __getattr__ imports them
    from droneplan.formulations.shark import (
        Assignment,
        InterceptionOCP,
        InterceptionPlan,
        build_assignment_model,
        build_interception_nlp,
        greedy_assignment,
        interception_time_bound,
        optimal_altitude,
        solve_assignment,
        solve_interception,
    )
    from droneplan.planners.shark import (
        ClassicalPursuit,
        OCPInterceptor,
        RepellingOperator,
        VirtualSharkInterceptor,
        allocate_operators,
        interception_time_matrix,
        optimal_interception,
        thesis_altitude,
        virtual_shark_plan,
    )
    from droneplan.scenarios.envs.shark import InterceptionEnv, policy_controller
    from droneplan.scenarios.loaders import load_shark_track_csv
    from droneplan.scenarios.shark import (
        THESIS_TABLE_5_1,
        AlarmLevel,
        InterceptionController,
        InterceptionScenario,
        InterceptionTrace,
        ObserverDrone,
        RepellingMode,
        RepellingObservation,
        RepellingScenario,
        RepellingTrace,
        SharkBehaviour,
        SharkCommand,
        SharkFrame,
        SharkObservation,
        SharkParams,
        SharkPhase,
        SharkTrajectory,
        alarm_level,
        constant_velocity_trajectory,
        field_radius,
        make_trajectory,
        operator_start,
        random_trajectory,
        sharks_to_repel,
        simulate,
        simulate_repelling,
        thesis_trajectories,
        touches,
    )
    from droneplan.solvers.result import SolveResult, Status
    from droneplan.studies.plots import plot_time_series, plot_top_view
    from droneplan.studies.plots.maps.shark import map
    from droneplan.studies.plots.shark import animate

__all__ = [
    # world, presets, simulator
    "SharkParams",
    "THESIS_TABLE_5_1",
    "field_radius",
    "touches",
    "SharkTrajectory",
    "make_trajectory",
    "thesis_trajectories",
    "random_trajectory",
    "constant_velocity_trajectory",
    "load_shark_track_csv",
    "operator_start",
    "InterceptionScenario",
    "SharkObservation",
    "SharkCommand",
    "SharkPhase",
    "SharkFrame",
    "InterceptionController",
    "InterceptionTrace",
    "simulate",
    "SharkBehaviour",
    "RepellingScenario",
    "RepellingObservation",
    "RepellingMode",
    "RepellingTrace",
    "simulate_repelling",
    "ObserverDrone",
    "AlarmLevel",
    "alarm_level",
    "sharks_to_repel",
    # learned controllers: the Gymnasium environment and a policy as a controller
    "InterceptionEnv",
    "policy_controller",
    # models
    "optimal_altitude",
    "InterceptionOCP",
    "InterceptionPlan",
    "build_interception_nlp",
    "solve_interception",
    "interception_time_bound",
    "Assignment",
    "build_assignment_model",
    "solve_assignment",
    "greedy_assignment",
    # thesis methods and controllers
    "thesis_altitude",
    "ClassicalPursuit",
    "VirtualSharkInterceptor",
    "OCPInterceptor",
    "optimal_interception",
    "virtual_shark_plan",
    "allocate_operators",
    "interception_time_matrix",
    "RepellingOperator",
    # results and plots
    "SolveResult",
    "Status",
    "plot_top_view",
    "plot_time_series",
    "animate",
    "map",
]

_SOURCES: dict[str, tuple[str, ...]] = {
    "droneplan.formulations.shark": (
        "Assignment",
        "InterceptionOCP",
        "InterceptionPlan",
        "build_assignment_model",
        "build_interception_nlp",
        "greedy_assignment",
        "interception_time_bound",
        "optimal_altitude",
        "solve_assignment",
        "solve_interception",
    ),
    "droneplan.planners.shark": (
        "ClassicalPursuit",
        "OCPInterceptor",
        "RepellingOperator",
        "VirtualSharkInterceptor",
        "allocate_operators",
        "interception_time_matrix",
        "optimal_interception",
        "thesis_altitude",
        "virtual_shark_plan",
    ),
    "droneplan.scenarios.envs.shark": (
        "InterceptionEnv",
        "policy_controller",
    ),
    "droneplan.scenarios.loaders": ("load_shark_track_csv",),
    "droneplan.scenarios.shark": (
        "THESIS_TABLE_5_1",
        "AlarmLevel",
        "InterceptionController",
        "InterceptionScenario",
        "InterceptionTrace",
        "ObserverDrone",
        "RepellingMode",
        "RepellingObservation",
        "RepellingScenario",
        "RepellingTrace",
        "SharkBehaviour",
        "SharkCommand",
        "SharkFrame",
        "SharkObservation",
        "SharkParams",
        "SharkPhase",
        "SharkTrajectory",
        "alarm_level",
        "constant_velocity_trajectory",
        "field_radius",
        "make_trajectory",
        "operator_start",
        "random_trajectory",
        "sharks_to_repel",
        "simulate",
        "simulate_repelling",
        "thesis_trajectories",
        "touches",
    ),
    "droneplan.solvers.result": (
        "SolveResult",
        "Status",
    ),
    "droneplan.studies.plots": (
        "plot_time_series",
        "plot_top_view",
    ),
    "droneplan.studies.plots.maps.shark": ("map",),
    "droneplan.studies.plots.shark": ("animate",),
}

"""The module each public name comes from; a name is imported on first use, so importing this
front door loads no solver library, cvxpy, matplotlib or pandas."""

if not TYPE_CHECKING:  # type checkers see the imports above (and flag a misspelt name)
    __getattr__, __dir__ = _lazy_names(globals(), _SOURCES, deprecated={"simulate_interception": "simulate"})
