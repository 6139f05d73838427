"""Herders (controllers) for ``scenarios.herding.simulate``: the proposed method and the benchmark.

Both follow the closed-loop contract (``reset(scenario, *, seed)``, ``command(HerdingObservation)
-> HerdingCommand``, ``phase``): on an observation with ``replan`` (every Delta) they plan
(hull, steering points, allocation or driving formation), and every sub-step they steer.

Both gather with the drones restricted to the extended hull and drive with the
same side-to-side strategy (§6.4.4):

* ``ProposedHerder`` (§6.4.1-6.4.3): Fly to edge until every drone is on the
  extended hull; then every Delta the n_d steering points (extended-hull vertices
  of the hull animals farthest from C_o) are allocated by the collision-free
  min-max allocation (6.21)-(6.23) and each drone flies to its point with Fly on edge.
* ``BenchmarkHerder`` (§6.5): the extended hull is split into n_d segments of equal
  length (starting where the ray from C_o at angle 0 meets it); each drone keeps
  one segment (assigned once, in cyclic order, by the same allocation with the
  segment midpoints) and flies side to side on it with Fly on edge.

Driving (both): the extended circle is the minimum enclosing circle of the herd
grown by d_s; the semicircle L farther from G carries n_d + 1 evenly spaced points
Q_j, and drone j flies side to side between Q_j and Q_{j+1} (straight between
them, with the Fly-to-edge law aimed at the point). The thesis sets L "moving
towards G with a constant speed V_driving"; we let L's centre follow the
enclosing circle's centre at no more than V_driving (so L never runs away from a
slow herd nor lags behind a pushed one), with the radius grown to keep the whole
herd inside.
"""

from __future__ import annotations

import abc
import math
from dataclasses import dataclass

import numpy as np

from droneplan.core.validation import check_array, check_instance, check_int, check_positive, require_set
from droneplan.formulations.herding import solve_allocation, solve_checked_exact
from droneplan.planners.herding.allocation import allocate_bruteforce, allocate_collision_blind, crosses
from droneplan.planners.herding.geometry import (
    ExtendedHull,
    HullTracker,
    _min_enclosing_circle,
)
from droneplan.planners.herding.guidance import fly_on_edge, fly_to_edge, steer
from droneplan.scenarios.herding import HerdingCommand, HerdingObservation, HerdingPhase

__all__ = ["ALLOCATORS", "HerderSettings", "steering_points", "ProposedHerder", "BenchmarkHerder"]

ALLOCATORS = ("exact", "cp-sat", "bruteforce", "collision-blind")


@dataclass(frozen=True)
class HerderSettings:
    """Tolerances of the herders (m)."""

    arrive_tol: float = 2.0
    """A drone counts as on the extended hull when its distance to it is below this, m."""
    turn_tol: float = 2.0
    """Side-to-side movements turn round within this distance of a segment end, m."""
    allocation: str = "exact"
    """Allocation method of the proposed herder: "exact", "cp-sat", "bruteforce" or "collision-blind"."""

    def __post_init__(self) -> None:
        for name in ("arrive_tol", "turn_tol"):
            check_positive(name, getattr(self, name))
        if self.allocation not in ALLOCATORS:
            raise ValueError(f"allocation must be one of {ALLOCATORS}, got {self.allocation!r}")


def steering_points(hull: ExtendedHull, centroid: np.ndarray, n_drones: int) -> np.ndarray:
    """Arc positions of the steering points (§6.4.3), m.

    The extended-hull vertices whose animals are farthest from ``centroid``; at most
    n_drones of them (fewer when the hull has fewer vertices: the allocation then
    pads them by ``formulations.herding.pad_steering_points``).
    """
    if not isinstance(hull, ExtendedHull):
        raise TypeError(f"hull must be an ExtendedHull, got {type(hull).__name__}")
    centroid = check_array("centroid", centroid, shape=(2,))
    n_drones = check_int("n_drones", n_drones, min_value=1)
    return _steering_points(hull, centroid, n_drones)


def _steering_points(hull: ExtendedHull, centroid: np.ndarray, n_drones: int) -> np.ndarray:
    """:func:`steering_points` of checked arguments (the herders' own hull, centroid and drone count)."""
    dist = np.linalg.norm(hull.animals - centroid, axis=1)
    k = min(n_drones, len(dist))
    idx = np.argsort(-dist, kind="stable")[:k]
    return hull.vertex_s[idx]


def _allocate(method: str, drone_s, steer_s, M):
    if method == "bruteforce":
        return allocate_bruteforce(drone_s, steer_s, M)
    if method == "collision-blind":
        return allocate_collision_blind(drone_s, steer_s, M)
    if method == "exact":  # the herder's arc positions lie in [0, M) by construction
        return solve_checked_exact(drone_s, steer_s, M)
    return solve_allocation(drone_s, steer_s, M, engine=method, workers=1)


class _Herder(abc.ABC):
    """Shared state: the hull each Delta, Fly-to-edge arrival, the driving formation."""

    name = "herder"

    def __init__(self, settings: HerderSettings | None = None):
        self.settings = (
            check_instance("settings", settings, HerderSettings, optional=True) or HerderSettings()
        )
        self.phase = HerdingPhase.GATHERING

    # -- the closed-loop contract
    def reset(self, scenario, *, seed=None) -> None:
        """Start a run on ``scenario`` (the herders are deterministic: ``seed`` is unused)."""
        self.p = scenario.params
        self.goal = np.asarray(scenario.goal, dtype=float)
        n = self.p.n_drones
        self.on_hull = np.zeros(n, dtype=bool)
        self.hull: ExtendedHull | None = None
        self.herd_hull = HullTracker()  # the herd's convex hull, step after step
        self.phase = HerdingPhase.GATHERING
        self.s_target = np.zeros(n)
        self.direction = np.ones(n, dtype=int)
        self.allocated = False
        self.n_allocations = 0
        self.n_crossing_allocations = 0
        self.all_on_hull_time = None
        self.drive_centre: np.ndarray | None = None
        self.drive_slot: np.ndarray | None = None
        self.drive_toggle = np.zeros(n, dtype=bool)
        self.fallbacks = 0  # allocations without a solution (the drones then hold position)
        self.statuses: list[str] = []  # status of every allocation solve

    def command(self, obs: HerdingObservation) -> HerdingCommand:
        """Speeds (m/s) and heading rates (rad/s) of the drones for this sub-step.

        Replans (hull, allocation or driving formation) when ``obs.replan``.
        """
        if obs.replan:  # the observation's arrays are checked here, once, for the planning below
            animals = check_array("animals", obs.animals, shape=(None, 2), min_rows=1)
            self._observe(animals, check_array("centroid", obs.centroid, shape=(2,)), obs.phase, obs.drones)
        return HerdingCommand(*self._control(obs.t, obs.drones, obs.headings, obs.dt))

    def _observe(self, animals, centroid, phase, drones) -> None:
        self.centroid = centroid
        if phase == HerdingPhase.GATHERING:
            if self.phase == HerdingPhase.DRIVING:  # the simulator sent the herd back to gathering
                self._regroup()
            self.hull = ExtendedHull._from_checked_hull(self.herd_hull._track(animals), self.p.d_s)
            if self.on_hull.all():
                self._plan_gathering(drones)
        else:
            if self.phase != HerdingPhase.DRIVING:
                self.phase = HerdingPhase.DRIVING
            self._plan_driving(animals, drones)

    def _regroup(self) -> None:
        """Back from driving to gathering: fly to the new hull and allocate again."""
        self.phase = HerdingPhase.GATHERING
        self.on_hull[:] = False
        self.allocated = False
        self.drive_centre = None
        self.drive_slot = None
        self.drive_toggle[:] = False

    def _control(self, t, drones, headings, dt):
        p = self.p
        if self.phase == HerdingPhase.DRIVING:
            b = self.Q_target - drones
            return steer(headings, b, p.V_max, p.U_max, dt)
        hull = require_set(self.hull, "the hull (_observe builds it on a step's first sub-step)")
        if self.allocated and self.on_hull.all():  # the common case: every drone flies on the hull
            v_n, w_n, _ = fly_on_edge(
                drones, headings, hull, self.s_target, self.direction, p.V_max, p.U_max, dt
            )
            return v_n, w_n
        v = np.zeros(len(drones))
        omega = np.zeros(len(drones))
        off = ~self.on_hull
        if off.any():
            v_o, w_o, b = fly_to_edge(drones[off], headings[off], hull, p.V_max, p.U_max, dt)
            v[off], omega[off] = v_o, w_o
            arrived = np.linalg.norm(b, axis=1) < self.settings.arrive_tol
            idx = np.flatnonzero(off)[arrived]
            self.on_hull[idx] = True
            if self.on_hull.all():
                self.all_on_hull_time = t
        on = ~off
        if on.any():
            if self.allocated:
                tgt, dirn = self.s_target[on], self.direction[on]
            else:  # waiting for the others to arrive: hold position on the hull
                s_now = hull.project(drones[on])[0]
                tgt, dirn = s_now, np.ones(on.sum(), dtype=int)
            v_n, w_n, _ = fly_on_edge(drones[on], headings[on], hull, tgt, dirn, p.V_max, p.U_max, dt)
            v[on], omega[on] = v_n, w_n
        return v, omega

    @abc.abstractmethod
    def _plan_gathering(self, drones) -> None:
        """Set each drone's gathering target (steering point and direction) for this period."""

    # -- driving (§6.4.4), shared
    def _plan_driving(self, animals, drones) -> None:
        p = self.p
        hv = self.herd_hull._track(animals)
        centre, _ = _min_enclosing_circle(hv)
        to_goal = self.goal - centre
        dist_goal = float(np.linalg.norm(to_goal))
        c = self.drive_centre
        if c is None:
            c = centre.copy()
        else:  # L follows the herd's extended circle at no more than V_driving
            gap = centre - c
            dn = float(np.linalg.norm(gap))
            step = p.V_driving * p.delta
            c = centre.copy() if dn <= step else c + gap / dn * step
        self.drive_centre = c
        # the circle around L's centre that encloses the herd, grown by d_s (equals the
        # extended circle while L's centre is the enclosing circle's centre)
        R = float(np.max(np.linalg.norm(hv - c, axis=1))) + p.d_s
        phi0 = math.atan2(c[1] - self.goal[1], c[0] - self.goal[0]) if dist_goal > 1e-9 else 0.0
        n = p.n_drones
        angles = phi0 - math.pi / 2 + math.pi * np.arange(n + 1) / n
        Q = c + R * np.column_stack([np.cos(angles), np.sin(angles)])
        slot = self.drive_slot
        if slot is None:
            # slots in angular order of the drones around the centre: nobody crosses
            rel = np.arctan2(drones[:, 1] - c[1], drones[:, 0] - c[0])
            order = np.argsort(np.mod(rel - (phi0 - math.pi), 2 * math.pi))
            slot = np.empty(n, dtype=int)
            slot[order] = np.arange(n)
            self.drive_slot = slot
        lo, hi = Q[slot], Q[slot + 1]
        # side to side: turn round near the current end
        cur = np.where(self.drive_toggle[:, None], lo, hi)
        reached = np.linalg.norm(drones - cur, axis=1) < max(self.settings.turn_tol, p.V_max * p.delta)
        self.drive_toggle ^= reached
        self.Q_target = np.where(self.drive_toggle[:, None], lo, hi)


class ProposedHerder(_Herder):
    """The thesis's method: steering points allocated every Delta by (6.21)-(6.23).

    settings.allocation chooses the allocator ("exact" by default; "cp-sat" and
    "bruteforce" give the same optimum; "collision-blind" is the crossing baseline).
    ``n_crossing_allocations`` counts allocations whose drones would pass each other.
    """

    name = "proposed"

    def _plan_gathering(self, drones) -> None:
        hull = require_set(self.hull, "the hull (_observe builds it before planning)")
        M = hull.perimeter
        s_d = hull.project(drones)[0]
        steer_s = _steering_points(hull, self.centroid, self.p.n_drones)
        s_d = np.where(s_d >= M, 0.0, s_d)
        res = _allocate(self.settings.allocation, s_d, steer_s, M)
        self.statuses.append(res.status.name)
        if not res.has_solution:  # cannot happen for distinct vertices; hold position
            self.fallbacks += 1
            self.s_target, self.direction = s_d, np.ones(len(s_d), dtype=int)
            return
        alloc = res.x
        self.s_target = alloc.destination
        self.direction = alloc.direction
        self.allocated = True
        self.n_allocations += 1
        if crosses(s_d, M, alloc):  # (6.22)-(6.23) violated: drones would pass each other
            self.n_crossing_allocations += 1
        self.last_allocation = res


class BenchmarkHerder(_Herder):
    """The thesis's benchmark (§6.5): equal-length hull segments, side to side on each."""

    name = "benchmark"

    def reset(self, scenario, *, seed=None) -> None:
        super().reset(scenario, seed=seed)
        self.segment = None
        self.heading_to_end = np.ones(self.p.n_drones, dtype=int)

    def _bounds(self):
        hull = require_set(self.hull, "the hull (_observe builds it before planning)")
        M = hull.perimeter
        n = self.p.n_drones
        s0 = hull.ray_s(self.centroid, 0.0)
        starts = np.mod(s0 + M * np.arange(n) / n, M)
        return starts, M / n, M

    def _plan_gathering(self, drones) -> None:
        starts, length, M = self._bounds()
        s_d = require_set(self.hull, "the hull (_observe builds it before planning)").project(drones)[0]
        s_d = np.where(s_d >= M, 0.0, s_d)
        if self.segment is None:
            mids = np.mod(starts + length / 2, M)
            res = solve_allocation(s_d, mids, M)
            self.segment = res.x.target.copy()
        a = starts[self.segment]
        b = np.mod(a + length, M)
        # position inside the segment, in [0, M)
        off = np.mod(s_d - a, M)
        inside = off <= length
        end = np.where(self.heading_to_end > 0, b, a)
        to_end = np.where(self.heading_to_end > 0, length - off, off)
        turn = inside & (to_end < self.settings.turn_tol)
        self.heading_to_end = np.where(turn, -self.heading_to_end, self.heading_to_end)
        end = np.where(self.heading_to_end > 0, b, a)
        # inside: move towards the end along the segment; outside: the shorter way to the segment
        fwd = np.mod(end - s_d, M)
        shorter = np.where(fwd <= M - fwd, 1, -1)
        self.direction = np.where(inside, self.heading_to_end, shorter)
        self.s_target = end
        self.allocated = True
