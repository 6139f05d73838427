"""Open gap studies end to end: user methods that misbehave in every way, reruns, the library, the CLI."""

from __future__ import annotations

import sys
import textwrap
import time

import numpy as np
import pandas as pd
import pytest

import droneplan
from droneplan.formulations.herding import solve_allocation
from droneplan.solvers.result import SolveResult, Status
from droneplan.studies.cli import main
from droneplan.studies.library import load_library
from droneplan.studies.methods import Method


# --------------------------------------------------------------------------- user methods
def good_alloc(drone_s, steer_s, perimeter, *, seed, time_limit):
    res = solve_allocation(drone_s, steer_s, perimeter)
    return res.x.target, res.x.direction


def identity_alloc(drone_s, steer_s, perimeter, *, seed, time_limit):
    n = len(drone_s)
    return np.arange(n), np.ones(n, dtype=int)


def sleepy(*args, seed, time_limit):
    time.sleep(60)


def raises(*args, seed, time_limit):
    raise ZeroDivisionError("my heuristic divided by zero")


def wrong_type(*args, seed, time_limit):
    return {"target": 1}


def boasting_alloc(drone_s, steer_s, perimeter, *, seed, time_limit):
    res = solve_allocation(drone_s, steer_s, perimeter)
    return SolveResult(Status.OPTIMAL, objective=np.float32(-1.0), bound=-1.0, x=res.x)


def test_user_allocation_methods_are_scored_independently(tmp_path):
    methods = [
        ("good", good_alloc),
        ("identity", identity_alloc),
        ("sleepy", sleepy),
        ("raises", raises),
        ("wrong-type", wrong_type),
        ("boasting", boasting_alloc),
    ]
    t0 = time.perf_counter()
    df = droneplan.gap("herding", methods=methods, n=[4, 6], seeds=2, out=tmp_path, time_limit=1.0, workers=2)
    assert time.perf_counter() - t0 < 45  # four sleepy jobs, each stopped near its 1 s limit
    status = df.groupby("method")["status"].agg(lambda s: set(s))
    assert status["good"] == {"feasible"}
    assert status["sleepy"] == {"timeout"} and status["raises"] == {"error"}
    assert status["wrong-type"] == {"invalid"}
    assert status["identity"] <= {"feasible", "infeasible"}
    assert (df.loc[df["method"] == "raises", "message"].str.contains("divided by zero")).all()
    assert df.loc[df["method"] == "raises", "herding_traceback"].str.contains("in raises").all()
    # the library reference is there for every instance, and "good" meets it
    lib = df[df["method"] == "library"].set_index("instance")["objective"]
    good = df[df["method"] == "good"].set_index("instance")["objective"]
    assert len(lib) == 4 and np.allclose(good, lib.reindex(good.index))
    assert (df.loc[df["method"] == "good", "gap_to_bound"].abs() < 1e-9).all()
    # a claim is kept apart, flagged, and never believed
    boast = df[df["method"] == "boasting"]
    assert (boast["claimed_objective"] == -1.0).all() and boast["flag"].str.contains("claim-mismatch").all()
    assert boast["bound"].isna().all() and (boast["status"] == "feasible").all()
    # provenance and the configuration hash in every row
    ran = df[df["method"] != "library"]
    for col in (
        "config",
        "droneplan_version",
        "code_hash",
        "packages",
        "cpu",
        "cores",
        "family_version",
        "finished_at",
    ):
        assert ran[col].notna().all(), col
    for col in (
        "config",
        "droneplan_version",
        "finished_at",
        "family_version",
    ):  # the library's own provenance
        assert df.loc[df["method"] == "library", col].notna().all(), col
    assert (tmp_path / "results.parquet").exists() and (tmp_path / "results.csv").exists()
    pq = pd.read_parquet(tmp_path / "results.parquet")
    assert len(pq) == len(droneplan.load_results(tmp_path))


def test_rerun_resumes_changed_settings_recompute_and_new_methods_keep_rows(tmp_path, capsys):
    kw = dict(n=4, seeds=2, out=tmp_path, workers=1, progress=False)
    first = droneplan.gap("herding", methods=["exact", ("mine", identity_alloc)], time_limit=5, **kw)
    capsys.readouterr()
    again = droneplan.gap("herding", methods=["exact", ("mine", identity_alloc)], time_limit=5, **kw)
    assert "0 of 4 jobs run" in capsys.readouterr().err
    pd.testing.assert_frame_equal(
        first.sort_values(["instance", "method"]).reset_index(drop=True)[
            ["instance", "method", "config", "objective"]
        ],
        again.sort_values(["instance", "method"]).reset_index(drop=True)[
            ["instance", "method", "config", "objective"]
        ],
    )
    # other settings: new rows, the old ones set aside (not current, not lost)
    changed = droneplan.gap("herding", methods=["exact", ("mine", identity_alloc)], time_limit=7, **kw)
    err = capsys.readouterr().err
    assert "4 of 4 jobs run" in err and "4 older rows computed under other settings set aside" in err
    assert set(changed["config"]) & set(first["config"]) == set(first[first["method"] == "library"]["config"])
    assert (changed.loc[changed["method"] != "library", "time_limit_s"] == 7).all()
    everything = droneplan.load_results(tmp_path, include_superseded=True)
    assert len(everything) == len(changed) + 4
    # a new method on the same instances keeps every existing row
    droneplan.gap("herding", methods=["alg3"], time_limit=7, **kw)
    now = droneplan.load_results(tmp_path)
    assert {"exact", "mine", "alg3", "library"} == set(now["method"])
    assert len(now) == len(changed) + 2


def test_a_changed_user_method_is_recomputed(tmp_path, capsys):
    mod = tmp_path / "user_heuristics_mod.py"
    mod.write_text(
        "import numpy as np\n"
        "def h(d, s, M, *, seed, time_limit):\n"
        "    return np.arange(len(d)), np.ones(len(d), int)\n"
    )
    sys.path.insert(0, str(tmp_path))
    try:
        droneplan.gap("herding", methods=["user_heuristics_mod:h"], n=3, out=tmp_path / "o", progress=False)
        mod.write_text(mod.read_text().replace("np.ones(len(d), int)", "-np.ones(len(d), int)"))
        sys.modules.pop("user_heuristics_mod", None)
        capsys.readouterr()
        droneplan.gap("herding", methods=["user_heuristics_mod:h"], n=3, out=tmp_path / "o", progress=False)
        assert "1 older rows computed under other settings set aside" in capsys.readouterr().err
    finally:
        sys.path.remove(str(tmp_path))
        sys.modules.pop("user_heuristics_mod", None)


def test_cells_user_methods_against_the_library(tmp_path):
    entries = load_library("table4.2")
    if "table4.2@1:m=1,seed=0" not in entries:
        pytest.skip("the cells library holds no m=1 entries")

    def first_user(problem, *, seed, time_limit):
        return problem.users[problem.active][:1]

    def nan_plan(problem, *, seed, time_limit):
        return np.full((1, 2), np.nan)

    def too_many(problem, *, seed, time_limit):
        return np.array([[2000.0 * k, 3000.0] for k in range(problem.n_cells + 1)])

    df = droneplan.gap(
        "cells",
        methods=[first_user, nan_plan, too_many, "greedy"],
        m=1,
        seeds=2,
        out=tmp_path,
        workers=2,
        progress=False,
    )
    lib = df[df["method"] == "library"]
    assert len(lib) == 2 and (lib["status"] == "optimal").all()
    assert (df.loc[df["method"] == "nan_plan", "status"] == "invalid").all()
    too = df[df["method"] == "too_many"]
    assert (too["status"] == "invalid").all() and too["message"].str.contains("n_cells = 1").all()
    solved = df[df["status"].isin(["feasible", "optimal"])]
    # nothing verified beats the certified optimum, and gaps are measured against it
    assert (solved["objective"] <= solved["instance"].map(lib.set_index("instance")["bound"]) + 1e-9).all()
    assert (solved["gap_to_bound"] >= -1e-12).all()


def test_instances_from_files_and_objects(tmp_path):
    from droneplan.studies.instances import AllocationInstance, family_instances, save_instance

    inst = family_instances("allocation", n=5, seeds=[3])[0]
    save_instance(inst, tmp_path / "mine.json")
    df = droneplan.gap(
        "herding", methods=["exact"], instances=tmp_path / "mine.json", out=tmp_path / "a", progress=False
    )
    assert set(df["instance"]) == {inst.id} and "library" in set(df["method"])
    own = AllocationInstance(np.array([1.0, 5.0]), np.array([2.0, 9.0]), 10.0)
    df = droneplan.gap(
        "herding", methods=["exact", "alg3"], instances=[own], out=tmp_path / "b", progress=False
    )
    assert df["instance"].str.startswith("user:").all() and set(df["method"]) == {"exact", "alg3"}
    assert df["objective"].nunique() == 1


def test_bad_study_arguments(tmp_path):
    with pytest.raises(ValueError, match="unknown method"):
        droneplan.gap("cells", methods=["nope"], out=tmp_path)
    with pytest.raises(ValueError, match=r"unknown instance family|neither an instance family"):
        droneplan.gap("cells", methods=["greedy"], instances="table9.9", out=tmp_path)
    with pytest.raises(ValueError, match="problem must be one of"):
        droneplan.gap("sheep", methods=["greedy"], out=tmp_path)
    with pytest.raises(ValueError, match="time_limit"):
        droneplan.gap("cells", methods=["greedy"], out=tmp_path, time_limit=-1)
    with pytest.raises(ValueError, match="reserved"):
        droneplan.gap("herding", methods=[("library", identity_alloc)], n=3, out=tmp_path)


def test_cli_open_study_and_its_errors(tmp_path, capsys, monkeypatch):
    pkg = tmp_path / "pkg"
    pkg.mkdir()
    (pkg / "cli_user_mod.py").write_text(
        textwrap.dedent(
            """
            import numpy as np
            def mine(d, s, M, *, seed, time_limit):
                return np.arange(len(d)), np.ones(len(d), int)
            """
        )
    )
    monkeypatch.syspath_prepend(str(pkg))
    out = tmp_path / "out"
    args = [
        "gap",
        "herding",
        "--n",
        "4,5",
        "--seeds",
        "2",
        "--method",
        "exact",
        "--method",
        "cli_user_mod:mine",
    ]
    rc = main([*args, "--time-limit", "10", "--workers", "1", "--out", str(out)])
    assert rc == 0
    text = capsys.readouterr().out
    assert "cli_user_mod:mine" in text and (out / "herding" / "gap_profile_objective.png").exists()
    assert len(droneplan.load_results(out)) == 4 * 3
    assert main(["gap", "herding", "--method", "no_such_mod_abc:f", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "cannot import module" in err
    assert main(["gap", "cells", "--method", "greedy", "--instances", "table0", "--out", str(out)]) == 2
    assert "neither an instance family" in capsys.readouterr().err
    bad = tmp_path / "bad.json"
    bad.write_text("{")
    assert main(["gap", "cells", "--method", "greedy", "--instances", str(bad), "--out", str(out)]) == 2
    assert "not a readable instance file" in capsys.readouterr().err
    assert main(["list"]) == 0
    assert "table4.2@1" in capsys.readouterr().out


def test_cli_certify_writes_and_resumes_a_library(tmp_path, capsys):
    args = [
        "certify",
        "allocation",
        "--n",
        "3,4",
        "--seeds",
        "2",
        "--workers",
        "1",
        "--library-dir",
        str(tmp_path),
    ]
    assert main(args) == 0
    assert "4 certified now, 4 entries (4 proven optimal)" in capsys.readouterr().out
    assert load_library("allocation", tmp_path).keys() == {
        f"allocation@1:n={n},seed={s}" for n in (3, 4) for s in (0, 1)
    }
    assert main(args) == 0
    assert "0 certified now, 4 entries" in capsys.readouterr().out
    assert main(["certify", "table6.2", "--library-dir", str(tmp_path)]) == 2
    assert "no certified library" in capsys.readouterr().err


def _slow_identity(drone_s, steer_s, perimeter, *, seed, time_limit, log=""):
    with open(log, "a") as fh:  # one line per call: the test counts the work done
        fh.write(f"{seed} {len(drone_s)}\n")
    time.sleep(0.3)
    return identity_alloc(drone_s, steer_s, perimeter, seed=seed, time_limit=time_limit)


def test_two_runs_on_one_out_share_the_work(tmp_path):
    import multiprocessing as mp

    log = tmp_path / "calls.txt"
    method = Method("slow", _slow_identity, params={"log": str(log)})

    def run() -> None:
        droneplan.gap(
            "herding", methods=[method], n=[3, 4], seeds=4, out=tmp_path / "o", workers=1, progress=False
        )

    ctx = mp.get_context("fork")
    procs = [ctx.Process(target=run) for _ in range(2)]
    for p in procs:
        p.start()
    for p in procs:
        p.join(120)
        assert p.exitcode == 0
    calls = log.read_text().splitlines()
    assert len(calls) == 8 and len(set(calls)) == 8  # every job once, none twice
    df = droneplan.load_results(tmp_path / "o")
    assert (df["method"] == "slow").sum() == 8 and not df.duplicated(["instance", "method"]).any()
