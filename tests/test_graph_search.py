"""Global graph search on the occupancy grid (the baseline route planner)."""

import numpy as np
import pytest

import windnav as wn
from windnav.city import City
from windnav.plan import free_space, grid_route


def _segment_clear(city, a, b, clearance):
    s = np.linspace(0, 1, 400)[:, None]
    pts = a[None] + s * (b - a)[None]
    for x0, x1, y0, y1 in city.footprints:
        dx = np.maximum.reduce([x0 - pts[:, 0], np.zeros(len(pts)), pts[:, 0] - x1])
        dy = np.maximum.reduce([y0 - pts[:, 1], np.zeros(len(pts)), pts[:, 1] - y1])
        if np.min(np.hypot(dx, dy)) < clearance:
            return False
    return True


def test_empty_map_gives_the_straight_line():
    city = City((0, 100, 0, 100), np.zeros((0, 4)), np.zeros(0))
    r = grid_route(city, (10, 10), (90, 70), dx=1.0, clearance=2.0)
    assert len(r["waypoints"]) == 2
    assert r["length"] == pytest.approx(100.0)


@pytest.mark.parametrize("seed", range(5))
def test_routes_keep_clearance_and_are_near_optimal(seed):
    city = wn.city.training_map(rng=np.random.default_rng(seed), size=300.0)
    rng = np.random.default_rng(100 + seed)
    clearance = 6.0
    _, _, free = free_space(city, 2.0, clearance)
    x, y = city.grid(2.0)
    free_xy = np.argwhere(free)
    a, b = free_xy[rng.choice(len(free_xy), 2, replace=False)]
    start = np.array([x[a[1]], y[a[0]]])
    goal = np.array([x[b[1]], y[b[0]]])
    r = grid_route(city, start, goal, dx=2.0, clearance=clearance)
    wp = r["waypoints"]
    np.testing.assert_allclose(wp[0], start)
    np.testing.assert_allclose(wp[-1], goal)
    # every leg keeps (almost) the clearance: the grid resolution costs at most one cell
    for p, q in zip(wp[:-1], wp[1:], strict=True):
        assert _segment_clear(city, p, q, clearance - 2.0)
    assert r["length"] >= np.linalg.norm(goal - start) - 1e-9


def test_a_city_of_another_type_is_named():
    with pytest.raises(ValueError, match="'city' parameter of grid_route must be a "
                                         "windnav.city.City"):
        grid_route(None, (5, 5), (50, 50))


def test_goal_inside_a_building_is_rejected():
    city = City((0, 100, 0, 100), [[40, 60, 40, 60]], [20])
    with pytest.raises(ValueError, match="'goal_xy'"):
        grid_route(city, (5, 5), (50, 50))
    walled = City((0, 100, 0, 100), [[45, 55, 0, 100]], [20])
    with pytest.raises(ValueError, match="cannot be reached"):
        grid_route(walled, (5, 50), (95, 50))


@pytest.mark.parametrize("start, goal, name", [((-20, 50), (95, 50), "start_xy"),
                                               ((5, 50), (1e6, 1e6), "goal_xy")])
def test_an_end_point_off_the_map_is_rejected(start, goal, name):
    # it used to be snapped to the nearest edge cell and joined by a straight leg that no
    # one checked (a route to (1e6, 1e6) of 1.4e6 m)
    city = City((0, 100, 0, 100), [[40, 60, 40, 60]], [20])
    with pytest.raises(ValueError, match=f"'{name}' parameter of grid_route must lie inside "
                                         "the map"):
        grid_route(city, start, goal)
    # a point on the map's boundary is on the map
    r = grid_route(city, (0, 0), (100, 100), clearance=2.0)
    np.testing.assert_allclose(r["waypoints"][[0, -1]], [[0, 0], [100, 100]])
