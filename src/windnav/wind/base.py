"""The ``WindField`` protocol: what every wind model in windnav answers.

A wind field maps a time and a batch of positions to the wind velocity there::

    velocity(t, xyz) -> ndarray of shape (B, 3)     # m/s, world frame (x east, y north, z up)

``xyz`` is validated once here (:func:`check_query`) so every implementation rejects bad input
with the same message naming ``'xyz'`` or ``'t'``.
"""

from __future__ import annotations

import math
from typing import Protocol, runtime_checkable

import numpy as np

from windnav._validate import batch_array


@runtime_checkable
class WindField(Protocol):
    """Anything with ``velocity(t, xyz) -> (B, 3)``: the wind at positions ``xyz`` at time ``t``.

    Implementations return float64 arrays in m/s, world frame, one row per position. A single
    position of shape (3,) is treated as a batch of one.
    """

    def velocity(self, t: float, xyz: np.ndarray) -> np.ndarray:
        """Wind velocity at time ``t`` (s) and positions ``xyz`` (B, 3) m world; (B, 3) m/s."""
        ...


def check_query(t, xyz, where: str, *, batch: int | None = None) -> tuple[float, np.ndarray]:
    """Validate a ``velocity`` query; return ``(float(t), xyz as float64 (B, 3))``.

    Raises
    ------
    ValueError
        Naming ``'t'`` when ``t`` is not a finite number, or ``'xyz'`` when it is not a finite
        array of shape (B, 3) or (3,) (or not a batch of ``batch`` rows, when given).
    """
    try:
        t_f = float(t)
    except (TypeError, ValueError):
        raise ValueError(
            f"The 't' parameter of {where} must be a number. Got {t!r} instead."
        ) from None
    if not math.isfinite(t_f):
        raise ValueError(f"The 't' parameter of {where} must be finite. Got {t!r} instead.")
    return t_f, batch_array(xyz, "xyz", where, (3,), batch=batch)
