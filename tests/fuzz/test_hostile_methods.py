"""Methods written by a hostile or careless user cannot reach droneplan's scorer, store or proofs.

Each test is a regression test of one way the promise "every number in a gap study comes from
droneplan, not from the method being measured" once broke: the study unpickled what a method
returned, believed the closed-loop metrics of the method's own process, scored plans of any size
without a bound, and left jobs running after the study was killed.
"""

from __future__ import annotations

import dataclasses
import functools
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
import droneplan.scenarios.covert.dynamics as covert_dynamics
import droneplan.scenarios.herding as herding_scenarios
import droneplan.studies.methods
import droneplan.studies.study
from droneplan.formulations.herding import check_allocation
from droneplan.planners.covert import HoverBenchmark
from droneplan.planners.herding import BenchmarkHerder
from droneplan.planners.shark import VirtualSharkInterceptor
from droneplan.studies import harness

shark_simulate = importlib.import_module("droneplan.scenarios.shark.simulate")  # the module, not the function

ORIGINALS = {
    "evaluate": cells_formulation.evaluate,
    "score": harness.score,
    "check_allocation": check_allocation,
    "inside_field": shark_simulate.inside_field,
}

PATCHED_ORIGINALS = {
    "_delivered": herding_scenarios._delivered,
    "bearing_changes": covert_dynamics.bearing_changes,
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


def test_over_dask_the_client_decodes_plain_data_and_scores_it(tmp_path):
    """The worker hands back the child's bytes; the study decodes them, so a return value that
    would patch the evaluator when unpickled is an invalid row here too."""
    distributed = pytest.importorskip("distributed")
    methods = [("pickle-bomb", returns_a_patching_object), "greedy"]
    with distributed.LocalCluster(
        n_workers=1, threads_per_worker=1, processes=False, dashboard_address=None
    ) as cluster:
        df = droneplan.gap(
            "cells",
            methods=methods,
            m=2,
            seeds=1,
            out=tmp_path,
            dask=cluster.scheduler_address,
            progress=False,
        )
    _assert_scorers_untouched()
    bomb = df[df["method"] == "pickle-bomb"].iloc[0]
    assert bomb["status"] == "invalid" and "PatchesTheScorerWhenUnpickled" in bomb["message"]
    greedy = df[df["method"] == "greedy"].iloc[0]
    assert greedy["status"] in ("feasible", "optimal") and np.isfinite(greedy["cells_score_time_s"])


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


class PatchingBenchmarkHerder(BenchmarkHerder):
    """The benchmark herder, after making its process's herding simulator call the flock delivered."""

    def __init__(self):
        super().__init__()
        herding_scenarios._delivered = lambda *args, **kwargs: True


class PatchingHover(HoverBenchmark):
    """The hover benchmark, after making its process's covert simulator record no bearing change."""

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        real = PATCHED_ORIGINALS["bearing_changes"]
        covert_dynamics.bearing_changes = lambda drone, targets, R: 0.0 * real(drone, targets, R)


_PATCHED_RUNS = {
    "herding": (BenchmarkHerder, PatchingBenchmarkHerder, herding_scenarios, "_delivered", {}),
    "covert": (
        HoverBenchmark,
        PatchingHover,
        covert_dynamics,
        "bearing_changes",
        {"n_targets": 2, "seeds": 1},
    ),
}


@pytest.mark.parametrize("problem", sorted(_PATCHED_RUNS))
def test_a_controller_that_patches_its_simulator_changes_no_score(tmp_path, monkeypatch, problem):
    """The old study ran the simulator in the method's process and believed its metrics: there the
    patched delivery test ends a herding run at once, and the patched bearing changes give a
    covert run beta_max 0, so the patching rows scored better than the honest ones. The last lines
    show that the patch does change a run in the process that made it."""
    honest_cls, patching_cls, module, attr, size = _PATCHED_RUNS[problem]
    instances = None
    if problem == "herding":
        instances = [
            droneplan.herding.thesis_scenario(10, seed=0, field_size=(100.0, 100.0), goal=(-100.0, 50.0))
        ]
    methods = [("honest", honest_cls), ("patching", patching_cls)]
    df = droneplan.gap(
        problem,
        methods=methods,
        instances=instances,
        out=tmp_path,
        workers=1,
        progress=False,
        time_limit=60,
        **size,
    )
    _assert_scorers_untouched()
    assert getattr(module, attr) is PATCHED_ORIGINALS[attr]
    honest = df[df["method"] == "honest"].set_index("instance")
    patching = df[df["method"] == "patching"].set_index("instance")
    assert len(honest) == 1 and (honest["status"] == "feasible").all()
    inst = honest.index[0]
    assert patching.loc[inst, "status"] == "feasible"
    assert patching.loc[inst, "objective"] == pytest.approx(honest.loc[inst, "objective"])
    assert honest.loc[inst, "objective"] > 0

    # in the controller's own process the patch works: the old study would have believed this run
    monkeypatch.setattr(module, attr, getattr(module, attr))  # restored after the test
    plan = droneplan.studies.study.plan_study(problem, methods=methods, instances=instances, **size)
    instance = plan.instances[0]
    metrics = instance.kind_class.simulate(instance.data, patching_cls(), seed=0)
    claimed = metrics["total_time"] if problem == "herding" else metrics["beta_max_deg"]
    assert claimed < honest.loc[inst, "objective"]


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
    import os, signal, sys, time
    import droneplan

    # a study started under nohup inherits an ignored SIGHUP; this one is to die of it
    signal.signal(signal.SIGHUP, signal.SIG_DFL)

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
        deadline = time.monotonic() + 240  # a loaded machine starts the study slowly
        while not list(tmp_path.glob("job.*")) and time.monotonic() < deadline:
            assert proc.poll() is None, "the study ended before its job started"
            time.sleep(0.1)
        (started,) = tmp_path.glob("job.*")
        job_pid = int(started.suffix[1:])
        assert _alive(job_pid)
        proc.send_signal(sig)
        proc.wait(timeout=120)
        deadline = time.monotonic() + 30
        while _alive(job_pid) and time.monotonic() < deadline:
            time.sleep(0.1)
        assert not _alive(job_pid), f"the job {job_pid} outlived the study killed by {sig.name}"
    finally:
        if proc.poll() is None:
            proc.kill()


# --------------------------------------------------------------------------- one id, one data set
def test_a_user_name_over_other_data_is_another_instance(tmp_path):
    from droneplan.cells import thesis_problem
    from droneplan.studies.instances import as_instance

    a, b = thesis_problem(1, 0), thesis_problem(1, 1)
    assert as_instance(a, name="town").id != as_instance(b, name="town").id
    kw = {"out": tmp_path, "progress": False, "reference": "none"}  # no reference rows: one method each
    droneplan.gap("cells", methods=["greedy"], instances=[as_instance(a, name="town")], **kw)
    df = droneplan.gap("cells", methods=["ga"], instances=[as_instance(b, name="town")], **kw)
    assert len(set(df["instance"])) == 1 and df["method"].tolist() == ["ga"]  # greedy's row is not compared
    everything = droneplan.load_results(tmp_path)
    assert everything.groupby("instance")["method"].nunique().max() == 1


def test_an_edited_family_file_becomes_a_user_instance(tmp_path):
    import json

    from droneplan.studies.instances import family_instances, load_instance, save_instance

    inst = family_instances("table4.2", m=1, seeds=1)[0]
    path = save_instance(inst, tmp_path / "one.json")
    doc = json.loads(path.read_text())
    doc["data"]["users"][0] = [doc["data"]["users"][0][0] + 500.0, doc["data"]["users"][0][1]]
    del doc["fingerprint"]  # a careful editor removes the check too
    path.write_text(json.dumps(doc))
    edited = load_instance(path)
    assert edited.id.startswith("user:") and edited.family == "user"
    assert load_instance(save_instance(inst, tmp_path / "two.json")).id == inst.id  # unedited: unchanged


def test_the_store_refuses_other_data_under_a_known_id(tmp_path):
    from droneplan.studies.store import InstanceDataError, ResultStore

    with ResultStore(tmp_path / "results.sqlite") as store:
        store.bind_instances("cells", {"table4.2@1:m=1,seed=0": "a" * 16})
        store.bind_instances("cells", {"table4.2@1:m=1,seed=0": "a" * 16})  # the same data: fine
        with pytest.raises(InstanceDataError, match="names other data") as info:
            store.bind_instances("cells", {"table4.2@1:m=1,seed=0": "b" * 16})
        assert "\n" not in str(info.value)


# --------------------------------------------------------------------------- only droneplan proves
def _claims_a_bound(problem, *, seed, time_limit):
    return droneplan.SolveResult(droneplan.Status.OPTIMAL, objective=0.0, bound=0.0, x=np.zeros((0, 2)))


@pytest.mark.parametrize(
    ("method", "words"),
    [
        (droneplan.studies.methods.Method("mine", _claims_a_bound, trusted_bound=True), "states no proof"),
        (droneplan.studies.methods.Method("mine", _claims_a_bound, builtin=True), "states no proof"),
        (
            droneplan.studies.methods.Method(
                "mine", _claims_a_bound, "bound", trusted_bound=True, builtin=True
            ),
            "states no proof",
        ),
        (("bnb", _claims_a_bound), "reserved for droneplan's registered method"),
        (("library", _claims_a_bound), "reserved"),
        (("task", _claims_a_bound), "reserved"),
    ],
)
def test_a_user_method_cannot_declare_a_proof_or_take_a_builtin_name(tmp_path, method, words):
    with pytest.raises(ValueError, match=words):
        droneplan.gap("cells", methods=[method], m=1, seeds=1, out=tmp_path, progress=False)


def test_a_claimed_bound_never_outranks_the_library(tmp_path):
    df = droneplan.gap("cells", methods=[("claims", _claims_a_bound), "greedy"], m=1, seeds=1, out=tmp_path)
    claims = df[df["method"] == "claims"].iloc[0]
    assert np.isnan(claims["bound"]) and claims["cells_claimed_bound"] == 0.0
    assert (df["gap_bound_kind"].dropna() != "none").all()
    greedy = df[df["method"] == "greedy"].iloc[0]
    assert "beats-bound" not in str(greedy["flag"]) and greedy["gap_to_bound"] >= 0


# --------------------------------------------------------------------------- a complete, stable config hash
def _write(path: Path, text: str) -> None:
    path.write_text(textwrap.dedent(text))


def test_the_code_hash_follows_the_users_helper_modules(tmp_path, monkeypatch):
    from droneplan.studies.method_hash import code_fingerprint

    _write(tmp_path / "hostile_helper.py", "RADIUS = 1.0\ndef helper():\n    return RADIUS\n")
    _write(
        tmp_path / "hostile_method.py",
        "from hostile_helper import helper\n\n"
        "def method(problem, *, seed, time_limit):\n    return helper()\n",
    )
    monkeypatch.syspath_prepend(str(tmp_path))
    import hostile_method

    before = code_fingerprint(hostile_method.method)
    assert code_fingerprint(hostile_method.method) == before
    _write(tmp_path / "hostile_helper.py", "RADIUS = 2.0\ndef helper():\n    return RADIUS\n")
    assert code_fingerprint(hostile_method.method) != before


def _scaled(problem, *, seed, time_limit, scale=1.0, shift=None):
    return np.zeros((0, 2))


@pytest.mark.parametrize(
    "make_param",
    [
        lambda: functools.partial(_scaled, scale=2.0),
        lambda: np.arange(3.0),
        lambda: Shift(1.0, (2, 3)),
        lambda: droneplan.Status.OPTIMAL,
    ],
)
def test_parameters_hash_by_value(make_param):
    from droneplan.studies.methods import Method
    from droneplan.studies.study import plan_study

    def config():
        m = Method("scaled", _scaled, params={"shift": make_param()})
        return plan_study("cells", methods=[m], m=1, seeds=1).tasks[0].config

    assert config() == config()  # a new object of the same value resumes


def test_a_parameter_without_a_stable_value_is_refused_in_one_line():
    from droneplan.studies.methods import Method
    from droneplan.studies.study import plan_study

    with pytest.raises(ValueError, match="no stable value to hash") as info:
        plan_study("cells", methods=[Method("scaled", _scaled, params={"shift": object()})], m=1, seeds=1)
    assert "\n" not in str(info.value) and "params['shift']" in str(info.value)


@dataclasses.dataclass
class Shift:
    dx: float
    cells: tuple


# --------------------------------------------------------------------------- error rows, signals
def test_a_user_method_named_task_keeps_its_error_rows(tmp_path):
    from droneplan.studies.store import ResultStore

    base = {"problem": "cells", "instance": "user:x", "config": "c", "sense": "max"}
    with ResultStore(tmp_path / "results.sqlite") as store:
        store.write([{**base, "method": "task", "role": "heuristic", "status": "error", "message": "boom"}])
        store.write([{**base, "method": "greedy", "role": "heuristic", "status": "feasible", "objective": 3}])
        rows = store.frame(problem="cells")
    assert set(rows["method"]) == {"task", "greedy"}


def test_gap_with_methods_exits_1_on_error_rows(tmp_path, monkeypatch, capsys):
    from droneplan.studies.cli import main

    _write(tmp_path / "hostile_raiser.py", "def fails(*a, seed, time_limit):\n    raise RuntimeError('no')\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    code = main(
        [
            "gap",
            "herding",
            "--method",
            "hostile_raiser:fails",
            "--n",
            "3",
            "--seeds",
            "1",
            "--out",
            str(tmp_path / "o"),
        ]
    )
    assert code == 1 and "ended in an error row" in capsys.readouterr().err


def test_ctrl_c_during_certify_is_one_line_and_130(monkeypatch, capsys):
    from droneplan.studies import cli

    def interrupted(args):
        raise KeyboardInterrupt

    monkeypatch.setattr(cli, "_run_certify", interrupted)
    assert cli.main(["certify", "allocation"]) == 130
    err = capsys.readouterr().err
    assert "interrupted" in err and "Traceback" not in err


_CLI_STUDY = textwrap.dedent(
    """
    import sys, time

    def sleeper(*args, seed, time_limit):
        open(sys.argv[1], "w").write("started")
        time.sleep(120)
    """
)


@pytest.mark.parametrize(("sig", "code"), [(signal.SIGTERM, 143), (signal.SIGHUP, 129)])
def test_sigterm_and_sighup_stop_the_cli_as_ctrl_c_does(tmp_path, sig, code):
    (tmp_path / "hostile_sleeper.py").write_text(
        _CLI_STUDY.replace("sys.argv[1]", repr(str(tmp_path / "go")))
    )
    env = {**os.environ, "PYTHONPATH": str(tmp_path)}
    cmd = [
        sys.executable,
        "-c",
        "import sys; from droneplan.studies.cli import main; sys.exit(main())",
        "gap",
        "herding",
        "--method",
        "hostile_sleeper:sleeper",
        "--n",
        "3",
        "--seeds",
        "1",
        "--out",
        str(tmp_path / "o"),
        "--time-limit",
        "600",
    ]
    proc = subprocess.Popen(cmd, env=env, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 90
    while not (tmp_path / "go").exists() and time.monotonic() < deadline:
        time.sleep(0.1)
    proc.send_signal(sig)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == code
    assert f"stopped by {sig.name}" in err and "Traceback" not in err


def test_the_cli_memory_cap_is_configurable(tmp_path, monkeypatch, capsys):
    from droneplan.studies.cli import main

    _write(
        tmp_path / "hostile_greedy.py",
        "import numpy as np\n"
        "def big(*a, seed, time_limit):\n    return np.ones(3 << 30, dtype=np.uint8)[:0]\n",
    )
    monkeypatch.syspath_prepend(str(tmp_path))
    argv = ["gap", "herding", "--method", "hostile_greedy:big", "--n", "3", "--seeds", "1"]
    assert main([*argv, "--out", str(tmp_path / "o"), "--memory-limit", "1"]) == 1
    df = droneplan.load_results(tmp_path / "o")
    assert "MemoryError" in df.loc[df["method"] == "hostile_greedy:big", "message"].iloc[0]
    with pytest.raises(SystemExit, match="--memory-limit must be > 0"):
        main([*argv, "--out", str(tmp_path / "p"), "--memory-limit", "0"])
