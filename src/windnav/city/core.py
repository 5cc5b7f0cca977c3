"""Building maps: axis-aligned rectangular footprints inside rectangular bounds.

A :class:`City` is a frozen value: bounds ``(x_min, x_max, y_min, y_max)`` in metres (world
frame, x east, y north) and an ``(M, 4)`` array of building footprints
``[x_min, x_max, y_min, y_max]`` with heights ``(M,)`` in metres kept for 3D export.
Overlapping footprints are allowed and form a union.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True, eq=False)
class City:
    """A 2D city map.

    Attributes
    ----------
    bounds : tuple of 4 float
        ``(x_min, x_max, y_min, y_max)`` of the map, m.
    footprints : ndarray of shape (M, 4)
        Building footprints ``[x_min, x_max, y_min, y_max]``, m.
    heights : ndarray of shape (M,)
        Building heights, m.
    """

    bounds: tuple
    footprints: np.ndarray
    heights: np.ndarray

    def __post_init__(self):
        b = tuple(float(v) for v in self.bounds)
        fp = np.array(self.footprints, dtype=np.float64).reshape(-1, 4)
        h = np.array(self.heights, dtype=np.float64).reshape(-1)
        if len(b) != 4 or not (b[0] < b[1] and b[2] < b[3]) or not np.all(np.isfinite(b)):
            raise ValueError(
                "The 'bounds' parameter of City must be finite (x_min, x_max, y_min, y_max) "
                f"with x_min < x_max and y_min < y_max. Got {self.bounds!r} instead."
            )
        if h.shape != (fp.shape[0],):
            raise ValueError(
                f"The 'heights' parameter of City must have one value per footprint "
                f"({fp.shape[0]}). Got shape {h.shape} instead."
            )
        fp.setflags(write=False)
        h.setflags(write=False)
        object.__setattr__(self, "bounds", b)
        object.__setattr__(self, "footprints", fp)
        object.__setattr__(self, "heights", h)

    @property
    def n_buildings(self) -> int:
        """Number of building footprints M."""
        return int(self.footprints.shape[0])

    def rasterize(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Solid mask on the grid of cell centres ``x`` (nx,) and ``y`` (ny,).

        A cell is solid when its centre lies inside (or on the edge of) any footprint.

        Returns
        -------
        ndarray of bool, shape (ny, nx)
        """
        x = np.asarray(x, dtype=np.float64)
        y = np.asarray(y, dtype=np.float64)
        mask = np.zeros((y.size, x.size), dtype=bool)
        for x0, x1, y0, y1 in self.footprints:
            ix = (x >= x0) & (x <= x1)
            iy = (y >= y0) & (y <= y1)
            mask |= iy[:, None] & ix[None, :]
        return mask
