"""Obstacle cost: the distance field against brute force over the LiDAR points."""

import numpy as np
import pytest

import windnav as wn
from windnav.city import City
from windnav.plan import obstacle_cost, obstacle_field, scan_points


def _brute_distance(q, pts):
    return np.sqrt(((q[:, None, :] - pts[None]) ** 2).sum(-1).min(1))


def _free_origin(city, rng):
    while True:
        o = rng.uniform(20, 580, 2)
        if not city.contains(o[None])[0] and np.sum(city.lidar(o)[0] < 100) > 10:
            return o


def test_node_distances_are_exact():
    rng = np.random.default_rng(0)
    pts = rng.uniform(-60, 60, (200, 2))
    f = obstacle_field(pts, resolution=1.5, padding=5.0)
    ny, nx = f.node_distance.shape
    X, Y = np.meshgrid(f.meta[0] + 1.5 * np.arange(nx), f.meta[1] + 1.5 * np.arange(ny))
    nodes = np.stack([X.ravel(), Y.ravel()], 1)
    np.testing.assert_allclose(f.node_distance.ravel(), _brute_distance(nodes, pts), atol=1e-9)
    np.testing.assert_allclose(np.linalg.norm(nodes - pts[f.node_nearest.ravel()], axis=1),
                               f.node_distance.ravel(), atol=1e-9)


@pytest.mark.parametrize("seed", range(4))
def test_j_obs_matches_brute_force_on_random_city_scans(seed):
    """J_obs = 1 / (closest distance)^2 (non-dimensional by D_max), field vs brute force."""
    rng = np.random.default_rng(seed)
    city = wn.city.planning_map(rng=seed)
    for _ in range(5):
        o = _free_origin(city, rng)
        pts = scan_points(city.lidar(o, noise_std=0.35, rng=rng)[0], max_range=100.0)
        f = obstacle_field(pts)
        # random-walk trajectories from the origin, some far outside the field's grid
        traj = np.cumsum(rng.normal(0, rng.uniform(0.5, 8.0), (300, 25, 2)), axis=1)
        j_field = f.cost(traj, 100.0)
        j_brute = obstacle_cost(traj, pts, 100.0)
        d_min = _brute_distance(traj.reshape(-1, 2), pts).reshape(300, 25).min(1)
        np.testing.assert_allclose(j_brute, (100.0 / d_min) ** 2, rtol=1e-12)
        np.testing.assert_allclose(j_field, j_brute, rtol=1e-9)
        q = rng.uniform(-150, 150, (2000, 2))
        np.testing.assert_allclose(f.distance(q), _brute_distance(q, pts), rtol=1e-9, atol=1e-12)


def test_degenerate_points_equal_heights_and_duplicates():
    # a horizontal wall (every point at one y), duplicated points, a single point
    wall = np.stack([np.linspace(-20, 20, 41), np.full(41, 7.0)], 1)
    pts = np.concatenate([wall, wall[:5], [[3.0, -4.0]]])
    f = obstacle_field(pts, resolution=0.7)
    q = np.random.default_rng(1).uniform(-40, 40, (3000, 2))
    np.testing.assert_allclose(f.distance(q), _brute_distance(q, pts), rtol=1e-9, atol=1e-12)
    one = obstacle_field([[1.0, 2.0]])
    np.testing.assert_allclose(one.distance(q), np.hypot(q[:, 0] - 1, q[:, 1] - 2), rtol=1e-12)


def test_no_points_no_cost():
    f = obstacle_field(np.zeros((0, 2)))
    assert f.empty
    assert np.all(f.cost(np.ones((3, 4, 2)), 100.0) == 0)
    assert np.all(np.isinf(f.distance([[0.0, 0.0]])))


def test_scan_points_lie_on_the_building_in_the_world_frame():
    city = City((0, 100, 0, 100), [[60, 70, 40, 80]], [20])
    origin = np.array([30.0, 50.0])
    pts = scan_points(city.lidar(origin, max_range=100.0)[0], max_range=100.0)
    world = pts + origin
    assert len(pts) > 10
    # every return is on the building's boundary; the face seen is x = 60 (east of the sensor)
    assert np.all((world[:, 0] >= 60 - 1e-9) & (world[:, 0] <= 70 + 1e-9))
    assert np.all((world[:, 1] >= 40 - 1e-9) & (world[:, 1] <= 80 + 1e-9))
    np.testing.assert_allclose(world[:, 0].min(), 60.0, atol=1e-9)


def test_bad_points_raise_named_errors():
    # fields too large to hold: 5 GB for a point at 1e7 m, MemoryErrors, "negative
    # dimensions" (API audit, 2026-12-05)
    for pts, kw in (([[1e7, 0.0]], {}), ([[1e5, 1e5]], {}), ([[10.0, 0.0]], {"resolution": 1e-4}),
                    ([[10.0, 0.0]], {"padding": 1e12}), ([[1e300, 0.0]], {})):
        with pytest.raises(ValueError, match="'points' parameter of obstacle_field must span"):
            obstacle_field(pts, **kw)
    assert not obstacle_field([[3000.0, 3000.0]]).empty  # 3 km at 1 m: 9.1e6 nodes, allowed
    with pytest.raises(ValueError, match="'ranges' parameter of scan_points must be >= 0"):
        scan_points(np.full(8, -5.0), max_range=100.0)
    assert scan_points(np.array([0.0, np.nan, 3.0, 100.0]), max_range=100.0).shape == (2, 2)
    with pytest.raises(ValueError, match="'points' parameter of obstacle_field"):
        obstacle_field([[0.0, np.nan]])
    with pytest.raises(ValueError, match="'points' parameter of obstacle_field"):
        obstacle_field(np.zeros((3, 3)))
    with pytest.raises(ValueError, match="'resolution' parameter of obstacle_field"):
        obstacle_field([[0.0, 1.0]], resolution=0)


@pytest.mark.parametrize("seed", range(3))
def test_distance_and_j_obs_match_brute_force_in_every_cell_of_a_coarse_field(seed):
    """A coarse field (h = 4 m, little padding) over dense points: queries in every cell,
    each cell's own node bound must use the node spacing h, or a query near a node that is not
    its nearest point's node is answered from the wrong node."""
    rng = np.random.default_rng(seed)
    pts = rng.uniform(-30, 30, (400, 2))
    f = obstacle_field(pts, resolution=4.0, padding=0.5)
    assert f.resolution == 4.0
    ny, nx = f.node_distance.shape
    q = np.stack([f.meta[0] + rng.uniform(0, 4.0 * (nx - 1), 20000),
                  f.meta[1] + rng.uniform(0, 4.0 * (ny - 1), 20000)], 1)
    np.testing.assert_allclose(f.distance(q), _brute_distance(q, pts), rtol=1e-9, atol=1e-12)
    traj = q.reshape(2000, 10, 2)
    d_min = _brute_distance(q, pts).reshape(2000, 10).min(1)
    np.testing.assert_allclose(f.cost(traj, 100.0), (100.0 / d_min) ** 2, rtol=1e-9)
