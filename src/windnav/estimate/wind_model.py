"""The Wind UKF process and measurement models (Folk 2026, ch. 3), batched over sigma points.

State ``x`` in R^(12 + N) (index: meaning, unit):

    0..2   psi, theta, phi   ZYX Euler angles, body to world, rad
    3..5   p, q, r           body rates, rad/s (random walk)
    6..8   v_b               body-frame velocity, m/s
    9..11  w_b               body-frame wind, m/s (random walk)
    12..   eta               rotor speeds, rad/s

Input ``u``: commanded rotor speeds (N,), rad/s.

Continuous model, with ``R = Rz(psi) Ry(theta) Rx(phi)`` and airspeed ``v_a = v_b - w_b``::

    phi'   = p + (q sin(phi) + r cos(phi)) tan(theta)
    theta' = q cos(phi) - r sin(phi)
    psi'   = (q sin(phi) + r cos(phi)) / cos(theta)
    F      = (k_eta sum eta_i^2 + N k_h (v_a,x^2 + v_a,y^2)) e3
             - (sum eta_i) diag(k_d, k_d, k_z) v_a - |v_a| diag(c_dx, c_dy, c_dz) v_a
    v_b'   = F / m - R^T [0, 0, g] - Omega x v_b
    eta_i' = (u_i - eta_i) / tau_m
    p', q', r', w_b' = 0          (driven by the process noise Q)

Option ``wind_frame="world"``: the world-frame wind is the random walk instead, so the body
wind turns with the vehicle, ``w_b' = -Omega x w_b`` (better when the vehicle rotates in a
steady wind; not part of the thesis model).

The lever-arm term ``Omega x r_i`` of each rotor's airspeed is neglected, as in the thesis.
Integration over ``dt``: classical RK4 on the first 12 states (``n_substeps`` steps), with the
motor states taken from the exact solution ``eta(t) = u + (eta_0 - u) exp(-t / tau_m)`` at
each stage (the motor equation is stiff for ``tau_m`` = 5 ms at 100 Hz).

Measurement models:

    accelerometer  F / m                        specific force, body axes, m/s^2 (3,)
    gyro           (p, q, r)                    rad/s (3,)
    odometry       (R v_b, psi, theta, phi)     world velocity m/s and Euler angles rad (6,)
    rotor speeds   eta                          rad/s (N,)

Kernels are ``numba.njit(cache=True)`` loops over the sigma points.
"""

from __future__ import annotations

import numba
import numpy as np

from windnav.vehicle.params import GRAVITY, MultirotorParams

__all__ = [
    "IDX_EULER",
    "IDX_RATES",
    "IDX_ROTORS",
    "IDX_VELOCITY",
    "IDX_WIND",
    "euler_to_matrix",
    "model_constants",
    "odometry",
    "process",
    "specific_force",
    "state_derivative",
    "state_labels",
]

IDX_EULER = slice(0, 3)
IDX_RATES = slice(3, 6)
IDX_VELOCITY = slice(6, 9)
IDX_WIND = slice(9, 12)
IDX_ROTORS = slice(12, None)


def state_labels(n_rotors: int) -> list[str]:
    """Names of the ``12 + n_rotors`` state components, in order."""
    return (["psi", "theta", "phi", "p", "q", "r", "vx_b", "vy_b", "vz_b", "wx_b", "wy_b",
             "wz_b"] + [f"eta_{i}" for i in range(n_rotors)])


def model_constants(params: MultirotorParams, *, wind_frame: str = "body") -> np.ndarray:
    """Pack the parameters the kernels need.

    Parameters
    ----------
    params : MultirotorParams
    wind_frame : {"body", "world"}
        "body": the body-frame wind is a random walk, ``w_b' = 0`` (the thesis model).
        "world": the *world-frame* wind is a random walk, so ``w_b' = -Omega x w_b``.

    Returns
    -------
    ndarray of shape (11,)
        ``[mass, k_eta, k_d, k_z, k_h, c_dx, c_dy, c_dz, tau_m, g, world_wind_flag]`` (SI).
    """
    if wind_frame not in ("body", "world"):
        raise ValueError("The 'wind_frame' parameter of model_constants must be 'body' or "
                         f"'world'. Got {wind_frame!r} instead.")
    return np.array([params.mass, params.k_eta, params.k_d, params.k_z, params.k_h,
                     params.c_dx, params.c_dy, params.c_dz, params.tau_m, GRAVITY,
                     1.0 if wind_frame == "world" else 0.0])


@numba.njit(cache=True)
def _force(x, eta, prm, out):
    """Non-gravitational force / mass (specific force) in body axes into ``out`` (3,)."""
    s_eta = 0.0
    s_eta2 = 0.0
    for i in range(eta.shape[0]):
        s_eta += eta[i]
        s_eta2 += eta[i] * eta[i]
    m, k_eta, k_d, k_z, k_h = prm[0], prm[1], prm[2], prm[3], prm[4]
    c_dx, c_dy, c_dz = prm[5], prm[6], prm[7]
    vax = x[6] - x[9]
    vay = x[7] - x[10]
    vaz = x[8] - x[11]
    speed = np.sqrt(vax * vax + vay * vay + vaz * vaz)
    out[0] = (-s_eta * k_d * vax - speed * c_dx * vax) / m
    out[1] = (-s_eta * k_d * vay - speed * c_dy * vay) / m
    out[2] = (k_eta * s_eta2 + eta.shape[0] * k_h * (vax * vax + vay * vay)
              - s_eta * k_z * vaz - speed * c_dz * vaz) / m


@numba.njit(cache=True, inline="always")
def _deriv12(x, s_eta, s_eta2, n_rot, prm, k):
    """Derivative of the first 12 states into ``k`` (12,), given ``sum eta`` and
    ``sum eta^2``. Entries 3..5 (rates) stay untouched (zero); 9..11 (wind) are written only
    for the world-fixed wind option ``prm[10] != 0``: ``w_b' = -Omega x w_b``."""
    m, k_eta, k_d, k_z, k_h = prm[0], prm[1], prm[2], prm[3], prm[4]
    c_dx, c_dy, c_dz, g = prm[5], prm[6], prm[7], prm[9]
    th, ph = x[1], x[2]
    p, q, r = x[3], x[4], x[5]
    vx, vy, vz = x[6], x[7], x[8]
    wx, wy, wz = x[9], x[10], x[11]
    vax = vx - wx
    vay = vy - wy
    vaz = vz - wz
    speed = np.sqrt(vax * vax + vay * vay + vaz * vaz)
    sth, cth = np.sin(th), np.cos(th)
    sph, cph = np.sin(ph), np.cos(ph)
    a = q * sph + r * cph
    k[0] = a / cth
    k[1] = q * cph - r * sph
    k[2] = p + a * sth / cth
    k[6] = (-s_eta * k_d * vax - speed * c_dx * vax) / m + g * sth - (q * vz - r * vy)
    k[7] = (-s_eta * k_d * vay - speed * c_dy * vay) / m - g * cth * sph - (r * vx - p * vz)
    k[8] = ((k_eta * s_eta2 + n_rot * k_h * (vax * vax + vay * vay) - s_eta * k_z * vaz
             - speed * c_dz * vaz) / m - g * cth * cph - (p * vy - q * vx))
    if prm[10] != 0.0:
        k[9] = -(q * wz - r * wy)
        k[10] = -(r * wx - p * wz)
        k[11] = -(p * wy - q * wx)


@numba.njit(cache=True)
def _state_derivative(X, u, prm):
    S, n = X.shape
    nr = n - 12
    out = np.zeros((S, n))
    k = np.zeros(12)
    for s in range(S):
        se = 0.0
        se2 = 0.0
        for i in range(nr):
            se += X[s, 12 + i]
            se2 += X[s, 12 + i] * X[s, 12 + i]
            out[s, 12 + i] = (u[i] - X[s, 12 + i]) / prm[8]
        _deriv12(X[s], se, se2, nr, prm, k)
        for i in range(12):
            out[s, i] = k[i]
    return out


@numba.njit(cache=True)
def _process(X, dt, u, prm, n_substeps):
    S, n = X.shape
    nr = n - 12
    h = dt / n_substeps
    e_half = np.exp(-0.5 * h / prm[8])
    out = np.empty((S, n))
    k1 = np.zeros(12)
    k2 = np.zeros(12)
    k3 = np.zeros(12)
    k4 = np.zeros(12)
    xs = np.empty(12)
    x = np.empty(12)
    eta = np.empty(nr)
    for s in range(S):
        for i in range(12):
            x[i] = X[s, i]
        for i in range(nr):
            eta[i] = X[s, 12 + i]
        for _ in range(n_substeps):
            # exact motor solution at the RK4 stage times 0, h/2, h
            se0 = 0.0
            se20 = 0.0
            sem = 0.0
            se2m = 0.0
            se1 = 0.0
            se21 = 0.0
            for i in range(nr):
                em = u[i] + (eta[i] - u[i]) * e_half
                e1 = u[i] + (em - u[i]) * e_half
                se0 += eta[i]
                se20 += eta[i] * eta[i]
                sem += em
                se2m += em * em
                se1 += e1
                se21 += e1 * e1
                eta[i] = e1
            _deriv12(x, se0, se20, nr, prm, k1)
            for i in range(12):
                xs[i] = x[i] + 0.5 * h * k1[i]
            _deriv12(xs, sem, se2m, nr, prm, k2)
            for i in range(12):
                xs[i] = x[i] + 0.5 * h * k2[i]
            _deriv12(xs, sem, se2m, nr, prm, k3)
            for i in range(12):
                xs[i] = x[i] + h * k3[i]
            _deriv12(xs, se1, se21, nr, prm, k4)
            for i in range(12):
                x[i] += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])
        for i in range(12):
            out[s, i] = x[i]
        for i in range(nr):
            out[s, 12 + i] = eta[i]
    return out


@numba.njit(cache=True)
def _specific_force(X, prm):
    S = X.shape[0]
    out = np.empty((S, 3))
    f = np.empty(3)
    for s in range(S):
        _force(X[s], X[s, 12:], prm, f)
        out[s] = f
    return out


@numba.njit(cache=True)
def _odometry(X):
    S = X.shape[0]
    out = np.empty((S, 6))
    for s in range(S):
        ps, th, ph = X[s, 0], X[s, 1], X[s, 2]
        cps, sps = np.cos(ps), np.sin(ps)
        cth, sth = np.cos(th), np.sin(th)
        cph, sph = np.cos(ph), np.sin(ph)
        vx, vy, vz = X[s, 6], X[s, 7], X[s, 8]
        out[s, 0] = (cps * cth * vx + (cps * sth * sph - sps * cph) * vy
                     + (cps * sth * cph + sps * sph) * vz)
        out[s, 1] = (sps * cth * vx + (sps * sth * sph + cps * cph) * vy
                     + (sps * sth * cph - cps * sph) * vz)
        out[s, 2] = -sth * vx + cth * sph * vy + cth * cph * vz
        out[s, 3] = ps
        out[s, 4] = th
        out[s, 5] = ph
    return out


def _check_states(X, name: str, where: str) -> np.ndarray:
    X = np.asarray(X, dtype=np.float64)
    if X.ndim == 1:
        X = X[None]
    if X.ndim != 2 or X.shape[1] < 13:
        raise ValueError(f"The {name!r} parameter of {where} must have shape (S, 12 + N). "
                         f"Got shape {X.shape} instead.")
    return np.ascontiguousarray(X)


def state_derivative(X, u, prm) -> np.ndarray:
    """Continuous-time derivative ``dx/dt`` of the Wind UKF model.

    Parameters
    ----------
    X : ndarray of shape (S, 12 + N)
        States (see the module docstring).
    u : ndarray of shape (N,)
        Commanded rotor speeds, rad/s.
    prm : ndarray of shape (11,)
        :func:`model_constants`.

    Returns
    -------
    ndarray of shape (S, 12 + N)
    """
    X = _check_states(X, "X", "state_derivative")
    return _state_derivative(X, np.asarray(u, dtype=np.float64), prm)


def process(X, dt: float, u, prm, n_substeps: int = 1) -> np.ndarray:
    """Propagate states over ``dt`` (RK4 with exact first-order motors).

    Parameters
    ----------
    X : ndarray of shape (S, 12 + N)
    dt : float
        Step, s.
    u : ndarray of shape (N,)
        Commanded rotor speeds, rad/s (held over the step).
    prm : ndarray of shape (11,)
        :func:`model_constants`.
    n_substeps : int
        RK4 steps per ``dt``.

    Returns
    -------
    ndarray of shape (S, 12 + N)
    """
    return _process(X, float(dt), u, prm, int(n_substeps))


def specific_force(X, prm) -> np.ndarray:
    """Accelerometer model: ``F / m`` in body axes, m/s^2, of shape (S, 3)."""
    return _specific_force(X, prm)


def odometry(X) -> np.ndarray:
    """Odometry model ``(R v_b, psi, theta, phi)`` of shape (S, 6): m/s world, rad."""
    return _odometry(X)


def euler_to_matrix(euler) -> np.ndarray:
    """Rotation matrices ``Rz(psi) Ry(theta) Rx(phi)`` (body to world).

    Parameters
    ----------
    euler : ndarray of shape (B, 3)
        ``(psi, theta, phi)``, rad.

    Returns
    -------
    ndarray of shape (B, 3, 3)
    """
    e = np.asarray(euler, dtype=np.float64).reshape(-1, 3)
    cps, sps = np.cos(e[:, 0]), np.sin(e[:, 0])
    cth, sth = np.cos(e[:, 1]), np.sin(e[:, 1])
    cph, sph = np.cos(e[:, 2]), np.sin(e[:, 2])
    R = np.empty((e.shape[0], 3, 3))
    R[:, 0, 0] = cps * cth
    R[:, 0, 1] = cps * sth * sph - sps * cph
    R[:, 0, 2] = cps * sth * cph + sps * sph
    R[:, 1, 0] = sps * cth
    R[:, 1, 1] = sps * sth * sph + cps * cph
    R[:, 1, 2] = sps * sth * cph - cps * sph
    R[:, 2, 0] = -sth
    R[:, 2, 1] = cth * sph
    R[:, 2, 2] = cth * cph
    return R


@numba.njit(cache=True)
def _wind_world_ut(x, P, wm_, wc_, scale):
    """Unscented transform of ``R(euler) w_b`` over the (euler, w_b) marginal of (x, P).

    Returns (mean (3,), cov (3, 3), ok); ``ok`` is False when the 6x6 marginal is not
    positive definite (the caller repairs it).
    """
    idx = np.array([0, 1, 2, 9, 10, 11])
    A = np.empty((6, 6))
    for i in range(6):
        for j in range(6):
            A[i, j] = 0.5 * (P[idx[i], idx[j]] + P[idx[j], idx[i]])
    L = np.zeros((6, 6))
    mean = np.zeros(3)
    cov = np.zeros((3, 3))
    for j in range(6):
        d = A[j, j]
        for k in range(j):
            d -= L[j, k] * L[j, k]
        if not d > 0.0:
            return mean, cov, False
        L[j, j] = np.sqrt(d)
        for i in range(j + 1, 6):
            v = A[i, j]
            for k in range(j):
                v -= L[i, k] * L[j, k]
            L[i, j] = v / L[j, j]
    c = np.sqrt(scale)
    W = np.empty((13, 3))
    e = np.empty(6)
    for s in range(13):
        for i in range(6):
            e[i] = x[idx[i]]
        if s > 0:
            col = (s - 1) % 6
            sign = 1.0 if s <= 6 else -1.0
            for i in range(6):
                e[i] += sign * c * L[i, col]
        cps, sps = np.cos(e[0]), np.sin(e[0])
        cth, sth = np.cos(e[1]), np.sin(e[1])
        cph, sph = np.cos(e[2]), np.sin(e[2])
        wx, wy, wz = e[3], e[4], e[5]
        W[s, 0] = (cps * cth * wx + (cps * sth * sph - sps * cph) * wy
                   + (cps * sth * cph + sps * sph) * wz)
        W[s, 1] = (sps * cth * wx + (sps * sth * sph + cps * cph) * wy
                   + (sps * sth * cph - cps * sph) * wz)
        W[s, 2] = -sth * wx + cth * sph * wy + cth * cph * wz
        for i in range(3):
            mean[i] += wm_[s] * W[s, i]
    for s in range(13):
        for i in range(3):
            for j in range(3):
                cov[i, j] += wc_[s] * (W[s, i] - mean[i]) * (W[s, j] - mean[j])
    return mean, cov, True
