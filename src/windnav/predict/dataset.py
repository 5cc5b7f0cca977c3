"""Samples of the wind flow decoder, derived on the fly from time-averaged solver fields.

Thesis ch. 4: the decoder maps one LiDAR scan ``D`` and two winds, the inlet (free-stream)
``W_up`` and the time-averaged wind at the robot ``W_robot``, to the mean wind ``(u, v)`` on an
``H x H`` grid of spacing ``Delta`` centred on the robot and aligned with the world axes. A
sample is drawn from a :class:`MeanField` (one map at one inlet) as

- a robot position in free space, at least ``wall_clearance`` (1 m) from every wall and within
  ``building_reach`` (40 m) of some building ("around the buildings"), with the whole label
  grid inside the solver grid (:func:`robot_positions`);
- the scan: ``City.lidar`` with 360 rays, returns plus ``N(0, 0.35 m)`` noise (rays that hit
  nothing read 100 m exactly, as ``City.lidar`` does), clipped to [0.25, 100] m;
- ``W_up``; ``W_robot`` = the mean field at the robot, plus optional ``N(0, w_robot_noise)``
  per component (in flight it comes from the Wind UKF);
- the labels: the mean field at ``position + (offsets[ix], offsets[iy])``, 0 inside buildings;
- optionally (``turn_deg`` > 0, training only) the whole scene turned about the robot by a
  whole number of degrees: scan, winds and labels those of the world turned by that angle
  (:meth:`MeanField.turned_grid_values`), so the sample is no longer the world frame's.

Interpolation: the thesis interpolates with ``scipy.interpolate.RectBivariateSpline``; here its
degree is 1 (``kx = ky = 1``, ``s = 0``), the tensor B-spline through the cell centres, which
is bilinear interpolation:
``w = (1-a)(1-b) w00 + a(1-b) w10 + (1-a) b w01 + a b w11``. Degree 1 because the solver's mean
field jumps to 0 at walls, where a cubic spline rings (about 11 % of the jump: speed-ups and
reversed flow that are not in the solution), and because it is the interpolation of
:class:`windnav.wind.GriddedWind`, the wind the simulated vehicle flies in, so labels and flights
see the same field. The spline is evaluated by a batched tensor-grid kernel (each grid's
brackets found once per row and column); tests check it against ``RectBivariateSpline.ev`` and
``GriddedWind``. Label cells inside footprints (and in pockets the solver filled) are 0 and not
free; so are cells outside the hull of the solver's cell centres.

Randomness: :func:`draw_samples` takes one ``rng``; it draws the positions, then one 64-bit key
from which the noise of sample ``j`` is the ``j``-th block of 362 values of a counter-based
stream: SplitMix64 (Steele, Lea & Flood 2014, as in ``windnav.plan._random``) at counter
``362 j + r``, turned into normals pairwise by the Box-Muller transform. The noise of a sample
is therefore a pure function of (key, j): :class:`DecoderDataset` regenerates any subset of its
samples bit for bit, in any batch.
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from functools import cached_property
from typing import NamedTuple

import numpy as np

from windnav._jit import njit
from windnav._validate import ReadOnlyOnCopy, batch_array, positive_float, positive_int
from windnav.city import City

N_RAYS = 360
"""Rays per scan; ray k points at k degrees counter-clockwise from +x (world frame)."""
SCAN_MIN = 0.25
"""Smallest range reading, m."""
SCAN_MAX = 100.0
"""Largest range reading, m (read where nothing is hit)."""
SCAN_NOISE = 0.35
"""Standard deviation of the range noise on returns, m."""

_NOISE_PER_SAMPLE = N_RAYS + 2  # scan rays, then the two components of the W_robot noise
_BLOCK = 8192  # samples generated together by DecoderDataset.epoch


def grid_offsets(size: int = 25, spacing: float = 1.0) -> np.ndarray:
    """Cell-centre offsets of the label grid from the robot, the same along x and y.

    Parameters
    ----------
    size : int
        Cells per side ``H``, >= 1 (odd ``H`` has a cell centred on the robot).
    spacing : float
        Cell size ``Delta``, m, > 0.

    Returns
    -------
    ndarray of shape (H,)
        ``(arange(H) - (H - 1) / 2) * spacing``, m, increasing.
    """
    size = positive_int(size, "size", "grid_offsets")
    spacing = positive_float(spacing, "spacing", "grid_offsets")
    return (np.arange(size) - (size - 1) / 2.0) * spacing


def _axis(values, name: str, where: str) -> np.ndarray:
    arr = np.array(values, dtype=np.float64)
    if arr.ndim != 1 or arr.size < 2 or not np.all(np.isfinite(arr)) or np.any(np.diff(arr) <= 0):
        raise ValueError(
            f"The {name!r} parameter of {where} must be a finite, strictly increasing 1-D "
            f"array of at least 2 cell centres, m. Got shape {arr.shape} instead."
        )
    return arr


def _locate(axis: np.ndarray, q: np.ndarray):
    """Bracket ``q`` on ``axis``: lower index in [0, n-2], weight in [0, 1], inside-hull mask."""
    i = np.clip(np.searchsorted(axis, q, side="right") - 1, 0, axis.size - 2)
    t = np.clip((q - axis[i]) / (axis[i + 1] - axis[i]), 0.0, 1.0)
    return i, t, (q >= axis[0]) & (q <= axis[-1])


@njit(cache=True, nogil=True)
def _clear_footprints(fp, gx, gy, free):  # pragma: no cover - numba
    """Set ``free[b, r, c] = False`` where ``(gx[b, c], gy[b, r])`` lies in a footprint (closed).

    ``gx`` (B, Hx) and ``gy`` (B, Hy) increase along their rows, so one bounding-box test per
    (grid, footprint) skips the footprints away from the grid: O(B M + covered cells).
    """
    for b in range(gx.shape[0]):
        x0, x1 = gx[b, 0], gx[b, gx.shape[1] - 1]
        y0, y1 = gy[b, 0], gy[b, gy.shape[1] - 1]
        for m in range(fp.shape[0]):
            if fp[m, 0] > x1 or fp[m, 1] < x0 or fp[m, 2] > y1 or fp[m, 3] < y0:
                continue
            for r in range(gy.shape[1]):
                if gy[b, r] < fp[m, 2] or gy[b, r] > fp[m, 3]:
                    continue
                for c in range(gx.shape[1]):
                    if gx[b, c] >= fp[m, 0] and gx[b, c] <= fp[m, 1]:
                        free[b, r, c] = False


@njit(cache=True, nogil=True)
def _bilinear_grids(u, v, ix, tx, iy, ty, free, out):  # pragma: no cover - numba
    """``out[b, :, r, c]`` = the bilinear interpolant of ``(u, v)`` (ny, nx) at column
    ``(ix, tx)[b, c]`` and row ``(iy, ty)[b, r]`` (lower index, weight), 0 where not free."""
    for b in range(ix.shape[0]):
        for r in range(iy.shape[1]):
            j = iy[b, r]
            t = ty[b, r]
            for c in range(ix.shape[1]):
                if not free[b, r, c]:
                    out[b, 0, r, c] = 0.0
                    out[b, 1, r, c] = 0.0
                    continue
                i = ix[b, c]
                a = tx[b, c]
                w00 = (1.0 - a) * (1.0 - t)
                w01 = a * (1.0 - t)
                w10 = (1.0 - a) * t
                w11 = a * t
                out[b, 0, r, c] = (w00 * u[j, i] + w01 * u[j, i + 1]
                                   + w10 * u[j + 1, i] + w11 * u[j + 1, i + 1])
                out[b, 1, r, c] = (w00 * v[j, i] + w01 * v[j, i + 1]
                                   + w10 * v[j + 1, i] + w11 * v[j + 1, i + 1])


@njit(cache=True, nogil=True)
def _clear_footprints_points(fp, px, py, free):  # pragma: no cover - numba
    """Set ``free[b, k] = False`` where ``(px[b, k], py[b, k])`` lies in a footprint (closed):
    one bounding-box test per (row, footprint), then the row's points against the few
    footprints its box meets."""
    for b in range(px.shape[0]):
        x0, x1 = px[b, 0], px[b, 0]
        y0, y1 = py[b, 0], py[b, 0]
        for k in range(1, px.shape[1]):
            x0, x1 = min(x0, px[b, k]), max(x1, px[b, k])
            y0, y1 = min(y0, py[b, k]), max(y1, py[b, k])
        for m in range(fp.shape[0]):
            if fp[m, 0] > x1 or fp[m, 1] < x0 or fp[m, 2] > y1 or fp[m, 3] < y0:
                continue
            for k in range(px.shape[1]):
                if (px[b, k] >= fp[m, 0] and px[b, k] <= fp[m, 1] and py[b, k] >= fp[m, 2]
                        and py[b, k] <= fp[m, 3]):
                    free[b, k] = False


@njit(cache=True, nogil=True)
def _bilinear_points(u, v, ix, tx, iy, ty, free, out):  # pragma: no cover - numba
    """``out[b, :, k]`` = the bilinear interpolant of ``(u, v)`` (ny, nx) at the point of
    column ``(ix, tx)[b, k]`` and row ``(iy, ty)[b, k]`` (lower index, weight), 0 where not
    free: :func:`_bilinear_grids`'s arithmetic, point by point."""
    for b in range(ix.shape[0]):
        for k in range(ix.shape[1]):
            if not free[b, k]:
                out[b, 0, k] = 0.0
                out[b, 1, k] = 0.0
                continue
            i, a = ix[b, k], tx[b, k]
            j, t = iy[b, k], ty[b, k]
            w00 = (1.0 - a) * (1.0 - t)
            w01 = a * (1.0 - t)
            w10 = (1.0 - a) * t
            w11 = a * t
            out[b, 0, k] = (w00 * u[j, i] + w01 * u[j, i + 1]
                            + w10 * u[j + 1, i] + w11 * u[j + 1, i + 1])
            out[b, 1, k] = (w00 * v[j, i] + w01 * v[j, i + 1]
                            + w10 * v[j + 1, i] + w11 * v[j + 1, i + 1])


def _offsets(offsets, where: str) -> np.ndarray:
    o = np.asarray(offsets, dtype=np.float64)
    if o.ndim != 1 or o.size < 1 or not np.all(np.isfinite(o)) or np.any(np.diff(o) <= 0):
        raise ValueError(f"The 'offsets' parameter of {where} must be a finite, increasing "
                         f"1-D array, m. Got shape {o.shape} instead.")
    return o


@dataclass(frozen=True, eq=False)
class MeanField(ReadOnlyOnCopy):
    """One time-averaged solver field of one map at one inlet: the source of decoder samples.

    Parameters
    ----------
    city : City
        The map (its footprints are the buildings of the labels and the scans).
    x : array_like of shape (nx,)
        Cell-centre x coordinates of the solver grid, m (world frame), strictly increasing.
    y : array_like of shape (ny,)
        Cell-centre y coordinates, m, strictly increasing.
    u, v : array_like of shape (ny, nx)
        Mean wind components, m/s, world frame, finite (0 in the solver's solid cells).
    solid : array_like of bool, shape (ny, nx)
        The solver's solid cells (footprints, plus enclosed pockets it filled).
    w_up : array_like of shape (2,)
        Inlet (free-stream) wind vector, m/s, world frame: ``speed * (cos d, sin d)``.
    name : str
        Label, e.g. ``"training-3/17"`` (map name / case index).

    Raises
    ------
    ValueError
        Naming the parameter: a non-City map, a non-increasing axis, mismatched shapes,
        non-finite wind.
    """

    city: City
    x: np.ndarray
    y: np.ndarray
    u: np.ndarray
    v: np.ndarray
    solid: np.ndarray
    w_up: np.ndarray
    name: str = ""

    def __post_init__(self):
        where = "MeanField"
        if not isinstance(self.city, City):
            raise ValueError(f"The 'city' parameter of {where} must be a windnav.city.City. "
                             f"Got {type(self.city).__name__} instead.")
        x = _axis(self.x, "x", where)
        y = _axis(self.y, "y", where)
        shape = (y.size, x.size)
        wind = []
        for name in ("u", "v"):
            arr = np.array(getattr(self, name), dtype=np.float64, order="C")
            if arr.shape != shape or not np.all(np.isfinite(arr)):
                raise ValueError(
                    f"The {name!r} parameter of {where} must be a finite array of shape "
                    f"(ny, nx) = {shape}, m/s. Got shape {arr.shape}"
                    f"{'' if arr.shape != shape else ' with non-finite entries'} instead.")
            wind.append(arr)
        solid = np.array(self.solid)
        if solid.shape != shape or solid.dtype.kind not in "biu":
            raise ValueError(f"The 'solid' parameter of {where} must be a boolean array of "
                             f"shape {shape}. Got {solid.dtype} of shape {solid.shape} instead.")
        w_up = batch_array(self.w_up, "w_up", where, (2,), batch=1)[0].copy()
        solid = solid.astype(bool)
        for arr in (x, y, *wind, solid, w_up):
            arr.setflags(write=False)
        for name, value in (("x", x), ("y", y), ("u", wind[0]), ("v", wind[1]),
                            ("solid", solid), ("w_up", w_up), ("name", str(self.name))):
            object.__setattr__(self, name, value)

    def __repr__(self) -> str:
        return (f"MeanField(name={self.name!r}, grid={self.y.size}x{self.x.size}, "
                f"w_up=({self.w_up[0]:.3g}, {self.w_up[1]:.3g}) m/s)")

    @property
    def inlet_speed(self) -> float:
        """Speed of the inlet wind ``|w_up|``, m/s."""
        return float(np.hypot(*self.w_up))

    @cached_property
    def splines(self):
        """``(u, v)`` as ``scipy.interpolate.RectBivariateSpline`` of degree 1 (built once).

        The reference definition of the interpolant; :meth:`interpolate` and
        :meth:`grid_values` evaluate the same spline, batched (see the module doc).
        """
        from scipy.interpolate import RectBivariateSpline

        return tuple(RectBivariateSpline(self.x, self.y, f.T, kx=1, ky=1, s=0)
                     for f in (self.u, self.v))

    @cached_property
    def _pockets(self) -> np.ndarray | None:
        """Solver-solid cells outside every footprint (filled enclosed pockets), or None."""
        pockets = self.solid & ~self.city.rasterize(self.x, self.y)
        return pockets if pockets.any() else None

    def _evaluate(self, gx: np.ndarray, gy: np.ndarray, out: np.ndarray) -> np.ndarray:
        """Write the wind on the grids ``gy[b] x gx[b]`` into ``out`` (B, 2, Hy, Hx) (0 where
        not free); return the free mask (B, Hy, Hx)."""
        ix, tx, okx = _locate(self.x, gx)
        iy, ty, oky = _locate(self.y, gy)
        free = oky[:, :, None] & okx[:, None, :]
        _clear_footprints(self.city.footprints, gx, gy, free)
        if self._pockets is not None:
            near = (iy + (ty >= 0.5))[:, :, None], (ix + (tx >= 0.5))[:, None, :]
            free &= ~self._pockets[near]
        _bilinear_grids(self.u, self.v, ix, tx, iy, ty, free, out)
        return free

    def grid_values(self, centres_xy, offsets, dtype=np.float64):
        """The mean wind on square grids centred on points: the decoder's label grids.

        Parameters
        ----------
        centres_xy : array_like of shape (B, 2) or (2,)
            Grid centres (robot positions), m, world frame.
        offsets : array_like of shape (H,)
            Increasing cell-centre offsets, m, the same along x and y (:func:`grid_offsets`).
        dtype : numpy dtype
            Of the returned wind.

        Returns
        -------
        uv : ndarray of shape (B, 2, H, H)
            ``[u, v]`` at ``(x_c + offsets[ix], y_c + offsets[iy])`` indexed ``[b, :, iy, ix]``,
            m/s; 0 where not free.
        free : ndarray of bool, shape (B, H, H)
            Cells inside the solver grid (the hull of its cell centres) and outside every
            building (footprints, and pockets the solver filled).
        """
        where = "MeanField.grid_values"
        c = batch_array(centres_xy, "centres_xy", where, (2,))
        o = _offsets(offsets, where)
        uv = np.empty((c.shape[0], 2, o.size, o.size), dtype=dtype)
        free = self._evaluate(c[:, :1] + o, c[:, 1:] + o, uv)
        return uv, free

    def turned_grid_values(self, centres_xy, offsets, angles_deg, dtype=np.float64):
        """The label grids of the scene turned about each centre: :meth:`grid_values` of the
        world turned ``angles_deg`` counter-clockwise about the robot.

        The turned world's wind at its cell ``o`` is ``R u(c + R^T o)``, ``R`` the turn: the
        field at the world's point that the turn carries onto the cell, its vector turned
        with it (as :func:`windnav.predict.decoder.turned_inputs` turns a scene's scan and
        winds). An angle of 0 gives :meth:`grid_values`'s numbers to the bit.

        Parameters
        ----------
        centres_xy : array_like of shape (B, 2)
            Grid centres (robot positions), m, world frame.
        offsets : array_like of shape (H,)
            As in :meth:`grid_values`.
        angles_deg : array_like of shape (B,)
            Each grid's turn, deg counter-clockwise.
        dtype : numpy dtype
            Of the returned wind.

        Returns
        -------
        uv : ndarray of shape (B, 2, H, H)
            ``[u, v]`` of the turned scene, m/s, indexed ``[b, :, iy, ix]``; 0 where not free.
        free : ndarray of bool, shape (B, H, H)
            Cells whose world point lies inside the solver grid's hull and outside every
            building (footprints, and pockets the solver filled).
        """
        where = "MeanField.turned_grid_values"
        c = batch_array(centres_xy, "centres_xy", where, (2,))
        o = _offsets(offsets, where)
        a = np.radians(np.asarray(angles_deg, dtype=np.float64).reshape(-1))
        if a.size != c.shape[0] or not np.all(np.isfinite(a)):
            raise ValueError(f"The 'angles_deg' parameter of {where} must hold one finite angle "
                             f"per centre ({c.shape[0]}). Got shape {a.shape} instead.")
        b, h = c.shape[0], o.size
        ox, oy = (g.reshape(1, -1) for g in np.meshgrid(o, o))  # cells [iy, ix], row-major
        cos, sin = np.cos(a)[:, None], np.sin(a)[:, None]
        px = c[:, :1] + cos * ox + sin * oy  # c + R^T o
        py = c[:, 1:] - sin * ox + cos * oy
        ix, tx, okx = _locate(self.x, px)
        iy, ty, oky = _locate(self.y, py)
        free = okx & oky
        _clear_footprints_points(self.city.footprints, px, py, free)
        if self._pockets is not None:
            free &= ~self._pockets[iy + (ty >= 0.5), ix + (tx >= 0.5)]
        uv = np.empty((b, 2, h * h))
        _bilinear_points(self.u, self.v, ix, tx, iy, ty, free, uv)
        u, v = uv[:, 0].copy(), uv[:, 1]
        uv[:, 0] = cos * u - sin * v  # R u
        uv[:, 1] = sin * u + cos * v
        return uv.astype(dtype, copy=False).reshape(b, 2, h, h), free.reshape(b, h, h)

    def interpolate(self, points_xy) -> np.ndarray:
        """The mean wind at points.

        Parameters
        ----------
        points_xy : array_like of shape (N, 2) or (2,)
            Points in the world frame, m.

        Returns
        -------
        ndarray of shape (N, 2)
            ``[u, v]``, m/s, world frame: the degree-1 spline (bilinear); 0 inside buildings
            and outside the city's bounds. Between the outermost cell centres and the bounds
            (half a cell) the point is moved onto the centres' hull, as
            :class:`~windnav.wind.GriddedWind` reads it: it read 0 m/s there, in open air
            (API audit, thirty-ninth session; the label grids of :meth:`grid_values` keep
            such cells out, and training draws its robots 12 m inside).
        """
        p = batch_array(points_xy, "points_xy", "MeanField.interpolate", (2,))
        x0, x1, y0, y1 = (float(b) for b in self.city.bounds)
        inside = (p[:, 0] >= x0) & (p[:, 0] <= x1) & (p[:, 1] >= y0) & (p[:, 1] <= y1)
        q = p.copy()
        q[inside, 0] = np.clip(q[inside, 0], self.x[0], self.x[-1])
        q[inside, 1] = np.clip(q[inside, 1], self.y[0], self.y[-1])
        out = np.empty((p.shape[0], 2, 1, 1))
        self._evaluate(q[:, :1], q[:, 1:], out)
        out[self.city.contains(p)] = 0.0  # a point in a building, wherever its clamp lands
        return out[:, :, 0, 0]


def _inlet(speed: float, direction_deg: float) -> np.ndarray:
    a = np.deg2rad(direction_deg)
    return float(speed) * np.array([np.cos(a), np.sin(a)])


def field_from_solution(city: City, solution, w_up=None, name: str = "") -> MeanField:
    """The mean field of a :class:`windnav.flow.FlowSolution`.

    Parameters
    ----------
    city : City
        The map the solution was computed on.
    solution : FlowSolution
        Its ``x``, ``y``, ``solid``, ``mean_u``, ``mean_v`` are used.
    w_up : array_like of shape (2,), optional
        Inlet wind, m/s, world frame; default from the solution's ``speed`` and
        ``direction_deg``.
    name : str
        Label of the field.
    """
    if w_up is None:
        w_up = _inlet(solution.speed, solution.direction_deg)
    return MeanField(city, solution.x, solution.y, solution.mean_u, solution.mean_v,
                     solution.solid, w_up, name)


def fields_from_store(path_or_store, maps=None, cases=None) -> list[MeanField]:
    """Every finished case of a sweep store (:class:`windnav.flow.SweepStore`) as a MeanField.

    The maps are rebuilt from the store's map attributes (bounds, footprints, heights), checked
    against the stored map fingerprint.

    Parameters
    ----------
    path_or_store : str, os.PathLike or SweepStore
    maps : sequence of int, optional
        Map indices (default: all).
    cases : sequence of int, optional
        Case indices (default: all); cases not done are skipped.

    Returns
    -------
    list of MeanField
        Ordered by (map, case), named ``"<map name>/<case>"``.

    Raises
    ------
    ValueError
        Naming the argument for an index out of range; a ``CorruptStoreError`` (a ValueError)
        when the map attributes are missing or do not match the fingerprint.
    """
    from windnav.flow.sweep_store import CorruptStoreError, SweepStore, map_fingerprint

    where = "fields_from_store"
    store = path_or_store if isinstance(path_or_store, SweepStore) else SweepStore(path_or_store)
    maps = _indices(maps, store.n_maps, "maps", where)
    cases = _indices(cases, store.n_cases, "cases", where)
    out = []
    for k in maps:
        attrs = store.map_attrs(k)
        try:
            footprints = np.asarray(attrs["footprints"], dtype=np.float64).reshape(-1, 4)
            city = City(attrs["bounds"], footprints, attrs["heights"])
        except (KeyError, ValueError) as exc:
            raise CorruptStoreError(f"{where}: map {k} of {store.path!r} has no usable map "
                                    f"attributes (bounds, footprints, heights): {exc}") from exc
        if "fingerprint" in attrs and map_fingerprint(city) != attrs["fingerprint"]:
            raise CorruptStoreError(f"{where}: map {k} of {store.path!r}: the stored footprints "
                                    "do not match the map fingerprint.")
        done = store.done(k)
        for c in cases:
            if not done[c]:
                continue
            case = store.read_case(k, c)
            out.append(MeanField(city, case["x"], case["y"], case["mean_u"], case["mean_v"],
                                 case["solid"], _inlet(case["speed"], case["direction_deg"]),
                                 f"{attrs.get('name', k)}/{c}"))
    return out


def _indices(values, n: int, name: str, where: str) -> list[int]:
    if values is None:
        return list(range(n))
    idx = [int(v) for v in np.atleast_1d(values)]
    bad = [i for i in idx if not 0 <= i < n]
    if bad:
        raise ValueError(f"The {name!r} parameter of {where} must hold indices in [0, {n}). "
                         f"Got {bad} instead.")
    return idx


class SampleBatch(NamedTuple):
    """A batch of decoder samples (thesis ch. 4).

    Attributes
    ----------
    scans : ndarray of float32, shape (B, 360)
        LiDAR ranges, m, ray k at k degrees counter-clockwise from +x (world), noisy, in
        [0.25, 100].
    w_up : ndarray of float32, shape (B, 2)
        Inlet wind, m/s, world frame.
    w_robot : ndarray of float32, shape (B, 2)
        Time-averaged wind at the robot (plus the optional noise), m/s, world frame.
    labels : ndarray of float32, shape (B, 2, H, H)
        ``[u, v]`` mean wind, m/s, indexed ``[b, :, iy, ix]`` at
        ``position + (offsets[ix], offsets[iy])``; 0 where not ``free``. A sample drawn with
        ``turn_deg`` > 0 is its scene turned about the robot: scan, winds and labels those of
        the turned world (:meth:`MeanField.turned_grid_values`).
    free : ndarray of bool, shape (B, H, H)
        Cells outside buildings and inside the solver grid.
    positions : ndarray of float64, shape (B, 2)
        Robot positions, m, world frame.
    inlet_speed : ndarray of float32, shape (B,)
        ``|w_up|``, m/s.
    """

    scans: np.ndarray
    w_up: np.ndarray
    w_robot: np.ndarray
    labels: np.ndarray
    free: np.ndarray
    positions: np.ndarray
    inlet_speed: np.ndarray


def _generator(rng, where: str) -> np.random.Generator:
    if isinstance(rng, np.random.Generator):
        return rng
    if isinstance(rng, bool) or not (rng is None or isinstance(rng, int | np.integer)):
        raise ValueError(f"The 'rng' parameter of {where} must be a numpy.random.Generator, an "
                         f"integer seed or None. Got {rng!r} instead.")
    return np.random.default_rng(rng)


def _min_distance2(fp: np.ndarray, p: np.ndarray) -> np.ndarray:
    """Squared distance of each point (N, 2) to the nearest footprint (closed rectangle)."""
    out = np.empty(p.shape[0])
    step = max(1, (1 << 22) // fp.shape[0])
    for s in range(0, p.shape[0], step):
        q = p[s:s + step]
        ex = np.maximum(np.maximum(fp[:, 0] - q[:, :1], q[:, :1] - fp[:, 1]), 0.0)
        ey = np.maximum(np.maximum(fp[:, 2] - q[:, 1:], q[:, 1:] - fp[:, 3]), 0.0)
        out[s:s + step] = (ex * ex + ey * ey).min(axis=1)
    return out


def robot_positions(field_or_city, n: int, *, rng, wall_clearance: float = 1.0,
                    building_reach: float = 40.0, edge_margin: float = 0.0) -> np.ndarray:
    """Random robot positions "around the buildings", uniform over the admissible set.

    A position is admissible when it lies outside every footprint, its distance to the nearest
    one lies in ``[wall_clearance, building_reach]``, and it keeps ``edge_margin`` from the edge
    of the domain: the hull of the solver's cell centres for a MeanField (so that label grids of
    half-width ``edge_margin`` lie inside the solver grid; the nearest solver cell must also be
    fluid), the map bounds for a City. Drawn by vectorised rejection sampling from the domain's
    part within ``building_reach`` of the buildings' bounding box.

    Parameters
    ----------
    field_or_city : MeanField or City
    n : int
        Number of positions, >= 1.
    rng : numpy.random.Generator, int or None, keyword-only (required)
        Random source or seed (None: fresh entropy); same source, same positions.
    wall_clearance : float
        Smallest distance to every wall, m, >= 0.
    building_reach : float
        Largest distance to the nearest building, m, > ``wall_clearance``.
    edge_margin : float
        Smallest distance to the domain's edge, m, >= 0.

    Returns
    -------
    ndarray of shape (n, 2)
        Positions, m, world frame.

    Raises
    ------
    ValueError
        Naming the argument for a bad value; and when the map has no buildings or no
        admissible area (or too little to find ``n`` positions in 1000 n + 10^6 draws).
    """
    where = "robot_positions"
    if isinstance(field_or_city, MeanField):
        field, city = field_or_city, field_or_city.city
        bx = field.x[0], field.x[-1], field.y[0], field.y[-1]
        b = city.bounds
        box = max(bx[0], b[0]), min(bx[1], b[1]), max(bx[2], b[2]), min(bx[3], b[3])
    elif isinstance(field_or_city, City):
        field, city = None, field_or_city
        box = city.bounds
    else:
        raise ValueError(f"The 'field_or_city' parameter of {where} must be a MeanField or a "
                         f"City. Got {type(field_or_city).__name__} instead.")
    n = positive_int(n, "n", where)
    rng = _generator(rng, where)
    clearance = positive_float(wall_clearance, "wall_clearance", where, allow_zero=True)
    reach = positive_float(building_reach, "building_reach", where)
    margin = positive_float(edge_margin, "edge_margin", where, allow_zero=True)
    if reach <= clearance:
        raise ValueError(f"The 'building_reach' parameter of {where} must be greater than "
                         f"wall_clearance ({clearance!r}). Got {building_reach!r} instead.")
    fp = city.footprints
    if fp.shape[0] == 0:
        raise ValueError(f"{where}: the map has no buildings, so no position lies within "
                         f"building_reach = {reach:g} m of one.")
    lo = np.array([max(box[0] + margin, fp[:, 0].min() - reach),
                   max(box[2] + margin, fp[:, 2].min() - reach)])
    hi = np.array([min(box[1] - margin, fp[:, 1].max() + reach),
                   min(box[3] - margin, fp[:, 3].max() + reach)])
    if np.any(lo >= hi):
        raise ValueError(f"{where}: the map has no admissible area: no point keeps "
                         f"edge_margin = {margin:g} m from the domain's edge within "
                         f"building_reach = {reach:g} m of a building.")
    found, count, drawn, budget = [], 0, 0, 1000 * n + 10**6
    batch = max(1024, 2 * n)
    while count < n:
        if drawn >= budget or (drawn >= 10**6 and count == 0):
            raise ValueError(
                f"{where}: the map has {'no' if count == 0 else 'too little'} admissible area "
                f"({count} of {drawn} uniform draws were >= wall_clearance = {clearance:g} m "
                f"from every wall and <= building_reach = {reach:g} m from a building).")
        p = rng.uniform(lo, hi, size=(batch, 2))
        drawn += batch
        d2 = _min_distance2(fp, p)
        # d2 > 0: a point inside a footprint is at distance 0, which wall_clearance = 0
        # admitted (923 of 2,000 draws inside one building; audit, 2026-12-05)
        ok = (d2 >= clearance * clearance) & (d2 > 0.0) & (d2 <= reach * reach)
        if field is not None:
            ix, tx, _ = _locate(field.x, p[:, 0])
            iy, ty, _ = _locate(field.y, p[:, 1])
            ok &= ~field.solid[iy + (ty >= 0.5), ix + (tx >= 0.5)]
        found.append(p[ok])
        count += int(ok.sum())
        rate = max(count / drawn, 1e-3)
        batch = int(min(max(1024, 1.2 * (n - count) / rate), 1 << 20))
    return np.concatenate(found)[:n]


_GOLDEN = np.uint64(0x9E3779B97F4A7C15)
_MIX1 = np.uint64(0xBF58476D1CE4E5B9)
_MIX2 = np.uint64(0x94D049BB133111EB)
_S11, _S27, _S30, _S31 = (np.uint64(k) for k in (11, 27, 30, 31))
_TWO_M53 = 2.0**-53


@njit(cache=True, inline="always")
def _mix(state):  # pragma: no cover - numba
    """SplitMix64's output function of ``state`` (uint64)."""
    z = (state ^ (state >> _S30)) * _MIX1
    z = (z ^ (z >> _S27)) * _MIX2
    return z ^ (z >> _S31)


@njit(cache=True)
def _splitmix64(key, counter, out):  # pragma: no cover - numba
    """``out[k]`` = output ``counter[k]`` of the stream of ``key``:
    ``mix(key + (counter + 1) * golden)``, all uint64 (key 0, counter 0: 0xE220A8397B1DCDAF)."""
    for k in range(counter.size):
        out[k] = _mix(key + (counter[k] + np.uint64(1)) * _GOLDEN)


@njit(cache=True, nogil=True)
def _normal_blocks(key, index, out):  # pragma: no cover - numba
    """Standard normals: row b of ``out`` (B, m), m even, from counters ``index[b] * m + r``
    of the stream of ``key``; pairs of 53-bit uniforms (u1, u2) in (0, 1) become
    ``sqrt(-2 ln u1) (cos 2 pi u2, sin 2 pi u2)`` (Box & Muller 1958)."""
    m = out.shape[1]
    for b in range(index.size):
        state = key + np.uint64(index[b]) * np.uint64(m) * _GOLDEN
        for r in range(0, m, 2):
            state += _GOLDEN
            u1 = (float(_mix(state) >> _S11) + 0.5) * _TWO_M53
            state += _GOLDEN
            u2 = (float(_mix(state) >> _S11) + 0.5) * _TWO_M53
            radius = math.sqrt(-2.0 * math.log(u1))
            out[b, r] = radius * math.cos(2.0 * math.pi * u2)
            out[b, r + 1] = radius * math.sin(2.0 * math.pi * u2)


def _normals(key: int, index: np.ndarray, m: int) -> np.ndarray:
    """Standard normals (B, m): row b is block ``index[b]`` of the counter stream of ``key``."""
    out = np.empty((index.size, m))
    _normal_blocks(np.uint64(key), np.ascontiguousarray(index, dtype=np.int64), out)
    return out


_TURN_SALT = 0x7475726E5F646567  # "turn_deg": the turns' stream of a key, apart from its noise


def turn_angles(key: int, index: np.ndarray, turn_deg: int) -> np.ndarray:
    """The turns of samples ``index`` of ``key``, whole degrees uniform in ``[-turn_deg,
    turn_deg]`` (int64): output ``index[b]`` of the SplitMix64 stream of ``key ^ salt``, modulo
    ``2 turn_deg + 1`` (a bias under 1e-17). A pure function of (key, index), as the noise."""
    out = np.empty(np.size(index), dtype=np.uint64)
    _splitmix64(np.uint64(int(key) ^ _TURN_SALT),
                np.ascontiguousarray(index, dtype=np.int64).astype(np.uint64), out)
    return (out % np.uint64(2 * turn_deg + 1)).astype(np.int64) - turn_deg


def _samples(field: MeanField, positions: np.ndarray, key: int, index: np.ndarray,
             offsets: np.ndarray, scan_noise: float, w_robot_noise: float,
             turn_deg: int = 0) -> SampleBatch:
    """Samples of ``field`` at ``positions``, with the noise blocks ``index`` of ``key``; each
    scene turned by its :func:`turn_angles` when ``turn_deg`` > 0."""
    b = positions.shape[0]
    clean = field.city.lidar(positions, n_rays=N_RAYS, max_range=SCAN_MAX, min_range=0.0)
    z = _normals(key, index, _NOISE_PER_SAMPLE)
    # returns only: a ray that hits nothing reads SCAN_MAX exactly, as City.lidar's noise does
    scans = clean + (scan_noise * (clean < SCAN_MAX)) * z[:, :N_RAYS]
    np.clip(scans, SCAN_MIN, SCAN_MAX, out=scans)
    w_robot = field.interpolate(positions) + w_robot_noise * z[:, N_RAYS:]
    w_up = np.broadcast_to(field.w_up, (b, 2)).copy()
    if turn_deg:
        # the world turned about the robot: ray k of the turned scan is ray k - angle (1 deg
        # rays), both winds and the labels' vectors turned, the labels read where the turn
        # carries the world's points (MeanField.turned_grid_values)
        angles = turn_angles(key, index, turn_deg)
        rays = (np.arange(N_RAYS) - angles[:, None]) % N_RAYS
        scans = np.take_along_axis(scans, rays, axis=1)
        a = np.radians(angles)
        turn = np.stack([np.stack([np.cos(a), -np.sin(a)], -1),
                         np.stack([np.sin(a), np.cos(a)], -1)], 1)  # (B, 2, 2)
        w_up = np.einsum("bij,bj->bi", turn, w_up)
        w_robot = np.einsum("bij,bj->bi", turn, w_robot)
        labels, free = field.turned_grid_values(positions, offsets, angles, dtype=np.float32)
    else:
        labels, free = field.grid_values(positions, offsets, dtype=np.float32)
    return SampleBatch(scans.astype(np.float32), w_up.astype(np.float32),
                       w_robot.astype(np.float32), labels, free, positions.copy(),
                       np.full(b, field.inlet_speed, dtype=np.float32))


TURN_LIMIT_DEG = 45
"""The largest ``turn_deg`` of the decoder's samples, deg."""


def _check_noise(scan_noise, w_robot_noise, where: str) -> tuple[float, float]:
    return (positive_float(scan_noise, "scan_noise", where, allow_zero=True),
            positive_float(w_robot_noise, "w_robot_noise", where, allow_zero=True))


def _check_turn(turn_deg, where: str) -> int:
    if (isinstance(turn_deg, bool) or not isinstance(turn_deg, int | np.integer)
            or not 0 <= turn_deg <= TURN_LIMIT_DEG):
        raise ValueError(f"The 'turn_deg' parameter of {where} must be a whole number of "
                         f"degrees in [0, {TURN_LIMIT_DEG}]. Got {turn_deg!r} instead.")
    return int(turn_deg)


def _draw(field, n, rng, offsets, clearance, reach, where, turn_deg: int = 0):
    """Positions and noise key of ``n`` samples of ``field`` from ``rng`` (in this order); the
    label grid, turned by up to ``turn_deg``, inside the solver grid."""
    rng = _generator(rng, where)
    a = math.radians(turn_deg)  # a turned grid's corner reaches (cos a + sin a) of the half-width
    margin = float(offsets[-1]) * ((math.cos(a) + math.sin(a)) if turn_deg else 1.0)
    positions = robot_positions(field, n, rng=rng, wall_clearance=clearance, building_reach=reach,
                                edge_margin=margin)
    return positions, int(rng.integers(0, 2**63, dtype=np.int64))


def draw_samples(field: MeanField, n: int, *, rng, size: int = 25, spacing: float = 1.0,
                 scan_noise: float = SCAN_NOISE, w_robot_noise: float = 0.0,
                 wall_clearance: float = 1.0, building_reach: float = 40.0,
                 turn_deg: int = 0) -> SampleBatch:
    """Draw ``n`` decoder samples from one mean field (see the module doc).

    Parameters
    ----------
    field : MeanField
    n : int
        Number of samples, >= 1.
    rng : numpy.random.Generator, int or None, keyword-only (required)
        Random source or seed (None: fresh entropy); same source, same batch bit for bit.
    size : int
        Label grid cells per side ``H``.
    spacing : float
        Label cell size, m.
    scan_noise : float
        Standard deviation of the range noise, m, >= 0.
    w_robot_noise : float
        Standard deviation of the noise on each component of ``W_robot``, m/s, >= 0.
    wall_clearance, building_reach : float
        Of the robot positions, m (:func:`robot_positions`); the positions also keep the
        label grid's half-width from the solver grid's edge.
    turn_deg : int
        Turn each sample's scene about its robot by a whole number of degrees drawn uniformly
        from ``[-turn_deg, turn_deg]`` (:func:`turn_angles`): its scan shifted by as many
        rays, both winds turned, and its labels the turned world's
        (:meth:`MeanField.turned_grid_values`), so that a field simulated at one inlet
        direction teaches the directions around it. 0 (default): as simulated. The positions
        keep the turned grid's half-width from the solver grid's edge, so 0 and > 0 draw
        other positions.

    Returns
    -------
    SampleBatch
    """
    where = "draw_samples"
    if not isinstance(field, MeanField):
        raise ValueError(f"The 'field' parameter of {where} must be a MeanField. "
                         f"Got {type(field).__name__} instead.")
    offsets = grid_offsets(size, spacing)
    noise = _check_noise(scan_noise, w_robot_noise, where)
    turn = _check_turn(turn_deg, where)
    positions, key = _draw(field, positive_int(n, "n", where), rng, offsets, wall_clearance,
                           building_reach, where, turn)
    return _samples(field, positions, key, np.arange(positions.shape[0]), offsets, *noise, turn)


class DecoderDataset:
    """A fixed set of decoder samples, ``samples_per_field`` per field, derived on demand.

    Sample ``i`` is sample ``j = i % S`` of field ``f = i // S`` (``S = samples_per_field``),
    and the samples of field ``f`` are exactly ``draw_samples(fields[f], S,
    rng=numpy.random.default_rng([seed, 0, f]), ...)``: positions are drawn (and kept, 16 bytes
    each) at construction; scans, labels and noise are recomputed whenever asked for.

    Guarantees: sample ``i`` is the same, bit for bit, in every epoch, batch size, order,
    :meth:`samples` and :meth:`materialize` call, for the same fields and arguments. The
    order of epoch ``e`` is a permutation drawn from ``default_rng([seed, 1, e])``.

    Parameters
    ----------
    fields : sequence of MeanField
    samples_per_field : int
        Samples drawn from each field, >= 1 (the thesis uses 2048).
    seed : int
        Root seed.
    size, spacing, scan_noise, w_robot_noise, wall_clearance, building_reach, turn_deg
        As in :func:`draw_samples`.
    threads : int
        Threads deriving the samples of different fields at once (>= 1; the same samples bit
        for bit for any count). 2 on the 2-core machine: a training block of 552,960 samples
        in half the time (2026-12-03).

    Attributes
    ----------
    fields : tuple of MeanField
    samples_per_field : int
    offsets : ndarray of shape (H,)
        Label cell-centre offsets, m.
    """

    def __init__(self, fields: Sequence[MeanField], samples_per_field: int, *, seed: int = 0,
                 size: int = 25, spacing: float = 1.0, scan_noise: float = SCAN_NOISE,
                 w_robot_noise: float = 0.0, wall_clearance: float = 1.0,
                 building_reach: float = 40.0, threads: int = 1, turn_deg: int = 0):
        where = "DecoderDataset"
        self.fields = tuple(fields)
        if not self.fields or not all(isinstance(f, MeanField) for f in self.fields):
            raise ValueError(f"The 'fields' parameter of {where} must be a non-empty sequence "
                             f"of MeanField. Got {fields!r} instead.")
        self.samples_per_field = positive_int(samples_per_field, "samples_per_field", where)
        if isinstance(seed, bool) or not isinstance(seed, int | np.integer) or seed < 0:
            raise ValueError(f"The 'seed' parameter of {where} must be an integer >= 0. "
                             f"Got {seed!r} instead.")
        self.seed = int(seed)
        self.threads = positive_int(threads, "threads", where)
        self.offsets = grid_offsets(size, spacing)
        self.offsets.setflags(write=False)
        self._noise = _check_noise(scan_noise, w_robot_noise, where)
        self.turn_deg = _check_turn(turn_deg, where)
        # positions and noise keys, drawn now so that a map without room fails here, not in
        # the middle of an epoch
        self._draws = []
        for k, f in enumerate(self.fields):
            rng = np.random.default_rng([self.seed, 0, k])
            try:
                self._draws.append(_draw(f, self.samples_per_field, rng, self.offsets,
                                         wall_clearance, building_reach, where, self.turn_deg))
            except ValueError as exc:
                raise ValueError(f"{where}: field {k} ({f.name!r}): {exc}") from exc

    def __len__(self) -> int:
        return len(self.fields) * self.samples_per_field

    def samples(self, indices) -> SampleBatch:
        """The samples of the given global indices, in that order.

        Parameters
        ----------
        indices : array_like of int, shape (B,)
            In ``[0, len(self))``.
        """
        idx = np.asarray(indices).reshape(-1)
        if idx.dtype.kind not in "iu" or (idx.size and (idx.min() < 0 or idx.max() >= len(self))):
            raise ValueError(f"The 'indices' parameter of DecoderDataset.samples must be "
                             f"integers in [0, {len(self)}). Got {np.asarray(indices)!r} "
                             "instead.")
        h, b = self.offsets.size, idx.size
        out = SampleBatch(np.empty((b, N_RAYS), np.float32), np.empty((b, 2), np.float32),
                          np.empty((b, 2), np.float32), np.empty((b, 2, h, h), np.float32),
                          np.empty((b, h, h), bool), np.empty((b, 2)), np.empty(b, np.float32))
        f_of, j_of = np.divmod(idx.astype(np.int64), self.samples_per_field)
        order = np.argsort(f_of, kind="stable")
        fields, starts = np.unique(f_of[order], return_index=True)

        def fill(group) -> None:  # one field's samples into its own rows of out
            f, rows = group
            positions, key = self._draws[f]
            j = j_of[rows]
            part = _samples(self.fields[f], positions[j], key, j, self.offsets, *self._noise,
                            self.turn_deg)
            for dst, src in zip(out, part, strict=True):
                dst[rows] = src

        groups = list(zip(fields, np.split(order, starts[1:]), strict=True))
        if self.threads > 1 and len(groups) > 1:
            # the fields on threads: the LiDAR, noise and label kernels release the GIL
            with ThreadPoolExecutor(min(self.threads, len(groups))) as pool:
                list(pool.map(fill, groups))
        else:
            for group in groups:
                fill(group)
        return out

    def indices(self, epoch: int, shuffle: bool = True) -> np.ndarray:
        """The sample order of an epoch: a permutation from ``default_rng([seed, 1, epoch])``,
        or ``arange(len(self))`` without ``shuffle``."""
        if isinstance(epoch, bool) or not isinstance(epoch, int | np.integer) or epoch < 0:
            raise ValueError(f"The 'epoch' parameter of DecoderDataset.epoch must be an integer "
                             f">= 0. Got {epoch!r} instead.")
        if not shuffle:
            return np.arange(len(self))
        return np.random.default_rng([self.seed, 1, int(epoch)]).permutation(len(self))

    def epoch(self, epoch: int, batch_size: int, shuffle: bool = True) -> Iterator[SampleBatch]:
        """Batches covering every sample once, in the order of :meth:`indices`.

        Parameters
        ----------
        epoch : int
            Epoch number, >= 0 (chooses the order).
        batch_size : int
            Samples per batch, >= 1; the last batch may be smaller.
        shuffle : bool
            Permute the samples (else in index order).
        """
        batch_size = positive_int(batch_size, "batch_size", "DecoderDataset.epoch")
        order = self.indices(epoch, shuffle)
        # Generated in blocks of at least _BLOCK samples, then cut: the cost per field touched
        # (one LiDAR call, one label evaluation) is paid once per block, not once per batch.
        block = batch_size * max(1, -(-_BLOCK // batch_size))
        for s in range(0, order.size, block):
            part = self.samples(order[s:s + block])
            for t in range(0, part.scans.shape[0], batch_size):
                yield SampleBatch(*(a[t:t + batch_size] for a in part))

    def materialize(self) -> SampleBatch:
        """All samples at once, in index order (small sets, evaluation)."""
        return self.samples(np.arange(len(self)))
