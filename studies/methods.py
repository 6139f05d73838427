"""Methods of a gap study: the built-in ones by name and the user's own, under one contract per kind.

A method is what a study runs on each instance. Built-in methods and the user's are treated alike:
each is a :class:`Method` whose ``target`` follows the contract of the instance kind it runs on:

``cells``        ``fn(problem: CellProblem, *, seed, time_limit) -> positions (k, 2)`` in metres,
                 or a ``SolveResult`` whose ``x`` holds them
``cells-mobile`` ``fn(problem: MobileProblem, *, seed, time_limit) -> positions (T, k, w)``, drone-cell
                 i at ``[t, i]`` in epoch t (w = 2, or 3 with altitude levels), or a ``SolveResult``
``cells-fleet``  ``fn(problem: CellProblem, coverage, *, seed, time_limit) -> positions (k, 2)``: at
                 most ``problem.n_cells`` drone-cells covering ``coverage`` of the users' weight
``allocation``   ``fn(drone_s, steer_s, perimeter, *, seed, time_limit) -> (target, direction)``
                 (``target[j]``: index of drone j's steering point in ``steer_s`` padded as by
                 ``droneplan.herding.pad_steering_points``; ``direction[j]``: +1 towards
                 increasing arc length, counter-clockwise, or -1), or an ``Allocation``, or a
                 ``SolveResult`` whose ``x`` is one
``shark-fleet``  ``fn(operators, sharks_pos, sharks_vel, humans, *, seed, time_limit) -> (sharks,
                 operator)`` (``operator[k]``: index of the operator sent to shark ``sharks[k]``),
                 or an ``Assignment``, or a ``SolveResult`` whose ``x`` is one
``shark-path``, ``covert-run``, ``herding-run``
                 a controller class of the closed-loop contract (``reset(scenario, *, seed)``,
                 ``command(observation)``, ``phase``), instantiated without arguments for every run

Registered *bound engines* (``onsphere-optimum`` for covert runs, ``interception-bound`` for shark
paths) are the exception on closed-loop kinds: they are droneplan's own functions
``fn(scenario, *, seed, time_limit) -> {"status", "bound", "bound_kind", "message", "extras"}``
with role ``bound`` and ``trusted_bound``, whose row carries a proven bound and no objective.

A *warm-started composite* is spelled ``"ENGINE<HEURISTIC"`` (``"milp<ga"``, ``"bnb<mymod:fn"``,
``"cp-sat<alg3"``): ENGINE is one of droneplan's exact engines of the kind that takes a start
(:func:`warm_start_engines`: its registered target names a ``warm_start`` parameter), HEURISTIC any
method spelling but a composite. It resolves to a :class:`WarmStarted` method, which the study runs
as :func:`droneplan.studies.harness.run_warm_started` describes: the heuristic in a process of
its own, its plan verified by droneplan's evaluator, then the engine warm-started with it.

``seed`` is the instance's seed (0 when it has none) and ``time_limit`` the study's limit in
seconds; a function may ignore them but must accept them as keywords. ``Method.params`` are
passed on as further keywords (functions) or constructor arguments (classes) and are part of the
configuration hash of every row. A method is given as a registered name (``BUILTIN``), a
``"module:attribute"`` string, a function, a controller class, a ``(name, target)`` pair or a
:class:`Method`.
"""

from __future__ import annotations

import dataclasses
import importlib
import inspect
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from typing import Any

from droneplan.core.validation import check_time_limit
from droneplan.studies.kinds import KINDS

__all__ = [
    "Method",
    "BUILTIN",
    "DEFAULT_METHODS",
    "builtin_methods",
    "default_methods",
    "resolve_methods",
    "CLOSED_LOOP_KINDS",
    "RESERVED_NAMES",
    "WarmStarted",
    "COMPOSITE_SEPARATOR",
    "warm_start_engines",
    "warm_started",
]

COMPOSITE_SEPARATOR = "<"
"""What joins the engine and the heuristic of a warm-started composite (``"milp<ga"``)."""

CLOSED_LOOP_KINDS = tuple(name for name, kind in KINDS.items() if kind.closed_loop)
"""Instance kinds whose methods are controller classes run by the problem's simulator (a view of
the kind classes)."""


@dataclass(frozen=True)
class Method:
    """One method of a study.

    name: the row's ``method`` (unique within a study). target: the function or controller class
    (module docstring: the contract per kind). role: ``heuristic`` or ``model`` (``bound`` for the
    registered bound engines, which must have ``trusted_bound``). params: keyword
    arguments for the target, recorded in every row. kinds: the instance kinds it runs on (empty:
    decided by its contract, i.e. any kind that fits). trusted_bound: the method is one of
    droneplan's exact engines, whose proven bound is recorded as a bound (a user method's claimed
    bound is kept only as a claim). builtin: registered by droneplan. time_limit: the method's own
    wall-time limit in seconds, replacing the study's (None: the study's). deterministic: True when
    the same instance always gives the same plan whatever the seed (a study with ``runs > 1`` then
    runs it once), False for a seeded stochastic method (run ``runs`` times), None: not known (a
    study runs it twice and, when both plans agree, marks it deterministic and stops there).
    """

    name: str
    target: Any
    role: str = "heuristic"
    params: Mapping[str, Any] = field(default_factory=dict)
    kinds: tuple[str, ...] = ()
    trusted_bound: bool = False
    builtin: bool = False
    time_limit: float | None = None
    deterministic: bool | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name.strip() or "\n" in self.name:
            raise ValueError(f"a method name must be a non-empty one-line string, got {self.name!r}")
        if self.role not in ("heuristic", "model", "bound"):
            raise ValueError(f"method {self.name!r}: role must be 'heuristic' or 'model', got {self.role!r}")
        if self.role == "bound" and not self.trusted_bound:
            raise ValueError(f"method {self.name!r}: role 'bound' is for droneplan's exact engines only")
        if not callable(self.target):
            raise TypeError(
                f"method {self.name!r}: target must be a function or a class, got {self.target!r}"
            )
        if not isinstance(self.params, Mapping):
            raise TypeError(
                f"method {self.name!r}: params must be a mapping, got {type(self.params).__name__}"
            )
        limit = check_time_limit(self.time_limit, f"method {self.name!r} time_limit")
        object.__setattr__(self, "time_limit", limit)
        if self.deterministic is not None and not isinstance(self.deterministic, bool):
            raise TypeError(
                f"method {self.name!r}: deterministic must be True, False or None, got {self.deterministic!r}"
            )

    @property
    def is_bound_engine(self) -> bool:
        """True for a registered bound engine of a closed-loop kind (a function, not a controller)."""
        return self.builtin and self.trusted_bound and self.role == "bound"

    @property
    def is_class(self) -> bool:
        """True for a controller class (closed-loop methods)."""
        return inspect.isclass(self.target)

    def fingerprint(self) -> str:
        """What identifies this method's code: its qualified name and a hash (16 hex) of its source,
        its module and every module of the user's tree it imports
        (:func:`~droneplan.studies.method_hash.code_fingerprint`)."""
        from droneplan.studies.method_hash import code_fingerprint

        return code_fingerprint(self.target)

    def call(self, *args: Any, seed: int, time_limit: float | None, **extra: Any) -> Any:
        """Run the method's target with the contract's keywords, the study's ``extra`` keywords
        (``report``, ``cpu_limit``, ``max_evaluations``: only those it :meth:`accepts`) and
        ``params``."""
        return self.target(*args, seed=seed, time_limit=time_limit, **extra, **self.params)

    def accepts(self, keyword: str) -> bool:
        """Whether the target names ``keyword`` among its parameters (a ``**kwargs`` catch-all
        does not count: a method says which of the study's optional keywords it takes)."""
        try:
            parameters = inspect.signature(self.target).parameters
        except (TypeError, ValueError):
            return False
        found = parameters.get(keyword)
        named = (inspect.Parameter.KEYWORD_ONLY, inspect.Parameter.POSITIONAL_OR_KEYWORD)
        return found is not None and found.kind in named

    def controller(self) -> Any:
        """A new controller instance (closed-loop methods)."""
        return self.target(**self.params)


# --------------------------------------------------------------------------- built-ins
def _engine(name: str, target: Callable[..., Any], kinds: tuple[str, ...]) -> Method:
    """A built-in exact engine: role ``model``, its bound trusted, deterministic."""
    return Method(name, target, "model", kinds=kinds, trusted_bound=True, builtin=True, deterministic=True)


def _cells_ga(problem, *, seed, time_limit, max_evaluations=None, report=None):
    from droneplan.planners.cells import genetic

    return genetic(problem, seed=seed, max_evaluations=max_evaluations, report=report)


def _cells_ga_polished(problem, *, seed, time_limit):
    from droneplan.planners.cells import genetic_polished

    return genetic_polished(problem, seed=seed)


def _cells_exhaustive(problem, *, seed, time_limit, max_evaluations=None, report=None):
    from droneplan.planners.cells import exhaustive

    res = exhaustive(problem, time_limit=time_limit, max_evaluations=max_evaluations, report=report)
    return dataclasses.replace(res, info={**res.info, "evaluations": res.info["last_cell_searches"]})


def _cells_engine(engine: str) -> Callable[..., Any]:
    def run(problem, *, seed, time_limit, report=None, warm_start=None):
        from droneplan.formulations.cells import solve_exact

        return solve_exact(
            problem, engine=engine, time_limit=time_limit, workers=1, report=report, warm_start=warm_start
        )

    run.__name__ = run.__qualname__ = f"cells_{engine}"
    return run


def _cells_greedy(problem, *, seed, time_limit):
    from droneplan.formulations.cells import greedy_placement

    return greedy_placement(problem)


def _cells_joint(mp, *, seed, time_limit):
    from droneplan.formulations.cells import solve_mobile

    return solve_mobile(mp, time_limit=time_limit, workers=1)


def _cells_myopic(mp, *, seed, time_limit):
    from droneplan.formulations.cells import myopic

    return myopic(mp, time_limit=time_limit, workers=1)


def _cells_min_fleet(problem, coverage, *, seed, time_limit):
    from droneplan.formulations.cells import min_fleet

    return min_fleet(problem, coverage=coverage, time_limit=time_limit, workers=1)


def _cells_greedy_fleet(problem, coverage, *, seed, time_limit):
    """The greedy placement of 1, 2, ... drone-cells, the first that reaches the share (the
    largest allowed when none does)."""
    from droneplan.formulations.cells import evaluate, greedy_placement
    from droneplan.studies.kinds.cells import FleetSizeInstance

    need = FleetSizeInstance(problem, coverage).required_value
    plan = None
    for k in range(1, problem.n_cells + 1):
        plan = greedy_placement(problem.with_cells(k))
        if evaluate(problem, plan).value >= need - 1e-9 * max(1.0, need):
            break
    return plan


def _alloc_exact(d, s, M, *, seed, time_limit):
    from droneplan.formulations.herding import solve_allocation

    return solve_allocation(d, s, M)


def _alloc_cpsat(d, s, M, *, seed, time_limit, warm_start=None):
    from droneplan.formulations.herding import solve_allocation

    return solve_allocation(d, s, M, engine="cp-sat", time_limit=time_limit, warm_start=warm_start)


def _alloc_alg3(d, s, M, *, seed, time_limit):
    from droneplan.planners.herding import allocate_bruteforce

    return allocate_bruteforce(d, s, M)


def _alloc_blind(d, s, M, *, seed, time_limit):
    from droneplan.planners.herding import allocate_collision_blind

    return allocate_collision_blind(d, s, M)


def _fleet_bottleneck(operators, sharks_pos, sharks_vel, humans, *, seed, time_limit):
    import dataclasses

    from droneplan.planners.shark import allocate_operators

    res = allocate_operators(operators, sharks_pos, sharks_vel, humans)
    if res.bound is None:
        return res
    # CP-SAT rounds each time to the nearest ms: the unrounded optimum is at most 0.5 ms below its bound
    return dataclasses.replace(res, bound=res.bound - 0.5e-3)


def _fleet_greedy(operators, sharks_pos, sharks_vel, humans, *, seed, time_limit):
    from droneplan.planners.shark import allocate_operators

    return allocate_operators(operators, sharks_pos, sharks_vel, humans, greedy=True)


def _covert_onsphere(scenario, *, seed, time_limit):
    from droneplan.studies.bound_engines import onsphere_bounds

    return onsphere_bounds(scenario, seed=seed)


def _shark_interception_bound(scenario, *, seed, time_limit):
    from droneplan.studies.bound_engines import interception_bounds

    return interception_bounds(scenario, time_limit=time_limit)


def _controller(module: str, name: str) -> Callable[..., Any]:
    """A lazily imported controller class (so listing the built-ins imports no solver)."""

    def make(**kwargs: Any) -> Any:
        return getattr(importlib.import_module(module), name)(**kwargs)

    make.__name__ = make.__qualname__ = name
    make.__module__ = module
    make.lazy_class = (module, name)  # type: ignore[attr-defined]
    return make


_CONTROLLERS = (
    # registered name, planners module, controller class, role, instance kind
    ("virtual-shark", "shark", "VirtualSharkInterceptor", "heuristic", "shark-path"),
    ("classical-pursuit", "shark", "ClassicalPursuit", "heuristic", "shark-path"),
    ("ocp", "shark", "OCPInterceptor", "model", "shark-path"),
    ("sliding", "covert", "SlidingModeObserver", "heuristic", "covert-run"),
    ("hover", "covert", "HoverBenchmark", "heuristic", "covert-run"),
    ("mpc", "covert", "MPCObserver", "model", "covert-run"),
    ("mpc-safeguarded", "covert", "SafeguardedMPCObserver", "model", "covert-run"),
    ("proposed", "herding", "ProposedHerder", "heuristic", "herding-run"),
    ("benchmark", "herding", "BenchmarkHerder", "heuristic", "herding-run"),
)
_CELLS = ("cells",)
_MOBILE = ("cells-mobile",)
_FLEET_SIZE = ("cells-fleet",)
_ALLOC = ("allocation",)
_FLEET = ("shark-fleet",)

BUILTIN: dict[str, Method] = {
    m.name: m
    for m in (
        Method("ga", _cells_ga, kinds=_CELLS, builtin=True, deterministic=False),
        Method("ga-polished", _cells_ga_polished, kinds=_CELLS, builtin=True, deterministic=False),
        Method("exhaustive", _cells_exhaustive, kinds=_CELLS, builtin=True, deterministic=True),
        Method("greedy", _cells_greedy, kinds=_CELLS, builtin=True, deterministic=True),
        _engine("bnb", _cells_engine("bnb"), _CELLS),
        _engine("milp", _cells_engine("milp"), _CELLS),
        _engine("joint", _cells_joint, _MOBILE),
        Method("myopic", _cells_myopic, kinds=_MOBILE, builtin=True, deterministic=True),
        _engine("min-fleet", _cells_min_fleet, _FLEET_SIZE),
        Method("greedy-fleet", _cells_greedy_fleet, kinds=_FLEET_SIZE, builtin=True, deterministic=True),
        _engine("exact", _alloc_exact, _ALLOC),
        _engine("cp-sat", _alloc_cpsat, _ALLOC),
        Method("alg3", _alloc_alg3, kinds=_ALLOC, builtin=True, deterministic=True),
        Method("collision-blind", _alloc_blind, kinds=_ALLOC, builtin=True, deterministic=True),
        _engine("bottleneck", _fleet_bottleneck, _FLEET),
        Method("greedy-nearest", _fleet_greedy, kinds=_FLEET, builtin=True, deterministic=True),
        *(
            Method(name, _controller(f"droneplan.planners.{layer}", cls), role, kinds=(kind,), builtin=True)
            for name, layer, cls, role, kind in _CONTROLLERS
        ),
        Method(
            "onsphere-optimum",
            _covert_onsphere,
            "bound",
            kinds=("covert-run",),
            trusted_bound=True,
            builtin=True,
            deterministic=True,
        ),
        Method(
            "interception-bound",
            _shark_interception_bound,
            "bound",
            kinds=("shark-path",),
            trusted_bound=True,
            builtin=True,
            deterministic=True,
        ),
    )
}
"""The registered methods by name (``bnb`` is the cells branch and bound, ``milp`` the cells MILP;
``joint`` the joint model of moving users and ``myopic`` its epoch-by-epoch baseline; ``min-fleet``
the fewest drone-cells model and ``greedy-fleet`` the greedy placement grown until the share;
``exact`` the exact allocation algorithm; ``bottleneck`` the optimal operator-shark assignment
(CP-SAT) and ``greedy-nearest`` the nearest-free-operator baseline; ``onsphere-optimum`` and
``interception-bound`` the bound engines of covert runs and shark paths)."""

DEFAULT_METHODS: dict[str, tuple[str, ...]] = {
    name: kind.default_methods for name, kind in KINDS.items() if kind.default_methods
}
"""The registered methods a study of these kinds runs when it is given none (the built-in gap studies)."""


def default_methods(kind: str) -> list[str]:
    """The methods a study on instances of ``kind`` runs when given none (``DEFAULT_METHODS``).

    kind: an instance kind; one without defaults raises ValueError listing its registered methods.
    """
    defaults = KINDS[kind].default_methods if kind in KINDS else ()
    if not defaults:
        raise ValueError(
            f"methods: name at least one method; registered for {kind}: {', '.join(builtin_methods(kind))}"
        )
    return list(defaults)


def builtin_methods(kind: str) -> list[str]:
    """Names of the registered methods for instances of ``kind``."""
    return [n for n, m in BUILTIN.items() if kind in m.kinds]


# --------------------------------------------------------------------------- warm-started composites
def _composite_target(*args: Any, seed: int, time_limit: float | None) -> Any:
    """What a :class:`WarmStarted` method's ``target`` is: the study runs a composite through
    :func:`droneplan.studies.warm_starts.run_warm_started` (which needs the instance), never this."""
    raise TypeError(
        "a warm-started composite runs inside a study (droneplan.gap), which runs its heuristic "
        "in a process of its own and then its engine"
    )


@dataclass(frozen=True)
class WarmStarted(Method):
    """A composite ``"ENGINE<HEURISTIC"``: the heuristic's verified plan warm-starts the engine.

    engine: the registered exact engine (a :class:`Method` of :data:`BUILTIN` whose target names a
    ``warm_start`` parameter). heuristic: the method whose plan is the start (any method of the
    kind but a composite). The other fields are set by :func:`warm_started`: the name
    ``"ENGINE<HEURISTIC"``, role ``model``, the engine's trusted bound, ``builtin`` when the
    heuristic is droneplan's, and the heuristic's ``deterministic``.
    """

    engine: Method | None = None
    heuristic: Method | None = None

    def __post_init__(self) -> None:
        super().__post_init__()
        for part in ("engine", "heuristic"):
            if not isinstance(getattr(self, part), Method):
                raise TypeError(f"method {self.name!r}: {part} must be a Method")
        if isinstance(self.heuristic, WarmStarted):
            raise ValueError(f"method {self.name!r}: a composite's heuristic cannot be a composite")

    def fingerprint(self) -> str:
        """Both parts' code fingerprints, ``"ENGINE<HEURISTIC"`` (a change to either part gives the
        rows a new configuration; the code joining them is droneplan's, in every row's hash)."""
        if self.engine is None or self.heuristic is None:  # refused by __post_init__
            raise ValueError(f"method {self.name!r}: a composite needs an engine and a heuristic")
        return COMPOSITE_SEPARATOR.join((self.engine.fingerprint(), self.heuristic.fingerprint()))


def warm_start_engines(kind: str) -> list[str]:
    """Names of the registered exact engines of ``kind`` that take a warm start (their target names a
    ``warm_start`` parameter): ``bnb`` and ``milp`` on cells, ``cp-sat`` on the herding allocation.

    kind: an instance kind (a kind without such an engine gives an empty list).
    """
    return [n for n, m in BUILTIN.items() if kind in m.kinds and m.trusted_bound and m.accepts("warm_start")]


def warm_started(spec: str, kind: str) -> WarmStarted:
    """The composite method spelled ``spec`` (``"ENGINE<HEURISTIC"``) for instances of ``kind``.

    spec: the engine's registered name, ``<``, then the heuristic (a registered name or
        ``"module:function"``); e.g. ``"milp<ga"``, ``"bnb<mymod:fn"``, ``"cp-sat<alg3"``.
    kind: the instance kind the study runs on.

    An unknown or unsuitable part raises a one-line ValueError naming it and the valid choices.
    """
    if not isinstance(spec, str):
        raise TypeError(f"a composite method is a string 'ENGINE<HEURISTIC', got {type(spec).__name__}")
    engine_name, _, heuristic_spec = (p.strip() for p in spec.partition(COMPOSITE_SEPARATOR))
    engines = warm_start_engines(kind)
    choices = ", ".join(engines) or f"none (no engine of {kind} instances takes a warm start)"
    if engine_name not in engines:
        raise ValueError(
            f"method {spec!r}: {engine_name!r} is not an exact engine of {kind} instances that takes "
            f"a warm start; engines: {choices}"
        )
    heuristics = [n for n in builtin_methods(kind) if not BUILTIN[n].trusted_bound]
    if not heuristic_spec or COMPOSITE_SEPARATOR in heuristic_spec:
        raise ValueError(
            f"method {spec!r}: write 'ENGINE<HEURISTIC' with one heuristic (a registered name or "
            f"'module:function'); heuristics of {kind}: {', '.join(heuristics) or 'none'}"
        )
    if heuristic_spec in BUILTIN:
        heuristic = BUILTIN[heuristic_spec]
        if heuristic.kinds and kind not in heuristic.kinds:
            raise ValueError(
                f"method {spec!r}: heuristic {heuristic_spec!r} runs on {', '.join(heuristic.kinds)} "
                f"instances, not on {kind}; heuristics of {kind}: {', '.join(heuristics) or 'none'}"
            )
    elif ":" in heuristic_spec:
        heuristic = Method(heuristic_spec, _import_target(heuristic_spec))
    else:
        raise ValueError(
            f"method {spec!r}: unknown heuristic {heuristic_spec!r}; heuristics of {kind}: "
            f"{', '.join(heuristics) or 'none'} (or 'module:function')"
        )
    return _composite(BUILTIN[engine_name], heuristic)


def _composite(engine: Method, heuristic: Method) -> WarmStarted:
    return WarmStarted(
        f"{engine.name}{COMPOSITE_SEPARATOR}{heuristic.name}",
        _composite_target,
        "model",
        kinds=engine.kinds,
        trusted_bound=True,
        builtin=heuristic.builtin,
        deterministic=heuristic.deterministic,
        engine=engine,
        heuristic=heuristic,
    )


def _import_target(spec: str) -> Any:
    mod, _, attr = spec.partition(":")
    if not mod or not attr:
        raise ValueError(f"method {spec!r}: write a user method as 'module:function' (or a registered name)")
    try:
        obj: Any = importlib.import_module(mod)
    except ImportError as exc:
        raise ValueError(f"method {spec!r}: cannot import module {mod!r} ({exc})") from None
    except Exception as exc:  # noqa: BLE001 - the user's module raised while it was imported
        why = " ".join(str(exc).split())[:200]
        raise ValueError(
            f"method {spec!r}: importing module {mod!r} raised {type(exc).__name__}"
            + (f": {why}" if why else "")
        ) from None
    for part in attr.split("."):
        try:
            obj = getattr(obj, part)
        except AttributeError:
            raise ValueError(f"method {spec!r}: module {mod!r} has no attribute {attr!r}") from None
    return obj


def _one(entry: Any, kind: str, position: int) -> Method:
    if isinstance(entry, Method):
        return entry
    if isinstance(entry, tuple) and len(entry) == 2 and isinstance(entry[0], str):
        name, target = entry
        return _one(target, kind, position) if isinstance(target, Method) else Method(name, target)
    if isinstance(entry, str):
        if entry in BUILTIN:
            return BUILTIN[entry]
        if COMPOSITE_SEPARATOR in entry:
            return warm_started(entry, kind)
        if ":" in entry:
            return Method(entry, _import_target(entry))
        raise ValueError(
            f"unknown method {entry!r}; registered for {kind}: {', '.join(builtin_methods(kind)) or 'none'} "
            "(or give 'module:function', a function or a controller class)"
        )
    if callable(entry):
        name = getattr(entry, "__name__", "") or type(entry).__name__
        if name == "<lambda>":
            name = f"lambda-{position}"
        return Method(name, entry)
    raise TypeError(
        f"methods[{position}] must be a name, 'module:function', a function or a class, got {entry!r}"
    )


def resolve_methods(kind: str, methods: Any) -> list[Method]:
    """The study's methods for instances of ``kind``, each checked against that kind's contract.

    methods: one method or a list of them (module docstring: the accepted forms), or a mapping
    ``{name: target}``; None: the kind's ``DEFAULT_METHODS`` (an error for kinds without them).
    """
    entries = _method_entries(kind, methods)
    if not entries:
        raise ValueError("methods must not be empty")
    out = [_one(e, kind, i) for i, e in enumerate(entries)]
    for m in out:
        _check_not_forged(m)
    names = [m.name for m in out]
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise ValueError(f"methods repeat names {dup}: give each a name, e.g. ('mine-2', fn)")
    for m in out:
        if m.kinds and kind not in m.kinds:
            raise ValueError(
                f"method {m.name!r} runs on {', '.join(m.kinds)} instances, not on {kind!r} instances"
            )
        closed = kind in KINDS and KINDS[kind].closed_loop
        lazy = hasattr(m.target, "lazy_class")
        if closed and not (m.is_class or lazy or m.is_bound_engine):
            raise TypeError(f"method {m.name!r}: {kind} instances take a controller class, got {m.target!r}")
        if not closed and m.is_class:
            raise TypeError(
                f"method {m.name!r}: {kind} instances take a function, got the class {m.target.__name__}"
            )
    return out


RESERVED_NAMES = ("library", "reference", "task")
"""Method names droneplan's own rows use (the certified reference row, a reference solved for a
study, a built-in study's error row)."""


def _check_not_forged(m: Method) -> None:
    """Only droneplan's registered methods carry a built-in name, ``builtin``, ``trusted_bound`` or
    role ``bound``: a user's method states no proof and takes no name of droneplan's."""
    if isinstance(m, WarmStarted):
        _check_composite(m)
        return
    registered = BUILTIN.get(m.name)
    if registered is not None:
        same = (m.target, m.role, m.kinds, m.trusted_bound, m.builtin) == (
            registered.target,
            registered.role,
            registered.kinds,
            registered.trusted_bound,
            registered.builtin,
        )
        if not same:
            raise ValueError(
                f"method name {m.name!r} is reserved for droneplan's registered method; name yours "
                f"otherwise, e.g. ('my-{m.name}', fn)"
            )
        return
    if m.name in RESERVED_NAMES:
        raise ValueError(f"method name {m.name!r} is reserved for droneplan's own rows; name yours otherwise")
    if m.builtin or m.trusted_bound or m.role == "bound":
        raise ValueError(
            f"method {m.name!r}: builtin, trusted_bound and role 'bound' are droneplan's registered "
            "engines' alone; a user's method states no proof (a bound it returns is kept as a claim)"
        )


def _check_composite(m: WarmStarted) -> None:
    """A composite is trusted for its engine's bound only when it is what :func:`warm_started` builds:
    a registered engine that takes a start, and a heuristic that itself forges nothing."""
    engine, heuristic = m.engine, m.heuristic
    if engine is None or heuristic is None:  # refused by WarmStarted itself; kept for the type checker
        raise ValueError(f"method {m.name!r}: a composite needs an engine and a heuristic")
    registered = BUILTIN.get(engine.name)
    if registered is None or registered != engine or not engine.accepts("warm_start"):
        raise ValueError(
            f"method {m.name!r}: a composite's engine must be one of droneplan's registered engines "
            "that take a warm start"
        )
    _check_not_forged(heuristic)
    if m != _composite(engine, heuristic):
        raise ValueError(
            f"method {m.name!r}: build a composite with warm_started('ENGINE<HEURISTIC', kind) or spell "
            "it so in the methods list"
        )


def _method_entries(kind: str, methods: Any) -> list[Any]:
    """:func:`resolve_methods`'s ``methods`` as a list of single entries (None: the kind's defaults)."""
    if methods is None:
        methods = default_methods(kind)
    if isinstance(methods, Mapping):
        return list(methods.items())
    if isinstance(methods, (str, Method, tuple)) or callable(methods):
        return [methods]
    if isinstance(methods, Iterable):
        return list(methods)
    raise TypeError(
        "methods must be a method (a registered name, 'module:function', a function or class, "
        f"a (name, method) pair) or a list or mapping of them, got {type(methods).__name__}"
    )


def check_study_time_limit(time_limit: Any) -> float | None:
    """A study's per-method time limit (s): None or a finite number > 0."""
    return check_time_limit(time_limit)
