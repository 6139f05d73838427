"""Certification on a Dask LocalCluster: the instances run on the workers, the library file is
written by this process under its lock after each instance, with the same entries as a local run;
an interrupted run resumes; an address that does not answer is one line naming ``--dask``."""

from __future__ import annotations

import dataclasses
import socket
import threading

import pytest

import droneplan.studies.library.certify as certify_module
from droneplan.studies.cli import main
from droneplan.studies.common import StudyError, make_executor
from droneplan.studies.library import library_path, load_library
from droneplan.studies.library.certify import certify, verify
from droneplan.studies.library.cross import cross_certify

distributed = pytest.importorskip("distributed")
pytestmark = pytest.mark.slow  # a cluster per module, seconds per test: CI runs them with the Dask tests

SIZE = {"n": 4, "seeds": 3}  # allocation n = 4, seeds 0-2: each certifies in well under a second
PROVENANCE = {"time_s", "certified_at", "droneplan_version", "git_commit", "code_hash", "packages", "cpu"}
PROVENANCE |= {"cores"}


def _entries(directory) -> dict[str, dict]:
    """The library entries of ``allocation`` in ``directory`` without their times and provenance."""
    return {
        k: {f: v for f, v in dataclasses.asdict(e).items() if f not in PROVENANCE}
        for k, e in load_library("allocation", directory).items()
    }


def _ran_on_cluster(cluster, fn: str) -> int:
    """How many tasks calling ``fn`` the cluster's workers have finished so far."""
    prefix = cluster.scheduler.task_prefixes.get(fn)
    return 0 if prefix is None else prefix.state_counts["memory"]


def _writes(monkeypatch) -> list[tuple[list[str], bool]]:
    """Record each library write certify makes: the ids written and whether the main thread of
    this process made it."""
    seen: list[tuple[list[str], bool]] = []
    real = certify_module.save_library

    def spy(family, entries, directory=None, *, merge=False):
        seen.append((sorted(entries), threading.current_thread() is threading.main_thread()))
        return real(family, entries, directory, merge=merge)

    monkeypatch.setattr(certify_module, "save_library", spy)
    return seen


def test_a_cluster_certifies_the_same_entries_as_a_local_run(tmp_path, cluster, monkeypatch):
    local = certify("allocation", workers=2, directory=tmp_path / "local", progress=False, **SIZE)
    writes = _writes(monkeypatch)
    ran = _ran_on_cluster(cluster, "run_isolated")
    on_dask = certify(
        "allocation", dask=cluster.scheduler_address, directory=tmp_path / "dask", progress=False, **SIZE
    )
    assert _ran_on_cluster(cluster, "run_isolated") == ran + 3  # each instance on a worker
    assert on_dask["certified"] == local["certified"] == 3 and not on_dask["failed"]
    assert on_dask["proven"] == local["proven"] == 3
    assert _entries(tmp_path / "dask") == _entries(tmp_path / "local")
    # one write per instance, each of one entry, all by this process's main thread (the client)
    assert len(writes) == 3 and all(len(ids) == 1 and main for ids, main in writes)
    assert sorted(i for ids, _ in writes for i in ids) == sorted(_entries(tmp_path / "local"))
    for e in load_library("allocation", tmp_path / "dask").values():
        assert e.certified_at and e.code_hash and e.droneplan_version


def test_an_executor_of_make_executor_runs_certify_and_verify(tmp_path, cluster):
    with make_executor(dask_address=cluster.scheduler_address) as ex:
        summary = certify("allocation", executor=ex, directory=tmp_path, progress=False, n=4, seeds=2)
        checked = verify("allocation", executor=ex, directory=tmp_path, progress=False)
    assert summary["certified"] == 2 and summary["entries"] == 2
    assert checked["checked"] == 2 and checked["failed"] == []


def test_an_interrupted_cluster_run_resumes_where_it_stopped(tmp_path, cluster, monkeypatch):
    real = certify_module.save_library

    def stop_after_first(family, entries, directory=None, *, merge=False):
        real(family, entries, directory, merge=merge)
        raise KeyboardInterrupt  # Ctrl-C right after the first entry is on disk

    monkeypatch.setattr(certify_module, "save_library", stop_after_first)
    with pytest.raises(KeyboardInterrupt):
        certify("allocation", dask=cluster.scheduler_address, directory=tmp_path, progress=False, **SIZE)
    first = load_library("allocation", tmp_path)
    assert len(first) == 1
    monkeypatch.setattr(certify_module, "save_library", real)
    writes = _writes(monkeypatch)
    resumed = certify(
        "allocation", dask=cluster.scheduler_address, directory=tmp_path, progress=False, **SIZE
    )
    assert resumed["certified"] == 2 and resumed["entries"] == 3 and not resumed["failed"]
    assert not set(first) & {i for ids, _ in writes for i in ids}  # the finished entry was not redone
    after = load_library("allocation", tmp_path)
    assert {k: after[k] for k in first} == first
    again = certify("allocation", dask=cluster.scheduler_address, directory=tmp_path, progress=False, **SIZE)
    assert again["certified"] == 0 and again["path"] is None and again["entries"] == 3


def test_the_cli_certifies_and_verifies_on_a_cluster(tmp_path, cluster, capsys):
    argv = ["certify", "allocation", "--n", "4", "--seeds", "3", "--library-dir", str(tmp_path)]
    assert main([*argv, "--dask", cluster.scheduler_address]) == 0
    assert "3 certified now, 3 entries (3 proven optimal)" in capsys.readouterr().out
    assert main([*argv, "--verify", "--dask", cluster.scheduler_address]) == 0
    assert "3 entries re-proven" in capsys.readouterr().out
    with pytest.raises(SystemExit):  # one place to run: --workers or --dask
        main([*argv, "--workers", "2", "--dask", cluster.scheduler_address])
    assert "not allowed with argument" in capsys.readouterr().err


def test_cross_certify_on_a_cluster_gives_the_local_summary(tmp_path, cluster):
    kw = {"m": [1], "seeds": 2, "time_limit": 30, "directory": tmp_path / "bad"}
    local = cross_certify("table4.2", log=tmp_path / "local.jsonl", **kw)
    ran = _ran_on_cluster(cluster, "run_engines")
    on_dask = cross_certify("table4.2", dask=cluster.scheduler_address, log=tmp_path / "dask.jsonl", **kw)
    counts = ("instances", "both_proven", "bnb_proven", "milp_proven", "library_matched", "disagreements")
    assert {k: on_dask[k] for k in counts} == {k: local[k] for k in counts}
    assert on_dask["instances"] == 2 and on_dask["library_matched"] == 2
    assert _ran_on_cluster(cluster, "run_engines") == ran + 2
    assert len((tmp_path / "dask.jsonl").read_text().splitlines()) == 2
    assert not (tmp_path / "bad").exists()


def test_the_cross_certify_cli_runs_on_a_cluster(tmp_path, cluster, capsys):
    argv = ["cross-certify", "table4.2", "--m", "1", "--seeds", "1", "--out", str(tmp_path / "bad")]
    assert main([*argv, "--dask", cluster.scheduler_address]) == 0
    assert "1 instances; both engines proved 1" in capsys.readouterr().out


# --------------------------------------------------------------------------- addresses that do not answer
@pytest.fixture
def silent_peer():
    """The address of a port that accepts connections and never answers."""
    server = socket.socket()
    server.bind(("127.0.0.1", 0))
    server.listen(8)
    yield f"tcp://127.0.0.1:{server.getsockname()[1]}"
    server.close()


@pytest.fixture
def closed_port() -> str:
    """The address of a port nothing listens on."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    return f"tcp://127.0.0.1:{port}"


@pytest.mark.parametrize("peer", ["silent_peer", "closed_port"])
@pytest.mark.parametrize("command", ["certify", "verify", "cross-certify"])
def test_an_address_that_does_not_answer_is_one_line_naming_dask(tmp_path, capsys, request, peer, command):
    address = request.getfixturevalue(peer)
    lib = tmp_path / "lib"
    if command == "cross-certify":
        argv = ["cross-certify", "table4.2", "--m", "1", "--seeds", "1", "--out", str(tmp_path / "bad")]
        argv += ["--log", str(tmp_path / "log.jsonl"), "--library-dir", str(lib)]
    else:
        argv = ["certify", "allocation", "--n", "4", "--seeds", "1", "--library-dir", str(lib)]
        argv += ["--verify"] if command == "verify" else []
    assert main([*argv, "--dask", address]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and err.startswith("droneplan: --dask: ") and address in err
    assert "Traceback" not in err
    assert not list(tmp_path.rglob("*.json*")) and not library_path("allocation", lib).exists()


def test_the_python_functions_name_dask_and_write_nothing(tmp_path, closed_port):
    with pytest.raises(StudyError, match=r"^dask: cannot reach the Dask scheduler"):
        certify("allocation", dask=closed_port, directory=tmp_path, progress=False, n=4, seeds=1)
    with pytest.raises(StudyError, match=r"^dask: "):
        cross_certify("table4.2", m=1, seeds=1, dask=closed_port, directory=tmp_path, log=tmp_path / "l")
    assert not list(tmp_path.iterdir())


@pytest.mark.parametrize(
    ("kw", "words"),
    [
        ({"dask": 8786}, "dask must be"),
        ({"dask": " "}, "dask must be a scheduler address"),
        ({"executor": "tcp://x:1"}, "executor must be"),
    ],
)
def test_bad_cluster_options_are_refused_by_name(tmp_path, kw, words):
    with pytest.raises((TypeError, ValueError), match=words):
        certify("allocation", directory=tmp_path, progress=False, n=4, seeds=1, **kw)
    assert not list(tmp_path.iterdir())
