"""2D incompressible (Euler) wind around buildings: step factory, run driver, solution.

Each step solves the inviscid incompressible equations by operator splitting
(Chorin 1968; Stam 1999; Bridson 2015, "Fluid Simulation for Computer Graphics"):

    u* = advect(u, dt)                   semi-Lagrangian or MacCormack, see advection.py
    u  = u* - grad q,  div(grad q) = div(u*)                            see pressure.py

By default there is no explicit viscosity: the advection scheme's numerical diffusion plays
its part, and the sharp building corners fix the separation points, which is what vortex shedding
from bluff rectangular bodies needs (St = 0.13 for a square cylinder: Okajima 1982,
Lyn et al. 1995). An optional kinematic viscosity adds ``nu lap(u)`` after advection
(Navier-Stokes); it gives the flow a Reynolds number that does not change with the grid,
which a resolution study needs (see strouhal.py).

The run (:func:`simulate`) starts from the uniform inlet flow with a small transverse
component (a deliberate symmetry break so that shedding starts), projects it, runs
``spinup_steps``, then averages the cell-centred velocity over ``steps`` and optionally
records frames every ``record_every`` steps.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np

from windnav._validate import finite_float, positive_float
from windnav.flow.advection import make_advection
from windnav.flow.grid import FACE_FIXED, BoundaryConditions, FlowDomain, MACGrid, make_domain
from windnav.flow.pressure import make_exact_projection, make_jacobi_projection

MAX_CFL = 2.0
BLOWUP_FACTOR = 10.0
PRESSURE_SOLVERS = ("exact", "jacobi")


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

    def advance(self, u, v, out_u, out_v):
        """One step from ``(u, v)`` into ``out_u``, ``out_v`` (must not alias the inputs)."""
        if hasattr(self.advect, "into") and hasattr(self.project, "into"):
            if self._mid is None or self._mid[0].shape != u.shape:
                self._mid = (np.empty_like(u), np.empty_like(v))
            mu, mv = self.advect.into(u, v, *self._mid)
            return self.project.into(mu, mv, out_u, out_v)
        nu, nv = self(u, v)
        np.copyto(out_u, nu)
        np.copyto(out_v, nv)
        return out_u, out_v


def make_flow_step(
    domain: FlowDomain, dt: float, advect=None, pressure_solve=None, viscosity: float = 0.0
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
    """
    dt = positive_float(dt, "dt", "make_flow_step")
    if advect is None or isinstance(advect, str):
        advect = make_advection(domain, dt, advect or "maccormack", viscosity)
    if pressure_solve is None or isinstance(pressure_solve, str):
        kind = pressure_solve or "exact"
        if kind not in PRESSURE_SOLVERS:
            raise ValueError(
                f"The 'pressure_solve' parameter of make_flow_step must be a callable or one of "
                f"{PRESSURE_SOLVERS}. Got {kind!r} instead."
            )
        pressure_solve = (
            make_exact_projection(domain) if kind == "exact" else make_jacobi_projection(domain)
        )
    return FlowStep(domain, dt, advect, pressure_solve)


@numba.njit(cache=True)
def _max_abs(a):
    """max |a|, or inf if any entry is not finite."""
    m = 0.0
    for x in a.ravel():
        if not math.isfinite(x):
            return math.inf
        m = max(m, abs(x))
    return m


def check_finite(u, v, limit: float, step: int) -> None:
    """Raise :class:`FlowDivergedError` if |u| or |v| exceeds ``limit`` (m/s) or is not finite."""
    m = max(_max_abs(u), _max_abs(v))
    if not m <= limit:
        what = "non-finite values" if not math.isfinite(m) else f"max |velocity| = {m:.3g} m/s"
        raise FlowDivergedError(
            f"The flow solution blew up at step {step}: {what} (limit {limit:.3g} m/s, "
            f"{BLOWUP_FACTOR:g} x the inlet speed). Reduce 'dt' or refine 'dx'."
        )


@numba.njit(cache=True)
def _to_centres(u, v, solid, out_u, out_v, weight):
    ny, nx = solid.shape
    for j in range(ny):
        for i in range(nx):
            if not solid[j, i]:
                out_u[j, i] += weight * 0.5 * (u[j, i] + u[j, i + 1])
                out_v[j, i] += weight * 0.5 * (v[j, i] + v[j + 1, i])


def cell_centred(domain: FlowDomain, u, v) -> tuple[np.ndarray, np.ndarray]:
    """Average the face fields to the cell centres, (ny, nx) each, m/s; 0 in buildings."""
    cu = np.zeros(domain.grid.shape)
    cv = np.zeros(domain.grid.shape)
    _to_centres(u, v, domain.solid, cu, cv, 1.0)
    return cu, cv


@dataclass(frozen=True, eq=False)
class FlowSolution:
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
        return GriddedWind(self.x, self.y, self.frames_u, self.frames_v, t=self.t, solid=self.solid)


def city_domain(city, speed: float, direction_deg: float, dx: float) -> FlowDomain:
    """Rasterise ``city`` on a grid of spacing ``dx`` and set the wind's boundary conditions."""
    x0, x1, y0, y1 = city.bounds
    nx = max(int(round((x1 - x0) / dx)), 2)
    ny = max(int(round((y1 - y0) / dx)), 2)
    grid = MACGrid((ny, nx), dx, (x0, y0))
    solid = np.asarray(city.rasterize(grid.x, grid.y), dtype=bool)
    bc = BoundaryConditions.for_wind(speed, direction_deg)
    domain = make_domain(grid, solid, bc)
    _check_inlet_open(domain, "city", "simulate")
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
    viscosity: float = 0.0,
    progress: bool = False,
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
        Time step, s. ``speed * dt / dx`` must not exceed 2 (CFL).
    spinup_steps : int
        Steps run before averaging starts (>= 0).
    steps : int
        Steps averaged (>= 1).
    record_every : int
        Record a cell-centred frame every this many averaged steps (0: none).
    advection : {"maccormack", "semi_lagrangian"}
    pressure : {"exact", "jacobi"}
    symmetry_break : float
        Transverse velocity of the initial field as a fraction of ``speed`` (starts shedding).
    viscosity : float
        Kinematic viscosity, m^2/s (>= 0). 0 (default): inviscid, the advection scheme's
        numerical diffusion only.
    progress : bool
        Show a tqdm progress bar.

    Returns
    -------
    FlowSolution

    Raises
    ------
    ValueError
        On bad input (naming the argument), a CFL number above 2, or an inlet fully blocked.
    FlowDivergedError
        If the solution blows up (non-finite or faster than 10 x ``speed``).
    """
    where = "simulate"
    speed = positive_float(speed, "speed", where)
    direction_deg = finite_float(direction_deg, "direction_deg", where)
    dx = positive_float(dx, "dx", where)
    dt = positive_float(dt, "dt", where)
    spinup_steps = _nonneg_int(spinup_steps, "spinup_steps", where)
    steps = _nonneg_int(steps, "steps", where)
    if steps < 1:
        raise ValueError(f"The 'steps' parameter of {where} must be >= 1. Got {steps} instead.")
    record_every = _nonneg_int(record_every, "record_every", where)
    symmetry_break = finite_float(symmetry_break, "symmetry_break", where)
    viscosity = finite_float(viscosity, "viscosity", where)
    if viscosity < 0:
        raise ValueError(
            f"The 'viscosity' parameter of {where} must be >= 0. Got {viscosity!r} instead."
        )
    cfl = speed * dt / dx
    if cfl > MAX_CFL:
        raise ValueError(
            f"The 'dt' parameter of {where} gives a CFL number speed*dt/dx = {cfl:.3g} above "
            f"{MAX_CFL:g}; use dt <= {MAX_CFL * dx / speed:.4g} s. Got dt={dt!r} instead."
        )
    domain = city_domain(city, speed, direction_deg, dx)
    step = make_flow_step(domain, dt, advection, pressure, viscosity)
    u, v = step.project(*domain.initial_velocity(symmetry_break * speed))
    limit = BLOWUP_FACTOR * speed
    ny, nx = domain.grid.shape
    mean_u = np.zeros((ny, nx))
    mean_v = np.zeros((ny, nx))
    n_frames = steps // record_every if record_every else 0
    frames_u = np.zeros((n_frames, ny, nx)) if n_frames else None
    frames_v = np.zeros((n_frames, ny, nx)) if n_frames else None
    iterator = range(1, spinup_steps + steps + 1)
    if progress:
        from tqdm import tqdm

        iterator = tqdm(iterator, desc="flow", unit="step")
    solid = domain.solid
    u_next, v_next = np.empty_like(u), np.empty_like(v)
    for n in iterator:
        step.advance(u, v, u_next, v_next)
        u, v, u_next, v_next = u_next, v_next, u, v
        check_finite(u, v, limit, n)
        k = n - spinup_steps
        if k <= 0:
            continue
        _to_centres(u, v, solid, mean_u, mean_v, 1.0 / steps)
        if record_every and k % record_every == 0 and k // record_every <= n_frames:
            f = k // record_every - 1
            _to_centres(u, v, solid, frames_u[f], frames_v[f], 1.0)
    t = dt * record_every * np.arange(1, n_frames + 1) if n_frames else None
    return FlowSolution(
        x=domain.grid.x,
        y=domain.grid.y,
        solid=np.array(solid),
        mean_u=mean_u,
        mean_v=mean_v,
        frames_u=frames_u,
        frames_v=frames_v,
        t=t,
        speed=speed,
        direction_deg=direction_deg,
        dx=dx,
        dt=dt,
    )


def _nonneg_int(value, name, where) -> int:
    try:
        ok = not isinstance(value, bool) and int(value) == value and int(value) >= 0
    except (TypeError, ValueError, OverflowError):
        ok = False
    if not ok:
        raise ValueError(
            f"The {name!r} parameter of {where} must be an integer >= 0. Got {value!r} instead."
        )
    return int(value)


def fixed_face_violation(domain: FlowDomain, u, v) -> float:
    """max |u - prescribed| over fixed faces (buildings, walls, inlet), m/s."""
    du = np.abs(u - domain.u_fixed)[domain.u_code == FACE_FIXED]
    dv = np.abs(v - domain.v_fixed)[domain.v_code == FACE_FIXED]
    return float(max(du.max(initial=0.0), dv.max(initial=0.0)))
