"""Constant wind: the same velocity everywhere and at all times (``w(t, x) = w0``)."""

from __future__ import annotations

import numpy as np

from windnav._validate import ReadOnlyOnCopy, batch_array
from windnav.wind.base import check_query


class ConstantWind(ReadOnlyOnCopy):
    """Spatially uniform, steady wind.

    Parameters
    ----------
    velocity : array_like of shape (3,)
        Wind velocity, m/s, world frame (x east, y north, z up). Default ``(2, 1, 0)``.

    Examples
    --------
    >>> w = ConstantWind((2.0, 1.0, 0.0))
    >>> w.velocity(0.0, [[0.0, 0.0, 1.0], [5.0, 3.0, 2.0]])
    array([[2., 1., 0.],
           [2., 1., 0.]])
    """

    def __init__(self, velocity=(2.0, 1.0, 0.0)):
        try:  # "could not convert string to float: 'abc'" named nothing (API audit)
            np.asarray(velocity, dtype=np.float64)
        except (TypeError, ValueError):
            raise ValueError("The 'velocity' parameter of ConstantWind must be three numbers, "
                             f"m/s. Got {velocity!r} instead.") from None
        v = batch_array(velocity, "velocity", "ConstantWind", (3,), batch=1)[0].copy()
        v.setflags(write=False)
        self._velocity = v

    @property
    def mean(self) -> np.ndarray:
        """The wind velocity (3,), m/s, world frame."""
        return self._velocity

    def velocity(self, t: float, xyz: np.ndarray) -> np.ndarray:
        """Wind at time ``t`` (s) and positions ``xyz`` (B, 3) m: (B, 3) m/s, all rows equal."""
        _, xyz = check_query(t, xyz, "ConstantWind.velocity")
        return np.tile(self._velocity, (xyz.shape[0], 1))

    def __repr__(self) -> str:
        return f"ConstantWind(velocity={tuple(self._velocity.tolist())})"
