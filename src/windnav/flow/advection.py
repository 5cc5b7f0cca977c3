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

Implementation: the floating-point operations of plain whole-field passes, in the same order
(so the same bits), arranged for speed on one core. Each semi-Lagrangian pass works a row of
faces at a time (trace, sample points, samples), so its loops without data-dependent branches
vectorise; the building test of a trace is skipped where the trace is too short to reach a
building (a clearance precomputed per face); the diffusion substeps run in one sweep over the
rows, the few rows that each substep still needs kept in small ring buffers.
"""

from __future__ import annotations

import math

import numpy as np
from scipy import ndimage

from windnav._jit import njit
from windnav.flow.grid import FlowDomain

SCHEMES = ("semi_lagrangian", "maccormack")
MAX_DIFFUSION_SUBSTEPS = 3
_SL, _FORWARD, _BACK = 0, 1, 2  # modes of _advect_pass


@njit(cache=True)
def _fill_ghosts(fp, sides, inflow_val):
    """Fill the ghost layer of the padded face field ``fp`` from its interior: the inlet
    value beyond an inflow side (``sides[k] == 0``), the edge value beyond any other."""
    nyf, nxf = fp.shape[0] - 2, fp.shape[1] - 2
    for i in range(1, nxf + 1):
        fp[0, i] = inflow_val if sides[2] == 0 else fp[1, i]
        fp[nyf + 1, i] = inflow_val if sides[3] == 0 else fp[nyf, i]
    for j in range(nyf + 2):
        fp[j, 0] = inflow_val if sides[0] == 0 else fp[j, 1]
        fp[j, nxf + 1] = inflow_val if sides[1] == 0 else fp[j, nxf]


@njit(cache=True)
def _pad(f, sides, inflow_val, out):
    """Copy ``f`` into ``out[1:-1, 1:-1]`` and fill one ghost layer implementing the sides."""
    nyf, nxf = f.shape
    out[1 : nyf + 1, 1 : nxf + 1] = f
    _fill_ghosts(out, sides, inflow_val)


def _trace_clearance(solid):
    """How long a trace must be to possibly end in a building, per u and per v face (uint8).

    A trace of face ``(j, i)`` with both components shorter than ``clear[j, i] - 2.25`` cells
    ends in a fluid or ghost cell, so its building test can be skipped (same result, less
    work). ``clear`` is the chessboard distance ``d`` from the face's cell (``(j, i)``; the
    last one on the far edge) to the nearest building cell (capped at 255): the square of
    half-side ``d - 1`` cells around that cell is free of buildings, and it holds every cell
    that a trace shorter than ``d - 2.25`` can end in (a face lies on its cell's edge; 0.25
    cells of margin absorb the rounding of the end point).
    """
    ny, nx = solid.shape
    if solid.any():
        d = np.minimum(ndimage.distance_transform_cdt(~solid, metric="chessboard"), 255)
    else:
        d = np.full((ny, nx), 255)
    d = d.astype(np.uint8)
    clear_u = d[:, np.minimum(np.arange(nx + 1), nx - 1)]
    clear_v = d[np.minimum(np.arange(ny + 1), ny - 1), :]
    return np.ascontiguousarray(clear_u), np.ascontiguousarray(clear_v)


@njit(cache=True, inline="always")
def _cell(p, n):
    """Index in a padded array (one ghost layer) of the cell holding position ``p`` (cell
    units, clamped to the ghost layer; ``n`` cells). The outer ``max`` changes nothing but
    tells the compiler the index is not negative (no wraparound code)."""
    return max(int(min(max(p + 1.0, 0.0), n + 1.0)), 0)


@njit(cache=True)
def _trace_row(u, v, c, solid_p, clear, is_u, j, dxs, dys, near):
    """Displacements ``-c * velocity`` (cell units) of the faces of row ``j`` into ``dxs``,
    ``dys``, halved then zeroed where the end point falls in a building cell (``c < 0``
    gives the reverse trace); ``near`` is scratch.

    The velocity at a face is its own component and the mean of the 4 nearest faces of the
    other one (clamped at the edges). The building test is only made where the trace is not
    shorter than the face's clearance (:func:`_trace_clearance`); the other loops vectorise.
    """
    nxf = dxs.size
    ny, nx = solid_p.shape[0] - 2, solid_p.shape[1] - 2
    if is_u:
        for i in range(1, nxf - 1):
            dxs[i] = -c * u[j, i]
            dys[i] = -c * (0.25 * (v[j, i - 1] + v[j, i] + v[j + 1, i - 1] + v[j + 1, i]))
        for i in (0, nxf - 1):
            il, ir = max(i - 1, 0), min(i, nx - 1)
            dxs[i] = -c * u[j, i]
            dys[i] = -c * (0.25 * (v[j, il] + v[j, ir] + v[j + 1, il] + v[j + 1, ir]))
    else:
        jl, jr = max(j - 1, 0), min(j, ny - 1)
        for i in range(nxf):
            dxs[i] = -c * (0.25 * (u[jl, i] + u[jl, i + 1] + u[jr, i] + u[jr, i + 1]))
            dys[i] = -c * v[j, i]
    for i in range(nxf):
        free = clear[j, i] - 2.25
        near[i] = 0.0 if (abs(dxs[i]) < free) & (abs(dys[i]) < free) else 1.0
    x0 = 0.0 if is_u else 0.5  # face position in cell units: (i + x0, j + y0)
    y0 = 0.5 if is_u else 0.0
    for i in range(nxf):
        if near[i] == 0.0:
            continue
        dX, dY = dxs[i], dys[i]
        if solid_p[_cell(j + y0 + dY, ny), _cell(i + x0 + dX, nx)]:
            dX = 0.5 * dX
            dY = 0.5 * dY
            if solid_p[_cell(j + y0 + dY, ny), _cell(i + x0 + dX, nx)]:
                dX = 0.0 * dX
                dY = 0.0 * dY
            dxs[i] = dX
            dys[i] = dY


@njit(cache=True)
def _sample_points(nyf, j, dxs, dys, aa, bb, kk):
    """Where the faces of row ``j`` (``nyf`` rows) displaced by ``dxs``, ``dys`` sample a
    padded face field: the bilinear weights ``aa`` (x), ``bb`` (y) and the flat index ``kk``
    (as float64, exact) of the lower-left of the 4 values."""
    nxf = dxs.size
    w = nxf + 2
    for i in range(nxf):
        # index in the padded field: position - offset + 1 ghost layer
        fi = min(max(i + dxs[i] + 1.0, 0.0), nxf + 1.0)
        fj = min(max(j + dys[i] + 1.0, 0.0), nyf + 1.0)
        i0 = min(np.floor(fi), float(nxf))  # = min(int(fi), nxf), as fi >= 0
        j0 = min(np.floor(fj), float(nyf))
        aa[i] = fi - i0
        bb[i] = fj - j0
        kk[i] = j0 * w + i0


@njit(cache=True)
def _sample_row(src_p, f, code, j, mode, aa, bb, kk, los, his, out, off):
    """Row ``j`` of a pass of :func:`_advect_pass`: the samples of the padded ``src_p`` at
    the points of :func:`_sample_points`, used as ``mode`` says (fixed faces keep ``f``)."""
    flat = src_p.reshape(-1)
    w = src_p.shape[1]
    for i in range(aa.size):
        a, b = aa[i], bb[i]
        k = max(int(kk[i]), 0)  # max: as in _cell
        f00 = flat[k]
        f01 = flat[k + 1]
        f10 = flat[k + w]
        f11 = flat[k + w + 1]
        val = (1.0 - b) * ((1.0 - a) * f00 + a * f01) + b * ((1.0 - a) * f10 + a * f11)
        if mode == _FORWARD:
            los[j, i] = min(min(f00, f01), min(f10, f11))
            his[j, i] = max(max(f00, f01), max(f10, f11))
        if mode == _BACK:
            f_ij = f[j, i]
            val = src_p[j + 1, i + 1] + 0.5 * (f_ij - val)
            val = min(max(val, los[j, i]), his[j, i])
        else:
            f_ij = src_p[j + 1, i + 1]  # src_p is the padded f (one array less to read)
        out[j + off, i + off] = f_ij if code[j, i] == 0 else val


@njit(cache=True)
def _advect_pass(src_p, f, code, u, v, c, solid_p, clear, is_u, mode, los, his, out, off, rows):
    """One semi-Lagrangian pass over face field ``f``, row by row (fixed faces, ``code ==
    0``, keep ``f``).

    Every face ``(j, i)`` is traced by ``-c * velocity`` (:func:`_trace_row`; ``c < 0`` gives
    the reverse trace) and the padded field ``src_p`` sampled bilinearly at the end point
    (:func:`_sample_points`, :func:`_sample_row`). ``mode``:

    * ``_SL``: the sample into ``out[j + off, i + off]``;
    * ``_FORWARD``: the same, and the extrema of the 4 values it interpolated into
      ``los``/``his`` (``phi_hat`` of MacCormack);
    * ``_BACK`` (``src_p`` the padded ``phi_hat``): the sample is ``phi_back``; the clamped
      correction ``phi_hat + (f - phi_back) / 2`` goes into ``out``.

    ``rows`` (6, nxf) is scratch. Working on a row at a time lets the loops without data-
    dependent branches vectorise.
    """
    nyf = f.shape[0]
    dxs, dys, near, aa, bb, kk = rows[0], rows[1], rows[2], rows[3], rows[4], rows[5]
    for j in range(nyf):
        _trace_row(u, v, c, solid_p, clear, is_u, j, dxs, dys, near)
        _sample_points(nyf, j, dxs, dys, aa, bb, kk)
        _sample_row(src_p, f, code, j, mode, aa, bb, kk, los, his, out, off)


@njit(cache=True)
def _advect_component(f, code, u, v, c, solid_p, sides, inflow_val, is_u, maccormack, ws, res):
    """Advect face field ``f`` into ``res``; ``ws`` is the field's workspace
    (:meth:`Advection._scratch`).

    ``ws``: the field and ``phi_hat`` padded with their ghost layer, the range lo and hi of
    ``phi_hat`` (face-shaped), the row scratch of :func:`_advect_pass`, two arrays of the
    diffusion, and the trace clearance of the field's faces (:func:`_trace_clearance`).
    """
    fp, fhat_p, los, his, rows, clear = ws[0], ws[1], ws[2], ws[3], ws[4], ws[7]
    _pad(f, sides, inflow_val, fp)
    if not maccormack:
        _advect_pass(fp, f, code, u, v, c, solid_p, clear, is_u, _SL, los, his, res, 0, rows)
        return
    _advect_pass(fp, f, code, u, v, c, solid_p, clear, is_u, _FORWARD, los, his, fhat_p, 1,
                 rows)
    _fill_ghosts(fhat_p, sides, inflow_val)
    _advect_pass(fhat_p, f, code, u, v, -c, solid_p, clear, is_u, _BACK, los, his, res, 0, rows)


@njit(cache=True)
def _eddy_viscosity(u, v, solid, nu0, cs_delta2, inv_dx, corner, out):
    """Cell-centred kinematic viscosity ``nu0 + (C_s Delta)^2 |S|`` (Smagorinsky 1963), m^2/s.

    ``|S| = sqrt(2 S_ij S_ij)``: the normal strains from the face differences of the cell, the
    shear strain ``(du/dy + dv/dx) / 2`` averaged from the cell's four corners (``corner``,
    (ny + 1, nx + 1) scratch; at the domain's edges the derivative across the edge, du/dy on
    the y edges and dv/dx on the x edges, is taken as 0, as the free-slip and zero-gradient
    sides have it, so an edge cell sees half a shear that crosses it). Building cells get
    ``nu0``.
    Returns the largest value.
    """
    ny, nx = solid.shape
    for jc in range(ny + 1):
        ja, jb = max(jc - 1, 0), min(jc, ny - 1)
        for ic in range(1, nx):
            duy = (u[jb, ic] - u[ja, ic]) * inv_dx if jb > ja else 0.0
            corner[jc, ic] = duy + (v[jc, ic] - v[jc, ic - 1]) * inv_dx
        for ic in (0, nx):  # the x edges: dv/dx = 0 (kept apart: the loop above vectorises)
            duy = (u[jb, ic] - u[ja, ic]) * inv_dx if jb > ja else 0.0
            corner[jc, ic] = duy + 0.0
    top = nu0
    for j in range(ny):
        for i in range(nx):
            ux = (u[j, i + 1] - u[j, i]) * inv_dx
            vy = (v[j + 1, i] - v[j, i]) * inv_dx
            shear = 0.25 * (corner[j, i] + corner[j, i + 1] + corner[j + 1, i]
                            + corner[j + 1, i + 1])
            nu = nu0 + cs_delta2 * math.sqrt(2.0 * (ux * ux + vy * vy) + shear * shear)
            out[j, i] = nu0 if solid[j, i] else nu
        for i in range(nx):  # the maximum apart, so the loop above vectorises
            top = max(top, out[j, i])
    return top


@njit(cache=True)
def _face_viscosity(nu_c, solid, is_u, out):
    """Viscosity on the faces, padded by one ghost layer (``out`` (nyf + 2, nxf + 2)): the mean
    of the two cells' values (fluid cells only); the ghosts repeat the edge."""
    nyf, nxf = out.shape[0] - 2, out.shape[1] - 2
    ny, nx = solid.shape
    for j in range(nyf):
        if is_u:
            for i in range(1, nxf - 1):  # vectorises; the edge faces (one cell) below
                out[j + 1, i + 1] = _face_mean(nu_c[j, i - 1], nu_c[j, i], solid[j, i - 1],
                                               solid[j, i])
            for i in (0, nxf - 1):
                ia, ib = max(i - 1, 0), min(i, nx - 1)
                out[j + 1, i + 1] = _face_mean(nu_c[j, ia], nu_c[j, ib], solid[j, ia],
                                               solid[j, ib])
        else:
            ja, jb = max(j - 1, 0), min(j, ny - 1)
            for i in range(nxf):
                out[j + 1, i + 1] = _face_mean(nu_c[ja, i], nu_c[jb, i], solid[ja, i],
                                               solid[jb, i])
    for i in range(1, nxf + 1):
        out[0, i] = out[1, i]
        out[nyf + 1, i] = out[nyf, i]
    for j in range(nyf + 2):
        out[j, 0] = out[j, 1]
        out[j, nxf + 1] = out[j, nxf]


@njit(cache=True, inline="always")
def _face_mean(nu_a, nu_b, solid_a, solid_b):
    """The viscosity of a face between cells a and b: the mean of the fluid cells' values
    (``nu_b`` when both are solid)."""
    one = nu_a if solid_b else 0.5 * (nu_a + nu_b)
    return nu_b if solid_a else one


def _diffusion_weights(code, solid_p, sides, is_u):
    """Per face: which neighbour fluxes count and how many neighbours are mirrored, packed
    in one uint8 array of the face shape (0 on the fixed faces).

    Bits 0-3: weight 1 (else 0) of the (E, W, N, S) neighbour; bits 4-6: the count of
    neighbours inside a building (no-slip mirror). A neighbour across an inflow side reads
    the inlet value (weight 1, from the ghost layer); across a wall or outflow side it is the
    face itself (weight 0: zero gradient); a neighbour face between two building cells mirrors
    (``-u``: no slip on the wall half a cell away); any other neighbour (fluid, or a fixed
    face with its prescribed value) has weight 1.
    """
    nyf, nxf = code.shape
    mask = np.zeros((nyf, nxf), dtype=np.uint8)
    mirror = np.zeros((nyf, nxf), dtype=np.uint8)
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
        mask |= np.where(free & (ghost_inflow | (~outside & ~inside)), 1 << k, 0).astype(np.uint8)
        mirror += (free & inside).astype(np.uint8)
    return mask | (mirror << 4)


@njit(cache=True)
def _diffusion_row_weights(j, mask, nu_p, c, wts):
    """The flux weights of the faces of row ``j`` into ``wts``: ``a_k = w_k (nu + nu_k)`` of
    the (E, W, N, S) neighbours and the total weight ``s = c (sum(a_k) / 2 + 2 nu m)``.

    ``nu_p`` is the face viscosity (m^2/s) padded by one ghost layer, ``mask`` holds the
    neighbour weights ``w_k`` and the mirror count ``m`` of :func:`_diffusion_weights`; the
    viscosity between two neighbouring faces is the mean of theirs. ``c = dt / dx^2``.
    """
    for i in range(mask.shape[1]):
        m = mask[j, i]
        nu = nu_p[j + 1, i + 1]
        # weight (0.0 or 1.0) times the summed viscosities, as with a float weight array
        a0 = (1.0 if m & 1 else 0.0) * (nu + nu_p[j + 1, i + 2])
        a1 = (1.0 if m & 2 else 0.0) * (nu + nu_p[j + 1, i])
        a2 = (1.0 if m & 4 else 0.0) * (nu + nu_p[j + 2, i + 1])
        a3 = (1.0 if m & 8 else 0.0) * (nu + nu_p[j, i + 1])
        wts[0, i], wts[1, i], wts[2, i], wts[3, i] = a0, a1, a2, a3
        wts[4, i] = 0.5 * c * (a0 + a1 + a2 + a3) + 2.0 * c * nu * float(m >> 4)


@njit(cache=True, error_model="numpy")
def _diffuse_row(src, j, wts, c, dst, rd, off):
    """Row ``j`` of ``f + c * div(nu grad f)`` on the free faces (``c = dt / dx^2``; the
    fixed faces have zero weights and keep f) into ``dst[rd, i + off]``.

    ``src`` holds the field's padded rows ``j, j + 1, j + 2`` (one ghost layer; the inlet
    value beyond an inflow side) at ``src[r % 4]``, ``wts`` the row's flux weights
    (:func:`_diffusion_row_weights`).

    Explicit where that is a convex combination of the face and its neighbours (total weight
    ``s = c sum(nu_k) <= 1``); where the eddy viscosity is so large that it is not, the face is
    updated point-implicitly, ``(f + c sum(nu_k g_k)) / (1 + s)`` (still convex), so the update
    is stable for any viscosity.
    """
    rs, rm, rn = j % 4, (j + 1) % 4, (j + 2) % 4
    for i in range(wts.shape[1]):
        f = src[rm, i + 1]
        pull = wts[0, i] * src[rm, i + 2] + wts[1, i] * src[rm, i] + wts[2, i] * src[rn, i + 1]
        pull = 0.5 * c * (pull + wts[3, i] * src[rs, i + 1])
        total = wts[4, i]
        # both computed, then selected: branch-free, so the loop vectorises (with the numpy
        # error model: no zero-division check, and 1 + total > 0 anyway)
        explicit = f + pull - total * f
        implicit = (f + pull) / (1.0 + total)
        dst[rd, i + off] = explicit if total <= 1.0 else implicit


@njit(cache=True)
def _row_ghosts(row, sides, inflow_val):
    """The ghost ends of one padded row, as :func:`_fill_ghosts`."""
    n = row.size - 2
    row[0] = inflow_val if sides[0] == 0 else row[1]
    row[n + 1] = inflow_val if sides[1] == 0 else row[n]


@njit(cache=True)
def _ghost_row(ghost, edge, side, sides, inflow_val):
    """The padded ghost row beyond y side ``side`` (2 or 3) from the padded edge row, as
    :func:`_fill_ghosts`."""
    for i in range(1, ghost.size - 1):
        ghost[i] = inflow_val if sides[side] == 0 else edge[i]
    _row_ghosts(ghost, sides, inflow_val)


@njit(cache=True)
def _diffuse_substeps(f, mask, nu_p, c, substeps, sides, inflow_val, rings, wts):
    """``substeps`` explicit diffusion steps of face field ``f`` in place, in one sweep.

    Substep ``s`` of row ``j`` needs substep ``s - 1`` of rows ``j - 1 .. j + 1``: at sweep
    step ``t`` row ``t`` of ``f`` is loaded (substep 0) and row ``t - s`` of every substep
    ``s`` computed (:func:`_diffuse_row`), the last one into ``f``. The rows still needed
    stay in ``rings[s]`` (padded row ``r`` at ``r % 4``, with its ghost ends, and the ghost
    rows once the edge rows are there), the flux weights of row ``j`` (the same in every
    substep) in ``wts[j % len(wts)]`` (more slots than substeps): the same values as
    substeps over the whole padded field, from a few rows that stay in cache.
    """
    nyf, nxf = f.shape
    nw = wts.shape[0]  # > substeps: rows t - substeps .. t - 1 have their weights in use
    for t in range(nyf + substeps):
        for s in range(substeps + 1):
            j = t - s
            if j < 0 or j >= nyf:
                continue
            if s == 1:
                _diffusion_row_weights(j, mask, nu_p, c, wts[j % nw])
            if s == substeps:
                _diffuse_row(rings[s - 1], j, wts[j % nw], c, f, j, 0)
                continue
            ring = rings[s]
            if s == 0:
                ring[(j + 1) % 4, 1 : nxf + 1] = f[j]
            else:
                _diffuse_row(rings[s - 1], j, wts[j % nw], c, ring, (j + 1) % 4, 1)
            _row_ghosts(ring[(j + 1) % 4], sides, inflow_val)
            if j == 0:
                _ghost_row(ring[0], ring[1], 2, sides, inflow_val)
            if j == nyf - 1:
                _ghost_row(ring[(nyf + 1) % 4], ring[nyf % 4], 3, sides, inflow_val)


def _substeps_for(r: float) -> int:
    """The explicit diffusion substeps for ``r = nu dt / dx^2``: at most 0.2 per substep."""
    return max(int(math.ceil(r / 0.2)), 1)


def _scratch_shapes(shape, max_substeps=MAX_DIFFUSION_SUBSTEPS):
    """The scratch arrays of a face field of ``shape`` (nyf, nxf): the field and ``phi_hat``
    padded, the range lo and hi of ``phi_hat``, the advection's row scratch, the diffusion's
    row rings (one per substep) and flux weights."""
    nyf, nxf = shape
    padded = (nyf + 2, nxf + 2)
    rings = (max_substeps, 4, nxf + 2)
    return padded, padded, shape, shape, (6, nxf), rings, (max(4, max_substeps + 1), 5, nxf)


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
        ny, nx = domain.grid.shape
        face_shapes = ((ny, nx + 1), (ny + 1, nx))
        self._clear = dict(zip(face_shapes, _trace_clearance(domain.solid), strict=True))
        self._ws = {}
        self._bufs = []
        self._sized_for = None
        self._cs_delta2 = (self.smagorinsky * self.filter_width) ** 2
        self._nu_c = np.full((ny, nx), self.viscosity)
        self._corner = np.zeros((ny + 1, nx + 1))
        self._nu_u = np.full((ny + 2, nx + 3), self.viscosity)
        self._nu_v = np.full((ny + 3, nx + 2), self.viscosity)
        self._w_u = self._w_v = None
        # a fixed viscosity gets the explicit substeps it needs, however many: the
        # point-implicit update applies only nu / (1 + s) of it (a Taylor-Green mode at
        # s = 4 decayed at 0.2 of the requested rate; convergence audit, 2026-12-05); the cap
        # bounds only what the Smagorinsky closure's corner faces add
        self.max_substeps = max(MAX_DIFFUSION_SUBSTEPS,
                                _substeps_for(self.viscosity * self.dt / dx**2))
        if self.diffuses:
            self._w_u = _diffusion_weights(domain.u_code, self._solid_p, self._sides, True)
            self._w_v = _diffusion_weights(domain.v_code, self._solid_p, self._sides, False)

    @property
    def diffuses(self) -> bool:
        """Whether an explicit viscous step follows the advection."""
        return self.viscosity > 0.0 or self._cs_delta2 > 0.0

    def _scratch(self, shape):
        """The workspace of the u or v field (by its ``shape``): the scratch arrays of
        :func:`_scratch_shapes` (views of buffers that the two fields share, one at a time, so
        a step touches less memory) and the field's trace clearance."""
        if self._bufs and self._sized_for != self.max_substeps:
            # the rings hold one row set per substep, sized on the first step: a changed
            # max_substeps would index past them in the kernel (no bounds check); size anew
            self._bufs, self._ws = [], {}
        if shape not in self._ws:
            clear = self._clear[shape]
            if not self._bufs:
                self._sized_for = self.max_substeps
                both = zip(*(_scratch_shapes(s, self.max_substeps) for s in self._clear),
                           strict=True)
                self._bufs = [np.zeros(max(math.prod(a), math.prod(b))) for a, b in both]
            views = tuple(
                buf[: math.prod(s)].reshape(s)
                for buf, s in zip(self._bufs, _scratch_shapes(shape, self.max_substeps),
                                  strict=True)
            )
            self._ws[shape] = (*views, clear)
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
        everywhere) up to ``max_substeps`` (:data:`MAX_DIFFUSION_SUBSTEPS`, or more when a
        fixed viscosity alone needs more); beyond that the few faces of the largest eddy
        viscosity (sharp corners at high CFL) are updated point-implicitly, which applies
        ``nu / (1 + s)`` there (``s`` the face's total weight per substep): a limiter on the
        closure's eddy viscosity at those faces (0.02 % of the fluid faces of a 200 m map at
        5 m/s, 0.3 % at 10 m/s, dx = 1 m, dt = 0.25 s)."""
        d = self.domain
        ux, uy = d.bc.inflow_velocity
        inv_dx = 1.0 / d.grid.dx
        nu_max = self.viscosity
        if self._cs_delta2 > 0.0:
            nu_max = _eddy_viscosity(out_u, out_v, d.solid, self.viscosity, self._cs_delta2,
                                     inv_dx, self._corner, self._nu_c)
            _face_viscosity(self._nu_c, d.solid, True, self._nu_u)
            _face_viscosity(self._nu_c, d.solid, False, self._nu_v)
        substeps = min(_substeps_for(nu_max * self.dt * inv_dx**2), self.max_substeps)
        c = self.dt * inv_dx**2 / substeps
        # the components do not interact: all substeps of u, then all of v
        ws_u, ws_v = self._scratch(out_u.shape), self._scratch(out_v.shape)
        sides = self._sides
        _diffuse_substeps(out_u, self._w_u, self._nu_u, c, substeps, sides, ux, *ws_u[5:7])
        _diffuse_substeps(out_v, self._w_v, self._nu_v, c, substeps, sides, uy, *ws_v[5:7])

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
        diffusion only). Applied after advection in explicit substeps, as many as it needs
        (``ceil(5 nu dt / dx^2)``: a large viscosity costs a pass per substep); with the
        Smagorinsky closure the substeps are capped at ``max(MAX_DIFFUSION_SUBSTEPS, those)``
        and its corner faces beyond the cap are updated point-implicitly.
    smagorinsky : float
        Smagorinsky constant ``C_s`` of an eddy viscosity ``(C_s Delta)^2 |S|`` added to
        ``viscosity`` (0, the default: none).
    filter_width : float, optional
        The filter width ``Delta`` of that eddy viscosity, m (default ``dx``).

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
