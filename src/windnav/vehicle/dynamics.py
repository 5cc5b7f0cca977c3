"""Batched multirotor rigid-body dynamics with rotor aerodynamics and first-order motors.

Forces and moments follow the thesis (ch. 2) and RotorPy's ``Multirotor``. With airspeed
``v_a = R^T (v - w)`` in body axes and hub airspeed ``v_a,i = R^T (v - w_i) + Omega x r_i``:

    thrust          T_i   = (k_eta eta_i^2 + k_h (v_a,i,x^2 + v_a,i,y^2)) e3
    rotor drag      H_i   = -eta_i diag(k_d, k_d, k_z) v_a,i
    parasitic drag  D     = -|v_a| diag(c_dx, c_dy, c_dz) v_a
    flapping moment Mf_i  = -k_flap eta_i (v_a,i x e3)
    yaw moment      My_i  = dir_i k_m eta_i^2 e3
    F_body = sum_i (T_i + H_i) + D
    M_body = sum_i (r_i x (T_i + H_i) + Mf_i + My_i)
    m dv/dt = R F_body - m g e3,   I dOmega/dt = M_body - Omega x I Omega,
    dq/dt   = 0.5 q (x) [Omega, 0],  deta/dt = (clip(eta_cmd) - eta) / tau_m.

The motor equation is linear with a constant command over a step, so it is integrated exactly
(``eta(t) = c + (eta_0 - c) exp(-t / tau_m)``); the rigid body is integrated with classical RK4
over ``substeps`` equal sub-steps, the quaternion renormalised after each step. The rotation
matrix is built from the normalised quaternion (as ``scipy.spatial.transform.Rotation`` does).

``w_i`` is the wind at each hub: either one wind per vehicle (sampled at the centre of mass,
RotorPy's model) or one per rotor hub, in which case parasitic drag uses the hub average.
All kernels loop over the batch in Numba; parameters may be batched too (Monte Carlo over
vehicles), see :func:`pack_params`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numba
import numpy as np

from windnav.vehicle.params import GRAVITY, MultirotorParams

# Layout of the per-vehicle scalar parameter row.
_MASS, _KETA, _KM, _KD, _KZ, _KH, _KFLAP, _CDX, _CDY, _CDZ, _TAU, _WMIN, _WMAX, _G = range(14)
N_SCALARS = 14


@dataclass(frozen=True, eq=False)
class PackedParams:
    """Parameters as contiguous arrays for the kernels; leading axis P = 1 or B.

    Attributes
    ----------
    scalars : ndarray of shape (P, 14)
        mass, k_eta, k_m, k_d, k_z, k_h, k_flap, c_dx, c_dy, c_dz, tau_m, eta_min, eta_max, g.
    inertia, inertia_inv : ndarray of shape (P, 3, 3)
    rotor_positions : ndarray of shape (P, N, 3)
    rotor_directions : ndarray of shape (P, N)
    """

    scalars: np.ndarray
    inertia: np.ndarray
    inertia_inv: np.ndarray
    rotor_positions: np.ndarray
    rotor_directions: np.ndarray

    @property
    def n_rotors(self) -> int:
        return int(self.rotor_positions.shape[1])

    @property
    def size(self) -> int:
        return int(self.scalars.shape[0])


def pack_params(
    params: MultirotorParams | Sequence[MultirotorParams],
    *,
    aero: bool = True,
    gravity: bool = True,
) -> PackedParams:
    """Pack one or a batch of vehicles (same rotor count) into kernel arrays.

    ``aero=False`` zeroes every aerodynamic coefficient (k_d, k_z, k_h, k_flap, c_d);
    ``gravity=False`` sets g = 0.
    """
    plist = [params] if isinstance(params, MultirotorParams) else list(params)
    if not plist:
        raise ValueError("The 'params' parameter of pack_params must not be empty.")
    n = plist[0].n_rotors
    if any(p.n_rotors != n for p in plist):
        raise ValueError(
            "The 'params' parameter of pack_params must hold vehicles with the same rotor count. "
            f"Got {[p.n_rotors for p in plist]} instead."
        )
    a = 1.0 if aero else 0.0
    scalars = np.array([
        [p.mass, p.k_eta, p.k_m, a * p.k_d, a * p.k_z, a * p.k_h, a * p.k_flap,
         a * p.c_dx, a * p.c_dy, a * p.c_dz, p.tau_m, p.rotor_speed_min, p.rotor_speed_max,
         GRAVITY if gravity else 0.0]
        for p in plist
    ])
    inertia = np.stack([p.inertia for p in plist])
    return PackedParams(
        scalars=np.ascontiguousarray(scalars),
        inertia=np.ascontiguousarray(inertia),
        inertia_inv=np.ascontiguousarray(np.linalg.inv(inertia)),
        rotor_positions=np.ascontiguousarray(np.stack([p.rotor_positions for p in plist])),
        rotor_directions=np.ascontiguousarray(np.stack([p.rotor_directions for p in plist])),
    )


# --------------------------------------------------------------------------------------------
# Kernels. Rigid-body state y (13,): position(3), velocity(3), quaternion xyzw(4), rates(3).


@numba.njit(cache=True, inline="always")
def _rotation(s, R):
    """Rotation matrix (body -> world) of the normalised quaternion xyzw in ``s[6:10]``."""
    n = np.sqrt(s[6] * s[6] + s[7] * s[7] + s[8] * s[8] + s[9] * s[9])
    x = s[6] / n
    y = s[7] / n
    z = s[8] / n
    w = s[9] / n
    R[0, 0] = 1.0 - 2.0 * (y * y + z * z)
    R[0, 1] = 2.0 * (x * y - z * w)
    R[0, 2] = 2.0 * (x * z + y * w)
    R[1, 0] = 2.0 * (x * y + z * w)
    R[1, 1] = 1.0 - 2.0 * (x * x + z * z)
    R[1, 2] = 2.0 * (y * z - x * w)
    R[2, 0] = 2.0 * (x * z - y * w)
    R[2, 1] = 2.0 * (y * z + x * w)
    R[2, 2] = 1.0 - 2.0 * (x * x + y * y)


@numba.njit(cache=True)
def _wrench(sc, rpos, rdir, R, y, eta, wind_com, wind_hub, F, M):
    """Body-frame force F (3,) and moment M (3,) (aerodynamics included)."""
    n_rot = eta.shape[0]
    keta = sc[_KETA]
    km = sc[_KM]
    kd = sc[_KD]
    kz = sc[_KZ]
    kh = sc[_KH]
    kflap = sc[_KFLAP]
    for j in range(3):
        F[j] = 0.0
        M[j] = 0.0
    # parasitic drag at the centre of mass
    v0 = y[3]
    v1 = y[4]
    v2 = y[5]
    o0 = y[10]
    o1 = y[11]
    o2 = y[12]
    d0 = v0 - wind_com[0]
    d1 = v1 - wind_com[1]
    d2 = v2 - wind_com[2]
    ax = R[0, 0] * d0 + R[1, 0] * d1 + R[2, 0] * d2
    ay = R[0, 1] * d0 + R[1, 1] * d1 + R[2, 1] * d2
    az = R[0, 2] * d0 + R[1, 2] * d1 + R[2, 2] * d2
    speed = np.sqrt(ax * ax + ay * ay + az * az)
    F[0] = -speed * sc[_CDX] * ax
    F[1] = -speed * sc[_CDY] * ay
    F[2] = -speed * sc[_CDZ] * az
    for i in range(n_rot):
        e0 = v0 - wind_hub[i, 0]
        e1 = v1 - wind_hub[i, 1]
        e2 = v2 - wind_hub[i, 2]
        rx = rpos[i, 0]
        ry = rpos[i, 1]
        rz = rpos[i, 2]
        # hub airspeed, body frame: R^T (v - w_i) + Omega x r_i
        vx = R[0, 0] * e0 + R[1, 0] * e1 + R[2, 0] * e2 + (o1 * rz - o2 * ry)
        vy = R[0, 1] * e0 + R[1, 1] * e1 + R[2, 1] * e2 + (o2 * rx - o0 * rz)
        vz = R[0, 2] * e0 + R[1, 2] * e1 + R[2, 2] * e2 + (o0 * ry - o1 * rx)
        et = eta[i]
        fx = -et * kd * vx
        fy = -et * kd * vy
        fz = keta * et * et + kh * (vx * vx + vy * vy) - et * kz * vz
        F[0] += fx
        F[1] += fy
        F[2] += fz
        M[0] += ry * fz - rz * fy - kflap * et * vy
        M[1] += rz * fx - rx * fz + kflap * et * vx
        M[2] += rx * fy - ry * fx + rdir[i] * km * et * et


@numba.njit(cache=True)
def _rigid_deriv(sc, I, Iinv, rpos, rdir, y, eta, wind_com, wind_hub, dy, R, F, M):
    """dy/dt of the 13-vector rigid-body state."""
    _rotation(y, R)
    _wrench(sc, rpos, rdir, R, y, eta, wind_com, wind_hub, F, M)
    m = sc[_MASS]
    dy[0] = y[3]
    dy[1] = y[4]
    dy[2] = y[5]
    dy[3] = (R[0, 0] * F[0] + R[0, 1] * F[1] + R[0, 2] * F[2]) / m
    dy[4] = (R[1, 0] * F[0] + R[1, 1] * F[1] + R[1, 2] * F[2]) / m
    dy[5] = (R[2, 0] * F[0] + R[2, 1] * F[1] + R[2, 2] * F[2]) / m - sc[_G]
    q0, q1, q2, q3 = y[6], y[7], y[8], y[9]
    w0, w1, w2 = y[10], y[11], y[12]
    dy[6] = 0.5 * (q3 * w0 - q2 * w1 + q1 * w2)
    dy[7] = 0.5 * (q2 * w0 + q3 * w1 - q0 * w2)
    dy[8] = 0.5 * (-q1 * w0 + q0 * w1 + q3 * w2)
    dy[9] = 0.5 * (-q0 * w0 - q1 * w1 - q2 * w2)
    # I dOmega = M - Omega x I Omega
    h0 = I[0, 0] * w0 + I[0, 1] * w1 + I[0, 2] * w2
    h1 = I[1, 0] * w0 + I[1, 1] * w1 + I[1, 2] * w2
    h2 = I[2, 0] * w0 + I[2, 1] * w1 + I[2, 2] * w2
    t0 = M[0] - (w1 * h2 - w2 * h1)
    t1 = M[1] - (w2 * h0 - w0 * h2)
    t2 = M[2] - (w0 * h1 - w1 * h0)
    dy[10] = Iinv[0, 0] * t0 + Iinv[0, 1] * t1 + Iinv[0, 2] * t2
    dy[11] = Iinv[1, 0] * t0 + Iinv[1, 1] * t1 + Iinv[1, 2] * t2
    dy[12] = Iinv[2, 0] * t0 + Iinv[2, 1] * t1 + Iinv[2, 2] * t2


@numba.njit(cache=True, inline="always")
def _motor(eta0, cmd, decay, out):
    """Exact first-order response: ``cmd + (eta0 - cmd) * decay`` with decay = exp(-t/tau)."""
    for i in range(eta0.shape[0]):
        out[i] = cmd[i] + (eta0[i] - cmd[i]) * decay


@numba.njit(cache=True)
def step_kernel(scalars, inertia, inertia_inv, rpos, rdir, x, eta_cmd, wind_com, wind_hub,
                dt, substeps, out):
    """Advance packed states ``x`` (B, 13 + N) by ``dt``; write into ``out``.

    ``eta_cmd`` (B, N) is clipped to the rotor limits; ``wind_com`` (B, 3) and
    ``wind_hub`` (B, N, 3) are world-frame winds held constant over the step.
    """
    B = x.shape[0]
    n_rot = rpos.shape[1]
    P = scalars.shape[0]
    h = dt / substeps
    y = np.empty(13)
    yt = np.empty(13)
    k1 = np.empty(13)
    k2 = np.empty(13)
    k3 = np.empty(13)
    k4 = np.empty(13)
    R = np.empty((3, 3))
    F = np.empty(3)
    M = np.empty(3)
    cmd = np.empty(n_rot)
    eta0 = np.empty(n_rot)
    eta_a = np.empty(n_rot)
    eta_b = np.empty(n_rot)
    eta_c = np.empty(n_rot)
    for b in range(B):
        p = b if P > 1 else 0
        sc = scalars[p]
        I = inertia[p]
        Iinv = inertia_inv[p]
        rp = rpos[p]
        rd = rdir[p]
        tau = sc[_TAU]
        for i in range(n_rot):
            c = eta_cmd[b, i]
            c = min(max(c, sc[_WMIN]), sc[_WMAX])
            cmd[i] = c
            eta0[i] = x[b, 13 + i]
        for j in range(13):
            y[j] = x[b, j]
        wc = wind_com[b]
        wh = wind_hub[b]
        half = np.exp(-0.5 * h / tau)
        full = half * half
        decay = 1.0
        for _ in range(substeps):
            _motor(eta0, cmd, decay, eta_a)
            _motor(eta0, cmd, decay * half, eta_b)
            decay *= full
            _motor(eta0, cmd, decay, eta_c)
            _rigid_deriv(sc, I, Iinv, rp, rd, y, eta_a, wc, wh, k1, R, F, M)
            for j in range(13):
                yt[j] = y[j] + 0.5 * h * k1[j]
            _rigid_deriv(sc, I, Iinv, rp, rd, yt, eta_b, wc, wh, k2, R, F, M)
            for j in range(13):
                yt[j] = y[j] + 0.5 * h * k2[j]
            _rigid_deriv(sc, I, Iinv, rp, rd, yt, eta_b, wc, wh, k3, R, F, M)
            for j in range(13):
                yt[j] = y[j] + h * k3[j]
            _rigid_deriv(sc, I, Iinv, rp, rd, yt, eta_c, wc, wh, k4, R, F, M)
            for j in range(13):
                y[j] += h / 6.0 * (k1[j] + 2.0 * k2[j] + 2.0 * k3[j] + k4[j])
            qn = np.sqrt(y[6] * y[6] + y[7] * y[7] + y[8] * y[8] + y[9] * y[9])
            for j in range(6, 10):
                y[j] /= qn
        _motor(eta0, cmd, np.exp(-dt / tau), eta_c)
        for j in range(13):
            out[b, j] = y[j]
        for i in range(n_rot):
            out[b, 13 + i] = eta_c[i]


@numba.njit(cache=True)
def derivative_kernel(scalars, inertia, inertia_inv, rpos, rdir, x, wind_com, wind_hub,
                      out_dy, out_force, out_moment):
    """Rigid-body derivative (B, 13), body force (B, 3) and moment (B, 3) at states ``x``."""
    B = x.shape[0]
    P = scalars.shape[0]
    R = np.empty((3, 3))
    for b in range(B):
        p = b if P > 1 else 0
        _rigid_deriv(scalars[p], inertia[p], inertia_inv[p], rpos[p], rdir[p], x[b],
                     x[b, 13:], wind_com[b], wind_hub[b], out_dy[b], R, out_force[b],
                     out_moment[b])
