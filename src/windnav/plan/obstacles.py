"""Obstacles for the planner: LiDAR points, a nearest-point field, and the obstacle cost.

The obstacle cost of a trajectory ``p_1 .. p_K`` (positions relative to the start of the
planning period, m) against the LiDAR points ``o_1 .. o_P`` is, non-dimensionalised by the
LiDAR range ``D_max`` (Folk 2026, ch. 5; the thesis prints "min", a typo)::

    J_obs = max_k max_o 1 / |p_k / D_max - o / D_max|^2 = (D_max / d_min)^2,
    d_min = min_k min_o |p_k - o|.

Brute force costs ``K P`` distances per trajectory. :class:`ObstacleField` precomputes, once
per scan, the exact nearest point (and its distance) at every node of a grid (spacing ``h``)
covering the points and the origin (the vehicle) plus a margin, with the lower-envelope
distance transform of Felzenszwalb & Huttenlocher (2012) in ``O(n_x (P + n_y))``, and sorts the
points into buckets of side ``B``. Then, per trajectory:

1. at every step, the nearest node ``n`` bounds the distance for two lookups,
   ``d(n) - |p - n| <= d(p) <= |p - o_n|`` (``d`` is 1-Lipschitz; ``o_n``, ``n``'s nearest
   point, is usually ``p``'s too); outside the grid, the distance to the points' bounding box
   is the lower bound;
2. only the steps whose lower bound is below the best distance so far are examined further:
   first the tighter bound of the four surrounding nodes, then an exact search among the
   points in the buckets within that distance (all points when that is most of them).

The result is the exact ``d_min``: brute force's number, to rounding (tests/test_plan_obstacles
checks it on city scans), at the cost of about two lookups per step and one or two exact
searches per trajectory.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from windnav._validate import positive_float
from windnav.city.lidar import ray_directions
from windnav.plan import _kernels as K

__all__ = ["ObstacleField", "obstacle_cost", "obstacle_field", "scan_points"]


def scan_points(ranges, *, max_range: float | None = None) -> np.ndarray:
    """LiDAR returns as points relative to the sensor, world-aligned, m.

    Parameters
    ----------
    ranges : array_like of shape (n_rays,)
        One scan of :meth:`windnav.city.City.lidar`: ray ``k`` points at ``2 pi k / n_rays``
        from +x.
    max_range : float, optional
        Readings at or beyond it are "no return" and dropped; default the largest reading.

    Returns
    -------
    ndarray of shape (P, 2)
        The returns, m. Non-finite readings are dropped.

    Raises
    ------
    ValueError
        On a reading below 0 (it would put an obstacle on the opposite side).
    """
    r = np.asarray(ranges, dtype=np.float64)
    if r.ndim != 1 or r.size < 1:
        raise ValueError("The 'ranges' parameter of scan_points must be a 1-D array of "
                         f"n_rays >= 1 readings. Got shape {r.shape} instead.")
    if (r < 0).any():
        raise ValueError("The 'ranges' parameter of scan_points must be >= 0 (distances, m). "
                         f"Got {np.nanmin(r)!r} instead.")
    top = np.nanmax(r) if max_range is None else positive_float(max_range, "max_range",
                                                                 "scan_points")
    return returns(r, top)


def returns(r: np.ndarray, top: float) -> np.ndarray:
    """:func:`scan_points` of ranges ``r`` (n_rays,) float64 already checked (1-D, none below
    0) and ``top`` > 0: the planner, which checks them under its own name, calls this."""
    keep = np.isfinite(r) & (r < top)
    return _directions(r.size)[keep] * r[keep, None]


@lru_cache(maxsize=8)
def _directions(n_rays: int) -> np.ndarray:
    d = ray_directions(n_rays)
    d.setflags(write=False)
    return d


@dataclass(frozen=True, eq=False)
class ObstacleField:
    """Distance field of a set of obstacle points (see the module docstring).

    Build it with :func:`obstacle_field`.

    Attributes
    ----------
    sites : ndarray of shape (P, 2)
        The obstacle points, m (relative to the planning origin).
    nodes : ndarray of shape (ny, nx, 3)
        Per node ``(x0 + i h, y0 + j h)``: the exact distance to the nearest point (m) and that
        point's x and y (interleaved for the kernels).
    node_nearest : ndarray of shape (ny, nx) of int64
        Index into ``sites`` of that point.
    meta : ndarray of shape (8,)
        ``[x0, y0, 1 / h, h, bbox x_min, x_max, y_min, y_max]`` (bounding box of the sites).
    bucket_order : ndarray of shape (P,) of int64
        The sites sorted by bucket (row-major, side ``B``) for the exact searches.
    bucket_start : ndarray of shape (nbx nby + 1,) of int64
        Bucket ``b`` holds ``sites[bucket_order[bucket_start[b]:bucket_start[b + 1]]]``.
    bucket_meta : ndarray of shape (5,)
        ``[x0, y0, 1 / B, nbx, nby]``.
    sorted_x, sorted_y : ndarray of shape (P,)
        ``sites[bucket_order]``, by coordinate.
    """

    sites: np.ndarray
    nodes: np.ndarray
    node_nearest: np.ndarray
    meta: np.ndarray
    bucket_order: np.ndarray
    bucket_start: np.ndarray
    bucket_meta: np.ndarray
    sorted_x: np.ndarray
    sorted_y: np.ndarray

    @property
    def empty(self) -> bool:
        """True when there are no points (no obstacle cost)."""
        return self.sites.shape[0] == 0

    @property
    def resolution(self) -> float:
        """Node spacing ``h``, m."""
        return float(self.meta[3])

    @property
    def node_distance(self) -> np.ndarray:
        """Exact distance from each node to the nearest point, (ny, nx), m."""
        return self.nodes[..., 0]

    def kernel_args(self) -> tuple:
        """The arrays the kernels take, in order: ``node, fmeta, sx, sy, bstart, bmeta``."""
        return (self.nodes, self.meta, self.sorted_x, self.sorted_y, self.bucket_start,
                self.bucket_meta)

    def distance(self, points) -> np.ndarray:
        """Distance from each point (M, 2) (m) to the nearest obstacle point, m (inf if none).

        Raises
        ------
        ValueError
            On ``points`` whose last axis is not 2, or with NaN or inf.
        """
        q = _finite_xy(points, "points", "ObstacleField.distance", "(M, 2)")
        return self._distance(q.reshape(-1, 2))

    def _distance(self, points: np.ndarray) -> np.ndarray:
        """:meth:`distance` of points (M, 2) float64 already checked."""
        q = np.ascontiguousarray(points)
        if self.empty:
            return np.full(q.shape[0], np.inf)
        out = np.empty(q.shape[0])
        K.field_distance(q, *self.kernel_args(), out)
        return out

    def cost(self, positions, lidar_range: float) -> np.ndarray:
        """``J_obs = (D_max / d_min)^2`` of trajectories ``positions`` (S, K, 2), m.

        Raises
        ------
        ValueError
            On ``positions`` not of shape (S, K, 2) with K >= 1 or with NaN or inf, or a
            ``lidar_range`` that is not a finite number > 0.
        """
        where = "ObstacleField.cost"
        pos = _trajectories(positions, where)
        lidar_range = positive_float(lidar_range, "lidar_range", where)
        if self.empty:
            return np.zeros(pos.shape[0])
        d = self._distance(pos.reshape(-1, 2)).reshape(pos.shape[:-1]).min(axis=1)
        return lidar_range**2 / np.maximum(d * d, K._MIN_D2)


def _finite_xy(values, name: str, where: str, shape: str) -> np.ndarray:
    """``values`` as float64 with a last axis of 2 and finite entries, else a ValueError naming
    ``name`` (a last axis of 3 was reshaped into other points, NaN read as no obstacle: inf;
    closure-module audit)."""
    try:
        a = np.asarray(values, dtype=np.float64)
    except (TypeError, ValueError):
        a = None
    if a is not None and a.size == 0 and (a.ndim < 1 or a.shape[-1] != 2):
        a = a.reshape(0, 2)  # none, as obstacle_field takes them
    if a is None or a.ndim < 1 or a.shape[-1] != 2:
        raise ValueError(f"The {name!r} parameter of {where} must be an array of shape {shape}, "
                         f"m. Got shape {np.shape(values)} instead.")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"The {name!r} parameter of {where} must be finite (no NaN or inf). "
                         "Got non-finite entries instead.")
    return a


def _trajectories(positions, where: str) -> np.ndarray:
    """``positions`` checked as finite trajectories (S, K, 2), K >= 1, float64."""
    pos = _finite_xy(positions, "positions", where, "(S, K, 2) with K >= 1")
    if pos.ndim != 3 or pos.shape[1] < 1:  # (K, 2) was an AxisError, K = 0 a reduction error
        raise ValueError(f"The 'positions' parameter of {where} must be an array of shape "
                         f"(S, K, 2) with K >= 1, m. Got shape {pos.shape} instead.")
    return pos


MAX_NODES = 2 * 10**7
"""The most nodes (and buckets) of an obstacle field: 480 MB of node data."""


def obstacle_field(points, *, resolution: float = 1.0, padding: float = 10.0,
                   bucket: float = 2.0) -> ObstacleField:
    """Build the distance field of ``points`` (P, 2) (m) on nodes ``resolution`` m apart.

    Parameters
    ----------
    points : array_like of shape (P, 2)
        Obstacle points, m; P may be 0. Must be finite.
    resolution : float
        Node spacing ``h``, m.
    padding : float
        Margin of the node grid around the points' bounding box, m.
    bucket : float
        Side of the buckets of the exact searches, m.

    Returns
    -------
    ObstacleField
    """
    where = "obstacle_field"
    h = positive_float(resolution, "resolution", where)
    pad = positive_float(padding, "padding", where, allow_zero=True)
    b = positive_float(bucket, "bucket", where)
    pts = np.asarray(points, dtype=np.float64)
    if pts.size == 0:
        pts = pts.reshape(0, 2)
    if pts.ndim != 2 or pts.shape[1] != 2:
        raise ValueError(f"The 'points' parameter of {where} must be an array of shape (P, 2). "
                         f"Got shape {pts.shape} instead.")
    if not np.all(np.isfinite(pts)):
        raise ValueError(f"The 'points' parameter of {where} must be finite (no NaN or inf). "
                         "Got non-finite entries instead.")
    pts = np.ascontiguousarray(pts)
    if pts.shape[0] == 0:
        return ObstacleField(pts, np.zeros((1, 1, 3)), np.zeros((1, 1), np.int64),
                             np.array([0, 0, 1 / h, h, 0, 0, 0, 0.0]), np.zeros(0, np.int64),
                             np.zeros(2, np.int64), np.array([0, 0, 1 / b, 1, 1.0]),
                             np.zeros(0), np.zeros(0))
    r = float(np.abs(pts).max())  # one cheap bound first: the planner calls this every update
    side = MAX_NODES ** 0.5
    if 2.0 * (r + pad) / h + 2.0 > side or 2.0 * r / b + 1.0 > side:
        _check_field_size(pts, h, pad, b, where)  # a point at 1e7 m took 5 GB
    return ObstacleField(pts, *K.build_field(pts, h, pad, b))


def _check_field_size(pts, h: float, pad: float, b: float, where: str) -> None:
    """A ValueError when the field of ``pts`` would hold more than :data:`MAX_NODES` nodes or
    buckets (the extents of :func:`windnav.plan._kernels.build_field`)."""
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    with np.errstate(over="ignore"):  # inf counts are refused like any other too many
        span = np.maximum(hi, 0.0) - np.minimum(lo, 0.0) + 2.0 * pad  # the nodes' extent, m
        nodes = float(np.prod(span / h + 2.0))
        buckets = float(np.prod((hi - lo) / b + 1.0))
    if not nodes <= MAX_NODES or not buckets <= MAX_NODES:
        raise ValueError(f"The 'points' parameter of {where} must span, with the origin and the "
                         f"padding, at most {MAX_NODES:.0e} nodes of 'resolution' and buckets "
                         f"of 'bucket'. Got {span.tolist()} m at resolution {h:g} m and bucket "
                         f"{b:g} m instead ({nodes:.3g} nodes, {buckets:.3g} buckets).")


def obstacle_cost(positions, points, lidar_range: float) -> np.ndarray:
    """Brute-force ``J_obs = max_k max_o (D_max / |p_k - o|)^2`` (the reference), per trajectory.

    Parameters
    ----------
    positions : array_like of shape (S, K, 2)
        Trajectories, m.
    points : array_like of shape (P, 2)
        Obstacle points, m.
    lidar_range : float
        ``D_max``, m.

    Returns
    -------
    ndarray of shape (S,)
        0 where there are no points.

    Raises
    ------
    ValueError
        On ``positions`` not of shape (S, K, 2) with K >= 1, ``points`` not of shape (P, 2)
        (P may be 0), either with NaN or inf, or a ``lidar_range`` that is not a finite
        number > 0.
    """
    where = "obstacle_cost"
    pos = _trajectories(positions, where)
    pts = _finite_xy(points, "points", where, "(P, 2)")
    if pts.ndim != 2:  # (P, 3) points were reshaped into other 2-D points
        raise ValueError(f"The 'points' parameter of {where} must be an array of shape (P, 2), "
                         f"m. Got shape {pts.shape} instead.")
    lidar_range = positive_float(lidar_range, "lidar_range", where)  # -100 gave 100's cost
    if pts.shape[0] == 0:
        return np.zeros(pos.shape[0])
    d2 = np.full(pos.shape[:-1], np.inf)
    for o in pts:  # one point at a time: memory stays (S, K)
        np.minimum(d2, np.sum((pos - o) ** 2, axis=-1), out=d2)
    return lidar_range**2 / np.maximum(d2.min(axis=1), K._MIN_D2)
