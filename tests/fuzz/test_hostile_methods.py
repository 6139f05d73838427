"""Methods written by a hostile or careless user cannot reach droneplan's scorer, store or proofs.

Each test is a regression test of one way the promise "every number in a gap study comes from
droneplan, not from the method being measured" once broke: the study unpickled what a method
returned, believed the closed-loop metrics of the method's own process, scored plans of any size
without a bound, and left jobs running after the study was killed.
"""

from __future__ import annotations

import importlib
import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest

import droneplan
import droneplan.formulations.cells as cells_formulation
from droneplan.formulations.herding import check_allocation
from droneplan.planners.shark import VirtualSharkInterceptor
from droneplan.studies import harness

shark_simulate = importlib.import_module("droneplan.scenarios.shark.simulate")  # the module, not the function

ORIGINALS = {
    "evaluate": cells_formulation.evaluate,
    "score": harness.score,
    "check_allocation": check_allocation,
    "inside_field": shark_simulate.inside_field,
}


def _assert_scorers_untouched():
    import droneplan.formulations.herding as herding_formulation

    assert cells_formulation.evaluate is ORIGINALS["evaluate"]
    assert harness.score is ORIGINALS["score"]
    assert herding_formulation.check_allocation is ORIGINALS["check_allocation"]
    assert shark_simulate.inside_field is ORIGINALS["inside_field"]


def _fake_evaluate(problem, positions):
    raise AssertionError("the method's replacement scorer ran in the study")


class PatchesTheScorerWhenUnpickled:
    """A return value whose unpickling would replace droneplan's cells evaluator."""

    def __reduce__(self):
        return (setattr, (cells_formulation, "evaluate", _fake_evaluate))


def returns_a_patching_object(problem, *, seed, time_limit):
    return PatchesTheScorerWhenUnpickled()


def nests_a_patching_object(problem, *, seed, time_limit):
    return droneplan.SolveResult(
        droneplan.Status.FEASIBLE, objective=1e6, x=[PatchesTheScorerWhenUnpickled()]
    )


def writes_a_forged_pickle_to_its_pipe(problem, *, seed, time_limit):
    """Skips the return path: writes a length-prefixed pickle straight to every pipe it holds."""
    import pickle
    import stat
    import struct

    body = pickle.dumps(("ok", PatchesTheScorerWhenUnpickled()))
    for fd in range(3, 256):
        try:
            if stat.S_ISFIFO(os.fstat(fd).st_mode):
                for kind in (b"", b"P", b"B"):
                    os.write(fd, struct.pack(">Q", len(kind + body)) + kind + body)
        except OSError:
            continue
    os._exit(0)


def test_nothing_a_cells_method_returns_is_executed(tmp_path):
    methods = [
        ("pickle-bomb", returns_a_patching_object),
        ("nested-bomb", nests_a_patching_object),
        ("forged-pipe", writes_a_forged_pickle_to_its_pipe),
        "greedy",
    ]
    df = droneplan.gap("cells", methods=methods, m=2, seeds=2, out=tmp_path, workers=1, progress=False)
    _assert_scorers_untouched()
    by = df.set_index(["method", "instance"])
    for name in ("pickle-bomb", "nested-bomb"):
        rows = df[df["method"] == name]
        assert (rows["status"] == "invalid").all()
        assert rows["message"].str.contains("PatchesTheScorerWhenUnpickled").all()
    assert df.loc[df["method"] == "forged-pipe", "status"].isin(["error", "invalid"]).all()
    # greedy is scored by droneplan's own evaluator, against the certified library
    for inst in df["instance"].unique():
        greedy, library = by.loc[("greedy", inst)], by.loc[("library", inst)]
        assert greedy["status"] in ("feasible", "optimal") and greedy["objective"] <= library["bound"]
        assert "beats-bound" not in str(greedy["flag"])


class PatchingVirtualShark(VirtualSharkInterceptor):
    """The thesis controller, after patching the contact test and the simulator in its own process."""

    def __init__(self):
        super().__init__()
        shark_simulate.inside_field = lambda shark, operator, params: np.full(len(shark), -1.0)
        import droneplan.scenarios.shark as shark_scenarios

        shark_scenarios.simulate = lambda *a, **k: (_ for _ in ()).throw(AssertionError("patched"))


def test_a_controller_that_patches_the_simulator_changes_no_score(tmp_path):
    methods = [("honest", VirtualSharkInterceptor), ("patching", PatchingVirtualShark)]
    df = droneplan.gap(
        "shark", methods=methods, seeds=2, out=tmp_path, workers=1, progress=False, time_limit=120
    )
    _assert_scorers_untouched()
    honest = df[df["method"] == "honest"].set_index("instance")
    patching = df[df["method"] == "patching"].set_index("instance")
    assert len(honest) == 2
    for inst in honest.index:
        assert patching.loc[inst, "status"] == honest.loc[inst, "status"]
        assert patching.loc[inst, "objective"] == pytest.approx(honest.loc[inst, "objective"])
    assert (df.loc[df["method"] != "library", "shark_method_time_s"] > 0).all()


class SendsAnObjectAsCommand:
    """A herding controller whose commands are not plain data."""

    phase = None

    def reset(self, scenario, *, seed=None):
        from droneplan.scenarios.herding import HerdingPhase

        self.phase = HerdingPhase.GATHERING

    def command(self, obs):
        return PatchesTheScorerWhenUnpickled()


def test_a_controller_reply_that_is_not_plain_is_invalid(tmp_path):
    scenario = droneplan.herding.thesis_scenario(10, seed=0, field_size=(100.0, 100.0), goal=(-100.0, 50.0))
    df = droneplan.gap(
        "herding",
        methods=[("objects", SendsAnObjectAsCommand)],
        instances=[scenario],
        out=tmp_path,
        workers=1,
        progress=False,
        time_limit=60,
    )
    _assert_scorers_untouched()
    row = df[df["method"] == "objects"].iloc[0]
    assert row["status"] == "invalid" and "PatchesTheScorerWhenUnpickled" in row["message"]


def six_thousand_cells(problem, *, seed, time_limit):
    rng = np.random.default_rng(seed)
    return rng.uniform(-100.0, 100.0, size=(6000, 2))


def test_a_plan_beyond_the_instance_is_invalid_before_any_quadratic_work(tmp_path):
    df = droneplan.gap(
        "cells", methods=[six_thousand_cells], m=2, seeds=1, out=tmp_path, workers=1, progress=False
    )
    row = df[df["method"] == "six_thousand_cells"].iloc[0]
    assert (
        row["status"] == "invalid"
        and "6000 drone-cells" in row["message"]
        and "n_cells = 2" in row["message"]
    )
    assert np.isfinite(row["cells_score_time_s"])  # scoring ran, under its own budget, and is recorded


def allocates_too_much(problem, *, seed, time_limit):
    return np.ones(6 << 30, dtype=np.uint8).reshape(-1, 2)[:1]


def test_each_job_has_a_memory_cap(tmp_path):
    df = droneplan.gap(
        "cells",
        methods=[allocates_too_much],
        m=1,
        seeds=1,
        out=tmp_path,
        workers=1,
        progress=False,
        memory_limit=1 << 30,
    )
    row = df[df["method"] == "allocates_too_much"].iloc[0]
    assert row["status"] == "error" and "MemoryError" in row["message"]


_STUDY = textwrap.dedent(
    """
    import os, sys, time
    import droneplan

    def sleeper(problem, *, seed, time_limit):
        with open(sys.argv[1] + f".{os.getpid()}", "w") as fh:
            fh.write("started")
        time.sleep(120)

    droneplan.gap("cells", methods=[sleeper], m=1, seeds=1, out=sys.argv[2], workers=1, progress=False,
                  time_limit=600)
    """
)


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    try:  # a zombie is dead for our purpose
        return Path(f"/proc/{pid}/stat").read_text().split()[2] != "Z"
    except OSError:
        return False


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="PR_SET_PDEATHSIG is Linux's")
@pytest.mark.parametrize("sig", [signal.SIGKILL, signal.SIGTERM, signal.SIGHUP])
def test_jobs_die_with_the_study(tmp_path, sig):
    script = tmp_path / "study.py"
    script.write_text(_STUDY)
    marker = tmp_path / "job"
    proc = subprocess.Popen([sys.executable, str(script), str(marker), str(tmp_path / "out")])
    try:
        deadline = time.monotonic() + 90
        while not list(tmp_path.glob("job.*")) and time.monotonic() < deadline:
            assert proc.poll() is None, "the study ended before its job started"
            time.sleep(0.1)
        (started,) = tmp_path.glob("job.*")
        job_pid = int(started.suffix[1:])
        assert _alive(job_pid)
        proc.send_signal(sig)
        proc.wait(timeout=30)
        deadline = time.monotonic() + 10
        while _alive(job_pid) and time.monotonic() < deadline:
            time.sleep(0.1)
        assert not _alive(job_pid), f"the job {job_pid} outlived the study killed by {sig.name}"
    finally:
        if proc.poll() is None:
            proc.kill()
