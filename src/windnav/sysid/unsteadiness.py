"""Flow reconstruction and unsteadiness maps: flight samples binned on an x-y grid.

The thesis (ch. 6) reconstructs the mean flow by binning the wind estimates on an x-y grid
(the mean per bin), and maps unsteadiness as the standard deviation of the lateral force
command and the mean body-rate magnitude per bin. Here:

- lateral force command: the horizontal (world x, y) part of the commanded collective thrust
  ``R e3 sum_i k_eta eta_cmd,i^2`` (N), with the attitude ``R`` at the same instant; its
  unsteadiness per bin is the total standard deviation ``sqrt(var F_x + var F_y)`` (N);
- body-rate magnitude ``|Omega|`` (rad/s), its mean per bin.

Bins are ``cell`` metres square, aligned on multiples of ``cell``; a bin with fewer than
``min_count`` samples is NaN.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from windnav._validate import positive_float, positive_int
from windnav.sysid.io import Table

__all__ = ["UNSTEADINESS_COLUMNS", "FlightSamples", "UnsteadinessMaps", "bin_xy",
           "flight_samples_from_log", "lateral_force_command", "unsteadiness_maps"]

UNSTEADINESS_COLUMNS = ("x", "y", "wind_x", "wind_y", "force_cmd_x", "force_cmd_y",
                        "body_rate_x", "body_rate_y", "body_rate_z")
"""Columns of an unsteadiness CSV: position (m), estimated wind (m/s) and lateral force
command (N), world frame; body rates (rad/s)."""


def lateral_force_command(attitude, rotor_speed_cmd, k_eta: float) -> np.ndarray:
    """Horizontal part of the commanded collective thrust, world frame.

    Parameters
    ----------
    attitude : ndarray of shape (K, 4)
        Quaternions xyzw, body to world.
    rotor_speed_cmd : ndarray of shape (K, N)
        Commanded rotor speeds, rad/s.
    k_eta : float
        Thrust coefficient, N/(rad/s)^2.

    Returns
    -------
    ndarray of shape (K, 2)
        ``[F_x, F_y]`` of ``R e3 sum_i k_eta eta_cmd,i^2``, N.
    """
    from scipy.spatial.transform import Rotation

    where = "lateral_force_command"
    k = positive_float(k_eta, "k_eta", where)
    # an IndexError, a broadcast error, an AxisError or SciPy's "Found zero norm quaternions"
    # before (Python API audit, fifty-eighth session)
    q = _array(attitude, "attitude", where, "(K, 4)", lambda a: a.ndim == 2 and a.shape[1] == 4)
    eta = _array(rotor_speed_cmd, "rotor_speed_cmd", where, f"(K, N) with K = {q.shape[0]}",
                 lambda a: a.ndim == 2 and a.shape[0] == q.shape[0] and a.shape[1] >= 1)
    if np.any(np.linalg.norm(q, axis=1) == 0):
        raise ValueError(f"The 'attitude' parameter of {where} must hold unit quaternions "
                         "(xyzw). Got a quaternion of norm 0 instead.")
    thrust = k * np.sum(eta ** 2, axis=1)
    axis = Rotation.from_quat(q).apply([0.0, 0.0, 1.0])
    return axis[:, :2] * thrust[:, None]


def _array(value, name: str, where: str, shape: str, ok, *, finite: bool = True) -> np.ndarray:
    """``value`` as float64, else a ValueError naming ``name``: not numbers, ``ok(array)``
    false (the wanted ``shape`` said), or NaN/inf entries (when ``finite``)."""
    try:
        a = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"The {name!r} parameter of {where} must be an array of numbers. Got "
                         f"{type(value).__name__} instead.") from None
    if not ok(a):
        raise ValueError(f"The {name!r} parameter of {where} must be an array of shape {shape}. "
                         f"Got shape {a.shape} instead.")
    if finite and not np.all(np.isfinite(a)):
        raise ValueError(f"The {name!r} parameter of {where} must be finite (no NaN or inf). "
                         "Got non-finite entries instead.")
    return a


@dataclass(frozen=True, eq=False)
class FlightSamples:
    """Samples along one or more flights for the maps.

    Attributes
    ----------
    xy : ndarray of shape (K, 2)
        Position, world frame, m.
    wind_xy : ndarray of shape (K, 2)
        Wind (estimate or truth), world frame, m/s.
    force_cmd_xy : ndarray of shape (K, 2)
        Lateral force command, world frame, N.
    body_rates : ndarray of shape (K, 3)
        rad/s.

    Every array is checked at construction: of these shapes with one K (K may be 0), and
    finite (``xy`` excepted: :func:`unsteadiness_maps` refuses non-finite positions);
    :meth:`from_table` and :func:`flight_samples_from_log` leave out the non-finite rows.
    """

    xy: np.ndarray
    wind_xy: np.ndarray
    force_cmd_xy: np.ndarray
    body_rates: np.ndarray

    def __post_init__(self):
        # float64, as from_table and flight_samples_from_log give them, also when built by hand
        # from float32 arrays (which binned in float32: last bits, 5e-8 relative; audit).
        # Shapes and finiteness checked: NaN winds mapped NaN bins counted as occupied, (K, 3)
        # positions and (K, 2) body rates passed, unequal lengths or 1-D positions failed in
        # NumPy (Python API audit, fifty-eighth session). Non-finite positions are left to
        # unsteadiness_maps, which names them ("must have finite positions").
        where = "FlightSamples"
        k = None
        for name, width in (("xy", 2), ("wind_xy", 2), ("force_cmd_xy", 2), ("body_rates", 3)):
            want = f"(K, {width})" + ("" if k is None else f" with K = {k}, as xy")
            a = _array(getattr(self, name), name, where, want,
                       lambda a, w=width, n=k: (a.ndim == 2 and a.shape[1] == w
                                                and (n is None or a.shape[0] == n)),
                       finite=name != "xy")
            k = a.shape[0] if k is None else k
            object.__setattr__(self, name, a)

    @classmethod
    def from_table(cls, table: Table, where: str = "FlightSamples.from_table"
                   ) -> FlightSamples:
        """From a table with :data:`UNSTEADINESS_COLUMNS` (rows with NaN are dropped)."""
        table.require(UNSTEADINESS_COLUMNS, where)
        c = table.columns
        cols = [np.column_stack([c[n] for n in names]) for names in (
            ("x", "y"), ("wind_x", "wind_y"), ("force_cmd_x", "force_cmd_y"),
            ("body_rate_x", "body_rate_y", "body_rate_z"))]
        ok = np.logical_and.reduce([np.all(np.isfinite(a), 1) for a in cols])
        return cls(*(a[ok] for a in cols))

    @staticmethod
    def concatenate(parts) -> FlightSamples:
        """The samples of ``parts`` (FlightSamples), one after another."""
        parts = list(parts)
        return FlightSamples(*(np.concatenate([getattr(p, f) for p in parts]) for f in
                               ("xy", "wind_xy", "force_cmd_xy", "body_rates")))


def flight_samples_from_log(log, k_eta: float, *, wind_xy=None) -> FlightSamples:
    """Samples of every finite vehicle of a FlightLog at its logged instants.

    Parameters
    ----------
    log : FlightLog
    k_eta : float
        Thrust coefficient of the vehicle, N/(rad/s)^2 (for the force command).
    wind_xy : ndarray of shape (T, B, 2), optional
        Wind estimates on the log's times; default the logged true wind.
    """
    from windnav.sim.log import FlightLog

    where = "flight_samples_from_log"
    if not isinstance(log, FlightLog):  # an AttributeError before (Python API audit)
        raise ValueError(f"The 'log' parameter of {where} must be a FlightLog. Got "
                         f"{type(log).__name__} instead.")
    positive_float(k_eta, "k_eta", where)
    T, B = log.position.shape[:2]
    wind = log.wind[..., :2] if wind_xy is None else _array(
        wind_xy, "wind_xy", where, str((T, B, 2)), lambda a: True, finite=False)
    if wind.shape != (T, B, 2):
        raise ValueError(f"The 'wind_xy' parameter of {where} must have shape "
                         f"{(T, B, 2)}. Got {wind.shape} instead.")
    parts = []
    for b in np.flatnonzero(np.asarray(log.finite, dtype=bool)):
        arrays = (log.position[:, b, :2], wind[:, b], log.attitude[:, b],
                  log.rotor_speed_cmd[:, b], log.body_rates[:, b])
        # the instants where every value is finite (all of them in a vehicle flagged finite,
        # unless a wind estimate is not): FlightSamples holds finite samples, as from_table
        # keeps them
        ok = np.logical_and.reduce([np.all(np.isfinite(a), 1) for a in arrays])
        xy, w, q, eta, rates = (a if ok.all() else a[ok] for a in arrays)
        parts.append(FlightSamples(xy, w, lateral_force_command(q, eta, k_eta), rates))
    if not parts:
        raise ValueError("The flight log has no vehicle that flew with finite values.")
    return FlightSamples.concatenate(parts)


def bin_xy(xy, values, x_edges, y_edges):
    """Per-bin count, mean and variance of ``values`` on an x-y grid.

    Parameters
    ----------
    xy : ndarray of shape (K, 2)
        Positions, m.
    values : ndarray of shape (K, C)
        Quantities to bin.
    x_edges, y_edges : ndarray of shape (nx + 1,), (ny + 1,)
        Bin edges, m, increasing.

    Returns
    -------
    count : ndarray of shape (ny, nx)
    mean : ndarray of shape (ny, nx, C)
        NaN in empty bins.
    var : ndarray of shape (ny, nx, C)
        Population variance, NaN in empty bins.
    """
    where = "bin_xy"
    # decreasing edges gave all-zero counts, 1-D values an IndexError, empty edges
    # "minlength must not be negative" (Python API audit, fifty-eighth session)
    xy = _array(xy, "xy", where, "(K, 2)", lambda a: a.ndim == 2 and a.shape[1] == 2,
                finite=False)
    v = _array(values, "values", where, f"(K, C) with K = {xy.shape[0]}",
               lambda a: a.ndim == 2 and a.shape[0] == xy.shape[0], finite=False)
    for name, e in (("x_edges", x_edges), ("y_edges", y_edges)):
        e = _array(e, name, where, "(n + 1,) with n >= 1", lambda a: a.ndim == 1 and a.size >= 2)
        if not np.all(np.diff(e) > 0):
            raise ValueError(f"The {name!r} parameter of {where} must increase strictly. Got "
                             f"{e.tolist()!r} instead.")
    nx, ny = len(x_edges) - 1, len(y_edges) - 1
    ix = np.searchsorted(x_edges, xy[:, 0], side="right") - 1
    iy = np.searchsorted(y_edges, xy[:, 1], side="right") - 1
    inside = (ix >= 0) & (ix < nx) & (iy >= 0) & (iy < ny)
    flat = iy[inside] * nx + ix[inside]
    v = v[inside]
    count = np.bincount(flat, minlength=nx * ny).astype(np.float64)
    with np.errstate(invalid="ignore", divide="ignore"):
        s1 = np.stack([np.bincount(flat, v[:, c], nx * ny) for c in range(v.shape[1])], 1)
        mean = s1 / count[:, None]
        dev = v - mean[flat]
        var = np.stack([np.bincount(flat, dev[:, c] ** 2, nx * ny)
                        for c in range(v.shape[1])], 1) / count[:, None]
    return (count.reshape(ny, nx), mean.reshape(ny, nx, -1), var.reshape(ny, nx, -1))


@dataclass(frozen=True, eq=False)
class UnsteadinessMaps:
    """Binned mean flow and unsteadiness.

    Attributes
    ----------
    x_edges, y_edges : ndarray
        Bin edges, m.
    count : ndarray of shape (ny, nx)
        Samples per bin.
    wind_mean : ndarray of shape (ny, nx, 2)
        Mean wind per bin, world frame, m/s (NaN below ``min_count``).
    force_cmd_std : ndarray of shape (ny, nx)
        ``sqrt(var F_x + var F_y)`` of the lateral force command, N (NaN in bins of fewer
        than two samples, whose spread is undefined, as below ``min_count``).
    body_rate_mean : ndarray of shape (ny, nx)
        Mean ``|Omega|``, rad/s.
    min_count : int
        The least samples of a mapped bin (fewer: NaN).
    """

    x_edges: np.ndarray
    y_edges: np.ndarray
    count: np.ndarray
    wind_mean: np.ndarray
    force_cmd_std: np.ndarray
    body_rate_mean: np.ndarray
    min_count: int = 1

    @property
    def centres(self) -> tuple[np.ndarray, np.ndarray]:
        """Bin centres ``(x (nx,), y (ny,))``, m."""
        return (0.5 * (self.x_edges[1:] + self.x_edges[:-1]),
                0.5 * (self.y_edges[1:] + self.y_edges[:-1]))

    def to_dict(self) -> dict:
        """JSON payload (arrays as nested lists, NaN as null by the writer)."""
        occupied = self.count >= self.min_count  # blanked bins counted before (audit)
        return {
            "x_edges_m": self.x_edges, "y_edges_m": self.y_edges, "count": self.count,
            "wind_mean_x_m_s": self.wind_mean[..., 0], "wind_mean_y_m_s": self.wind_mean[..., 1],
            "force_cmd_std_N": self.force_cmd_std, "body_rate_mean_rad_s": self.body_rate_mean,
            "occupied_bins": int(occupied.sum()),
            "force_cmd_std_N_max": float(np.nanmax(self.force_cmd_std))
            if np.isfinite(self.force_cmd_std).any() else None,
            "body_rate_mean_rad_s_max": float(np.nanmax(self.body_rate_mean))
            if np.isfinite(self.body_rate_mean).any() else None,
        }


MAX_CELLS = 10**8
"""The most cells :func:`unsteadiness_maps` may bin into."""


def unsteadiness_maps(samples: FlightSamples, *, cell: float = 1.0,
                      min_count: int = 1) -> UnsteadinessMaps:
    """Bin ``samples`` on a grid of ``cell``-metre squares covering them.

    Parameters
    ----------
    samples : FlightSamples
    cell : float
        Bin size, m.
    min_count : int
        Bins with fewer samples are NaN.
    """
    where = "unsteadiness_maps"
    cell = positive_float(cell, "cell", where)
    min_count = positive_int(min_count, "min_count", where)
    if samples.xy.shape[0] == 0:
        raise ValueError(f"The 'samples' parameter of {where} holds no finite sample.")
    if not np.all(np.isfinite(samples.xy)):  # "arange: cannot compute length" before
        raise ValueError(f"The 'samples' parameter of {where} must have finite positions. Got "
                         "NaN or inf in xy instead.")
    # whole cells from a multiple of `cell`, enough that every sample lies in a half-open
    # bin: a sample on a multiple of a cell not exact in binary (55.2 m, cell 0.2) fell on
    # or past the last edge and out of every bin (reference audit, 2026-12-05)
    xy_min, xy_max = samples.xy.min(axis=0), samples.xy.max(axis=0)
    lo = np.floor(xy_min / cell) * cell
    lo = np.where(lo > xy_min, lo - cell, lo)
    n = np.floor((xy_max - lo) / cell) + 1
    n = n + (lo + n * cell <= xy_max)
    hi = lo + n * cell
    n_cells = float(np.prod(n))
    if n_cells > MAX_CELLS:  # a 1e-6 m cell tried to allocate 7.5 TiB
        raise ValueError(f"The 'cell' parameter of {where} must give at most {MAX_CELLS:.0e} "
                         f"cells over the samples' extent {(hi - lo).tolist()} m. Got {cell!r} "
                         f"instead ({n_cells:.3g} cells).")
    x_edges = lo[0] + cell * np.arange(int(n[0]) + 1)
    y_edges = lo[1] + cell * np.arange(int(n[1]) + 1)
    rate = np.linalg.norm(samples.body_rates, axis=1)
    values = np.column_stack([samples.wind_xy, samples.force_cmd_xy, rate])
    count, mean, var = bin_xy(samples.xy, values, x_edges, y_edges)
    empty = count < min_count
    if empty.all():  # every bin blanked: maps of NaN, NumPy's warnings, status 0 (audit)
        raise ValueError(f"The 'min_count' parameter of {where} must be met by at least one "
                         f"bin: no {cell:g} m bin holds {min_count} of the "
                         f"{samples.xy.shape[0]} samples (the fullest holds "
                         f"{int(count.max())}); lower it, or enlarge the bins.")
    mean[empty] = np.nan
    var[empty] = np.nan
    # one sample has no spread: its population variance, 0, read as a perfectly steady bin
    # (44 of 47 bins at min_count=1 in an audit)
    var[count < 2] = np.nan
    return UnsteadinessMaps(x_edges, y_edges, count, mean[..., :2],
                            np.sqrt(var[..., 2] + var[..., 3]), mean[..., 4], min_count)

