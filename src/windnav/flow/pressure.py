"""Pressure projection on the MAC grid: exact sparse-direct solve and fixed-count Jacobi.

Chorin's projection: the advected field ``u*`` is made divergence-free by
``u = u* - grad(q)`` with ``div(grad(q)) = div(u*)`` (``q = p dt / (rho dx)`` in cell units,
so the discrete system has integer coefficients and no ``dx``). Per fluid cell ``c``

    sum over open faces f:  w_f (q_c - q_nb(f)) = -(u_E - u_W + v_N - v_S)_c      (A q = b)

with ``w = 1`` across an interior face (to the neighbour's ``q``) and ``w = 2`` on an outflow
face (Dirichlet ``p = 0`` on the face: ghost ``q = -q_c``). Fixed faces (buildings, walls,
inlet) carry no term (Neumann). ``A`` is symmetric positive definite once every connected
fluid region touches an outflow face; a region that does not (a closed box) gets ``q = 0``
pinned in one cell, which is exact because its right-hand side sums to zero.

The exact solver eliminates the red cells (``i + j`` even, coupled only to black ones) in
closed form and factorises the Schur complement on the black cells once, by CHOLMOD's sparse
Cholesky (default) or SuperLU, see :class:`RedBlackFactor`;
a :class:`FactorCache` owned by the caller (e.g. one per :func:`~windnav.flow.simulate_batch`
call, shared by its inlet speeds) reuses factors keyed by the face classification (mask +
grid + boundary kinds); there is no module-level state.
Whole-matrix SuperLU orderings (geometric nested dissection, George 1973; MMD; COLAMD)
remain selectable. The Jacobi solver reproduces the thesis's fixed-iteration scheme (300
sweeps from q = 0).
"""

from __future__ import annotations

import hashlib
import importlib
import os
import signal
import sys
import threading
from collections import OrderedDict

import numpy as np
import scipy.sparse as sp
from scipy import ndimage
from scipy.sparse.linalg import splu

from windnav._jit import njit
from windnav.flow.grid import FACE_INTERIOR, FACE_OUTFLOW, FlowDomain

ORDERINGS = ("red_black", "nested_dissection", "MMD_AT_PLUS_A", "COLAMD")
FACTOR_BACKENDS = ("cholmod", "superlu")


@njit(cache=True)
def _divergence_raw(u, v):
    ny, nx = u.shape[0], v.shape[1]
    d = np.empty((ny, nx))
    for j in range(ny):
        for i in range(nx):
            d[j, i] = u[j, i + 1] - u[j, i] + v[j + 1, i] - v[j, i]
    return d


def divergence(domain: FlowDomain, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Discrete divergence ``(du/dx + dv/dy)`` per cell, shape (ny, nx), 1/s; 0 in buildings."""
    d = _divergence_raw(np.ascontiguousarray(u), np.ascontiguousarray(v)) / domain.grid.dx
    d[domain.solid] = 0.0
    return d


@njit(cache=True)
def _rhs(u, v, idx, b):
    """``b = -div(u)`` (raw face differences) on the unknowns numbered by ``idx``."""
    ny, nx = idx.shape
    for j in range(ny):
        for i in range(nx):
            k = idx[j, i]
            if k >= 0:
                b[k] = -(u[j, i + 1] - u[j, i] + v[j + 1, i] - v[j, i])
    return b


@njit(cache=True)
def _subtract_gradient(q, idx, u_code, v_code, u_in, v_in, u, v):
    """``u = u_in - grad q``, ``v = v_in - grad q`` on the open faces, the other faces copied
    (``u`` may be ``u_in``); ``q`` indexed by ``idx``."""
    ny, nx = idx.shape
    for j in range(ny):
        for i in range(nx + 1):
            c = u_code[j, i]
            g = 0.0
            if c == FACE_INTERIOR:
                g = q[idx[j, i]] - q[idx[j, i - 1]]
            elif c == FACE_OUTFLOW:
                g = 2.0 * q[idx[j, 0]] if i == 0 else -2.0 * q[idx[j, nx - 1]]
            u[j, i] = u_in[j, i] - g if c == FACE_INTERIOR or c == FACE_OUTFLOW else u_in[j, i]
    for j in range(ny + 1):
        for i in range(nx):
            c = v_code[j, i]
            g = 0.0
            if c == FACE_INTERIOR:
                g = q[idx[j, i]] - q[idx[j - 1, i]]
            elif c == FACE_OUTFLOW:
                g = 2.0 * q[idx[0, i]] if j == 0 else -2.0 * q[idx[ny - 1, i]]
            v[j, i] = v_in[j, i] - g if c == FACE_INTERIOR or c == FACE_OUTFLOW else v_in[j, i]


def _nested_dissection(ny: int, nx: int, leaf: int = 16) -> np.ndarray:
    """Geometric nested-dissection order of the cells of an (ny, nx) grid (flat indices)."""
    cells = np.arange(ny * nx).reshape(ny, nx)
    order = []
    stack = [(0, ny, 0, nx, False)]
    # explicit stack: (j0, j1, i0, i1, emit) where emit pushes a separator after its halves
    while stack:
        j0, j1, i0, i1, emit = stack.pop()
        if emit:
            order.append(cells[j0:j1, i0:i1].ravel())
            continue
        h, w = j1 - j0, i1 - i0
        if h <= 0 or w <= 0:
            continue
        if h * w <= leaf:
            order.append(cells[j0:j1, i0:i1].ravel())
            continue
        if w >= h:
            m = (i0 + i1) // 2
            parts = [(j0, j1, i0, m, False), (j0, j1, m + 1, i1, False), (j0, j1, m, m + 1, True)]
        else:
            m = (j0 + j1) // 2
            parts = [(j0, m, i0, i1, False), (m + 1, j1, i0, i1, False), (m, m + 1, i0, i1, True)]
        stack.extend(reversed(parts))
    return np.concatenate(order)


def _cell_index(domain: FlowDomain, ordering: str) -> tuple[np.ndarray, int]:
    """Map cell -> unknown number (-1 in buildings).

    ``red_black``: the red cells (``i + j`` even) first, then the black ones, each row-major
    (so the two halves of a vector are contiguous views). ``nested_dissection``: the
    geometric nested-dissection order. Otherwise row-major.
    """
    ny, nx = domain.grid.shape
    fluid = ~domain.solid.ravel()
    if ordering == "nested_dissection":
        seq = _nested_dissection(ny, nx)
    elif ordering == "red_black":
        jj, ii = np.divmod(np.arange(ny * nx), nx)
        seq = np.argsort((jj + ii) % 2, kind="stable")
    else:
        seq = np.arange(ny * nx)
    seq = seq[fluid[seq]]
    idx = np.full(ny * nx, -1, dtype=np.int64)
    idx[seq] = np.arange(seq.size)
    return idx.reshape(ny, nx), int(seq.size)


def _diagonal(uc, vc) -> np.ndarray:
    """Per-cell diagonal of A: 1 per interior face, 2 per outflow face."""
    diag = np.zeros((uc.shape[0], vc.shape[1]))
    for code, w in ((FACE_INTERIOR, 1.0), (FACE_OUTFLOW, 2.0)):
        for faces in (uc[:, :-1], uc[:, 1:], vc[:-1, :], vc[1:, :]):
            diag += w * (faces == code)
    return diag


def poisson_matrix(domain: FlowDomain, idx: np.ndarray, n: int):
    """Assemble ``A`` (n, n) CSC and the unknowns pinned in closed regions.

    Returns
    -------
    A : scipy.sparse.csc_matrix
    pinned : ndarray of int
        Unknowns whose ``q`` is fixed to 0 (one per region without an outflow face).
    """
    uc, vc = domain.u_code, domain.v_code
    diag = _diagonal(uc, vc)
    iu = uc[:, 1:-1] == FACE_INTERIOR
    iv = vc[1:-1, :] == FACE_INTERIOR
    a = np.concatenate([idx[:, :-1][iu], idx[:-1, :][iv]])
    b = np.concatenate([idx[:, 1:][iu], idx[1:, :][iv]])
    fluid = idx >= 0
    pinned = _pinned_cells(domain, idx)
    keep = ~(np.isin(a, pinned) | np.isin(b, pinned))
    a, b = a[keep], b[keep]
    d = diag[fluid]
    order = idx[fluid]
    dvec = np.empty(n)
    dvec[order] = d
    dvec[pinned] = 1.0
    rows = np.concatenate([a, b, np.arange(n)])
    cols = np.concatenate([b, a, np.arange(n)])
    vals = np.concatenate([-np.ones(2 * a.size), dvec])
    return sp.csc_matrix((vals, (rows, cols)), shape=(n, n)), pinned


def _pinned_cells(domain: FlowDomain, idx: np.ndarray) -> np.ndarray:
    labels, count = ndimage.label(~domain.solid)
    if count == 0:
        return np.zeros(0, dtype=np.int64)
    uc, vc = domain.u_code, domain.v_code
    touches = np.zeros(domain.grid.shape, dtype=bool)
    touches |= (uc[:, :-1] == FACE_OUTFLOW) | (uc[:, 1:] == FACE_OUTFLOW)
    touches |= (vc[:-1, :] == FACE_OUTFLOW) | (vc[1:, :] == FACE_OUTFLOW)
    open_labels = np.unique(labels[touches])
    pinned = []
    for lab in range(1, count + 1):
        if lab not in open_labels:
            cells = np.flatnonzero(labels.ravel() == lab)
            pinned.append(idx.ravel()[cells[0]])
    return np.array(pinned, dtype=np.int64)


def _factor_key(domain: FlowDomain, ordering: str, backend: str) -> str:
    h = hashlib.sha1()
    h.update(repr((domain.grid.shape, ordering, backend)).encode())
    h.update(domain.u_code.tobytes())
    h.update(domain.v_code.tobytes())
    return h.hexdigest()


class RedBlackFactor:
    """Exact solver of ``A q = b`` by eliminating the red cells first.

    The 5-point stencil couples a red cell (``i + j`` even) only to black ones, so with the
    red unknowns first ``A = [[D_R, A_RB], [A_BR, A_BB]]`` with ``D_R`` diagonal, and

        S q_B = b_B - A_BR D_R^-1 b_R,     q_R = D_R^-1 (b_R - A_RB q_B),

    where the Schur complement ``S = A_BB - A_BR D_R^-1 A_RB`` (SPD, a 9-point stencil on half
    the cells) is factorised once. This is cyclic reduction's first level (Buzbee, Golub &
    Nielson 1970) in front of a sparse direct solve: the factor of S has fewer nonzeros than
    that of A under any ordering SuperLU offers, and half the columns.

    ``backend``: ``"cholmod"`` (default) is the supernodal sparse Cholesky factor ``S = L L^T``
    of CHOLMOD (Chen, Davis, Hager & Rajamanickam 2008), through the ``cholespy`` wheel; its
    solves with several right-hand sides are dense block operations on the supernodes, and it
    stores only ``L``. ``"superlu"`` is SuperLU's LU (symmetric mode, no pivoting, multiple
    minimum degree on S + S^T), about half as fast per solve on a 500^2 map (see
    docs/benchmarks.md).
    """

    def __init__(self, A, n_red: int, backend: str = "cholmod"):
        if backend not in FACTOR_BACKENDS:
            raise ValueError(
                f"The 'backend' parameter of RedBlackFactor must be one of {FACTOR_BACKENDS}. "
                f"Got {backend!r} instead."
            )
        A = A.tocsr()
        self.shape = A.shape
        self.backend = backend
        self._nr = n_red
        d = A.diagonal()
        self._dinv_r = 1.0 / d[:n_red]
        self._a_rb = A[:n_red, n_red:].tocsr()
        self._a_br = A[n_red:, :n_red].tocsr()
        schur = A[n_red:, n_red:] - self._a_br @ sp.diags(self._dinv_r) @ self._a_rb
        self._schur_solve = None
        if schur.shape[0]:
            self._schur_solve = (_cholmod_solver(schur) if backend == "cholmod"
                                 else _splu_spd(schur.tocsc(), "MMD_AT_PLUS_A").solve)

    def solve(self, b: np.ndarray) -> np.ndarray:
        """``A^-1 b`` for ``b`` of shape (n,) or (n, k) (k right-hand sides at once: one
        multi-right-hand-side solve of the Schur complement, each sparse product one call)."""
        b = np.ascontiguousarray(b, dtype=float)
        nr = self._nr
        dinv = self._dinv_r if b.ndim == 1 else self._dinv_r[:, None]
        x = np.empty(b.shape)
        br, xr = b[:nr], x[:nr]
        np.multiply(br, dinv, out=xr)
        if self._schur_solve is not None:
            rhs = self._a_br @ xr
            np.subtract(b[nr:], rhs, out=rhs)
            x[nr:] = self._schur_solve(rhs)
            t = self._a_rb @ x[nr:]
            np.subtract(br, t, out=t)
            np.multiply(t, dinv, out=xr)
        return x


def import_holding_ctrl_c(name: str):
    """``importlib.import_module(name)`` with Ctrl-C (SIGINT) held until the import ends.

    nanobind, which builds ``cholespy``, turns a ``KeyboardInterrupt`` raised while its
    extension initialises into a C++ exception, and the process aborts (SIGABRT, "terminate
    called after throwing an instance of 'nanobind::python_error'") instead of stopping as
    Ctrl-C should (``windnav`` exits 130). A SIGINT that arrives during the import is handed to
    the previous handler just after it (the default one raises ``KeyboardInterrupt``; an
    ignored one stays ignored). Only the main thread can hold a signal, and only a handler set
    from Python can be put back; otherwise, and once the module is loaded, this is a plain
    import.
    """
    if (name in sys.modules or threading.current_thread() is not threading.main_thread()
            or signal.getsignal(signal.SIGINT) is None):  # None: a handler not set from Python
        return importlib.import_module(name)
    held = []
    previous = signal.signal(signal.SIGINT, lambda signum, frame: held.append(signum))
    try:
        module = importlib.import_module(name)
    finally:
        signal.signal(signal.SIGINT, previous)
    if held:
        if callable(previous):
            previous(signal.SIGINT, None)
        elif previous == signal.SIG_DFL:
            os.kill(os.getpid(), signal.SIGINT)
    return module


def _cholmod_solver(schur):
    """``solve(b) -> S^-1 b`` (b: (m,) or (m, k)) by CHOLMOD's Cholesky factor of SPD ``S``.

    cholespy 2.2.0 (the latest) does not free the dense work array of its first solve when the
    solver is destroyed: ``8 m k`` bytes stay allocated per factor that was used (measured: 157
    kB per solver of m = 20,000, k = 1, against 0.6 kB unsolved, and 130 kB per flow of a 200 m
    map; computed from m, about 1.4 MB for a 600 m map at 1 m and one speed; leak audit,
    thirty-seventh session). A process making thousands of flows grows by that much per flow.
    A factor reused from a :class:`FactorCache` costs nothing more.
    """
    cholespy = import_holding_ctrl_c("cholespy")
    CholeskySolverD, MatrixType = cholespy.CholeskySolverD, cholespy.MatrixType

    coo = sp.coo_matrix(schur)
    chol = CholeskySolverD(coo.shape[0], coo.row.astype(np.int32), coo.col.astype(np.int32),
                           np.ascontiguousarray(coo.data, dtype=float), MatrixType.COO)

    def solve(b):
        b = np.ascontiguousarray(b)
        x = np.empty_like(b)
        chol.solve(b, x)
        return x

    return solve


def _splu_spd(A, permc: str):
    # A is SPD: no pivoting needed, and symmetric mode keeps the column order on the rows
    return splu(A, permc_spec=permc, diag_pivot_thresh=0.0, options={"SymmetricMode": True})


class FactorCache:
    """Factorisations of Poisson matrices, reused by face classification; owned by the caller.

    Pass one to :func:`factorize`, :func:`make_exact_projection` or
    :func:`~windnav.flow.make_flow_step` to share a factorisation between projections of the
    same mask, grid and boundary kinds (several inlet speeds of one direction). Keeps the
    ``maxsize`` most recently used factors (each holds tens of MB on a 500^2 grid).
    """

    def __init__(self, maxsize: int = 4):
        if isinstance(maxsize, bool) or not isinstance(maxsize, (int, np.integer)) or maxsize < 1:
            raise ValueError(
                f"The 'maxsize' parameter of FactorCache must be an integer >= 1. "
                f"Got {maxsize!r} instead."
            )
        self.maxsize = int(maxsize)
        self._items: OrderedDict = OrderedDict()

    def __len__(self) -> int:
        return len(self._items)

    def get(self, key: str):
        """The cached entry for ``key`` (marked most recently used), or None."""
        if key not in self._items:
            return None
        self._items.move_to_end(key)
        return self._items[key]

    def put(self, key: str, value) -> None:
        """Store ``value`` under ``key``, dropping the least recently used beyond ``maxsize``."""
        self._items[key] = value
        self._items.move_to_end(key)
        while len(self._items) > self.maxsize:
            self._items.popitem(last=False)


def factorize(
    domain: FlowDomain,
    ordering: str = "red_black",
    *,
    cache: FactorCache | None = None,
    backend: str = "cholmod",
):
    """Factors of the domain's Poisson matrix (from ``cache`` when it holds them).

    Parameters
    ----------
    domain : FlowDomain
    ordering : {"red_black", "nested_dissection", "MMD_AT_PLUS_A", "COLAMD"}
        ``red_black`` (default): :class:`RedBlackFactor`. Otherwise SuperLU on the whole
        matrix with that column ordering (``nested_dissection``: cells numbered by geometric
        nested dissection, then refined by SuperLU's MMD on A + A^T).
    cache : FactorCache, optional
        Where to look the factors up and store them (keyed by the face classification);
        None (default): factorise afresh.
    backend : {"cholmod", "superlu"}
        The factorisation of the ``red_black`` ordering's Schur complement, see
        :class:`RedBlackFactor` (the other orderings always use SuperLU).

    Returns
    -------
    factor : RedBlackFactor or scipy.sparse.linalg.SuperLU
        ``factor.solve(b)`` returns ``A^-1 b``.
    idx : ndarray of int64, shape (ny, nx)
        Unknown number of each cell (-1 in buildings).
    pinned : ndarray of int
        Pinned unknowns (see :func:`poisson_matrix`).
    """
    if ordering not in ORDERINGS:
        raise ValueError(
            f"The 'ordering' parameter of factorize must be one of {ORDERINGS}. "
            f"Got {ordering!r} instead."
        )
    key = _factor_key(domain, ordering, backend) if cache is not None else None
    if cache is not None and (hit := cache.get(key)) is not None:
        return hit
    idx, n = _cell_index(domain, ordering)
    A, pinned = poisson_matrix(domain, idx, n)
    if ordering == "red_black":
        ny, nx = domain.grid.shape
        jj, ii = np.mgrid[0:ny, 0:nx]
        n_red = int(np.count_nonzero(~domain.solid & ((jj + ii) % 2 == 0)))
        factor = RedBlackFactor(A, n_red, backend)
    else:
        permc = "MMD_AT_PLUS_A" if ordering == "nested_dissection" else ordering
        factor = _splu_spd(A, permc)
    idx.setflags(write=False)
    entry = (factor, idx, pinned)
    if cache is not None:
        cache.put(key, entry)
    return entry


class Projection:
    """A built projection: ``project(u, v) -> (u, v)`` (pure) and ``project.into(u, v,
    out_u, out_v)`` (outputs may be the inputs). Build with :func:`make_exact_projection`
    or :func:`make_jacobi_projection`.

    :meth:`into_many` projects several fields that share the face classification (the same
    map and boundary kinds, e.g. several inlet speeds) with one multi-right-hand-side solve.
    """

    def __init__(self, domain: FlowDomain, solve_q, idx: np.ndarray, solve_many=None):
        self.domain = domain
        self._solve_q = solve_q
        self._solve_many = solve_many
        self._idx = idx

    def into_many(self, us, vs, outs_u, outs_v, domains=None) -> None:
        """Project each ``(us[c], vs[c])`` into ``(outs_u[c], outs_v[c])``.

        ``domains`` (optional) are the fields' own domains: they must have this projection's
        face classification (only their prescribed inlet values may differ).
        """
        if domains is not None:
            for d in domains:
                if not (
                    np.array_equal(d.u_code, self.domain.u_code)
                    and np.array_equal(d.v_code, self.domain.v_code)
                ):
                    raise ValueError(
                        "Projection.into_many: every domain must have the projection's face "
                        "classification (same buildings, grid and boundary kinds)."
                    )
        if self._solve_many is None:
            for u, v, ou, ov in zip(us, vs, outs_u, outs_v, strict=True):
                self.into(u, v, ou, ov)
            return
        q = self._solve_many(us, vs)
        d = self.domain
        for c, (u, v, ou, ov) in enumerate(zip(us, vs, outs_u, outs_v, strict=True)):
            _subtract_gradient(q[:, c], self._idx, d.u_code, d.v_code, u, v, ou, ov)

    def solve(self, u, v) -> np.ndarray:
        """The potential ``q`` (indexed by the cell numbering) that removes div of (u, v)."""
        return self._solve_q(u, v)

    def into(self, u, v, out_u, out_v, q_cells=None):
        """Project ``(u, v)`` into ``out_u``, ``out_v``; ``q_cells`` (ny, nx), if given,
        receives the potential ``q = p dt / (rho dx)`` (m/s) per fluid cell."""
        q = self._solve_q(u, v)
        if q_cells is not None:
            fluid = self._idx >= 0
            q_cells[fluid] = q[self._idx[fluid]]
        d = self.domain
        _subtract_gradient(q, self._idx, d.u_code, d.v_code, u, v, out_u, out_v)
        return out_u, out_v

    def __call__(self, u, v):
        return self.into(u, v, np.empty_like(u), np.empty_like(v))


def make_exact_projection(
    domain: FlowDomain,
    ordering: str = "red_black",
    *,
    cache: FactorCache | None = None,
    backend: str = "cholmod",
) -> Projection:
    """Build the projection solving the masked Poisson problem exactly (sparse direct).

    The factorisation happens here, once (or comes from ``cache``, shared by every
    projection built with it for the same mask, grid and boundary kinds).

    Parameters
    ----------
    domain : FlowDomain
    ordering : {"red_black", "nested_dissection", "MMD_AT_PLUS_A", "COLAMD"}
        Elimination order of the unknowns, see :func:`factorize`.
    cache : FactorCache, optional
        Factor cache owned by the caller (default: none, factorise here).
    backend : {"cholmod", "superlu"}
        Factorisation of the ``red_black`` Schur complement, see :func:`factorize`.
    """
    lu, idx, pinned = factorize(domain, ordering, cache=cache, backend=backend)
    n = lu.shape[0]

    def solve_q(u, v):
        b = np.empty(n)  # every unknown is a fluid cell: _rhs writes each entry
        _rhs(u, v, idx, b)
        b[pinned] = 0.0
        return lu.solve(b)

    def solve_many(us, vs):
        bm = np.empty((n, len(us)))  # row-major: what the Cholesky solve takes without a copy
        for c, (u, v) in enumerate(zip(us, vs, strict=True)):
            _rhs(u, v, idx, bm[:, c])
        bm[pinned] = 0.0
        return lu.solve(bm)

    return Projection(domain, solve_q, idx, solve_many)


@njit(cache=True)
def _jacobi(b_grid, diag, wE, wW, wN, wS, iterations):
    ny, nx = b_grid.shape
    q = np.zeros((ny, nx))
    q_new = np.zeros((ny, nx))
    for _ in range(iterations):
        for j in range(ny):
            for i in range(nx):
                d = diag[j, i]
                if d == 0.0:
                    continue
                s = b_grid[j, i]
                if wE[j, i]:
                    s += q[j, i + 1]
                if wW[j, i]:
                    s += q[j, i - 1]
                if wN[j, i]:
                    s += q[j + 1, i]
                if wS[j, i]:
                    s += q[j - 1, i]
                q_new[j, i] = s / d
        q, q_new = q_new, q
    return q


def make_jacobi_projection(domain: FlowDomain, iterations: int = 300) -> Projection:
    """Build the projection with ``iterations`` Jacobi sweeps from ``q = 0``.

    This is the thesis's fixed-cost scheme: the residual divergence is not driven to zero.
    """
    iterations = int(iterations)
    if iterations < 1:
        raise ValueError(
            "The 'iterations' parameter of make_jacobi_projection must be an integer >= 1. "
            f"Got {iterations!r} instead."
        )
    uc, vc = domain.u_code, domain.v_code
    ny, nx = domain.grid.shape
    idx = np.arange(ny * nx).reshape(ny, nx)
    diag = _diagonal(uc, vc)
    diag[domain.solid] = 0.0
    wE = np.ascontiguousarray(uc[:, 1:] == FACE_INTERIOR)
    wW = np.ascontiguousarray(uc[:, :-1] == FACE_INTERIOR)
    wN = np.ascontiguousarray(vc[1:, :] == FACE_INTERIOR)
    wS = np.ascontiguousarray(vc[:-1, :] == FACE_INTERIOR)

    def solve_q(u, v):
        b = -_divergence_raw(u, v)
        b[domain.solid] = 0.0
        return _jacobi(b, diag, wE, wW, wN, wS, iterations).ravel()

    return Projection(domain, solve_q, idx)
