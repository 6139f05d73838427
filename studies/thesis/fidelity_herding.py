"""Why the herd of 200 animals does not gather at R_b = 140 m (thesis Fig. 6.10a), traced.

Equations quoted from the thesis (ch. 6): the animal moves along (6.1),
``N = eta_d N_d + eta_L N_L + eta_r N_r + eta_i N_i + eta_e N_e`` with N_d "the repulsive force
from the barking drone" (a unit vector) and N_L "the attractive force to the center of mass of
the animal's neighbours"; only animals in a barking cone (angle beta, radius R_b, axis towards
C_o, Fig. 6.2) feel N_d; the drones stay on the extended hull (Definition 6.3.1, offset d_s) and
go to the steering points, the extended-hull vertices of the n_d hull animals farthest from C_o
(§6.4.3), allocated by (6.21)-(6.23).

The mechanism (measured by :func:`trace_gathering`)
---------------------------------------------------
1. Far-side barking. An animal on the far side of C_o from a drone, ``(a - C_o).(d - C_o) < 0``,
   is farther from the drone than C_o is (``|a - d|^2 = |a - C_o|^2 + |d - C_o|^2 - 2 (a - C_o).(d - C_o)``),
   so the drone can bark at it only when its distance D to C_o is below R_b; the push then
   points away from the drone, i.e. away from C_o on the far side. A drone on the extended hull
   has D of about (herd extent) + d_s, so far-side barking starts once the herd is within about
   R_b - d_s of C_o: 110 m at R_b = 140 m, well before R_c = 60 m; at R_b = 100 m it would start
   at 70 m, and the traced run never has any.
2. Bunched drones. As the herd tightens it breaks into a few compact groups. The steering points
   are the n_d farthest hull animals, which then all belong to the farthest group, so the four
   drones stand together on one side of C_o (traced: within 95-125 degrees of arc).
3. No pull between groups. N_L attracts an animal to the centre of its n nearest neighbours
   (n = 20 here, Strömbom's model; the thesis does not give n); a group of more than n animals
   feels no pull towards the others.

Together: at R_b = 140 m every animal is barked at, most of them from across C_o, by drones all
on one side, so the whole herd is pushed the same way. It translates (its centroid drifts
hundreds of metres) instead of contracting, and the footprint stalls at 75-80 m with the same
animals outside R_c. At R_b = 100 m the cones do not reach across C_o until the herd is nearly
gathered, and it gathers.

Thesis-consistent readings tried (:data:`RULES`, :func:`variant_animal_step`)
-----------------------------------------------------------------------------
- N_d as the unit vector away from *the* (nearest) barking drone (``"nearest"``), or the plain
  sum of the unit vectors (``"unnormalised"``), instead of the scenario's unit sum (``"sum"``):
  neither gathers at R_b = 140 m. The reading of N_d is not the cause.
- A larger neighbourhood n for N_L (the thesis leaves it open): with n = 50 or n = all animals the
  herd gathers at R_b = 140 m, as Fig. 6.10a shows.

:func:`variant_animal_step` is the animal step of ``droneplan.scenarios.herding`` (small-herd path,
same random draws) with the N_d reading as a parameter; with rule ``"sum"`` it reproduces
``animal_step`` bit for bit, so a difference between the rules is the rule alone.
Units: metres, seconds, radians.
"""

from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from droneplan.core.validation import as_generator, check_array, check_int, check_positive
from droneplan.planners.herding import ProposedHerder
from droneplan.scenarios.herding import (
    HerdingObservation,
    HerdingParams,
    HerdingPhase,
    HerdingScenario,
    barking_mask,
    drone_step,
    thesis_scenario,
)

__all__ = [
    "RULES",
    "stalled_state",
    "drone_repulsion",
    "variant_animal_step",
    "trace_gathering",
    "run_fidelity_herding",
]

RULES = ("sum", "nearest", "unnormalised")
"""Readings of N_d of (6.1) for an animal in several cones (module docstring)."""


def _check_rule(rule: str) -> str:
    if rule not in RULES:
        raise ValueError(f"rule must be one of {RULES}, got {rule!r}")
    return rule


def _unit(v: np.ndarray) -> np.ndarray:
    n = np.sqrt(np.sum(v * v, axis=-1, keepdims=True))
    return v / np.maximum(n, 1e-12)


def drone_repulsion(
    animals: np.ndarray, drones: np.ndarray, centroid: np.ndarray, params: HerdingParams, rule: str = "sum"
) -> tuple[np.ndarray, np.ndarray]:
    """N_d of (6.1) for every animal under a reading ``rule`` (one of :data:`RULES`).

    animals: (n, 2) positions, m; drones: (n_d, 2) positions, m; centroid: (2,) herd centroid C_o, m
    (the cones' axes point at it); params: the model (R_b, m; beta, rad).
    Returns (N_d (n, 2), cone (n, n_d) bool); N_d is zero for an animal in no cone; it is a unit
    vector for ``"sum"`` and ``"nearest"``, and of length <= n_d for ``"unnormalised"``.
    """
    animals = check_array("animals", animals, shape=(None, 2), min_rows=1)
    drones = check_array("drones", drones, shape=(None, 2), min_rows=1)
    centroid = check_array("centroid", centroid, shape=(2,))
    if not isinstance(params, HerdingParams):
        raise TypeError(f"params must be HerdingParams, got {type(params).__name__}")
    rule = _check_rule(rule)
    cone = barking_mask(animals, drones, centroid, params.R_b, params.beta)
    return _repulsion_rule(animals, drones, cone, rule), cone


def _repulsion_rule(pos: np.ndarray, drones: np.ndarray, cone: np.ndarray, rule: str) -> np.ndarray:
    rel = pos[:, None, :] - drones[None, :, :]
    dist = np.maximum(np.sqrt(np.sum(rel * rel, axis=2)), 1e-12)
    if rule == "nearest":
        masked = np.where(cone, dist, np.inf)
        j = np.argmin(masked, axis=1)
        rows = np.arange(pos.shape[0])
        out = rel[rows, j] / dist[rows, j][:, None]
        hit: np.ndarray = np.asarray(cone.any(axis=1))
        return np.where(hit[:, None], out, 0.0)
    s = np.einsum("md,mdc->mc", cone / dist, rel)  # the sum of the unit vectors, as the model has it
    return _unit(s) if rule == "sum" else s


def _neighbour_terms(animals, pos, params) -> tuple[np.ndarray, np.ndarray]:
    """N_r and N_L of (6.1) for the moving animals ``pos`` (the scenario's small-herd path)."""
    n, m = animals.shape[0], pos.shape[0]
    R_a, C = np.zeros((m, 2)), np.zeros((m, 2))
    if n > 1:
        K = min(params.n_neighbours, n - 1)
        tree = cKDTree(animals, balanced_tree=False, compact_nodes=False)
        dist, idx = tree.query(pos, k=K + 1)
        dist, idx = dist[:, 1:], idx[:, 1:]
        nb = animals[idx.T]
        w = np.where(dist < params.r_a, 1.0 / np.maximum(dist, 1e-12), 0.0).T
        R_a = _unit((w[:, :, None] * (pos - nb)).sum(axis=0))
        C = _unit(nb.sum(axis=0) / K - pos)
    return R_a, C


def variant_animal_step(
    animals: np.ndarray,
    heading: np.ndarray,
    drones: np.ndarray,
    params: HerdingParams,
    seed=None,
    rule: str = "sum",
    centroid: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One animal step of ``params.delta`` s with the N_d reading ``rule`` (module docstring).

    animals: (n, 2) positions, m (n < 1000: the scenario's small-herd path); heading: (n, 2)
    previous unit headings; drones: (n_d, 2) positions, m; params: the model; seed: int or
    Generator (drawn in the scenario's order); rule: one of :data:`RULES`; centroid: C_o, m
    (default: the mean of ``animals``).
    Returns (new positions (n, 2), new headings (n, 2), barked-at mask (n,)).
    """
    animals = check_array("animals", animals, shape=(None, 2), min_rows=1)
    check_int("n_animals (variant_animal_step: small-herd path)", animals.shape[0], max_value=999)
    rule = _check_rule(rule)
    rng = as_generator(seed)
    c = np.add.accumulate(animals, axis=0)[-1] / animals.shape[0] if centroid is None else centroid
    cone = barking_mask(animals, drones, c, params.R_b, params.beta)
    affected: np.ndarray = np.asarray(cone.any(axis=1))
    grazing = (~affected) & (rng.random(animals.shape[0]) < params.graze_prob)
    movers = np.flatnonzero(affected | grazing)
    new_pos, new_head = animals.copy(), heading.copy()
    if movers.size == 0:
        return new_pos, new_head, affected
    pos = animals[movers]
    eps = _unit(rng.normal(size=(movers.size, 2)))
    aff = affected[movers]
    R_a, C = _neighbour_terms(animals, pos, params)
    R_d = _repulsion_rule(pos, drones, cone[movers], rule)
    herd = params.eta_d * R_d + params.eta_L * C + params.eta_r * R_a + params.eta_i * heading[movers]
    herd += params.eta_e * eps
    graze = params.eta_r * R_a + params.eta_e * eps
    direction = _unit(np.where(aff[:, None], herd, graze))
    speed = np.where(aff, params.V_animal, params.graze_speed)
    new_pos[movers] = pos + (speed * params.delta)[:, None] * direction
    new_head[movers] = direction
    return new_pos, new_head, affected


def _groups(animals: np.ndarray, link: float) -> int:
    """Number of groups: connected components of the animals closer than ``link`` m."""
    pairs = cKDTree(animals).query_pairs(link, output_type="ndarray")
    graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(len(animals),) * 2)
    return int(connected_components(graph, directed=False)[0])


def _arc_span(drones: np.ndarray, c: np.ndarray) -> float:
    """Smallest arc (rad) around ``c`` that holds every drone."""
    ang = np.sort(np.mod(np.arctan2(drones[:, 1] - c[1], drones[:, 0] - c[0]), 2 * np.pi))
    gaps = np.diff(np.r_[ang, ang[0] + 2 * np.pi])
    return float(2 * np.pi - gaps.max())


def _step_record(animals, drones, c, params, herder) -> dict:
    """What one traced step shows: who is outside R_c, who is barked at and from where, the drones."""
    d = np.sqrt(np.sum((animals - c) ** 2, axis=1))
    cone = barking_mask(animals, drones, c, params.R_b, params.beta)
    across = ((animals - c) @ (drones - c).T) < 0  # animal and drone on opposite sides of C_o
    hull = herder.hull
    steer = (
        hull.point_at(herder.s_target)
        if (hull is not None and herder.allocated)
        else np.full_like(drones, np.nan)
    )
    return {
        "r": float(d.max()),
        "n_out": int(np.sum(d > params.R_c)),
        "barked": int(np.sum(cone.any(axis=1))),
        "barked_across": int(np.sum((cone & across).any(axis=1))),
        "groups": _groups(animals, 4 * params.r_a),
        "drone_arc": _arc_span(drones, c),
        "drone_dist": np.sqrt(np.sum((drones - c) ** 2, axis=1)),
        "steer_dist": np.sqrt(np.sum((steer - c) ** 2, axis=1)),
        "centroid": c.copy(),
    }


def trace_gathering(
    scenario: HerdingScenario,
    *,
    rule: str = "sum",
    t_max: float = 1200.0,
    seed=10_000,
    every: float = 1.0,
) -> dict:
    """Gather with the proposed herder under N_d reading ``rule`` and record the mechanism.

    scenario: a herd of fewer than 1000 animals (the scenario's small-herd path); rule: one of
    :data:`RULES` (``"sum"`` is the scenario's model); t_max: simulated time limit, s (> 0);
    seed: the animals' noise (int or Generator); every: record every this many s (> 0).
    Returns a dict of arrays over the recorded steps: ``t`` (s), ``r`` (footprint radius, m),
    ``n_out`` (animals beyond R_c), ``barked`` (animals in at least one cone), ``barked_across``
    (animals in the cone of a drone on the other side of C_o), ``groups`` (groups of animals
    linked within 4 r_a), ``drone_arc`` (smallest arc around C_o holding every drone, rad),
    ``drone_dist`` and ``steer_dist`` ((T, n_d) distances of the drones and of their allocated
    steering points to C_o, m; NaN before the first allocation), ``centroid`` ((T, 2), m); plus
    ``gather_time`` (s or None), ``cpu`` (CPU s) and the last ``animals`` and ``drones`` (m).
    """
    if not isinstance(scenario, HerdingScenario):
        raise TypeError(f"scenario must be a HerdingScenario, got {type(scenario).__name__}")
    rule = _check_rule(rule)
    t_max = check_positive("t_max", t_max)
    every = check_positive("every", every)
    p = scenario.params
    herder = ProposedHerder()
    herder.reset(scenario, seed=0)
    rng = as_generator(seed)
    A, H = scenario.animals.copy(), np.zeros_like(scenario.animals)
    D, hd = scenario.drones.copy(), scenario.headings.copy()
    stride = max(1, round(every / p.delta))
    rec: dict[str, list] = {"t": []}
    gather_time = None
    c0 = time.process_time()
    for step in range(math.ceil(t_max / p.delta) + 1):
        t = step * p.delta
        c = np.add.accumulate(A, axis=0)[-1] / A.shape[0]
        r = float(np.sqrt(np.max(np.sum((A - c) ** 2, axis=1))))
        if step % stride == 0 or r <= p.R_c:
            rec["t"].append(t)
            for k, v in _step_record(A, D, c, p, herder).items():
                rec.setdefault(k, []).append(v)
        if r <= p.R_c:
            gather_time = t
            break
        cmd = herder.command(HerdingObservation(t, A, c, HerdingPhase.GATHERING, D, hd, p.delta, True))
        D, hd = drone_step(D, hd, cmd[0], cmd[1], p, p.delta)
        A, H, _ = variant_animal_step(A, H, D, p, rng, rule, c)
    out: dict = {k: np.array(v) for k, v in rec.items()}
    out.update(gather_time=gather_time, cpu=time.process_time() - c0, animals=A, drones=D, rule=rule)
    return out


def stalled_state(params: HerdingParams, seed=0) -> HerdingScenario:
    """A herd like the traced stall at R_b = 140 m: three compact groups, drones on one side.

    Groups of 92, 74 and 34 animals (discs of radius 8 m) with centres 45-60 m from the herd's
    centroid, and the n_d drones within 90 degrees of arc, 105 m from it on the side of the
    farthest group (the state the trace reaches after about 8 minutes).
    params: the model (``params.n_drones`` drones); seed: int or Generator for the animals' places.
    """
    if not isinstance(params, HerdingParams):
        raise TypeError(f"params must be HerdingParams, got {type(params).__name__}")
    rng = as_generator(seed)
    centres = np.array([[10.0, -45.0], [45.0, 40.0], [-60.0, 30.0]])
    sizes = (92, 74, 34)
    parts = []
    for ctr, k in zip(centres, sizes, strict=True):
        rad = 8.0 * np.sqrt(rng.random(k))
        ang = rng.uniform(0, 2 * np.pi, k)
        parts.append(ctr + np.column_stack([rad * np.cos(ang), rad * np.sin(ang)]))
    animals = np.concatenate(parts)
    animals -= animals.mean(axis=0)
    n = params.n_drones
    phi = math.atan2(40.0, 45.0) + np.linspace(-math.pi / 4, math.pi / 4, n)
    drones = 105.0 * np.column_stack([np.cos(phi), np.sin(phi)])
    return HerdingScenario(
        params, animals, drones, phi + math.pi, np.array([-900.0, 0.0]), (-100, -100, 100, 100)
    )


def _figure(path: Path, traces: dict, neighbours: dict, p: HerdingParams) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(1, 3, figsize=(16, 4.8))
    for lab, tr in [
        *((f"N_d '{k}', n = {p.n_neighbours}", v) for k, v in traces.items()),
        *((f"N_d 'sum', n = {k}", v) for k, v in neighbours.items()),
    ]:
        end = f"gathered {tr['gather_time'] / 60:.1f} min" if tr["gather_time"] else "no gathering"
        ax[0].plot(tr["t"] / 60, tr["r"], label=f"{lab}: {end}")
    ax[0].axhline(p.R_c, color="k", ls=":", label="R_c")
    ax[0].set(
        xlabel="t (min)",
        ylabel="footprint radius (m)",
        yscale="log",
        title=f"(a) R_b = {p.R_b:.0f} m, 200 animals, seed 0",
    )
    ax[0].legend(fontsize=7)
    tr = traces["sum"]
    tm = tr["t"] / 60
    ax[1].plot(tm, tr["n_out"], label="animals beyond R_c")
    ax[1].plot(tm, tr["barked"], label="animals barked at")
    ax[1].plot(tm, tr["barked_across"], label="... by a drone across C_o")
    ax[1].plot(tm, 10 * tr["groups"].clip(max=20), label="10 x groups (<= 20 shown)")
    ax[1].plot(tm, np.degrees(tr["drone_arc"]), label="drones' arc around C_o (deg)")
    ax[1].set(xlabel="t (min)", ylabel="count / deg", title="(b) the scenario's model, traced")
    ax[1].legend(fontsize=7)
    A, D, c = tr["animals"], tr["drones"], tr["centroid"][-1]
    R_d, cone = drone_repulsion(A, D, A.mean(axis=0), p, "sum")
    ax[2].scatter(*A.T, s=5, c=cone.sum(axis=1), cmap="viridis", vmin=0, vmax=p.n_drones)
    ax[2].quiver(A[:, 0], A[:, 1], R_d[:, 0], R_d[:, 1], scale=35, width=0.002)
    ax[2].plot(*D.T, "rs", label="drones")
    ax[2].plot(*tr["centroid"].T, "k-", lw=0.8, label="centroid path (last part)")
    ax[2].add_patch(plt.Circle(c, p.R_c, fill=False, ls=":"))
    ax[2].set_xlim(c[0] - 150, c[0] + 150)
    ax[2].set_ylim(c[1] - 150, c[1] + 150)
    ax[2].set_aspect("equal")
    ax[2].set_title(f"(c) t = {tr['t'][-1] / 60:.0f} min: colour = cones, arrow = N_d", fontsize=9)
    ax[2].legend(fontsize=7, loc="lower left")
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def run_fidelity_herding(
    out,
    *,
    n_animals: int = 200,
    R_b: float = 140.0,
    seed: int = 0,
    t_max: float = 1500.0,
    neighbours=(50, 199),
) -> dict:
    """Trace the R_b study and write ``herding_rb_trace.png`` in ``out``.

    Runs the proposed herder at ``R_b`` under the three N_d readings (:data:`RULES`, n = 20) and
    under the scenario's reading with larger neighbourhoods n for N_L, plus the scenario's model
    at R_b = 100 m for comparison.
    out: folder for the figure (created); n_animals: herd size (2..999); R_b: barking radius, m;
    seed: herd layout seed (the noise seed is seed + 10000); t_max: simulated limit per run, s;
    neighbours: the neighbour counts n (ints >= 1) tried with rule "sum".
    Returns {"runs": {label: summary}, "figure": path}; a summary holds gather_time (s or None),
    final_r (m), stall_r (median footprint over the last quarter, m), barked_across (median over
    the last quarter), drone_arc_deg (median over the last quarter, deg), drift_m (centroid
    displacement over the last quarter, m) and cpu (CPU s).
    """
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    n_animals = check_int("n_animals", n_animals, min_value=2, max_value=999)
    R_b = check_positive("R_b", R_b)
    neighbours = [check_int("neighbours", k, min_value=1) for k in neighbours]

    def summary(tr):
        q = 3 * len(tr["r"]) // 4
        return {
            "gather_time": tr["gather_time"],
            "final_r": float(tr["r"][-1]),
            "stall_r": float(np.median(tr["r"][q:])),
            "barked_across": float(np.median(tr["barked_across"][q:])),
            "drone_arc_deg": float(np.degrees(np.median(tr["drone_arc"][q:]))),
            "drift_m": float(np.linalg.norm(tr["centroid"][-1] - tr["centroid"][q])),
            "cpu": float(tr["cpu"]),
        }

    noise = seed + 10_000
    sc = thesis_scenario(n_animals, seed=seed, R_b=R_b)
    traces = {rule: trace_gathering(sc, rule=rule, t_max=t_max, seed=noise) for rule in RULES}
    nbr = {
        k: trace_gathering(
            thesis_scenario(n_animals, seed=seed, R_b=R_b, n_neighbours=k), t_max=t_max, seed=noise
        )
        for k in neighbours
    }
    ref = trace_gathering(thesis_scenario(n_animals, seed=seed, R_b=100.0), t_max=t_max, seed=noise)
    path = out / "herding_rb_trace.png"
    _figure(path, traces, nbr, sc.params)
    runs = {f"R_b={R_b:g} N_d={k} n={sc.params.n_neighbours}": summary(v) for k, v in traces.items()}
    runs.update({f"R_b={R_b:g} N_d=sum n={k}": summary(v) for k, v in nbr.items()})
    runs[f"R_b=100 N_d=sum n={sc.params.n_neighbours}"] = summary(ref)
    return {"runs": runs, "figure": path}
