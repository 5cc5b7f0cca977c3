"""City maps: buildings, RotorPy world JSON, generators, rasterisation and 2D LiDAR."""

from windnav.city.core import (
    City,
    check_city,
    city_from_rotorpy_dict,
    grid_shape,
    read_rotorpy_json,
)
from windnav.city.generate import dense_map, planning_map, training_map
from windnav.city.lidar import lidar_scan, ray_directions
from windnav.city.rotorpy_json import to_rotorpy_dict, write_rotorpy_json

__all__ = [
    "City",
    "check_city",
    "city_from_rotorpy_dict",
    "dense_map",
    "grid_shape",
    "lidar_scan",
    "planning_map",
    "ray_directions",
    "read_rotorpy_json",
    "to_rotorpy_dict",
    "training_map",
    "write_rotorpy_json",
]
