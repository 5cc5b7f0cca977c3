"""Drag calibration of the Wind UKF's force model from steady flights (Folk 2026, ch. 3).

The filter's force model (see :mod:`windnav.estimate.wind_model`) is linear in the drag
coefficients. With the body airspeed ``v_a`` (m/s), the sum of rotor speeds
``s = sum_i eta_i`` (rad/s), ``s2 = sum_i eta_i^2`` and the accelerometer's specific force
``a`` (body axes, m/s^2), the in-plane and axial rows are::

    m a_x                                     = -k_d s v_a,x - c_dx |v_a| v_a,x
    m a_y                                     = -k_d s v_a,y - c_dy |v_a| v_a,y
    m a_z - k_eta s2 - N k_h (v_a,x^2 + v_a,y^2) = -k_z s v_a,z - c_dz |v_a| v_a,z

The thesis fits ``k_d`` from ``a_x = -(k_d / m) s v_x`` and ``k_z`` from the z rows by least
squares; :func:`fit_drag` does the same and, with ``parasitic=True`` (default), fits the
parasitic coefficients ``c_dx, c_dy, c_dz`` jointly: ``(k_d, c_dx, c_dy)`` from the stacked
x and y rows, ``(k_z, c_dz)`` from the z rows, each by non-negative least squares (drag
coefficients are >= 0). The mass ``m`` (weighed), the thrust coefficient ``k_eta`` (hover test)
and the translational-lift coefficient ``k_h`` are taken as known.

Data: steady flights at a range of airspeeds along each body axis, flown in a simulated wind
tunnel by :func:`windnav.experiments.calibration.calibration_flights` (this module is only the
fitting math and does not fly the simulator). The fit uses the known tunnel wind,
``v_a = R^T (v_odom - w)`` (the SE(3) controller has no integral action, so a vehicle drifts
slowly downwind; its ground speed is part of ``v_a``, so the rows need not be exactly steady).
Samples before ``settle_s`` are dropped, and so are rows whose rotor commands saturated (loss
of control authority) or whose samples are not finite.
"""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass, field

import numpy as np
from scipy.optimize import nnls

from windnav._validate import positive_float
from windnav.vehicle.params import MultirotorParams
from windnav.vehicle.rotation import quat_to_matrix

__all__ = ["AXES", "DEFAULT_SPEEDS", "DragFit", "fit_drag"]

DEFAULT_SPEEDS = {
    "x": (-5.0, -4.0, -3.0, -2.0, -1.0, 1.0, 2.0, 3.0, 4.0, 5.0),
    "y": (-5.0, -4.0, -3.0, -2.0, -1.0, 1.0, 2.0, 3.0, 4.0, 5.0),
    "z": (-2.0, -1.5, -1.0, -0.5, 0.5, 1.0, 1.5, 2.0),
}
"""Airspeeds flown along each axis, m/s (signed: + flies toward +axis)."""

AXES = {"x": 0, "y": 1, "z": 2}
"""Body axis names of a calibration's ``speeds`` and their indices."""


@dataclass(frozen=True)
class DragFit:
    """Fitted drag coefficients with their residuals.

    Attributes
    ----------
    k_d, k_z : float
        Rotor drag coefficients, kg/rad.
    c_dx, c_dy, c_dz : float
        Parasitic drag coefficients, N/(m/s)^2 (0 when not fitted).
    stderr : dict of str to float
        Standard errors of the fitted coefficients (same units), from the residual variance
        and ``(J^T J)^-1``.
    residual_rms : tuple of float
        RMS residual of the specific force along body x, y, z after the fit, m/s^2.
    r2 : tuple of float
        Coefficient of determination of the in-plane (x, y stacked) and axial (z) fits.
    n_samples : int
        Samples (time x rows) used.
    rows_used, rows_dropped : int
        Calibration rows kept, and dropped for saturation or non-finite samples.
    parasitic : bool
        Whether ``c_dx, c_dy, c_dz`` were fitted.
    """

    k_d: float
    k_z: float
    c_dx: float = 0.0
    c_dy: float = 0.0
    c_dz: float = 0.0
    stderr: dict = field(default_factory=dict)
    residual_rms: tuple = (0.0, 0.0, 0.0)
    r2: tuple = (0.0, 0.0)
    n_samples: int = 0
    rows_used: int = 0
    rows_dropped: int = 0
    parasitic: bool = True

    @property
    def coefficients(self) -> dict[str, float]:
        """``{"k_d", "k_z", "c_dx", "c_dy", "c_dz"}``."""
        return {k: getattr(self, k) for k in ("k_d", "k_z", "c_dx", "c_dy", "c_dz")}

    def apply(self, params: MultirotorParams) -> MultirotorParams:
        """``params`` with the fitted drag coefficients (what the filter should believe)."""
        return params.replace(**self.coefficients)

    def relative_errors(self, truth: MultirotorParams) -> dict[str, float]:
        """``(fit - true) / true`` per coefficient (absolute error where the truth is 0)."""
        out = {}
        for k, v in self.coefficients.items():
            ref = getattr(truth, k)
            out[k] = (v - ref) / ref if ref != 0 else v - ref
        return out

    def to_json(self) -> str:
        """JSON text of every field."""
        return json.dumps(asdict(self), indent=2)


def _regressors(log, params: MultirotorParams, settle_s: float):
    """Stacked samples after ``settle_s`` of the usable rows: a, v_a, s, s2 (flattened)."""
    imu, od = log.sensors["imu"], log.sensors["odometry"]
    t = imu["t"]
    if not (np.array_equal(t, od["t"]) and "rotor_speeds" in log.sensors
            and np.array_equal(t, log.sensors["rotor_speeds"]["t"])):
        raise ValueError("The 'log' parameter of fit_drag must carry the imu, odometry and "
                         "rotor_speeds sensors at one common rate.")
    keep_t = np.flatnonzero(t >= settle_s)
    keep_t = keep_t[keep_t >= 1]  # eta(t_k) is measured by the command sampled at t_{k-1}
    if keep_t.size < 2:
        raise ValueError(f"The 'settle_s' parameter of fit_drag must leave samples in the "
                         f"log (ends at {t[-1]:.3f} s). Got {settle_s!r} instead.")
    settled = log.t >= settle_s
    finite = np.all(np.isfinite(imu["accel"][keep_t]), axis=(0, 2)) & np.all(
        np.isfinite(od["velocity"][keep_t]), axis=(0, 2))
    ok = ~np.any(log.saturated[settled], axis=(0, 2)) & finite
    if not np.any(ok):
        raise ValueError("The 'log' parameter of fit_drag has no calibration row free of "
                         "saturation.")
    cmd = np.clip(log.sensors["rotor_speeds"]["cmd"], params.rotor_speed_min,
                  params.rotor_speed_max)
    eta = cmd[keep_t - 1][:, ok]                                     # (K, B', N)
    acc = imu["accel"][keep_t][:, ok]                                # (K, B', 3)
    wind_idx = np.clip(np.searchsorted(log.t, t[keep_t] - 1e-9), 0, log.t.size - 1)
    wind = log.wind[wind_idx][:, ok]
    R = quat_to_matrix(od["attitude"][keep_t][:, ok].reshape(-1, 4))
    v_w = (od["velocity"][keep_t][:, ok] - wind).reshape(-1, 3)
    v_a = np.einsum("bji,bj->bi", R, v_w)
    return (acc.reshape(-1, 3), v_a, eta.sum(-1).reshape(-1), (eta**2).sum(-1).reshape(-1),
            int(ok.sum()), int((~ok).sum()))


def _nnls(A: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Non-negative least squares with column scaling; returns coef, stderr, residual."""
    scale = np.linalg.norm(A, axis=0)
    scale[scale == 0] = 1.0
    coef, _ = nnls(A / scale, y)
    coef = coef / scale
    res = y - A @ coef
    dof = max(y.size - A.shape[1], 1)
    s2 = float(res @ res) / dof
    cov = s2 * np.linalg.pinv(A.T @ A)
    return coef, np.sqrt(np.clip(np.diag(cov), 0.0, None)), res


def fit_drag(
    log,
    params: MultirotorParams,
    *,
    settle_s: float = 3.0,
    parasitic: bool = True,
) -> DragFit:
    """Least-squares fit of the drag coefficients from a calibration flight log.

    Parameters
    ----------
    log : FlightLog
        Steady flights (:func:`windnav.experiments.calibration.calibration_flights`) with
        the ``imu``, ``odometry`` and
        ``rotor_speeds`` sensors at one common rate; ``log.wind`` is the known wind the
        vehicle flew in (zero in still air, the tunnel wind otherwise).
    params : MultirotorParams
        Known parameters: mass, k_eta, k_h, rotor count and limits. Its drag values are ignored.
    settle_s : float
        Samples earlier than this are dropped (transient), s.
    parasitic : bool
        Also fit ``c_dx, c_dy, c_dz`` (else they are fixed at 0, the thesis' linear model).

    Returns
    -------
    DragFit
    """
    where = "fit_drag"
    if not isinstance(params, MultirotorParams):
        raise ValueError(f"The 'params' parameter of {where} must be a MultirotorParams. "
                         f"Got {type(params).__name__} instead.")
    settle_s = positive_float(settle_s, "settle_s", where, allow_zero=True)
    acc, v_a, s, s2, used, dropped = _regressors(log, params, settle_s)
    m = params.mass
    speed = np.linalg.norm(v_a, axis=1)
    n = v_a.shape[0]
    # in-plane rows: unknowns (k_d, c_dx, c_dy)
    A_xy = np.zeros((2 * n, 3))
    A_xy[:n, 0] = -s * v_a[:, 0]
    A_xy[n:, 0] = -s * v_a[:, 1]
    A_xy[:n, 1] = -speed * v_a[:, 0]
    A_xy[n:, 2] = -speed * v_a[:, 1]
    y_xy = m * np.r_[acc[:, 0], acc[:, 1]]
    # axial rows: unknowns (k_z, c_dz)
    A_z = np.stack([-s * v_a[:, 2], -speed * v_a[:, 2]], axis=1)
    y_z = (m * acc[:, 2] - params.k_eta * s2
           - params.n_rotors * params.k_h * (v_a[:, 0] ** 2 + v_a[:, 1] ** 2))
    if not parasitic:
        A_xy, A_z = A_xy[:, :1], A_z[:, :1]
    c_xy, se_xy, r_xy = _nnls(A_xy, y_xy)
    c_z, se_z, r_z = _nnls(A_z, y_z)
    coef = {"k_d": c_xy[0], "k_z": c_z[0]}
    se = {"k_d": se_xy[0], "k_z": se_z[0]}
    if parasitic:
        coef.update(c_dx=c_xy[1], c_dy=c_xy[2], c_dz=c_z[1])
        se.update(c_dx=se_xy[1], c_dy=se_xy[2], c_dz=se_z[1])

    def r2(res, y):
        return float(1.0 - (res @ res) / max(float(((y - y.mean()) ** 2).sum()), 1e-300))

    rms = (float(np.sqrt(np.mean(r_xy[:n] ** 2))) / m, float(np.sqrt(np.mean(r_xy[n:] ** 2))) / m,
           float(np.sqrt(np.mean(r_z**2))) / m)
    return DragFit(**{k: float(v) for k, v in coef.items()},
                   stderr={k: float(v) for k, v in se.items()}, residual_rms=rms,
                   r2=(r2(r_xy, y_xy), r2(r_z, y_z)), n_samples=int(n), rows_used=used,
                   rows_dropped=dropped, parasitic=bool(parasitic))
