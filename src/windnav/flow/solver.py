"""2D incompressible wind around buildings: step factory, run driver, solution.

Each step solves the incompressible equations by operator splitting (Chorin 1968; Stam 1999;
Bridson 2015, "Fluid Simulation for Computer Graphics"):

    u* = advect(u, dt)                   semi-Lagrangian or MacCormack, see advection.py
    u* = u* + dt div(nu grad u*)         eddy (+ fixed) viscosity, see advection.py
    u  = u* - grad q,  div(grad q) = div(u*)                            see pressure.py

The default closure is a Smagorinsky (1963) subgrid eddy viscosity ``nu_t = (C_s Delta)^2 |S|``
(``Delta`` the filter width, :func:`default_filter_width`) with ``C_s = 0.17`` (Lilly 1967), the
standard closure of urban large-eddy simulation. The inviscid equations have no length scale for
the shear layers that leave a building's corners, so without a closure the scheme's numerical
diffusion sets the Reynolds number, which then grows with every refinement and the shedding
frequency drifts (docs/flow_validation.md). The eddy viscosity is dissipative where the resolved
strain is large (the separating shear layers), nearly zero in the free stream, and zero in
uniform flow. ``smagorinsky=0`` gives the inviscid scheme and ``viscosity`` a fixed kinematic
viscosity (a fixed Reynolds number).

The run (:func:`simulate`) starts from the projected uniform inlet flow; a cross-wind kick in
the cells just downstream of each building starts the shedding and leaves with the first
vortices (:func:`initial_velocity`). It runs ``spinup_steps``, then averages the cell-centred
velocity over ``steps`` and optionally records frames every ``record_every`` steps. The
solution reports how many times the flow crossed the domain during spin-up and averaging, and
the difference between the means of the two halves of the window (the mean's own noise).
"""

from __future__ import annotations

import gc
import math
import mmap
import threading
import warnings
import weakref
from dataclasses import dataclass

import numpy as np

from windnav._jit import njit
from windnav._validate import ReadOnlyOnCopy, finite_float, nonnegative_int, positive_float
from windnav.city.core import check_city
from windnav.flow.advection import make_advection
from windnav.flow.grid import (
    FACE_FIXED,
    BoundaryConditions,
    FlowDomain,
    grid_for,
    make_domain,
)
from windnav.flow.pressure import FactorCache, make_exact_projection, make_jacobi_projection

MAX_CFL = 2.5
"""Largest ``speed * dt / dx`` accepted: the thesis's protocol (dx = 1 m, dt = 0.25 s) at its
fastest inlet, 10 m/s. The advection is unconditionally stable; the limit bounds the trace
length (2.5 cells at the inlet speed, more in the jets between buildings, so a building a few
cells thin can be stepped over at this limit: keep buildings thicker than the traces)."""
SMAGORINSKY = 0.17
"""Default Smagorinsky constant of :func:`simulate` (Lilly 1967's value for inertial-range
turbulence; not fitted to any validation case)."""
FILTER_PER_BUILDING = 8
"""The default filter width is the median building's smaller side over this (or dx)."""
WAKE_SEED_CELLS = 3
DIAGNOSTICS = (
    "flow_throughs_spinup",
    "flow_throughs_average",
    "half_window_difference",
    "smagorinsky",
    "filter_width",
    "viscosity",
)
BLOWUP_FACTOR = 10.0
START_JET_MARGIN = 1.25
"""A run is declared blown up when a face is faster than ``BLOWUP_FACTOR`` x the inlet speed
or ``START_JET_MARGIN`` x the fastest face of its projected start, whichever is larger
(:func:`blowup_limit`). The start is the uniform inlet flow projected onto the map: the
potential flow through its gaps, whose jets the impulsive start makes the fastest of the run
(measured on three 2026-11 cases at 10.0-10.7 x the inlet at step 1, 8.0-8.8 x at most from
step 6 on). A numerical blow-up grows past both."""
PRESSURE_SOLVERS = ("exact", "jacobi")
BITWISE_BATCH = 3
"""Most runs of one :func:`simulate_batch` that equal :func:`simulate` run by run to the bit:
the exact projection's CHOLMOD factor (``cholespy``, pinned) solves one, two or three
right-hand sides with the same arithmetic per column, four or more with kernels that sum in
another order (measured on the thesis suite's 600 m maps; tests/test_flow_closure.py)."""

MAX_SPEED = 100.0
"""Fastest inlet, m/s: Mach 0.3 at sea level, the edge of the incompressible model."""


class FlowDivergedError(RuntimeError):
    """The solution became non-finite or far faster than the inlet (a numerical blow-up)."""


class FlowStep:
    """A built time step: ``step(u, v) -> (u, v)``, pure.

    ``step.advance(u, v, out_u, out_v)`` does the same into given arrays with reused
    scratch memory (what :func:`simulate` runs). ``advect`` and ``project`` are the injected
    parts.
    """

    def __init__(self, domain: FlowDomain, dt: float, advect, project):
        self.domain = domain
        self.dt = dt
        self.advect = advect
        self.project = project
        self._mid = None

    def __call__(self, u, v):
        return self.project(*self.advect(u, v))

    def advance(self, u, v, out_u, out_v, q_cells=None):
        """One step from ``(u, v)`` into ``out_u``, ``out_v`` (must not alias the inputs).

        ``q_cells`` (ny, nx), if given, receives the projection's potential
        ``q = p dt / (rho dx)`` (m/s) in the fluid cells (the kinematic pressure is
        ``p / rho = q dx / dt``); it needs the built-in projection.
        """
        if hasattr(self.advect, "into") and hasattr(self.project, "into"):
            if self._mid is None or self._mid[0].shape != u.shape:
                self._mid = (np.empty_like(u), np.empty_like(v))
            mu, mv = self.advect.into(u, v, *self._mid)
            if q_cells is None:
                return self.project.into(mu, mv, out_u, out_v)
            return self.project.into(mu, mv, out_u, out_v, q_cells)
        if q_cells is not None:
            raise ValueError("FlowStep.advance: 'q_cells' needs the built-in projection.")
        nu, nv = self(u, v)
        np.copyto(out_u, nu)
        np.copyto(out_v, nv)
        return out_u, out_v


def make_flow_step(
    domain: FlowDomain,
    dt: float,
    advect=None,
    pressure_solve=None,
    viscosity: float = 0.0,
    smagorinsky: float = 0.0,
    filter_width: float | None = None,
    *,
    factor_cache: FactorCache | None = None,
) -> FlowStep:
    """Factory of the pure time step ``(u, v) -> (u, v)`` (jax-cfd style).

    Parameters
    ----------
    domain : FlowDomain
        Grid, buildings and boundary conditions.
    dt : float
        Time step, s.
    advect : callable or str, optional
        ``advect(u, v) -> (u*, v*)``, or a scheme name for :func:`make_advection`
        (default ``"maccormack"``).
    pressure_solve : callable or str, optional
        ``project(u*, v*) -> (u, v)``, or ``"exact"`` (default, sparse direct, factorised
        once) or ``"jacobi"`` (300 sweeps).
    viscosity : float
        Kinematic viscosity, m^2/s, diffused after advection when ``advect`` is a scheme
        name (0: inviscid Euler, the default).
    smagorinsky : float
        Smagorinsky constant ``C_s`` of an eddy viscosity ``(C_s Delta)^2 |S|`` added to
        ``viscosity`` when ``advect`` is a scheme name (0, the default here: none; the
        default of :func:`simulate` is :data:`SMAGORINSKY`).
    filter_width : float, optional
        The filter width ``Delta`` of the eddy viscosity ``(C_s Delta)^2 |S|``, m
        (default ``dx``).
    factor_cache : FactorCache, optional
        Caller-owned cache of pressure factorisations for the ``"exact"`` projection: steps
        built with the same cache for the same face classification share one factorisation.
    """
    dt = positive_float(dt, "dt", "make_flow_step")
    if advect is None or isinstance(advect, str):
        advect = make_advection(
            domain, dt, advect or "maccormack", viscosity, smagorinsky, filter_width
        )
    if pressure_solve is None or isinstance(pressure_solve, str):
        kind = pressure_solve or "exact"
        if kind not in PRESSURE_SOLVERS:
            raise ValueError(
                f"The 'pressure_solve' parameter of make_flow_step must be a callable or one of "
                f"{PRESSURE_SOLVERS}. Got {kind!r} instead."
            )
        pressure_solve = (
            make_exact_projection(domain, cache=factor_cache)
            if kind == "exact"
            else make_jacobi_projection(domain)
        )
    return FlowStep(domain, dt, advect, pressure_solve)


_ABS_BITS = np.uint64(0x7FFF_FFFF_FFFF_FFFF)
_INF_BITS = np.uint64(0x7FF0_0000_0000_0000)


@njit(cache=True)
def _max_abs_bits(bits):
    """The largest of ``bits & ~sign`` over a flat uint64 view of float64 values: for finite
    values the bit pattern of ``max |a|`` (IEEE 754 magnitudes order as their bit patterns),
    at least ``_INF_BITS`` when any is inf or NaN. No branch: the loop vectorises."""
    m = np.uint64(0)
    for b in bits:
        m = max(m, b & _ABS_BITS)
    return m


def _max_abs(a) -> float:
    """max |a| (exactly), or inf if any entry is not finite."""
    m = _max_abs_bits(np.ascontiguousarray(a, dtype=np.float64).reshape(-1).view(np.uint64))
    return math.inf if m >= _INF_BITS else float(np.array(m, dtype=np.uint64).view(np.float64))


def check_finite(u, v, limit: float, step: int,
                 basis: str = f"{BLOWUP_FACTOR:g} x the inlet speed") -> None:
    """Raise :class:`FlowDivergedError` if |u| or |v| exceeds ``limit`` (m/s, finite; ``basis``
    says where it comes from) or is not finite."""
    m = max(_max_abs(u), _max_abs(v))
    if not m <= limit:
        what = "non-finite values" if not math.isfinite(m) else f"max |velocity| = {m:.3g} m/s"
        raise FlowDivergedError(
            f"The flow solution blew up at step {step}: {what} (limit {limit:.3g} m/s, "
            f"{basis}). Reduce 'dt' or refine 'dx'."
        )


def blowup_limit(speed: float, u0, v0) -> tuple[float, str]:
    """The blow-up limit of a run (m/s) and what sets it: ``BLOWUP_FACTOR`` x ``speed``, or
    ``START_JET_MARGIN`` x the fastest face of its projected start ``(u0, v0)`` when that is
    larger (see :data:`START_JET_MARGIN`)."""
    jet = max(_max_abs(u0), _max_abs(v0))
    inlet = BLOWUP_FACTOR * speed
    if math.isfinite(jet) and START_JET_MARGIN * jet > inlet:
        return START_JET_MARGIN * jet, (f"{START_JET_MARGIN:g} x the start's fastest jet, "
                                        f"{jet / speed:.3g} x the inlet speed")
    return inlet, f"{BLOWUP_FACTOR:g} x the inlet speed"


@njit(cache=True)
def _to_centres(u, v, solid, out_u, out_v, weight):
    ny, nx = solid.shape
    for j in range(ny):
        for i in range(nx):
            if not solid[j, i]:
                out_u[j, i] += weight * 0.5 * (u[j, i] + u[j, i + 1])
                out_v[j, i] += weight * 0.5 * (v[j, i] + v[j + 1, i])


@njit(cache=True)
def _centres_into(u, v, solid, out_u, out_v):
    """Write the cell-centred velocity into every cell of ``out_u, out_v`` (0 in buildings):
    bitwise ``_to_centres`` into zeros with weight 1 (``0.0 + 0.5 * ...`` keeps its -0.0 -> 0.0),
    so a reused, uninitialised frame needs no clearing first."""
    ny, nx = solid.shape
    for j in range(ny):
        for i in range(nx):
            if solid[j, i]:
                out_u[j, i] = 0.0
                out_v[j, i] = 0.0
            else:
                out_u[j, i] = 0.0 + 0.5 * (u[j, i] + u[j, i + 1])
                out_v[j, i] = 0.0 + 0.5 * (v[j, i] + v[j + 1, i])


@njit(cache=True)
def _to_centres_recording(u, v, solid, out_u, out_v, weight, frame_u, frame_v):
    """:func:`_to_centres` and :func:`_centres_into` (into ``frame_u, frame_v``) in one pass
    over the faces, each value bitwise theirs (the face sum is formed once; both kernels
    scale that same sum)."""
    ny, nx = solid.shape
    for j in range(ny):
        for i in range(nx):
            if solid[j, i]:
                frame_u[j, i] = 0.0
                frame_v[j, i] = 0.0
            else:
                su = u[j, i] + u[j, i + 1]
                sv = v[j, i] + v[j + 1, i]
                out_u[j, i] += weight * 0.5 * su
                out_v[j, i] += weight * 0.5 * sv
                frame_u[j, i] = 0.0 + 0.5 * su
                frame_v[j, i] = 0.0 + 0.5 * sv


class FrameBuffers:
    """Caller-owned memory for the recorded frames of :func:`simulate_batch`, reused by later runs.

    A run's frames of a 600 m map are 2.3 GB; writing into freshly allocated memory costs a page
    fault per page (5.5 s of a 28 s wind on a 2-core Xeon VM, against 0.3 s into memory touched
    before). A worker that simulates wind after wind keeps one ``FrameBuffers`` and passes it to
    every run: a run gets a block of its frames' size that no array refers to any more (the
    previous wind's solution and every view of it gone), or a new one. The frames are written
    whole, so a reused block gives the same values as a fresh one.

    Each block is an anonymous memory map kept by the pool; a run gets an array over it, and
    since every view of that array has it as its ``base``, a weak reference to it tells when
    the block is free. Free blocks of another size are dropped when a new one is made. One pool
    may serve several threads: :meth:`take` holds a lock between finding a free block and
    handing it out (two threads could get one block; audit, thirty-seventh session).
    """

    def __init__(self):
        self._blocks: list[list] = []  # [mmap, weak reference to the array handed out]
        self._lock = threading.Lock()

    def __len__(self) -> int:
        return len(self._blocks)

    @staticmethod
    def _is_free(entry) -> bool:
        return entry[1] is None or entry[1]() is None

    def take(self, shape: tuple[int, ...]) -> np.ndarray:
        """A float64 array of ``shape`` (uninitialised contents) that shares memory with no
        other live array."""
        shape = tuple(int(n) for n in shape)
        nbytes = 8 * math.prod(shape)
        if nbytes == 0:
            return np.empty(shape)
        with self._lock:
            return self._take(shape, nbytes)

    def _take(self, shape: tuple[int, ...], nbytes: int) -> np.ndarray:
        for attempt in range(2):
            for entry in self._blocks:
                if len(entry[0]) == nbytes and self._is_free(entry):
                    return self._hand_out(entry, shape)
            if attempt == 0:
                gc.collect()  # a solution kept alive only by a reference cycle
        self._blocks = [e for e in self._blocks if len(e[0]) == nbytes or not self._is_free(e)]
        # private anonymous memory (Python's default on Unix, shared, is shmem: no huge pages)
        private = ({"flags": mmap.MAP_PRIVATE | getattr(mmap, "MAP_ANONYMOUS", 0)}
                   if hasattr(mmap, "MAP_PRIVATE") else {})
        block = mmap.mmap(-1, nbytes, **private)
        if hasattr(mmap, "MADV_HUGEPAGE"):  # as NumPy asks for its large arrays (Linux)
            block.madvise(mmap.MADV_HUGEPAGE)
        self._blocks.append([block, None])
        return self._hand_out(self._blocks[-1], shape)

    @staticmethod
    def _hand_out(entry, shape) -> np.ndarray:
        flat = np.frombuffer(entry[0], dtype=np.float64)
        entry[1] = weakref.ref(flat)
        return flat.reshape(shape)  # a view: its base (and every later view's) is ``flat``


def cell_centred(domain: FlowDomain, u, v) -> tuple[np.ndarray, np.ndarray]:
    """Average the face fields to the cell centres, (ny, nx) each, m/s; 0 in buildings."""
    cu = np.empty(domain.grid.shape)
    cv = np.empty(domain.grid.shape)
    _centres_into(u, v, domain.solid, cu, cv)
    return cu, cv


@dataclass(frozen=True, eq=False)
class FlowSolution(ReadOnlyOnCopy):
    """Result of :func:`simulate`.

    Attributes
    ----------
    x : ndarray of shape (nx,)
        Cell-centre x coordinates, m (world frame).
    y : ndarray of shape (ny,)
        Cell-centre y coordinates, m.
    solid : ndarray of bool, shape (ny, nx)
        Building cells (including enclosed pockets filled by the solver).
    mean_u, mean_v : ndarray of shape (ny, nx)
        Time-averaged cell-centred velocity over the averaging window, m/s (0 in buildings).
    frames_u, frames_v : ndarray of shape (T, ny, nx) or None
        Cell-centred snapshots every ``record_every`` steps, m/s.
    t : ndarray of shape (T,) or None
        Frame times measured from the start of the averaging window, s.
    speed, direction_deg, dx, dt : float
        The inlet and discretisation that produced the solution (m/s, deg, m, s).
    flow_throughs_spinup, flow_throughs_average : float
        ``U t / L`` of the spin-up and of the averaging window: how many times the inlet flow
        crossed the domain (``L``, m, is the domain's extent along the wind).
    half_window_difference : float
        RMS over fluid cells of ``|mean of the first half - mean of the second half|`` of the
        averaging window, divided by ``speed``: the statistical uncertainty of the mean field
        (NaN with fewer than 2 averaged steps).
    smagorinsky, filter_width, viscosity : float
        The closure: Smagorinsky constant (0: none), its filter width (m) and the fixed
        kinematic viscosity (m^2/s).
    blowup_limit : float
        The face speed (m/s, either component) no step of the run exceeded: 10 x ``speed``,
        or 1.25 x the fastest jet of the projected start when that is larger
        (:func:`blowup_limit`). NaN for a solution that was loaded or not simulated.
    """

    x: np.ndarray
    y: np.ndarray
    solid: np.ndarray
    mean_u: np.ndarray
    mean_v: np.ndarray
    frames_u: np.ndarray | None
    frames_v: np.ndarray | None
    t: np.ndarray | None
    speed: float
    direction_deg: float
    dx: float
    dt: float
    flow_throughs_spinup: float = float("nan")
    flow_throughs_average: float = float("nan")
    half_window_difference: float = float("nan")
    smagorinsky: float = float("nan")
    filter_width: float = float("nan")
    viscosity: float = float("nan")
    blowup_limit: float = float("nan")

    @property
    def diagnostics(self) -> dict:
        """The averaging and closure figures as a JSON-ready dict (see the class docstring)."""
        return {k: float(getattr(self, k)) for k in DIAGNOSTICS}

    @property
    def inlet_xy(self) -> np.ndarray:
        """The inlet (free-stream) wind ``W_up``, ndarray of shape (2,), m/s, world x-y.

        ``speed * (cos a, sin a)`` with ``a = direction_deg`` (the direction the wind blows
        toward, counter-clockwise from +x): the ``w_up`` the decoder and its datasets take
        (:func:`windnav.predict.field_from_solution`). A fresh array each call.
        """
        a = np.deg2rad(self.direction_deg)
        return float(self.speed) * np.array([np.cos(a), np.sin(a)])

    def wind_field(self, unsteady: bool = False):
        """The solution as a :class:`windnav.wind.gridded.GriddedWind`.

        Parameters
        ----------
        unsteady : bool
            False: the time-averaged field (steady). True: the recorded frames, linear in time
            (requires ``record_every > 0``).
        """
        from windnav.wind.gridded import GriddedWind

        if not unsteady:
            return GriddedWind(self.x, self.y, self.mean_u, self.mean_v, t=None, solid=self.solid)
        if self.frames_u is None:
            raise ValueError(
                "The 'unsteady' parameter of FlowSolution.wind_field needs recorded frames; "
                "run simulate with record_every > 0."
            )
        # the solver's own frames are finite by construction (see _Run.solution); any other
        # solution (loaded, or made with dataclasses.replace) is scanned
        return GriddedWind(self.x, self.y, self.frames_u, self.frames_v, t=self.t,
                           solid=self.solid, known_finite=getattr(self, "_frames_finite", False))


def city_domain(city, speed: float, direction_deg: float, dx: float) -> FlowDomain:
    """Rasterise ``city`` on a grid of spacing ``dx`` and set the wind's boundary conditions.

    The caller checks the resolution first (:meth:`~windnav.city.City.check_resolution`, once
    per map, as :func:`simulate_batch` does)."""
    grid = grid_for(city.bounds, dx)
    solid = np.asarray(city.rasterize(grid.x, grid.y), dtype=bool)
    bc = BoundaryConditions.for_wind(speed, direction_deg)
    domain = make_domain(grid, solid, bc)
    _check_inlet_open(domain, "city", "simulate")
    n = int(np.count_nonzero(domain.filled))
    if n:  # a sealed courtyard read as still air in predict, unsaid (failure audit, 2026-12-06)
        warnings.warn(f"simulate: {n} cells ({n * dx * dx:g} m^2) enclosed by buildings, with "
                      "no path to the outflow, are filled as solid: the wind there is 0, not "
                      "simulated (a sealed courtyard; open it to a street to simulate its air)",
                      RuntimeWarning, stacklevel=2)
    return domain


def _check_inlet_open(domain: FlowDomain, name: str, where: str) -> None:
    ux, uy = domain.bc.inflow_velocity
    open_inflow = np.count_nonzero(domain.u_fixed[:, [0, -1]] != 0.0) + np.count_nonzero(
        domain.v_fixed[[0, -1], :] != 0.0
    )
    if (ux != 0.0 or uy != 0.0) and open_inflow == 0:
        raise ValueError(
            f"The {name!r} parameter of {where} has buildings blocking the whole inlet "
            f"(or every path from the inlet to the outflow) for wind {domain.bc.inflow_velocity} "
            "m/s: no fluid can enter the domain."
        )


def default_filter_width(city, dx: float) -> float:
    """The default filter width of the eddy viscosity, m: ``max(dx, s / 8)`` with ``s`` the
    median over the buildings of their smaller side (``dx`` for an empty map).

    A filter tied to the buildings rather than to the grid gives the flow a fixed length
    scale: on grids finer than ``s / 8`` the equations no longer change with ``dx`` and the
    solution converges (the square-cylinder Strouhal number: docs/flow_validation.md).
    """
    side = city.median_building_side
    if side is None:
        return float(dx)
    return float(max(dx, side / FILTER_PER_BUILDING))


def wake_seed(domain: FlowDomain, cells: int = WAKE_SEED_CELLS) -> np.ndarray:
    """Fluid cells within ``cells`` cells downstream of a building cell, (ny, nx) bool.

    Downstream is along the inlet velocity of ``domain.bc``; an empty map (or a still inlet)
    has no seed cells.
    """
    ny, nx = domain.grid.shape
    seed = np.zeros((ny, nx), dtype=bool)
    ux, uy = domain.bc.inflow_velocity
    speed = math.hypot(ux, uy)
    jj, ii = np.nonzero(domain.solid)
    if speed == 0.0 or jj.size == 0:
        return seed
    for k in range(1, int(cells) + 1):
        ci = np.floor(ii + 0.5 + k * ux / speed).astype(np.int64)
        cj = np.floor(jj + 0.5 + k * uy / speed).astype(np.int64)
        ok = (ci >= 0) & (ci < nx) & (cj >= 0) & (cj < ny)
        seed[cj[ok], ci[ok]] = True
    return seed & ~domain.solid


def initial_velocity(domain: FlowDomain, kick: float) -> tuple[np.ndarray, np.ndarray]:
    """The start of :func:`simulate`: the uniform inlet flow, plus ``kick`` m/s across the wind
    on the free faces of the :func:`wake_seed` cells (not yet projected).

    The kick breaks the mirror symmetry that would delay vortex shedding, and it stays in the
    near wake of each building, so it leaves the domain with the first shed vortices instead of
    filling it (a domain-wide transverse start biases every mean taken before the flow has
    crossed the domain). Without buildings the start is exactly the inlet flow.
    """
    u, v = domain.initial_velocity(0.0)
    seed = wake_seed(domain)
    if kick == 0.0 or not seed.any():
        return u, v
    ux, uy = domain.bc.inflow_velocity
    speed = math.hypot(ux, uy)
    tx, ty = -uy / speed, ux / speed
    fu = np.zeros(u.shape, dtype=bool)
    fv = np.zeros(v.shape, dtype=bool)
    fu[:, :-1] |= seed
    fu[:, 1:] |= seed
    fv[:-1, :] |= seed
    fv[1:, :] |= seed
    fu &= domain.u_code != FACE_FIXED
    fv &= domain.v_code != FACE_FIXED
    u[fu] += kick * tx
    v[fv] += kick * ty
    return u, v


def flow_length(domain: FlowDomain) -> float:
    """Extent of the domain along the inlet wind, m (``|Lx cos| + |Ly sin|``)."""
    ux, uy = domain.bc.inflow_velocity
    speed = math.hypot(ux, uy)
    ny, nx = domain.grid.shape
    lx, ly = nx * domain.grid.dx, ny * domain.grid.dx
    if speed == 0.0:
        return max(lx, ly)
    return (abs(ux) * lx + abs(uy) * ly) / speed


def simulate(
    city,
    speed: float = 5.0,
    direction_deg: float = 0.0,
    dx: float = 1.0,
    dt: float = 0.25,
    spinup_steps: int = 100,
    steps: int = 200,
    record_every: int = 0,
    *,
    advection: str = "maccormack",
    pressure: str = "exact",
    symmetry_break: float = 0.05,
    smagorinsky: float = SMAGORINSKY,
    filter_width: float | None = None,
    viscosity: float = 0.0,
    progress: bool = False,
    memory_limit: float | None = None,
    factor_cache: FactorCache | None = None,
    frame_buffers: FrameBuffers | None = None,
) -> FlowSolution:
    """Simulate the 2D wind through ``city`` and return its time average (and frames).

    Parameters
    ----------
    city : windnav.city.City
        Building map; its bounds are the simulation domain.
    speed : float
        Inlet wind speed, m/s (> 0).
    direction_deg : float
        Direction the wind blows toward, degrees counter-clockwise from +x.
    dx : float
        Cell size, m.
    dt : float
        Time step, s. ``speed * dt / dx`` must not exceed 2.5 (CFL).
    spinup_steps : int
        Steps run before averaging starts (>= 0).
    steps : int
        Steps averaged (>= 1).
    record_every : int
        Record a cell-centred frame every this many averaged steps (0: none; at most
        ``steps``).
    advection : {"maccormack", "semi_lagrangian"}
    pressure : {"exact", "jacobi"}
    symmetry_break : float
        Cross-wind velocity, as a fraction of ``speed``, given at the start to the cells just
        downstream of each building (:func:`initial_velocity`); it starts the shedding and
        leaves with the first vortices. 0: a symmetric start.
    smagorinsky : float
        Smagorinsky constant ``C_s`` (>= 0) of the eddy viscosity ``(C_s Delta)^2 |S|``
        (``Delta``: ``filter_width``), the default closure (see the module docstring). 0 turns
        it off.
    filter_width : float, optional
        The eddy viscosity's filter width ``Delta``, m. Default (None):
        :func:`default_filter_width`, ``max(dx, median building side / 8)``, a physical length,
        so refining ``dx`` below it converges to one solution.
    viscosity : float
        Fixed kinematic viscosity, m^2/s (>= 0), added to the eddy viscosity. With
        ``smagorinsky=0`` and ``viscosity=0``: inviscid Euler, the advection scheme's numerical
        diffusion only (whose effective Reynolds number grows as dx shrinks).
    progress : bool
        Show a tqdm progress bar.
    memory_limit : float, optional
        Bytes the run may use (default :func:`windnav.flow.memory.default_memory_limit`: 75 %
        of the machine's memory, or ``$WINDNAV_MEMORY_LIMIT``); a run estimated above it is
        refused with :class:`~windnav.flow.memory.MemoryEstimateError` before allocating.
    factor_cache : FactorCache, optional
        Caller-owned cache of pressure factorisations, shared with earlier and later runs on
        the same map whose inlets have the same boundary kinds (default: one for this run).
    frame_buffers : FrameBuffers, optional
        Caller-owned pool the recorded frames are taken from (default: new memory). Reusing a
        block is bitwise the same as new memory and saves its page faults.

    Returns
    -------
    FlowSolution
        With the averaging diagnostics ``flow_throughs_spinup``, ``flow_throughs_average``
        and ``half_window_difference``.

    Raises
    ------
    ValueError
        On bad input (naming the argument), a CFL number above 2.5, or an inlet fully blocked.
    FlowDivergedError
        If the solution blows up (non-finite, or faster than 10 x ``speed`` and than 1.25 x the
        fastest jet of the projected start: :func:`blowup_limit`).
    """
    return simulate_batch(
        city,
        [positive_float(speed, "speed", "simulate")],
        direction_deg,
        dx,
        dt,
        spinup_steps,
        steps,
        record_every,
        advection=advection,
        pressure=pressure,
        symmetry_break=symmetry_break,
        smagorinsky=smagorinsky,
        filter_width=filter_width,
        viscosity=viscosity,
        progress=progress,
        memory_limit=memory_limit,
        factor_cache=factor_cache,
        frame_buffers=frame_buffers,
        _where="simulate",
    )[0]


def simulate_batch(
    city,
    speeds,
    direction_deg: float = 0.0,
    dx: float = 1.0,
    dt: float = 0.25,
    spinup_steps: int = 100,
    steps: int = 200,
    record_every: int = 0,
    *,
    advection: str = "maccormack",
    pressure: str = "exact",
    symmetry_break: float = 0.05,
    smagorinsky: float = SMAGORINSKY,
    filter_width: float | None = None,
    viscosity: float = 0.0,
    progress: bool = False,
    memory_limit: float | None = None,
    factor_cache: FactorCache | None = None,
    frame_buffers: FrameBuffers | None = None,
    _where: str = "simulate_batch",
) -> list[FlowSolution]:
    """:func:`simulate` for several inlet speeds (and directions), stepped together.

    The runs share the map and the boundary kinds (which sides are inlets: one direction, or
    directions such as 15, 30 and 45 deg whose inlets are the same two sides): one
    factorisation, and one multi-right-hand-side pressure solve per step for all runs.
    Batches of up to :data:`BITWISE_BATCH` runs equal :func:`simulate` run by run to the bit
    (CHOLMOD solves up to three right-hand sides with the arithmetic of one; from four on its
    kernels differ in summation order, so larger batches equal it to round-off only;
    tests/test_flow_closure.py). Parameters as in :func:`simulate`, with ``speeds`` a
    sequence of m/s (> 0), ``direction_deg`` one direction for every run or one per speed
    (degrees; runs whose boundary kinds differ raise ValueError), and
    ``memory_limit`` (bytes, default :func:`windnav.flow.memory.default_memory_limit`): a run
    whose estimated memory is above it is refused with
    :class:`~windnav.flow.memory.MemoryEstimateError` before anything is allocated.
    ``factor_cache`` and ``frame_buffers`` (caller-owned, reused across runs) as in
    :func:`simulate`.

    Returns
    -------
    list of FlowSolution
        In the order of ``speeds``.
    """
    where = _where
    check_city(city, where)
    speeds = [positive_float(sp, "speed" if where == "simulate" else "speeds", where)
              for sp in np.atleast_1d(np.asarray(speeds, dtype=object))]
    if not speeds:
        raise ValueError(f"The 'speeds' parameter of {where} must not be empty.")
    if max(speeds) > MAX_SPEED:  # 1e300 m/s overflowed in the diffusion, far past its physics
        raise ValueError(
            f"The {'speed' if where == 'simulate' else 'speeds'!r} parameter of {where} must be "
            f"<= {MAX_SPEED:g} m/s: the solver is incompressible, valid below Mach 0.3 (about "
            f"{MAX_SPEED:g} m/s at sea level). Got {max(speeds)!r} instead.")
    directions = _directions(direction_deg, len(speeds), where)
    dx = positive_float(dx, "dx", where)
    dt = positive_float(dt, "dt", where)
    spinup_steps = nonnegative_int(spinup_steps, "spinup_steps", where)
    steps = nonnegative_int(steps, "steps", where)
    if steps < 1:
        raise ValueError(f"The 'steps' parameter of {where} must be >= 1. Got {steps} instead.")
    record_every = nonnegative_int(record_every, "record_every", where)
    if record_every > steps:  # it would record no frame at all
        raise ValueError(f"The 'record_every' parameter of {where} must be at most steps "
                         f"({steps}) to record a frame, or 0 for none. Got {record_every} "
                         "instead.")
    symmetry_break = finite_float(symmetry_break, "symmetry_break", where)
    smagorinsky = _nonneg_float(smagorinsky, "smagorinsky", where)
    viscosity = _nonneg_float(viscosity, "viscosity", where)
    if filter_width is None:
        filter_width = default_filter_width(city, dx)
    else:
        filter_width = positive_float(filter_width, "filter_width", where)
    cfl = max(speeds) * dt / dx
    if cfl > MAX_CFL:
        raise ValueError(
            f"The 'dt' parameter of {where} gives a CFL number speed*dt/dx = {cfl:.3g} above "
            f"{MAX_CFL:g}; use dt <= {MAX_CFL * dx / max(speeds):.4g} s. Got dt={dt!r} instead."
        )
    from windnav.flow.memory import check_city_memory

    check_city_memory(city, dx, len(speeds), steps // record_every if record_every else 0,
                      pressure=pressure, memory_limit=memory_limit, where=where)
    # a dx at which a building covers no cell would let the flow pass through it
    city.check_resolution(dx, where)
    domains = [city_domain(city, sp, dd, dx) for sp, dd in zip(speeds, directions, strict=True)]
    for d, dd in zip(domains[1:], directions[1:], strict=True):
        if d.bc.sides != domains[0].bc.sides:
            raise ValueError(
                f"The 'direction_deg' parameter of {where} must give every run the same boundary "
                f"kinds: {directions[0]:g} deg has inlets {domains[0].bc.sides} and {dd:g} deg "
                f"{d.bc.sides}. Simulate them in separate batches."
            )
    # the speeds share one face classification; a caller's cache also shares it across runs
    factors = FactorCache(maxsize=1) if factor_cache is None else factor_cache
    if frame_buffers is None:
        frame_buffers = FrameBuffers()  # new memory for each run's frames
    flow_steps = [
        make_flow_step(d, dt, advection, pressure, viscosity, smagorinsky, filter_width,
                       factor_cache=factors)
        for d in domains
    ]
    project = flow_steps[0].project
    runs = [
        _Run(d, st, sp, dd, symmetry_break, steps, record_every, frame_buffers)
        for d, st, sp, dd in zip(domains, flow_steps, speeds, directions, strict=True)
    ]
    iterator = range(1, spinup_steps + steps + 1)
    if progress:
        from windnav._console import progress_bar

        iterator = progress_bar(iterator, auto=False, desc="flow", unit="step")
    for n in iterator:
        for r in runs:
            r.step.advect.into(r.u, r.v, r.mid_u, r.mid_v)
        project.into_many(
            [r.mid_u for r in runs], [r.mid_v for r in runs], [r.u for r in runs],
            [r.v for r in runs],
        )
        for r in runs:
            check_finite(r.u, r.v, r.limit, n, r.limit_basis)
            if n > spinup_steps:
                r.accumulate(n - spinup_steps)
    closure = {"smagorinsky": smagorinsky, "filter_width": filter_width, "viscosity": viscosity}
    return [r.solution(spinup_steps, closure) for r in runs]


def _directions(direction_deg, n: int, where: str) -> list[float]:
    """``direction_deg`` (one float, or one per run) as ``n`` floats, degrees."""
    if np.ndim(direction_deg) == 0:
        return [finite_float(direction_deg, "direction_deg", where)] * n
    values = [finite_float(d, "direction_deg", where) for d in np.asarray(direction_deg,
                                                                          dtype=object).ravel()]
    if len(values) != n:
        raise ValueError(
            f"The 'direction_deg' parameter of {where} must be one direction or one per speed "
            f"({n}). Got {len(values)} directions instead."
        )
    return values


class _Run:
    """The state of one run of :func:`simulate_batch`: fields, scratch, running means."""

    def __init__(self, domain, step, speed, direction_deg, symmetry_break, steps, record_every,
                 frame_buffers: FrameBuffers):
        self.domain, self.step, self.speed = domain, step, speed
        self.direction_deg = direction_deg
        self.u, self.v = step.project(*initial_velocity(domain, symmetry_break * speed))
        self.limit, self.limit_basis = blowup_limit(speed, self.u, self.v)
        self.mid_u, self.mid_v = np.empty_like(self.u), np.empty_like(self.v)
        shape = domain.grid.shape
        self.steps, self.record_every = steps, record_every
        self.n_first = steps // 2
        self.halves = tuple(np.zeros(shape) for _ in range(4))
        self.n_frames = steps // record_every if record_every else 0
        # both components of a frame side by side, (T, ny, nx, 2): the layout GriddedWind
        # keeps, so that a wind field of the frames adopts them instead of copying (2.3 GB for
        # a 600 m map x 400 frames); frames_u / frames_v are views
        # every frame is written whole (_centres_into), so the block needs no clearing
        self.frames = (frame_buffers.take((self.n_frames, *shape, 2)) if self.n_frames
                       else None)
        self.frames_u = self.frames[..., 0] if self.n_frames else None
        self.frames_v = self.frames[..., 1] if self.n_frames else None

    def accumulate(self, k: int) -> None:
        """Add averaged step ``k`` (1-based) to its half-window mean (and record a frame)."""
        h, solid = self.halves, self.domain.solid
        if k <= self.n_first:
            mean_u, mean_v, weight = h[0], h[1], 1.0 / self.n_first
        else:
            mean_u, mean_v, weight = h[2], h[3], 1.0 / (self.steps - self.n_first)
        re = self.record_every
        if re and k % re == 0 and k // re <= self.n_frames:
            f = k // re - 1
            _to_centres_recording(self.u, self.v, solid, mean_u, mean_v, weight,
                                  self.frames_u[f], self.frames_v[f])
        else:
            _to_centres(self.u, self.v, solid, mean_u, mean_v, weight)

    def solution(self, spinup_steps: int, closure: dict) -> FlowSolution:
        d, h, steps, speed = self.domain, self.halves, self.steps, self.speed
        w1 = self.n_first / steps
        mean_u = w1 * h[0] + (1.0 - w1) * h[2]
        mean_v = w1 * h[1] + (1.0 - w1) * h[3]
        fluid = ~d.solid
        if self.n_first and fluid.any():
            diff2 = (h[0] - h[2]) ** 2 + (h[1] - h[3]) ** 2
            half_diff = float(np.sqrt(diff2[fluid].mean()) / speed)
        else:
            half_diff = float("nan") if not self.n_first else 0.0
        length = flow_length(d)
        n_frames, dt = self.n_frames, self.step.dt
        check_jets(mean_u, mean_v, fluid, speed, dt, d.grid.dx)
        solution = FlowSolution(
            x=d.grid.x,
            y=d.grid.y,
            solid=np.array(d.solid),
            mean_u=mean_u,
            mean_v=mean_v,
            frames_u=self.frames_u,
            frames_v=self.frames_v,
            t=dt * self.record_every * np.arange(1, n_frames + 1) if n_frames else None,
            speed=speed,
            direction_deg=self.direction_deg,
            dx=d.grid.dx,
            dt=dt,
            flow_throughs_spinup=speed * spinup_steps * dt / length,
            flow_throughs_average=speed * steps * dt / length,
            half_window_difference=half_diff,
            blowup_limit=self.limit,
            **closure,
        )
        # every step passed check_finite (|u|, |v| <= blowup_limit, finite) before it was
        # recorded, and a frame is the mean of two such faces: finite. The frames are made
        # read-only so that it stays true (a wind field of them makes them so anyway), and the
        # flag is not a dataclass field, so dataclasses.replace (which may swap them) drops it.
        if n_frames:
            for arr in (self.frames, self.frames_u, self.frames_v):
                arr.setflags(write=False)
        object.__setattr__(solution, "_frames_finite", n_frames > 0)
        return solution


JET_TRACE_CELLS = 8 * MAX_CFL
"""Most cells a trace may cross in one step at the mean flow's fastest cell before
:func:`check_jets` warns: 20. The thesis suite's 10 m/s inlets reach about 5 in their jets,
the dense evaluation maps (jets of 6.4-9.4 x the inlet, at ``dt = dx / U``) up to 9.4; a 1 m
street through a barrier 41 at a 5 m/s inlet."""


def check_jets(mean_u, mean_v, fluid, speed: float, dt: float, dx: float) -> None:
    """Warn when the mean flow's fastest fluid cell is past Mach 0.3 (:data:`MAX_SPEED`) or
    moves a trace more than :data:`JET_TRACE_CELLS` cells a step: the inlet is checked before
    the run, but a gap of a cell or two between buildings made jets of 115-410 m/s from 5-10
    m/s inlets, each reported as an ordinary (even converged) flow (failure audit,
    2026-12-06)."""
    if not np.any(fluid):
        return
    peak = float(np.sqrt(np.max((mean_u**2 + mean_v**2)[fluid])))
    trace = peak * dt / dx
    if peak > MAX_SPEED or trace > JET_TRACE_CELLS:
        why = []
        if peak > MAX_SPEED:
            why.append(f"past Mach 0.3 ({MAX_SPEED:g} m/s), where the incompressible model "
                       "does not hold")
        if trace > JET_TRACE_CELLS:
            why.append(f"{trace:.3g} cells a step, past {JET_TRACE_CELLS:g}, so a trace can "
                       "step over thin buildings (lower dt)")
        warnings.warn(f"simulate: the mean flow reaches {peak:.4g} m/s ({peak / speed:.3g} x "
                      f"the inlet) in its fastest cell: {'; and '.join(why)}; gaps of a cell "
                      "or two between buildings make such jets (widen them, or a finer dx)",
                      RuntimeWarning, stacklevel=2)


def _nonneg_float(value, name, where) -> float:
    value = finite_float(value, name, where)
    if value < 0:
        raise ValueError(f"The {name!r} parameter of {where} must be >= 0. Got {value!r} instead.")
    return value


def fixed_face_violation(domain: FlowDomain, u, v) -> float:
    """max |u - prescribed| over fixed faces (buildings, walls, inlet), m/s."""
    du = np.abs(u - domain.u_fixed)[domain.u_code == FACE_FIXED]
    dv = np.abs(v - domain.v_fixed)[domain.v_code == FACE_FIXED]
    return float(max(du.max(initial=0.0), dv.max(initial=0.0)))
