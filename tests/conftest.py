"""Test-wide settings: under CI (CI=true) hypothesis replays a fixed set of examples
so that a gate run is reproducible; locally it explores new examples each run.

The saved herding trajectories (``tests/unit/planners/test_herding_regression.py`` and
``tests/unit/scenarios/test_herding_reference.py``) were recorded with OpenBLAS's SkylakeX
kernels, and they must be reproduced to 1e-9 m. OpenBLAS picks its kernels by CPU or by
``OPENBLAS_CORETYPE``, and another kernel can round a BLAS product (the hull geometry calls a
few) differently in the last bit, which the herd's dynamics amplify. On an AMD EPYC with AVX-512
whose environment sets ``OPENBLAS_CORETYPE=Haswell``, two of those tests mismatched; with
SkylakeX (or Cooperlake) none did. So where the CPU has AVX-512 the SkylakeX kernels are asked
for here, for the test process only and before numpy loads OpenBLAS, unless a recorded kernel is
already set; the fixture ``recorded_blas_kernel`` skips those tests, naming the kernel, where
OpenBLAS runs another one."""

import ctypes
import glob
import os


def _cpu_has_avx512() -> bool:
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as f:
            return any(line.startswith("flags") and " avx512f" in line for line in f)
    except OSError:
        return False


RECORDED_BLAS_KERNELS = ("SkylakeX", "Cooperlake")
"""OpenBLAS kernels that reproduce the saved herding trajectories bit for bit (measured)."""

if _cpu_has_avx512() and os.environ.get("OPENBLAS_CORETYPE") not in RECORDED_BLAS_KERNELS:
    os.environ["OPENBLAS_CORETYPE"] = "SkylakeX"

import numpy as np  # noqa: E402  (after OPENBLAS_CORETYPE: OpenBLAS reads it when it loads)
import pytest  # noqa: E402
from hypothesis import settings  # noqa: E402


def _openblas_kernel() -> str | None:
    """The kernel ("core") numpy's OpenBLAS runs, or None when it cannot be asked."""
    libs = glob.glob(os.path.join(os.path.dirname(np.__file__), os.pardir, "numpy.libs", "*openblas*"))
    for path in libs:
        try:
            lib = ctypes.CDLL(path)
        except OSError:
            continue
        for name in (
            "scipy_openblas_get_corename64_",
            "scipy_openblas_get_corename",
            "openblas_get_corename",
        ):
            fn = getattr(lib, name, None)
            if fn is not None:
                fn.restype = ctypes.c_char_p
                return fn().decode()
    return None


@pytest.fixture
def recorded_blas_kernel() -> str:
    """Skip unless numpy's OpenBLAS runs a kernel the saved herding trajectories were recorded
    with (module docstring); returns its name."""
    kernel = _openblas_kernel()
    if kernel not in RECORDED_BLAS_KERNELS:
        pytest.skip(
            f"the saved herding trajectories need OpenBLAS kernels {RECORDED_BLAS_KERNELS} "
            f"(AVX-512); numpy's OpenBLAS runs {kernel!r} here"
        )
    return kernel


settings.register_profile("ci", derandomize=True, database=None, print_blob=True)
if os.environ.get("CI"):
    settings.load_profile("ci")
