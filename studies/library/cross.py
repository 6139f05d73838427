"""Cross-certification of the two exact cells engines on library instances.

:func:`cross_certify` runs the combinatorial branch and bound (``engine="bnb"``) and the
candidate MILP (``engine="milp"``) on each instance of a cells family and checks, for
every instance:

- the independent checker ``evaluate`` re-scores each engine's plan: feasible, and
  covering exactly the users the engine claims;
- each engine's bound is at least its own objective and at least the other engine's
  checked objective (a plan of one is feasible for the other's problem: both solve the
  same candidate problem);
- when both prove optimality, their optima are equal;
- a proven optimum lies between the library entry's value and bound (when the entry was
  certified on the same data), and equals its value when the entry is proven.

Any failed check is a *disagreement*: the instance is written (``save_instance``) to
``<directory>/<id>.json`` beside ``<id>.results.json`` with both engines' outcomes, a line
goes to stderr at once, and :class:`CrossCertificationError` is raised at the end (after
the other instances, so one run shows them all), unless ``strict=False``.

An instance where an engine stopped at its time limit is compared on bounds only; the
summary counts the instances where both proved.

On a Dask cluster (``dask=ADDRESS``, ``droneplan cross-certify ... --dask ADDRESS``, or a
Dask ``executor`` of :func:`~droneplan.studies.common.make_executor`) the two engines of each
instance run on a worker, which sends back their outcomes only; the library lookup, the checks,
the log and the saved disagreements are done here, as each instance comes back.
"""

from __future__ import annotations

import argparse
import concurrent.futures as cf
import contextlib
import json
import math
import os
import re
import sys
import time
from collections.abc import Callable, Iterable, Iterator
from pathlib import Path
from typing import Any

import numpy as np

from droneplan.core.validation import check_int, check_time_limit
from droneplan.studies.common import StudyError, StudyExecutor
from droneplan.studies.instances import FAMILIES, StudyInstance, family_instances, save_instance
from droneplan.studies.library import lookup
from droneplan.studies.library.certify import check_cluster_options, connect, option_message

__all__ = ["CrossCertificationError", "cross_certify", "cross_check_instance"]

ENGINE_NAMES = ("bnb", "milp")
"""The two exact engines compared (``solve_exact(engine=...)``)."""


class CrossCertificationError(AssertionError):
    """The exact cells engines, the checker or the library disagree on some instance; the
    message names each instance and the file its data was saved to."""


def _run_engine(problem, engine: str, time_limit: float | None, backend: str, workers: int) -> dict[str, Any]:
    """One engine on one problem: its claims and the checker's verdict on its plan."""
    from droneplan.formulations import cells

    t_cpu, t_wall = time.process_time(), time.perf_counter()
    res = cells.solve_exact(problem, engine=engine, backend=backend, time_limit=time_limit, workers=workers)
    cpu, wall = time.process_time() - t_cpu, time.perf_counter() - t_wall
    x = np.zeros((0, 2)) if res.x is None else np.asarray(res.x, dtype=float).reshape(-1, 2)
    ev = cells.evaluate(problem, x)
    return {
        "status": res.status.value,
        "proven": res.status.value == "optimal",
        "objective": None if res.objective is None else float(res.objective),
        "bound": None if res.bound is None else float(res.bound),
        "checked": int(ev.covered) if ev.feasible else None,
        "violations": list(ev.violations),
        "plan": x.tolist(),
        "cpu_s": cpu,
        "wall_s": wall,
        "message": res.message,
    }


def _disagreements(out: dict[str, dict[str, Any]], entry) -> list[str]:
    """Every failed check of the module docstring for one instance's engine outcomes."""
    bad = []
    for name, r in out.items():
        if r["checked"] is None:
            bad.append(f"{name}: its plan is infeasible ({'; '.join(r['violations'])})")
        elif r["objective"] is None or abs(r["checked"] - r["objective"]) > 1e-6:
            bad.append(f"{name}: claims {r['objective']} users, the checker counts {r['checked']}")
        for other, o in out.items():
            if r["bound"] is not None and o["checked"] is not None and o["checked"] > r["bound"] + 1e-6:
                bad.append(f"{name}'s bound {r['bound']} is below {other}'s checked plan ({o['checked']})")
    proven = {name: r["checked"] for name, r in out.items() if r["proven"] and r["checked"] is not None}
    if len(set(proven.values())) > 1:
        bad.append(f"proven optima differ: {proven}")
    if entry is not None:
        for name, value in proven.items():
            if value < entry.value - 1e-6 or (entry.bound is not None and value > entry.bound + 1e-6):
                bad.append(f"{name}'s proven {value} is outside the library's [{entry.value}, {entry.bound}]")
    return bad


def _safe_name(instance_id: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.=-]+", "_", instance_id)


def _save_disagreement(
    instance: StudyInstance, out: dict, entry, problems: list[str], directory: Path
) -> Path:
    """Write the instance and the engines' outcomes; returns the instance file."""
    directory.mkdir(parents=True, exist_ok=True)
    path = save_instance(instance, directory / f"{_safe_name(instance.id)}.json")
    record = {
        "id": instance.id,
        "disagreements": problems,
        "engines": out,
        "library": None
        if entry is None
        else {"value": entry.value, "bound": entry.bound, "status": entry.status},
    }
    (directory / f"{_safe_name(instance.id)}.results.json").write_text(json.dumps(record, indent=1))
    return path


def cross_check_instance(
    instance: StudyInstance,
    *,
    time_limit: float | None = 60.0,
    milp_time_limit: float | None = None,
    backend: str = "cp-sat",
    workers: int = 1,
    library_dir: str | os.PathLike | None = None,
) -> dict[str, Any]:
    """Both engines on one cells instance, checked (module docstring); no file is written.

    instance: a cells StudyInstance. time_limit: the branch and bound's limit (s; None:
    none). milp_time_limit: the MILP's (s; default ``time_limit``). backend: the MILP's
    linear backend. workers: processes / solver threads of each engine. library_dir: where
    the library files are (default: the package's).
    Returns {"id", "engines": {"bnb": ..., "milp": ...}, "library": entry or None,
    "both_proven", "disagreements": [messages]}; each engine's outcome holds ``status``,
    ``proven``, ``objective``, ``bound``, ``checked`` (users the checker counts, None when
    infeasible), ``plan``, ``cpu_s`` and ``wall_s`` (s).
    """
    if instance.kind != "cells":
        raise ValueError(f"instance must be a cells instance, got kind {instance.kind!r} ({instance.id})")
    _require_thesis_model(instance)
    out = _run_engines(instance.data, _limits(time_limit, milp_time_limit), backend, workers)
    return _checked(instance, out, library_dir)


def _limits(time_limit: float | None, milp_time_limit: float | None) -> dict[str, float | None]:
    """Each engine's time limit (s; None: none)."""
    return {"bnb": time_limit, "milp": time_limit if milp_time_limit is None else milp_time_limit}


def _run_engines(
    problem: Any, limits: dict[str, float | None], backend: str, workers: int
) -> dict[str, dict[str, Any]]:
    """Both engines on one problem (where the instance is computed: here, or on a Dask worker),
    by name; each outcome as :func:`_run_engine` gives it. limits: each engine's time limit (s)."""
    return {name: _run_engine(problem, name, limits[name], backend, workers) for name in ENGINE_NAMES}


def _checked(
    instance: StudyInstance, out: dict[str, dict[str, Any]], library_dir: str | os.PathLike | None
) -> dict[str, Any]:
    """The record of :func:`cross_check_instance` from both engines' outcomes ``out``: the library
    entry (read from ``library_dir`` in this process) and every disagreement."""
    entry = lookup(instance, library_dir)
    return {
        "id": instance.id,
        "engines": out,
        "library": entry,
        "both_proven": all(r["proven"] for r in out.values()),
        "disagreements": _disagreements(out, entry),
    }


def _require_thesis_model(instance: Any) -> None:
    """ValueError for a variant instance: only the MILP solves it, so there is nothing to cross."""
    if instance.data.variants:
        raise ValueError(
            f"{instance.id} uses the variant(s) {', '.join(instance.data.variants)}, which only the MILP "
            "solves: cross-certification needs both engines (certify it with 'droneplan certify')"
        )


def cross_certify(
    family: str = "table4.2",
    *,
    m: int | Iterable[int] = (1, 2, 3, 4),
    seeds: int | Iterable[int] = 100,
    first_seed: int = 0,
    time_limit: float | None = 60.0,
    milp_time_limit: float | None = None,
    backend: str = "cp-sat",
    workers: int = 1,
    directory: str | os.PathLike = "cross-certify",
    library_dir: str | os.PathLike | None = None,
    strict: bool = True,
    log: str | os.PathLike | None = None,
    progress: Callable[[dict[str, Any]], None] | None = None,
    dask: str | None = None,
    executor: StudyExecutor | None = None,
) -> dict[str, Any]:
    """Cross-certify the exact cells engines on ``family``'s instances (module docstring).

    family: a cells instance family (``"table4.2"`` has a library). m: number(s) of
    drone-cells. seeds: how many seeds (from ``first_seed``) or the seeds. time_limit,
    milp_time_limit, backend, workers: as :func:`cross_check_instance` (s). directory: where
    disagreeing instances are saved. library_dir: the library files (default: the
    package's). strict: raise :class:`CrossCertificationError` after the run when any
    instance disagrees. log: a JSON-lines file that gets one line per instance as it ends
    (None: none). progress: called with each instance's record. dask: the address of a Dask
    scheduler (``"tcp://host:8786"``) whose workers run the engines, one instance per task (the
    checks, the log and the saved files stay in this process); one that does not answer within
    5 s is a :class:`~droneplan.studies.common.StudyError` naming ``dask``, raised before any
    file is written. executor: a :class:`~droneplan.studies.common.StudyExecutor` instead (serial:
    as without one; a process pool or Dask: the instances are spread over it). With either, the
    log's lines come in the order the instances finish.

    Returns {"family", "instances", "both_proven", "bnb_proven", "milp_proven",
    "library_matched" (proven optima equal to a proven library value), "disagreements"
    ({id: [messages]}), "saved" ([instance files]), "cpu_s" ({engine: total CPU s})}.
    """
    if family not in FAMILIES or FAMILIES[family].kind != "cells":
        cells_families = sorted(k for k, f in FAMILIES.items() if f.kind == "cells")
        raise ValueError(f"family must be a cells family ({', '.join(cells_families)}), got {family!r}")
    check_time_limit(time_limit)
    check_time_limit(milp_time_limit)
    check_int("workers", workers, min_value=1)
    check_cluster_options(dask, executor)
    instances = family_instances(
        family, m=list(m) if isinstance(m, Iterable) else m, seeds=seeds, first_seed=first_seed
    )
    for inst in instances[:1]:
        _require_thesis_model(inst)
    summary: dict[str, Any] = {
        "family": family,
        "instances": 0,
        "both_proven": 0,
        "bnb_proven": 0,
        "milp_proven": 0,
        "library_matched": 0,
        "disagreements": {},
        "saved": [],
        "cpu_s": dict.fromkeys(ENGINE_NAMES, 0.0),
    }
    limits = _limits(time_limit, milp_time_limit)
    with contextlib.ExitStack() as stack:
        runner = connect(stack, dask, executor)
        for inst, out in _engine_outcomes(instances, limits, backend, workers, runner):
            _record(summary, _checked(inst, out, library_dir), inst, directory, log, progress)
    if strict and summary["disagreements"]:
        lines = [f"{k}: {'; '.join(v)}" for k, v in summary["disagreements"].items()]
        raise CrossCertificationError(
            f"{len(lines)} of {summary['instances']} instances disagree (saved in {directory}):\n"
            + "\n".join(lines)
        )
    return summary


def _engine_outcomes(
    instances: list[StudyInstance],
    limits: dict[str, float | None],
    backend: str,
    workers: int,
    executor: StudyExecutor | None,
) -> Iterator[tuple[StudyInstance, dict[str, dict[str, Any]]]]:
    """(instance, both engines' outcomes) for each instance: one after the other in this process
    (no executor, or a serial one), or spread over ``executor`` in the order they finish. Leaving
    early cancels the instances not yet finished."""
    if executor is None or executor.kind == "serial":
        for inst in instances:
            yield inst, _run_engines(inst.data, limits, backend, workers)
        return
    futures = {executor.submit(_run_engines, inst.data, limits, backend, workers): inst for inst in instances}
    try:
        for fut in cf.as_completed(futures):
            yield futures[fut], fut.result()
    finally:
        for fut in futures:
            fut.cancel()


def _record(
    summary: dict[str, Any],
    rec: dict[str, Any],
    inst: StudyInstance,
    directory: str | os.PathLike,
    log: str | os.PathLike | None,
    progress: Callable[[dict[str, Any]], None] | None,
) -> None:
    """Count one instance's record in ``summary``, save it when it disagrees, log it, report it."""
    _tally(summary, rec)
    if rec["disagreements"]:
        path = _save_disagreement(inst, rec["engines"], rec["library"], rec["disagreements"], Path(directory))
        summary["disagreements"][inst.id] = rec["disagreements"]
        summary["saved"].append(str(path))
        print(
            f"cross-certify DISAGREEMENT {inst.id}: {rec['disagreements']} (saved {path})",
            file=sys.stderr,
        )
    if log is not None:
        with open(log, "a") as fh:
            fh.write(json.dumps({**rec, "library": _entry_dict(rec["library"])}) + "\n")
    if progress is not None:
        progress(rec)


def _entry_dict(entry) -> dict | None:
    return None if entry is None else {"value": entry.value, "bound": entry.bound, "status": entry.status}


def _tally(summary: dict[str, Any], rec: dict[str, Any]) -> None:
    """Add one instance's record to the run's counts."""
    eng = rec["engines"]
    summary["instances"] += 1
    summary["both_proven"] += rec["both_proven"]
    for name in ENGINE_NAMES:
        summary[f"{name}_proven"] += eng[name]["proven"]
        summary["cpu_s"][name] += eng[name]["cpu_s"]
    entry = rec["library"]
    if rec["both_proven"] and entry is not None and entry.status == "optimal":
        summary["library_matched"] += all(math.isclose(r["checked"] or -1, entry.value) for r in eng.values())


# --------------------------------------------------------------------------- command line
HELP = (
    "run both exact cells engines (branch and bound, MILP) on a family's instances and check them "
    "against each other, the independent checker and the library; disagreements are saved and fail the run"
)
"""One-line help of the ``cross-certify`` command."""


def add_arguments(parser: argparse.ArgumentParser) -> argparse.ArgumentParser:
    """Add the ``cross-certify`` options to ``parser`` (an argparse parser or sub-parser); returns it."""
    parser.add_argument("family", nargs="?", default="table4.2", help="a cells family (default table4.2)")
    parser.add_argument("--m", default="1,2,3,4", help="drone-cells, comma-separated (default 1,2,3,4)")
    parser.add_argument("--seeds", type=int, default=100, help="number of seeds (default 100)")
    parser.add_argument("--first-seed", type=int, default=0, help="first seed (default 0)")
    parser.add_argument(
        "--time-limit",
        type=float,
        default=60.0,
        metavar="S",
        help="branch and bound, per instance (default 60 s)",
    )
    parser.add_argument(
        "--milp-time-limit",
        type=float,
        default=None,
        metavar="S",
        help="MILP, per instance (default --time-limit)",
    )
    parser.add_argument("--backend", default="cp-sat", help="the MILP's linear backend (default cp-sat)")
    parser.add_argument(
        "--workers", type=int, default=1, help="processes / solver threads per engine (default 1)"
    )
    parser.add_argument(
        "--out", type=Path, default=Path("cross-certify"), help="where disagreeing instances are saved"
    )
    parser.add_argument("--log", type=Path, default=None, help="a JSON-lines file, one line per instance")
    parser.add_argument(
        "--library-dir", type=Path, default=None, help="where the library files are (default: the package's)"
    )
    parser.add_argument(
        "--dask",
        metavar="ADDRESS",
        default=None,
        help="address of a running Dask scheduler whose workers run the engines, e.g. tcp://10.0.0.1:8786",
    )
    return parser


def run(args: argparse.Namespace) -> int:
    """Run :func:`cross_certify` with the options of :func:`add_arguments`; print the summary and
    every disagreement (stderr). Returns the exit code: 0, or 1 when an instance disagrees.

    args: the parsed options."""
    try:
        m = [int(v) for v in str(args.m).split(",") if v.strip()]
    except ValueError:
        raise ValueError(f"--m must be comma-separated integers, got {args.m!r}") from None
    try:
        summary = cross_certify(
            args.family,
            m=m,
            seeds=args.seeds,
            first_seed=args.first_seed,
            time_limit=args.time_limit,
            milp_time_limit=args.milp_time_limit,
            backend=args.backend,
            workers=args.workers,
            directory=args.out,
            library_dir=args.library_dir,
            log=args.log,
            strict=False,
            dask=getattr(args, "dask", None),
        )
    except StudyError as exc:  # an unreachable scheduler: named as the option it came from
        raise StudyError(option_message(exc)) from None
    print(
        f"cross-certify {summary['family']}: {summary['instances']} instances; both engines proved "
        f"{summary['both_proven']} (bnb {summary['bnb_proven']}, milp {summary['milp_proven']}), "
        f"{summary['library_matched']} equal to the library's proven optimum; "
        f"{len(summary['disagreements'])} disagreements; CPU s: "
        + ", ".join(f"{k} {v:.0f}" for k, v in summary["cpu_s"].items()),
        flush=True,
    )
    for key, lines in summary["disagreements"].items():
        print(f"  DISAGREEMENT {key}: {'; '.join(lines)}", file=sys.stderr)
    return 1 if summary["disagreements"] else 0


if __name__ == "__main__":
    sys.exit(run(add_arguments(argparse.ArgumentParser(prog="cross-certify", description=HELP)).parse_args()))
