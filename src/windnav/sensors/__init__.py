"""Sensors: IMU, odometry / motion capture, rotor-speed pseudo-measurements.

Every sensor follows one protocol (:class:`Sensor`): a ``name``, a ``rate_hz`` and
``sample(truth, rng)`` on the true flight at its sample instants (:class:`SensorTruth`).
Named suites (windnav, RotorPy's arithmetic, the hardware's) are in :mod:`~windnav.sensors.presets`.
"""

from windnav.sensors import presets
from windnav.sensors.base import Sensor, SensorTruth
from windnav.sensors.models import IMU, Odometry, RotorSpeedSensor, SensorSuite

__all__ = ["IMU", "Odometry", "RotorSpeedSensor", "Sensor", "SensorSuite", "SensorTruth", "presets"]
