"""Closed-loop simulation: trajectories, the multi-rate runner and ``FlightLog``."""

from windnav.sim.log import FlightLog
from windnav.sim.runner import fly
from windnav.sim.trajectories import (
    TRAJECTORIES,
    Circle,
    FlatOutput,
    Hover,
    Line,
    Waypoints,
    make_trajectory,
)

__all__ = [
    "TRAJECTORIES",
    "Circle",
    "FlatOutput",
    "FlightLog",
    "Hover",
    "Line",
    "Waypoints",
    "fly",
    "make_trajectory",
]
