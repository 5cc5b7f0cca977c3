"""Rotation formulas, written once: quaternions (scalar-last ``[x, y, z, w]``) and ZYX Euler.

Two scalar Numba helpers hold the formulas; kernels (dynamics, SE(3) control, the Wind UKF
model) inline them, and the batched NumPy-facing functions below loop over them::

    quaternion (normalised first, as scipy.spatial.transform.Rotation does):
        R = [[1 - 2(y^2 + z^2), 2(xy - zw),       2(xz + yw)],
             [2(xy + zw),       1 - 2(x^2 + z^2), 2(yz - xw)],
             [2(xz - yw),       2(yz + xw),       1 - 2(x^2 + y^2)]]
    ZYX Euler (psi yaw, theta pitch, phi roll), body to world:
        R = Rz(psi) Ry(theta) Rx(phi)

Both return the nine entries row by row (``r00, r01, r02, r10, ...``). The NumPy helpers avoid
constructing ``scipy.spatial.transform.Rotation`` objects in per-step loops, where the object
overhead dominates for small batches. ``test_rotation.py`` checks them against SciPy.
"""

from __future__ import annotations

import numpy as np

from windnav._jit import njit

__all__ = [
    "euler_zyx_to_rotation",
    "euler_zyx_to_matrix",
    "quat_from_rotvec",
    "quat_multiply",
    "quat_to_matrix",
    "quat_to_rotation",
]


@njit(cache=True, inline="always")
def quat_to_rotation(qx, qy, qz, qw):
    """Row-major entries of the rotation matrix of a (not necessarily unit) quaternion."""
    n = np.sqrt(qx * qx + qy * qy + qz * qz + qw * qw)
    x = qx / n
    y = qy / n
    z = qz / n
    w = qw / n
    return (1.0 - 2.0 * (y * y + z * z), 2.0 * (x * y - z * w), 2.0 * (x * z + y * w),
            2.0 * (x * y + z * w), 1.0 - 2.0 * (x * x + z * z), 2.0 * (y * z - x * w),
            2.0 * (x * z - y * w), 2.0 * (y * z + x * w), 1.0 - 2.0 * (x * x + y * y))


@njit(cache=True, inline="always")
def euler_zyx_to_rotation(psi, theta, phi):
    """Row-major entries of ``Rz(psi) Ry(theta) Rx(phi)`` (angles in rad)."""
    cps, sps = np.cos(psi), np.sin(psi)
    cth, sth = np.cos(theta), np.sin(theta)
    cph, sph = np.cos(phi), np.sin(phi)
    return (cps * cth, cps * sth * sph - sps * cph, cps * sth * cph + sps * sph,
            sps * cth, sps * sth * sph + cps * cph, sps * sth * cph - cps * sph,
            -sth, cth * sph, cth * cph)


@njit(cache=True)
def _quat_matrices(q, out):
    for b in range(q.shape[0]):
        r = quat_to_rotation(q[b, 0], q[b, 1], q[b, 2], q[b, 3])
        for k in range(9):
            out[b, k // 3, k % 3] = r[k]


@njit(cache=True)
def _euler_matrices(e, out):
    for b in range(e.shape[0]):
        r = euler_zyx_to_rotation(e[b, 0], e[b, 1], e[b, 2])
        for k in range(9):
            out[b, k // 3, k % 3] = r[k]


def _last_axis(a, width: int, name: str, where: str) -> np.ndarray:
    """``a`` as an array whose last axis has ``width`` entries, else a ValueError naming it."""
    try:
        arr = np.asarray(a)
    except ValueError:  # ragged
        arr = None
    if arr is None or arr.ndim == 0 or arr.shape[-1] != width:
        raise ValueError(f"The {name!r} parameter of {where} must be an array of shape "
                         f"(..., {width}). Got shape {np.shape(arr)} instead.")
    return arr


def _batched(fn, a: np.ndarray, width: int, name: str, where: str) -> np.ndarray:
    try:
        a = np.asarray(a, dtype=np.float64)
        flat = np.ascontiguousarray(a.reshape(-1, width))
        out = np.empty((flat.shape[0], 3, 3))
        fn(flat, out)
        return out.reshape(a.shape[:-1] + (3, 3))
    except (ValueError, ZeroDivisionError):  # another last axis fails a reshape, a zero
        # quaternion divides by zero: say so by name (no test on the per-step path)
        try:
            a = _last_axis(a, width, name, where)
        except ValueError as named:
            raise named from None
        if width == 4 and not np.all(np.any(a != 0.0, axis=-1)):
            raise ValueError(f"The {name!r} parameter of {where} must hold non-zero "
                             "quaternions (the rotation divides by the norm). Got a zero "
                             "one.") from None
        raise


def quat_multiply(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Hamilton product ``p (x) q`` of batches (B, 4); the rotation ``p`` after ``q``.

    Raises
    ------
    ValueError
        Naming ``p`` or ``q`` when its last axis does not hold 4 entries.
    """
    p = _last_axis(p, 4, "p", "quat_multiply")
    q = _last_axis(q, 4, "q", "quat_multiply")
    px, py, pz, pw = p[..., 0], p[..., 1], p[..., 2], p[..., 3]
    qx, qy, qz, qw = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    return np.stack([
        pw * qx + px * qw + py * qz - pz * qy,
        pw * qy - px * qz + py * qw + pz * qx,
        pw * qz + px * qy - py * qx + pz * qw,
        pw * qw - px * qx - py * qy - pz * qz,
    ], axis=-1)


def quat_from_rotvec(rotvec: np.ndarray) -> np.ndarray:
    """Quaternions (B, 4) of rotation vectors (B, 3) (axis times angle, rad).

    Raises
    ------
    ValueError
        Naming ``rotvec`` when its last axis does not hold 3 entries.
    """
    rotvec = _last_axis(rotvec, 3, "rotvec", "quat_from_rotvec")
    angle = np.linalg.norm(rotvec, axis=-1, keepdims=True)
    half = 0.5 * angle
    # sin(a/2)/a, with its Taylor series near zero
    small = angle < 1e-6
    scale = np.where(small, 0.5 - angle**2 / 48.0, np.sin(half) / np.where(small, 1.0, angle))
    return np.concatenate([rotvec * scale, np.cos(half)], axis=-1)


def quat_to_matrix(q: np.ndarray) -> np.ndarray:
    """Rotation matrices of (not necessarily unit) quaternions.

    Parameters
    ----------
    q : ndarray of shape (..., 4)
        ``[qx, qy, qz, qw]``.

    Returns
    -------
    ndarray of shape (..., 3, 3)
        Body-to-world rotation matrices.

    Raises
    ------
    ValueError
        Naming ``q`` when its last axis does not hold 4 entries or a quaternion is zero.
    """
    return _batched(_quat_matrices, q, 4, "q", "quat_to_matrix")


def euler_zyx_to_matrix(euler: np.ndarray) -> np.ndarray:
    """Rotation matrices ``Rz(psi) Ry(theta) Rx(phi)`` (body to world).

    Parameters
    ----------
    euler : ndarray of shape (..., 3)
        ``(psi, theta, phi)``, rad.

    Returns
    -------
    ndarray of shape (..., 3, 3)

    Raises
    ------
    ValueError
        Naming ``euler`` when its last axis does not hold 3 entries.
    """
    return _batched(_euler_matrices, euler, 3, "euler", "euler_zyx_to_matrix")
