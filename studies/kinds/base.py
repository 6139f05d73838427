"""What every instance kind is: the :class:`Kind` base class, :class:`Family` and the protocols a
kind is called with.

A kind says what an instance's data is and everything a study does with it, in one class:

- its *codec* (:meth:`Kind.encode` / :meth:`Kind.decode`: the data as JSON values and back, the
  instance-file format) and the data type it holds (:attr:`Kind.data_type`);
- its *sense* (``"max"`` or ``"min"``: which objective is better);
- its *method-call contract*: a static kind's methods are called with :meth:`Kind.arguments` and
  return a plan; a closed-loop kind's methods are controllers that :meth:`Kind.simulate` runs in the
  problem's simulator;
- :meth:`Kind.execute` (run a method on the data), :meth:`Kind.score` (droneplan's verdict on what
  it returned, never the method's word) and :meth:`Kind.certify` (the library entry of an instance);
- its *families* (:meth:`Kind.families`: the named, versioned generators of its instances).

This module sits below the instance layer: a kind receives the instance (:class:`InstanceLike`),
the method (:class:`MethodLike`) and, to certify, a way to run registered methods
(:class:`MethodRunner`) as arguments, so it imports none of the study engine above it.
"""

from __future__ import annotations

import abc
import dataclasses
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any, ClassVar, Protocol

import numpy as np

from droneplan.studies.scoring import Scored

__all__ = [
    "Kind",
    "Family",
    "InstanceLike",
    "MethodLike",
    "MethodRunner",
    "plain_array",
    "plain_plan",
    "certify_by_engine",
    "ClosedLoopKind",
]


@dataclass(frozen=True)
class Family:
    """A named, versioned instance generator.

    name: its name; problem, kind: what it makes; version: bumped whenever ``build`` would give
    other data for the same parameters; grid: the size parameters besides ``seed`` (e.g.
    ``("m",)``) with their defaults in ``defaults``; seeded: whether instances take a seed;
    build(**params): the data; describe: one line for docs and ``--help``.
    """

    name: str
    problem: str
    kind: str
    version: int
    grid: tuple[str, ...]
    defaults: Mapping[str, Sequence[Any]]
    build: Callable[..., Any]
    describe: str
    seeded: bool = True


class InstanceLike(Protocol):
    """What a kind reads of a study instance (:class:`~droneplan.studies.instances.StudyInstance`)."""

    @property
    def id(self) -> str: ...

    @property
    def kind(self) -> str: ...

    @property
    def data(self) -> Any: ...

    def fingerprint(self) -> str: ...


class MethodLike(Protocol):
    """What a kind reads of a study method (:class:`~droneplan.studies.methods.Method`)."""

    @property
    def name(self) -> str: ...

    @property
    def trusted_bound(self) -> bool: ...

    def call(self, *args: Any, seed: int, time_limit: float | None, **extra: Any) -> Any: ...


MethodRunner = Callable[[str, float | None], tuple[Any, Scored]]
"""Runs the registered method of that name on the instance being certified (with that time limit,
s) and returns what it returned and droneplan's verdict: how :meth:`Kind.certify` reaches the
registered methods without importing the study engine."""


def plain_array(a: Any) -> list:
    """An array as nested lists of floats (a codec's JSON values)."""
    return np.asarray(a, dtype=float).tolist()


class Kind(abc.ABC):
    """One instance kind (module docstring: what a kind holds). Subclasses set the class
    attributes and implement the methods their kind needs; one instance of each is registered
    in :data:`droneplan.studies.kinds.KINDS`."""

    name: ClassVar[str]
    """The kind's name (``StudyInstance.kind``, the ``kind`` of an instance file)."""
    problem: ClassVar[str]
    """The problem it belongs to: ``cells``, ``herding``, ``shark`` or ``covert``."""
    sense: ClassVar[str]
    """``"max"`` or ``"min"``: the direction in which its objective is better."""
    data_type: ClassVar[type | None] = None
    """The type of its data, by which a user's object is recognised (None: recognised by
    :meth:`holds`)."""
    closed_loop: ClassVar[bool] = False
    """True when its methods are controllers run in the problem's simulator; False when they
    return a plan."""
    default_methods: ClassVar[tuple[str, ...]] = ()
    """The registered methods a study of this kind runs when it is given none (empty: it must be
    given some)."""
    objective: ClassVar[str] = ""
    """What the objective is, with its unit (one line, for docs)."""
    exact_engine: ClassVar[str | None] = None
    """The registered exact engine that certifies an instance (:meth:`certify`'s default: the
    engine's scored plan, or the :attr:`baseline`'s when better and the engine does not prove)."""
    baseline: ClassVar[str | None] = None
    """The registered heuristic whose plan a certification keeps when it beats an unproven engine."""

    def holds(self, data: Any) -> bool:
        """Whether ``data`` is this kind's data (a user's own object, recognised by its type).

        data: any object.
        """
        return self.data_type is not None and isinstance(data, self.data_type)

    @abc.abstractmethod
    def encode(self, data: Any) -> dict | None:
        """The data as plain JSON values (None for kinds rebuilt from their family's parameters).

        data: this kind's data.
        """

    @abc.abstractmethod
    def decode(self, payload: Mapping[str, Any]) -> Any:
        """The data from :meth:`encode`'s JSON values (raises KeyError, TypeError or ValueError when
        they do not fit).

        payload: the decoded JSON object.
        """

    def size(self, data: Any) -> int:
        """The problem's main size (cells m, allocation n, drones of a herding run, targets; 1 for
        a shark path).

        data: this kind's data.
        """
        return 1

    def arguments(self, data: Any) -> tuple[Any, ...]:
        """The positional arguments a static kind's method is called with (arrays are copies): the
        data itself by default.

        data: this kind's data.
        """
        return (data,)

    def execute(
        self, data: Any, method: MethodLike, *, seed: int, time_limit: float | None, **extra: Any
    ) -> Any:
        """Run a static kind's ``method`` on ``data`` and return its raw return value.

        data: this kind's data. method: the study method. seed: the run's seed. time_limit: the
        method's wall-time limit (s; None: none). extra: the study's budgets the method names.
        """
        return method.call(*self.arguments(data), seed=seed, time_limit=time_limit, **extra)

    def warm_start(self, data: Any, plan: Any) -> Any:
        """A verified plan as the start an exact engine of this kind takes (``warm_start`` or hint):
        positions as a float array by default.

        data: this kind's data. plan: a plan that droneplan's scorer verified.
        """
        return np.asarray(plan, dtype=float)

    def simulate(self, data: Any, controller: Any, seed: int) -> dict[str, Any]:
        """A closed-loop kind's simulator metrics of one run of ``controller`` on ``data``.

        data: this kind's data. controller: a controller following the closed-loop contract
        (``droneplan.scenarios.loop.Controller``). seed: the run's seed.
        """
        raise ValueError(f"{self.name} methods return a plan; there is no simulator to run")

    @abc.abstractmethod
    def score(self, instance: InstanceLike, returned: Any, method: MethodLike) -> Scored:
        """Droneplan's verdict on what ``method`` returned for ``instance`` (a plan, or a closed-loop
        kind's simulator metrics).

        instance: the study instance. returned: the method's return value (static kinds) or
        :meth:`simulate`'s metrics. method: the study method (its ``trusted_bound`` decides whether
        a bound it returns is recorded).
        """

    def certify(
        self, instance: InstanceLike, *, time_limit: float | None, run: MethodRunner
    ) -> dict[str, Any]:
        """The certified-library fields of one instance (value, bound, bound_kind, status, sense,
        plan, engine, time_s, message); raises when the engine's plan does not verify. By default
        the kind's :attr:`exact_engine` (:func:`certify_by_engine`).

        instance: the study instance. time_limit: the engine's limit (s; None: none). run: runs a
        registered method on the instance (:data:`MethodRunner`).
        """
        if self.exact_engine is None or self.baseline is None:
            raise ValueError(f"no certification procedure for {self.name!r} instances")
        return certify_by_engine(
            self, instance, engine=self.exact_engine, baseline=self.baseline, time_limit=time_limit, run=run
        )

    def families(self) -> tuple[Family, ...]:
        """The named, versioned generators of this kind's instances."""
        return ()

    def family(
        self,
        name: str,
        version: int,
        grid: Mapping[str, Sequence[Any]],
        build: Callable[..., Any],
        describe: str,
        *,
        seeded: bool = True,
    ) -> Family:
        """A :class:`Family` of this kind (its problem and kind filled in).

        name: the family's name. version: its version. grid: the size parameters besides ``seed``
        with their default values. build: the generator. describe: one line. seeded: whether its
        instances take a seed.
        """
        return Family(name, self.problem, self.name, version, tuple(grid), grid, build, describe, seeded)

    def __repr__(self) -> str:
        return f"<kind {self.name!r} of {self.problem}>"


def plain_plan(plan: Any) -> Any:
    """A plan as JSON values: an array's nested lists, a dataclass (a fleet's ``Assignment``) as
    a dict of its fields' values.

    plan: an array-like, a dataclass instance, or a str, bool or None (kept as it is).
    """
    if dataclasses.is_dataclass(plan) and not isinstance(plan, type):
        return {f.name: plain_plan(getattr(plan, f.name)) for f in dataclasses.fields(plan)}
    if isinstance(plan, (str, bool, type(None))):
        return plan
    return np.asarray(plan, dtype=float).tolist()


def certify_by_engine(
    kind: Kind,
    instance: InstanceLike,
    *,
    engine: str,
    baseline: str,
    time_limit: float | None,
    run: MethodRunner,
) -> dict[str, Any]:
    """An instance's library fields from the kind's registered exact engine, its plan scored as a
    study scores it (so an entry holds what a study would score); when the engine does not prove
    its plan, the better of it and the baseline's.

    kind: the instance's kind (its sense). instance: the study instance. engine, baseline: names of
    registered methods of the kind. time_limit: each method's limit (s; None: none). run: runs a
    registered method on the instance (:data:`MethodRunner`).
    """
    from droneplan.solvers.result import SolveResult

    res, verdict = run(engine, time_limit)
    plan, described = res.x, f"{engine} ({res.backend}, workers=1)"
    if verdict.status != "optimal":  # the baseline may do better
        base, mine = run(baseline, time_limit)
        sign = 1.0 if kind.sense == "max" else -1.0
        if mine.objective is not None and (
            verdict.objective is None or sign * (mine.objective - verdict.objective) > 0
        ):
            bound = verdict.bound
            proven = bound is not None and sign * (mine.objective - bound) >= -1e-9
            verdict = dataclasses.replace(
                verdict, objective=mine.objective, status="optimal" if proven else "feasible"
            )
            plan = base.x if isinstance(base, SolveResult) else base
            described += f"; plan from {baseline}"
    if verdict.objective is None or verdict.status not in ("optimal", "feasible"):
        raise RuntimeError(
            f"{instance.id}: {engine} gave no verified plan ({verdict.status}: {verdict.message})"
        )
    return {
        "value": float(verdict.objective),
        "bound": verdict.bound,
        "bound_kind": verdict.bound_kind if verdict.bound is not None else "none",
        "status": "optimal" if verdict.status == "optimal" else "feasible",
        "sense": kind.sense,
        "plan": plain_plan(plan),
        "engine": described,
        "time_s": float(res.solve_time),
        "message": res.message,
    }


class ClosedLoopKind(Kind):
    """A kind whose methods are controllers that droneplan's simulator runs (the simulator runs in
    the study's process, the controller in a sandbox of its own): :meth:`score` reads the
    simulator's metrics, never the controller's word."""

    closed_loop = True
    metric: ClassVar[str]
    """The simulator metric that is the row's objective."""

    def arguments(self, data: Any) -> tuple[Any, ...]:
        """Refused: a closed-loop kind's methods are controllers, not called on data.

        data: this kind's data.
        """
        raise ValueError(f"{self.name} methods are controllers run in a simulator, not called on data")

    def score(self, instance: InstanceLike, returned: Any, method: MethodLike) -> Scored:
        """Droneplan's verdict on one simulated run: ``returned`` is :meth:`simulate`'s metrics, with
        ``controller_failed`` (and ``failure_status``) when the controller failed.

        instance: the study instance. returned: the metrics. method: the controller's method.
        """
        extras = {
            k: v for k, v in returned.items() if k not in (self.metric, "controller_failed", "failure_status")
        }
        if "controller_failed" in returned:
            status = "invalid" if returned.get("failure_status") == "invalid" else "error"
            return Scored(status, message=str(returned["controller_failed"]), extras=extras)
        return self.score_metrics(returned, extras)

    @abc.abstractmethod
    def score_metrics(self, metrics: Mapping[str, Any], extras: dict[str, Any]) -> Scored:
        """The verdict on a run whose controller answered every command.

        metrics: :meth:`simulate`'s metrics. extras: the metrics besides the objective (the row's
        extra columns).
        """
