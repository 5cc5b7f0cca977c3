"""Run the Wind UKF over a recorded flight: sensor alignment, filter loop, accuracy metric.

:func:`run_wind_ukf` is a pure function of a :class:`~windnav.sim.FlightLog` (or any object
with the same fields) and the parameters the filter *believes* (e.g. calibrated ones; the
simulated vehicle's true parameters may differ). The filter steps on the time grid of the
sensors it uses, ``t_k``; step ``k`` predicts from ``t_{k-1}`` to ``t_k`` with the rotor-speed
command held over that interval, ``u_k = clip(cmd(t_{k-1}), eta_min, eta_max)``, then fuses the
measurements stamped ``t_k``:

    accel, gyro     IMU sample at t_k (body axes)
    odom            (v_world, psi, theta, phi): odometry velocity and the ZYX Euler angles of its
                    attitude quaternion at t_k
    rotor_speeds    the command held over (t_{k-1}, t_k] as a pseudo-measurement of eta(t_k)
                    (the thesis uses commanded speeds this way)

The state starts at ``t_0`` from the first odometry sample (attitude, body velocity
``R^T v_world``), the first command for the rotor speeds and zero wind (prior std 3 m/s).

Accuracy metric (:meth:`WindTrack.rmse_after`): the root mean square over the samples with
``t - t_0 >= settle_s`` of the 3D error norm ``|w_hat(t_k) - w(t_k)|``, where ``w`` is the true
world-frame wind at the centre of mass logged by the simulator. Samples where the filter did
not run (a non-finite estimate), and those between the samples of a log sparser than the
filter's grid (``log_every`` > 1: no true wind there, NaN), are left out of it, of the mean
error and of the NEES alike.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable, Mapping
from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from windnav._console import progress_bar
from windnav._validate import finite_float, positive_int
from windnav.estimate import wind_model as wm
from windnav.estimate.conditions import UKFConditions, ukf_conditions
from windnav.estimate.hardware import OdometryAccel
from windnav.estimate.layout import (
    IDX_EULER,
    IDX_ROTORS,
    IDX_VELOCITY,
    N_BASE,
    ODOM_EULER,
    ODOM_VELOCITY,
)
from windnav.estimate.ukf import FilterDivergedError
from windnav.estimate.wind_ukf import WindUKF
from windnav.vehicle.params import MultirotorParams

__all__ = ["WindTrack", "filter_inputs", "run_wind_ukf"]

_SENSORS = ("imu", "odometry", "rotor_speeds")


@dataclass(frozen=True)
class WindTrack:
    """The Wind UKF's estimate along a flight, with the truth to score it.

    Fields are readable as attributes or as ``track["wind_est"]``.

    Attributes
    ----------
    t : ndarray of shape (T,)
        Filter times, s.
    wind_est : ndarray of shape (T, 3)
        Estimated wind, world frame, m/s.
    wind_cov : ndarray of shape (T, 3, 3)
        Its covariance, (m/s)^2.
    wind_true : ndarray of shape (T, 3)
        True wind at the centre of mass, world frame, m/s (NaN at grid times the log does not
        hold, ``log_every`` > 1).
    x : ndarray of shape (T, 12 + N)
        Filter state at each step.
    repairs : int
        Covariance repairs the filter needed (0 for a healthy run).
    """

    t: np.ndarray
    wind_est: np.ndarray
    wind_cov: np.ndarray
    wind_true: np.ndarray
    x: np.ndarray
    repairs: int = 0

    def __getitem__(self, key: str):
        return getattr(self, key)

    @property
    def error(self) -> np.ndarray:
        """Estimation error ``wind_est - wind_true`` (T, 3), m/s."""
        return self.wind_est - self.wind_true

    def rmse_after(self, settle_s: float = 2.0, axis: int | None = None) -> float:
        """RMS of the 3D wind error (or of one axis) over ``t - t_0 >= settle_s``, m/s.

        Samples where the filter did not run (a non-finite estimate) are left out, as by
        :meth:`mean_error_after` and :meth:`nees`: for the 3D error a sample with any
        non-finite component, for one axis a sample whose component on that axis is not
        finite. When none is left the result is NaN, with a RuntimeWarning saying so.

        Parameters
        ----------
        settle_s : float
            Settling time excluded from the start, s.
        axis : int, optional
            0, 1 or 2 for the RMS error of one world axis; None for the 3D error norm.
        """
        where = "WindTrack.rmse_after"
        e = self.error[self._settled(settle_s, where)]
        sq = np.sum(e**2, axis=1) if axis is None else e[:, axis] ** 2
        return float(np.sqrt(_mean_of_finite(sq, where, settle_s)))

    def mean_error_after(self, settle_s: float = 2.0) -> np.ndarray:
        """Mean wind error per world axis over ``t - t_0 >= settle_s`` (its bias), m/s, (3,).

        Samples where the filter did not run (a non-finite estimate) are left out of each
        axis's mean, as by :meth:`rmse_after` and :meth:`nees`; an axis with none left is NaN,
        with a RuntimeWarning saying so.
        """
        where = "WindTrack.mean_error_after"
        return _mean_of_finite(self.error[self._settled(settle_s, where)], where, settle_s)

    def _settled(self, settle_s, where: str) -> np.ndarray:
        """The samples at ``t - t_0 >= settle_s`` (bool mask), at least one, else a
        ValueError naming ``where``."""
        settle_s = finite_float(settle_s, "settle_s", where)
        keep = self.t - self.t[0] >= settle_s
        if not np.any(keep):
            raise ValueError(f"The 'settle_s' parameter of {where} must be below "
                             f"the track length {self.t[-1] - self.t[0]:.3f} s. "
                             f"Got {settle_s!r} instead.")
        return keep

    def nees(self, settle_s: float = 2.0) -> float:
        """Mean normalised estimation error squared ``e^T C^-1 e`` after ``settle_s`` (3 when
        the reported covariance is consistent).

        Samples where the filter did not run (a non-finite estimate or covariance) are left
        out, as by :meth:`rmse_after` and :meth:`mean_error_after`; when none is left the
        result is NaN, with a RuntimeWarning saying so.
        """
        where = "WindTrack.nees"
        keep = self._settled(settle_s, where)
        e, cov = self.error[keep], self.wind_cov[keep]
        ran = np.all(np.isfinite(e), axis=1) & np.all(np.isfinite(cov), axis=(1, 2))
        value = np.full(e.shape[0], np.nan)
        if np.any(ran):
            sol = np.linalg.solve(cov[ran], e[ran][..., None])[..., 0]
            value[ran] = np.sum(e[ran] * sol, axis=1)
        return float(_mean_of_finite(value, where, settle_s))


def _mean_of_finite(values: np.ndarray, where: str, settle_s) -> np.ndarray:
    """The mean of ``values`` (K, ...) over axis 0, non-finite entries (samples where the
    filter did not run) left out: :func:`numpy.nanmean`; NaN where none is left, with a
    RuntimeWarning naming ``where`` (not NumPy's "Mean of empty slice")."""
    ok = np.isfinite(values)
    if not np.all(ok.any(axis=0)):
        warnings.warn(f"{where}: no estimate (the filter did not run) or no logged truth at "
                      f"any of the {values.shape[0]} samples after settle_s = "
                      f"{float(settle_s):g} s"
                      + ("" if values.ndim == 1 else " on some axis") + "; the result is NaN "
                      "there.", RuntimeWarning, stacklevel=3)
    with warnings.catch_warnings():  # said above, with the metric's name
        warnings.simplefilter("ignore", RuntimeWarning)
        return np.nanmean(np.where(ok, values, np.nan), axis=0)


def _grid(log, use: tuple[str, ...]) -> tuple[np.ndarray, float]:
    """Union of the sensor times (must be uniform) and its spacing."""
    times = np.unique(np.round(np.concatenate([log.sensors[s]["t"] for s in use]), 9))
    if times.size < 2:
        raise ValueError("The 'log' parameter of run_wind_ukf must hold at least two sensor "
                         "samples.")
    steps = np.diff(times)
    dt = float(np.median(steps))
    if np.any(np.abs(steps - dt) > 1e-6 * dt):
        raise ValueError("The 'log' parameter of run_wind_ukf has sensor rates whose sample "
                         "times do not form a uniform grid (each rate must divide the fastest).")
    return times, dt


def _at(times: np.ndarray, query: np.ndarray) -> np.ndarray:
    """Index of the last sample of ``times`` at or before each ``query`` (clipped to 0)."""
    return np.clip(np.searchsorted(times, query + 1e-9, side="right") - 1, 0, times.size - 1)


def _on_grid(grid: np.ndarray, t: np.ndarray, values: np.ndarray) -> np.ndarray:
    """Place ``values`` (K, ...) stamped ``t`` on ``grid`` (T,); NaN where no sample."""
    out = np.full((grid.size,) + values.shape[1:], np.nan)
    idx = np.searchsorted(grid, t - 1e-9)
    ok = (idx < grid.size) & (np.abs(grid[np.minimum(idx, grid.size - 1)] - t) < 1e-6)
    out[idx[ok]] = values[ok]
    return out


def _commands(log, vehicle: int, caller: tuple[str, int]) -> tuple[np.ndarray, np.ndarray]:
    """The rotor-speed commands of ``vehicle`` and their times: the log's, or the rotor-speed
    sensor's where its samples are finer and it reads the commands exactly (its values equal
    the log's at every common time: a noise-free sensor), fused or not. With ``log_every`` =
    100 the log's were up to 99 physics steps stale and the estimate moved by up to 0.49 m/s
    (0.23 m/s at 10; metamorphic audit, 2026-12-05); a noisy sensor's readings are
    measurements, not the commands, and would count its noise twice. Commands coarser than the
    controller's, from neither, are warned (``where``: the public function's name)."""
    t_cmd, cmd = log.t, log.rotor_speed_cmd[:, vehicle]
    if log.t.size < 2:
        return t_cmd, cmd
    step_log = float(np.median(np.diff(log.t)))
    rs = log.sensors.get("rotor_speeds")
    if rs is not None and rs["t"].size > 1 and np.median(np.diff(rs["t"])) < step_log * (
            1 - 1e-6):
        i = np.minimum(np.searchsorted(log.t, rs["t"] - 1e-9), log.t.size - 1)
        common = np.abs(log.t[i] - rs["t"]) <= 1e-9
        if common.any() and np.array_equal(rs["cmd"][common, vehicle], cmd[i[common]]):
            return rs["t"], rs["cmd"][:, vehicle]
    rate = log.meta.get("control_rate_hz") if isinstance(log.meta, dict) else None
    if rate and step_log > (1.0 + 1e-6) / float(rate):
        where, level = caller
        warnings.warn(f"{where}: the log holds the rotor-speed commands every {step_log:g} s, "
                      f"coarser than the controller's {1.0 / float(rate):g} s (log_every), and "
                      "no noise-free rotor-speed sensor holds them finer: the filter's inputs "
                      "lag the commands by up to that much, and its estimate differs from a "
                      "full log's; fly with a log_every that keeps every control step",
                      RuntimeWarning, stacklevel=level)
    return t_cmd, cmd


def _mapped(rotor_speed_map, t: np.ndarray, cmd: np.ndarray) -> np.ndarray:
    """``rotor_speed_map(t, cmd)`` checked to keep the shape (``cmd`` when no map)."""
    if rotor_speed_map is None:
        return cmd
    out = np.asarray(rotor_speed_map(t, cmd), dtype=np.float64)
    if out.shape != cmd.shape:
        raise ValueError(f"The 'rotor_speed_map' parameter of filter_inputs must return the "
                         f"shape of the commands {cmd.shape}. Got shape {out.shape} instead.")
    return out


def filter_inputs(log, params: MultirotorParams, *, vehicle: int = 0,
                  sensors: tuple[str, ...] = _SENSORS,
                  rotor_speed_map: Callable | None = None,
                  _caller: tuple[str, int] = ("filter_inputs", 3)) -> dict[str, np.ndarray]:
    """The filter's inputs on its time grid, from a flight log.

    Parameters
    ----------
    log : FlightLog
        A flight with at least the ``imu`` and ``odometry`` sensors.
    params : MultirotorParams
        Vehicle the filter believes in (for the rotor-speed limits).
    vehicle : int
        Batch row of the log.
    sensors : tuple of str
        Which logged sensors to use (``imu``, ``odometry``, ``rotor_speeds``).
    rotor_speed_map : callable ``(t (K,), cmd (K, N)) -> (K, N)``, optional
        Applied to the commands before they become the inputs ``u``, and to the logged
        pseudo-measurements (see :func:`run_wind_ukf`).

    Returns
    -------
    dict
        ``t`` (T,) s; ``dt`` float s; ``u`` (T, N) command held over ``(t_{k-1}, t_k]``
        (row 0: the command at ``t_0``), rad/s; ``accel``, ``gyro`` (T, 3); ``odom`` (T, 6);
        ``rotor_speeds`` (T, N); ``wind_true`` (T, 3). Missing samples are NaN rows.

    Notes
    -----
    The inputs ``u`` are the commands of the log, or of the ``rotor_speeds`` sensor (fused or
    not) where its samples are finer and it reads them without noise (a log with ``log_every``
    > 2 at 100 Hz control; otherwise such a log's stale commands are warned); the true wind is
    the log's at the grid times it holds, NaN between them (the metrics leave those samples
    out).
    """
    where = "filter_inputs"
    B = log.position.shape[1]
    # 0.7 was read as 0, NaN raised "cannot convert float NaN to integer"
    if isinstance(vehicle, bool) or not isinstance(vehicle, (int, np.integer)):
        raise ValueError(f"The 'vehicle' parameter of {where} must be an integer. Got "
                         f"{vehicle!r} instead.")
    vehicle = int(vehicle)
    if not 0 <= vehicle < B:
        raise ValueError(f"The 'vehicle' parameter of {where} must be in [0, {B}). "
                         f"Got {vehicle!r} instead.")
    unknown = set(sensors) - set(_SENSORS)
    if unknown:
        raise ValueError(f"The 'sensors' parameter of {where} has unknown names "
                         f"{sorted(unknown)}; known: {list(_SENSORS)}.")
    use = tuple(s for s in sensors if s in log.sensors)
    for need in ("imu", "odometry"):
        if need not in use:
            raise ValueError(f"The 'log' parameter of {where} must carry the {need!r} sensor "
                             f"(logged: {sorted(log.sensors)}).")
    grid, dt = _grid(log, use)
    N = log.rotor_speed_cmd.shape[2]
    t_cmd, cmd = _commands(log, vehicle, _caller)
    cmd = np.clip(_mapped(rotor_speed_map, t_cmd, cmd), params.rotor_speed_min,
                  params.rotor_speed_max)
    held = cmd[_at(t_cmd, np.r_[grid[0], grid[:-1]])]
    imu, od = log.sensors["imu"], log.sensors["odometry"]
    euler = Rotation.from_quat(od["attitude"][:, vehicle]).as_euler("ZYX")
    out = {
        "t": grid, "dt": dt, "u": held,
        "accel": _on_grid(grid, imu["t"], imu["accel"][:, vehicle]),
        "gyro": _on_grid(grid, imu["t"], imu["gyro"][:, vehicle]),
        "odom": _on_grid(grid, od["t"], np.concatenate([od["velocity"][:, vehicle], euler], 1)),
        "rotor_speeds": np.full((grid.size, N), np.nan),
        # the true wind where the log holds it: with log_every > 1 the last sample was taken,
        # up to log_every - 1 steps stale, and gusts scored against it (metamorphic audit)
        "wind_true": _on_grid(grid, log.t, log.wind[:, vehicle]),
    }
    if "rotor_speeds" in use:
        rs = log.sensors["rotor_speeds"]
        prev = np.clip(_mapped(rotor_speed_map, rs["t"], rs["cmd"][:, vehicle]),
                       params.rotor_speed_min, params.rotor_speed_max)
        # the command sampled at t_{j-1} measures eta at t_j (the next sample time)
        out["rotor_speeds"] = _on_grid(grid, rs["t"][1:], prev[:-1])
    return out


def run_wind_ukf(
    log,
    params_filter: MultirotorParams,
    *,
    vehicle: int = 0,
    q: Mapping[str, float] | None = None,
    r: Mapping | None = None,
    wind_frame: str | None = None,
    accel_from_odometry: bool | OdometryAccel | None = None,
    sensors: tuple[str, ...] | None = None,
    n_substeps: int = 1,
    conditions: str | UKFConditions | None = None,
    alpha: float | None = None,
    beta: float | None = None,
    kappa: float | None = None,
    rotor_speed_map: Callable[[np.ndarray, np.ndarray], np.ndarray] | None = None,
    progress: bool = False,
) -> WindTrack:
    """Feed a flight's logged sensors through :class:`~windnav.estimate.WindUKF`.

    Parameters
    ----------
    log : FlightLog
        Recorded flight (sensors ``imu`` and ``odometry`` required, ``rotor_speeds`` used when
        present); see the module docstring for the alignment.
    params_filter : MultirotorParams
        The vehicle the filter believes in (calibrated drag coefficients).
    vehicle : int
        Batch row of the log to estimate.
    q, r : mapping, optional
        Process / measurement noise overrides passed to :class:`WindUKF`.
    wind_frame : {"world", "body"}, optional
        Random-walk frame of the wind (see :mod:`windnav.estimate.wind_model`). Default
        "world" (as for :class:`WindUKF`): the mean wind of a flight is fixed in the world, not
        in the turning body.
    accel_from_odometry : bool or OdometryAccel, optional
        Form the specific force from differenced odometry instead of the IMU (an
        :class:`~windnav.estimate.hardware.OdometryAccel`: the hardware's chain).
    sensors : tuple of str, optional
        Logged sensors to use (default all three, or the conditions').
    n_substeps : int
        RK4 steps per filter step.
    conditions : str or UKFConditions, optional
        A preset (:data:`windnav.estimate.conditions.CONDITIONS`) whose filter settings and
        fused sensors are the defaults of the arguments above; explicit arguments override
        it (``q`` and ``r`` key by key). What the filter is told about the vehicle
        (``params_filter``) and the rotor-speed chain (``rotor_speed_map``) are the caller's.
        None (the default; unlike :func:`~windnav.estimate.ukf_conditions`, where None is
        ``"windnav"``): :class:`~windnav.estimate.WindUKF`'s general-purpose
        :data:`~windnav.estimate.DEFAULT_Q` and :data:`~windnav.estimate.DEFAULT_R`, tuned to no
        sensor suite. For a log flown with ``fly``'s default
        sensors pass ``conditions="windnav"``: on the README's 20 s circle in Dryden gusts the
        defaults gave 0.324 m/s of RMS error and a NEES of 6.4 (a covariance about 2x too
        small), ``"windnav"`` 0.121 m/s and 1.5 (API audit, 2026-12-05). The demo and
        ``sysid``'s UKF wind run with the defaults, and their documented numbers with them.
    alpha, beta, kappa : float, optional
        Sigma-point parameters (default 1, 2, 0, or the conditions').
    rotor_speed_map : callable ``(t (K,), cmd (K, N)) -> (K, N)``, optional
        What the filter sees of the rotor-speed commands (rad/s) at times ``t`` (s), for the
        inputs ``u`` and the pseudo-measurements alike: e.g. commands sent as PWM and read
        back through a motor model with errors (:mod:`windnav.experiments.ukf_conditions`).
        Default: the commands themselves.
    progress : bool
        Show a progress bar.

    Returns
    -------
    WindTrack
    """
    where = "run_wind_ukf"
    if not isinstance(params_filter, MultirotorParams):
        raise ValueError(f"The 'params_filter' parameter of {where} must be a MultirotorParams. "
                         f"Got {type(params_filter).__name__} instead.")
    n_substeps = positive_int(n_substeps, "n_substeps", where)
    if conditions is not None:
        sensors = ukf_conditions(conditions).filter_sensors if sensors is None else sensors
    inp = filter_inputs(log, params_filter, vehicle=vehicle,
                        sensors=_SENSORS if sensors is None else sensors,
                        rotor_speed_map=rotor_speed_map, _caller=(where, 4))
    T = inp["t"].size
    N = params_filter.n_rotors
    if inp["u"].shape[1] != N:
        raise ValueError(f"The 'params_filter' parameter of {where} has {N} rotors but the log "
                         f"has {inp['u'].shape[1]}.")
    finite = np.flatnonzero(np.all(np.isfinite(inp["odom"]), axis=1))
    if finite.size == 0:  # an IndexError before
        raise ValueError(f"The 'log' parameter of {where} must hold at least one finite "
                         f"odometry sample of vehicle {vehicle} (the filter starts from it). "
                         "Got none instead.")
    first = int(finite[0])
    x0 = np.zeros(N_BASE + N)
    odom0 = inp["odom"][first]
    x0[IDX_EULER] = odom0[ODOM_EULER]
    x0[IDX_VELOCITY] = wm.euler_to_matrix(odom0[ODOM_EULER])[0].T @ odom0[ODOM_VELOCITY]
    x0[IDX_ROTORS] = inp["u"][0]
    ukf = WindUKF(params_filter, inp["dt"], q=q, r=r, x0=x0, wind_frame=wind_frame,
                  accel_from_odometry=accel_from_odometry, n_substeps=n_substeps,
                  alpha=alpha, beta=beta, kappa=kappa, conditions=conditions)
    est = ukf.estimate()
    wind_est = np.empty((T, 3))
    wind_cov = np.empty((T, 3, 3))
    xs = np.empty((T, N_BASE + N))
    wind_est[0], wind_cov[0], xs[0] = est.wind_world, est.wind_world_cov, est.x
    blocks = ("accel", "gyro", "odom", "rotor_speeds")
    have = {b: np.all(np.isfinite(inp[b]), axis=1) for b in blocks}
    for k in progress_bar(range(1, T), disable=not progress, desc="wind ukf", unit="step",
                          leave=False, mininterval=0.5):
        meas = {b: inp[b][k] for b in blocks if have[b][k]}
        try:
            est = ukf.step(inp["u"][k], meas)
        except FilterDivergedError as exc:
            status = log.meta.get("status")
            raise FilterDivergedError(
                f"{exc} The Wind UKF diverged at t = {inp['t'][k]:.3f} s of the log (vehicle "
                f"{vehicle}), whose flight status is {status!r}: a flight saturated or outside "
                "the aerodynamic envelope (e.g. flown with a physics step too long for the "
                "controller) gives measurements the filter's model cannot follow.") from exc
        wind_est[k], wind_cov[k], xs[k] = est.wind_world, est.wind_world_cov, est.x
    return WindTrack(inp["t"], wind_est, wind_cov, inp["wind_true"], xs, ukf.repairs)
