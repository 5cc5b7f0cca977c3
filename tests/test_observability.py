"""Observability of the Wind UKF model: symbolic model = numeric model; rank and its drops."""

import numpy as np
import pytest

import windnav as wn
from windnav.estimate import observability as ob
from windnav.estimate import wind_model as wm

P_HB = wn.vehicle.params("hummingbird")


def random_state(rng, params=P_HB):
    x = np.zeros(12 + params.n_rotors)
    x[0:3] = rng.uniform([-np.pi, -0.5, -0.5], [np.pi, 0.5, 0.5])
    x[3:6] = rng.normal(0, 0.5, 3)
    x[6:12] = rng.normal(0, 3.0, 6)
    x[12:] = params.hover_rotor_speed * rng.uniform(0.8, 1.2, params.n_rotors)
    return x


def hover_state(params=P_HB):
    x = np.zeros(12 + params.n_rotors)
    x[12:] = params.hover_rotor_speed
    return x


@pytest.mark.parametrize("frame", ["world", "body"])
def test_symbolic_model_equals_the_filter_model(frame):
    """In either wind frame (``world``, the filter's default: ``w_b' = -Omega x w_b``;
    ``body``, the thesis's: ``w_b' = 0``). The symbolic model was the body one whatever the
    filter's frame until an audit of 2026-12-05."""
    import sympy as sp

    x, prm, f0, gs, h = ob.symbolic_model(4, frame)
    args = [x, prm]
    f0_fn = sp.lambdify(args, f0, "numpy")
    g_fn = sp.lambdify(args, sp.Matrix.hstack(*gs), "numpy")
    h_fn = sp.lambdify(args, h, "numpy")
    num = wm.model_constants(P_HB, wind_frame=frame)
    rng = np.random.default_rng(0)
    for _ in range(10):
        s = random_state(rng)
        u = rng.uniform(300, 700, 4)
        pv = list(num[:10]) + [0.0]
        sym = np.asarray(f0_fn(s, pv), float).ravel() + np.asarray(g_fn(s, pv), float) @ u
        np.testing.assert_allclose(sym, wm.state_derivative(s, u, num)[0], rtol=1e-10,
                                   atol=1e-10)
        meas = np.r_[wm.specific_force(s[None], num)[0], s[3:6], wm.odometry(s[None])[0]]
        np.testing.assert_allclose(np.asarray(h_fn(s, pv), float).ravel(), meas, rtol=1e-10,
                                   atol=1e-10)


def test_full_rank_at_random_states_with_first_order_lie_derivatives():
    rng = np.random.default_rng(1)
    states = [random_state(rng) for _ in range(20)]
    assert [ob.rank_at(P_HB, s) for s in states] == [16] * 20
    # order 0 is not enough: first-order derivatives are the lowest that give full rank
    assert max(ob.rank_at(P_HB, s, order=0) for s in states[:5]) == 12
    cf = wn.vehicle.params("crazyflie_brushless")
    assert ob.rank_at(cf, random_state(rng, cf)) == 16


@pytest.mark.parametrize("changes, frame, expected", [
    (dict(k_d=0.0, c_dx=0.0, c_dy=0.0), "world", 15),             # lift: one combination left
    (dict(k_d=0.0, c_dx=0.0, c_dy=0.0), "body", 15),
    # no equation sees the horizontal wind: in the thesis's body-frame model it stays
    # invisible; with a world-fixed wind the turning body carries it into the vertical axis,
    # where the rotors' vertical drag k_z sees one more direction
    (dict(k_d=0.0, c_dx=0.0, c_dy=0.0, k_h=0.0, c_dz=0.0), "body", 14),
    (dict(k_d=0.0, c_dx=0.0, c_dy=0.0, k_h=0.0, c_dz=0.0), "world", 15),
])
def test_rank_drops_without_horizontal_drag(changes, frame, expected):
    rng = np.random.default_rng(2)
    p = P_HB.replace(**changes)
    assert [ob.rank_at(p, random_state(rng), wind_frame=frame) for _ in range(5)] == \
        [expected] * 5


def test_hover_needs_linear_rotor_drag():
    assert ob.rank_at(P_HB, hover_state()) == 16
    # parasitic drag and lift are quadratic in airspeed: no gradient at zero airspeed
    assert ob.rank_at(P_HB.replace(k_d=0.0), hover_state()) == 14
    assert ob.rank_at(P_HB.replace(k_z=0.0), hover_state()) == 15


def test_bad_arguments():
    with pytest.raises(ValueError, match="'state'"):
        ob.rank_at(P_HB, np.zeros(12))
    with pytest.raises(ValueError, match="'order'"):
        ob.observability_matrix(P_HB, hover_state(), order=5)


def test_hardware_measurement_set_no_accelerometer_needs_second_order():
    """The hardware filter's outputs (gyro, mocap velocity, Euler angles; its differenced
    velocity is d/dt of an output) reach full rank at order 2, not order 1."""
    rng = np.random.default_rng(3)
    states = [random_state(rng) for _ in range(3)]
    assert [ob.rank_at(P_HB, s, measurements="hardware") for s in states] == [12] * 3
    assert [ob.rank_at(P_HB, s, order=2, measurements="hardware") for s in states] == [16] * 3
    # at hover rotor drag still makes the wind observable, and losing it still loses it
    assert ob.rank_at(P_HB, hover_state(), order=2, measurements="hardware") == 16
    assert ob.rank_at(P_HB.replace(k_d=0.0), hover_state(), order=2,
                      measurements="hardware") == 14
    # the hardware rows are a subset of the IMU set's: never more rank at the same order
    O_imu = ob.observability_matrix(P_HB, states[0], order=1)
    O_hw = ob.observability_matrix(P_HB, states[0], order=1, measurements="hardware")
    assert O_hw.shape[0] < O_imu.shape[0]
    with pytest.raises(ValueError, match="'measurements'"):
        ob.rank_at(P_HB, hover_state(), measurements="lidar")
    with pytest.raises(ValueError, match="'wind_frame' parameter of observability_matrix"):
        ob.rank_at(P_HB, hover_state(), wind_frame="earth")
