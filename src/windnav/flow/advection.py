"""Self-advection of the staggered velocity: semi-Lagrangian and MacCormack schemes.

Semi-Lagrangian (Stam 1999; Staniforth & Cote 1991): a face value at ``x`` becomes the
bilinear interpolation of the old field at the departure point ``x - dt * u(x)``.

MacCormack (Selle, Fedkiw, Kim, Liu & Rossignac 2008, "An unconditionally stable MacCormack
method"): with the semi-Lagrangian operator ``A`` and its time reverse ``A^R``,

    phi_hat  = A(phi)
    phi_back = A^R(phi_hat)
    phi_new  = phi_hat + (phi - phi_back) / 2,  clamped to the extrema of the 4 values
               that ``phi_hat`` interpolated,

which cancels the leading (diffusive) error of ``A`` while the clamp keeps it stable.

Boundaries and buildings: positions are in cell units (``X = (x - x0) / dx``). A sample
beyond an inflow side reads the inlet velocity; beyond another side the sample is clamped to
the domain (zero gradient, free slip). Building faces hold zero normal velocity, so samples
next to a building see a no-slip-like wall. A departure point that falls inside a building
cell is pulled back toward its face by halving the trace (3 times, then the face keeps its
value), so nothing is ever sampled from inside a solid.
"""

from __future__ import annotations

import numba
import numpy as np

from windnav.flow.grid import FACE_FIXED, FlowDomain

SCHEMES = ("semi_lagrangian", "maccormack")


@numba.njit(cache=True, inline="always")
def _sample(f, ox, oy, X, Y, sides, inflow_val):
    """Bilinear sample of face field ``f`` (offset ox, oy) at (X, Y); returns (val, lo, hi)."""
    nyf, nxf = f.shape
    ny = nyf if oy == 0.5 else nyf - 1
    nx = nxf if ox == 0.5 else nxf - 1
    if (
        (X < 0.0 and sides[0] == 0)
        or (X > nx and sides[1] == 0)
        or (Y < 0.0 and sides[2] == 0)
        or (Y > ny and sides[3] == 0)
    ):
        return inflow_val, inflow_val, inflow_val
    fi = min(max(X - ox, 0.0), nxf - 1.0)
    fj = min(max(Y - oy, 0.0), nyf - 1.0)
    i0 = min(int(fi), nxf - 2)
    j0 = min(int(fj), nyf - 2)
    a = fi - i0
    b = fj - j0
    f00 = f[j0, i0]
    f01 = f[j0, i0 + 1]
    f10 = f[j0 + 1, i0]
    f11 = f[j0 + 1, i0 + 1]
    val = (1.0 - b) * ((1.0 - a) * f00 + a * f01) + b * ((1.0 - a) * f10 + a * f11)
    lo = min(min(f00, f01), min(f10, f11))
    hi = max(max(f00, f01), max(f10, f11))
    return val, lo, hi


@numba.njit(cache=True, inline="always")
def _in_solid(solid, X, Y):
    ny, nx = solid.shape
    i = int(np.floor(X))
    j = int(np.floor(Y))
    if i < 0 or j < 0 or i >= nx or j >= ny:
        return False
    return solid[j, i]


@numba.njit(cache=True, inline="always")
def _safe_trace(solid, X, Y, dX, dY):
    """Scale the displacement so the end point is not inside a building cell."""
    for _ in range(4):
        if not _in_solid(solid, X + dX, Y + dY):
            return dX, dY
        dX *= 0.5
        dY *= 0.5
    return 0.0, 0.0


@numba.njit(cache=True, inline="always")
def _face_velocity(u, v, j, i, is_u):
    """Velocity (u, v) at face (j, i) of the u-faces (is_u) or the v-faces."""
    if is_u:
        nx = v.shape[1]
        il = max(i - 1, 0)
        ir = min(i, nx - 1)
        return u[j, i], 0.25 * (v[j, il] + v[j, ir] + v[j + 1, il] + v[j + 1, ir])
    ny = u.shape[0]
    jl = max(j - 1, 0)
    jr = min(j, ny - 1)
    return 0.25 * (u[jl, i] + u[jl, i + 1] + u[jr, i] + u[jr, i + 1]), v[j, i]


@numba.njit(cache=True)
def _advect_component(f, code, u, v, c, solid, sides, inflow_val, is_u, maccormack):
    ox = 0.0 if is_u else 0.5
    oy = 0.5 if is_u else 0.0
    nyf, nxf = f.shape
    out = f.copy()
    if maccormack:
        dxs = np.zeros(f.shape)
        dys = np.zeros(f.shape)
        los = np.empty(f.shape)
        his = np.empty(f.shape)
    for j in range(nyf):
        for i in range(nxf):
            if code[j, i] == FACE_FIXED:
                continue
            X = i + ox
            Y = j + oy
            uu, vv = _face_velocity(u, v, j, i, is_u)
            dX, dY = _safe_trace(solid, X, Y, -c * uu, -c * vv)
            val, lo, hi = _sample(f, ox, oy, X + dX, Y + dY, sides, inflow_val)
            out[j, i] = val
            if maccormack:
                dxs[j, i] = dX
                dys[j, i] = dY
                los[j, i] = lo
                his[j, i] = hi
    if not maccormack:
        return out
    res = out.copy()
    for j in range(nyf):
        for i in range(nxf):
            if code[j, i] == FACE_FIXED:
                continue
            X = i + ox
            Y = j + oy
            bX, bY = _safe_trace(solid, X, Y, -dxs[j, i], -dys[j, i])
            back, _, _ = _sample(out, ox, oy, X + bX, Y + bY, sides, inflow_val)
            val = out[j, i] + 0.5 * (f[j, i] - back)
            res[j, i] = min(max(val, los[j, i]), his[j, i])
    return res


def make_advection(domain: FlowDomain, dt: float, scheme: str = "maccormack"):
    """Build ``advect(u, v) -> (u_new, v_new)``: self-advection of the face velocity over ``dt``.

    Parameters
    ----------
    domain : FlowDomain
        Grid, buildings and boundary conditions.
    dt : float
        Time step, s.
    scheme : {"maccormack", "semi_lagrangian"}
        Advection scheme (resolved once here, not in the loop).

    Returns
    -------
    callable
        Pure function of the face fields ``u`` (ny, nx + 1) and ``v`` (ny + 1, nx), m/s.
    """
    if scheme not in SCHEMES:
        raise ValueError(
            f"The 'scheme' parameter of make_advection must be one of {SCHEMES}. "
            f"Got {scheme!r} instead."
        )
    c = float(dt) / domain.grid.dx
    solid = np.ascontiguousarray(domain.solid)
    sides = domain.side_codes
    ux, uy = domain.bc.inflow_velocity
    u_code, v_code = domain.u_code, domain.v_code
    mac = scheme == "maccormack"

    def advect(u, v):
        u_new = _advect_component(u, u_code, u, v, c, solid, sides, ux, True, mac)
        v_new = _advect_component(v, v_code, u, v, c, solid, sides, uy, False, mac)
        return u_new, v_new

    return advect
