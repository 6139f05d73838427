"""Provenance of result rows: package/code/library versions, git state, configuration hashes."""

from __future__ import annotations

import datetime as dt
import hashlib
import json
import re
import shutil
import subprocess
import time

import numpy as np
import pytest

from droneplan.studies import provenance as prov
from droneplan.studies.provenance import config_hash, provenance, provenance_columns


def test_provenance_fields_and_cache():
    p = provenance()
    assert set(p) == {"droneplan_version", "git_commit", "code_hash", "packages", "cpu", "cores"}
    import droneplan

    assert p["droneplan_version"] == droneplan.__version__
    assert re.fullmatch(r"[0-9a-f]{16}", p["code_hash"])
    assert set(p["packages"]) == set(prov.PACKAGES)
    assert p["packages"]["numpy"] == np.__version__
    assert p["cores"] == __import__("os").cpu_count() and p["cpu"]
    p["packages"]["numpy"] = "mutated"  # a copy: the cached value is untouched
    assert provenance()["packages"]["numpy"] == np.__version__
    t0 = time.perf_counter()
    provenance()
    assert time.perf_counter() - t0 < 0.05  # cached


def test_versions_come_from_metadata_without_importing(monkeypatch):
    import builtins
    import importlib

    asked = []
    real_import, real_import_module = builtins.__import__, importlib.import_module

    def spy_import(name, *args, **kwargs):
        asked.append(name)
        return real_import(name, *args, **kwargs)

    def spy_import_module(name, *args, **kwargs):
        asked.append(name)
        return real_import_module(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", spy_import)
    monkeypatch.setattr(importlib, "import_module", spy_import_module)
    fresh = prov._provenance.__wrapped__()  # uncached
    monkeypatch.undo()
    assert fresh["packages"]["scipy"] is not None
    assert not {n.split(".")[0] for n in asked} & set(prov.PACKAGES), asked


def test_code_hash_is_sha256_over_sorted_sources(tmp_path, monkeypatch):
    a, b = tmp_path / "a", tmp_path / "b"
    (a / "sub").mkdir(parents=True)
    b.mkdir()
    (a / "__init__.py").write_bytes(b"x = 1\n")
    (a / "sub" / "m.py").write_bytes(b"y = 2\n")
    (a / "notes.txt").write_text("ignored")
    (b / "__init__.py").write_bytes(b"")
    monkeypatch.setattr(prov, "_package_dirs", lambda: {"droneplan": a, "droneplan.studies": b})
    h = hashlib.sha256()
    for rel, data in sorted(
        {
            "droneplan/__init__.py": b"x = 1\n",
            "droneplan/sub/m.py": b"y = 2\n",
            "droneplan/studies/__init__.py": b"",
        }.items()
    ):
        h.update(rel.encode() + b"\0" + str(len(data)).encode() + b"\0" + data)
    assert prov._code_hash() == h.hexdigest()[:16]
    first = prov._code_hash()
    (a / "sub" / "m.py").write_bytes(b"y = 3\n")  # any source change changes the hash
    assert prov._code_hash() != first


@pytest.mark.skipif(shutil.which("git") is None, reason="needs git")
def test_git_commit_clean_dirty_and_not_a_checkout(tmp_path):
    repo = tmp_path / "repo"
    repo.mkdir()
    (repo / "mod.py").write_text("a = 1\n")

    def git(*args):
        subprocess.run(
            ["git", "-c", "user.name=t", "-c", "user.email=t@t", *args],
            cwd=repo,
            check=True,
            capture_output=True,
        )

    git("init", "-q")
    assert prov._git_commit(repo, "mod.py") is None  # untracked: not a checkout of this source
    git("add", "mod.py")
    git("commit", "-qm", "one")
    head = subprocess.run(
        ["git", "rev-parse", "HEAD"], cwd=repo, capture_output=True, text=True
    ).stdout.strip()
    (repo / "new.txt").write_text("untracked files do not make it dirty")
    t0 = time.perf_counter()
    assert prov._git_commit(repo, "mod.py") == head
    assert time.perf_counter() - t0 < 0.5
    (repo / "mod.py").write_text("a = 2\n")
    assert prov._git_commit(repo, "mod.py") == head + "-dirty"
    plain = tmp_path / "plain"
    plain.mkdir()
    (plain / "mod.py").write_text("")
    assert prov._git_commit(plain, "mod.py") is None


def test_git_missing_or_hanging_gives_none(tmp_path, monkeypatch):
    monkeypatch.setenv("PATH", str(tmp_path))  # no git on PATH
    assert prov._git_commit(tmp_path, "x.py") is None
    slow = tmp_path / "git"
    slow.write_text("#!/bin/sh\nsleep 5\n")
    slow.chmod(0o755)
    t0 = time.perf_counter()
    assert prov._git_commit(tmp_path, "x.py") is None
    assert time.perf_counter() - t0 < 1.0


def test_config_hash_canonical_json():
    base = {"seed": 3, "sizes": (1, 2), "w": 0.1, "nested": {"b": True, "a": None}}
    h = config_hash(base)
    assert re.fullmatch(r"[0-9a-f]{16}", h)
    # key order, tuples vs lists, numpy scalars and arrays do not matter
    same = {
        "nested": {"a": None, "b": np.bool_(True)},
        "w": np.float64(0.1),
        "sizes": np.array([1, 2]),
        "seed": np.int64(3),
    }
    assert config_hash(same) == h
    expected = '{"nested":{"a":null,"b":true},"seed":3,"sizes":[1,2],"w":0.1}'
    assert h == hashlib.sha256(expected.encode()).hexdigest()[:16]
    assert config_hash({**base, "w": 1 / 10}) == h  # the same float, computed
    assert config_hash({**base, "w": 0.10000000000000002}) != h  # repr keeps every digit
    assert config_hash({**base, "seed": 3.0}) != h  # int and float differ
    assert config_hash(np.float32(0.1)) == config_hash(float(np.float32(0.1)))


def test_config_hash_rejects_other_types_by_name():
    with pytest.raises(TypeError, match=r"set.*at x"):
        config_hash({"x": {1, 2}})
    with pytest.raises(TypeError, match="PosixPath"):
        config_hash([__import__("pathlib").Path("a")])
    with pytest.raises(TypeError, match="key 1"):
        config_hash({1: "a"})


def test_provenance_columns():
    cols = provenance_columns()
    assert list(cols) == [
        "droneplan_version",
        "git_commit",
        "code_hash",
        "packages",
        "cpu",
        "cores",
        "finished_at",
    ]
    assert json.loads(cols["packages"]) == provenance()["packages"]
    when = dt.datetime.fromisoformat(cols["finished_at"])
    assert when.tzinfo is not None and abs((dt.datetime.now(dt.UTC) - when).total_seconds()) < 5
    assert provenance_columns(finished_at="x", family="f")["finished_at"] == "x"
