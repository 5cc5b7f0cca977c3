"""One grid rule: City.grid, the flow solver, the sweep store and the graph-search planner put
the same cells on a map, also when its extent is not a multiple of dx (issue: the planner's
grid and the wind's grid disagreed by a cell)."""

from __future__ import annotations

import numpy as np
import pytest

from windnav.city import City, grid_shape
from windnav.experiments.wind_sweep import solver_grid
from windnav.flow import simulate
from windnav.flow.grid import grid_for
from windnav.flow.solver import city_domain
from windnav.plan.graph_search import free_space

AWKWARD = [
    ((0.0, 100.0, 0.0, 60.0), 1.0),  # multiples
    ((0.0, 100.3, -5.0, 47.77), 1.0),  # not multiples: 100.3 and 52.77 cells
    ((-12.5, 40.1, 3.0, 33.4), 0.7),
    ((0.0, 30.0, 0.0, 20.0), 7.0),  # coarse: 4.29 and 2.86 cells
    ((0.0, 0.3, 0.0, 2.9999999999), 0.1),  # float noise must not add a cell (3 and 30)
    ((0.0, 1.0, 0.0, 1.0), 5.0),  # smaller than a cell: the 2-cell minimum
]


@pytest.mark.parametrize(("bounds", "dx"), AWKWARD)
def test_every_grid_on_a_map_is_the_same(bounds, dx):
    x0, x1, y0, y1 = bounds
    city = City(bounds, np.zeros((0, 4)), [])  # the grids do not depend on the buildings
    ny, nx = grid_shape(bounds, dx)
    xc, yc = city.grid(dx)
    assert (yc.size, xc.size) == (ny, nx)
    flow_grid = grid_for(bounds, dx)
    solver = city_domain(city, 2.0, 30.0, dx).grid
    grids = {
        "grid_for": (flow_grid.x, flow_grid.y),
        "solver": (solver.x, solver.y),
        "sweep": solver_grid(city, dx),
        "planner": free_space(city, dx, 0.0)[:2],
    }
    for name, (gx, gy) in grids.items():
        np.testing.assert_allclose(gx, xc, rtol=0, atol=1e-9, err_msg=name)
        np.testing.assert_allclose(gy, yc, rtol=0, atol=1e-9, err_msg=name)
    # the grid covers the map: no part of it is left off, and less than one cell is added
    assert xc[0] - dx / 2 == pytest.approx(x0) and yc[0] - dx / 2 == pytest.approx(y0)
    assert xc[-1] + dx / 2 >= x1 - 1e-9 and yc[-1] + dx / 2 >= y1 - 1e-9
    assert nx == 2 or xc[-1] - dx / 2 < x1 - 1e-12 * dx


def test_solution_lives_on_the_city_grid():
    city = City((0.0, 40.3, 0.0, 20.6), [[10.0, 14.0, 8.0, 12.0]], [10.0])
    sol = simulate(city, speed=1.0, direction_deg=0.0, dx=1.0, dt=0.5, spinup_steps=0, steps=2)
    x, y = city.grid(1.0)
    np.testing.assert_allclose(sol.x, x, atol=1e-12)
    np.testing.assert_allclose(sol.y, y, atol=1e-12)
    np.testing.assert_array_equal(sol.solid, city.rasterize(x, y))
