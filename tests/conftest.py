"""Test-wide settings: under CI (CI=true) hypothesis replays a fixed set of examples
so that a gate run is reproducible; locally it explores new examples each run."""

import os

from hypothesis import settings

settings.register_profile("ci", derandomize=True, database=None, print_blob=True)
if os.environ.get("CI"):
    settings.load_profile("ci")
