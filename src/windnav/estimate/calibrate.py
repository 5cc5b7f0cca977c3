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

A coefficient the data do not determine is said (:attr:`DragFit.undetermined`, a note in
:attr:`DragFit.notes` and a ``RuntimeWarning``), its standard error NaN, its value kept as
fitted (as the sys-id fits treat a coefficient on a bound, :mod:`windnav.sysid._fit`):

- **no airflow along its axis**: no row of the log flew faster than :data:`AIRFLOW_MIN` along
  x, y or z of the heading frame (the world frame turned by the yaw, so the tilt of a
  horizontal flight is no vertical airflow): ``c_dx``, ``c_dy`` without flights along x, y,
  ``k_d`` without either, ``k_z`` and ``c_dz`` without vertical flights. The body-z airflow a
  horizontal flight's tilt makes grows with its speed, as the translational lift does, and does
  not separate them from it (``windnav.sysid.aero.COLLINEAR_KZ_KH``): flights along x alone at
  1-3 m/s gave ``k_z`` -19 % and ``c_dz`` 3.9 x the truth, each about 5 standard errors off;
- **not separated** from another coefficient: the fit's columns, scaled to unit norm, have a
  singular value below :data:`COLLINEAR_MIN`; the coefficients of its direction are named
  (one airspeed along x: ``k_d`` -36 %, ``c_dx`` 9 x);
- **on the bound 0** of the non-negative least squares: the covariance's linearisation assumes
  the estimate could move either way, which the bound forbids.

A fit that explains less than :data:`R2_MIN` of the specific force's variance (in-plane or
axial) is noted too; its standard errors are kept. The default flights
(:data:`DEFAULT_SPEEDS`) trip none of these, and their fit is what it was before the checks,
to the last bit.
"""

from __future__ import annotations

import json
import math
import warnings
from dataclasses import asdict, dataclass, field

import numpy as np
from scipy.optimize import nnls

from windnav._validate import positive_float
from windnav.vehicle.params import MultirotorParams
from windnav.vehicle.rotation import quat_to_matrix

__all__ = ["AIRFLOW_MIN", "AXES", "COLLINEAR_MIN", "DEFAULT_SPEEDS", "R2_MIN", "DragFit",
           "fit_drag"]

DEFAULT_SPEEDS = {
    "x": (-5.0, -4.0, -3.0, -2.0, -1.0, 1.0, 2.0, 3.0, 4.0, 5.0),
    "y": (-5.0, -4.0, -3.0, -2.0, -1.0, 1.0, 2.0, 3.0, 4.0, 5.0),
    "z": (-2.0, -1.5, -1.0, -0.5, 0.5, 1.0, 1.5, 2.0),
}
"""Airspeeds flown along each axis, m/s (signed: + flies toward +axis)."""

AXES = {"x": 0, "y": 1, "z": 2}
"""Body axis names of a calibration's ``speeds`` and their indices."""

AIRFLOW_MIN = 0.2
"""Least airflow along an axis for the calibration to have flown along it, m/s: the RMS, over
one row's samples, of the airspeed along that axis of the heading frame, in the row that flew
fastest along it. Hover gives 0.02 m/s (odometry noise; 0.05 with the ``hardware`` preset's
motion capture), the crosswind axis of flights along x at up to 15 m/s 0.12 m/s, the slowest
flight of :data:`DEFAULT_SPEEDS` 0.5 m/s."""

COLLINEAR_MIN = 0.02
"""Smallest singular value of a fit's columns (scaled to unit norm) below which the
coefficients of its direction are not separated (for two columns, a cosine above 0.9996 between
them; their standard errors about 35 times those of orthogonal columns). The default flights
give 0.17 in-plane and 0.31-0.35 axial; one airspeed along x gives 0.012."""

R2_MIN = 0.1
"""Least coefficient of determination of a fit without a note: below it the drag explains
less than a tenth of the specific force's variance (its force varies less than a third as
much as the noise), as when the flights barely move the air past the vehicle (hover alone:
0.003 and -0.010). The noisiest preset that calibrates, ``thesis`` (1.02 m/s^2 of accelerometer
noise), gives 0.46 in-plane and 0.34 axial on the Hummingbird."""

_AXIS_COEFFICIENTS = {"x": ("c_dx",), "y": ("c_dy",), "z": ("k_z", "c_dz")}
"""The coefficients that only airflow along an axis determines (``k_d``: along x or y)."""


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
        and ``(J^T J)^-1``; NaN for those in ``undetermined``.
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
    undetermined : dict of str to str
        The fitted coefficients the data do not determine, each with why (module docstring):
        their value is the fit's, their standard error NaN. Empty for a well-excited fit.
    notes : tuple of str
        Caveats of the fit, one sentence each: the undetermined coefficients, and a
        coefficient of determination below :data:`R2_MIN`. Empty for a well-excited fit.
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
    undetermined: dict = field(default_factory=dict)
    notes: tuple = ()

    @property
    def coefficients(self) -> dict[str, float]:
        """``{"k_d", "k_z", "c_dx", "c_dy", "c_dz"}``."""
        return {k: getattr(self, k) for k in ("k_d", "k_z", "c_dx", "c_dy", "c_dz")}

    def apply(self, params: MultirotorParams) -> MultirotorParams:
        """``params`` with the fitted drag coefficients (what the filter should believe).

        The undetermined coefficients (:attr:`undetermined`) are handed on as fitted too, with
        a ``RuntimeWarning`` naming them: ``params``' own values would be a guess the data do
        not support either (and, in a simulated calibration, the truth the filter cannot
        know). Replace them knowingly: ``fit.apply(p).replace(c_dz=...)``.
        """
        if self.undetermined:
            which = ", ".join(f"{k} = {getattr(self, k):.4g} ({why})"
                              for k, why in self.undetermined.items())
            warnings.warn(f"DragFit.apply: the calibration data do not determine {which}; "
                          "they are handed on as fitted", RuntimeWarning, stacklevel=2)
        return params.replace(**self.coefficients)

    def relative_errors(self, truth: MultirotorParams) -> dict[str, float]:
        """``(fit - true) / true`` per coefficient (absolute error where the truth is 0)."""
        out = {}
        for k, v in self.coefficients.items():
            ref = getattr(truth, k)
            out[k] = (v - ref) / ref if ref != 0 else v - ref
        return out

    def to_json(self) -> str:
        """JSON text of every field (a NaN standard error as null)."""
        d = asdict(self)
        d["stderr"] = {k: None if isinstance(v, float) and not math.isfinite(v) else v
                       for k, v in d["stderr"].items()}
        return json.dumps(d, indent=2)


def _regressors(log, params: MultirotorParams, settle_s: float):
    """Stacked samples after ``settle_s`` of the usable rows: a, v_a, s, s2 (flattened), the
    rows used and dropped, and the airflow along each axis (:func:`_airflow`)."""
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
    v_rows = od["velocity"][keep_t][:, ok] - wind                    # (K, B', 3)
    v_w = v_rows.reshape(-1, 3)
    v_a = np.einsum("bji,bj->bi", R, v_w)
    return (acc.reshape(-1, 3), v_a, eta.sum(-1).reshape(-1), (eta**2).sum(-1).reshape(-1),
            int(ok.sum()), int((~ok).sum()), _airflow(v_rows, R))


def _airflow(v_rows: np.ndarray, R: np.ndarray) -> np.ndarray:
    """Airflow along x, y, z of the heading frame (the world frame turned by the yaw), m/s: the
    largest, over the rows, of the RMS over a row's samples.

    ``v_rows`` (K, B, 3) is the world airspeed ``v - w`` (m/s) of ``B`` rows at ``K`` times,
    ``R`` (K * B, 3, 3) the body-to-world rotations of the same samples, flattened alike.
    """
    yaw = np.arctan2(R[:, 1, 0], R[:, 0, 0]).reshape(v_rows.shape[:2])
    c, s = np.cos(yaw), np.sin(yaw)
    heading = np.stack([c * v_rows[..., 0] + s * v_rows[..., 1],
                        -s * v_rows[..., 0] + c * v_rows[..., 1], v_rows[..., 2]], axis=-1)
    return np.sqrt(np.mean(heading**2, axis=0)).max(axis=0)


def _undetermined(fits, airflow: np.ndarray, tilt_z: float, r2: tuple
                  ) -> tuple[dict[str, str], tuple[str, ...]]:
    """The coefficients the data do not determine, with why, and the fit's notes (module
    docstring).

    Parameters
    ----------
    fits : sequence of (names, A, coef)
        Each least-squares problem: its coefficient names, its columns ``A`` (n, p) and the
        fitted coefficients (p,).
    airflow : ndarray of shape (3,)
        Airflow along x, y, z of the heading frame, m/s (:func:`_airflow`).
    tilt_z : float
        RMS body-z airspeed over the samples, m/s (the tilt's, when no row flew vertically).
    r2 : tuple of float
        Coefficients of determination of the in-plane and axial fits.

    Returns
    -------
    undetermined : dict of str to str
        ``{coefficient: reasons}``, in the order of :attr:`DragFit.coefficients`.
    notes : tuple of str
    """
    names = [k for fit_names, _, _ in fits for k in fit_names]
    reasons = {k: [] for k in names}
    notes = []
    still = [a for a, i in AXES.items() if airflow[i] < AIRFLOW_MIN]
    unflown = [k for k in names
               if (k == "k_d" and {"x", "y"} <= set(still))
               or any(k in _AXIS_COEFFICIENTS[a] for a in still)]
    for k in unflown:
        reasons[k].append("no airflow along " + ("x or y" if k == "k_d" else
                                                 next(a for a in still
                                                      if k in _AXIS_COEFFICIENTS[a])))
    if unflown:
        tilt = ""
        vertical = [k for k in ("k_z", "c_dz") if k in unflown]
        if vertical and not {"x", "y"} <= set(still):
            tilt = (f"; the body-z airflow the tilt of the horizontal flights makes ({tilt_z:.2g}"
                    " m/s RMS) grows with their speed as the translational lift does, and does "
                    f"not separate {_join(vertical, 'and')} from it")
        axes = [a for a in still  # those an undetermined coefficient needs
                if "k_d" in unflown and a != "z" or set(_AXIS_COEFFICIENTS[a]) & set(unflown)]
        fastest = ", ".join(f"{a} {airflow[AXES[a]]:.2g}" for a in axes)
        notes.append(f"no calibration row flew along {_join(axes, 'or')} (the fastest row's "
                     f"airflow: {fastest} m/s RMS, below {AIRFLOW_MIN:g} m/s), so the data do "
                     f"not determine {_join(unflown, 'and')}{tilt}; standard errors NaN; fly "
                     f"along {_join(axes, 'and')}")
    for fit_names, A, _ in fits:
        active = [j for j, k in enumerate(fit_names) if k not in unflown]
        if len(active) < 2:
            continue
        cols = A[:, active]
        norm = np.linalg.norm(cols, axis=0)
        sv, vt = np.linalg.svd(cols / np.where(norm > 0, norm, 1.0), full_matrices=False)[1:]
        for value, direction in zip(sv, vt, strict=True):
            if value >= COLLINEAR_MIN:
                continue
            tied = [fit_names[j] for j, w in zip(active, direction, strict=True) if w**2 >= 0.1]
            for k in tied:
                others = [t for t in tied if t != k]
                reasons[k].append("not separated from " + _join(others, "and") if others
                                  else "its column is zero")
            notes.append(f"the data do not separate {_join(tied, 'and')}: their columns, scaled "
                         f"to unit norm, have a singular value of {value:.2g}, below "
                         f"{COLLINEAR_MIN:g}; standard errors NaN; fly more airspeeds along "
                         "each axis")
    pinned = [k for fit_names, _, coef in fits for k, c in zip(fit_names, coef, strict=True)
              if c == 0.0]
    for k in pinned:
        reasons[k].append("on the bound 0")
    pinned = [k for k in pinned if len(reasons[k]) == 1]  # the others are said above
    if pinned:
        one = len(pinned) == 1
        notes.append(f"{_join(pinned, 'and')} {'lies' if one else 'lie'} at 0, the bound of the "
                     f"non-negative least squares (the data would put {'it' if one else 'them'}"
                     " at or below 0): no standard error is given (NaN), since the covariance's "
                     "linearisation does not hold at a bound")
    low = [f"{what} {v:.3g}" for what, v in zip(("in-plane", "axial"), r2, strict=True)
           if not v >= R2_MIN]
    if low:
        notes.append(f"the drag model explains little of the specific force: R^2 "
                     f"{' and '.join(low)}, below {R2_MIN:g}; the flights barely excite the "
                     "drag, or the noise swamps it")
    order = ("k_d", "k_z", "c_dx", "c_dy", "c_dz")
    return ({k: "; ".join(reasons[k]) for k in order if reasons.get(k)}, tuple(notes))


def _join(words, last: str) -> str:
    """``"a"``, ``"a or b"``, ``"a, b or c"`` (``last`` the final conjunction)."""
    words = list(words)
    if len(words) < 2:
        return "".join(words)
    return f"{', '.join(words[:-1])} {last} {words[-1]}"


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
        With the coefficients the data do not determine in ``undetermined`` (NaN standard
        errors) and the caveats in ``notes``, each also a ``RuntimeWarning`` (module
        docstring). The fit itself does not change: a user may calibrate one axis knowingly.
    """
    where = "fit_drag"
    if not isinstance(params, MultirotorParams):
        raise ValueError(f"The 'params' parameter of {where} must be a MultirotorParams. "
                         f"Got {type(params).__name__} instead.")
    settle_s = positive_float(settle_s, "settle_s", where, allow_zero=True)
    acc, v_a, s, s2, used, dropped, airflow = _regressors(log, params, settle_s)
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
    fit_r2 = (r2(r_xy, y_xy), r2(r_z, y_z))
    names_xy, names_z = ("k_d", "c_dx", "c_dy")[:A_xy.shape[1]], ("k_z", "c_dz")[:A_z.shape[1]]
    undetermined, notes = _undetermined(
        ((names_xy, A_xy, c_xy), (names_z, A_z, c_z)), airflow,
        float(np.sqrt(np.mean(v_a[:, 2] ** 2))), fit_r2)
    for k in undetermined:  # the well-determined ones keep their standard error to the bit
        se[k] = math.nan
    for note in notes:
        warnings.warn(f"fit_drag: {note}", RuntimeWarning, stacklevel=2)
    return DragFit(**{k: float(v) for k, v in coef.items()},
                   stderr={k: float(v) for k, v in se.items()}, residual_rms=rms,
                   r2=fit_r2, n_samples=int(n), rows_used=used,
                   rows_dropped=dropped, parasitic=bool(parasitic),
                   undetermined=undetermined, notes=notes)
