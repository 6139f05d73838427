"""Extreme inputs on every public entry: one table, generated from the signatures.

Every public callable of the front doors (the ``SPECS`` of ``test_public_api.py``, which
``test_every_public_callable_has_a_strategy`` keeps complete) and of ``droneplan.__all__``
(``TOP_SPECS`` below) is called from its valid call with one parameter swapped for an extreme
value of the parameter's kind:

- a number: NaN, a huge magnitude (1e200), a vanishing one (1e-300 and 1e-6, a resolution or
  a step) and a huge horizon (1e12);
- an int: a huge count (10**12), a large one (10**6) and NaN;
- a bool flag: the string "yes";
- an array: entries of magnitude 1e200, NaN entries, an empty array of the same width, and
  (a table of points) a thousand times its rows;
- an optional parameter (None by default): 1e12, 1e-300 and 10**12.

Each call must return or refuse with a ValueError/TypeError whose message names the parameter,
within a CPU-time guard (and a wall-clock backstop), without asking for more memory than the
guard allows. NaN, a flag given as a string, arrays of NaN or 1e200 and scalars of 1e200 (but a
time limit) must be refused; the other values may also be accepted, provided the result is
finite (a huge time limit, a coarse tolerance or a one-frame animation are legitimate requests).

Every case must pass: there is no list of known gaps. A new failure is fixed in the entry
(a check naming the parameter, or a work budget refusing the call up front), with a direct
regression test beside the entry's own tests.
"""

from __future__ import annotations

import contextlib
import importlib.util
import inspect
import math
import resource
import signal
import sys
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
import pytest

import droneplan as dp


def _load_public_api():
    """The sibling module ``test_public_api`` (its SPECS, CALLABLES and _assert_finite)."""
    name = "droneplan_fuzz_public_api"
    if name in sys.modules:
        return sys.modules[name]
    spec = importlib.util.spec_from_file_location(name, Path(__file__).with_name("test_public_api.py"))
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module  # dataclasses look their module up while the module executes
    spec.loader.exec_module(module)
    return module


API = _load_public_api()
NAN = float("nan")

# ---------------------------------------------------------------------------- the top level
_TMP: dict[str, Any] = {}


def _study() -> dict[str, Any]:
    """A one-job gap study (greedy on one Table 4.2 instance) in a temporary directory, run once."""
    if not _TMP:
        out = Path(tempfile.mkdtemp(prefix="droneplan-fuzz-study-"))
        dp.gap("cells", methods=["greedy"], instances="table4.2", out=out, progress=False, m=1, seeds=1)
        inst = dp.family_instances("table4.2", seeds=1, m=1)[0]
        _TMP.update(out=out, df=dp.load_results(out), inst=inst, file=dp.save_instance(inst, out / "i.json"))
    return _TMP


def _fresh_dir() -> str:
    return tempfile.mkdtemp(prefix="droneplan-fuzz-gap-")


_HOME = (47.0, 8.0, 400.0)
"""A home position (lat, lon in degrees, alt in m) for the mission and GeoJSON exports."""
_PLAN = np.array([[900.0, -3300.0], [2900.0, -800.0]])
"""Two drone-cell positions (m) for the exports."""
_CELLS: list[Any] = []


def _cells_problem() -> Any:
    """The Table 4.2 problem the exports' plan places drone-cells in, built once."""
    if not _CELLS:
        _CELLS.append(dp.cells.thesis_problem(n_cells=2, seed=0))
    return _CELLS[0]


TOP_SPECS: dict[str, Any] = {
    "load_results": lambda: ((_study()["out"],), {}),
    "gap": lambda: (
        ("cells",),
        {
            "methods": ["greedy"],
            "instances": "table4.2",
            "out": _fresh_dir(),
            "progress": False,
            "m": 1,
            "seeds": 1,
        },
    ),
    "summary_table@top": lambda: ((_study()["df"],), {}),
    "performance_profile": lambda: ((_study()["df"],), {}),
    "plot_performance_profile": lambda: ((_study()["df"],), {}),
    "family_instances": lambda: (("table4.2",), {"seeds": 1, "m": 1}),
    "save_instance": lambda: ((_study()["inst"], Path(_fresh_dir()) / "i.json"), {}),
    "load_instance": lambda: ((_study()["file"],), {}),
    "load_traces": lambda: ((_study()["out"],), {}),
    "anytime_summary": lambda: ((_study()["df"], dp.load_traces(_study()["out"])), {}),
    "plot_anytime": lambda: ((_study()["df"], dp.load_traces(_study()["out"])), {}),
    "plot_anytime_ecdf": lambda: ((_study()["df"], dp.load_traces(_study()["out"])), {}),
    "run_gap": lambda: (("cells",), {"seeds": 1, "out": _fresh_dir()}),
    "export_mission": lambda: (
        (_PLAN, Path(_fresh_dir()) / "m.wpl"),
        {"origin": _HOME, "problem": _cells_problem()},
    ),
    "to_geojson": lambda: ((_PLAN,), {"origin": _HOME, "problem": _cells_problem()}),
    "to_geodataframe": lambda: ((_PLAN,), {"origin": _HOME, "problem": _cells_problem()}),
}
TOP_EXTRA = {
    "gap": {"seeds": 1, "m": 1},
    "family_instances": {"seeds": 1, "m": 1},
    "run_gap": {"seeds": 1},
    "export_mission": {"origin": _HOME},
    "to_geojson": {"origin": _HOME},
    "to_geodataframe": {"origin": _HOME},
}
"""Valid values of the top-level entries' parameters that have no default (``**size`` keywords too)."""

SLOW = {"gap", "run_gap", "ga_ablation", "optimal_interception"}
"""Entries whose valid call takes seconds: only the values that must be refused are tried."""


def _top_callable(name: str):
    return getattr(dp, name.split("@")[0])


def test_every_top_level_callable_has_a_spec():
    names = {
        n
        for n in dp.__all__
        if callable(getattr(dp, n))
        and not inspect.ismodule(getattr(dp, n))
        and n not in ("SolveResult", "Status")
    }
    assert names == {k.split("@")[0] for k in TOP_SPECS}


# ---------------------------------------------------------------------------- the cases
MUST_REFUSE = {"nan", "str-flag", "arr-1e200", "arr-nan", "top-nan"}


def _values(valid: Any) -> list[tuple[str, Any]]:
    """(label, extreme value) pairs for a parameter whose valid value is ``valid``."""
    if isinstance(valid, bool):
        return [("str-flag", "yes")]
    if isinstance(valid, int):
        return [("10**12", 10**12), ("10**6", 10**6), ("nan", NAN)]
    if isinstance(valid, float):
        return [("nan", NAN), ("1e200", 1e200), ("1e-300", 1e-300), ("1e-6", 1e-6), ("1e12", 1e12)]
    if valid is None:
        return [("1e12", 1e12), ("1e-300", 1e-300), ("10**12", 10**12)]
    if isinstance(valid, (str, bytes, Path, dict)):
        return []
    try:
        arr = np.asarray(valid)
    except (ValueError, TypeError):
        return []
    if arr.dtype.kind not in "if" or arr.size == 0:
        return []
    out = [
        ("arr-1e200", np.full(arr.shape, 1e200)),
        ("arr-nan", np.full(arr.shape, NAN)),
        ("arr-empty", np.zeros((0, *arr.shape[1:]))),
    ]
    if arr.ndim == 2:  # a thousand times the rows (points, users, targets ...)
        out.append(("arr-x1000", np.tile(arr, (1000, 1))))
    return out


def _entry(name: str) -> tuple[Any, Any]:
    """(callable, valid-call factory) of a front-door or top-level entry."""
    if name in TOP_SPECS:
        return _top_callable(name), TOP_SPECS[name]
    return API.CALLABLES[name], API.SPECS[name].call


def _parameters(name: str) -> list[tuple[str, Any]]:
    """(parameter, valid value) of every parameter of ``name`` that has a valid value.

    Front-door entries take them from their valid call; top-level entries from their defaults
    and ``TOP_EXTRA`` (so collecting the cases runs no study)."""
    fn, call = _entry(name)
    sig = inspect.signature(fn)
    if name in TOP_SPECS:
        given = dict(TOP_EXTRA.get(name, {}))
    else:
        args, kwargs = call()
        given = dict(sig.bind_partial(*args, **kwargs).arguments)
    out = []
    for pname, p in sig.parameters.items():
        if p.kind in (p.VAR_POSITIONAL, p.VAR_KEYWORD):
            continue
        valid = given.get(pname, p.default)
        if valid is not inspect.Parameter.empty:
            out.append((pname, valid))
    out += [(k, v) for k, v in given.items() if k not in sig.parameters]
    return out


def _cases() -> list[tuple[str, str, str, Any]]:
    names = sorted(API.SPECS) + sorted(TOP_SPECS)
    cases = []
    for name in names:
        for pname, valid in _parameters(name):
            for label, value in _values(valid):
                huge_count = label == "10**12" and "seed" not in pname  # a seed of 10**12 is valid
                quick = label in MUST_REFUSE or huge_count
                if name in SLOW and not quick:
                    continue
                cases.append((name, pname, label, value))
    return cases


CASES = _cases()


def _param(case: tuple[str, str, str, Any]):
    name, pname, label, value = case
    return pytest.param(name, pname, label, value, id=f"{name}-{pname}-{label}")


# ---------------------------------------------------------------------------- the guard
class _OverBudget(BaseException):
    """Raised by the guard's timers (a BaseException, so no ``except Exception`` swallows it)."""


def _raise_over_budget(signum, frame):
    raise _OverBudget(signal.Signals(signum).name)


CPU_SECONDS = 8.0
"""CPU time (s, every thread of the process) a call may take before it counts as a hang."""

WALL_SECONDS = 60.0
"""Wall-clock backstop (s) for a call blocked without using CPU."""

MEMORY_BYTES = 6 * 2**30
"""Address space (bytes) a call may add: an allocation beyond it is a MemoryError, a failure."""


@contextlib.contextmanager
def guard(cpu: float = CPU_SECONDS) -> Iterator[None]:
    """Run the block under a CPU-time alarm, a wall-clock alarm and an address-space limit."""
    old_prof = signal.signal(signal.SIGPROF, _raise_over_budget)
    old_alrm = signal.signal(signal.SIGALRM, _raise_over_budget)
    soft, hard = resource.getrlimit(resource.RLIMIT_AS)
    used = _address_space()
    limit = used + MEMORY_BYTES if used else resource.RLIM_INFINITY
    if hard != resource.RLIM_INFINITY:
        limit = min(limit, hard)
    resource.setrlimit(resource.RLIMIT_AS, (limit, hard))
    signal.setitimer(signal.ITIMER_PROF, cpu)
    signal.setitimer(signal.ITIMER_REAL, WALL_SECONDS)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_PROF, 0)
        signal.setitimer(signal.ITIMER_REAL, 0)
        resource.setrlimit(resource.RLIMIT_AS, (soft, hard))
        signal.signal(signal.SIGPROF, old_prof)
        signal.signal(signal.SIGALRM, old_alrm)


def _address_space() -> int:
    """This process's virtual memory size (bytes), 0 if unknown."""
    try:
        fields = Path("/proc/self/statm").read_text().split()
        return int(fields[0]) * resource.getpagesize()
    except (OSError, ValueError, IndexError):
        return 0


def _call_with(name: str, pname: str, value: Any) -> tuple[Any, tuple, dict]:
    fn, call = _entry(name)
    args, kwargs = call()
    sig = inspect.signature(fn)
    bound = sig.bind_partial(*args, **kwargs)
    if pname in sig.parameters:
        bound.arguments[pname] = value
        return fn, bound.args, bound.kwargs
    return fn, bound.args, {**bound.kwargs, pname: value}  # a **size keyword


def verdict(name: str, pname: str, value: Any, *, cpu: float = CPU_SECONDS) -> tuple[str, str]:
    """("refused", exception type) / ("returned", "finite"|"not finite") / ("failed", what)."""
    fn, args, kwargs = _call_with(name, pname, value)
    start = time.process_time()
    try:
        with guard(cpu):
            result = fn(*args, **kwargs)
    except _OverBudget as exc:
        return "failed", f"over budget ({exc}) after {time.process_time() - start:.1f} s CPU"
    except (ValueError, TypeError) as exc:
        if pname not in str(exc):
            return "failed", f"{type(exc).__name__} not naming {pname}: {exc}"
        return "refused", type(exc).__name__
    except BaseException as exc:  # noqa: BLE001 - any other exception is the finding
        return "failed", f"{type(exc).__name__}: {exc}"
    finally:
        plt.close("all")
    return "returned", "finite" if _finite(result) else "not finite"


def _finite(result: Any) -> bool:
    """Whether the numbers of a result are finite (a SolveResult's objective, bound and float x;
    an array; a float; each part of a tuple). Written without ``assert``, so that it also holds
    under ``python -O``."""
    if isinstance(result, dp.SolveResult):
        numbers = [v for v in (result.objective, result.bound) if v is not None]
        x = result.x if isinstance(result.x, np.ndarray) and result.x.dtype.kind == "f" else np.zeros(0)
        return isinstance(result.status, dp.Status) and all(map(math.isfinite, numbers)) and _finite(x)
    if isinstance(result, np.ndarray) and result.dtype.kind in "fc":
        return bool(np.all(np.isfinite(result)))
    if isinstance(result, float):
        return math.isfinite(result)
    if isinstance(result, tuple):
        return all(_finite(part) for part in result)
    return True


@pytest.mark.parametrize(("name", "pname", "label", "value"), [_param(c) for c in CASES])
def test_extreme_input_returns_or_refuses_naming_the_parameter(name, pname, label, value):
    kind, detail = verdict(name, pname, value)
    assert kind != "failed", f"{name}({pname}={label}): {detail}"
    if kind == "returned":
        # a time limit of 1e200 s means "no limit"; every other scalar that large is refused
        huge = label == "1e200" and "limit" not in pname
        assert label not in MUST_REFUSE and not huge, f"{name}({pname}={label}) was accepted"
        assert detail == "finite", f"{name}({pname}={label}) returned non-finite numbers"


def test_the_guard_stops_a_hang_and_a_huge_allocation():
    def spin():
        while True:
            pass

    start = time.process_time()
    with pytest.raises(_OverBudget), guard(cpu=0.5):
        spin()
    assert time.process_time() - start < 5.0
    with pytest.raises(MemoryError), guard():
        np.ones(2 * MEMORY_BYTES // 8)
    assert math.isfinite(float(np.ones(3).sum()))  # the limits are lifted again


# ---------------------------------------------------------------------------- python -O
_VERDICTS_SCRIPT = """
import importlib.util, json, sys
spec = importlib.util.spec_from_file_location("droneplan_fuzz_extreme", sys.argv[1])
mod = importlib.util.module_from_spec(spec)
sys.modules["droneplan_fuzz_extreme"] = mod
spec.loader.exec_module(mod)
cases = {f"{n}-{p}-{lbl}": (n, p, v) for n, p, lbl, v in mod.CASES}
out = {}
for key in json.loads(sys.argv[2]):
    name, pname, value = cases[key]
    kind, detail = mod.verdict(name, pname, value)
    out[key] = [kind, detail.split(":")[0] if kind == "failed" else detail]
print(json.dumps(out))
"""


def _sample() -> list[str]:
    """Every 6th case that must be refused or is a huge count (not the slow entries), plus every
    case of check_allocation, whose checks were once written as ``assert``."""
    pool = [c for c in CASES if c[0] not in SLOW and (c[2] in MUST_REFUSE or c[2] == "10**12")]
    keys = [f"{n}-{p}-{lbl}" for n, p, lbl, _ in pool[::6]]
    keys += [f"{n}-{p}-{lbl}" for n, p, lbl, _ in CASES if n == "check_allocation"]
    return sorted(set(keys))


def test_python_dash_O_gives_the_same_verdicts():
    import json
    import subprocess

    sample = _sample()
    assert len(sample) >= 40
    runs = {}
    for flags in ((), ("-O",)):
        proc = subprocess.run(
            [sys.executable, *flags, "-c", _VERDICTS_SCRIPT, __file__, json.dumps(sample)],
            capture_output=True,
            text=True,
            timeout=900,
            check=False,
        )
        assert proc.returncode == 0, proc.stderr[-2000:]
        runs[flags] = json.loads(proc.stdout.strip().splitlines()[-1])
    plain, optimised = runs[()], runs[("-O",)]
    assert set(plain) == set(sample)
    differ = {k: (plain[k], optimised[k]) for k in sample if plain[k] != optimised[k]}
    assert not differ, f"verdicts that change under python -O: {differ}"
    refused = [k for k in sample if plain[k][0] == "refused"]
    assert len(refused) >= 0.8 * len(sample)  # the sample exercises the checks, not only returns
