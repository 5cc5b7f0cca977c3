"""Wind fields: the :class:`WindField` protocol and its kinds.

``velocity(t, xyz) -> (B, 3)`` m/s in the world frame, for every kind:

- :class:`ConstantWind` -- uniform and steady;
- :class:`DrydenWind` -- mean wind plus Dryden (MIL-F-8785C) turbulence, a function of (t, seed);
- :class:`GriddedWind` -- a 2D field on cell centres from the flow solver, steady or unsteady;

and :class:`RotorPyWind` / :func:`to_rotorpy` to hand any of them to RotorPy's simulator,
:class:`FromRotorPy` / :func:`from_rotorpy` to use RotorPy's wind profiles (its Dryden gusts)
here.
The discretisation helpers (``dryden_state_space``, ``van_loan``, ``stationary_covariance``)
stay importable from :mod:`windnav.wind.dryden`.
"""

from windnav.wind.adapters import FromRotorPy, RotorPyWind, from_rotorpy, to_rotorpy
from windnav.wind.base import WindField, check_query
from windnav.wind.constant import ConstantWind
from windnav.wind.dryden import DrydenWind, dryden_length_scales
from windnav.wind.gridded import GriddedWind

__all__ = [
    "ConstantWind",
    "DrydenWind",
    "FromRotorPy",
    "GriddedWind",
    "RotorPyWind",
    "WindField",
    "check_query",
    "dryden_length_scales",
    "from_rotorpy",
    "to_rotorpy",
]
