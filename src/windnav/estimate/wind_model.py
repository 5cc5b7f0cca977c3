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

Option ``wind_frame`` (default "world", the same in :func:`model_constants`, ``WindUKF`` and
``run_wind_ukf``): "world" makes the world-frame wind the random walk, so the body wind turns
with the vehicle, ``w_b' = -Omega x w_b`` (right when the vehicle rotates in a wind fixed in the
world); "body" makes the body-frame wind the random walk, ``w_b' = 0`` (the thesis model).

The lever-arm term ``Omega x r_i`` of each rotor's airspeed is neglected, as in the thesis.
Integration over ``dt``: classical RK4 on the first 12 states (``n_substeps`` steps), with the
motor states taken from the exact solution ``eta(t) = u + (eta_0 - u) exp(-t / tau_m)`` at
each stage (the motor equation is stiff for ``tau_m`` = 5 ms at 100 Hz).

Measurement models:

    accelerometer  F / m                        specific force, body axes, m/s^2 (3,)
    gyro           (p, q, r)                    rad/s (3,)
    odometry       (R v_b, psi, theta, phi)     world velocity m/s and Euler angles rad (6,)
    rotor speeds   eta                          rad/s (N,)

Kernels are cached ``njit`` loops over the sigma points. The force law is written
once (:func:`_specific_force_body`, used by the dynamics and the accelerometer model), the
rotation once (:func:`windnav.vehicle.rotation.euler_zyx_to_rotation`), and the packed layouts
of the state and constants are named in :mod:`windnav.estimate.layout`.
"""

from __future__ import annotations

import numpy as np

from windnav._jit import njit
from windnav.estimate._ukf_kernels import chol_lower, sigma_from_chol, unscented
from windnav.estimate.layout import (
    EULER,
    IDX_EULER,
    IDX_RATES,
    IDX_ROTORS,
    IDX_VELOCITY,
    IDX_WIND,
    N_BASE,
    N_PRM,
    PRM_C_DX,
    PRM_C_DY,
    PRM_C_DZ,
    PRM_G,
    PRM_K_D,
    PRM_K_ETA,
    PRM_K_H,
    PRM_K_Z,
    PRM_MASS,
    PRM_TAU_M,
    PRM_WORLD_WIND,
    RATES,
    ROTORS,
    VELOCITY,
    WIND,
    state_labels,
)
from windnav.vehicle.params import GRAVITY, MultirotorParams
from windnav.vehicle.rotation import euler_zyx_to_matrix, euler_zyx_to_rotation

__all__ = [
    "IDX_EULER",
    "IDX_RATES",
    "IDX_ROTORS",
    "IDX_VELOCITY",
    "IDX_WIND",
    "WIND_FRAMES",
    "euler_to_matrix",
    "model_constants",
    "odometry",
    "process",
    "specific_force",
    "state_derivative",
    "state_labels",
]

WIND_FRAMES = ("world", "body")
"""Accepted ``wind_frame`` values; the first is the default everywhere in the package."""


def model_constants(params: MultirotorParams, *, wind_frame: str = "world") -> np.ndarray:
    """Pack the parameters the kernels need.

    Parameters
    ----------
    params : MultirotorParams
    wind_frame : {"world", "body"}
        "world" (default): the *world-frame* wind is a random walk, so ``w_b' = -Omega x w_b``.
        "body": the body-frame wind is a random walk, ``w_b' = 0`` (the thesis model).

    Returns
    -------
    ndarray of shape (11,)
        ``[mass, k_eta, k_d, k_z, k_h, c_dx, c_dy, c_dz, tau_m, g, world_wind_flag]`` (SI),
        indexed by the ``PRM_*`` names of :mod:`windnav.estimate.layout`.
    """
    if wind_frame not in WIND_FRAMES:
        raise ValueError("The 'wind_frame' parameter of model_constants must be 'world' or "
                         f"'body'. Got {wind_frame!r} instead.")
    prm = np.empty(N_PRM)
    prm[PRM_MASS] = params.mass
    prm[PRM_K_ETA] = params.k_eta
    prm[PRM_K_D] = params.k_d
    prm[PRM_K_Z] = params.k_z
    prm[PRM_K_H] = params.k_h
    prm[PRM_C_DX] = params.c_dx
    prm[PRM_C_DY] = params.c_dy
    prm[PRM_C_DZ] = params.c_dz
    prm[PRM_TAU_M] = params.tau_m
    prm[PRM_G] = GRAVITY
    prm[PRM_WORLD_WIND] = 1.0 if wind_frame == "world" else 0.0
    return prm


@njit(cache=True, inline="always")
def _specific_force_body(x, s_eta, s_eta2, n_rot, prm):
    """The force law: ``F / m`` in body axes (no gravity), given ``sum eta`` and
    ``sum eta^2`` of the ``n_rot`` rotors (see the module docstring)."""
    m = prm[PRM_MASS]
    k_d = prm[PRM_K_D]
    vax = x[VELOCITY] - x[WIND]
    vay = x[VELOCITY + 1] - x[WIND + 1]
    vaz = x[VELOCITY + 2] - x[WIND + 2]
    speed = np.sqrt(vax * vax + vay * vay + vaz * vaz)
    return ((-s_eta * k_d * vax - speed * prm[PRM_C_DX] * vax) / m,
            (-s_eta * k_d * vay - speed * prm[PRM_C_DY] * vay) / m,
            (prm[PRM_K_ETA] * s_eta2 + n_rot * prm[PRM_K_H] * (vax * vax + vay * vay)
             - s_eta * prm[PRM_K_Z] * vaz - speed * prm[PRM_C_DZ] * vaz) / m)


@njit(cache=True, inline="always")
def _rotor_sums(x, n_rot):
    """``(sum eta_i, sum eta_i^2)`` of the rotor-speed states of ``x``."""
    s_eta = 0.0
    s_eta2 = 0.0
    for i in range(n_rot):
        e = x[ROTORS + i]
        s_eta += e
        s_eta2 += e * e
    return s_eta, s_eta2


@njit(cache=True, inline="always")
def _deriv12(x, s_eta, s_eta2, n_rot, prm, k):
    """Derivative of the first 12 states into ``k`` (12,), given ``sum eta`` and
    ``sum eta^2``. Entries of the rates stay untouched (zero); those of the wind are written
    only for the world-fixed wind option: ``w_b' = -Omega x w_b``."""
    g = prm[PRM_G]
    th, ph = x[EULER + 1], x[EULER + 2]
    p, q, r = x[RATES], x[RATES + 1], x[RATES + 2]
    vx, vy, vz = x[VELOCITY], x[VELOCITY + 1], x[VELOCITY + 2]
    wx, wy, wz = x[WIND], x[WIND + 1], x[WIND + 2]
    sth, cth = np.sin(th), np.cos(th)
    sph, cph = np.sin(ph), np.cos(ph)
    fx, fy, fz = _specific_force_body(x, s_eta, s_eta2, n_rot, prm)
    a = q * sph + r * cph
    k[EULER] = a / cth
    k[EULER + 1] = q * cph - r * sph
    k[EULER + 2] = p + a * sth / cth
    # v_b' = F / m - R^T g e3 - Omega x v_b, with R^T e3 = (-sin th, cos th sin ph, cos th cos ph)
    k[VELOCITY] = fx + g * sth - (q * vz - r * vy)
    k[VELOCITY + 1] = fy - g * cth * sph - (r * vx - p * vz)
    k[VELOCITY + 2] = fz - g * cth * cph - (p * vy - q * vx)
    if prm[PRM_WORLD_WIND] != 0.0:
        k[WIND] = -(q * wz - r * wy)
        k[WIND + 1] = -(r * wx - p * wz)
        k[WIND + 2] = -(p * wy - q * wx)


@njit(cache=True)
def _state_derivative(X, u, prm):
    S, n = X.shape
    nr = n - N_BASE
    out = np.zeros((S, n))
    k = np.zeros(N_BASE)
    for s in range(S):
        se, se2 = _rotor_sums(X[s], nr)
        for i in range(nr):
            out[s, ROTORS + i] = (u[i] - X[s, ROTORS + i]) / prm[PRM_TAU_M]
        _deriv12(X[s], se, se2, nr, prm, k)
        for i in range(N_BASE):
            out[s, i] = k[i]
    return out


@njit(cache=True)
def _process(X, dt, u, prm, n_substeps):
    S, n = X.shape
    nr = n - N_BASE
    h = dt / n_substeps
    e_half = np.exp(-0.5 * h / prm[PRM_TAU_M])
    out = np.empty((S, n))
    k1 = np.zeros(N_BASE)
    k2 = np.zeros(N_BASE)
    k3 = np.zeros(N_BASE)
    k4 = np.zeros(N_BASE)
    xs = np.empty(N_BASE)
    x = np.empty(N_BASE)
    eta = np.empty(nr)
    for s in range(S):
        for i in range(N_BASE):
            x[i] = X[s, i]
        for i in range(nr):
            eta[i] = X[s, ROTORS + i]
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
            for i in range(N_BASE):
                xs[i] = x[i] + 0.5 * h * k1[i]
            _deriv12(xs, sem, se2m, nr, prm, k2)
            for i in range(N_BASE):
                xs[i] = x[i] + 0.5 * h * k2[i]
            _deriv12(xs, sem, se2m, nr, prm, k3)
            for i in range(N_BASE):
                xs[i] = x[i] + h * k3[i]
            _deriv12(xs, se1, se21, nr, prm, k4)
            for i in range(N_BASE):
                x[i] += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])
        for i in range(N_BASE):
            out[s, i] = x[i]
        for i in range(nr):
            out[s, ROTORS + i] = eta[i]
    return out


@njit(cache=True)
def _specific_force(X, prm):
    S, n = X.shape
    nr = n - N_BASE
    out = np.empty((S, 3))
    for s in range(S):
        se, se2 = _rotor_sums(X[s], nr)
        out[s, 0], out[s, 1], out[s, 2] = _specific_force_body(X[s], se, se2, nr, prm)
    return out


@njit(cache=True, inline="always")
def _rotate_euler(psi, theta, phi, vx, vy, vz):
    """``Rz(psi) Ry(theta) Rx(phi) v``."""
    r00, r01, r02, r10, r11, r12, r20, r21, r22 = euler_zyx_to_rotation(psi, theta, phi)
    return (r00 * vx + r01 * vy + r02 * vz, r10 * vx + r11 * vy + r12 * vz,
            r20 * vx + r21 * vy + r22 * vz)


@njit(cache=True)
def _odometry(X):
    S = X.shape[0]
    out = np.empty((S, 6))
    for s in range(S):
        ps, th, ph = X[s, EULER], X[s, EULER + 1], X[s, EULER + 2]
        out[s, 0], out[s, 1], out[s, 2] = _rotate_euler(
            ps, th, ph, X[s, VELOCITY], X[s, VELOCITY + 1], X[s, VELOCITY + 2])
        out[s, 3] = ps
        out[s, 4] = th
        out[s, 5] = ph
    return out


def _check_states(X, name: str, where: str) -> np.ndarray:
    X = np.asarray(X, dtype=np.float64)
    if X.ndim == 1:
        X = X[None]
    if X.ndim != 2 or X.shape[1] < N_BASE + 1:
        raise ValueError(f"The {name!r} parameter of {where} must have shape (S, 12 + N). "
                         f"Got shape {X.shape} instead.")
    return np.ascontiguousarray(X)


def _check_commands(u, X: np.ndarray, where: str) -> np.ndarray:
    """``u`` as a float64 array of one rotor speed per rotor of the states ``X`` (a scalar
    was a Numba TypingError deep inside the kernel)."""
    n = X.shape[1] - N_BASE
    a = np.asarray(u, dtype=np.float64)
    if a.shape != (n,):
        raise ValueError(f"The 'u' parameter of {where} must be an array of the {n} commanded "
                         f"rotor speeds (N,), rad/s. Got shape {a.shape} instead.")
    return np.ascontiguousarray(a)


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
    return _state_derivative(X, _check_commands(u, X, "state_derivative"), prm)


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
    X = _check_states(X, "X", "process")
    return _process(X, float(dt), _check_commands(u, X, "process"), prm, int(n_substeps))


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
    return euler_zyx_to_matrix(np.reshape(np.asarray(euler, dtype=np.float64), (-1, 3)))


# The (Euler angles, body wind) marginal that the world-frame wind depends on.
_WIND_MARGINAL = np.array([EULER, EULER + 1, EULER + 2, WIND, WIND + 1, WIND + 2])


@njit(cache=True)
def _wind_world_sigma(x6, L, wm_, wc_, scale):
    """Unscented transform of ``R(euler) w_b`` from the mean ``x6`` (6,) of (euler, w_b) and
    the lower Cholesky factor ``L`` (6, 6) of its covariance: mean (3,), covariance (3, 3)."""
    X = sigma_from_chol(x6, L, scale)
    W = np.empty((X.shape[0], 3))
    for s in range(X.shape[0]):
        W[s, 0], W[s, 1], W[s, 2] = _rotate_euler(X[s, 0], X[s, 1], X[s, 2],
                                                  X[s, 3], X[s, 4], X[s, 5])
    return unscented(W, wm_, wc_, np.zeros((1, 1)), False)


@njit(cache=True)
def _wind_world_ut(x, P, wm_, wc_, scale):
    """:func:`_wind_world_sigma` over the (euler, w_b) marginal of (x, P).

    Returns (mean (3,), cov (3, 3), ok); ``ok`` is False when the 6x6 marginal is not
    positive definite (the caller repairs it).
    """
    idx = _WIND_MARGINAL
    x6 = np.empty(6)
    A = np.empty((6, 6))
    for i in range(6):
        x6[i] = x[idx[i]]
        for j in range(6):
            A[i, j] = P[idx[i], idx[j]]
    L = np.empty((6, 6))
    if not chol_lower(A, L):
        return np.zeros(3), np.zeros((3, 3)), False
    mean, cov = _wind_world_sigma(x6, L, wm_, wc_, scale)
    return mean, cov, True
