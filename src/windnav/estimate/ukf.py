"""Generic unscented Kalman filter: a pure functional core and a thin stateful shell.

Scaled sigma points of van der Merwe (2004), *Sigma-Point Kalman Filters for Probabilistic
Inference in Dynamic State-Space Models*, eqs. 3.170-3.173::

    lambda  = alpha^2 (n + kappa) - n
    X_0     = x,  X_i = x + [sqrt((n + lambda) P)]_i,  X_{n+i} = x - [sqrt((n + lambda) P)]_i
    Wm_0    = lambda / (n + lambda),  Wc_0 = Wm_0 + 1 - alpha^2 + beta
    Wm_i    = Wc_i = 1 / (2 (n + lambda))

with the lower Cholesky factor as matrix square root (column i of ``L`` with ``L L^T = c P``),
additive process noise Q and additive measurement noise R::

    predict:  Y = f(X, dt, u);  x- = Wm Y;  P- = sum Wc (Y - x-)(Y - x-)^T + Q
    update:   X = sigma(x-, P-);  Z = h(X);  z^ = Wm Z;  S = sum Wc (Z - z^)(Z - z^)^T + R
              Pxz = sum Wc (X - x-)(Z - z^)^T;  K = Pxz S^-1;  x+ = x- + K (z - z^)
              P+ = P- - K S K^T

This is the arithmetic of FilterPy's ``UnscentedKalmanFilter`` with ``MerweScaledSigmaPoints``
(the update draws fresh sigma points from the prior), which the tests reproduce to 1e-9.

Models are *batched over sigma points*: ``fx(X (S, n), dt, u) -> (S, n)`` and
``hx(X (S, n)) -> (S, m)``, so they are written vectorised (or numba-compiled) once.

Robustness: every covariance is symmetrised; a covariance whose Cholesky factorisation fails is
repaired by eigenvalue clipping (then jitter) and the repair is reported through the ``repaired``
flag of the results (the shell counts repairs and warns once). The shell rejects and counts
non-finite measurements and skips missing blocks.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from scipy.linalg import lapack

from windnav._validate import finite_float, positive_float
from windnav.estimate import _ukf_kernels as _k

__all__ = [
    "FilterDivergedError",
    "UKF",
    "PredictResult",
    "SigmaWeights",
    "UpdateResult",
    "merwe_weights",
    "robust_cholesky",
    "sigma_points",
    "ukf_predict",
    "ukf_update",
    "unscented_transform",
]


class FilterDivergedError(FloatingPointError):
    """The filter's arithmetic broke down (NaN or inf in the state, its covariance or a sigma
    point; a covariance that cannot be repaired): a FloatingPointError that windnav names."""


@dataclass(frozen=True, eq=False)
class SigmaWeights:
    """Weights of the scaled (Merwe) sigma points for an ``n``-dimensional state.

    Attributes
    ----------
    n : int
        State dimension.
    alpha, beta, kappa : float
        Spread, prior-knowledge (2 is optimal for Gaussians) and secondary scaling parameters.
    lam : float
        ``alpha^2 (n + kappa) - n``.
    wm, wc : ndarray of shape (2n + 1,)
        Weights of the mean and of the covariance.
    """

    n: int
    alpha: float
    beta: float
    kappa: float
    lam: float
    wm: np.ndarray
    wc: np.ndarray

    @property
    def n_sigma(self) -> int:
        """Number of sigma points, ``2n + 1``."""
        return 2 * self.n + 1

    @property
    def scale(self) -> float:
        """``n + lambda``: the factor of P whose square root spreads the points."""
        return self.n + self.lam


def merwe_weights(n: int, alpha: float = 1.0, beta: float = 2.0, kappa: float = 0.0
                  ) -> SigmaWeights:
    """Weights of van der Merwe's scaled sigma points.

    Parameters
    ----------
    n : int
        State dimension, >= 1.
    alpha : float
        Spread of the points around the mean, > 0. The default 1 with ``kappa = 0`` gives
        non-negative weights (a positive semi-definite unscented covariance), which is robust
        for the 16-state Wind UKF.
    beta : float
        2 is optimal for Gaussian priors.
    kappa : float
        Secondary scaling; ``n + lambda`` must stay > 0.

    Returns
    -------
    SigmaWeights
    """
    where = "merwe_weights"
    if isinstance(n, bool) or int(n) != n or int(n) < 1:
        raise ValueError(f"The 'n' parameter of {where} must be an integer >= 1. Got {n!r} "
                         "instead.")
    n = int(n)
    alpha = positive_float(alpha, "alpha", where)
    beta = finite_float(beta, "beta", where)
    kappa = finite_float(kappa, "kappa", where)
    lam = alpha**2 * (n + kappa) - n
    if n + lam <= 0:
        raise ValueError(f"The 'kappa' parameter of {where} must make n + lambda > 0. Got "
                         f"{kappa!r} instead (n + lambda = {n + lam!r}).")
    c = 0.5 / (n + lam)
    wm = np.full(2 * n + 1, c)
    wc = np.full(2 * n + 1, c)
    wm[0] = lam / (n + lam)
    wc[0] = lam / (n + lam) + (1.0 - alpha**2 + beta)
    wm.setflags(write=False)
    wc.setflags(write=False)
    return SigmaWeights(n, alpha, beta, kappa, lam, wm, wc)


def robust_cholesky(P: np.ndarray) -> tuple[np.ndarray, np.ndarray, bool]:
    """Lower Cholesky factor of a covariance, repairing it if it is not positive definite.

    The matrix is symmetrised first. If the factorisation (LAPACK ``dpotrf``) fails, negative
    and tiny eigenvalues are clipped to ``1e-12 * max(|eig|)`` (plus diagonal jitter if that
    still fails).

    Parameters
    ----------
    P : ndarray of shape (n, n)
        Covariance.

    Returns
    -------
    L : ndarray of shape (n, n)
        Lower-triangular factor, ``L @ L.T == P_used``.
    P_used : ndarray of shape (n, n)
        The symmetrised (and, if repaired, clipped) covariance that ``L`` factors.
    repaired : bool
        True if eigenvalue clipping or jitter was needed.

    Raises
    ------
    FilterDivergedError (a FloatingPointError)
        If ``P`` holds NaN or inf (the filter has diverged).
    """
    P = np.asarray(P, dtype=np.float64)  # a float32 P was repaired in float32
    Ps = 0.5 * (P + P.T)
    L, info = lapack.dpotrf(Ps, lower=1, clean=1)
    if info == 0:
        return L, Ps, False
    if not np.all(np.isfinite(Ps)):
        raise FilterDivergedError("The covariance holds NaN or inf: the filter has diverged.")
    w, V = np.linalg.eigh(Ps)
    floor = max(1e-12 * float(np.max(np.abs(w))), np.finfo(np.float64).tiny)
    Pr = (V * np.maximum(w, floor)) @ V.T
    Pr = 0.5 * (Pr + Pr.T)
    jitter = floor
    for _ in range(20):
        L, info = lapack.dpotrf(Pr, lower=1, clean=1)
        if info == 0:
            return L, Pr, True
        Pr = Pr + jitter * np.eye(Pr.shape[0])
        jitter *= 10.0
    raise FilterDivergedError("The covariance could not be repaired to positive definite.")


def sigma_points(x: np.ndarray, L: np.ndarray, weights: SigmaWeights) -> np.ndarray:
    """Scaled sigma points from a mean and the Cholesky factor of its covariance.

    Parameters
    ----------
    x : ndarray of shape (n,)
        Mean.
    L : ndarray of shape (n, n)
        Lower Cholesky factor of the covariance ``P`` (not yet scaled).
    weights : SigmaWeights

    Returns
    -------
    ndarray of shape (2n + 1, n)
        ``x``, then ``x + sqrt(n + lambda) L[:, i]``, then ``x - sqrt(n + lambda) L[:, i]``.

    Raises
    ------
    ValueError
        On ``x`` not 1-D, or ``L`` or ``weights`` of another size than ``x``.
    """
    where = "sigma_points"
    n = _check_state(x, weights, where)
    _check_square(L, n, "L", where, "x")
    return _k.sigma_from_chol(np.asarray(x, dtype=np.float64),
                              np.asarray(L, dtype=np.float64), weights.scale)


_NO_NOISE = np.zeros((1, 1))
_NO_WRAP = np.empty(0, dtype=np.intp)


# The public functions' checks (code-hash audit, 2026-12-07: with a Q, P, weights, L, Y or R
# of another size the Numba kernels read past the arrays, or returned a plausible wrong mean).
# The UKF shell checks its sizes once, at construction, and steps through the unchecked
# _ukf_predict and _ukf_update.


def _check_weights(weights, where: str) -> int:
    """``weights.n``, once ``weights`` is checked to be SigmaWeights of 2n + 1 points."""
    if not isinstance(weights, SigmaWeights):
        raise ValueError(f"The 'weights' parameter of {where} must be a SigmaWeights "
                         f"(merwe_weights). Got {type(weights).__name__} instead.")
    n = weights.n
    if np.shape(weights.wm) != (2 * n + 1,) or np.shape(weights.wc) != (2 * n + 1,):
        raise ValueError(f"The 'weights' parameter of {where} must hold 2n + 1 = {2 * n + 1} "
                         f"weights of the mean and of the covariance for n = {n}. Got shapes "
                         f"{np.shape(weights.wm)} and {np.shape(weights.wc)} instead.")
    return n


def _check_state(x, weights, where: str) -> int:
    """``n``, the length of the 1-D ``x``, checked against ``weights``."""
    n_w = _check_weights(weights, where)
    shape = np.shape(x)
    if len(shape) != 1 or shape[0] < 1:
        raise ValueError(f"The 'x' parameter of {where} must be a 1-D array of length n >= 1. "
                         f"Got shape {shape} instead.")
    n = shape[0]
    if n_w != n:
        raise ValueError(f"The 'weights' parameter of {where} must be for n = {n}, the length "
                         f"of x (merwe_weights({n})). Got weights for n = {n_w} instead.")
    return n


def _check_square(A, m: int, name: str, where: str, of: str) -> None:
    """A ValueError naming ``name`` unless ``A`` is (m, m), ``m`` the length of ``of``."""
    if np.shape(A) != (m, m):
        dims = "(n, n)" if of == "x" else "(m, m)"
        raise ValueError(f"The {name!r} parameter of {where} must be {dims} = ({m}, {m}) for "
                         f"{of} of length {m}. Got shape {np.shape(A)} instead.")


def unscented_transform(Y: np.ndarray, weights: SigmaWeights, noise: np.ndarray | None = None
                        ) -> tuple[np.ndarray, np.ndarray]:
    """Weighted mean and covariance of transformed sigma points.

    Parameters
    ----------
    Y : ndarray of shape (2n + 1, m)
        Transformed sigma points.
    weights : SigmaWeights
    noise : ndarray of shape (m, m), optional
        Additive noise covariance.

    Returns
    -------
    mean : ndarray of shape (m,)
    cov : ndarray of shape (m, m)
        Symmetric.

    Raises
    ------
    ValueError
        On ``Y`` not 2-D with ``2n + 1`` rows (n of ``weights``), or ``noise`` not (m, m).
    """
    where = "unscented_transform"
    n = _check_weights(weights, where)
    if np.ndim(Y) != 2 or np.shape(Y)[0] != 2 * n + 1:
        raise ValueError(f"The 'Y' parameter of {where} must be a 2-D array of 2n + 1 = "
                         f"{2 * n + 1} rows, one per sigma point of weights for n = {n}. Got "
                         f"shape {np.shape(Y)} instead.")
    if noise is not None:
        m = np.shape(Y)[1]
        if np.shape(noise) != (m, m):
            raise ValueError(f"The 'noise' parameter of {where} must be (m, m) = ({m}, {m}) for "
                             f"Y of {m} columns. Got shape {np.shape(noise)} instead.")
    Y = np.ascontiguousarray(Y, dtype=np.float64)
    if noise is None:
        return _k.unscented(Y, weights.wm, weights.wc, _NO_NOISE, False)
    return _k.unscented(Y, weights.wm, weights.wc, np.asarray(noise, dtype=np.float64), True)


class PredictResult(NamedTuple):
    """Output of :func:`ukf_predict`: prior mean ``x`` (n,), covariance ``P`` (n, n), and
    ``repaired`` (True if the input covariance had to be repaired)."""

    x: np.ndarray
    P: np.ndarray
    repaired: bool


class _JointModel:
    """The measurement model of several blocks fused at once: their outputs side by side (a
    class, not a closure, so that a filter pickles whatever it has fused; audit, thirty-seventh
    session)."""

    def __init__(self, models: tuple):
        self.models = models

    def __call__(self, X: np.ndarray) -> np.ndarray:
        return np.concatenate([h(X) for h in self.models], axis=1)


class UpdateResult(NamedTuple):
    """Output of :func:`ukf_update`: posterior ``x`` (n,), ``P`` (n, n), the ``innovation``
    ``z - z_pred`` (m,), its covariance ``S`` (m, m), and ``repaired``."""

    x: np.ndarray
    P: np.ndarray
    innovation: np.ndarray
    S: np.ndarray
    repaired: bool


def _sigma(x: np.ndarray, P: np.ndarray, weights: SigmaWeights):
    """Sigma points of (x, P), repairing P if needed: (X, P_used, repaired)."""
    X, ok = _k.sigma_from_cov(x, P, weights.scale)
    if ok:
        return X, P, False
    L, P, repaired = robust_cholesky(P)
    return _k.sigma_from_chol(x, L, weights.scale), P, repaired


def _model_output(Y, S: int, m: int, what: str) -> np.ndarray:
    Y = np.asarray(Y, dtype=np.float64)
    if Y.shape != (S, m):
        raise ValueError(f"The {what!r} model must return an array of shape ({S}, {m}) for {S} "
                         f"sigma points. Got shape {Y.shape} instead.")
    return Y if Y.flags.c_contiguous else np.ascontiguousarray(Y)


def ukf_predict(x: np.ndarray, P: np.ndarray, fx: Callable, dt: float, Q: np.ndarray,
                weights: SigmaWeights, u=None) -> PredictResult:
    """UKF prediction: push sigma points of ``(x, P)`` through ``fx`` over ``dt``.

    Parameters
    ----------
    x : ndarray of shape (n,)
    P : ndarray of shape (n, n)
    fx : callable ``fx(X (S, n), dt, u) -> (S, n)``
        Process model, batched over the S sigma points.
    dt : float
        Time step, s.
    Q : ndarray of shape (n, n)
        Additive process-noise covariance over ``dt``.
    weights : SigmaWeights
    u : optional
        Input passed to ``fx`` unchanged.

    Returns
    -------
    PredictResult

    Raises
    ------
    ValueError
        On ``x`` not 1-D, or ``P``, ``Q`` or ``weights`` of another size than ``x``.
    FilterDivergedError (a FloatingPointError)
        If the process model returns NaN or inf.
    """
    where = "ukf_predict"
    n = _check_state(x, weights, where)
    _check_square(P, n, "P", where, "x")
    _check_square(Q, n, "Q", where, "x")
    return _ukf_predict(x, P, fx, dt, Q, weights, u)


def _ukf_predict(x: np.ndarray, P: np.ndarray, fx: Callable, dt: float, Q: np.ndarray,
                 weights: SigmaWeights, u=None) -> PredictResult:
    """:func:`ukf_predict` without its checks (the ``UKF`` shell's step)."""
    X, _, repaired = _sigma(x, P, weights)
    Y = _model_output(fx(X, dt, u), X.shape[0], X.shape[1], "fx")
    xp, Pp = _k.unscented(Y, weights.wm, weights.wc, Q, True)
    if not math.isfinite(float(xp.sum())):
        raise FilterDivergedError("The process model returned NaN or inf for a sigma point.")
    return PredictResult(xp, Pp, repaired)


def ukf_update(x: np.ndarray, P: np.ndarray, z: np.ndarray, hx: Callable, R: np.ndarray,
               weights: SigmaWeights, wrap: np.ndarray | None = None) -> UpdateResult:
    """UKF measurement update with fresh sigma points of the prior ``(x, P)``.

    Parameters
    ----------
    x : ndarray of shape (n,)
    P : ndarray of shape (n, n)
    z : ndarray of shape (m,)
        Measurement.
    hx : callable ``hx(X (S, n)) -> (S, m)``
        Measurement model, batched over sigma points.
    R : ndarray of shape (m, m)
        Additive measurement-noise covariance (positive definite).
    weights : SigmaWeights
    wrap : ndarray of int, optional
        Indices of angle components (rad) whose innovation is wrapped to [-pi, pi).

    Returns
    -------
    UpdateResult

    Raises
    ------
    ValueError
        On ``x`` or ``z`` not 1-D, ``P`` or ``weights`` of another size than ``x``, ``R`` not
        (m, m) for ``z`` of length m, or ``wrap`` not 1-D indices of ``z``.
    FilterDivergedError (a FloatingPointError)
        If the innovation covariance is not positive definite.
    """
    where = "ukf_update"
    n = _check_state(x, weights, where)
    _check_square(P, n, "P", where, "x")
    if np.ndim(z) != 1:
        raise ValueError(f"The 'z' parameter of {where} must be a 1-D array. Got shape "
                         f"{np.shape(z)} instead.")
    m = np.shape(z)[0]
    _check_square(R, m, "R", where, "z")
    if wrap is not None:
        try:
            w = np.asarray(wrap, dtype=np.intp)
        except (TypeError, ValueError):
            w = np.full((1, 1), -1)
        if w.ndim != 1 or np.any((w < -m) | (w >= m)):
            raise ValueError(f"The 'wrap' parameter of {where} must be a 1-D array of indices "
                             f"of z's {m} components. Got {wrap!r} instead.")
    return _ukf_update(x, P, z, hx, R, weights, wrap)


def _ukf_update(x: np.ndarray, P: np.ndarray, z: np.ndarray, hx: Callable, R: np.ndarray,
                weights: SigmaWeights, wrap: np.ndarray | None = None) -> UpdateResult:
    """:func:`ukf_update` without its checks (the ``UKF`` shell's step)."""
    # float64, as the kernel is compiled for (float32 failed in Numba's typing); no copy else
    x, P, R = (np.asarray(a, dtype=np.float64) for a in (x, P, R))
    X, P, repaired = _sigma(x, P, weights)
    Z = _model_output(hx(X), X.shape[0], z.shape[0], "hx")
    wrap = _NO_WRAP if wrap is None else np.asarray(wrap, dtype=np.intp)
    xn, Pn, y, S, ok = _k.update(x, P, X, Z, np.asarray(z, dtype=np.float64), R,
                                 weights.wm, weights.wc, wrap)
    if not ok:
        raise FilterDivergedError("The innovation covariance S is not positive definite: the "
                                  "filter has diverged, or R is not positive definite.")
    return UpdateResult(xn, Pn, y, S, repaired)


class _Block(NamedTuple):
    hx: Callable
    R: np.ndarray
    wrap: np.ndarray
    limit: np.ndarray  # (m,): a component at or beyond it rejects the sample (inf: none)


class UKF:
    """Stateful shell over :func:`ukf_predict` / :func:`ukf_update` with named measurement blocks.

    Parameters
    ----------
    fx : callable ``fx(X (S, n), dt, u) -> (S, n)``
        Process model batched over sigma points.
    x0 : array_like of shape (n,)
        Initial mean.
    P0 : array_like of shape (n, n)
        Initial covariance.
    Q : array_like of shape (n, n)
        Additive process-noise covariance per step of ``dt``.
    dt : float
        Default prediction step, s.
    blocks : mapping of str to (hx, R), (hx, R, wrap) or (hx, R, wrap, limit), optional
        Measurement blocks: ``hx(X (S, n)) -> (S, m)``, noise covariance ``R`` (m, m),
        optionally the indices of angle components of that block (wrapped innovation), and
        optionally the sensor's range: a sample with a component ``|z_i| >= limit_i`` is
        rejected like a non-finite one (see :meth:`add_block`).
    alpha, beta, kappa : float
        Sigma-point parameters (see :func:`merwe_weights`).

    Attributes
    ----------
    x : ndarray of shape (n,)
    P : ndarray of shape (n, n)
    repairs : int
        How many times a covariance had to be repaired to positive definite.
    rejected : dict of str to int
        Measurements rejected (non-finite, or beyond the block's range), per block.

    Examples
    --------
    >>> ukf = UKF(fx, x0, P0, Q, dt=0.01, blocks={"gyro": (h_gyro, R_gyro)})
    >>> ukf.predict(u=u_cmd)
    >>> ukf.update({"gyro": z_gyro})     # blocks that are absent or None are skipped
    """

    def __init__(self, fx: Callable, x0, P0, Q, *, dt: float,
                 blocks: Mapping[str, tuple] | None = None,
                 alpha: float = 1.0, beta: float = 2.0, kappa: float = 0.0):
        where = "UKF"
        x0 = np.array(x0, dtype=np.float64)
        if x0.ndim != 1 or x0.size < 1 or not np.all(np.isfinite(x0)):
            raise ValueError(f"The 'x0' parameter of {where} must be a finite 1-D array. "
                             f"Got shape {x0.shape} instead.")
        n = x0.size
        self.x = x0
        self.P = self._square(P0, n, "P0")
        self.Q = self._square(Q, n, "Q")
        self.dt = positive_float(dt, "dt", where)
        self.fx = fx
        self.weights = merwe_weights(n, alpha, beta, kappa)
        self.blocks: dict[str, _Block] = {}
        self.rejected: dict[str, int] = {}
        self.repairs = 0
        self._warned = False
        self._stack_cache: dict[tuple, tuple] = {}
        for name, spec in (blocks or {}).items():
            self.add_block(name, *spec)

    @staticmethod
    def _square(A, n: int, name: str, where: str = "UKF", psd: bool = True) -> np.ndarray:
        A = np.array(A, dtype=np.float64)
        if A.shape != (n, n) or not np.all(np.isfinite(A)):
            raise ValueError(f"The {name!r} parameter of {where} must be a finite ({n}, {n}) "
                             f"array. Got shape {A.shape} instead.")
        tol = 1e-9 * max(float(np.abs(A).max()), 1e-300)
        if psd and (np.abs(A - A.T).max() > tol or np.linalg.eigvalsh(A).min() < -tol):
            # a covariance: the filter would only "repair" it, with a warning, at its first step
            raise ValueError(f"The {name!r} parameter of {where} must be a symmetric positive "
                             "semi-definite covariance. Got smallest eigenvalue "
                             f"{float(np.linalg.eigvals(A).real.min())!r} and asymmetry "
                             f"{float(np.abs(A - A.T).max())!r} instead.")
        return A

    @property
    def n(self) -> int:
        """State dimension."""
        return self.x.size

    def add_block(self, name: str, hx: Callable, R, wrap=(), limit=np.inf) -> None:
        """Register (or replace) measurement block ``name`` with model ``hx`` and noise ``R``.

        ``limit`` (scalar or (m,), > 0, default inf: none) is the sensor's range: a sample with
        a component ``|z_i| >= limit_i`` is rejected and counted, as a non-finite one is. One
        absurd but finite sample (an accelerometer reading of 1e6 m/s^2) can otherwise throw
        the state so far that every later prediction fails.
        """
        R = np.atleast_2d(np.array(R, dtype=np.float64))
        m = R.shape[0]
        self._square(R, m, f"R[{name!r}]", "UKF.add_block", psd=False)  # definite: below
        if not _k.chol_lower(R, np.zeros((m, m))):
            raise ValueError(f"The 'R[{name!r}]' parameter of UKF.add_block must be positive "
                             "definite.")
        wrap = np.array(wrap, dtype=np.intp).reshape(-1)  # a copy: made read-only below
        if np.any((wrap < 0) | (wrap >= m)):
            raise ValueError(f"The 'wrap' parameter of UKF.add_block must index the {m} "
                             f"components of block {name!r}. Got {wrap.tolist()!r} instead.")
        try:
            lim = np.broadcast_to(np.asarray(limit, dtype=np.float64), (m,)).copy()
        except (TypeError, ValueError):
            lim = np.full(m, np.nan)
        if np.isnan(lim).any() or (lim <= 0).any():
            raise ValueError(f"The 'limit' parameter of UKF.add_block must be > 0 (inf: no "
                             f"limit), a scalar or one per component ({m}) of block {name!r}. "
                             f"Got {limit!r} instead.")
        for arr in (R, wrap, lim):  # the stacked model is cached from them: an edit in place
            arr.setflags(write=False)  # went unseen (cache audit); add_block again replaces
        self.blocks[name] = _Block(hx, R, wrap, lim)
        self.rejected.setdefault(name, 0)
        self._stack_cache.clear()

    def _note_repair(self, repaired: bool) -> None:
        if repaired:
            self.repairs += 1
            if not self._warned:
                self._warned = True
                warnings.warn("UKF covariance lost positive definiteness and was repaired by "
                              "eigenvalue clipping (counted in UKF.repairs).", RuntimeWarning,
                              stacklevel=3)

    def predict(self, dt: float | None = None, u=None) -> None:
        """Propagate the state over ``dt`` (default ``self.dt``) with input ``u``."""
        dt = self.dt if dt is None else positive_float(dt, "dt", "UKF.predict")
        res = _ukf_predict(self.x, self.P, self.fx, dt, self.Q, self.weights, u)
        self.x, self.P = res.x, res.P
        self._note_repair(res.repaired)

    def _stacked(self, names: tuple[str, ...]):
        """Joint model, noise, wrapped indices and block offsets of the blocks ``names``."""
        hit = self._stack_cache.get(names)
        if hit is not None:
            return hit
        blocks = [self.blocks[k] for k in names]
        sizes = [b.R.shape[0] for b in blocks]
        offsets = np.concatenate([[0], np.cumsum(sizes)])
        R = np.zeros((offsets[-1], offsets[-1]))
        wrap = []
        for b, o, m in zip(blocks, offsets[:-1], sizes, strict=True):
            R[o:o + m, o:o + m] = b.R
            wrap.extend((b.wrap + o).tolist())
        hxs = [b.hx for b in blocks]
        hx = hxs[0] if len(hxs) == 1 else _JointModel(tuple(hxs))
        hit = (hx, R, np.asarray(wrap, dtype=np.intp), offsets,
               np.concatenate([b.limit for b in blocks]))
        self._stack_cache[names] = hit
        return hit

    def update(self, measurements: Mapping[str, np.ndarray | None],
               noise: Mapping[str, np.ndarray] | None = None) -> UpdateResult | None:
        """Fuse any subset of the registered blocks in one joint update.

        Parameters
        ----------
        measurements : mapping of str to array_like of shape (m,) or None
            Block name to measured value. ``None`` means "no sample this step". A value with NaN
            or inf, or a component at or beyond the block's ``limit``, is rejected and counted
            in ``rejected[name]``; the other blocks are fused.
        noise : mapping of str to ndarray of shape (m, m), optional
            Measurement-noise covariances for this update only, replacing the registered ``R``
            of those blocks (the registered blocks are not changed).

        Returns
        -------
        UpdateResult or None
            None when no block was fused.

        Raises
        ------
        ValueError
            On an unknown block name or a measurement of the wrong shape.
        """
        names, zs = [], []
        for name, z in measurements.items():
            block = self.blocks.get(name)
            if block is None:
                raise ValueError(f"The 'measurements' parameter of UKF.update holds unknown "
                                 f"block {name!r}; registered: {sorted(self.blocks)}.")
            if z is None:
                continue
            z = np.atleast_1d(np.asarray(z, dtype=np.float64))
            m = block.R.shape[0]
            if z.shape != (m,):
                raise ValueError(f"The 'measurements[{name!r}]' parameter of UKF.update must "
                                 f"have shape ({m},). Got shape {np.shape(z)} instead.")
            names.append(name)
            zs.append(z)
        z = zs[0] if len(zs) == 1 else np.concatenate(zs) if zs else None
        stack = self._stacked(tuple(names)) if names else None
        # one check for all, then by block: NaN, inf and samples beyond the range fail "<"
        if z is not None and not (np.abs(z) < stack[4]).all():
            kept = [(name, zb) for name, zb in zip(names, zs, strict=True)
                    if (np.abs(zb) < self.blocks[name].limit).all()]
            for name in set(names) - {name for name, _ in kept}:
                self.rejected[name] += 1
            names, zs = [name for name, _ in kept], [zb for _, zb in kept]
            z = zs[0] if len(zs) == 1 else np.concatenate(zs) if zs else None
            stack = self._stacked(tuple(names)) if names else None
        if not names:
            return None
        unknown = set(noise or ()) - set(self.blocks)
        if unknown:
            raise ValueError(f"The 'noise' parameter of UKF.update holds unknown blocks "
                             f"{sorted(unknown)}; registered: {sorted(self.blocks)}.")
        hx, R, wrap, offsets, _ = stack
        if noise:
            R = R.copy()
            for k, name in enumerate(names):
                if name in noise:
                    o, m = int(offsets[k]), int(offsets[k + 1] - offsets[k])
                    block = np.asarray(noise[name], dtype=np.float64)
                    if block.shape != (m, m):
                        raise ValueError(f"The 'noise[{name!r}]' parameter of UKF.update must "
                                         f"have shape ({m}, {m}). Got shape {block.shape} "
                                         "instead.")
                    R[o:o + m, o:o + m] = block  # not positive definite: S fails below
        res = _ukf_update(self.x, self.P, z, hx, R, self.weights, wrap)
        self.x, self.P = res.x.copy(), res.P.copy()  # the result is the caller's to keep
        self._note_repair(res.repaired)
        return res
