"""Repelling episodes (thesis §5.3.1): closed-loop sharks that react to the field, several operators.

Shark behaviour model (ours; the thesis only states the assumptions): a shark heads for its
nearest swimmer at ``speed`` with a bounded turn rate; when its snout touches a field it
turns away from that operator (random spread) and flees for ``flee_time``; afterwards it
returns to hunting with probability ``return_prob``, otherwise it leaves the area for good.
Touches within ``desensitise_time`` of the previous reaction are ignored (the loss of
sensitivity under continuous stimulation that motivates the thesis's waiting time T_w).
A shark that comes within ``bite_radius`` of a swimmer attacks (episode failed); it has left
once it is ``safety_distance`` from every swimmer (thesis: e.g. 3 km).

The observer drone of §5.3.1 (:class:`ObserverDrone`): when the sharks are spotted (t = 0) one
observer leaves the surveillance formation and flies at a fixed altitude over the sharks that
have not left, monitoring them. It raises the alarm at once (:class:`AlarmLevel`): its speakers
tell the swimmers near a shark to leave the water; with no swimmer near a shark it gives early
warning through the lifeguards; with more sharks than operators (s > n) it sends the highest
alert (close the beach) and the n sharks closest to swimmers are the ones to repel.
"""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass, field, fields
from typing import Any

import numpy as np
from numpy.typing import NDArray

from droneplan.core.validation import (
    as_generator,
    check_array,
    check_instance,
    check_int,
    check_methods,
    check_positive,
    check_real,
    check_sequence,
    check_work,
)
from droneplan.scenarios.shark.params import THESIS_TABLE_5_1, SharkParams, inside_field
from droneplan.scenarios.shark.simulate import SharkCommand, clip_velocity

__all__ = [
    "SharkBehaviour",
    "ObserverDrone",
    "AlarmLevel",
    "alarm_level",
    "sharks_to_repel",
    "RepellingMode",
    "RepellingScenario",
    "RepellingObservation",
    "RepellingTrace",
    "simulate_repelling",
]


@dataclass(frozen=True)
class SharkBehaviour:
    """Parameters of the reacting shark (our choices)."""

    speed: float = 5.0
    """Cruise speed when hunting or fleeing (m/s, <= VsMxy)."""
    turn_rate: float = 0.8
    """Maximum heading rate (rad/s)."""
    flee_time: float = 8.0
    """Time spent fleeing after reacting to the field (s)."""
    flee_spread: float = math.radians(40)
    """Half-width of the random spread of the flight direction around 'away from the operator' (rad)."""
    return_prob: float = 0.6
    """Probability of resuming the hunt after fleeing (else it leaves for good)."""
    desensitise_time: float = 3.0
    """Touches within this time after a reaction are ignored (s)."""
    depth: float = -3.0
    """Swimming depth (m, < 0)."""
    bite_radius: float = 2.0
    """Horizontal distance to a swimmer that counts as an attack (m)."""
    safety_distance: float = 300.0
    """Distance from every swimmer beyond which the shark has left (m; thesis example 3 km)."""

    def __post_init__(self) -> None:
        for f in fields(self):
            check_real(f.name, getattr(self, f.name))
        for name in ("speed", "turn_rate", "flee_time", "bite_radius", "safety_distance"):
            if getattr(self, name) <= 0:
                raise ValueError(f"{name} must be > 0")
        if not 0 <= self.return_prob <= 1:
            raise ValueError("return_prob must be in [0, 1]")
        if self.depth >= 0:
            raise ValueError("depth must be < 0")
        if self.desensitise_time < 0 or self.flee_spread < 0:
            raise ValueError("desensitise_time and flee_spread must be >= 0")


@dataclass(frozen=True)
class ObserverDrone:
    """The observer of a repelling episode (thesis §5.3.1; altitude, speed and radii are our choices)."""

    altitude: float = 30.0
    """Altitude it flies and monitors at (m above the sea surface, > 0)."""
    speed: float = 10.0
    """Maximum horizontal speed (m/s, > 0)."""
    near_radius: float = 50.0
    """A swimmer within this horizontal distance of a shark is near it (m, > 0): the speakers alarm
    them; with no swimmer near any shark the warning goes through the lifeguards."""
    start: tuple[float, float] | None = None
    """Where it leaves the surveillance formation (x, y in m); None: above the operators' centroid."""

    def __post_init__(self) -> None:
        for name in ("altitude", "speed", "near_radius"):
            check_positive(name, getattr(self, name))
        if self.start is not None:
            xy = check_array("start", self.start, shape=(2,))
            object.__setattr__(self, "start", (float(xy[0]), float(xy[1])))


class AlarmLevel(enum.IntEnum):
    """The observer's alarm (thesis §5.3.1), by increasing severity."""

    LIFEGUARD = 1
    """No swimmer near a shark: early warning to swimmers and surfers through the lifeguards."""
    SPEAKER = 2
    """A swimmer near a shark: the observer's speakers tell them to leave the water at once."""
    CLOSE_BEACH = 3
    """More sharks than operators (s > n): highest alert to the lifeguards to close the beach."""


def _near(sharks: NDArray[np.float64], swimmers: NDArray[np.float64], radius: float) -> NDArray[np.bool_]:
    """(m,) bool: swimmer within ``radius`` (m, horizontal) of one of ``sharks`` (k, >=2)."""
    if not len(sharks) or not len(swimmers):
        return np.zeros(len(swimmers), bool)
    d = np.linalg.norm(swimmers[:, None, :2] - sharks[None, :, :2], axis=2)
    return np.asarray(d.min(axis=1) <= radius)


def alarm_level(sharks: Any, swimmers: Any, n_operators: int, near_radius: float) -> AlarmLevel:
    """The observer's alarm for spotted sharks (s, 2|3) and swimmers (m, 2|3) in m, with
    ``n_operators`` operators (count) and the near radius (m): CLOSE_BEACH when s > n, else
    SPEAKER when a swimmer is within ``near_radius`` of a shark, else LIFEGUARD."""
    S = check_array("sharks", sharks)
    H = check_array("swimmers", swimmers)
    n = check_int("n_operators", n_operators, min_value=0)
    r = check_positive("near_radius", near_radius)
    if S.ndim != 2 or S.shape[1] not in (2, 3) or H.ndim != 2 or H.shape[1] not in (2, 3):
        raise ValueError(f"sharks and swimmers must be (k, 2|3) arrays, got {S.shape} and {H.shape}")
    if len(S) > n:
        return AlarmLevel.CLOSE_BEACH
    return AlarmLevel.SPEAKER if _near(S, H, r).any() else AlarmLevel.LIFEGUARD


def sharks_to_repel(sharks: Any, swimmers: Any, n_operators: int) -> NDArray[np.intp]:
    """Indices of the sharks the operators are sent to: all of them when s <= n, else the n closest
    (horizontal distance to the nearest swimmer, ties by index) as the thesis's highest alert asks.

    sharks: (s, 2|3) shark positions (m); swimmers: (m, 2|3) swimmer positions (m), m >= 1;
    n_operators: number of operators n (count). Returned sorted by index.
    """
    S = check_array("sharks", sharks)
    H = check_array("swimmers", swimmers)
    n = check_int("n_operators", n_operators, min_value=0)
    if S.ndim != 2 or S.shape[1] not in (2, 3) or H.ndim != 2 or H.shape[1] not in (2, 3) or not len(H):
        raise ValueError(f"sharks (s, 2|3) and swimmers (m >= 1, 2|3) expected, got {S.shape} and {H.shape}")
    d = np.linalg.norm(S[:, None, :2] - H[None, :, :2], axis=2).min(axis=1)
    return np.sort(np.argsort(d, kind="stable")[: min(n, len(S))])


class RepellingMode(enum.StrEnum):
    """Phases of a repelling operator (thesis §5.3.1, steps 1-5)."""

    FOLLOW = "follow"
    """Following its shark at a stand-off (the shark approaches no one)."""
    INTERCEPT = "intercept"
    """Intercepting its shark (step 2)."""
    WAIT = "wait"
    """Waiting T_w after a field contact, following (step 3)."""
    COVER = "cover"
    """Covering a swimmer the shark is about to reach (step 1)."""
    RETURN = "return"
    """The shark has left: flying back to base (step 5)."""


@dataclass(frozen=True)
class RepellingScenario:
    """A repelling episode's set-up (what ``controller.reset`` receives)."""

    sharks0: NDArray[np.float64]
    """(s, 3) initial shark positions (m)."""
    operators0: NDArray[np.float64]
    """(n, 3) initial operator positions (m)."""
    swimmers: NDArray[np.float64]
    """(m, 2) swimmer positions (m)."""
    params: SharkParams = THESIS_TABLE_5_1
    """Problem parameters (Table 5.1)."""
    behaviour: SharkBehaviour = SharkBehaviour()
    """The sharks' reaction model."""


@dataclass(frozen=True)
class RepellingObservation:
    """What one operator's controller knows at one control instant (the argument of ``command``)."""

    t: float
    """Time (s)."""
    operator: NDArray[np.float64]
    """(3,) this operator's position (m)."""
    sharks_pos: NDArray[np.float64]
    """(s, 3) shark positions (m)."""
    sharks_vel: NDArray[np.float64]
    """(s, 3) shark velocities (m/s)."""
    swimmers: NDArray[np.float64]
    """(m, 2) swimmer positions (m)."""
    contact: NDArray[np.bool_]
    """(s,) bool: this operator's field touched that shark during the last step."""


@dataclass
class RepellingTrace:
    """Outcome of a repelling episode.

    t (K,) s; sharks (K,s,3), operators (K,n,3) m; mode (K,s) shark modes (0 hunt, 1 flee, 2 leave);
    reactions (s,) number of field contacts each shark reacted to (= successful interceptions);
    ignored (s,) contacts ignored through desensitisation; attacked: a swimmer was reached;
    left (s,) bool: shark beyond the safety distance; end_time (s); seed.
    """

    t: NDArray[np.float64]
    sharks: NDArray[np.float64]
    operators: NDArray[np.float64]
    mode: NDArray[np.integer[Any]]
    reactions: NDArray[np.integer[Any]]
    ignored: NDArray[np.integer[Any]]
    attacked: bool
    left: NDArray[np.bool_]
    end_time: float
    seed: int | None = None
    info: dict = field(default_factory=dict)
    """Extra per-episode data (e.g. per-operator counters)."""
    observer: NDArray[np.float64] = field(default_factory=lambda: np.zeros((0, 3)))
    """(K, 3) observer drone positions (m)."""
    alarm: NDArray[np.integer[Any]] = field(default_factory=lambda: np.zeros(0, int))
    """(K,) the observer's :class:`AlarmLevel` at each instant (from t = 0, when the sharks are spotted)."""
    alerted_at: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0))
    """(m,) first time each swimmer was near a shark and told by the speakers to leave the water
    (s; NaN: never)."""
    to_repel: NDArray[np.intp] = field(default_factory=lambda: np.zeros(0, np.intp))
    """Indices of the sharks the operators are sent to (:func:`sharks_to_repel` at t = 0)."""


def _rows(name: str, value: Any) -> NDArray[np.float64]:
    """``value`` as a 2-D array with at least one row (one point (k,) becomes (1, k))."""
    arr = check_array(name, value)
    arr = arr.reshape(1, -1) if arr.ndim == 1 else arr
    if arr.ndim != 2 or len(arr) == 0:
        raise ValueError(f"{name} must be a (k, 2|3) array with at least one row, got shape {arr.shape}")
    return arr


def _repelling_positions(
    sharks0: Any, operators0: Any, swimmers: Any, depth: float
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Sharks (s, 3) (a (s, 2) input swims at ``depth``), operators (n, 3) and swimmers (m, 2), in m,
    each checked under its parameter's name (at least one of each, finite, within MAX_COORDINATE)."""
    S = _rows("sharks0", sharks0)
    if S.shape[1] not in (2, 3):
        raise ValueError(f"sharks0 must have shape (s, 2) or (s, 3), got {S.shape}")
    if S.shape[1] == 2:
        S = np.c_[S, np.full(len(S), depth)]
    O = _rows("operators0", operators0)
    if O.shape[1] != 3:
        raise ValueError(f"operators0 must have shape (n, 3), got {O.shape}")
    H = _rows("swimmers", swimmers)
    if H.shape[1] not in (2, 3):
        raise ValueError(f"swimmers must have shape (m, 2) or (m, 3), got {H.shape}")
    return S, O, H[:, :2].copy()


def simulate_repelling(  # noqa: C901, PLR0915
    sharks0,
    operators0,
    swimmers,
    controllers,
    params: SharkParams = THESIS_TABLE_5_1,
    behaviour: SharkBehaviour = SharkBehaviour(),
    *,
    t_max: float = 300.0,
    seed=0,
    observer: ObserverDrone | None = None,
) -> RepellingTrace:
    """Simulate sharks hunting swimmers while operators repel them, at Ts.

    sharks0 (s,2|3), operators0 (n,3), swimmers (m,2|3) in m; controllers: one per operator,
    each following the closed-loop contract (``reset(RepellingScenario, *, seed)`` once, then
    ``command(RepellingObservation) -> SharkCommand`` every Ts; a bare velocity (3,) in m/s is
    accepted). Stops when every shark has left, a swimmer is attacked, or at t_max (s).

    params: problem parameters, SharkParams (default: THESIS_TABLE_5_1).
    behaviour: SharkBehaviour, the reacting-shark model (our choices).
    seed: int, numpy Generator or None for the sharks' random reactions (recorded when an int).
    observer: the :class:`ObserverDrone` (None: the default one). It does not act on the sharks or
        the operators; the trace records its path, its alarm at each instant and the swimmers its
        speakers warned.
    """
    t_max = check_positive("t_max", t_max)
    obs_drone = ObserverDrone() if observer is None else check_instance("observer", observer, ObserverDrone)
    if not isinstance(params, SharkParams) or not isinstance(behaviour, SharkBehaviour):
        raise TypeError("params must be SharkParams and behaviour SharkBehaviour")
    g = as_generator(seed)
    if behaviour.speed > params.VsMxy:
        raise ValueError(f"behaviour.speed must be <= VsMxy={params.VsMxy}")
    check_work("t_max", t_max / params.Ts, "evaluations")
    S, O, H = _repelling_positions(sharks0, operators0, swimmers, behaviour.depth)
    controllers = check_sequence("controllers", controllers, min_len=0)
    if len(controllers) != len(O):
        raise ValueError(
            f"controllers must hold one controller per operator of operators0 ({len(O)}), "
            f"got {len(controllers)}"
        )
    for i, c in enumerate(controllers):
        check_methods(f"controllers[{i}]", c, ("reset", "command"))
    scenario = RepellingScenario(S.copy(), O.copy(), H.copy(), params, behaviour)
    for c in controllers:
        c.reset(scenario, seed=seed)
    s = len(S)
    Ts = params.Ts
    near0 = H[np.argmin(np.linalg.norm(H[None] - S[:, None, :2], axis=2), axis=1)]
    heading = np.arctan2(near0[:, 1] - S[:, 1], near0[:, 0] - S[:, 0])
    mode = np.zeros(s, int)
    flee_until = np.zeros(s)
    last_react = np.full(s, -np.inf)
    reactions = np.zeros(s, int)
    ignored = np.zeros(s, int)
    contact_prev = np.zeros((len(O), s), bool)
    start = np.mean(O[:, :2], axis=0) if obs_drone.start is None else np.asarray(obs_drone.start)
    W = np.r_[start, obs_drone.altitude]  # the observer leaves the formation at its altitude
    close_beach = s > len(O)
    alerted_at = np.full(len(H), np.nan)

    def _alarm(t: float, S: NDArray[np.float64], mode: NDArray[np.integer[Any]]) -> int:
        near = _near(S[mode != 2], H, obs_drone.near_radius)
        alerted_at[near & np.isnan(alerted_at)] = t
        if close_beach:
            return int(AlarmLevel.CLOSE_BEACH)
        return int(AlarmLevel.SPEAKER if near.any() else AlarmLevel.LIFEGUARD)

    ts, Ss, Os, Ms = [0.0], [S.copy()], [O.copy()], [mode.copy()]
    Ws, alarms = [W.copy()], [_alarm(0.0, S, mode)]
    attacked = False
    n_steps = round(t_max / Ts)
    for k in range(n_steps):
        t = k * Ts
        V = np.c_[behaviour.speed * np.cos(heading), behaviour.speed * np.sin(heading), np.zeros(s)]
        cmds = [
            c.command(
                RepellingObservation(t, O[i].copy(), S.copy(), V.copy(), H.copy(), contact_prev[i].copy())
            )
            for i, c in enumerate(controllers)
        ]
        vel = np.array(
            [clip_velocity(cmd.velocity if isinstance(cmd, SharkCommand) else cmd, params)[0] for cmd in cmds]
        ).reshape(-1, 3)
        On = O + Ts * vel
        On[:, 2] = np.clip(On[:, 2], params.lmin, params.le)
        # shark heading update
        dist = np.linalg.norm(H[None] - S[:, None, :2], axis=2)
        near = H[np.argmin(dist, axis=1)]
        desired = np.arctan2(near[:, 1] - S[:, 1], near[:, 0] - S[:, 0])
        for j in range(s):
            if mode[j] == 1 and t >= flee_until[j]:
                mode[j] = 0 if g.random() < behaviour.return_prob else 2
            if mode[j] == 0:
                err = (desired[j] - heading[j] + np.pi) % (2 * np.pi) - np.pi
                heading[j] += np.clip(err, -behaviour.turn_rate * Ts, behaviour.turn_rate * Ts)
        V = np.c_[behaviour.speed * np.cos(heading), behaviour.speed * np.sin(heading), np.zeros(s)]
        Sn = S + Ts * V
        # field contacts (end of step) and reactions
        contact = inside_field(Sn[None, :, :], On[:, None, :], params) <= 0  # (n, s)
        for j in range(s):
            if contact[:, j].any() and mode[j] != 2:
                if t - last_react[j] < behaviour.desensitise_time:
                    ignored[j] += 1
                    continue
                i = int(np.argmax(contact[:, j]))
                away = math.atan2(Sn[j, 1] - On[i, 1], Sn[j, 0] - On[i, 0])
                heading[j] = away + g.uniform(-behaviour.flee_spread, behaviour.flee_spread)
                mode[j] = 1
                flee_until[j] = t + behaviour.flee_time
                last_react[j] = t
                reactions[j] += 1
        watched = S[mode != 2] if (mode != 2).any() else S  # fly over the sharks still around
        to = np.mean(watched[:, :2], axis=0) - W[:2]
        dist_to = float(np.linalg.norm(to))
        if dist_to > 0:
            W[:2] += to * min(1.0, obs_drone.speed * Ts / dist_to)
        S, O = Sn, On
        contact_prev = contact
        ts.append(t + Ts)
        Ss.append(S.copy())
        Os.append(O.copy())
        Ms.append(mode.copy())
        Ws.append(W.copy())
        alarms.append(_alarm(t + Ts, S, mode))
        dist = np.linalg.norm(H[None] - S[:, None, :2], axis=2)
        if (dist.min(axis=1) < behaviour.bite_radius).any():
            attacked = True
            break
        if (dist.min(axis=1) > behaviour.safety_distance).all():
            break
    dist = np.linalg.norm(H[None] - S[:, None, :2], axis=2).min(axis=1)
    return RepellingTrace(
        np.array(ts),
        np.array(Ss),
        np.array(Os),
        np.array(Ms),
        reactions,
        ignored,
        attacked,
        dist > behaviour.safety_distance,
        ts[-1],
        seed if isinstance(seed, int) else None,
        observer=np.array(Ws),
        alarm=np.array(alarms),
        alerted_at=alerted_at,
        to_repel=sharks_to_repel(scenario.sharks0, H, len(O)),
    )
