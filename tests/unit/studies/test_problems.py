"""One module owns the list of problems; the modules that need it use that very tuple."""

from __future__ import annotations

import importlib

import pytest

from droneplan.studies.problems import PROBLEMS


def test_the_problem_list_names_every_study_module_in_chapter_order():
    assert PROBLEMS == ("covert", "cells", "shark", "herding")
    for name in PROBLEMS:
        assert callable(importlib.import_module(f"droneplan.studies.thesis.{name}").gap)


@pytest.mark.parametrize("module", ["cli", "thesis.report", "store"])
def test_every_module_imports_the_one_list(module):
    assert importlib.import_module(f"droneplan.studies.{module}").PROBLEMS is PROBLEMS
