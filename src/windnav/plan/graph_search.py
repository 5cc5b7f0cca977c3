"""Global graph search on an occupancy grid: shortest collision-free routes through a city.

The map is rasterised at ``dx`` and buildings are inflated by ``clearance`` (a disk, via a
Euclidean distance transform); free cells form an 8-connected graph with edge lengths dx or
sqrt(2) dx, solved with Dijkstra (``scipy.sparse.csgraph``). The cell path is then shortened by
line-of-sight pruning so the result is a short list of waypoints. No torch: this is the
baseline the energy-aware planner is compared with.
"""

from __future__ import annotations

import numpy as np
import scipy.ndimage
import scipy.sparse
import scipy.sparse.csgraph

from windnav._validate import batch_array, positive_float
from windnav.city.core import check_city

BYTES_PER_FREE_CELL = {"grid_route": 650.0, "energy_route": 1000.0}
"""Peak bytes per free lattice cell of each search's graph (edges, the sparse matrix, Dijkstra's
arrays), with a margin over the measured 480 and 730 B per cell (scale audit, 2026-12-05)."""


def check_lattice_memory(free: np.ndarray, where: str) -> None:
    """Refuse a search whose graph over the ``free`` cells would not fit the memory limit
    (an 8 km map at dx = 1 m needs about 47 GB: a bare ``MemoryError``, or the out-of-memory
    killer, before; scale audit, 2026-12-05)."""
    from windnav.flow.memory import refuse_above_limit

    n_free = int(np.count_nonzero(free))
    refuse_above_limit(BYTES_PER_FREE_CELL[where] * n_free, where,
                       f"a lattice of {free.shape[0]} x {free.shape[1]} cells ({n_free} free) "
                       "for its graph", "Use a larger dx or a smaller map")


def free_space(city, dx: float, clearance: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Cell centres ``x`` (nx,), ``y`` (ny,) and the free mask (ny, nx) after inflation.

    Occupancy is conservative (``rasterize(rule="overlap")``): a cell touched by a building
    is solid, so no route passes through a building thinner than a cell. A cell is free when
    its centre lies more than ``clearance`` (m) from the centre of every solid cell; a
    building's edge may lie up to ``dx / 2`` nearer than that (5.1 m at ``clearance`` 6 and
    ``dx`` 2: audit, 2026-12-05)."""
    x, y = city.grid(dx)
    solid = city.rasterize(x, y, rule="overlap")
    if not solid.any():  # the transform needs a background cell; with none, all is free
        return x, y, np.ones_like(solid)
    dist = scipy.ndimage.distance_transform_edt(~solid, sampling=dx)
    return x, y, dist > clearance


def free_cell(p, name: str, x, y, free, dx: float, clearance: float, where: str) -> int:
    """Flat index (``j * nx + i``) of the grid cell nearest ``p`` (m); a ValueError naming
    ``name`` when ``p`` lies outside the grid's cells (off the map) or that cell is not free
    (inside a building or its ``clearance``, m)."""
    half = 0.5 * dx * (1.0 + 1e-9)
    if not (x[0] - half <= p[0] <= x[-1] + half and y[0] - half <= p[1] <= y[-1] + half):
        raise ValueError(f"The '{name}' parameter of {where} must lie inside the map (x in "
                         f"[{x[0] - 0.5 * dx:g}, {x[-1] + 0.5 * dx:g}], y in "
                         f"[{y[0] - 0.5 * dx:g}, {y[-1] + 0.5 * dx:g}] m). Got {p.tolist()} "
                         "instead.")
    i = int(np.clip(np.round((p[0] - x[0]) / dx), 0, len(x) - 1))
    j = int(np.clip(np.round((p[1] - y[0]) / dx), 0, len(y) - 1))
    if not free[j, i]:
        raise ValueError(f"The '{name}' parameter of {where} lies inside a building or within "
                         f"{clearance} m of one. Got {p.tolist()} instead.")
    return j * len(x) + i


def cell_path(pred, s: int, g: int, x, y, start, goal) -> np.ndarray:
    """Cell centres (K, 2), m, of the shortest-path tree ``pred`` from cell ``s`` to ``g``,
    with the exact ``start`` and ``goal`` as end points."""
    order = [g]
    while order[-1] != s:
        order.append(pred[order[-1]])
    order = np.array(order[::-1])
    path = np.stack([x[order % len(x)], y[order // len(x)]], axis=1)
    path[0], path[-1] = start, goal
    return path


def _grid_graph(free: np.ndarray, dx: float) -> scipy.sparse.csr_matrix:
    """8-connected graph of the free cells (no corner cutting), edge weights in metres."""
    ny, nx = free.shape
    F = np.pad(free, 1, constant_values=False)
    idx = np.pad(np.arange(ny * nx).reshape(ny, nx), 1, constant_values=-1)

    def shifted(a, dj, di):
        return a[1 + dj:ny + 1 + dj, 1 + di:nx + 1 + di]

    rows, cols, w = [], [], []
    for dj, di in ((0, 1), (1, 0), (1, 1), (1, -1)):
        ok = free & shifted(F, dj, di)
        if dj and di:
            ok &= shifted(F, dj, 0) & shifted(F, 0, di)
        rows.append(shifted(idx, 0, 0)[ok])
        cols.append(shifted(idx, dj, di)[ok])
        w.append(np.full(int(ok.sum()), dx * np.hypot(di, dj)))
    r = np.concatenate(rows)
    c = np.concatenate(cols)
    ww = np.concatenate(w)
    return scipy.sparse.csr_matrix((np.r_[ww, ww], (np.r_[r, c], np.r_[c, r])),
                                   shape=(ny * nx, ny * nx))


def _line_free(free, x, y, p, q, dx) -> bool:
    n = int(np.ceil(np.hypot(*(q - p)) / (0.25 * dx))) + 1
    s = np.linspace(0.0, 1.0, n)
    pts = p[None] + s[:, None] * (q - p)[None]
    i = np.clip(np.round((pts[:, 0] - x[0]) / dx).astype(int), 0, len(x) - 1)
    j = np.clip(np.round((pts[:, 1] - y[0]) / dx).astype(int), 0, len(y) - 1)
    return bool(np.all(free[j, i]))


def grid_route(city, start_xy, goal_xy, *, dx: float = 2.0, clearance: float = 6.0) -> dict:
    """Shortest collision-free route from ``start_xy`` to ``goal_xy`` (m, world x-y).

    Parameters
    ----------
    city : windnav.city.City
    start_xy, goal_xy : array_like of shape (2,)
    dx : float
        Grid resolution, m.
    clearance : float
        Distance kept from every building, m, to within ``dx / 2`` (:func:`free_space`).

    Returns
    -------
    dict with ``waypoints`` (K, 2) (pruned, start and goal included), ``path`` (L, 2) the cell
    path, and ``length`` (m) of the pruned route.

    Raises
    ------
    ValueError
        If the start or goal lies inside a building's clearance, or no route exists.
    """
    where = "grid_route"
    check_city(city, where)
    dx = positive_float(dx, "dx", where)
    clearance = positive_float(clearance, "clearance", where, allow_zero=True)
    start = batch_array(start_xy, "start_xy", where, (2,), batch=1)[0]
    goal = batch_array(goal_xy, "goal_xy", where, (2,), batch=1)[0]
    x, y, free = free_space(city, dx, clearance)
    check_lattice_memory(free, where)

    s = free_cell(start, "start_xy", x, y, free, dx, clearance, where)
    g = free_cell(goal, "goal_xy", x, y, free, dx, clearance, where)
    graph = _grid_graph(free, dx)
    dist, pred = scipy.sparse.csgraph.dijkstra(graph, indices=s, return_predecessors=True)
    if not np.isfinite(dist[g]):
        raise ValueError(f"The 'goal_xy' parameter of {where} cannot be reached from start_xy "
                         f"with {clearance} m clearance. Got {goal.tolist()} instead.")
    path = cell_path(pred, s, g, x, y, start, goal)
    # line-of-sight pruning
    keep = [0]
    k = 0
    while k < len(path) - 1:
        nxt = len(path) - 1
        while nxt > k + 1 and not _line_free(free, x, y, path[k], path[nxt], dx):
            nxt -= 1
        keep.append(nxt)
        k = nxt
    wp = path[keep]
    return {"waypoints": wp, "path": path,
            "length": float(np.sum(np.linalg.norm(np.diff(wp, axis=0), axis=1)))}
