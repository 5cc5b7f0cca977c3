"""The multirotor state: a dataclass of batched arrays (batch on the leading axis)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from windnav._validate import positive_int
from windnav.vehicle.layout import (
    ATTITUDE,
    BODY_RATES,
    N_RIGID,
    POSITION,
    ROTOR_SPEEDS,
    VELOCITY,
)

# the fields' widths in the packed layout (0: the rotors, N >= 1)
_WIDTHS = (("position", 3), ("velocity", 3), ("attitude", 4), ("body_rates", 3),
           ("rotor_speeds", 0))


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
        (the layout of :mod:`windnav.vehicle.layout`).

        Raises
        ------
        ValueError
            Naming the field that is not (B, width) with the batch of ``position`` (fields
            of other widths were packed into a state of shifted blocks).
        """
        batch = np.shape(self.position)[0] if np.ndim(self.position) == 2 else None
        for name, width in _WIDTHS:
            shape = np.shape(getattr(self, name))
            if len(shape) != 2 or shape[0] != batch or (
                    shape[1] != width if width else shape[1] < 1):
                want = f"(B, {width})" if width else "(B, N) with N >= 1"
                raise ValueError(f"The {name!r} field of VehicleState must have shape {want} "
                                 f"with the batch of position. Got shape {shape} instead.")
        return _pack(self)

    @classmethod
    def from_array(cls, x: np.ndarray, *, n_rotors: int | None = None) -> VehicleState:
        """Inverse of :meth:`to_array`.

        Parameters
        ----------
        x : ndarray of shape (B, 13 + N)
            Packed states.
        n_rotors : int, optional
            N, when known: ``x`` must then be (B, 13 + n_rotors). Without it any N >= 1 is
            read from the width (15 is a two-rotor state).

        Raises
        ------
        ValueError
            Naming ``x`` when it is not 2-D of width at least 14 (or 13 + n_rotors).
        """
        x = np.asarray(x, dtype=np.float64)
        if n_rotors is not None:
            n_rotors = positive_int(n_rotors, "n_rotors", "VehicleState.from_array")
        if x.ndim != 2 or (x.shape[1] <= N_RIGID if n_rotors is None
                           else x.shape[1] != N_RIGID + n_rotors):
            want = (f"(B, {N_RIGID} + N) with N >= 1" if n_rotors is None
                    else f"(B, {N_RIGID + n_rotors})")
            raise ValueError(f"The 'x' parameter of VehicleState.from_array must have shape "
                             f"{want}. Got shape {x.shape} instead.")
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


def _pack(state: VehicleState) -> np.ndarray:
    """:meth:`VehicleState.to_array` without its checks of the fields' shapes, for a caller
    that has made them (:class:`~windnav.vehicle.multirotor.Multirotor`'s step)."""
    return np.concatenate(  # float64 whatever the fields' dtype (the physics' precision)
        [state.position, state.velocity, state.attitude, state.body_rates, state.rotor_speeds],
        axis=1, dtype=np.float64,
    )
