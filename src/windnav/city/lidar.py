"""Planar (2D) LiDAR ray casting against the building footprints of a :class:`City`.

Ray k from origin ``o`` points along ``d_k = (cos a_k, sin a_k)``, ``a_k = 2 pi k / n_rays``
(counter-clockwise from +x); rays along the axes (``4 k`` divisible by ``n_rays``) use exact
directions ``(+-1, 0)``/``(0, +-1)``. The range is the first hit with a footprint, found with
the slab method (Kay & Kajiya 1986): with ``t_x = ([x_min, x_max] - o_x) / d_x`` and likewise
``t_y``,

    t_near = max(min t_x, min t_y),   t_far = min(max t_x, max t_y)
    hit iff t_near <= t_far and t_far >= 0;   range = t_near,

a ray parallel to a slab hitting only when its origin lies within it. Footprints are closed,
so a ray grazing an edge or corner hits it. The map bounds are not walls.

Broad phase (per origin): only buildings closer than ``max_range`` are kept, and each is cast
against only the rays inside its angular extent seen from the origin (padded by one ray on
each side), so the cost is ``O(M + n_rays + rays that meet nearby buildings)`` per scan.

Readings: ``max_range`` where no building is hit within range; returns get Gaussian noise of
standard deviation ``noise_std``, then every reading is clipped to ``[min_range, max_range]``.
An origin inside or on the edge of a footprint is blocked: all its rays read ``min_range``.
"""

from __future__ import annotations

import functools
import math

import numpy as np

from windnav._jit import njit
from windnav._validate import (
    batch_array,
    generator,
    keyword_only,
    positive_float,
    positive_int,
)

_WHERE = "City.lidar"
_ONE_PASS = 4096
"""Above this many ranges, the clip to ``[min_range, max_range]`` is ``np.clip``'s one pass
(10,000 scans: 346 k against 323 k scans/s); below, two ufuncs without its wrapper's cost (one
scan, the onboard stack's: 204 -> 190 us a step). The same values either way."""


def ray_directions(n_rays: int) -> np.ndarray:
    """Unit directions of the rays, exact along the axes.

    Parameters
    ----------
    n_rays : int
        Number of rays, >= 1.

    Returns
    -------
    ndarray of shape (n_rays, 2)
        ``(cos a_k, sin a_k)`` with ``a_k = 2 pi k / n_rays``.
    """
    n_rays = positive_int(n_rays, "n_rays", "ray_directions")
    k = np.arange(n_rays)
    a = 2.0 * np.pi * k / n_rays
    d = np.stack([np.cos(a), np.sin(a)], axis=1)
    axis = (4 * k) % n_rays == 0
    quarter = (4 * k[axis]) // n_rays
    d[axis] = np.array([[1.0, 0.0], [0.0, 1.0], [-1.0, 0.0], [0.0, -1.0]])[quarter % 4]
    return d


@functools.lru_cache(maxsize=8)
def _ray_components(n_rays: int) -> tuple[np.ndarray, np.ndarray]:
    """The x and y components of :func:`ray_directions` as contiguous read-only arrays, made
    once per ray count (a scan at 10 Hz would otherwise rebuild them every time)."""
    d = ray_directions(n_rays)
    cos_a, sin_a = d[:, 0].copy(), d[:, 1].copy()
    cos_a.flags.writeable = sin_a.flags.writeable = False
    return cos_a, sin_a


def lidar_scan(
    city,
    origins_xy,
    n_rays: int = 360,
    max_range: float = 100.0,
    min_range: float = 0.0,
    noise_std: float = 0.0,
    *args,
    rng=None,
    normals=None,
) -> np.ndarray:
    """Planar LiDAR scans of ``city`` from a batch of origins.

    Parameters
    ----------
    city : City
        The map; only its footprints are obstacles.
    origins_xy : array_like of shape (B, 2) or (2,)
        Sensor positions in the world frame, m. A single origin gives a batch of one.
    n_rays : int
        Rays per scan, >= 1; ray k points at angle ``2 pi k / n_rays`` from +x.
    max_range : float
        Largest reading, m, > ``min_range``; returned where nothing is hit.
    min_range : float
        Smallest reading, m, >= 0.
    noise_std : float
        Standard deviation of the Gaussian range noise on returns, m, >= 0.
    rng : numpy.random.Generator or int, optional, keyword-only (positional: deprecated)
        Noise source (or its seed); required when ``noise_std > 0`` and ``normals`` is None.
    normals : array_like of shape (B, n_rays), optional
        The standard normals of the range noise, drawn by the caller (as
        ``rng.standard_normal(size=(B, n_rays))`` would draw them here; used instead of
        ``rng``): the scan a caller computes later than its noise was drawn, the same scan.

    Returns
    -------
    ndarray of shape (B, n_rays)
        Ranges, m, in ``[min_range, max_range]``. Rays that hit nothing read ``max_range``
        exactly (no noise); origins inside or on the edge of a building read ``min_range``
        on every ray.

    Raises
    ------
    ValueError
        Naming the argument: NaN/inf or wrongly shaped origins, ``n_rays < 1``,
        ``max_range <= min_range``, negative ``noise_std``, noise without ``rng`` or
        ``normals``, or ``normals`` not finite or of another shape.
    """
    kw = keyword_only(args, {"rng": rng, "normals": normals}, "lidar_scan")
    rng, normals = kw["rng"], kw["normals"]
    origins = batch_array(origins_xy, "origins_xy", _WHERE, (2,))
    n_rays = positive_int(n_rays, "n_rays", _WHERE)
    max_range = positive_float(max_range, "max_range", _WHERE)
    min_range = positive_float(min_range, "min_range", _WHERE, allow_zero=True)
    if max_range <= min_range:
        raise ValueError(
            f"The 'max_range' parameter of {_WHERE} must be greater than min_range "
            f"({min_range!r}). Got {max_range!r} instead."
        )
    noise_std = positive_float(noise_std, "noise_std", _WHERE, allow_zero=True)
    if normals is not None:
        normals = np.asarray(normals, dtype=np.float64)
        if normals.shape != (origins.shape[0], n_rays) or not np.isfinite(normals).all():
            raise ValueError(
                f"The 'normals' parameter of {_WHERE} must be a finite array of shape "
                f"({origins.shape[0]}, {n_rays}). Got shape {normals.shape} instead."
            )
    elif noise_std > 0.0:
        if rng is None:
            raise ValueError(
                f"The 'rng' parameter of {_WHERE} must be a numpy.random.Generator or a seed "
                "when noise_std > 0. Got None instead."
            )
        rng = generator(rng, "rng", _WHERE)

    cos_a, sin_a = _ray_components(n_rays)
    ranges = np.empty((origins.shape[0], n_rays))
    hit = np.empty((origins.shape[0], n_rays), dtype=np.bool_)
    blocked = np.empty(origins.shape[0], dtype=np.bool_)
    _scan(np.ascontiguousarray(origins), np.ascontiguousarray(city.footprints),
          cos_a, sin_a, max_range, ranges, hit, blocked)
    if noise_std > 0.0:
        noise = (rng.standard_normal(size=ranges.shape) if normals is None
                 else normals.copy())
        noise *= noise_std
        noise *= hit  # rays without a return keep max_range exactly
        ranges += noise
    if ranges.size > _ONE_PASS:  # a batch: np.clip's one pass (two cost 7 % of the scans/s)
        np.clip(ranges, min_range, max_range, out=ranges)
    else:  # np.clip's values (bounds > 0: no signed-zero tie), without its wrapper's cost
        np.minimum(np.maximum(ranges, min_range, out=ranges), max_range, out=ranges)
    ranges[blocked] = min_range
    return ranges


@njit(cache=True)
def _slab(ox, oy, c, s, x0, x1, y0, y1):
    """Distance along the unit ray to the closed box, or inf when missed."""
    if c == 0.0:
        if ox < x0 or ox > x1:
            return np.inf
        tx0, tx1 = -np.inf, np.inf
    else:
        ta = (x0 - ox) / c
        tb = (x1 - ox) / c
        tx0, tx1 = min(ta, tb), max(ta, tb)
    if s == 0.0:
        if oy < y0 or oy > y1:
            return np.inf
        ty0, ty1 = -np.inf, np.inf
    else:
        ta = (y0 - oy) / s
        tb = (y1 - oy) / s
        ty0, ty1 = min(ta, tb), max(ta, tb)
    t_near = max(tx0, ty0)
    t_far = min(tx1, ty1)
    if t_near > t_far or t_far < 0.0:
        return np.inf
    return max(t_near, 0.0)


@njit(cache=True)
def _wrap(a):
    """Angle wrapped into [-pi, pi)."""
    return (a + math.pi) % (2.0 * math.pi) - math.pi


@njit(cache=True, nogil=True)
def _scan(origins, rects, cos_k, sin_k, max_range, ranges, hit, blocked):
    """Fill ``ranges`` (B, n) with first-hit distances (``max_range`` if none) and flags."""
    n = cos_k.shape[0]
    m = rects.shape[0]
    dtheta = 2.0 * math.pi / n
    near = np.empty(m, dtype=np.int64)
    r2 = max_range * max_range
    for b in range(origins.shape[0]):
        ox = origins[b, 0]
        oy = origins[b, 1]
        for k in range(n):
            ranges[b, k] = max_range
            hit[b, k] = False
        blocked[b] = False
        n_near = 0
        for j in range(m):
            ex = max(rects[j, 0] - ox, 0.0, ox - rects[j, 1])
            ey = max(rects[j, 2] - oy, 0.0, oy - rects[j, 3])
            e2 = ex * ex + ey * ey
            if e2 == 0.0:
                blocked[b] = True
                break
            if e2 <= r2:
                near[n_near] = j
                n_near += 1
        if blocked[b]:
            continue
        for i in range(n_near):
            j = near[i]
            x0, x1, y0, y1 = rects[j, 0], rects[j, 1], rects[j, 2], rects[j, 3]
            # Angular extent of the box seen from outside it (< pi), relative to its centre.
            ac = math.atan2(0.5 * (y0 + y1) - oy, 0.5 * (x0 + x1) - ox)
            lo = 0.0
            hi = 0.0
            for px, py in ((x0, y0), (x1, y0), (x0, y1), (x1, y1)):
                da = _wrap(math.atan2(py - oy, px - ox) - ac)
                lo = min(lo, da)
                hi = max(hi, da)
            k_lo = int(math.floor((ac + lo) / dtheta)) - 1
            k_hi = int(math.ceil((ac + hi) / dtheta)) + 1
            for q in range(min(k_hi - k_lo + 1, n)):
                k = (k_lo + q) % n
                t = _slab(ox, oy, cos_k[k], sin_k[k], x0, x1, y0, y1)
                if t < ranges[b, k]:
                    ranges[b, k] = t
                    hit[b, k] = True
