"""The packed layouts: every named column and block holds what its name says."""

import dataclasses

import numpy as np
from scipy.spatial.transform import Rotation

import windnav as wn
from windnav.estimate import layout as est
from windnav.estimate import wind_model as wm
from windnav.vehicle import layout
from windnav.vehicle.dynamics import pack_params


def test_packed_parameter_columns_hold_the_named_parameters():
    p = wn.vehicle.params("hummingbird", k_flap=1e-6, translational_lift="bounded")
    q = wn.vehicle.params("crazyflie_brushless")
    packed = pack_params([p, q])
    assert packed.scalars.shape == (2, layout.N_SCALARS) == (2, len(layout.SCALAR_NAMES))
    fields = {f.name for f in dataclasses.fields(wn.vehicle.MultirotorParams)}
    for col, name in enumerate(layout.SCALAR_NAMES):
        assert getattr(layout, name.upper()) == col
        if name in fields:
            np.testing.assert_array_equal(packed.scalars[:, col], [getattr(p, name),
                                                                  getattr(q, name)])
    np.testing.assert_array_equal(packed.scalars[:, layout.G], wn.vehicle.GRAVITY)
    np.testing.assert_array_equal(packed.scalars[:, layout.LIFT_BOUNDED], [1.0, 0.0])
    np.testing.assert_allclose(packed.scalars[:, layout.LIFT_INV_THRUST],
                               [p.n_rotors / p.weight, q.n_rotors / q.weight], rtol=1e-15)
    # the accessors read the same columns, and cannot write into the kernels' arrays
    np.testing.assert_array_equal(packed.k_eta, [p.k_eta, q.k_eta])
    np.testing.assert_array_equal(packed.rotor_speed_max, [p.rotor_speed_max,
                                                           q.rotor_speed_max])
    assert not packed.mass.flags.writeable
    np.testing.assert_allclose(packed.hover_rotor_speed,
                               [p.hover_rotor_speed, q.hover_rotor_speed], rtol=1e-15)
    no_aero = pack_params(p, aero=False, gravity=False)
    for col in (layout.K_D, layout.K_Z, layout.K_H, layout.K_FLAP, layout.C_DX, layout.C_DY,
                layout.C_DZ, layout.G):
        assert no_aero.scalars[0, col] == 0.0


def test_packed_state_blocks_are_the_state_fields():
    rng = np.random.default_rng(0)
    s = wn.vehicle.VehicleState(rng.normal(size=(3, 3)), rng.normal(size=(3, 3)),
                                Rotation.random(3, random_state=1).as_quat(),
                                rng.normal(size=(3, 3)), rng.normal(size=(3, 6)))
    x = s.to_array()
    assert x.shape == (3, layout.N_RIGID + 6)
    np.testing.assert_array_equal(x[:, layout.POSITION], s.position)
    np.testing.assert_array_equal(x[:, layout.VELOCITY], s.velocity)
    np.testing.assert_array_equal(x[:, layout.ATTITUDE], s.attitude)
    np.testing.assert_array_equal(x[:, layout.BODY_RATES], s.body_rates)
    np.testing.assert_array_equal(x[:, layout.ROTOR_SPEEDS], s.rotor_speeds)
    for offset, block in ((layout.POS, layout.POSITION), (layout.VEL, layout.VELOCITY),
                          (layout.QUAT, layout.ATTITUDE), (layout.RATES, layout.BODY_RATES),
                          (layout.ROTORS, layout.ROTOR_SPEEDS)):
        assert block.start == offset
    np.testing.assert_array_equal(wn.vehicle.VehicleState.from_array(x).to_array(), x)


def test_wind_ukf_layouts_name_the_state_and_the_constants():
    p = wn.vehicle.params("hummingbird")
    labels = est.state_labels(4)
    assert labels[est.IDX_EULER] == ["psi", "theta", "phi"]
    assert labels[est.IDX_RATES] == ["p", "q", "r"]
    assert labels[est.IDX_VELOCITY] == ["vx_b", "vy_b", "vz_b"]
    assert labels[est.IDX_WIND] == ["wx_b", "wy_b", "wz_b"]
    assert labels[est.IDX_ROTORS] == [f"eta_{i}" for i in range(4)]
    assert wm.IDX_WIND == est.IDX_WIND and wm.state_labels is est.state_labels
    prm = wm.model_constants(p, wind_frame="world")
    assert prm.shape == (est.N_PRM,)
    for name in ("mass", "k_eta", "k_d", "k_z", "k_h", "c_dx", "c_dy", "c_dz", "tau_m"):
        assert prm[getattr(est, "PRM_" + name.upper())] == getattr(p, name)
    assert prm[est.PRM_G] == wn.vehicle.GRAVITY and prm[est.PRM_WORLD_WIND] == 1.0
    assert wm.model_constants(p, wind_frame="body")[est.PRM_WORLD_WIND] == 0.0
    # the odometry block: world velocity then the Euler angles of the state
    x = np.zeros(16)
    x[est.IDX_EULER] = [0.3, -0.2, 0.1]
    x[est.IDX_VELOCITY] = [1.0, 2.0, 3.0]
    odom = wm.odometry(x[None])[0]
    np.testing.assert_array_equal(odom[est.ODOM_EULER], x[est.IDX_EULER])
    np.testing.assert_allclose(odom[est.ODOM_VELOCITY],
                               wm.euler_to_matrix(x[est.IDX_EULER])[0] @ x[est.IDX_VELOCITY],
                               atol=1e-15)


def test_kernels_are_not_exported_from_the_subpackages():
    import warnings

    import pytest

    for pkg, name in ((wn.vehicle, "pack_params"), (wn.vehicle, "PackedParams"),
                      (wn.control, "se3_kernel")):
        assert name not in pkg.__all__
        with pytest.warns(DeprecationWarning, match=name):
            getattr(pkg, name)
    with pytest.warns(DeprecationWarning, match="params_to_rotorpy_dict"):
        old = wn.vehicle.to_rotorpy_dict(wn.vehicle.params("hummingbird"))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        new = wn.vehicle.params_to_rotorpy_dict(wn.vehicle.params("hummingbird"))
    assert old.keys() == new.keys() and old["k_h"] == new["k_h"]
