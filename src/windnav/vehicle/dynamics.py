"""Batched multirotor rigid-body dynamics with rotor aerodynamics and first-order motors.

Forces and moments follow the thesis (ch. 2) and RotorPy's ``Multirotor``. With airspeed
``v_a = R^T (v - w)`` in body axes and hub airspeed ``v_a,i = R^T (v - w_i) + Omega x r_i``:

    thrust          T_i   = (k_eta eta_i^2 + L_i) e3
    transl. lift    L_i   = k_h (v_a,i,x^2 + v_a,i,y^2) s_i
    rotor drag      H_i   = -eta_i diag(k_d, k_d, k_z) v_a,i
    parasitic drag  D     = -|v_a| diag(c_dx, c_dy, c_dz) v_a
    flapping moment Mf_i  = -k_flap eta_i (v_a,i x e3)
    yaw moment      My_i  = dir_i k_m eta_i^2 e3
    F_body = sum_i (T_i + H_i) + D
    M_body = sum_i (r_i x (T_i + H_i) + Mf_i + My_i)
    m dv/dt = R F_body - m g e3,   I dOmega/dt = M_body - Omega x I Omega,
    dq/dt   = 0.5 q (x) [Omega, 0],  deta/dt = (clip(eta_cmd) - eta) / tau_m.

Translational lift (``MultirotorParams.translational_lift``):

    "rotorpy" (default)  s_i = 1: RotorPy's model. The lift does not depend on the rotor
                         speed, so far outside its envelope a stopped rotor still lifts (a
                         Crazyflie in a 30 m/s wind climbs with its motors off).
    "bounded"            s_i = min(1, k_eta eta_i^2 / T_ref),  T_ref = m g / N:
                         the lift scales with each rotor's own thrust below the hover thrust
                         per rotor and vanishes when the rotor stops; at or above hover thrust
                         it equals RotorPy's.

The motor equation is linear with a constant command over a step, so it is integrated exactly
(``eta(t) = c + (eta_0 - c) exp(-t / tau_m)``); the rigid body is integrated with classical RK4
over ``substeps`` equal sub-steps, the quaternion renormalised after each step. The rotation
matrix is built from the normalised quaternion (:func:`windnav.vehicle.rotation.quat_to_rotation`,
as ``scipy.spatial.transform.Rotation`` does).

``w_i`` is the wind at each hub: either one wind per vehicle (sampled at the centre of mass,
RotorPy's model) or one per rotor hub, in which case parasitic drag uses the hub average.
All kernels loop over the batch in Numba; parameters may be batched too (Monte Carlo over
vehicles), see :func:`pack_params`. The packed layouts are named in
:mod:`windnav.vehicle.layout`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from windnav._jit import njit
from windnav.vehicle.layout import (
    C_DX,
    C_DY,
    C_DZ,
    K_D,
    K_ETA,
    K_FLAP,
    K_H,
    K_M,
    K_Z,
    LIFT_BOUNDED,
    LIFT_INV_THRUST,
    MASS,
    N_RIGID,
    N_SCALARS,
    QUAT,
    RATES,
    ROTOR_SPEED_MAX,
    ROTOR_SPEED_MIN,
    ROTORS,
    TAU_M,
    VEL,
    G,
    column,
)
from windnav.vehicle.params import GRAVITY, MultirotorParams
from windnav.vehicle.rotation import quat_to_rotation


def _column_property(index: int, doc: str) -> property:
    return property(lambda self: column(self.scalars, index), doc=doc)


@dataclass(frozen=True, eq=False)
class PackedParams:
    """Parameters as contiguous arrays for the kernels; leading axis P = 1 or B.

    Attributes
    ----------
    scalars : ndarray of shape (P, N_SCALARS)
        One row per vehicle, columns named in :mod:`windnav.vehicle.layout` (mass, k_eta, k_m,
        k_d, k_z, k_h, k_flap, c_dx, c_dy, c_dz, tau_m, eta_min, eta_max, g, lift_bounded,
        lift_inv_thrust); read them with the accessors below (``packed.k_eta``).
    inertia, inertia_inv : ndarray of shape (P, 3, 3)
    rotor_positions : ndarray of shape (P, N, 3)
    rotor_directions : ndarray of shape (P, N)
    """

    scalars: np.ndarray
    inertia: np.ndarray
    inertia_inv: np.ndarray
    rotor_positions: np.ndarray
    rotor_directions: np.ndarray

    mass = _column_property(MASS, "Mass (P,), kg.")
    k_eta = _column_property(K_ETA, "Thrust coefficient (P,), N/(rad/s)^2.")
    k_m = _column_property(K_M, "Yaw-moment coefficient (P,), N m/(rad/s)^2.")
    k_d = _column_property(K_D, "In-plane rotor drag (P,), kg/rad (0 with aero=False).")
    k_z = _column_property(K_Z, "Axial rotor drag (P,), kg/rad (0 with aero=False).")
    k_h = _column_property(K_H, "Translational lift (P,), kg/m (0 with aero=False).")
    tau_m = _column_property(TAU_M, "Motor time constant (P,), s.")
    rotor_speed_min = _column_property(ROTOR_SPEED_MIN, "Lower rotor-speed limit (P,), rad/s.")
    rotor_speed_max = _column_property(ROTOR_SPEED_MAX, "Upper rotor-speed limit (P,), rad/s.")
    gravity = _column_property(G, "Gravitational acceleration (P,), m/s^2 (0 with "
                                  "gravity=False).")

    @property
    def n_rotors(self) -> int:
        return int(self.rotor_positions.shape[1])

    @property
    def size(self) -> int:
        return int(self.scalars.shape[0])

    @property
    def hover_rotor_speed(self) -> np.ndarray:
        """Speed (P,) at which N equal rotors carry ``mass * gravity`` in still air, rad/s."""
        return np.sqrt(self.mass * self.gravity / (self.n_rotors * self.k_eta))


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
    plist = [params] if isinstance(params, MultirotorParams) else (
        list(params) if isinstance(params, Sequence) and not isinstance(params, str)
        else [params])
    if not plist:
        raise ValueError("The 'params' parameter of pack_params must not be empty.")
    bad = [type(p).__name__ for p in plist if not isinstance(p, MultirotorParams)]
    if bad:
        raise ValueError("The 'params' parameter of pack_params must be MultirotorParams (e.g. "
                         f"windnav.vehicle.params('hummingbird')) or a list of them. Got "
                         f"{bad[0]} instead.")
    n = plist[0].n_rotors
    if any(p.n_rotors != n for p in plist):
        raise ValueError(
            "The 'params' parameter of pack_params must hold vehicles with the same rotor count. "
            f"Got {[p.n_rotors for p in plist]} instead."
        )
    a = 1.0 if aero else 0.0
    scalars = np.empty((len(plist), N_SCALARS))
    for row, p in zip(scalars, plist, strict=True):
        row[MASS] = p.mass
        row[K_ETA] = p.k_eta
        row[K_M] = p.k_m
        row[K_D] = a * p.k_d
        row[K_Z] = a * p.k_z
        row[K_H] = a * p.k_h
        row[K_FLAP] = a * p.k_flap
        row[C_DX] = a * p.c_dx
        row[C_DY] = a * p.c_dy
        row[C_DZ] = a * p.c_dz
        row[TAU_M] = p.tau_m
        row[ROTOR_SPEED_MIN] = p.rotor_speed_min
        row[ROTOR_SPEED_MAX] = p.rotor_speed_max
        row[G] = GRAVITY if gravity else 0.0
        row[LIFT_BOUNDED] = 1.0 if p.translational_lift == "bounded" else 0.0
        row[LIFT_INV_THRUST] = 1.0 / p.hover_thrust_per_rotor
    inertia = np.stack([p.inertia for p in plist])
    return PackedParams(
        scalars=np.ascontiguousarray(scalars),
        inertia=np.ascontiguousarray(inertia),
        inertia_inv=np.ascontiguousarray(np.linalg.inv(inertia)),
        rotor_positions=np.ascontiguousarray(np.stack([p.rotor_positions for p in plist])),
        rotor_directions=np.ascontiguousarray(np.stack([p.rotor_directions for p in plist])),
    )


# --------------------------------------------------------------------------------------------
# Kernels. Vehicles are processed in blocks of BLOCK in structure-of-arrays layout (component
# first, vehicle last) so that every inner loop runs over vehicles with unit stride and no
# branches, which LLVM turns into SIMD code. Each kernel allocates its block arrays itself
# (a helper returning them as a tuple cost ~0.5 us per call, 15% of a one-vehicle step).
# Rigid-body rows of a block are those of the packed state (layout.POS, VEL, QUAT, RATES); R
# holds the rotation matrix row-major (9, n).

BLOCK = 64


@njit(cache=True)
def _gather_params(scalars, inertia, inertia_inv, rpos, rdir, b0, n, sc, I, Iinv, rp, rd):
    """Per-vehicle parameters of the block ``b0 : b0 + n`` in SoA layout."""
    P = scalars.shape[0]
    n_rot = rpos.shape[1]
    for j in range(n):
        p = b0 + j if P > 1 else 0
        for k in range(N_SCALARS):
            sc[k, j] = scalars[p, k]
        for r in range(3):
            for c in range(3):
                I[3 * r + c, j] = inertia[p, r, c]
                Iinv[3 * r + c, j] = inertia_inv[p, r, c]
        for i in range(n_rot):
            rd[i, j] = rdir[p, i]
            for c in range(3):
                rp[i, c, j] = rpos[p, i, c]


@njit(cache=True, inline="always")
def _rotation_block(y, n, R):
    """Rotation matrices (body to world) of the block's quaternions into ``R`` (9, n)."""
    for j in range(n):
        (R[0, j], R[1, j], R[2, j], R[3, j], R[4, j], R[5, j], R[6, j], R[7, j],
         R[8, j]) = quat_to_rotation(y[QUAT, j], y[QUAT + 1, j], y[QUAT + 2, j], y[QUAT + 3, j])


@njit(cache=True, inline="always")
def _hub_airspeed(R, y, wh, rp, i, j):
    """Body-frame airspeed of rotor ``i`` of vehicle ``j``: ``R^T (v - w_i) + Omega x r_i``."""
    o0 = y[RATES, j]
    o1 = y[RATES + 1, j]
    o2 = y[RATES + 2, j]
    rx = rp[i, 0, j]
    ry = rp[i, 1, j]
    rz = rp[i, 2, j]
    e0 = y[VEL, j] - wh[i, 0, j]
    e1 = y[VEL + 1, j] - wh[i, 1, j]
    e2 = y[VEL + 2, j] - wh[i, 2, j]
    vx = R[0, j] * e0 + R[3, j] * e1 + R[6, j] * e2 + (o1 * rz - o2 * ry)
    vy = R[1, j] * e0 + R[4, j] * e1 + R[7, j] * e2 + (o2 * rx - o0 * rz)
    vz = R[2, j] * e0 + R[5, j] * e1 + R[8, j] * e2 + (o0 * ry - o1 * rx)
    return vx, vy, vz


@njit(cache=True, inline="always")
def _translational_lift(sc, j, thrust, vx, vy):
    """``L_i = k_h (v_x^2 + v_y^2) s_i`` with ``s_i = 1`` (RotorPy) or ``min(1, T_i / T_ref)``
    (bounded), selected without a branch by the LIFT_BOUNDED column (0 or 1)."""
    b = sc[LIFT_BOUNDED, j]
    scale = min(1.0, 1.0 - b + b * thrust * sc[LIFT_INV_THRUST, j])
    return sc[K_H, j] * (vx * vx + vy * vy) * scale


@njit(cache=True)
def _deriv_block(sc, I, Iinv, rp, rd, y, eta, wc, wh, n, dy, R, F, M):
    """Rigid-body derivative ``dy`` (13, n), body force F (3, n) and moment M (3, n)."""
    n_rot = rp.shape[0]
    _rotation_block(y, n, R)
    for j in range(n):
        # parasitic drag at the centre of mass: D = -|v_a| diag(c) v_a, v_a = R^T (v - w)
        d0 = y[VEL, j] - wc[0, j]
        d1 = y[VEL + 1, j] - wc[1, j]
        d2 = y[VEL + 2, j] - wc[2, j]
        ax = R[0, j] * d0 + R[3, j] * d1 + R[6, j] * d2
        ay = R[1, j] * d0 + R[4, j] * d1 + R[7, j] * d2
        az = R[2, j] * d0 + R[5, j] * d1 + R[8, j] * d2
        speed = np.sqrt(ax * ax + ay * ay + az * az)
        F[0, j] = -speed * sc[C_DX, j] * ax
        F[1, j] = -speed * sc[C_DY, j] * ay
        F[2, j] = -speed * sc[C_DZ, j] * az
        M[0, j] = 0.0
        M[1, j] = 0.0
        M[2, j] = 0.0
    for i in range(n_rot):
        for j in range(n):
            vx, vy, vz = _hub_airspeed(R, y, wh, rp, i, j)
            rx = rp[i, 0, j]
            ry = rp[i, 1, j]
            rz = rp[i, 2, j]
            et = eta[i, j]
            kd_et = sc[K_D, j] * et
            fx = -kd_et * vx
            fy = -kd_et * vy
            thrust = sc[K_ETA, j] * et * et
            fz = thrust + _translational_lift(sc, j, thrust, vx, vy) - et * sc[K_Z, j] * vz
            kf_et = sc[K_FLAP, j] * et
            F[0, j] += fx
            F[1, j] += fy
            F[2, j] += fz
            M[0, j] += ry * fz - rz * fy - kf_et * vy
            M[1, j] += rz * fx - rx * fz + kf_et * vx
            M[2, j] += rx * fy - ry * fx + rd[i, j] * sc[K_M, j] * et * et
    for j in range(n):
        m = sc[MASS, j]
        f0 = F[0, j]
        f1 = F[1, j]
        f2 = F[2, j]
        dy[0, j] = y[VEL, j]
        dy[1, j] = y[VEL + 1, j]
        dy[2, j] = y[VEL + 2, j]
        dy[VEL, j] = (R[0, j] * f0 + R[1, j] * f1 + R[2, j] * f2) / m
        dy[VEL + 1, j] = (R[3, j] * f0 + R[4, j] * f1 + R[5, j] * f2) / m
        dy[VEL + 2, j] = (R[6, j] * f0 + R[7, j] * f1 + R[8, j] * f2) / m - sc[G, j]
        q0 = y[QUAT, j]
        q1 = y[QUAT + 1, j]
        q2 = y[QUAT + 2, j]
        q3 = y[QUAT + 3, j]
        w0 = y[RATES, j]
        w1 = y[RATES + 1, j]
        w2 = y[RATES + 2, j]
        dy[QUAT, j] = 0.5 * (q3 * w0 - q2 * w1 + q1 * w2)
        dy[QUAT + 1, j] = 0.5 * (q2 * w0 + q3 * w1 - q0 * w2)
        dy[QUAT + 2, j] = 0.5 * (-q1 * w0 + q0 * w1 + q3 * w2)
        dy[QUAT + 3, j] = 0.5 * (-q0 * w0 - q1 * w1 - q2 * w2)
        # I dOmega = M - Omega x I Omega
        h0 = I[0, j] * w0 + I[1, j] * w1 + I[2, j] * w2
        h1 = I[3, j] * w0 + I[4, j] * w1 + I[5, j] * w2
        h2 = I[6, j] * w0 + I[7, j] * w1 + I[8, j] * w2
        t0 = M[0, j] - (w1 * h2 - w2 * h1)
        t1 = M[1, j] - (w2 * h0 - w0 * h2)
        t2 = M[2, j] - (w0 * h1 - w1 * h0)
        dy[RATES, j] = Iinv[0, j] * t0 + Iinv[1, j] * t1 + Iinv[2, j] * t2
        dy[RATES + 1, j] = Iinv[3, j] * t0 + Iinv[4, j] * t1 + Iinv[5, j] * t2
        dy[RATES + 2, j] = Iinv[6, j] * t0 + Iinv[7, j] * t1 + Iinv[8, j] * t2


@njit(cache=True)
def _load_block(x, wind_com, wind_hub, b0, n, y, eta0, wc, wh):
    n_rot = eta0.shape[0]
    for j in range(n):
        b = b0 + j
        for c in range(N_RIGID):
            y[c, j] = x[b, c]
        for i in range(n_rot):
            eta0[i, j] = x[b, ROTORS + i]
            for c in range(3):
                wh[i, c, j] = wind_hub[b, i, c]
        for c in range(3):
            wc[c, j] = wind_com[b, c]


@njit(cache=True)
def step_kernel(scalars, inertia, inertia_inv, rpos, rdir, x, eta_cmd, wind_com, wind_hub,
                dt, substeps, out):
    """Advance packed states ``x`` (B, 13 + N) by ``dt``; write into ``out``.

    ``eta_cmd`` (B, N) is clipped to the rotor limits; ``wind_com`` (B, 3) and
    ``wind_hub`` (B, N, 3) are world-frame winds held constant over the step.
    """
    B = x.shape[0]
    n_rot = rpos.shape[1]
    h = dt / substeps
    nb = min(B, BLOCK)
    sc = np.empty((N_SCALARS, nb))
    I = np.empty((9, nb))
    Iinv = np.empty((9, nb))
    rp = np.empty((n_rot, 3, nb))
    rd = np.empty((n_rot, nb))
    y = np.empty((N_RIGID, nb))
    eta0 = np.empty((n_rot, nb))
    R = np.empty((9, nb))
    F = np.empty((3, nb))
    M = np.empty((3, nb))
    wc = np.empty((3, nb))
    wh = np.empty((n_rot, 3, nb))
    yt = np.empty((N_RIGID, nb))
    k1 = np.empty((N_RIGID, nb))
    k2 = np.empty((N_RIGID, nb))
    k3 = np.empty((N_RIGID, nb))
    k4 = np.empty((N_RIGID, nb))
    cmd = np.empty((n_rot, nb))
    eta_a = np.empty((n_rot, nb))
    eta_b = np.empty((n_rot, nb))
    eta_c = np.empty((n_rot, nb))
    half = np.empty(nb)
    decay = np.empty(nb)
    for b0 in range(0, B, nb):
        n = min(nb, B - b0)
        _gather_params(scalars, inertia, inertia_inv, rpos, rdir, b0, n, sc, I, Iinv, rp, rd)
        _load_block(x, wind_com, wind_hub, b0, n, y, eta0, wc, wh)
        for i in range(n_rot):
            for j in range(n):
                cmd[i, j] = min(max(eta_cmd[b0 + j, i], sc[ROTOR_SPEED_MIN, j]),
                                sc[ROTOR_SPEED_MAX, j])
        for j in range(n):
            half[j] = np.exp(-0.5 * h / sc[TAU_M, j])
            decay[j] = 1.0
        for _ in range(substeps):
            # exact motor speeds at the start, middle and end of the sub-step
            for i in range(n_rot):
                for j in range(n):
                    c = cmd[i, j]
                    e = eta0[i, j] - c
                    eta_a[i, j] = c + e * decay[j]
                    eta_b[i, j] = c + e * decay[j] * half[j]
                    eta_c[i, j] = c + e * decay[j] * half[j] * half[j]
            for j in range(n):
                decay[j] *= half[j] * half[j]
            _deriv_block(sc, I, Iinv, rp, rd, y, eta_a, wc, wh, n, k1, R, F, M)
            for c in range(N_RIGID):
                for j in range(n):
                    yt[c, j] = y[c, j] + 0.5 * h * k1[c, j]
            _deriv_block(sc, I, Iinv, rp, rd, yt, eta_b, wc, wh, n, k2, R, F, M)
            for c in range(N_RIGID):
                for j in range(n):
                    yt[c, j] = y[c, j] + 0.5 * h * k2[c, j]
            _deriv_block(sc, I, Iinv, rp, rd, yt, eta_b, wc, wh, n, k3, R, F, M)
            for c in range(N_RIGID):
                for j in range(n):
                    yt[c, j] = y[c, j] + h * k3[c, j]
            _deriv_block(sc, I, Iinv, rp, rd, yt, eta_c, wc, wh, n, k4, R, F, M)
            for c in range(N_RIGID):
                for j in range(n):
                    y[c, j] += h / 6.0 * (k1[c, j] + 2.0 * k2[c, j] + 2.0 * k3[c, j] + k4[c, j])
            for j in range(n):
                qn = np.sqrt(y[QUAT, j] * y[QUAT, j] + y[QUAT + 1, j] * y[QUAT + 1, j]
                             + y[QUAT + 2, j] * y[QUAT + 2, j] + y[QUAT + 3, j] * y[QUAT + 3, j])
                y[QUAT, j] /= qn
                y[QUAT + 1, j] /= qn
                y[QUAT + 2, j] /= qn
                y[QUAT + 3, j] /= qn
        for j in range(n):
            b = b0 + j
            for c in range(N_RIGID):
                out[b, c] = y[c, j]
            full = np.exp(-dt / sc[TAU_M, j])
            for i in range(n_rot):
                out[b, ROTORS + i] = cmd[i, j] + (eta0[i, j] - cmd[i, j]) * full


@njit(cache=True)
def derivative_kernel(scalars, inertia, inertia_inv, rpos, rdir, x, wind_com, wind_hub,
                      out_dy, out_force, out_moment):
    """Rigid-body derivative (B, 13), body force (B, 3) and moment (B, 3) at states ``x``."""
    B = x.shape[0]
    n_rot = rpos.shape[1]
    nb = min(B, BLOCK)
    sc = np.empty((N_SCALARS, nb))
    I = np.empty((9, nb))
    Iinv = np.empty((9, nb))
    rp = np.empty((n_rot, 3, nb))
    rd = np.empty((n_rot, nb))
    y = np.empty((N_RIGID, nb))
    eta = np.empty((n_rot, nb))
    R = np.empty((9, nb))
    F = np.empty((3, nb))
    M = np.empty((3, nb))
    wc = np.empty((3, nb))
    wh = np.empty((n_rot, 3, nb))
    dy = np.empty((N_RIGID, nb))
    for b0 in range(0, B, nb):
        n = min(nb, B - b0)
        _gather_params(scalars, inertia, inertia_inv, rpos, rdir, b0, n, sc, I, Iinv, rp, rd)
        _load_block(x, wind_com, wind_hub, b0, n, y, eta, wc, wh)
        _deriv_block(sc, I, Iinv, rp, rd, y, eta, wc, wh, n, dy, R, F, M)
        for j in range(n):
            for c in range(N_RIGID):
                out_dy[b0 + j, c] = dy[c, j]
            for c in range(3):
                out_force[b0 + j, c] = F[c, j]
                out_moment[b0 + j, c] = M[c, j]


@njit(cache=True)
def rotor_loads_kernel(scalars, inertia, inertia_inv, rpos, rdir, x, wind_com, wind_hub,
                       out_thrust, out_lift):
    """Per-rotor thrust ``k_eta eta_i^2`` and translational lift ``L_i`` (B, N), N, at the
    packed states ``x`` (the same hub airspeed and lift law as the dynamics)."""
    B = x.shape[0]
    n_rot = rpos.shape[1]
    nb = min(B, BLOCK)
    sc = np.empty((N_SCALARS, nb))
    I = np.empty((9, nb))
    Iinv = np.empty((9, nb))
    rp = np.empty((n_rot, 3, nb))
    rd = np.empty((n_rot, nb))
    y = np.empty((N_RIGID, nb))
    eta = np.empty((n_rot, nb))
    R = np.empty((9, nb))
    wc = np.empty((3, nb))
    wh = np.empty((n_rot, 3, nb))
    for b0 in range(0, B, nb):
        n = min(nb, B - b0)
        _gather_params(scalars, inertia, inertia_inv, rpos, rdir, b0, n, sc, I, Iinv, rp, rd)
        _load_block(x, wind_com, wind_hub, b0, n, y, eta, wc, wh)
        _rotation_block(y, n, R)
        for i in range(n_rot):
            for j in range(n):
                vx, vy, _ = _hub_airspeed(R, y, wh, rp, i, j)
                thrust = sc[K_ETA, j] * eta[i, j] * eta[i, j]
                out_thrust[b0 + j, i] = thrust
                out_lift[b0 + j, i] = _translational_lift(sc, j, thrust, vx, vy)
