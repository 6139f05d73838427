"""Warm starts as a study: an exact engine started from a heuristic's plan, against the engine cold.

A *composite* method is spelled ``"ENGINE<HEURISTIC"`` in a study's method list (``"milp<ga"``,
``"bnb<greedy"``, ``"bnb<mymod:fn"``, ``"cp-sat<alg3"``; :func:`~droneplan.studies.methods.warm_started`
parses it). The study runs it as :func:`~droneplan.studies.harness.run_warm_started` describes: the
heuristic in a process of its own, its plan checked by droneplan's evaluator, then the engine
warm-started with a verified plan (cold otherwise), within the row's one time limit (the
heuristic at most ``harness.HEURISTIC_SHARE`` of it, the engine the rest). The row's extras hold
both parts' times, the heuristic's verified objective and the warm start's fate.

This module turns such rows into evidence: :func:`warm_start_table` pairs each composite's rows
with its engine's cold rows on the same instances (time to proof, nodes, objective at a limit,
median ratios and sign tests), and :func:`warm_start_study` runs both to proof and at a short
limit (the ``droneplan gap cells|herding --warm-starts`` command).
"""

from __future__ import annotations

import math
import os
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from droneplan.studies.methods import COMPOSITE_SEPARATOR

__all__ = [
    "SHORT_LIMIT",
    "PROOF_LIMIT",
    "warm_start_table",
    "warm_start_markdown",
    "warm_start_methods",
    "warm_start_study",
]

PROOF_LIMIT = 120.0
"""The time limit (s) of the run to proof of :func:`warm_start_study` when given none."""

SHORT_LIMIT = 5.0
"""The short time limit (s) of :func:`warm_start_study`: the objective each run reaches by then."""


# --------------------------------------------------------------------------- the paired table
def _engine_time(rows: pd.DataFrame, problem: str, composite: bool) -> pd.Series:
    """The engine's own solve time of each row (s): extra ``engine_time_s`` of a composite, the
    engine's ``solve_time_s`` of a cold row; the row's wall time where those are missing."""
    col = f"{problem}_{'engine_time_s' if composite else 'solve_time_s'}"
    own = pd.to_numeric(rows[col], errors="coerce") if col in rows else pd.Series(np.nan, index=rows.index)
    return own.fillna(pd.to_numeric(rows["time_s"], errors="coerce"))


def _to_proof(rows: pd.DataFrame, times: pd.Series) -> pd.Series:
    """Time to proof (s): the time of a proven row, +inf for one not proven within its limit."""
    return times.where(rows["status"] == "optimal", np.inf)


def _sign_test(better: int, worse: int) -> float | None:
    """Two-sided sign test p-value of ``better`` against ``worse`` pairs (ties dropped); None
    without untied pairs."""
    n = better + worse
    if n == 0:
        return None
    from scipy.stats import binomtest

    return float(binomtest(better, n, 0.5, alternative="two-sided").pvalue)


def _ratio(warm: pd.Series, cold: pd.Series, cap: pd.Series) -> float | None:
    """Median of warm / cold over the pairs, an unproven run counted at its limit (``cap``)."""
    w = warm.where(np.isfinite(warm), cap).astype(float)
    c = cold.where(np.isfinite(cold), cap).astype(float)
    ok = (c > 0) & w.notna() & c.notna()
    return float(np.median(w[ok] / c[ok])) if ok.any() else None


def _pairs(df: pd.DataFrame, engine: str, composite: str) -> pd.DataFrame:
    """One row per (instance, run of the composite): its row and the engine's cold row (run 0: the
    engines are deterministic) on the same instance, at the same time limit."""
    cold = df[df["method"] == engine].sort_values("run").drop_duplicates(["instance", "time_limit_s"])
    warm = df[df["method"] == composite]
    return warm.merge(cold, on=["instance", "time_limit_s"], suffixes=("_warm", "_cold"))


def _compare(p: pd.DataFrame, problem: str, sense: str) -> dict[str, Any]:
    """The figures of one (engine, heuristic, time limit) from its pairs ``p``."""
    warm, cold = _side(p, "_warm"), _side(p, "_cold")
    cap = pd.to_numeric(p["time_limit_s"], errors="coerce")
    t_cold = _to_proof(cold, _engine_time(cold, problem, composite=False))
    t_eng = _to_proof(warm, _engine_time(warm, problem, composite=True))
    h_col = f"{problem}_heuristic_time_s"
    h_time = pd.to_numeric(warm[h_col], errors="coerce").fillna(0.0) if h_col in warm else 0.0
    t_total = _to_proof(warm, _engine_time(warm, problem, composite=True) + h_time)
    out: dict[str, Any] = {
        "pairs": len(p),
        "cold_proven": int((cold["status"] == "optimal").sum()),
        "warm_proven": int((warm["status"] == "optimal").sum()),
        "cold_time_median_s": _median(t_cold),
        "warm_engine_time_median_s": _median(t_eng),
        "warm_total_time_median_s": _median(t_total),
        "engine_time_ratio_median": _ratio(t_eng, t_cold, cap),
        "total_time_ratio_median": _ratio(t_total, t_cold, cap),
    }
    faster, slower = int((t_eng < t_cold).sum()), int((t_eng > t_cold).sum())
    out.update(engine_faster=faster, engine_slower=slower, engine_time_sign_p=_sign_test(faster, slower))
    faster, slower = int((t_total < t_cold).sum()), int((t_total > t_cold).sum())
    out.update(total_faster=faster, total_slower=slower, total_time_sign_p=_sign_test(faster, slower))
    n_col = f"{problem}_nodes"
    if n_col in warm and n_col in cold:
        nw, nc = (pd.to_numeric(x[n_col], errors="coerce") for x in (warm, cold))
        both = nw.notna() & nc.notna()
        fewer, more = int((nw[both] < nc[both]).sum()), int((nw[both] > nc[both]).sum())
        ok = both & (nc > 0)
        out.update(
            cold_nodes_median=_median(nc[both]),
            warm_nodes_median=_median(nw[both]),
            nodes_ratio_median=float(np.median(nw[ok] / nc[ok])) if ok.any() else None,
            fewer_nodes=fewer,
            more_nodes=more,
            nodes_sign_p=_sign_test(fewer, more),
        )
    ow, oc = (pd.to_numeric(x["objective"], errors="coerce") for x in (warm, cold))
    sign = 1.0 if sense == "max" else -1.0
    better, worse = int((sign * (ow - oc) > 1e-9).sum()), int((sign * (oc - ow) > 1e-9).sum())
    out.update(
        cold_objective_mean=_mean(oc),
        warm_objective_mean=_mean(ow),
        warm_better=better,
        warm_worse=worse,
        objective_sign_p=_sign_test(better, worse),
    )
    fate = warm.get(f"{problem}_warm_start")
    if fate is not None:
        out.update(start_used=int((fate == "used").sum()), start_cold=int((fate == "cold").sum()))
    obj = warm.get(f"{problem}_heuristic_objective")
    if obj is not None:
        out["heuristic_objective_mean"] = _mean(pd.to_numeric(obj, errors="coerce"))
    return out


def _side(p: pd.DataFrame, suffix: str) -> pd.DataFrame:
    """The columns of one side of the pairs, without their suffix."""
    side = p[[c for c in p.columns if str(c).endswith(suffix)]]
    return side.rename(columns=lambda c: str(c)[: -len(suffix)])


def _median(s: pd.Series) -> float | None:
    s = pd.to_numeric(s, errors="coerce").dropna()
    return float(np.median(s)) if len(s) else None


def _mean(s: pd.Series) -> float | None:
    s = pd.to_numeric(s, errors="coerce").dropna()
    return float(s.mean()) if len(s) else None


def warm_start_table(df: pd.DataFrame) -> pd.DataFrame:
    """The paired table of warm starts: each composite against its engine run cold.

    df: rows of one problem's studies (:func:`droneplan.gap` or ``load_results``), holding the
        engines' cold rows (method ``ENGINE``) and the composites' rows (``ENGINE<HEURISTIC``) on
        the same instances, at one or more time limits (column ``time_limit_s``). Rows of other
        methods are ignored.

    Returns one row per (engine, heuristic, time limit) with at least one pair (a composite's row
    and the engine's cold row on the same instance and limit; a stochastic heuristic's runs each
    pair with the one cold row): ``pairs``; ``cold_proven``/``warm_proven`` (rows proven optimal);
    time to proof, an unproven run counting as not finished: ``cold_time_median_s`` (the engine's
    solve time), ``warm_engine_time_median_s`` (the engine's part of the composite),
    ``warm_total_time_median_s`` (heuristic + engine); ``engine_time_ratio_median`` and
    ``total_time_ratio_median``, the median over pairs of warm / cold (an unproven run counted at
    the limit), each with the pairs where warm was faster / slower (``engine_faster``,
    ``engine_slower``, ``total_faster``, ``total_slower``) and the two-sided sign test's p-value
    over the untied pairs (``*_sign_p``, ``scipy.stats.binomtest`` with p = 1/2; None with no
    untied pair); the engines' search nodes where they report them (``cold_nodes_median``,
    ``warm_nodes_median``, ``nodes_ratio_median``, ``fewer_nodes``, ``more_nodes``,
    ``nodes_sign_p``); the objective reached (``cold_objective_mean``, ``warm_objective_mean``,
    ``warm_better``, ``warm_worse``, ``objective_sign_p``, better in the problem's sense);
    ``start_used``/``start_cold`` (rows whose start the engine used / that ran cold) and
    ``heuristic_objective_mean``.
    """
    if not isinstance(df, pd.DataFrame):
        raise TypeError(f"df must be a DataFrame of study rows, got {type(df).__name__}")
    need = {"problem", "instance", "method", "status", "objective", "time_s", "time_limit_s", "sense"}
    missing = sorted(need - set(df.columns))
    if missing:
        raise ValueError(f"df lacks the study columns {missing}")
    rows = []
    names = [m for m in df["method"].dropna().unique() if COMPOSITE_SEPARATOR in str(m)]
    for composite in sorted(names):
        engine, _, heuristic = str(composite).partition(COMPOSITE_SEPARATOR)
        pairs = _pairs(df, engine, composite)
        for limit, p in pairs.groupby("time_limit_s", sort=True):
            problem = str(p["problem_warm"].iloc[0])
            sense = str(p["sense_warm"].iloc[0])
            rows.append(
                {
                    "engine": engine,
                    "heuristic": heuristic,
                    "time_limit_s": float(limit),
                    **_compare(p, problem, sense),
                }
            )
    return pd.DataFrame(rows)


def warm_start_markdown(table: pd.DataFrame) -> str:
    """``table`` (:func:`warm_start_table`) as a markdown table of its main columns.

    table: the paired table.
    """
    if table.empty:
        return "(no pairs of a composite and its engine run cold)"
    cols = [
        ("engine", "engine"),
        ("heuristic", "heuristic"),
        ("time_limit_s", "limit (s)"),
        ("pairs", "pairs"),
        ("start_used", "start used"),
        ("cold_proven", "proven cold"),
        ("warm_proven", "proven warm"),
        ("cold_time_median_s", "cold (s)"),
        ("warm_engine_time_median_s", "warm engine (s)"),
        ("engine_time_ratio_median", "ratio engine"),
        ("engine_time_sign_p", "p"),
        ("warm_total_time_median_s", "warm total (s)"),
        ("total_time_ratio_median", "ratio total"),
        ("total_time_sign_p", "p"),
        ("nodes_ratio_median", "ratio nodes"),
        ("nodes_sign_p", "p"),
        ("cold_objective_mean", "objective cold"),
        ("warm_objective_mean", "objective warm"),
        ("objective_sign_p", "p"),
    ]
    cols = [(c, h) for c, h in cols if c in table.columns]
    lines = ["| " + " | ".join(h for _, h in cols) + " |", "|" + "---|" * len(cols)]
    for _, r in table.iterrows():
        lines.append("| " + " | ".join(_cell(r[c]) for c, _ in cols) + " |")
    return "\n".join(lines)


def _cell(v: Any) -> str:
    if v is None or (isinstance(v, float) and math.isnan(v)):
        return "—"
    if isinstance(v, float):
        return "∞" if math.isinf(v) else f"{v:.3g}"
    return str(v)


# --------------------------------------------------------------------------- the study
def warm_start_methods(kind: str, methods: Any = None) -> list[str]:
    """The methods of a warm-start study on ``kind``: each warm-startable engine cold, and each
    composite ``ENGINE<HEURISTIC``.

    kind: the instance kind (``cells``, ``allocation``).
    methods: names to pick the engines and heuristics from (None: every engine of the kind that
        takes a warm start and every registered heuristic of the kind); a ``module:function`` or
        another name that is no engine counts as a heuristic.
    """
    from droneplan.studies.methods import BUILTIN, builtin_methods, warm_start_engines

    engines = warm_start_engines(kind)
    if not engines:
        raise ValueError(f"no exact engine of {kind} instances takes a warm start")
    if methods is None:
        heuristics = [n for n in builtin_methods(kind) if not BUILTIN[n].trusted_bound]
        chosen = engines
    else:
        names = [methods] if isinstance(methods, str) else list(methods)
        bad = [n for n in names if not isinstance(n, str) or COMPOSITE_SEPARATOR in n]
        if bad:
            raise ValueError(f"methods: name engines and heuristics apart, got {bad[0]!r}")
        chosen = [n for n in names if n in engines] or engines
        heuristics = [
            n for n in names if n not in engines and not getattr(BUILTIN.get(n), "trusted_bound", False)
        ]
    if not heuristics:
        raise ValueError(f"methods: name at least one heuristic of {kind} instances")
    return [*chosen, *(f"{e}{COMPOSITE_SEPARATOR}{h}" for e in chosen for h in heuristics)]


def warm_start_study(
    problem: str,
    *,
    out: str | os.PathLike,
    methods: Any = None,
    time_limit: float | None = None,
    short_limit: float = SHORT_LIMIT,
    **options: Any,
) -> tuple[pd.DataFrame, pd.DataFrame]:
    """Run each warm-startable engine cold and warm from each heuristic, to proof and at a short
    limit, through :func:`droneplan.gap`, and write the paired table.

    problem: ``cells`` or ``herding`` (its allocation instances).
    out: directory; the two studies' stores go to ``out/limit-<T>s`` and ``out/limit-<S>s``, the
        table to ``out/<problem>/warm_starts.csv`` and ``warm_starts.md``.
    methods: engines and heuristics to pair (:func:`warm_start_methods`; None: all of the kind).
    time_limit: the limit to proof per row (s; None: ``PROOF_LIMIT``).
    short_limit: the short limit (s) at which the objective reached is compared.
    options: further keywords of :func:`droneplan.gap` (``instances``, ``workers``, ``m``, ``n``,
        ``seeds``, ``first_seed``, ``runs``, ``progress`` ...).

    Returns (the rows of both studies, the paired table of :func:`warm_start_table`).
    """
    from droneplan.studies.instances import resolve_instances
    from droneplan.studies.study import gap

    out = Path(out)
    proof = PROOF_LIMIT if time_limit is None else float(time_limit)
    run_options = {"instances", "workers", "dask", "progress", "store", "executor", "memory_limit", "runs"}
    sizes = {k: v for k, v in options.items() if k not in run_options | {"cpu_limit", "max_evaluations"}}
    kinds = {i.kind for i in resolve_instances(problem, options.get("instances"), **sizes)}
    if len(kinds) != 1:
        raise ValueError(f"a warm-start study runs on one kind of instance, got {sorted(kinds)}")
    names = warm_start_methods(kinds.pop(), methods)
    frames = [
        gap(problem, methods=names, out=out / f"limit-{limit:g}s", time_limit=limit, **options)
        for limit in dict.fromkeys((proof, float(short_limit)))
    ]
    df = pd.concat(frames, ignore_index=True)
    table = warm_start_table(df)
    folder = out / problem
    folder.mkdir(parents=True, exist_ok=True)
    table.to_csv(folder / "warm_starts.csv", index=False)
    (folder / "warm_starts.md").write_text(warm_start_markdown(table) + "\n", encoding="utf-8")
    return df, table
