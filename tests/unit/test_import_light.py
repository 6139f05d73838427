"""``import droneplan`` stays light: the front doors and public names load on first use."""

from __future__ import annotations

import subprocess
import sys

HEAVY = ("cvxpy", "casadi", "ortools", "matplotlib", "pandas")


def _run(code: str) -> list[str]:
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    return out.stdout.strip().splitlines()


def test_import_droneplan_loads_no_heavy_library():
    lines = _run(f"import droneplan, sys\nprint(sorted(m for m in {HEAVY!r} if m in sys.modules))")
    assert lines == ["[]"]


def test_the_whole_api_is_reachable_after_a_light_import():
    code = (
        "import droneplan as dp\n"
        "print(dp.cells.solve_milp.__name__, dp.herding.simulate.__module__, dp.Status.OPTIMAL.name)\n"
        "print(all(hasattr(dp, n) for n in dp.__all__))\n"
        "print(sorted(set(dp.__all__) - set(dir(dp))))\n"
        "from droneplan import gap, herding\n"
        "print(gap.__name__, herding.__name__)\n"
    )
    assert _run(code) == [
        "solve_milp droneplan.scenarios.herding OPTIMAL",
        "True",
        "[]",
        "gap droneplan.herding",
    ]
