"""SE(3) geometric tracking control (Lee, Leok, McClamroch 2010; RotorPy's ``SE3Control``).

Position mode::

    F_des = m (-K_p (p - p_d) - K_d (v - v_d) + a_d + g e3)

Acceleration-command mode (the planner's interface)::

    F_des = m (a_cmd + g e3)

Then, with c1 = [cos psi_d, sin psi_d, 0]::

    u1 = F_des . R e3,   b3_d = F_des / |F_des|,
    b2_d = b3_d x c1 / |b3_d x c1|,  b1_d = b2_d x b3_d
    e_R = 0.5 vee(R_d^T R - R^T R_d),   e_w = Omega - [0, 0, psi_dot_d]
    u2 = I (-k_R e_R - k_w e_w) + Omega x I Omega

and the wrench ``[u1, u2]`` is allocated to rotor thrusts with the (pseudo-)inverse of the
allocation matrix, then to speeds ``eta_i = sqrt(max(T_i, 0) / k_eta)``. Saturation is applied
by the vehicle; the runner records it.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from windnav._jit import njit
from windnav.vehicle.dynamics import PackedParams, pack_params
from windnav.vehicle.layout import (
    ATTITUDE,
    K_ETA,
    MASS,
    N_RIGID,
    POS,
    QUAT,
    RATES,
    ROTORS,
    VEL,
    G,
)
from windnav.vehicle.params import MultirotorParams
from windnav.vehicle.rotation import quat_to_rotation

# Layout of SE3Gains.as_array(), the gains the kernel reads.
GAIN_KP_POS = 0  # 3 entries
GAIN_KD_POS = 3  # 3 entries
GAIN_KP_ATT = 6
GAIN_KD_ATT = 7


@dataclass(frozen=True)
class SE3Gains:
    """Gains of the SE(3) controller.

    Attributes
    ----------
    kp_pos : tuple of 3 float
        Position gains, 1/s^2.
    kd_pos : tuple of 3 float
        Velocity gains, 1/s.
    kp_att : float
        Attitude gain (multiplies the inertia), 1/s^2.
    kd_att : float
        Body-rate gain (multiplies the inertia), 1/s.
    """

    kp_pos: tuple = (6.5, 6.5, 15.0)
    kd_pos: tuple = (4.0, 4.0, 9.0)
    kp_att: float = 544.0
    kd_att: float = 46.64
    extra: dict = field(default_factory=dict)

    def as_array(self) -> np.ndarray:
        """``[kp_x, kp_y, kp_z, kd_x, kd_y, kd_z, kp_att, kd_att]`` (offsets ``GAIN_KP_POS``,
        ``GAIN_KD_POS``, ``GAIN_KP_ATT``, ``GAIN_KD_ATT`` of this module)."""
        return np.array([*self.kp_pos, *self.kd_pos, self.kp_att, self.kd_att], dtype=np.float64)


_DEFAULT_GAINS = {
    # RotorPy's SE3Control position gains and the Hummingbird's attitude gains.
    "hummingbird": SE3Gains(kp_att=544.0, kd_att=46.64),
    # RotorPy ships kp_att = 3264.54, kd_att = 361.58 for this vehicle; with its 50 ms motors
    # they saturate the rotors 36% of the time on a 1.5 m/s circle in still air (0.25 m RMS
    # error), while the Hummingbird's gains give no saturation and 0.15 m RMS.
    "crazyflie_brushless": SE3Gains(kp_att=544.0, kd_att=46.64),
}


def default_gains(params: MultirotorParams) -> SE3Gains:
    """Gains for ``params`` (RotorPy's for the built-in vehicles, Hummingbird's otherwise)."""
    return _DEFAULT_GAINS.get(params.name, _DEFAULT_GAINS["hummingbird"])


@njit(cache=True)
def se3_kernel(scalars, inertia, alloc_pinv, x, pos_d, vel_d, acc_d, yaw_d, yaw_rate_d,
               gains, accel_mode, out_cmd, out_wrench):
    """Batched SE(3) control law; writes rotor-speed commands (B, N) and wrenches (B, 4).

    In ``accel_mode`` ``acc_d`` is the commanded acceleration and positions/velocities are
    ignored.

    Returns 0; or, its outputs then meaningless, 1 where an argument's shape does not fit
    (nothing written) and 2 where the sum of the targets is not finite (a target NaN or
    infinite, or finite ones whose sum overflows). These cheap tests keep the checks off
    each control step: :class:`SE3Controller` looks at the arguments only when one fails.
    """
    B = x.shape[0]
    P = scalars.shape[0]
    n_rot = alloc_pinv.shape[1]
    if (x.shape[1] != ROTORS + n_rot or (P != 1 and P != B) or pos_d.shape[0] != B
            or pos_d.shape[1] != 3 or vel_d.shape[0] != B or vel_d.shape[1] != 3
            or acc_d.shape[0] != B or acc_d.shape[1] != 3 or yaw_d.shape[0] != B
            or yaw_rate_d.shape[0] != B or out_cmd.shape[0] != B or out_wrench.shape[0] != B):
        return 1
    targets = 0.0  # a sum apart from the control law's arithmetic, which it leaves unchanged
    R = np.empty((3, 3))
    Rd = np.empty((3, 3))
    S = np.empty((3, 3))
    F = np.empty(3)
    u = np.empty(4)
    for b in range(B):
        p = b if P > 1 else 0
        m = scalars[p, MASS]
        keta = scalars[p, K_ETA]
        g = scalars[p, G]
        I = inertia[p]
        (R[0, 0], R[0, 1], R[0, 2], R[1, 0], R[1, 1], R[1, 2], R[2, 0], R[2, 1],
         R[2, 2]) = quat_to_rotation(x[b, QUAT], x[b, QUAT + 1], x[b, QUAT + 2], x[b, QUAT + 3])
        for j in range(3):
            if accel_mode:
                a = acc_d[b, j]
                targets += a
            else:
                targets += (pos_d[b, j] + vel_d[b, j]) + acc_d[b, j]
                a = (-gains[GAIN_KP_POS + j] * (x[b, POS + j] - pos_d[b, j])
                     - gains[GAIN_KD_POS + j] * (x[b, VEL + j] - vel_d[b, j]) + acc_d[b, j])
            F[j] = m * a
        F[2] += m * g
        u1 = F[0] * R[0, 2] + F[1] * R[1, 2] + F[2] * R[2, 2]
        fn = np.sqrt(F[0] * F[0] + F[1] * F[1] + F[2] * F[2])
        if fn < 1e-9:  # free fall commanded: keep the current attitude
            b3x, b3y, b3z = R[0, 2], R[1, 2], R[2, 2]
        else:
            b3x, b3y, b3z = F[0] / fn, F[1] / fn, F[2] / fn
        c1x = np.cos(yaw_d[b])
        c1y = np.sin(yaw_d[b])
        # b2 = b3 x c1
        b2x = -b3z * c1y
        b2y = b3z * c1x
        b2z = b3x * c1y - b3y * c1x
        bn = np.sqrt(b2x * b2x + b2y * b2y + b2z * b2z)
        if bn < 1e-9:  # thrust along the heading: keep the current body y axis
            b2x, b2y, b2z = R[0, 1], R[1, 1], R[2, 1]
        else:
            b2x /= bn
            b2y /= bn
            b2z /= bn
        # b1 = b2 x b3
        b1x = b2y * b3z - b2z * b3y
        b1y = b2z * b3x - b2x * b3z
        b1z = b2x * b3y - b2y * b3x
        Rd[0, 0], Rd[1, 0], Rd[2, 0] = b1x, b1y, b1z
        Rd[0, 1], Rd[1, 1], Rd[2, 1] = b2x, b2y, b2z
        Rd[0, 2], Rd[1, 2], Rd[2, 2] = b3x, b3y, b3z
        # S = 0.5 (Rd^T R - R^T Rd); only the off-diagonal entries are needed
        for i in range(3):
            for k in range(3):
                acc = 0.0
                for j in range(3):
                    acc += Rd[j, i] * R[j, k] - R[j, i] * Rd[j, k]
                S[i, k] = 0.5 * acc
        eR0 = -S[1, 2]
        eR1 = S[0, 2]
        eR2 = -S[0, 1]
        w0 = x[b, RATES]
        w1 = x[b, RATES + 1]
        w2 = x[b, RATES + 2]
        ew2 = w2 - yaw_rate_d[b]
        kp_att = gains[GAIN_KP_ATT]
        kd_att = gains[GAIN_KD_ATT]
        t0 = -kp_att * eR0 - kd_att * w0
        t1 = -kp_att * eR1 - kd_att * w1
        t2 = -kp_att * eR2 - kd_att * ew2
        h0 = I[0, 0] * w0 + I[0, 1] * w1 + I[0, 2] * w2
        h1 = I[1, 0] * w0 + I[1, 1] * w1 + I[1, 2] * w2
        h2 = I[2, 0] * w0 + I[2, 1] * w1 + I[2, 2] * w2
        u[0] = u1
        u[1] = I[0, 0] * t0 + I[0, 1] * t1 + I[0, 2] * t2 + (w1 * h2 - w2 * h1)
        u[2] = I[1, 0] * t0 + I[1, 1] * t1 + I[1, 2] * t2 + (w2 * h0 - w0 * h2)
        u[3] = I[2, 0] * t0 + I[2, 1] * t1 + I[2, 2] * t2 + (w0 * h1 - w1 * h0)
        for j in range(4):
            out_wrench[b, j] = u[j]
        A = alloc_pinv[p]
        for i in range(n_rot):
            f = A[i, 0] * u[0] + A[i, 1] * u[1] + A[i, 2] * u[2] + A[i, 3] * u[3]
            out_cmd[b, i] = np.sqrt(f / keta) if f > 0.0 else 0.0
        targets += yaw_d[b] + yaw_rate_d[b]
    return 0 if np.isfinite(targets) else 2


class SE3Controller:
    """Batched SE(3) geometric controller producing rotor-speed commands.

    Parameters
    ----------
    params : MultirotorParams or sequence of them
        The vehicle(s) controlled (the model's own parameters; for robustness studies pass the
        nominal parameters the controller believes in).
    gains : SE3Gains, optional
        Defaults to :func:`default_gains` of the (first) vehicle.
    """

    def __init__(self, params: MultirotorParams | Sequence[MultirotorParams],
                 gains: SE3Gains | None = None):
        plist = [params] if isinstance(params, MultirotorParams) else list(params)
        for i, p in enumerate(plist):
            rank = np.linalg.matrix_rank(p.allocation_matrix)
            if rank < 4:
                # the pseudo-inverse would give the least-squares split and the vehicle would
                # spin or tumble, flagged nowhere: in 10 s of hover a tricopter reached 6.5
                # rad/s of yaw rate, 26 deg of tilt and 0.65 m of error, and a quadrotor whose
                # rotors all turn one way 18 rad/s of yaw rate (thirty-fifth session)
                row = "" if len(plist) == 1 else f" (vehicle {i} of the batch)"
                raise ValueError(
                    f"The 'params' parameter of SE3Controller must describe a vehicle whose "
                    f"rotors can set thrust, roll, pitch and yaw independently{row}: its "
                    f"allocation matrix [sum T; y T; -x T; dir k_m/k_eta T] has rank {rank} of "
                    f"4 ({p.n_rotors} rotors, directions {p.rotor_directions.tolist()}, "
                    f"k_m={p.k_m:g}). Fixed rotors need at least 4, not all in one line, not "
                    f"all turning one way, and k_m > 0; a tricopter's tilting rotor is not "
                    f"modelled.")
        self.gains = gains or default_gains(plist[0])
        self._gains = self.gains.as_array()
        self.packed: PackedParams = pack_params(plist)
        self.alloc_pinv = np.ascontiguousarray(
            np.stack([np.linalg.pinv(p.allocation_matrix) for p in plist]))
        self.n_rotors = plist[0].n_rotors

    def _run(self, x, pos, vel, acc, yaw, yaw_rate, accel_mode):
        try:
            # float64, the physics' precision (a float32 state compiled a float32 kernel); no
            # copy of float64 arrays
            x, pos, vel, acc, yaw, yaw_rate = (np.asarray(a, dtype=np.float64)
                                               for a in (x, pos, vel, acc, yaw, yaw_rate))
            B = x.shape[0]
            cmd = np.empty((B, self.n_rotors))
            wrench = np.empty((B, 4))
            p = self.packed
            status = se3_kernel(p.scalars, p.inertia, self.alloc_pinv, x, pos, vel, acc, yaw,
                                yaw_rate, self._gains, accel_mode, cmd, wrench)
        except Exception:  # a wrong number of axes fails the kernel's typing, a zero
            # quaternion divides by zero: say which argument, without Numba's report
            try:
                self._refuse(accel_mode, x, pos, vel, acc, yaw, yaw_rate)
            except ValueError as named:
                raise named from None
            raise
        if status:  # a shape that does not fit, or targets that are not all finite
            self._refuse(accel_mode, x, pos, vel, acc, yaw, yaw_rate)
        return cmd, wrench

    def _refuse(self, accel_mode, x, pos, vel, acc, yaw, yaw_rate) -> None:
        """Raise the ValueError naming the argument the kernel could not use; return where
        there is none (finite targets whose sum overflowed the kernel's test)."""
        if accel_mode:
            where = "SE3Controller.accelerate"
            targets = (("acceleration_cmd", acc, (3,)), ("yaw", yaw, ()),
                       ("yaw_rate", yaw_rate, ()))
        else:
            where = "SE3Controller.track"
            targets = (("position", pos, (3,)), ("velocity", vel, (3,)),
                       ("acceleration", acc, (3,)), ("yaw", yaw, ()), ("yaw_rate", yaw_rate, ()))
        width = N_RIGID + self.n_rotors
        x = _float_array(x, "x", where)
        if x.ndim != 2 or x.shape[1] != width:
            raise ValueError(f"The 'x' parameter of {where} must be a packed state of shape "
                             f"(B, {width}). Got shape {x.shape} instead.")
        B, P = x.shape[0], self.packed.size
        if P not in (1, B):
            raise ValueError(f"The 'x' parameter of {where} must hold the {P} vehicles the "
                             f"controller was built for. Got a batch of {B} instead.")
        for name, a, tail in targets:
            a = _float_array(a, name, where)
            if a.shape != (B, *tail):
                raise ValueError(f"The {name!r} parameter of {where} must have shape "
                                 f"{(B, *tail)} (the batch of x). Got shape {a.shape} instead.")
            if not np.isfinite(a).all():
                raise ValueError(f"The {name!r} parameter of {where} must be finite. Got "
                                 f"NaN or inf in row {int(np.nonzero(~np.isfinite(a))[0][0])}.")
        zero = np.nonzero(~np.any(x[:, ATTITUDE] != 0.0, axis=1))[0]
        if zero.size:  # the rotation divides by the quaternion's norm
            raise ValueError(f"The 'x' parameter of {where} must hold non-zero attitude "
                             f"quaternions (columns {QUAT} to {QUAT + 3}). Got a zero one in "
                             f"row {int(zero[0])}.")

    def track(self, x, position, velocity, acceleration, yaw, yaw_rate):
        """Rotor-speed commands (B, N) and wrench ``[u1, M]`` (B, 4) to track a flat output.

        ``x`` is the packed state (B, 13 + N) (``VehicleState.to_array()``); targets are world
        frame arrays of shape (B, 3) (positions m, velocities m/s, accelerations m/s^2) and
        (B,) yaw (rad) and yaw rate (rad/s).

        Raises
        ------
        ValueError
            Naming ``x`` (not (B, 13 + N), another batch than the controller's vehicles, or a
            zero attitude quaternion) or the target that is not finite or not of x's batch.
        """
        return self._run(x, position, velocity, acceleration, yaw, yaw_rate, False)

    def accelerate(self, x, acceleration_cmd, yaw, yaw_rate=None):
        """Acceleration-command mode: rotor speeds that produce ``acceleration_cmd`` (B, 3).

        ``acceleration_cmd`` is the desired world-frame acceleration (gravity compensated by the
        controller), m/s^2.

        Raises
        ------
        ValueError
            As :meth:`track` does, naming ``x``, ``acceleration_cmd``, ``yaw`` or ``yaw_rate``.
        """
        try:
            B = len(x)
        except TypeError:  # not a sequence: _run names x
            B = 0
        yaw_rate = np.zeros(B) if yaw_rate is None else yaw_rate
        dummy = np.zeros((B, 3))
        return self._run(x, dummy, dummy, acceleration_cmd, yaw, yaw_rate, True)


def _float_array(a, name: str, where: str) -> np.ndarray:
    try:
        return np.asarray(a, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"The {name!r} parameter of {where} must be an array of numbers. Got "
                         f"{type(a).__name__} instead.") from None
