"""The candidate-site MILP for drone-cell placement, with exact reductions and hop-level connectivity.

Model (over a candidate set, see ``_core.candidate_sites``)::

    max  sum_j y_j
    s.t. y_j <= sum_{c covers j} x_c          (coverage, eq. 4.9)
         sum_c x_c <= m
         x_c + x_d <= 1   if |c - d| < 2 R_d  (4.8, written as cliques, see below)
         hop-level connectivity (item 3)      (backhaul with relays, 4.7-4.8)
         x, y binary

Every candidate already satisfies |c - G_h| >= R_g + R_d (4.7) and the bounds, so
those constraints are enforced by the candidate filter.

Size engineering (thesis scale has ~5 000 candidates, ~10^6 pairs closer than 2 R_d
and ~3*10^6 pairs within r2, far too many to write out). Each item says what it does and
why the model stays exact; the measurements that chose between the options (per-seed
timings, LP bounds, rows tried and dropped) are on the page ``docs/findings/cells-milp.md``.

1. **Incumbent pruning (exact).** Any solution containing site c covers at most
   |S(c)| + B_{m-1} users, where B_{m-1} is the optimum of the *unconstrained*
   maximum coverage by m-1 discs (a relaxation: it drops non-overlap and backhaul,
   and by disjointness-free union bound |S(X)| <= |S(c)| + |S(X - c)|). If that is
   <= the value z of a known feasible solution, no solution containing c is better
   than z, so c is dropped unless it belongs to that incumbent (which is kept).
   The optimum of the reduced model is therefore the optimum of the full
   candidate model (either z, attained by the kept incumbent, or a better value
   reached only by unpruned sites).
2. **Non-overlap as cliques.** Points in one half-open square of side
   (2 R_d - TOL) / sqrt(2) are pairwise closer than 2 R_d - TOL (they overlap), so each square gives an
   at-most-one constraint; four grids shifted by half a square cover most
   conflicting pairs. Conflicting pairs that share no square are written as sector
   cliques: a site with its remaining partners in one 60-degree sector around it
   (``_sector_cliques``, exact by the law of cosines).
3. **Connectivity**, two exact formulations (``connectivity=``):

   a. **Lazy cuts.** A non-direct site c
   (not within r1 of a GBS) needs a chosen, non-overlapping neighbour within r2:
   ``x_c <= sum_{d in N(c)} x_d``. That alone admits chosen groups that only link to each
   other; for such a group C found in a solution we add, for W = the non-direct sites
   within distance delta of C (delta in {0, R_d}), ``x_e <= sum_{d in N(W) - W} x_d`` for
   every e in W (through one auxiliary binary): a chosen site in W reaches a GBS only
   through a chosen site outside W adjacent to W. Each cut is valid for every connected
   placement, every model in the loop is a relaxation of the candidate problem (so its
   bound is valid at any time), and the loop stops only at a connected optimum.

   b. **Hop levels** (default: no lazy rounds, and its LP charges the relays a far site
   needs). A site within r1 of a GBS
   is *direct* (level 1). A non-direct site c used at level l (2 <= l <= m) needs a
   used site at level l - 1 within r2 of it: ``z_{c,l} <= sum_{d in N(c)} z_{d,l-1}``
   (the level-1 variables are the direct sites' x), and ``x_c = sum_l z_{c,l}``.
   Exact: in a connected placement label every site with its hop count on a shortest
   backhaul path to a GBS (direct sites 1); a path among at most m drone-cells has at
   most m hops, and a site at hop l >= 2 has a neighbour at hop l - 1, so the labels
   satisfy the rows. Conversely, by induction on l every labelled site reaches a GBS.
   Level l is offered only to sites within r1 + (l - 1) r2 of a GBS (farther ones
   cannot be l hops away). A row leaves out the sources closer to c than 2 R_d - TOL and
   the squares of 3b wholly inside that disc: they overlap c, so they are 0 whenever c is
   used (item 2), and the neighbour that labels c is elsewhere in the row. This also
   stops the LP from feeding c from its own level-(l-1) variable through its own square.
4. **Objective cuts (exact).** ``sum_j y_j <= B_m`` (the continuous bound, from a
   relaxation) and ``sum_j y_j >= z`` for an incumbent of value z (no worse solution is
   of interest; the incumbent satisfies it and is the hint).
5. **User cliques (exact).** For a user u, the sites covering it are within R_d + TOL of
   u; unless two of them are >= 2 R_d - TOL apart (u in a lens, both may be chosen), they
   overlap pairwise and ``sum_{c covers u} x_c <= 1`` is a clique row.

6. **Coverage without user variables (exact).** A user of item 5 is covered exactly when
   ``sum_{c covers u} x_c = 1``, so it has no variable: its sites gain weight 1 in the
   objective. Lens users with the same covering sites share one weighted variable
   (``_coverage_objective``).
7. **Incumbent.** ``solve_exact`` polishes the greedy start with the branch and bound's
   primal heuristics before the model is built (a start only: every value is checked with
   ``evaluate``, and the model alone proves the bound). Items 1 and 4 prune with it.

8. **Lifted hop rows (exact; HiGHS and SCIP only, ``LIFTED_HOPS``).** The hop rows of 3b let
   the LP feed a far site from itself: a square term a_Q at level l - 1 may hold c's own
   z_{c,l-1}, so z_{c,l} <= z_{c,l-1} + ... costs no relay, and one relay at 1/3 feeds
   three overlapping sites at 1/3 each. The first is repaired for every backend in 3b; for
   the second every user clique C_u of item 5 gets
   ``sum_{c in C_u} z_{c,l} <= its sources`` (``_clique_hop_rows``; at most one site of C_u
   is used), where the squares straddling the circle of radius R_d - 3 TOL around u are
   written source by source. CP-SAT measured slower with them, so it stays off there.

9. **Light-site rows (exact; ``_light_site_rows``).** With the objective cut
   ``sum_j y_j >= lo`` of item 4 and B_k the continuous bound of k discs (B_0 = 0, B_k
   nondecreasing), a placement that holds k sites of weight |S(c)| <= t covers at most
   k t + B_{m-k} users (a union is at most the sum; its other sites are at most m - k
   discs). So when k t + B_{m-k} < lo for some k, at most k - 1 chosen sites weigh <= t:
   ``sum_{|S(c)| <= t} x_c <= k - 1`` (k the smallest such). Pairs likewise: two sites with
   |S(a)| + |S(b)| <= T = lo - 1 - B_{m-2} are never chosen together, written per t <= T/2
   as ``K sum_{|S(c)| <= t} x_c + sum_{t < |S(c)| <= T - t} x_c <= K``, K >= 1 the most
   sites of weight <= T - t the first rule allows (so the row cuts nothing else; two sites
   of the first sum are a pair too, 2 t <= T). Every placement worth >= lo satisfies them,
   and the incumbent (the hint) is worth lo. They stop the LP from paying relays with many
   light sites. ``solve_prepared`` writes them on CP-SAT only (``LIGHT_ROWS``: HiGHS
   measured slower with them).

10. **LP fixing (exact; ``lp_fixing``, CP-SAT only, ``LP_FIXING``).** CP-SAT with one
   worker does not bring its bound down to the LP bound of the lifted rows of item 8 on a
   model this size, while HiGHS's simplex solves that LP in a fraction of that time. So
   before the final model, when item 1 keeps at least ``LP_FIXING_MIN_SITES`` sites, the
   lifted model's LP relaxation is solved and its row duals y give, by weak duality over the
   0/1 box (``solvers.lp_bound``: valid for *any* y, so neither HiGHS's optimality nor its
   tolerances matter), a bound B on every placement worth at least the incumbent value z
   (the model's objective cut), and a bound B + min(d_c, 0) on those that hold site c (d_c
   the reduced cost of x_c). A site whose bound is below z + 1 is in no better placement and
   is dropped (the incumbent's sites stay); floor(B) caps the objective, and when it is <= z
   the incumbent is proven at once. The LP is built with hop levels 3..m merged when m <= 4
   (``LP_FIXING_LEVELS``, a relaxation, so its bounds stay valid), and item 10 is skipped
   above ``LP_FIXING_MAX_TERMS`` hop-row terms.

11. **Why the LP bound of Table 4.2 m = 6 seed 1 stays high**, and the rows tried on it and
   dropped: a measurement, on the findings page (the model with item 12 proves that
   instance's optimum, 66).

12. **Dominance rows (exact for the optimum; ``dominance_rows``, CP-SAT, ``DOMINANCE_ROWS``).**
   Order the model's sites by weight |S(c)| descending, then index. Let K(a) be the users of a
   that no model site at least 2 R_d - TOL from a covers (all of S(a) but for users on its very
   edge shared with a touching site; ``_private_users``). For a site a before b that overlaps
   it, with |K(a) - S(b)| >= |S(b) - S(a)| and a direct when b is, let E be the model's other
   sites that overlap a but not b, or are linked to b but not to a. The row
   ``x_b <= sum_{e in E} x_e`` cuts off feasible placements (those holding b and nothing of E),
   but never the one that matters. Let X* be the optimal
   candidate placement whose sites, sorted by the order, come lexicographically first. If X*
   held b and no site of E, X* - b + a would be a placement: a overlaps no site of X* - b (one
   overlapping a but not b would be in E, and none overlaps b), every site of X* linked to b is
   linked to a, and a is direct when b is, so every path through b can run through a. With U
   the users of X* - b, whose sites do not overlap a, U misses K(a), so a adds
   |S(a) - U| - |S(b) - U| = |(S(a) - S(b)) - U| - |(S(b) - S(a)) - U| >= |K(a) - S(b)| -
   |S(b) - S(a)| >= 0 users against b: X* - b + a covers S(X*) or more and comes earlier in the
   order, a contradiction. (Non-overlapping discs share only edge users, so the condition
   holds for nearly every pair with a before b; S(b) within S(a), the first form of these rows,
   is the special case |S(b) - S(a)| = 0.)
   When X* beats the incumbent, its sites are all in the model (items 1 and 10 drop only sites
   in no better placement, and each restricted round of the target scheme keeps every site of
   a placement worth more than its target), and it meets every other row (each valid for
   every placement worth at least the incumbent). So the model's optimum is the candidate
   optimum whenever that beats the incumbent, and its bound stays valid. Rows the incumbent
   breaks are left out, so the hint stays a solution (any subset of the rows is as exact),
   and E is taken 1e-6 m wide on every side, so rounding can only add sites to it. A site b
   with E empty is simply 0 (the branch and bound's item 13 clears such sites too). Clusters
   hold many near-identical sites, and without these rows the search visits each of them in
   turn with the same completion.

``solve_milp`` (``solve_exact(engine="milp")``) solves this model; ``branch_and_bound``
(``solve_exact(engine="bnb")``) solves the same candidate problem by the combinatorial
search of ``_bnb``. Both start from ``_prepare.prepare`` (candidates, incumbent, bounds).
"""

from __future__ import annotations

import dataclasses
import itertools
import math
import os
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.spatial import cKDTree

from droneplan.core.validation import (
    check_bool,
    check_instance,
    check_int,
    check_real,
    check_sequence,
    check_typed_array,
    machine_load,
    machine_memory,
)
from droneplan.formulations.cells._core import TOL, Candidates, candidate_sites, evaluate, pairwise_distances
from droneplan.formulations.cells._levels import build_level_model
from droneplan.formulations.cells._model import CellModel, _new_model, _objective_part, _sites_by_user
from droneplan.formulations.cells._prepare import Prepared, _feasible_subset, coverage_upper_bound
from droneplan.scenarios.cells import CellProblem
from droneplan.solvers.lazy import lazy_constraint_loop
from droneplan.solvers.lp_bound import lp_dual_bound
from droneplan.solvers.registry import available_backends
from droneplan.solvers.result import SolveResult, Status

BACKENDS = tuple(available_backends("linear"))
"""Backends (registry names of kind "linear") that can solve the cells models here."""

# With 1-2 workers CP-SAT's default portfolio has no LP-based subsolver, so its bound
# on this covering model stalls far above the optimum (m=4 thesis instance: bound 222 vs
# optimum 61 after 120 s). Two LP-based workers close it: the default LP search (what one
# worker runs) and the one with the full linearization. With the core-based worker in place
# of the first, Table 4.2 m = 4 seed 5 (2 workers, with item 10) stayed open at 61 / 65
# after 120 s (75 CPU s, load 3-4); with these two it was proven in 21.7 CPU s (34 s wall),
# seeds 0, 3, 4, 6 alike (4.8-6.8 CPU s either way). Keyed by backend name.
FEW_WORKER_OPTIONS: dict[str, dict[str, Any]] = {"cp-sat": {"subsolvers": ["default_lp", "max_lp"]}}
"""Backend options used when ``workers <= 2``, by registry name."""

TARGET_START: dict[str, float] = {"cp-sat": 0.0}
"""The first target of ``solve_prepared``'s descending scheme on the hop model, by backend
(others: 0.5; the lazy model always 0.5): incumbent + this share of the gap to the
continuous bound (0: the full reduced model at once). On CP-SAT with the light-site rows
(item 9) the scheme's rounds cost more than they save: Table 4.2 m = 4 seed 5, 1 worker,
120 s (rows in the first, stronger pair form): from 0.5 three rounds, open at bound 64
after 62 CPU s; from 0 one round, proven in 52 CPU s. On HiGHS, seed 0: 72.5 CPU s from 0
with the rows, not proven in 82 CPU s from 0.5 with them, 29 CPU s from 0.5 without."""

LIGHT_ROWS: dict[str, bool] = {"cp-sat": True}
"""Backends whose model gets the light-site rows of item 9 from ``solve_prepared`` (by registry
name). HiGHS is left out: Table 4.2 m = 4 seed 0 (one worker, load 4-5) stayed open at bound
65 after 82 CPU s with them and was proven in 29 CPU s without."""

DOMINANCE_ROWS: dict[str, bool] = {"cp-sat": True}
"""Backends whose models get the dominance rows of item 12 (by registry name). Measured once on
HiGHS (1 thread, load 1.8): held-out Table 4.2 m = 6 seed 30, open at 91 / 92 after 600 s
without them, proven in 598 s with them; one instance only, so HiGHS stays without them."""

DOMINANCE_PER_SITE = 2
"""Item 12: rows per dominated site b, from the dominating sites a whose E is smallest."""

DOMINANCE_MAX_PAIRS = 2_000_000
"""Item 12 looks for dominating sites among at most this many pairs of sites (the search radius
is halved until they fit): at Table 4.2 density x4 every overlapping pair would be tens of
millions."""

DOMINANCE_BLOCK = 1 << 20
"""``_private_users`` checks the edge users of item 12 this many (site, user, covering site)
triples at a time: at Table 4.2 density x4 (m = 4, 19,545 sites) a user is covered by up to
thousands of sites, and all triples at once took 2.7 GiB."""

DOMINANCE_SHARE = 0.1
"""Share of the time left that the rows of item 12 may take (rows are added site by site;
any subset of them is exact, so a cut-short pass is kept)."""

LP_FIXING: dict[str, bool] = {"cp-sat": True}
"""Backends whose hop model is first reduced by the LP fixing of item 10 (by registry name)."""

LP_FIXING_MIN_SITES = 1500
"""Item 10 runs only when the pruning of item 1 keeps at least this many sites (below it
CP-SAT proves Table 4.2 m = 4 in a few seconds, less than the LP takes)."""

LP_FIXING_LEVELS = 3
"""The LP of item 10 merges the hop levels from this one up (``build_milp(max_level=)``, a
relaxation) when m <= ``LP_FIXING_MERGE_MAX_M``: Table 4.2 m = 4 seed 5, LP 64.62 -> 65.00
but 26 -> 2.8 CPU s, 3 431 -> 3 253 sites dropped."""

LP_FIXING_MERGE_MAX_M = 4
"""Largest m whose item-10 LP merges levels. At m = 6 merging costs too much bound: Table 4.2
m = 6 seed 5 (incumbent 85), all levels: LP 88.90, 2 007 sites dropped, proven in 82 CPU s;
merged from level 3 or 5: 89.00, 1 284 or 1 329 dropped, not proven after 5 min wall."""

LP_FIXING_SHARE = 0.5
"""Share of the time left that the LP of item 10 may take (HiGHS returns no usable duals
before the simplex ends, so a stopped LP fixes nothing)."""

MODEL_BYTES_PER_TERM = 128
"""Peak memory of a model solve per hop-row term, bytes, with the backend's own copies: Table 4.2
density x4 at m = 4 (seed 0) peaked at 15.7 GiB with 139 M hop-row terms on CP-SAT (113 bytes a
term), rounded up."""

MODEL_MEMORY_SHARE = 0.5
"""Share of the machine's memory a model may take: a model whose hop rows pass
``MODEL_MEMORY_SHARE * memory / MODEL_BYTES_PER_TERM`` terms is refused (``model_term_cap``)."""


def model_term_cap() -> int | None:
    """Most hop-row terms a model may hold on this machine (None: its memory is not known)."""
    memory = machine_memory()
    return None if memory is None else int(MODEL_MEMORY_SHARE * memory / MODEL_BYTES_PER_TERM)


LP_FIXING_MAX_TERMS = 1_200_000
"""Item 10 is skipped when the lifted model has more hop-row terms than this (the build stops
as soon as the rows pass the cap: built in full and then discarded, that model cost 8-12 s of
m = 6 seed 1's time limit). With all hop levels, Table 4.2 m = 4 seed 5 (0.93 M terms) solved
its LP in about 25 CPU s, m = 6 seed 1 (1.5 M) had not after 300 s (merged from level 3 its
LP is 75.0, the cap already, and fixes nothing). By IPM (``LP_FIXING_METHOD``) it took 47
CPU s (bound 73.79, 268 sites fixed), and with the cap at 4 M m = 6 seed 1 ended at 66 / 73
after 600 s instead of 66 / 75, still open; but m = 8 seed 3 (CP-SAT, 1 worker, load 2)
then spent 68 s on that LP and was proven in 84 CPU s instead of 28, so the cap stays.
Measured again with the simplex handing over to IPM (``LP_FIXING_IPM_AFTER``), CP-SAT, 1
worker, load 1.2-2: m = 8 seed 3 (1.27 M lifted terms) with a cap of 4 M, 96.6 CPU s against
19.2 under this cap; a Thomas-process instance at m = 6 (7,045 sites, 1.67 M lifted terms),
353 CPU s under this cap, 243 with a cap of 4 M (the simplex switched to IPM after 30 s, 1,697
sites fixed), 548 with a cap of 2 M (the simplex ended in 45 s, 2,784 fixed, 4,261 sites left):
the fixing's effect on CP-SAT's search is erratic, so the cap still stays."""

LP_FIXING_METHOD = "simplex"
"""HiGHS's LP algorithm for item 10 (``lp_dual_bound(method=)``). Measured with IPM (with
crossover; the bound is valid either way), Table 4.2 m = 6, CP-SAT, 1 worker, load 2, CPU s
simplex / IPM: seed 3 121 / 32 (LP 115 / 20 s), seed 5 67 / 116 (IPM's duals fixed 768 sites
instead of 2 007), so neither wins."""

LP_FIXING_IPM_AFTER = 60.0
"""Seconds the simplex of item 10 gets before IPM takes over the rest of its time
(``lp_dual_bound(ipm_after=)``): a simplex stopped by its time limit fixes nothing. Table 4.2
m = 8 seed 4 (CP-SAT, 1 worker, load 2.8): the simplex hit its limit after 302.7 s (half the
time left) and fixed nothing, then CP-SAT proved 95 in about 10 s more (313.8 s wall); that LP
takes 273.6 CPU s by simplex and 15.4 by IPM, with the same bound (95.44, which proves the
incumbent 95) and 2,281 of 2,289 sites fixed by either. With the switch after 30 s the whole
solve took 56.5 s wall and 35.7 CPU s (load 2.6), proven by the LP fixing alone. m = 6 seed 3:
the simplex takes 120 s (1,990 sites fixed) and IPM 28 s (759 fixed); switched after 30 s the
solve was proven in 60.1 CPU s, 121 with the simplex alone. IPM is not always the faster: on a
Thomas-process instance (m = 6, 7,045 sites) the LP fixing (its build and the simplex) takes
42 s and fixes 2,784 sites, while switched after 30 s it took 164 s and fixed 1,697; and on
Table 4.2 m = 6 seeds 0-2 and 4-9 the simplex ends within 33 s. Hence 60 s. The threshold is in
seconds of a whole core: on a machine loaded past one runnable process per core it is stretched
by the load per core (``_ipm_after``). At load 5 on 2 cores, before that, m = 6 seed 5's
simplex (32 s alone) was stopped at 30 s wall, IPM fixed 768 sites instead of 2,007, and the
solve took 134.8 CPU s instead of 54.4. With 60 s (load 1.4-1.8): seed 5 proven in 44.3 CPU s
(the simplex ended in time), seed 3 in 86.9 (handed over after 60 s)."""


def _ipm_after() -> float:
    """``LP_FIXING_IPM_AFTER`` in wall seconds now: times the 1-minute load per core when that
    is above 1 (each runnable process then gets about cores / load of a core)."""
    load = machine_load()
    per_core = 0.0 if load is None else load / (os.cpu_count() or 1)
    return LP_FIXING_IPM_AFTER * max(1.0, per_core)


CONNECTIVITY = ("lazy", "hops")
"""Exact backhaul formulations of the candidate model (module docstring, item 3)."""


# --------------------------------------------------------------------------- model
@dataclass
class _SearchState:
    """Incumbent and bookkeeping shared by the rounds of ``solve_milp``'s target scheme."""

    inc: np.ndarray  # incumbent placement (m, 2), m
    inc_val: float  # users it covers
    rounds: int = 0  # model solves so far
    raw: str = ""  # the last backend status code
    stats: dict[str, Any] = field(default_factory=dict)  # the last model's size


def _grid_cliques(points: np.ndarray, R_d: float) -> list[np.ndarray]:
    side = (2 * R_d - TOL) / math.sqrt(2)  # same half-open square => distance < 2 R_d - TOL
    out: list[np.ndarray] = []
    for sx, sy in ((0, 0), (0.5, 0), (0, 0.5), (0.5, 0.5)):
        key = np.floor(points / side - np.array([sx, sy])).astype(np.int64)
        _, inv = np.unique(key, axis=0, return_inverse=True)
        inv = inv.ravel()
        order = np.argsort(inv, kind="stable")
        bounds = np.flatnonzero(np.diff(inv[order])) + 1
        out.extend(np.sort(grp) for grp in np.split(order, bounds) if len(grp) > 1)
    return out


def _uncovered_pairs(points: np.ndarray, R_d: float, cliques: list[np.ndarray]) -> np.ndarray:
    if len(points) < 2:
        return np.zeros((0, 2), dtype=np.int64)
    pairs = cKDTree(points).query_pairs(2 * R_d - 2 * TOL, output_type="ndarray")
    if len(pairs) == 0:
        return pairs.reshape(0, 2)
    d = np.hypot(*(points[pairs[:, 0]] - points[pairs[:, 1]]).T)
    pairs = pairs[d < 2 * R_d - TOL]
    side = (2 * R_d - TOL) / math.sqrt(2)  # same half-open square => distance < 2 R_d - TOL
    covered = np.zeros(len(pairs), dtype=bool)
    for sx, sy in ((0, 0), (0.5, 0), (0, 0.5), (0.5, 0.5)):
        key = np.floor(points / side - np.array([sx, sy])).astype(np.int64)
        covered |= np.all(key[pairs[:, 0]] == key[pairs[:, 1]], axis=1)
    return pairs[~covered]


_SQUARE = 6
"""The hop rows' squares have side r2 / ``_SQUARE``."""

LIFTED_HOPS: dict[str, bool] = {"highs": True, "scip": True}
"""Backends whose model gets the lifted hop rows of item 8 by default (by registry name;
others, CP-SAT among them, do not: measured slower there)."""


class _LevelSources:
    """The level-(l-1) sources of the hop rows at one level l, with their squares (item 3b)."""

    def __init__(
        self, pts: np.ndarray, src: np.ndarray, var, problem: CellProblem, lin, squares: dict, lev: int
    ):
        """pts: all sites (m); src: indices of the sources; var[d]: source d's variable at level
        l - 1; squares: the model's square map, extended here; lev: the level l."""
        side = problem.r2 / _SQUARE
        self.pts, self.src, self.var, self.side = pts, src, var, side
        self.reach = problem.r2 + TOL
        """Link range (m)."""
        keys, inv = np.unique(np.floor(pts[src] / side).astype(np.int64), axis=0, return_inverse=True)
        self.inv = inv.ravel()
        members = [src[self.inv == q] for q in range(len(keys))]
        self.agg = np.array([len(g) >= 2 for g in members])
        self.sq_var: dict[int, Any] = {}
        for q in np.flatnonzero(self.agg).tolist():
            v = lin.unit_var(f"square_any{lev - 1}_{q}")
            lin.add_implies_any(v, [var[d] for d in members[q].tolist()])
            self.sq_var[q] = v
            squares[lev - 1, tuple(keys[q].tolist())] = (v, members[q])
        self.lo = keys * side  # square corners (m)
        self.tree = cKDTree(pts[src])

    def terms(
        self, centre: np.ndarray, rch: float, inner: float = 0.0, skip: int = -1, split: bool = True
    ) -> list:
        """Terms for the sources at distance in [inner, rch] of ``centre`` (except ``skip``):
        the squares inside that disc by their variable, the other sources one by one. A square
        wholly closer than ``inner`` gives no term; with ``split`` (item 8) a square that
        straddles the ``inner`` circle is written source by source (its closer sources left
        out), without it by its variable."""
        lo, side = self.lo, self.side
        ax, ay = np.abs(lo[:, 0] - centre[0]), np.abs(lo[:, 0] + side - centre[0])
        bx, by = np.abs(lo[:, 1] - centre[1]), np.abs(lo[:, 1] + side - centre[1])
        far = np.hypot(np.maximum(ax, ay), np.maximum(bx, by))
        full = self.agg & (far <= rch) & (far >= inner)
        if inner > 0 and split:
            in_x = (lo[:, 0] <= centre[0]) & (centre[0] <= lo[:, 0] + side)
            in_y = (lo[:, 1] <= centre[1]) & (centre[1] <= lo[:, 1] + side)
            near = np.hypot(np.where(in_x, 0.0, np.minimum(ax, ay)), np.where(in_y, 0.0, np.minimum(bx, by)))
            full &= near >= inner
        idx = np.asarray(self.tree.query_ball_point(centre, rch), dtype=np.int64)
        idx = idx[~full[self.inv[idx]]]
        if inner > 0:
            idx = idx[np.hypot(*(self.pts[self.src[idx]] - centre).T) >= inner]
        out = [self.sq_var[q] for q in np.flatnonzero(full).tolist()]
        return out + [self.var[d] for d in self.src[idx].tolist() if d != skip]


def _clique_hop_rows(
    lin, z: dict, lev: int, clique_rows: list, sources: _LevelSources, R_d: float, late
) -> int | None:
    """The clique-lifted hop rows of item 8 at level ``lev``; returns their terms.

    For a user u whose covering sites C_u pairwise overlap (item 5):
    ``sum_{c in C_u} z_{c,l} <= sum of the level-(l-1) sources at distance in
    [R_d - 3 TOL, R_d + r2 + 2 TOL] of u``. Exact: at most one site of C_u is used, so the
    left side is 0 or 1. When it is 1, the used site c (within R_d + TOL of u) has a used
    level-(l-1) neighbour d within r2 + TOL of c, so within R_d + r2 + 2 TOL of u; and d does
    not overlap c (>= 2 R_d - TOL from c), so it is >= R_d - 2 TOL from u (a square term is
    positive only when a source in it is). None once ``late()`` (checked every
    ``_LATE_EVERY`` rows)."""
    n_terms = 0
    seen: set = set()
    rch = R_d + TOL + sources.reach
    for k, (centre, sites) in enumerate(clique_rows):
        if k % _LATE_EVERY == _LATE_EVERY - 1 and late():
            return None
        lhs_sites = tuple(c for c in sites if (c, lev) in z)
        if len(lhs_sites) < 2 or lhs_sites in seen:
            continue
        seen.add(lhs_sites)
        terms = sources.terms(centre, rch, inner=R_d - 3 * TOL)
        lin.add(lin.sum([z[c, lev] for c in lhs_sites]) <= lin.sum(terms))
        n_terms += len(terms)
    return n_terms


def _source_vars(lin, z: dict, nd: np.ndarray, lev: int, merged: bool) -> tuple[np.ndarray, dict]:
    """The sources of the hop rows at level ``lev`` >= 3 and their variables: the sites with a
    level-(lev-1) variable, by it. ``merged`` (the top level of a merged model, see
    ``_hop_levels``): the sites with a variable at level lev - 1 or lev, each by a unit
    u_d <= z_{d,lev-1} + z_{d,lev} ("at level lev - 1 or above")."""
    if not merged:
        src = np.array([c for c in nd.tolist() if (c, lev - 1) in z], dtype=np.int64)
        return src, {d: z[d, lev - 1] for d in src.tolist()}
    var: dict[int, Any] = {}
    for d in nd.tolist():
        own = [z[d, lv] for lv in (lev - 1, lev) if (d, lv) in z]
        if own:
            var[d] = lin.unit_var(f"hop_le{d}_{lev}")
            lin.add_implies_any(var[d], own)
    return np.array(sorted(var), dtype=np.int64), var


def _lowest_levels(problem: CellProblem, points: np.ndarray) -> np.ndarray:
    """The lowest hop level (>= 2) each non-direct site of ``points`` ((k, 2) m) may take in the
    hop rows of item 3b: level l reaches r1 + (l - 1) r2 from a GBS, each of the m links with
    tolerance TOL."""
    dg = np.min(pairwise_distances(points, problem.gbs), axis=1)
    reach = np.ceil((dg - problem.r1 - problem.n_cells * TOL) / problem.r2).astype(np.int64) + 1
    return np.maximum(2, reach)


def _hop_levels(
    lin,
    x: list,
    pts: np.ndarray,
    direct: np.ndarray,
    problem: CellProblem,
    late,
    clique_rows: list | None,
    top: int | None = None,
    max_terms: int | None = None,
    projected_cap: int | None = None,
):
    """The hop-level rows of item 3b, with the sources of a row grouped by squares.

    A square Q (side r2 / _SQUARE) holding several level-(l-1) sources gets one variable
    a_{Q,l-1} <= sum_{d in Q} z_{d,l-1}; the row of a site c then reads
    ``z_{c,l} <= sum_{Q inside B(c, r2 + TOL)} a_{Q,l-1} + sum_{other d in N(c)} z_{d,l-1}``.
    Exact: a square inside the (convex) link disc of c holds only neighbours of c, so a
    positive a_Q needs a used neighbour at level l - 1; conversely a labelled placement
    sets a_Q = 1 exactly for the squares with a used source. Grouping cut the rows' terms
    from 3.2 M to 0.61 M on Table 4.2 m = 4 seed 4 (r2 = 3 km reaches a third of the area;
    sides r2/4, r2/8, r2/12: 0.64, 0.66, 0.89 M), and CP-SAT (1 worker) then proves seed 4
    in 101 s (before: bound 61 after 120 s) and seed 3 in 21 s (before: 80 s).

    ``clique_rows`` (a list of (user position, its clique sites), or None): the lifted rows
    of item 8.

    ``top`` < m (a relaxation, for item 10 only): levels top..m merge into one, "level top or
    above", whose rows take the sources at level top - 1 or top. Every connected placement
    still satisfies the rows (label a site at hop h >= top with top: its neighbour at hop
    h - 1 is labelled top - 1 or top), but a far site may then be fed by another far site.

    Returns (z, squares, level variables, terms), or None once ``late()`` (checked every
    ``_LATE_EVERY`` rows: one level of Table 4.2 m = 6 takes seconds) or once the rows hold
    more than ``max_terms`` terms (None: no cap), or before a level whose projection
    (``_projected_terms``) passes ``projected_cap`` (None: no projection)."""
    m = problem.n_cells
    top = m if top is None else min(m, max(3, top))
    nd = np.flatnonzero(~direct)
    # sources closer than 2 R_d - TOL overlap c and are never used with it (item 3b)
    inner = 2 * problem.R_d - 2 * TOL
    lowest = np.minimum(_lowest_levels(problem, pts[nd]), top)
    z: dict[tuple[int, int], Any] = {}
    for k, c in enumerate(nd.tolist()):
        for lev in range(int(lowest[k]), top + 1):
            z[c, lev] = lin.bool_var(f"hop{c}_{lev}")
    for k, c in enumerate(nd.tolist()):
        lin.add(lin.sum([z[c, lev] for lev in range(int(lowest[k]), top + 1)]) == x[c])
    squares: dict = {}
    n_vars = n_terms = 0

    def stop(terms: int) -> bool:
        return late() or (max_terms is not None and terms > max_terms)

    for lev in range(2, top + 1):
        rows = nd[lowest <= lev]
        src, var = (np.flatnonzero(direct), x) if lev == 2 else _source_vars(lin, z, nd, lev, lev == top < m)
        if len(rows) == 0 or len(src) == 0:
            for c in rows.tolist():
                lin.add_implies_any(z[c, lev], [])
            continue
        sources = _LevelSources(pts, src, var, problem, lin, squares, lev)
        projection = None if projected_cap is None else (projected_cap, top - lev + 1)
        level_terms = _level_rows(
            lin, z, lev, rows, sources, inner, clique_rows, problem.R_d, stop, n_terms, projection
        )
        if level_terms is None:
            return None
        n_vars += len(rows)
        n_terms += level_terms
    return z, squares, n_vars, n_terms


PROJECTION_MARGIN = 1.1
"""``build_milp(project_terms=True)`` stops when the projected hop-row terms pass ``max_terms``
by more than this factor (room for the sampling error of ``_projected_terms``)."""

_PROJECTION_SAMPLE = 200
"""Rows of a level whose terms ``_projected_terms`` counts."""


def _projected_terms(sources: _LevelSources, rows: np.ndarray, inner: float) -> float:
    """The terms of one level's hop rows estimated from a fixed random sample of its rows (their
    mean times the rows). Counting them adds nothing to the model. A later level has at least
    the rows of this one and usually more sources (the non-direct sites, not level 2's direct
    ones), so ``_level_rows`` multiplies by the levels left, usually an underestimate: on Table
    4.2 density x4 at m = 4 level 2 projects 38.7 M terms (43,288 rows) of the 139 M the three
    levels wrote."""
    rng = np.random.default_rng(0)
    sample = rng.choice(rows, size=min(_PROJECTION_SAMPLE, len(rows)), replace=False)
    counts = [
        len(sources.terms(sources.pts[c], sources.reach, inner=inner, skip=c, split=False))
        for c in sample.tolist()
    ]
    return float(np.mean(counts)) * len(rows) if counts else 0.0


def _projected_model_terms(
    problem: CellProblem, cand: Candidates, keep: np.ndarray, backend: str
) -> tuple[float, float]:
    """The hop-row terms of the exact hop model (item 3b) over the sites ``keep`` of ``cand``
    projected as ``build_milp(project_terms=True)`` first projects them, before anything of the
    model is built: level 2's terms from the same sample of its rows (``_projected_terms``)
    times the m - 1 levels. Returns (that projection, level 2's projection); (0, 0) without
    level-2 rows or sources. Level 2's rows and sources are those of ``_hop_levels``: the
    non-direct sites within r1 + r2 (with its tolerance) of a GBS, and the direct sites; only
    their square variables are made, on a scratch model of ``backend``."""
    m = problem.n_cells
    pts, direct = cand.points[keep], cand.direct[keep]
    nd, src = np.flatnonzero(~direct), np.flatnonzero(direct)
    if m < 2 or len(nd) == 0 or len(src) == 0:
        return 0.0, 0.0
    rows = nd[_lowest_levels(problem, pts[nd]) <= 2]
    if len(rows) == 0:
        return 0.0, 0.0
    lin = _new_model(backend)
    var = {d: lin.bool_var(f"site{d}") for d in src.tolist()}
    sources = _LevelSources(pts, src, var, problem, lin, {}, 2)
    level2 = _projected_terms(sources, rows, 2 * problem.R_d - 2 * TOL)
    return level2 * (m - 1), level2


def _level_rows(
    lin,
    z: dict,
    lev: int,
    rows: np.ndarray,
    sources: _LevelSources,
    inner: float,
    clique_rows: list | None,
    R_d: float,
    stop,
    before: int,
    projection: tuple[int, int] | None = None,
) -> int | None:
    """The hop rows of item 3b at level ``lev`` for the sites ``rows`` (sources closer than
    ``inner`` left out) and, with ``clique_rows``, the lifted rows of item 8; returns their
    terms, or None once ``stop(terms written, ``before`` included)`` is true (checked every
    ``_LATE_EVERY`` rows and at the end). ``projection`` (cap, levels left): None without
    writing a row when ``before`` plus this level's projected terms (``_projected_terms``) times
    the levels left pass ``PROJECTION_MARGIN`` times the cap."""
    if projection is not None:
        cap, levels_left = projection
        if before + _projected_terms(sources, rows, inner) * levels_left > PROJECTION_MARGIN * cap:
            return None
    n_terms = 0
    for k, c in enumerate(rows.tolist()):
        if k % _LATE_EVERY == _LATE_EVERY - 1 and stop(before + n_terms):
            return None
        terms = sources.terms(sources.pts[c], sources.reach, inner=inner, skip=c, split=False)
        lin.add_implies_any(z[c, lev], terms)
        n_terms += len(terms)
    if clique_rows:
        lifted = _clique_hop_rows(lin, z, lev, clique_rows, sources, R_d, lambda: stop(before + n_terms))
        if lifted is None:
            return None
        n_terms += lifted
    return None if stop(before + n_terms) else n_terms


_LATE_EVERY = 256
"""Rows between two deadline checks while the hop rows are written."""


def _sector_cliques(points: np.ndarray, pairs: np.ndarray) -> list[np.ndarray]:
    """Conflicting ``pairs`` (a, b) as clique rows: for each site a, its partners b in one
    60-degree sector around a, together with a.

    Exact: partners b, b' of a at distances p, q < L = 2 R_d - TOL whose directions from a
    differ by theta < 60 degrees satisfy |b - b'|^2 = p^2 + q^2 - 2 p q cos(theta)
    < p^2 + q^2 - p q <= max(p, q)^2 < L^2, so they conflict too and the group is a clique.
    Every pair lies in the row of its first site, so the rows imply every pair row and
    their LP is at least as tight (the aggregated per-site rows used before were weaker:
    Table 4.2 m = 4 seed 4 has 211 053 pairs outside the grid cliques)."""
    if len(pairs) == 0:
        return []
    d = points[pairs[:, 1]] - points[pairs[:, 0]]
    sector = np.floor((np.arctan2(d[:, 1], d[:, 0]) + math.pi) / (math.pi / 3)).astype(np.int64) % 6
    key = pairs[:, 0].astype(np.int64) * 6 + sector
    order = np.argsort(key, kind="stable")
    starts = np.flatnonzero(np.r_[True, np.diff(key[order]) != 0])
    groups = np.split(order, starts[1:])
    return [np.r_[pairs[g[0], 0], pairs[g, 1]] for g in groups]


def _light_site_rows(lin, x: list, weights: np.ndarray, lo: float, bounds: list[float]) -> int:
    """The light-site rows of item 9 for the objective cut ``sum_j y_j >= lo``; returns how
    many were added.

    weights: |S(c)| per site of ``x``; bounds: B_0, ..., B_m, the continuous bound of k discs
    (covered users, B_0 = 0), each valid for any k pairwise compatible candidate sites."""
    m = len(bounds) - 1
    lo_i = math.ceil(lo - 1e-9)
    if len(x) == 0 or m < 1:
        return 0
    order = np.argsort(weights, kind="stable")
    ws = weights[order]

    def lighter(t: int) -> list:
        return [x[i] for i in order[: np.searchsorted(ws, t, side="right")].tolist()]

    def most(t: int) -> int:
        """How many chosen sites of weight <= t a placement worth >= lo holds at most."""
        k = next((k for k in range(1, m + 1) if k * t + bounds[m - k] < lo_i), None)
        return m if k is None else k - 1

    n_rows = 0
    for t in range(int(ws[-1]) + 1):
        light = lighter(t)
        if len(light) > most(t):
            lin.add(lin.sum(light) <= most(t))
            n_rows += 1
    if m >= 2:
        top = lo_i - 1 - math.floor(bounds[m - 2] + 1e-9)  # two sites weighing <= top in all: excluded
        for t in range(top // 2 + 1):
            light, heavier = lighter(t), lighter(top - t)
            cap = most(top - t)
            if len(light) and len(heavier) > len(light) and cap >= 1:
                # a site of weight <= t (coefficient cap) excludes every other site of weight <= top - t
                others = heavier[len(light) :]
                lin.add(lin.sum([cap * v for v in light] + others) <= cap)
                n_rows += 1
    return n_rows


def reduce_candidates(
    problem: CellProblem,
    cand: Candidates,
    incumbent_value: float,
    incumbent_sites: np.ndarray,
    bound_m_minus_1: float,
) -> np.ndarray:
    """Indices of candidates kept by the exact incumbent pruning (see module docstring, item 1)."""
    size = np.array([len(c) for c in cand.cover])
    keep = size + bound_m_minus_1 > incumbent_value + 1e-9
    if len(incumbent_sites):
        keep |= np.any(pairwise_distances(cand.points, incumbent_sites) <= 1e-3, axis=1)
    return np.flatnonzero(keep)


def _as_keep(keep: Any, n: int) -> np.ndarray:
    """``keep`` as a 1-D int64 array of distinct indices into ``n`` candidates (TypeError for
    floats and bools, ValueError out of range or repeated); an empty list keeps nothing."""
    arr = check_typed_array("keep", keep, "iu", "an array of int candidate indices")
    if arr.ndim != 1:
        raise ValueError(f"keep must be a 1-D array of candidate indices, got shape {arr.shape}")
    if arr.size and (int(arr.min()) < 0 or int(arr.max()) >= n):
        raise ValueError(
            f"keep must hold indices in [0, {n}) (the candidates), got {int(arr.min())}..{int(arr.max())}"
        )
    if len(np.unique(arr)) != len(arr):
        raise ValueError("keep must not repeat a candidate index")
    return arr.astype(np.int64)


def _as_objective_range(objective_range: Any) -> tuple[float, float] | None:
    """None, or ``objective_range`` as a pair (lo, hi) of finite numbers (covered users)."""
    if objective_range is None:
        return None
    pair = check_sequence("objective_range", objective_range, min_len=2)
    if len(pair) != 2:
        raise ValueError(f"objective_range must be a pair (lo, hi), got {len(pair)} items")
    return check_real("objective_range[0]", pair[0]), check_real("objective_range[1]", pair[1])


def _as_max_level(max_level: Any) -> int | None:
    """None, or ``max_level`` as an int >= 3 (a hop level)."""
    return None if max_level is None else check_int("max_level", max_level, min_value=3)


def _as_disc_bounds(disc_bounds: Any, m: int) -> list[float] | None:
    """None, or ``disc_bounds`` as m + 1 finite numbers B_0 = 0 <= B_1 <= ... <= B_m."""
    if disc_bounds is None:
        return None
    seq = check_sequence("disc_bounds", disc_bounds, min_len=m + 1)
    if len(seq) != m + 1:
        raise ValueError(f"disc_bounds must hold m + 1 = {m + 1} bounds (B_0..B_m), got {len(seq)}")
    vals = [check_real(f"disc_bounds[{k}]", b) for k, b in enumerate(seq)]
    if vals[0] != 0 or any(b < a for a, b in itertools.pairwise(vals)):
        raise ValueError(f"disc_bounds must start at 0 and never decrease, got {vals}")
    return vals


def _check_connectivity(connectivity: Any) -> None:
    if connectivity not in CONNECTIVITY:
        raise ValueError(f"connectivity must be one of {CONNECTIVITY}, got {connectivity!r}")


def build_milp(
    problem: CellProblem,
    *,
    backend: str = "cp-sat",
    candidates: Candidates | None = None,
    keep: np.ndarray | None = None,
    objective_range: tuple[float, float] | None = None,
    deadline: float | None = None,
    pair_limit: int = 50_000,
    connectivity: str = "hops",
    cuts: list | None = None,
    user_cliques: bool = True,
    lifted_hops: bool | None = None,
    disc_bounds: Any = None,
    max_level: int | None = None,
    max_terms: int | None = None,
    project_terms: bool = False,
) -> CellModel | None:
    """Build the candidate model (module docstring) without solving it.

    backend: "cp-sat" (default), "highs" or "scip".
    candidates: a candidate set (default :func:`candidate_sites(problem)`).
    keep: distinct indices of candidates to keep (a 1-D int array; default all), e.g. from
        :func:`reduce_candidates`.
    objective_range: (lo, hi) covered users, finite, written as ``lo <= sum_j y_j <= hi``
        (item 4), or None.
    pair_limit: an int >= 0, unused (conflicting pairs left over by the grid cliques are always
        written as sector cliques, item 2); kept for callers that pass it.
    deadline: a ``time.perf_counter()`` value; building stops and returns None once it
        has passed (None: no limit).
    connectivity: "hops" (default; item 3b: the exact hop-level model) or "lazy" (item 3a:
        one neighbour row per non-direct site plus ``cuts``; a relaxation until the cut loop
        of :func:`solve_milp` finds a connected optimum).
    cuts: for "lazy", cuts found so far: ("clique", idx) or ("conn", W_idx, boundary_idx),
        indices into the full candidate set (restricted to ``keep``: dropped sites are 0, so a
        restricted cut stays valid).
    user_cliques: add the per-user at-most-one rows of item 5 (default True).
    lifted_hops: add the lifted hop rows of item 8 ("hops" with ``user_cliques`` only); None
        (default): per backend, ``LIFTED_HOPS``.
    disc_bounds: None, or (B_0, ..., B_m): for k = 0..m an upper bound on the users any k
        discs cover (covered users, e.g. ``coverage_upper_bound(problem, k)``; B_0 = 0);
        with ``objective_range`` they add the light-site rows of item 9.
    max_level: None (default: the exact model), or an int >= 3: hop levels from this one up
        merge into one (``_hop_levels``), a relaxation of the candidate problem with fewer
        rows, whose bounds are valid but whose solutions may be disconnected.
    max_terms: None (default: no cap), or an int >= 0: building stops and returns None as
        soon as the hop rows hold more terms than this (so a model too large to be used
        costs no full build).
    project_terms: with ``max_terms``, also stop before a hop level is written when the terms
        written so far plus that level's, estimated from a sample of its rows, times the levels
        left (later levels have at least as many sources, see ``_projected_terms``) pass
        ``max_terms`` by more than ``PROJECTION_MARGIN``.
    """
    check_instance("problem", problem, CellProblem)
    if problem.altitudes is not None:  # the model with altitude levels (``_levels``)
        return build_level_model(problem, backend=backend, deadline=deadline)
    max_terms = None if max_terms is None else check_int("max_terms", max_terms, min_value=0)
    project_terms = check_bool("project_terms", project_terms)
    max_level = _as_max_level(max_level)
    lifted_hops = None if lifted_hops is None else check_bool("lifted_hops", lifted_hops)
    _check_connectivity(connectivity)
    check_instance("candidates", candidates, Candidates, optional=True)
    check_int("pair_limit", pair_limit, min_value=0)
    user_cliques = check_bool("user_cliques", user_cliques)
    objective_range = _as_objective_range(objective_range)
    bounds_k = _as_disc_bounds(disc_bounds, problem.n_cells)
    lin = _new_model(backend)

    def late() -> bool:
        return deadline is not None and time.perf_counter() > deadline

    cand = candidate_sites(problem) if candidates is None else candidates
    idx = np.arange(len(cand.points)) if keep is None else _as_keep(keep, len(cand.points))
    pts = cand.points[idx]
    cover = [cand.cover[i] for i in idx]
    direct = cand.direct[idx]
    x = [lin.bool_var(f"site{i}") for i in range(len(pts))]
    y, objective, user_clique_sites, n_subst, group_of, serve = _objective_part(
        lin, x, pts, cover, problem, user_cliques
    )
    if x:
        lin.add(lin.sum(x) <= problem.n_cells)
    # (4.8) non-overlap: grid cliques, then every remaining conflicting pair
    overlap = None if late() else _nonoverlap_rows(lin, x, pts, problem.R_d, late)
    if overlap is None or late():
        return None
    stats = {
        "candidates": len(cand.points),
        "kept": len(pts),
        "users": len(y),
        "substituted_users": n_subst,
        **overlap,
        "connectivity": connectivity,
        "level_vars": 0,
        "connectivity_terms": 0,
        "lazy_cuts": 0,
        "user_cliques": len(user_clique_sites),
        "light_site_rows": 0,
    }
    z: dict[tuple[int, int], Any] = {}
    squares: dict = {}
    if connectivity == "lazy":
        terms = _neighbour_rows(lin, x, pts, np.flatnonzero(~direct), problem, late)
        if terms is None:
            return None
        stats["connectivity_terms"] = terms
        stats["lazy_cuts"] = _lazy_cut_rows(lin, x, idx, len(cand.points), cuts or [])
    elif not direct.all():  # item 3b
        lifted = LIFTED_HOPS.get(backend, False) if lifted_hops is None else lifted_hops
        clique_rows = (
            [(problem.targets[u], sorted(sites)) for u, sites in user_clique_sites.items()]
            if lifted
            else None
        )
        projected = max_terms if project_terms else None
        built = _hop_levels(lin, x, pts, direct, problem, late, clique_rows, max_level, max_terms, projected)
        if built is None:
            return None
        z, squares, stats["level_vars"], stats["connectivity_terms"] = built
    if x:
        weights = np.array([len(c) for c in cover], dtype=np.int64)
        stats["light_site_rows"] = _objective_rows(lin, x, objective, weights, objective_range, bounds_k)
    return CellModel(
        problem=problem,
        backend=backend,
        points=pts,
        cover=cover,
        direct=direct,
        model=lin,
        x=x,
        y=y,
        levels=z,
        squares=squares,
        stats=stats,
        objective=objective,
        group_of=group_of,
        serve=serve,
        user_sites=_sites_by_user(cover),
        cliques=user_clique_sites,
    )


def _nonoverlap_rows(lin, x: list, pts: np.ndarray, R_d: float, late) -> dict[str, int] | None:
    """The non-overlap rows (4.8) of item 2: grid cliques, then the conflicting pairs they miss
    as sector cliques. Returns their counts, or None once ``late()``."""
    cliques = _grid_cliques(pts, R_d) if len(pts) else []
    for q in cliques:
        lin.add_at_most_one([x[i] for i in q])
    extra = _uncovered_pairs(pts, R_d, cliques)
    sectors = _sector_cliques(pts, extra)
    for k, q in enumerate(sectors):
        lin.add_at_most_one([x[i] for i in q.tolist()])
        if k % 20_000 == 19_999 and late():
            return None
    return {"grid_cliques": len(cliques), "extra_pairs": len(extra), "sector_cliques": len(sectors)}


def _neighbour_rows(lin, x: list, pts: np.ndarray, nd: np.ndarray, problem: CellProblem, late) -> int | None:
    """Item 3a: every non-direct site (indices ``nd``) needs a chosen, non-overlapping
    neighbour within r2. Returns the rows' terms, or None once ``late()``."""
    if len(nd) == 0:
        return 0
    n_terms = 0
    tree = cKDTree(pts)
    for k, nb in enumerate(tree.query_ball_point(pts[nd], problem.r2 + TOL)):
        c = int(nd[k])
        nb = np.asarray(nb, dtype=np.int64)
        far = np.hypot(*(pts[nb] - pts[c]).T) >= 2 * problem.R_d - TOL
        src = [x[d] for d in nb[far].tolist()]
        lin.add_implies_any(x[c], src)
        n_terms += len(src)
        if k % 500 == 499 and late():
            return None
    return n_terms


def _lazy_cut_rows(lin, x: list, idx: np.ndarray, n_cand: int, cuts: list) -> int:
    """The cuts of item 3a found so far (indices into all ``n_cand`` candidates), restricted to
    the kept sites ``idx`` (a dropped site is 0, so a restricted cut stays valid); returns
    how many were written."""
    local = np.full(n_cand, -1, dtype=np.int64)
    local[idx] = np.arange(len(idx))
    n_cuts = 0
    for cut in cuts:
        if cut[0] == "clique":
            q = local[cut[1]]
            lin.add_at_most_one([x[i] for i in q[q >= 0].tolist()])
        else:
            w, bnd = local[cut[1]], local[cut[2]]
            w, bnd = w[w >= 0], bnd[bnd >= 0]
            if len(w) == 0:
                continue
            b = lin.bool_var(f"cut{n_cuts}")
            lin.add_implies_any(b, [x[j] for j in bnd.tolist()])
            for e in w.tolist():
                lin.add(x[e] <= b)
        n_cuts += 1
    return n_cuts


def _objective_rows(
    lin,
    x: list,
    objective,
    weights: np.ndarray,
    objective_range: tuple[float, float] | None,
    bounds_k: list[float] | None,
) -> int:
    """The objective cuts of item 4 and, with ``bounds_k``, the light-site rows of item 9
    (returns how many of those); then the objective itself."""
    n_light = 0
    if objective_range is not None:
        obj_lo, obj_hi = objective_range
        lin.add(objective >= math.ceil(obj_lo - 1e-9))
        lin.add(objective <= math.floor(obj_hi + 1e-9))
        if bounds_k is not None:
            # k candidate sites cover at most the k largest |S(c)| together; the continuous bound
            # alone was found below that on a small clustered instance (a candidate disc holding 4
            # users, B_1 = 3), so each B_k is raised to that sum where it falls short: the rows stay valid
            top = np.concatenate([[0], np.cumsum(np.sort(weights)[::-1])]).astype(float)
            bounds_k = [max(float(b), float(top[min(k, len(weights))])) for k, b in enumerate(bounds_k)]
            n_light = _light_site_rows(lin, x, weights, obj_lo, bounds_k)
    lin.maximize(objective)
    return n_light


# --------------------------------------------------------------------------- solve
def _add_cuts(
    problem: CellProblem, cand: Candidates, tree: cKDTree, chosen: np.ndarray, pos: np.ndarray, cuts: list
) -> None:
    """Append to ``cuts`` the cuts violated by the chosen sites (global indices ``chosen`` at
    ``pos``): a clique around each overlapping pair and the connectivity cuts of item 3a."""
    d = pairwise_distances(pos, pos)
    for a, b in zip(*np.nonzero(np.triu(d < 2 * problem.R_d - TOL, 1)), strict=True):
        mid = (pos[a] + pos[b]) / 2
        # d/2 < rho and 2 rho < 2 R_d - TOL: the ball holds both sites and is a clique
        rho = (d[a, b] + 2 * problem.R_d - TOL) / 4
        cuts.append(("clique", np.array(sorted(tree.query_ball_point(mid, rho)), dtype=np.int64)))
    for comp in _components_without_gbs(problem, pos):
        for delta in (0.0, problem.R_d):
            w: set = set()
            for i in comp:
                w.update(tree.query_ball_point(pos[i], delta + TOL))
            w_arr = np.array(sorted(j for j in w if not cand.direct[j]), dtype=np.int64)
            nb: set = set()
            for e in w_arr:
                nb.update(tree.query_ball_point(cand.points[e], problem.r2 + TOL))
            bnd = np.array(sorted(nb - set(w_arr.tolist())), dtype=np.int64)
            cuts.append(("conn", w_arr, bnd))


def _components_without_gbs(problem: CellProblem, pos: np.ndarray) -> list[np.ndarray]:
    """Connected groups (by r2 links) of placed sites none of which is within r1 of a GBS."""
    k = len(pos)
    d = pairwise_distances(pos, pos)
    adj = d <= problem.r2 + TOL
    dg = pairwise_distances(pos, problem.gbs)
    direct = np.any(dg <= problem.r1 + TOL, axis=1)
    seen = np.zeros(k, dtype=bool)
    out = []
    for s0 in range(k):
        if seen[s0]:
            continue
        comp = {s0}
        stack = [s0]
        while stack:
            i = stack.pop()
            for j in np.flatnonzero(adj[i]):
                if int(j) not in comp:
                    comp.add(int(j))
                    stack.append(int(j))
        seen[list(comp)] = True
        c = np.array(sorted(comp))
        if not direct[c].any():
            out.append(c)
    return out


def _private_users(mdl: CellModel, rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
    """(entries,) bool over the cover entries (site ``rows[k]`` covers user ``cols[k]``): True
    when no model site at least 2 R_d - TOL - 1e-6 m from that site covers that user, so that
    no site that may share a placement with it does (K(a) of item 12)."""
    import scipy.sparse as sp

    problem, pts = mdl.problem, mdl.points
    users = problem.targets
    r_conf, eps = 2 * problem.R_d - TOL, 1e-6
    private = np.ones(len(rows), dtype=bool)
    # a site c >= r_conf - eps from a covers u only if |u - a| >= R_d - 2 TOL - eps: the edge
    edge = np.flatnonzero(np.hypot(*(users[cols] - pts[rows]).T) > problem.R_d - 1e-4)
    if len(edge) == 0:
        return private
    by_user = sp.csc_matrix((np.ones(len(rows), dtype=np.int8), (rows, cols)), shape=(len(pts), len(users)))
    start, count = by_user.indptr[cols[edge]], np.diff(by_user.indptr)[cols[edge]]
    # (a, u, c) triples, c the sites covering u, at most about DOMINANCE_BLOCK at a time
    cuts = np.searchsorted(np.cumsum(count), np.arange(DOMINANCE_BLOCK, count.sum(), DOMINANCE_BLOCK))
    for part in np.split(np.arange(len(edge)), np.unique(cuts[cuts > 0])):
        cnt = count[part]
        owner = np.repeat(rows[edge[part]], cnt)
        offset = np.arange(cnt.sum()) - np.repeat(np.cumsum(cnt) - cnt, cnt)
        other = by_user.indices[np.repeat(start[part], cnt) + offset]
        apart = np.hypot(*(pts[other] - pts[owner]).T) >= r_conf - eps
        private[edge[part]] = np.add.reduceat(apart.astype(np.int64), np.cumsum(cnt) - cnt) == 0
    return private


def _dominating_pairs(mdl: CellModel, tree: cKDTree) -> tuple[np.ndarray, np.ndarray]:
    """(b, a) index pairs of item 12, sorted by b, then a: a comes before b in the order (weight |S(.)|
    descending, then index), |K(a) - S(b)| >= |S(b) - S(a)| (``_private_users``), a is direct
    when b is, and |a - b| < 2 R_d - TOL by a margin (the two overlap), or a half, quarter, ...
    of that when more than ``DOMINANCE_MAX_PAIRS`` pairs are that close."""
    import scipy.sparse as sp

    problem = mdl.problem
    radius = 2 * problem.R_d - TOL - 1e-6
    # count_neighbors counts ordered pairs and each site with itself
    while radius > 1e-3 and tree.count_neighbors(tree, radius) > 2 * DOMINANCE_MAX_PAIRS + tree.n:
        radius /= 2
    pairs = tree.query_pairs(radius, output_type="ndarray")
    if len(pairs) == 0:
        return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)
    b = np.concatenate([pairs[:, 0], pairs[:, 1]])
    a = np.concatenate([pairs[:, 1], pairs[:, 0]])
    w = np.array([len(c) for c in mdl.cover], dtype=np.int64)
    ok = ((w[a] > w[b]) | ((w[a] == w[b]) & (a < b))) & (~mdl.direct[b] | mdl.direct[a])
    b, a = b[ok], a[ok]
    cols = np.concatenate([np.asarray(c, dtype=np.int64) for c in mdl.cover])
    rows = np.repeat(np.arange(len(mdl.cover)), w)
    shape = (len(mdl.cover), len(problem.targets))
    incidence = sp.csr_matrix((np.ones(len(rows), dtype=np.int32), (rows, cols)), shape=shape)
    private = _private_users(mdl, rows, cols)
    kept = sp.csr_matrix(
        (np.ones(private.sum(), dtype=np.int32), (rows[private], cols[private])), shape=shape
    )
    n_kept = np.bincount(rows[private], minlength=len(w))
    gain = np.zeros(len(b), dtype=np.int64)  # |K(a) - S(b)| - |S(b) - S(a)|
    for lo in range(0, len(b), 1 << 15):  # a block of pairs at a time (memory)
        sl = slice(lo, lo + (1 << 15))
        shared = np.asarray(incidence[a[sl]].multiply(incidence[b[sl]]).sum(axis=1)).ravel()
        kept_shared = np.asarray(kept[a[sl]].multiply(incidence[b[sl]]).sum(axis=1)).ravel()
        gain[sl] = (n_kept[a[sl]] - kept_shared) - (w[b[sl]] - shared)
    ok = gain >= 0
    order = np.lexsort((a[ok], b[ok]))
    return b[ok][order], a[ok][order]


def _smallest_sets(
    pts: np.ndarray, b: int, a: np.ndarray, near: np.ndarray, radii: tuple[float, float, float]
) -> list[np.ndarray]:
    """The sets E of item 12 for site b and the ``DOMINANCE_PER_SITE`` sites of ``a`` (sorted
    indices) with the smallest E (ties: the smaller index), E taken among ``near`` (the sites
    that may be in one) and ``radii`` = (2 R_d - TOL, r2 + TOL, eps).

    E is the sites within r_conf + eps of a and over r_conf - eps from b (overlapping a but not
    b), plus those within r_link + eps of b and over r_link - eps from a (linked to b but not to
    a): disjoint parts (r2 >= 2 R_d), neither holding a or b (a and b overlap). Their sizes are
    counted by k-d tree range counts over the two candidate parts; the chosen sets are then
    built from the distances themselves."""
    r_conf, r_link, eps = radii
    d_b = np.hypot(*(pts[near] - pts[b]).T)
    part1, part2 = near[d_b > r_conf - eps], near[d_b <= r_link + eps]
    sizes = np.zeros(len(a), dtype=np.int64)
    if len(part1):
        inside = np.nextafter(r_conf + eps, 0.0)  # strictly closer than r_conf + eps
        sizes += cKDTree(pts[part1]).query_ball_point(pts[a], inside, return_length=True)
    if len(part2):
        within = cKDTree(pts[part2]).query_ball_point(pts[a], r_link - eps, return_length=True)
        sizes += len(part2) - within
    out = []
    for k in np.lexsort((a, sizes))[:DOMINANCE_PER_SITE].tolist():
        d_a = np.hypot(*(pts[near] - pts[a[k]]).T)
        in_e = ((d_a < r_conf + eps) & (d_b > r_conf - eps)) | ((d_b <= r_link + eps) & (d_a > r_link - eps))
        in_e &= (near != b) & (near != a[k])
        out.append(np.sort(near[in_e]))
    return out


def dominance_row_sets(
    mdl: CellModel, on: np.ndarray, stop: float | None = None
) -> tuple[list[tuple[int, np.ndarray]], bool]:
    """The dominance rows of item 12 over the sites of ``mdl``, as (b, E): ``x_b <= sum_{e in E}
    x_e`` (E an index array, empty: ``x_b = 0``), for each site b the ``DOMINANCE_PER_SITE``
    pairs of ``_dominating_pairs`` with the smallest E (ties: the smaller index a). Rows that
    the placement ``on`` ((c,) bool over the model's sites: the incumbent, which is the hint)
    breaks are left out. Stops at ``stop`` (a ``time.perf_counter()`` value; any subset of the
    rows is exact). Returns (rows, whether every site b was done)."""
    problem, pts = mdl.problem, mdl.points
    rows: list[tuple[int, np.ndarray]] = []
    if len(pts) < 2:
        return rows, True
    tree = cKDTree(pts)
    b_all, a_all = _dominating_pairs(mdl, tree)
    if len(b_all) == 0:
        return rows, True
    r_conf, r_link, eps = 2 * problem.R_d - TOL, problem.r2 + TOL, 1e-6
    reach = max(2 * r_conf, r_link) + eps  # E lies within this of b
    starts = np.flatnonzero(np.r_[True, b_all[1:] != b_all[:-1]])
    for lo, hi in zip(starts, np.r_[starts[1:], len(b_all)], strict=True):
        if stop is not None and time.perf_counter() > stop:
            return rows, False
        b, a = int(b_all[lo]), a_all[lo:hi]
        near = np.asarray(tree.query_ball_point(pts[b], reach), dtype=np.int64)
        best = _smallest_sets(pts, b, a, near, (r_conf, r_link, eps))
        for e in best:
            if on[b] and not on[e].any():
                continue  # the incumbent breaks it: left out (the hint stays a solution)
            rows.append((b, e))
    return rows, True


def dominance_rows(mdl: CellModel, on: np.ndarray, deadline: float | None = None) -> dict[str, Any]:
    """Add the rows of ``dominance_row_sets`` (item 12) to ``mdl``, computed for at most
    ``DOMINANCE_SHARE`` of the time left before ``deadline`` (a ``time.perf_counter()`` value,
    None: no limit). Returns counts for the model's stats."""
    t0 = time.perf_counter()
    stop = None if deadline is None else t0 + DOMINANCE_SHARE * max(deadline - t0, 0.0)
    rows, complete = dominance_row_sets(mdl, on, stop)
    lin, x = mdl.model, mdl.x
    for b, e in rows:
        lin.add(x[b] <= (lin.sum([x[i] for i in e.tolist()]) if len(e) else 0))
    return {
        "dominance_rows": len(rows),
        "dominance_zero": sum(len(e) == 0 for _, e in rows),
        "dominance_terms": sum(len(e) for _, e in rows),
        "dominance_complete": complete,
        "dominance_time": time.perf_counter() - t0,
    }


def _hint(problem: CellProblem, mdl: CellModel, placement: np.ndarray) -> dict:
    """A complete start assignment {variable: 0/1} of ``mdl`` for ``placement`` (sites of
    the model): site variables, covered users, and hop levels from a breadth-first search."""
    pk = mdl.points
    on = np.zeros(len(pk), dtype=bool)
    for p in placement:
        j = np.flatnonzero(np.hypot(*(pk - p).T) <= 1e-3)
        if len(j):
            on[j[0]] = True
    hint = {v: bool(on[i]) for i, v in enumerate(mdl.x)}
    covered: set[int] = set()
    for i in np.flatnonzero(on):
        covered.update(int(u) for u in mdl.cover[i])
    hint.update({v: u in covered for u, v in mdl.y.items()})
    level = {int(i): 1 for i in np.flatnonzero(on & mdl.direct)}
    frontier = list(level)
    lev = 1
    while frontier:
        lev += 1
        nxt = []
        for i in np.flatnonzero(on):
            if int(i) not in level and any(math.dist(pk[i], pk[j]) <= problem.r2 + TOL for j in frontier):
                level[int(i)] = lev
                nxt.append(int(i))
        frontier = nxt
    for (c, lv), v in mdl.levels.items():
        hint[v] = level.get(c) == lv
    for (lv, _), (v, sites) in mdl.squares.items():
        hint[v] = any(level.get(int(d)) == lv for d in sites.tolist())
    return hint


def _bound_m_minus_1(prep: Prepared) -> float:
    """B_{m-1} for the pruning of item 1; B_m (>= B_{m-1}, weaker but still exact pruning)
    when there is less time left than the first relaxation took."""
    time_left = prep.left()
    if time_left is not None and time_left < prep.relax_time:
        return prep.ub
    relax = prep.relaxation_m_minus_1()
    return float(len(prep.problem.targets)) if relax.bound is None else float(relax.bound)


def _disc_bounds(prep: Prepared, b_prev: float) -> list[float]:
    """(B_0, ..., B_m) for the light-site rows of item 9: B_k the continuous bound of k discs
    (``coverage_upper_bound``), B_{m-1} = ``b_prev`` and B_m = ``prep.ub``. A bound for more
    discs also bounds fewer, so each B_k is lowered to the smallest later one (and a bound
    not computed in time is that later one): valid, and nondecreasing."""
    m = prep.problem.n_cells
    out = [float(prep.ub)] * (m + 1)
    if m >= 1:
        out[m - 1] = min(float(b_prev), out[m])
    for k in range(m - 2, 0, -1):
        out[k] = out[k + 1]
        if not prep.expired():
            relax = coverage_upper_bound(prep.problem, k, time_limit=prep.left())
            if relax.bound is not None:
                out[k] = min(out[k], float(relax.bound))
    out[0] = 0.0
    return out


def lp_fixing(
    problem: CellProblem,
    cand: Candidates,
    keep: np.ndarray,
    *,
    incumbent: np.ndarray,
    objective_range: tuple[float, float],
    disc_bounds: list[float] | None = None,
    user_cliques: bool = True,
    deadline: float | None = None,
    time_limit: float | None = None,
    max_terms: int | None = None,
    max_level: int | None = None,
) -> tuple[np.ndarray, float, dict[str, Any]] | None:
    """Item 10: which of the sites ``keep`` a placement covering more than lo =
    ``objective_range[0]`` users may hold, by the LP relaxation of the lifted hop model.

    Returns (alive: bool per site of ``keep``, an upper bound on every placement of the
    ``keep`` sites worth >= lo, stats), or None past ``deadline`` (a ``time.perf_counter()``
    value) or when the lifted model has more than ``max_terms`` hop-row terms (None: no
    cap; building stops as soon as it has more). The sites of ``incumbent`` ((k, 2) m) stay
    alive. ``disc_bounds`` and ``user_cliques`` as in :func:`build_milp`, and ``max_level``
    (its hop levels merged from this one up, a relaxation: the bound and the fixing stay
    valid); ``time_limit`` (s) for the LP solve, which also ends by ``deadline``.
    """
    t0 = time.perf_counter()
    mdl = build_milp(
        problem,
        backend="highs",
        candidates=cand,
        keep=keep,
        deadline=deadline,
        objective_range=objective_range,
        user_cliques=user_cliques,
        lifted_hops=True,
        disc_bounds=disc_bounds,
        max_level=max_level,
        max_terms=max_terms,
    )
    if mdl is None or (deadline is not None and time.perf_counter() > deadline):
        return None
    if deadline is not None:  # the LP ends by the deadline, however long the build took
        left = max(deadline - time.perf_counter(), 0.01)
        time_limit = left if time_limit is None else min(time_limit, left)
    ipm_after = _ipm_after() if LP_FIXING_METHOD == "simplex" else None
    lpb = lp_dual_bound(
        mdl.model.native, mdl.x, time_limit=time_limit, method=LP_FIXING_METHOD, ipm_after=ipm_after
    )
    # a better placement covers at least lo + 1 users (an integer)
    alive = lpb.at_one >= math.floor(objective_range[0] + 1e-9) + 1
    if len(incumbent) and len(mdl.points):
        alive |= np.any(pairwise_distances(mdl.points, incumbent) <= 1e-3, axis=1)
    stats = {
        "lp_bound": lpb.bound,
        "lp_status": lpb.status,
        "lp_fixed_sites": int(len(keep) - alive.sum()),
        "lp_time": time.perf_counter() - t0,
        "lp_method": lpb.method,
    }
    return alive, float(math.floor(lpb.bound)), stats


def _lp_fixing_runs(backend: str, connectivity: str, n_sites: int) -> bool:
    """True when item 10 (``lp_fixing``) runs before a final round over ``n_sites`` sites."""
    return (
        LP_FIXING.get(backend, False)
        and connectivity == "hops"
        and n_sites >= LP_FIXING_MIN_SITES
        and "highs" in BACKENDS
    )


def _refuse_model_size(term_cap: int | None, projected: float | None = None) -> None:
    """Refuse the model, naming the size asked for: its build stopped at ``term_cap`` terms,
    or (``projected``) its hop rows are projected to this many terms before it is built."""
    cap = int(term_cap or 0)
    memory = machine_memory() or 0.0
    asked = (
        "counted, or projected from a sample of a level's rows, while the model was built"
        if projected is None
        else f"about {projected:,.0f} terms ({projected * MODEL_BYTES_PER_TERM / 2**30:.1f} GiB), "
        "projected from a sample of level 2's rows before the model is built"
    )
    raise ValueError(
        f"problem: the candidate model's hop rows would hold more than {cap:,} terms, the most a "
        f"model may take here ({MODEL_MEMORY_SHARE:.0%} of this machine's memory, "
        f"{memory / 2**30:.1f} GiB, at {MODEL_BYTES_PER_TERM} bytes a term with the solver's "
        f"copies): {asked}; use engine='bnb', connectivity='lazy' or fewer candidate sites"
    )


def refuse_before_polish(prep: Prepared, *, backend: str, connectivity: str, max_rounds: int) -> None:
    """Refuse, before ``solve_exact``'s polish, a hop model too large even in the best case the
    polish could reach.

    The polish can raise the incumbent at most to the continuous bound ``ub``. The first round's
    sites are then those of ``reduce_candidates`` at ``ub`` (plus the incumbent's own sites):
    every lower incumbent or target keeps a superset of them, so when the hop rows over this
    smallest set are already projected (``_projected_model_terms``) past ``PROJECTION_MARGIN``
    times ``model_term_cap``, no incumbent the polish finds makes the model fit, and the
    refusal of :meth:`_ModelSolve._refuse_projected_size` is certain; it comes here, before the
    polish's seconds. In that best case the first round is the final one, so when the LP fixing
    would run and level 2 alone is projected within its own cap (it might drop sites), the
    decision is left to the later check. Nothing is refused without a known cap, with the lazy
    cuts (no hop rows) or with ``max_rounds`` 0 (no model built).

    prep: the prepared call (its bound ``ub`` and ``bound_m_minus_1``); backend, connectivity,
    max_rounds: those of :func:`solve_prepared`.
    """
    term_cap = model_term_cap()
    if term_cap is None or connectivity != "hops" or max_rounds == 0:
        return
    none = np.zeros((0, prep.problem.plan_width))
    keep = reduce_candidates(prep.problem, prep.cand, float(prep.ub), none, prep.bound_m_minus_1())
    total, level2 = _projected_model_terms(prep.problem, prep.cand, keep, backend)
    if total <= PROJECTION_MARGIN * term_cap:
        return
    lp_may_shrink = level2 <= PROJECTION_MARGIN * LP_FIXING_MAX_TERMS
    if lp_may_shrink and _lp_fixing_runs(backend, connectivity, len(keep)):
        return
    _refuse_model_size(term_cap, total)


class _ModelSolve:
    """One call of :func:`solve_prepared`: the prepared instance, the backend settings and the
    search state shared by the rounds of the target scheme."""

    def __init__(
        self,
        prep: Prepared,
        *,
        backend: str,
        workers: int,
        connectivity: str,
        max_rounds: int,
        user_cliques: bool,
    ) -> None:
        """The arguments of :func:`solve_prepared`."""
        self.prep, self.backend, self.workers = prep, backend, workers
        self.connectivity, self.max_rounds, self.user_cliques = connectivity, max_rounds, user_cliques
        self.b_prev = _bound_m_minus_1(prep)
        self.state = _SearchState(inc=prep.inc, inc_val=float(prep.inc_val))
        self.ub = float(prep.ub)  # the model's objective cap (item 4), lowered by item 10
        self.term_cap = model_term_cap()  # a model over it would not fit: refused before it is built
        self._last_projection: tuple[np.ndarray, tuple[float, float]] | None = None
        self._refuse_projected_size()  # before the bounds of item 9 and the LP of item 10
        self.disc_bounds = _disc_bounds(prep, self.b_prev) if LIGHT_ROWS.get(backend, False) else None
        self.tree = cKDTree(prep.cand.points)
        self.cuts: list = []
        self.deadline = None if prep.time_limit is None else prep.t0 + prep.time_limit
        self.fix_stats: dict[str, Any] = {}

    def _first_target(self) -> float:
        """The first target g of the descending scheme (``targets``; ``TARGET_START``)."""
        state = self.state
        start = TARGET_START.get(self.backend, 0.5) if self.connectivity == "hops" else 0.5
        return max(state.inc_val + start * (self.ub - state.inc_val), state.inc_val)

    def _lp_fixing_on(self, n_sites: int) -> bool:
        """True when item 10 runs before a final round over ``n_sites`` sites (``lp_fixing``)."""
        return _lp_fixing_runs(self.backend, self.connectivity, n_sites)

    def _refuse_projected_size(self) -> None:
        """Refuse up front a hop model that the first round's build would refuse: its sites
        (``reduce_candidates`` at the first target) projected by ``_projected_model_terms``,
        which is the build's own first check (the same sites and sample give the same figure),
        past ``PROJECTION_MARGIN`` times ``term_cap``.

        Nothing between here and that build makes the model smaller, except item 10 when the
        first round is the final one: the LP fixing may drop sites. Its lifted model holds
        at least level 2's rows of this model, so when level 2 alone is projected past
        ``PROJECTION_MARGIN * LP_FIXING_MAX_TERMS`` its build stops and it drops nothing;
        otherwise the decision is left to the build. Earlier, before ``solve_exact``'s polish,
        no refusal is sound: the polish may raise the incumbent up to the continuous bound
        (or to it, proving it without a model), and at that threshold Table 4.2 density x4
        at m = 4 seed 0 keeps 2,384 of its 63,984 sites. Without a known cap, with the lazy
        cuts (no hop rows) or with ``max_rounds`` 0 (no model built) nothing is refused, nor
        when the time limit stopped the polish before it could start (``polish_stopped``: the
        incumbent could still rise, so the model's size is not known; the build's own checks
        and the time limit answer instead)."""
        if (
            self.term_cap is None
            or self.connectivity != "hops"
            or self.max_rounds == 0
            or self.prep.polish_stopped
        ):
            return
        prep, g = self.prep, self._first_target()
        keep = reduce_candidates(prep.problem, prep.cand, g, self.state.inc, self.b_prev)
        total, level2 = self._projection(keep)
        if total <= PROJECTION_MARGIN * self.term_cap:
            return
        final = g <= self.state.inc_val
        if final and self._lp_fixing_on(len(keep)) and level2 <= PROJECTION_MARGIN * LP_FIXING_MAX_TERMS:
            return
        self._refuse_model_size(total)

    def _projection(self, keep: np.ndarray) -> tuple[float, float]:
        """``_projected_model_terms`` of the hop model over the sites ``keep``, kept for the last
        ``keep`` asked (the refusal and the LP fixing's skip ask for the same sites when the first
        round is the final one)."""
        last = self._last_projection
        if last is None or not np.array_equal(last[0], keep):
            last = self._last_projection = (
                keep.copy(),
                _projected_model_terms(self.prep.problem, self.prep.cand, keep, self.backend),
            )
        return last[1]

    def _refuse_model_size(self, projected: float | None = None) -> None:
        """Refuse the model, naming the size asked for: its build stopped at ``term_cap`` terms,
        or (``projected``) its hop rows are projected to this many terms before it is built."""
        _refuse_model_size(self.term_cap, projected)

    def relaxation(self, keep: np.ndarray, found: list) -> SolveResult:
        """Build and solve the model on the sites ``keep`` with the cuts ``found`` (one round
        of the cut loop); ``x`` of the result is (kept indices, positions, evaluation)."""
        prep, state, backend = self.prep, self.state, self.backend
        problem = prep.problem
        state.rounds += 1
        mdl = None
        if not prep.expired():
            mdl = build_milp(
                problem,
                backend=backend,
                candidates=prep.cand,
                keep=keep,
                deadline=self.deadline,
                objective_range=(state.inc_val, self.ub),
                connectivity=self.connectivity,
                cuts=found,
                user_cliques=self.user_cliques,
                disc_bounds=self.disc_bounds,
                max_terms=self.term_cap,
                project_terms=True,
            )
            if mdl is None and not prep.expired() and self.term_cap is not None:
                self._refuse_model_size()
        if mdl is None or prep.expired():  # building can be long: the limit covers it
            return SolveResult(Status.NO_SOLUTION, backend=backend, message="time limit")
        hint = _hint(problem, mdl, state.inc)
        if DOMINANCE_ROWS.get(backend, False):
            mdl.stats.update(dominance_rows(mdl, np.array([bool(hint[v]) for v in mdl.x]), self.deadline))
        state.stats = {**mdl.stats, **self.fix_stats}
        res = mdl.model.solve(
            variables=mdl.x,
            time_limit=prep.left(),
            workers=self.workers,
            hint={v: int(b) for v, b in hint.items()},
            options=FEW_WORKER_OPTIONS.get(backend) if self.workers <= 2 else None,
            on_solution=None if prep.report is None else self._reporter(mdl.points),
        )
        state.raw = res.backend_status
        if res.bound is not None:
            res = dataclasses.replace(res, bound=float(math.floor(res.bound + 1e-6)))
        if not res.has_solution:
            return res
        chosen = np.flatnonzero(np.asarray(res.x) > 0.5)
        pos = mdl.points[chosen]
        ev = evaluate(problem, pos)
        feas = pos if ev.feasible else _feasible_subset(problem, pos)
        cv = evaluate(problem, feas).covered
        if cv > state.inc_val:
            state.inc, state.inc_val = feas, cv
            prep.offer_report(feas)
        return dataclasses.replace(res, x=(keep[chosen], pos, ev), objective=float(ev.covered))

    def _reporter(self, points: np.ndarray) -> Callable[[np.ndarray, float | None, float | None], None]:
        """The backend's ``on_solution``: each solution's chosen sites offered as a report."""

        def offer(x: np.ndarray, _objective: float | None, _bound: float | None) -> None:
            self.prep.offer_report(points[np.flatnonzero(np.asarray(x) > 0.5)])

        return offer

    def separate(self, res: SolveResult) -> list:
        """The cuts violated by a round's placement (none when it is feasible)."""
        idx, pos, ev = res.x
        if ev.feasible:
            return []
        if self.connectivity == "hops":  # exact model: a bug, never hidden
            raise RuntimeError(
                f"internal: the hop-level model returned an infeasible placement: {ev.violations}"
            )
        new: list = []
        _add_cuts(self.prep.problem, self.prep.cand, self.tree, idx, pos, new)
        return new

    def solve_restricted(self, keep: np.ndarray) -> tuple[str, float]:
        """Solve the model restricted to ``keep`` with ``objective >= incumbent value`` exactly:
        ``solvers.lazy.lazy_constraint_loop`` (one round with hop levels: nothing is ever
        violated; lazy cuts otherwise). Returns ("optimal", value) or ("stopped", bound of
        the restricted problem)."""
        state, prep = self.state, self.prep
        if state.rounds >= self.max_rounds or prep.expired():
            return "stopped", math.inf
        out = lazy_constraint_loop(
            lambda found, _left: self.relaxation(keep, found),
            self.separate,
            sense="max",
            max_rounds=self.max_rounds - state.rounds,
            time_limit=prep.left(),
            cuts=self.cuts,
        )
        self.cuts[:] = out.info["cuts"]  # valid for every restriction: kept for the next one
        if out.status is Status.INFEASIBLE:
            # nothing in the restricted relaxation reaches the incumbent's value (the
            # incumbent itself is feasible for it, so this only happens at rounding
            # edges): the restricted optimum is at most the incumbent's value
            return "optimal", float(state.inc_val)
        if out.status is Status.OPTIMAL and out.objective is not None:
            return "optimal", float(out.objective)
        return "stopped", math.inf if out.bound is None else float(out.bound)

    def lp_fixing(self, keep: np.ndarray) -> np.ndarray | None:
        """Item 10 on the sites ``keep`` (``lp_fixing``) when it is on for this backend and
        model; lowers ``self.ub`` to the LP bound. None: not run (or no time to build the LP)."""
        prep, state = self.prep, self.state
        if not self._lp_fixing_on(len(keep)):
            return None
        level2 = self._projection(keep)[1]
        if level2 > PROJECTION_MARGIN * LP_FIXING_MAX_TERMS:
            # the lifted model holds at least level 2's rows of this model, so its build would stop
            # at its cap after the non-overlap rows (85 s at Table 4.2 density x4, m = 4)
            self.fix_stats = {
                "lp_fixing": f"skipped (level 2's hop rows projected at {level2:,.0f} terms, "
                "over LP_FIXING_MAX_TERMS)"
            }
            return None
        left = prep.left()
        out = lp_fixing(
            prep.problem,
            prep.cand,
            keep,
            incumbent=state.inc,
            objective_range=(state.inc_val, self.ub),
            disc_bounds=self.disc_bounds,
            user_cliques=self.user_cliques,
            deadline=self.deadline,
            time_limit=None if left is None else LP_FIXING_SHARE * left,
            max_terms=LP_FIXING_MAX_TERMS,
            max_level=LP_FIXING_LEVELS if prep.problem.n_cells <= LP_FIXING_MERGE_MAX_M else None,
        )
        if out is None:
            self.fix_stats = {"lp_fixing": "skipped (model above LP_FIXING_MAX_TERMS terms, or no time)"}
            return None
        alive, bound, self.fix_stats = out
        self.ub = min(self.ub, bound)
        return keep[alive]

    def targets(self) -> tuple[Status, float]:
        """The descending target scheme (exact): any solution worth more than g uses only sites
        with |S(c)| + B_{m-1} > g. Solve on those; an optimum z_r > g is the optimum of the
        full candidate problem, otherwise z_r is a new incumbent and g is lowered, ending
        with g = incumbent value (the plain pruning of item 1, then item 10). Returns
        (status, bound)."""
        state = self.state
        g = self._first_target()
        while True:
            g = max(g, state.inc_val)
            final = g <= state.inc_val
            keep = reduce_candidates(self.prep.problem, self.prep.cand, g, state.inc, self.b_prev)
            if final:
                fixed = self.lp_fixing(keep)
                keep = keep if fixed is None else fixed
                if self.ub <= state.inc_val:  # the LP bound alone proves the incumbent
                    state.stats = dict(self.fix_stats)
                    return Status.OPTIMAL, float(state.inc_val)
            outcome, val = self.solve_restricted(keep)
            if outcome == "optimal" and (val > g or final):
                return Status.OPTIMAL, min(self.ub, max(val, state.inc_val))
            if outcome == "stopped":
                # restricted to sites of value > g (unless final): solutions worth more than g
                # are bounded by val; others are bounded by g
                return Status.FEASIBLE, min(self.ub, val if final else max(val, math.floor(g)))
            g = state.inc_val + 0.5 * (g - state.inc_val) if g - state.inc_val > 2 else state.inc_val


def solve_prepared(
    prep: Prepared,
    *,
    backend: str,
    workers: int,
    connectivity: str = "hops",
    max_rounds: int = 200,
    user_cliques: bool = True,
) -> SolveResult:
    """Solve the candidate model (module docstring) from the prepared incumbent and bounds.

    prep: the output of ``_prepare.prepare`` (its clock and time limit cover this solve).
    backend: linear backend name ("cp-sat", "highs", "scip").
    workers: backend threads / CP-SAT workers.
    connectivity: "lazy" or "hops" (module docstring, item 3).
    max_rounds: model solves at most (target scheme and cut rounds).
    user_cliques: add the per-user at-most-one rows of item 5.
    """
    run = _ModelSolve(
        prep,
        backend=backend,
        workers=workers,
        connectivity=connectivity,
        max_rounds=max_rounds,
        user_cliques=user_cliques,
    )
    status, best_bound = run.targets()
    state = run.state
    obj = float(evaluate(prep.problem, state.inc).covered)
    if obj >= best_bound:
        status = Status.OPTIMAL
    msg = prep.bound_text(best_bound, f"the candidate model on {backend} (engine 'milp')")
    if status is not Status.OPTIMAL:
        msg += (
            f"; stopped after {state.rounds} model solves (time limit or max_rounds), optimality not proven"
        )
    return prep.result(
        status,
        objective=obj,
        bound=float(best_bound),
        x=state.inc,
        backend=backend,
        backend_status=state.raw,
        message=msg,
        engine="milp",
        iterations=state.rounds,
        rounds=state.rounds,
        model_stats=state.stats,
    )
