"""The reproduction report: one static HTML page from what ``droneplan reproduce`` wrote.

``droneplan reproduce --quick --report`` (or ``python -m droneplan.studies.thesis.report OUT`` on an
existing ``--out`` directory) writes ``OUT/report.html``. It opens with the run itself: the machines
and code that made the stored rows and the last reproduce's wall and CPU time per section. For each
problem it shows every thesis
table written under ``OUT/<problem>/`` (the CSV files with ``thesis`` and ``this run`` columns,
deviation column included, rows beyond the deviation threshold highlighted), the list of those
rows with the reason each carries in its ``why`` column (:data:`FLAG_REASONS`; a flagged row
without one is marked), every PNG figure and GIF animation, the other CSV files as links, and a
short note on each place where droneplan deliberately deviates from the thesis (:data:`DEVIATIONS`).
Both registries also appear on the documentation's problem pages. Images and data are referenced by relative
paths, so the page works opened from disk.
"""

from __future__ import annotations

import argparse
import csv
import datetime as _dt
import html
import importlib.metadata
import re
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

from droneplan.studies.problems import PROBLEMS

__all__ = [
    "PROBLEMS",
    "CHAPTER_TITLES",
    "REPORT_NAME",
    "Deviation",
    "DEVIATIONS",
    "deviations_markdown",
    "FlagReason",
    "FLAG_REASONS",
    "flag_reasons",
    "flag_reasons_markdown",
    "write_report",
    "main",
]

CHAPTER_TITLES = {
    "covert": "Ch. 3: covert observation of moving animals",
    "cells": "Ch. 4: backhaul-aware drone-cell placement",
    "shark": "Ch. 5: shark interception",
    "herding": "Ch. 6: herding with barking drones",
}
"""Section title of each problem in the report."""

REPORT_NAME = "report.html"
"""File name of the report inside the ``--out`` directory."""


@dataclass(frozen=True)
class Deviation:
    """One deliberate difference from the thesis, with the reason."""

    where: str
    """The thesis element concerned (equation, table, proposition, figure)."""
    thesis: str
    """What the thesis says or does."""
    here: str
    """What droneplan does instead."""
    why: str
    """The reason."""


DEVIATIONS: dict[str, tuple[Deviation, ...]] = {
    "covert": (
        Deviation(
            "Table 3.2, U_max",
            "printed in m/s²",
            "the bound on |u| with ḣ = u and |h| = 1, a heading rate (rad/s); the simulator rotates h "
            "so |h| = 1 exactly",
            "the model only makes sense with |h| = 1; the unit in the table is a misprint",
        ),
        Deviation(
            "sliding-mode laws",
            "sign-type switching laws",
            "a piecewise-linear saturation by default (the variant the thesis simulates, §3.5); the literal "
            "law with SlidingSettings(saturation=False)",
            "the literal law chatters in discrete time",
        ),
        Deviation(
            "W(μ1, μ2) in (3.9)",
            "applied to f",
            "μ1 is normalised before the projection",
            "the projection needs a unit vector",
        ),
        Deviation(
            "worst-target switch (3.13)",
            "switch to the single worst target",
            "weights over the targets within delta_beta of the maximum",
            "without it the drone chatters between two lines near R and never leaves D_s",
        ),
        Deviation(
            "(3.17)",
            "adds p_m (metres) to a unit vector",
            "p_m enters by its direction (unit_p)",
            "the units do not match literally",
        ),
        Deviation(
            "end of the observation",
            "not specified",
            "ends when the remaining time equals the straight return time plus return_margin",
            "the mission must end at D_s within its duration",
        ),
        Deviation(
            "terrain and target paths",
            "shown in figures only",
            "smooth Gaussian hills and curves of our choice (case 1: two targets, case 2: ten)",
            "the thesis gives no coordinates",
        ),
    ),
    "cells": (
        Deviation(
            "GA fitness of infeasible chromosomes",
            "not fully specified",
            "a drone-cell contributes only when it clears every GBS cell, overlaps no other drone-cell (both "
            "overlapping cells are discarded) and reaches a GBS through contributing cells; fitness = users "
            "covered by contributing cells",
            "keeps the search effective, and the reported plan (the contributing subset) is always feasible",
        ),
        Deviation(
            "mutation (4.10) when f_best = 0",
            "divides by zero",
            "the factor (1 - f/f_best) is taken as 1; mutated coordinates are clipped to the area",
            "the formula is undefined there",
        ),
        Deviation(
            "crossover (4.11)",
            "exchange of coordinates",
            "the y coordinate of one random drone-cell is exchanged between randomly paired chromosomes",
            "the pairing and the gene are not specified",
        ),
        Deviation(
            "cluster radii (§4.4)",
            "random radii no larger than R_c",
            "drawn uniformly on (0, R_c]",
            "the distribution is not stated",
        ),
        Deviation(
            "optimality of the exhaustive search",
            "claimed for the continuous problem",
            "the MILP is exact over the candidate set, and a separate bound says how far that can be from "
            "the continuous optimum",
            "a proven statement needs a bound",
        ),
    ),
    "shark": (
        Deviation(
            "Prop. 5.3.1",
            "z_o* = z_s + l2 in case (c)",
            "kept verbatim as thesis_altitude; optimal_altitude (the exact maximiser) is ground truth",
            "with Table 5.1, case (c) puts the operator above le for -5.5 < z_s < -3.5 m, violating its "
            "own constraint",
        ),
        Deviation(
            "side rule (5.12, 5.20)",
            "written with both ≤ and <",
            "p is the perpendicular of the shark's velocity on the operator's side of its path",
            "a typo in the thesis",
        ),
        Deviation(
            "eq. 5.16",
            "divides by the shark's horizontal speed",
            "below speed_eps the last heading is kept and 5.16 is replaced by its limit",
            "guards against a shark speed going to 0",
        ),
        Deviation(
            "speed limits (5.5, 5.14)",
            "VoM along the line of sight",
            "the command is clipped to |v_xy| <= VoMxy and |v_z| <= VoMz",
            "the limits of §5.3.2",
        ),
        Deviation(
            "final step of a pursuit",
            "not discretised",
            "when the pursued point is reachable within one Ts the operator moves onto it",
            "avoids overshooting and chattering around the capture ball",
        ),
        Deviation(
            "shark reversal during step 2",
            "not covered",
            "restart_step1=True returns to step 1 when the along-path gap exceeds eps' (False: the thesis "
            "law alone)",
            "otherwise the operator shadows a reversing shark forever",
        ),
        Deviation(
            "field touch",
            "not defined",
            "the shark's snout, a point, entering either ball",
            "makes 'touched early' decidable",
        ),
        Deviation(
            "shark paths a-d (Fig. 5.12)",
            "described qualitatively",
            "our shapes, with mean speeds near Table 5.2",
            "no coordinates are given",
        ),
        Deviation(
            "reacting sharks (repelling)",
            "assumptions only",
            "a reacting-shark model of ours (SharkBehaviour)",
            "the thesis states no model",
        ),
    ),
    "herding": (
        Deviation(
            "animal model (6.1)",
            "Table 6.2 weights only",
            "Strömbom's interaction distance r_a = 2 m, attraction to the centre of mass of the n nearest "
            "neighbours, grazing with probability 0.05 outside every barking cone",
            "needed to simulate; taken from the cited model (Strömbom et al. 2014)",
        ),
        Deviation(
            "extended hull (Def. 6.3.1)",
            "the hull offset by d_s",
            "offset outward with mitred corners (same vertex count, parallel edges)",
            "keeps a one-to-one map between hull and extended-hull vertices",
        ),
        Deviation(
            "(6.22) for one drone",
            "reads 0 < 0",
            "the order constraints are dropped for n = 1",
            "a single drone cannot collide",
        ),
        Deviation(
            "guidance laws (6.13), (6.16)",
            "command v = -V_max when the target is behind, contradicting v in [0, V_max] of (6.5)",
            "implemented literally; the simulator accepts |v| <= V_max",
            "faithfulness to the laws",
        ),
        Deviation(
            "guidance in discrete time",
            "|v| = V_max until the target is reached",
            "|v| capped at the distance to go per step, the turn at the angle to go per step",
            "otherwise a drone overshoots and chatters by V_max·dt around its target",
        ),
        Deviation(
            "driving (§6.4.4)",
            "the semicircle moves towards G at constant speed",
            "its centre follows the enclosing circle's centre at no more than V_driving",
            "the semicircle never runs away from a slow herd nor lags behind a pushed one",
        ),
        Deviation(
            "fewer hull vertices than drones",
            "not covered",
            "extra steering points by splitting the longest arc gap",
            "every drone still gets a distinct destination",
        ),
    ),
}
"""Deliberate deviations from the thesis per problem (each module's docstring gives the details)."""


def deviations_markdown(problem: str) -> str:
    """The deviations of ``problem`` as a Markdown table (used by the documentation's problem pages)."""
    if problem not in DEVIATIONS:
        raise ValueError(f"problem must be one of {sorted(DEVIATIONS)}, got {problem!r}")

    def cell(text: str) -> str:
        return text.replace("|", "\\|")

    lines = ["| where | thesis | here | why |", "|---|---|---|---|"]
    lines += [
        f"| {cell(d.where)} | {cell(d.thesis)} | {cell(d.here)} | {cell(d.why)} |"
        for d in DEVIATIONS[problem]
    ]
    return "\n".join(lines)


@dataclass(frozen=True)
class FlagReason:
    """Why rows of a reproduce table deviate from the thesis beyond the threshold.

    The reason is one line; what backs it is a cited thesis statement (section, figure, table)
    or a measurement (a row or file of the same reproduction).
    """

    where: str
    """The rows concerned, for a reader (thesis figure or table, quantity)."""
    table: str
    """Regular expression searched in the table's title."""
    rows: str
    """Regular expression searched in the rows' quantity."""
    reason: str
    """The reason, one line."""
    backing: str
    """The thesis statement cited or the measurement that backs the reason."""

    def text(self) -> str:
        """The cell of the table's ``why`` column: the reason and, in brackets, its backing."""
        return f"{self.reason} [{self.backing}]"


_LAYOUT = (
    "§3.5 gives no coordinates ('a simulated uneven square zone (200 m by 200 m)'); the paths are drawn "
    "only in Figs 3.9c and 3.14a"
)

FLAG_REASONS: dict[str, tuple[FlagReason, ...]] = {
    "covert": (
        FlagReason(
            "Figs 3.10, 3.14: beta_max of hover and of sliding mode",
            r"^Case [12]: maximum recorded bearing change",
            r"^beta_max (hover benchmark|sliding mode) \(deg\)$",
            "our terrain and target paths are our own, so the absolute bearing changes differ",
            _LAYOUT,
        ),
        FlagReason(
            "Figs 3.10, 3.14: reduction of sliding mode vs hover",
            r"^Case [12]: maximum recorded bearing change",
            r"^reduction sliding vs hover",
            "on our scene no controller on the sphere gets far below sliding mode, so the margin over "
            "hover is capped by the scene, not by the controller",
            "measured: the row 'lower bound, any controller on the sphere' of the same table; " + _LAYOUT,
        ),
    ),
    "cells": (
        FlagReason(
            "Table 4.3: T_ES and T_GA",
            r"^Table 4\.3",
            r"T_ES|T_GA",
            "a computing time on another machine and implementation, reported as a speed-up",
            "§4.4: MATLAB 2019b on an HP desktop with a 7th-generation Intel Core i7 and 16 GB RAM",
        ),
        FlagReason(
            "Table 4.3: P_save",
            r"^Table 4\.3",
            r"P_save",
            "a ratio of two computing times of this implementation, not MATLAB's: our Algorithm 2 is a "
            "vectorised sweep (at m = 1 one sweep, faster than the GA's 50 x 30 generations), so the GA "
            "saves less at m = 1 and more at m = 2, 3 than in the thesis",
            "measured (thesis_problem(m, 0), CPU s under load 7-10 on 2 cores): Algorithm 2 as written "
            "(prune=False) 0.023 / 3.4 s at m = 1 / 2 and about 430 s at m = 3 (20 032 last-cell "
            "searches x 21-22 ms); the GA at Table 4.3 settings 0.14 / 0.51 / 2.3 s; P_save -490 % / "
            "85 % / 99.5 % (thesis -5.13 % / 47.4 % / 98.39 %)",
        ),
        FlagReason(
            "Table 4.3 P_Global, Fig. 4.3 success rates, GA ablation P_Global of the thesis GA",
            r"^(Table 4\.3|Fig\. 4\.3|GA ablation)",
            r"P_Global|^success",
            "the GA's populations collapse onto their best plan within each restart ((4.10) gives the best "
            "chromosome zero mutation and the 20 % replacement copies it), so few runs end on the optimum, "
            "under every reading of §4.3.2 measured: on 10 Table 4.2 instances per m (the thesis's "
            "snapshot is not published) P_Global against the proven optimum is 22 / 0 / 0 % at m = 1 / 2 "
            "/ 3 for ours, at most 24 / 1 / 0 % for any other single reading but carrying the best into "
            "each restart (45 / 7 %), and 50 / 3 / 0 % for all favourable readings together",
            "§4.3.2, (4.10)-(4.12), Table 4.2; measured: the GA readings study (ga_readings, 29 Nov 2026, "
            "200 / 80 / 19 runs per reading at m = 1 / 2 / 3, 20 / 14-30 / 9 for the restart-carrying "
            "ones; docs/problems/cells.md, 'Readings of the thesis GA') and 'final population ... copies "
            "of its best' in the ga_ablation table",
        ),
    ),
    "shark": (
        FlagReason(
            "Table 5.2: interception distance of the virtual shark",
            r"Table 5\.2",
            r"interception distance, virtual shark",
            "the shark paths are our shapes (the thesis describes them only qualitatively), and the "
            "distance shrinks with how much the path curves before contact, which ours may do less",
            "§5.4 ('a shark with curvier trajectory is likely to be intercepted in a shorter distance') "
            "and Fig. 5.12 (no coordinates); the mean speeds of Table 5.2 are matched (rows above); "
            "measured: path length vs displacement at contact, in this row",
        ),
    ),
    "herding": (
        FlagReason(
            "Fig. 6.7: proposed gathering and total times",
            r"^Fig\. 6\.7",
            r"animals: proposed (gathering|total) time",
            "not the same experiment: the thesis times one illustrative run per herd size on a herd it does "
            "not publish, with an animal model whose interaction distance and neighbour count it leaves "
            "open (ours are Strömbom's); ours are means over random herds",
            "§6.5 ('some illustrative results ... on two cases'), §6.3.1 (6.1) and Table 6.2 (weights only); "
            "measured: the per-seed times in fig_6_7_runs.csv (range in this row)",
        ),
        FlagReason(
            "Fig. 6.7: benchmark minus proposed",
            r"^Fig\. 6\.7",
            r"animals: benchmark minus proposed",
            "the benchmark is specified in one sentence (equal hull segments, side-to-side movement), so its "
            "times are those of our reading of it, and the thesis's gap is one illustrative run",
            "§6.5 (the benchmark paragraph; 'some illustrative results'); measured: the per-seed "
            "differences in fig_6_7_runs.csv (range in this row) and the gathering-only row below it",
        ),
    ),
}
"""Reasons for the reproduce rows that deviate from the thesis beyond the threshold, per problem
(the ``why`` column of the tables, the report and the documentation's problem pages)."""


def flag_reasons(problem: str) -> Callable[[str, str], str]:
    """The explainer of ``problem``'s reproduce tables (``ComparisonTable(..., explain=...)``).

    problem: one of :data:`PROBLEMS`. Returns ``explain(title, quantity)``: the ``why`` text of
    the first :data:`FLAG_REASONS` entry whose patterns match the table title and the row's
    quantity, or ``""``.
    """
    if problem not in FLAG_REASONS:
        raise ValueError(f"problem must be one of {sorted(FLAG_REASONS)}, got {problem!r}")
    entries = FLAG_REASONS[problem]

    def explain(title: str, quantity: str) -> str:
        for e in entries:
            if re.search(e.table, title) and re.search(e.rows, quantity):
                return e.text()
        return ""

    return explain


def flag_reasons_markdown(problem: str) -> str:
    """The flag reasons of ``problem`` as a Markdown table (the documentation's problem pages)."""
    if problem not in FLAG_REASONS:
        raise ValueError(f"problem must be one of {sorted(FLAG_REASONS)}, got {problem!r}")

    def cell(text: str) -> str:
        return text.replace("|", "\\|")

    lines = ["| rows | why | backed by |", "|---|---|---|"]
    lines += [f"| {cell(e.where)} | {cell(e.reason)} | {cell(e.backing)} |" for e in FLAG_REASONS[problem]]
    return "\n".join(lines)


@dataclass(frozen=True)
class _Table:
    stem: str
    title: str
    header: list[str]
    rows: list[list[str]]
    csv_path: str


def _read_table(path: Path, out: Path) -> _Table | None:
    with path.open(newline="", encoding="utf-8") as fh:
        rows = list(csv.reader(fh))
    if not rows or "thesis" not in rows[0] or "this run" not in rows[0]:
        return None
    title = path.stem.replace("_", " ")
    md = path.with_suffix(".md")
    if md.is_file():  # ComparisonTable.emit writes "**title**" as the first line of the Markdown copy
        first = md.read_text(encoding="utf-8").splitlines()[:1]
        if first and first[0].startswith("**") and first[0].endswith("**"):
            title = first[0].strip("*")
    return _Table(path.stem, title, rows[0], rows[1:], path.relative_to(out).as_posix())


def _table_html(table: _Table) -> str:
    flag_col = table.header.index("flag") if "flag" in table.header else None
    shown = [i for i, c in enumerate(table.header) if c != "flag"]
    head = "".join(f"<th>{html.escape(table.header[i])}</th>" for i in shown)
    body = []
    for row in table.rows:
        flagged = flag_col is not None and flag_col < len(row) and row[flag_col].strip() == "!"
        cells = "".join(f"<td>{html.escape(row[i]) if i < len(row) else ''}</td>" for i in shown)
        css = ("flagged unexplained" if not _why(table, row) else "flagged") if flagged else ""
        body.append(f'<tr class="{css}">{cells}</tr>' if css else f"<tr>{cells}</tr>")
    csv_path = html.escape(table.csv_path)
    return (
        f'<h3 id="{html.escape(table.stem)}">{html.escape(table.title)}</h3>\n'
        f"<table>\n<thead><tr>{head}</tr></thead>\n<tbody>\n" + "\n".join(body) + "\n</tbody>\n</table>\n"
        f'<p class="source">data: <a href="{csv_path}">{csv_path}</a></p>\n'
    )


def _why(table: _Table, row: list[str]) -> str:
    """The ``why`` cell of a table row ("" when the table has no such column)."""
    col = table.header.index("why") if "why" in table.header else None
    return row[col].strip() if col is not None and col < len(row) else ""


def _flagged(tables: Sequence[_Table]) -> list[tuple[_Table, str, str]]:
    """(table, quantity, why) of every row flagged ``!`` in ``tables``."""
    out = []
    for t in tables:
        if "flag" not in t.header:
            continue
        k = t.header.index("flag")
        out += [(t, r[0], _why(t, r)) for r in t.rows if k < len(r) and r[k].strip() == "!"]
    return out


def _flagged_html(tables: Sequence[_Table]) -> str:
    """The flagged rows of a problem with their reasons; a row without one is marked."""
    rows = _flagged(tables)
    if not rows:
        return "<p><i>No row deviates from the thesis beyond the threshold.</i></p>\n"
    items = "\n".join(
        f'<li><a href="#{html.escape(t.stem)}">{html.escape(t.title)}</a>: <b>{html.escape(q)}</b>: '
        + (html.escape(why) if why else '<span class="unexplained">NO REASON GIVEN</span>')
        + "</li>"
        for t, q, why in rows
    )
    summary = f"<summary>Rows beyond the threshold ({len(rows)}) and why</summary>"
    return f"<details open>{summary}\n<ul>\n{items}\n</ul>\n</details>\n"


def _deviations_html(problem: str) -> str:
    items = "\n".join(
        f"<li><b>{html.escape(d.where)}.</b> Thesis: {html.escape(d.thesis)}. Here: {html.escape(d.here)}. "
        f"<i>Why:</i> {html.escape(d.why)}.</li>"
        for d in DEVIATIONS.get(problem, ())
    )
    summary = "<summary>Deliberate deviations from the thesis</summary>"
    return f"<details open>{summary}\n<ul>\n{items}\n</ul>\n</details>\n"


_STYLE = """
body { font-family: system-ui, sans-serif; max-width: 1250px; margin: 2em auto; padding: 0 1em; color: #222; }
h1 { margin-bottom: 0.2em; } h2 { border-bottom: 2px solid #ccc; margin-top: 2em; }
table { border-collapse: collapse; margin: 0.5em 0; font-size: 0.9em; }
th, td { border: 1px solid #ccc; padding: 0.25em 0.6em; text-align: left; vertical-align: top; }
th { background: #f0f0f0; } tr.flagged td { background: #fff0d0; } tr.unexplained td { background: #ffd0d0; }
.unexplained { color: #b00; font-weight: bold; }
figure { display: inline-block; margin: 0.5em; vertical-align: top; max-width: 600px; }
figure img { max-width: 100%; border: 1px solid #ddd; } figcaption { font-size: 0.85em; color: #555; }
.source, .meta { font-size: 0.85em; color: #555; } details { margin: 0.5em 0 1em; }
"""


def _run_html(out: Path) -> str:
    """Where and how long the run took: the machines and code that made the stored rows (the
    store's provenance columns) and the last invocation's time per section (its time table),
    each only when ``out`` holds it."""
    from droneplan.studies.jobs import TIMES_NAME
    from droneplan.studies.store import STORE_NAME, ResultStore

    parts: list[str] = []
    if (out / STORE_NAME).is_file():
        with ResultStore(out / STORE_NAME, readonly=True) as store:
            runs = store.runs()
        escaped = [{k: html.escape(str(v)) for k, v in r.items()} for r in runs]
        items = "".join(
            f"<li>{e['rows']} rows: {e['cpu']} ({e['cores']} cores), droneplan {e['droneplan_version']}, "
            f"commit {e['git_commit']}, code hash {e['code_hash']}; "
            f"finished {e['first']} to {e['last']}</li>\n"
            for e in escaped
        )
        if items:
            parts.append(f"<p>The rows in the results store were made by:</p>\n<ul>\n{items}</ul>\n")
    times = out / TIMES_NAME
    if times.is_file():
        with times.open(newline="", encoding="utf-8") as fh:
            rows = list(csv.DictReader(fh))
        total = next((r for r in rows if r.get("section") == "total"), None)
        if total is not None:
            parts.append(
                f"<p>The last <code>droneplan reproduce</code> into this folder took "
                f"{float(total['span_s']):.0f} s of wall time and {float(total['cpu_s']):.0f} CPU seconds in "
                f"its {total['jobs']} jobs (a resumed run counts only the jobs it ran; the table below "
                f"is <code>{TIMES_NAME}</code>).</p>\n"
            )
        head = "<tr><th>section</th><th>jobs</th><th>CPU s</th><th>span s</th></tr>\n"
        body = "".join(
            f"<tr><td>{html.escape(r['section'])}</td><td>{r['jobs']}</td>"
            f"<td>{float(r['cpu_s']):.1f}</td><td>{float(r['span_s']):.1f}</td></tr>\n"
            for r in rows
        )
        parts.append(f"<table>\n{head}{body}</table>\n")
    if not parts:
        return ""
    return '<h2 id="run">This run: machine, code and time</h2>\n' + "".join(parts)


def _version() -> str:
    try:
        return importlib.metadata.version("droneplan")
    except importlib.metadata.PackageNotFoundError:  # running from a source tree that is not installed
        return "(not installed)"


def write_report(out: str | Path, *, problems: Sequence[str] = PROBLEMS, title: str | None = None) -> Path:
    """Write ``out/report.html`` from the tables (CSV), figures (PNG) and animations (GIF) under
    ``out/<problem>/``.

    out: the ``--out`` directory of ``droneplan reproduce``. problems: which problems to include
    (those without a directory are listed as not reproduced). title: the page title (default:
    "droneplan reproduction report"). Returns the path of the written page.
    """
    out = Path(out)
    if not out.is_dir():
        raise ValueError(f"out: {out} is not a directory (run droneplan reproduce --out {out} first)")
    unknown = [p for p in problems if p not in PROBLEMS]
    if unknown:
        raise ValueError(f"problems: unknown {unknown}; choose from {list(PROBLEMS)}")
    title = title or "droneplan reproduction report"
    generated = _dt.datetime.now(_dt.UTC).strftime("%Y-%m-%d %H:%M UTC")
    parts = [
        '<!DOCTYPE html>\n<html lang="en">\n<head>\n<meta charset="utf-8">\n'
        f"<title>{html.escape(title)}</title>\n"
        f"<style>{_STYLE}</style>\n</head>\n<body>\n<h1>{html.escape(title)}</h1>\n"
        f'<p class="meta">droneplan {html.escape(_version())}, generated {generated} from '
        f"<code>{html.escape(str(out))}</code>. Each table puts the thesis value beside this run; "
        "deviation = (this run - thesis) / |thesis|; rows beyond the threshold are highlighted and their "
        "'why' column gives the reason and what backs it (a thesis statement or a measurement). Computing "
        "times are shown as speed-ups, not as deviations.</p>\n<ul>\n"
    ]
    parts += [f'<li><a href="#{p}">{html.escape(CHAPTER_TITLES[p])}</a></li>\n' for p in problems]
    parts.append("</ul>\n")
    parts.append(_run_html(out))
    for problem in problems:
        folder = out / problem
        parts.append(f'<h2 id="{problem}">{html.escape(CHAPTER_TITLES[problem])}</h2>\n')
        parts.append(_deviations_html(problem))
        if not folder.is_dir():
            parts.append(
                f"<p><i>Not reproduced in this run (no {html.escape(problem)}/ directory).</i></p>\n"
            )
            continue
        tables, data = [], []
        for path in sorted(folder.glob("*.csv")):
            table = _read_table(path, out)
            if table is None:
                data.append(path.relative_to(out).as_posix())
            else:
                tables.append(table)
        parts.append(_flagged_html(tables))
        parts += [_table_html(t) for t in tables]
        figures = sorted([*folder.glob("*.png"), *folder.glob("*.gif")])  # GIFs: the runs animated
        if figures:
            parts.append("<h3>Figures</h3>\n")
        for fig in figures:
            rel = html.escape(fig.relative_to(out).as_posix())
            parts.append(
                f'<figure><a href="{rel}"><img src="{rel}" alt="{html.escape(fig.stem)}" loading="lazy"></a>'
                f"<figcaption>{html.escape(fig.stem.replace('_', ' '))}</figcaption></figure>\n"
            )
        from droneplan.studies.plots.maps import report_map_html  # folium loads for a report only

        parts.append(report_map_html(problem))  # the problem's interactive map, if it has one
        if data:
            links = ", ".join(f'<a href="{html.escape(d)}">{html.escape(d)}</a>' for d in data)
            parts.append(f'<p class="source">other data: {links}</p>\n')
    parts.append("</body>\n</html>\n")
    page = out / REPORT_NAME
    page.write_text("".join(parts), encoding="utf-8")
    return page


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m droneplan.studies.thesis.report OUT``: rebuild the report from an existing ``--out``."""
    parser = argparse.ArgumentParser(
        prog="python -m droneplan.studies.thesis.report", description=__doc__.splitlines()[0]
    )
    parser.add_argument(
        "out", type=Path, nargs="?", default=Path("results"), help="the reproduce --out directory"
    )
    args = parser.parse_args(argv)
    try:
        page = write_report(args.out)
    except ValueError as exc:
        parser.error(str(exc))
    print(f"report: {page}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
