"""Several sharks and operators: interception-time matrices and the allocation (thesis §5.3.1)."""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from droneplan.core.validation import (
    check_array,
    check_bool,
    check_instance,
    check_positive,
    check_size,
    check_work,
)
from droneplan.formulations.shark import greedy_assignment, solve_assignment, solve_interception
from droneplan.planners.shark.pursuit import VirtualSharkInterceptor
from droneplan.scenarios.shark import (
    THESIS_TABLE_5_1,
    InterceptionScenario,
    SharkParams,
    constant_velocity_trajectory,
    simulate,
)
from droneplan.solvers.result import SolveResult

__all__ = ["interception_time_matrix", "allocate_operators"]


def _check_horizon(t_max: Any, params: SharkParams, n_ops: int, n_sharks: int, method: str) -> float:
    """``t_max`` (s) checked against the sampling time and the work of ``n_ops x n_sharks`` predictions
    (a simulated path of t_max / Ts control periods each, or one OCP each for ``method="ocp"``)."""
    t_max = check_positive("t_max", t_max)
    if t_max < params.Ts:
        raise ValueError(f"t_max must be >= the sampling time Ts = {params.Ts} s, got {t_max}")
    pairs = n_ops * n_sharks
    check_size("t_max", 9 * t_max / params.Ts)  # one predicted path per shark
    check_work(
        "operators x sharks_pos x t_max / Ts (control periods)", pairs * t_max / params.Ts, "evaluations"
    )
    if method == "ocp":
        check_work("operators x sharks_pos (one OCP per pair)", pairs, "solves")
    return t_max


def interception_time_matrix(
    operators,
    sharks_pos,
    sharks_vel,
    params: SharkParams = THESIS_TABLE_5_1,
    *,
    method: str = "virtual-shark",
    t_max: float = 30.0,
) -> NDArray[np.float64]:
    """(n, s) predicted interception times (s) of each operator on each shark (inf if none).

    Sharks are predicted at constant velocity. method: "virtual-shark" (capture time of the
    thesis algorithm) or "ocp" (time-optimal OCP, best of both sides).

    operators: (n, 3) operator positions (m).
    sharks_pos: (s, 3) shark positions (m).
    sharks_vel: (s, 3) shark velocities (m/s).
    params: problem parameters, SharkParams (default: THESIS_TABLE_5_1).
    t_max: prediction horizon (s); longer interceptions count as inf.
    """
    if method not in ("virtual-shark", "ocp"):
        raise ValueError(f"method must be 'virtual-shark' or 'ocp', got {method!r}")
    check_instance("params", params, SharkParams)
    O = check_array("operators", operators, shape=(None, 3))
    Sp = check_array("sharks_pos", sharks_pos, shape=(None, 3))
    Sv = check_array("sharks_vel", sharks_vel, shape=(None, 3))
    t_max = _check_horizon(t_max, params, len(O), len(Sp), method)
    if len(Sp) != len(Sv):
        raise ValueError("sharks_pos and sharks_vel must have the same length")
    C = np.full((len(O), len(Sp)), np.inf)
    for j in range(len(Sp)):
        v = Sv[j].copy()
        v[2] = 0.0
        path = constant_velocity_trajectory(Sp[j], v, duration=t_max, dt=params.Ts)
        for i in range(len(O)):
            if np.hypot(*(O[i, :2] - Sp[j, :2])) <= params.eps_o:
                continue
            if method == "virtual-shark":
                vs = VirtualSharkInterceptor(params)
                simulate(InterceptionScenario(path, params, O[i]), vs)
                if vs.capture_time is not None:
                    C[i, j] = vs.capture_time
            else:
                r = solve_interception((Sp[j], Sv[j]), O[i], params, N=30, t_max=t_max)
                if r.status.has_solution:
                    C[i, j] = r.objective
    return C


def allocate_operators(
    operators,
    sharks_pos,
    sharks_vel,
    humans,
    params: SharkParams = THESIS_TABLE_5_1,
    *,
    method: str = "virtual-shark",
    greedy: bool = False,
) -> SolveResult:
    """Allocate operators to sharks: optimal bottleneck assignment (or the greedy baseline).

    humans: (m, 2 or 3) swimmer positions (m); a shark's priority is its horizontal distance
    to the nearest human (s > n: the n closest sharks are served, thesis §5.3.1).

    sharks_pos: (s, 3) shark positions (m).
    sharks_vel: (s, 3) shark velocities (m/s).
    params: problem parameters, SharkParams (default: THESIS_TABLE_5_1).
    method: how interception times are predicted ("virtual-shark" or "ocp").
    """
    check_instance("params", params, SharkParams)
    check_bool("greedy", greedy)
    check_array("operators", operators, shape=(None, 3))
    check_array("sharks_vel", sharks_vel, shape=(None, 3))
    H = check_array("humans", humans)
    Sp = check_array("sharks_pos", sharks_pos, shape=(None, 3))
    if H.ndim != 2 or len(H) == 0:
        raise ValueError("humans must be a non-empty (m, 2|3) array")
    d = np.min(np.linalg.norm(Sp[:, None, :2] - H[None, :, :2], axis=2), axis=1)
    C = interception_time_matrix(operators, sharks_pos, sharks_vel, params, method=method)
    if greedy:
        return greedy_assignment(operators, Sp, d, C)
    return solve_assignment(C, shark_to_human=d)
