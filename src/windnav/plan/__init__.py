"""Planning: global graph search (this module needs no torch); MPPI comes later."""

from windnav.plan.graph_search import free_space, grid_route

__all__ = ["free_space", "grid_route"]
