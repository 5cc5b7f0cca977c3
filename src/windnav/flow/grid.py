"""Staggered (MAC) grid, boundary conditions and the face classification of a flow domain.

Layout follows Harlow & Welch (1965) and the jax-cfd ``Grid``: a frozen value holding the
cell-count ``shape = (ny, nx)``, the spacing ``dx`` (square cells, m) and the ``origin``
(x, y) of the lower-left corner (m). Pressure lives at cell centres, ``u`` on the x-faces
``(ny, nx + 1)`` and ``v`` on the y-faces ``(ny + 1, nx)``.

Every face is one of three kinds (``FACE_FIXED``, ``FACE_INTERIOR``, ``FACE_OUTFLOW``):

* fixed: the normal velocity is prescribed -- zero on a face touching a building cell or a
  wall, the inlet's normal component on an inflow boundary;
* interior: between two fluid cells, updated by advection and projection;
* outflow: on an outflow boundary next to a fluid cell; advected (convective outflow) and
  corrected with the Dirichlet condition ``p = 0`` on the face (ghost ``p = -p_cell``).

Fluid pockets that cannot reach an outflow boundary (a courtyard closed by buildings) carry
no flow in an incompressible fluid; when the domain has an outflow side they are filled (made
solid) so the pressure problem stays non-singular. A domain without outflow (a closed box) is
kept as is and its pressure is pinned in one cell per connected component.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from windnav.city.core import grid_shape

FACE_FIXED = 0
FACE_INTERIOR = 1
FACE_OUTFLOW = 2

SIDE_KINDS = ("inflow", "outflow", "wall")
SIDE_NAMES = ("x_min", "x_max", "y_min", "y_max")


@dataclass(frozen=True)
class MACGrid:
    """A uniform staggered grid of square cells.

    Attributes
    ----------
    shape : tuple of 2 int
        ``(ny, nx)`` number of cells.
    dx : float
        Cell size, m.
    origin : tuple of 2 float
        ``(x, y)`` of the lower-left corner, m.
    """

    shape: tuple
    dx: float
    origin: tuple = (0.0, 0.0)

    def __post_init__(self):
        shape = tuple(int(s) for s in self.shape)
        if len(shape) != 2 or min(shape) < 2:
            raise ValueError(
                f"The 'shape' parameter of MACGrid must be (ny, nx) with both >= 2. "
                f"Got {self.shape!r} instead."
            )
        dx = float(self.dx)
        if not np.isfinite(dx) or dx <= 0:
            raise ValueError(
                "The 'dx' parameter of MACGrid must be a finite number > 0. "
                f"Got {self.dx!r} instead."
            )
        origin = tuple(float(o) for o in self.origin)
        object.__setattr__(self, "shape", shape)
        object.__setattr__(self, "dx", dx)
        object.__setattr__(self, "origin", origin)

    @property
    def ny(self) -> int:
        return self.shape[0]

    @property
    def nx(self) -> int:
        return self.shape[1]

    @property
    def x(self) -> np.ndarray:
        """Cell-centre x coordinates, shape (nx,), m."""
        return self.origin[0] + (np.arange(self.nx) + 0.5) * self.dx

    @property
    def y(self) -> np.ndarray:
        """Cell-centre y coordinates, shape (ny,), m."""
        return self.origin[1] + (np.arange(self.ny) + 0.5) * self.dx

    @property
    def x_faces(self) -> np.ndarray:
        """x coordinates of the x-faces (where ``u`` lives), shape (nx + 1,), m."""
        return self.origin[0] + np.arange(self.nx + 1) * self.dx

    @property
    def y_faces(self) -> np.ndarray:
        """y coordinates of the y-faces (where ``v`` lives), shape (ny + 1,), m."""
        return self.origin[1] + np.arange(self.ny + 1) * self.dx

    def check_u(self, u: np.ndarray, name: str = "u") -> None:
        """Raise a ValueError naming ``name`` unless ``u`` has the x-face shape (ny, nx + 1)."""
        _check_shape(u, (self.ny, self.nx + 1), name)

    def check_v(self, v: np.ndarray, name: str = "v") -> None:
        """Raise a ValueError naming ``name`` unless ``v`` has the y-face shape (ny + 1, nx)."""
        _check_shape(v, (self.ny + 1, self.nx), name)


def grid_for(bounds, dx: float) -> MACGrid:
    """The grid the solver puts on a map: square cells of side ``dx`` (m) from the lower-left
    corner of ``bounds = (x0, x1, y0, y1)`` (m), as many as :func:`windnav.city.grid_shape`
    gives (the one rule shared with :meth:`City.grid <windnav.city.City.grid>`, the sweeps and
    the planners: the grid covers the map, the last cell reaching past the bound when the
    extent is not a multiple of ``dx``)."""
    x0, _, y0, _ = (float(b) for b in bounds)
    return MACGrid(grid_shape(bounds, dx), dx, (x0, y0))


def _check_shape(a, want, name):
    if np.shape(a) != want:
        raise ValueError(
            f"The {name!r} field must live on faces of shape {want}. Got {np.shape(a)} instead."
        )


@dataclass(frozen=True)
class BoundaryConditions:
    """Kinds of the four domain sides and the inlet velocity.

    Attributes
    ----------
    sides : tuple of 4 str
        Kind of the ``(x_min, x_max, y_min, y_max)`` sides: ``"inflow"`` (velocity fixed to
        ``inflow_velocity``; samples beyond it read the inlet), ``"outflow"`` (``p = 0``,
        zero-gradient velocity) or ``"wall"`` (free slip: zero normal velocity).
    inflow_velocity : tuple of 2 float
        ``(u, v)`` of the uniform inlet, m/s.
    """

    sides: tuple = ("inflow", "outflow", "inflow", "inflow")
    inflow_velocity: tuple = (0.0, 0.0)

    def __post_init__(self):
        sides = tuple(str(s) for s in self.sides)
        if len(sides) != 4 or any(s not in SIDE_KINDS for s in sides):
            raise ValueError(
                f"The 'sides' parameter of BoundaryConditions must be 4 of {SIDE_KINDS}. "
                f"Got {self.sides!r} instead."
            )
        vel = tuple(float(c) for c in self.inflow_velocity)
        if len(vel) != 2 or not np.all(np.isfinite(vel)):
            raise ValueError(
                "The 'inflow_velocity' parameter of BoundaryConditions must be 2 finite numbers. "
                f"Got {self.inflow_velocity!r} instead."
            )
        object.__setattr__(self, "sides", sides)
        object.__setattr__(self, "inflow_velocity", vel)

    @classmethod
    def for_wind(cls, speed: float, direction_deg: float) -> BoundaryConditions:
        """Inlet on the upwind sides, outflow on the downwind ones.

        ``direction_deg`` is the direction the wind blows toward, counter-clockwise from +x.
        A side is an inlet when the wind's inward normal component is >= 0, so sides parallel
        to the wind are far-field inlets (zero normal velocity, free-stream tangential value).
        """
        theta = np.deg2rad(direction_deg)
        ux, uy = speed * np.cos(theta), speed * np.sin(theta)
        tol = 1e-9 * max(abs(speed), 1e-300)
        inward = (ux, -ux, uy, -uy)
        sides = tuple("inflow" if c >= -tol else "outflow" for c in inward)
        # exact zeros keep the parallel sides free of round-off inflow (cos(90 deg) = 6e-17)
        ux = 0.0 if abs(ux) <= tol else ux
        uy = 0.0 if abs(uy) <= tol else uy
        return cls(sides=sides, inflow_velocity=(ux, uy))


@dataclass(frozen=True, eq=False)
class FlowDomain:
    """A grid, its solid cells and its boundary conditions, with every face classified.

    Build it with :func:`make_domain`.

    Attributes
    ----------
    grid : MACGrid
    solid : ndarray of bool, shape (ny, nx)
        Building cells (after filling unreachable pockets).
    bc : BoundaryConditions
    u_code, v_code : ndarray of int8, shapes (ny, nx + 1) and (ny + 1, nx)
        Face kinds (``FACE_FIXED``, ``FACE_INTERIOR``, ``FACE_OUTFLOW``).
    u_fixed, v_fixed : ndarray of float64, same shapes
        Prescribed normal velocity on fixed faces (0 elsewhere), m/s.
    filled : ndarray of bool, shape (ny, nx)
        Fluid cells that were filled because they cannot reach an outflow side.
    """

    grid: MACGrid
    solid: np.ndarray
    bc: BoundaryConditions
    u_code: np.ndarray
    v_code: np.ndarray
    u_fixed: np.ndarray
    v_fixed: np.ndarray
    filled: np.ndarray

    @property
    def side_codes(self) -> np.ndarray:
        """Side kinds as int8 ``(x_min, x_max, y_min, y_max)``: 0 inflow, 1 outflow, 2 wall."""
        return np.array([SIDE_KINDS.index(s) for s in self.bc.sides], dtype=np.int8)

    def initial_velocity(self, transverse: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
        """Uniform inlet velocity on all free faces, plus ``transverse`` m/s across the inlet.

        Returns the face fields ``(u, v)`` (not yet projected).
        """
        ux, uy = self.bc.inflow_velocity
        speed = float(np.hypot(ux, uy))
        nx_, ny_ = (-uy / speed, ux / speed) if speed > 0 else (0.0, 1.0)
        u = np.where(self.u_code == FACE_FIXED, self.u_fixed, ux + transverse * nx_)
        v = np.where(self.v_code == FACE_FIXED, self.v_fixed, uy + transverse * ny_)
        return u, v


def make_domain(grid: MACGrid, solid: np.ndarray, bc: BoundaryConditions) -> FlowDomain:
    """Classify every face of ``grid`` given the building mask ``solid`` (ny, nx) and ``bc``."""
    solid = np.asarray(solid, dtype=bool)
    if solid.shape != grid.shape:
        raise ValueError(
            f"The 'solid' parameter of make_domain must have the grid shape {grid.shape}. "
            f"Got {solid.shape} instead."
        )
    solid = solid.copy()
    filled = np.zeros_like(solid)
    if "outflow" in bc.sides:
        reach = _cells_reaching_outflow(solid, bc.sides)
        filled = ~solid & ~reach
        solid |= filled
    u_code, v_code, u_fixed, v_fixed = _classify_faces(solid, bc)
    for a in (solid, u_code, v_code, u_fixed, v_fixed, filled):
        a.setflags(write=False)
    return FlowDomain(grid, solid, bc, u_code, v_code, u_fixed, v_fixed, filled)


def _cells_reaching_outflow(solid: np.ndarray, sides: tuple) -> np.ndarray:
    labels, _ = ndimage.label(~solid)
    edge = {
        "x_min": labels[:, 0],
        "x_max": labels[:, -1],
        "y_min": labels[0, :],
        "y_max": labels[-1, :],
    }
    good = [edge[name] for name, kind in zip(SIDE_NAMES, sides, strict=True) if kind == "outflow"]
    good = np.unique(np.concatenate(good))
    good = good[good > 0]
    return np.isin(labels, good)


def _classify_faces(solid, bc):
    ny, nx = solid.shape
    fluid = ~solid
    u_code = np.zeros((ny, nx + 1), dtype=np.int8)
    v_code = np.zeros((ny + 1, nx), dtype=np.int8)
    u_code[:, 1:-1][fluid[:, :-1] & fluid[:, 1:]] = FACE_INTERIOR
    v_code[1:-1, :][fluid[:-1, :] & fluid[1:, :]] = FACE_INTERIOR
    u_fixed = np.zeros((ny, nx + 1))
    v_fixed = np.zeros((ny + 1, nx))
    ux, uy = bc.inflow_velocity
    x_min, x_max, y_min, y_max = bc.sides
    for kind, code_view, fixed_view, cells, value in (
        (x_min, u_code[:, 0], u_fixed[:, 0], fluid[:, 0], ux),
        (x_max, u_code[:, -1], u_fixed[:, -1], fluid[:, -1], ux),
        (y_min, v_code[0, :], v_fixed[0, :], fluid[0, :], uy),
        (y_max, v_code[-1, :], v_fixed[-1, :], fluid[-1, :], uy),
    ):
        if kind == "outflow":
            code_view[cells] = FACE_OUTFLOW
        elif kind == "inflow":
            fixed_view[cells] = value
    return u_code, v_code, u_fixed, v_fixed
