"""Reachability: the least time in which any vehicle whose airspeed stays within a limit can
reach a goal through a city's wind.

A scenario of the navigation benchmark can only be flown if some path gets from the start to
the goal before the recorded wind ends while the vehicle's airspeed stays inside the envelope
where its aerodynamic model is trusted (:attr:`windnav.vehicle.MultirotorParams.airspeed_limit`,
13.4 m/s for the Hummingbird). :func:`least_time` searches for the earliest such arrival:

- Flying ``dL`` metres along the unit vector ``e`` in the wind ``w`` with airspeed at most
  ``A``, the ground speed is at most ``v_max = w.e + sqrt(A^2 - (w x e)^2)``
  (:func:`max_ground_speed`); none when the crosswind ``|w x e|`` exceeds ``A`` or the
  headwind exceeds the rest.
- The map is the lattice of :func:`windnav.plan.energy_route` (cells of ``dx``, buildings
  inflated by ``clearance``, the 16 moves of :data:`~windnav.plan.MOVES`, which follow straight
  lines within 3 degrees) and each move is flown at its ``v_max`` in the mean of its two cells'
  winds.
- The wind is either steady (e.g. the mean field the ``+W`` planners know) or the recorded
  frames, linear in time: then a move takes the wind at its departure time, and where no
  airspeed within ``A`` makes headway the vehicle may wait for the wind to change
  (``wait="blocked"``, the default), or also wait before a move it could fly when a later
  frame time arrives sooner (``wait="best"``).
- Earliest arrival times are label-set by Dijkstra (exact for the steady wind; for the unsteady
  one, exact when the arrival time of a move never decreases with its departure time).

Nothing else limits the vehicle: it turns and accelerates instantly, and hovering is free. In a
steady wind the result is the least time on the lattice. In the recorded frames it is the time
of a route flown within the limit, so a goal reached is shown reachable (up to the lattice's
discretisation: directions within 3 degrees, 2 m cells, the wind of a move taken at its two
ends), but it is the least time only where departing later never arrives sooner: a reference
audit (2026-12-05) found the default's arrivals up to 23 % late on test winds that change
completely from frame to frame, and a goal it cannot reach is not proven out of reach.
``wait="best"`` closes most of that (departures between frame times are still not tried); on
the benchmark's recorded winds the two differ by what ``docs/navigation/reach_wait.py``
measures (navigation.md, "Which scenarios can be flown at all?"). A goal it can reach may still
be out of reach of a real vehicle.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from windnav._validate import batch_array, finite_float, positive_float
from windnav.city.core import check_city
from windnav.plan import _search_kernels as SK
from windnav.plan.energy_search import MOVES, _guards
from windnav.plan.graph_search import cell_path, free_cell, free_space

__all__ = [
    "FastestRoute",
    "ReachLattice",
    "ReachResult",
    "fastest_route",
    "least_time",
    "max_ground_speed",
    "nearest_free_cell",
    "reach_lattice",
    "wind_covariance",
]


MIN_ROUTE_SPEED = 0.5
"""The slowest ground speed :func:`fastest_route` flies a piece at, m/s."""

MAX_AIRSPEED = 1000.0
"""The largest ``airspeed_max`` the least-time searches take, m/s (1e308 gave a time of 0)."""


def _airspeed(value, where: str) -> float:
    a = positive_float(value, "airspeed_max", where)
    if a > MAX_AIRSPEED:
        raise ValueError(f"The 'airspeed_max' parameter of {where} must be at most "
                         f"{MAX_AIRSPEED:g} m/s. Got {value!r} instead.")
    return a

def max_ground_speed(direction, wind, airspeed_max) -> np.ndarray:
    """Largest ground speed along ``direction`` with airspeed at most ``airspeed_max``.

    Parameters
    ----------
    direction : array_like of shape (B, 2)
        Unit vectors of the track (normalised here), world frame.
    wind : array_like of shape (B, 2)
        Horizontal wind, m/s, world frame.
    airspeed_max : float
        Largest airspeed, m/s (> 0).

    Returns
    -------
    ndarray of shape (B,)
        ``w.e + sqrt(A^2 - (w x e)^2)``, m/s; 0 where no ground speed > 0 is possible.
    """
    where = "max_ground_speed"
    e = batch_array(direction, "direction", where, (2,))
    w = batch_array(wind, "wind", where, (2,), batch=e.shape[0])
    a = positive_float(airspeed_max, "airspeed_max", where)
    norm = np.hypot(e[:, 0], e[:, 1])
    if not np.all(norm > 0):
        raise ValueError(f"The 'direction' parameter of {where} must hold non-zero vectors. "
                         f"Got a zero vector instead.")
    e = e / norm[:, None]
    return np.array([SK.max_ground_speed(ex, ey, wx, wy, a)
                     for (ex, ey), (wx, wy) in zip(e, w, strict=True)])


@dataclass(frozen=True, eq=False)
class ReachResult:
    """The least time to a goal (:func:`least_time`).

    Attributes
    ----------
    time_s : float
        Earliest arrival at the goal's cell, s from the wind's time 0 (inf: not reached by
        ``t_end``).
    path : ndarray of shape (K, 2)
        Cell centres of the fastest route, start and goal included, m (empty when not reached).
    length_m : float
        Length of ``path``, m (inf when not reached).
    airspeed_max : float
        The airspeed limit used, m/s.
    unsteady : bool
        Whether the wind was the recorded frames (else steady).
    """

    time_s: float
    path: np.ndarray
    length_m: float
    airspeed_max: float
    unsteady: bool

    @property
    def reached(self) -> bool:
        """Whether the goal was reached by ``t_end``."""
        return bool(np.isfinite(self.time_s))


@dataclass(frozen=True, eq=False)
class ReachLattice:
    """A city and its wind on the search lattice of :func:`least_time` (:func:`reach_lattice`).

    Attributes
    ----------
    x, y : ndarray of shape (nx,), (ny,)
        Cell centres, m.
    free : ndarray of shape (ny, nx) of bool
        Cells farther than ``clearance`` from every building.
    frames : ndarray of shape (T, ny, nx, 2)
        The wind at the cells, m/s, world frame (``T = 1``: steady).
    t0, dt_frames : float
        Time of the first frame and the spacing of the frames, s.
    dx, clearance : float
        Lattice spacing and building clearance, m.
    gust : ndarray of shape (ny, nx, 3) or None
        The covariance of the wind at the cells, ``(var u, cov uv, var v)``, m^2/s^2
        (:func:`wind_covariance`), for the gust-aware searches (``gust_k > 0``); None: not
        known.
    """

    x: np.ndarray
    y: np.ndarray
    free: np.ndarray
    frames: np.ndarray
    t0: float
    dt_frames: float
    dx: float
    clearance: float
    gust: np.ndarray | None = None

    def __post_init__(self):
        # float64, as reach_lattice builds them: a lattice built by hand from float32 arrays
        # searched in float32 (last bits, 5e-8 relative; audit); float64 arrays are kept as given
        for name in ("x", "y", "frames", "gust"):
            value = getattr(self, name)
            if value is not None:
                object.__setattr__(self, name, np.asarray(value, dtype=np.float64))

    @property
    def unsteady(self) -> bool:
        """Whether the wind has more than one frame."""
        return self.frames.shape[0] > 1


def wind_covariance(solution, every: int = 4) -> np.ndarray:
    """The covariance of a recorded wind at each of its cells, over every ``every``-th frame.

    Parameters
    ----------
    solution : FlowSolution
        With recorded frames (``frames_u``, ``frames_v`` of shape (T, ny, nx)).
    every : int
        Frame stride (>= 1): at the suite's 0.25 s frames, 4 takes one frame a second. On a
        10 m/s suite wind (``thesis/m12/w14``, 400 frames) the standard deviation along the
        inlet then differs from all frames' by 0.013 m/s on average (0.45 % of its 2.96 m/s
        mean over the fluid), in 0.064 s instead of 0.25 s.

    Returns
    -------
    ndarray of shape (ny, nx, 3)
        ``(var u, cov uv, var v)`` about the frames' own mean, m^2/s^2, on the solution's
        grid (``reach_lattice(..., gust=)``).
    """
    where = "wind_covariance"
    fu = getattr(solution, "frames_u", None)
    fv = getattr(solution, "frames_v", None)
    if fu is None or fv is None:
        raise ValueError(f"The 'solution' parameter of {where} must have recorded frames "
                         f"(simulate with record_every > 0). Got {type(solution).__name__} "
                         "without them instead.")
    if isinstance(every, bool) or not isinstance(every, (int, np.integer)) or every < 1:
        raise ValueError(f"The 'every' parameter of {where} must be an integer >= 1. Got "
                         f"{every!r} instead.")
    fu = np.asarray(fu, dtype=np.float64)
    fv = np.asarray(fv, dtype=np.float64)
    out = np.empty(fu.shape[1:] + (3,))
    SK.frame_covariance(fu, fv, int(every), out)
    return out


def reach_lattice(city, wind, *, dx: float = 2.0, clearance: float = 1.0,
                  gust=None) -> ReachLattice:
    """Rasterise ``city`` and sample ``wind`` on the lattice of :func:`least_time`.

    Parameters
    ----------
    city : windnav.city.City
    wind : FlowSolution, GriddedWind or array_like of shape (2,)
        A :class:`~windnav.flow.FlowSolution` (its recorded frames when it has them, else its
        mean field), a :class:`~windnav.wind.GriddedWind` (steady, or unsteady with evenly
        spaced frames; resampled bilinearly at the cells), or a uniform wind, m/s.
    dx : float
        Lattice spacing, m.
    clearance : float
        Distance kept from every building, m (the vehicle's size), to within ``dx / 2``
        (:func:`windnav.plan.graph_search.free_space`).
    gust : ndarray of shape (ny_w, nx_w, 3), optional
        The wind's covariance on the grid of ``wind`` (a GriddedWind, or a FlowSolution's)
        (:func:`wind_covariance`), resampled bilinearly at the cells into
        :attr:`ReachLattice.gust`.

    Returns
    -------
    ReachLattice
    """
    from windnav.wind.gridded import GriddedWind, _bracket

    where = "reach_lattice"
    check_city(city, where)
    dx = positive_float(dx, "dx", where)
    clearance = positive_float(clearance, "clearance", where, allow_zero=True)
    x, y, free = free_space(city, dx, clearance)
    if hasattr(wind, "frames_u") and hasattr(wind, "mean_u"):  # a FlowSolution
        wind = wind.wind_field(unsteady=wind.frames_u is not None)
    t0, dt_frames = 0.0, 1.0
    gust_cells = None
    if gust is not None:
        if not isinstance(wind, GriddedWind):
            raise ValueError(f"The 'gust' parameter of {where} needs a gridded wind (a "
                             f"GriddedWind or FlowSolution). Got a {type(wind).__name__} "
                             "instead.")
        gust = np.asarray(gust, dtype=np.float64)
        if gust.shape != (wind.y.size, wind.x.size, 3) or not np.all(np.isfinite(gust)):
            raise ValueError(f"The 'gust' parameter of {where} must be a finite covariance of "
                             f"shape {(wind.y.size, wind.x.size, 3)} (the wind's grid). Got "
                             f"shape {gust.shape} instead.")
    if isinstance(wind, GriddedWind):
        i0, a = _bracket(wind.x, x)
        j0, b = _bracket(wind.y, y)
        src = wind._frames
        frames = np.empty((src.shape[0], y.size, x.size, 2))
        SK.resample_frames(src, i0, a, j0, b, frames)
        if gust is not None:
            pairs = np.empty((2, y.size, x.size, 2))
            SK.resample_frames(np.stack([gust[..., :2], gust[..., 1:]]), i0, a, j0, b, pairs)
            gust_cells = np.ascontiguousarray(np.dstack([pairs[0], pairs[1, ..., 1]]))
        if wind.t is not None:
            steps = np.diff(wind.t)
            if steps.size and np.ptp(steps) > 1e-9 * steps[0]:
                raise ValueError(f"The 'wind' parameter of {where} must have evenly spaced "
                                 f"frames. Got steps from {steps.min()} to {steps.max()} s "
                                 "instead.")
            t0, dt_frames = float(wind.t[0]), float(steps[0]) if steps.size else 1.0
    else:
        w = batch_array(wind, "wind", where, (2,), batch=1)[0]
        frames = np.broadcast_to(w, (1, y.size, x.size, 2)).copy()
    return ReachLattice(x=x, y=y, free=np.ascontiguousarray(free), frames=frames, t0=t0,
                        dt_frames=dt_frames, dx=dx, clearance=clearance, gust=gust_cells)


def _gust_k(lattice: ReachLattice, gust_k, where: str) -> float:
    """``gust_k`` checked (>= 0; > 0 needs a steady lattice with :attr:`~ReachLattice.gust`)."""
    k = positive_float(gust_k, "gust_k", where, allow_zero=True)
    if k > 0 and (lattice.gust is None or lattice.unsteady):
        raise ValueError(f"The 'gust_k' parameter of {where} needs a steady lattice built with "
                         f"reach_lattice(..., gust=). Got gust_k={k!r} with "
                         f"{'an unsteady' if lattice.unsteady else 'no gust'} lattice instead.")
    return k


def least_time(
    lattice: ReachLattice,
    start_xy,
    goal_xy,
    *,
    airspeed_max: float,
    t_start: float = 0.0,
    t_end: float = np.inf,
    goal_radius: float = 0.0,
    gust_k: float = 0.0,
    wait: str = "blocked",
) -> ReachResult:
    """Earliest arrival at ``goal_xy`` (or within ``goal_radius`` of it) from ``start_xy``
    within an airspeed limit.

    Parameters
    ----------
    lattice : ReachLattice
        The city and its wind (:func:`reach_lattice`).
    start_xy, goal_xy : array_like of shape (2,)
        m, world.
    airspeed_max : float
        Largest airspeed, m/s, e.g. the vehicle's ``airspeed_limit``.
    t_start : float
        Departure time in the wind's clock, s.
    t_end : float
        Arrivals after this time count as not reached, s (the end of a recorded wind).
    goal_radius : float
        Arriving at any free cell whose centre lies within this distance of the goal counts,
        m (0: the goal's cell).
    gust_k : float
        Gust margin (>= 0): each move's ground speed is lowered by ``gust_k`` standard
        deviations of the wind along it (the lattice's :attr:`~ReachLattice.gust`), so that
        routes avoid the streets whose gusts stop the vehicle more than their mean wind says.
        0: the mean wind alone. Steady lattices only.
    wait : {"blocked", "best"}
        When the vehicle may hover before a move, in an unsteady wind: ``"blocked"`` (the
        default, the rule of the committed feasibility study) only where the move cannot be
        flown, a frame at a time; ``"best"`` also before a move it could fly, at any later
        frame time that arrives sooner. Neither changes a steady wind's answer. With
        ``"blocked"`` the time is that of a route flown within the limit, and the least time
        only where no move arrives sooner by departing later (see the module docstring).

    Returns
    -------
    ReachResult

    Raises
    ------
    ValueError
        On invalid arguments, or a start or goal inside a building's clearance.
    """
    where = "least_time"
    if not isinstance(lattice, ReachLattice):
        raise ValueError(f"The 'lattice' parameter of {where} must be a ReachLattice (from "
                         f"reach_lattice). Got {type(lattice).__name__} instead.")
    a_max = _airspeed(airspeed_max, where)
    t_start = finite_float(t_start, "t_start", where)
    t_end = float(t_end)
    if not t_end > t_start:
        raise ValueError(f"The 't_end' parameter of {where} must be greater than t_start "
                         f"({t_start}). Got {t_end!r} instead.")
    radius = positive_float(goal_radius, "goal_radius", where, allow_zero=True)
    k = _gust_k(lattice, gust_k, where)
    if wait not in ("blocked", "best"):
        raise ValueError(f"The 'wait' parameter of {where} must be 'blocked' or 'best'. Got "
                         f"{wait!r} instead.")
    start = batch_array(start_xy, "start_xy", where, (2,), batch=1)[0]
    goal = batch_array(goal_xy, "goal_xy", where, (2,), batch=1)[0]
    lat = lattice
    gust = lat.gust if k > 0 else np.zeros((1, 1, 3))
    s = free_cell(start, "start_xy", lat.x, lat.y, lat.free, lat.dx, lat.clearance, where)
    g = free_cell(goal, "goal_xy", lat.x, lat.y, lat.free, lat.dx, lat.clearance, where)
    arrival = np.empty(lat.free.size)
    pred = np.empty(lat.free.size, np.int64)
    SK.earliest_arrival(lat.free, lat.frames, lat.t0, lat.dt_frames, MOVES, _guards(MOVES),
                        lat.dx, a_max, s, t_start, t_end, -1 if radius > 0 else g, arrival,
                        pred, gust, k, wait == "best")
    if radius > 0:  # the first cell reached inside the goal's disk
        gx, gy = np.meshgrid(lat.x, lat.y)
        near = np.flatnonzero((np.hypot(gx - goal[0], gy - goal[1]) <= radius).ravel()
                              & lat.free.ravel())
        near = np.append(near, g)
        g = int(near[np.argmin(arrival[near])])
        goal = np.array([lat.x[g % lat.x.size], lat.y[g // lat.x.size]])
    t_goal = arrival[g]
    if not (np.isfinite(t_goal) and t_goal <= t_end):
        return ReachResult(time_s=float("inf"), path=np.zeros((0, 2)), length_m=float("inf"),
                           airspeed_max=a_max, unsteady=lat.unsteady)
    path = cell_path(pred, s, g, lat.x, lat.y, start, goal)
    return ReachResult(time_s=float(t_goal), path=path,
                       length_m=float(np.hypot(*np.diff(path, axis=0).T).sum()),
                       airspeed_max=a_max, unsteady=lat.unsteady)


@dataclass(frozen=True, eq=False)
class FastestRoute:
    """The least-time route of :func:`fastest_route` and the ground speeds to fly it.

    Attributes
    ----------
    samples : ndarray of shape (M, 2)
        The route's points, from the start to the goal, m (world).
    speeds : ndarray of shape (M - 1,)
        Ground speed of each piece, m/s: the largest whose airspeed in the lattice's (steady)
        wind stays within ``airspeed_max`` (:func:`max_ground_speed`), at most ``speed_max``.
    time_s : float
        Flight time at ``speeds``, s.
    length_m : float
        m.
    airspeed_max : float
        m/s.
    """

    samples: np.ndarray
    speeds: np.ndarray
    time_s: float
    length_m: float
    airspeed_max: float


def nearest_free_cell(lattice: ReachLattice, point_xy, max_distance: float = np.inf):
    """Centre (2,) of the free cell of ``lattice`` nearest ``point_xy``, m; None when none lies
    within ``max_distance`` (m, >= 0)."""
    where = "nearest_free_cell"
    p = batch_array(point_xy, "point_xy", where, (2,), batch=1)[0]  # NaN found a cell
    max_distance = float(max_distance)
    if not max_distance >= 0:  # a negative one was ignored
        raise ValueError(f"The 'max_distance' parameter of {where} must be >= 0 (inf allowed). "
                         f"Got {max_distance!r} instead.")
    j, i = np.nonzero(lattice.free)
    if i.size == 0:
        return None
    d2 = (lattice.x[i] - p[0]) ** 2 + (lattice.y[j] - p[1]) ** 2
    k = int(np.argmin(d2))
    if d2[k] > max_distance**2:
        return None
    return np.array([lattice.x[i[k]], lattice.y[j[k]]])


def fastest_route(lattice: ReachLattice, start_xy, goal_xy, *, airspeed_max: float,
                  speed_max: float = 20.0, snap_m: float = 20.0,
                  gust_k: float = 0.0) -> FastestRoute | None:
    """The least-time route from ``start_xy`` to ``goal_xy`` in a steady wind, with the ground
    speed of each piece (:func:`least_time`, then :func:`max_ground_speed` in the mean of the
    wind at the piece's two end cells; with ``gust_k > 0`` the search weighs the gusts).

    A start inside the clearance of a building (a vehicle stalled beside one) joins the lattice
    at the nearest free cell within ``snap_m``, flown straight at 2 m/s.

    Parameters
    ----------
    lattice : ReachLattice
        Steady (one frame).
    start_xy, goal_xy : array_like of shape (2,)
        m, world; the goal must lie in a free cell.
    airspeed_max : float
        m/s (> 0).
    speed_max : float
        Largest ground speed flown, m/s (> 0).
    snap_m : float
        How far a start may lie from the nearest free cell, m (>= 0).
    gust_k : float
        Gust margin of the search (:func:`least_time`), >= 0: the route keeps out of the
        streets whose gusts would slow it; its pieces' ``speeds`` and ``time_s`` are still
        those of the mean wind (lowering them as well was tried in the benchmark and lost
        flights: docs/navigation.md).

    Returns
    -------
    FastestRoute or None
        None when the goal cannot be reached within ``airspeed_max``, or the start lies
        farther than ``snap_m`` from every free cell.
    """
    where = "fastest_route"
    if not isinstance(lattice, ReachLattice) or lattice.unsteady:
        raise ValueError(f"The 'lattice' parameter of {where} must be a steady ReachLattice. "
                         f"Got {type(lattice).__name__} instead.")
    a_max = _airspeed(airspeed_max, where)
    v_cap = positive_float(speed_max, "speed_max", where)
    if v_cap < MIN_ROUTE_SPEED:  # the pieces are flown at least this fast: 0.5 > 1e-300
        raise ValueError(f"The 'speed_max' parameter of {where} must be at least "
                         f"{MIN_ROUTE_SPEED:g} m/s, the slowest piece flown. Got {speed_max!r} "
                         "instead.")
    snap = positive_float(snap_m, "snap_m", where, allow_zero=True)
    k = _gust_k(lattice, gust_k, where)
    start = batch_array(start_xy, "start_xy", where, (2,), batch=1)[0]
    goal = batch_array(goal_xy, "goal_xy", where, (2,), batch=1)[0]
    nx = lattice.x.size
    i = int(np.clip(np.round((start[0] - lattice.x[0]) / lattice.dx), 0, nx - 1))
    j = int(np.clip(np.round((start[1] - lattice.y[0]) / lattice.dx), 0, lattice.y.size - 1))
    entry = start if lattice.free[j, i] else nearest_free_cell(lattice, start, snap)
    if entry is None:
        return None
    result = least_time(lattice, entry, goal, airspeed_max=a_max, gust_k=k)
    if not result.reached:
        return None
    path = result.path if entry is start else np.vstack([start, result.path])
    pieces = np.diff(path, axis=0)
    keep = np.hypot(pieces[:, 0], pieces[:, 1]) > 1e-9
    path = np.vstack([path[:1], path[1:][keep]])
    pieces = pieces[keep]
    lengths = np.hypot(pieces[:, 0], pieces[:, 1])
    if lengths.size == 0:
        return FastestRoute(samples=path, speeds=np.zeros(0), time_s=0.0, length_m=0.0,
                            airspeed_max=a_max)
    ci = np.clip(np.round((path[:, 0] - lattice.x[0]) / lattice.dx), 0, nx - 1).astype(int)
    cj = np.clip(np.round((path[:, 1] - lattice.y[0]) / lattice.dx), 0,
                 lattice.y.size - 1).astype(int)
    w_cells = lattice.frames[0, cj, ci]
    wind = 0.5 * (w_cells[:-1] + w_cells[1:])
    speeds = np.minimum(max_ground_speed(pieces, wind, a_max), v_cap)
    if entry is not start:  # the way out of the clearance
        speeds[0] = min(2.0, v_cap)
    speeds = np.maximum(speeds, MIN_ROUTE_SPEED)
    return FastestRoute(samples=path, speeds=speeds, time_s=float(np.sum(lengths / speeds)),
                        length_m=float(lengths.sum()), airspeed_max=a_max)
