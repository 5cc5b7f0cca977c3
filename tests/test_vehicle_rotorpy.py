"""windnav's dynamics against RotorPy's ``Multirotor`` (the reference physics).

Same parameters, initial state, constant rotor-speed commands and constant wind; RotorPy is
integrated tightly (RK45, rtol = atol = 1e-11) for 2 s at 100 Hz, windnav with its fixed-step
RK4. Positions must agree to 1e-4 m and attitudes to 1e-5 rad.
"""

import numpy as np
import pytest
from rotorpy.vehicles import multirotor as rotorpy_multirotor  # the reference: required
from scipy.spatial.transform import Rotation

import windnav as wn

WINDS = [(0.0, 0.0, 0.0), (4.0, -2.0, 0.0), (-3.0, 5.0, 1.0), (8.0, 0.0, -0.5)]
DT = 0.01
STEPS = 200


def _initial(p, manoeuvre: bool):
    if manoeuvre:
        q = Rotation.from_euler("xyz", [0.35, -0.25, 0.6]).as_quat()
        rates = np.array([0.4, -0.3, 0.2])
        vel = np.array([1.0, -0.5, 0.3])
    else:
        q = np.array([0.0, 0.0, 0.0, 1.0])
        rates = np.zeros(3)
        vel = np.zeros(3)
    eta = np.full(p.n_rotors, p.hover_rotor_speed)
    return q, rates, vel, eta


def _commands(p, manoeuvre: bool):
    h = p.hover_rotor_speed
    if manoeuvre:
        # a rolled/pitched, yawing manoeuvre: differential commands around hover
        return h * np.array([1.03, 0.99, 1.01, 0.985])
    return np.full(p.n_rotors, h)


def _fly_rotorpy(p, wind, manoeuvre):
    q, rates, vel, eta = _initial(p, manoeuvre)
    state = {"x": np.zeros(3), "v": vel.copy(), "q": q.copy(), "w": rates.copy(),
             "wind": np.array(wind, dtype=float), "rotor_speeds": eta.copy()}
    vehicle = rotorpy_multirotor.Multirotor(
        wn.vehicle.params_to_rotorpy_dict(p), initial_state=state, aero=True,
        integrator_kwargs={"method": "RK45", "rtol": 1e-11, "atol": 1e-11},
    )
    cmd = {"cmd_motor_speeds": _commands(p, manoeuvre)}
    pos, att = [], []
    for _ in range(STEPS):
        state["wind"] = np.array(wind, dtype=float)
        state = vehicle.step(state, cmd, DT)
        pos.append(state["x"].copy())
        att.append(state["q"].copy())
    return np.array(pos), np.array(att)


def _fly_windnav(p, wind, manoeuvre):
    q, rates, vel, eta = _initial(p, manoeuvre)
    model = wn.vehicle.Multirotor(p)
    s = wn.vehicle.VehicleState(np.zeros((1, 3)), vel[None], q[None], rates[None], eta[None])
    cmd = _commands(p, manoeuvre)[None]
    pos, att = [], []
    for _ in range(STEPS):
        s = model.step(s, cmd, np.array(wind)[None], DT)
        pos.append(s.position[0].copy())
        att.append(s.attitude[0].copy())
    return np.array(pos), np.array(att)


def _angle(q1, q2):
    return (Rotation.from_quat(q1).inv() * Rotation.from_quat(q2)).magnitude()


@pytest.mark.parametrize("vehicle", ["hummingbird", "crazyflie_brushless"])
@pytest.mark.parametrize("manoeuvre", [False, True], ids=["hover", "manoeuvre"])
@pytest.mark.parametrize("wind", WINDS, ids=lambda w: f"wind{w}")
def test_agrees_with_rotorpy(vehicle, manoeuvre, wind):
    p = wn.vehicle.params(vehicle)
    pos_ref, att_ref = _fly_rotorpy(p, wind, manoeuvre)
    pos, att = _fly_windnav(p, wind, manoeuvre)
    # the flight must actually move for the comparison to mean something
    assert np.max(np.abs(pos_ref)) > 0.05 or not (manoeuvre or any(wind))
    assert np.max(np.abs(pos - pos_ref)) <= 1e-4
    assert np.max(_angle(att, att_ref)) <= 1e-5
