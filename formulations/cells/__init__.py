"""Drone-cell placement (thesis ch. 4): the problem, its evaluation and two exact engines
(the candidate MILP and a combinatorial branch and bound) behind one entry, ``solve_exact``.

``CellProblem`` is defined in ``scenarios.cells`` (data only, so the scenario layer can
build instances without importing this one) and re-exported here.
"""

from droneplan.formulations.cells._core import (
    TOL,
    Candidates,
    Evaluation,
    candidate_sites,
    circle_intersections,
    connected_mask,
    evaluate,
    raw_candidate_points,
)
from droneplan.formulations.cells._exact import ENGINES, branch_and_bound, solve_exact, solve_milp
from droneplan.formulations.cells._fleet import min_fleet
from droneplan.formulations.cells._milp import BACKENDS, CellModel, build_milp, reduce_candidates
from droneplan.formulations.cells._mobile import (
    MobileEvaluation,
    MobileProblem,
    evaluate_mobile,
    myopic,
    solve_mobile,
)
from droneplan.formulations.cells._open import BNB_VARIANTS, solve_model, write_model
from droneplan.formulations.cells._prepare import coverage_upper_bound, greedy_placement
from droneplan.scenarios.cells import CellProblem, problem_from_instance, thesis_problem

__all__ = [
    "CellProblem",
    "Evaluation",
    "Candidates",
    "CellModel",
    "TOL",
    "BACKENDS",
    "ENGINES",
    "evaluate",
    "connected_mask",
    "candidate_sites",
    "raw_candidate_points",
    "circle_intersections",
    "coverage_upper_bound",
    "greedy_placement",
    "reduce_candidates",
    "build_milp",
    "solve_model",
    "write_model",
    "min_fleet",
    "MobileProblem",
    "MobileEvaluation",
    "evaluate_mobile",
    "solve_mobile",
    "myopic",
    "BNB_VARIANTS",
    "solve_milp",
    "solve_exact",
    "branch_and_bound",
    "problem_from_instance",
    "thesis_problem",
]
