"""Thesis ch. 4 heuristics: the genetic algorithm with restarts (§4.3.2, Table 4.1) and
the exhaustive search of Algorithm 2 with a constrained single-disc maximum coverage.

Decisions where the thesis is not explicit:

* **Fitness of infeasible chromosomes.** A drone-cell *contributes* when it lies in the
  area, clears every GBS cell (|D - G| >= R_g + R_d), overlaps no other drone-cell
  (|D_i - D_h| >= 2 R_d; both overlapping cells are discarded) and reaches a GBS through
  contributing drone-cells (links <= r1 / r2). The fitness is the number of users
  covered by contributing drone-cells, so the contributing subset is always a
  feasible placement and the reported plan is that subset.
* **Mutation (4.10)** ``g' = g [1 +- rnd (1 - f/f_best)^2]`` acts on coordinates
  relative to the first GBS (the thesis's origin) with a random sign; when
  ``f_best = 0`` the factor ``(1 - f/f_best)`` is taken as 1. Mutated coordinates are
  clipped to the operating area.
* **Crossover (4.11)** exchanges the y coordinate of one randomly chosen drone-cell
  between two chromosomes; chromosomes are paired at random and each pair crosses
  with the adaptive probability (4.12) (``P_c2`` when ``f_max = f_avg``).
* Each restart is an independent run of ``iter_max`` generations from a fresh
  random population (temperature reset to T); the final population's best is the
  restart's result and the best over restarts is returned.

Where the thesis text admits more than one reading (crossover row or column, mutation per gene
or per chromosome, f_best per generation or over the run, the final or the best-ever result,
fresh restarts or the best carried over, the fitness filter), :class:`GASettings` names each
reading as a field whose default is the one above, and :data:`GA_READINGS` lists the
alternatives with the sentence each reads differently.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from droneplan.core.validation import (
    check_array,
    check_in_range,
    check_instance,
    check_int,
    check_positive,
    check_size,
    check_time_limit,
    check_work,
    current_limit,
    resolve_seed,
)
from droneplan.formulations.cells import TOL, CellProblem, evaluate
from droneplan.scenarios.cells import THESIS_GA_TABLE_4_1, THESIS_TABLE_4_3
from droneplan.solvers.result import SolveResult, Status

__all__ = [
    "GASettings",
    "GA_READINGS",
    "ga_reading",
    "genetic",
    "genetic_polished",
    "polish",
    "fitness",
    "exhaustive",
    "max_coverage_in_region",
    "Region",
    "deployment_region",
    "thesis_ga_settings",
]


# =========================================================================== GA
_GA_CHOICES: dict[str, tuple[str, ...]] = {
    "crossover": ("cell", "column"),
    "mutation": ("gene", "chromosome"),
    "f_best": ("generation", "run"),
    "result": ("final", "best_ever"),
    "fitness": ("contributing", "all_or_nothing", "unfiltered"),
}
"""The readings each string field of :class:`GASettings` admits, ours first."""


@dataclass(frozen=True)
class GASettings:
    """GA parameters (thesis Table 4.1 defaults) and, for each rule the thesis text admits in more
    than one way, the reading used (the default is droneplan's reading throughout;
    :data:`GA_READINGS` names the alternatives)."""

    T: float = THESIS_GA_TABLE_4_1["T"]
    """Initial simulated-annealing temperature (fitness units, users). The thesis's T = 500 against
    fitness differences of a few users accepts almost every worse mutation; a tiny T (1e-9)
    reads SAM as "no worse move accepted" (annealing off)."""
    alpha: float = THESIS_GA_TABLE_4_1["alpha"]
    """Cooling factor of the temperature per generation, in (0, 1] (dimensionless)."""
    p_m: float = THESIS_GA_TABLE_4_1["p_m"]
    """Mutation probability per gene (coordinate), in [0, 1]."""
    p_c1: float = THESIS_GA_TABLE_4_1["p_c1"]
    """Crossover probability for below-average pairs (4.12), in [0, 1]."""
    p_c2: float = THESIS_GA_TABLE_4_1["p_c2"]
    """Crossover probability for the best pair (4.12), in [0, 1]."""
    replace_frac: float = 0.2
    """Fraction of worst chromosomes replaced by the best each generation, in [0, 1)."""
    mutation_step: float | None = None
    """None: the thesis mutation (4.10), multiplicative on coordinates relative to the first
    GBS. A length (m): an ablation variant (not the thesis) that moves a mutated coordinate
    by ``+- rnd * mutation_step * (1 - f/f_best)^2`` instead, a step independent of how far
    the drone-cell is from the GBS."""

    crossover: str = "cell"
    """Reading of crossover (4.11), which swaps y between ``[x_n, y_n]`` and ``[x_m, y_m]`` of two
    chromosomes: "cell" (ours) takes each row as one drone-cell, so the y of one randomly chosen
    drone-cell is swapped; "column" takes ``x``/``y`` as the chromosome's whole x and y columns,
    so every drone-cell's y is swapped (the two readings agree at m = 1)."""
    mutation: str = "gene"
    """Reading of "applied with a mutation probability P_m to some genes g" (§4.3.2.1): "gene"
    (ours) mutates each coordinate with probability P_m; "chromosome" picks each chromosome with
    probability P_m and mutates all its genes (each with its own rnd and sign)."""
    f_best: str = "generation"
    """Reading of f_best in (4.10), "the current highest fitness achieved by the population":
    "generation" (ours) is the highest fitness in the population now; "run" is the highest
    fitness the restart has reached so far (the two differ when crossover or an accepted
    annealing move lowers the population's best)."""
    result: str = "final"
    """Reading of "once reach ... iter_max, return the chromosome I* that has the highest fitness
    in the population" (§4.3.2.3): "final" (ours) returns the final population's best;
    "best_ever" returns the best chromosome the restart held at any point (never lower)."""
    carry_best: bool = False
    """Reading of the restart strategy ("restart the GA for a number of times N_start"):
    False (ours) restarts from a fresh random population each time; True puts the best
    chromosome of the restarts so far into each new restart's initial population (the restarts
    then run one after another instead of side by side)."""
    fitness: str = "contributing"
    """Reading of "f(I) equals the number of users covered by the drone-cells with their
    coordinates satisfy the backhaul constraints (4.7) (4.8)": "contributing" (ours) counts the
    users of the drone-cells that satisfy them (module docstring); "all_or_nothing" counts the
    users of the whole chromosome when every drone-cell satisfies them and 0 otherwise;
    "unfiltered" counts every drone-cell's users as (4.9) alone would (not a reading of that
    sentence; for comparison). The returned plan is always the best chromosome's contributing
    drone-cells, so it stays feasible."""

    def __post_init__(self) -> None:
        for name, choices in _GA_CHOICES.items():
            if getattr(self, name) not in choices:
                raise ValueError(f"{name} must be one of {choices}, got {getattr(self, name)!r}")
        if not isinstance(self.carry_best, bool):
            raise TypeError(f"carry_best must be a bool, got {type(self.carry_best).__name__}")
        check_positive("T", self.T)
        check_in_range("alpha", self.alpha, 0.0, 1.0, lo_open=True)
        for name in ("p_m", "p_c1", "p_c2"):
            check_in_range(name, getattr(self, name), 0.0, 1.0)
        check_in_range("replace_frac", self.replace_frac, 0.0, 1.0, hi_open=True)
        if self.mutation_step is not None:
            check_positive("mutation_step", self.mutation_step)


GA_READINGS: dict[str, dict[str, Any]] = {
    "ours": {
        "settings": {},
        "label": "droneplan's reading (the GASettings defaults)",
        "reads": "-",
    },
    "column-crossover": {
        "settings": {"crossover": "column"},
        "label": "crossover swaps the whole y column (every drone-cell's y)",
        "reads": "(4.11): [x_n, y_n], [x_m, y_m] -> [x_n, y_m], [x_m, y_n]",
    },
    "chromosome-mutation": {
        "settings": {"mutation": "chromosome"},
        "label": "mutation picks a chromosome with P_m and mutates all its genes",
        "reads": "§4.3.2.1: 'applied with a mutation probability P_m to some genes g'",
    },
    "f-best-run": {
        "settings": {"f_best": "run"},
        "label": "f_best of (4.10) is the restart's best so far",
        "reads": "(4.10): 'f_best is the current highest fitness achieved by the population'",
    },
    "best-ever": {
        "settings": {"result": "best_ever"},
        "label": "each restart returns its best-ever chromosome",
        "reads": "§4.3.2.3: 'return the chromosome I* that has the highest fitness in the population'",
    },
    "no-annealing": {
        "settings": {"T": 1e-9},
        "label": "no worse mutation accepted (annealing off)",
        "reads": "§4.3.2.1 SAM: 'the annealing probability exp(delta_f/T)', T = 500 (Table 4.1)",
    },
    "carry-best": {
        "settings": {"carry_best": True},
        "label": "each restart starts with the best chromosome so far",
        "reads": "restart strategy: 'restart the GA for a number of times N_start'",
    },
    "all-or-nothing-fitness": {
        "settings": {"fitness": "all_or_nothing"},
        "label": "fitness 0 unless every drone-cell satisfies (4.7)-(4.8)",
        "reads": "§4.3.2: 'f(I) equals the number of users covered by the drone-cells with their "
        "coordinates satisfy the backhaul constraints (4.7) (4.8)'",
    },
    "unfiltered-fitness": {
        "settings": {"fitness": "unfiltered"},
        "label": "fitness (4.9) alone, no (4.7)-(4.8) filter (not a reading of §4.3.2; comparison)",
        "reads": "(4.9) without the sentence of §4.3.2 that filters by (4.7) (4.8)",
    },
    "favourable": {
        "settings": {"crossover": "column", "f_best": "run", "result": "best_ever", "carry_best": True},
        "label": "all favourable readings together (column crossover, f_best over the run, best-ever "
        "result, best carried into each restart)",
        "reads": "(4.10), (4.11), §4.3.2.3 and the restart strategy together",
    },
}
"""Readings of the thesis GA, keyed by a short name: ``settings`` are the :class:`GASettings`
overrides, ``label`` says what changes and ``reads`` which equation or sentence of §4.3.2 is read
differently. "ours" is the default; "favourable" combines the alternatives that keep more of the
search (more diverse crossover, larger mutation, nothing lost between or within restarts)."""


def ga_reading(name: str, **overrides: Any) -> GASettings:
    """The :class:`GASettings` of reading ``name`` (a key of :data:`GA_READINGS`).

    name: the reading's key.
    overrides: further GASettings fields (e.g. Table 4.1 values), applied after the reading's.
    """
    if name not in GA_READINGS:
        raise ValueError(f"name must be a key of GA_READINGS {list(GA_READINGS)}, got {name!r}")
    return GASettings(**{**GA_READINGS[name]["settings"], **overrides})


def thesis_ga_settings(m: int) -> tuple[int, int]:
    """(population size, restarts) of thesis Table 4.3 for m drone-cells (m > 4: the m = 4 row)."""
    row = THESIS_TABLE_4_3[min(check_int("m", m, min_value=1), 4)]
    return int(row[3]), int(row[4])


def _area(problem: CellProblem) -> tuple[float, float, float, float]:
    if problem.bounds is not None:
        return problem.bounds
    reach = problem.r1 + (problem.n_cells - 1) * problem.r2
    g = problem.gbs
    return (g[:, 0].min() - reach, g[:, 0].max() + reach, g[:, 1].min() - reach, g[:, 1].max() + reach)


def _contributing(problem: CellProblem, pop: NDArray[np.float64]) -> NDArray[np.bool_]:
    """(P, m) bool: drone-cells that count towards the fitness (module docstring)."""
    _, m, _ = pop.shape
    xmin, xmax, ymin, ymax = _area(problem)
    ok = (
        (pop[..., 0] >= xmin - TOL)
        & (pop[..., 0] <= xmax + TOL)
        & (pop[..., 1] >= ymin - TOL)
        & (pop[..., 1] <= ymax + TOL)
    )
    dg = np.sqrt(((pop[:, :, None, :] - problem.gbs[None, None, :, :]) ** 2).sum(-1))  # (P, m, k)
    ok &= np.all(dg >= problem.R_g + problem.R_d - TOL, axis=2)
    dd = np.sqrt(((pop[:, :, None, :] - pop[:, None, :, :]) ** 2).sum(-1))  # (P, m, m)
    eye = np.eye(m, dtype=bool)[None]
    ok &= ~np.any((dd < 2 * problem.R_d - TOL) & ~eye, axis=2)
    reach = ok & np.any(dg <= problem.r1 + TOL, axis=2)
    adj = (dd <= problem.r2 + TOL) & ok[:, :, None] & ok[:, None, :]
    for _ in range(m):
        new = reach | np.any(adj & reach[:, None, :], axis=2)
        if np.array_equal(new, reach):
            break
        reach = new
    return reach


@dataclass(frozen=True)
class _UserGrid:
    """Active users bucketed on a square grid of side ``h >= R_d + TOL``: every user within
    ``R_d + TOL`` of a point lies in the 3 x 3 block of cells around the point's cell, so
    coverage is tested only against that block (``nbr``) instead of against every user."""

    x0: float
    """Lower-left corner of the grid, x (m)."""
    y0: float
    """Lower-left corner of the grid, y (m)."""
    h: float
    """Cell side (m), at least R_d + TOL."""
    nx: int
    """Cells along x (count)."""
    ny: int
    """Cells along y (count)."""
    nbr: NDArray[np.intp]
    """(nx * ny, K) indices of the users in each cell's 3 x 3 block, padded with n (a far dummy)."""
    tx: NDArray[np.float64]
    """(n + 1,) user x coordinates (m), the dummy last."""
    ty: NDArray[np.float64]
    """(n + 1,) user y coordinates (m), the dummy last."""


_FAR = 1e100
"""Coordinate of the padding user (m): never within R_d of a finite position."""


def _user_grid(problem: CellProblem) -> _UserGrid:
    t = problem.targets
    n = len(t)
    r = problem.R_d + TOL
    lo = t.min(axis=0)
    extent = float(np.max(t.max(axis=0) - lo))
    # a margin keeps |u - q| <= r => |cell(u) - cell(q)| <= 1 despite rounding in floor(); the
    # grid is coarsened so that it never has more than ~4 cells per user
    h = max(r * (1.0 + 1e-6), extent / max(1.0, math.sqrt(4.0 * n)) * (1.0 + 1e-6))
    g = np.floor((t - lo) / h).astype(np.intp)
    nx, ny = int(g[:, 0].max()) + 1, int(g[:, 1].max()) + 1
    buckets: dict[tuple[int, int], list[int]] = {}
    for i, (gx, gy) in enumerate(g.tolist()):
        buckets.setdefault((gx, gy), []).append(i)
    lists = [
        [i for dx in (-1, 0, 1) for dy in (-1, 0, 1) for i in buckets.get((gx + dx, gy + dy), ())]
        for gx in range(nx)
        for gy in range(ny)
    ]
    K = max(1, max(len(li) for li in lists))
    nbr = np.full((nx * ny, K), n, dtype=np.intp)
    for c, li in enumerate(lists):
        nbr[c, : len(li)] = li
    tx = np.append(t[:, 0], _FAR)
    ty = np.append(t[:, 1], _FAR)
    return _UserGrid(float(lo[0]), float(lo[1]), h, nx, ny, nbr, tx, ty)


def _covered_counts(
    problem: CellProblem, grid: _UserGrid, blk: NDArray[np.float64], contrib: NDArray[np.bool_]
) -> NDArray[np.int64]:
    """Users within R_d of a contributing drone-cell, per chromosome of ``blk`` (B, m, 2).

    The distance test is evaluate()'s: sqrt(dx**2 + dy**2) <= R_d + TOL, on the users of the
    3 x 3 grid block around each drone-cell (all the users that can pass it); a user covered
    by several drone-cells of a chromosome is counted once."""
    B = len(blk)
    n = len(grid.tx) - 1
    ix = np.clip(np.floor((blk[..., 0] - grid.x0) / grid.h), 0, grid.nx - 1).astype(np.intp)
    iy = np.clip(np.floor((blk[..., 1] - grid.y0) / grid.h), 0, grid.ny - 1).astype(np.intp)
    idx = grid.nbr[ix * grid.ny + iy]  # (B, m, K)
    dx = grid.tx[idx] - blk[..., 0, None]
    dy = grid.ty[idx] - blk[..., 1, None]
    cov = (np.sqrt(dx * dx + dy * dy) <= problem.R_d + TOL) & contrib[:, :, None]
    rows = np.broadcast_to(np.arange(B)[:, None, None], idx.shape)
    mark = np.zeros((B, n + 1), dtype=bool)
    mark[rows[cov], idx[cov]] = True
    return mark[:, :n].sum(axis=1)


def fitness(problem: CellProblem, pop: ArrayLike, *, chunk: int = 2048) -> NDArray[np.int64]:
    """GA fitness of a population (..., m, 2) in metres -> (...) covered users (int),
    counting only contributing drone-cells (module docstring). Vectorised over the
    population (in chunks of ``chunk`` chromosomes to bound memory).

    A user counts when it lies within R_d of a contributing drone-cell by the test of
    :func:`~droneplan.formulations.cells.evaluate` (``sqrt(dx**2 + dy**2) <= R_d + TOL``),
    so a chromosome's fitness equals ``evaluate`` of its contributing drone-cells. Only the
    users bucketed near each drone-cell are tested (a grid of side >= R_d + TOL).

    problem: the CellProblem (users, GBSs, m, radii in metres).
    pop: (..., m, 2) chromosomes, drone-cell positions (m).
    chunk: chromosomes evaluated per vectorised block (count).
    """
    if not isinstance(problem, CellProblem):
        raise TypeError(f"problem must be a CellProblem, got {type(problem).__name__}")
    problem.require_thesis_model("fitness")
    chunk = check_int("chunk", chunk, min_value=1)
    arr = check_array("pop", pop)
    if arr.ndim < 2 or arr.shape[-1] != 2:
        raise ValueError(f"pop must have shape (..., m, 2) (positions in metres), got {arr.shape}")
    return _fitness(problem, arr, None, chunk)


def _fitness(
    problem: CellProblem,
    arr: NDArray[np.float64],
    grid: _UserGrid | None,
    chunk: int = 2048,
    mode: str = "contributing",
) -> NDArray[np.int64]:
    """:func:`fitness` without argument checks; ``grid`` is the problem's user grid (built if None);
    ``mode`` is the reading :attr:`GASettings.fitness` (the public function's is "contributing")."""
    if arr.ndim == 2:
        arr = arr[None]
    lead = arr.shape[:-2]
    flat = arr.reshape(-1, *arr.shape[-2:])
    out = np.zeros(len(flat), dtype=np.int64)
    if len(problem.targets) == 0 or len(flat) == 0:
        return out.reshape(lead)
    grid = _user_grid(problem) if grid is None else grid
    for a in range(0, len(flat), chunk):
        blk = flat[a : a + chunk]
        counted = np.ones(blk.shape[:2], dtype=bool) if mode == "unfiltered" else _contributing(problem, blk)
        vals = _covered_counts(problem, grid, blk, counted)
        if mode == "all_or_nothing":
            vals = np.where(counted.all(axis=1), vals, 0)
        out[a : a + chunk] = vals
    return out.reshape(lead)


class _GaProgress:
    """What a GA run has done so far: fitness evaluations against a budget, and the best
    chromosome across the restarts, handed to ``on_best`` each time it improves."""

    def __init__(self, max_evaluations: int | None, on_best: Callable[[NDArray[np.float64]], Any] | None):
        self.max_evaluations, self.on_best = max_evaluations, on_best
        self.evaluations = self.generations = 0
        self.best = -1

    def count(self, n: int) -> None:
        self.evaluations += int(n)

    def room_for(self, n: int) -> bool:
        """Whether ``n`` more evaluations stay within the budget."""
        return self.max_evaluations is None or self.evaluations + n <= self.max_evaluations

    def look(self, pop: NDArray[np.float64], f: NDArray[np.int_]) -> None:
        """Report the best chromosome of all runs if it beats the best seen (no random draw)."""
        if self.on_best is None:
            return
        run, member = np.unravel_index(int(np.argmax(f)), f.shape)
        if f[run, member] > self.best:
            self.best = int(f[run, member])
            self.on_best(pop[run, member].copy())


class _RunBests:
    """The best chromosome each of N runs has held so far, and its fitness (for the "run"
    reading of f_best and the "best_ever" reading of the result)."""

    def __init__(self, pop: NDArray[np.float64], f: NDArray[np.int_]):
        self.idx = np.arange(len(pop))
        self.f = np.full(len(pop), -1, dtype=np.int64)
        self.chrom = np.zeros((len(pop), *pop.shape[2:]))
        self.look(pop, f)

    def look(self, pop: NDArray[np.float64], f: NDArray[np.int_]) -> None:
        """Keep each run's best of ``pop`` when it beats the best held (no random draw)."""
        i = np.argmax(f, axis=1)
        fi = f[self.idx, i]
        up = fi > self.f
        self.chrom[up] = pop[self.idx, i][up]
        self.f[up] = fi[up]


def _mutate(
    problem: CellProblem,
    pop: NDArray[np.float64],
    f: NDArray[np.int_],
    fbest: NDArray[Any],
    box: tuple[NDArray[np.float64], NDArray[np.float64]],
    s: GASettings,
    rng: np.random.Generator,
) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """Mutation (4.10) of every run's population: the candidate population and which
    chromosomes changed. ``fbest`` (N, 1) is f_best of each run (its reading chosen by the caller)."""
    N, P, m, _ = pop.shape
    lo, hi = box
    origin = problem.gbs[0]
    scale = np.where(fbest > 0, (1.0 - f / np.maximum(fbest, 1e-12)) ** 2, 1.0)
    if s.mutation == "gene":
        mask = rng.random((N, P, m, 2)) < s.p_m
    else:  # "chromosome": each chromosome with probability P_m, all its genes
        mask = np.broadcast_to((rng.random((N, P)) < s.p_m)[..., None, None], (N, P, m, 2))
    sign = rng.choice([-1.0, 1.0], size=(N, P, m, 2))
    step = sign * rng.random((N, P, m, 2)) * scale[..., None, None]
    if s.mutation_step is None:  # (4.10): g' = g (1 +- rnd (1 - f/f_best)^2), g relative to the GBS
        moved = origin + (pop - origin) * (1.0 + step)
    else:  # ablation variant: an absolute step
        moved = pop + step * s.mutation_step
    cand: NDArray[np.float64] = np.clip(np.where(mask, moved, pop), lo, hi)
    changed: NDArray[np.bool_] = np.asarray(mask.any(axis=(2, 3)))
    return cand, changed


def _crossover(
    pop: NDArray[np.float64], f: NDArray[np.int_], s: GASettings, rng: np.random.Generator
) -> tuple[NDArray[np.intp], NDArray[np.intp], NDArray[np.intp]]:
    """Adaptive crossover (4.11)-(4.12) in place on ``pop`` (N, P, m, 2), pairs drawn within each
    run; returns (run, first, second) of the crossed pairs."""
    N, P, m, _ = pop.shape
    perm = np.argsort(rng.random((N, P)), axis=1)
    half = P // 2
    a, b = perm[:, 0 : 2 * half : 2], perm[:, 1 : 2 * half : 2]
    fmax = f.max(axis=1, keepdims=True).astype(float)
    favg = f.mean(axis=1, keepdims=True)
    fp = np.maximum(np.take_along_axis(f, a, 1), np.take_along_axis(f, b, 1))
    spread = fmax - favg
    ramp = s.p_c1 - (s.p_c1 - s.p_c2) * (fp - favg) / np.where(spread > 0, spread, 1.0)
    pc = np.where(fp >= favg, ramp, s.p_c1)
    pc = np.where(spread > 0, pc, s.p_c2)
    do = rng.random((N, half)) < pc
    rr, cc = np.nonzero(do)
    ia, ib = a[rr, cc], b[rr, cc]
    if s.crossover == "cell":  # one drone-cell's y
        r = rng.integers(0, m, size=(N, half))[rr, cc]
        ya = pop[rr, ia, r, 1].copy()
        pop[rr, ia, r, 1] = pop[rr, ib, r, 1]
        pop[rr, ib, r, 1] = ya
    else:  # "column": every drone-cell's y
        ya = pop[rr, ia, :, 1].copy()
        pop[rr, ia, :, 1] = pop[rr, ib, :, 1]
        pop[rr, ib, :, 1] = ya
    return rr, ia, ib


def _select(pop: NDArray[np.float64], f: NDArray[np.int_], n_rep: int) -> None:
    """Selection (§4.3.2.3) in place: the worst ``n_rep`` of each run replaced by its best."""
    if not n_rep:
        return
    N = len(pop)
    order = np.argsort(f, axis=1, kind="stable")
    best = order[:, -1]
    worst = order[:, :n_rep]
    pop[np.arange(N)[:, None], worst] = pop[np.arange(N), best][:, None]
    f[np.arange(N)[:, None], worst] = f[np.arange(N), best][:, None]


def _run_batch(
    problem: CellProblem,
    N: int,
    P: int,
    iter_max: int,
    s: GASettings,
    rng: np.random.Generator,
    progress: _GaProgress | None = None,
    init_best: NDArray[np.float64] | None = None,
) -> tuple[NDArray[np.float64], NDArray[np.int_], NDArray[np.float64]]:
    """N independent GA runs (the restarts) advanced together: arrays are (N, P, m, 2).
    Every operator acts within its own run only, so this equals N sequential restarts.
    Returns each run's result chromosome (by ``s.result``), its fitness and the share of the
    final population identical to the final population's best. ``progress`` counts the fitness
    evaluations, stops before a generation that could go beyond its budget (one evaluates at
    most 2 N P chromosomes), and reports new best chromosomes. ``init_best`` (m, 2), when
    given, replaces the first chromosome of every run's initial population."""
    progress = progress or _GaProgress(None, None)
    m = problem.n_cells
    xmin, xmax, ymin, ymax = _area(problem)
    box = (np.array([xmin, ymin]), np.array([xmax, ymax]))
    grid = _user_grid(problem) if len(problem.targets) else None
    pop = rng.uniform(box[0], box[1], size=(N, P, m, 2))
    if init_best is not None:
        pop[:, 0] = init_best
    f = _fitness(problem, pop, grid, mode=s.fitness)
    progress.count(N * P)
    progress.look(pop, f)
    track = s.f_best == "run" or s.result == "best_ever"
    held = _RunBests(pop, f) if track else None
    T = s.T
    n_rep = math.floor(s.replace_frac * P)
    for _ in range(iter_max):
        if not progress.room_for(2 * N * P):
            break
        # --- mutation (4.10) with simulated-annealing acceptance (per run's f_best)
        fbest = held.f[:, None] if held is not None and s.f_best == "run" else f.max(axis=1, keepdims=True)
        cand, changed = _mutate(problem, pop, f, fbest, box, s, rng)
        fc = f.copy()
        if changed.any():
            fc[changed] = _fitness(problem, cand[changed], grid, mode=s.fitness)
            progress.count(changed.sum())
        delta = fc - f
        accept = changed & ((delta >= 0) | (rng.random((N, P)) < np.exp(np.minimum(delta, 0) / T)))
        pop = np.where(accept[..., None, None], cand, pop)
        f = np.where(accept, fc, f)
        if held is not None:
            held.look(pop, f)
        # --- adaptive crossover (4.11)-(4.12)
        rr, ia, ib = _crossover(pop, f, s, rng)
        # the fitness is a function of the chromosome alone: re-evaluate the crossed ones only
        crossed = np.zeros((N, P), dtype=bool)
        crossed[rr, ia] = True
        crossed[rr, ib] = True
        f[crossed] = _fitness(problem, pop[crossed], grid, mode=s.fitness)
        progress.count(crossed.sum())
        if held is not None:
            held.look(pop, f)
        _select(pop, f, n_rep)
        progress.look(pop, f)
        progress.generations += 1
        T *= s.alpha
    i = np.argmax(f, axis=1)
    best_chrom = pop[np.arange(N), i]
    # how far each run's population has collapsed: the share of chromosomes equal to its best
    share = np.all(pop == best_chrom[:, None], axis=(2, 3)).mean(axis=1)
    if held is not None and s.result == "best_ever":
        return held.chrom.copy(), held.f.astype(int), share
    return best_chrom.copy(), f[np.arange(N), i].astype(int), share


_GA_WORKING_ARRAYS = 10
"""Arrays of the population's shape (restarts, pop_size, m, 2) a generation holds at once
(population, mutated copy, random draws, steps ...): the peak memory measured with
``tracemalloc`` is 9-11 times the population array once that array dominates (restarts=10**5,
pop_size=4, m=2: 120 MB; Table 4.3 m=4: 11 times)."""


def _check_ga_work(problem: CellProblem, P: int, iter_max: int, N: int) -> None:
    """Refuse up front a GA run beyond the work budgets (``droneplan.core.validation``).

    - generations: ``iter_max`` sequential generations, each a Python-level step (about
      0.2 ms), against the ``evaluations`` budget (100 000 by default);
    - fitness evaluations: pop_size x restarts x (iter_max + 1) chromosomes (the initial
      population and one pass per generation), against the ``elements`` budget (50 000 000 by
      default): each evaluation is a vectorised pass over one chromosome of about 1-4 us CPU
      (1.1 us with 3 users, 3.4 us on a Table 4.2 instance with m = 3), the cost of a few
      array elements, not of a Python-level step. Table 4.3 at m = 4 (P = 200, N = 200,
      iter_max = 50) asks for 2 040 000, far beyond the ``evaluations`` budget but 25 times
      within this one; the error names the parameter furthest above its Table 4.3 value;
    - memory: ``_GA_WORKING_ARRAYS`` arrays of the population's shape, against ``elements``.
    """
    m = problem.n_cells
    P0, N0 = thesis_ga_settings(m)
    check_work("iter_max (sequential generations)", iter_max, "evaluations")
    ratios = {"pop_size": P / P0, "iter_max": (iter_max + 1) / 51, "restarts": N / N0}
    blame = max(ratios, key=lambda k: ratios[k])
    check_work(
        f"{blame} (pop_size x restarts x (iter_max + 1) fitness evaluations, counted as array elements)",
        float(P) * N * (iter_max + 1),
        "elements",
    )
    # fitness() evaluates coverage in blocks of `chunk` chromosomes, so the user count does
    # not multiply the memory
    check_size(
        f"restarts x pop_size x n_cells x 2 x {_GA_WORKING_ARRAYS} (the GA's working arrays)",
        float(N) * P * m * 2 * _GA_WORKING_ARRAYS,
    )


def genetic(
    problem: CellProblem,
    *,
    pop_size: int | None = None,
    iter_max: int = 50,
    restarts: int | None = None,
    seed: int | np.random.Generator | None = None,
    settings: GASettings | None = None,
    max_evaluations: int | None = None,
    report: Callable[[NDArray[np.float64]], Any] | None = None,
) -> SolveResult:
    """Thesis GA with the restart strategy (§4.3.2, Tables 4.1 and 4.3).

    pop_size: population size P_size (default: Table 4.3 row for m).
    iter_max: generations per restart (thesis: 50).
    restarts: number of independent restarts N_start (default: Table 4.3 row for m).
    seed: int or Generator; the run is reproducible from it.
    settings: :class:`GASettings` (default Table 4.1).
    max_evaluations: a budget of fitness evaluations (chromosomes evaluated, count); the run
        stops before a generation that could exceed it (a generation evaluates at most
        2 x pop_size x restarts chromosomes: the mutated and the crossed ones). None: the
        thesis's iter_max generations. The count used is ``info["evaluations"]``.
    report: called with each new best plan across the restarts, the contributing drone-cells
        (k, 2) in metres, after the initial population and after every generation that
        improves it (an anytime trace); it draws no random number, so the run is the same
        with or without it.

    Returns a SolveResult with status FEASIBLE (no bound), ``x`` the contributing
    drone-cells (k, 2) of the best chromosome (m), ``objective`` their covered users,
    ``iterations`` = restarts * iter_max, and ``info``: ``restart_bests`` (best fitness of
    each restart), ``final_best_share`` (per restart, the fraction of the final population
    identical to its best chromosome: 1 means the population has collapsed), ``chromosome``
    (the full m x 2 best chromosome), ``seed``.

    problem: the CellProblem (users, GBSs, m, radii in metres).

    Work budgets (``droneplan.core.validation.work_limits``): at most ``evaluations``
    generations (iter_max; default 100 000), at most ``elements`` fitness evaluations
    pop_size x restarts x (iter_max + 1) (default 50 000 000; Table 4.3 at m = 4 asks for
    2 040 000) and the GA's working arrays within ``elements``; beyond them a ValueError names
    the parameter, the size asked for and the limit before any work starts.
    """
    if not isinstance(problem, CellProblem):
        raise TypeError(f"problem must be a CellProblem, got {type(problem).__name__}")
    problem.require_thesis_model("genetic")
    P0, N0 = thesis_ga_settings(problem.n_cells)
    P = P0 if pop_size is None else pop_size
    N = N0 if restarts is None else restarts
    for name, v, lo in (("pop_size", P, 2), ("iter_max", iter_max, 0), ("restarts", N, 1)):
        check_int(name, v, min_value=lo)
    _check_ga_work(problem, int(P), int(iter_max), int(N))
    if settings is not None and not isinstance(settings, GASettings):
        raise TypeError(f"settings must be GASettings or None, got {type(settings).__name__}")
    s = settings or GASettings()
    rng, drawn = resolve_seed(seed)
    seed = seed if drawn is None else drawn  # the seed drawn for seed=None is recorded
    t0 = time.perf_counter()
    if max_evaluations is not None:
        check_int("max_evaluations", max_evaluations, min_value=1)
    if report is not None and not callable(report):
        raise TypeError(f"report must be callable or None, got {type(report).__name__}")
    on_best = None
    if report is not None:
        send = report

        def on_best(chromosome: NDArray[np.float64]) -> None:
            send(chromosome[_contributing(problem, chromosome[None])[0]])

    progress = _GaProgress(max_evaluations, on_best)
    if s.carry_best:  # restarts one after another, each seeded with the best so far
        parts: list[tuple[NDArray[np.float64], NDArray[np.int_], NDArray[np.float64]]] = []
        for _ in range(int(N)):
            carried = None if not parts else max(parts, key=lambda t: int(t[1][0]))[0][0]
            parts.append(_run_batch(problem, 1, int(P), int(iter_max), s, rng, progress, carried))
        chromos, fvals, share = (np.concatenate([t[j] for t in parts]) for j in range(3))
        generations = progress.generations
    else:
        chromos, fvals, share = _run_batch(problem, int(N), int(P), int(iter_max), s, rng, progress)
        generations = int(N * progress.generations)
    bests = [int(v) for v in fvals]
    k = int(np.argmax(bests))
    chrom = chromos[k]
    contrib = _contributing(problem, chrom[None])[0]
    x = chrom[contrib]
    obj = evaluate(problem, x).covered
    return SolveResult(
        Status.FEASIBLE,
        objective=float(obj),
        bound=None,
        x=x,
        backend="ga",
        message=f"thesis GA: {N} restarts x {iter_max} generations, population {P}",
        solve_time=time.perf_counter() - t0,
        iterations=generations,
        info={
            "restart_bests": bests,
            "final_best_share": [float(v) for v in share],
            "chromosome": chrom,
            "seed": seed if not isinstance(seed, np.random.Generator) else None,
            "pop_size": int(P),
            "restarts": int(N),
            "evaluations": progress.evaluations,
        },
    )


# =========================================================================== exhaustive search
@dataclass(frozen=True)
class Region:
    """A deployment region (Definition 4.3.1): points p with |p - c| >= r for every
    (c, r) in ``exclude``, |p - c| <= r for at least one (c, r) in ``link``, and inside
    ``box`` (xmin, xmax, ymin, ymax) when given. Lengths in metres."""

    exclude: tuple[tuple[float, float, float], ...]
    """(cx, cy, r): keep-out discs (GBS cells with r = R_g + R_d, drone-cells with r = 2 R_d)."""
    link: tuple[tuple[float, float, float], ...]
    """(cx, cy, r): backhaul discs (GBS with r1, placed drone-cells with r2); the union counts."""
    box: tuple[float, float, float, float] | None = None
    """Operating area, or None."""

    def contains(self, pts: ArrayLike) -> NDArray[np.bool_]:
        """(q,) bool for points (q, 2), with the package tolerance."""
        pts = np.asarray(pts, float).reshape(-1, 2)
        ok = np.ones(len(pts), dtype=bool)
        for cx, cy, r in self.exclude:
            ok &= np.hypot(pts[:, 0] - cx, pts[:, 1] - cy) >= r - TOL
        if self.link:
            lk = np.zeros(len(pts), dtype=bool)
            for cx, cy, r in self.link:
                lk |= np.hypot(pts[:, 0] - cx, pts[:, 1] - cy) <= r + TOL
            ok &= lk
        else:
            ok[:] = False
        if self.box is not None:
            xmin, xmax, ymin, ymax = self.box
            ok &= (
                (pts[:, 0] >= xmin - TOL)
                & (pts[:, 0] <= xmax + TOL)
                & (pts[:, 1] >= ymin - TOL)
                & (pts[:, 1] <= ymax + TOL)
            )
        return ok

    def circles(self) -> list[tuple[float, float, float]]:
        """Every boundary circle (cx, cy, r) of the region, keep-out discs first."""
        return list(self.exclude) + list(self.link)

    def geometry(self, *, quad_segs: int = 64) -> Any:
        """The region as a shapely geometry (a (Multi)Polygon, empty when the region is):
        (union of ``link`` discs) intersected with ``box``, minus the union of ``exclude``
        discs. Discs are polygons with 4 * ``quad_segs`` vertices on the circle, so a
        point farther than :meth:`geometry_error` (m) from every boundary circle is
        classified as by :meth:`contains`."""
        from shapely.geometry import Point, Polygon, box
        from shapely.ops import unary_union

        if isinstance(quad_segs, bool) or not isinstance(quad_segs, int) or quad_segs < 1:
            raise ValueError(f"quad_segs must be an int >= 1, got {quad_segs!r}")
        if not self.link:
            return Polygon()
        # coincident discs (drone-cells placed at one spot) are one disc
        geom = unary_union(
            [Point(cx, cy).buffer(r, quad_segs=quad_segs) for cx, cy, r in dict.fromkeys(self.link)]
        )
        if self.box is not None:
            xmin, xmax, ymin, ymax = self.box
            geom = geom.intersection(box(xmin, ymin, xmax, ymax))
        if self.exclude:
            geom = geom.difference(
                unary_union(
                    [
                        Point(cx, cy).buffer(r, quad_segs=quad_segs)
                        for cx, cy, r in dict.fromkeys(self.exclude)
                    ]
                )
            )
        return geom

    def geometry_error(self, *, quad_segs: int = 64) -> float:
        """Largest distance (m) between a boundary circle and its polygon in :meth:`geometry`:
        r (1 - cos(pi / (4 quad_segs))) for the largest radius."""
        r = max((c[2] for c in self.circles()), default=0.0)
        return r * (1.0 - math.cos(math.pi / (4 * quad_segs)))


def deployment_region(problem: CellProblem, placed: ArrayLike = ()) -> Region:
    """Deployment region (Definition 4.3.1, Fig. 4.2) of one more drone-cell given the
    GBSs and drone-cells already ``placed`` ((k, 2) m): clear of every GBS cell
    (|D - G| >= R_g + R_d, 4.7) and of every placed cell (>= 2 R_d, 4.8), within r1 of a
    GBS or r2 of a placed cell (a backhaul link), inside ``problem.bounds``."""
    check_instance("problem", problem, CellProblem)
    return _region(problem, check_array("placed", placed, shape=(None, 2)))


def _region(problem: CellProblem, placed: NDArray[np.float64]) -> Region:
    ex = [(g[0], g[1], problem.R_g + problem.R_d) for g in problem.gbs]
    ex += [(d[0], d[1], 2 * problem.R_d) for d in placed]
    lk = [(g[0], g[1], problem.r1) for g in problem.gbs] + [(d[0], d[1], problem.r2) for d in placed]
    return Region(tuple(ex), tuple(lk), problem.bounds)


def _circle_line_angles(
    ox: float, oy: float, rho: float, box: tuple[float, float, float, float] | None
) -> NDArray[np.float64]:
    out: list[float] = []
    if box is None:
        return np.zeros(0)
    for axis, val in ((0, box[0]), (0, box[1]), (1, box[2]), (1, box[3])):
        c = (val - (ox if axis == 0 else oy)) / rho
        if -1 <= c <= 1:
            a = math.acos(c)
            out += [a, -a] if axis == 0 else [math.asin(c), math.pi - math.asin(c)]
    return np.array(out)


def max_coverage_in_region(
    users: ArrayLike, R_d: float, region: Region
) -> tuple[int, NDArray[np.float64] | None]:
    """Maximum number of ``users`` ((n, 2) m) one radius-R_d disc centred in ``region``
    can cover, and a centre attaining it (None when the region is empty).

    Angular sweep (the thesis uses Chazelle & Lee's method [141] for this step): an
    optimal covered set S leaves a compact set A = (intersection of B(u, R_d), u in S)
    intersected with the region, and some point of A lies on a user circle or on a
    region boundary circle (or is a box corner). On each such circle, the angles at
    which a user disc or a region constraint starts or stops holding are the only
    places where the count or feasibility changes, and closed sets attain their
    maximum at one of those angles, so we evaluate the count at every such event angle.
    Circles whose neighbourhood holds no more users than the best count so far are
    skipped (they cannot improve it).

    users: (n, 2) positions (m), finite; R_d: disc radius (m) > 0; region: a :class:`Region`
    (e.g. from :func:`deployment_region`). The sweep compares candidate points with users:
    n x n pairs beyond the array-element budget (``core.validation.work_limits``) are
    refused up front, and the sweep stops with a ValueError naming ``users`` once its
    point comparisons pass 20 times that budget (about ten seconds of work).
    """
    pts = check_array("users", users, shape=(None, 2))
    R_d = check_positive("R_d", R_d)
    check_instance("region", region, Region)
    check_size("users (n x n user pairs)", pts.shape[0] * (pts.shape[0] + 4))
    return _max_coverage(pts, R_d, region, budget=20 * current_limit("elements"))


def _max_coverage(  # noqa: C901, PLR0915
    users: NDArray[np.float64], R_d: float, region: Region, floor: int = -1, budget: int | None = None
) -> tuple[int, NDArray[np.float64] | None]:
    """:func:`max_coverage_in_region`; with ``floor`` >= 0 it also skips the circles whose
    neighbourhood holds no more than ``floor`` users, so it returns the true maximum and
    the same centre whenever that maximum exceeds ``floor`` (else a lower count). With a
    ``budget``, more point-user comparisons than that raise ValueError naming ``users``."""
    best, best_p = -1, None
    work = 0
    circles = [(u[0], u[1], R_d) for u in users] + region.circles()
    if len(users):
        from scipy.spatial import cKDTree

        tree = cKDTree(users)
    extra = []
    if region.box is not None:
        xmin, xmax, ymin, ymax = region.box
        extra += [(xmin, ymin), (xmin, ymax), (xmax, ymin), (xmax, ymax)]
    # user points and box corners, in that order: the first feasible point of largest count
    cand = np.concatenate([users, np.asarray(extra, float).reshape(-1, 2)])
    if len(cand):
        feas = region.contains(cand)
        if feas.any():
            pts = cand[feas]
            cnt = (
                (
                    np.hypot(users[None, :, 0] - pts[:, 0, None], users[None, :, 1] - pts[:, 1, None])
                    <= R_d + TOL
                ).sum(1)
                if len(users)
                else np.zeros(len(pts), dtype=np.intp)
            )
            j = int(np.argmax(cnt))
            best, best_p = int(cnt[j]), pts[j].copy()
    all_c = np.array(circles) if circles else np.zeros((0, 3))
    if not len(users):
        return (0, None) if best_p is None else (best, best_p)
    # how many users each circle's neighbourhood holds, for all circles in one call
    n_near = tree.query_ball_point(all_c[:, :2], all_c[:, 2] + R_d + TOL, return_length=True)
    for (ox, oy, rho), k in zip(circles, n_near.tolist(), strict=True):
        if k <= max(best, floor):
            continue
        near = tree.query_ball_point((ox, oy), rho + R_d + TOL)
        lu = users[near]
        ang = [np.zeros(1)]
        # events of user discs and region circles on this circle
        for cs, rs in ((lu, np.full(len(lu), R_d)), (all_c[:, :2], all_c[:, 2])):
            dx, dy = cs[:, 0] - ox, cs[:, 1] - oy
            d = np.hypot(dx, dy)
            ok = d > 0
            kappa = np.full(len(d), 2.0)
            kappa[ok] = (rho**2 + d[ok] ** 2 - rs[ok] ** 2) / (2 * rho * d[ok])
            ok &= np.abs(kappa) <= 1
            phi = np.arctan2(dy[ok], dx[ok])
            al = np.arccos(np.clip(kappa[ok], -1, 1))
            ang += [phi + al, phi - al]
        ang.append(_circle_line_angles(ox, oy, rho, region.box))
        th = np.concatenate(ang)
        pts = np.column_stack([ox + rho * np.cos(th), oy + rho * np.sin(th)])
        feas = region.contains(pts)
        if not feas.any():
            continue
        pts = pts[feas]
        work += len(th) * (len(all_c) + 1) + len(pts) * len(lu)
        if budget is not None:
            what = f"users ({len(users)} users; the sweep's point comparisons, 20 x the element budget)"
            check_work(what, work, limit=budget)
        cnt = (
            (pts[:, None, 0] - lu[None, :, 0]) ** 2 + (pts[:, None, 1] - lu[None, :, 1]) ** 2
            <= (R_d + TOL) ** 2
        ).sum(1)
        j = int(np.argmax(cnt))
        if cnt[j] > best:
            best, best_p = int(cnt[j]), pts[j]
    if best_p is None:
        return 0, None
    return best, best_p


@dataclass
class _SearchState:
    """The best placement found so far by :func:`exhaustive` and the enumeration's progress."""

    val: int
    """Users covered by ``pos`` (count)."""
    pos: NDArray[np.float64]
    """Drone-cell positions (k, 2) in metres."""
    complete: bool = True
    """False once the time limit stopped the enumeration."""
    visited: int = 0
    """Searches of the last drone-cell's region done (count)."""
    skipped: int = 0
    """Searches of the last drone-cell's region skipped by the bound (count)."""
    pruned: int = 0
    """Subtrees (a drone-cell 1..m-2 and everything after it) skipped by the bound (count)."""
    report: Callable[[NDArray[np.float64]], Any] | None = None
    """Called with each new best placement (k, 2), in metres."""

    def improve(self, val: int, pos: NDArray[np.float64]) -> None:
        """Keep ``pos`` (covering ``val`` users) as the best; report it."""
        self.val, self.pos = val, pos
        if self.report is not None:
            self.report(pos.copy())


class _DiscBound:
    """Upper bound on the users one radius-R_d disc can add: a disc covering users u and v
    has |u - v| <= 2 (R_d + TOL), so it covers at most the number of still-uncovered
    users within that distance of one of them (``near`` holds the pairs, with a margin)."""

    def __init__(self, problem: CellProblem):
        t = problem.targets
        self.users = t
        self.R_d = problem.R_d
        d = np.sqrt(((t[:, None, :] - t[None, :, :]) ** 2).sum(-1))
        self.near = (d <= 2.0 * (problem.R_d + TOL) + 1e-6 * (1.0 + problem.R_d)).astype(np.int32)

    def one_disc(self, eligible: NDArray[np.bool_]) -> int:
        """Most of the ``eligible`` users one disc can cover (an upper bound)."""
        if not eligible.any():
            return 0
        return int((self.near[eligible] @ eligible.astype(np.int32)).max())

    def reachable(self, region: Region) -> NDArray[np.bool_]:
        """Users that a disc centred in ``region`` can cover: within R_d (+ margin) of a
        backhaul disc of the region (a necessary condition)."""
        t = self.users
        ok = np.zeros(len(t), dtype=bool)
        for cx, cy, r in region.link:
            ok |= np.hypot(t[:, 0] - cx, t[:, 1] - cy) <= r + self.R_d + 2 * TOL + 1e-6 * (1.0 + r)
        return ok


def exhaustive(  # noqa: C901
    problem: CellProblem,
    *,
    time_limit: float | None = None,
    prune: bool = True,
    max_evaluations: int | None = None,
    report: Callable[[NDArray[np.float64]], Any] | None = None,
) -> SolveResult:
    """Algorithm 2 (thesis §4.3.1): drone-cells 1..m-1 visit every user location inside
    their deployment region (which depends on the GBSs and the cells placed before);
    the m-th is placed by :func:`max_coverage_in_region` in its region; the best
    combination is returned. Quasi-optimal (thesis) and O(n^(2m)) in the worst case.

    time_limit: stop enumerating after this many seconds (s) and return the best found
        with status FEASIBLE and ``info["complete"] = False``.
    prune: skip, in the same enumeration order, every last-cell search and every subtree
        that cannot cover *more* users than the best found so far: with c users covered
        and k drone-cells still to place, at most c + k * B users, B the bound of
        :class:`_DiscBound` on what one disc adds (over the users it can reach, for the
        last cell). The search keeps a new best only when it is strictly better, so the
        returned value and plan are those of the plain enumeration (``prune=False``), the
        Algorithm 2 of the thesis, which is only faster; ``solve_time`` is the honest wall
        time of the pruned search.
    max_evaluations: stop, as at the time limit, once this many searches of the last drone-cell's
        region were done (count; ``info["last_cell_searches"]``); None: no such budget.
    report: called with each new best placement (k, 2), in metres, as the enumeration finds it
        (an anytime trace).

    Returns a SolveResult (no bound): ``x`` positions (k, 2), ``objective`` covered users;
    ``info``: ``complete``, ``last_cell_searches`` (done), ``last_cell_skipped`` and
    ``subtrees_pruned`` (skipped by the bound).

    problem: the CellProblem (users, GBSs, m, radii in metres).
    """
    if not isinstance(problem, CellProblem):
        raise TypeError(f"problem must be a CellProblem, got {type(problem).__name__}")
    problem.require_thesis_model("exhaustive")
    time_limit = check_time_limit(time_limit)
    if not isinstance(prune, bool):
        raise TypeError(f"prune must be a bool, got {type(prune).__name__}")
    if max_evaluations is not None:
        check_int("max_evaluations", max_evaluations, min_value=1)
    if report is not None and not callable(report):
        raise TypeError(f"report must be callable or None, got {type(report).__name__}")
    t0 = time.perf_counter()
    users = problem.targets
    m = problem.n_cells
    best = _SearchState(val=0, pos=np.zeros((0, 2)), report=report)
    bound = _DiscBound(problem) if prune and len(users) else None

    def rec(placed: NDArray[np.float64], covered: NDArray[np.bool_]) -> None:  # noqa: C901
        out_of_time = time_limit is not None and time.perf_counter() - t0 > time_limit
        if out_of_time or (max_evaluations is not None and best.visited >= max_evaluations):
            best.complete = False
            return
        region = _region(problem, placed)
        if len(placed) == m - 1:
            if bound is not None:
                gain = bound.one_disc(~covered & bound.reachable(region))
                if int(covered.sum()) + gain <= best.val:
                    best.skipped += 1
                    return
            left = users[~covered]
            # circles that cannot lift the total above the best are skipped (_max_coverage)
            c, p = _max_coverage(left, problem.R_d, region, best.val - int(covered.sum()) if prune else -1)
            best.visited += 1
            if p is not None:
                val = int(covered.sum()) + c
                if val > best.val:
                    best.improve(val, np.vstack([placed, p[None]]))
            return
        inside = np.flatnonzero(region.contains(users))
        for j in inside:
            newcov = covered | (
                np.hypot(users[:, 0] - users[j, 0], users[:, 1] - users[j, 1]) <= problem.R_d + TOL
            )
            pl = np.vstack([placed, users[j][None]])
            if int(newcov.sum()) > best.val:
                best.improve(int(newcov.sum()), pl)
            # the cells after this one add at most (m - len(pl)) discs' worth of users
            if (
                bound is not None
                and len(pl) < m - 1
                and int(newcov.sum()) + (m - len(pl)) * bound.one_disc(~newcov) <= best.val
            ):
                best.pruned += 1
                continue
            rec(pl, newcov)
            if not best.complete:
                return

    rec(np.zeros((0, 2)), np.zeros(len(users), dtype=bool))
    return _exhaustive_result(problem, best, prune=prune, budgets=(time_limit, max_evaluations), t0=t0)


def _exhaustive_result(
    problem: CellProblem,
    best: _SearchState,
    *,
    prune: bool,
    budgets: tuple[float | None, int | None],
    t0: float,
) -> SolveResult:
    """The result of :func:`exhaustive` from its final search state; ``budgets``: its time limit
    (s) and its budget of last-cell searches."""
    time_limit, max_evaluations = budgets
    ev = evaluate(problem, best.pos)
    if not ev.feasible:  # cannot happen by construction; never report an infeasible plan
        return SolveResult(
            Status.ERROR,
            backend="exhaustive",
            message=f"internal: infeasible plan {ev.violations}",
            solve_time=time.perf_counter() - t0,
        )
    msg = "Algorithm 2 (exhaustive search, quasi-optimal)"
    if prune:
        msg += "; bound-pruned enumeration (same result as the plain one)"
    if not best.complete:
        budget = f"the time limit {time_limit} s" if time_limit is not None else ""
        if max_evaluations is not None and best.visited >= max_evaluations:
            budget = f"the budget of {max_evaluations} last-cell searches"
        msg += f"; stopped at {budget} before finishing the enumeration"
    return SolveResult(
        Status.FEASIBLE,
        objective=float(ev.covered),
        x=best.pos,
        backend="exhaustive",
        message=msg,
        solve_time=time.perf_counter() - t0,
        info={
            "complete": best.complete,
            "last_cell_searches": best.visited,
            "last_cell_skipped": best.skipped,
            "subtrees_pruned": best.pruned,
        },
    )


# =========================================================================== improved variant
def polish(problem: CellProblem, positions: ArrayLike, *, max_passes: int = 10) -> NDArray[np.float64]:
    """Coordinate ascent on a feasible placement (not in the thesis): move one drone-cell
    at a time to the best point of its deployment region given the others (the
    constrained single-disc sweep), keeping the move only when the whole placement
    stays feasible and covers more users. Returns the improved positions (k, 2).

    problem: the CellProblem (users, GBSs, m, radii in metres).
    max_passes: maximum sweeps over all drone-cells (count).
    """
    if not isinstance(problem, CellProblem):
        raise TypeError(f"problem must be a CellProblem, got {type(problem).__name__}")
    problem.require_thesis_model("polish")
    max_passes = check_int("max_passes", max_passes, min_value=0)
    pos = check_array("positions", positions, shape=(None, 2))
    if not evaluate(problem, pos).feasible:
        raise ValueError("positions must be a feasible placement to polish")
    val = evaluate(problem, pos).covered
    users = problem.targets
    for _ in range(max_passes):
        improved = False
        for i in range(len(pos)):
            others = np.delete(pos, i, axis=0)
            covered = np.zeros(len(users), dtype=bool)
            if len(others):
                d = np.hypot(users[:, None, 0] - others[None, :, 0], users[:, None, 1] - others[None, :, 1])
                covered = np.any(d <= problem.R_d + TOL, axis=1)
            _, p = max_coverage_in_region(users[~covered], problem.R_d, _region(problem, others))
            if p is None:
                continue
            trial = pos.copy()
            trial[i] = p
            ev = evaluate(problem, trial)
            if ev.feasible and ev.covered > val:
                pos, val, improved = trial, ev.covered, True
        if not improved:
            break
    return pos


def genetic_polished(problem: CellProblem, **kwargs: Any) -> SolveResult:
    """The thesis GA (:func:`genetic`, same arguments) followed by :func:`polish` of its
    best plan. An improved variant beside the faithful baseline, not the thesis method.

    problem: the CellProblem (users, GBSs, m, radii in metres).
    kwargs: passed on to genetic (pop_size, iter_max, restarts, seed, settings).
    """
    t0 = time.perf_counter()
    ga = genetic(problem, **kwargs)
    x = polish(problem, ga.x)
    obj = evaluate(problem, x).covered
    return SolveResult(
        Status.FEASIBLE,
        objective=float(obj),
        x=x,
        backend="ga+polish",
        message=ga.message + "; then coordinate ascent with the constrained sweep",
        solve_time=time.perf_counter() - t0,
        iterations=ga.iterations,
        info={**ga.info, "ga_objective": ga.objective},
    )
