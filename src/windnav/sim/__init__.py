"""Closed-loop simulation: trajectories, the closed loop, the multi-rate runner, ``FlightLog``."""

from windnav.sim.log import FlightLog, FlightStatus
from windnav.sim.loop import ClosedLoop, LoopState, closed_loop_step, make_closed_loop
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
    "ClosedLoop",
    "FlatOutput",
    "FlightLog",
    "FlightStatus",
    "Hover",
    "Line",
    "LoopState",
    "Waypoints",
    "closed_loop_step",
    "fly",
    "make_closed_loop",
    "make_trajectory",
]
