"""``WindUKF``: the thesis' wind estimator (Folk 2026, ch. 3) as a shell over the generic UKF.

The model lives in :mod:`windnav.estimate.wind_model`. Measurement blocks, all optional at every
step (multi-rate sensors simply leave theirs out):

    "accel"         (3,)  accelerometer specific force, body axes, m/s^2
    "gyro"          (3,)  body rates, rad/s
    "odom"          (6,)  world-frame velocity (m/s) then ZYX Euler angles psi, theta, phi (rad)
    "rotor_speeds"  (N,)  measured rotor speeds, rad/s

With ``accel_from_odometry=True`` the accelerometer is not used: each odometry sample after the
first forms the specific force

    a_b = R(psi, theta, phi)^T ((v_k - v_{k-1}) / (t_k - t_{k-1}) + [0, 0, g])

from the differenced world velocity and the measured Euler angles, fused through the same
accelerometer model. Its default noise is ``sqrt(2) sigma_v / dt_odom`` per axis
(uncorrelated differencing noise; correlation between consecutive samples is neglected),
built for each update from the interval between the two samples and passed to that update
(``UKF.update(..., noise=...)``): a step never rewrites the filter's configured noise. With
``accel_from_odometry=OdometryAccel(...)`` the differenced specific force is clamped and
low-passed as on the author's hardware (:mod:`windnav.estimate.hardware`) and fused with the
configured ``r["accel"]`` (3.61 (m/s^2)^2 on the hardware).

``conditions=`` (a name of :data:`windnav.estimate.conditions.CONDITIONS` or a
:class:`~windnav.estimate.conditions.UKFConditions`) sets ``q, r, alpha, beta, kappa,
wind_frame`` and ``accel_from_odometry`` of a preset; arguments given explicitly override it
(``q`` and ``r`` key by key).

Output: wind in the world frame ``w = R(psi, theta, phi) w_b`` with its 3x3 covariance from an
unscented transform over the 6-dimensional marginal of (Euler angles, body wind), so the
uncertainty of the attitude is carried into the world-frame wind.

Noise tuning defaults (``DEFAULT_R``, ``DEFAULT_Q``) assume 100 Hz sensors with RotorPy's
default IMU and motion-capture noise densities (e.g. accelerometer 0.038 m/s^2/sqrt(Hz) gives
0.27 m/s^2 at 100 Hz).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from windnav._validate import batch_array, positive_float, positive_int
from windnav.estimate import wind_model as wm
from windnav.estimate.conditions import UKFConditions, ukf_conditions
from windnav.estimate.hardware import OdometryAccel
from windnav.estimate.layout import (
    IDX_EULER,
    IDX_RATES,
    IDX_ROTORS,
    IDX_VELOCITY,
    IDX_WIND,
    N_BASE,
    ODOM_EULER,
    ODOM_VELOCITY,
)
from windnav.estimate.ukf import UKF, merwe_weights, robust_cholesky
from windnav.vehicle.params import GRAVITY, MultirotorParams

__all__ = ["DEFAULT_Q", "DEFAULT_R", "WindEstimate", "WindUKF", "check_noise", "sensor_range",
           "wind_world"]

DEFAULT_R = {
    "accel": 0.3,          # m/s^2, per axis
    "gyro": 0.07,          # rad/s
    "odom_velocity": 0.035,  # m/s
    "odom_euler": 0.005,   # rad
    "rotor_speeds": 10.0,  # rad/s
}
"""Default measurement noise standard deviations at 100 Hz."""

DEFAULT_Q = {
    "euler": 0.01,         # rad/sqrt(s): kinematics are exact, only rate errors leak in
    "rates": 5.0,          # rad/s/sqrt(s): unmodelled torques (rates are a random walk)
    "velocity": 0.3,       # m/s/sqrt(s): model error of the force model
    "wind": 0.5,           # m/s/sqrt(s): wind random walk (gusts)
    "rotor_speeds": 20.0,  # rad/s/sqrt(s): motor model error
}
"""Default process-noise densities: per-step variance is ``q**2 * dt``."""

_P0 = {"euler": 0.1, "rates": 0.2, "velocity": 0.5, "wind": 3.0, "rotor_speeds": 50.0}
_GROUPS = (("euler", IDX_EULER), ("rates", IDX_RATES), ("velocity", IDX_VELOCITY),
           ("wind", IDX_WIND), ("rotor_speeds", IDX_ROTORS))
_WIND_WEIGHTS = merwe_weights(6, 1.0, 2.0, 0.0)


@dataclass(frozen=True)
class WindEstimate:
    """What :meth:`WindUKF.step` returns.

    Attributes
    ----------
    wind_world : ndarray of shape (3,)
        Wind velocity, world frame, m/s.
    wind_world_cov : ndarray of shape (3, 3)
        Its covariance, (m/s)^2.
    x : ndarray of shape (12 + N,)
        Filter state (see :mod:`windnav.estimate.wind_model`).
    P : ndarray of shape (12 + N, 12 + N)
        Filter covariance.
    """

    wind_world: np.ndarray
    wind_world_cov: np.ndarray
    x: np.ndarray
    P: np.ndarray

    @property
    def wind_body(self) -> np.ndarray:
        """Wind in body axes, m/s (3,)."""
        return self.x[IDX_WIND]


def wind_world(x: np.ndarray, P: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """World-frame wind ``R(psi, theta, phi) w_b`` and its covariance by unscented transform.

    Parameters
    ----------
    x : ndarray of shape (12 + N,)
    P : ndarray of shape (12 + N, 12 + N)

    Returns
    -------
    mean : ndarray of shape (3,)
        m/s, world frame.
    cov : ndarray of shape (3, 3)
        (m/s)^2.

    Raises
    ------
    ValueError
        On ``x`` shorter than 12 + 1 or a ``P`` of another shape than ``x``'s square.
    """
    x = np.asarray(x, dtype=np.float64)
    P = np.asarray(P, dtype=np.float64)
    if x.ndim != 1 or x.size <= N_BASE or P.shape != (x.size, x.size):
        raise ValueError(f"The 'x' and 'P' parameters of wind_world must have shapes (12 + N,) "
                         f"and (12 + N, 12 + N), N >= 1. Got {x.shape} and {P.shape} instead.")
    w = _WIND_WEIGHTS
    mean, cov, ok = wm._wind_world_ut(x, P, w.wm, w.wc, w.scale)
    if ok:
        return mean, cov
    # the (euler, wind) marginal lost positive definiteness: repair it, same transform
    idx = wm._WIND_MARGINAL
    L, _, _ = robust_cholesky(P[np.ix_(idx, idx)])
    return wm._wind_world_sigma(np.ascontiguousarray(x[idx]), np.ascontiguousarray(L), w.wm,
                                w.wc, w.scale)


def sensor_range(params: MultirotorParams) -> dict[str, np.ndarray]:
    """The range of each measurement block, per component: a sample at or beyond it is
    rejected and counted in ``WindUKF.rejected``, as a non-finite one is.

    Far beyond any flight's measurements and a multirotor IMU's full scale (16-32 g, 2000-4000
    deg/s), and well inside what the filter survives (a fresh filter is thrown beyond recovery
    by one accelerometer sample of 1e4 m/s^2, not by 3e3):

    - ``accel``: 1,000 m/s^2 (about 100 g);
    - ``gyro``: 100 rad/s;
    - ``odom``: 1,000 m/s for the velocity, 4 pi rad for the Euler angles;
    - ``rotor_speeds``: 10 x ``params.rotor_speed_max``.
    """
    n = params.n_rotors
    return {"accel": np.full(3, 1000.0), "gyro": np.full(3, 100.0),
            "odom": np.r_[np.full(3, 1000.0), np.full(3, 4.0 * np.pi)],
            "rotor_speeds": np.full(n, 10.0 * float(np.max(params.rotor_speed_max)))}


_R_SIZES = {"accel": 3, "gyro": 3, "odom": 6, "odom_velocity": 3, "odom_euler": 3}
"""Components of each measurement-noise key but ``rotor_speeds`` (one per rotor)."""


def _noise_ok(value, m: int | None) -> bool:
    """Whether ``value`` is a finite standard deviation > 0 (scalar or (m,)) or a finite
    (m, m) covariance; any m where ``m`` is None."""
    try:
        a = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        return False
    if not np.isfinite(a).all():
        return False
    if a.ndim == 2:
        return a.shape[0] == a.shape[1] and m in (None, a.shape[0])
    return (a.ndim == 0 or (a.ndim == 1 and m in (None, a.size))) and bool((a > 0).all())


def check_noise(q=None, r=None, where: str = "WindUKF", *, n_rotors: int | None = None
                ) -> None:
    """Check process- and measurement-noise settings by the rules :class:`WindUKF` takes them
    by (the one place they are written; the Monte-Carlo study checks its own with it).

    Parameters
    ----------
    q : mapping, optional
        Keys of :data:`DEFAULT_Q`; each a finite density >= 0.
    r : mapping, optional
        Keys of :data:`DEFAULT_R` or ``odom``; each a finite standard deviation > 0 (a scalar
        or one per component) or a finite (m, m) covariance.
    where : str
        The caller, named in the message.
    n_rotors : int, optional
        The components of ``r["rotor_speeds"]``; None: any.

    Raises
    ------
    ValueError
        Naming ``q`` or ``r`` and the key (``r['accel']``), on another type, an unknown key or
        a value the filter does not take.
    """
    sizes = {**_R_SIZES, "rotor_speeds": n_rotors}
    for name, value, known in (("q", q, sorted(DEFAULT_Q)),
                               ("r", r, sorted({*DEFAULT_R, "odom"}))):
        if value is None:
            continue
        if not isinstance(value, Mapping):
            raise ValueError(f"The {name!r} parameter of {where} must be a dict with keys among "
                             f"{known}. Got {value!r} instead.")
        unknown = set(value) - set(known)
        if unknown:
            raise ValueError(f"The {name!r} parameter of {where} has unknown keys "
                             f"{sorted(unknown, key=str)}; known: {known}.")
        for key, v in value.items():
            if name == "q":
                try:
                    ok = math.isfinite(float(v)) and float(v) >= 0.0
                except (TypeError, ValueError):
                    ok = False
                rule = "a finite density >= 0"
            else:
                m = sizes[key]
                ok = _noise_ok(v, m)
                rule = ("a finite standard deviation > 0 (a scalar or one per component) or a "
                        "finite square covariance" if m is None else
                        f"a finite standard deviation > 0 (a scalar or ({m},)) or a finite "
                        f"({m}, {m}) covariance")
            if not ok:
                got = np.shape(v) if np.ndim(v) == 2 else v
                raise ValueError(f"The {name!r} parameter of {where} must give "
                                 f"{name}[{key!r}] {rule}. Got "
                                 f"{'shape ' if np.ndim(v) == 2 else ''}{got!r} instead.")


def _noise_cov(value, m: int) -> np.ndarray:
    """A std (scalar or (m,)) or a full (m, m) covariance -> (m, m) covariance (checked by
    :func:`check_noise`)."""
    a = np.asarray(value, dtype=np.float64)
    if a.ndim == 2:
        return a
    std = np.broadcast_to(a, (m,))
    return np.diag(std**2)


_OPTION_DEFAULTS = {"alpha": 1.0, "beta": 2.0, "kappa": 0.0, "wind_frame": "world",
                    "accel_from_odometry": False}


def _resolve_options(conditions, q, r, rate_hz: float = 100.0, **given
                     ) -> tuple[dict, dict, dict]:
    """``(q, r, options)``: the conditions' filter settings (if any) for sensors at
    ``rate_hz`` under the explicit arguments (``q``, ``r`` key by key; options not None), then
    the filter's defaults."""
    preset = ({} if conditions is None
              else ukf_conditions(conditions).filter_options(rate_hz))
    q = {**preset.get("q", {}), **(q or {})}
    r = {**preset.get("r", {}), **(r or {})}
    opt = {k: v if v is not None else preset.get(k, _OPTION_DEFAULTS[k])
           for k, v in given.items()}
    return q, r, opt


def _process_model(X, dt, u, *, prm, nsub):
    """The filter's process model (:func:`windnav.estimate.wind_model._process`)."""
    return wm._process(X, dt, u, prm, nsub)


def _accel_model(X, *, prm):
    """Specific force (S, 3) of the sigma points."""
    return wm._specific_force(X, prm)


def _gyro_model(X):
    """Body rates (S, 3) of the sigma points."""
    return X[:, IDX_RATES]


def _rotor_model(X):
    """Rotor speeds (S, N) of the sigma points."""
    return X[:, IDX_ROTORS]


class WindUKF:
    """Wind estimator of the thesis: a 12 + N state UKF over the multirotor force model.

    Parameters
    ----------
    params : MultirotorParams
        Vehicle (mass, thrust and drag coefficients, motor time constant).
    dt : float
        Filter step (one ``step`` call), s. Default 0.01 (100 Hz).
    q : mapping, optional
        Process-noise densities overriding :data:`DEFAULT_Q` (keys ``euler``, ``rates``,
        ``velocity``, ``wind``, ``rotor_speeds``); per-step variance ``q**2 dt``.
    r : mapping, optional
        Measurement noise overriding :data:`DEFAULT_R` per block: ``accel``, ``gyro``,
        ``rotor_speeds`` (std scalar, std per component, or full covariance); ``odom`` (full
        (6, 6) covariance or std (6,)), or its parts ``odom_velocity`` and ``odom_euler``.
    x0 : array_like of shape (12 + N,), optional
        Initial state; default level hover at rest in still air.
    P0 : array_like of shape (12 + N, 12 + N), optional
        Initial covariance; default diagonal (0.1 rad, 0.2 rad/s, 0.5 m/s, 3 m/s, 50 rad/s).
    accel_from_odometry : bool or OdometryAccel, optional
        Form the accelerometer measurement from differenced odometry (see module docstring);
        an :class:`~windnav.estimate.hardware.OdometryAccel` adds the hardware's clamp and
        low-pass. Default False (or the conditions'). Differenced odometry is fused with the
        noise of the module docstring unless ``r["accel"]`` is given here, or by conditions
        whose acceleration is differenced odometry; an IMU preset's accelerometer noise does
        not apply to it.
    n_substeps : int
        RK4 steps per ``dt``.
    wind_frame : {"world", "body"}, optional
        Random-walk frame of the wind: "world" (default, as in :func:`run_wind_ukf`:
        ``w_b' = -Omega x w_b``, the wind is fixed in the world while the body turns) or "body"
        (``w_b' = 0``, the thesis model); see :func:`windnav.estimate.wind_model.model_constants`.
    alpha, beta, kappa : float, optional
        Sigma-point parameters; default 1, 2, 0 (or the conditions').
    conditions : str or UKFConditions, optional
        A preset whose filter settings are the defaults of the arguments above (see the module
        docstring), for sensors sampled once per step (``1 / dt``:
        :meth:`~windnav.estimate.UKFConditions.filter_options`); None: windnav's defaults
        (:data:`DEFAULT_Q`, :data:`DEFAULT_R`).

    Examples
    --------
    >>> ukf = WindUKF(wn.vehicle.params("hummingbird"), dt=0.01)
    >>> est = ukf.step(u_cmd, {"accel": a, "gyro": w, "odom": np.r_[v_world, euler]})
    >>> est.wind_world, est.wind_world_cov
    """

    def __init__(self, params: MultirotorParams, dt: float = 0.01, *,
                 q: Mapping[str, float] | None = None, r: Mapping | None = None,
                 x0=None, P0=None, accel_from_odometry: bool | OdometryAccel | None = None,
                 n_substeps: int = 1, wind_frame: str | None = None,
                 alpha: float | None = None, beta: float | None = None,
                 kappa: float | None = None,
                 conditions: str | UKFConditions | None = None):
        where = "WindUKF"
        if not isinstance(params, MultirotorParams):
            raise ValueError(f"The 'params' parameter of {where} must be a MultirotorParams. "
                             f"Got {type(params).__name__} instead.")
        # an accelerometer noise given here, or by conditions whose acceleration is itself
        # differenced odometry, is that measurement's; an IMU preset's is not (with
        # accel_from_odometry=True it made the 'windnav' preset fuse differenced velocity as a
        # 0.1 m/s^2 measurement: 2.9 m/s of wind error and a NEES of 574; audit, 2026-12-05)
        accel_noise_given = "accel" in (r or {}) or (
            conditions is not None and ukf_conditions(conditions).accel != "imu")
        # one step per sample of the sensors: the conditions' noise at that rate
        q, r, opt = _resolve_options(conditions, q, r,
                                     1.0 / positive_float(dt, "dt", where), alpha=alpha,
                                     beta=beta, kappa=kappa, wind_frame=wind_frame,
                                     accel_from_odometry=accel_from_odometry)
        alpha, beta, kappa, wind_frame = (opt[k] for k in ("alpha", "beta", "kappa",
                                                             "wind_frame"))
        self.params = params
        self.dt = positive_float(dt, "dt", where)
        self.n_substeps = positive_int(n_substeps, "n_substeps", where)
        chain = opt["accel_from_odometry"]
        if not isinstance(chain, (bool, np.bool_, OdometryAccel)):
            raise ValueError(f"The 'accel_from_odometry' parameter of {where} must be a bool or "
                             f"an OdometryAccel. Got {chain!r} instead.")
        self.odometry_accel = chain if isinstance(chain, OdometryAccel) else None
        self.accel_from_odometry = self.odometry_accel is not None or bool(chain)
        N = params.n_rotors
        n = N_BASE + N
        self._prm = wm.model_constants(params, wind_frame=wind_frame)
        self.wind_frame = wind_frame
        self._u_lo, self._u_hi = params.rotor_speed_min, params.rotor_speed_max

        q = {**DEFAULT_Q, **q}
        check_noise(q, r, where, n_rotors=N)
        qd = np.empty(n)
        for key, sl in _GROUPS:
            qd[sl] = float(q[key]) ** 2 * self.dt
        self.Q = np.diag(qd)

        if x0 is None:
            x0 = np.zeros(n)
            x0[IDX_ROTORS] = params.hover_rotor_speed
        x0 = batch_array(x0, "x0", where, (n,))[0]
        if P0 is None:
            p0 = np.empty(n)
            for key, sl in _GROUPS:
                p0[sl] = _P0[key] ** 2
            P0 = np.diag(p0)
        self.R = self._measurement_covs(r, N)
        # module-level functions bound by partial, not closures: the filter pickles (spawned
        # workers, ProcessPoolExecutor; audit, thirty-seventh session)
        fx = functools.partial(_process_model, prm=self._prm, nsub=self.n_substeps)
        h_accel = functools.partial(_accel_model, prm=self._prm)
        h_gyro, h_rotor = _gyro_model, _rotor_model
        limit = sensor_range(params)
        blocks = {
            "accel": (h_accel, self.R["accel"], (), limit["accel"]),
            "gyro": (h_gyro, self.R["gyro"], (), limit["gyro"]),
            "odom": (wm._odometry, self.R["odom"], np.arange(6)[ODOM_EULER], limit["odom"]),
            "rotor_speeds": (h_rotor, self.R["rotor_speeds"], (), limit["rotor_speeds"]),
        }
        self.ukf = UKF(fx, x0, P0, self.Q, dt=self.dt, blocks=blocks, alpha=alpha, beta=beta,
                       kappa=kappa)
        self._last_odom: np.ndarray | None = None
        self._steps_since_odom = 0
        self._accel_lp: np.ndarray | None = None  # output of the hardware chain
        self._r_accel_override = accel_noise_given or self.odometry_accel is not None
        # std of differenced odometry velocity times the interval: sqrt(2) sigma_v, m/s
        self._diff_std_dt = np.sqrt(2.0) * np.sqrt(np.diag(self.R["odom"])[ODOM_VELOCITY])

    def _measurement_covs(self, r: Mapping, N: int) -> dict[str, np.ndarray]:
        """The blocks' noise covariances from ``r`` (checked by :func:`check_noise`)."""
        rr = {**DEFAULT_R, **r}
        out = {
            "accel": _noise_cov(rr["accel"], 3),
            "gyro": _noise_cov(rr["gyro"], 3),
            "rotor_speeds": _noise_cov(rr["rotor_speeds"], N),
        }
        if "odom" in r:
            out["odom"] = _noise_cov(r["odom"], 6)
        else:
            v = _noise_cov(rr["odom_velocity"], 3)
            e = _noise_cov(rr["odom_euler"], 3)
            out["odom"] = np.block([[v, np.zeros((3, 3))], [np.zeros((3, 3)), e]])
        return out

    # State accessors ----------------------------------------------------------------------
    @property
    def x(self) -> np.ndarray:
        """Filter state (12 + N,)."""
        return self.ukf.x

    @property
    def P(self) -> np.ndarray:
        """Filter covariance (12 + N, 12 + N)."""
        return self.ukf.P

    @property
    def rejected(self) -> dict[str, int]:
        """Measurements rejected (non-finite, or beyond :func:`sensor_range`), per block."""
        return self.ukf.rejected

    @property
    def repairs(self) -> int:
        """Covariance repairs (loss of positive definiteness) so far."""
        return self.ukf.repairs

    def estimate(self) -> WindEstimate:
        """The current estimate, with the wind rotated to the world frame."""
        w, C = wind_world(self.ukf.x, self.ukf.P)
        return WindEstimate(w, C, self.ukf.x.copy(), self.ukf.P.copy())

    def _accel_from_odom(self, odom: np.ndarray):
        """Specific force (3,) from the previous and this odometry sample and its noise
        covariance (3, 3) for this step (None to keep the registered one); ``(None, None)`` at
        the first sample. The noise follows the interval between the samples, so it is built
        per call rather than written into the filter's blocks."""
        last, self._last_odom = self._last_odom, odom
        steps, self._steps_since_odom = self._steps_since_odom, 0
        chain = self.odometry_accel
        if last is None:
            if chain is not None:
                self._accel_lp = chain.initial(odom[ODOM_EULER])
            return None, None
        dt = steps * self.dt
        if chain is not None:
            self._accel_lp = chain.step(self._accel_lp, last[ODOM_VELOCITY],
                                        odom[ODOM_VELOCITY], odom[ODOM_EULER], dt)
            return self._accel_lp.copy(), None
        a_world = (odom[ODOM_VELOCITY] - last[ODOM_VELOCITY]) / dt
        a_world[2] += GRAVITY
        Rm = wm.euler_to_matrix(odom[ODOM_EULER])[0]
        noise = None if self._r_accel_override else np.diag((self._diff_std_dt / dt) ** 2)
        return Rm.T @ a_world, noise

    def step(self, u_cmd, measurements: Mapping[str, np.ndarray | None]) -> WindEstimate:
        """Predict over ``dt`` with the commanded rotor speeds, then fuse the measurements.

        Parameters
        ----------
        u_cmd : array_like of shape (N,)
            Commanded rotor speeds, rad/s (clipped to the vehicle's range).
        measurements : mapping of str to array_like or None
            Any of ``accel`` (3,), ``gyro`` (3,), ``odom`` (6,), ``rotor_speeds`` (N,); absent
            or None blocks are skipped, non-finite ones and ones beyond the sensor's range
            (:func:`sensor_range`) are rejected and counted in ``rejected``. With
            ``accel_from_odometry`` an ``accel`` entry is ignored.

        Returns
        -------
        WindEstimate
        """
        N = self.params.n_rotors
        u = u_cmd
        if not (type(u) is np.ndarray and u.dtype == np.float64 and u.shape == (N,)
                and np.isfinite(u).all()):  # the checks of batch_array, without its cost
            u = batch_array(u_cmd, "u_cmd", "WindUKF.step", (N,), batch=1)[0]
        if not isinstance(measurements, Mapping):
            raise ValueError("The 'measurements' parameter of WindUKF.step must be a mapping of "
                             f"block name to array (or None). Got {type(measurements).__name__} "
                             "instead.")
        u = np.minimum(np.maximum(u, self._u_lo), self._u_hi)  # np.clip, without its wrapper
        self.ukf.predict(self.dt, u)
        self._steps_since_odom += 1
        meas = dict(measurements)
        noise = {}
        if self.accel_from_odometry:
            meas.pop("accel", None)
            odom = meas.get("odom")
            if odom is not None:
                # a copy: the next step differences against it, and a caller may refill
                # one buffer every step
                odom = np.array(odom, dtype=np.float64)
                if odom.shape == (6,) and np.isfinite(odom).all():
                    meas["accel"], r_accel = self._accel_from_odom(odom)
                    if r_accel is not None:
                        noise["accel"] = r_accel
        self.ukf.update(meas, noise)
        return self.estimate()
