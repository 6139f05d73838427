"""No import circle among the modules of a layer (docs/architecture.md, section 1).

Checked on the source text (AST), so it covers every module, including ones added later.
An import counts wherever it is written: at module level, inside a function, or under
``if TYPE_CHECKING:``. A function-level import does not break a circle, it only hides it
from the interpreter, so the modules of a circle still cannot be read, tested or moved
one at a time."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

from droneplan._layers import LAYERS

ROOT = Path(__file__).resolve().parents[2]


def _module_names() -> dict[str, Path]:
    """Every module of every layer folder, by its installed dotted name."""
    names = {}
    for layer in LAYERS:
        for path in sorted((ROOT / layer).rglob("*.py")):
            parts = list(path.relative_to(ROOT).with_suffix("").parts)
            if parts[-1] == "__init__":
                parts.pop()
            names[".".join(["droneplan", *parts])] = path
    return names


MODULES = _module_names()


def _package_of(name: str) -> str:
    path = MODULES[name]
    return name if path.name == "__init__.py" else name.rpartition(".")[0]


def _resolve(name: str, package: str, node: ast.ImportFrom) -> str:
    if node.level == 0:
        return node.module or ""
    base = package.split(".")
    if node.level > 1:
        base = base[: -(node.level - 1)]
    return ".".join(base + ([node.module] if node.module else []))


def _imports(name: str) -> set[str]:
    """The droneplan modules that the module ``name`` imports, anywhere in its source.

    ``from droneplan.studies import x`` counts as an import of ``droneplan.studies.x`` when
    ``x`` is a module, else of the package ``droneplan.studies`` itself."""
    path = MODULES[name]
    tree = ast.parse(path.read_text(), filename=str(path))
    found = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            targets = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            module = _resolve(name, _package_of(name), node)
            targets = [
                f"{module}.{a.name}" if f"{module}.{a.name}" in MODULES else module for a in node.names
            ]
        else:
            continue
        for target in targets:
            # ``import droneplan.a.b`` names the module a.b (or its nearest enclosing module)
            while target and target not in MODULES:
                target = target.rpartition(".")[0]
            if target and target != name:
                found.add(target)
    return found


def _graph(prefix: str) -> dict[str, set[str]]:
    inside = [n for n in MODULES if n == prefix or n.startswith(prefix + ".")]
    return {n: {m for m in _imports(n) if m in inside} for n in inside}


def _reach(graph: dict[str, set[str]], start: str) -> set[str]:
    """Every module that ``start`` imports, directly or through others."""
    seen: set[str] = set()
    todo = list(graph[start])
    while todo:
        v = todo.pop()
        if v not in seen:
            seen.add(v)
            todo.extend(graph[v])
    return seen


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The import circles: each group of modules that reach one another (a strongly connected
    component of more than one module), sorted."""
    reach = {v: _reach(graph, v) for v in graph}
    groups = {tuple(sorted(w for w in reach[v] if v in reach[w])) for v in graph if v in reach[v]}
    return sorted(list(g) for g in groups)


def _path_in(graph: dict[str, set[str]], component: list[str]) -> list[str]:
    """One circle through the first module of a component, for the failure message."""
    start = component[0]
    members = set(component)
    seen = {start: [start]}
    todo = [start]
    while todo:
        v = todo.pop(0)
        for w in sorted(graph[v] & members):
            if w == start:
                return [*seen[v], start]
            if w not in seen:
                seen[w] = [*seen[v], w]
                todo.append(w)
    return component


def _report(graph: dict[str, set[str]], cycles: list[list[str]]) -> str:
    return "; ".join(" -> ".join(m.removeprefix("droneplan.") for m in _path_in(graph, c)) for c in cycles)


def test_the_graph_sees_function_level_and_package_imports():
    # a function-level ``from droneplan.studies.x import y`` and a package-level
    # ``from droneplan.studies import x`` both count as importing the module x
    assert "droneplan.studies.kinds.cells" in _imports("droneplan.studies.methods")
    assert "droneplan.studies.wire" in _imports("droneplan.studies.harness")
    assert _cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]
    assert _cycles({"a": {"b"}, "b": set()}) == []


@pytest.mark.parametrize("layer", ["solvers", "studies"])
def test_no_import_circle(layer):
    graph = _graph(f"droneplan.{layer}")
    cycles = _cycles(graph)
    assert not cycles, f"import circles in {layer}/: {_report(graph, cycles)}"


CLI_ROOM = {"droneplan.studies.cli", "droneplan.studies.bench_summary"}
"""The command line and the benches, which import both the engine and the thesis reproductions."""


def _is_thesis(name: str) -> bool:
    return name == "droneplan.studies.thesis" or name.startswith("droneplan.studies.thesis.")


def test_the_study_engine_never_imports_the_thesis_reproductions():
    engine = [n for n in _graph("droneplan.studies") if not _is_thesis(n) and n not in CLI_ROOM]
    assert "droneplan.studies.study" in engine and "droneplan.studies.thesis.cells" in MODULES
    offending = {n: sorted(m for m in _imports(n) if _is_thesis(m)) for n in engine}
    offending = {n: ms for n, ms in offending.items() if ms}
    assert not offending, f"engine modules that import studies/thesis/: {offending}"
    # and nothing below the studies layer does either
    below = [n for n in MODULES if not n.startswith("droneplan.studies")]
    assert not [n for n in below if any(_is_thesis(m) for m in _imports(n))]
