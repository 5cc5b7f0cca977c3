"""Numba kernels of the UKF arithmetic (see :mod:`windnav.estimate.ukf` for the equations).

The user models stay Python callables; everything between their calls runs here, so that a
16-state predict + update costs a few numba calls instead of dozens of small numpy calls.
"""

from __future__ import annotations

import numpy as np

from windnav._jit import njit


@njit(cache=True)
def chol_lower(A, L):
    """Lower Cholesky factor of the symmetric part of ``A`` into ``L``; False if not PD."""
    n = A.shape[0]
    for j in range(n):
        d = A[j, j]
        for k in range(j):
            d -= L[j, k] * L[j, k]
        if not d > 0.0:
            return False
        L[j, j] = np.sqrt(d)
        for i in range(j + 1, n):
            v = 0.5 * (A[i, j] + A[j, i])
            for k in range(j):
                v -= L[i, k] * L[j, k]
            L[i, j] = v / L[j, j]
        for i in range(j):
            L[i, j] = 0.0
    return True


@njit(cache=True)
def sigma_from_chol(x, L, scale):
    """Sigma points ``x, x + sqrt(scale) L[:, i], x - sqrt(scale) L[:, i]`` (2n + 1, n)."""
    n = x.shape[0]
    c = np.sqrt(scale)
    X = np.empty((2 * n + 1, n))
    for j in range(n):
        X[0, j] = x[j]
    for i in range(n):
        for j in range(n):
            d = c * L[j, i]
            X[1 + i, j] = x[j] + d
            X[1 + n + i, j] = x[j] - d
    return X


@njit(cache=True)
def sigma_from_cov(x, P, scale):
    """Sigma points from a covariance; ``ok`` False when P is not positive definite."""
    n = x.shape[0]
    L = np.zeros((n, n))
    ok = chol_lower(P, L)
    if not ok:
        return np.empty((0, n)), False
    return sigma_from_chol(x, L, scale), True


@njit(cache=True)
def unscented(Y, wm, wc, noise, add_noise):
    """Weighted mean (m,) and symmetric covariance (m, m) of sigma points Y (S, m)."""
    S, m = Y.shape
    mean = np.zeros(m)
    for s in range(S):
        for j in range(m):
            mean[j] += wm[s] * Y[s, j]
    D = np.empty((S, m))
    for s in range(S):
        for j in range(m):
            D[s, j] = Y[s, j] - mean[j]
    cov = np.empty((m, m))
    for i in range(m):
        for j in range(i + 1):
            v = 0.0
            for s in range(S):
                v += wc[s] * D[s, i] * D[s, j]
            if add_noise:
                v += 0.5 * (noise[i, j] + noise[j, i])
            cov[i, j] = v
            cov[j, i] = v
    return mean, cov


@njit(cache=True)
def update(x, P, X, Z, z, R, wm, wc, wrap):
    """Measurement update from sigma points X (S, n) of the prior and their images Z (S, m).

    Returns ``(x+, P+, innovation, S, ok)``; ``ok`` is False if S is not positive definite
    (then x+ and P+ are the prior).
    """
    Sn, n = X.shape
    m = Z.shape[1]
    zp, S = unscented(Z, wm, wc, R, True)
    Pxz = np.zeros((n, m))
    for s in range(Sn):
        for i in range(n):
            a = wc[s] * (X[s, i] - x[i])
            for j in range(m):
                Pxz[i, j] += a * (Z[s, j] - zp[j])
    y = z - zp
    for k in range(wrap.shape[0]):
        i = wrap[k]
        y[i] = (y[i] + np.pi) % (2.0 * np.pi) - np.pi
    LS = np.zeros((m, m))
    if not chol_lower(S, LS):
        return x.copy(), P.copy(), y, S, False
    # K^T = S^-1 Pxz^T by forward and back substitution, column by column of Pxz^T
    Kt = np.empty((m, n))
    for c in range(n):
        for i in range(m):
            v = Pxz[c, i]
            for k in range(i):
                v -= LS[i, k] * Kt[k, c]
            Kt[i, c] = v / LS[i, i]
        for i in range(m - 1, -1, -1):
            v = Kt[i, c]
            for k in range(i + 1, m):
                v -= LS[k, i] * Kt[k, c]
            Kt[i, c] = v / LS[i, i]
    xn = x.copy()
    for i in range(n):
        for j in range(m):
            xn[i] += Kt[j, i] * y[j]
    # P+ = P - K S K^T = P - Pxz K^T, symmetrised
    Pn = np.empty((n, n))
    for i in range(n):
        for j in range(i + 1):
            v = 0.0
            w = 0.0
            for k in range(m):
                v += Pxz[i, k] * Kt[k, j]
                w += Pxz[j, k] * Kt[k, i]
            val = 0.5 * (P[i, j] + P[j, i]) - 0.5 * (v + w)
            Pn[i, j] = val
            Pn[j, i] = val
    return xn, Pn, y, S, True
