"""Wind fields: the :class:`WindField` protocol and its kinds.

``velocity(t, xyz) -> (B, 3)`` m/s in the world frame, for every kind:

- :class:`ConstantWind` -- uniform and steady;
- :class:`DrydenWind` -- mean wind plus Dryden (MIL-F-8785C) turbulence, exactly discretised;
- :class:`GriddedWind` -- a 2D field on cell centres from the flow solver, steady or unsteady;

and :class:`RotorPyWind` / :func:`to_rotorpy` to hand any of them to RotorPy's simulator.
"""

from windnav.wind.adapters import RotorPyWind, to_rotorpy
from windnav.wind.base import WindField, check_query
from windnav.wind.constant import ConstantWind
from windnav.wind.dryden import (
    DrydenWind,
    dryden_length_scales,
    dryden_state_space,
    stationary_covariance,
    van_loan,
)
from windnav.wind.gridded import GriddedWind

__all__ = [
    "ConstantWind",
    "DrydenWind",
    "GriddedWind",
    "RotorPyWind",
    "WindField",
    "check_query",
    "dryden_length_scales",
    "dryden_state_space",
    "stationary_covariance",
    "to_rotorpy",
    "van_loan",
]
