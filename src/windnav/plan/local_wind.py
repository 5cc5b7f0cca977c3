"""The wind the planner knows: uniform, or on a local grid centred on the vehicle.

The planner's wind ``w(p~)`` (m/s, world-aligned) is a local, time-averaged estimate around the
vehicle: the Wind UKF's uniform estimate, or the decoder's field ``(2, H, H)`` (``[u, v]``
indexed ``[iy, ix]`` on cell-centre offsets, as :meth:`windnav.predict` returns it). It is
known only inside the window ``L_t = {|p~|_inf <= H/2}`` around the start of the planning
period and is zero outside (Folk 2026, ch. 5); ``H`` is :attr:`PlannerConfig.horizon`. Between
the outermost cell centres and the window's edge the grid is clamped to its edge cells. A
:attr:`LocalWind.fill` other than zero replaces the zero outside the window (not the thesis's
planner: an option of the onboard stack, which may fill with its uniform local estimate).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from windnav.plan._kernels import evenly_increasing

__all__ = ["LocalWind"]

_WHERE = "LocalWind"


def _array(values, name: str, rule: str) -> np.ndarray:
    """``values`` as a C-contiguous float64 array (itself when it is one already)."""
    try:
        return np.ascontiguousarray(values, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"The {name!r} parameter of {_WHERE} must be {rule}. Got {values!r} "
                         "instead.") from None


def _offsets(values, name: str) -> np.ndarray:
    a = np.ascontiguousarray(values, dtype=np.float64).reshape(-1)
    if a.size >= 2 and evenly_increasing(a):  # one compiled pass: checked at every update
        return a
    if a.size < 2 or not np.all(np.isfinite(a)):
        raise ValueError(f"The {name!r} parameter of {_WHERE} must be a finite 1-D array of at "
                         f"least 2 offsets. Got shape {a.shape} instead.")
    step = np.diff(a)
    if np.any(step <= 0) or np.ptp(step) > 1e-6 * step[0]:
        raise ValueError(f"The {name!r} parameter of {_WHERE} must be evenly spaced and "
                         "increasing (cell centres). Got uneven or decreasing offsets instead.")
    return a


@dataclass(frozen=True, eq=False)
class LocalWind:
    """Wind around the vehicle, relative to its position at the start of the planning period.

    Attributes
    ----------
    uv : ndarray of shape (2, ny, nx)
        ``[u, v]`` wind components, world frame, m/s; ``(2, 1, 1)`` for a uniform wind.
    x, y : ndarray of shape (nx,), (ny,)
        Evenly spaced cell-centre offsets, m (empty for a uniform wind).

    Build it with :meth:`uniform` or :meth:`grid`. Values may be non-finite: the planner
    checks them at each update and falls back (it does not raise in its loop). The layout is
    checked at construction: ``uv`` (2, 1, 1) with ``x`` and ``y`` empty, or ``uv``
    (2, ny, nx) on finite, evenly increasing ``x`` and ``y`` of at least 2 offsets each.
    """

    uv: np.ndarray
    x: np.ndarray
    y: np.ndarray
    known_finite: bool = field(default=False, repr=False)
    """True when the caller has checked every value finite (a window of a field it checked
    once): :attr:`finite` then skips the check (0.4 ms on a 600 m map per update)."""
    fill: tuple = (0.0, 0.0)
    """``(u, v)`` wind outside the window, m/s, world frame (default zero, the thesis's)."""

    def __post_init__(self):
        # built directly, a (2, 3) wind, offsets that did not match it, NaN or decreasing
        # offsets (a NaN or negative cell size for the kernel) and a fill of three values were
        # packed as given; the values themselves may be NaN (LocalWind.finite)
        set_ = object.__setattr__
        x, y = (_array(getattr(self, n), n, "a 1-D array of offsets, m") for n in ("x", "y"))
        uv = _array(self.uv, "uv", "an array of wind components (2, ny, nx), m/s")
        if x.ndim != 1 or y.ndim != 1:
            bad = "x" if x.ndim != 1 else "y"
            raise ValueError(f"The {bad!r} parameter of {_WHERE} must be a 1-D array of "
                             f"offsets, m. Got shape {np.shape(getattr(self, bad))} instead.")
        if x.size or y.size:
            x, y = _offsets(x, "x"), _offsets(y, "y")
            want, what = (2, y.size, x.size), "on the offsets y and x"
        else:
            want, what = (2, 1, 1), "for a uniform wind (x and y empty)"
        if uv.shape != want:
            raise ValueError(f"The 'uv' parameter of {_WHERE} must have shape {want} {what}. "
                             f"Got shape {uv.shape} instead.")
        try:
            fill = () if isinstance(self.fill, (str, bytes)) else tuple(map(float, self.fill))
        except (TypeError, ValueError):
            fill = ()
        if len(fill) != 2:
            raise ValueError(f"The 'fill' parameter of {_WHERE} must be two numbers (u, v), "
                             f"m/s. Got {self.fill!r} instead.")
        set_(self, "uv", uv)
        set_(self, "x", x)
        set_(self, "y", y)
        set_(self, "known_finite", bool(self.known_finite))
        set_(self, "fill", fill)

    @classmethod
    def uniform(cls, wind_xy) -> LocalWind:
        """A uniform wind ``wind_xy`` (2,), m/s, world frame."""
        w = np.asarray(wind_xy, dtype=np.float64).reshape(-1)
        if w.shape != (2,):
            raise ValueError(f"The 'wind_xy' parameter of {_WHERE}.uniform must have shape (2,). "
                             f"Got shape {np.shape(wind_xy)} instead.")
        return cls(w.reshape(2, 1, 1).copy(), np.zeros(0), np.zeros(0))

    @classmethod
    def grid(cls, uv, offsets, offsets_y=None, *, known_finite: bool = False,
             fill=(0.0, 0.0), copy: bool = True) -> LocalWind:
        """A gridded wind ``uv`` (2, ny, nx) (m/s) on cell centres ``offsets`` (m).

        ``offsets`` are the x offsets and, unless ``offsets_y`` is given, the y offsets too
        (the decoder's ``dec.offsets``). ``known_finite``, ``fill``: see the attributes.
        ``uv`` and the offsets are copied, so that a caller refilling one buffer does not change
        a wind already built (nor a planner's :meth:`~windnav.plan.MPPIPlanner.plan` of it);
        ``copy=False`` adopts a C-contiguous float64 ``uv`` as it is, for a caller that never
        writes it afterwards (the closed loop's own whole-map field, which would otherwise be
        copied at every update).
        """
        arr = np.array(uv, dtype=np.float64, copy=True if copy else None)
        x = _offsets(offsets, "offsets")
        y = x if offsets_y is None else _offsets(offsets_y, "offsets_y")
        if copy:
            x, y = x.copy(), y.copy()  # y may be x: two arrays either way
        if arr.shape != (2, y.size, x.size):
            raise ValueError(f"The 'uv' parameter of {_WHERE}.grid must have shape "
                             f"(2, {y.size}, {x.size}). Got shape {arr.shape} instead.")
        f = np.asarray(fill, dtype=np.float64).reshape(-1)
        if f.shape != (2,):
            raise ValueError(f"The 'fill' parameter of {_WHERE}.grid must have shape (2,). "
                             f"Got shape {np.shape(fill)} instead.")
        return cls(np.ascontiguousarray(arr), x, y, bool(known_finite),
                   (float(f[0]), float(f[1])))

    @property
    def is_uniform(self) -> bool:
        """True for a uniform wind."""
        return self.x.size == 0

    @property
    def finite(self) -> bool:
        """True when every value is finite."""
        return ((self.known_finite or bool(np.all(np.isfinite(self.uv))))
                and all(np.isfinite(self.fill)))

    def pack(self, horizon: float) -> tuple[int, np.ndarray, np.ndarray]:
        """``(mode, grid, meta)`` for the kernels, with the window side ``H = horizon`` (m,
        > 0, ``inf`` for everywhere)."""
        try:
            h = float(horizon)
        except (TypeError, ValueError):
            h = math.nan
        if not h > 0:  # NaN gave a NaN window, <= 0 a wind known nowhere
            raise ValueError(f"The 'horizon' parameter of {_WHERE}.pack must be a number > 0, m "
                             f"(inf allowed). Got {horizon!r} instead.")
        half = 0.5 * h
        if self.is_uniform:
            return 1, self.uv, np.array([0.0, 0.0, 1.0, 1.0, half, *self.fill])
        meta = np.array([self.x[0], self.y[0], self.x[1] - self.x[0], self.y[1] - self.y[0],
                         half, *self.fill])
        return 2, self.uv, meta


NO_WIND = (0, np.zeros((2, 1, 1)), np.array([0.0, 0.0, 1.0, 1.0, 0.0, 0.0, 0.0]))
"""Packed kernel arguments of the variants without wind."""
