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
from windnav.vehicle.state import VehicleState

__all__ = [
    "GRAVITY",
    "VEHICLES",
    "Multirotor",
    "MultirotorParams",
    "PackedParams",
    "pack_params",
    "VehicleState",
    "alternating_directions",
    "params",
    "symmetric_rotor_positions",
    "to_rotorpy_dict",
]
