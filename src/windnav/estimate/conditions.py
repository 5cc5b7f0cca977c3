"""Conditions of the Wind UKF: the sensing it gets and the filter it runs, as named presets.

A :class:`UKFConditions` bundles what decides how well the filter can do, so that every place
the filter runs (the Monte Carlo, ``windnav fly``, the demo, an onboard stack) can pick the same
conditions by name::

    cond = wn.estimate.ukf_conditions("thesis")
    sensors = cond.sensor_suite(100.0)                 # what the vehicle carries
    track = run_wind_ukf(log, params, conditions=cond)  # what the filter does with it

The presets (:data:`CONDITIONS`; sources and numbers in ``docs/ukf.md``):

``windnav``
    windnav's sensors (accelerometer 0.028 m/s^2 per sample), exact rotor-speed commands as
    pseudo-measurements, the filter models and calibrates parasitic drag, sigma points
    ``alpha = 1, beta = 2, kappa = 0``: the kindest conditions, the study's previous default.
``thesis``, ``thesis-0.038``
    The thesis's Monte Carlo (Folk 2026, ch. 3): RotorPy's sensor arithmetic with the
    accelerometer density 0.38^2 (1.02 m/s^2 per sample at 100 Hz) or 0.038^2 (0.0102), noisy
    rotor-speed pseudo-measurements, a filter without parasitic drag (only ``k_d, k_z``
    calibrated) and its body-frame wind walk, FilterPy sigma points ``alpha = 0.001,
    beta = 2, kappa = -1``.
``hardware``
    The thesis's flights (ch. 6, the author's ROS node): no accelerometer; the specific force
    from differenced motion-capture velocity (:class:`~windnav.estimate.hardware.OdometryAccel`,
    ``R_acc = 3.61``); rotor speeds from PWM and battery voltage through a motor model with
    ``kv_error`` relative error in ``Kv`` as the filter's inputs, no rotor-speed
    pseudo-measurement; every believed parameter off by up to ``parameter_error``; motion
    capture at 100 Hz with realistic noise; no parasitic drag in the filter.

Which parts act where: ``sensors`` (a :mod:`windnav.sensors.presets` name) is the simulated
sensing; ``q, r, alpha, beta, kappa, wind_frame, accel, rotor_speed_measurements`` configure
:class:`~windnav.estimate.WindUKF` and :func:`~windnav.estimate.run_wind_ukf`
(:meth:`UKFConditions.filter_options`); ``parasitic_drag, calibrate, parameter_error,
rotor_speeds, kv_error`` say what the filter is told about the vehicle and its motors, applied
by the harnesses
(:mod:`windnav.experiments.ukf_conditions`).
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from types import MappingProxyType

from windnav._validate import finite_float, positive_float
from windnav.estimate.hardware import OdometryAccel
from windnav.estimate.wind_model import WIND_FRAMES
from windnav.sensors.presets import (
    HARDWARE_MOCAP,
    ROTORPY_ACCEL_DENSITY,
    ROTORPY_ACCEL_DENSITY_NUMPY,
    SENSOR_PRESETS,
    THESIS_ROTOR_SPEED_STD,
    rotorpy_rate_scale,
    sensor_suite,
)

__all__ = ["CONDITIONS", "MODEL_ERROR_FLOOR", "THESIS_SIGMA_POINTS", "UKFConditions",
           "ukf_conditions"]

MODEL_ERROR_FLOOR = 0.1
"""m/s^2: what the filter's force model errs by even with a perfect accelerometer (rotor
lever-arm airspeed, motor lag between commands and speeds, calibration error). The
accelerometer noise ``R`` of a preset is ``hypot(sensor white noise, MODEL_ERROR_FLOOR)``."""

THESIS_SIGMA_POINTS = (0.001, 2.0, -1.0)
"""``(alpha, beta, kappa)`` of the thesis's filter (FilterPy ``MerweScaledSigmaPoints``)."""


def _frozen(mapping) -> MappingProxyType:
    return MappingProxyType(dict(mapping or {}))


@dataclass(frozen=True)
class UKFConditions:
    """The sensing and the filter settings of one Wind UKF configuration.

    Attributes
    ----------
    name : str
    sensors : str
        Sensor preset (:data:`windnav.sensors.presets.SENSOR_PRESETS`).
    q, r : mapping
        Overrides of :data:`~windnav.estimate.DEFAULT_Q` / :data:`~windnav.estimate.DEFAULT_R`
        (process-noise densities; measurement standard deviations).
    alpha, beta, kappa : float
        Sigma-point parameters.
    wind_frame : {"world", "body"}
        Random-walk frame of the wind (see :mod:`windnav.estimate.wind_model`).
    accel : {"imu", "odometry"} or OdometryAccel
        Where the filter's specific force comes from: the accelerometer, plain differenced
        odometry (``WindUKF(accel_from_odometry=True)``), or the hardware chain.
    rotor_speed_measurements : bool
        Fuse the rotor-speed pseudo-measurements (else rotor speeds are inputs only).
    rotor_speeds : {"command", "pwm"}
        What the filter's rotor speeds are made from: the commands, or the commands sent as
        PWM and read back through a motor model whose ``Kv`` errs by up to ``kv_error``.
    parasitic_drag : bool
        The filter models parasitic drag (``c_dx, c_dy, c_dz`` calibrated); else they are 0.
    calibrate : bool
        Drag coefficients come from calibration flights; else from the true values, with
        ``parameter_error``.
    parameter_error : float
        Relative half-width of a uniform error on every believed parameter (mass, ``k_eta``,
        ``k_d``, ``k_z``, ``k_h``, ``tau_m``); 0 for exact.
    kv_error : float
        Relative half-width of a uniform error on the believed ``Kv`` of the PWM motor model;
        0: the filter sees the rotor-speed commands themselves.
    description, source : str
        One line each, for reports (``docs/ukf.md`` has the full sources).
    """

    name: str
    sensors: str = "windnav"
    q: MappingProxyType = field(default_factory=dict)
    r: MappingProxyType = field(default_factory=dict)
    alpha: float = 1.0
    beta: float = 2.0
    kappa: float = 0.0
    wind_frame: str = "world"
    accel: str | OdometryAccel = "imu"
    rotor_speed_measurements: bool = True
    rotor_speeds: str = "command"
    parasitic_drag: bool = True
    calibrate: bool = True
    parameter_error: float = 0.0
    kv_error: float = 0.0
    description: str = ""
    source: str = ""

    def __post_init__(self):
        where = "UKFConditions"
        if self.sensors not in SENSOR_PRESETS:
            raise ValueError(f"The 'sensors' parameter of {where} must be one of "
                             f"{sorted(SENSOR_PRESETS)}. Got {self.sensors!r} instead.")
        object.__setattr__(self, "q", _frozen(self.q))
        object.__setattr__(self, "r", _frozen(self.r))
        positive_float(self.alpha, "alpha", where)
        finite_float(self.beta, "beta", where)
        finite_float(self.kappa, "kappa", where)
        if self.wind_frame not in WIND_FRAMES:
            raise ValueError(f"The 'wind_frame' parameter of {where} must be one of "
                             f"{WIND_FRAMES}. Got {self.wind_frame!r} instead.")
        if not (isinstance(self.accel, OdometryAccel) or self.accel in ("imu", "odometry")):
            raise ValueError(f"The 'accel' parameter of {where} must be 'imu', 'odometry' or an "
                             f"OdometryAccel. Got {self.accel!r} instead.")
        if self.rotor_speeds not in ("command", "pwm"):
            raise ValueError(f"The 'rotor_speeds' parameter of {where} must be 'command' or "
                             f"'pwm'. Got {self.rotor_speeds!r} instead.")
        for name in ("parameter_error", "kv_error"):
            if positive_float(getattr(self, name), name, where, allow_zero=True) >= 1.0:
                raise ValueError(f"The {name!r} parameter of {where} must be below 1 (a "
                                 f"relative error). Got {getattr(self, name)!r} instead.")

    def __hash__(self):
        return hash(json.dumps(self.to_dict(), sort_keys=True))

    def __reduce__(self):  # MappingProxyType does not pickle: rebuild from plain dicts
        return (_rebuild, (self.to_dict(),))

    def sensor_suite(self, rate_hz: float = 100.0):
        """The simulated sensors of these conditions, all at ``rate_hz`` (Hz)."""
        return sensor_suite(self.sensors, rate_hz)

    @property
    def accel_from_odometry(self) -> bool | OdometryAccel:
        """The ``accel_from_odometry`` argument of :class:`~windnav.estimate.WindUKF`."""
        if isinstance(self.accel, OdometryAccel):
            return self.accel
        return self.accel == "odometry"

    @property
    def filter_sensors(self) -> tuple[str, ...]:
        """Logged sensors :func:`~windnav.estimate.run_wind_ukf` fuses."""
        return ("imu", "odometry") + (("rotor_speeds",) if self.rotor_speed_measurements else ())

    def filter_options(self, rate_hz: float = 100.0) -> dict:
        """Keyword arguments of :class:`~windnav.estimate.WindUKF` for these conditions:
        ``q, r, alpha, beta, kappa, wind_frame, accel_from_odometry``, for sensors sampled at
        ``rate_hz`` (Hz).

        The presets' ``r`` are set for sensors at 100 Hz. The RotorPy-arithmetic sensors of
        ``thesis`` and ``thesis-0.038`` draw a per-sample noise that grows as
        ``sqrt(rate_hz)``, so at another rate their accelerometer ``R`` is the model floor
        over that rate's white noise (where ``r`` holds the preset's own value), and the
        odometry's velocity and attitude ``R`` scale by ``sqrt(rate_hz / 100)`` (where ``r``
        does not set them). Until 2026-12-05 every rate got the 100 Hz numbers: at 200 Hz the
        filter believed 1.03 m/s^2 where the accelerometer drew 1.44, and its wind error was
        0.651 m/s (NEES 3.15) against 0.547 m/s (1.60) with the matched ``R`` (conventions
        audit). At 100 Hz, and for the other presets, ``r`` is returned as it is.
        """
        rate = positive_float(rate_hz, "rate_hz", "UKFConditions.filter_options")
        r = dict(self.r)
        density = _ROTORPY_ACCEL.get(self.sensors)
        if density is not None and abs(rate / 100.0 - 1.0) > 1e-9:
            from windnav.estimate.wind_ukf import DEFAULT_R

            if r.get("accel") == _accel_r(_RATE_SCALE_100HZ * density):
                r["accel"] = _accel_r(rotorpy_rate_scale(rate) * density)
            for key in ("odom_velocity", "odom_euler"):
                if key not in r:
                    r[key] = DEFAULT_R[key] * math.sqrt(rate / 100.0)
        return {"q": dict(self.q), "r": r, "alpha": self.alpha, "beta": self.beta,
                "kappa": self.kappa, "wind_frame": self.wind_frame,
                "accel_from_odometry": self.accel_from_odometry}

    def to_dict(self) -> dict:
        """JSON-ready description (the hardware chain as its parameters)."""
        accel = self.accel
        if isinstance(accel, OdometryAccel):
            accel = {"odometry_accel": {"tau_s": accel.tau_s, "clamp": accel.clamp,
                                        "min_dt": accel.min_dt, "max_dt": accel.max_dt}}
        return {"name": self.name, "sensors": self.sensors, "q": dict(self.q),
                "r": dict(self.r), "alpha": self.alpha, "beta": self.beta, "kappa": self.kappa,
                "wind_frame": self.wind_frame, "accel": accel,
                "rotor_speed_measurements": self.rotor_speed_measurements,
                "rotor_speeds": self.rotor_speeds,
                "parasitic_drag": self.parasitic_drag, "calibrate": self.calibrate,
                "parameter_error": self.parameter_error, "kv_error": self.kv_error,
                "description": self.description, "source": self.source}


def _rebuild(d: dict) -> UKFConditions:
    d = dict(d)
    if isinstance(d["accel"], dict):
        d["accel"] = OdometryAccel(**d["accel"]["odometry_accel"])
    return UKFConditions(**d)


def _accel_r(per_sample_std: float) -> float:
    return math.hypot(per_sample_std, MODEL_ERROR_FLOOR)


_RATE_SCALE_100HZ = rotorpy_rate_scale(100.0)
_ROTORPY_ACCEL = {"thesis": ROTORPY_ACCEL_DENSITY, "thesis-0.038": ROTORPY_ACCEL_DENSITY_NUMPY}
"""The sensor presets with RotorPy's arithmetic (noise growing as ``sqrt(rate)``) and their
accelerometer densities."""

CONDITIONS: dict[str, UKFConditions] = {c.name: c for c in (
    UKFConditions(
        "windnav", sensors="windnav", q={"wind": 1.0}, r={"accel": 0.1},
        description="windnav's sensors and filter: exact commands, calibrated parasitic drag",
        source="windnav defaults (docs/ukf.md)"),
    UKFConditions(
        "thesis", sensors="thesis", q={"wind": 1.0},
        r={"accel": _accel_r(_RATE_SCALE_100HZ * ROTORPY_ACCEL_DENSITY),
           "rotor_speeds": THESIS_ROTOR_SPEED_STD},
        alpha=THESIS_SIGMA_POINTS[0], beta=THESIS_SIGMA_POINTS[1], kappa=THESIS_SIGMA_POINTS[2],
        wind_frame="body", parasitic_drag=False,
        description="thesis Monte Carlo: RotorPy IMU arithmetic, density 0.38^2 (1.02 m/s^2 "
                    "at 100 Hz), noisy rotor speeds, no parasitic drag, FilterPy sigma points",
        source="Folk 2026 ch. 3; rotorpy 3.0 sensors/imu.py, sensors/external_mocap.py"),
    UKFConditions(
        "thesis-0.038", sensors="thesis-0.038", q={"wind": 1.0},
        r={"accel": _accel_r(_RATE_SCALE_100HZ * ROTORPY_ACCEL_DENSITY_NUMPY),
           "rotor_speeds": THESIS_ROTOR_SPEED_STD},
        alpha=THESIS_SIGMA_POINTS[0], beta=THESIS_SIGMA_POINTS[1], kappa=THESIS_SIGMA_POINTS[2],
        wind_frame="body", parasitic_drag=False,
        description="thesis Monte Carlo with RotorPy's numpy Imu default density 0.038^2 "
                    "(0.0102 m/s^2 at 100 Hz)",
        source="Folk 2026 ch. 3; rotorpy 3.0 sensors/imu.py (Imu default)"),
    UKFConditions(
        "hardware", sensors="hardware", q={"wind": 1.0},
        r={"accel": math.sqrt(3.61), "odom_velocity": HARDWARE_MOCAP["velocity"],
           "odom_euler": HARDWARE_MOCAP["attitude"]},
        alpha=THESIS_SIGMA_POINTS[0], beta=THESIS_SIGMA_POINTS[1], kappa=THESIS_SIGMA_POINTS[2],
        wind_frame="body", accel=OdometryAccel(tau_s=0.25, clamp=15.0),
        rotor_speed_measurements=False, rotor_speeds="pwm", parasitic_drag=False,
        calibrate=False,
        parameter_error=0.05, kv_error=0.05,
        description="hardware sensing: differenced mocap acceleration (tau 0.25 s, clamp 15, "
                    "R_acc 3.61), PWM rotor speeds with Kv error, +-5% parameters",
        source="Folk 2026 ch. 6; spencerfolk/wind_aware_ros wind_aware_ukf "
               "(wind_ukf_node.cpp, config/ukf_params.yaml)"),
)}
"""The named presets (see the module docstring)."""


def ukf_conditions(conditions: str | UKFConditions | None = "windnav") -> UKFConditions:
    """Resolve a preset name (:data:`CONDITIONS`) or pass a :class:`UKFConditions` through;
    None gives ``"windnav"``."""
    if conditions is None:
        return CONDITIONS["windnav"]
    if isinstance(conditions, UKFConditions):
        return conditions
    found = CONDITIONS.get(conditions) if isinstance(conditions, str) else None
    if found is None:
        raise ValueError(f"The 'conditions' parameter must be one of {sorted(CONDITIONS)} or a "
                         f"UKFConditions. Got {conditions!r} instead.")
    return found
