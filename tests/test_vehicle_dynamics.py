"""Closed-form and invariant checks of the batched multirotor dynamics."""

import dataclasses

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import windnav as wn
from windnav.vehicle import Multirotor, VehicleState


@pytest.mark.parametrize("vehicle", wn.vehicle.VEHICLES)
def test_hover_drift_below_1e9_m_in_10_s(vehicle):
    p = wn.vehicle.params(vehicle)
    model = Multirotor(p)
    s = model.hover_state([1.0, 2.0, 3.0])
    cmd = np.full((1, p.n_rotors), p.hover_rotor_speed)
    for _ in range(1000):
        s = model.step(s, cmd, np.zeros(3), 0.01)
    assert np.max(np.abs(s.position - [1.0, 2.0, 3.0])) <= 1e-9
    assert abs(np.linalg.norm(s.attitude) - 1.0) <= 1e-12


def test_free_spin_conserves_angular_momentum_and_quaternion_norm():
    p = wn.vehicle.params("hummingbird")
    # an asymmetric body with products of inertia, spinning near its intermediate axis
    p = dataclasses.replace(p, inertia=np.array([[3.65e-3, 2e-4, -1e-4],
                                                 [2e-4, 5.0e-3, 3e-4],
                                                 [-1e-4, 3e-4, 7.03e-3]]))
    model = Multirotor(p, aero=False, gravity=False)
    q0 = Rotation.from_euler("xyz", [0.3, -0.2, 1.0]).as_quat()
    s = VehicleState(np.zeros((1, 3)), np.zeros((1, 3)), q0[None], np.array([[1.5, 2.0, -1.0]]),
                     np.zeros((1, 4)))

    def momentum_world(state):
        R = Rotation.from_quat(state.attitude[0]).as_matrix()
        return R @ (p.inertia @ state.body_rates[0])

    L0 = momentum_world(s)
    max_norm_err = 0.0
    for _ in range(1000):
        s = model.step(s, np.zeros((1, 4)), np.zeros(3), 0.01)
        max_norm_err = max(max_norm_err, abs(np.linalg.norm(s.attitude[0]) - 1.0))
    rel = np.linalg.norm(momentum_world(s) - L0) / np.linalg.norm(L0)
    assert rel <= 1e-9
    assert max_norm_err <= 1e-14
    # the body really tumbled (the rates changed direction in the body frame)
    assert np.linalg.norm(s.body_rates[0] - [1.5, 2.0, -1.0]) > 0.1


def test_batch_equals_one_by_one():
    p = wn.vehicle.params("hummingbird")
    model = Multirotor(p)
    rng = np.random.default_rng(0)
    B = 5
    s = VehicleState(rng.normal(size=(B, 3)), rng.normal(size=(B, 3)),
                     Rotation.random(B, random_state=1).as_quat(), rng.normal(size=(B, 3)),
                     rng.uniform(300, 700, size=(B, 4)))
    cmd = rng.uniform(0, 1600, size=(B, 4))
    wind = rng.normal(scale=3, size=(B, 3))
    batched = model.step(s, cmd, wind, 0.01).to_array()
    single = np.vstack([model.step(s[i], cmd[i], wind[i], 0.01).to_array() for i in range(B)])
    np.testing.assert_array_equal(batched, single)


def test_batched_parameters_match_separate_models():
    p1 = wn.vehicle.params("hummingbird")
    p2 = dataclasses.replace(p1, mass=0.7, k_d=3e-4)
    both = Multirotor([p1, p2])
    s = both.hover_state(np.zeros((2, 3)))
    cmd = np.array([[500.0, 520, 480, 510], [600, 600, 600, 600]])
    wind = np.array([[3.0, 1.0, 0.0], [-2.0, 0.5, 0.0]])
    out = both.step(s, cmd, wind, 0.02).to_array()
    for i, p in enumerate((p1, p2)):
        ref = Multirotor(p).step(s[i], cmd[i], wind[i], 0.02).to_array()
        np.testing.assert_array_equal(out[i], ref[0])


@pytest.mark.parametrize("n_rotors", [6, 8])
def test_hexa_and_octo_hover_and_yaw_balance(n_rotors):
    base = wn.vehicle.params("hummingbird")
    p = dataclasses.replace(
        base, name=f"{n_rotors}-rotor",
        rotor_positions=wn.vehicle.symmetric_rotor_positions(n_rotors, 0.2),
        rotor_directions=wn.vehicle.alternating_directions(n_rotors),
    )
    model = Multirotor(p)
    s = model.hover_state([0.0, 0.0, 0.0])
    cmd = np.full((1, n_rotors), p.hover_rotor_speed)
    for _ in range(200):
        s = model.step(s, cmd, np.zeros(3), 0.01)
    assert np.max(np.abs(s.position)) <= 1e-9
    assert np.max(np.abs(s.body_rates)) <= 1e-9
    # speeding up the +1 rotors yaws the vehicle positive (their reaction is dir*k_m*eta^2)
    cmd2 = cmd * np.where(p.rotor_directions > 0, 1.01, 0.99)
    s2 = model.step(s, cmd2, np.zeros(3), 0.05)
    assert s2.body_rates[0, 2] > 0


def test_translational_lift_and_rotor_drag_directions():
    p = wn.vehicle.params("hummingbird")
    model = Multirotor(p)
    s = model.hover_state([0.0, 0.0, 0.0])
    d0 = model.derivatives(s, np.zeros(3))
    d = model.derivatives(s, [5.0, 0.0, 0.0])  # wind blowing toward +x
    # rotor drag pushes the vehicle downwind, translational lift adds thrust
    assert d["force_body"][0, 0] > 0
    assert d["force_body"][0, 2] > d0["force_body"][0, 2]
    eta = p.hover_rotor_speed
    expected_fx = 4 * eta * p.k_d * 5.0 + p.c_dx * 25.0
    np.testing.assert_allclose(d["force_body"][0, 0], expected_fx, rtol=1e-12)
    expected_fz = 4 * (p.k_eta * eta**2 + p.k_h * 25.0)
    np.testing.assert_allclose(d["force_body"][0, 2], expected_fz, rtol=1e-12)


def test_hub_wind_equal_to_com_wind_matches():
    p = wn.vehicle.params("hummingbird")
    model = Multirotor(p)
    s = model.hover_state([0.0, 0.0, 0.0])
    w = np.array([[2.0, -1.0, 0.5]])
    a = model.step(s, np.full(4, 500.0), w, 0.01).to_array()
    b = model.step(s, np.full(4, 500.0), np.repeat(w[:, None, :], 4, axis=1), 0.01).to_array()
    np.testing.assert_allclose(a, b, rtol=0, atol=1e-15)


def _moment_in_a_wind_gradient(wind_axis: int, across_axis: int):
    """``(params, hover rotor speed, hub offsets along across_axis, moment_body)`` of the
    Hummingbird (k_flap 2e-6) in level hover whose hub wind along ``wind_axis`` is
    ``3 + 2 r_i`` with ``r_i`` the hub's body offset along ``across_axis``, m/s."""
    p = wn.vehicle.params("hummingbird", k_flap=2.0e-6)
    model = Multirotor(p)
    offsets = p.rotor_positions[:, across_axis]
    hub = np.zeros((1, 4, 3))
    hub[0, :, wind_axis] = 3.0 + 2.0 * offsets
    m = model.derivatives(model.hover_state([0.0, 0.0, 0.0]), hub)["moment_body"][0]
    return p, p.hover_rotor_speed, offsets, m


def test_wind_gradient_moment_matches_the_closed_form():
    """Level hover, x-wind u_i = 3 + 2 y_i at hub i of the quad-X (sum y_i = sum x_i y_i = 0,
    sum y_i^3 = sum x_i y_i^2 = 0). Each rotor carries f_i = (k_d eta u_i, 0, k_eta eta^2 +
    k_h u_i^2) and the flapping moment (0, -k_flap eta u_i, 0); summing r_i x f_i + Mf_i + My_i
    (the k_m yaw moments cancel at equal speeds):

        M_x = k_h sum y_i u_i^2 = 12 k_h sum y_i^2
        M_y = -k_h sum x_i u_i^2 - k_flap eta sum u_i = -12 k_flap eta
        M_z = -k_d eta sum y_i u_i = -2 k_d eta sum y_i^2
    """
    p, eta, y, m = _moment_in_a_wind_gradient(wind_axis=0, across_axis=1)  # u grows along y
    sy2 = np.sum(y**2)
    expected = [12.0 * p.k_h * sy2, -12.0 * p.k_flap * eta, -2.0 * p.k_d * eta * sy2]
    np.testing.assert_allclose(m, expected, rtol=1e-9, atol=0.0)
    assert min(abs(v) for v in expected) > 1e-4  # every term is far above round-off


def test_flapping_moment_of_a_y_wind_gradient_matches_the_closed_form():
    """The y-airflow companion of the test above (which checks only the flapping M_y). Level
    hover, y-wind v_i = 3 + 2 x_i at hub i of the quad-X (sum x_i = sum x_i y_i = sum x_i^2 y_i
    = 0, sum v_i = 12). Hub airspeed (0, -v_i, 0), so f_i = (0, k_d eta v_i, k_eta eta^2 +
    k_h v_i^2) and the flapping moment Mf_i = -k_flap eta (v_a,i x e3) = (k_flap eta v_i, 0, 0):

        M_x = k_h sum y_i v_i^2 + k_flap eta sum v_i = 12 k_flap eta
        M_y = -k_h sum x_i v_i^2 = -12 k_h sum x_i^2
        M_z = k_d eta sum x_i v_i = 2 k_d eta sum x_i^2
    """
    p, eta, x, m = _moment_in_a_wind_gradient(wind_axis=1, across_axis=0)  # v grows along x
    sx2 = np.sum(x**2)
    expected = [12.0 * p.k_flap * eta, -12.0 * p.k_h * sx2, 2.0 * p.k_d * eta * sx2]
    np.testing.assert_allclose(m, expected, rtol=1e-9, atol=0.0,
                               err_msg="moment_body (M_x carries the flapping term)")
    assert min(abs(v) for v in expected) > 1e-4  # every term is far above round-off


@pytest.mark.parametrize(
    "kwargs, name",
    [
        (dict(dt=0.0), "dt"),
        (dict(dt=-0.01), "dt"),
        (dict(cmd=np.array([np.nan, 1, 1, 1.0])), "rotor_speed_cmd"),
        (dict(wind=np.array([np.nan, 0, 0])), "wind_world"),
        (dict(cmd=np.ones(3)), "rotor_speed_cmd"),
        (dict(wind=np.ones(2)), "wind_world"),
    ],
)
def test_bad_input_names_the_argument(kwargs, name):
    p = wn.vehicle.params("hummingbird")
    model = Multirotor(p)
    s = model.hover_state([0.0, 0.0, 0.0])
    args = dict(dt=0.01, cmd=np.full(4, 400.0), wind=np.zeros(3))
    args.update(kwargs)
    with pytest.raises(ValueError, match=f"'{name}'"):
        model.step(s, args["cmd"], args["wind"], args["dt"])


@pytest.mark.parametrize("field, value, match", [
    ("attitude", np.zeros((1, 4)), "a non-zero attitude quaternion"),  # ZeroDivisionError before
    ("attitude", np.array([[0, 0, 0, 1e-200]]), "a non-zero attitude quaternion"),
    ("position", np.zeros(3), r"position of shape \(B, 3\)"),  # numpy's AxisError before
    ("velocity", np.zeros((2, 3)), r"velocity of shape \(B, 3\)"),  # concatenate's message
    ("rotor_speeds", np.zeros((1, 6)), r"rotor_speeds of shape \(B, 4\)"),
])
def test_a_malformed_state_names_its_field(field, value, match):
    model = Multirotor(wn.vehicle.params("hummingbird"))
    s = dataclasses.replace(model.hover_state([0.0, 0.0, 0.0]), **{field: value})
    with pytest.raises(ValueError, match="'state' parameter of Multirotor.step must have "
                                         + match):
        model.step(s, np.full(4, 400.0), np.zeros(3), 0.01)
    with pytest.raises(ValueError, match="'state' parameter of Multirotor.derivatives"):
        model.derivatives(s, np.zeros(3))


def test_state_indexing_counts_from_the_end_and_checks_the_range():
    model = Multirotor(wn.vehicle.params("hummingbird"))
    s = model.hover_state([[0.0, 0.0, 0.0], [1.0, 2.0, 3.0], [4.0, 5.0, 6.0]])
    np.testing.assert_array_equal(s[-1].position, [[4.0, 5.0, 6.0]])  # was empty
    np.testing.assert_array_equal(s[1].position, [[1.0, 2.0, 3.0]])
    for bad in (3, 5, -4):
        with pytest.raises(IndexError, match="out of range for a batch of 3"):
            s[bad]
    assert s[1:].batch_size == 2


@pytest.mark.parametrize("params", ["hummingbird", None, [None]])
def test_a_model_of_something_else_than_params_is_named(params):
    with pytest.raises(ValueError, match="'params' parameter of pack_params must be "
                                         "MultirotorParams"):
        Multirotor(params)


def test_unknown_vehicle_name():
    with pytest.raises(ValueError, match="'name'"):
        wn.vehicle.params("blimp")


def test_commands_beyond_limits_are_clipped():
    p = wn.vehicle.params("hummingbird")
    model = Multirotor(p)
    s = model.hover_state([0.0, 0.0, 0.0])
    a = model.step(s, np.full(4, 5000.0), np.zeros(3), 0.01).to_array()
    b = model.step(s, np.full(4, p.rotor_speed_max), np.zeros(3), 0.01).to_array()
    np.testing.assert_array_equal(a, b)
    clipped, sat = model.clip_rotor_speeds(np.array([[-5.0, 100.0, 2000.0, 1500.0]]))
    np.testing.assert_array_equal(clipped, [[0.0, 100.0, 1500.0, 1500.0]])
    np.testing.assert_array_equal(sat, [[True, False, True, False]])


# Translational lift: RotorPy's model (default) and the bounded option ------------------------
def _lift_state(model, p, eta):
    s = model.hover_state([0.0, 0.0, 0.0])
    return VehicleState(s.position, s.velocity, s.attitude, s.body_rates,
                        np.full((1, p.n_rotors), float(eta)))


@pytest.mark.parametrize("vehicle", wn.vehicle.VEHICLES)
def test_bounded_lift_closed_form_from_stopped_rotors_to_hover(vehicle):
    """Level, at rest, in a horizontal wind V (so v_a,z = 0: no axial drag, no vertical
    parasitic drag): F_z = sum_i (k_eta eta^2 + k_h V^2 s), s = min(1, k_eta eta^2 / T_ref)."""
    rotorpy = wn.vehicle.params(vehicle)
    bounded = rotorpy.replace(translational_lift="bounded")
    V = 8.0
    wind = np.array([[V * 0.6, -V * 0.8, 0.0]])
    t_ref = rotorpy.mass * wn.vehicle.GRAVITY / rotorpy.n_rotors
    for frac in (0.0, 0.25, 0.5, 1.0, 1.7):
        eta = np.sqrt(frac * t_ref / rotorpy.k_eta)
        f_rp = Multirotor(rotorpy).derivatives(_lift_state(Multirotor(rotorpy), rotorpy, eta), wind)
        f_b = Multirotor(bounded).derivatives(_lift_state(Multirotor(bounded), bounded, eta), wind)
        thrust = rotorpy.n_rotors * rotorpy.k_eta * eta**2
        lift = rotorpy.n_rotors * rotorpy.k_h * V**2
        np.testing.assert_allclose(f_rp["force_body"][0, 2], thrust + lift, rtol=1e-12)
        np.testing.assert_allclose(f_b["force_body"][0, 2], thrust + lift * min(1.0, frac),
                                   rtol=1e-12, atol=1e-15)
        # the in-plane forces (rotor and parasitic drag) do not depend on the lift model
        np.testing.assert_array_equal(f_b["force_body"][0, :2], f_rp["force_body"][0, :2])
        if frac >= 1.0:  # at and above hover thrust the two models agree
            np.testing.assert_allclose(f_b["force_body"], f_rp["force_body"], rtol=1e-12)
            np.testing.assert_allclose(f_b["moment_body"], f_rp["moment_body"], rtol=1e-12,
                                       atol=1e-15)
    # stopped rotors: no lift at all with the bounded model
    f0 = Multirotor(bounded).derivatives(_lift_state(Multirotor(bounded), bounded, 0.0), wind)
    assert f0["force_body"][0, 2] == 0.0


def test_stopped_rotors_in_a_30_m_s_wind_climb_only_with_rotorpy_lift():
    """Issue 13: with RotorPy's lift a Crazyflie whose rotors are stopped climbs in a 30 m/s
    wind (lift 4 k_h V^2 = 4.0 N against a weight of 0.43 N); the bounded lift lets it fall."""
    p = wn.vehicle.params("crazyflie_brushless")
    out = {}
    for model_name in ("rotorpy", "bounded"):
        model = Multirotor(p.replace(translational_lift=model_name))
        s = _lift_state(model, p, 0.0)
        for _ in range(20):
            s = model.step(s, np.zeros((1, 4)), [30.0, 0.0, 0.0], 0.005)
        out[model_name] = s.velocity[0, 2]
    assert out["rotorpy"] > 0.0
    # free fall: no thrust, no lift, no vertical drag (c_dz = 0 for this vehicle)
    np.testing.assert_allclose(out["bounded"], -wn.vehicle.GRAVITY * 0.1, rtol=1e-9)


def test_lift_model_and_airspeed_limit_are_validated():
    p = wn.vehicle.params("hummingbird")
    with pytest.raises(ValueError, match="'translational_lift'"):
        p.replace(translational_lift="momentum")
    with pytest.raises(ValueError, match="'max_airspeed'"):
        p.replace(max_airspeed=-1.0)
    assert p.replace(max_airspeed=12.0).airspeed_limit == 12.0


def test_an_empty_batch_steps_to_an_empty_batch():
    """hover_state took a batch of 0, but step and derivatives failed inside the compiled
    kernel with "range() arg 3 must not be zero", naming no argument (fuzz audit)."""
    m = wn.vehicle.Multirotor(wn.vehicle.params("hummingbird"))
    s0 = m.hover_state(np.zeros((0, 3)))
    s1 = m.step(s0, np.zeros((0, 4)), np.zeros(3), 0.01)
    assert s1.position.shape == (0, 3) and s1.rotor_speeds.shape == (0, 4)
    d = m.derivatives(s0, np.zeros(3))
    assert all(v.shape == (0, 3) for v in d.values())
