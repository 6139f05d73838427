"""Every ```python block of README.md runs (in a temporary directory), so the quickstart cannot rot."""

import os
import re
from pathlib import Path

import matplotlib
import pytest

matplotlib.use("Agg")

README = Path(__file__).resolve().parents[1] / "README.md"
BLOCKS = re.findall(r"^```python\n(.*?)^```", README.read_text(encoding="utf-8"), flags=re.S | re.M)


def test_readme_has_a_python_block_per_problem():
    text = "\n".join(BLOCKS)
    for problem in ("covert", "cells", "shark", "herding"):
        assert f"dp.{problem}." in text, f"README has no Python block for {problem}"


@pytest.mark.parametrize("index", range(len(BLOCKS)), ids=[f"block{i}" for i in range(len(BLOCKS))])
def test_readme_python_block_runs(index, tmp_path, monkeypatch):
    import matplotlib.pyplot as plt

    monkeypatch.chdir(tmp_path)
    code = compile(BLOCKS[index], f"README.md python block {index}", "exec")
    try:
        exec(code, {"__name__": f"readme_block_{index}"})
    finally:
        plt.close("all")
    # a block that saves a figure leaves it in the working directory
    if "savefig(" in BLOCKS[index]:
        assert any(p.endswith(".png") for p in os.listdir(tmp_path)), "the block saved no plot"
