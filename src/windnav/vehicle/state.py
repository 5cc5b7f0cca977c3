"""The multirotor state: a dataclass of batched arrays (batch on the leading axis)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from windnav.vehicle.layout import ATTITUDE, BODY_RATES, POSITION, ROTOR_SPEEDS, VELOCITY


@dataclass(frozen=True)
class VehicleState:
    """Batched rigid-body and rotor state.

    Attributes
    ----------
    position : ndarray of shape (B, 3)
        Centre-of-mass position, world frame (x east, y north, z up), m.
    velocity : ndarray of shape (B, 3)
        Centre-of-mass velocity, world frame, m/s.
    attitude : ndarray of shape (B, 4)
        Unit quaternion ``[qx, qy, qz, qw]`` rotating body to world.
    body_rates : ndarray of shape (B, 3)
        Angular velocity in body axes, rad/s.
    rotor_speeds : ndarray of shape (B, N)
        Rotor speeds, rad/s.
    """

    position: np.ndarray
    velocity: np.ndarray
    attitude: np.ndarray
    body_rates: np.ndarray
    rotor_speeds: np.ndarray

    @property
    def batch_size(self) -> int:
        return int(self.position.shape[0])

    def to_array(self) -> np.ndarray:
        """Packed ``(B, 13 + N)``: position, velocity, attitude, body rates, rotor speeds
        (the layout of :mod:`windnav.vehicle.layout`)."""
        return np.concatenate(  # float64 whatever the fields' dtype (the physics' precision)
            [self.position, self.velocity, self.attitude, self.body_rates, self.rotor_speeds],
            axis=1, dtype=np.float64,
        )

    @classmethod
    def from_array(cls, x: np.ndarray) -> VehicleState:
        """Inverse of :meth:`to_array`."""
        x = np.asarray(x, dtype=np.float64)
        return cls(x[:, POSITION], x[:, VELOCITY], x[:, ATTITUDE], x[:, BODY_RATES],
                   x[:, ROTOR_SPEEDS])

    def __getitem__(self, idx) -> VehicleState:
        """Select vehicles (keeps the batch axis for an integer index, which may count from
        the end; out of range it raises IndexError)."""
        if isinstance(idx, (int, np.integer)):
            b = self.batch_size
            i = int(idx) + b if idx < 0 else int(idx)
            if not 0 <= i < b:
                raise IndexError(f"VehicleState index {int(idx)} is out of range for a batch "
                                 f"of {b}.")
            idx = slice(i, i + 1)
        return VehicleState(self.position[idx], self.velocity[idx], self.attitude[idx],
                            self.body_rates[idx], self.rotor_speeds[idx])
