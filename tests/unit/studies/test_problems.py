"""One module owns the list of problems; the modules that need it use that very tuple."""

from __future__ import annotations

import importlib

import pytest

from droneplan.studies.problems import PROBLEMS


def test_the_problem_list_names_every_study_module_in_chapter_order():
    assert PROBLEMS == ("covert", "cells", "shark", "herding")
    for name in PROBLEMS:
        assert callable(importlib.import_module(f"droneplan.studies.{name}").gap)


@pytest.mark.parametrize("module", ["cli", "report"])
def test_cli_and_report_import_the_one_list(module):
    assert importlib.import_module(f"droneplan.studies.{module}").PROBLEMS is PROBLEMS


def test_the_store_agrees_with_the_one_list():
    # the store still holds its own copy; it must name the same problems in the same order
    assert tuple(importlib.import_module("droneplan.studies.store").PROBLEMS) == PROBLEMS
