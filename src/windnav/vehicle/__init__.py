"""Multirotor parameters, batched dynamics with aerodynamics and motors, power models."""

from windnav.vehicle.dynamics import PackedParams, pack_params
from windnav.vehicle.multirotor import Multirotor
from windnav.vehicle.params import (
    GRAVITY,
    VEHICLES,
    MultirotorParams,
    alternating_directions,
    params,
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
    "PackedParams",
    "PowerCurve",
    "RangeOptimum",
    "pack_params",
    "rotor_power",
    "VehicleState",
    "alternating_directions",
    "energy",
    "max_endurance_speed",
    "max_range_speed",
    "params",
    "symmetric_rotor_positions",
    "to_rotorpy_dict",
]
