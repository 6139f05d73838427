"""mkdocs hooks: the API pages list every ``__all__`` name of the front doors, and the last
reproduction report (``droneplan reproduce --report``) is published under ``report/``.

- ``<!-- deviations: cells -->`` expands to the table of deliberate deviations from the thesis
  (``droneplan.studies.thesis.report.DEVIATIONS``, shared with the reproduction report).
- A page line ``<!-- api: droneplan.cells -->`` expands to one mkdocstrings block per name in
  ``droneplan.cells.__all__`` (read statically from the source), so a new public name appears
  in the reference without editing the docs.
- If ``results/report.html`` exists (or the directory named by ``DRONEPLAN_REPORT_DIR``), it and
  every file it references are added to the site as ``report/...``; the reproduction page links it.
"""

from __future__ import annotations

import ast
import os
import re
from pathlib import Path

from mkdocs.structure.files import File

ROOT = Path(__file__).resolve().parents[1]
API_MARKER = re.compile(r"^<!-- api: (droneplan(?:\.\w+)?) -->$", re.MULTILINE)
REPORT_MARKER = "<!-- report-link -->"
DEVIATIONS_MARKER = re.compile(r"^<!-- deviations: (\w+) -->$", re.MULTILINE)


def front_door_all(module: str) -> list[str]:
    """The ``__all__`` list of a front-door module, read from its source without importing it."""
    parts = module.split(".")
    path = ROOT / "droneplan" / ("__init__.py" if len(parts) == 1 else f"{parts[1]}.py")
    for node in ast.parse(path.read_text(encoding="utf-8")).body:
        if isinstance(node, ast.Assign) and any(getattr(t, "id", None) == "__all__" for t in node.targets):
            return list(ast.literal_eval(node.value))
    raise ValueError(f"{path} defines no __all__")


def _bound_nodes(tree: ast.Module) -> list[ast.stmt]:
    """The module-level statements of a source, with those under ``if TYPE_CHECKING:``."""
    body = list(tree.body)
    for node in tree.body:
        if isinstance(node, ast.If) and getattr(node.test, "id", None) == "TYPE_CHECKING":
            body += node.body
    return body


def _getattr_imports(tree: ast.Module) -> dict[str, str]:
    """name -> source module of each name a module-level ``__getattr__`` imports."""
    found: dict[str, str] = {}
    for node in tree.body:
        if isinstance(node, ast.FunctionDef) and node.name == "__getattr__":
            for sub in ast.walk(node):
                if isinstance(sub, ast.ImportFrom) and sub.module:
                    for a in sub.names:
                        found.setdefault(a.asname or a.name, sub.module)
    return found


def _static_targets(module: str) -> dict[str, str]:
    """name -> the identifier mkdocstrings should render for each name bound in a front door.

    Names bound at module level (imports, also those under ``if TYPE_CHECKING:``, which is how a
    front door declares the names its ``__getattr__`` imports on first use; defs, assignments)
    render under the front door; names only a module ``__getattr__`` imports render under the
    module they come from (griffe reads sources statically and cannot follow ``__getattr__``).
    """
    parts = module.split(".")
    path = ROOT / "droneplan" / ("__init__.py" if len(parts) == 1 else f"{parts[1]}.py")
    tree = ast.parse(path.read_text(encoding="utf-8"))
    targets: dict[str, str] = {}
    for node in _bound_nodes(tree):
        if isinstance(node, ast.ImportFrom | ast.Import):
            targets.update({(a.asname or a.name).split(".")[0]: module for a in node.names})
        elif isinstance(node, ast.FunctionDef | ast.ClassDef):
            targets[node.name] = module
        elif isinstance(node, ast.Assign):
            targets.update({t.id: module for t in node.targets if isinstance(t, ast.Name)})
    for name, where in _getattr_imports(tree).items():
        targets.setdefault(name, where)
    return {name: f"{where}.{name}" for name, where in targets.items()}


def _api_blocks(match: re.Match[str]) -> str:
    module = match.group(1)
    targets = _static_targets(module)
    blocks = []
    for name in front_door_all(module):
        if name.startswith("__") or name in ("cells", "covert", "shark", "herding"):
            continue
        if name not in targets:
            raise ValueError(f"{module}.__all__ names {name!r}, which the module does not bind")
        blocks.append(f"::: {targets[name]}\n")
    return "\n".join(blocks)


def report_dir() -> Path:
    return Path(os.environ.get("DRONEPLAN_REPORT_DIR", ROOT / "results"))


def report_files(directory: Path) -> list[Path]:
    """report.html and the local files it references (images, CSV), relative to ``directory``."""
    html = directory / "report.html"
    if not html.is_file():
        return []
    refs = re.findall(r'(?:src|href)="([^"#:]+)"', html.read_text(encoding="utf-8"))
    files = [Path("report.html")]
    files += [Path(r) for r in dict.fromkeys(refs) if (directory / r).is_file()]
    return files


def on_files(files, config):
    directory = report_dir()
    for rel in report_files(directory):
        files.append(File.generated(config, f"report/{rel.as_posix()}", abs_src_path=str(directory / rel)))
    return files


def on_page_markdown(markdown, page, config, files):
    markdown = API_MARKER.sub(_api_blocks, markdown)
    if DEVIATIONS_MARKER.search(markdown):
        from droneplan.studies.thesis.report import deviations_markdown  # one source for docs and report

        markdown = DEVIATIONS_MARKER.sub(lambda m: deviations_markdown(m.group(1)), markdown)
    if REPORT_MARKER in markdown:
        if report_files(report_dir()):
            link = (
                "The last report built on this machine: "
                "**[open the reproduction report](report/report.html)** "
                "(every thesis table beside this run, and every figure)."
            )
        else:
            link = (
                '!!! note "No report in this build"\n'
                "    No `results/report.html` was found when this site was built. Run "
                "`droneplan reproduce --quick --report` and rebuild the site to include it."
            )
        markdown = markdown.replace(REPORT_MARKER, link)
    return markdown
