"""Control: SE(3) geometric tracking, acceleration commands, rotor allocation."""

from windnav.control.se3 import SE3Controller, SE3Gains, default_gains, se3_kernel

__all__ = ["SE3Controller", "SE3Gains", "default_gains", "se3_kernel"]
