"""The hardware filter's acceleration: differenced motion-capture velocity, not the IMU.

The Wind UKF flown on the thesis's Crazyflie (Folk 2026, ch. 6; the author's public ROS node,
``wind_aware_ukf/src/wind_ukf_node.cpp``) ignores the accelerometer. At each motion-capture
sample ``k`` with the interval ``dt_k = t_k - t_{k-1}`` it forms the specific force

    a_raw = R_k^T ((v_k - v_{k-1}) / dt_k + [0, 0, g])       (body axes, m/s^2)
    a_raw = clip(a_raw, -a_max, a_max)                        a_max = 15 m/s^2
    a_k   = alpha_k a_raw + (1 - alpha_k) a_{k-1},            alpha_k = dt_k / (tau + dt_k)

with ``tau = 0.25 s``, and fuses ``a_k`` through the accelerometer model ``F / m`` with
``R_acc = 3.61 (m/s^2)^2``. The low-pass state starts at the hover specific force
``R_0^T [0, 0, g]``. An interval outside ``(min_dt, max_dt)`` (1e-5 s, 0.1 s in the node) leaves
the output unchanged (the node then re-rotates its previous output; windnav keeps it as is).

:class:`OdometryAccel` holds the chain's parameters and its one step;
:func:`odometry_specific_force` runs it over a recorded series. ``WindUKF`` runs the same
step online (``accel_from_odometry=OdometryAccel()``).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

from windnav._validate import positive_float
from windnav.vehicle.params import GRAVITY
from windnav.vehicle.rotation import euler_zyx_to_matrix

__all__ = ["OdometryAccel", "odometry_specific_force"]


@dataclass(frozen=True)
class OdometryAccel:
    """Differenced-odometry specific force with a clamp and a first-order low-pass.

    Attributes
    ----------
    tau_s : float
        Low-pass time constant, s (0.25 on the hardware).
    clamp : float
        Per-axis limit of the raw specific force, m/s^2 (15 on the hardware).
    min_dt, max_dt : float
        Intervals outside ``(min_dt, max_dt)`` (s) do not update the output.
    """

    tau_s: float = 0.25
    clamp: float = 15.0
    min_dt: float = 1e-5
    max_dt: float = 0.1

    def __post_init__(self):
        where = "OdometryAccel"
        positive_float(self.tau_s, "tau_s", where, allow_zero=True)
        positive_float(self.clamp, "clamp", where)
        positive_float(self.min_dt, "min_dt", where, allow_zero=True)
        if positive_float(self.max_dt, "max_dt", where) <= self.min_dt:
            raise ValueError(f"The 'max_dt' parameter of {where} must exceed min_dt "
                             f"{self.min_dt!r}. Got {self.max_dt!r} instead.")

    def initial(self, euler) -> np.ndarray:
        """The low-pass state at the first sample: hover, ``R^T [0, 0, g]`` (3,), m/s^2.

        ``euler`` (3,) is ``(psi, theta, phi)``, rad.
        """
        R = euler_zyx_to_matrix(np.reshape(np.asarray(euler, dtype=np.float64), (1, 3)))[0]
        return R[2] * GRAVITY  # R^T e3 g

    def step(self, previous, v_prev, v, euler, dt: float) -> np.ndarray:
        """One sample of the chain.

        Parameters
        ----------
        previous : ndarray of shape (3,)
            The previous output, body axes, m/s^2.
        v_prev, v : ndarray of shape (3,)
            World-frame velocity at the previous and this sample, m/s.
        euler : ndarray of shape (3,)
            ``(psi, theta, phi)`` of this sample, rad.
        dt : float
            Interval between the samples, s.

        Returns
        -------
        ndarray of shape (3,)
            The filtered specific force, body axes, m/s^2.
        """
        if not self.min_dt < dt < self.max_dt:
            return np.array(previous, dtype=np.float64)
        a_world = (np.asarray(v, dtype=np.float64) - v_prev) / dt
        a_world[2] += GRAVITY
        R = euler_zyx_to_matrix(np.reshape(np.asarray(euler, dtype=np.float64), (1, 3)))[0]
        raw = np.clip(R.T @ a_world, -self.clamp, self.clamp)
        alpha = dt / (self.tau_s + dt)
        return alpha * raw + (1.0 - alpha) * np.asarray(previous, dtype=np.float64)


def odometry_specific_force(t, velocity_world, euler, chain: OdometryAccel | None = None
                            ) -> np.ndarray:
    """Run :class:`OdometryAccel` over a recorded odometry series.

    Parameters
    ----------
    t : ndarray of shape (K,)
        Sample times, s: finite. An interval outside ``(min_dt, max_dt)`` (a repeated or
        out-of-order stamp, a gap) holds the output, as the hardware does; where every one is,
        the output stays at the hover value throughout, and a RuntimeWarning says so (times in
        ms, or reversed).
    velocity_world : ndarray of shape (K, 3)
        Measured world-frame velocity, m/s.
    euler : ndarray of shape (K, 3)
        Measured ``(psi, theta, phi)``, rad.
    chain : OdometryAccel, optional
        Default ``OdometryAccel()`` (the hardware's settings).

    Returns
    -------
    ndarray of shape (K, 3)
        The specific force the hardware filter fuses at each sample, body axes, m/s^2 (row 0
        is the initial hover value).

    Raises
    ------
    ValueError
        On ``t`` not 1-D or not finite, or on ``velocity_world`` or ``euler`` not (K, 3).
    """
    chain = OdometryAccel() if chain is None else chain
    t = np.asarray(t, dtype=np.float64)
    v = np.asarray(velocity_world, dtype=np.float64)
    e = np.asarray(euler, dtype=np.float64)
    where = "odometry_specific_force"
    if t.ndim != 1 or t.size < 1:
        raise ValueError(f"The 't' parameter of {where} must be a 1-D array of K >= 1 sample "
                         f"times. Got shape {t.shape} instead.")
    if not np.isfinite(t).all():
        k = int(np.flatnonzero(~np.isfinite(t))[0])
        raise ValueError(f"The 't' parameter of {where} must hold finite times. Got "
                         f"t[{k}] = {float(t[k])!r} instead.")
    if v.shape != (t.size, 3) or e.shape != (t.size, 3):
        raise ValueError("The 'velocity_world' and 'euler' parameters of "
                         "odometry_specific_force must have shape (K, 3) for K = len(t) >= 1. "
                         f"Got {v.shape} and {e.shape} for K = {t.size} instead.")
    dt = np.diff(t)
    if dt.size and not ((dt > chain.min_dt) & (dt < chain.max_dt)).any():
        # every sample held: gravity alone, as if the vehicle never moved (code-hash audit,
        # 2026-12-07: times that do not increase; times in ms do the same)
        warnings.warn(f"{where}: no interval of 't' lies in (min_dt, max_dt) = ({chain.min_dt}, "
                      f"{chain.max_dt}) s (intervals {float(dt.min())!r} to {float(dt.max())!r}),"
                      " so every output is the initial hover value; are the times in seconds "
                      "and increasing?", RuntimeWarning, stacklevel=2)
    out = np.empty((t.size, 3))
    out[0] = chain.initial(e[0])
    for k in range(1, t.size):
        out[k] = chain.step(out[k - 1], v[k - 1], v[k], e[k], float(t[k] - t[k - 1]))
    return out
