"""Calibration flights of the Wind UKF's drag model: a simulated wind tunnel, then the fit.

Steady flight at airspeed ``V`` through still air is, by Galilean invariance, hover in a
uniform wind of ``-V`` (a wind tunnel): :func:`calibration_flights` hovers one batch row per
(axis, airspeed) in such a wind (:class:`windnav.sim.sweeps.RowWind`), with the SE(3) controller
and the sensors of the study; :func:`calibrate` then fits the drag coefficients by least squares
(:func:`windnav.estimate.calibrate.fit_drag`, the pure fitting math, which knows nothing of the
simulator).
"""

from __future__ import annotations

import warnings

import numpy as np

from windnav._validate import finite_float, positive_float
from windnav.estimate.calibrate import AXES, DEFAULT_SPEEDS, DragFit, fit_drag
from windnav.sensors.models import IMU, Odometry, RotorSpeedSensor, SensorSuite
from windnav.sim.log import FlightLog
from windnav.sim.runner import fly
from windnav.sim.sweeps import RowWind
from windnav.sim.trajectories import Hover
from windnav.vehicle.params import MultirotorParams

__all__ = ["DEFAULT_SPEEDS", "calibrate", "calibration_flights"]


def _rng(rng, seed, where: str):
    """``rng``, or the deprecated ``seed`` alias (with a DeprecationWarning)."""
    if seed is None:
        return rng
    if rng is not None:
        raise ValueError(f"The 'seed' parameter of {where} is a deprecated alias of 'rng'; pass "
                         f"only one of them. Got seed={seed!r} and rng={rng!r}.")
    warnings.warn(f"The 'seed' parameter of {where} is deprecated; use 'rng'.",
                  DeprecationWarning, stacklevel=3)
    return seed


def calibration_flights(
    params: MultirotorParams,
    speeds: dict | None = None,
    *,
    duration: float = 6.0,
    dt: float = 0.005,
    sensor_rate_hz: float = 100.0,
    sensors: SensorSuite | None = None,
    rng: np.random.Generator | int | None = None,
    seed: np.random.Generator | int | None = None,
) -> FlightLog:
    """Simulate the calibration: hover, one batch row per (axis, airspeed), in a tunnel wind.

    Parameters
    ----------
    params : MultirotorParams
        The true vehicle.
    speeds : dict of str to sequence of float, optional
        Signed airspeeds (m/s) per body axis ``"x"``, ``"y"``, ``"z"``; default
        :data:`DEFAULT_SPEEDS`. A zero-speed row (hover) is always added.
    duration : float
        Flight time of every row, s.
    dt : float
        Physics step, s.
    sensor_rate_hz : float
        Rate of the IMU, odometry and rotor-speed sensors, Hz (when ``sensors`` is None).
    sensors : SensorSuite, optional
        Overrides the default suite.
    rng : numpy.random.Generator or int, optional
        Sensor noise (default seed 0, as :func:`windnav.sim.fly`).
    seed : numpy.random.Generator or int, optional
        Deprecated alias of ``rng``.

    Returns
    -------
    FlightLog
        ``meta["airspeed_world"]`` lists the (B, 3) airspeed of each row, m/s.
    """
    where = "calibration_flights"
    rng = _rng(rng, seed, where)
    speeds = DEFAULT_SPEEDS if speeds is None else speeds
    unknown = set(speeds) - set(AXES)
    if unknown:
        raise ValueError(f"The 'speeds' parameter of {where} has unknown axes {sorted(unknown)};"
                         f" known: {sorted(AXES)}.")
    rows = [np.zeros(3)]
    for axis, values in speeds.items():
        for v in np.asarray(values, dtype=np.float64).reshape(-1):
            finite_float(v, f"speeds[{axis!r}]", where)
            row = np.zeros(3)
            row[AXES[axis]] = v
            rows.append(row)
    airspeed = np.array(rows)
    rate = positive_float(sensor_rate_hz, "sensor_rate_hz", where)
    if sensors is None:
        sensors = SensorSuite(IMU(rate_hz=rate), Odometry(rate_hz=rate),
                              RotorSpeedSensor(rate_hz=rate))
    # flying at +V through still air == hovering in a wind of -V (yaw 0: body = world axes)
    log = fly(params, Hover((0.0, 0.0, 10.0)), RowWind(-airspeed), duration, dt=dt,
              batch=airspeed.shape[0], sensors=sensors, rng=rng)
    log.meta["airspeed_world"] = airspeed.tolist()
    return log


def calibrate(
    params_true: MultirotorParams,
    *,
    speeds: dict | None = None,
    duration: float = 6.0,
    settle_s: float = 3.0,
    parasitic: bool = True,
    sensors: SensorSuite | None = None,
    rng: np.random.Generator | int | None = None,
    seed: np.random.Generator | int | None = None,
) -> tuple[DragFit, MultirotorParams]:
    """Fly the calibration flights of ``params_true`` and fit its drag coefficients.

    Arguments are those of :func:`calibration_flights` and
    :func:`windnav.estimate.calibrate.fit_drag`.

    Returns
    -------
    fit : DragFit
    params_filter : MultirotorParams
        ``params_true`` with the drag coefficients replaced by the fitted ones: what the
        Wind UKF believes (mass, thrust and lift coefficients known).
    """
    rng = _rng(rng, seed, "calibrate")
    log = calibration_flights(params_true, speeds, duration=duration, sensors=sensors, rng=rng)
    fit = fit_drag(log, params_true, settle_s=settle_s, parasitic=parasitic)
    return fit, fit.apply(params_true)
