"""The one adapter shape every backend follows, and the helper that runs a native solve.

An adapter is a :class:`BackendAdapter` subclass with a ``name``, an explicit
``status_map`` from the backend's native status codes to :class:`Status` (a code
missing from it maps to ERROR), the packages it ``requires`` (imported inside its
methods, never at the top of its module) and one or more *capabilities*, each an
abstract mixin below that fixes what a formulation may ask of it (the class attribute
``kinds`` lists them):

=============== ==================================== ==========================================
kind            mixin                                what the formulation gets
=============== ==================================== ==========================================
``"linear"``    :class:`LinearBackend`               ``new_model()``: an empty
                                                     :class:`~droneplan.solvers.linear.LinearModel`
``"cp"``        :class:`CpBackend`                   ``solve_cp(model, ...)``: a native CP-SAT model solved
``"nlp"``       :class:`NlpBackend`                  ``create_nlp(nlp, ...)``: an :class:`NlpSolver`
``"qp"``        :class:`QpBackend`                   ``create_qp(P, q, A, l, u, ...)``: a QP solver
=============== ==================================== ==========================================

Every adapter runs its native call through :func:`run_native`, which times it, turns
an exception into an ERROR result, maps the native code through the adapter's
``status_map`` and builds the :class:`SolveResult`; the adapter only reads the
solution back (:class:`NativeReadout`). Adapters are quiet by default: solver output
reaches stdout only when the caller passes ``verbose=True``.
"""

from __future__ import annotations

import abc
import importlib.util
import time
from collections.abc import Callable, Hashable, Mapping
from dataclasses import dataclass, field
from typing import Any, ClassVar, Protocol

from droneplan.solvers.result import SolveResult, Status, map_status

__all__ = [
    "BackendAdapter",
    "LinearBackend",
    "CpBackend",
    "NlpBackend",
    "NlpSolver",
    "QpBackend",
    "NativeReadout",
    "run_native",
    "KINDS",
    "missing_packages_reason",
]

KINDS = ("linear", "cp", "nlp", "qp")
"""The capabilities an adapter can offer (see the module docstring)."""


class BackendAdapter(abc.ABC):
    """Base of every backend adapter: a name, a status map, the kinds it serves."""

    name: ClassVar[str]
    """Registry name, e.g. "cp-sat", "highs", "ipopt"."""
    status_map: ClassVar[Mapping[Any, Status]]
    """Native status code -> Status; a code not in it maps to ERROR."""
    description: ClassVar[str] = ""
    """One line for listings: library and algorithm."""
    kinds: ClassVar[frozenset[str]] = frozenset()
    """The capabilities (``KINDS``) this adapter implements: set on each subclass from the
    capability mixins it inherits, so the class itself answers without an instance."""
    requires: ClassVar[tuple[str, ...]] = ()
    """The top-level Python packages the adapter needs (e.g. ``("ortools",)``). An adapter
    imports them inside its methods, so its module and its listing load none of them."""

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        cls.kinds = frozenset(kind for kind, mixin in _MIXINS.items() if issubclass(cls, mixin))

    install_hint: ClassVar[str] = ""
    """How to install what ``requires`` lists, for the reason a missing backend is not listed
    (e.g. ``pip install "droneplan[scip]"``; empty: the packages are core dependencies)."""

    @classmethod
    def missing_requirements(cls) -> list[str]:
        """The packages of ``requires`` that are not on the path (looked up, not imported)."""
        return [package for package in cls.requires if importlib.util.find_spec(package) is None]

    @classmethod
    def requires_installed(cls) -> bool:
        """True when every package of ``requires`` is on the path (looked up, not imported)."""
        return not cls.missing_requirements()

    def is_available(self) -> bool:
        """True when the backend can run in this installation (library present, licensed);
        by default, when the packages of ``requires`` are installed."""
        return self.requires_installed()

    def unavailable_reason(self) -> str:
        """Why the backend cannot run here, in one line ("" when it can). By default it names
        the missing packages of ``requires``; an adapter with a further check (a licence)
        overrides it."""
        return missing_packages_reason(type(self)) if not self.is_available() else ""

    def map_status(self, code: Hashable) -> Status:
        """The Status of a native ``code`` through ``status_map`` (unknown: ERROR)."""
        try:
            return map_status(code, self.status_map)
        except TypeError:  # an unhashable code is unknown too
            return Status.ERROR

    def status_name(self, code: Hashable) -> str:
        """The native code as text for ``SolveResult.backend_status``."""
        return str(code)

    def __repr__(self) -> str:
        return f"<{type(self).__name__} {self.name!r} kinds={sorted(self.kinds)}>"


def missing_packages_reason(cls: type[BackendAdapter]) -> str:
    """The reason the adapter class ``cls`` cannot run when packages of its ``requires`` are
    missing ("" when none is, though a further check of ``is_available`` may still fail)."""
    missing = cls.missing_requirements()
    if not missing:
        return ""
    how = f" (install: {cls.install_hint})" if cls.install_hint else ""
    return f"needs the Python package{'s' if len(missing) > 1 else ''} {', '.join(missing)}{how}"


class LinearBackend(abc.ABC):
    """Capability "linear": builds :class:`~droneplan.solvers.linear.LinearModel` objects."""

    @abc.abstractmethod
    def new_model(self) -> Any:
        """An empty LinearModel of this backend for a formulation to fill."""


class CpBackend(abc.ABC):
    """Capability "cp": solves a native OR-Tools ``cp_model.CpModel``."""

    @abc.abstractmethod
    def solve_cp(
        self,
        model: Any,
        *,
        variables: Any = (),
        time_limit: float | None = None,
        workers: int | None = None,
        hint: Mapping[Any, int] | None = None,
        verbose: bool = False,
        seed: int | None = None,
        parameters: Mapping[str, Any] | None = None,
    ) -> SolveResult:
        """Solve ``model``; ``x`` holds the values of ``variables``; ``parameters`` are the
        backend's own."""


class NlpSolver(Protocol):
    """A nonlinear program set up once and re-solved with new numbers (see NlpBackend)."""

    def solve(
        self,
        *,
        x0: Any = None,
        lbx: Any = None,
        ubx: Any = None,
        lbg: Any = None,
        ubg: Any = None,
        p: Any = None,
        warm_start: SolveResult | None = None,
        time_limit: float | None = None,
        project: Callable[[Any], Any] | None = None,
    ) -> SolveResult:
        """Solve from ``x0``; ``warm_start`` is a previous result of the same solver.

        project: a map of iterates onto points the caller knows are good (e.g. states
        re-simulated from the commands); methods that iterate outside the backend (SQP)
        apply it to ``x0`` and after every step, others ignore it."""


class NlpBackend(abc.ABC):
    """Capability "nlp": turns a CasADi NLP ``{x, f, g, p}`` into an :class:`NlpSolver`.

    ``options`` are the backend's own options (a formulation keeps them in a table
    keyed by backend name, never in an ``if``); ``structure`` holds optional hints
    that only methods that linearise use (see :class:`droneplan.solvers.sqp.SqpStructure`).
    """

    reuses_duals: ClassVar[bool] = False
    """True when ``warm_start`` hands a previous solution's duals back to the backend, so a
    caller should pass a previous result (and may set a lower iteration limit for such solves)."""
    solves_to_local_optimum: ClassVar[bool] = False
    """True when a solve iterates until a local optimum (KKT point), so restarting from
    another point can find a better one; False for a fixed number of linearised steps."""

    @abc.abstractmethod
    def create_nlp(
        self,
        nlp: Mapping[str, Any],
        *,
        options: Mapping[str, Any] | None = None,
        structure: Any = None,
        time_limit: float | None = None,
        verbose: bool = False,
    ) -> NlpSolver:
        """A solver for ``nlp``."""


class QpBackend(abc.ABC):
    """Capability "qp": a convex QP ``min 1/2 x'Px + q'x s.t. l <= Ax <= u`` set up once."""

    @abc.abstractmethod
    def create_qp(
        self,
        P: Any,
        q: Any,
        A: Any,
        l: Any,
        u: Any,
        *,
        settings: Mapping[str, Any] | None = None,
        time_limit: float | None = None,
        verbose: bool = False,
    ) -> Any:
        """A QP solver with ``update(...)`` and ``solve(warm_start=...)``."""


_MIXINS: dict[str, type] = {"linear": LinearBackend, "cp": CpBackend, "nlp": NlpBackend, "qp": QpBackend}


@dataclass
class NativeReadout:
    """What an adapter reads back after its native call (everything but timing and status mapping)."""

    objective: float | None = None
    bound: float | None = None
    x: Any = None
    iterations: int | None = None
    message: str = ""
    info: Mapping[str, Any] = field(default_factory=dict)
    status: Status | None = None
    """Replaces the mapped status when the adapter knows better (e.g. a limit status whose
    point is infeasible); the adapter documents each such rule."""
    backend_status: str | None = None
    """Replaces ``adapter.status_name(code)`` as the raw status text."""


def run_native(
    adapter: BackendAdapter,
    call: Callable[[], tuple[Any, Any]],
    read: Callable[[Any, Any, Status, float], NativeReadout],
    *,
    warm_started: bool = False,
    backend: str | None = None,
) -> SolveResult:
    """Run ``call`` timed and build the SolveResult (the one place where this happens).

    call: performs the native solve; returns ``(native status code, payload)``.
    read: ``read(code, payload, mapped_status, elapsed_s)`` reads the solution back.
    warm_started: whether a warm start was handed to the backend.
    backend: the name in the result (default ``adapter.name``).

    An exception raised by ``call`` gives an ERROR result with the exception in
    ``message`` (a backend failure is a status, not a crash); misuse is checked by
    the adapter before calling this.
    """
    name = adapter.name if backend is None else backend
    t0 = time.perf_counter()
    try:
        code, payload = call()
    except Exception as exc:  # noqa: BLE001 - a backend failure is a status, never a result that looks valid
        return SolveResult(
            Status.ERROR,
            backend=name,
            backend_status="exception",
            message=f"{name} raised {exc!r}",
            solve_time=time.perf_counter() - t0,
            warm_started=warm_started,
        )
    elapsed = time.perf_counter() - t0
    status = adapter.map_status(code)
    out = read(code, payload, status, elapsed)
    final = status if out.status is None else out.status
    return SolveResult(
        status=final,
        objective=out.objective,
        bound=out.bound,
        x=out.x,
        backend=name,
        backend_status=adapter.status_name(code) if out.backend_status is None else out.backend_status,
        message=out.message,
        solve_time=elapsed,
        iterations=out.iterations,
        warm_started=warm_started,
        info=dict(out.info),
    )
