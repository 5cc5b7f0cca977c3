"""Sensors: IMU, odometry / motion capture, rotor-speed pseudo-measurements."""

from windnav.sensors.models import IMU, Odometry, RotorSpeedSensor, SensorSuite

__all__ = ["IMU", "Odometry", "RotorSpeedSensor", "SensorSuite"]
