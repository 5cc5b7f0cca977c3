"""2D incompressible wind around buildings on a staggered (MAC) grid.

``simulate(city, speed, direction_deg, dx, dt, ...)`` returns a :class:`FlowSolution` with
the time-averaged (and optionally recorded) cell-centred wind. The building blocks --
:class:`MACGrid`, :class:`BoundaryConditions`, :func:`make_domain`, :func:`make_flow_step`
with injected advection (:func:`make_advection`) and pressure projection
(:func:`make_exact_projection`, :func:`make_jacobi_projection`) -- and the Strouhal analysis
(:func:`strouhal_number`, :func:`square_cylinder_strouhal`) are public too.
"""

from windnav.flow.advection import make_advection
from windnav.flow.grid import BoundaryConditions, FlowDomain, MACGrid, make_domain
from windnav.flow.pressure import divergence, make_exact_projection, make_jacobi_projection
from windnav.flow.solver import (
    FlowDivergedError,
    FlowSolution,
    FlowStep,
    cell_centred,
    fixed_face_violation,
    make_flow_step,
    simulate,
)
from windnav.flow.strouhal import SquareCylinderCase, square_cylinder_strouhal, strouhal_number

__all__ = [
    "BoundaryConditions",
    "FlowDivergedError",
    "FlowDomain",
    "FlowSolution",
    "FlowStep",
    "MACGrid",
    "SquareCylinderCase",
    "cell_centred",
    "divergence",
    "fixed_face_violation",
    "make_advection",
    "make_domain",
    "make_exact_projection",
    "make_flow_step",
    "make_jacobi_projection",
    "simulate",
    "square_cylinder_strouhal",
    "strouhal_number",
]
