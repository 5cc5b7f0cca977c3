"""Numba kernels of the planners (private): power curve, obstacle field, fused rollout + cost.

All kernels are float64 and compiled with ``cache=True``, and single-threaded but for the two
``..._chunks`` kernels, which run chunks of the samples on Numba's threads
(``MPPIPlanner(threads=N)``; every sample's arithmetic is the serial kernels'). The public modules
(:mod:`windnav.plan.mppi`, :mod:`windnav.plan.obstacles`, :mod:`windnav.plan.energy_search`)
validate their inputs and call these; nothing here raises.

Packed arguments
----------------
``ptab`` (power table, non-dimensional by ``P_hover``; the polynomial padded with zeros to
degree 7 so that the kernels unroll it)::

    [V_max, P(V_max), P'(V_max), P''(V_max) / 2, c_0, c_1, ..., c_7]

``P(V) = sum c_k V^k`` for ``V <= V_max``, else ``P(V_max) + P' e + P''/2 e^2`` with
``e = V - V_max``.

``wmeta`` (local wind grid ``wgrid`` (2, ny, nx), [u, v] on cell centres)::

    [x_0, y_0, dx, dy, H/2, fill_u, fill_v]

with ``wmode`` 0 (no wind), 1 (uniform ``wgrid[:, 0, 0]``), 2 (bilinear, clamped at the edge
cells). In modes 1 and 2 the wind outside the window ``|x|, |y| <= H/2`` is ``(fill_u,
fill_v)``: zero (the thesis's planner), or a uniform estimate (the onboard stack's option).

``fmeta`` (obstacle field: ``node`` (ny, nx, 3) holds, at the nodes ``(x_0 + i h, y_0 + j h)``,
the exact distance to the nearest of the sites ``(sx, sy)`` (P,) and that site's x and y)::

    [x_0, y_0, 1/h, h, bbox x_min, bbox x_max, bbox y_min, bbox y_max]

``bmeta`` (the sites, sorted by bucket of side ``B``; bucket ``b`` holds
``bstart[b]:bstart[b + 1]``)::

    [x_0, y_0, 1/B, nbx, nby]
"""

from __future__ import annotations

import math

import numba
import numpy as np

from windnav._jit import njit
from windnav.plan._random import FN, KN, WN, fill_normal

_HUGE = 1e300
_MIN_D2 = 1e-6  # m^2: a sample through a LiDAR point costs D^2 / 1e-6, finite
_SMOOTH_BLOCK = 256  # columns per block of the control smoothing (float32: 1 KB per row)


@njit(cache=True, inline="always")
def power_bar(v, ptab):  # pragma: no cover - numba
    """Non-dimensional steady-flight power ``P(v) / P_hover`` at airspeed ``v`` (m/s).

    Branch-free (so that loops over samples vectorise): the polynomial at ``min(v, V_max)``
    plus the Taylor continuation in ``e = max(v - V_max, 0)``, which is 0 below ``V_max``.
    """
    w = min(v, ptab[0])
    e = max(v - ptab[0], 0.0)
    r = 0.0
    for i in range(ptab.size - 1, 3, -1):
        r = r * w + ptab[i]
    return r + e * (ptab[2] + e * ptab[3])


@njit(cache=True)
def _power_bar_flat(v, ptab, out):  # pragma: no cover - numba
    for i in range(v.size):
        out[i] = power_bar(v[i], ptab)


def power_bar_array(v: np.ndarray, ptab: np.ndarray) -> np.ndarray:
    """:func:`power_bar` over an array of airspeeds (any shape)."""
    v = np.asarray(v, dtype=np.float64)
    flat = np.ascontiguousarray(v).reshape(-1)
    out = np.empty_like(flat)
    _power_bar_flat(flat, np.asarray(ptab, dtype=np.float64), out)
    return out.reshape(v.shape)


@njit(cache=True)
def evenly_increasing(a):  # pragma: no cover - numba
    """Whether the finite 1-D ``a`` (>= 2 values, all finite) increases in steps equal to
    ``1e-6`` of the first (the check of a wind grid's cell-centre offsets), in one pass:
    ``all(diff(a) > 0)`` and ``ptp(diff(a)) <= 1e-6 diff(a)[0]``."""
    for x in a:
        if not math.isfinite(x):
            return False
    first = a[1] - a[0]
    lo = hi = first
    for i in range(1, a.size):
        d = a[i] - a[i - 1]
        if not d > 0.0:
            return False
        lo = min(lo, d)
        hi = max(hi, d)
    return hi - lo <= 1e-6 * first


@njit(cache=True, inline="always")
def _bilinear(px, py, half, x0, y0, wmeta, nx, ny, wgrid):  # pragma: no cover - numba
    """Mode 2 of :func:`wind_at` with the window and grid read once by the caller: ``half``,
    ``x0``, ``y0`` from ``wmeta`` and the grid's ``nx``, ``ny``. The spacings stay reads of
    ``wmeta`` at the division: a divisor the compiler sees as loop-invariant would let the
    callers' ``arcp`` turn the division into a multiplication by its reciprocal (other bits).
    The argument order is measured, not cosmetic: with ``wgrid`` last the 100 x 187 lookups of
    a rollout take 0.16 ms inside it, with ``wmeta`` last 0.54 ms (same values)."""
    if abs(px) > half or abs(py) > half:
        return wmeta[5], wmeta[6]
    fx = (px - x0) / wmeta[2]
    fy = (py - y0) / wmeta[3]
    fx = min(max(fx, 0.0), nx - 1.0)
    fy = min(max(fy, 0.0), ny - 1.0)
    i = min(int(fx), nx - 2)
    j = min(int(fy), ny - 2)
    a = fx - i
    b = fy - j
    w00 = (1.0 - a) * (1.0 - b)
    w10 = a * (1.0 - b)
    w01 = (1.0 - a) * b
    w11 = a * b
    u = (w00 * wgrid[0, j, i] + w10 * wgrid[0, j, i + 1] + w01 * wgrid[0, j + 1, i]
         + w11 * wgrid[0, j + 1, i + 1])
    v = (w00 * wgrid[1, j, i] + w10 * wgrid[1, j, i + 1] + w01 * wgrid[1, j + 1, i]
         + w11 * wgrid[1, j + 1, i + 1])
    return u, v


@njit(cache=True, inline="always")
def wind_at(px, py, wmode, wgrid, wmeta):  # pragma: no cover - numba
    """Wind (u, v) at local position (px, py), m/s."""
    if wmode == 0:
        return 0.0, 0.0
    half = wmeta[4]
    if wmode == 1:
        if abs(px) > half or abs(py) > half:
            return wmeta[5], wmeta[6]
        return wgrid[0, 0, 0], wgrid[1, 0, 0]
    return _bilinear(px, py, half, wmeta[0], wmeta[1], wmeta, wgrid.shape[2], wgrid.shape[1],
                     wgrid)


@njit(cache=True, inline="always")
def distance_bounds(px, py, node, fmeta):  # pragma: no cover - numba
    """Lower bound on the distance from (px, py) to the nearest site (m), and an upper bound
    on its square (m^2).

    Inside the node grid, at the nearest node ``n``: ``d(n) - |q - n|`` (``d`` is 1-Lipschitz
    and exact at the nodes) and the squared distance to ``n``'s nearest site (a real site, so
    an upper bound, and usually the answer). Outside: the distance to the sites' bounding box,
    and infinity. (Variants that clamp to the grid, branch-free or for finite bounds outside,
    measured slower.)
    """
    ny = node.shape[0]
    nx = node.shape[1]
    gx = (px - fmeta[0]) * fmeta[2]
    gy = (py - fmeta[1]) * fmeta[2]
    if gx >= 0.0 and gy >= 0.0 and gx <= nx - 1.0 and gy <= ny - 1.0:
        i = int(gx + 0.5)
        j = int(gy + 0.5)
        ex = px - (fmeta[0] + i * fmeta[3])
        ey = py - (fmeta[1] + j * fmeta[3])
        dx = px - node[j, i, 1]
        dy = py - node[j, i, 2]
        return node[j, i, 0] - math.sqrt(ex * ex + ey * ey), dx * dx + dy * dy
    lx = max(fmeta[4] - px, 0.0, px - fmeta[5])
    ly = max(fmeta[6] - py, 0.0, py - fmeta[7])
    return math.sqrt(lx * lx + ly * ly), np.inf


@njit(cache=True, fastmath=True, inline="always")
def _range_d2(px, py, sx, sy, a, b, best):  # pragma: no cover - numba
    """``min(best, min_{a <= s < b} |q - site_s|^2)``, m^2 (the sites are finite; fast-math
    only reorders this minimum)."""
    m = best
    for s in range(a, b):
        dx = px - sx[s]
        dy = py - sy[s]
        d = dx * dx + dy * dy
        if d < m:
            m = d
    return m


@njit(cache=True, inline="always")
def exact_d2(px, py, best2, sx, sy, bstart, bmeta):  # pragma: no cover - numba
    """``min(best2, d^2)``, ``d`` the exact distance to the nearest site (m^2).

    The sites ``(sx, sy)`` are sorted by bucket (row-major on a grid of side ``B``,
    ``bmeta = [x0, y0, 1/B, nbx, nby]``; bucket ``b`` holds ``bstart[b]:bstart[b + 1]``), so
    the buckets that meet the square of half-side ``sqrt(best2)`` around the query are one
    contiguous range per bucket row; when that square covers much of the grid, all the sites
    are searched at once.
    """
    nbx = int(bmeta[3])
    nby = int(bmeta[4])
    if best2 < np.inf:
        rho = math.sqrt(best2)
        inv_b = bmeta[2]
        i0 = max(int(math.floor((px - rho - bmeta[0]) * inv_b)), 0)
        i1 = min(int(math.floor((px + rho - bmeta[0]) * inv_b)), nbx - 1)
        j0 = max(int(math.floor((py - rho - bmeta[1]) * inv_b)), 0)
        j1 = min(int(math.floor((py + rho - bmeta[1]) * inv_b)), nby - 1)
        if i0 > i1 or j0 > j1:
            return best2
        if 4 * (i1 - i0 + 1) * (j1 - j0 + 1) < nbx * nby:
            for bj in range(j0, j1 + 1):
                best2 = _range_d2(px, py, sx, sy, bstart[bj * nbx + i0],
                                  bstart[bj * nbx + i1 + 1], best2)
            return best2
    return _range_d2(px, py, sx, sy, 0, sx.size, best2)


@njit(cache=True, inline="always")
def corner_bound(px, py, node, fmeta):  # pragma: no cover - numba
    """Lower bound on the distance (m) from the four nodes around (px, py):
    ``max_n d(n) - |q - n|``; ``-inf`` outside the node grid."""
    ny = node.shape[0]
    nx = node.shape[1]
    gx = (px - fmeta[0]) * fmeta[2]
    gy = (py - fmeta[1]) * fmeta[2]
    if not (gx >= 0.0 and gy >= 0.0 and gx < nx - 1.0 and gy < ny - 1.0):
        return -np.inf
    i = int(gx)
    j = int(gy)
    h = fmeta[3]
    lo = -np.inf
    for dj in range(2):
        for di in range(2):
            ex = px - (fmeta[0] + (i + di) * h)
            ey = py - (fmeta[1] + (j + dj) * h)
            lo = max(lo, node[j + dj, i + di, 0] - math.sqrt(ex * ex + ey * ey))
    return lo


@njit(cache=True, inline="always")
def min_distance(qx, qy, lb, ub2_min, node, fmeta, sx, sy, bstart,
                 bmeta):  # pragma: no cover - numba
    """Exact ``min_k d(q_k)`` (m) over points ``q_k`` with lower bounds ``lb`` (m), given the
    smallest squared upper bound ``ub2_min``: a point is searched only when its lower bound,
    then the tighter bound of its four surrounding nodes, is below the best so far."""
    best2 = ub2_min
    for k in range(qx.size):
        lo = lb[k]
        if lo <= 0.0 or lo * lo < best2:
            lo = corner_bound(qx[k], qy[k], node, fmeta)
            if lo <= 0.0 or lo * lo < best2:
                best2 = exact_d2(qx[k], qy[k], best2, sx, sy, bstart, bmeta)
    return math.sqrt(best2)


@njit(cache=True)
def nearest_sites(sites, order, x0, y0, h, out, node):  # pragma: no cover - numba
    """Index of the nearest site (``out`` (ny, nx)), and its distance and coordinates
    (``node`` (ny, nx, 3)), at every node ``(x0 + i h, y0 + j h)``.

    Exact, in ``O(nx (P + ny))``: for each node column ``x_i`` the squared distances to the
    sites are parabolas in ``y``, ``g_s + (y - y_s)^2`` with ``g_s = (x_i - x_s)^2``; their
    lower envelope is built in one pass over the sites sorted by ``y`` (``order``), as in the
    distance transform of Felzenszwalb & Huttenlocher (2012), and read at the node rows.
    """
    ny, nx = out.shape
    n = order.size
    v = np.empty(n, dtype=np.int64)
    z = np.empty(n + 1)
    for i in range(nx):
        xc = x0 + i * h
        k = -1
        for qi in range(n):
            q = order[qi]
            yq = sites[q, 1]
            gq = (xc - sites[q, 0]) ** 2
            fq = gq + yq * yq
            ys = -np.inf
            skip = False
            while k >= 0:
                s = v[k]
                ysv = sites[s, 1]
                gs = (xc - sites[s, 0]) ** 2
                if yq == ysv:
                    if gq >= gs:
                        skip = True
                        break
                    k -= 1
                    continue
                ys = (fq - (gs + ysv * ysv)) / (2.0 * (yq - ysv))
                if ys <= z[k]:
                    k -= 1
                    continue
                break
            if skip:
                continue
            k += 1
            v[k] = q
            z[k] = ys if k > 0 else -np.inf
        z[k + 1] = np.inf
        m = 0
        for j in range(ny):
            yj = y0 + j * h
            while z[m + 1] < yj:
                m += 1
            q = v[m]
            out[j, i] = q
            node[j, i, 0] = math.sqrt((xc - sites[q, 0]) ** 2 + (yj - sites[q, 1]) ** 2)
            node[j, i, 1] = sites[q, 0]
            node[j, i, 2] = sites[q, 1]


@njit(cache=True)
def build_field(pts, h, pad, b):  # pragma: no cover - numba
    """Everything :class:`~windnav.plan.obstacles.ObstacleField` holds for the sites ``pts``
    (P >= 1, finite): ``(nodes, nearest, fmeta, order, bstart, bmeta, sx, sy)`` (see the
    module docstring), with node spacing ``h``, buckets of side ``b``, and nodes over the
    bounding box of the sites and the origin plus a margin ``pad``."""
    n = pts.shape[0]
    lo_x = hi_x = pts[0, 0]
    lo_y = hi_y = pts[0, 1]
    for i in range(1, n):
        lo_x = min(lo_x, pts[i, 0])
        hi_x = max(hi_x, pts[i, 0])
        lo_y = min(lo_y, pts[i, 1])
        hi_y = max(hi_y, pts[i, 1])
    # the nodes cover the sites and the origin (the vehicle, where every rollout starts)
    x0 = min(lo_x, 0.0) - pad
    y0 = min(lo_y, 0.0) - pad
    nx = int(math.ceil((max(hi_x, 0.0) + pad - x0) / h)) + 1
    ny = int(math.ceil((max(hi_y, 0.0) + pad - y0) / h)) + 1
    nearest = np.empty((ny, nx), dtype=np.int64)
    nodes = np.empty((ny, nx, 3))
    nearest_sites(pts, np.argsort(pts[:, 1]), x0, y0, h, nearest, nodes)
    fmeta = np.array([x0, y0, 1.0 / h, h, lo_x, hi_x, lo_y, hi_y])
    nbx = int((hi_x - lo_x) // b) + 1
    nby = int((hi_y - lo_y) // b) + 1
    cell = np.empty(n, dtype=np.int64)
    start = np.zeros(nbx * nby + 1, dtype=np.int64)
    for i in range(n):
        bi = min(int((pts[i, 0] - lo_x) // b), nbx - 1)
        bj = min(int((pts[i, 1] - lo_y) // b), nby - 1)
        cell[i] = bj * nbx + bi
        start[cell[i] + 1] += 1
    for c in range(nbx * nby):
        start[c + 1] += start[c]
    order = np.empty(n, dtype=np.int64)
    fill = start[:-1].copy()
    for i in range(n):
        order[fill[cell[i]]] = i
        fill[cell[i]] += 1
    sx = np.empty(n)
    sy = np.empty(n)
    for t in range(n):
        sx[t] = pts[order[t], 0]
        sy[t] = pts[order[t], 1]
    bmeta = np.array([lo_x, lo_y, 1.0 / b, float(nbx), float(nby)])
    return nodes, nearest, fmeta, order, start, bmeta, sx, sy


@njit(cache=True)
def field_distance(points, node, fmeta, sx, sy, bstart, bmeta, out):  # pragma: no cover
    """Exact distance from each point (M, 2) to its nearest site, m."""
    for m in range(points.shape[0]):
        lo, hi2 = distance_bounds(points[m, 0], points[m, 1], node, fmeta)
        if lo * lo < hi2 or lo <= 0.0:
            hi2 = exact_d2(points[m, 0], points[m, 1], hi2, sx, sy, bstart, bmeta)
        out[m] = math.sqrt(hi2)


@njit(cache=True, inline="always")
def _winds(px, py, wmode, wgrid, wmeta, wx, wy):  # pragma: no cover - numba
    """Wind at every sample's position into ``wx, wy`` (S,): the fill outside the window,
    uniform (branch-free, so the loop vectorises) or bilinear on the grid."""
    half = wmeta[4]
    if wmode == 2:
        x0, y0, nx, ny = wmeta[0], wmeta[1], wgrid.shape[2], wgrid.shape[1]
        for s in range(px.size):
            wx[s], wy[s] = _bilinear(px[s], py[s], half, x0, y0, wmeta, nx, ny, wgrid)
    elif wmode == 1:
        w0x = wgrid[0, 0, 0]
        w0y = wgrid[1, 0, 0]
        fx = wmeta[5]
        fy = wmeta[6]
        for s in range(px.size):
            inside = (abs(px[s]) <= half) & (abs(py[s]) <= half)
            wx[s] = w0x if inside else fx
            wy[s] = w0y if inside else fy


@njit(cache=True, fastmath={"contract", "arcp"})
def rollout_cost(U, v0, goal, dt, drag, inv_d, a_lo, a_hi, q_obs, q_e, ptab, mission,
                 wmode, wgrid, wmeta, has_obs, node, fmeta, sx, sy, bstart, bmeta,
                 costs, parts):  # pragma: no cover - numba
    """Roll out every control sequence and accumulate its cost, in one pass over time.

    Parameters
    ----------
    U : ndarray of shape (K, 2, S)
        Accelerations, m/s^2, float32 or float64 (clipped here to ``[a_lo, a_hi]``).
    v0 : ndarray of shape (2,)
        Ground velocity at the start, m/s; the start position is the origin.
    goal : ndarray of shape (2,)
        Goal relative to the start, m (already capped at ``D_max``).
    mission : ndarray of shape (5,)
        ``[on, g_x, g_y, r, e_R]``: when ``on > 0``, ``J_E`` is the mission's energy
        (``PlannerConfig.energy_mode``): the power is summed only until the rollout first comes
        within ``r`` (m) of the uncapped goal ``g`` (m, relative to the start), and a rollout
        that never does adds ``e_R (|p_K - g| - r)`` (``e_R`` in s/m).
    costs : ndarray of shape (S,)
        Out: ``J = J_prog + Q_O J_obs + Q_E J_E`` (inf where not finite).
    parts : ndarray of shape (S, 4)
        Out: ``J_prog, J_obs, J_E`` and the closest distance to a site ``d_min``, m.

    Forward Euler, for k = 0 .. K-1::

        v_a = v_k - w(p_k)
        J_E += P(|v_a|) / P_hover * dt        (mission: while |p_k - g| > r)
        p_{k+1} = p_k + dt v_k
        v_{k+1} = v_k + dt (u_k - C |v_a| v_a)
        J_prog += |(p_{k+1} - goal) / D_max|^2

    and ``J_obs = (D_max / d_min)^2``, ``d_min = min_k dist(p_{k+1}, sites)``: the field's
    bounds at every step, then exact searches only where the lower bound is below the best.

    Time-major: each step advances all samples at once (structure-of-arrays, so the dynamics
    vectorise); the obstacle bounds follow in a second, scalar loop over the samples.
    """
    K = U.shape[0]
    S = U.shape[2]
    gx = goal[0]
    gy = goal[1]
    d_max2 = 1.0 / (inv_d * inv_d)
    vm = ptab[0]
    e1 = ptab[2]
    e2 = ptab[3]
    c0, c1, c2, c3, c4, c5, c6, c7 = ptab[4], ptab[5], ptab[6], ptab[7], ptab[8], ptab[9], \
        ptab[10], ptab[11]
    px = np.zeros(S)
    py = np.zeros(S)
    vx = np.full(S, v0[0])
    vy = np.full(S, v0[1])
    wx = np.zeros(S)
    wy = np.zeros(S)
    jp = np.zeros(S)
    je = np.zeros(S)
    on = mission[0] > 0.0
    mx = mission[1]
    my = mission[2]
    r2 = mission[3] * mission[3]
    live = np.ones(S)   # 1 until the rollout reaches the goal (mission energy), then 0
    ub2 = np.full(S, np.inf)
    n_obs = K if has_obs else 1
    qx = np.empty((n_obs, S))
    qy = np.empty((n_obs, S))
    lb = np.empty((n_obs, S))
    for k in range(K):
        _winds(px, py, wmode, wgrid, wmeta, wx, wy)
        ux = U[k, 0]
        uy = U[k, 1]
        for s in range(S):
            x = px[s]
            y = py[s]
            bx = vx[s]
            by = vy[s]
            ax = bx - wx[s]
            ay = by - wy[s]
            va = math.sqrt(ax * ax + ay * ay)
            w = min(va, vm)
            e = max(va - vm, 0.0)
            p = ((((((c7 * w + c6) * w + c5) * w + c4) * w + c3) * w + c2) * w + c1) * w \
                + c0 + e * (e1 + e * e2)
            x += dt * bx
            y += dt * by
            if on:
                je[s] += p * live[s]
                if (x - mx) * (x - mx) + (y - my) * (y - my) <= r2:
                    live[s] = 0.0
            else:
                je[s] += p
            px[s] = x
            py[s] = y
            vx[s] = bx + dt * (min(max(ux[s], a_lo), a_hi) - drag * va * ax)
            vy[s] = by + dt * (min(max(uy[s], a_lo), a_hi) - drag * va * ay)
            ex = (x - gx) * inv_d
            ey = (y - gy) * inv_d
            jp[s] += ex * ex + ey * ey
        if has_obs:
            for s in range(S):
                lo, hi2 = distance_bounds(px[s], py[s], node, fmeta)
                qx[k, s] = px[s]
                qy[k, s] = py[s]
                lb[k, s] = lo
                if hi2 < ub2[s]:
                    ub2[s] = hi2
    if has_obs:
        # exact closest distances: only where a step's lower bound is below the sample's best
        for k in range(K):
            for s in range(S):
                lo = lb[k, s]
                if lo <= 0.0 or lo * lo < ub2[s]:
                    lo = corner_bound(qx[k, s], qy[k, s], node, fmeta)
                    if lo <= 0.0 or lo * lo < ub2[s]:
                        ub2[s] = exact_d2(qx[k, s], qy[k, s], ub2[s], sx, sy, bstart, bmeta)
    for s in range(S):
        e = je[s] * dt
        if on and live[s] > 0.0:
            dx = px[s] - mx
            dy = py[s] - my
            e += mission[4] * max(math.sqrt(dx * dx + dy * dy) - mission[3], 0.0)
        if has_obs:
            d_min = math.sqrt(ub2[s])
            jo = d_max2 / max(ub2[s], _MIN_D2)
        else:
            d_min = np.inf
            jo = 0.0
        c = jp[s] + q_obs * jo + q_e * e
        costs[s] = c if c == c else np.inf
        parts[s, 0] = jp[s]
        parts[s, 1] = jo
        parts[s, 2] = e
        parts[s, 3] = d_min


@njit(cache=True)
def rollout_states(U, v0, dt, drag, a_lo, a_hi, wmode, wgrid, wmeta,
                   pos, vel):  # pragma: no cover - numba
    """States of the rollouts of ``U`` (K, 2, S): ``pos``, ``vel`` (S, K + 1, 2), the model of
    rollout_cost."""
    K = U.shape[0]
    S = U.shape[2]
    for s in range(S):
        px = 0.0
        py = 0.0
        vx = v0[0]
        vy = v0[1]
        pos[s, 0, 0] = px
        pos[s, 0, 1] = py
        vel[s, 0, 0] = vx
        vel[s, 0, 1] = vy
        for k in range(K):
            wx, wy = wind_at(px, py, wmode, wgrid, wmeta)
            ax = vx - wx
            ay = vy - wy
            va = math.sqrt(ax * ax + ay * ay)
            ux = min(max(U[k, 0, s], a_lo), a_hi)
            uy = min(max(U[k, 1, s], a_lo), a_hi)
            px += dt * vx
            py += dt * vy
            vx += dt * (ux - drag * va * ax)
            vy += dt * (uy - drag * va * ay)
            pos[s, k + 1, 0] = px
            pos[s, k + 1, 1] = py
            vel[s, k + 1, 0] = vx
            vel[s, k + 1, 1] = vy


@njit(cache=True, inline="always")
def _smooth_row(row, src, j, m0, m1, taps, k, a, n):  # pragma: no cover - numba
    """``row = sum_t taps[k, t] src[a + t, j, m0:m1]`` over ``t < n``, summed from ``t = 0`` up,
    four taps per pass over the row (one load and store of the row per four taps). ``src`` is
    the contiguous (K, J, M) array itself: its rows' views are then contiguous to Numba, and the
    loops vectorise (a (K, width) view of a block took 2.6 x the time)."""
    row[:] = 0.0
    t = 0
    while t + 4 <= n:     # four taps per pass over the row, added in the same order
        w0 = taps[k, t]
        w1 = taps[k, t + 1]
        w2 = taps[k, t + 2]
        w3 = taps[k, t + 3]
        s0 = src[a + t, j, m0:m1]
        s1 = src[a + t + 1, j, m0:m1]
        s2 = src[a + t + 2, j, m0:m1]
        s3 = src[a + t + 3, j, m0:m1]
        for m in range(row.size):
            row[m] = (((row[m] + w0 * s0[m]) + w1 * s1[m]) + w2 * s2[m]) + w3 * s3[m]
        t += 4
    while t < n:
        w = taps[k, t]
        s0 = src[a + t, j, m0:m1]
        for m in range(row.size):
            row[m] += w * s0[m]
        t += 1


@njit(cache=True)
def perturb_clip_smooth(seed, clipped, mean, sigma, a_lo, a_hi, taps, lo, hi,
                        out):  # pragma: no cover - numba
    """``out = G @ clip(mean + sigma eps)``, ``eps ~ N(0, 1)`` (single-threaded).

    ``seed`` (uint64) starts the normal stream of :mod:`windnav.plan._random`; ``clipped``
    (K, 2, S) is a work buffer; ``out`` (K, 2, S) the result; ``mean`` (K, 2); the banded
    smoothing matrix ``G`` row ``k`` has the weights ``taps[k, :hi[k] - lo[k]]`` on columns
    ``lo[k] .. hi[k] - 1``. ``clipped``, ``taps`` and ``out`` may be float32 (the smoothing is
    memory-bound: half the bytes, twice the speed).

    The product runs over blocks of ``_SMOOTH_BLOCK`` columns, so that a block's input and output
    rows stay in the L1 cache, and adds four taps per pass over a row (one load and store of the
    row per four taps); each element still sums ``w_t src_t`` from ``t = 0`` up in float32, so
    the result is the same to the bit (0.066 against 0.10 ms at 1000 x 25 on an Intel Xeon).
    """
    K = clipped.shape[0]
    S = clipped.shape[2]
    fill_normal(seed, clipped, mean, sigma, a_lo, a_hi, KN, WN, FN)
    flat = clipped.reshape(K, 1, 2 * S)
    res = out.reshape(K, 2 * S)
    for m0 in range(0, 2 * S, _SMOOTH_BLOCK):
        m1 = min(m0 + _SMOOTH_BLOCK, 2 * S)
        for k in range(K):   # views from 0: indices known non-negative, so it vectorises
            _smooth_row(res[k, m0:m1], flat, 0, m0, m1, taps, k, lo[k], hi[k] - lo[k])


@njit(cache=True, parallel=True)
def perturb_clip_smooth_chunks(seeds, clipped, mean, sigma, a_lo, a_hi, taps, lo, hi, out,
                               bounds):  # pragma: no cover - numba
    """:func:`perturb_clip_smooth` with the samples in chunks ``bounds[c]:bounds[c + 1]`` run
    in parallel, chunk ``c``'s normals from the stream of ``seeds[c]`` (so another stream
    than the serial kernel's one). Each element's smoothing is the serial kernel's sum, in the
    same order: the same ``clipped`` gives the same ``out`` to the bit."""
    K = clipped.shape[0]
    for c in numba.prange(seeds.size):
        s0 = bounds[c]
        s1 = bounds[c + 1]
        fill_normal(seeds[c], clipped[:, :, s0:s1], mean, sigma, a_lo, a_hi, KN, WN, FN)
        for j in range(2):
            for m0 in range(s0, s1, _SMOOTH_BLOCK):
                m1 = min(m0 + _SMOOTH_BLOCK, s1)
                for k in range(K):
                    _smooth_row(out[k, j, m0:m1], clipped, j, m0, m1, taps, k, lo[k],
                                hi[k] - lo[k])


@njit(cache=True, parallel=True)
def rollout_cost_chunks(U, v0, goal, dt, drag, inv_d, a_lo, a_hi, q_obs, q_e, ptab, mission,
                        wmode, wgrid, wmeta, has_obs, node, fmeta, sx, sy, bstart, bmeta,
                        costs, parts, bounds):  # pragma: no cover - numba
    """:func:`rollout_cost` of the sample chunks ``bounds[c]:bounds[c + 1]`` in parallel: the
    same costs and parts to the bit (every sample's rollout is its own)."""
    for c in numba.prange(bounds.size - 1):
        s0 = bounds[c]
        s1 = bounds[c + 1]
        rollout_cost(U[:, :, s0:s1], v0, goal, dt, drag, inv_d, a_lo, a_hi, q_obs, q_e, ptab,
                     mission, wmode, wgrid, wmeta, has_obs, node, fmeta, sx, sy, bstart, bmeta,
                     costs[s0:s1], parts[s0:s1])


@njit(cache=True)
def softmin_mean(costs, temperature, u, weights, out):  # pragma: no cover - numba
    """Softmin weights ``w_s ∝ exp(-(J_s - min J) / lambda)`` (0 where ``J_s`` is not finite)
    into ``weights`` (S,) and the weighted mean of ``u`` (K, 2, S) into ``out`` (K, 2).

    Returns False (and leaves ``out`` untouched) when no cost is finite.
    """
    S = costs.size
    c_min = np.inf
    for s in range(S):
        if costs[s] < c_min:
            c_min = costs[s]
    if not c_min < np.inf:
        weights[:] = 0.0
        return False
    total = 0.0
    for s in range(S):
        c = costs[s]
        w = math.exp(-(c - c_min) / temperature) if c < np.inf else 0.0
        weights[s] = w
        total += w
    for s in range(S):
        weights[s] /= total
    K = u.shape[0]
    for k in range(K):
        for c in range(2):
            acc = 0.0
            row = u[k, c]
            for s in range(S):
                acc += weights[s] * row[s]
            out[k, c] = acc
    return True
