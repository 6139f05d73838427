"""``import droneplan`` stays light: the front doors and public names load on first use."""

from __future__ import annotations

import subprocess
import sys

HEAVY = (
    "cvxpy",
    "casadi",
    "ortools",
    "matplotlib",
    "pandas",
    "pyscipopt",
    "gurobipy",
    "folium",
    "pyproj",
    "geopandas",
    "shapely",
)


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


FRONT_DOORS = ("cells", "covert", "shark", "herding")


def test_touching_every_front_door_loads_no_heavy_library():
    code = (
        "import sys\nimport droneplan as dp\n"
        f"doors = [getattr(dp, d) for d in {FRONT_DOORS!r}]\n"
        "print([d.__name__ for d in doors])\n"
        f"print(sorted(m for m in {HEAVY!r} if m in sys.modules))\n"
    )
    assert _run(code) == [str([f"droneplan.{d}" for d in FRONT_DOORS]), "[]"]


def test_a_name_loads_its_library_on_first_use():
    """The check above can fail: the first use of a name that needs matplotlib loads it."""
    code = (
        "import sys\nimport droneplan as dp\n"
        "print('matplotlib' in sys.modules)\n"
        "dp.herding.plot_state\n"
        "print('matplotlib' in sys.modules)\n"
    )
    assert _run(code) == ["False", "True"]


def test_every_public_name_of_every_front_door_resolves():
    code = (
        "import importlib, inspect\n"
        f"for door in {FRONT_DOORS!r}:\n"
        "    m = importlib.import_module('droneplan.' + door)\n"
        "    missing = [n for n in m.__all__ if getattr(m, n, None) is None]\n"
        "    hidden = sorted(set(m.__all__) - set(dir(m)))\n"
        "    wrong = [n for n in m.__all__ if inspect.getmodule(getattr(m, n)) is m]\n"
        "    print(door, len(m.__all__), missing, hidden, wrong)\n"
    )
    lines = _run(code)
    assert [line.split(" ", 1)[0] for line in lines] == list(FRONT_DOORS)
    for line in lines:
        door, count, rest = line.split(" ", 2)
        assert int(count) > 10 and rest == "[] [] []", f"droneplan.{door}: {rest}"


def test_the_lazy_table_matches_the_names_type_checkers_see():
    """Each front door lists its names twice (the ``if TYPE_CHECKING:`` imports for mypy and the
    docs, ``_SOURCES`` for ``__getattr__``); both must name the same modules and names, and
    ``__all__`` exactly those names."""
    import ast
    from pathlib import Path

    import droneplan

    root = Path(__file__).resolve().parents[2]
    for door in FRONT_DOORS:
        tree = ast.parse((root / "droneplan" / f"{door}.py").read_text(encoding="utf-8"))
        checked = [
            node
            for node in tree.body
            if isinstance(node, ast.If) and getattr(node.test, "id", None) == "TYPE_CHECKING"
        ]
        assert len(checked) == 1, f"droneplan/{door}.py: one `if TYPE_CHECKING:` import block"
        declared: dict[str, set[str]] = {}
        for node in checked[0].body:
            assert isinstance(node, ast.ImportFrom) and node.module
            declared.setdefault(node.module, set()).update(a.name for a in node.names)
        module = getattr(droneplan, door)
        table = {src: set(names) for src, names in module._SOURCES.items()}
        assert table == declared, f"droneplan/{door}.py: _SOURCES and the TYPE_CHECKING imports differ"
        assert sorted(n for names in table.values() for n in names) == sorted(module.__all__)


def test_help_lists_the_lazy_names():
    lines = _run("import pydoc, droneplan.herding as h\nprint('simulate(' in pydoc.render_doc(h))")
    assert lines == ["True"]
