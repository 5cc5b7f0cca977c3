"""Compiled single-sample sensor arithmetic for a loop that samples one vehicle per step.

:func:`imu_odometry_sample` gives, from standard normals drawn in the order
:meth:`IMU.measure <windnav.sensors.IMU.measure>` then
:meth:`Odometry.measure <windnav.sensors.Odometry.measure>` draw theirs, the very values
those two functions return for one sample of one vehicle (no bias random walk), operation
for operation (``tests/test_sensors_kernels.py`` checks them equal to the bit). The batched
NumPy functions stay the models; this is their per-step form without 20 small array calls.
"""

from __future__ import annotations

import math

import numpy as np

from windnav._jit import njit

N_NORMALS = 21
"""Standard normals one IMU + odometry sample draws: bias walk (6), accelerometer (3),
gyroscope (3), position (3), velocity (3), attitude (3)."""


@njit(cache=True)
def imu_odometry_sample(sf, rates, vel, att, z, scales, accel, gyro, vel_out, att_out):
    """One IMU and odometry sample of one vehicle.

    Parameters
    ----------
    sf, rates, vel : ndarray of shape (3,)
        True specific force (body, m/s^2), body rates (rad/s) and world velocity (m/s).
    att : ndarray of shape (4,)
        True attitude, xyzw.
    z : ndarray of shape (21,)
        Standard normals (:data:`N_NORMALS`, in that order).
    scales : ndarray of shape (4,)
        Standard deviations: accelerometer, gyroscope, velocity, attitude.
    accel, gyro, vel_out : ndarray of shape (3,)
        Out: the measured specific force, body rates and velocity.
    att_out : ndarray of shape (4,)
        Out: the measured attitude (the true one after a small random body rotation).
    """
    # zero bias: IMU.measure's (cumsum(walk) - walk) + bias0 is +0.0 for one sample
    for i in range(3):
        accel[i] = (sf[i] + 0.0) + (0.0 + scales[0] * z[6 + i])
        gyro[i] = (rates[i] + 0.0) + (0.0 + scales[1] * z[9 + i])
        vel_out[i] = vel[i] + (0.0 + scales[2] * z[15 + i])
    d0 = 0.0 + scales[3] * z[18]
    d1 = 0.0 + scales[3] * z[19]
    d2 = 0.0 + scales[3] * z[20]
    # quat_from_rotvec, its norm summed in NumPy's order
    angle = math.sqrt((d0 * d0 + d1 * d1) + d2 * d2)
    half = 0.5 * angle
    if angle < 1e-6:
        scale = 0.5 - angle * angle / 48.0
    else:
        scale = math.sin(half) / angle
    qx, qy, qz, qw = d0 * scale, d1 * scale, d2 * scale, math.cos(half)
    # quat_multiply(att, q)
    px, py, pz, pw = att[0], att[1], att[2], att[3]
    att_out[0] = pw * qx + px * qw + py * qz - pz * qy
    att_out[1] = pw * qy - px * qz + py * qw + pz * qx
    att_out[2] = pw * qz + px * qy - py * qx + pz * qw
    att_out[3] = pw * qw - px * qx - py * qy - pz * qz


class NormalStream:
    """Standard normals of one generator, drawn in blocks and handed out in order: the same
    numbers, in the same order, as drawing them one call at a time
    (``Generator.normal(scale=s)`` is ``0.0 + s * standard_normal()``)."""

    def __init__(self, rng: np.random.Generator, block: int = 4096):
        self.rng, self.block = rng, int(block)
        self._buf = np.empty(0)
        self._at = 0

    def take(self, n: int) -> np.ndarray:
        """The next ``n`` normals (a view; read it before the next call)."""
        if self._at + n > self._buf.size:
            rest = self._buf[self._at:]
            self._buf = np.concatenate([rest, self.rng.standard_normal(max(self.block, n))])
            self._at = 0
        out = self._buf[self._at:self._at + n]
        self._at += n
        return out
