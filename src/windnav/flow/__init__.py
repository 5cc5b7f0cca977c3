"""2D incompressible wind around buildings on a staggered (MAC) grid.

``simulate(city, speed, direction_deg, dx, dt, ...)`` returns a :class:`FlowSolution` with
the time-averaged (and optionally recorded) cell-centred wind. The building blocks --
:class:`MACGrid`, :class:`BoundaryConditions`, :func:`make_domain`, :func:`make_flow_step`
with injected advection (:func:`make_advection`) and pressure projection
(:func:`make_exact_projection`, :func:`make_jacobi_projection`) -- and the Strouhal analysis
(:func:`strouhal_number`, :func:`square_cylinder_strouhal`) are public too.
:func:`averaging_verdict` says whether a solution's mean has converged (its half-window
difference, spin-up and window in flow-throughs), as ``windnav wind`` prints it.

On disk (Zarr v3): one solution with :func:`save_flow` / :func:`load_flow` / :func:`flow_attrs`
(:mod:`windnav.flow.solution_io`), a dataset of many with :class:`SweepStore` and
:class:`SweepMap` (:mod:`windnav.flow.sweep_store`). These are imported on first use, so that
``import windnav.flow`` does not load zarr.
"""

import importlib

from windnav.flow.advection import make_advection
from windnav.flow.grid import BoundaryConditions, FlowDomain, MACGrid, make_domain
from windnav.flow.memory import MemoryEstimateError, check_flow_memory, estimate_flow_memory
from windnav.flow.pressure import (
    FactorCache,
    divergence,
    make_exact_projection,
    make_jacobi_projection,
)
from windnav.flow.solver import (
    FlowDivergedError,
    FlowSolution,
    FlowStep,
    FrameBuffers,
    cell_centred,
    fixed_face_violation,
    make_flow_step,
    simulate,
    simulate_batch,
)
from windnav.flow.strouhal import (
    BluffBodyCase,
    SquareCylinderCase,
    bluff_body_strouhal,
    square_cylinder_strouhal,
    strouhal_number,
)
from windnav.flow.validity import averaging_verdict

# The Zarr I/O, imported on first access (PEP 562): name -> module.
_LAZY = {
    "CorruptStoreError": "_zarr",
    "VerifyReport": "sweep_store",
    "flow_attrs": "solution_io",
    "load_flow": "solution_io",
    "save_flow": "solution_io",
    "SweepMap": "sweep_store",
    "SweepStore": "sweep_store",
}

__all__ = [
    "BluffBodyCase",
    "BoundaryConditions",
    "CorruptStoreError",
    "FactorCache",
    "FlowDivergedError",
    "FlowDomain",
    "FlowSolution",
    "FlowStep",
    "FrameBuffers",
    "MACGrid",
    "MemoryEstimateError",
    "SquareCylinderCase",
    "SweepMap",
    "SweepStore",
    "VerifyReport",
    "averaging_verdict",
    "bluff_body_strouhal",
    "cell_centred",
    "check_flow_memory",
    "divergence",
    "estimate_flow_memory",
    "fixed_face_violation",
    "flow_attrs",
    "load_flow",
    "make_advection",
    "make_domain",
    "make_exact_projection",
    "make_flow_step",
    "make_jacobi_projection",
    "save_flow",
    "simulate",
    "simulate_batch",
    "square_cylinder_strouhal",
    "strouhal_number",
]


def __getattr__(name: str):
    if name in _LAZY:
        value = getattr(importlib.import_module(f"{__name__}.{_LAZY[name]}"), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__():
    return sorted(set(globals()) | set(__all__))
