"""Gridded 2D wind: a horizontal flow field sampled on cell centres, steady or unsteady.

The flow solver (``windnav.flow``) returns its velocities on a rectilinear grid of cell centres
``x`` (nx,), ``y`` (ny,). :class:`GriddedWind` turns them into a :class:`~windnav.wind.WindField`:

- space: bilinear interpolation between the four surrounding cell centres,
  ``w = (1-a)(1-b) w00 + a(1-b) w10 + (1-a) b w01 + a b w11`` with ``a = (x - x_i)/(x_i+1 - x_i)``,
  ``b`` likewise in y; positions outside the grid are clamped to its edge;
- time (unsteady fields, frames at times ``t`` (T,)): linear between the two bracketing frames,
  clamped to the first/last frame outside ``[t_0, t_{T-1}]``;
- the vertical component is 0 and ``z`` is ignored (the flow is 2D).
"""

from __future__ import annotations

import math

import numpy as np

from windnav._jit import njit
from windnav._validate import ReadOnlyOnCopy, batch_array
from windnav.wind.base import check_query


def _axis(values, name: str, where: str) -> np.ndarray:
    arr = np.array(values, dtype=np.float64)  # a copy: the field's own, made read-only
    if arr.ndim != 1 or arr.size < 2 or not np.all(np.isfinite(arr)):
        raise ValueError(
            f"The {name!r} parameter of {where} must be a finite 1-D array of at least 2 "
            f"values. Got shape {arr.shape} instead."
        )
    if np.any(np.diff(arr) <= 0):
        raise ValueError(f"The {name!r} parameter of {where} must be strictly increasing.")
    return arr


def _bracket(axis: np.ndarray, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Lower index ``i`` (clamped to [0, n-2]) and weight ``a`` in [0, 1] of ``q`` on ``axis``."""
    q = np.clip(q, axis[0], axis[-1])
    i = np.clip(np.searchsorted(axis, q, side="right") - 1, 0, axis.size - 2)
    a = (q - axis[i]) / (axis[i + 1] - axis[i])
    return i, a


@njit(cache=True, inline="always")
def _locate(axis, q):  # pragma: no cover - numba
    """Clamped bracket of ``q``: index ``i`` in [0, n-2] and weight in [0, 1] (binary search)."""
    n = axis.size
    if q <= axis[0]:
        return 0, 0.0
    if q >= axis[n - 1]:
        return n - 2, 1.0
    lo, hi = 0, n - 1
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if axis[mid] <= q:
            lo = mid
        else:
            hi = mid
    return lo, (q - axis[lo]) / (axis[lo + 1] - axis[lo])


@njit(cache=True)
def _interpolate(x, y, frames, k0, k1, c, xyz, out):  # pragma: no cover - numba
    """Bilinear in space on ``frames[k0]`` and ``frames[k1]`` (ny, nx, 2), linear (weight c)
    between them; writes (u, v, 0) per position into ``out`` (B, 3)."""
    for p in range(xyz.shape[0]):
        i, a = _locate(x, xyz[p, 0])
        j, b = _locate(y, xyz[p, 1])
        w00 = (1.0 - a) * (1.0 - b)
        w10 = a * (1.0 - b)
        w01 = (1.0 - a) * b
        w11 = a * b
        for comp in range(2):
            f = frames[k0]
            val = (w00 * f[j, i, comp] + w10 * f[j, i + 1, comp]
                   + w01 * f[j + 1, i, comp] + w11 * f[j + 1, i + 1, comp])
            if c > 0.0:
                g = frames[k1]
                val2 = (w00 * g[j, i, comp] + w10 * g[j, i + 1, comp]
                        + w01 * g[j + 1, i, comp] + w11 * g[j + 1, i + 1, comp])
                val = (1.0 - c) * val + c * val2
            out[p, comp] = val
        out[p, 2] = 0.0


@njit(cache=True)
def _all_finite(a):  # pragma: no cover - numba
    """True when every value of the 3-D array ``a`` (any strides) is finite; no temporary
    (np.isfinite of 2.3 GB of strided frames allocates 144 M booleans and takes ~3x longer)."""
    s = 0.0
    n0, n1, n2 = a.shape
    for t in range(n0):
        for j in range(n1):
            for i in range(n2):
                x = a[t, j, i]
                s += x - x  # 0 for finite x, NaN for inf or NaN (and NaN stays)
    return s == 0.0


def _interleaved(u, v) -> np.ndarray | None:
    """The C-contiguous float64 (T, ny, nx, 2) array whose ``[..., 0]`` and ``[..., 1]`` are
    the views ``u`` and ``v``, or None when they are not such views. Their common ``base``
    may be that array or any C-contiguous float64 block of its size (the solver's reusable
    frame memory, :class:`~windnav.flow.FrameBuffers`); the result is then a view of it."""
    if not (isinstance(u, np.ndarray) and isinstance(v, np.ndarray)) or u.ndim != 3:
        return None
    base = u.base
    shape = (*u.shape, 2)
    if (not isinstance(base, np.ndarray) or v.base is not base or base.dtype != np.float64
            or base.size != math.prod(shape) or not base.flags.c_contiguous):
        return None
    frames = base.reshape(shape)  # no copy: base is C-contiguous
    if (u.strides != frames.strides[:3] or v.strides != frames.strides[:3]
            or u.ctypes.data != frames.ctypes.data
            or v.ctypes.data != frames.ctypes.data + frames.itemsize):
        return None
    return frames


class GriddedWind(ReadOnlyOnCopy):
    """Horizontal wind field on a rectilinear grid of cell centres (steady or unsteady).

    Parameters
    ----------
    x : array_like of shape (nx,)
        Cell-centre x coordinates, m, strictly increasing (nx >= 2).
    y : array_like of shape (ny,)
        Cell-centre y coordinates, m, strictly increasing (ny >= 2).
    u, v : array_like of shape (ny, nx) or (T, ny, nx)
        Wind components along world x and y, m/s: a steady field, or T frames.
    t : array_like of shape (T,), optional
        Frame times, s, strictly increasing; required with (T, ny, nx) frames, not allowed with
        a steady (ny, nx) field.
    solid : array_like of bool, shape (ny, nx), optional
        Cells inside buildings. Carried for consumers (see :meth:`is_solid`); it does not
        change the interpolation (the solver already sets the wind in solid cells).
    known_finite : bool
        The caller vouches that ``u`` and ``v`` are finite, and the scan of every value is
        skipped (0.25-0.45 s for a 600 m map's 400 frames). Only for a solver's own
        output (:meth:`windnav.flow.FlowSolution.wind_field` passes it for the frames of
        :func:`windnav.flow.simulate`, checked at every step); default False.

    Examples
    --------
    >>> x = y = np.arange(4.0)
    >>> u = np.tile(x, (4, 1))          # u = x
    >>> w = GriddedWind(x, y, u, np.zeros((4, 4)))
    >>> w.velocity(0.0, [[1.5, 2.0, 10.0]])
    array([[1.5, 0. , 0. ]])
    """

    def __init__(self, x, y, u, v, t=None, solid=None, *, known_finite: bool = False):
        where = "GriddedWind"
        self.x = _axis(x, "x", where)
        self.y = _axis(y, "y", where)
        grid = (self.y.size, self.x.size)
        comps = []
        for name, arr in (("u", u), ("v", v)):
            arr = np.asarray(arr, dtype=np.float64)
            if arr.shape == grid:
                arr = arr[None]
            elif arr.ndim != 3 or arr.shape[1:] != grid:
                raise ValueError(
                    f"The {name!r} parameter of {where} must have shape (ny, nx) = {grid} or "
                    f"(T, ny, nx). Got shape {arr.shape} instead."
                )
            if not known_finite and not _all_finite(arr):
                raise ValueError(f"The {name!r} parameter of {where} must be finite.")
            comps.append(arr)
        if comps[0].shape != comps[1].shape:
            raise ValueError(
                f"The 'v' parameter of {where} must have the shape of 'u' {comps[0].shape}. "
                f"Got shape {comps[1].shape} instead."
            )
        if np.ndim(u) != np.ndim(v):
            raise ValueError(
                f"The 'v' parameter of {where} must have as many dimensions as 'u' "
                f"({np.ndim(u)}). Got {np.ndim(v)} instead."
            )
        steady = np.ndim(u) == 2
        if t is None:
            if not steady:
                raise ValueError(
                    f"The 't' parameter of {where} is required with (T, ny, nx) frames."
                )
            self.t = None
        else:
            if steady:
                raise ValueError(
                    f"The 't' parameter of {where} must be None for a steady (ny, nx) field."
                )
            t_arr = np.atleast_1d(np.array(t, dtype=np.float64))  # a copy, as the axes
            if t_arr.shape != (comps[0].shape[0],) or not np.all(np.isfinite(t_arr)):
                raise ValueError(
                    f"The 't' parameter of {where} must be finite of shape "
                    f"({comps[0].shape[0]},). Got shape {t_arr.shape} instead."
                )
            if np.any(np.diff(t_arr) <= 0):
                raise ValueError(f"The 't' parameter of {where} must be strictly increasing.")
            self.t = t_arr
        # (T, ny, nx, 2) so one gather fetches both components; frames already laid out so
        # (the solver records them that way) are adopted, not copied
        self._frames = _interleaved(u, v)
        if self._frames is None:
            self._frames = np.ascontiguousarray(np.stack(comps, axis=-1))
        if solid is None:
            self.solid = None
        else:
            mask = np.asarray(solid)
            if mask.shape != grid:
                raise ValueError(
                    f"The 'solid' parameter of {where} must have shape {grid}. "
                    f"Got shape {mask.shape} instead."
                )
            self.solid = mask.astype(bool)
        for arr in (self.x, self.y, self._frames, self.t, self.solid):
            if arr is not None:
                arr.setflags(write=False)

    @property
    def steady(self) -> bool:
        """True for a single time-independent frame."""
        return self.t is None

    @property
    def u(self) -> np.ndarray:
        """x components, (ny, nx) steady or (T, ny, nx), m/s."""
        return self._frames[0, ..., 0] if self.steady else self._frames[..., 0]

    @property
    def v(self) -> np.ndarray:
        """y components, (ny, nx) steady or (T, ny, nx), m/s."""
        return self._frames[0, ..., 1] if self.steady else self._frames[..., 1]

    def _frame_weights(self, t: float) -> tuple[int, int, float]:
        if self.t is None or self.t.size == 1:
            return 0, 0, 0.0
        k, a = _bracket(self.t, np.array([t]))
        return int(k[0]), int(k[0]) + 1, float(a[0])

    def velocity(self, t: float, xyz: np.ndarray) -> np.ndarray:
        """Wind at time ``t`` (s) and positions ``xyz`` (B, 3) m: (B, 3) m/s, world, z = 0."""
        t, xyz = check_query(t, xyz, "GriddedWind.velocity")
        k0, k1, c = self._frame_weights(t)
        out = np.empty((xyz.shape[0], 3))
        _interpolate(self.x, self.y, self._frames, k0, k1, c, xyz, out)
        return out

    def is_solid(self, xyz: np.ndarray) -> np.ndarray:
        """Whether each position (B, 3) m lies in a solid cell (nearest cell centre), (B,) bool.

        Positions outside the grid are not solid. All False when no ``solid`` mask was given.
        """
        xyz = batch_array(xyz, "xyz", "GriddedWind.is_solid", (3,))
        if self.solid is None:
            return np.zeros(xyz.shape[0], dtype=bool)
        out = np.zeros(xyz.shape[0], dtype=bool)
        half_x = 0.5 * np.diff(self.x)[[0, -1]]
        half_y = 0.5 * np.diff(self.y)[[0, -1]]
        inside = ((xyz[:, 0] >= self.x[0] - half_x[0]) & (xyz[:, 0] <= self.x[-1] + half_x[1])
                  & (xyz[:, 1] >= self.y[0] - half_y[0]) & (xyz[:, 1] <= self.y[-1] + half_y[1]))
        i = _nearest(self.x, xyz[inside, 0])
        j = _nearest(self.y, xyz[inside, 1])
        out[inside] = self.solid[j, i]
        return out

    def __repr__(self) -> str:
        frames = "steady" if self.steady else f"{self.t.size} frames"
        return f"GriddedWind(nx={self.x.size}, ny={self.y.size}, {frames})"


def _nearest(axis: np.ndarray, q: np.ndarray) -> np.ndarray:
    i = np.clip(np.searchsorted(axis, q), 1, axis.size - 1)
    return np.where(np.abs(q - axis[i - 1]) <= np.abs(axis[i] - q), i - 1, i)
