"""Steady-flight sweeps in the simulator: the power curve P(|v_a|) of any vehicle.

Steady level flight at airspeed V is, by Galilean invariance, hover in a uniform wind of speed
V: the sweep hovers a batch of copies of the vehicle, row k in a wind of ``speeds[k]`` along
``direction`` (body x by default), with the SE(3) controller, and averages the rotor power
``sum_i k_m eta_i^3 / efficiency`` once the transient has settled.
"""

from __future__ import annotations

import numpy as np

from windnav._validate import positive_float
from windnav.sensors.models import SensorSuite
from windnav.sim.runner import fly
from windnav.sim.trajectories import Hover
from windnav.vehicle.params import MultirotorParams
from windnav.vehicle.power import PowerCurve


class RowWind:
    """A uniform, steady wind with one velocity per batch row (``velocities`` (B, 3), m/s)."""

    def __init__(self, velocities):
        self.velocities = np.asarray(velocities, dtype=np.float64)

    def velocity(self, t, xyz):
        return self.velocities.copy()


def power_sweep(
    params: MultirotorParams,
    speeds,
    *,
    direction=(1.0, 0.0, 0.0),
    duration: float = 6.0,
    settle_s: float = 4.0,
    dt: float = 0.005,
) -> dict:
    """Mean rotor power of steady flight at each airspeed.

    Parameters
    ----------
    params : MultirotorParams
    speeds : array_like of shape (K,)
        Airspeeds, m/s (>= 0).
    direction : array_like of shape (3,)
        Direction of flight relative to the air, world frame (normalised).
    duration, settle_s : float
        Flight time per point and the time after which power is averaged, s.
    dt : float
        Physics step, s.

    Returns
    -------
    dict with ``speeds`` (K,), ``power`` (K,) W, ``pitch_deg`` (K,) mean tilt from vertical,
    ``tracking_error`` (K,) m (how well the hover held), ``saturated`` (K,) fraction.
    """
    speeds = np.asarray(speeds, dtype=np.float64).reshape(-1)
    if speeds.size < 1 or not np.all(np.isfinite(speeds)) or np.any(speeds < 0):
        raise ValueError("The 'speeds' parameter of power_sweep must be finite values >= 0. "
                         f"Got {speeds!r} instead.")
    duration = positive_float(duration, "duration", "power_sweep")
    if not 0 <= settle_s < duration:
        raise ValueError(f"The 'settle_s' parameter of power_sweep must be in [0, duration). "
                         f"Got {settle_s!r} instead.")
    d = np.asarray(direction, dtype=np.float64)
    d = d / np.linalg.norm(d)
    # flying at +V through still air == hovering in a wind blowing toward -direction
    wind = RowWind(-speeds[:, None] * d[None, :])
    log = fly(params, Hover((0.0, 0.0, 10.0)), wind, duration, dt=dt, batch=speeds.size,
              sensors=SensorSuite(None, None, None))
    keep = log.t >= settle_s
    tilt = 2 * np.arcsin(np.clip(np.linalg.norm(log.attitude[keep][..., :2], axis=-1), 0, 1))
    return {
        "speeds": speeds,
        "power": log.power[keep].mean(axis=0),
        "pitch_deg": np.degrees(tilt.mean(axis=0)),
        "tracking_error": log.tracking_error[keep].max(axis=0),
        "saturated": log.saturated[keep].mean(axis=(0, 2)),
    }


def simulated_power_curve(params: MultirotorParams, max_speed: float = 12.0, n: int = 25,
                          degree: int = 4) -> tuple[PowerCurve, dict]:
    """Fit a :class:`PowerCurve` to a simulated sweep over ``[0, max_speed]`` m/s."""
    max_speed = positive_float(max_speed, "max_speed", "simulated_power_curve")
    sweep = power_sweep(params, np.linspace(0.0, max_speed, n))
    ok = sweep["saturated"] == 0
    curve = PowerCurve.from_samples(sweep["speeds"][ok], sweep["power"][ok], degree=degree,
                                    name=f"{params.name} (simulated)")
    return curve, sweep
