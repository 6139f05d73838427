"""Drone-cell placement (thesis ch. 4): scenarios, two exact engines over the candidate
sites (``solve_exact(engine="bnb")``, the combinatorial branch and bound, and
``engine="milp"``, the candidate MILP; also as ``branch_and_bound`` and ``solve_milp``),
the thesis GA and exhaustive search, plotting. Positions in metres.

    import droneplan as dp
    problem = dp.cells.thesis_problem(n_cells=2, seed=0)
    ga = dp.cells.genetic(problem, seed=0)
    opt = dp.cells.solve_exact(problem, engine="bnb", warm_start=ga.x, time_limit=60)
"""

from typing import TYPE_CHECKING

from droneplan import _lazy_names

if TYPE_CHECKING:  # the names for type checkers and the docs; at run time __getattr__ imports them
    from droneplan.formulations.cells import (
        BACKENDS,
        ENGINES,
        Candidates,
        CellModel,
        Evaluation,
        MobileEvaluation,
        MobileProblem,
        branch_and_bound,
        build_milp,
        candidate_sites,
        connected_mask,
        coverage_upper_bound,
        evaluate,
        evaluate_mobile,
        greedy_placement,
        min_fleet,
        myopic,
        solve_exact,
        solve_milp,
        solve_mobile,
        solve_model,
        write_model,
    )
    from droneplan.planners.cells import (
        GASettings,
        Region,
        deployment_region,
        exhaustive,
        fitness,
        genetic,
        genetic_polished,
        max_coverage_in_region,
        polish,
        thesis_ga_settings,
    )
    from droneplan.scenarios.air_to_ground import AirToGround
    from droneplan.scenarios.cells import (
        THESIS_GA_TABLE_4_1,
        THESIS_TABLE_4_2,
        THESIS_TABLE_4_3,
        CellParams,
        CellProblem,
        Instance,
        matern_users,
        problem_from_instance,
        thesis_instance,
        thesis_problem,
        uniform_users,
    )
    from droneplan.scenarios.loaders import (
        ProjectedCells,
        load_cells_csv,
        load_cells_geojson,
        read_user_tracks,
    )
    from droneplan.solvers.result import SolveResult, Status
    from droneplan.studies.plots import plot_deployment_region, plot_map
    from droneplan.studies.plots.maps.cells import map
    from droneplan.studies.thesis.cells import GA_VARIANTS, ga_ablation, instance_features

__all__ = [
    # scenarios and presets
    "CellParams",
    "CellProblem",
    "AirToGround",
    "Instance",
    "THESIS_TABLE_4_2",
    "THESIS_TABLE_4_3",
    "THESIS_GA_TABLE_4_1",
    "matern_users",
    "uniform_users",
    "thesis_instance",
    "thesis_problem",
    "problem_from_instance",
    "ProjectedCells",
    "load_cells_csv",
    "load_cells_geojson",
    # the model
    "Evaluation",
    "evaluate",
    "connected_mask",
    "Candidates",
    "candidate_sites",
    "CellModel",
    "build_milp",
    "solve_model",
    "write_model",
    "min_fleet",
    "MobileProblem",
    "MobileEvaluation",
    "evaluate_mobile",
    "solve_mobile",
    "myopic",
    "read_user_tracks",
    "solve_milp",
    "solve_exact",
    "branch_and_bound",
    "ENGINES",
    "coverage_upper_bound",
    "greedy_placement",
    "BACKENDS",
    # thesis heuristics and the improved variant
    "GASettings",
    "genetic",
    "genetic_polished",
    "polish",
    "fitness",
    "exhaustive",
    "max_coverage_in_region",
    "thesis_ga_settings",
    "Region",
    "deployment_region",
    # results and plots
    "SolveResult",
    "Status",
    "plot_map",
    "plot_deployment_region",
    "map",
    # studies
    "ga_ablation",
    "GA_VARIANTS",
    "instance_features",
]

_SOURCES: dict[str, tuple[str, ...]] = {
    "droneplan.formulations.cells": (
        "BACKENDS",
        "ENGINES",
        "Candidates",
        "CellModel",
        "Evaluation",
        "branch_and_bound",
        "build_milp",
        "candidate_sites",
        "connected_mask",
        "coverage_upper_bound",
        "evaluate",
        "greedy_placement",
        "solve_exact",
        "solve_milp",
        "solve_model",
        "write_model",
        "min_fleet",
        "MobileProblem",
        "MobileEvaluation",
        "evaluate_mobile",
        "solve_mobile",
        "myopic",
    ),
    "droneplan.planners.cells": (
        "GASettings",
        "Region",
        "deployment_region",
        "exhaustive",
        "fitness",
        "genetic",
        "genetic_polished",
        "max_coverage_in_region",
        "polish",
        "thesis_ga_settings",
    ),
    "droneplan.scenarios.cells": (
        "THESIS_GA_TABLE_4_1",
        "THESIS_TABLE_4_2",
        "THESIS_TABLE_4_3",
        "CellParams",
        "CellProblem",
        "Instance",
        "matern_users",
        "problem_from_instance",
        "thesis_instance",
        "thesis_problem",
        "uniform_users",
    ),
    "droneplan.scenarios.air_to_ground": ("AirToGround",),
    "droneplan.scenarios.loaders": (
        "ProjectedCells",
        "load_cells_csv",
        "load_cells_geojson",
        "read_user_tracks",
    ),
    "droneplan.solvers.result": (
        "SolveResult",
        "Status",
    ),
    "droneplan.studies.thesis.cells": (
        "GA_VARIANTS",
        "ga_ablation",
        "instance_features",
    ),
    "droneplan.studies.plots": (
        "plot_deployment_region",
        "plot_map",
    ),
    "droneplan.studies.plots.maps.cells": ("map",),
}

"""The module each public name comes from; a name is imported on first use, so importing this
front door loads no solver library, cvxpy, matplotlib or pandas."""

if not TYPE_CHECKING:  # type checkers see the imports above (and flag a misspelt name)
    __getattr__, __dir__ = _lazy_names(globals(), _SOURCES)
