"""Steady-flight sweeps in the simulator: the power curve P(|v_a|) of any vehicle.

Steady level flight at airspeed V is, by Galilean invariance, hover in a uniform wind of speed
V: the sweep hovers a batch of copies of the vehicle, row k in a wind of ``speeds[k]`` along
``direction`` (body x by default), with the SE(3) controller, and averages the rotor power
``sum_i k_m eta_i^3 / efficiency`` once the transient has settled.

A point is *valid* only where the vehicle trims inside the model's envelope: after settling
its values are finite, no rotor command is clipped (either limit), no logged instant is
outside the envelope (:func:`windnav.vehicle.envelope.outside_envelope`: translational lift
above half the rotor thrust, or airspeed above the vehicle's limit) and it holds still (speed
below ``steady_speed``). Elsewhere the power is NaN, and the sweep reports the first speed at
which it leaves the envelope; fitted curves and their best speeds use only the valid points
below it.
"""

from __future__ import annotations

import math

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
    steady_speed: float = 0.1,
) -> dict:
    """Mean rotor power of steady flight at each airspeed, NaN where the flight is not valid.

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
    steady_speed : float
        Largest ground speed after ``settle_s`` of a trimmed (steady) point, m/s.

    Returns
    -------
    dict with ``speeds`` (K,), ``power`` (K,) W (NaN where not ``valid``), ``pitch_deg`` (K,)
    mean tilt from vertical, ``tracking_error`` (K,) m (how well the hover held),
    ``saturated`` (K,) and ``envelope_fraction`` (K,) fractions after settling, ``steady`` (K,)
    bool, ``valid`` (K,) bool, and ``envelope_speed``: the lowest swept speed that is not valid
    (m/s; None when every point is).
    """
    where = "power_sweep"
    speeds = np.asarray(speeds, dtype=np.float64).reshape(-1)
    if speeds.size < 1 or not np.all(np.isfinite(speeds)) or np.any(speeds < 0):
        raise ValueError(f"The 'speeds' parameter of {where} must be finite values >= 0. "
                         f"Got {speeds!r} instead.")
    duration = positive_float(duration, "duration", where)
    if not 0 <= settle_s < duration:
        raise ValueError(f"The 'settle_s' parameter of {where} must be in [0, duration). "
                         f"Got {settle_s!r} instead.")
    steady_speed = positive_float(steady_speed, "steady_speed", where)
    d = np.asarray(direction, dtype=np.float64)
    size = float(np.linalg.norm(d)) if d.shape == (3,) else math.nan
    if not (math.isfinite(size) and size > 0):  # (0, 0, 0): NaN power, "hover is outside"
        raise ValueError(f"The 'direction' parameter of {where} must be a finite, non-zero "
                         f"3-vector. Got {direction!r} instead.")
    d = d / size
    # flying at +V through still air == hovering in a wind blowing toward -direction
    wind = RowWind(-speeds[:, None] * d[None, :])
    log = fly(params, Hover((0.0, 0.0, 10.0)), wind, duration, dt=dt, batch=speeds.size,
              sensors=SensorSuite(None, None, None))
    keep = log.t >= settle_s
    tilt = 2 * np.arcsin(np.clip(np.linalg.norm(log.attitude[keep][..., :2], axis=-1), 0, 1))
    with np.errstate(over="ignore", invalid="ignore"):  # diverged points are only flagged
        ground_speed = np.linalg.norm(log.velocity[keep], axis=-1).max(axis=0)
    saturated = log.saturated[keep].mean(axis=(0, 2))
    outside = log.outside_envelope[keep].mean(axis=0)
    steady = ground_speed < steady_speed
    valid = log.finite & (saturated == 0) & (outside == 0) & steady
    power = np.where(valid, log.power[keep].mean(axis=0), np.nan)
    order = np.argsort(speeds, kind="stable")
    invalid = order[~valid[order]]
    return {
        "speeds": speeds,
        "power": power,
        "pitch_deg": np.degrees(tilt.mean(axis=0)),
        "tracking_error": log.tracking_error[keep].max(axis=0),
        "saturated": saturated,
        "envelope_fraction": outside,
        "steady": steady,
        "valid": valid,
        "envelope_speed": float(speeds[invalid[0]]) if invalid.size else None,
    }


def simulated_power_curve(params: MultirotorParams, max_speed: float = 12.0, n: int = 25,
                          degree: int = 4) -> tuple[PowerCurve, dict]:
    """Fit a :class:`PowerCurve` to a simulated sweep over ``[0, max_speed]`` m/s.

    Only the valid points below the sweep's ``envelope_speed`` are fitted, and the curve's
    ``speed_max`` is the fastest of them, so the best speeds derived from it
    (:func:`~windnav.vehicle.power.max_endurance_speed`, ``max_range_speed``) stay inside the
    envelope. The sweep dict gains ``fitted`` (K,) bool, the points used.

    Raises
    ------
    ValueError
        Naming ``max_speed`` when fewer than ``degree + 1`` points lie inside the envelope.
    """
    where = "simulated_power_curve"
    max_speed = positive_float(max_speed, "max_speed", where)
    sweep = power_sweep(params, np.linspace(0.0, max_speed, n))
    edge = sweep["envelope_speed"]
    fitted = sweep["valid"] & (True if edge is None else sweep["speeds"] < edge)
    if np.count_nonzero(fitted) <= degree:
        raise ValueError(
            f"The 'max_speed' parameter of {where} leaves {np.count_nonzero(fitted)} points "
            f"inside the envelope of {params.name} (it leaves it at {edge} m/s), too few for a "
            f"degree-{degree} fit. Got {max_speed!r}; sweep more points below {edge} m/s.")
    sweep["fitted"] = fitted
    curve = PowerCurve.from_samples(sweep["speeds"][fitted], sweep["power"][fitted],
                                    degree=degree, name=f"{params.name} (simulated)")
    return curve, sweep
