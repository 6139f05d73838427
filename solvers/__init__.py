"""Backend adapters under one result contract, found by name in a registry. Knows nothing of drones.

- :mod:`~droneplan.solvers.result`: ``SolveResult``, ``Status``, ``map_status``.
- :mod:`~droneplan.solvers.base`: the adapter shape (``BackendAdapter`` and the capability
  mixins) and ``run_native``, the one helper that times a native call, maps its status and
  builds the ``SolveResult``.
- :mod:`~droneplan.solvers.registry`: ``get_backend``, ``register_backend``, ``available_backends``.
- :mod:`~droneplan.solvers.linear`: ``LinearModel``, one builder for CP-SAT and MIP backends.
- adapters: ``cpsat`` (CP-SAT), ``mip`` (HiGHS, SCIP via pywraplp), ``scip`` (SCIP via pyscipopt,
  extra ``scip``), ``gurobi`` (Gurobi via gurobipy, extra ``gurobi``), ``nlp`` (IPOPT via CasADi),
  ``qp`` (OSQP); ``native_mip`` holds the status rules of the two optional MIP adapters.
"""

from droneplan.solvers.base import BackendAdapter, NativeReadout, run_native
from droneplan.solvers.linear import LinearModel
from droneplan.solvers.registry import (
    available_backends,
    get_backend,
    register_backend,
    registered_backends,
    unavailable_backends,
    unregister_backend,
)
from droneplan.solvers.result import SolveResult, Status, map_status

__all__ = [
    "BackendAdapter",
    "LinearModel",
    "NativeReadout",
    "SolveResult",
    "Status",
    "available_backends",
    "get_backend",
    "map_status",
    "register_backend",
    "registered_backends",
    "run_native",
    "unavailable_backends",
    "unregister_backend",
]
