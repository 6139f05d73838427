"""The covert-observation kind (thesis ch. 3): ``covert-run``, one observation run in the simulator."""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

from droneplan.core.validation import check_int
from droneplan.studies.kinds.base import ClosedLoopKind, Family
from droneplan.studies.scoring import Scored, number

__all__ = ["CovertRunKind"]


def _covert_case(case: int, seed: int):
    from droneplan.scenarios.covert import thesis_case

    return thesis_case(
        check_int("case", case, min_value=1, max_value=2), check_int("seed", seed, min_value=0)
    )


def _covert_random(n_targets: int, seed: int):
    from droneplan.scenarios.covert import random_case

    return random_case(check_int("n_targets", n_targets, min_value=1), check_int("seed", seed, min_value=0))


class CovertRunKind(ClosedLoopKind):
    """A covert observation run (a covert scenario, rebuilt from its family's parameters): methods
    are observer controllers; the objective is the largest bearing change they caused."""

    name = "covert-run"
    problem = "covert"
    sense = "min"
    metric = "beta_max_deg"
    default_methods = ("hover", "sliding", "mpc", "mpc-safeguarded", "onsphere-optimum")
    objective = "the largest recorded bearing change beta_max (deg)"

    def holds(self, data: Any) -> bool:
        return type(data).__name__ == "CovertScenario"

    def encode(self, data: Any) -> dict | None:
        return None  # rebuilt from the family's parameters (terrain and paths are generated objects)

    def decode(self, payload: Mapping[str, Any]) -> Any:
        return None

    def size(self, data: Any) -> int:
        return len(data.paths)

    def simulate(self, data: Any, controller: Any, seed: int) -> dict[str, Any]:
        from droneplan.scenarios.covert import simulate as simulate_covert

        covert = simulate_covert(data, controller, seed=seed)
        return {
            "beta_max_deg": math.degrees(covert.beta_max) if covert.beta_max is not None else None,
            "sphere_error": covert.sphere_error,
            "t_a": covert.t_a,
            "fallbacks": int(covert.fallbacks),
        }

    def score_metrics(self, metrics: Mapping[str, Any], extras: dict[str, Any]) -> Scored:
        b = number(metrics.get("beta_max_deg"))
        if b is None:
            return Scored(
                "no_solution", message="no bearing change recorded (no target observed)", extras=extras
            )
        return Scored(
            "feasible", objective=b, message="max recorded bearing change beta_max, deg", extras=extras
        )

    def families(self) -> tuple[Family, ...]:
        return (
            self.family(
                "thesis-case",
                1,
                {"case": (1, 2)},
                _covert_case,
                "Table 3.2 covert observation cases 1 (two targets) and 2 (ten targets)",
            ),
            self.family(
                "random-group",
                1,
                {"n_targets": (2, 3, 4)},
                _covert_random,
                "random group of targets on curvy paths over uneven terrain",
            ),
        )
