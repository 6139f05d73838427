"""griffe extension for the API pages: this project's docstrings document parameters and fields as
``name: meaning (unit)`` lines (several names may share one line: ``a, b: ...``). Rendered as
Markdown those lines would run together into one paragraph; this turns each such line, with its
indented continuation lines, into a list item so every parameter stays on its own line, and drops
the Sphinx role prefixes (``:class:``) that Markdown would print literally.
"""

from __future__ import annotations

import re
from typing import Any

import griffe

SPHINX_ROLE = re.compile(r":(?:func|class|mod|meth|attr|data|obj|exc):`~?")
PARAM_LINE = re.compile(r"^(?P<names>\*{0,2}[A-Za-z_]\w*(?:, \*{0,2}[A-Za-z_]\w*)*): (?P<text>\S.*)$")


def listify(text: str) -> str:
    """Turn ``name: text`` lines (and their continuation lines) into Markdown list items, and
    Sphinx roles (``:class:`X```) into plain code spans."""
    text = SPHINX_ROLE.sub("`", text)
    out: list[str] = []
    in_item = False
    in_code = False
    for line in text.splitlines():
        if line.strip().startswith("```") or line.rstrip().endswith("::"):
            in_code = not in_code if line.strip().startswith("```") else in_code
        match = None if in_code else PARAM_LINE.match(line)
        if match:
            if out and out[-1].strip() and not in_item:
                out.append("")  # a list needs a blank line before it
            names = ", ".join(f"`{n.strip()}`" for n in match["names"].split(","))
            out.append(f"- {names}: {match['text']}")
            in_item = True
        elif in_item and line.startswith(" ") and line.strip():
            out.append("  " + line.strip())
        else:
            if in_item and line.strip():
                out.append("")  # end the list before ordinary text
            in_item = False
            out.append(line)
    return "\n".join(out)


class ParamLines(griffe.Extension):
    """Apply :func:`listify` to the docstring of every function and class."""

    def _fix(self, obj: Any) -> None:
        if obj.docstring is not None:
            obj.docstring.value = listify(obj.docstring.value)

    def on_function_instance(self, *, func: griffe.Function, **kwargs: Any) -> None:
        self._fix(func)

    def on_class_instance(self, *, cls: griffe.Class, **kwargs: Any) -> None:
        self._fix(cls)
