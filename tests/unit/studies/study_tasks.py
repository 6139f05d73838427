"""Task functions and a runner for the store/interrupt tests (importable by subprocesses).

``python study_tasks.py OUT MODE N [DELAY]`` maps ``N`` fake tasks into the store ``OUT``
with MODE ``serial`` | ``processes`` | ``dask`` | ``cpsat`` (serial, each task a long
CP-SAT solve) and exits like the CLI (130 on Ctrl-C).
"""

from __future__ import annotations

import os
import sys
import time

from droneplan.studies.store import Outcome, build_rows, instance_id


def fake_task(task: dict) -> list[dict]:
    """Two methods on instance ``seed``: objective seed and seed + 1 (minimised); sleeps ``delay`` s.

    Raises for the seeds listed in the environment variable ``FAIL_SEEDS``.
    """
    seed = int(task["seed"])
    time.sleep(float(task.get("delay", 0.0)))
    if str(seed) in os.environ.get("FAIL_SEEDS", "").split(","):
        raise RuntimeError(f"planned failure on seed {seed}")
    return build_rows(
        "herding",
        task["instance"],
        seed=seed,
        size=2,
        sense="min",
        outcomes=[
            Outcome(
                "good",
                "model",
                "optimal",
                objective=float(seed),
                bound=float(seed),
                bound_kind="proven-global",
                time_s=0.0,
            ),
            Outcome("worse", "heuristic", "feasible", objective=float(seed) + 1.0, time_s=0.0),
        ],
    )


def cpsat_task(task: dict) -> list[dict]:
    """A CP-SAT solve that runs to its 20 s time limit unless stopped (an n-queens optimisation)."""
    from ortools.sat.python import cp_model

    from droneplan.solvers.cpsat import solve_cpsat

    n = 40
    m = cp_model.CpModel()
    x = [m.new_int_var(0, n - 1, f"x{i}") for i in range(n)]
    m.add_all_different(x)
    m.add_all_different([x[i] + i for i in range(n)])
    m.add_all_different([x[i] - i for i in range(n)])
    m.maximize(sum((i % 7) * x[i] for i in range(n)))
    res = solve_cpsat(m, variables=x, time_limit=20.0, workers=1)
    return build_rows(
        "herding",
        task["instance"],
        seed=int(task["seed"]),
        size=n,
        sense="max",
        outcomes=[Outcome.of("cp-sat", "model", res, bound_kind="proven-global")],
    )


def tasks(n: int, delay: float = 0.0) -> list[dict]:
    return [
        {"problem": "herding", "instance": instance_id("test", seed=s), "seed": s, "delay": delay}
        for s in range(n)
    ]


def main(argv: list[str]) -> int:
    from droneplan.studies import common
    from droneplan.studies.common import make_executor
    from droneplan.studies.jobs import map_rows
    from droneplan.studies.store import ResultStore

    out, mode, n = argv[0], argv[1], int(argv[2])
    delay = float(argv[3]) if len(argv) > 3 else 0.0
    common.INTERRUPT_GRACE_S = 3.0
    fn = cpsat_task if mode == "cpsat" else fake_task
    try:
        with ResultStore(out) as store:
            if mode == "dask":
                from distributed import LocalCluster

                with (
                    LocalCluster(
                        n_workers=2, threads_per_worker=1, processes=False, dashboard_address=None
                    ) as cl,
                    make_executor(dask_address=cl.scheduler_address) as ex,
                ):
                    print("started", flush=True)
                    map_rows(fn, tasks(n, delay), executor=ex, store=store)
            else:
                with make_executor(2 if mode == "processes" else 1) as ex:
                    print("started", flush=True)
                    map_rows(fn, tasks(n, delay), executor=ex, store=store)
    except KeyboardInterrupt:
        return 130
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
