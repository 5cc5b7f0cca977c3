"""Named sensor suites: windnav's defaults, RotorPy's arithmetic, and the hardware's mocap.

Every preset is built from the public constructors of :class:`~windnav.sensors.IMU`,
:class:`~windnav.sensors.Odometry` and :class:`~windnav.sensors.RotorSpeedSensor`, all at one
rate (:func:`sensor_suite`). Sources and numbers are in ``docs/ukf.md``.

RotorPy's arithmetic (``rotorpy/sensors/imu.py`` ``Imu``, ``rotorpy/sensors/external_mocap.py``
``MotionCapture``, rotorpy 3.0): each sample adds

    noise = sqrt(rate_hz / 2) * N(0, |noise_density|)

per axis, where ``noise_density`` is the number RotorPy is given. Its IMU configurations give
the accelerometer's density already squared (``(0.38**2) * ones(3)`` in the batched IMU and
the examples, ``(0.038**2) * ones(3)`` as the numpy class's default) and use it as a standard
deviation, so at 100 Hz the accelerometer's white noise is ``sqrt(50) * 0.38**2 = 1.02 m/s^2``
or ``sqrt(50) * 0.038**2 = 0.0102 m/s^2`` per sample. :func:`rotorpy_imu` and
:func:`rotorpy_mocap` reproduce that arithmetic exactly (windnav's IMU takes a density ``d`` and
draws ``d * sqrt(rate_hz)``, so ``d = sqrt(rate / 2) * noise_density / sqrt(rate)``); the bias
random walks are zero, as in RotorPy's defaults.
"""

from __future__ import annotations

import math

from windnav._validate import positive_float
from windnav.sensors.models import IMU, Odometry, RotorSpeedSensor, SensorSuite

__all__ = [
    "HARDWARE_MOCAP",
    "ROTORPY_ACCEL_DENSITY",
    "ROTORPY_ACCEL_DENSITY_NUMPY",
    "ROTORPY_GYRO_DENSITY",
    "ROTORPY_MOCAP",
    "SENSOR_PRESETS",
    "THESIS_ROTOR_SPEED_STD",
    "rotorpy_imu",
    "rotorpy_mocap",
    "rotorpy_rate_scale",
    "sensor_suite",
]

ROTORPY_ACCEL_DENSITY = 0.38**2
"""RotorPy's accelerometer ``noise_density`` of its batched IMU and example configurations
(already squared; used by RotorPy as a standard deviation), m/s^2/sqrt(Hz) as labelled."""

ROTORPY_ACCEL_DENSITY_NUMPY = 0.038**2
"""RotorPy's accelerometer ``noise_density`` default of its numpy ``Imu`` class."""

ROTORPY_GYRO_DENSITY = 0.01**2
"""RotorPy's gyroscope ``noise_density`` (both classes), rad/s/sqrt(Hz) as labelled."""

ROTORPY_MOCAP = {"position": 0.0005, "velocity": 0.005, "attitude": 0.0005}
"""RotorPy ``MotionCapture`` default noise densities: m, m/s and rad per sqrt(Hz)."""

HARDWARE_MOCAP = {"position": 0.001, "velocity": 0.05, "attitude": 0.0087}
"""Per-sample white noise of the hardware preset's motion capture at 100 Hz: 1 mm, 0.05 m/s
(a filtered finite difference of the positions; raw differences of 1 mm positions at 100 Hz
would be 0.14 m/s), 0.5 degrees."""

THESIS_ROTOR_SPEED_STD = 10.0
"""Noise on the rotor-speed pseudo-measurements of the thesis preset, rad/s: the level the Wind
UKF's default ``R`` assumes (``DEFAULT_R["rotor_speeds"]``), about 2% of the Hummingbird's
hover speed."""


def rotorpy_rate_scale(rate_hz: float) -> float:
    """``sqrt(rate_hz / 2)``: RotorPy's factor from noise density to per-sample noise."""
    return math.sqrt(positive_float(rate_hz, "rate_hz", "rotorpy_rate_scale") / 2.0)


def rotorpy_imu(rate_hz: float = 100.0, *, accel_noise_density: float = ROTORPY_ACCEL_DENSITY,
                gyro_noise_density: float = ROTORPY_GYRO_DENSITY) -> IMU:
    """An IMU whose white noise is RotorPy's ``Imu`` at ``rate_hz``.

    Parameters
    ----------
    rate_hz : float
        Sample rate, Hz.
    accel_noise_density, gyro_noise_density : float
        The ``noise_density`` entries RotorPy is given (its configurations pass them already
        squared); per-sample standard deviation ``sqrt(rate_hz / 2) * noise_density``.

    Returns
    -------
    IMU
        With ``accel_std = sqrt(rate_hz / 2) * accel_noise_density`` (m/s^2) and
        ``gyro_std = sqrt(rate_hz / 2) * gyro_noise_density`` (rad/s), no bias walk.
    """
    where = "rotorpy_imu"
    rate = positive_float(rate_hz, "rate_hz", where)
    a = positive_float(accel_noise_density, "accel_noise_density", where, allow_zero=True)
    g = positive_float(gyro_noise_density, "gyro_noise_density", where, allow_zero=True)
    to_density = rotorpy_rate_scale(rate) / math.sqrt(rate)  # = 1 / sqrt(2)
    return IMU(rate_hz=rate, accel_noise_density=a * to_density,
               gyro_noise_density=g * to_density, accel_bias_walk=0.0, gyro_bias_walk=0.0)


def rotorpy_mocap(rate_hz: float = 100.0, *, position: float = ROTORPY_MOCAP["position"],
                  velocity: float = ROTORPY_MOCAP["velocity"],
                  attitude: float = ROTORPY_MOCAP["attitude"]) -> Odometry:
    """Odometry whose white noise is RotorPy's ``MotionCapture`` at ``rate_hz``: each
    standard deviation is ``sqrt(rate_hz / 2)`` times the density (m, m/s, rad per sqrt(Hz))."""
    where = "rotorpy_mocap"
    c = rotorpy_rate_scale(positive_float(rate_hz, "rate_hz", where))
    std = {name: c * positive_float(value, name, where, allow_zero=True)
           for name, value in (("position", position), ("velocity", velocity),
                               ("attitude", attitude))}
    return Odometry(rate_hz=rate_hz, position_std=std["position"],
                    velocity_std=std["velocity"], attitude_std=std["attitude"])


def _windnav(rate):
    return SensorSuite(IMU(rate_hz=rate), Odometry(rate_hz=rate), RotorSpeedSensor(rate_hz=rate))


def _rotorpy_densities(rate):
    # the legacy "rotorpy" suite: RotorPy's default densities read as densities (not squared)
    c = rotorpy_rate_scale(rate)
    return SensorSuite(
        IMU(rate_hz=rate, accel_noise_density=0.038 / math.sqrt(2.0),
            gyro_noise_density=0.01 / math.sqrt(2.0), accel_bias_walk=0.0, gyro_bias_walk=0.0),
        Odometry(rate_hz=rate, position_std=0.0005 * c, velocity_std=0.005 * c,
                 attitude_std=0.0005 * c),
        RotorSpeedSensor(rate_hz=rate))


def _thesis(accel_density):
    def build(rate):
        return SensorSuite(rotorpy_imu(rate, accel_noise_density=accel_density),
                           rotorpy_mocap(rate),
                           RotorSpeedSensor(rate_hz=rate, noise_std=THESIS_ROTOR_SPEED_STD))
    return build


def _hardware(rate):
    m = HARDWARE_MOCAP
    return SensorSuite(IMU(rate_hz=rate),
                       Odometry(rate_hz=rate, position_std=m["position"],
                                velocity_std=m["velocity"], attitude_std=m["attitude"]),
                       RotorSpeedSensor(rate_hz=rate))


SENSOR_PRESETS = {
    "windnav": _windnav,
    "rotorpy": _rotorpy_densities,
    "thesis": _thesis(ROTORPY_ACCEL_DENSITY),
    "thesis-0.038": _thesis(ROTORPY_ACCEL_DENSITY_NUMPY),
    "hardware": _hardware,
}
"""``name -> builder(rate_hz) -> SensorSuite``:

- ``windnav``: the defaults of :mod:`windnav.sensors` (accelerometer 0.028 m/s^2 per sample at
  100 Hz, odometry 0.02 m/s and 0.005 rad, exact rotor-speed commands);
- ``rotorpy``: RotorPy's default densities read as densities, ``d * sqrt(rate / 2)``
  (accelerometer 0.27 m/s^2 at 100 Hz); kept for earlier studies, it is *not* RotorPy's
  arithmetic;
- ``thesis``, ``thesis-0.038``: RotorPy's arithmetic (:func:`rotorpy_imu`,
  :func:`rotorpy_mocap`) with the accelerometer density 0.38^2 or 0.038^2, and rotor-speed
  pseudo-measurements with :data:`THESIS_ROTOR_SPEED_STD` noise;
- ``hardware``: windnav's IMU (only its gyroscope is used by the hardware filter), motion
  capture with :data:`HARDWARE_MOCAP` noise, exact commands (the hardware chain maps them to
  PWM and back in the harness).
"""


def sensor_suite(preset: str = "windnav", rate_hz: float = 100.0) -> SensorSuite:
    """IMU, odometry and rotor-speed sensors of ``preset`` (:data:`SENSOR_PRESETS`), all at
    ``rate_hz`` (Hz)."""
    rate = positive_float(rate_hz, "rate_hz", "sensor_suite")
    build = SENSOR_PRESETS.get(preset)
    if build is None:
        raise ValueError(f"The 'preset' parameter of sensor_suite must be one of "
                         f"{sorted(SENSOR_PRESETS)}. Got {preset!r} instead.")
    return build(rate)
