"""Bad inputs to the planner's library functions (``windnav.plan``) and to
``flow.validity.resolution_check``: each is refused up front by a ValueError naming the argument
(closure-module audit, fifty-ninth session). Each case says what happened before."""

from __future__ import annotations

import numpy as np
import pytest

from windnav.city import City
from windnav.flow.validity import resolution_check
from windnav.plan import (
    MPPIPlanner,
    PlannerConfig,
    Problem,
    energy_route,
    fused_rollout_cost,
    obstacle_cost,
    obstacle_field,
    rollout,
    smoothing_matrix,
)
from windnav.plan.local_wind import NO_WIND

NAN = np.nan


@pytest.fixture(scope="module")
def cfg():
    # the planner's fields without the vehicle sweep (fast)
    return PlannerConfig(a_max=9.9, drag=0.01, power_coefficients=(100.0, 0.0, 0.5),
                         power_speed_max=15.0, n_samples=8, n_steps=6)


# ------------------------------------------------------------------------------ mppi


@pytest.mark.parametrize("controls", [np.ones((5, 1)), np.ones((5, 3)), np.ones((2, 5, 3)),
                                      np.ones(5), np.ones((1, 2, 5, 2))])
def test_rollout_refuses_controls_of_another_shape(cfg, controls):
    # a last axis of 1 was read as two columns past the array's end, of 3 with the third
    # dropped; 1-D and 4-D were NumPy's "axes don't match array"
    with pytest.raises(ValueError, match=r"'controls' parameter of rollout must be an array "
                                         r"of shape \(S, K, 2\) or \(K, 2\)"):
        rollout(cfg, controls, [0.0, 0.0])


def test_rollout_refuses_a_bad_config_and_velocity(cfg):
    # config None was an AttributeError; the velocity's shape was checked already (kept)
    with pytest.raises(ValueError, match="'config' parameter of rollout must be a "
                                         "PlannerConfig"):
        rollout(None, np.zeros((5, 2)), [0.0, 0.0])
    with pytest.raises(ValueError, match="'velocity' parameter of rollout"):
        rollout(cfg, np.zeros((5, 2)), [0.0, 0.0, 0.0])
    assert rollout(cfg, np.zeros((3, 5, 2)), [1.0, 0.0])[0].shape == (3, 6, 2)


@pytest.mark.parametrize("n_steps", [10**6, 5001])
def test_smoothing_matrix_refuses_a_matrix_too_large_to_hold(n_steps):
    # 10**6 steps asked NumPy for 7.3 TiB
    with pytest.raises(ValueError, match="'n_steps' parameter of smoothing_matrix must be at "
                                         "most 5000"):
        smoothing_matrix(n_steps, 1.0)


def test_fused_rollout_cost_refuses_controls_and_problems_of_other_shapes(cfg):
    field = obstacle_field([[10.0, 2.0]])
    good = Problem(np.zeros(2), np.array([50.0, 0.0]), field, NO_WIND)
    u = np.zeros((cfg.n_steps, 2, 4), np.float32)
    assert fused_rollout_cost(cfg, u, good)[0].shape == (4,)
    # (K, 3, S) and (K, 1, S) gave the plausible costs of other controls
    for bad in (np.zeros((6, 3, 4), np.float32), np.zeros((6, 1, 4), np.float32),
                np.zeros((6, 2), np.float32), np.zeros((6, 2, 4)).tolist()):
        with pytest.raises(ValueError, match="'controls' parameter of fused_rollout_cost"):
            fused_rollout_cost(cfg, bad, good)
    # a velocity (1,) was read past its end
    with pytest.raises(ValueError, match="'problem' parameter of fused_rollout_cost must hold "
                                         r"velocity \(2,\)"):
        fused_rollout_cost(cfg, u, good._replace(velocity=np.zeros(1)))
    with pytest.raises(ValueError, match="'problem' parameter of fused_rollout_cost must be a "
                                         "Problem"):
        fused_rollout_cost(cfg, u, tuple(good))


def test_planner_refuses_a_rollout_cost_that_is_not_callable(cfg):
    # a TypeError ('int' object is not callable) at the first update
    with pytest.raises(ValueError, match="'rollout_cost' parameter of MPPIPlanner must be "
                                         "callable"):
        MPPIPlanner(cfg, [10.0, 0.0], rollout_cost=5)


def test_energy_per_metre_refuses_a_zero_direction(cfg):
    # hovering's power at the top speed of the range (0.04 s/m) came back
    with pytest.raises(ValueError, match="'direction' parameter of "
                                         "PlannerConfig.energy_per_metre must be a non-zero"):
        cfg.energy_per_metre([0.0, 0.0])
    assert cfg.energy_per_metre([3.0, 0.0]) == cfg.energy_per_metre([1.0, 0.0])


def test_power_names_airspeeds_that_are_not_numbers(cfg):
    # NumPy's "could not convert string to float"
    with pytest.raises(ValueError, match="'airspeed' parameter of PlannerConfig.power must be "
                                         "numbers"):
        cfg.power("fast")


# ------------------------------------------------------------------------------ obstacles


def test_obstacle_cost_refuses_points_trajectories_and_ranges():
    traj = np.zeros((2, 4, 2))
    # (P, 3) points were reshaped into other 2-D points
    for pts in (np.ones((4, 3)), [1.0, 2.0]):
        with pytest.raises(ValueError, match=r"'points' parameter of obstacle_cost must be an "
                                             r"array of shape \(P, 2\)"):
            obstacle_cost(traj, pts, 100.0)
    with pytest.raises(ValueError, match="'points' parameter of obstacle_cost must be finite"):
        obstacle_cost(traj, [[NAN, 0.0]], 100.0)
    # a negative range gave the positive one's cost
    for r in (-100.0, NAN):
        with pytest.raises(ValueError, match="'lidar_range' parameter of obstacle_cost"):
            obstacle_cost(traj, [[1.0, 0.0]], r)
    # (K, 2) was NumPy's AxisError
    with pytest.raises(ValueError, match="'positions' parameter of obstacle_cost"):
        obstacle_cost(np.zeros((4, 2)), [[1.0, 0.0]], 100.0)
    assert np.all(obstacle_cost(traj, np.zeros((0, 2)), 100.0) == 0)
    assert np.all(obstacle_cost(traj, [], 100.0) == 0)


def test_obstacle_field_distance_and_cost_refuse_bad_points():
    field = obstacle_field([[1.0, 2.0], [5.0, 5.0]])
    # NaN read as "no obstacle" (inf); a last axis of 3 as other points
    with pytest.raises(ValueError, match="'points' parameter of ObstacleField.distance must be "
                                         "finite"):
        field.distance([[NAN, 0.0]])
    with pytest.raises(ValueError, match=r"'points' parameter of ObstacleField.distance must be "
                                         r"an array of shape \(M, 2\)"):
        field.distance(np.ones((2, 3)))
    assert field.distance([1.0, 2.0]) == pytest.approx([0.0])
    # NaN trajectories cost 0; a negative range was squared away
    with pytest.raises(ValueError, match="'positions' parameter of ObstacleField.cost"):
        field.cost(np.full((2, 4, 2), NAN), 100.0)
    with pytest.raises(ValueError, match="'lidar_range' parameter of ObstacleField.cost"):
        field.cost(np.zeros((2, 4, 2)), -100.0)


# ------------------------------------------------------------------------------ search, flow


@pytest.fixture(scope="module")
def city():
    return City((0, 60, 0, 60), [[25, 35, 25, 35]], [20])


def test_energy_route_names_a_wind_it_cannot_read(cfg, city):
    from dataclasses import replace

    gs_w = replace(cfg, variant="gs-w", energy_weight=None, use_wind=None)
    # a string was NumPy's "could not convert string to float"; a WindField of one column a
    # NumPy reshape error
    with pytest.raises(ValueError, match="'wind' parameter of energy_route must be None, a "
                                         r"\(2,\) vector or a WindField. Got str"):
        energy_route(city, [5.0, 5.0], [55.0, 55.0], gs_w, wind="east", dx=5.0, clearance=1.0)

    class OneColumn:
        def velocity(self, t, xyz):
            return np.ones((len(xyz), 1))

    with pytest.raises(ValueError, match="'wind' parameter of energy_route must be a WindField "
                                         "whose velocity"):
        energy_route(city, [5.0, 5.0], [55.0, 55.0], gs_w, wind=OneColumn(), dx=5.0,
                     clearance=1.0)


@pytest.mark.parametrize("dx", [NAN, np.inf, 0.0, -1.0, "fine"])
def test_resolution_check_refuses_a_bad_dx(city, dx):
    # NaN was reported as "dx = nan m"
    with pytest.raises(ValueError, match="'dx' parameter of resolution_check"):
        resolution_check(city, dx)


def test_resolution_check_refuses_what_is_not_a_city():
    with pytest.raises(ValueError, match="'city' parameter of resolution_check"):
        resolution_check(None, 1.0)


def test_a_power_curve_whose_continuation_falls_below_zero_is_refused():
    # (10, 0, -0.1) to 5 m/s is above 0 W there, but the planner's continuation beyond it
    # (slope -1 W/(m/s), no curvature) reached 0 W at 12.5 m/s: J_E rewarded speed and a
    # flight's energy came out negative (review of the closure-module audit)
    with pytest.raises(ValueError, match=r"'power_coefficients' parameter of PlannerConfig "
                                         r"must be a power curve whose continuation"):
        PlannerConfig(a_max=5.0, drag=0.3, power_coefficients=(10.0, 0.0, -0.1),
                      power_speed_max=5.0)
    # falling at the top but curving up: the continuation's least power is above 0 W
    falling = PlannerConfig(a_max=5.0, drag=0.3, power_coefficients=(10.0, -2.0, 0.3),
                            power_speed_max=3.0)
    assert falling.power(np.linspace(0.0, 100.0, 1001)).min() > 0
