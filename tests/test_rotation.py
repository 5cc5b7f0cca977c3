"""The quaternion helpers against SciPy's Rotation."""

import numpy as np
from scipy.spatial.transform import Rotation

from windnav.vehicle.rotation import quat_from_rotvec, quat_multiply, quat_to_matrix


def test_against_scipy():
    rng = np.random.default_rng(3)
    p = Rotation.random(50, random_state=1)
    q = Rotation.random(50, random_state=2)
    np.testing.assert_allclose(quat_to_matrix(p.as_quat()), p.as_matrix(), atol=1e-14)
    prod = quat_multiply(p.as_quat(), q.as_quat())
    np.testing.assert_allclose(quat_to_matrix(prod), (p * q).as_matrix(), atol=1e-14)
    rv = rng.normal(size=(50, 3)) * np.logspace(-9, 0.5, 50)[:, None]
    np.testing.assert_allclose(quat_to_matrix(quat_from_rotvec(rv)),
                               Rotation.from_rotvec(rv).as_matrix(), atol=1e-14)


def test_euler_zyx_matrices_against_scipy():
    from windnav.vehicle.rotation import euler_zyx_to_matrix

    rng = np.random.default_rng(4)
    e = rng.uniform([-np.pi, -1.5, -np.pi], [np.pi, 1.5, np.pi], size=(50, 3))
    R = euler_zyx_to_matrix(e)
    np.testing.assert_allclose(R, Rotation.from_euler("ZYX", e).as_matrix(), atol=1e-14)
    # leading axes are kept; a single triple gives a single matrix
    assert euler_zyx_to_matrix(e.reshape(5, 10, 3)).shape == (5, 10, 3, 3)
    np.testing.assert_array_equal(euler_zyx_to_matrix(e[7]), R[7])
