"""The thesis GA measured through :func:`droneplan.gap`: the ablation and the readings study.

Every GA run, exhaustive search and exact reference of these studies is a row of an open gap
study (:func:`droneplan.studies.study.gap`): each GA variant or reading is a
:class:`~droneplan.studies.methods.Method` (the function :func:`ga_run` with its settings as
``params``) run ``runs`` times per instance (run r seeded by
:func:`~droneplan.core.validation.run_seed` of the instance seed and r, so run r of every variant
uses one seed: paired runs); exhaustive search (Algorithm 2, :func:`es_run`) is deterministic and
runs once; the exact reference is the certified library's row (``library``, a proven optimum for
every Table 4.2 instance it holds) or, on an instance the library lacks, the branch and bound
(``bnb``) run as a method of a study of its own (:func:`reference_parts`; the studies run with
``reference="none"``, as their CSV exports go to a scratch folder that would not keep a solved
reference for the next call). P_Global is then the share of the GA's rows that
reach the exhaustive-search value (the thesis's criterion) or the proven optimum.

A row carries what droneplan's evaluator measured (covered users, wall time) and, where the
harness keeps them, the numbers a method reports about its run in ``info["extras"]``: the GA's
``best_share`` (the mean share of a final population identical to its best chromosome) and the
exhaustive search's ``es_complete``. Where a row lacks ``es_complete``, a search whose wall time
stayed below its limit is complete (a stopped search runs at least that long).
"""

from __future__ import annotations

import contextlib
import dataclasses
import os
import tempfile
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np
import pandas as pd

from droneplan.core.validation import check_int, check_positive, check_sequence, check_work
from droneplan.planners.cells import GASettings, exhaustive, ga_reading, genetic, thesis_ga_settings
from droneplan.scenarios.cells import (
    THESIS_TABLE_4_2,
    THESIS_TABLE_4_3,
    problem_from_instance,
    thesis_instance,
)
from droneplan.solvers.result import SolveResult
from droneplan.studies.methods import BUILTIN, Method

__all__ = [
    "GA_TIME_LIMIT",
    "GapPart",
    "ga_run",
    "es_run",
    "ga_method",
    "es_method",
    "exact_method",
    "reference_parts",
    "gap_rows",
    "stored_rows",
    "reference_row",
    "es_is_complete",
    "run_seconds",
    "share_text",
    "GA_VARIANTS",
    "INSTANCE_VARIANTS",
    "instance_features",
    "ablation_plan",
    "ablation_parts",
    "ablation_table",
    "ablation_summary",
    "ablation_correlations",
    "ablation_finding",
    "ga_ablation",
    "READINGS_FAMILY",
    "readings_markdown",
    "ga_readings",
]

GA_TIME_LIMIT = 3600.0
"""Wall-time limit of one GA run in these studies (s): a backstop far above any run's need."""

_ES_BACKSTOP = 1.5
"""An exhaustive search stops itself at its limit; its job is killed only this many times later."""


class GapPart(NamedTuple):
    """One call of :func:`droneplan.studies.study.gap`: ``methods`` run ``runs`` times on the
    instances ``seeds`` of ``family`` with ``m`` drone-cells."""

    family: str
    m: int
    seeds: tuple[int, ...]
    methods: tuple[Method, ...]
    runs: int


# --------------------------------------------------------------------------- the methods
def ga_run(
    problem,
    *,
    seed: int,
    time_limit: float | None,
    pop_size: int | None = None,
    restarts: int | None = None,
    iter_max: int = 50,
    settings: Mapping[str, Any] | None = None,
    reading: str | None = None,
    restarts_factor: int | None = None,
    no_restarts: bool = False,
) -> SolveResult:
    """One run of the thesis GA (:func:`~droneplan.planners.cells.genetic`) as a study method.

    problem: the CellProblem. seed: the run's seed. time_limit: the study's limit (s; the GA runs
    its generations and ignores it). pop_size, restarts, iter_max: as in ``genetic`` (None: the
    Table 4.3 row of m). settings: :class:`~droneplan.planners.cells.GASettings` fields (a
    mapping), applied over the reading's. reading: a key of
    :data:`~droneplan.planners.cells.GA_READINGS` (None: the defaults). restarts_factor: run this
    many times the Table 4.3 restarts. no_restarts: one run of N_start x ``iter_max`` generations.

    Returns the GA's SolveResult with ``info["extras"]["best_share"]``: the mean share of a final
    population identical to its best chromosome.
    """
    s = ga_reading(reading, **dict(settings or {})) if reading else GASettings(**dict(settings or {}))
    n_start = thesis_ga_settings(problem.n_cells)[1]
    if no_restarts:
        restarts, iter_max = 1, iter_max * n_start
    elif restarts_factor is not None:
        restarts = int(restarts_factor) * n_start
    res = genetic(problem, pop_size=pop_size, restarts=restarts, iter_max=iter_max, seed=seed, settings=s)
    share = float(np.mean(res.info["final_best_share"]))
    return dataclasses.replace(res, info={**res.info, "extras": {"best_share": share}})


def es_run(
    problem, *, seed: int, time_limit: float | None, prune: bool = True, stop_after: float
) -> SolveResult:
    """Exhaustive search (Algorithm 2, :func:`~droneplan.planners.cells.exhaustive`) as a study method.

    problem: the CellProblem. seed: unused (the search is deterministic). time_limit: the job's
    backstop (s; the search stops itself at ``stop_after``). prune: the bound-pruned search (True)
    or Algorithm 2 as written (False). stop_after: the search's own time limit (s).

    Returns its SolveResult with ``info["evaluations"]`` (last-cell searches) and
    ``info["extras"]["es_complete"]`` (whether the enumeration finished).
    """
    res = exhaustive(problem, time_limit=stop_after, prune=prune)
    info = {
        **res.info,
        "evaluations": res.info["last_cell_searches"],
        "extras": {"es_complete": bool(res.info["complete"])},
    }
    return dataclasses.replace(res, info=info)


def ga_method(name: str, **params: Any) -> Method:
    """A GA variant as a stochastic study method named ``name`` (:func:`ga_run` with ``params``).

    name: the rows' method name. params: keywords of :func:`ga_run` (recorded in every row)."""
    return Method(
        name, ga_run, params=params, kinds=("cells",), deterministic=False, time_limit=GA_TIME_LIMIT
    )


def es_method(stop_after: float, *, prune: bool = True) -> Method:
    """Exhaustive search stopped at ``stop_after`` s as a deterministic study method, named
    ``exhaustive@<limit>s`` (pruned) or ``exhaustive-plain@<limit>s`` (as written), so searches
    under other limits are other rows.

    stop_after: the search's time limit (s > 0). prune: the bound-pruned search or the plain one."""
    limit = check_positive("stop_after", stop_after)
    name = f"exhaustive{'' if prune else '-plain'}@{limit:g}s"
    params = {"prune": bool(prune), "stop_after": limit}
    backstop = _ES_BACKSTOP * limit + 30.0
    return Method(name, es_run, params=params, kinds=("cells",), deterministic=True, time_limit=backstop)


def exact_method(time_limit: float) -> Method:
    """The registered branch and bound (``bnb``) under its own time limit (s > 0).

    time_limit: seconds per instance."""
    return dataclasses.replace(BUILTIN["bnb"], time_limit=check_positive("time_limit", time_limit))


def reference_parts(
    family: str, ms: Sequence[int], seeds: Sequence[int], exact_limit: float
) -> list[GapPart]:
    """The exact reference of the instances whose certified library entry is not a proven
    optimum: one :class:`GapPart` per m running the branch and bound on them (none when the
    library proves every one; its ``library`` rows come with every study on these instances).

    family: the instance family. ms: drone-cell counts. seeds: instance seeds. exact_limit: the
    branch and bound's time limit (s)."""
    from droneplan.studies.instances import family_instances
    from droneplan.studies.library import lookup

    parts = []
    for m in ms:
        missing = []
        for inst in family_instances(family, m=m, seeds=list(seeds)):
            entry = lookup(inst)
            if entry is None or entry.status != "optimal":
                missing.append(int(inst.seed or 0))
        if missing:
            parts.append(GapPart(family, int(m), tuple(missing), (exact_method(exact_limit),), 1))
    return parts


def gap_rows(parts: Sequence[GapPart], *, store, executor=None) -> pd.DataFrame:
    """The rows of ``parts``, each one :func:`droneplan.studies.study.gap` call on ``store``
    (rows already there under the same configuration are reused, not rerun).

    parts: the calls. store: an open ``ResultStore``. executor: a
    :class:`~droneplan.studies.common.StudyExecutor` the jobs run on (None: one at a time)."""
    from droneplan.studies.study import gap

    run_on = {"workers": 1} if executor is None else {"executor": executor}
    with tempfile.TemporaryDirectory(prefix="droneplan-cells-ga-") as scratch:  # gap's CSV exports
        frames = [
            gap(
                "cells",
                methods=list(p.methods),
                instances=p.family,
                m=p.m,
                seeds=list(p.seeds),
                runs=p.runs,
                out=scratch,
                store=store,
                progress=False,
                reference="none",  # the exact reference is explicit: reference_parts
                **run_on,
            )
            for p in parts
        ]
    if not frames:
        return pd.DataFrame()
    df = pd.concat(frames, ignore_index=True)
    return df.drop_duplicates(subset=["instance", "method", "run"], keep="last", ignore_index=True)


def stored_rows(store, parts: Sequence[GapPart]) -> pd.DataFrame:
    """The rows ``parts`` wrote, read from ``store`` without running anything (what
    :func:`gap_rows` returns once every row is there, at the cost of one read of the store):
    their methods' runs and the instances' reference rows.

    store: an open ``ResultStore``. parts: the studies whose rows are wanted."""
    from droneplan.studies.instances import family_instances

    df = store.frame(problem="cells")
    keep = pd.Series(False, index=df.index)
    for p in parts:
        ids = {i.id for i in family_instances(p.family, m=p.m, seeds=list(p.seeds))}
        names = {m.name for m in p.methods} | {"library", "reference"}
        keep |= df["instance"].isin(ids) & df["method"].isin(names) & (df["run"] < p.runs)
    found = df[keep]
    return found.drop_duplicates(subset=["instance", "method", "run"], keep="last", ignore_index=True)


def reference_row(rows: pd.DataFrame) -> pd.Series | None:
    """The exact reference among one instance's rows: the certified library's row when it is a
    proven optimum, else a proven ``reference`` row (one a study with ``reference="auto"`` solved),
    else the branch and bound's (``bnb``) row, else None.

    rows: the gap rows of one instance."""
    for method in ("library", "reference", "bnb"):
        found = rows[(rows["method"] == method) & rows["objective"].notna()]
        if len(found) and (method == "bnb" or found.iloc[0]["status"] == "optimal"):
            return found.iloc[0]
    return None


def run_seconds(rows: pd.DataFrame) -> tuple[pd.Series, str]:
    """The run times of ``rows`` (s) and how they were taken: the method's own clock (the extra
    ``said_solve_time_s``, the ``SolveResult.solve_time`` it returned) where every row carries it, else
    the wall time of each row's gap job (which adds the job's process start and result transfer).

    rows: gap rows of one or more runs."""
    own = pd.to_numeric(
        rows.get("cells_said_solve_time_s", pd.Series(np.nan, index=rows.index)), errors="coerce"
    )
    if len(rows) and own.notna().all():
        return own.astype(float), "the method's own clock"
    return rows["time_s"].astype(float), "wall time of its gap job"


def es_is_complete(row: pd.Series, stop_after: float) -> bool:
    """Whether the exhaustive search of ``row`` finished: its ``es_complete`` extra where the row
    has it, else whether its run time (:func:`run_seconds`) stayed below its limit (a stopped
    search runs at least that long).

    row: an exhaustive-search row. stop_after: the search's time limit (s)."""
    flag = row.get("cells_said_es_complete")
    if flag is not None and not (isinstance(flag, float) and np.isnan(flag)):
        return bool(flag)
    return bool(float(run_seconds(row.to_frame().T)[0].iloc[0]) < stop_after)


def _best_share(rows: pd.DataFrame) -> float:
    """The mean ``best_share`` of GA rows (NaN where the rows do not carry it)."""
    if "cells_said_best_share" not in rows:
        return float("nan")
    vals = pd.to_numeric(rows["cells_said_best_share"], errors="coerce").dropna()
    return float(vals.mean()) if len(vals) else float("nan")


# --------------------------------------------------------------------------- the ablation
GA_VARIANTS: dict[str, dict[str, Any]] = {
    "thesis": {"label": "thesis GA (Tables 4.1, 4.3)"},
    "T5": {"label": "SA at T=5 (scaled to the fitness)", "settings": {"T": 5.0}},
    "noSA": {"label": "no SA (improvements only)", "settings": {"T": 1e-9}},
    "abs-step": {"label": "absolute mutation step R_d", "settings": {"mutation_step": 500.0}},
    "repl50": {"label": "replace worst 50%", "settings": {"replace_frac": 0.5}},
    "no-restarts": {"label": "no restarts (1 run, same generations)", "no_restarts": True},
    "restarts-x4": {"label": "4 x N_start restarts (4 x the budget)", "restarts_factor": 4},
}
"""GA ablation variants, keyed by a short name: the faithful thesis GA and one
change each, as :class:`GASettings` fields (``settings``) or run shape (``no_restarts``: one
run of N_start x 50 generations; ``restarts_factor``: that many times N_start restarts, to see
whether the budget closes the gap); ``label`` says what changes. Only "thesis" is the thesis
method. Each is the study method ``ga-<name>`` (:func:`ga_run`); run r of every variant on an
instance has the seed of the thesis GA's run r (paired runs)."""


INSTANCE_VARIANTS: dict[str, dict[str, Any]] = {
    "thesis": {"label": "Table 4.2 users", "params": {}, "family": "table4.2"},
    "clusters-only": {
        "label": "thesis GA, clusters only (Table 4.2 without background users, lambda_nc = 0)",
        "params": {"lambda_nc": 0.0},
        "family": "table4.2-clusters",
    },
}
"""Instance side of the ablation: the Table 4.2 snapshot of a seed, and the same snapshot without
its uniform background users (the clustered users are drawn first, so they are the same
users); ``family`` is the instance family of each. The thesis GA and both references run on each."""


def _variant_method(variant: str) -> Method:
    spec = GA_VARIANTS[variant]
    params: dict[str, Any] = {}
    if spec.get("settings"):
        params["settings"] = dict(spec["settings"])
    if spec.get("no_restarts"):
        params["no_restarts"] = True
    if "restarts_factor" in spec:
        params["restarts_factor"] = int(spec["restarts_factor"])
    return ga_method(f"ga-{variant}", **params)


def instance_features(problem, centres=None) -> dict:
    """Descriptors of ``problem`` used to explain GA success (m, lengths in metres): active users,
    users within r1 + R_d of a GBS (coverable by a direct drone-cell), users within
    r1 + (m - 1) r2 + R_d (coverable at all), and, given the cluster ``centres`` ((c, 2) m,
    from :func:`~droneplan.scenarios.cells.thesis_instance`), the clusters whose centre lies
    within that reach and within direct reach."""
    from droneplan.core.validation import check_array, check_instance, check_size
    from droneplan.formulations.cells import CellProblem

    check_instance("problem", problem, CellProblem)
    if centres is not None:
        centres = check_array("centres", centres, shape=(None, 2))
        check_size("centres", float(len(centres)) * len(problem.gbs))

    def gbs_dist(pts):
        pts = np.asarray(pts, float).reshape(-1, 2)
        if not len(pts):
            return np.zeros(0)
        return np.min(
            np.hypot(pts[:, None, 0] - problem.gbs[None, :, 0], pts[:, None, 1] - problem.gbs[None, :, 1]),
            axis=1,
        )

    dg = gbs_dist(problem.targets)
    direct = problem.r1 + problem.R_d
    reach = problem.r1 + (problem.n_cells - 1) * problem.r2 + problem.R_d
    out = {
        "active_users": len(problem.targets),
        "users_direct_reach": int((dg <= direct).sum()),
        "users_in_reach": int((dg <= reach).sum()),
    }
    if centres is not None:
        dc = gbs_dist(centres)
        out["clusters_direct_reach"] = int((dc <= direct).sum())
        out["clusters_in_reach"] = int((dc <= reach).sum())
    return out


def _ga_run_cost(variant: str) -> int:
    """Solver calls one GA run of ``variant`` counts as in the ablation's work budget."""
    return int(GA_VARIANTS[variant].get("restarts_factor", 1))


def _check_ablation_work(
    n_instances: int,
    runs: int,
    ablation_runs: int,
    variants: list[str],
    instances: list[str],
    ablation_name: str = "ablation_runs",
) -> None:
    """Refuse, before any run, an ablation whose runs exceed the solves budget: the thesis runs
    (``runs``), then the other variants' and instance variants' runs (``ablation_runs``), then
    everything with the references."""
    thesis = float(n_instances) * runs * _ga_run_cost("thesis") if "thesis" in variants else 0.0
    check_work("runs", thesis, "solves")
    per_instance = sum(_ga_run_cost(v) for v in variants if v != "thesis") + (len(instances) - 1)
    other = float(n_instances) * ablation_runs * per_instance
    check_work(ablation_name, other, "solves")
    refs = 2.0 * n_instances * len(instances)
    check_work("runs and ablation_runs", thesis + other + refs, "solves")


def _keys(name: str, given, table: Mapping[str, Any], table_name: str) -> list[str]:
    keys = list(table) if given is None else check_sequence(name, given)
    unknown = [k for k in keys if k not in table]
    if unknown:
        raise ValueError(f"{name} must be keys of {table_name} {list(table)}, got {unknown}")
    return keys


def ablation_plan(
    *, seeds, ms, runs, ablation_runs=None, variants=None, instances=None, es_limit, exact_limit
) -> dict[str, Any]:
    """The checked settings of an ablation (:func:`ga_ablation`'s keywords but executor, store and
    out: seeds, ms, runs, ablation_runs, variants, instances, es_limit, exact_limit) and its gap
    studies (``parts``, :func:`ablation_parts`), refused up front beyond the solves budget."""
    seeds = [check_int("seeds", s, min_value=0) for s in check_sequence("seeds", seeds)]
    ms = [check_int("ms", m, min_value=1, max_value=4) for m in check_sequence("ms", ms)]
    variants = _keys("variants", variants, GA_VARIANTS, "GA_VARIANTS")
    instances = _keys("instances", instances, INSTANCE_VARIANTS, "INSTANCE_VARIANTS")
    runs = check_int("runs", runs, min_value=1)
    given = ablation_runs is not None
    ablation_runs = runs if ablation_runs is None else check_int("ablation_runs", ablation_runs, min_value=1)
    es_limit, exact_limit = check_positive("es_limit", es_limit), check_positive("exact_limit", exact_limit)
    _check_ablation_work(
        len(seeds) * len(ms),
        runs,
        ablation_runs,
        variants,
        instances,
        "ablation_runs" if given else "runs (the default ablation_runs)",
    )
    es = es_method(es_limit)
    parts: list[GapPart] = []
    for users in instances:
        family = INSTANCE_VARIANTS[users]["family"]
        unproven = {p.m: p.methods for p in reference_parts(family, ms, seeds, exact_limit)}
        for m in ms:
            # one study per number of runs; exhaustive search and the branch and bound (where the
            # library lacks the optimum) are deterministic and join the first, running once
            refs = (es, *unproven.get(m, ()))
            if users == "thesis":
                first = tuple(_variant_method(v) for v in variants if v == "thesis")
                rest = tuple(_variant_method(v) for v in variants if v != "thesis")
                groups = [(first, runs), (rest, ablation_runs)]
            else:
                groups = [((_variant_method("thesis"),), ablation_runs)]
            groups = [(methods, n) for methods, n in groups if methods]
            groups[0] = ((*groups[0][0], *refs), groups[0][1])
            parts += [GapPart(family, m, tuple(seeds), methods, n) for methods, n in groups]
    return {
        "seeds": seeds,
        "ms": ms,
        "variants": variants,
        "instances": instances,
        "es": es,
        "es_limit": es_limit,
        "parts": parts,
    }


def ablation_parts(**settings: Any) -> list[GapPart]:
    """The gap studies of :func:`ga_ablation` with these ``settings`` (its keywords but executor,
    store and out), checked and budgeted as there: per (instance variant, m) one study of the
    thesis GA's ``runs`` with exhaustive search and, where the certified library does not prove
    the optimum, the branch and bound (both deterministic: one run), and one of the other
    variants' ``ablation_runs``."""
    return list(ablation_plan(**settings)["parts"])


def _ablation_frame(df: pd.DataFrame, plan: Mapping[str, Any]) -> pd.DataFrame:
    """Per (seed, m, variant) the rows of :func:`ga_ablation` (its docstring) from the gap rows."""
    rows = []
    es_name = plan["es"].name
    for seed in plan["seeds"]:
        for m in plan["ms"]:
            for users in plan["instances"]:
                spec = INSTANCE_VARIANTS[users]
                own = df[(df["family"] == spec["family"]) & (df["seed"] == seed) & (df["size"] == m)]
                es_rows = own[(own["method"] == es_name) & own["objective"].notna()]
                exact = reference_row(own)
                if exact is None or not len(es_rows):
                    continue  # a reference failed (an error row): rerun to retry it
                es = es_rows.iloc[0]
                inst = thesis_instance(seed, dataclasses.replace(THESIS_TABLE_4_2, **spec["params"]))
                feats = instance_features(problem_from_instance(inst, m), inst.cluster_centres)
                proven = exact["status"] == "optimal"
                for v in plan["variants"] if users == "thesis" else ["thesis"]:
                    ga = own[own["method"] == f"ga-{v}"]
                    if not len(ga):
                        continue
                    obj = ga["objective"].astype(float).fillna(-np.inf).to_numpy()
                    valid = obj[np.isfinite(obj)]
                    rows.append(
                        {
                            "seed": seed,
                            "m": m,
                            "variant": v if users == "thesis" else users,
                            "users": users,
                            "label": GA_VARIANTS[v]["label"] if users == "thesis" else spec["label"],
                            "runs": len(obj),
                            "p_es": float(np.mean(obj >= float(es["objective"]))),
                            "p_exact": float(np.mean(obj >= float(exact["objective"]))) if proven else None,
                            "mean_obj": float(valid.mean()) if len(valid) else float("nan"),
                            "best_obj": float(valid.max()) if len(valid) else float("nan"),
                            "best_share": _best_share(ga),
                            "mean_time_s": float(run_seconds(ga)[0].mean()),
                            "es_obj": float(es["objective"]),
                            "es_complete": es_is_complete(es, plan["es_limit"]),
                            "es_time_s": float(run_seconds(es_rows.iloc[:1])[0].iloc[0]),
                            "exact_obj": float(exact["objective"]),
                            "exact_status": str(exact["status"]).upper(),
                            "exact_bound": None if pd.isna(exact["bound"]) else float(exact["bound"]),
                            **dict(sorted(feats.items())),
                        }
                    )
    return pd.DataFrame(rows)


def ablation_summary(abl: pd.DataFrame) -> pd.DataFrame:
    """Per (m, variant) over seeds: seeds, runs per seed, P_Global vs ES and vs the exact optimum
    (pooled over runs; vs the exact optimum over the seeds where it is proven), mean covered users,
    mean relative gap to the exact optimum, mean final-population share of the best chromosome."""
    out = []
    for (m, v), g in abl.groupby(["m", "variant"], sort=False):
        pm = g["p_exact"].dropna()
        out.append(
            {
                "m": m,
                "variant": v,
                "label": g["label"].iloc[0],
                "seeds": len(g),
                "runs_per_seed": int(g["runs"].iloc[0]),
                "p_global_es": float(g["p_es"].mean()),
                "p_global_exact": float(pm.mean()) if len(pm) else None,
                "mean_obj": float(g["mean_obj"].mean()),
                "mean_gap_to_exact": float(
                    ((g["exact_obj"] - g["mean_obj"]) / g["exact_obj"].clip(lower=1)).mean()
                ),
                "best_share": float(g["best_share"].mean()),
                "mean_time_s": float(g["mean_time_s"].mean()),
            }
        )
    return pd.DataFrame(out)


def _spearman(a, b) -> float | None:
    a, b = pd.Series(np.asarray(a, float)), pd.Series(np.asarray(b, float))
    if len(a) < 3 or a.std() == 0 or b.std() == 0:
        return None
    return float(a.rank().corr(b.rank()))


def ablation_correlations(abl: pd.DataFrame) -> pd.DataFrame:
    """Per m: Spearman rank correlation over seeds of the thesis GA's P_Global (vs ES) with each
    instance feature (None when a column is constant or there are fewer than 3 seeds)."""
    th = abl[abl["variant"] == "thesis"]
    feats = [
        c for c in ("users_in_reach", "users_direct_reach", "clusters_in_reach", "active_users") if c in th
    ]
    rows = [
        {"m": m, "feature": f, "spearman": _spearman(g["p_es"], g[f]), "seeds": len(g)}
        for m, g in th.groupby("m")
        for f in feats
    ]
    return pd.DataFrame(rows)


def share_text(share: float) -> str:
    """A final-population share of the best chromosome as text (``n/a`` when the rows lack it).

    share: a fraction in [0, 1] or NaN."""
    return "n/a" if share is None or pd.isna(share) else f"{share:.0%}"


def ablation_finding(abl: pd.DataFrame) -> str:
    """A short reading of the ablation, written from its numbers (the text of the reproduce
    output and notebook 02): per m, the faithful GA against both references, every variant's
    P_Global and mean covered users, and the rank correlations with the instance features."""
    summ = ablation_summary(abl)
    corr = ablation_correlations(abl)
    lines = []
    for m, g in summ.groupby("m", sort=True):
        th = g[g["variant"] == "thesis"].iloc[0]
        inst = abl[(abl["m"] == m) & (abl["variant"] == "thesis")]
        pm = th["p_global_exact"]
        pm_txt = "n/a (optimum not proven)" if pm is None or pd.isna(pm) else f"{pm:.0%}"
        below = int((inst["es_obj"] < inst["exact_obj"]).sum())
        line = (
            f"m={m}: the faithful GA reaches the exhaustive-search value in {th['p_global_es']:.0%} of "
            f"{th['seeds']} seeds x {th['runs_per_seed']} runs (thesis: {THESIS_TABLE_4_3[m][5]:.0%}) "
            f"and the exact optimum in {pm_txt}; it covers {th['mean_obj']:.1f} users on average against "
            f"{inst['es_obj'].mean():.1f} (ES) and {inst['exact_obj'].mean():.1f} (exact; ES is below it "
            f"on {below} of {len(inst)} seeds); its final populations are {share_text(th['best_share'])} "
            "copies of their best chromosome."
        )
        others = g[g["variant"] != "thesis"].sort_values(["p_global_es", "mean_obj"], ascending=False)
        if len(others):
            line += " One change at a time (P_Global vs ES, mean covered): " + "; ".join(
                f"{r['label']} {r['p_global_es']:.0%}, {r['mean_obj']:.1f}" for _, r in others.iterrows()
            )
            top = others.iloc[0]
            if top["p_global_es"] >= 0.9:
                line += f". {top['label']} alone brings P_Global to the thesis's level."
            elif top["p_global_es"] > th["p_global_es"]:
                line += f". No single change reaches the thesis's level; the largest rise is {top['label']}."
            else:
                line += ". No single change raises P_Global above the faithful GA's."
        cm = corr[(corr["m"] == m) & corr["spearman"].notna()]
        if len(cm):
            line += (
                " Rank correlation of the faithful GA's P_Global with instance features over seeds: "
                + ", ".join(f"{r['feature']} {r['spearman']:+.2f}" for _, r in cm.iterrows())
            )
            line += "."
        lines.append(line)
    return "\n".join(lines)


def _open(stack: contextlib.ExitStack, store, out, prefix: str):
    """``store``, or the store under ``out`` (a temporary directory when both are None)."""
    from droneplan.studies.common import open_store

    if store is None and out is None:
        out = Path(stack.enter_context(tempfile.TemporaryDirectory(prefix=prefix)))
    return stack.enter_context(open_store(store, out if out is not None else "."))


def _check_run_options(executor, store, out) -> None:
    from droneplan.core.validation import check_instance
    from droneplan.studies.common import StudyExecutor
    from droneplan.studies.store import ResultStore

    check_instance("executor", executor, StudyExecutor, optional=True)
    check_instance("store", store, ResultStore, optional=True)
    check_instance("out", out, (str, os.PathLike), optional=True)


def ga_ablation(
    *,
    seeds,
    ms,
    runs: int,
    variants=None,
    instances=None,
    es_limit: float = 600.0,
    exact_limit: float = 300.0,
    ablation_runs: int | None = None,
    executor=None,
    store=None,
    out: Path | None = None,
) -> pd.DataFrame:
    """P_Global of the thesis GA and of the ablation variants, through :func:`droneplan.gap`:
    every GA variant is a method run ``runs`` (thesis GA) or ``ablation_runs`` (the others) times
    per instance, exhaustive search one deterministic method, and the exact reference the
    certified library's row (the branch and bound, as a method, where the library lacks a proven
    optimum) (:func:`ablation_parts`). The rows go to ``store`` (default ``out/results.sqlite``; a
    temporary directory when ``out`` is None too), so an interrupted ablation resumes.

    seeds: thesis-scale instance seeds (non-empty); ms: numbers of drone-cells (1-4, non-empty);
    runs: GA runs of the thesis variant per instance; ablation_runs: runs of each other variant
    (default ``runs``); variants: keys of :data:`GA_VARIANTS` (default all); instances: keys of
    :data:`INSTANCE_VARIANTS` (default all; only the thesis GA runs on the other instance
    variants, ``ablation_runs`` times); es_limit, exact_limit: time limits (s) of the exhaustive
    search (a stopped search still gives its best value, flagged ``es_complete``) and of the exact
    solve where one runs (``p_exact`` is None unless the optimum is proven). Runs beyond the
    solves budget (every GA run one solver call, "restarts-x4" four, every reference two) are
    refused up front, naming ``runs`` or ``ablation_runs``; executor: a
    :class:`~droneplan.studies.common.StudyExecutor` the runs go to (None: one at a time);
    store: a ``ResultStore`` or None; out: a directory path or None.

    Returns one row per (seed, m, variant): ``runs``, ``p_es`` (share of runs reaching the
    exhaustive-search value), ``p_exact`` (reaching the proven optimum), ``mean_obj``,
    ``best_obj``, ``best_share`` (mean share of a final population equal to its best; NaN where
    the rows do not carry it), ``mean_time_s``, the references (``es_obj``, ``es_complete``,
    ``es_time_s``, ``exact_obj``, ``exact_status``, ``exact_bound``) and the instance features
    (:func:`instance_features`). ``attrs["finding"]`` holds :func:`ablation_finding`'s text and
    ``attrs["summary"]`` :func:`ablation_summary`'s table (per m and variant).
    """
    _check_run_options(executor, store, out)
    plan = ablation_plan(
        seeds=seeds,
        ms=ms,
        runs=runs,
        ablation_runs=ablation_runs,
        variants=variants,
        instances=instances,
        es_limit=es_limit,
        exact_limit=exact_limit,
    )
    with contextlib.ExitStack() as stack:
        st = _open(stack, store, out, "droneplan-ablation-")
        df = gap_rows(plan["parts"], store=st, executor=executor)
    return ablation_table(df, plan)


def ablation_table(df: pd.DataFrame, plan: Mapping[str, Any]) -> pd.DataFrame:
    """:func:`ga_ablation`'s table from its rows, with the finding and the summary in ``attrs``.

    df: the gap rows of the ablation's studies. plan: :func:`ablation_plan`'s settings."""
    abl = _ablation_frame(df, plan)
    abl.attrs["finding"] = ablation_finding(abl)
    abl.attrs["summary"] = ablation_summary(abl)
    return abl


# --------------------------------------------------------------------------- the readings
READINGS_FAMILY = "table4.2"
"""The instance family of the readings study (the Table 4.2 process, certified library)."""


def _readings_plan(*, seeds, ms, runs, readings, exact_limit) -> dict[str, Any]:
    from droneplan.planners.cells import GA_READINGS

    seeds = [check_int("seeds", v, min_value=0) for v in check_sequence("seeds", seeds)]
    ms = [check_int("ms", v, min_value=1, max_value=4) for v in check_sequence("ms", ms)]
    runs = check_int("runs", runs, min_value=1)
    readings = _keys("readings", readings, GA_READINGS, "GA_READINGS")
    check_work("runs", float(len(seeds)) * len(ms) * len(readings) * runs, "solves")
    methods = tuple(ga_method(f"ga-reading-{name}", reading=name) for name in readings)
    unproven = {p.m: p.methods for p in reference_parts(READINGS_FAMILY, ms, seeds, exact_limit)}
    parts = [GapPart(READINGS_FAMILY, m, tuple(seeds), (*methods, *unproven.get(m, ())), runs) for m in ms]
    return {"readings": readings, "parts": parts}


def _readings_frame(df: pd.DataFrame, readings: Sequence[str]) -> pd.DataFrame:
    """Per (m, reading) the table of :func:`ga_readings` from the gap rows."""
    from droneplan.planners.cells import GA_READINGS

    recs = []
    for _, own in df.groupby("instance", sort=False):
        ref = reference_row(own)
        if ref is None or ref["status"] != "optimal":
            continue  # no proven optimum: the instance does not count
        opt = float(ref["objective"])
        for name in readings:
            ga = own[own["method"] == f"ga-reading-{name}"]
            secs = run_seconds(ga)[0]
            for idx, row in ga.iterrows():
                obj = float(row["objective"]) if pd.notna(row["objective"]) else -np.inf
                recs.append(
                    {
                        "m": int(row["size"]),
                        "seed": int(row["seed"]),
                        "reading": name,
                        "hit": obj >= opt,
                        "gap": (opt - max(obj, 0.0)) / max(opt, 1.0),
                        "share": float(row["cells_said_best_share"])
                        if "cells_said_best_share" in row
                        else np.nan,
                        "time_s": float(secs.loc[idx]),
                    }
                )
    runs = pd.DataFrame(recs, columns=["m", "seed", "reading", "hit", "gap", "share", "time_s"])
    runs["order"] = runs["reading"].map({r: i for i, r in enumerate(readings)})
    out = []
    for (m, _, name), g in runs.groupby(["m", "order", "reading"], sort=True):
        out.append(
            {
                "m": int(m),
                "reading": name,
                "label": GA_READINGS[name]["label"],
                "reads": GA_READINGS[name]["reads"],
                "seeds": int(g["seed"].nunique()),
                "runs": len(g),
                "p_global": float(g["hit"].mean()),
                "mean_gap": float(g["gap"].mean()),
                "best_share": float(g["share"].mean()),
                "mean_time_s": float(g["time_s"].mean()),
            }
        )
    return pd.DataFrame(out)


def readings_markdown(frame: pd.DataFrame) -> str:
    """The readings study as a markdown table: one row per reading, P_Global per m (each with
    the runs and seeds behind it), the label and the sentence it reads.

    frame: :func:`ga_readings`'s table."""
    if frame.empty:
        return "(no runs)\n"
    ms = sorted(frame["m"].unique())
    head = [f"P_Global m={m} (runs / seeds)" for m in ms]
    lines = [
        "| reading | " + " | ".join(head) + " | what changes | reads |",
        "|---|" + "---|" * len(ms) + "---|---|",
    ]
    for name in dict.fromkeys(frame["reading"]):
        g = frame[frame["reading"] == name].set_index("m")
        cells = [
            f"{g.loc[m, 'p_global']:.0%} ({int(g.loc[m, 'runs'])} / {int(g.loc[m, 'seeds'])})"
            if m in g.index
            else "-"
            for m in ms
        ]
        first = g.iloc[0]
        lines.append(f"| {name} | " + " | ".join(cells) + f" | {first['label']} | {first['reads']} |")
    return "\n".join(lines) + "\n"


def ga_readings(
    *,
    seeds,
    ms,
    runs: int,
    readings=None,
    exact_limit: float = 120.0,
    executor=None,
    store=None,
    out: Path | None = None,
) -> pd.DataFrame:
    """P_Global of the thesis GA under each reading of :data:`~droneplan.planners.cells.GA_READINGS`
    on Table 4.2 instances, through :func:`droneplan.gap`: each reading is the method
    ``ga-reading-<name>`` run ``runs`` times per instance (run r of every reading with one seed),
    and the success criterion is the instance's proven optimum (the certified library's; the branch
    and bound, as a method of the study, where the library lacks it). The rows go to ``store``
    (default ``out/results.sqlite``; a temporary directory when ``out`` is None too), so an
    interrupted study resumes. With ``out``, writes ``ga_readings.csv`` and ``ga_readings.md``.

    seeds: Table 4.2 instance seeds; ms: numbers of drone-cells (1-4); runs: GA runs per
    instance and reading (every run one solver call against the ``solves`` work budget);
    readings: keys of ``GA_READINGS`` (default all); exact_limit: time limit of the branch and
    bound where the library holds no proven optimum (s); executor: a
    :class:`~droneplan.studies.common.StudyExecutor` the runs go to (None: one at a time); store: a
    ``ResultStore`` or None; out: a directory path or None.

    Returns per (m, reading), pooled over the seeds with a proven optimum: ``seeds``, ``runs``,
    ``p_global`` (share of runs reaching it), ``mean_gap`` (mean relative gap to it),
    ``best_share`` (mean share of a final population equal to its best; NaN where the rows do not
    carry it), ``mean_time_s``, with the reading's ``label`` and ``reads``; ``attrs["markdown"]``
    holds :func:`readings_markdown`'s text.
    """
    _check_run_options(executor, store, out)
    exact_limit = check_positive("exact_limit", exact_limit)
    plan = _readings_plan(seeds=seeds, ms=ms, runs=runs, readings=readings, exact_limit=exact_limit)
    with contextlib.ExitStack() as stack:
        st = _open(stack, store, out, "droneplan-readings-")
        df = gap_rows(plan["parts"], store=st, executor=executor)
    frame = _readings_frame(df, plan["readings"])
    frame.attrs["markdown"] = readings_markdown(frame)
    if out is not None:
        frame.to_csv(Path(out) / "ga_readings.csv", index=False)
        (Path(out) / "ga_readings.md").write_text(frame.attrs["markdown"])
    return frame
