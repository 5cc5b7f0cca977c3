"""GS and GS+W: energy-optimal routes by graph search over position and ground speed.

The global baseline of the thesis (Folk 2026, ch. 5) knows every obstacle and, for GS+W, the
mean wind field ``w(x, y)``; GS plans with ``w = 0``. A route is flown at ground speed
``|v| in [0.5, 20]`` m/s, and flying ``dL`` metres along the unit vector ``e`` at ground speed
``v`` costs the energy ::

    dE = P(|v e - w|) / v dL        (J; P the steady-flight power curve of PlannerConfig)

The lattice. Nodes are (free cell, speed level): the map rasterised at ``dx`` with buildings
inflated by ``clearance`` (:func:`windnav.plan.graph_search.free_space`), times the speed
levels. Moves go to the 16 neighbours (8 adjacent cells and 8 knight moves, so that straight
lines are followed within 3 degrees) and never cut a blocked cell. A move's energy uses the mean
wind of its two cells. Speed changes between moves are not constrained (the planner's vehicle
changes speed by its ``a_max`` in far less than a cell: 70 m/s^2 for the Hummingbird), so the
(cell, speed) graph's shortest path takes each move at that move's best level; the search
therefore runs Dijkstra on the cell graph with each edge weighted by its minimum over the levels
- the same optimum on a graph |levels| times smaller.

Post-processing. The cell path is shortened greedily by straight segments that are free and cost
no more energy than the lattice sub-path they replace; every segment is then cut into pieces of
at most ``dx / 2`` and each piece is flown at its continuous optimum ``argmin_v P(|v e - w|)/v``
(golden section), which is the maximum-range speed ``V_R(W)`` in a uniform wind.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np
import scipy.sparse
import scipy.sparse.csgraph

from windnav._validate import batch_array, finite_float, positive_float
from windnav._validate import speed_range as check_speed_range
from windnav.city.core import check_city
from windnav.plan import _search_kernels as SK
from windnav.plan.config import PlannerConfig
from windnav.plan.graph_search import cell_path, check_lattice_memory, free_cell, free_space

__all__ = ["MOVES", "EnergyRoute", "energy_route"]

MOVES = np.array([(1, 0), (0, 1), (-1, 0), (0, -1), (1, 1), (-1, 1), (-1, -1), (1, -1),
                  (2, 1), (1, 2), (-1, 2), (-2, 1), (-2, -1), (-1, -2), (1, -2), (2, -1)])
"""The 16 lattice moves ``(di, dj)`` in cells."""


def _guards(moves: np.ndarray) -> np.ndarray:
    """Cells a straight move passes through besides its ends, padded with (0, 0)."""
    out = np.zeros((len(moves), 2, 2), dtype=np.int64)
    for m, (di, dj) in enumerate(moves):
        si, sj = np.sign(di), np.sign(dj)
        if abs(di) == 1 and abs(dj) == 1:
            out[m] = [(di, 0), (0, dj)]
        elif abs(di) == 2:
            out[m] = [(si, 0), (si, dj)]
        elif abs(dj) == 2:
            out[m] = [(0, sj), (di, sj)]
    return out


@dataclass(frozen=True, eq=False)
class EnergyRoute:
    """An energy-optimal route and the speeds to fly it.

    Attributes
    ----------
    waypoints : ndarray of shape (M, 2)
        Corners of the route, start and goal included, m (world).
    samples : ndarray of shape (N + 1, 2)
        The route cut into N pieces of at most ``dx / 2``, m.
    speeds : ndarray of shape (N,)
        Ground speed of each piece, m/s.
    airspeeds : ndarray of shape (N,)
        Airspeed of each piece, m/s.
    energy : float
        Energy of the route flown at ``speeds`` in the planning wind, J.
    time : float
        Flight time, s.
    length : float
        Length, m.
    lattice_energy : float
        Energy of the lattice path before shortening, J.
    path : ndarray of shape (L, 2)
        The lattice (cell) path, m.
    variant : str
        ``"gs"`` or ``"gs-w"``.
    """

    waypoints: np.ndarray
    samples: np.ndarray
    speeds: np.ndarray
    airspeeds: np.ndarray
    energy: float
    time: float
    length: float
    lattice_energy: float
    path: np.ndarray
    variant: str


def _wind_grid(wind, x, y, altitude, use_wind, where) -> np.ndarray:
    """Wind at the cell centres, (ny, nx, 2) m/s."""
    out = np.zeros((y.size, x.size, 2))
    if wind is None or not use_wind:
        return out
    if hasattr(wind, "velocity"):
        X, Y = np.meshgrid(x, y)
        xyz = np.stack([X.ravel(), Y.ravel(), np.full(X.size, altitude)], axis=1)
        got = wind.velocity(0.0, xyz)
        if np.ndim(got) != 2 or np.shape(got)[0] != X.size or np.shape(got)[1] < 2:
            # a NumPy reshape error from inside before
            raise ValueError(f"The 'wind' parameter of {where} must be a WindField whose "
                             f"velocity(t, xyz) of N points is (N, 2) or (N, 3), m/s. Got shape "
                             f"{np.shape(got)} for {X.size} points instead.")
        out[...] = np.asarray(got)[:, :2].reshape(y.size, x.size, 2)
    else:
        try:
            w = np.asarray(wind, dtype=np.float64)
        except (TypeError, ValueError):  # NumPy's "could not convert string to float"
            raise ValueError(f"The 'wind' parameter of {where} must be None, a (2,) vector or "
                             f"a WindField. Got {type(wind).__name__} {wind!r:.60} instead."
                             ) from None
        if w.shape != (2,):
            raise ValueError(f"The 'wind' parameter of {where} must be None, a (2,) vector or a "
                             f"WindField. Got shape {w.shape} instead.")
        out[...] = w
    if not np.all(np.isfinite(out)):
        raise ValueError(f"The 'wind' parameter of {where} must be finite over the map. Got "
                         "non-finite values instead.")
    return out


def _ignored_wind_matters(wind) -> bool:
    """Whether a ``wind`` that a still-air config ignores could have changed the route: any
    WindField (not sampled here), any uniform vector but zero."""
    if hasattr(wind, "velocity"):
        return True
    try:
        return bool(np.any(np.asarray(wind, dtype=np.float64) != 0.0))
    except (TypeError, ValueError):
        return True


MAX_SPEED_LEVELS = 100_000
"""The most ground-speed levels :func:`energy_route`'s lattice may have."""


def energy_route(
    city,
    start_xy,
    goal_xy,
    config: PlannerConfig,
    *,
    wind=None,
    dx: float = 2.0,
    clearance: float = 6.0,
    speed_range: tuple = (0.5, 20.0),
    speed_step: float = 0.25,
    altitude: float = 10.0,
) -> EnergyRoute:
    """Energy-optimal route from ``start_xy`` to ``goal_xy`` through ``city`` (GS / GS+W).

    Parameters
    ----------
    city : windnav.city.City
    start_xy, goal_xy : array_like of shape (2,)
        m, world.
    config : PlannerConfig
        Supplies the power curve; ``config.use_wind`` (variant ``"gs-w"``) decides whether
        ``wind`` is used (``"gs"``: planned in still air).
    wind : WindField or array_like of shape (2,), optional
        The mean wind: any object with ``velocity(t, xyz)`` (e.g. ``FlowSolution.wind_field()``,
        sampled once at the cell centres at ``t = 0``, height ``altitude``) or a uniform vector,
        m/s. A still-air config (``config.use_wind`` False, ``"gs"``) ignores it, with a
        UserWarning unless it is None or a zero vector.
    dx : float
        Lattice spacing, m.
    clearance : float
        Distance kept from every building, m, to within ``dx / 2``
        (:func:`windnav.plan.graph_search.free_space`).
    speed_range : (float, float)
        Ground speeds allowed, m/s.
    speed_step : float
        Spacing of the lattice's speed levels, m/s.
    altitude : float
        Height at which a WindField is sampled, m.

    Returns
    -------
    EnergyRoute

    Raises
    ------
    ValueError
        On invalid arguments, a start or goal inside a building's clearance, or no route.
    """
    where = "energy_route"
    check_city(city, where)
    if not isinstance(config, PlannerConfig):
        raise ValueError(f"The 'config' parameter of {where} must be a PlannerConfig. Got "
                         f"{type(config).__name__} instead.")
    if wind is not None and not config.use_wind and _ignored_wind_matters(wind):
        warnings.warn(f"The 'wind' parameter of {where} is ignored: the config "
                      f"(variant {config.variant!r}, use_wind False) plans in still air. Pass "
                      "wind=None for that, or a wind-aware config (planner_config(vehicle, "
                      "'gs-w')) to plan in the wind.", UserWarning, stacklevel=2)
    dx = positive_float(dx, "dx", where)
    clearance = positive_float(clearance, "clearance", where, allow_zero=True)
    step = positive_float(speed_step, "speed_step", where)
    altitude = finite_float(altitude, "altitude", where)
    v_lo, v_hi = check_speed_range(speed_range, "speed_range", where)
    if (v_hi - v_lo) / step > MAX_SPEED_LEVELS:  # np.arange would allocate them all
        raise ValueError(f"The 'speed_step' parameter of {where} must give at most "
                         f"{MAX_SPEED_LEVELS} speed levels over {speed_range!r} m/s. Got "
                         f"{speed_step!r} instead.")
    start = batch_array(start_xy, "start_xy", where, (2,), batch=1)[0]
    goal = batch_array(goal_xy, "goal_xy", where, (2,), batch=1)[0]
    x, y, free = free_space(city, dx, clearance)
    check_lattice_memory(free, where)
    free = np.ascontiguousarray(free)
    wind_grid = _wind_grid(wind, x, y, altitude, config.use_wind, where)
    speeds = np.arange(v_lo, v_hi + 1e-9, step)
    if speeds[-1] < v_hi - 1e-9:
        speeds = np.append(speeds, v_hi)
    ptab = config.power_table()

    s = free_cell(start, "start_xy", x, y, free, dx, clearance, where)
    g = free_cell(goal, "goal_xy", x, y, free, dx, clearance, where)
    n_cap = int(free.sum()) * len(MOVES)
    rows = np.empty(n_cap, np.int64)
    cols = np.empty(n_cap, np.int64)
    weights = np.empty(n_cap)
    levels = np.empty(n_cap, np.int64)
    n = SK.edge_weights(free, wind_grid, MOVES, _guards(MOVES), dx, speeds, ptab, rows, cols,
                        weights, levels)
    graph = scipy.sparse.csr_matrix((weights[:n], (rows[:n], cols[:n])),
                                    shape=(free.size, free.size))
    dist, pred = scipy.sparse.csgraph.dijkstra(graph, directed=True, indices=s,
                                               return_predecessors=True)
    if not np.isfinite(dist[g]):
        raise ValueError(f"The 'goal_xy' parameter of {where} cannot be reached from start_xy "
                         f"with {clearance} m clearance. Got {goal.tolist()} instead.")
    path = np.ascontiguousarray(cell_path(pred, s, g, x, y, start, goal))
    buf = np.empty(int(np.ceil(4 * dx / (0.5 * dx))) + 8)
    seg = np.array([SK.segment(*path[t], *path[t + 1], free, x[0], y[0], dx, wind_grid, speeds,
                               ptab, False, buf)[0] for t in range(len(path) - 1)])
    prefix = np.concatenate([[0.0], np.cumsum(seg)])
    keep = np.empty(len(path), np.int64)
    m = SK.prune(path, prefix, free, x[0], y[0], dx, wind_grid, speeds, ptab, keep)
    waypoints = path[keep[:m]]
    samples, v_all, e_total = [waypoints[:1]], [], 0.0
    for p, q in zip(waypoints[:-1], waypoints[1:], strict=True):
        length = float(np.hypot(*(q - p)))
        vbuf = np.empty(int(np.ceil(length / (0.5 * dx))) + 2)
        e, k = SK.segment(p[0], p[1], q[0], q[1], free, x[0], y[0], dx, wind_grid, speeds,
                          ptab, True, vbuf)
        if not np.isfinite(e):  # a start/goal snapped off its cell centre: keep the leg
            e, k = SK.segment(p[0], p[1], q[0], q[1], np.ones_like(free), x[0], y[0], dx,
                              wind_grid, speeds, ptab, True, vbuf)
        e_total += e
        v_all.append(vbuf[:k].copy())
        samples.append(p + np.outer(np.arange(1, k + 1) / k, q - p))
    samples = np.concatenate(samples)
    v = np.concatenate(v_all) if v_all else np.zeros(0)
    pieces = np.diff(samples, axis=0)
    lengths = np.hypot(pieces[:, 0], pieces[:, 1])
    mids = 0.5 * (samples[1:] + samples[:-1])
    w_mid = _bilinear(wind_grid, x, y, dx, mids)
    e_dir = pieces / np.maximum(lengths, 1e-300)[:, None]
    air = np.hypot(*(v[:, None] * e_dir - w_mid).T) if v.size else np.zeros(0)
    return EnergyRoute(
        waypoints=waypoints, samples=samples, speeds=v, airspeeds=air,
        energy=float(e_total * config.hover_power),
        time=float(np.sum(lengths / v)) if v.size else 0.0,
        length=float(lengths.sum()),
        lattice_energy=float(dist[g] * config.hover_power),
        path=path, variant=config.variant if config.planner == "gs" else
        ("gs-w" if config.use_wind else "gs"),
    )


def _bilinear(grid, x, y, dx, pts) -> np.ndarray:
    fx = np.clip((pts[:, 0] - x[0]) / dx, 0, x.size - 1)
    fy = np.clip((pts[:, 1] - y[0]) / dx, 0, y.size - 1)
    i = np.minimum(fx.astype(int), x.size - 2)
    j = np.minimum(fy.astype(int), y.size - 2)
    a = (fx - i)[:, None]
    b = (fy - j)[:, None]
    return ((1 - a) * (1 - b) * grid[j, i] + a * (1 - b) * grid[j, i + 1]
            + (1 - a) * b * grid[j + 1, i] + a * b * grid[j + 1, i + 1])
