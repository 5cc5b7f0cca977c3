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
