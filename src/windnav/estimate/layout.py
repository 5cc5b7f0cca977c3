"""The packed layouts of the Wind UKF: its state, its model constants, its odometry block.

State ``x`` of shape (12 + N,) (index: meaning, unit)::

    EULER    0..2   psi, theta, phi   ZYX Euler angles, body to world, rad
    RATES    3..5   p, q, r           body rates, rad/s
    VELOCITY 6..8   v_b               body-frame velocity, m/s
    WIND     9..11  w_b               body-frame wind, m/s
    ROTORS   12..   eta               rotor speeds, rad/s

The upper-case names are the integer offsets of the blocks (Numba kernels fold ``x[WIND + 2]``
into a constant); ``IDX_*`` are the same blocks as slices for NumPy code.

Model constants ``prm`` of shape (N_PRM,) (:func:`windnav.estimate.wind_model.model_constants`):
``PRM_MASS`` kg, ``PRM_K_ETA`` N/(rad/s)^2, ``PRM_K_D``, ``PRM_K_Z`` kg/rad, ``PRM_K_H`` kg/m,
``PRM_C_DX``, ``PRM_C_DY``, ``PRM_C_DZ`` N/(m/s)^2, ``PRM_TAU_M`` s, ``PRM_G`` m/s^2 and
``PRM_WORLD_WIND`` (1.0 when the world-frame wind is the random walk, else 0.0).

Odometry measurement of shape (6,): world velocity (``ODOM_VELOCITY``, m/s) then the Euler
angles (``ODOM_EULER``, rad).
"""

from __future__ import annotations

__all__ = [
    "EULER",
    "IDX_EULER",
    "IDX_RATES",
    "IDX_ROTORS",
    "IDX_VELOCITY",
    "IDX_WIND",
    "N_BASE",
    "N_PRM",
    "ODOM_EULER",
    "ODOM_VELOCITY",
    "PRM_C_DX",
    "PRM_C_DY",
    "PRM_C_DZ",
    "PRM_G",
    "PRM_K_D",
    "PRM_K_ETA",
    "PRM_K_H",
    "PRM_K_Z",
    "PRM_MASS",
    "PRM_TAU_M",
    "PRM_WORLD_WIND",
    "RATES",
    "ROTORS",
    "VELOCITY",
    "WIND",
    "state_labels",
]

EULER = 0
RATES = 3
VELOCITY = 6
WIND = 9
ROTORS = 12
N_BASE = 12
"""States before the rotor speeds."""

IDX_EULER = slice(EULER, EULER + 3)
IDX_RATES = slice(RATES, RATES + 3)
IDX_VELOCITY = slice(VELOCITY, VELOCITY + 3)
IDX_WIND = slice(WIND, WIND + 3)
IDX_ROTORS = slice(ROTORS, None)

PRM_MASS = 0
PRM_K_ETA = 1
PRM_K_D = 2
PRM_K_Z = 3
PRM_K_H = 4
PRM_C_DX = 5
PRM_C_DY = 6
PRM_C_DZ = 7
PRM_TAU_M = 8
PRM_G = 9
PRM_WORLD_WIND = 10
N_PRM = 11

ODOM_VELOCITY = slice(0, 3)
ODOM_EULER = slice(3, 6)


def state_labels(n_rotors: int) -> list[str]:
    """Names of the ``12 + n_rotors`` state components, in order."""
    return (["psi", "theta", "phi", "p", "q", "r", "vx_b", "vy_b", "vz_b", "wx_b", "wy_b",
             "wz_b"] + [f"eta_{i}" for i in range(n_rotors)])
