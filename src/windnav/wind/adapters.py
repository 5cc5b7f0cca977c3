"""Adapters between windnav wind fields and other simulators.

RotorPy (``rotorpy/simulate.py``) asks its wind profile ``wind_profile.update(t, position)`` once
per step, with ``position`` of shape (3,) (or (B, 3) in its batched simulator) in the world frame,
and expects the wind there, m/s, of the same shape. :class:`RotorPyWind` answers that from any
:class:`~windnav.wind.WindField`.
"""

from __future__ import annotations

import numpy as np

from windnav.wind.base import WindField


class RotorPyWind:
    """Wrap a windnav :class:`~windnav.wind.WindField` as a RotorPy wind profile.

    Parameters
    ----------
    field : WindField
        Any object with ``velocity(t, xyz) -> (B, 3)``.

    Examples
    --------
    >>> from windnav.wind import ConstantWind
    >>> RotorPyWind(ConstantWind((1.0, 0.0, 0.0))).update(0.0, np.zeros(3))
    array([1., 0., 0.])
    """

    def __init__(self, field: WindField):
        if not isinstance(field, WindField):
            raise ValueError(
                "The 'field' parameter of RotorPyWind must have a velocity(t, xyz) method. "
                f"Got {type(field).__name__} instead."
            )
        self.field = field

    def update(self, t: float, position) -> np.ndarray:
        """Wind at time ``t`` (s) and ``position`` (3,) or (B, 3) m, world; same shape, m/s."""
        if type(position).__module__.startswith("torch"):  # RotorPy's batched simulator
            import torch

            wind = self.field.velocity(float(t), position.detach().cpu().numpy())
            return torch.as_tensor(wind, dtype=position.dtype, device=position.device)
        pos = np.asarray(position, dtype=np.float64)
        wind = self.field.velocity(float(t), pos.reshape(-1, 3))
        return wind[0] if pos.ndim == 1 else wind

    def __repr__(self) -> str:
        return f"RotorPyWind({self.field!r})"


def to_rotorpy(field: WindField) -> RotorPyWind:
    """Return ``RotorPyWind(field)``: ``field`` as a RotorPy wind profile (``update(t, x)``)."""
    return RotorPyWind(field)
