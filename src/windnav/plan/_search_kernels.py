"""Numba kernels of the energy-optimal graph search (private; see energy_search.py)."""

from __future__ import annotations

import math

import numpy as np

from windnav._jit import njit
from windnav.plan._kernels import power_bar

_GOLDEN = 0.5 * (math.sqrt(5.0) - 1.0)


@njit(cache=True, inline="always")
def energy_per_metre(v, ex, ey, wx, wy, ptab):  # pragma: no cover - numba
    """``P(|v e - w|) / (P_hover v)``: energy per metre of track at ground speed ``v`` along
    the unit vector ``e`` in the wind ``w``, in units of ``P_hover`` (s/m)."""
    ax = v * ex - wx
    ay = v * ey - wy
    return power_bar(math.sqrt(ax * ax + ay * ay), ptab) / v


@njit(cache=True)
def best_level(ex, ey, wx, wy, speeds, ptab):  # pragma: no cover - numba
    """Index of the speed level with the least energy per metre, and that energy."""
    best = np.inf
    j = 0
    for m in range(speeds.size):
        e = energy_per_metre(speeds[m], ex, ey, wx, wy, ptab)
        if e < best:
            best = e
            j = m
    return j, best


@njit(cache=True)
def best_speed(ex, ey, wx, wy, speeds, ptab):  # pragma: no cover - numba
    """Continuous minimiser of the energy per metre over ``[speeds[0], speeds[-1]]``: the best
    level, then golden-section search between its neighbours. Returns ``(v, e)``."""
    j, e = best_level(ex, ey, wx, wy, speeds, ptab)
    a = speeds[max(j - 1, 0)]
    b = speeds[min(j + 1, speeds.size - 1)]
    c = b - _GOLDEN * (b - a)
    d = a + _GOLDEN * (b - a)
    fc = energy_per_metre(c, ex, ey, wx, wy, ptab)
    fd = energy_per_metre(d, ex, ey, wx, wy, ptab)
    for _ in range(60):
        if fc < fd:
            b = d
            d = c
            fd = fc
            c = b - _GOLDEN * (b - a)
            fc = energy_per_metre(c, ex, ey, wx, wy, ptab)
        else:
            a = c
            c = d
            fc = fd
            d = a + _GOLDEN * (b - a)
            fd = energy_per_metre(d, ex, ey, wx, wy, ptab)
    v = 0.5 * (a + b)
    ev = energy_per_metre(v, ex, ey, wx, wy, ptab)
    if ev < e:
        return v, ev
    return speeds[j], e


@njit(cache=True, inline="always")
def move_ok(free, i, j, m, moves, guards):  # pragma: no cover - numba
    """Whether move ``m`` from cell ``(i, j)`` stays on the grid, ends in a free cell and passes
    only free guard cells (the cells the straight move crosses besides its ends)."""
    ny, nx = free.shape
    i2 = i + moves[m, 0]
    j2 = j + moves[m, 1]
    if i2 < 0 or j2 < 0 or i2 >= nx or j2 >= ny or not free[j2, i2]:
        return False
    for g in range(guards.shape[1]):
        if not free[j + guards[m, g, 1], i + guards[m, g, 0]]:
            return False
    return True


@njit(cache=True)
def edge_weights(free, wind, moves, guards, dx, speeds, ptab, rows, cols, weights,
                 levels):  # pragma: no cover - numba
    """Directed edges of the lattice and their energies (units of ``P_hover`` seconds).

    For every free cell and every move ``(di, dj)`` to a free cell whose guard cells (the cells
    the straight move passes through) are free: weight ``L min_v P(|v e - w|) / v`` with ``L``
    the move's length, ``e`` its direction, ``w`` the mean of the two cells' winds and ``v``
    over the speed levels. Returns the number of edges written.
    """
    ny, nx = free.shape
    n = 0
    for j in range(ny):
        for i in range(nx):
            if not free[j, i]:
                continue
            for m in range(moves.shape[0]):
                if not move_ok(free, i, j, m, moves, guards):
                    continue
                di = moves[m, 0]
                dj = moves[m, 1]
                i2 = i + di
                j2 = j + dj
                length = dx * math.sqrt(di * di + dj * dj)
                ex = di * dx / length
                ey = dj * dx / length
                wx = 0.5 * (wind[j, i, 0] + wind[j2, i2, 0])
                wy = 0.5 * (wind[j, i, 1] + wind[j2, i2, 1])
                lev, e = best_level(ex, ey, wx, wy, speeds, ptab)
                rows[n] = j * nx + i
                cols[n] = j2 * nx + i2
                weights[n] = length * e
                levels[n] = lev
                n += 1
    return n


@njit(cache=True, inline="always")
def _wind_bilinear(x, y, x0, y0, dx, wind):  # pragma: no cover - numba
    ny, nx = wind.shape[0], wind.shape[1]
    fx = min(max((x - x0) / dx, 0.0), nx - 1.0)
    fy = min(max((y - y0) / dx, 0.0), ny - 1.0)
    i = min(int(fx), nx - 2)
    j = min(int(fy), ny - 2)
    a = fx - i
    b = fy - j
    wx = ((1 - a) * (1 - b) * wind[j, i, 0] + a * (1 - b) * wind[j, i + 1, 0]
          + (1 - a) * b * wind[j + 1, i, 0] + a * b * wind[j + 1, i + 1, 0])
    wy = ((1 - a) * (1 - b) * wind[j, i, 1] + a * (1 - b) * wind[j, i + 1, 1]
          + (1 - a) * b * wind[j + 1, i, 1] + a * b * wind[j + 1, i + 1, 1])
    return wx, wy


@njit(cache=True)
def segment(px, py, qx, qy, free, x0, y0, dx, wind, speeds, ptab, refine,
            out_v):  # pragma: no cover - numba
    """Energy (units of ``P_hover`` s) of the straight segment p -> q flown at the best speed
    of each piece (pieces of at most ``dx / 2``), or inf when it meets a non-free cell.

    ``out_v`` (at least n pieces) receives each piece's speed; returns ``(energy, n)``.
    ``refine``: continuous speeds (golden section) instead of the levels.
    """
    ny, nx = free.shape
    lx = qx - px
    ly = qy - py
    length = math.sqrt(lx * lx + ly * ly)
    if length == 0.0:
        return 0.0, 0
    n = int(math.ceil(length / (0.5 * dx)))
    ex = lx / length
    ey = ly / length
    piece = length / n
    total = 0.0
    # collision: sample at quarter cells, nearest cell centre
    m = int(math.ceil(length / (0.25 * dx))) + 1
    for t in range(m):
        s = t / (m - 1)
        i = int(round((px + s * lx - x0) / dx))
        j = int(round((py + s * ly - y0) / dx))
        i = min(max(i, 0), nx - 1)
        j = min(max(j, 0), ny - 1)
        if not free[j, i]:
            return np.inf, 0
    for t in range(n):
        s = (t + 0.5) / n
        wx, wy = _wind_bilinear(px + s * lx, py + s * ly, x0, y0, dx, wind)
        if refine:
            v, e = best_speed(ex, ey, wx, wy, speeds, ptab)
        else:
            lev, e = best_level(ex, ey, wx, wy, speeds, ptab)
            v = speeds[lev]
        out_v[t] = v
        total += piece * e
    return total, n


@njit(cache=True)
def _shortcut_ok(path, prefix, k, m, free, x0, y0, dx, wind, speeds, ptab, buf):  # pragma: no cover
    e, _ = segment(path[k, 0], path[k, 1], path[m, 0], path[m, 1], free, x0, y0, dx, wind,
                   speeds, ptab, False, buf)
    return e <= prefix[m] - prefix[k] + 1e-9 * (1.0 + prefix[m])


@njit(cache=True)
def prune(path, prefix, free, x0, y0, dx, wind, speeds, ptab, keep):  # pragma: no cover
    """Greedy shortcutting of a cell path (L, 2): from each kept point, the straight segment to
    the goal if it is free and costs no more energy than the lattice sub-path (``prefix``:
    cumulative lattice energy along the path), else the farthest point reached by extending
    the segment one path point at a time while that holds. Returns the count kept."""
    L = path.shape[0]
    span = 0.0
    for t in range(L - 1):
        span += math.sqrt((path[t + 1, 0] - path[t, 0]) ** 2 + (path[t + 1, 1] - path[t, 1]) ** 2)
    buf = np.empty(int(math.ceil(span / (0.5 * dx))) + 8)
    keep[0] = 0
    n = 1
    k = 0
    while k < L - 1:
        if L - 1 > k + 1 and _shortcut_ok(path, prefix, k, L - 1, free, x0, y0, dx, wind,
                                          speeds, ptab, buf):
            nxt = L - 1
        else:
            nxt = k + 1
            while nxt + 1 < L - 1 and _shortcut_ok(path, prefix, k, nxt + 1, free, x0, y0, dx,
                                                   wind, speeds, ptab, buf):
                nxt += 1
        keep[n] = nxt
        n += 1
        k = nxt
    return n


# ------------------------------------------------------------------ least time (reach.py)


@njit(cache=True)
def resample_frames(frames, i0, a, j0, b, out):  # pragma: no cover - numba
    """``out[k, j, i] = `` bilinear of ``frames[k]`` (T, ny_w, nx_w, 2) between columns
    ``i0[i], i0[i] + 1`` (weight ``a[i]`` on the second) and rows ``j0[j], j0[j] + 1``
    (weight ``b[j]``)."""
    for k in range(out.shape[0]):
        for j in range(out.shape[1]):
            jj = j0[j]
            bb = b[j]
            for i in range(out.shape[2]):
                ii = i0[i]
                aa = a[i]
                for c in range(2):
                    out[k, j, i, c] = ((1 - bb) * ((1 - aa) * frames[k, jj, ii, c]
                                                   + aa * frames[k, jj, ii + 1, c])
                                       + bb * ((1 - aa) * frames[k, jj + 1, ii, c]
                                               + aa * frames[k, jj + 1, ii + 1, c]))


@njit(cache=True, inline="always")
def max_ground_speed(ex, ey, wx, wy, airspeed_max):  # pragma: no cover - numba
    """Largest ground speed ``v >= 0`` along the unit vector ``e`` with ``|v e - w| <=
    airspeed_max`` in the wind ``w`` (m/s): ``w.e + sqrt(A^2 - (w x e)^2)``, or 0 when no
    such ``v > 0`` exists (the crosswind exceeds ``A``, or the headwind does)."""
    along = wx * ex + wy * ey
    cross = wx * ey - wy * ex
    disc = airspeed_max * airspeed_max - cross * cross
    if disc < 0.0:
        return 0.0
    v = along + math.sqrt(disc)
    return v if v > 0.0 else 0.0


@njit(cache=True, inline="always")
def gust_ground_speed(ex, ey, wx, wy, suu, suv, svv, airspeed_max, gust_k):  # pragma: no cover
    """:func:`max_ground_speed` less ``gust_k`` standard deviations of the wind along ``e``
    (``e^T S e``, ``S = [[suu, suv], [suv, svv]]`` the wind's covariance, m^2/s^2), or 0: the
    ground speed kept when the along-track wind is ``gust_k`` deviations more adverse than its
    mean. ``gust_k = 0`` is :func:`max_ground_speed` exactly."""
    v = max_ground_speed(ex, ey, wx, wy, airspeed_max)
    if gust_k > 0.0 and v > 0.0:
        var = ex * ex * suu + 2.0 * ex * ey * suv + ey * ey * svv
        v -= gust_k * math.sqrt(var if var > 0.0 else 0.0)
        if v < 0.0:
            v = 0.0
    return v


@njit(cache=True)
def frame_covariance(frames_u, frames_v, every, out):  # pragma: no cover - numba
    """Covariance over frames ``0, every, 2 every, ...`` of the wind at each cell: ``out``
    (ny, nx, 3) receives ``(var u, cov uv, var v)``, m^2/s^2 (population, about the frames'
    own mean)."""
    T, ny, nx = frames_u.shape
    su = np.zeros((ny, nx))
    sv = np.zeros((ny, nx))
    out[:] = 0.0
    n = 0
    for k in range(0, T, every):
        n += 1
        for j in range(ny):
            for i in range(nx):
                u = frames_u[k, j, i]
                v = frames_v[k, j, i]
                su[j, i] += u
                sv[j, i] += v
                out[j, i, 0] += u * u
                out[j, i, 1] += u * v
                out[j, i, 2] += v * v
    for j in range(ny):
        for i in range(nx):
            mu = su[j, i] / n
            mv = sv[j, i] / n
            out[j, i, 0] = max(out[j, i, 0] / n - mu * mu, 0.0)
            out[j, i, 1] = out[j, i, 1] / n - mu * mv
            out[j, i, 2] = max(out[j, i, 2] / n - mv * mv, 0.0)


@njit(cache=True, inline="always")
def _heap_push(keys, nodes, n, key, node):  # pragma: no cover - numba
    k = n
    keys[k] = key
    nodes[k] = node
    while k > 0:
        parent = (k - 1) >> 1
        if keys[parent] <= keys[k]:
            break
        keys[parent], keys[k] = keys[k], keys[parent]
        nodes[parent], nodes[k] = nodes[k], nodes[parent]
        k = parent
    return n + 1


@njit(cache=True, inline="always")
def _heap_pop(keys, nodes, n):  # pragma: no cover - numba
    key = keys[0]
    node = nodes[0]
    n -= 1
    keys[0] = keys[n]
    nodes[0] = nodes[n]
    k = 0
    while True:
        c = 2 * k + 1
        if c >= n:
            break
        if c + 1 < n and keys[c + 1] < keys[c]:
            c += 1
        if keys[k] <= keys[c]:
            break
        keys[k], keys[c] = keys[c], keys[k]
        nodes[k], nodes[c] = nodes[c], nodes[k]
        k = c
    return key, node, n


@njit(cache=True)
def _best_departure(frames, t0_frames, dt_frames, i, j, i2, j2, ex, ey, length, airspeed_max,
                    dep, arr, t_end):  # pragma: no cover - numba
    """The earliest arrival of the move from cell (i, j) to (i2, j2) departing at ``dep``
    (arriving at ``arr``) or at any later frame time before ``arr`` (past the last frame the
    wind is held, so no later departure helps)."""
    T = frames.shape[0]
    k = int(math.floor((dep - t0_frames) / dt_frames)) + 1
    if k < 0:
        k = 0
    while k <= T - 1:
        td = t0_frames + k * dt_frames
        if td >= arr or td > t_end:
            break
        if td > dep:
            wx = 0.5 * (frames[k, j, i, 0] + frames[k, j2, i2, 0])
            wy = 0.5 * (frames[k, j, i, 1] + frames[k, j2, i2, 1])
            v = max_ground_speed(ex, ey, wx, wy, airspeed_max)
            if v > 0.0 and td + length / v < arr:
                arr = td + length / v
        k += 1
    return arr


@njit(cache=True)
def earliest_arrival(free, frames, t0_frames, dt_frames, moves, guards, dx, airspeed_max,
                     source, t_start, t_end, target, arrival, pred, gust,
                     gust_k, lookahead=False):  # pragma: no cover - numba
    """Earliest arrival time at every lattice cell from ``source`` leaving at ``t_start`` (s),
    flying every move at its largest ground speed within ``airspeed_max`` (m/s).

    ``frames`` (T, ny, nx, 2): the wind at the lattice cells, m/s, frame ``k`` at time
    ``t0_frames + k dt_frames`` (linear in time between frames, the first and last held
    outside; ``T = 1``: a steady wind). A move's wind is the mean of its two cells' at the
    departure time; when the move cannot be flown then (:func:`max_ground_speed` is 0), the
    vehicle waits at the cell a frame at a time (unsteady winds only). Moves and their guard
    cells as in :func:`edge_weights`. Label-setting (Dijkstra) on the arrival times; cells
    reached after ``t_end`` are not expanded, and the search stops once ``target`` (a flat
    index, or -1 for none) is settled. ``arrival`` (ny * nx) receives the times (inf: not
    reached), ``pred`` the predecessor cell (-1 at the source and unreached cells).

    ``gust`` (ny, nx, 3): the covariance of the wind at the cells (:func:`frame_covariance`);
    with ``gust_k > 0`` (steady winds only) a move is flown at :func:`gust_ground_speed` in the
    mean of its two cells' covariances; ``gust_k = 0`` leaves ``gust`` unread.

    ``lookahead`` (unsteady winds): a move that can be flown also tries departing at each later
    frame time before its arrival, and keeps the earliest arrival: hovering for a better wind
    can beat flying a slow move at once, which the first rule misses (a reference audit found
    arrivals up to 23 % late in winds that change completely each frame).
    """
    ny, nx = free.shape
    T = frames.shape[0]
    n_cells = ny * nx
    arrival[:] = np.inf
    pred[:] = -1
    keys = np.empty(n_cells * moves.shape[0] + 1)
    nodes = np.empty(n_cells * moves.shape[0] + 1, np.int64)
    arrival[source] = t_start
    n = _heap_push(keys, nodes, 0, t_start, source)
    while n > 0:
        tau, k, n = _heap_pop(keys, nodes, n)
        if tau > arrival[k]:
            continue
        if k == target or tau > t_end:
            break
        j = k // nx
        i = k - j * nx
        for m in range(moves.shape[0]):
            if not move_ok(free, i, j, m, moves, guards):
                continue
            di = moves[m, 0]
            dj = moves[m, 1]
            i2 = i + di
            j2 = j + dj
            length = dx * math.sqrt(di * di + dj * dj)
            ex = di * dx / length
            ey = dj * dx / length
            dep = tau
            arr = np.inf
            while True:
                if T == 1:
                    f0 = 0
                    f1 = 0
                    c = 0.0
                else:
                    s = (dep - t0_frames) / dt_frames
                    if s <= 0.0:
                        f0 = 0
                        c = 0.0
                    elif s >= T - 1:
                        f0 = T - 2
                        c = 1.0
                    else:
                        f0 = int(s)
                        c = s - f0
                    f1 = f0 + 1
                wx = 0.5 * ((1 - c) * (frames[f0, j, i, 0] + frames[f0, j2, i2, 0])
                            + c * (frames[f1, j, i, 0] + frames[f1, j2, i2, 0]))
                wy = 0.5 * ((1 - c) * (frames[f0, j, i, 1] + frames[f0, j2, i2, 1])
                            + c * (frames[f1, j, i, 1] + frames[f1, j2, i2, 1]))
                if gust_k > 0.0:
                    v = gust_ground_speed(ex, ey, wx, wy,
                                          0.5 * (gust[j, i, 0] + gust[j2, i2, 0]),
                                          0.5 * (gust[j, i, 1] + gust[j2, i2, 1]),
                                          0.5 * (gust[j, i, 2] + gust[j2, i2, 2]),
                                          airspeed_max, gust_k)
                else:
                    v = max_ground_speed(ex, ey, wx, wy, airspeed_max)
                if v > 0.0:
                    arr = dep + length / v
                    if lookahead and T > 1:
                        arr = _best_departure(frames, t0_frames, dt_frames, i, j, i2, j2, ex,
                                              ey, length, airspeed_max, dep, arr, t_end)
                    break
                if T == 1 or dep > t_end or s >= T - 1:
                    # past the last frame the wind is held: waiting cannot open the move (with
                    # t_end = inf the loop never ended; metamorphic audit, 2026-12-05)
                    break
                dep += dt_frames
            k2 = j2 * nx + i2
            if arr < arrival[k2]:
                arrival[k2] = arr
                pred[k2] = k
                n = _heap_push(keys, nodes, n, arr, k2)
    return arrival[target] if target >= 0 else np.inf
