"""Building maps: axis-aligned rectangular footprints inside rectangular bounds.

A :class:`City` is a frozen value: bounds ``(x_min, x_max, y_min, y_max)`` in metres (world
frame, x east, y north) and an ``(M, 4)`` array of building footprints
``[x_min, x_max, y_min, y_max]`` with heights ``(M,)`` in metres kept for 3D export.
Each footprint is one cuboid block ``[x_min, x_max] x [y_min, y_max] x [base_z, base_z + height]``,
the primitive of a RotorPy world. Overlapping or touching blocks are allowed and form a union
(one building, see :meth:`City.building_labels`). Footprints are closed sets: a point on an edge
is inside the building.

The map bounds are the simulation domain, not walls: only buildings are solid.
"""

from __future__ import annotations

import copy
import math
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from windnav._validate import ReadOnlyOnCopy, batch_array, keyword_only, positive_float
from windnav.city.lidar import lidar_scan
from windnav.city.rotorpy_json import (
    DEFAULT_COLOR,  # noqa: F401  (re-exported: the colour of blocks written without one)
    load_rotorpy_doc,
    parse_rotorpy_doc,
    write_rotorpy_json,
)

RASTER_RULES = ("centre", "overlap")
"""Rules of :meth:`City.rasterize`."""


def _block_text(i: int, fp, base: float, height: float) -> str:
    ext = [float(fp[0]), float(fp[1]), float(fp[2]), float(fp[3]), base, base + height]
    return f"block {i} with extents {ext}"


@dataclass(frozen=True, eq=False)
class City(ReadOnlyOnCopy):
    """A city map of cuboid buildings.

    Parameters
    ----------
    bounds : sequence of 4 float
        ``(x_min, x_max, y_min, y_max)`` of the map, m.
    footprints : array_like of shape (M, 4)
        Building footprints ``[x_min, x_max, y_min, y_max]``, m. Each lies inside ``bounds`` and
        has positive width and depth.
    heights : array_like of shape (M,)
        Building heights above their base, m, > 0.
    base_z : array_like of shape (M,), optional
        Height of each block's floor, m. Defaults to 0.
    z_bounds : (float, float), optional
        Vertical extent ``(z_min, z_max)`` of the map, m; every block lies inside it. Defaults
        to ``(min(0, min base_z), max(1, max top))``.
    block_attrs : sequence of M dict, optional
        Extra JSON keys of each block (``"color"``, ...), kept for a lossless RotorPy round trip.
    extras : dict, optional
        Extra top-level JSON keys (and extra keys of ``"bounds"`` under ``extras["bounds"]``).

    Raises
    ------
    ValueError
        If the bounds are not a finite box, or a block is non-finite, has a non-positive size or
        lies outside the bounds; the message names the block by index and extents.
    """

    bounds: tuple
    footprints: np.ndarray
    heights: np.ndarray
    base_z: np.ndarray | None = None
    z_bounds: tuple | None = None
    block_attrs: tuple | None = field(default=None, repr=False)
    extras: dict | None = field(default=None, repr=False)

    def __post_init__(self):
        b = tuple(float(v) for v in np.asarray(self.bounds, dtype=np.float64).reshape(-1))
        if len(b) != 4 or not np.all(np.isfinite(b)) or not (b[0] < b[1] and b[2] < b[3]):
            raise ValueError(
                "The 'bounds' parameter of City must be finite (x_min, x_max, y_min, y_max) "
                f"with x_min < x_max and y_min < y_max. Got {self.bounds!r} instead."
            )
        fp = np.array(self.footprints, dtype=np.float64)
        if fp.size == 0:
            fp = fp.reshape(0, 4)
        if fp.ndim != 2 or fp.shape[1] != 4:
            raise ValueError(
                "The 'footprints' parameter of City must have shape (M, 4). "
                f"Got shape {fp.shape} instead."
            )
        m = fp.shape[0]
        h = np.array(self.heights, dtype=np.float64).reshape(-1)
        if h.shape != (m,):
            raise ValueError(
                f"The 'heights' parameter of City must have one value per footprint ({m}). "
                f"Got shape {h.shape} instead."
            )
        base = np.zeros(m) if self.base_z is None else np.array(self.base_z, dtype=np.float64)
        base = base.reshape(-1)
        if base.shape != (m,):
            raise ValueError(
                f"The 'base_z' parameter of City must have one value per footprint ({m}). "
                f"Got shape {base.shape} instead."
            )
        if self.z_bounds is None:
            top = float(np.max(base + h)) if m else 1.0
            zb = (min(0.0, float(np.min(base))) if m else 0.0, max(1.0, top))
        else:
            zb = tuple(float(v) for v in self.z_bounds)
            if len(zb) != 2 or not np.all(np.isfinite(zb)) or not zb[0] < zb[1]:
                raise ValueError(
                    "The 'z_bounds' parameter of City must be finite (z_min, z_max) with "
                    f"z_min < z_max. Got {self.z_bounds!r} instead."
                )
        _check_blocks(b, zb, fp, h, base)
        attrs = self.block_attrs
        if attrs is not None:
            try:
                attrs = tuple(dict(a) for a in attrs)
            except (TypeError, ValueError):
                raise ValueError("The 'block_attrs' parameter of City must be a sequence of "
                                 f"dicts, one per footprint. Got {attrs!r} instead.") from None
            if len(attrs) != m:
                raise ValueError(
                    f"The 'block_attrs' parameter of City must hold one dict per footprint ({m}). "
                    f"Got {len(attrs)} instead."
                )
        for arr in (fp, h, base):
            arr.setflags(write=False)
        object.__setattr__(self, "bounds", b)
        object.__setattr__(self, "footprints", fp)
        object.__setattr__(self, "heights", h)
        object.__setattr__(self, "base_z", base)
        object.__setattr__(self, "z_bounds", zb)
        object.__setattr__(self, "block_attrs", copy.deepcopy(attrs))
        object.__setattr__(self, "extras", copy.deepcopy(dict(self.extras or {})))

    # ------------------------------------------------------------------ geometry
    @property
    def n_buildings(self) -> int:
        """Number of blocks M: the rows of ``footprints`` (one cuboid each), not of buildings.

        Blocks that overlap or touch count separately, so a map of
        :func:`~windnav.city.planning_map` (buildings of 1-3 blocks) has more blocks than
        buildings. The distinct buildings are the labels of :meth:`building_labels`:
        ``np.unique(city.building_labels()).size`` (what ``planning_map``'s ``n_buildings``
        counts). The name is kept for compatibility.
        """
        return int(self.footprints.shape[0])

    @property
    def size(self) -> tuple[float, float]:
        """Map extent ``(x_max - x_min, y_max - y_min)``, m."""
        x0, x1, y0, y1 = self.bounds
        return (x1 - x0, y1 - y0)

    def building_labels(self) -> np.ndarray:
        """Label the connected buildings formed by overlapping or touching blocks.

        Returns
        -------
        ndarray of int, shape (M,)
            ``labels[i] == labels[j]`` iff blocks i and j are joined by a chain of blocks whose
            closed footprints intersect. Labels are ``0 .. n - 1`` in order of first block.
        """
        fp = self.footprints
        m = fp.shape[0]
        parent = np.arange(m)

        def root(i):
            while parent[i] != i:
                parent[i] = parent[parent[i]]
                i = parent[i]
            return i

        touch = (
            (fp[:, None, 0] <= fp[None, :, 1])
            & (fp[None, :, 0] <= fp[:, None, 1])
            & (fp[:, None, 2] <= fp[None, :, 3])
            & (fp[None, :, 2] <= fp[:, None, 3])
        )
        for i, j in zip(*np.nonzero(np.triu(touch, 1)), strict=True):
            ri, rj = root(i), root(j)
            if ri != rj:
                parent[max(ri, rj)] = min(ri, rj)
        roots = np.array([root(i) for i in range(m)], dtype=np.int64)
        _, labels = np.unique(roots, return_inverse=True)
        return labels.reshape(-1)

    def contains(self, points_xy) -> np.ndarray:
        """Whether points lie inside (or on the edge of) any footprint.

        Parameters
        ----------
        points_xy : array_like of shape (B, 2) or (2,)
            Points in the world frame, m.

        Returns
        -------
        ndarray of bool, shape (B,)
        """
        p = batch_array(points_xy, "points_xy", "City.contains", (2,), finite=False)
        fp = self.footprints
        x, y = p[:, 0:1], p[:, 1:2]
        inside = (x >= fp[:, 0]) & (x <= fp[:, 1]) & (y >= fp[:, 2]) & (y <= fp[:, 3])
        return inside.any(axis=1)

    def grid(self, dx: float) -> tuple[np.ndarray, np.ndarray]:
        """Cell centres of a uniform grid of spacing ``dx`` covering the bounds.

        The grid of :func:`grid_shape` (the one rule shared with the flow solver, the sweeps
        and the planners): it starts at ``(x_min, y_min)`` with ``nx = ceil((x_max - x_min) /
        dx)`` cells (at least 2; rounded to the nearest integer when the ratio is within 1e-9
        of it); when the extent is not a multiple of ``dx`` the last cell reaches past the
        bound.

        Parameters
        ----------
        dx : float
            Cell size, m, > 0.

        Returns
        -------
        x : ndarray of shape (nx,)
            Cell-centre abscissae ``x_min + (i + 0.5) dx``, m.
        y : ndarray of shape (ny,)
            Cell-centre ordinates ``y_min + (j + 0.5) dx``, m.
        """
        dx = positive_float(dx, "dx", "City.grid")
        x0, _, y0, _ = self.bounds
        ny, nx = grid_shape(self.bounds, dx)
        return x0 + (np.arange(nx) + 0.5) * dx, y0 + (np.arange(ny) + 0.5) * dx

    def rasterize(self, x: np.ndarray, y: np.ndarray, *, rule: str = "centre") -> np.ndarray:
        """Solid mask on the grid of cell centres ``x`` (nx,) and ``y`` (ny,).

        Parameters
        ----------
        x : array_like of shape (nx,)
            Cell-centre abscissae, m.
        y : array_like of shape (ny,)
            Cell-centre ordinates, m.
        rule : {"centre", "overlap"}
            ``"centre"`` (default, the flow solver's): a cell is solid when its centre lies
            inside (or on the edge of) any footprint, so the solid area converges to the
            footprint area; a block thinner than a cell can cover no centre and vanish (the
            solver refuses such maps, see :meth:`check_resolution`). ``"overlap"``
            (conservative, for occupancy and collision checks): a cell is solid when it
            overlaps any footprint with positive area (cells span the midpoints between
            centres), so nothing the LiDAR can hit is ever missing from the grid.

        For increasing coordinates each footprint fills one index range found by bisection, so
        the cost is ``O(M log n + solid cells)``; with ``"centre"`` other coordinates fall back
        to comparisons.

        Returns
        -------
        ndarray of bool, shape (ny, nx)
        """
        if rule not in RASTER_RULES:
            raise ValueError(
                f"The 'rule' parameter of City.rasterize must be one of {RASTER_RULES}. "
                f"Got {rule!r} instead."
            )
        x = np.asarray(x, dtype=np.float64).reshape(-1)
        y = np.asarray(y, dtype=np.float64).reshape(-1)
        mask = np.zeros((y.size, x.size), dtype=bool)
        fp = self.footprints
        if _increasing(x) and _increasing(y):
            for a, b, c, d in zip(*_index_ranges(fp, x, y, rule), strict=True):
                mask[c:d, a:b] = True
            return mask
        if rule != "centre":
            raise ValueError(
                "City.rasterize: the 'overlap' rule needs increasing cell centres 'x' and 'y'."
            )
        for x0, x1, y0, y1 in fp:
            ix = (x >= x0) & (x <= x1)
            iy = (y >= y0) & (y <= y1)
            mask |= iy[:, None] & ix[None, :]
        return mask

    def check_resolution(self, dx: float, where: str = "City.check_resolution") -> None:
        """Refuse a grid of spacing ``dx`` (m, the :meth:`grid`) on which a block would vanish.

        Under the solver's centre rule a block covers no cell centre when it is thinner than
        a cell (or slips between centres); the flow would then pass through a building the
        LiDAR sees. Raises a ValueError naming the first such block, its thinnest side and the
        largest ``dx`` that keeps every block. Blocks thinner than ``2 dx`` (kept, but with
        their shape lost) give a UserWarning, and so does a ``dx`` above ``s / 8`` (``s`` the
        median building's smaller side), the coarsest resolution at which the flow solver's
        grid independence was validated (:func:`windnav.flow.validity.resolution_check`).
        """
        dx = positive_float(dx, "dx", where)
        if self.n_buildings == 0:
            return
        x, y = self.grid(dx)
        i0, i1, j0, j1 = _index_ranges(self.footprints, x, y, "centre")
        fp = self.footprints
        thin = np.minimum(fp[:, 1] - fp[:, 0], fp[:, 3] - fp[:, 2])
        gone = np.flatnonzero((i1 <= i0) | (j1 <= j0))
        def block(k: int) -> str:
            return _block_text(k, fp[k], float(self.base_z[k]), float(self.heights[k]))

        if gone.size:
            k = int(gone[0])
            more = f" ({gone.size - 1} more blocks vanish too)" if gone.size > 1 else ""
            raise ValueError(
                f"{where}: City {block(k)} "
                f"covers no cell of the grid at dx = {dx:g} m (its thinnest side is "
                f"{thin[k]:.3g} m), so the flow would pass through it{more}. Use dx <= "
                f"{float(np.min(thin)) / 2:.3g} m (two cells across the thinnest block) or remove "
                "the block."
            )
        shape_lost = np.flatnonzero(thin < 2.0 * dx)
        if shape_lost.size:
            k = int(shape_lost[0])
            warnings.warn(
                f"{where}: {shape_lost.size} block(s) thinner than 2 cells at dx = {dx:g} m, "
                f"e.g. {block(k)} "
                f"({thin[k]:.3g} m): they keep at most one cell across.",
                UserWarning, stacklevel=3)
        note = self.resolution_note(dx)  # accepted, but outside the validated series
        if note is not None:
            warnings.warn(f"{where}: {note}", UserWarning, stacklevel=3)

    @property
    def median_building_side(self) -> float | None:
        """The median over the blocks of their smaller side, m (None without blocks): the
        length the flow solver's filter and its validated resolution are tied to."""
        if self.n_buildings == 0:
            return None
        fp = self.footprints
        return float(np.median(np.minimum(fp[:, 1] - fp[:, 0], fp[:, 3] - fp[:, 2])))

    def resolution_note(self, dx: float) -> str | None:
        """The words for a cell size ``dx`` (m) above ``s / 8`` (``s``:
        :attr:`median_building_side`), the coarsest grid of docs/flow_validation.md's
        grid-independence series (the filter is ``s / 8``,
        ``windnav.flow.solver.FILTER_PER_BUILDING``); None at or below it, or without blocks."""
        side = self.median_building_side
        if side is None or dx <= side / 8 * (1.0 + 1e-9):
            return None
        return (f"cell size above the validated resolution (s/8 = {side / 8:.3g} m, s the "
                f"median building's smaller side; dx = {dx:g} m): results grid-dependent")

    def fingerprint(self) -> str:
        """SHA-256 (hex) of the geometry every flow, scan and flight depends on: the bounds, the
        vertical extent and each block's footprint, height and floor (float64 bytes). Not the
        blocks' colours or other JSON keys, which change nothing flown; two files of the same
        blocks in the same order print alike (the order is kept: a reordered file is another
        fingerprint, though it flies the same)."""
        import hashlib

        h = hashlib.sha256(b"City/1")
        for part in (self.bounds, self.z_bounds, self.footprints, self.heights, self.base_z):
            a = np.ascontiguousarray(part, dtype=np.float64)
            h.update(f"{a.shape}".encode())
            h.update(a.tobytes())
        return h.hexdigest()

    # ------------------------------------------------------------------ sensing
    def lidar(
        self,
        origins_xy,
        n_rays: int = 360,
        max_range: float = 100.0,
        min_range: float = 0.0,
        noise_std: float = 0.0,
        *args,
        rng=None,
        normals=None,
    ) -> np.ndarray:
        """Planar LiDAR scans from a batch of origins (exact slab ray casting, numba).

        Parameters
        ----------
        origins_xy : array_like of shape (B, 2) or (2,)
            Sensor positions in the world frame, m.
        n_rays : int
            Rays per scan, >= 1.
        max_range : float
            Largest reading, m, > ``min_range``; read where nothing is hit.
        min_range : float
            Smallest reading, m, >= 0.
        noise_std : float
            Standard deviation of Gaussian noise on returns, m, >= 0.
        rng : numpy.random.Generator or int, optional, keyword-only (positional: deprecated)
            Noise source or seed; required when ``noise_std > 0`` and ``normals`` is None.
        normals : array_like of shape (B, n_rays), optional
            The noise's standard normals, drawn by the caller, instead of ``rng``.

        Returns
        -------
        ndarray of shape (B, n_rays)
            Ranges, m, clipped to ``[min_range, max_range]``; ray k points at angle
            ``2 pi k / n_rays`` from +x. Origins inside or on the edge of a building read
            ``min_range`` on every ray. The map bounds are not walls.

        See Also
        --------
        windnav.city.lidar.lidar_scan : the implementation and its equations.
        """
        kw = keyword_only(args, {"rng": rng, "normals": normals}, "City.lidar")
        return lidar_scan(self, origins_xy, n_rays=n_rays, max_range=max_range,
                          min_range=min_range, noise_std=noise_std, rng=kw["rng"],
                          normals=kw["normals"])

    # ------------------------------------------------------------------ files
    @classmethod
    def from_rotorpy_json(cls, path) -> City:
        """Read a RotorPy world JSON file (``bounds.extents``, ``blocks[].extents``).

        Parameters
        ----------
        path : str or path-like

        Returns
        -------
        City
            Every JSON key is kept, so :meth:`to_rotorpy_json` writes the same document.

        Raises
        ------
        FileNotFoundError
            If the file does not exist (naming it).
        ValueError
            Naming the file and what is wrong (a folder, not UTF-8 text, invalid JSON, missing
            keys, a block outside the bounds or without volume, by index and extents).

        See Also
        --------
        read_rotorpy_json
        """
        return read_rotorpy_json(path)

    def to_rotorpy_json(self, path) -> Path:
        """Write this map as RotorPy world JSON.

        Parameters
        ----------
        path : str or path-like
            The file to (over)write.

        Returns
        -------
        Path
            The file written.
        """
        return write_rotorpy_json(self, path)


def check_city(city, where: str) -> City:
    """``city`` if it is a :class:`City`, else a ValueError naming the parameter (an
    AttributeError deep inside the caller before)."""
    if not isinstance(city, City):
        raise ValueError(f"The 'city' parameter of {where} must be a windnav.city.City (e.g. "
                         f"City.from_rotorpy_json(path)). Got {type(city).__name__} instead.")
    return city


def read_rotorpy_json(path) -> City:
    """Read a RotorPy world JSON file.

    Parameters
    ----------
    path : str or path-like
        The file.

    Returns
    -------
    City

    Raises
    ------
    FileNotFoundError
        If the file does not exist.
    ValueError
        If the file is not valid JSON, lacks ``bounds.extents`` or ``blocks``, has an extents
        entry that is not 6 finite numbers, or a block that lies outside the bounds or has no
        volume. The message names the file and the offending block (index and extents).
    """
    doc = load_rotorpy_doc(path)
    try:
        return City(**parse_rotorpy_doc(doc))
    except ValueError as exc:
        raise ValueError(f"RotorPy world file {str(path)!r}: {exc}") from None


def city_from_rotorpy_dict(doc) -> City:
    """Build a :class:`City` from a RotorPy world dictionary (as ``json.load`` returns it).

    Raises
    ------
    ValueError
        Naming what is missing or malformed, or the offending block (index and extents).
    """
    return City(**parse_rotorpy_doc(doc))


def _check_blocks(b, zb, fp, h, base) -> None:
    bad = ~np.all(np.isfinite(fp), axis=1) | ~np.isfinite(h) | ~np.isfinite(base)
    rules = [
        (bad, "must be finite"),
        ((fp[:, 1] <= fp[:, 0]) | (fp[:, 3] <= fp[:, 2]) | (h <= 0),
         "must have positive size (x_min < x_max, y_min < y_max, z_min < z_max)"),
        ((fp[:, 0] < b[0]) | (fp[:, 1] > b[1]) | (fp[:, 2] < b[2]) | (fp[:, 3] > b[3])
         | (base < zb[0]) | (base + h > zb[1]),
         f"must lie inside the map bounds {[*b, *zb]}"),
    ]
    for fails, rule in rules:
        idx = np.flatnonzero(fails)
        if idx.size:
            i = int(idx[0])
            more = f" ({idx.size - 1} more blocks fail too)" if idx.size > 1 else ""
            raise ValueError(
                f"City {_block_text(i, fp[i], float(base[i]), float(h[i]))} {rule}{more}."
            )


MAX_GRID_CELLS = 10**9
"""The most cells a grid on a map may have (8 GB per float64 field)."""


def grid_shape(bounds, dx: float) -> tuple[int, int]:
    """``(ny, nx)`` of the grid of square cells of side ``dx`` (m) that covers ``bounds =
    (x_min, x_max, y_min, y_max)`` (m) from its lower-left corner.

    The one rule for every grid put on a map (:meth:`City.grid`, the flow solver's
    :func:`~windnav.flow.grid.grid_for`, sweeps, planners): ``n = ceil(extent / dx)`` per axis,
    rounded to the nearest integer when ``extent / dx`` is within 1e-9 of it (so float noise
    adds no cell), and at least 2. When the extent is not a multiple of ``dx`` the last cell
    reaches past the bound; no part of the map is left off.
    """
    dx = positive_float(dx, "dx", "grid_shape")  # 0 was a ZeroDivisionError
    x0, x1, y0, y1 = (float(b) for b in bounds)
    ny, nx = _n_cells(y1 - y0, dx), _n_cells(x1 - x0, dx)
    if ny * nx > MAX_GRID_CELLS:  # before anything allocates 8 bytes a cell, or more
        raise ValueError(f"The 'dx' parameter of grid_shape must give at most "
                         f"{MAX_GRID_CELLS:.0e} cells on the map {tuple(bounds)}. Got {dx!r} m "
                         f"instead ({ny} x {nx} cells).")
    return ny, nx


def _n_cells(length: float, dx: float) -> int:
    r = length / dx
    n = round(r)
    return max(2, int(n if abs(r - n) <= 1e-9 * max(1.0, r) else math.ceil(r)))


def _index_ranges(fp: np.ndarray, x: np.ndarray, y: np.ndarray, rule: str):
    """Per footprint, the index ranges ``[i0, i1)`` along ``x`` and ``[j0, j1)`` along ``y``
    (increasing cell centres) of the cells it makes solid under ``rule``."""
    if rule == "centre":
        return (np.searchsorted(x, fp[:, 0], side="left"),
                np.searchsorted(x, fp[:, 1], side="right"),
                np.searchsorted(y, fp[:, 2], side="left"),
                np.searchsorted(y, fp[:, 3], side="right"))
    # overlap: cell k spans [lo_k, hi_k] (midpoints between centres); solid when
    # hi_k > x_min and lo_k < x_max (positive overlap)
    xl, xh = _cell_edges(x)
    yl, yh = _cell_edges(y)
    return (np.searchsorted(xh, fp[:, 0], side="right"),
            np.searchsorted(xl, fp[:, 1], side="left"),
            np.searchsorted(yh, fp[:, 2], side="right"),
            np.searchsorted(yl, fp[:, 3], side="left"))


def _cell_edges(c: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Lower and upper edges of cells centred at increasing ``c`` (midpoints; the end cells
    symmetric about their centres)."""
    if c.size == 1:
        return c - 0.5, c + 0.5
    mid = 0.5 * (c[1:] + c[:-1])
    lo = np.concatenate([[c[0] - (mid[0] - c[0])], mid])
    hi = np.concatenate([mid, [c[-1] + (c[-1] - mid[-1])]])
    return lo, hi


def _increasing(a: np.ndarray) -> bool:
    return a.size < 2 or bool(np.all(a[1:] > a[:-1]))
