"""RotorPyWind: any windnav WindField drives RotorPy's simulator, which logs exactly its winds."""

from __future__ import annotations

import numpy as np
import pytest

from windnav.wind import ConstantWind, DrydenWind, GriddedWind, RotorPyWind, to_rotorpy

rotorpy = pytest.importorskip("rotorpy")


def _simulate(wind_profile, t_final=0.5, t_step=0.01):
    from rotorpy.controllers.quadrotor_control import SE3Control
    from rotorpy.estimators.nullestimator import NullEstimator
    from rotorpy.sensors.external_mocap import MotionCapture
    from rotorpy.sensors.imu import Imu
    from rotorpy.simulate import simulate
    from rotorpy.trajectories.hover_traj import HoverTraj
    from rotorpy.vehicles.crazyflie_params import quad_params
    from rotorpy.vehicles.multirotor import Multirotor
    from rotorpy.world import World

    x0 = np.array([1.0, 2.0, 1.5])
    state0 = {"x": x0, "v": np.zeros(3), "q": np.array([0, 0, 0, 1.0]), "w": np.zeros(3),
              "wind": np.zeros(3), "rotor_speeds": np.full(4, 1788.53)}
    vehicle = Multirotor(quad_params, initial_state=state0)
    time, state, *_ = simulate(
        World.empty([-10, 10, -10, 10, -10, 10]), state0, vehicle, SE3Control(quad_params),
        HoverTraj(x0=x0), wind_profile, Imu(), MotionCapture(sampling_rate=100),
        NullEstimator(), t_final, t_step, safety_margin=0.25, use_mocap=False, terminate=False,
    )
    return time, state


def _expected_log(field, time, x):
    """RotorPy stores ``update(t_{k+1}, x_k)`` in state k; the last state keeps the previous."""
    field.velocity(time[0], x[0])  # the first query RotorPy makes
    expected = np.array([field.velocity(time[k + 1], x[k])[0] for k in range(len(time) - 1)])
    return np.vstack([expected, expected[-1:]])


def _gridded():
    x = np.linspace(-5, 5, 11)
    y = np.linspace(-5, 5, 11)
    gx, gy = np.meshgrid(x, y)
    return lambda: GriddedWind(x, y, 1.0 + 0.5 * gx + 0.2 * gy, -0.3 * gx * gy)


@pytest.mark.parametrize(
    "make",
    [lambda: ConstantWind((2.0, -1.0, 0.3)),
     lambda: DrydenWind(mean=(3.0, 0.0, 0.0), sigma=(1.5, 1.5, 0.7), seed=8),
     _gridded()],
    ids=["constant", "dryden", "gridded"],
)
def test_rotorpy_logs_the_fields_wind(make):
    time, state = _simulate(RotorPyWind(make()))
    assert state["wind"].shape == (len(time), 3)
    np.testing.assert_allclose(state["wind"], _expected_log(make(), time, state["x"]), atol=1e-12)
    assert np.ptp(state["wind"][:, 0]) > 0 or isinstance(make(), ConstantWind)


def test_wind_pushes_the_vehicle_downwind():
    _, calm = _simulate(to_rotorpy(ConstantWind((0.0, 0.0, 0.0))), t_final=0.3)
    _, windy = _simulate(to_rotorpy(ConstantWind((6.0, 0.0, 0.0))), t_final=0.3)
    # drag from a +x wind accelerates the vehicle along +x before the controller responds
    assert windy["v"][10, 0] > calm["v"][10, 0] + 1e-3


def test_update_shapes_and_validation():
    adapter = to_rotorpy(ConstantWind((1.0, 2.0, 3.0)))
    np.testing.assert_array_equal(adapter.update(0.0, np.zeros(3)), [1.0, 2.0, 3.0])
    assert adapter.update(0.0, np.zeros((5, 3))).shape == (5, 3)
    with pytest.raises(ValueError, match="'field'"):
        RotorPyWind(object())
