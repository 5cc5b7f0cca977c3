"""windnav's SE(3) controller against RotorPy's ``SE3Control`` (the reference control law).

Both controllers get the same vehicle (``params_to_rotorpy_dict``), the same gains, the same
state and the same flat output (position, velocity, acceleration, jerk, snap, yaw, yaw rate;
neither law uses jerk or snap). The commanded collective thrust, body moment and rotor speeds
must agree to 1e-9 relative.

Deliberate differences, documented here and tested for what agrees:

- A rotor whose allocated thrust is negative gets ``-sqrt(|f| / k_eta)`` from RotorPy (a
  reversed rotor) but 0 rad/s from windnav (rotors cannot reverse); the wrench is the same.
- A commanded free fall (desired force exactly zero) makes RotorPy normalise a zero vector
  (NaN commands, or an exception from SciPy); windnav keeps the current attitude and commands
  zero thrust.
"""

import numpy as np
import pytest
from rotorpy.controllers.quadrotor_control import SE3Control  # the reference: required
from scipy.spatial.transform import Rotation

import windnav as wn
from windnav.control import SE3Controller, SE3Gains
from windnav.vehicle import VehicleState

B = 40


def _pair(vehicle, kp_att=None, kd_att=None):
    p = wn.vehicle.params(vehicle)
    quad = wn.vehicle.params_to_rotorpy_dict(p)
    if kp_att is not None:
        quad.update(kp_att=kp_att, kd_att=kd_att)
    ref = SE3Control(quad)
    gains = SE3Gains(kp_pos=tuple(ref.kp_pos), kd_pos=tuple(ref.kd_pos), kp_att=ref.kp_att,
                     kd_att=ref.kd_att)
    return p, ref, SE3Controller(p, gains)


def _states(p, rng):
    """Tilted (up to ~0.4 rad), rotating, moving vehicles; unnormalised quaternions."""
    q = Rotation.from_rotvec(rng.normal(scale=0.2, size=(B, 3))).as_quat()
    q *= rng.uniform(0.5, 2.0, size=(B, 1))
    return VehicleState(rng.normal(scale=0.3, size=(B, 3)), rng.normal(scale=0.5, size=(B, 3)),
                        q, rng.normal(scale=0.5, size=(B, 3)),
                        np.full((B, p.n_rotors), p.hover_rotor_speed))


def _flat(rng):
    return {"x": rng.normal(scale=0.3, size=(B, 3)), "x_dot": rng.normal(scale=0.5, size=(B, 3)),
            "x_ddot": rng.normal(scale=1.0, size=(B, 3)), "x_dddot": rng.normal(size=(B, 3)),
            "x_ddddot": rng.normal(size=(B, 3)), "yaw": rng.uniform(-np.pi, np.pi, B),
            "yaw_dot": rng.normal(scale=0.5, size=B)}


def _rotorpy(ref, s, flat):
    out = {"speeds": [], "thrusts": [], "thrust": [], "moment": []}
    for b in range(s.batch_size):
        st = {"x": s.position[b], "v": s.velocity[b], "q": s.attitude[b], "w": s.body_rates[b]}
        c = ref.update(0.0, st, {k: v[b] for k, v in flat.items()})
        out["speeds"].append(c["cmd_motor_speeds"])
        out["thrusts"].append(c["cmd_motor_thrusts"])
        out["thrust"].append(c["cmd_thrust"])
        out["moment"].append(c["cmd_moment"])
    return {k: np.array(v) for k, v in out.items()}


def _assert_agree(p, cmd, wrench, got, positive):
    np.testing.assert_allclose(wrench[:, 0], got["thrust"], rtol=1e-9, atol=0.0)
    scale = np.max(np.abs(got["moment"]))
    np.testing.assert_allclose(wrench[:, 1:], got["moment"], rtol=1e-9, atol=1e-9 * scale)
    np.testing.assert_allclose(cmd[positive], got["speeds"][positive], rtol=1e-9, atol=0.0)


@pytest.mark.parametrize("vehicle, gains", [
    ("hummingbird", (None, None)),
    ("crazyflie_brushless", (None, None)),
    ("crazyflie_brushless", (3264.54, 361.58)),  # RotorPy's own gains for this vehicle
])
def test_position_mode_matches_rotorpy(vehicle, gains):
    p, ref, ours = _pair(vehicle, *gains)
    rng = np.random.default_rng(0)
    s, flat = _states(p, rng), _flat(rng)
    cmd, wrench = ours.track(s.to_array(), flat["x"], flat["x_dot"], flat["x_ddot"], flat["yaw"],
                             flat["yaw_dot"])
    got = _rotorpy(ref, s, flat)
    positive = got["thrusts"] > 0
    # large yaw errors: many rotors are comparable speed by speed, some need reversed thrust
    assert positive.sum() >= B and (~positive).sum() >= 1
    _assert_agree(p, cmd, wrench, got, positive)
    # a negative allocated thrust: RotorPy reverses the rotor, windnav stops it
    np.testing.assert_array_equal(cmd[~positive], 0.0)
    np.testing.assert_allclose(got["speeds"][~positive],
                               -np.sqrt(-got["thrusts"][~positive] / p.k_eta), rtol=1e-12)


def test_acceleration_mode_is_position_mode_without_tracking_error():
    """``accelerate(a)`` equals RotorPy's law with the flat output at the vehicle's own
    position and velocity and ``x_ddot = a``."""
    p, ref, ours = _pair("hummingbird")
    rng = np.random.default_rng(1)
    s = _states(p, rng)
    flat = _flat(rng)
    flat["x"], flat["x_dot"] = s.position.copy(), s.velocity.copy()
    cmd, wrench = ours.accelerate(s.to_array(), flat["x_ddot"], flat["yaw"], flat["yaw_dot"])
    got = _rotorpy(ref, s, flat)
    _assert_agree(p, cmd, wrench, got, got["thrusts"] > 0)


def test_commanded_free_fall_keeps_windnav_finite_where_rotorpy_is_not():
    p, ref, ours = _pair("hummingbird")
    s = wn.vehicle.Multirotor(p).hover_state(np.zeros(3))
    g = np.array([[0.0, 0.0, -wn.vehicle.GRAVITY]])
    cmd, wrench = ours.accelerate(s.to_array(), g, np.zeros(1))
    np.testing.assert_allclose(wrench, 0.0, atol=1e-12)
    np.testing.assert_allclose(cmd, 0.0, atol=1e-3)
    flat = {"x": s.position, "x_dot": s.velocity, "x_ddot": g, "x_dddot": g, "x_ddddot": g,
            "yaw": np.zeros(1), "yaw_dot": np.zeros(1)}
    with np.errstate(invalid="ignore", divide="ignore"):
        try:
            rotorpy_finite = np.all(np.isfinite(_rotorpy(ref, s, flat)["speeds"]))
        except np.linalg.LinAlgError:  # SciPy cannot turn its NaN attitude into a quaternion
            rotorpy_finite = False
    assert not rotorpy_finite
