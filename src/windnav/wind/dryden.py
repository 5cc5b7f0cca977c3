"""Dryden turbulence: coloured Gaussian gusts with the MIL-F-8785C / MIL-HDBK-1797 spectra.

Model
-----
The wind is ``w(t) = mean + g(t)`` where the gust ``g = (g_x, g_y, g_z)`` has three independent
stationary Gaussian components whose shaping filters are the Dryden transfer functions
(MIL-F-8785C section 3.7.3; MIL-HDBK-1797 section 4.9.2 with ``L_v`` written as in 8785C)::

    H_u(s) = sigma_u sqrt(2 L_u / (pi V)) / (1 + (L_u/V) s)
    H_v(s) = sigma_v sqrt(L_v / (pi V)) (1 + sqrt(3) (L_v/V) s) / (1 + (L_v/V) s)^2
    H_w(s) = sigma_w sqrt(L_w / (pi V)) (1 + sqrt(3) (L_w/V) s) / (1 + (L_w/V) s)^2

driven by white noise of unit one-sided spectral density, so that the one-sided spectra
``Phi(omega) = |H(j omega)|^2`` integrate over ``omega in [0, inf)`` to ``sigma^2``. ``H_u`` shapes
the world-x component, ``H_v`` world-y and ``H_w`` world-z (axes fixed in the world, as in
RotorPy's Dryden wrapper; sigma is given per world axis). The autocorrelations are
``rho_u(tau) = exp(-tau/T_u)`` and ``rho_v(tau) = (1 - tau/(2 T_v)) exp(-tau/T_v)`` with
``T = L/V``.

Length scales (MIL-F-8785C low altitude, ``h`` in feet, valid for 10 ft <= h <= 1000 ft)::

    L_w = h,    L_u = L_v = h / (0.177 + 0.000823 h)^1.2      (feet)

``altitude`` is given in metres, converted to feet, clamped to [10, 1000] ft, and the scales are
returned in metres. Explicit ``length_scales`` (m) override them.

Reference airspeed ``V``
------------------------
Dryden turbulence is a frozen spatial field convected past the vehicle (Taylor's hypothesis), so
time scales are ``L / V`` with ``V`` the speed of the air relative to the vehicle. A multirotor
hovers (``V -> 0``, where the model is singular), so ``V`` is a fixed, stated parameter rather than
the instantaneous airspeed. The default 10 m/s is a typical relative speed of a small multirotor in
cruise (5-8 m/s) through a few m/s of mean wind; at 10 m altitude it gives ``L_u/V = 6.7 s`` and
``L_w/V = 1.0 s``.

Discretisation
--------------
Each filter is realised as a linear SDE ``dx = A x dt + B dW`` (``W`` a standard Wiener process,
whose one-sided spectral density is ``1/pi``, hence gains ``sqrt(pi) H``), ``g = C x``. A step of
any length ``dt`` is exact: ``x_{k+1} = Phi x_k + q_k``, ``Phi = expm(A dt)``, ``q_k ~ N(0, Q)``
with ``Q = int_0^dt expm(A s) B B^T expm(A^T s) ds`` from Van Loan's block matrix exponential
(C. F. Van Loan, "Computing integrals involving the matrix exponential", IEEE TAC 23(3), 1978).
For steps much longer than the slowest-decaying mode, where Van Loan's block exponential loses
precision, the equivalent identity ``Q = P - Phi P Phi^T`` is used. The state starts from the
stationary covariance ``P`` (``A P + P A^T + B B^T = 0``), so every sample, at any step size, has
standard deviation exactly ``sigma`` and the gust correlations of the continuous process.
"""

from __future__ import annotations

import math

import numba
import numpy as np
import scipy.linalg

from windnav._validate import batch_array, finite_float, positive_float, positive_int
from windnav.wind.base import check_query

FOOT = 0.3048
"""One international foot, m."""

_N_STATES = 5  # u: 1 state, v: 2 states, w: 2 states
_DT_DECIMALS = 12  # steps are keyed (and taken) to 1e-12 s so t_k = k*dt reuses one matrix
_CACHE_SIZE = 64
_VAN_LOAN_MAX_DECAYS = 4.0  # beyond dt * max|eig(A)| = 4 use Q = P - Phi P Phi^T
_CHUNK = 1 << 16


def dryden_length_scales(altitude: float) -> np.ndarray:
    """MIL-F-8785C low-altitude turbulence length scales ``(L_u, L_v, L_w)``, m.

    Parameters
    ----------
    altitude : float
        Height above ground, m (> 0). Clamped to the model's range [10, 1000] ft
        (3.048 m to 304.8 m).

    Returns
    -------
    ndarray of shape (3,)
        ``L_u = L_v = h / (0.177 + 0.000823 h)^1.2`` and ``L_w = h`` with ``h`` in feet,
        converted to metres.
    """
    h_m = positive_float(altitude, "altitude", "dryden_length_scales")
    h_ft = min(max(h_m / FOOT, 10.0), 1000.0)
    l_uv = h_ft / (0.177 + 0.000823 * h_ft) ** 1.2
    return np.array([l_uv, l_uv, h_ft]) * FOOT


def dryden_state_space(sigma, length_scales, airspeed: float):
    """Linear SDE realisation ``dx = A x dt + B dW``, ``g = C x`` of the three Dryden filters.

    Parameters
    ----------
    sigma : array_like of shape (3,)
        Gust standard deviations along world x, y, z, m/s (>= 0).
    length_scales : array_like of shape (3,)
        ``(L_u, L_v, L_w)``, m (> 0).
    airspeed : float
        Reference airspeed ``V``, m/s (> 0).

    Returns
    -------
    A : ndarray of shape (5, 5)
        Block diagonal: ``[-1/T_u]`` and, for v and w, ``[[0, 1], [-1/T^2, -2/T]]``, 1/s.
    B : ndarray of shape (5, 3)
        Noise input: one standard Wiener process per axis.
    C : ndarray of shape (3, 5)
        Output map, so that ``C (sI - A)^-1 B = sqrt(pi) diag(H_u, H_v, H_w)``.
    """
    where = "dryden_state_space"
    sig = batch_array(sigma, "sigma", where, (3,), batch=1)[0]
    if np.any(sig < 0):
        raise ValueError(f"The 'sigma' parameter of {where} must be >= 0. Got {sig!r} instead.")
    scales = batch_array(length_scales, "length_scales", where, (3,), batch=1)[0]
    if np.any(scales <= 0):
        raise ValueError(
            f"The 'length_scales' parameter of {where} must be > 0. Got {scales!r} instead."
        )
    v_ref = positive_float(airspeed, "airspeed", where)
    t_u, t_v, t_w = scales / v_ref
    a = np.zeros((_N_STATES, _N_STATES))
    b = np.zeros((_N_STATES, 3))
    c = np.zeros((3, _N_STATES))
    a[0, 0] = -1.0 / t_u
    b[0, 0] = 1.0
    c[0, 0] = sig[0] * math.sqrt(2.0 / t_u)
    # (1 + sqrt3 T s) / (1 + T s)^2 = T^-2 (sqrt3 T s + 1) / (s^2 + 2 s/T + 1/T^2),
    # in controllable canonical form
    for axis, tau, i in ((1, t_v, 1), (2, t_w, 3)):
        a[i, i + 1] = 1.0
        a[i + 1, i] = -1.0 / tau**2
        a[i + 1, i + 1] = -2.0 / tau
        b[i + 1, axis] = 1.0
        c[axis, i] = sig[axis] * tau**-1.5
        c[axis, i + 1] = sig[axis] * math.sqrt(3.0) * tau**-0.5
    return a, b, c


def stationary_covariance(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Solution ``P`` of ``A P + P A^T + B B^T = 0`` (stable ``A``), symmetrised."""
    p = scipy.linalg.solve_continuous_lyapunov(a, -b @ b.T)
    return 0.5 * (p + p.T)


def van_loan(a: np.ndarray, b: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Exact discretisation of ``dx = A x dt + B dW`` over a step ``dt`` (s).

    Returns ``Phi = expm(A dt)`` and ``Q = int_0^dt expm(A s) B B^T expm(A^T s) ds`` from
    ``expm([[-A, B B^T], [0, A^T]] dt) = [[., G12], [0, G22]]``: ``Phi = G22^T``,
    ``Q = Phi G12`` (Van Loan 1978).
    """
    n = a.shape[0]
    m = np.zeros((2 * n, 2 * n))
    m[:n, :n] = -a
    m[:n, n:] = b @ b.T
    m[n:, n:] = a.T
    g = scipy.linalg.expm(m * dt)
    phi = g[n:, n:].T
    q = phi @ g[:n, n:]
    return phi, 0.5 * (q + q.T)


def _psd_sqrt(q: np.ndarray) -> np.ndarray:
    """``S`` with ``S S^T = Q`` for a symmetric PSD ``Q`` (tiny negative eigenvalues -> 0)."""
    lam, vec = np.linalg.eigh(q)
    return vec * np.sqrt(np.clip(lam, 0.0, None))


@numba.njit(cache=True)
def _propagate(x, phis, sqrts, index, noise, c, mean, out):  # pragma: no cover - numba
    """Advance states ``x`` (R, n) through steps ``k`` with ``(Phi, S)[index[k]]``.

    ``noise`` (K, R, n) standard normals; writes ``mean + C x_k`` into ``out`` (K, R, 3).
    """
    n_steps, n_real, n = noise.shape
    new = np.empty(n)
    for k in range(n_steps):
        phi = phis[index[k]]
        s = sqrts[index[k]]
        for r in range(n_real):
            for i in range(n):
                acc = 0.0
                for j in range(n):
                    acc += phi[i, j] * x[r, j] + s[i, j] * noise[k, r, j]
                new[i] = acc
            for i in range(n):
                x[r, i] = new[i]
            for i in range(3):
                acc = mean[i]
                for j in range(n):
                    acc += c[i, j] * x[r, j]
                out[k, r, i] = acc


class DrydenWind:
    """Mean wind plus Dryden turbulence, exactly discretised for any query step.

    See the module docstring for the transfer functions, length scales and discretisation.

    Parameters
    ----------
    mean : array_like of shape (3,)
        Mean wind, m/s, world frame.
    sigma : array_like of shape (3,)
        Standard deviation of the gust along world x, y, z, m/s (>= 0).
    seed : int
        Seed of the ``numpy.random.Generator`` (PCG64) that draws the initial state and the
        process noise. Same seed and same query times give the same winds.
    airspeed : float
        Reference airspeed ``V`` for the time scales ``L/V``, m/s. Default 10 m/s (see module
        docstring).
    altitude : float
        Height above ground for the MIL-F-8785C length scales, m. Default 10 m.
    length_scales : array_like of shape (3,), optional
        ``(L_u, L_v, L_w)`` in m, overriding those from ``altitude``.
    batch_size : int, optional
        None (default): one realisation shared by every position (spatially uniform gusts).
        An int R: R independent realisations; queries must then pass exactly R positions and
        row r gets realisation r (for Monte Carlo over vehicles).
    t0 : float
        Time at which the process starts from its stationary distribution, s.

    Notes
    -----
    ``velocity(t, xyz)`` advances the process from the last queried time to ``t`` in one exact
    step (any step size). Querying the last time again returns the same value; an earlier time
    raises ValueError (the past is not stored); :meth:`reset` restarts from ``t0`` with the seed.
    The gust is spatially uniform: positions only set the batch size.

    Examples
    --------
    >>> g = DrydenWind(mean=(3, 0, 0), sigma=(1.5, 1.5, 0.7), seed=0)
    >>> g.velocity(0.01, [[0.0, 0.0, 2.0]]).shape
    (1, 3)
    """

    def __init__(
        self,
        mean=(3.0, 0.0, 0.0),
        sigma=(1.5, 1.5, 0.7),
        seed: int = 0,
        airspeed: float = 10.0,
        altitude: float = 10.0,
        length_scales=None,
        batch_size: int | None = None,
        t0: float = 0.0,
    ):
        where = "DrydenWind"
        self._mean = batch_array(mean, "mean", where, (3,), batch=1)[0]
        if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
            raise ValueError(
                f"The 'seed' parameter of {where} must be a non-negative int. Got {seed!r} instead."
            )
        self._seed = int(seed)
        self.airspeed = positive_float(airspeed, "airspeed", where)
        if length_scales is None:
            self.altitude = positive_float(altitude, "altitude", where)
            scales = dryden_length_scales(self.altitude)
        else:
            self.altitude = None
            scales = length_scales
        self._a, self._b, self._c = dryden_state_space(sigma, scales, self.airspeed)
        self._sigma = batch_array(sigma, "sigma", where, (3,), batch=1)[0]
        self._scales = np.asarray(scales, dtype=np.float64).copy()
        for arr in (self._mean, self._sigma, self._scales):
            arr.setflags(write=False)
        self._batch = None if batch_size is None else positive_int(batch_size, "batch_size", where)
        self._t0 = finite_float(t0, "t0", where)
        self._p = stationary_covariance(self._a, self._b)
        self._p_sqrt = _psd_sqrt(self._p)
        self._fastest = float(np.max(np.abs(np.linalg.eigvals(self._a))))
        self._cache: dict[float, tuple[np.ndarray, np.ndarray]] = {}
        self.reset()

    # Parameters -----------------------------------------------------------------------------
    @property
    def mean(self) -> np.ndarray:
        """Mean wind (3,), m/s, world frame."""
        return self._mean

    @property
    def sigma(self) -> np.ndarray:
        """Gust standard deviations along world x, y, z (3,), m/s."""
        return self._sigma

    @property
    def length_scales(self) -> np.ndarray:
        """``(L_u, L_v, L_w)`` (3,), m."""
        return self._scales

    @property
    def time_scales(self) -> np.ndarray:
        """``L / V`` for u, v, w (3,), s."""
        return self._scales / self.airspeed

    @property
    def state_space(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(A, B, C)`` of the gust SDE (see :func:`dryden_state_space`)."""
        return self._a.copy(), self._b.copy(), self._c.copy()

    @property
    def stationary_covariance(self) -> np.ndarray:
        """Stationary covariance ``P`` (5, 5) of the filter state."""
        return self._p.copy()

    def transition(self, dt: float) -> tuple[np.ndarray, np.ndarray]:
        """``(Phi, Q)`` of one exact step of ``dt`` s (Van Loan, or ``P - Phi P Phi^T``)."""
        dt = positive_float(dt, "dt", "DrydenWind.transition", allow_zero=True)
        phi, q, _ = self._step_matrices(round(dt, _DT_DECIMALS))
        return phi.copy(), q.copy()

    def lag_correlation(self, lag: float) -> np.ndarray:
        """Model autocorrelation of each gust component at ``lag`` s, (3,) (NaN where sigma=0)."""
        lag = positive_float(lag, "lag", "DrydenWind.lag_correlation", allow_zero=True)
        phi = scipy.linalg.expm(self._a * lag)
        cov0 = np.diag(self._c @ self._p @ self._c.T)
        with np.errstate(invalid="ignore", divide="ignore"):
            return np.diag(self._c @ phi @ self._p @ self._c.T) / cov0

    # State ------------------------------------------------------------------------------------
    @property
    def time(self) -> float:
        """Time of the last query (or ``t0``), s."""
        return self._t

    def reset(self) -> None:
        """Restart at ``t0`` from the stationary distribution drawn with the seed."""
        self._rng = np.random.default_rng(self._seed)
        n_real = 1 if self._batch is None else self._batch
        self._x = self._rng.standard_normal((n_real, _N_STATES)) @ self._p_sqrt.T
        self._t = self._t0
        self._value = self._mean + self._x @ self._c.T

    def _step_matrices(self, dt: float):
        hit = self._cache.get(dt)
        if hit is not None:
            return hit
        if dt * self._fastest <= _VAN_LOAN_MAX_DECAYS:
            phi, q = van_loan(self._a, self._b, dt)
        else:  # Van Loan's exp(-A dt) block overflows precision; use stationarity instead
            phi = scipy.linalg.expm(self._a * dt)
            q = self._p - phi @ self._p @ phi.T
            q = 0.5 * (q + q.T)
        entry = (phi, q, _psd_sqrt(q))
        if len(self._cache) >= _CACHE_SIZE:
            self._cache.pop(next(iter(self._cache)))
        self._cache[dt] = entry
        return entry

    def _check_time(self, t: float, where: str) -> None:
        if t < self._t:
            raise ValueError(
                f"The 't' parameter of {where} must be >= the last queried time {self._t!r} "
                f"(the process only moves forward; call reset() to restart). Got {t!r} instead."
            )

    def velocity(self, t: float, xyz: np.ndarray) -> np.ndarray:
        """Wind at time ``t`` (s) for positions ``xyz`` (B, 3) m: (B, 3) m/s, world frame.

        Raises
        ------
        ValueError
            If ``t`` is NaN/inf or earlier than the last query, or ``xyz`` is not finite (B, 3)
            (with B equal to ``batch_size`` when that is set).
        """
        where = "DrydenWind.velocity"
        t, xyz = check_query(t, xyz, where, batch=self._batch)
        self._check_time(t, where)
        if t > self._t:
            dt = round(t - self._t, _DT_DECIMALS)
            if dt > 0:
                phi, _, s = self._step_matrices(dt)
                noise = self._rng.standard_normal(self._x.shape)
                self._x = self._x @ phi.T + noise @ s.T
                self._value = self._mean + self._x @ self._c.T
            self._t = t
        if self._batch is None:
            return np.tile(self._value[0], (xyz.shape[0], 1))
        return self._value.copy()

    def sample(self, times) -> np.ndarray:
        """Advance through increasing ``times`` and return the wind at each, in one fast pass.

        Equivalent to calling ``velocity(t, ...)`` for each ``t`` in order (same random stream,
        same values) but vectorised, for long records.

        Parameters
        ----------
        times : array_like of shape (K,)
            Non-decreasing query times, s, none earlier than :attr:`time`.

        Returns
        -------
        ndarray of shape (K, 3), or (K, R, 3) when ``batch_size`` is R
            Wind, m/s, world frame.
        """
        where = "DrydenWind.sample"
        times = np.asarray(times, dtype=np.float64)
        if times.ndim != 1 or not np.all(np.isfinite(times)):
            raise ValueError(
                f"The 'times' parameter of {where} must be a finite 1-D array. "
                f"Got shape {times.shape} instead."
            )
        if times.size and (times[0] < self._t or np.any(np.diff(times) < 0)):
            raise ValueError(
                f"The 'times' parameter of {where} must be non-decreasing and >= the last "
                f"queried time {self._t!r}."
            )
        n_real = self._x.shape[0]
        out = np.empty((times.size, n_real, 3))
        prev = np.concatenate([[self._t], times[:-1]]) if times.size else times
        steps = np.round(times - prev, _DT_DECIMALS)
        for start in range(0, times.size, _CHUNK):
            stop = min(start + _CHUNK, times.size)
            keys, index = np.unique(steps[start:stop], return_inverse=True)
            mats = [self._step_matrices(float(k)) for k in keys]
            phis = np.stack([m[0] for m in mats])
            sqrts = np.stack([m[2] for m in mats])
            moving = keys[index] > 0
            # draw noise only for steps that move, in the order velocity() would draw it
            if moving.all():
                noise = self._rng.standard_normal((stop - start, n_real, _N_STATES))
            else:
                noise = np.zeros((stop - start, n_real, _N_STATES))
                noise[moving] = self._rng.standard_normal((int(moving.sum()), n_real, _N_STATES))
            _propagate(self._x, phis, sqrts, index.astype(np.int64), noise, self._c,
                       self._mean, out[start:stop])
        if times.size:
            self._t = float(times[-1])
            self._value = self._mean + self._x @ self._c.T
        return out[:, 0, :] if self._batch is None else out

    def __repr__(self) -> str:
        return (
            f"DrydenWind(mean={tuple(self._mean.tolist())}, sigma={tuple(self._sigma.tolist())}, "
            f"seed={self._seed}, airspeed={self.airspeed}, "
            f"length_scales={tuple(np.round(self._scales, 3).tolist())}, "
            f"batch_size={self._batch})"
        )
