"""Procedural city maps for training, planning and evaluation (thesis, map generation).

Three families, each drawn from an explicit ``numpy.random.Generator`` (or a seed), so the
same seed gives the same map:

- :func:`training_map`: 300 x 300 m or 500 x 500 m with 1-10 rectangular buildings separated
  by streets of at least 10 m (sequential rejection sampling of footprints).
- :func:`planning_map`: 600 x 600 m with 9-16 buildings whose footprints span 10-50 m on each
  side, each the union of 1-3 overlapping cuboids of different heights (a cross/L/T-shaped
  footprint with stacked towers), with alleys of at least 15 m between distinct buildings.
- :func:`dense_map`: 1.2 x 1.2 km with at least 200 buildings, one per lot of a regular lot
  grid, placed so that streets between neighbouring buildings are at least 10 m wide.

Spacing is measured between footprints (bounding boxes of a building's blocks): two buildings
are accepted when their boxes are separated by at least the street width along x or along y,
which bounds the Euclidean gap from below by the same width. Buildings also keep ``margin``
from the map edge. Sizes and heights not fixed by the thesis are parameters with documented
defaults.
"""

from __future__ import annotations

import warnings

import numpy as np

from windnav._validate import positive_float, positive_int
from windnav.city.core import City


class _Unset:
    """The default of the deprecated positional random source (``help()`` shows its repr)."""

    def __repr__(self) -> str:
        return "<none: the positional rng is deprecated, pass rng=>"


_UNSET = _Unset()


def _generator(positional, rng, where: str) -> np.random.Generator:
    """The random source of a generator: keyword ``rng`` (Generator, int seed or None for
    fresh entropy); a positional one still works, with a DeprecationWarning."""
    if positional is not _UNSET:
        warnings.warn(
            f"{where}: pass the random source as the keyword 'rng=' (positional use is "
            "deprecated).", DeprecationWarning, stacklevel=3)
        if rng is not None:
            raise ValueError(f"{where}: give the random source once, as 'rng='.")
        rng = positional
    if isinstance(rng, np.random.Generator):
        return rng
    if isinstance(rng, bool) or not (rng is None or isinstance(rng, int | np.integer)):
        raise ValueError(
            f"The 'rng' parameter of {where} must be a numpy.random.Generator, an integer "
            f"seed or None. Got {rng!r} instead."
        )
    return np.random.default_rng(rng)


def _range(value, name: str, where: str) -> tuple[float, float]:
    lo, hi = (positive_float(v, name, where) for v in value)
    if lo > hi:
        raise ValueError(f"The {name!r} parameter of {where} must be (low, high) with "
                         f"low <= high. Got {value!r} instead.")
    return lo, hi


def _place(rng, boxes: list, size: float, side: tuple, street: float, margin: float,
           tries: int = 2000) -> np.ndarray | None:
    """Rejection-sample one box ``[x0, x1, y0, y1]`` clear of ``boxes`` by ``street``.

    The largest side drawn shrinks linearly from ``side[1]`` to ``side[0]`` over the tries so a
    crowded map still admits small buildings.
    """
    lo, hi = side[0], min(side[1], size - 2.0 * margin)
    for i in range(tries):
        top = hi - (hi - lo) * i / tries
        w, d = rng.uniform(lo, top, size=2)
        x0 = rng.uniform(margin, size - margin - w)
        y0 = rng.uniform(margin, size - margin - d)
        box = np.array([x0, x0 + w, y0, y0 + d])
        if all(_clear(box, other, street) for other in boxes):
            return box
    return None


def _clear(a, b, gap: float) -> bool:
    """Whether boxes a and b are separated by at least ``gap`` along x or along y."""
    return bool(max(b[0] - a[1], a[0] - b[1]) >= gap or max(b[2] - a[3], a[2] - b[3]) >= gap)


def training_map(
    _rng=_UNSET,
    /,
    *,
    rng: np.random.Generator | int | None = None,
    size: float = 300.0,
    n_buildings: int | None = None,
    side_range: tuple = (10.0, 80.0),
    height_range: tuple = (10.0, 60.0),
    min_street: float = 10.0,
    margin: float = 10.0,
) -> City:
    """A training map: a square of ``size`` with 1-10 rectangular buildings.

    Parameters
    ----------
    rng : numpy.random.Generator or int or None, keyword-only
        Random source or seed (None: fresh entropy).
    size : float
        Side of the square map, m; the thesis uses 300 and 500.
    n_buildings : int, optional
        Number of buildings; drawn uniformly from 1-10 when omitted, whatever ``size``.
    side_range : (float, float)
        Range of footprint sides, m (the upper end shrinks if the map gets crowded).
    height_range : (float, float)
        Range of building heights, m (uniform).
    min_street : float
        Smallest street between buildings, m.
    margin : float
        Smallest distance from a building to the map edge, m.

    Returns
    -------
    City
        Bounds ``(0, size, 0, size)``, exactly ``n_buildings`` non-touching blocks.

    Raises
    ------
    ValueError
        On bad arguments, or if the buildings cannot be placed (map too small): naming
        ``n_buildings`` when it was passed, else saying how many were drawn.
    """
    where = "training_map"
    rng = _generator(_rng, rng, where)
    size = positive_float(size, "size", where)
    n = int(rng.integers(1, 11)) if n_buildings is None else positive_int(
        n_buildings, "n_buildings", where)
    boxes = _scatter(rng, n, size, _range(side_range, "side_range", where),
                     positive_float(min_street, "min_street", where),
                     positive_float(margin, "margin", where, allow_zero=True), where,
                     drawn="1-10" if n_buildings is None else None, gap="streets")
    heights = rng.uniform(*_range(height_range, "height_range", where), size=n)
    return City((0.0, size, 0.0, size), boxes, heights)


def _scatter(rng, n, size, side, street, margin, where, *, drawn: str | None = None,
             gap: str = "streets") -> np.ndarray:
    """``n`` boxes placed by :func:`_place`; ``drawn`` (e.g. ``"9-16"``) when ``n`` was drawn
    rather than passed, so a failure blames the draw and not an argument the user never gave."""
    if side[0] > size - 2 * margin:
        raise ValueError(f"The 'side_range' parameter of {where} must fit inside the map "
                         f"({size} m less 2 x {margin} m margin). Got {side!r} instead.")
    boxes: list = []
    for i in range(n):
        box = _place(rng, boxes, size, side, street, margin)
        if box is None:
            if drawn is not None:
                raise ValueError(
                    f"{where} drew {n} buildings ({drawn} when n_buildings is not given), "
                    f"which do not fit a {size:g} m map with these {gap} (>= {street:g} m) and "
                    f"margin ({margin:g} m): no room was found for building {i + 1}. Pass a "
                    f"smaller n_buildings= or a larger size.")
            raise ValueError(f"The 'n_buildings' parameter of {where} is too large: could "
                             f"place only {i} buildings on a {size} m map. Got {n} instead.")
        boxes.append(box)
    return np.array(boxes).reshape(-1, 4)


def planning_map(
    _rng=_UNSET,
    /,
    *,
    rng: np.random.Generator | int | None = None,
    size: float = 600.0,
    n_buildings: int | None = None,
    side_range: tuple = (10.0, 50.0),
    height_range: tuple = (10.0, 50.0),
    max_blocks: int = 3,
    min_alley: float = 15.0,
    margin: float = 15.0,
) -> City:
    """A planning map: 9-16 buildings stacked from overlapping cuboid blocks.

    Each building occupies a bounding box with sides drawn from ``side_range``. It is one
    block, or a cross/L/T of two blocks that span the full box along x and along y
    respectively, plus optionally a third block (a tower) overlapping the first; every block
    has its own height, so the building is a union of stacked cuboids with exactly that box.

    Parameters
    ----------
    rng : numpy.random.Generator or int or None, keyword-only
        Random source or seed (None: fresh entropy).
    size : float
        Side of the square map, m.
    n_buildings : int, optional
        Number of distinct buildings; drawn uniformly from 9-16 when omitted, whatever
        ``size`` (maps much smaller than 600 m may not hold the count drawn: pass it then).
    side_range : (float, float)
        Range of the building bounding-box sides, m.
    height_range : (float, float)
        Range of block heights, m.
    max_blocks : int
        Largest number of blocks per building (1-3).
    min_alley : float
        Smallest gap between distinct buildings, m.
    margin : float
        Smallest distance from a building to the map edge, m.

    Returns
    -------
    City
        Its :meth:`City.building_labels` has ``n_buildings`` distinct labels (its
        :attr:`City.n_buildings` counts the blocks, more).

    Raises
    ------
    ValueError
        On bad arguments, or if the buildings cannot be placed: naming ``n_buildings`` when it
        was passed, else saying how many were drawn.
    """
    where = "planning_map"
    rng = _generator(_rng, rng, where)
    size = positive_float(size, "size", where)
    n = int(rng.integers(9, 17)) if n_buildings is None else positive_int(
        n_buildings, "n_buildings", where)
    max_blocks = positive_int(max_blocks, "max_blocks", where)
    if max_blocks > 3:
        raise ValueError(f"The 'max_blocks' parameter of {where} must be 1, 2 or 3. "
                         f"Got {max_blocks!r} instead.")
    boxes = _scatter(rng, n, size, _range(side_range, "side_range", where),
                     positive_float(min_alley, "min_alley", where),
                     positive_float(margin, "margin", where, allow_zero=True), where,
                     drawn="9-16" if n_buildings is None else None, gap="alleys")
    heights_lohi = _range(height_range, "height_range", where)
    blocks = [b for box in boxes for b in _stack(rng, box, max_blocks)]
    fp = np.array(blocks).reshape(-1, 4)
    return City((0.0, size, 0.0, size), fp, rng.uniform(*heights_lohi, size=fp.shape[0]))


def _stack(rng, box, max_blocks: int) -> list:
    """Split a bounding box into 1-3 overlapping blocks whose union spans it exactly."""
    x0, x1, y0, y1 = box
    k = int(rng.integers(1, max_blocks + 1))
    if k == 1:
        return [box]
    w, d = x1 - x0, y1 - y0
    # Arm along x: full width, a band of the depth; arm along y: full depth, a band of width.
    bd = rng.uniform(0.3, 1.0) * d
    by = rng.uniform(y0, y1 - bd)
    bw = rng.uniform(0.3, 1.0) * w
    bx = rng.uniform(x0, x1 - bw)
    blocks = [np.array([x0, x1, by, by + bd]), np.array([bx, bx + bw, y0, y1])]
    if k == 3:
        # A tower inside the first arm, so it overlaps the building.
        tw, td = rng.uniform(0.2, 0.6) * w, rng.uniform(0.5, 1.0) * bd
        tx, ty = rng.uniform(x0, x1 - tw), rng.uniform(by, by + bd - td)
        blocks.append(np.array([tx, tx + tw, ty, ty + td]))
    return blocks


def dense_map(
    _rng=_UNSET,
    /,
    *,
    rng: np.random.Generator | int | None = None,
    size: float = 1200.0,
    n_buildings: int | None = None,
    lots_per_side: int = 16,
    min_side: float = 15.0,
    height_range: tuple = (10.0, 80.0),
    min_street: float = 10.0,
) -> City:
    """A dense evaluation map: ``n_buildings`` rectangular buildings on a lot grid.

    The square is cut into ``lots_per_side**2`` square lots; ``n_buildings`` lots are drawn
    without replacement and each gets one building with sides uniform in
    ``[min_side, lot - min_street]``, placed uniformly inside the lot less a border of
    ``min_street / 2``, so neighbouring buildings are at least ``min_street`` apart.

    Parameters
    ----------
    rng : numpy.random.Generator or int or None, keyword-only
        Random source or seed (None: fresh entropy).
    size : float
        Side of the square map, m.
    n_buildings : int, optional
        Number of buildings; drawn uniformly from 200 to ``lots_per_side**2`` when omitted.
    lots_per_side : int
        Lots along each side (16 gives 75 m lots on 1.2 km).
    min_side : float
        Smallest building side, m.
    height_range : (float, float)
        Range of building heights, m.
    min_street : float
        Smallest street between buildings (and to the map edge, half of it), m.

    Returns
    -------
    City
    """
    where = "dense_map"
    rng = _generator(_rng, rng, where)
    size = positive_float(size, "size", where)
    lots = positive_int(lots_per_side, "lots_per_side", where)
    street = positive_float(min_street, "min_street", where)
    min_side = positive_float(min_side, "min_side", where)
    lot = size / lots
    if min_side > lot - street:
        raise ValueError(f"The 'lots_per_side' parameter of {where} leaves lots of {lot} m, "
                         f"too small for {min_side} m buildings and {street} m streets. "
                         f"Got {lots} instead.")
    n_lots = lots * lots
    n = int(rng.integers(min(200, n_lots), n_lots + 1)) if n_buildings is None else (
        positive_int(n_buildings, "n_buildings", where))
    if n > n_lots:
        raise ValueError(f"The 'n_buildings' parameter of {where} must be at most the number "
                         f"of lots ({n_lots}). Got {n} instead.")
    chosen = np.sort(rng.choice(n_lots, size=n, replace=False))
    wd = rng.uniform(min_side, lot - street, size=(n, 2))
    free = lot - street - wd
    corner = np.column_stack([chosen % lots, chosen // lots]) * lot + street / 2
    xy0 = corner + rng.uniform(0.0, 1.0, size=(n, 2)) * free
    fp = np.column_stack([xy0[:, 0], xy0[:, 0] + wd[:, 0], xy0[:, 1], xy0[:, 1] + wd[:, 1]])
    return City((0.0, size, 0.0, size), fp,
                rng.uniform(*_range(height_range, "height_range", where), size=n))
