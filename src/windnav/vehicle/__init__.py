"""Multirotor parameters, batched dynamics with aerodynamics and motors, power models.

Public API::

    params, VEHICLES, MultirotorParams, GRAVITY          vehicle parameters
    symmetric_rotor_positions, alternating_directions    airframe helpers
    params_to_rotorpy_dict                               RotorPy's quad_params of a vehicle
    Multirotor, VehicleState                             batched dynamics and its state
    outside_envelope                                     where the aerodynamic model is trusted
    layout                                               named columns of the packed arrays
    rotor_power, energy, PowerCurve, ...                 power and energy

The Numba kernels and ``pack_params``/``PackedParams`` stay importable from
:mod:`windnav.vehicle.dynamics`.
"""

from windnav.vehicle import layout
from windnav.vehicle._compat import moved_attributes
from windnav.vehicle.envelope import outside_envelope
from windnav.vehicle.multirotor import Multirotor
from windnav.vehicle.params import (
    GRAVITY,
    VEHICLES,
    MultirotorParams,
    alternating_directions,
    params,
    params_to_rotorpy_dict,
    symmetric_rotor_positions,
    to_rotorpy_dict,
)
from windnav.vehicle.power import (
    PowerCurve,
    RangeOptimum,
    energy,
    max_endurance_speed,
    max_range_speed,
    rotor_power,
)
from windnav.vehicle.state import VehicleState

__all__ = [
    "GRAVITY",
    "VEHICLES",
    "Multirotor",
    "MultirotorParams",
    "PowerCurve",
    "RangeOptimum",
    "VehicleState",
    "alternating_directions",
    "energy",
    "layout",
    "max_endurance_speed",
    "max_range_speed",
    "outside_envelope",
    "params",
    "params_to_rotorpy_dict",
    "rotor_power",
    "symmetric_rotor_positions",
    "to_rotorpy_dict",  # deprecated alias of params_to_rotorpy_dict
]

# Deprecated: kernels were exported here before; they live in their private modules.
__getattr__ = moved_attributes("windnav.vehicle", {"pack_params": "windnav.vehicle.dynamics",
                                "PackedParams": "windnav.vehicle.dynamics"})
