"""Self-advection (semi-Lagrangian or MacCormack) and viscous diffusion of the staggered velocity.

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
the domain (zero gradient, free slip); both are one ghost layer around each face field, so
the interpolation is branch-free. Building faces hold zero normal velocity, so samples next
to a building see a no-slip-like wall. A trace whose end point falls inside a building cell
is halved, and if still inside, dropped (the face keeps its value), so nothing is ever
sampled from inside a solid.

Viscous diffusion (optional, kinematic viscosity ``nu``): explicit Euler substeps of
``u += nu dt_s / dx^2 (u_E + u_W + u_N + u_S - 4 u)`` on the free faces with
``nu dt_s / dx^2 <= 0.2`` (stable, 2D limit 0.25). Ghost neighbours: a face inside a building
mirrors (``-u``: no slip on the wall half a cell away), a fixed face gives its value (0 on a
building's face, the inlet value on an inlet), beyond an inflow side the inlet value, beyond
a wall or outflow side the face itself (free slip, zero gradient).
"""

from __future__ import annotations

import math

import numba
import numpy as np

from windnav.flow.grid import FlowDomain

SCHEMES = ("semi_lagrangian", "maccormack")
MAX_DIFFUSION_SUBSTEPS = 3


@numba.njit(cache=True)
def _pad(f, sides, inflow_val, out):
    """Copy ``f`` into ``out[1:-1, 1:-1]`` and fill one ghost layer implementing the sides."""
    nyf, nxf = f.shape
    out[1 : nyf + 1, 1 : nxf + 1] = f
    for i in range(1, nxf + 1):
        out[0, i] = inflow_val if sides[2] == 0 else f[0, i - 1]
        out[nyf + 1, i] = inflow_val if sides[3] == 0 else f[nyf - 1, i - 1]
    for j in range(nyf + 2):
        out[j, 0] = inflow_val if sides[0] == 0 else out[j, 1]
        out[j, nxf + 1] = inflow_val if sides[1] == 0 else out[j, nxf]


@numba.njit(cache=True)
def _trace(u, v, solid_p, c, is_u, dxs, dys):
    """Displacement ``-c * velocity`` (cell units) of every face, halved then zeroed when
    its end point falls in a building cell (``c < 0`` gives the forward, reverse trace)."""
    nyf, nxf = dxs.shape
    ny, nx = solid_p.shape[0] - 2, solid_p.shape[1] - 2
    ox = 0.0 if is_u else 0.5
    oy = 0.5 if is_u else 0.0
    for j in range(nyf):
        jl = max(j - 1, 0)
        jr = min(j, ny - 1)
        for i in range(nxf):
            if is_u:
                il = max(i - 1, 0)
                ir = min(i, nx - 1)
                uu = u[j, i]
                vv = 0.25 * (v[j, il] + v[j, ir] + v[j + 1, il] + v[j + 1, ir])
            else:
                uu = 0.25 * (u[jl, i] + u[jl, i + 1] + u[jr, i] + u[jr, i + 1])
                vv = v[j, i]
            dX = -c * uu
            dY = -c * vv
            for scale in (0.5, 0.0):
                ci = int(min(max(i + ox + dX + 1.0, 0.0), nx + 1.0))
                cj = int(min(max(j + oy + dY + 1.0, 0.0), ny + 1.0))
                s = solid_p[cj, ci]
                dX = scale * dX if s else dX
                dY = scale * dY if s else dY
            dxs[j, i] = dX
            dys[j, i] = dY


@numba.njit(cache=True)
def _sample_all(fp, code, fixed_src, dxs, dys, out, los, his, want_range):
    """out = bilinear sample of padded ``fp`` at face + displacement; fixed faces copy
    ``fixed_src``; ``los``/``his`` get the extrema of the 4 values (when ``want_range``)."""
    nyf, nxf = out.shape
    for j in range(nyf):
        for i in range(nxf):
            # index in the padded field: position - offset + 1 ghost layer
            fi = min(max(i + dxs[j, i] + 1.0, 0.0), nxf + 1.0)
            fj = min(max(j + dys[j, i] + 1.0, 0.0), nyf + 1.0)
            i0 = min(int(fi), nxf)
            j0 = min(int(fj), nyf)
            a = fi - i0
            b = fj - j0
            f00 = fp[j0, i0]
            f01 = fp[j0, i0 + 1]
            f10 = fp[j0 + 1, i0]
            f11 = fp[j0 + 1, i0 + 1]
            val = (1.0 - b) * ((1.0 - a) * f00 + a * f01) + b * ((1.0 - a) * f10 + a * f11)
            fixed = code[j, i] == 0
            out[j, i] = fixed_src[j, i] if fixed else val
            if want_range:
                los[j, i] = min(min(f00, f01), min(f10, f11))
                his[j, i] = max(max(f00, f01), max(f10, f11))


@numba.njit(cache=True)
def _maccormack_correct(f, fhat, fback, los, his, code, out):
    nyf, nxf = f.shape
    for j in range(nyf):
        for i in range(nxf):
            val = fhat[j, i] + 0.5 * (f[j, i] - fback[j, i])
            val = min(max(val, los[j, i]), his[j, i])
            out[j, i] = f[j, i] if code[j, i] == 0 else val


@numba.njit(cache=True)
def _advect_component(f, code, u, v, c, solid_p, sides, inflow_val, is_u, maccormack, ws, res):
    """Advect face field ``f`` into ``res``; ``ws`` is a tuple of scratch arrays.

    ``ws``: displacement x, y, forward value, range lo, hi, reverse value (face-shaped) and
    the field padded with its ghost layer.
    """
    dxs, dys, fhat, los, his, back, fp = ws[0], ws[1], ws[2], ws[3], ws[4], ws[5], ws[6]
    _trace(u, v, solid_p, c, is_u, dxs, dys)
    _pad(f, sides, inflow_val, fp)
    if not maccormack:
        _sample_all(fp, code, f, dxs, dys, res, los, his, False)
        return
    _sample_all(fp, code, f, dxs, dys, fhat, los, his, True)
    _trace(u, v, solid_p, -c, is_u, dxs, dys)
    _pad(fhat, sides, inflow_val, fp)
    _sample_all(fp, code, f, dxs, dys, back, los, his, False)
    _maccormack_correct(f, fhat, back, los, his, code, res)


@numba.njit(cache=True)
def _eddy_viscosity(u, v, solid, nu0, cs_delta2, inv_dx, corner, out):
    """Cell-centred kinematic viscosity ``nu0 + (C_s Delta)^2 |S|`` (Smagorinsky 1963), m^2/s.

    ``|S| = sqrt(2 S_ij S_ij)``: the normal strains from the face differences of the cell, the
    shear strain ``(du/dy + dv/dx) / 2`` averaged from the cell's four corners (``corner``,
    (ny + 1, nx + 1) scratch; one-sided at the domain edges). Building cells get ``nu0``.
    Returns the largest value.
    """
    ny, nx = solid.shape
    for jc in range(ny + 1):
        ja, jb = max(jc - 1, 0), min(jc, ny - 1)
        for ic in range(nx + 1):
            ia, ib = max(ic - 1, 0), min(ic, nx - 1)
            duy = (u[jb, ic] - u[ja, ic]) * inv_dx if jb > ja else 0.0
            dvx = (v[jc, ib] - v[jc, ia]) * inv_dx if ib > ia else 0.0
            corner[jc, ic] = duy + dvx
    top = nu0
    for j in range(ny):
        for i in range(nx):
            ux = (u[j, i + 1] - u[j, i]) * inv_dx
            vy = (v[j + 1, i] - v[j, i]) * inv_dx
            shear = 0.25 * (corner[j, i] + corner[j, i + 1] + corner[j + 1, i]
                            + corner[j + 1, i + 1])
            nu = nu0 + cs_delta2 * math.sqrt(2.0 * (ux * ux + vy * vy) + shear * shear)
            nu = nu0 if solid[j, i] else nu
            out[j, i] = nu
            top = max(top, nu)
    return top


@numba.njit(cache=True)
def _face_viscosity(nu_c, solid, is_u, out):
    """Viscosity on the faces, padded by one ghost layer (``out`` (nyf + 2, nxf + 2)): the mean
    of the two cells' values (fluid cells only); the ghosts repeat the edge."""
    nyf, nxf = out.shape[0] - 2, out.shape[1] - 2
    ny, nx = solid.shape
    for j in range(nyf):
        for i in range(nxf):
            if is_u:
                ja, ia, jb, ib = j, max(i - 1, 0), j, min(i, nx - 1)
            else:
                ja, ia, jb, ib = max(j - 1, 0), i, min(j, ny - 1), i
            fa, fb = not solid[ja, ia], not solid[jb, ib]
            if fa and fb:
                val = 0.5 * (nu_c[ja, ia] + nu_c[jb, ib])
            elif fa:
                val = nu_c[ja, ia]
            else:
                val = nu_c[jb, ib]
            out[j + 1, i + 1] = val
    for i in range(1, nxf + 1):
        out[0, i] = out[1, i]
        out[nyf + 1, i] = out[nyf, i]
    for j in range(nyf + 2):
        out[j, 0] = out[j, 1]
        out[j, nxf + 1] = out[j, nxf]


def _diffusion_weights(code, solid_p, sides, is_u):
    """Per free face: weights (E, W, N, S) of the neighbour fluxes and the count of neighbours
    inside a building (no-slip mirror), as float arrays of the face shape.

    A neighbour across an inflow side reads the inlet value (weight 1, from the ghost layer);
    across a wall or outflow side it is the face itself (weight 0: zero gradient); a neighbour
    face between two building cells mirrors (``-u``: no slip on the wall half a cell away);
    any other neighbour (fluid, or a fixed face with its prescribed value) has weight 1.
    """
    nyf, nxf = code.shape
    w = np.zeros((4, nyf, nxf))
    mirror = np.zeros((nyf, nxf))
    free = code != 0
    for k, (dj, di) in enumerate(((0, 1), (0, -1), (1, 0), (-1, 0))):
        jj = np.arange(nyf)[:, None] + dj + np.zeros((1, nxf), dtype=np.int64)
        ii = np.arange(nxf)[None, :] + di + np.zeros((nyf, 1), dtype=np.int64)
        outside = (jj < 0) | (jj >= nyf) | (ii < 0) | (ii >= nxf)
        side = np.where(jj < 0, 2, np.where(jj >= nyf, 3, np.where(ii < 0, 0, 1)))
        ghost_inflow = outside & (np.asarray(sides)[side] == 0)
        jc, ic = np.clip(jj, 0, nyf - 1), np.clip(ii, 0, nxf - 1)
        if is_u:
            inside = solid_p[jc + 1, ic] & solid_p[jc + 1, ic + 1]
        else:
            inside = solid_p[jc, ic + 1] & solid_p[jc + 1, ic + 1]
        inside &= ~outside
        w[k] = np.where(free & (ghost_inflow | (~outside & ~inside)), 1.0, 0.0)
        mirror += np.where(free & inside, 1.0, 0.0)
    return w, mirror


@numba.njit(cache=True)
def _diffuse_component(fp, w, mirror, nu_p, c, out):
    """``out = f + c * div(nu grad f)`` on the free faces (``c = dt / dx^2``, others keep f).

    ``fp`` and ``nu_p`` are the field and its face viscosity (m^2/s) padded by one ghost layer
    (the inlet value beyond an inflow side); ``w`` (4, nyf, nxf) the neighbour weights (E, W,
    N, S) and ``mirror`` the count of mirrored neighbours of :func:`_diffusion_weights`. The
    viscosity between two neighbouring faces is the mean of theirs.

    Explicit where that is a convex combination of the face and its neighbours (total weight
    ``s = c sum(nu_k) <= 1``); where the eddy viscosity is so large that it is not, the face is
    updated point-implicitly, ``(f + c sum(nu_k g_k)) / (1 + s)`` (still convex), so the update
    is stable for any viscosity.
    """
    nyf, nxf = out.shape
    for j in range(nyf):
        for i in range(nxf):
            f = fp[j + 1, i + 1]
            nu = nu_p[j + 1, i + 1]
            a0 = w[0, j, i] * (nu + nu_p[j + 1, i + 2])
            a1 = w[1, j, i] * (nu + nu_p[j + 1, i])
            a2 = w[2, j, i] * (nu + nu_p[j + 2, i + 1])
            a3 = w[3, j, i] * (nu + nu_p[j, i + 1])
            pull = a0 * fp[j + 1, i + 2] + a1 * fp[j + 1, i] + a2 * fp[j + 2, i + 1]
            pull = 0.5 * c * (pull + a3 * fp[j, i + 1])
            total = 0.5 * c * (a0 + a1 + a2 + a3) + 2.0 * c * nu * mirror[j, i]
            if total <= 1.0:
                out[j, i] = f + pull - total * f
            else:
                out[j, i] = (f + pull) / (1.0 + total)


class Advection:
    """Self-advection (and viscous diffusion) over one time step; build it with
    :func:`make_advection`.

    ``advection(u, v) -> (u_new, v_new)`` is pure (fresh arrays); ``advection.into(u, v,
    out_u, out_v)`` writes into given arrays and reuses internal scratch memory, which is
    what the time loop uses (fresh multi-megabyte arrays each step cost page faults).
    """

    def __init__(
        self,
        domain: FlowDomain,
        dt: float,
        scheme: str,
        viscosity: float = 0.0,
        smagorinsky: float = 0.0,
        filter_width: float | None = None,
    ):
        self.domain = domain
        self.dt = float(dt)
        self.scheme = scheme
        self.viscosity = float(viscosity)
        self.smagorinsky = float(smagorinsky)
        dx = domain.grid.dx
        self.filter_width = dx if filter_width is None else float(filter_width)
        self._c = self.dt / dx
        self._solid_p = np.pad(domain.solid, 1)
        self._sides = domain.side_codes
        self._mac = scheme == "maccormack"
        self._ws = {}
        self._cs_delta2 = (self.smagorinsky * self.filter_width) ** 2
        ny, nx = domain.grid.shape
        self._nu_c = np.full((ny, nx), self.viscosity)
        self._corner = np.zeros((ny + 1, nx + 1))
        self._nu_u = np.full((ny + 2, nx + 3), self.viscosity)
        self._nu_v = np.full((ny + 3, nx + 2), self.viscosity)
        self._w_u = self._w_v = None
        if self.diffuses:
            self._w_u = _diffusion_weights(domain.u_code, self._solid_p, self._sides, True)
            self._w_v = _diffusion_weights(domain.v_code, self._solid_p, self._sides, False)

    @property
    def diffuses(self) -> bool:
        """Whether an explicit viscous step follows the advection."""
        return self.viscosity > 0.0 or self._cs_delta2 > 0.0

    def _scratch(self, shape):
        if shape not in self._ws:
            bufs = [np.zeros(shape) for _ in range(6)]
            bufs.append(np.zeros((shape[0] + 2, shape[1] + 2)))
            self._ws[shape] = tuple(bufs)
        return self._ws[shape]

    def into(self, u, v, out_u, out_v):
        """Advect ``(u, v)`` into ``out_u`` (ny, nx + 1) and ``out_v`` (ny + 1, nx)."""
        d = self.domain
        ux, uy = d.bc.inflow_velocity
        args = (self._c, self._solid_p, self._sides)
        ws_u, ws_v = self._scratch(u.shape), self._scratch(v.shape)
        _advect_component(u, d.u_code, u, v, *args, ux, True, self._mac, ws_u, out_u)
        _advect_component(v, d.v_code, u, v, *args, uy, False, self._mac, ws_v, out_v)
        if self.diffuses:
            self._diffuse(out_u, out_v)
        return out_u, out_v

    def _diffuse(self, out_u, out_v):
        """Viscous substeps in place: enough for ``max(nu) dt_s / dx^2 <= 0.2`` (explicit
        everywhere) up to :data:`MAX_DIFFUSION_SUBSTEPS`; beyond that the few faces of the
        largest eddy viscosity (sharp corners at high CFL) are updated point-implicitly."""
        d = self.domain
        ux, uy = d.bc.inflow_velocity
        inv_dx = 1.0 / d.grid.dx
        nu_max = self.viscosity
        if self._cs_delta2 > 0.0:
            nu_max = _eddy_viscosity(out_u, out_v, d.solid, self.viscosity, self._cs_delta2,
                                     inv_dx, self._corner, self._nu_c)
            _face_viscosity(self._nu_c, d.solid, True, self._nu_u)
            _face_viscosity(self._nu_c, d.solid, False, self._nu_v)
        r = nu_max * self.dt * inv_dx**2
        substeps = min(max(int(math.ceil(r / 0.2)), 1), MAX_DIFFUSION_SUBSTEPS)
        c = self.dt * inv_dx**2 / substeps
        pu = self._scratch(out_u.shape)[6]
        pv = self._scratch(out_v.shape)[6]
        for _ in range(substeps):
            # Jacobi-style: both components from the same old field
            _pad(out_u, self._sides, ux, pu)
            _pad(out_v, self._sides, uy, pv)
            _diffuse_component(pu, *self._w_u, self._nu_u, c, out_u)
            _diffuse_component(pv, *self._w_v, self._nu_v, c, out_v)

    def __call__(self, u, v):
        return self.into(u, v, np.empty_like(u), np.empty_like(v))


def make_advection(
    domain: FlowDomain,
    dt: float,
    scheme: str = "maccormack",
    viscosity: float = 0.0,
    smagorinsky: float = 0.0,
    filter_width: float | None = None,
) -> Advection:
    """Build the self-advection of the face velocity over ``dt`` (plus viscous diffusion).

    Parameters
    ----------
    domain : FlowDomain
        Grid, buildings and boundary conditions.
    dt : float
        Time step, s.
    scheme : {"maccormack", "semi_lagrangian"}
        Advection scheme (resolved once here, not in the loop).
    viscosity : float
        Kinematic viscosity ``nu``, m^2/s (>= 0; 0: inviscid, the scheme's numerical
        diffusion only). Applied after advection in explicit substeps.

    Returns
    -------
    Advection
        ``advect(u, v) -> (u_new, v_new)`` on the face fields ``u`` (ny, nx + 1) and
        ``v`` (ny + 1, nx), m/s.
    """
    if scheme not in SCHEMES:
        raise ValueError(
            f"The 'scheme' parameter of make_advection must be one of {SCHEMES}. "
            f"Got {scheme!r} instead."
        )
    viscosity = float(viscosity)
    if not np.isfinite(viscosity) or viscosity < 0:
        raise ValueError(
            "The 'viscosity' parameter of make_advection must be a finite number >= 0. "
            f"Got {viscosity!r} instead."
        )
    for name, value in (("smagorinsky", smagorinsky), ("filter_width", filter_width)):
        if value is not None and not (np.isfinite(float(value)) and float(value) >= 0):
            raise ValueError(
                f"The {name!r} parameter of make_advection must be a finite number >= 0. "
                f"Got {value!r} instead."
            )
    return Advection(domain, dt, scheme, viscosity, float(smagorinsky), filter_width)
