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
stationary covariance ``P`` (``A P + P A^T + B B^T = 0``), so every sample has standard
deviation exactly ``sigma`` and the gust correlations of the continuous process.

A function of time, not a stream
--------------------------------
The gust is generated once on a fixed time lattice ``t_k = t0 + k h`` (``h = time_step``, 1 ms by
default) with the exact step above, in blocks of 2048 steps. The process noise of block
``j`` is drawn from its own counter-based stream, ``SeedSequence(seed, spawn_key=(1, j))``, and
the initial state from ``spawn_key=(0,)``; block ``j`` starts from the end state of block
``j - 1``. Every lattice value is therefore a fixed function of the seed and ``k``: blocks are
generated lazily, their start states kept, their values cached (and regenerated bit for bit when
evicted). Between lattice points the gust is interpolated linearly, which lowers its variance by
at most ``(1 - rho(h)) / 2`` relative, midway: ``h / (2 T_u)`` for u (``T_u = L_u / V``), less
for the smoother v and w (under 0.01 % at the defaults).

So ``velocity(t, xyz)`` is a pure function of ``(t, xyz)`` and the seed: queries may come in
any order (earlier times included), and one object can serve many vehicles and flights at once.
"""

from __future__ import annotations

import math
import threading
import warnings
from collections import OrderedDict

import numpy as np
import scipy.linalg

from windnav._jit import njit
from windnav._validate import (
    ReadOnlyOnCopy,
    batch_array,
    finite_float,
    positive_float,
    positive_int,
)
from windnav.wind.base import check_query

FOOT = 0.3048
"""One international foot, m."""

_N_STATES = 5  # u: 1 state, v: 2 states, w: 2 states
_VAN_LOAN_MAX_DECAYS = 4.0  # beyond dt * max|eig(A)| = 4 use Q = P - Phi P Phi^T
_BLOCK = 2048  # lattice steps per block of generated gusts
_CACHE_BYTES = 64 << 20  # generated values kept per DrydenWind; evicted blocks are regenerated
_START_STRIDE = 64  # block start states kept: every 64th and the furthest (a block between two
# kept ones is regenerated from the one before it, up to 63 blocks of work; keeping every one
# grew by one state per 2.048 s, about 100 MB at t = 1e6 s, long-run audit)
_SNAP = 1e-6  # a query within 1e-6 lattice steps of a lattice point reads that point
_MAX_STEPS = 2 ** 25  # lattice steps a query may reach from t0: 3.4e7, about 3 s of generation
# per realisation (1e7 steps a second), 9.3 h of gusts at the default 1 ms step; t = 1e9 s spun
# for ever (API audit). Steps alone, not times the realisations: a batch of 256 vehicles flying
# 300 s is legitimate work, and a flight must not be refused part-way (review)
_DECAYED = 1e3  # dt * the slowest decay rate beyond which exp(A dt) underflows to 0


def _numbers(value, name: str, where: str):
    """``value`` unchanged when NumPy reads it as numbers, else a ValueError naming ``name``
    (``DrydenWind('abc')`` said only "could not convert string to float: 'abc'")."""
    try:
        np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"The {name!r} parameter of {where} must be three numbers. "
                         f"Got {value!r} instead.") from None
    return value


def _step_length(dt, where: str) -> float:
    """``dt`` as a float >= 0 (a step of -1 s gave a negative Q), else a named ValueError."""
    return positive_float(dt, "dt", where, allow_zero=True)


def _decay(a: np.ndarray, dt: float, where: str, name: str = "dt") -> np.ndarray:
    """``expm(A dt)`` of a stable ``A``; zero where the exponential overflows in scaling and
    squaring (dt of 1e40 s and more gave NaN) far beyond every time constant, where its
    exact value underflows to 0."""
    phi = scipy.linalg.expm(a * dt)
    if np.all(np.isfinite(phi)):
        return phi
    slowest = float(np.min(np.abs(np.linalg.eigvals(a).real)))
    if dt * slowest > _DECAYED:
        return np.zeros_like(phi)
    raise ValueError(f"The {name!r} parameter of {where} must give a finite exp(A dt). "
                     f"Got {dt!r} instead.")


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


def dryden_state_space(sigma, length_scales, airspeed: float, *,
                       where: str = "dryden_state_space"):
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

    ``where`` names the caller in the errors.
    """
    sig = batch_array(_numbers(sigma, "sigma", where), "sigma", where, (3,), batch=1)[0]
    if np.any(sig < 0):
        raise ValueError(f"The 'sigma' parameter of {where} must be >= 0. Got {sig!r} instead.")
    scales = batch_array(_numbers(length_scales, "length_scales", where), "length_scales",
                         where, (3,), batch=1)[0]
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
    """Solution ``P`` of ``A P + P A^T + B B^T = 0`` (stable ``A``), symmetrised.

    Raises
    ------
    ValueError
        If ``A`` is not stable (an eigenvalue with real part >= 0): there is no stationary
        covariance, and the solve gave a negative-definite ``P`` (API audit).
    """
    where = "stationary_covariance"
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    if a.ndim != 2 or a.shape[0] != a.shape[1]:
        raise ValueError(f"The 'a' parameter of {where} must be a square matrix. Got shape "
                         f"{a.shape} instead.")
    if b.ndim != 2 or b.shape[0] != a.shape[0]:
        raise ValueError(f"The 'b' parameter of {where} must be a matrix of {a.shape[0]} rows "
                         f"(as 'a'). Got shape {b.shape} instead.")
    for name, m in (("a", a), ("b", b)):
        if not np.all(np.isfinite(m)):
            raise ValueError(f"The {name!r} parameter of {where} must be finite. Got "
                             f"{m.tolist()!r} instead.")
    growth = np.linalg.eigvals(a).real
    if a.size and growth.max() >= 0:
        raise ValueError(f"The 'a' parameter of {where} must be stable (every eigenvalue with "
                         f"a negative real part) for a stationary covariance. Got eigenvalues "
                         f"with real parts up to {growth.max()!r} instead.")
    p = scipy.linalg.solve_continuous_lyapunov(a, -b @ b.T)
    return 0.5 * (p + p.T)


def van_loan(a: np.ndarray, b: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Exact discretisation of ``dx = A x dt + B dW`` over a step ``dt`` (s).

    Returns ``Phi = expm(A dt)`` and ``Q = int_0^dt expm(A s) B B^T expm(A^T s) ds`` from
    ``expm([[-A, B B^T], [0, A^T]] dt) = [[., G12], [0, G22]]``: ``Phi = G22^T``,
    ``Q = Phi G12`` (Van Loan 1978).

    Raises
    ------
    ValueError
        If ``dt`` is negative or not finite (a step of -1 s gave a negative ``Q``), or so long
        that the block exponential overflows (use ``Q = P - Phi P Phi^T`` there).
    """
    dt = _step_length(dt, "van_loan")
    n = a.shape[0]
    m = np.zeros((2 * n, 2 * n))
    m[:n, :n] = -a
    m[:n, n:] = b @ b.T
    m[n:, n:] = a.T
    g = scipy.linalg.expm(m * dt)
    phi = g[n:, n:].T
    q = phi @ g[:n, n:]
    if not (np.all(np.isfinite(phi)) and np.all(np.isfinite(q))):
        raise ValueError(f"The 'dt' parameter of van_loan must be a step whose block "
                         f"exponential is finite. Got {dt!r} instead; for long steps of a "
                         "stable A use Q = P - Phi P Phi^T.")
    return phi, 0.5 * (q + q.T)


def _psd_sqrt(q: np.ndarray) -> np.ndarray:
    """``S`` with ``S S^T = Q`` for a symmetric PSD ``Q`` (tiny negative eigenvalues -> 0)."""
    lam, vec = np.linalg.eigh(q)
    return vec * np.sqrt(np.clip(lam, 0.0, None))


def _exact_step(a, b, p, fastest: float, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """``(Phi, Q)`` of one exact step of ``dt`` s: Van Loan, or ``P - Phi P Phi^T`` for long
    steps, where Van Loan's ``exp(-A dt)`` block loses precision."""
    if dt * fastest <= _VAN_LOAN_MAX_DECAYS:
        return van_loan(a, b, dt)
    phi = _decay(a, dt, "DrydenWind.transition")
    q = p - phi @ p @ phi.T
    return phi, 0.5 * (q + q.T)


@njit(cache=True)
def _run_block(x, phi, s, noise, c, mean, out):  # pragma: no cover - numba
    """Gusts of one block: ``out[k] = mean + C x_k`` for ``k = 0..M`` (``out`` (M+1, R, 3)).

    ``x`` (R, n) holds the states at the block start and is advanced in place to its end by
    ``x_{k+1} = Phi x_k + S noise[k]`` (``noise`` (M, R, n) standard normals).
    """
    n_steps, n_real, n = noise.shape
    new = np.empty(n)
    for k in range(n_steps + 1):
        if k > 0:
            for r in range(n_real):
                for i in range(n):
                    acc = 0.0
                    for j in range(n):
                        acc += phi[i, j] * x[r, j] + s[i, j] * noise[k - 1, r, j]
                    new[i] = acc
                for i in range(n):
                    x[r, i] = new[i]
        for r in range(n_real):
            for i in range(3):
                acc = mean[i]
                for j in range(n):
                    acc += c[i, j] * x[r, j]
                out[k, r, i] = acc


def _seed_entropy(seed, rng, where: str) -> int:
    """The integer that seeds every block: ``rng`` (int or Generator) or the alias ``seed``."""
    def is_seed(v):
        return isinstance(v, (int, np.integer)) and not isinstance(v, bool) and v >= 0

    if seed is not None:
        if rng is not None:
            raise ValueError(f"The 'seed' parameter of {where} is a deprecated alias of 'rng'; "
                             f"pass only one of them. Got seed={seed!r} and rng={rng!r}.")
        if not is_seed(seed):
            raise ValueError(f"The 'seed' parameter of {where} must be a non-negative int. "
                             f"Got {seed!r} instead.")
        return int(seed)
    if rng is None:
        return 0
    if isinstance(rng, np.random.Generator):
        return int(rng.integers(0, np.iinfo(np.int64).max))
    if not is_seed(rng):
        raise ValueError(f"The 'rng' parameter of {where} must be a numpy.random.Generator, a "
                         f"non-negative int or None. Got {rng!r} instead.")
    return int(rng)


def _interpolate(values: np.ndarray, i, frac) -> np.ndarray:
    """``g_i + frac (g_{i+1} - g_i)`` on a block's values; the one formula every query uses, so
    the same time gives the same bits whichever method asks."""
    return values[i] + frac * (values[i + 1] - values[i])


class DrydenWind(ReadOnlyOnCopy):
    """Mean wind plus Dryden turbulence: a fixed function of time and seed.

    See the module docstring for the transfer functions, length scales and discretisation.

    Parameters
    ----------
    mean : array_like of shape (3,)
        Mean wind, m/s, world frame.
    sigma : array_like of shape (3,)
        Standard deviation of the gust along world x, y, z, m/s (>= 0).
    seed : int, optional
        Deprecated alias of ``rng`` (an int); kept for the public contract
        ``DrydenWind(mean=..., sigma=..., seed=0)``.
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
        Time at which the process starts from its stationary distribution, s; the first
        lattice point. Earlier times raise ValueError.
    rng : int or numpy.random.Generator, optional
        Seed of the gusts. An int seeds them directly; a Generator is drawn from once for a
        seed; None (and no ``seed``) means seed 0, the former default. Same seed, same gusts.
    time_step : float
        Spacing ``h`` of the lattice on which the process is generated exactly, s (default
        1 ms); the gust is linear between lattice points. Keep it well below ``L_w / V``; a
        step longer than the shortest time scale ``L / V`` of an axis with gusts is refused
        (the lattice would not resolve the gust).

    Notes
    -----
    ``velocity(t, xyz)`` depends only on ``t``, ``xyz`` and the seed: the same time gives the
    same gust bit for bit whatever was queried before, earlier times included, so one object
    can serve many flights (and threads). The gust is spatially uniform: positions only set
    the batch size. The lattice is generated in order from ``t0``, so the first query at a
    time ``t`` costs ``(t - t0) / time_step`` exact steps per realisation (of the order of 1 s
    per 10^7); later queries up to ``t`` read the cache (at most 64 MB; evicted blocks are
    regenerated from their stored start states). A query more than 2^25 (3.4e7) steps from
    ``t0`` is refused with a ValueError (a few seconds of generation per realisation): at the
    default 1 ms step that is 9.3 h of gusts (t = 1e9 s spun for ever); a coarser
    ``time_step`` reaches further.

    Examples
    --------
    >>> g = DrydenWind(mean=(3, 0, 0), sigma=(1.5, 1.5, 0.7), rng=0)
    >>> g.velocity(0.01, [[0.0, 0.0, 2.0]]).shape
    (1, 3)
    """

    def __init__(
        self,
        mean=(3.0, 0.0, 0.0),
        sigma=(1.5, 1.5, 0.7),
        seed: int | None = None,
        airspeed: float = 10.0,
        altitude: float = 10.0,
        length_scales=None,
        batch_size: int | None = None,
        t0: float = 0.0,
        *,
        rng: np.random.Generator | int | None = None,
        time_step: float = 1e-3,
    ):
        where = "DrydenWind"
        self._mean = batch_array(_numbers(mean, "mean", where), "mean", where, (3,),
                                 batch=1)[0].copy()
        self._seed = _seed_entropy(seed, rng, where)
        self._airspeed = positive_float(airspeed, "airspeed", where)
        if length_scales is None:
            self._altitude = positive_float(altitude, "altitude", where)
            scales = dryden_length_scales(self._altitude)
        else:
            self._altitude = None
            scales = length_scales
        self._a, self._b, self._c = dryden_state_space(sigma, scales, self.airspeed,
                                                       where=where)
        self._sigma = batch_array(sigma, "sigma", where, (3,), batch=1)[0].copy()
        self._scales = np.asarray(scales, dtype=np.float64).copy()
        for arr in (self._mean, self._sigma, self._scales):
            arr.setflags(write=False)
        self._batch = None if batch_size is None else positive_int(batch_size, "batch_size", where)
        self._t0 = finite_float(t0, "t0", where)
        self._h = positive_float(time_step, "time_step", where)
        with warnings.catch_warnings():  # SciPy's perturbation notice: the check below decides
            warnings.filterwarnings("ignore", message='Input "a" has an eigenvalue pair',
                                    category=RuntimeWarning)
            self._p = stationary_covariance(self._a, self._b)
        variance = np.einsum("ij,jk,ik->i", self._c, self._p, self._c)
        if not np.allclose(variance, self._sigma ** 2, rtol=1e-6, atol=1e-12):
            # time constants L / V of a microsecond or less: the Lyapunov solve loses the
            # covariance, and the gusts came out hundreds of times larger than sigma
            raise ValueError(f"The 'length_scales' parameter of {where} must give time "
                             "constants L / airspeed that double precision can realise (the "
                             f"gust's variance came out {variance!r} (m/s)^2 "
                             f"for sigma^2 {self._sigma ** 2!r}). Got {self._scales!r} m at "
                             f"{self.airspeed} m/s instead.")
        gusty = self.time_scales[self._sigma > 0]
        if gusty.size and self._h > gusty.min():
            # time_step=1e6 s was accepted: every query read a straight line between two
            # lattice points a million seconds apart (API audit)
            raise ValueError(f"The 'time_step' parameter of {where} must be at most the "
                             f"shortest time scale L / airspeed of the gusts, "
                             f"{gusty.min():.4g} s (keep it well below). Got {time_step!r} "
                             "instead.")
        self._fastest = float(np.max(np.abs(np.linalg.eigvals(self._a))))
        phi, q = _exact_step(self._a, self._b, self._p, self._fastest, self._h)
        self._phi = np.ascontiguousarray(phi)
        self._s = np.ascontiguousarray(_psd_sqrt(q))
        self._init_cache()

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
    def seed(self) -> int:
        """The integer seed of the gusts (from ``rng``, or ``seed``)."""
        return self._seed

    @property
    def airspeed(self) -> float:
        """Reference airspeed ``V`` of the time scales ``L / V``, m/s. Read-only: the gusts
        are generated from it at construction, and an assigned value changed ``time_scales``
        and the repr but not the gusts (cache audit, thirty-ninth session)."""
        return self._airspeed

    @property
    def altitude(self) -> float | None:
        """Height of the MIL-F-8785C length scales, m (None when ``length_scales`` were
        given). Read-only, as ``airspeed``."""
        return self._altitude

    @property
    def batch_size(self) -> int | None:
        """Gust realisations, one per queried point (None: one shared by every point)."""
        return self._batch

    @property
    def time_step(self) -> float:
        """Spacing of the generation lattice, s."""
        return self._h

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
        dt = _step_length(dt, "DrydenWind.transition")
        return _exact_step(self._a, self._b, self._p, self._fastest, dt)

    def lag_correlation(self, lag: float) -> np.ndarray:
        """Model autocorrelation of each gust component at ``lag`` s, (3,) (NaN where sigma=0)."""
        lag = positive_float(lag, "lag", "DrydenWind.lag_correlation", allow_zero=True)
        phi = _decay(self._a, lag, "DrydenWind.lag_correlation", "lag")
        cov0 = np.diag(self._c @ self._p @ self._c.T)
        with np.errstate(invalid="ignore", divide="ignore"):
            return np.diag(self._c @ phi @ self._p @ self._c.T) / cov0

    # The lattice ------------------------------------------------------------------------------
    def _init_cache(self) -> None:
        n_real = 1 if self._batch is None else self._batch
        noise = self._noise((0,), (n_real, _N_STATES))
        # the state at the start of block j, for j a multiple of _START_STRIDE and for the
        # furthest block reached (the frontier)
        self._starts = {0: noise @ _psd_sqrt(self._p).T}
        self._frontier = 0
        self._values: OrderedDict[int, np.ndarray] = OrderedDict()
        self._lock = threading.Lock()

    def _noise(self, key: tuple, shape: tuple) -> np.ndarray:
        seq = np.random.SeedSequence(self._seed, spawn_key=key)
        return np.random.default_rng(seq).standard_normal(shape)

    def _run(self, j: int, x: np.ndarray) -> np.ndarray:
        """Values of block ``j`` (lattice points ``j M .. (j + 1) M``) from its start state
        ``x``, which is advanced in place to the block's end (the start of block ``j + 1``)."""
        noise = self._noise((1, j), (_BLOCK, x.shape[0], _N_STATES))
        out = np.empty((_BLOCK + 1, x.shape[0], 3))
        _run_block(x, self._phi, self._s, noise, self._c, self._mean, out)
        return out

    def _start(self, j: int) -> np.ndarray:
        """A copy of block ``j``'s start state (``j <= self._frontier``): kept, or run forward,
        bit for bit, from the kept one before it."""
        c = j if j in self._starts else (j // _START_STRIDE) * _START_STRIDE
        x = self._starts[c].copy()
        for k in range(c, j):
            self._run(k, x)
        return x

    def _generate(self, j: int) -> np.ndarray:
        """Values of block ``j``, from its start state; the frontier moves on past it."""
        x = self._start(j)
        out = self._run(j, x)
        if j == self._frontier:  # x is now the start of block j + 1
            if j % _START_STRIDE:
                del self._starts[j]
            self._starts[j + 1] = x
            self._frontier = j + 1
        return out

    def _block(self, j: int) -> np.ndarray:
        """Block ``j``'s values (``_BLOCK + 1``, R, 3), generated (in order from the last known
        start) or read from the cache."""
        with self._lock:
            values = self._values.get(j)
            if values is not None:
                self._values.move_to_end(j)
                return values
            for k in range(self._frontier, j + 1):
                values = self._generate(k)  # the blocks passed over give their start states
                if k == j:  # and are not kept: one query 2e4 s ahead kept them all (499 MB)
                    self._values[k] = values
            if j not in self._values:  # evicted earlier: regenerated bit for bit
                values = self._generate(j)
                self._values[j] = values
            while len(self._values) > 1 and len(self._values) * values.nbytes > _CACHE_BYTES:
                self._values.popitem(last=False)
            return values

    def _locate(self, times: np.ndarray, where: str, name: str):
        """Block, index within the block and weight of each time on the lattice."""
        u = (times - self._t0) / self._h
        if np.any(u < -_SNAP):
            raise ValueError(f"The {name!r} parameter of {where} must be >= t0 = {self._t0!r} s "
                             f"(the process starts there). Got {times.min()!r} instead.")
        self._check_reach(float(u.max()), float(times.max()), where, name)
        near = np.rint(u)
        snap = np.abs(u - near) <= _SNAP
        k = np.where(snap, near, np.floor(u))
        frac = np.where(snap, 0.0, u - k)
        k = k.astype(np.int64)
        block = k // _BLOCK
        return block, k - block * _BLOCK, frac

    def _check_reach(self, u: float, t: float, where: str, name: str) -> None:
        """Refuse a time ``u`` lattice steps from ``t0``, more than ``_MAX_STEPS``."""
        if u > _MAX_STEPS:
            raise ValueError(
                f"The {name!r} parameter of {where} must be at most "
                f"{self._t0 + _MAX_STEPS * self._h:.6g} s: the gusts are generated in order "
                f"from t0 = {self._t0:g} s on a lattice of time_step {self._h:g} s, at most "
                f"{_MAX_STEPS} steps (a few seconds' work per realisation). Got {t!r} instead; "
                "a coarser time_step reaches further.")

    def reset(self) -> None:
        """Drop the generated gusts (to free memory); later queries give the same values."""
        with self._lock:
            self._starts = {0: self._starts[0]}
            self._frontier = 0
            self._values.clear()

    def __getstate__(self):
        state = super().__getstate__()
        dropped = ("_starts", "_frontier", "_values", "_lock")
        for name in dropped:
            del state[name]
        state["_read_only_arrays"] = [e for e in state["_read_only_arrays"] if e[0] not in dropped]
        return state

    def __setstate__(self, state):
        super().__setstate__(state)
        self._init_cache()

    # Queries ----------------------------------------------------------------------------------
    def velocity(self, t: float, xyz: np.ndarray) -> np.ndarray:
        """Wind at time ``t`` (s) for positions ``xyz`` (B, 3) m: (B, 3) m/s, world frame.

        Raises
        ------
        ValueError
            If ``t`` is NaN/inf or earlier than ``t0``, or ``xyz`` is not finite (B, 3) (with B
            equal to ``batch_size`` when that is set).
        """
        where = "DrydenWind.velocity"
        t, xyz = check_query(t, xyz, where, batch=self._batch)
        u = (t - self._t0) / self._h  # the arithmetic of _locate, on one float
        if u < -_SNAP:
            self._locate(np.array([t]), where, "t")  # raises the named error
        if u > _MAX_STEPS:  # (compared here: the per-step query is the hot path)
            self._check_reach(u, t, where, "t")
        k = round(u)
        if abs(u - k) <= _SNAP:
            frac = 0.0
        else:
            k = math.floor(u)
            frac = u - k
        block, i = divmod(k, _BLOCK)
        value = _interpolate(self._block(block), i, frac)
        if self._batch is None:
            return np.tile(value[0], (xyz.shape[0], 1))
        return value.copy()

    def sample(self, times) -> np.ndarray:
        """The wind at each of ``times``, in one vectorised pass (same values as ``velocity``).

        Parameters
        ----------
        times : array_like of shape (K,)
            Query times, s, in any order, none earlier than ``t0``.

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
        n_real = 1 if self._batch is None else self._batch
        out = np.empty((times.size, n_real, 3))
        if times.size:
            block, i, frac = self._locate(times, where, "times")
            order = None if np.all(np.diff(block) >= 0) else np.argsort(block, kind="stable")
            sorted_blocks = block if order is None else block[order]
            firsts = np.flatnonzero(np.diff(sorted_blocks, prepend=-1))
            ends = np.append(firsts[1:], times.size)
            for a, b in zip(firsts, ends, strict=True):
                rows = slice(a, b) if order is None else order[a:b]
                values = self._block(int(sorted_blocks[a]))
                out[rows] = _interpolate(values, i[rows], frac[rows][:, None, None])
        return out[:, 0, :] if self._batch is None else out

    def __repr__(self) -> str:
        return (
            f"DrydenWind(mean={tuple(self._mean.tolist())}, sigma={tuple(self._sigma.tolist())}, "
            f"rng={self._seed}, airspeed={self.airspeed}, "
            f"length_scales={tuple(np.round(self._scales, 3).tolist())}, "
            f"batch_size={self._batch}, time_step={self._h})"
        )
