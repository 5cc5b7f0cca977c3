"""The onboard wind stack of EA-MPPI+Ŵ: the Wind UKF on simulated sensors feeds the decoder.

The navigation variant ``ea-mppi-w-hat`` (:data:`windnav.plan.VARIANTS`, issue 11) flies
EA-MPPI+W's planner (``Q_E = 5``) but replaces the ground-truth mean wind inside ``L_t`` by what
the vehicle could know on board (Folk 2026, ch. 4-6):

* **Wind UKF, at the control rate (100 Hz).** At every control step the sensors of the
  conditions preset (default ``"thesis"``, :func:`windnav.estimate.ukf_conditions`: RotorPy's
  IMU arithmetic with the accelerometer density 0.38^2, 1.02 m/s^2 per sample at 100 Hz, motion
  capture, rotor-speed pseudo-measurements with 10 rad/s noise) are sampled from the true 6-DoF
  state: ``accel`` the specific force of the dynamics at the true state and wind (body axes),
  ``gyro`` the body rates, ``odom`` the world velocity and the ZYX Euler angles of the measured
  attitude, ``rotor_speeds`` the command held over the last step. The filter predicts over
  ``1 / control_rate_hz`` with that command and fuses them, exactly the alignment of
  :func:`windnav.estimate.run_wind_ukf` (the same filter, online). It starts at the first step
  from the first odometry sample (attitude, body velocity), the rotor speeds of the hover the
  flight starts in, and zero wind. The filter believes the vehicle of the conditions: drag
  ``k_d, k_z`` from the calibration flights of :func:`windnav.experiments.calibration.calibrate`
  (flown once per vehicle and preset, seed :data:`CALIBRATION_SEED`), no parasitic drag, true
  mass and thrust coefficients (:func:`windnav.experiments.ukf_conditions.believed_params`).
* **Decoder, 50 Hz.** Every ``control_rate_hz / decoder_rate_hz`` control steps a fresh LiDAR
  scan (360 rays, 0.25-100 m, range noise ``scan_noise`` = 0.35 m on returns: the noise the
  decoder was trained with, :data:`windnav.predict.SCAN_NOISE`; the planner's own 10 Hz scan,
  0.14 m, is unchanged) goes into :meth:`windnav.predict.Decoder.predict` with
  ``W_up = speed [cos d, sin d]`` (the inlet wind) and ``W_robot`` = the UKF's horizontal
  world-frame estimate (with ``wrobot_tau_s > 0``, our option beyond the thesis, its
  exponential average over the flight, :func:`smooth_wind`: the decoder was trained with the
  mean wind at the robot, the UKF tracks the instantaneous one). The field ``(2, H, H)``
  (H = 25 cells of 1 m) is centred on the vehicle
  at the decode time. Only a planner update reads the field, so by default a decode is
  computed when one reads it (its scan noise drawn at its own time, in order): the decodes no
  update reads, 4 of 5 at these rates, are not computed, and the flight is the same to the
  bit as with every decode computed (``OnboardOptions.decode_all``; 28 % less wall time per
  flight over the thesis suite, 2026-12-04).
* **Planner, 10 Hz.** The planner's :class:`~windnav.plan.LocalWind` is the latest field, its
  cell-centre offsets shifted to the vehicle's position at the planning time (the decoder runs
  first on a step where both are due, so with the default rates the shift is 0). The window
  ``L_t`` is the decoder's grid, side ``H Delta = 25`` m; outside it the planner knows no wind,
  as the ``-w`` variants outside ``L_t`` with ``H = 25`` (or, with ``outside="robot"``, our
  option beyond the thesis, the uniform ``W_robot`` the decoder was given). When the UKF's
  estimate is not finite the decoder is skipped and the field is NaN (counted in
  ``decoder_skipped``); a field that is not finite reaches the planner as it is, which brakes
  and counts a ``"wind"`` fallback (nothing raises in the loop).

Timing (the thesis's chapter-6 profiling): the wall time of every UKF step (predict, update and
the world-frame wind), decoder prediction (every computed one), planner update and control
step (SE(3) acceleration mode and the rotor-speed clip) is measured with
:func:`time.perf_counter`; the simulated sensors
and LiDAR ray casting are the simulated world, not onboard work, and are not counted. The loop
keeps real time on one core when the sum of the per-second stage costs
``sum_s rate_s * median_s`` is below 1 s per s (:attr:`OnboardReport.real_time_fraction`).

Randomness: the stack spawns its own streams from the flight's generator after the planner's
and the LiDAR's (sensor noise, decoder scans, believed-parameter errors), so the other variants'
draws are unchanged and the same seed gives the same flight.

Limits: the sensors are sampled one step at a time, so IMU bias random walks are not carried;
presets whose IMU has one, or whose rotor speeds pass through a PWM chain, are refused
(``"thesis"`` and ``"thesis-0.038"`` qualify).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, fields
from functools import lru_cache

import numpy as np
from scipy.spatial.transform import Rotation

try:  # SciPy's compiled backend of Rotation (pinned SciPy; the public class otherwise)
    from scipy.spatial.transform import _rotation_cy as _ROTATION_CY
except ImportError:  # pragma: no cover
    _ROTATION_CY = None

from windnav._validate import positive_float
from windnav.predict.dataset import SCAN_MAX, SCAN_MIN, SCAN_NOISE
from windnav.sensors._kernels import N_NORMALS, NormalStream, imu_odometry_sample

__all__ = [
    "CALIBRATION_SEED",
    "ONBOARD_CONDITIONS",
    "OnboardOptions",
    "OnboardReport",
    "OnboardStack",
    "STAGES",
    "default_decoder",
    "smooth_wind",
]

ONBOARD_CONDITIONS = "thesis"
"""The Wind UKF conditions preset of the onboard stack (thesis-level noise)."""

CALIBRATION_SEED = 0
"""Seed of the drag calibration flights (flown once per vehicle and conditions)."""

STAGES = ("ukf", "decoder", "planner", "control")
"""The timed onboard stages."""

_WHERE = "OnboardOptions"
OUTSIDE = ("zero", "robot")
"""The planner's wind outside the decoder's window (:attr:`OnboardOptions.outside`)."""


@dataclass(frozen=True)
class OnboardOptions:
    """Settings of the onboard stack.

    Attributes
    ----------
    conditions : str or UKFConditions
        Wind UKF conditions preset (:data:`windnav.estimate.CONDITIONS`), default ``"thesis"``;
        its IMU must have no bias random walk and its rotor speeds be the commands.
    decoder_rate_hz : float
        Decoder rate, Hz (> 0; a whole number of control steps per prediction), default 50.
    scan_noise : float
        Range noise of the decoder's LiDAR scans, m (>= 0), default 0.35
        (:data:`windnav.predict.SCAN_NOISE`, the noise the decoder was trained with).
    settle_s : float
        Start of the flight left out of the UKF's RMS error, s (>= 0), default 2.
    outside : {"zero", "robot"}
        The planner's wind outside the decoder's window: ``"zero"`` (default, the thesis's
        ``L_t``) or ``"robot"``, the ``W_robot`` the decoder was given (the UKF's horizontal
        estimate at the last prediction), uniform: the Local baseline beyond the field.
    wrobot_tau_s : float
        Time constant of the exponential average of the UKF's horizontal estimate that is given
        as ``W_robot``, s (>= 0; :func:`smooth_wind` at the UKF's rate). Default 0: the
        estimate itself, the thesis's. Ours: the decoder is trained with the *mean* wind at the
        robot, and the UKF tracks the instantaneous wind, which in the benchmark's unsteady
        urban flows is several m/s from the mean (``windnav nav-study inflight``).
    decode_all : bool
        Scan and decode at every decode time (at ``decoder_rate_hz``), as the hardware would.
        Default False: a decode is computed when a planner update reads its field, and a
        decode that no update reads (4 of 5 at the simulation rates) is not computed. Its
        scan noise is drawn at its time either way, so the flights are the same to the bit;
        only the ``decoder`` stage's timed samples differ (``stage_updates``).
    """

    conditions: object = ONBOARD_CONDITIONS
    decoder_rate_hz: float = 50.0
    scan_noise: float = SCAN_NOISE
    settle_s: float = 2.0
    outside: str = "zero"
    wrobot_tau_s: float = 0.0
    decode_all: bool = False

    def __post_init__(self):
        from windnav.estimate import CONDITIONS, ukf_conditions

        try:
            cond = ukf_conditions(self.conditions)
        except ValueError:
            raise ValueError(f"The 'conditions' parameter of {_WHERE} must be one of "
                             f"{sorted(CONDITIONS)} or a UKFConditions. Got "
                             f"{self.conditions!r} instead.") from None
        imu = cond.sensor_suite(100.0).imu
        walk = 0.0 if imu is None else max(imu.accel_bias_walk, imu.gyro_bias_walk)
        if imu is None or walk > 0.0 or cond.rotor_speeds != "command":
            raise ValueError(f"The 'conditions' parameter of {_WHERE} must name a preset with an "
                             "IMU without bias random walk and rotor speeds from the commands "
                             f"(e.g. 'thesis'). Got {cond.name!r} instead.")
        object.__setattr__(self, "conditions", cond)
        object.__setattr__(self, "decoder_rate_hz",
                           positive_float(self.decoder_rate_hz, "decoder_rate_hz", _WHERE))
        object.__setattr__(self, "scan_noise",
                           positive_float(self.scan_noise, "scan_noise", _WHERE, allow_zero=True))
        object.__setattr__(self, "settle_s",
                           positive_float(self.settle_s, "settle_s", _WHERE, allow_zero=True))
        if self.outside not in OUTSIDE:
            raise ValueError(f"The 'outside' parameter of {_WHERE} must be one of {OUTSIDE}. "
                             f"Got {self.outside!r} instead.")
        object.__setattr__(self, "wrobot_tau_s", positive_float(  # finite, >= 0
            self.wrobot_tau_s, "wrobot_tau_s", _WHERE, allow_zero=True))
        if not isinstance(self.decode_all, (bool, np.bool_)):
            raise ValueError(f"The 'decode_all' parameter of {_WHERE} must be a bool. Got "
                             f"{self.decode_all!r} instead.")
        object.__setattr__(self, "decode_all", bool(self.decode_all))

    @classmethod
    def coerce(cls, value, where: str) -> OnboardOptions:
        """``value`` as options: None (defaults), a dict of fields, or OnboardOptions."""
        if value is None:
            return cls()
        if isinstance(value, cls):
            return value
        if isinstance(value, dict):
            unknown = sorted(set(value) - {f.name for f in fields(cls)})
            if unknown:
                raise ValueError(f"The 'onboard' parameter of {where} must hold fields of "
                                 f"OnboardOptions {[f.name for f in fields(cls)]}. Got "
                                 f"{unknown} instead.")
            return cls(**value)
        raise ValueError(f"The 'onboard' parameter of {where} must be None, a dict or "
                         f"OnboardOptions. Got {type(value).__name__} instead.")


def _smoothing_gain(dt: float, tau_s: float) -> float:
    """The gain ``a = 1 - exp(-dt / tau_s)`` of :func:`smooth_wind` (1 for ``tau_s = 0``)."""
    return -math.expm1(-dt / tau_s) if tau_s > 0.0 else 1.0


def smooth_wind(wind: np.ndarray, dt: float, tau_s: float) -> np.ndarray:
    """Exponential moving average of a wind time series, the onboard stack's ``W_robot``.

    ``m_0 = w_0`` and ``m_k = m_(k-1) + a (w_k - m_(k-1))`` with ``a = 1 - exp(-dt / tau_s)``:
    a first-order low-pass of time constant ``tau_s``. A sample that is not finite (a diverged
    filter) gives NaN and restarts the average at the next finite sample.

    Parameters
    ----------
    wind : array_like of shape (T, ...)
        The series along axis 0 (e.g. (T, 2) horizontal winds, m/s).
    dt : float
        Time between samples, s (> 0).
    tau_s : float
        Time constant, s (>= 0; 0 returns a copy of ``wind``).

    Returns
    -------
    ndarray of the shape of ``wind``, float64
    """
    where = "smooth_wind"
    w = np.array(wind, dtype=np.float64)
    step = positive_float(dt, "dt", where)
    tau = positive_float(tau_s, "tau_s", where, allow_zero=True)
    if w.ndim < 1:
        raise ValueError(f"The 'wind' parameter of {where} must be a series along axis 0. "
                         f"Got a {w.ndim}-D array instead.")
    if tau == 0.0 or w.shape[0] == 0:
        return w
    from scipy.signal import lfilter

    a = _smoothing_gain(step, tau)
    ok = np.isfinite(w.reshape(w.shape[0], -1)).all(axis=1)
    out = np.full_like(w, np.nan)
    edges = np.flatnonzero(np.diff(np.r_[0, ok.astype(np.int8), 0]))
    for start, stop in zip(edges[::2], edges[1::2], strict=True):
        run = w[start:stop]
        out[start:stop] = lfilter([a], [1.0, a - 1.0], run, axis=0,
                                  zi=((1.0 - a) * run[:1]))[0]
    return out


@lru_cache(maxsize=1)
def default_decoder():
    """The shipped wind flow decoder (:func:`windnav.predict.load_decoder`), loaded once."""
    from windnav.predict import load_decoder

    return load_decoder()


_BELIEVED: dict = {}


def _euler_zyx(quat_xyzw: np.ndarray) -> np.ndarray:
    """``Rotation.from_quat(q).as_euler("ZYX")`` of one quaternion (3,), rad: SciPy's own
    compiled conversion, without the array-API wrapper around it (a third of its time)."""
    if _ROTATION_CY is None:
        return Rotation.from_quat(quat_xyzw).as_euler("ZYX")
    q = _ROTATION_CY.from_quat(quat_xyzw[None], normalize=True, copy=True, scalar_first=False)
    return _ROTATION_CY.as_euler(q, "ZYX", degrees=False, suppress_warnings=False)[0]


def _calibrated(params, cond):
    """``params`` with the drag the conditions' calibration flights fit (cached)."""
    if not cond.calibrate:
        return params
    from windnav.experiments.calibration import calibrate
    from windnav.plan.config import _params_key

    # what the calibration depends on, not the conditions' name: a custom UKFConditions named
    # "windnav" with the thesis's sensors read the preset's calibration (cache audit)
    key = (_params_key(params), cond.sensors, bool(cond.parasitic_drag))
    if key not in _BELIEVED:
        _, believed = calibrate(params, rng=CALIBRATION_SEED, sensors=cond.sensor_suite(100.0),
                                parasitic=cond.parasitic_drag)
        while len(_BELIEVED) >= 64:  # the oldest first: bounded in a sweep over vehicles
            del _BELIEVED[next(iter(_BELIEVED))]
        _BELIEVED[key] = believed
    return _BELIEVED[key]


@dataclass(frozen=True)
class OnboardReport:
    """What the onboard stack did during one flight.

    Attributes
    ----------
    wind_estimate : ndarray of shape (T, 3)
        The Wind UKF's world-frame wind at each control step, m/s (NaN where the stack did not
        run: the flight's last step).
    ukf_wind_rms_mps : float
        RMS over ``t >= settle_s`` of ``|w_hat - w|`` (3D), ``w`` the true wind at the
        vehicle, m/s (NaN for a flight shorter than ``settle_s``).
    ukf_wind_rms_xy_mps : float
        The same for the horizontal components (what the decoder is given), m/s.
    stage_ms_median, stage_ms_mean : dict of str to float
        Per update of each of :data:`STAGES`, ms.
    stage_updates : dict of str to int
        Timed updates of each stage (the decoder's: the decodes computed, see
        ``OnboardOptions.decode_all``).
    stage_rate_hz : dict of str to float
        Rate of each stage, Hz.
    real_time_fraction : float
        ``sum_s rate_s * median_s``: onboard compute per second of flight, s/s (< 1: the loop
        keeps real time on one core).
    settings : dict
        Conditions, rates, scan noise, decoder, filter repairs and rejected measurements, and
        ``decoder_due`` / ``decoder_computed``: the decodes due at the decoder's rate and those
        computed (read by a planner update, or all with ``decode_all``).
    drag_model_bias_mps : float
        What the filter's drag model (the conditions' and the calibration's, less the random
        parameter errors) reads too strong an airflow by at the flight's median horizontal
        airspeed after ``settle_s`` (:func:`windnav.estimate.drag_model_bias`), m/s; NaN when
        the airspeed was not given.
    median_airspeed_mps : float
        That airspeed, m/s.
    """

    wind_estimate: np.ndarray
    ukf_wind_rms_mps: float
    ukf_wind_rms_xy_mps: float
    stage_ms_median: dict
    stage_ms_mean: dict
    stage_updates: dict
    stage_rate_hz: dict
    real_time_fraction: float
    settings: dict
    drag_model_bias_mps: float = math.nan
    median_airspeed_mps: float = math.nan

    def summary(self) -> dict:
        """The scalars, JSON-ready (merged into :meth:`NavigationResult.summary`)."""
        return {"ukf_drag_model_bias_mps": self.drag_model_bias_mps,
                "ukf_median_airspeed_mps": self.median_airspeed_mps,
                "stage_ms_median": dict(self.stage_ms_median),
                "stage_ms_mean": dict(self.stage_ms_mean),
                "stage_updates": dict(self.stage_updates),
                "stage_rate_hz": dict(self.stage_rate_hz),
                "real_time_fraction": self.real_time_fraction,
                "ukf_wind_rms_mps": self.ukf_wind_rms_mps,
                "ukf_wind_rms_xy_mps": self.ukf_wind_rms_xy_mps,
                "onboard": dict(self.settings)}


class OnboardStack:
    """Wind UKF on simulated sensors and the decoder, stepped by the navigation loop.

    Parameters
    ----------
    city : windnav.city.City
        The map the LiDAR scans.
    model : windnav.vehicle.Multirotor
        The simulated vehicle (its dynamics give the accelerometer's specific force).
    params : MultirotorParams
        Its parameters (the filter believes their calibrated version).
    speed, direction_deg : float
        Inlet wind, m/s and degrees counter-clockwise from +x: ``W_up``.
    control_rate_hz, plan_rate_hz : float
        Rates of the loop, Hz (the UKF steps at the control rate).
    n_max : int
        Most control steps of the flight.
    rng : numpy.random.Generator
        The flight's generator; the stack spawns its streams from it.
    decoder : object, optional
        ``offsets`` (H,), ``predict(scans, w_up, w_robot) -> (B, 2, H, H)``; default
        :func:`default_decoder`.
    options : OnboardOptions, optional
    """

    def __init__(self, city, model, params, *, speed: float, direction_deg: float,
                 control_rate_hz: float, plan_rate_hz: float, n_max: int, rng,
                 decoder=None, options: OnboardOptions | None = None):
        from windnav.estimate import WindUKF
        from windnav.experiments.ukf_conditions import believed_model, believed_params

        where = "navigate"
        opt = OnboardOptions() if options is None else options
        self.options = opt
        self.decoder = default_decoder() if decoder is None else decoder
        offsets = np.array(getattr(self.decoder, "offsets", None), dtype=np.float64)  # its own
        if offsets.ndim != 1 or offsets.size < 2 or not hasattr(self.decoder, "predict"):
            raise ValueError(f"The 'decoder' parameter of {where} must have 1-D offsets of at "
                             "least 2 cell centres and a predict(scans, w_up, w_robot) method. "
                             f"Got {type(self.decoder).__name__} instead.")
        self.offsets = offsets
        self.n_rays = int(getattr(self.decoder, "n_rays", 360))
        spacing = float(offsets[1] - offsets[0])
        self.window = float(offsets[-1] - offsets[0] + spacing)
        """Side of the decoder's grid, m (the window ``L_t`` of the variant)."""
        ratio = control_rate_hz / opt.decoder_rate_hz
        self.decode_every = int(round(ratio))
        if self.decode_every < 1 or abs(ratio - self.decode_every) > 1e-9 * ratio:
            raise ValueError(f"The 'decoder_rate_hz' parameter of {where} must divide "
                             f"control_rate_hz={control_rate_hz:g}. Got {opt.decoder_rate_hz!r} "
                             "instead.")
        self.rates = {"ukf": float(control_rate_hz), "decoder": float(opt.decoder_rate_hz),
                      "planner": float(plan_rate_hz), "control": float(control_rate_hz)}
        cond = opt.conditions
        self.sensors = cond.sensor_suite(control_rate_hz)
        self.sensor_rng, self.scan_rng, param_rng = rng.spawn(3)
        believed, errors = believed_params(_calibrated(params, cond), cond, rng=param_rng)
        self.believed = believed
        self.true_params = params
        # what the filter's model leaves out by design, without the drawn errors
        self.believed_model = believed_model(_calibrated(params, cond), cond)
        self.parameter_errors = errors
        self.city, self.model = city, model
        self.n_rotors = model.n_rotors
        d = math.radians(direction_deg)
        self.w_up = np.array([[speed * math.cos(d), speed * math.sin(d)]])
        self.dt = 1.0 / control_rate_hz
        self._ukf_cls = WindUKF
        self.ukf = None
        self.wind_est = np.full((n_max, 3), np.nan)
        self.wind_true = np.full((n_max, 3), np.nan)
        self.field = None
        self.centre = np.zeros(2)
        self.fill = (0.0, 0.0)  # the planner's wind outside the window (options.outside)
        # W_robot: the UKF's horizontal estimate, averaged (options.wrobot_tau_s; smooth_wind)
        self._w_gain = _smoothing_gain(self.dt, opt.wrobot_tau_s)
        self._w_robot = np.full(2, np.nan)
        self.skipped = 0
        self.ticks = 0  # decodes due (at decoder_rate_hz)
        self._due = None  # (pos_xy, w_robot, normals) of a due decode not computed yet
        self.ms = {s: [] for s in STAGES}
        self._com = np.zeros((1, 3))
        # every hub sees the centre-of-mass wind: a (1, N, 3) view of ``_com`` (as the loop)
        c = self._com
        self._hub = np.ndarray((1, self.n_rotors, 3), np.float64, c, 0,
                               (c.strides[0], 0, c.strides[1]))
        self._rotor_lo = float(believed.rotor_speed_min)
        self._rotor_hi = float(believed.rotor_speed_max)
        imu, odo = self.sensors.imu, self.sensors.odometry
        self._normals = NormalStream(self.sensor_rng)
        self._sensor_scales = np.array([imu.accel_std, imu.gyro_std, odo.velocity_std,
                                        odo.attitude_std], dtype=np.float64)
        rotor = self.sensors.rotor_speeds
        self._rotor_measured = rotor is not None and bool(cond.rotor_speed_measurements)
        self._rotor_std = 0.0 if rotor is None else float(rotor.noise_std)

    # ------------------------------------------------------------------------ sensors
    def _measure(self, x: np.ndarray, wind_com: np.ndarray, cmd_prev) -> tuple[dict, np.ndarray]:
        """The conditions' sensors at the true state ``x`` (1, 13 + N): the filter's
        measurement blocks, and the odometry's ZYX Euler angles.

        The values of ``IMU.measure``, ``Odometry.measure`` and ``RotorSpeedSensor.measure``
        with the sensor stream, computed one sample at a time
        (:func:`windnav.sensors._kernels.imu_odometry_sample`; equal to the bit)."""
        from windnav.vehicle import layout

        self._com[0] = wind_com
        sf = self.model.derivatives_packed(x, self._com, self._hub)["specific_force_body"]
        xs = x[0]
        accel, gyro, vel = np.empty(3), np.empty(3), np.empty(3)
        att = np.empty(4)
        imu_odometry_sample(sf[0], xs[layout.BODY_RATES], xs[layout.VELOCITY],
                            xs[layout.ATTITUDE], self._normals.take(N_NORMALS),
                            self._sensor_scales, accel, gyro, vel, att)
        euler = _euler_zyx(att)
        meas = {"accel": accel, "gyro": gyro, "odom": np.concatenate((vel, euler))}
        if cmd_prev is not None and self._rotor_measured:
            cmd = np.array(cmd_prev[0], dtype=np.float64)
            if self._rotor_std != 0.0:  # RotorSpeedSensor.measure: cmd + N(0, std)
                cmd += 0.0 + self._rotor_std * self._normals.take(self.n_rotors)
            meas["rotor_speeds"] = np.minimum(np.maximum(cmd, self._rotor_lo, out=cmd),
                                              self._rotor_hi, out=cmd)
        return meas, euler

    def _start(self, x: np.ndarray, meas: dict, euler: np.ndarray) -> None:
        from windnav.estimate.layout import IDX_EULER, IDX_ROTORS, IDX_VELOCITY, N_BASE
        from windnav.estimate.wind_model import euler_to_matrix
        from windnav.vehicle import layout

        x0 = np.zeros(N_BASE + self.n_rotors)
        x0[IDX_EULER] = euler
        x0[IDX_VELOCITY] = euler_to_matrix(euler)[0].T @ meas["odom"][:3]
        x0[IDX_ROTORS] = x[0, layout.ROTOR_SPEEDS]
        self.ukf = self._ukf_cls(self.believed, self.dt, x0=x0,
                                 conditions=self.options.conditions)

    # --------------------------------------------------------------------------- step
    def step(self, k: int, x: np.ndarray, wind_com: np.ndarray, cmd_prev) -> None:
        """Control step ``k``: sample the sensors and step the UKF; decode when due.

        Parameters
        ----------
        k : int
            Control step (time ``k / control_rate_hz``).
        x : ndarray of shape (1, 13 + N)
            True packed state at that time.
        wind_com : ndarray of shape (3,)
            True wind at the centre of mass, m/s, world.
        cmd_prev : ndarray of shape (1, N) or None
            Rotor-speed command applied over the last step, rad/s (None at ``k = 0``).
        """
        meas, euler = self._measure(x, wind_com, cmd_prev)
        if self.ukf is None:
            self._start(x, meas, euler)
            est = self.ukf.estimate().wind_world
        else:
            t0 = time.perf_counter()
            est = self.ukf.step(cmd_prev[0], meas).wind_world
            self.ms["ukf"].append(1e3 * (time.perf_counter() - t0))
        self.wind_est[k] = est
        self.wind_true[k] = wind_com
        w = self._w_robot
        if not np.isfinite(w).all() or self._w_gain == 1.0:  # (re)start, or no averaging
            w[:] = est[:2]
        else:  # a non-finite estimate makes w NaN: the average restarts at the next finite one
            w += self._w_gain * (est[:2] - w)
        if k % self.decode_every == 0:
            self._decode(x[0, :2].copy(), w.copy())
            if self.options.decode_all and self._due is not None:
                self._decode_due()

    def _decode(self, pos_xy: np.ndarray, w_robot: np.ndarray) -> None:
        """A decode is due at ``pos_xy`` with ``w_robot``: its scan's noise is drawn now, in
        the order of the decode times; the scan and the prediction wait for the planner
        (:meth:`_decode_due`), and a decode no planner update reads is never computed."""
        if self.options.outside == "robot":  # (not finite when the filter diverged, as the field)
            self.fill = (float(w_robot[0]), float(w_robot[1]))
        self.ticks += 1
        if not np.isfinite(w_robot).all():  # a diverged filter: no field, the planner brakes
            self.skipped += 1
            self._due = None
            self.field = np.full((2, self.offsets.size, self.offsets.size), np.nan)
            self.centre = pos_xy
            return
        normals = (self.scan_rng.standard_normal(size=(1, self.n_rays))
                   if self.options.scan_noise > 0.0 else None)
        self._due = (pos_xy, w_robot, normals)

    def _decode_due(self) -> None:
        """Compute the due decode (its scan, then the prediction): its field becomes the
        latest."""
        pos_xy, w_robot, normals = self._due
        self._due = None
        scan = self.city.lidar(pos_xy[None], n_rays=self.n_rays, max_range=SCAN_MAX,
                               min_range=SCAN_MIN, noise_std=self.options.scan_noise,
                               normals=normals)
        t0 = time.perf_counter()
        field = self.decoder.predict(scan, self.w_up, w_robot[None])
        self.ms["decoder"].append(1e3 * (time.perf_counter() - t0))
        self.field = np.asarray(field, dtype=np.float64)[0]
        self.centre = pos_xy

    def local_wind(self, pos_xy: np.ndarray):
        """The latest field as the planner's :class:`~windnav.plan.LocalWind`, offsets relative
        to ``pos_xy`` (m)."""
        from windnav.plan import LocalWind

        if self._due is not None:
            self._decode_due()
        dx, dy = self.centre - pos_xy
        return LocalWind.grid(self.field, self.offsets + dx, self.offsets + dy, fill=self.fill)

    def add_time(self, stage: str, ms: float) -> None:
        """Record ``ms`` (ms) for ``stage`` (the loop times the control and the planner)."""
        self.ms[stage].append(ms)

    # ------------------------------------------------------------------------- report
    def report(self, n: int, planner_ms, airspeed=None) -> OnboardReport:
        """The flight's :class:`OnboardReport` over its ``n`` control steps (``airspeed``:
        the horizontal airspeed at each of them, m/s, for the drag model's bias)."""
        self.ms["planner"] = list(planner_ms)
        est, true = self.wind_est[:n], self.wind_true[:n]
        keep = (np.arange(n) * self.dt >= self.options.settle_s) & np.isfinite(true[:, 0])
        err = est[keep] - true[keep]
        rms = float(np.sqrt(np.mean(np.sum(err**2, axis=1)))) if keep.any() else math.nan
        rms_xy = (float(np.sqrt(np.mean(np.sum(err[:, :2] ** 2, axis=1)))) if keep.any()
                  else math.nan)
        med = {s: float(np.median(v)) if v else math.nan for s, v in self.ms.items()}
        mean = {s: float(np.mean(v)) if v else math.nan for s, v in self.ms.items()}
        load = sum(self.rates[s] * med[s] / 1e3 for s in STAGES if math.isfinite(med[s]))
        cond = self.options.conditions
        settings = {"conditions": cond.name, "scan_noise_m": self.options.scan_noise,
                    "settle_s": self.options.settle_s, "window_m": self.window,
                    "outside": self.options.outside, "wrobot_tau_s": self.options.wrobot_tau_s,
                    "decoder": repr(self.decoder), "calibrated": bool(cond.calibrate),
                    "parameter_errors": dict(self.parameter_errors),
                    "ukf_repairs": 0 if self.ukf is None else int(self.ukf.repairs),
                    "ukf_rejected": {} if self.ukf is None else dict(self.ukf.rejected),
                    "decoder_skipped": self.skipped,
                    "decoder_due": self.ticks, "decoder_computed": len(self.ms["decoder"])}
        bias = median = math.nan
        if airspeed is not None:
            from windnav.estimate import drag_model_bias

            air = np.asarray(airspeed, dtype=np.float64)[:n]
            air = air[(np.arange(air.size) * self.dt >= self.options.settle_s)
                      & np.isfinite(air)]
            if air.size:
                median = float(np.median(air))
                bias = float(drag_model_bias(self.true_params, self.believed_model, median))
        return OnboardReport(
            wind_estimate=est.copy(), ukf_wind_rms_mps=rms, ukf_wind_rms_xy_mps=rms_xy,
            stage_ms_median=med, stage_ms_mean=mean,
            stage_updates={s: len(v) for s, v in self.ms.items()},
            stage_rate_hz=dict(self.rates), real_time_fraction=float(load), settings=settings,
            drag_model_bias_mps=bias, median_airspeed_mps=median)
