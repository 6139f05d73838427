"""Inputs a hostile or careless user hands the study machinery: peers that are not Dask schedulers,
forged library entries, truncated or exploding files, stale claims, edited stores, decimal commas.

Each is a one-line error with a clear exit code, or an honest result, never a traceback, a hang or
a silently wrong number.
"""

from __future__ import annotations

import dataclasses
import gzip
import json
import os
import socket
import stat
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

import droneplan
from droneplan.studies import study as study_module
from droneplan.studies.common import StudyError, make_executor
from droneplan.studies.instances import InstanceFileError, family_instances, load_instance, save_instance
from droneplan.studies.library import (
    LibraryFileError,
    library_instances,
    load_library,
    save_library,
)
from droneplan.studies.library.certify import verify
from droneplan.studies.store import LIBRARY_SUSPECT, ResultStore, StoreError


# ----------------------------------------------------------------- Dask peers that are not schedulers
def _peer(mode: str) -> tuple[socket.socket, int]:
    server = socket.socket()
    server.bind(("127.0.0.1", 0))
    server.listen(8)
    held: list[socket.socket] = []

    def serve() -> None:
        while True:
            try:
                conn, _ = server.accept()
            except OSError:
                return
            held.append(conn)
            if mode == "http":
                conn.recv(1024)
                conn.sendall(b"HTTP/1.1 200 OK\r\nContent-Length: 2\r\n\r\nok")
            elif mode == "garbage":
                conn.sendall(b"\xff" * 64)

    threading.Thread(target=serve, daemon=True).start()
    return server, server.getsockname()[1]


@pytest.mark.parametrize("mode", ["silent", "http", "garbage"])
def test_a_peer_that_is_not_a_scheduler_fails_in_seconds(mode):
    server, port = _peer(mode)
    try:
        t0 = time.monotonic()
        with (
            pytest.raises(StudyError) as info,
            make_executor(dask_address=f"tcp://127.0.0.1:{port}", connect_timeout=2.0),
        ):
            pytest.fail("an executor was made for a peer that is not a Dask scheduler")
        assert time.monotonic() - t0 < 10
        assert "\n" not in str(info.value) and f"127.0.0.1:{port}" in str(info.value)
    finally:
        server.close()


def test_the_cli_gives_one_line_and_exit_2_for_a_silent_peer(tmp_path):
    server, port = _peer("silent")
    try:
        cmd = [
            sys.executable,
            "-c",
            "import sys; from droneplan.studies.cli import main; sys.exit(main())",
            "gap",
            "herding",
            "--method",
            "alg3",
            "--n",
            "3",
            "--seeds",
            "1",
            "--out",
            str(tmp_path),
            "--dask",
            f"tcp://127.0.0.1:{port}",
        ]
        proc = subprocess.run(cmd, capture_output=True, text=True, timeout=60)
    finally:
        server.close()
    assert proc.returncode == 2
    assert "Traceback" not in proc.stderr and "Exception ignored" not in proc.stderr
    assert "Dask scheduler" in proc.stderr


# --------------------------------------------------------------------------- the library checks itself
def _forged(entry):
    """A worse but feasible plan's value, marked optimal with value = bound (cells: one user fewer)."""
    return dataclasses.replace(entry, value=entry.value - 1, bound=entry.value - 1, status="optimal")


def test_a_study_marks_a_library_entry_a_verified_plan_beats_as_suspect(tmp_path, monkeypatch, capsys):
    real = study_module.lookup
    monkeypatch.setattr(study_module, "lookup", lambda inst: _forged(real(inst)))
    df = droneplan.gap("cells", methods=["bnb"], m=2, seeds=1, out=tmp_path, progress=False)
    lib = df[df["method"] == "library"].iloc[0]
    bnb = df[df["method"] == "bnb"].iloc[0]
    assert LIBRARY_SUSPECT in lib["flag"]
    assert "beats-bound" not in str(bnb["flag"]) and bnb["gap_to_bound"] == 0.0  # its own proven bound
    assert "is suspect" in capsys.readouterr().err


def test_verify_finds_a_forged_entry_and_passes_the_real_ones(tmp_path):
    entries = load_library("allocation")
    ids = [inst.id for inst in library_instances("allocation", n=[2, 3], seeds=2)]
    kept = {i: entries[i] for i in ids}
    forged_id = ids[0]
    e = kept[forged_id]
    kept[forged_id] = dataclasses.replace(e, value=e.value + 10.0, bound=e.value + 10.0)  # min: worse
    save_library("allocation", kept, tmp_path)
    summary = verify("allocation", directory=tmp_path, time_limit=60, workers=1, progress=False)
    assert summary["checked"] == len(ids)
    assert len(summary["failed"]) == 1 and summary["failed"][0].startswith(forged_id)
    assert "beats the stored bound" in summary["failed"][0]


def test_library_files_are_readable_by_others(tmp_path):
    entries = dict(list(load_library("allocation").items())[:2])
    path = save_library("allocation", entries, tmp_path)
    umask = os.umask(0)
    os.umask(umask)
    assert stat.S_IMODE(path.stat().st_mode) == 0o666 & ~umask


def _library_doc(path: Path) -> dict:
    return json.loads(gzip.decompress(path.read_bytes()))


@pytest.mark.parametrize(
    ("damage", "words"),
    [
        (lambda p: p.write_bytes(p.read_bytes()[: len(p.read_bytes()) // 2]), "truncated gzip"),
        (lambda p: p.write_bytes(b"not gzip at all"), "not a readable gzip file"),
        (
            lambda p: p.write_bytes(
                gzip.compress(
                    json.dumps(
                        {**_library_doc(p), "entries": [{**_library_doc(p)["entries"][0], "x": 1}]}
                    ).encode()
                )
            ),
            "unknown fields ['x']",
        ),
        (lambda p: p.write_bytes(gzip.compress(b"[" * 200_000 + b"]" * 200_000)), "nested too deeply"),
    ],
)
def test_a_damaged_library_file_is_one_line(tmp_path, damage, words):
    path = save_library("allocation", dict(list(load_library("allocation").items())[:2]), tmp_path)
    damage(path)
    with pytest.raises(LibraryFileError, match=None) as info:
        load_library("allocation", tmp_path)
    assert words in str(info.value) and "\n" not in str(info.value) and str(path) in str(info.value)


# --------------------------------------------------------------------------- instance files
def test_truncated_and_nested_instance_files_are_one_line(tmp_path):
    inst = family_instances("table4.2", m=1, seeds=1)[0]
    gz = save_instance(inst, tmp_path / "a.json.gz")
    gz.write_bytes(gz.read_bytes()[:40])
    with pytest.raises(InstanceFileError, match="truncated gzip"):
        load_instance(gz)
    nested = tmp_path / "b.json"
    nested.write_text("[" * 200_000 + "]" * 200_000)
    with pytest.raises(InstanceFileError, match="nested too deeply"):
        load_instance(nested)


def test_a_gzip_bomb_is_refused_while_it_expands(tmp_path, monkeypatch):
    import droneplan.core.files as files

    bomb = tmp_path / "bomb.json.gz"
    bomb.write_bytes(gzip.compress(b" " * (64 << 20)))  # 64 MiB of spaces, 64 KiB on disk
    assert bomb.stat().st_size < 1 << 20
    with pytest.raises(files.JsonFileError, match="expands beyond"):
        files.read_json(bomb, max_bytes=8 << 20)


# --------------------------------------------------------------------------- the command line
def test_a_user_module_that_fails_to_import_is_one_line(tmp_path, monkeypatch):
    (tmp_path / "hostile_broken.py").write_text("raise RuntimeError('half-written module')\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    with pytest.raises(
        ValueError, match="importing module 'hostile_broken' raised RuntimeError: half-written"
    ):
        droneplan.gap(
            "herding", methods=["hostile_broken:fn"], n=3, seeds=1, out=tmp_path / "o", progress=False
        )


@pytest.mark.parametrize(
    ("argv", "words"),
    [
        (["certify", "allocation", "--n", "abc"], "n must be an int"),
        (
            ["certify", "allocation", "--n", "2", "--library-dir", "/proc/no-such-dir"],
            "not a writable directory",
        ),
    ],
)
def test_certify_refuses_bad_options_before_any_work(argv, words, capsys):
    from droneplan.studies.cli import main

    assert main(argv) == 2
    err = capsys.readouterr().err
    assert words in err and "Traceback" not in err


# --------------------------------------------------------------------------- the store
def test_a_store_whose_version_was_edited_to_1_is_refused_not_migrated(tmp_path):
    path = tmp_path / "results.sqlite"
    with ResultStore(path) as store:
        store.write(
            [{"problem": "cells", "instance": "i", "method": "m", "config": "c", "git_commit": "abc"}]
        )
    import sqlite3

    con = sqlite3.connect(path)
    con.execute("UPDATE meta SET value = '1' WHERE key = 'schema_version'")
    con.commit()
    con.close()
    with pytest.raises(StoreError, match="was its version edited"):
        ResultStore(path)


def test_a_claim_whose_pid_now_belongs_to_a_later_process_is_taken_over(tmp_path):
    import sqlite3

    path = tmp_path / "results.sqlite"
    key = ("cells", "i", "m", "c")
    later = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(30)"])
    try:
        with ResultStore(path) as store:
            assert store.try_claim(key)
        con = sqlite3.connect(path)  # the claim was made an hour ago by a process that is gone,
        con.execute(  # and the pid has since been reused by a live, unrelated process
            "UPDATE claims SET pid = ?, claimed_at = ?", (later.pid, time.time() - 3600)
        )
        con.commit()
        con.close()
        with ResultStore(path) as store:
            assert store.try_claim(key)
    finally:
        later.kill()


# --------------------------------------------------------------------------- users' data files
def test_decimal_commas_are_refused_not_misread(tmp_path):
    from droneplan.scenarios.loaders import read_points_csv

    path = tmp_path / "users.csv"
    path.write_text("x,y\n1.5,2.5\n1,5,2,5\n")
    with pytest.raises(ValueError, match=r"line 3: 4 fields, the header has 2 \(decimal commas"):
        read_points_csv(path)


def test_a_geojson_crs_other_than_wgs84_is_refused(tmp_path):
    from droneplan.scenarios.loaders import read_geojson_points

    doc = {
        "type": "FeatureCollection",
        "crs": {"type": "name", "properties": {"name": "urn:ogc:def:crs:EPSG::3857"}},
        "features": [{"type": "Feature", "geometry": {"type": "Point", "coordinates": [1000.0, 2000.0]}}],
    }
    path = tmp_path / "users.geojson"
    path.write_text(json.dumps(doc))
    with pytest.raises(ValueError, match="EPSG::3857"):
        read_geojson_points(path)
    doc["crs"]["properties"]["name"] = "urn:ogc:def:crs:OGC:1.3:CRS84"
    doc["features"][0]["geometry"]["coordinates"] = [10.0, 20.0]
    path.write_text(json.dumps(doc))
    lon, lat = read_geojson_points(path)
    assert lon.tolist() == [10.0] and lat.tolist() == [20.0]


@pytest.mark.parametrize(
    ("family", "params", "key"), [("table4.2", {"m": 1}, "users"), ("random-fleet", {}, "operators")]
)
def test_string_positions_in_an_instance_file_are_refused_not_parsed(tmp_path, family, params, key):
    """The cells and shark-fleet codecs converted with ``float()`` before the scenario's own check,
    so a file whose positions were quoted ("1.5") loaded as if they were numbers."""
    inst = family_instances(family, seeds=1, **params)[0]
    doc = inst.to_dict()
    doc["data"][key] = [[str(v) for v in row] for row in doc["data"][key]]
    path = tmp_path / "quoted.json"
    path.write_text(json.dumps(doc))
    with pytest.raises(InstanceFileError, match=f"{key} must be an array of real numbers"):
        load_instance(path)
    doc = inst.to_dict()  # the same file with numbers still loads, unchanged
    path.write_text(json.dumps(doc))
    assert load_instance(path).fingerprint() == inst.fingerprint()


def test_certify_verify_exits_1_on_a_forged_entry_and_0_on_real_ones(tmp_path, capsys):
    from droneplan.studies.cli import main

    entries = load_library("allocation")
    forged, honest = (inst.id for inst in library_instances("allocation", n=[2], seeds=2))
    e = entries[forged]
    kept = {
        forged: dataclasses.replace(e, value=e.value + 10.0, bound=e.value + 10.0),
        honest: entries[honest],
    }
    save_library("allocation", kept, tmp_path)
    argv = ["certify", "allocation", "--verify", "--library-dir", str(tmp_path), "--workers", "1"]
    assert main([*argv, "--ids", forged, honest]) == 1
    captured = capsys.readouterr()
    assert "2 entries re-proven" in captured.out and forged in captured.err and honest not in captured.err
    assert main([*argv, "--ids", honest]) == 0
    assert main([*argv, "--ids", "allocation@1:n=99,seed=0"]) == 2
    assert "ids: no library entry" in capsys.readouterr().err
