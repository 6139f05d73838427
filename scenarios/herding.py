"""The herding world of thesis ch. 6: animals (Strömbom flocking), barking drones, simulator.

Animal model (thesis (6.1), weights of Table 6.2; the model of Strömbom et al.,
"Solving the shepherding problem", J. R. Soc. Interface 11, 2014, which the
thesis cites as [199]). Every step of ``dt`` seconds:

* an animal inside the barking cone of at least one drone (within ``R_b`` of the
  drone and within ``beta/2`` of the drone's axis, which points at the herd
  centroid ``C_o``) moves ``V_animal * dt`` along the unit vector of
  ``eta_d R_d + eta_L C + eta_r R_a + eta_i H + eta_e eps`` with ``R_d`` the unit
  sum of the unit vectors from the barking drones to it, ``C`` the unit vector to
  the centre of mass of its ``n_neighbours`` nearest neighbours, ``R_a`` the unit
  sum of the unit vectors away from neighbours closer than ``r_a``, ``H`` its
  previous heading and ``eps`` a random unit vector;
* any other animal grazes: with probability ``graze_prob`` per step it moves
  ``graze_speed * dt`` along the unit vector of ``eta_r R_a + eta_e eps``
  (Strömbom's grazing; repulsion keeps animals apart); otherwise it stays.

So no animal ever moves faster than ``V_animal`` (``graze_speed <= V_animal``).

Drone model (6.3)-(6.6): ``d' = v a``, ``a' = u`` with ``|a| = 1``, ``(a, u) = 0``,
``|u| <= U_max``; we write ``u = omega a_perp`` and integrate the heading angle by
rotation so ``|a| = 1`` exactly. ``U_max`` is the heading rate, rad/s: Table 6.2
gives it in m/s^2, but in the model (6.3)-(6.6) |a| = 1 and a' = u, so |u| <= U_max
bounds the rate of turn, and we implement the model literally. The thesis's guidance laws
(6.13)/(6.16) command ``v = -V_max`` when the target is behind the drone, contradicting
``v in [0, V_max]`` of (6.5); the laws are implemented literally, so the simulator
accepts ``|v| <= V_max``.

A herder (planner) follows the closed-loop contract shared by every problem
(:mod:`droneplan.scenarios.loop`):

* ``reset(scenario, *, seed=None)`` — called once before the run;
* ``command(obs: HerdingObservation) -> HerdingCommand`` — every drone sub-step
  (``params.drone_substeps`` per animal step of ``delta`` = the thesis's re-allocation
  period Delta = 0.2 s); ``obs.replan`` is True on the first sub-step of each animal step,
  when the animals have just been observed; the command holds speeds (m/s) and heading
  rates (rad/s) per drone (clipped to the limits);
* ``phase`` — a :class:`HerdingPhase`; optional ``fallbacks``, ``statuses``, ``solve_times``.

This module imports no other layer of droneplan (only the shared closed-loop contract).
"""

from __future__ import annotations

import enum
import math
import time
from dataclasses import dataclass, field, replace
from typing import Any, NamedTuple

import numpy as np
from scipy.spatial import cKDTree

from droneplan.core.validation import (
    as_generator,
    check_array,
    check_bool,
    check_in_range,
    check_int,
    check_methods,
    check_nonneg,
    check_positive,
    check_size,
    resolve_seed,
)
from droneplan.scenarios.loop import Frame, LoopTrace, controller_counters

__all__ = [
    "HerdingParams",
    "THESIS_TABLE_6_2",
    "table_6_2_for",
    "HerdingScenario",
    "thesis_scenario",
    "barking_mask",
    "animal_step",
    "drone_step",
    "HerdingPhase",
    "HerdingObservation",
    "HerdingCommand",
    "HerdingFrame",
    "HerdingTrace",
    "footprint_radius",
    "herd_measures",
    "next_phase",
    "simulate",
    "with_params",
]

# --------------------------------------------------------------------------- parameters


@dataclass(frozen=True)
class HerdingParams:
    """Table 6.2 and the settings the thesis leaves open (units: m, s, rad)."""

    eta_d: float = 1.0
    """Weight of the repulsion from barking drones (dimensionless; Strömbom rho_s)."""
    eta_L: float = 1.05
    """Weight of the attraction to the local centre of mass (dimensionless; Strömbom c)."""
    eta_r: float = 2.0
    """Weight of the repulsion from close animals (dimensionless; Strömbom rho_a)."""
    eta_i: float = 0.5
    """Weight of the inertia, the previous heading (dimensionless; Strömbom h)."""
    eta_e: float = 0.3
    """Weight of the noise (dimensionless; Strömbom e)."""
    delta: float = 0.2
    """Re-allocation period Delta, s; also the animal time step."""
    V_max: float = 25.0
    """Maximum drone speed, m/s."""
    U_max: float = 5.0
    """Maximum heading rate |u| of (6.5), rad/s (Table 6.2 says m/s^2; with |a| = 1 and
    a' = u of (6.4), |u| is the rate of turn)."""
    V_animal: float = 4.0
    """Maximum animal speed (animals in a barking cone move at this speed), m/s."""
    beta: float = 2 * math.pi / 3
    """Barking-cone angle, rad."""
    R_b: float = 100.0
    """Barking-cone radius, m."""
    d_s: float = 30.0
    """Drone-to-animal distance: offset of the extended hull, m."""
    R_c: float = 60.0
    """Gathering ends when every animal is within R_c of the centroid, m (60 for 200, 110 for 1000
    animals)."""
    V_driving: float = 3.8
    """Speed of the driving formation towards G, m/s (3.8 for 200, 1.9 for 1000 animals)."""
    n_drones: int = 4
    """Number of barking drones n_d."""
    r_a: float = 2.0
    """Animal-animal repulsion distance, m (Strömbom r_a)."""
    n_neighbours: int = 20
    """Number of nearest neighbours whose centre of mass attracts an animal (Strömbom n; not in
    the thesis)."""
    graze_prob: float = 0.05
    """Probability per step that an animal outside every barking cone moves (Strömbom)."""
    graze_speed: float = 1.0
    """Speed of a grazing move, m/s (<= V_animal; not in the thesis)."""
    drone_substeps: int = 1
    """Number of drone control/integration sub-steps per animal step (drone step = delta / drone_substeps;
    1: the controller is sampled at the thesis's Delta)."""
    goal_radius: float = 50.0
    """Radius of the goal region (the yard), a disc around G, m (not in the thesis). The run is
    complete when every animal is inside it (the thesis does not state its criterion; the
    centroid reaching G would count a herd that split on the way as delivered)."""
    regroup_factor: float = 1.5
    """While driving, a herd whose footprint radius exceeds regroup_factor * R_c is gathered
    again before driving on (our rule, so the herd arrives whole; not in the thesis); dimensionless, >= 1."""

    def __post_init__(self) -> None:
        for name in ("eta_d", "eta_L", "eta_r", "eta_i", "eta_e"):
            check_nonneg(name, getattr(self, name))
        for name in (
            "delta",
            "V_max",
            "U_max",
            "V_animal",
            "R_b",
            "d_s",
            "R_c",
            "V_driving",
            "r_a",
            "graze_speed",
            "goal_radius",
        ):
            check_positive(name, getattr(self, name))
        check_in_range("beta", self.beta, 0.0, 2 * math.pi, lo_open=True)
        check_in_range("graze_prob", self.graze_prob, 0.0, 1.0)
        if self.graze_speed > self.V_animal:
            raise ValueError(f"graze_speed must be <= V_animal, got {self.graze_speed} > {self.V_animal}")
        if self.V_driving > self.V_animal:
            raise ValueError(
                f"V_driving must be <= V_animal (thesis §6.4.4), got {self.V_driving} > {self.V_animal}"
            )
        for name in ("n_drones", "n_neighbours", "drone_substeps"):
            check_int(name, getattr(self, name), min_value=1)
        check_in_range("regroup_factor", self.regroup_factor, 1.0)


THESIS_TABLE_6_2 = HerdingParams()
"""Table 6.2 with n_s = 200 (R_c = 60 m, V_driving = 3.8 m/s)."""


def table_6_2_for(n_animals: int) -> tuple[float, float]:
    """(R_c, V_driving) for a herd size: Table 6.2's values at 200 and 1000 animals,
    linear in n between them and clamped outside (our rule for other sizes)."""
    w = min(max((n_animals - 200) / 800.0, 0.0), 1.0)
    return 60.0 + w * (110.0 - 60.0), 3.8 + w * (1.9 - 3.8)


@dataclass(frozen=True)
class HerdingScenario:
    """An initial state and its parameters."""

    params: HerdingParams
    """Model and drone parameters."""
    animals: np.ndarray
    """(n_s, 2) initial animal positions, m."""
    drones: np.ndarray
    """(n_d, 2) initial drone positions, m."""
    headings: np.ndarray
    """(n_d,) initial drone heading angles, rad."""
    goal: np.ndarray
    """(2,) designated location G, m."""
    field: tuple[float, float, float, float] = (0.0, 0.0, 1200.0, 600.0)
    """Initial field (xmin, ymin, xmax, ymax), m."""

    def __post_init__(self) -> None:
        if not isinstance(self.params, HerdingParams):
            raise TypeError(f"params must be HerdingParams, got {type(self.params).__name__}")
        a = check_array("animals", self.animals, shape=(None, 2), min_rows=1)
        d = check_array("drones", self.drones, shape=(None, 2), min_rows=1)
        h = check_array("headings", self.headings, ndim=1)
        if h.shape[0] != d.shape[0]:
            raise ValueError(f"mismatched lengths: {h.shape[0]} headings for {d.shape[0]} drones")
        if d.shape[0] != self.params.n_drones:
            raise ValueError(
                f"mismatched lengths: {d.shape[0]} drones but params.n_drones = {self.params.n_drones}"
            )
        g = check_array("goal", self.goal, shape=(2,))
        f = check_array("field", self.field, shape=(4,))
        if not (f[0] < f[2] and f[1] < f[3]):
            raise ValueError(
                f"field must be (xmin, ymin, xmax, ymax) with xmin < xmax and ymin < ymax, got {f.tolist()}"
            )
        object.__setattr__(self, "field", tuple(float(v) for v in f))
        object.__setattr__(self, "animals", a)
        object.__setattr__(self, "drones", d)
        object.__setattr__(self, "headings", h)
        object.__setattr__(self, "goal", g)

    @property
    def n_animals(self) -> int:
        return int(self.animals.shape[0])


def thesis_scenario(
    n_animals: int = 200,
    seed=0,
    *,
    field_size: tuple[float, float] = (1200.0, 600.0),
    goal: tuple[float, float] | None = None,
    n_drones: int = 4,
    **overrides,
) -> HerdingScenario:
    """The §6.5 set-up: animals uniform in a field, drones lined up 80 m to its right, 50 m apart.

    n_animals: herd size n_s (>= 1).
    seed: int or numpy Generator.
    field_size: (width, height) of the initial field, m (thesis: 1200 x 600; Fig. 6.8a uses squares).
    goal: designated location G, m. Default: 900 m to the left of the field centre
        (the thesis gives no coordinates; 900 m matches its driving times, 3.9 min at
        3.8 m/s and 8.1 min at 1.9 m/s).
    n_drones: number of barking drones (thesis: 4).
    overrides: any HerdingParams field (R_c and V_driving default to Table 6.2 for the herd size).
    """
    n_animals = check_int("n_animals", n_animals, min_value=1)
    n_drones = check_int("n_drones", n_drones, min_value=1)
    check_size("n_animals", 2 * n_animals)
    check_size("n_drones", 2 * n_drones)
    fs = check_array("field_size", field_size, shape=(2,))
    w = check_positive("field_size[0] (field width)", fs[0])
    h = check_positive("field_size[1] (field height)", fs[1])
    goal_xy = None if goal is None else check_array("goal", goal, shape=(2,))
    rng = as_generator(seed)
    R_c, V_drv = table_6_2_for(int(n_animals))
    kw: dict[str, Any] = {"R_c": R_c, "V_driving": V_drv, "n_drones": n_drones}
    kw.update(overrides)
    params = HerdingParams(**kw)
    animals = rng.uniform((0.0, 0.0), (w, h), size=(int(n_animals), 2))
    ys = h / 2 + 50.0 * (np.arange(n_drones) - (n_drones - 1) / 2)
    drones = np.column_stack([np.full(n_drones, w + 80.0), ys])
    headings = np.full(n_drones, math.pi)  # facing the field
    g = np.array(goal_xy if goal_xy is not None else (w / 2 - 900.0, h / 2), dtype=float)
    return HerdingScenario(params, animals, drones, headings, g, (0.0, 0.0, w, h))


# --------------------------------------------------------------------------- dynamics
def _centroid(points: np.ndarray) -> np.ndarray:
    """``points.mean(axis=0)`` of (n, 2) points to the last bit, about twice as fast.

    numpy sums the rows of an (n, 2) array one after another (a sequential sum per column,
    one short inner loop per row); the running sum gives the same additions in the same order.
    """
    return np.add.accumulate(points, axis=0)[-1] / points.shape[0]


def _sq_dist(points: np.ndarray, centre: np.ndarray) -> np.ndarray:
    """Squared distances (n,) of (n, 2) points to ``centre`` (2,) or to (n, 2) points, m^2.

    The same value as ``np.sum((points - centre) ** 2, axis=1)`` (dx*dx + dy*dy), without the
    slow reduction over the short last axis.
    """
    d = points - centre
    dx, dy = d[:, 0], d[:, 1]
    return dx * dx + dy * dy


def _unit(v: np.ndarray) -> np.ndarray:
    """Rows of ``v`` (..., 2) scaled to unit length (zero rows stay zero).

    The norm is ``sqrt(x*x + y*y)``: the same value as numpy's sum over the short last axis,
    without its slow reduction.
    """
    x, y = v[..., 0], v[..., 1]
    n = np.sqrt(x * x + y * y)
    return v / np.maximum(n, 1e-12)[..., None]


def barking_mask(
    animals: np.ndarray,
    drones: np.ndarray,
    centroid: np.ndarray,
    R_b: float,
    beta: float,
    barking: np.ndarray | None = None,
) -> np.ndarray:
    """(n_s, n_d) bool: animal i lies in the barking cone of drone j (axis towards ``centroid``)."""
    rx = animals[:, 0, None] - drones[None, :, 0]  # (n, d)
    ry = animals[:, 1, None] - drones[None, :, 1]
    dist2 = rx * rx + ry * ry
    axis = _unit(centroid[None, :] - drones)  # (d, 2)
    proj = rx * axis[:, 0] + ry * axis[:, 1]
    cos_half = math.cos(beta / 2)
    inside = (dist2 <= R_b * R_b) & (proj >= cos_half * np.sqrt(dist2))
    if barking is not None:
        inside &= np.asarray(barking, dtype=bool)[None, :]
    return inside


_GRAZE_NEIGHBOURS = 4
"""Neighbours a grazing animal's first, bounded search looks for (module docstring of animal_step)."""

_SPLIT_MIN = 1000
"""Herds of at least this many animals get the per-animal split of the work in animal_step;
smaller herds take one neighbour search for all (fewer numpy calls)."""

_BALL_MIN = 3000
"""Herds of at least this many animals test the barking cones only for the animals within R_b of
a drone (found in the neighbour tree); smaller ones test every animal (fewer calls, and no
faster filter when the drones reach most of a herd, as while driving)."""


def animal_step(
    animals: np.ndarray,
    heading: np.ndarray,
    drones: np.ndarray,
    params: HerdingParams,
    seed=None,
    dt: float | None = None,
    barking: np.ndarray | None = None,
    centroid: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One animal step (module docstring); vectorised over animals, cKDTree for neighbours.

    animals: (n, 2) positions, m; heading: (n, 2) previous unit headings (zero rows allowed);
    drones: (n_d, 2) drone positions, m; seed: int or Generator for the noise and grazing draws;
    dt: step, s (default params.delta);
    barking: (n_d,) bool mask of drones that bark (default all);
    centroid: the herd centroid if already known (default: computed).
    Returns (new positions, new headings, affected mask (n,)).

    In a herd of 1000 or more, only the animals that need it get each part of the work
    (smaller herds take one pass over every moving animal): the attraction to
    the neighbours' centre of mass is computed for the barked-at animals only (a grazing
    animal does not use it); a grazing animal's repulsion first searches its neighbours
    closer than r_a with a small bounded query and falls back to the full n_neighbours
    search when that query comes back full. From 3000 animals, the barking cones are tested
    only for the animals within R_b of a drone (found in the neighbour tree). The neighbour
    queries run in the tree's leaf order. The step is the same as evaluating the model
    for every moving animal, to the last bit.
    """
    new_pos, new_head, affected, _ = _animal_step(
        animals, heading, drones, params, seed, dt, barking, centroid
    )
    return new_pos, new_head, affected


def _animal_step(  # noqa: PLR0915
    animals: np.ndarray,
    heading: np.ndarray,
    drones: np.ndarray,
    params: HerdingParams,
    seed,
    dt: float | None,
    barking: np.ndarray | None,
    centroid: np.ndarray | None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """:func:`animal_step`, also returning the indices of the animals that moved."""
    dt = params.delta if dt is None else dt
    rng = as_generator(seed)
    n = animals.shape[0]
    centroid = _centroid(animals) if centroid is None else centroid
    tree = cKDTree(animals, balanced_tree=False, compact_nodes=False) if n > 1 else None
    split = n >= _SPLIT_MIN
    affected = np.zeros(n, dtype=bool)
    if n < _BALL_MIN or tree is None:
        cone = barking_mask(animals, drones, centroid, params.R_b, params.beta, barking)
        affected[:] = cone.any(axis=1)
    else:
        # the cones reach R_b: test only the animals of the drones' R_b balls (a superset)
        balls = tree.query_ball_point(drones, params.R_b * (1 + 1e-9) + 1e-9)
        in_ball = np.zeros(n, dtype=bool)
        for b in balls:
            in_ball[b] = True
        near = np.flatnonzero(in_ball)  # ascending, as np.unique of the concatenated balls
        cone = np.zeros((n, drones.shape[0]), dtype=bool)
        if near.size:
            cone_near = barking_mask(animals[near], drones, centroid, params.R_b, params.beta, barking)
            cone[near] = cone_near
            affected[near] = cone_near.any(axis=1)
    grazing = (~affected) & (rng.random(n) < params.graze_prob)
    movers = np.flatnonzero(affected | grazing)
    new_pos = animals.copy()
    new_head = heading.copy()
    if movers.size == 0:
        return new_pos, new_head, affected, movers
    pos = animals[movers]
    m = movers.size
    eps = _unit(rng.normal(size=(m, 2)))
    aff = affected[movers]
    R_a = np.zeros((m, 2))
    C = np.zeros((m, 2))
    if tree is not None:
        K = min(params.n_neighbours, n - 1)
        rank = _tree_rank(tree, n)
        ax, ay = animals[:, 0].copy(), animals[:, 1].copy()
        full = aff.copy() if split else np.ones(m, dtype=bool)  # rows that need the full search
        gz = np.flatnonzero(~aff) if split else np.zeros(0, dtype=np.intp)
        if gz.size:
            # a grazing animal only feels the neighbours closer than r_a (among its K nearest):
            # look for a few within r_a; a full answer means there may be more
            kk = min(_GRAZE_NEIGHBOURS, K)
            gz = gz[np.argsort(rank[movers[gz]])]  # in the tree's order (_tree_rank)
            dist, idx = tree.query(pos[gz], k=kk + 1, distance_upper_bound=params.r_a * (1 + 1e-9))
            crowded = np.isfinite(dist[:, -1])
            full[gz[crowded]] = True
            rows = gz[~crowded]
            if rows.size:
                # missing neighbours (index n, distance inf) weigh 0: any row stands in for them
                nbi = np.minimum(idx[~crowded, 1:].T, n - 1)
                R_a[rows] = _repulsion_xy(ax[nbi], ay[nbi], pos[rows], dist[~crowded, 1:], params.r_a)
        rows = np.flatnonzero(full)
        if rows.size:
            rows = rows[np.argsort(rank[movers[rows]])]  # in the tree's order (_tree_rank)
            dist, idx = tree.query(pos[rows], k=K + 1)
            # drop self (distance 0 ranks first); neighbour-major (K, m), C order
            nbi = np.ascontiguousarray(idx[:, 1:].T)
            nbx, nby = ax[nbi], ay[nbi]
            pr = pos[rows]
            R_a[rows] = _repulsion_xy(nbx, nby, pr, dist[:, 1:], params.r_a)
            C[rows] = _unit_xy(_sum_rows(nbx) / K - pr[:, 0], _sum_rows(nby) / K - pr[:, 1])
    if not split:  # every row at once (fewer numpy calls for a small herd)
        rel = pos[:, None, :] - drones[None, :, :]
        rx, ry = rel[:, :, 0], rel[:, :, 1]
        wd = cone[movers] / np.maximum(np.sqrt(rx * rx + ry * ry), 1e-12)
        R_d = _unit(np.einsum("md,mdc->mc", wd, rel))
        herd = params.eta_d * R_d + params.eta_L * C + params.eta_r * R_a + params.eta_i * heading[movers]
        herd += params.eta_e * eps
        graze = params.eta_r * R_a + params.eta_e * eps
        direction = _unit(np.where(aff[:, None], herd, graze))
    else:
        direction = _split_directions(params, drones, cone, heading, movers, pos, aff, eps, R_a, C)
    speed = np.where(aff, params.V_animal, params.graze_speed)
    new_pos[movers] = pos + (speed * dt)[:, None] * direction
    new_head[movers] = direction
    return new_pos, new_head, affected, movers


def _split_directions(params, drones, cone, heading, movers, pos, aff, eps, R_a, C) -> np.ndarray:
    """The unit step directions (m, 2) of the moving animals, the barked-at and the grazing
    ones computed apart (the drones' repulsion for the barked-at ones only)."""
    m = movers.size
    direction = np.empty((m, 2))
    a_rows = np.flatnonzero(aff)
    if a_rows.size:
        # repulsion from the barking drones whose cone holds the animal
        pa = pos[a_rows]
        rel = pa[:, None, :] - drones[None, :, :]
        rx, ry = rel[:, :, 0], rel[:, :, 1]
        wd = cone[movers[a_rows]] / np.maximum(np.sqrt(rx * rx + ry * ry), 1e-12)
        R_d = _unit(np.einsum("md,mdc->mc", wd, rel))
        herd = (
            params.eta_d * R_d
            + params.eta_L * C[a_rows]
            + params.eta_r * R_a[a_rows]
            + params.eta_i * heading[movers[a_rows]]
            + params.eta_e * eps[a_rows]
        )
        direction[a_rows] = _unit(herd)
    g_rows = np.flatnonzero(~aff)
    if g_rows.size:
        direction[g_rows] = _unit(params.eta_r * R_a[g_rows] + params.eta_e * eps[g_rows])
    return direction


def _tree_rank(tree: cKDTree, n: int) -> np.ndarray:
    """(n,) the place of each point in the tree's leaf order (``tree.indices`` inverted).

    The animal step queries its rows sorted by this rank: each query's answer is its own (the
    same neighbours and distances in any order of the queries), and consecutive queries then
    walk the same nodes, which stay in the cache (a third less time for a large herd).
    """
    rank = np.empty(n, dtype=np.intp)
    rank[tree.indices] = np.arange(n)
    return rank


def _sum_rows(a: np.ndarray) -> np.ndarray:
    """Sum over the leading axis of (k, m) ``a``, one row after another (a sequential sum in row
    order, whatever the memory layout: numpy's sum over a leading axis of a C-ordered array adds
    the same way)."""
    out = a[0].copy()
    for row in a[1:]:
        out += row
    return out


def _unit_xy(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """:func:`_unit` of the rows (x, y), from their coordinates (m,) each: (m, 2)."""
    nrm = np.maximum(np.sqrt(x * x + y * y), 1e-12)
    out = np.empty((x.shape[0], 2))
    np.divide(x, nrm, out=out[:, 0])
    np.divide(y, nrm, out=out[:, 1])
    return out


def _repulsion_xy(
    nbx: np.ndarray, nby: np.ndarray, pos: np.ndarray, dist: np.ndarray, r_a: float
) -> np.ndarray:
    """:func:`_repulsion` of the neighbours' coordinates nbx, nby (k, m) each, m: the same values
    to the last bit (the same products, summed in the same neighbour order)."""
    k = int(np.searchsorted(dist.min(axis=0), r_a)) if dist.size else 0
    if k == 0:
        return np.zeros((pos.shape[0], 2))
    w = np.where(dist[:, :k] < r_a, 1.0 / np.maximum(dist[:, :k], 1e-12), 0.0).T
    return _unit_xy(_sum_rows(w * (pos[:, 0] - nbx[:k])), _sum_rows(w * (pos[:, 1] - nby[:k])))


def _repulsion(nb: np.ndarray, pos: np.ndarray, dist: np.ndarray, r_a: float) -> np.ndarray:
    """R_a: the unit sum of the unit vectors away from the neighbours closer than r_a.

    nb: (k, m, 2) neighbour positions, neighbour-major, m; dist: (m, k) their distances in
    increasing order, m (inf: missing). The sum is sequential, in neighbour order (as numpy's
    sum over the leading axis of nb); far or missing neighbours add zeros, which change nothing.
    """
    return _repulsion_xy(nb[..., 0], nb[..., 1], pos, dist, r_a)


def drone_step(
    drones: np.ndarray,
    headings: np.ndarray,
    v: np.ndarray,
    omega: np.ndarray,
    params: HerdingParams,
    dt: float,
) -> tuple[np.ndarray, np.ndarray]:
    """Integrate (6.3)-(6.6) over ``dt`` with |v| <= V_max, |omega| <= U_max (clipped)."""
    # np.clip's values (NaN kept), from the two ufuncs: a few µs less per call on a few drones
    v = np.minimum(np.maximum(np.asarray(v, dtype=float), -params.V_max), params.V_max)
    omega = np.minimum(np.maximum(np.asarray(omega, dtype=float), -params.U_max), params.U_max)
    drones = np.asarray(drones, dtype=float)
    headings = np.asarray(headings, dtype=float)
    step = v * dt
    out = np.empty_like(drones)
    out[:, 0] = drones[:, 0] + step * np.cos(headings)
    out[:, 1] = drones[:, 1] + step * np.sin(headings)
    return out, headings + omega * dt


# --------------------------------------------------------------------------- simulation
class HerdingPhase(enum.StrEnum):
    """Phases of a herding run (thesis §6.4), in order."""

    GATHERING = "gathering"
    """Bringing the herd together until every animal is within R_c of the centroid."""
    DRIVING = "driving"
    """Driving the gathered herd towards G (back to GATHERING if the herd spreads beyond
    ``regroup_factor * R_c``)."""
    DONE = "done"
    """Every animal is within the goal region (``goal_radius`` of G)."""


@dataclass(frozen=True)
class HerdingObservation:
    """What a herder knows at one drone sub-step (the argument of ``command``)."""

    t: float
    """Time of this sub-step (s)."""
    animals: np.ndarray
    """(n_s, 2) animal positions at the start of the current animal step (m)."""
    centroid: np.ndarray
    """(2,) herd centroid C_o (m)."""
    phase: HerdingPhase
    """Phase decided by the simulator (gathering or driving)."""
    drones: np.ndarray
    """(n_d, 2) drone positions now (m)."""
    headings: np.ndarray
    """(n_d,) drone heading angles now (rad)."""
    dt: float
    """Length of this drone sub-step (s)."""
    replan: bool
    """True on the first sub-step of an animal step (the animals were just observed; plan now)."""


class HerdingCommand(NamedTuple):
    """Drone commands for one sub-step (6.3)-(6.6); the simulator clips them to the limits."""

    v: np.ndarray
    """(n_d,) speeds (m/s), |v| <= V_max."""
    omega: np.ndarray
    """(n_d,) heading rates (rad/s), |omega| <= U_max."""


@dataclass(frozen=True, kw_only=True)
class HerdingFrame(Frame):
    """The state of a herding run at one instant."""

    animals: np.ndarray
    """(n_s, 2) animal positions (m)."""
    drones: np.ndarray
    """(n_d, 2) drone positions (m)."""
    headings: np.ndarray
    """(n_d,) drone heading angles (rad)."""
    phase: HerdingPhase
    """Phase of the run."""


@dataclass(kw_only=True)
class HerdingTrace(LoopTrace):
    """What :func:`simulate` records (times in s, distances in m); ``final`` holds the last state."""

    final: HerdingFrame
    """The state at the end of the run (always stored)."""
    footprint_radius: np.ndarray
    """(T,) max animal-to-centroid distance, m."""
    centroid: np.ndarray
    """(T, 2) herd centroid, m."""
    drones: np.ndarray
    """(T, n_d, 2) drone positions, m."""
    phase: np.ndarray
    """(T,) :class:`HerdingPhase` at each recorded time (object array)."""
    goal: np.ndarray
    """(2,) designated location G, m."""
    gather_time: float | None
    """First time every animal was within R_c of the centroid, s (None: not reached)."""
    total_time: float | None
    """First time every animal was within the goal region (goal_radius of G), s (None: not
    reached). Gathering + driving, including any regrouping."""
    delivered: np.ndarray = field(default_factory=lambda: np.zeros(0))
    """(T,) fraction of the animals within the goal region at each recorded time. The thesis
    leaves its end criterion unstated; here a run finishes only at delivered = 1."""
    regroupings: int = 0
    """Times the herd spread beyond regroup_factor * R_c while driving and was gathered again."""
    max_animal_speed: float
    """Largest displacement / dt of any animal over the run, m/s."""
    snapshots: dict[float, HerdingFrame] = field(default_factory=dict)
    """{requested time (s): state at the first step >= that time} (Fig. 6.7 b-f)."""
    frames: list[HerdingFrame] = field(default_factory=list)
    """States every ``frame_every`` seconds, for animations."""
    wall_time: float = 0.0
    """Wall-clock time of the run, s."""
    solve_times: np.ndarray = field(default_factory=lambda: np.zeros(0))
    """Per-solve times reported by the herder (s)."""


def footprint_radius(animals: np.ndarray) -> float:
    """Max distance of an animal to the herd centroid, m.

    animals: (n, 2) animal positions (m).
    """
    animals = check_array("animals", animals, shape=(None, 2), min_rows=1)
    c = animals.mean(axis=0)
    return float(np.sqrt(np.max(np.sum((animals - c) ** 2, axis=1))))


def _delivered(
    animals: np.ndarray, centroid: np.ndarray, radius: float, goal: np.ndarray, goal_radius: float
):
    """Fraction of the animals within ``goal_radius`` of ``goal`` (m): ``np.mean`` of the test.

    A herd whose footprint disc (``radius`` around ``centroid``, m) stays clear of the goal region
    holds no animal inside it (the triangle inequality, with a margin for rounding): 0.0 without
    testing every animal (most steps of a run, before the herd reaches the goal).
    """
    gap = float(np.sqrt(_sq_dist(centroid[None, :], goal)[0]))
    if gap - radius > goal_radius + 1e-9 * (gap + radius + goal_radius) + 1e-9:
        return 0.0
    return float(np.mean(_sq_dist(animals, goal) <= goal_radius**2))


def herd_measures(
    animals: np.ndarray, goal: np.ndarray, goal_radius: float
) -> tuple[np.ndarray, float, float]:
    """(centroid (2,) m, footprint radius m, fraction of the animals within ``goal_radius`` m of
    ``goal``) of (n, 2) animal positions (m): what :func:`simulate` measures at every animal step."""
    c = _centroid(animals)
    r = float(np.sqrt(np.max(_sq_dist(animals, c))))
    return c, r, _delivered(animals, c, r, goal, goal_radius)


def next_phase(
    phase: HerdingPhase, radius: float, share: float, params: HerdingParams, stop_after_gathering: bool
) -> tuple[HerdingPhase, bool, bool, bool]:
    """The run's phase after an animal step (the rules of :func:`simulate`).

    phase: the phase before; radius: footprint radius (m); share: fraction of the animals in the
    goal region; params: the run's HerdingParams; stop_after_gathering: the run ends when gathering
    finishes. Returns (phase, the herd was sent back to gathering, gathering finished now, the run
    stops after gathering).
    """
    regrouped = gathered = stop = False
    if phase == HerdingPhase.DRIVING and radius > params.regroup_factor * params.R_c:
        phase = HerdingPhase.GATHERING  # the herd split or spread: regroup it first
        regrouped = True
    if phase == HerdingPhase.GATHERING and radius <= params.R_c:
        gathered = True
        phase = HerdingPhase.DRIVING
        stop = stop_after_gathering
    if not stop and phase == HerdingPhase.DRIVING and share == 1.0:
        phase = HerdingPhase.DONE
    return phase, regrouped, gathered, stop


def simulate(  # noqa: C901, PLR0915
    scenario: HerdingScenario,
    controller,
    *,
    t_max: float = 1800.0,
    seed=None,
    snapshot_times=(),
    frame_every: float | None = None,
    stop_after_gathering: bool = False,
) -> HerdingTrace:
    """Run gathering then driving with ``controller`` (a herder) until the herd is delivered or ``t_max``.

    Delivered means every animal within ``params.goal_radius`` of G (``trace.delivered`` holds
    the fraction inside at each recorded time). While driving, a herd whose footprint radius
    exceeds ``params.regroup_factor * R_c`` goes back to gathering (``trace.regroupings``), so it
    arrives whole. The thesis states neither rule; both are our choice, so that a run ends
    with a measurable delivery and a herd that splits while driving is gathered again.

    scenario: initial state and parameters; controller: a herder (module docstring: ``reset``, ``command``).
    t_max: simulated time limit, s (> 0). seed: int or Generator for the animals' noise (recorded).
    snapshot_times: times (s) at which to keep full snapshots (Fig. 6.7 b-f).
    frame_every: keep an animation frame every this many seconds (None: none).
    stop_after_gathering: end the run when gathering finishes (the sweeps of Figs 6.8-6.10).
    """
    if not isinstance(scenario, HerdingScenario):
        raise TypeError(f"scenario must be a HerdingScenario, got {type(scenario).__name__}")
    check_methods("controller", controller, ("reset", "command"))
    stop_after_gathering = check_bool("stop_after_gathering", stop_after_gathering)
    t_max = check_positive("t_max", t_max)
    check_size("t_max", math.ceil(t_max / scenario.params.delta) * scenario.animals.shape[0])
    if frame_every is not None:
        check_positive("frame_every", frame_every)
    p = scenario.params
    rng, drawn = resolve_seed(seed)
    seed = seed if drawn is None else drawn  # record the seed drawn for seed=None
    dt = p.delta
    sub = p.drone_substeps
    dts = dt / sub
    animals = scenario.animals.copy()
    heading = np.zeros_like(animals)
    drones = scenario.drones.copy()
    headings = scenario.headings.copy()
    controller.reset(scenario, seed=seed)
    n_steps = math.ceil(t_max / dt)
    ts, radii, cents, dpos, phases, delivered = [], [], [], [], [], []
    regroupings = 0
    snaps_todo = sorted(float(s) for s in snapshot_times)
    snapshots: dict = {}
    frames: list = []
    next_frame = 0.0
    gather_time = total_time = None
    phase = HerdingPhase.GATHERING
    vmax_seen = 0.0
    t0 = time.perf_counter()
    for step in range(n_steps + 1):
        t = step * dt
        c, r, share = herd_measures(animals, scenario.goal, p.goal_radius)
        ts.append(t)
        radii.append(r)
        cents.append(c)
        dpos.append(drones.copy())
        delivered.append(share)
        phase, regrouped, gathered, stop = next_phase(phase, r, share, p, stop_after_gathering)
        regroupings += regrouped
        if gathered:
            gather_time = t if gather_time is None else gather_time
        if phase == HerdingPhase.DONE:
            total_time = t
        phases.append(phase)
        while snaps_todo and t >= snaps_todo[0] - 1e-9:
            snapshots[snaps_todo.pop(0)] = HerdingFrame(
                t=t, animals=animals.copy(), drones=drones.copy(), headings=headings.copy(), phase=phase
            )
        if frame_every is not None and t >= next_frame - 1e-9:
            frames.append(
                HerdingFrame(
                    t=t, animals=animals.copy(), drones=drones.copy(), headings=headings.copy(), phase=phase
                )
            )
            next_frame += frame_every
        if stop or phase == HerdingPhase.DONE or step == n_steps:
            break
        for k in range(sub):
            cmd = controller.command(
                HerdingObservation(t + k * dts, animals, c, phase, drones, headings, dts, k == 0)
            )
            drones, headings = drone_step(drones, headings, cmd[0], cmd[1], p, dts)
        new, heading, _, moved = _animal_step(animals, heading, drones, p, rng, dt, None, c)
        if moved.size:  # the others stood still
            step_max = float(np.sqrt(np.max(_sq_dist(new[moved], animals[moved]))))
            vmax_seen = max(vmax_seen, step_max / dt)
        animals = new
    phase_arr = np.empty(len(phases), dtype=object)
    phase_arr[:] = phases
    final = HerdingFrame(
        t=ts[-1], animals=animals.copy(), drones=drones.copy(), headings=headings.copy(), phase=phase
    )
    return HerdingTrace(
        t=np.array(ts),
        final=final,
        seed=seed,
        **controller_counters(controller),
        footprint_radius=np.array(radii),
        centroid=np.array(cents),
        drones=np.array(dpos),
        phase=phase_arr,
        goal=scenario.goal.copy(),
        gather_time=gather_time,
        total_time=total_time,
        max_animal_speed=vmax_seen,
        snapshots=snapshots,
        frames=frames,
        wall_time=time.perf_counter() - t0,
        delivered=np.array(delivered),
        regroupings=regroupings,
    )


def with_params(scenario: HerdingScenario, **changes) -> HerdingScenario:
    """A copy of ``scenario`` with some HerdingParams fields changed (validated).

    changes: HerdingParams field names and their new values (units of those fields).
    """
    return replace(scenario, params=replace(scenario.params, **changes))
