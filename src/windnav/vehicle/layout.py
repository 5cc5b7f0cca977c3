"""The packed layouts of the vehicle kernels: parameter columns and state components.

Two arrays cross package boundaries in packed form, and every reader names their fields here
rather than by number (reordering a field then changes one line, not three packages):

``PackedParams.scalars`` of shape (P, N_SCALARS), one row per vehicle::

    MASS             kg             mass
    K_ETA            N/(rad/s)^2    thrust coefficient, T_i = k_eta eta_i^2
    K_M              N m/(rad/s)^2  yaw-moment (rotor drag torque) coefficient
    K_D, K_Z         kg/rad         in-plane and axial rotor drag
    K_H              kg/m           translational lift
    K_FLAP           kg m/rad       blade flapping moment
    C_DX, C_DY, C_DZ N/(m/s)^2      parasitic drag along body axes
    TAU_M            s              motor time constant
    ROTOR_SPEED_MIN, ROTOR_SPEED_MAX  rad/s  command limits
    G                m/s^2          gravitational acceleration (0 with ``gravity=False``)
    LIFT_BOUNDED     1              1: bounded translational lift, 0: RotorPy's (see dynamics)
    LIFT_INV_THRUST  1/N            1 / T_ref, the rotor thrust above which lift is not scaled

Packed state of shape (B, 13 + N) (:meth:`VehicleState.to_array`): position (m, world),
velocity (m/s, world), attitude quaternion ``[qx, qy, qz, qw]`` body to world, body rates
(rad/s, body), rotor speeds (rad/s). ``POS``, ``VEL``, ``QUAT``, ``RATES`` and ``ROTORS`` are
the offsets of these blocks (plain integers, so Numba kernels fold ``y[QUAT + 3]`` into a
constant); ``POSITION``, ``VELOCITY``, ``ATTITUDE``, ``BODY_RATES`` and ``ROTOR_SPEEDS`` are the
matching slices for NumPy code.
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "ATTITUDE",
    "BODY_RATES",
    "C_DX",
    "C_DY",
    "C_DZ",
    "G",
    "K_D",
    "K_ETA",
    "K_FLAP",
    "K_H",
    "K_M",
    "K_Z",
    "LIFT_BOUNDED",
    "LIFT_INV_THRUST",
    "MASS",
    "N_RIGID",
    "N_SCALARS",
    "POS",
    "POSITION",
    "QUAT",
    "RATES",
    "ROTORS",
    "ROTOR_SPEEDS",
    "ROTOR_SPEED_MAX",
    "ROTOR_SPEED_MIN",
    "SCALAR_NAMES",
    "TAU_M",
    "VEL",
    "VELOCITY",
    "column",
]

# Parameter columns of PackedParams.scalars (new columns go at the end).
MASS = 0
K_ETA = 1
K_M = 2
K_D = 3
K_Z = 4
K_H = 5
K_FLAP = 6
C_DX = 7
C_DY = 8
C_DZ = 9
TAU_M = 10
ROTOR_SPEED_MIN = 11
ROTOR_SPEED_MAX = 12
G = 13
LIFT_BOUNDED = 14
LIFT_INV_THRUST = 15
N_SCALARS = 16

SCALAR_NAMES = ("mass", "k_eta", "k_m", "k_d", "k_z", "k_h", "k_flap", "c_dx", "c_dy", "c_dz",
                "tau_m", "rotor_speed_min", "rotor_speed_max", "g", "lift_bounded",
                "lift_inv_thrust")
"""Column names of ``PackedParams.scalars``, in order (``SCALAR_NAMES[K_ETA] == "k_eta"``)."""

# Packed state (B, 13 + N): offsets of the blocks ...
POS = 0
VEL = 3
QUAT = 6
RATES = 10
ROTORS = 13
N_RIGID = 13
"""Rigid-body components before the rotor speeds."""

# ... and the same blocks as slices.
POSITION = slice(POS, POS + 3)
VELOCITY = slice(VEL, VEL + 3)
ATTITUDE = slice(QUAT, QUAT + 4)
BODY_RATES = slice(RATES, RATES + 3)
ROTOR_SPEEDS = slice(ROTORS, None)


def column(scalars: np.ndarray, index: int) -> np.ndarray:
    """One parameter column of packed scalars.

    Parameters
    ----------
    scalars : ndarray of shape (P, N_SCALARS)
        ``PackedParams.scalars``.
    index : int
        Column, e.g. :data:`K_ETA`.

    Returns
    -------
    ndarray of shape (P,)
        A read-only view.
    """
    view = scalars[:, index]
    view.flags.writeable = False
    return view
