"""Monte Carlo of the Wind UKF over vehicles and winds (Folk 2026, ch. 3, Monte Carlo study).

The study runs under one of the named conditions of
:data:`windnav.estimate.conditions.CONDITIONS` (``conditions=``; ``docs/ukf.md`` has each one
and its sources): ``windnav`` (the kindest: windnav's sensors and filter, windnav's gusts),
``thesis`` / ``thesis-0.038`` (the thesis's Monte Carlo: RotorPy's sensor arithmetic and
Dryden gusts, a filter without parasitic drag, FilterPy sigma points) and ``hardware`` (the
thesis's flights: differenced motion-capture acceleration, PWM rotor speeds, parameter
errors).

Each trial (all draws uniform, from one seed per trial spawned from the study seed):

1. **Vehicle.** The Hummingbird with ``mass`` in [0.375, 0.9375] kg, ``c_dx``, ``c_dy`` in
   [0, 1e-3] N/(m/s)^2, ``c_dz`` in [0, 2e-2] N/(m/s)^2, ``k_d`` in [0, 1.19e-3] kg/rad and
   ``k_z`` in [0, 2.32e-3] kg/rad; every other parameter is the Hummingbird's (the thesis's
   ranges).
2. **Calibration** (conditions with ``calibrate``):
   :func:`windnav.experiments.calibration.calibrate`: steady flights along x, y, z at the
   airspeeds of :data:`~windnav.experiments.calibration.DEFAULT_SPEEDS` with the conditions'
   sensors, then a (non-negative) least-squares fit of ``k_d, k_z`` and, when the conditions'
   filter models parasitic drag, ``c_dx, c_dy, c_dz``. The filter believes the fitted drag and
   the true mass, ``k_eta`` and ``k_h`` (weighed / measured on a bench). Without
   ``calibrate`` (hardware) it believes the true values scaled by the conditions' parameter
   errors (:func:`windnav.experiments.ukf_conditions.believed_params`). The coefficients a
   trial's calibration leaves undetermined (:attr:`windnav.estimate.DragFit.undetermined`: a
   small drawn frame drag pinned at 0, in 19 of the default study's 50 trials) are in its
   record (``calibration_undetermined``) and counted by :func:`summarize`, not warned of
   trial by trial.
3. **Flight.** A counter-clockwise horizontal circle, radius in [2, 5] m, speed in [1, 3] m/s
   (SE(3) controller), for a duration in [20, 60] s, in gusts around a mean wind
   ``(U_x, U_y, 0)`` with ``U_x, U_y`` in [-3, 3] m/s:

   - ``wind_model="windnav"`` (windnav conditions): :class:`windnav.wind.DrydenWind` (default
     10 m altitude and 10 m/s reference airspeed), gust standard deviation ``s`` in [1, 2]
     m/s along world x and y and ``vertical_sigma_ratio * s`` along z. The default ratio
     0.53 is MIL-F-8785C's low-altitude ``sigma_w / sigma_u = (0.177 + 0.000823 h)^0.4`` at
     h = 10 m (33 ft).
   - ``wind_model="rotorpy"`` (thesis and hardware conditions): RotorPy's ``DrydenGust``
     with intensity ``s`` in [30, 60] on all three axes (ratio 1), stepped at 100 Hz
     (:func:`windnav.experiments.ukf_conditions.rotorpy_dryden`; gusts of about 1-2 m/s).

   IMU, odometry and rotor-speed sensors at 100 Hz (the conditions' sensor preset,
   :mod:`windnav.sensors.presets`); physics at 200 Hz.
4. **Estimate.** :func:`windnav.experiments.ukf_conditions.estimate_wind` under the
   conditions (filter settings, rotor-speed chain, believed parameters), with the study's
   overrides ``q``, ``r``, ``wind_frame``.

Metric: ``rmse`` = root mean square over the filter samples with ``t >= settle_s`` (2 s) of
the 3D error norm ``|w_hat - w_true|`` (m/s), the wind being the true wind at the centre of mass.
Per-axis RMS errors are recorded too.

Mass-to-drag ratio: ``tau_drag = m / (k_d N eta_hover)`` (s), with ``eta_hover = sqrt(m g /
(N k_eta))``: the time constant of the in-plane rotor-drag response to an airspeed change
(``a_x = -(k_d N eta_hover / m) v_a,x`` near hover). Large ``tau_drag`` = heavy vehicle, weak
drag, weak wind signal in the accelerometer.
"""

from __future__ import annotations

import math
import time
import warnings
from collections.abc import Mapping
from dataclasses import dataclass, fields

import numpy as np

from windnav._extras import require
from windnav._validate import positive_float, positive_int
from windnav.estimate.conditions import CONDITIONS, UKFConditions, ukf_conditions
from windnav.estimate.wind_ukf import DEFAULT_R, check_noise
from windnav.experiments.calibration import calibrate
from windnav.experiments.executor import run_tasks
from windnav.experiments.flight import drag_model_note
from windnav.experiments.ukf_conditions import estimate_wind, rotorpy_dryden
from windnav.sensors import presets
from windnav.sensors.models import SensorSuite
from windnav.sim.runner import fly
from windnav.sim.trajectories import Circle
from windnav.vehicle.params import GRAVITY, MultirotorParams, params
from windnav.wind.dryden import DrydenWind

__all__ = [
    "CONDITIONS",
    "config_dict",
    "FILTER_Q",
    "FILTER_R",
    "MIL_VERTICAL_SIGMA_RATIO",
    "MonteCarloConfig",
    "STUDY_WIND",
    "THESIS_MEDIAN",
    "TUNING",
    "TrialSpec",
    "draw_trials",
    "failed_record",
    "mass_to_drag",
    "records_header",
    "run_montecarlo",
    "run_trial",
    "sensor_suite",
    "study_wind",
    "summarize",
]

FILTER_Q = {"wind": 1.0}
"""Wind UKF process noise for the study (m/s/sqrt(s)): a Dryden gust of std ``s`` and time
scale ``T`` drifts at ``s sqrt(2 / T)``, 0.5-1 m/s/sqrt(s) horizontally (T ~ 6.7 s) and more
vertically (T ~ 1 s); 1.0 trades the two. Other densities are ``DEFAULT_Q``."""

FILTER_R = {"accel": 0.1}
"""Wind UKF measurement noise for windnav's default sensors: the simulated IMU's white noise is
0.028 m/s^2 at 100 Hz, but the filter's force model errs by more (rotor lever-arm airspeed,
motor lag between commands and speeds, calibration error), so 0.1 m/s^2. Others are
``DEFAULT_R``."""

TUNING = {
    "windnav": (FILTER_Q, FILTER_R),
    # RotorPy's densities read as densities are what DEFAULT_R was set for (accel 0.27 m/s^2
    # at 100 Hz); a smaller wind walk suits the slow horizontal gusts once the accelerometer
    # is this noisy
    "rotorpy": ({"wind": 0.7}, {"accel": DEFAULT_R["accel"]}),
}
"""``sensor_noise -> (q, r)`` filter tuning of the study under the ``windnav`` conditions
(on top of the conditions' own, key by key)."""

STUDY_WIND = {
    "windnav": ("windnav", (1.0, 2.0), None),
    "thesis": ("rotorpy", (30.0, 60.0), 1.0),
    "thesis-0.038": ("rotorpy", (30.0, 60.0), 1.0),
    "hardware": ("rotorpy", (30.0, 60.0), 1.0),
}
"""``conditions -> (wind_model, gust_sigma range, vertical_sigma_ratio)`` defaults of the study
(None: MIL-F-8785C's ratio); ``gust_sigma`` is in m/s for windnav's gusts and RotorPy's
intensity for RotorPy's. Conditions not listed get the thesis's."""

THESIS_MEDIAN = 0.5
"""Median 3D wind RMSE of the thesis's simulated Monte Carlo, m/s (its real flights: 0.8)."""

MIN_THRUST_TO_WEIGHT = 1.5
"""The least thrust-to-weight ratio a drawn vehicle may have at its heaviest (the navigation
loop's altitude hold asks for up to 1.5 g); :class:`MonteCarloConfig` refuses a mass range
beyond it."""

MIL_VERTICAL_SIGMA_RATIO = float((0.177 + 0.000823 * 10.0 / 0.3048) ** 0.4)
"""``sigma_w / sigma_u`` of MIL-F-8785C at 10 m (33 ft) altitude, about 0.53."""


def _check_tuning(q, r, wind_frame, where: str) -> None:
    """The study's filter overrides checked as the Wind UKF will take them, before any trial:
    ``q`` process-noise densities (keys of :data:`~windnav.estimate.wind_ukf.DEFAULT_Q`,
    numbers >= 0), ``r`` measurement noise (keys of
    :data:`~windnav.estimate.wind_ukf.DEFAULT_R` or ``odom``; standard deviations > 0, or a
    covariance), ``wind_frame`` one of :data:`~windnav.estimate.wind_model.WIND_FRAMES`. (An
    unknown key, a negative density or another frame was accepted here and failed every trial;
    Python API audit, fifty-eighth session.) ``q`` and ``r`` by the filter's own rules
    (:func:`~windnav.estimate.wind_ukf.check_noise`; restated here, without the sizes, until
    2026-12-08); ``r['rotor_speeds']`` of any size here, its size checked against the vehicle's
    rotors once :class:`MonteCarloConfig` has read the vehicle."""
    from windnav.estimate.wind_model import WIND_FRAMES

    check_noise(q, r, where)
    if wind_frame is not None and wind_frame not in WIND_FRAMES:
        raise ValueError(f"The 'wind_frame' parameter of {where} must be None or one of "
                         f"{list(WIND_FRAMES)}. Got {wind_frame!r} instead.")


@dataclass(frozen=True)
class MonteCarloConfig:
    """Ranges of the study (see the module docstring); all ranges are ``(low, high)``.

    Attributes
    ----------
    n_trials : int
    seed : int
    vehicle : str
        Base vehicle whose other parameters are kept.
    mass, k_d, k_z, c_dx, c_dy, c_dz : tuple of float
        Ranges of the vehicle draws (kg, kg/rad, N/(m/s)^2).
    duration : tuple of float
        Flight time, s.
    mean_wind : tuple of float
        Range of each horizontal component of the mean wind, m/s.
    gust_sigma : tuple of float, optional
        Range of the horizontal gust standard deviation, m/s (RotorPy's intensity for
        ``wind_model="rotorpy"``); default from :data:`STUDY_WIND`.
    vertical_sigma_ratio : float, optional
        Vertical gust std over horizontal; default from :data:`STUDY_WIND`.
    radius, speed : tuple of float
        Circle radius (m) and speed (m/s).
    sensor_rate_hz : float
    sensor_noise : str, optional
        Sensor preset (:mod:`windnav.sensors.presets`); default the conditions'. Under the
        ``windnav`` conditions it may be ``"rotorpy"`` (the earlier study's suite).
    dt : float
        Physics step, s.
    settle_s : float
        Samples before this time are not scored, s.
    q, r : dict, optional
        Filter tuning, on top of the conditions' key by key (and of ``TUNING[sensor_noise]``
        under the windnav conditions); stored resolved.
    wind_frame : str, optional
        Default the conditions'.
    conditions : str or UKFConditions
        A name of :data:`~windnav.estimate.conditions.CONDITIONS`, or custom conditions (an
        ablation: ``dataclasses.replace(CONDITIONS["hardware"], name=..., kv_error=0.0)``;
        the study's wind defaults are then the thesis's).
    wind_model : {"windnav", "rotorpy"}, optional
        Default from :data:`STUDY_WIND`.
    """

    n_trials: int = 50
    seed: int = 0
    vehicle: str = "hummingbird"
    mass: tuple = (0.375, 0.9375)
    k_d: tuple = (0.0, 1.19e-3)
    k_z: tuple = (0.0, 2.32e-3)
    c_dx: tuple = (0.0, 1e-3)
    c_dy: tuple = (0.0, 1e-3)
    c_dz: tuple = (0.0, 2e-2)
    duration: tuple = (20.0, 60.0)
    mean_wind: tuple = (-3.0, 3.0)
    gust_sigma: tuple | None = None
    vertical_sigma_ratio: float | None = None
    radius: tuple = (2.0, 5.0)
    speed: tuple = (1.0, 3.0)
    sensor_rate_hz: float = 100.0
    sensor_noise: str | None = None
    dt: float = 0.005
    settle_s: float = 2.0
    q: dict | None = None
    r: dict | None = None
    wind_frame: str | None = None
    conditions: str = "windnav"
    wind_model: str | None = None

    def __post_init__(self):
        where = "MonteCarloConfig"
        _check_tuning(self.q, self.r, self.wind_frame, where)
        self._resolve(where)
        positive_int(self.n_trials, "n_trials", where)
        if isinstance(self.seed, bool) or not isinstance(self.seed, (int, np.integer)) \
                or self.seed < 0:
            raise ValueError(f"The 'seed' parameter of {where} must be a non-negative int. "
                             f"Got {self.seed!r} instead.")
        for name in ("mass", "k_d", "k_z", "c_dx", "c_dy", "c_dz", "duration", "mean_wind",
                     "gust_sigma", "radius", "speed"):
            try:  # (three values raised "too many values to unpack"; Python API audit,
                lo, hi = (float(v) for v in getattr(self, name))  # fifty-eighth session)
            except (TypeError, ValueError):
                lo = hi = math.nan
            if not (math.isfinite(lo) and math.isfinite(hi) and lo <= hi):
                raise ValueError(f"The {name!r} parameter of {where} must be a finite range "
                                 f"(low, high) with low <= high. Got {getattr(self, name)!r} "
                                 "instead.")
        for name in ("mass", "duration", "radius"):
            positive_float(getattr(self, name)[0], name, where)
        for name in ("k_d", "k_z", "c_dx", "c_dy", "c_dz", "gust_sigma", "speed"):
            positive_float(getattr(self, name)[0], name, where, allow_zero=True)
        positive_float(self.vertical_sigma_ratio, "vertical_sigma_ratio", where, allow_zero=True)
        positive_float(self.sensor_rate_hz, "sensor_rate_hz", where)
        positive_float(self.dt, "dt", where)
        positive_float(self.settle_s, "settle_s", where, allow_zero=True)
        if self.settle_s >= self.duration[0]:
            raise ValueError(f"The 'settle_s' parameter of {where} must be below the shortest "
                             f"flight {self.duration[0]!r} s. Got {self.settle_s!r} instead.")
        try:
            base = params(self.vehicle)
        except (KeyError, ValueError) as exc:
            raise ValueError(f"The 'vehicle' parameter of {where} must name a vehicle of "
                             f"windnav.vehicle.params. Got {self.vehicle!r} instead.") from exc
        # one r['rotor_speeds'] per rotor (six for the Hummingbird passed here and failed every
        # trial in WindUKF; review)
        check_noise(r=self.r, where=where, n_rotors=base.n_rotors)
        # the ranges are absolute (the thesis's, about the 0.5 kg Hummingbird): with another
        # vehicle they drew 0.76-0.91 kg Crazyflies with a thrust-to-weight of 0.2, saturated
        # the whole flight, into the summary's median (vehicle audit, 2026-12-05)
        lift = base.max_thrust / GRAVITY  # kg at full thrust
        if not self.mass[1] < lift / MIN_THRUST_TO_WEIGHT:
            raise ValueError(
                f"The 'mass' parameter of {where} must stay below {lift / MIN_THRUST_TO_WEIGHT:.4g}"
                f" kg for {self.vehicle!r} (a thrust-to-weight of {MIN_THRUST_TO_WEIGHT:g} at "
                f"its full thrust; its own mass is {base.mass:g} kg; the default ranges are the "
                f"thesis's, about the Hummingbird: give the drag ranges for it too). Got "
                f"{tuple(self.mass)!r} instead.")
        kept = [f.name for f in fields(self) if f.name in ("k_d", "k_z", "c_dx", "c_dy", "c_dz")
                and tuple(getattr(self, f.name)) == f.default]
        if self.vehicle != "hummingbird" and kept:
            warnings.warn(f"{where}: the ranges {kept} are the thesis's for the Hummingbird, "
                          f"not scaled to {self.vehicle!r} (its own k_d is {base.k_d:.3g}, "
                          f"k_z {base.k_z:.3g}): give ranges for it", stacklevel=3)


    def _resolve(self, where: str) -> None:
        """Fill the fields left None from the conditions (names and their defaults)."""
        if not (isinstance(self.conditions, UKFConditions) or self.conditions in CONDITIONS):
            raise ValueError(f"The 'conditions' parameter of {where} must be one of "
                             f"{sorted(CONDITIONS)} or a UKFConditions. Got "
                             f"{self.conditions!r} instead.")
        cond = ukf_conditions(self.conditions)
        noise = cond.sensors if self.sensor_noise is None else self.sensor_noise
        allowed = sorted(TUNING) if cond.name == "windnav" else [cond.sensors]
        if noise not in allowed:
            raise ValueError(f"The 'sensor_noise' parameter of {where} must be one of {allowed} "
                             f"under the {cond.name!r} conditions. Got {noise!r} instead.")
        tq, tr = TUNING[noise] if cond.name == "windnav" else ({}, {})
        study = STUDY_WIND.get(cond.name, STUDY_WIND["thesis"])
        model, sigma, ratio = study
        model = model if self.wind_model is None else self.wind_model
        if model not in ("windnav", "rotorpy"):
            raise ValueError(f"The 'wind_model' parameter of {where} must be 'windnav' or "
                             f"'rotorpy'. Got {model!r} instead.")
        if model != study[0]:
            sigma, ratio = STUDY_WIND["windnav" if model == "windnav" else "thesis"][1:]
        ratio = MIL_VERTICAL_SIGMA_RATIO if ratio is None else ratio
        filled = {
            "sensor_noise": noise, "wind_model": model,
            "gust_sigma": sigma if self.gust_sigma is None else tuple(self.gust_sigma),
            "vertical_sigma_ratio": (ratio if self.vertical_sigma_ratio is None
                                     else self.vertical_sigma_ratio),
            "q": {**cond.q, **tq, **(self.q or {})},
            "r": {**cond.r, **tr, **(self.r or {})},
            "wind_frame": cond.wind_frame if self.wind_frame is None else self.wind_frame,
        }
        for k, v in filled.items():
            object.__setattr__(self, k, v)


_CONFIG_CLASS = MonteCarloConfig  # the class itself, should the public name be wrapped


@dataclass(frozen=True)
class TrialSpec:
    """Everything one trial needs (picklable): the drawn vehicle, wind and flight."""

    index: int
    seed: int
    vehicle: str
    drag: dict
    duration: float
    mean_wind: tuple
    sigma: tuple
    radius: float
    speed: float
    config: MonteCarloConfig

    def params(self) -> MultirotorParams:
        """The true vehicle of the trial."""
        return params(self.vehicle, **self.drag)


def sensor_suite(rate_hz: float = 100.0, noise: str = "windnav") -> SensorSuite:
    """IMU, odometry and rotor-speed sensors all at ``rate_hz``: the sensor preset ``noise``
    of :mod:`windnav.sensors.presets` (``"windnav"``: windnav's defaults; ``"rotorpy"``:
    RotorPy's default densities read as densities, ``density * sqrt(rate / 2)``, the earlier
    study's suite; ``"thesis"``, ``"thesis-0.038"``: RotorPy's arithmetic; ``"hardware"``)."""
    if noise not in presets.SENSOR_PRESETS:
        raise ValueError(f"The 'noise' parameter of sensor_suite must be one of "
                         f"{sorted(presets.SENSOR_PRESETS)}. Got {noise!r} instead.")
    return presets.sensor_suite(noise, positive_float(rate_hz, "rate_hz", "sensor_suite"))


def mass_to_drag(p: MultirotorParams) -> float:
    """``tau_drag = m / (k_d N eta_hover)``, s (inf when ``k_d = 0``)."""
    if not isinstance(p, MultirotorParams):  # (None: an AttributeError; Python API audit)
        raise ValueError(f"The 'p' parameter of mass_to_drag must be a MultirotorParams. Got "
                         f"{p!r} instead.")
    denom = p.k_d * p.n_rotors * p.hover_rotor_speed
    return float(p.mass / denom) if denom > 0 else math.inf


def draw_trials(config: MonteCarloConfig) -> list[TrialSpec]:
    """The trials of a study: the same config (seed) gives the same trials."""
    if not isinstance(config, _CONFIG_CLASS):  # (None: an AttributeError; Python API audit)
        raise ValueError(f"The 'config' parameter of draw_trials must be a MonteCarloConfig. "
                         f"Got {config!r} instead.")
    seqs = np.random.SeedSequence(config.seed).spawn(config.n_trials)
    out = []
    for i, ss in enumerate(seqs):
        rng = np.random.default_rng(ss)
        drag = {k: float(rng.uniform(*getattr(config, k)))
                for k in ("mass", "k_d", "k_z", "c_dx", "c_dy", "c_dz")}
        s = float(rng.uniform(*config.gust_sigma))
        out.append(TrialSpec(
            index=i, seed=int(ss.generate_state(1)[0] & 0x7FFFFFFF), vehicle=config.vehicle,
            drag=drag, duration=float(rng.uniform(*config.duration)),
            mean_wind=(float(rng.uniform(*config.mean_wind)),
                       float(rng.uniform(*config.mean_wind)), 0.0),
            sigma=(s, s, s * config.vertical_sigma_ratio),
            radius=float(rng.uniform(*config.radius)), speed=float(rng.uniform(*config.speed)),
            config=config))
    return out


def study_wind(spec: TrialSpec):
    """The gusts of a trial: windnav's Dryden field or RotorPy's ``DrydenGust``."""
    if spec.config.wind_model == "rotorpy":
        return rotorpy_dryden(spec.mean_wind, spec.sigma, seed=spec.seed)
    return DrydenWind(mean=spec.mean_wind, sigma=spec.sigma, seed=spec.seed)


def run_trial(spec: TrialSpec) -> dict:
    """Calibrate, fly and estimate one trial; returns its JSON-ready record (see
    :func:`run_montecarlo`)."""
    t0 = time.perf_counter()
    cfg = spec.config
    cond = ukf_conditions(cfg.conditions)
    truth = spec.params()
    sensors = sensor_suite(cfg.sensor_rate_hz, cfg.sensor_noise)
    fit = None
    believed = truth
    if cond.calibrate:
        with warnings.catch_warnings():  # said in the record, and counted by the summary
            warnings.filterwarnings("ignore", message="fit_drag: ", category=RuntimeWarning)
            fit, believed = calibrate(truth, rng=spec.seed, sensors=sensors,
                                      parasitic=cond.parasitic_drag)
    wind = study_wind(spec)
    traj = Circle(center=(0.0, 0.0, 10.0), radius=spec.radius, speed=spec.speed)
    # start on the circle (its t = 0 point) so the flight starts in hover
    log = fly(truth, traj, wind, spec.duration, dt=cfg.dt, sensors=sensors,
              rng=np.random.default_rng([spec.seed, 1]))
    track, applied = estimate_wind(log, believed, cond, rng=np.random.default_rng([spec.seed, 2]),
                                   q=cfg.q, r=cfg.r, wind_frame=cfg.wind_frame)
    drag = drag_model_note(log, truth, cond, cfg.settle_s, believed=believed)
    return {
        "index": spec.index, "seed": spec.seed, "conditions": cond.name,
        "params": {k: getattr(truth, k) for k in ("mass", "k_d", "k_z", "c_dx", "c_dy", "c_dz")},
        "fitted": None if fit is None else fit.coefficients,
        "calibration_residual_rms": None if fit is None else list(fit.residual_rms),
        "calibration_undetermined": None if fit is None else dict(fit.undetermined),
        # every note of the fit (a low R^2 too), whose warnings the trial does not pass on
        "calibration_notes": None if fit is None else list(fit.notes),
        "parameter_errors": applied["parameter_errors"], "kv_error": applied["kv_error"],
        "tau_drag": mass_to_drag(truth),
        "duration": spec.duration, "mean_wind": list(spec.mean_wind),
        "sigma": list(spec.sigma), "radius": spec.radius, "speed": spec.speed,
        "rmse": track.rmse_after(cfg.settle_s),
        "rmse_axes": [track.rmse_after(cfg.settle_s, axis=j) for j in range(3)],
        "nees": track.nees(cfg.settle_s),
        "max_tracking_error": float(log.tracking_error.max()),
        "saturated_fraction": log.saturation_fraction,
        "status": log.meta.get("status"),
        "outside_envelope_fraction": log.envelope_fraction,
        "filter_repairs": track.repairs,
        "median_horizontal_airspeed": drag["median_horizontal_airspeed_m_s"],
        "drag_model_bias": drag["drag_model_bias_m_s"],
        "seconds": time.perf_counter() - t0,
    }


MIN_QUARTILE_TRIALS = 4
"""Fewest finite trials whose quartiles are given (None below): the quartiles of one to three
values are interpolations between them, not a spread (``--trials 1`` printed "quartiles
0.042 / 0.042"; statistics audit)."""


def summarize(records: list[dict]) -> dict:
    """Median, quartiles, mean and extremes of the 3D RMSE over the finite trials (m/s), the
    median and quartiles of the per-axis RMSE (world x, y, z) (quartiles None below
    :data:`MIN_QUARTILE_TRIALS` trials), and the numbers of trials whose
    rotor commands saturated more than 1% of the time, that left the vehicle's envelope and
    whose calibration left a drag coefficient undetermined, and the largest drag-model bias of
    a trial (``max_drag_model_bias``, m/s; None for records written before it was kept), and
    the median of the trials' mean NEES (``nees_median``,
    :meth:`~windnav.estimate.WindTrack.nees`: 3 when the filter's reported wind covariance
    matches its errors; None without it).

    ``records``: :func:`run_trial`'s records (each with ``rmse`` and ``rmse_axes``; another
    raised a bare KeyError; Python API audit, fifty-eighth session)."""
    bad = [i for i, r in enumerate(records)
           if not isinstance(r, Mapping) or "rmse" not in r or "rmse_axes" not in r]
    if bad:
        raise ValueError("The 'records' parameter of summarize must be run_trial's records, "
                         f"each with 'rmse' and 'rmse_axes'. Got {len(bad)} without them (the "
                         f"first at index {bad[0]}) instead.")
    rmse = np.array([r["rmse"] for r in records], dtype=np.float64)
    ok = np.isfinite(rmse)
    if not np.any(ok):
        return {"n": 0}
    v = rmse[ok]
    axes = np.array([r["rmse_axes"] for r in records], dtype=np.float64)[ok]
    q1, med, q3 = np.percentile(v, [25, 50, 75])
    spread = v.size >= MIN_QUARTILE_TRIALS
    good = [r for r, g in zip(records, ok, strict=True) if g]
    nees = _finite([r.get("nees") for r in good])
    return {
        "n": int(v.size), "median": float(med), "q1": float(q1) if spread else None,
        "q3": float(q3) if spread else None,
        "mean": float(v.mean()), "min": float(v.min()), "max": float(v.max()),
        "median_axes": np.median(axes, axis=0).tolist(),
        "q1_axes": np.percentile(axes, 25, axis=0).tolist() if spread else None,
        "q3_axes": np.percentile(axes, 75, axis=0).tolist() if spread else None,
        "fraction_below_0.5": float(np.mean(v <= 0.5)),
        # heavy, high-drag draws can exceed the SE(3) controller's authority in strong wind:
        # they are kept (the filter sees the flight as flown) but counted
        "n_saturated_over_1pct": int(sum(r.get("saturated_fraction", 0.0) > 0.01
                                         for r in good)),
        # flown beyond the model's trusted airspeed or lift: their RMSE is the filter's
        # against an extrapolated vehicle (kept, counted)
        "n_outside_envelope": int(sum(r.get("outside_envelope_fraction", 0.0) > 0
                                      for r in good)),
        # the filter believed a drag coefficient its calibration did not determine (as fitted)
        "n_calibration_undetermined": int(sum(bool(r.get("calibration_undetermined"))
                                              for r in good)),
        # a filter whose drag model is not the vehicle's (the thesis's presets leave the frame
        # drag out) is biased, by about this much at the trial's airspeed (m/s)
        "max_drag_model_bias": max((abs(r["drag_model_bias"]) for r in good
                                    if r.get("drag_model_bias") is not None), default=None),
        # the covariance the filter reports against its errors: 3 (the wind's 3 components)
        # when consistent
        "nees_median": float(np.median(nees)) if nees.size else None,
        "nees_n": int(nees.size),
    }


def quartiles_text(summary: dict) -> str:
    """``"q1 / q3"`` of a :func:`summarize` result (m/s, 3 decimals), or why there are none."""
    if summary.get("q1") is None:
        n = summary.get("n", 0)
        return f"none from {n} trial{'' if n == 1 else 's'}"
    return f"{summary['q1']:.3f} / {summary['q3']:.3f}"


def _finite(values) -> np.ndarray:
    """The finite numbers of ``values`` (None left out)."""
    v = np.array([x for x in values if x is not None], dtype=np.float64)
    return v[np.isfinite(v)]


def config_dict(config: MonteCarloConfig) -> dict:
    """The JSON-ready fields of ``config`` (custom conditions as their description)."""
    out = {f.name: getattr(config, f.name) for f in fields(config)}
    out = {k: (dict(v) if isinstance(v, dict) else v) for k, v in out.items()}
    if isinstance(config.conditions, UKFConditions):
        out["conditions"] = config.conditions.to_dict()
    return out


def records_header(config: MonteCarloConfig) -> dict:
    """The header of a study's record log: which study its records belong to."""
    return {"study": "windnav.experiments.ukf_montecarlo", "config": config_dict(config)}


def failed_record(spec: TrialSpec, error: str | None, seconds: float = 0.0) -> dict:
    """The record of a trial that raised: its draw, the error, NaN results."""
    return {"index": spec.index, "seed": spec.seed, "params": spec.drag, "error": error,
            "rmse": math.nan, "rmse_axes": [math.nan] * 3, "seconds": seconds}


_RECORD_NUMBERS = ("rmse", "saturated_fraction", "outside_envelope_fraction")


def _recorded_trial(rec: dict, specs: list[TrialSpec]) -> bool:
    """Whether ``rec`` is the finished record of the trial it names: its index in range, its
    seed that trial's and the numbers the summary reads numbers. (A line of another study,
    seed 1 against 0, was taken for trial 1 and moved the median, silently; a record without
    its ``rmse`` failed the summary after every other trial had run; files audit.)"""
    i = rec.get("index")
    if isinstance(i, bool) or not isinstance(i, int) or not 0 <= i < len(specs):
        return False
    if rec.get("seed") != specs[i].seed:
        return False
    nums = [rec.get(k) for k in _RECORD_NUMBERS]
    axes = rec.get("rmse_axes")
    return (all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in nums)
            and isinstance(axes, list) and len(axes) == 3
            and all(isinstance(v, (int, float)) for v in axes))


def recorded_trials(records, specs: list[TrialSpec]) -> dict[int, dict]:
    """``{index: record}`` of the finished trials among ``records`` (a record log's): those
    without an error that :func:`_recorded_trial` accepts, the last of each index."""
    return {r["index"]: r for r in records
            if r.get("error") is None and _recorded_trial(r, specs)}


def run_montecarlo(config: MonteCarloConfig, *, backend: str = "process",
                   workers: int | None = None, progress: bool = True,
                   records=None) -> dict:
    """Run the study through :func:`windnav.experiments.run_tasks`.

    Parameters
    ----------
    config : MonteCarloConfig
    backend, workers, progress
        Passed to :func:`windnav.experiments.run_tasks`.
    records : str or path-like, optional
        A record log (:class:`windnav.experiments.results.RecordLog`, JSON lines): every
        trial's record is appended as soon as it finishes, so an interrupted study loses only
        the trials that were running. Trials already recorded there as successful are not run
        again (a failed one is retried); it must hold this study's records.

    Returns
    -------
    dict
        ``config`` (dict), ``trials`` (per-trial records sorted by index, see
        :func:`run_trial`; failed trials carry ``error`` instead of results), ``failed``
        (count), ``resumed`` (trials taken from ``records``), ``summary`` (:func:`summarize`
        over the successful trials), ``seconds``.

    Raises
    ------
    RecordMismatchError
        When ``records`` holds the records of another study (checked before any trial runs).
    """
    from windnav.experiments.results import RecordLog

    specs = draw_trials(config)
    if specs and specs[0].config.wind_model == "rotorpy":  # once, not a failure per trial
        require("rotorpy", f"The {ukf_conditions(config.conditions).name!r} conditions' gusts "
                "(RotorPy's DrydenGust)")
    log = RecordLog(records, records_header(config)) if records is not None else None
    done = recorded_trials(log.load() if log is not None else [], specs)
    t0 = time.perf_counter()
    trials = dict(done)
    todo = [s for s in specs if s.index not in done]
    for res in run_tasks(run_trial, todo, backend=backend, workers=workers, progress=progress,
                         desc="ukf monte carlo"):
        rec = res.value if res.ok else failed_record(res.task, res.error, res.seconds)
        if log is not None:
            log.append(rec)
        trials[rec["index"]] = rec
    trials = [trials[i] for i in sorted(trials)]
    failed = sum("error" in t and t["error"] is not None for t in trials)
    return {"config": config_dict(config), "trials": trials, "failed": failed,
            "resumed": len(done),
            "summary": summarize([t for t in trials if t.get("error") is None]),
            "seconds": time.perf_counter() - t0}
