"""Bad inputs to the controller, the vehicle model, the reference trajectories and the sensor
models: each is refused up front by a ValueError naming the argument (closure-module audit,
fifty-ninth session). Each case says what happened before."""

from __future__ import annotations

import numpy as np
import pytest

import windnav as wn
from windnav.control import SE3Controller
from windnav.sensors import IMU, Odometry, RotorSpeedSensor
from windnav.sim import Circle, Hover, Line
from windnav.vehicle import Multirotor, VehicleState
from windnav.vehicle.power import energy
from windnav.vehicle.rotation import (
    euler_zyx_to_matrix,
    quat_from_rotvec,
    quat_multiply,
    quat_to_matrix,
)

NAN = np.nan
HB = wn.vehicle.params("hummingbird")


@pytest.fixture(scope="module")
def hover():
    """A Hummingbird's SE(3) controller and its packed hover state (B = 1)."""
    return SE3Controller(HB), Multirotor(HB).hover_state(np.zeros(3)).to_array()


# --------------------------------------------------------------------------- SE(3) control


def test_the_controller_refuses_non_finite_targets(hover):
    # before: all four rotor commands 0 (the vehicle falls), no warning
    c, x = hover
    z, y = np.zeros((1, 3)), np.zeros(1)
    with pytest.raises(ValueError, match="'position' parameter of SE3Controller.track must "
                                         "be finite"):
        c.track(x, [[0.0, NAN, 1.0]], z, z, y, y)
    with pytest.raises(ValueError, match="'yaw_rate' parameter of SE3Controller.track"):
        c.track(x, z, z, z, y, [np.inf])
    with pytest.raises(ValueError, match="'acceleration_cmd' parameter of "
                                         "SE3Controller.accelerate must be finite"):
        c.accelerate(x, [[NAN, 0.0, 0.0]], y)
    with pytest.raises(ValueError, match="'yaw' parameter of SE3Controller.accelerate"):
        c.accelerate(x, z, [NAN])


def test_the_controller_refuses_targets_of_another_batch_or_shape(hover):
    # before: a (2, 3) target read one row; a (3,) one or a scalar yaw a Numba TypingError
    c, x = hover
    z, y = np.zeros((1, 3)), np.zeros(1)
    with pytest.raises(ValueError, match=r"'velocity' parameter of SE3Controller.track must "
                                         r"have shape \(1, 3\)"):
        c.track(x, z, np.zeros((2, 3)), z, y, y)
    with pytest.raises(ValueError, match=r"'acceleration_cmd' .* shape \(1, 3\)"):
        c.accelerate(x, np.zeros(3), y)
    with pytest.raises(ValueError, match=r"'yaw' parameter .* shape \(1,\)"):
        c.track(x, z, z, z, 0.0, y)


def test_the_controller_refuses_a_state_it_cannot_read(hover):
    # before: an (1, 8) state read past its row, a zero quaternion a ZeroDivisionError, a
    # batch of 2 for 3 vehicles' parameters read past them
    c, x = hover
    z, y = np.zeros((1, 3)), np.zeros(1)
    with pytest.raises(ValueError, match=r"'x' parameter .* shape \(B, 17\)"):
        c.track(x[:, :8], z, z, z, y, y)
    zero = x.copy()
    zero[:, 6:10] = 0.0
    with pytest.raises(ValueError, match="'x' parameter .* non-zero attitude quaternions"):
        c.accelerate(zero, z, y)
    three = SE3Controller([HB] * 3)
    with pytest.raises(ValueError, match="'x' parameter .* the 3 vehicles"):
        three.accelerate(np.repeat(x, 2, axis=0), np.zeros((2, 3)), np.zeros(2))


def test_targets_whose_sum_overflows_are_still_followed(hover):
    """The kernel's test sums the targets: finite ones that overflow the sum are looked at
    again, and accepted."""
    c, x = hover
    z, y = np.zeros((1, 3)), np.zeros(1)
    cmd, wrench = c.track(x, [[1e308, 1e308, 0.0]], z, z, y, y)
    assert cmd.shape == (1, 4) and wrench.shape == (1, 4)


# --------------------------------------------------------------------------- vehicle


def test_params_refuse_a_vehicle_that_cannot_hover():
    # before: accepted at thrust-to-weight 0.51, hover at 2098 of 1500 rad/s
    with pytest.raises(ValueError, match=r"'mass' parameter of windnav.vehicle.params must "
                                         r"leave a vehicle that can hover.*thrust-to-weight "
                                         r"of 0\.51"):
        wn.vehicle.params("hummingbird", mass=10)
    with pytest.raises(ValueError, match="'k_eta' and 'rotor_speed_max' parameters"):
        wn.vehicle.params("hummingbird", k_eta=1e-6, rotor_speed_max=500.0, k_d=0.0)
    with pytest.raises(ValueError, match="'mass' parameter of windnav.vehicle.params"):
        wn.vehicle.params("crazyflie_thesis", mass=1.0)
    # a study of the thrust margin still builds one on purpose
    assert HB.replace(mass=10.0).max_thrust < HB.replace(mass=10.0).weight


def test_params_refuse_an_inertia_no_rigid_body_has():
    # before: Izz > Ixx + Iyy accepted
    with pytest.raises(ValueError, match="'inertia' parameter of MultirotorParams must be a "
                                         "rigid body's"):
        wn.vehicle.params("hummingbird", inertia=[1e-3, 2e-3, 5e-3])
    flat = wn.vehicle.params("hummingbird", inertia=[1e-3, 2e-3, 3e-3])  # a flat body: equal
    assert flat.inertia[2, 2] == 3e-3


def test_energy_refuses_negative_power():
    # before: -10 J
    with pytest.raises(ValueError, match="'power' parameter of energy must be >= 0"):
        energy([0.0, 1.0], [-10.0, -10.0])


def test_packed_states_of_the_wrong_width_are_refused():
    # before: a (1, 10) state unpacked into 3 attitude components and no body rates, a 1-D
    # one an IndexError; fields of other widths packed into shifted blocks
    with pytest.raises(ValueError, match=r"'x' parameter of VehicleState.from_array must "
                                         r"have shape \(B, 13 \+ N\)"):
        VehicleState.from_array(np.zeros((1, 10)))
    with pytest.raises(ValueError, match=r"'x' parameter .* \(B, 17\)"):
        VehicleState.from_array(np.zeros((1, 15)), n_rotors=4)
    s = Multirotor(HB).hover_state(np.zeros(3))
    bad = VehicleState(s.position, s.velocity, s.attitude[:, :3], s.body_rates,
                       np.zeros((1, 5)))
    with pytest.raises(ValueError, match=r"'attitude' field of VehicleState must have shape "
                                         r"\(B, 4\)"):
        bad.to_array()


def test_clip_rotor_speeds_refuses_commands_for_other_rotors():
    # before: 3 commands for 4 rotors clipped as 3; (2, 4) for 3 vehicles a broadcast error
    with pytest.raises(ValueError, match=r"'rotor_speed_cmd' parameter of "
                                         r"Multirotor.clip_rotor_speeds must have shape "
                                         r"\(\.\.\., 4\)"):
        Multirotor(HB).clip_rotor_speeds(np.zeros(3))
    with pytest.raises(ValueError, match=r"'rotor_speed_cmd' .* \(\.\.\., 3, 4\)"):
        Multirotor([HB] * 3).clip_rotor_speeds(np.zeros((2, 4)))


def test_rotation_helpers_refuse_wrong_lengths_and_zero_quaternions():
    # before: a ZeroDivisionError, NumPy's reshape errors, an IndexError, a (1, 2) rotation
    # vector made into (1, 3) "quaternions", a 5-vector read as its first 4
    with pytest.raises(ValueError, match="'q' parameter of quat_to_matrix must hold non-zero"):
        quat_to_matrix(np.zeros(4))
    with pytest.raises(ValueError, match=r"'q' parameter .* shape \(\.\.\., 4\)"):
        quat_to_matrix(np.ones(8))
    with pytest.raises(ValueError, match=r"'euler' parameter .* shape \(\.\.\., 3\)"):
        euler_zyx_to_matrix(np.ones(4))
    with pytest.raises(ValueError, match="'p' parameter of quat_multiply"):
        quat_multiply(np.ones(5), np.ones(4))
    with pytest.raises(ValueError, match="'q' parameter of quat_multiply"):
        quat_multiply(np.ones(4), np.ones(3))
    with pytest.raises(ValueError, match="'rotvec' parameter of quat_from_rotvec"):
        quat_from_rotvec(np.ones((1, 2)))


# --------------------------------------------------------------------------- trajectories


@pytest.mark.parametrize("make, name", [
    (lambda: Hover((0.0, NAN, 1.0)), "'position' parameter of Hover"),
    (lambda: Hover(((0.0, 0.0, 1.0),)), "'position' parameter of Hover"),  # 2-D
    (lambda: Hover((0.0, 0.0, 1.0), yaw=NAN), "'yaw' parameter of Hover"),
    (lambda: Circle(center=(NAN, 0.0, 0.0)), "'center' parameter of Circle"),
    (lambda: Circle(center=np.zeros((2, 3))), "'center' parameter of Circle"),
    (lambda: Line((0.0, 0.0), (1.0, 0.0, 0.0)), "'start' parameter of Line"),
])
def test_trajectories_refuse_non_finite_or_2d_fields(make, name):
    # before: accepted; NaN flew rotor commands of 0, a (1, 3) point broadcast over the batch
    with pytest.raises(ValueError, match=name):
        make()


# --------------------------------------------------------------------------- sensors


def test_sensor_models_refuse_wrong_shapes():
    # before: NumPy broadcast errors, an IndexError, silent broadcasting of (5, 1, 3) rates
    # over 2 vehicles and of one attitude over 5 samples, an AttributeError for a list
    rng = np.random.default_rng(0)
    imu, odo = IMU(), Odometry()
    with pytest.raises(ValueError, match=r"'specific_force_body' parameter of IMU.measure "
                                         r"must have shape \(K, B, 3\)"):
        imu.measure(np.zeros((5, 3)), np.zeros((5, 3)), rng)
    with pytest.raises(ValueError, match="'body_rates' parameter of IMU.measure"):
        imu.measure(np.zeros((5, 2, 3)), np.zeros((5, 1, 3)), rng)
    with pytest.raises(ValueError, match=r"'bias0' parameter of IMU.measure must have shape "
                                         r"\(2, 6\)"):
        imu.measure(np.zeros((5, 2, 3)), np.zeros((5, 2, 3)), rng, bias0=np.zeros((2, 3)))
    with pytest.raises(ValueError, match="'attitude' parameter of Odometry.measure"):
        odo.measure(np.zeros((5, 3)), np.zeros((5, 3)), np.zeros((5, 3)), rng)
    with pytest.raises(ValueError, match="'attitude' parameter of Odometry.measure"):
        odo.measure(np.zeros((5, 3)), np.zeros((5, 3)), np.zeros((1, 4)), rng)
    with pytest.raises(ValueError, match="'velocity' parameter of Odometry.measure"):
        odo.measure(np.zeros((5, 3)), np.zeros((4, 3)), np.zeros((5, 4)), rng)
    with pytest.raises(ValueError, match="'rotor_speed_cmd' parameter of "
                                         "RotorSpeedSensor.measure"):
        RotorSpeedSensor(noise_std=1.0).measure([[1.0, 2.0], [3.0]], rng)
