"""Planning: the energy-aware MPPI planner and the global graph searches (no torch).

Public API::

    planner_config, PlannerConfig, VARIANTS, Variant     configuration derived from a vehicle
    ENERGY_MODES                                          J_E over the horizon or the mission
    WIND_SOURCES                                          where a variant's wind comes from
    MPPIPlanner, mppi_step, rollout, ...                  the MPPI planner and its parts
    LocalWind                                             the wind the planner knows
    obstacle_field, ObstacleField, obstacle_cost, scan_points   obstacles from a LiDAR scan
    energy_route, EnergyRoute                             GS / GS+W: energy-optimal routes
    EscapeConfig, ProgressMonitor, RouteEscape            stall detection, GS+W route escape
    FastestEscape                                          stall detection, least-time escape
    free_space, grid_route                                shortest-distance routes
"""

from windnav.plan.config import (
    ENERGY_MODES,
    SAMPLING,
    VARIANTS,
    WIND_SOURCES,
    PlannerConfig,
    Variant,
    acceleration_limit,
    planner_config,
    steady_flight,
    with_variant,
)
from windnav.plan.energy_search import MOVES, EnergyRoute, energy_route
from windnav.plan.escape import (
    EscapeConfig,
    FastestEscape,
    ProgressMonitor,
    RouteEscape,
    route_projection,
)
from windnav.plan.graph_search import free_space, grid_route
from windnav.plan.local_wind import LocalWind
from windnav.plan.mppi import (
    NO_MISSION,
    MPPIPlanner,
    PlannerStats,
    PlanResult,
    Problem,
    fused_rollout_cost,
    mission_terms,
    mppi_step,
    rollout,
    sample_controls,
    shift_controls,
    smoothing_matrix,
    softmin_weights,
)
from windnav.plan.obstacles import ObstacleField, obstacle_cost, obstacle_field, scan_points

__all__ = [
    "ENERGY_MODES",
    "MOVES",
    "NO_MISSION",
    "EnergyRoute",
    "EscapeConfig",
    "FastestEscape",
    "SAMPLING",
    "VARIANTS",
    "WIND_SOURCES",
    "LocalWind",
    "MPPIPlanner",
    "ObstacleField",
    "PlanResult",
    "PlannerConfig",
    "PlannerStats",
    "ProgressMonitor",
    "Problem",
    "RouteEscape",
    "Variant",
    "acceleration_limit",
    "energy_route",
    "free_space",
    "fused_rollout_cost",
    "grid_route",
    "mission_terms",
    "mppi_step",
    "obstacle_cost",
    "obstacle_field",
    "planner_config",
    "rollout",
    "route_projection",
    "sample_controls",
    "scan_points",
    "shift_controls",
    "smoothing_matrix",
    "softmin_weights",
    "steady_flight",
    "with_variant",
]
