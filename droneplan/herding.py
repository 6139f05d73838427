"""Herding with barking drones (thesis ch. 6): the animal world and simulator, the
steering-point allocation model (exact algorithm and CP-SAT), Algorithm 3, the hull
guidance laws and the proposed and benchmark herders. Metres, seconds.

    import droneplan as dp
    scenario = dp.herding.thesis_scenario(n_animals=100, seed=0)
    trace = dp.herding.simulate(scenario, dp.herding.ProposedHerder(), t_max=1800, seed=0)
    print(trace.gather_time, trace.total_time)
"""

from typing import TYPE_CHECKING

from droneplan import _lazy_names

if TYPE_CHECKING:  # the names for type checkers and the docs; at run time __getattr__ imports them
    from droneplan.formulations.herding import (
        Allocation,
        AllocationModel,
        build_allocation_model,
        check_allocation,
        pad_steering_points,
        solve_allocation,
        write_allocation_model,
    )
    from droneplan.planners.herding import (
        BenchmarkHerder,
        ExtendedHull,
        HerderSettings,
        ProposedHerder,
        allocate_bruteforce,
        allocate_collision_blind,
        convex_hull,
        min_enclosing_circle,
        steering_points,
    )
    from droneplan.scenarios.envs.herding import HerdingEnv, policy_controller
    from droneplan.scenarios.herding import (
        THESIS_TABLE_6_2,
        HerdingCommand,
        HerdingFrame,
        HerdingObservation,
        HerdingParams,
        HerdingPhase,
        HerdingScenario,
        HerdingTrace,
        footprint_radius,
        simulate,
        thesis_scenario,
        with_params,
    )
    from droneplan.scenarios.loaders import herding_scenario_from_csv, load_herd_csv
    from droneplan.solvers.result import SolveResult, Status
    from droneplan.studies.plots import plot_final, plot_footprint, plot_state
    from droneplan.studies.plots.herding import animate
    from droneplan.studies.plots.maps.herding import map
    from droneplan.studies.thesis.herding import run_times_table, write_gif

__all__ = [
    # world, presets, simulator
    "HerdingParams",
    "THESIS_TABLE_6_2",
    "HerdingScenario",
    "thesis_scenario",
    "with_params",
    "load_herd_csv",
    "herding_scenario_from_csv",
    "HerdingTrace",
    "HerdingObservation",
    "HerdingCommand",
    "HerdingPhase",
    "HerdingFrame",
    "simulate",
    "footprint_radius",
    # learned controllers: the Gymnasium environment and a policy as a herder
    "HerdingEnv",
    "policy_controller",
    # the allocation model
    "Allocation",
    "AllocationModel",
    "build_allocation_model",
    "solve_allocation",
    "check_allocation",
    "pad_steering_points",
    "write_allocation_model",
    # thesis methods and herders
    "allocate_bruteforce",
    "allocate_collision_blind",
    "ExtendedHull",
    "convex_hull",
    "min_enclosing_circle",
    "steering_points",
    "HerderSettings",
    "ProposedHerder",
    "BenchmarkHerder",
    # results and plots
    "SolveResult",
    "Status",
    "plot_state",
    "plot_final",
    "plot_footprint",
    "animate",
    "map",
    "write_gif",
    "run_times_table",
]

_SOURCES: dict[str, tuple[str, ...]] = {
    "droneplan.formulations.herding": (
        "Allocation",
        "AllocationModel",
        "build_allocation_model",
        "check_allocation",
        "pad_steering_points",
        "solve_allocation",
        "write_allocation_model",
    ),
    "droneplan.planners.herding": (
        "BenchmarkHerder",
        "ExtendedHull",
        "HerderSettings",
        "ProposedHerder",
        "allocate_bruteforce",
        "allocate_collision_blind",
        "convex_hull",
        "min_enclosing_circle",
        "steering_points",
    ),
    "droneplan.scenarios.envs.herding": (
        "HerdingEnv",
        "policy_controller",
    ),
    "droneplan.scenarios.herding": (
        "THESIS_TABLE_6_2",
        "HerdingCommand",
        "HerdingFrame",
        "HerdingObservation",
        "HerdingParams",
        "HerdingPhase",
        "HerdingScenario",
        "HerdingTrace",
        "footprint_radius",
        "simulate",
        "thesis_scenario",
        "with_params",
    ),
    "droneplan.scenarios.loaders": (
        "herding_scenario_from_csv",
        "load_herd_csv",
    ),
    "droneplan.solvers.result": (
        "SolveResult",
        "Status",
    ),
    "droneplan.studies.thesis.herding": (
        "run_times_table",
        "write_gif",
    ),
    "droneplan.studies.plots": (
        "plot_final",
        "plot_footprint",
        "plot_state",
    ),
    "droneplan.studies.plots.herding": ("animate",),
    "droneplan.studies.plots.maps.herding": ("map",),
}

"""The module each public name comes from; a name is imported on first use, so importing this
front door loads no solver library, cvxpy, matplotlib or pandas."""

if not TYPE_CHECKING:  # type checkers see the imports above (and flag a misspelt name)
    __getattr__, __dir__ = _lazy_names(globals(), _SOURCES, deprecated={"summary_table": "run_times_table"})
