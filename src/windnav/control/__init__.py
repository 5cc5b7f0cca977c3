"""Control: SE(3) geometric tracking, acceleration commands, rotor allocation.

Public API::

    SE3Controller, SE3Gains, default_gains     the SE(3) controller and its gains

The Numba kernel ``se3_kernel`` stays importable from :mod:`windnav.control.se3`.
"""

from windnav.control.se3 import SE3Controller, SE3Gains, default_gains
from windnav.vehicle._compat import moved_attributes

__all__ = ["SE3Controller", "SE3Gains", "default_gains"]

# Deprecated: kernels were exported here before; they live in their private modules.
__getattr__ = moved_attributes("windnav.control", {"se3_kernel": "windnav.control.se3"})
