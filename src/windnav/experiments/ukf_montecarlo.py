"""Monte Carlo of the Wind UKF over vehicles and winds (Folk 2026, ch. 3, Monte Carlo study).

Each trial (all draws uniform, from one seed per trial spawned from the study seed):

1. **Vehicle.** The Hummingbird with ``mass`` in [0.375, 0.9375] kg, ``c_dx``, ``c_dy`` in
   [0, 1e-3] N/(m/s)^2, ``c_dz`` in [0, 2e-2] N/(m/s)^2, ``k_d`` in [0, 1.19e-3] kg/rad and
   ``k_z`` in [0, 2.32e-3] kg/rad; every other parameter is the Hummingbird's.
2. **Calibration.** :func:`windnav.estimate.calibrate.calibrate`: steady flights along x, y, z
   at the airspeeds of :data:`~windnav.estimate.calibrate.DEFAULT_SPEEDS`, then a joint
   (non-negative) least-squares fit of ``k_d, k_z, c_dx, c_dy, c_dz``. The filter believes the
   fitted drag and the true mass, ``k_eta`` and ``k_h`` (weighed / measured on a bench).
3. **Flight.** A counter-clockwise horizontal circle, radius in [2, 5] m, speed in [1, 3] m/s
   (SE(3) controller), for a duration in [20, 60] s, in Dryden gusts
   (:class:`windnav.wind.DrydenWind`, default 10 m altitude and 10 m/s reference airspeed):
   mean wind ``(U_x, U_y, 0)`` with ``U_x, U_y`` in [-3, 3] m/s; gust standard deviation
   ``s`` in [1, 2] m/s along world x and y, and ``vertical_sigma_ratio * s`` along z. The
   default ratio 0.53 is MIL-F-8785C's low-altitude ``sigma_w / sigma_u = (0.177 + 0.000823
   h)^0.4`` at h = 10 m (33 ft). IMU, odometry and rotor-speed sensors at 100 Hz
   (:func:`sensor_suite`: windnav's default noise models, or ``sensor_noise="rotorpy"`` for
   RotorPy's default IMU and motion-capture noise, about 10x noisier accelerometer); physics at
   200 Hz.
4. **Estimate.** :func:`windnav.estimate.flight.run_wind_ukf` with the calibrated parameters and
   the study's filter tuning for that sensor suite (:data:`TUNING`, world-frame wind walk).

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
from dataclasses import asdict, dataclass

import numpy as np

from windnav._validate import positive_float, positive_int
from windnav.estimate.calibrate import calibrate
from windnav.estimate.flight import run_wind_ukf
from windnav.experiments.executor import run_tasks
from windnav.sensors.models import IMU, Odometry, RotorSpeedSensor, SensorSuite
from windnav.sim.runner import fly
from windnav.sim.trajectories import Circle
from windnav.vehicle.params import MultirotorParams, params
from windnav.wind.dryden import DrydenWind

__all__ = [
    "FILTER_Q",
    "FILTER_R",
    "MIL_VERTICAL_SIGMA_RATIO",
    "MonteCarloConfig",
    "TUNING",
    "TrialSpec",
    "draw_trials",
    "mass_to_drag",
    "run_montecarlo",
    "run_trial",
    "sensor_suite",
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
    # RotorPy's sensors are what DEFAULT_R was set for (accel 0.27 m/s^2 at 100 Hz); a smaller
    # wind walk suits the slow horizontal gusts once the accelerometer is this noisy
    "rotorpy": ({"wind": 0.7}, {}),
}
"""``sensor_noise -> (q, r)`` filter tuning of the study."""

MIL_VERTICAL_SIGMA_RATIO = float((0.177 + 0.000823 * 10.0 / 0.3048) ** 0.4)
"""``sigma_w / sigma_u`` of MIL-F-8785C at 10 m (33 ft) altitude, about 0.53."""


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
    gust_sigma : tuple of float
        Range of the horizontal gust standard deviation, m/s.
    vertical_sigma_ratio : float
        Vertical gust std over horizontal.
    radius, speed : tuple of float
        Circle radius (m) and speed (m/s).
    sensor_rate_hz : float
    sensor_noise : {"windnav", "rotorpy"}
        Noise models of the sensors (see :func:`sensor_suite`).
    dt : float
        Physics step, s.
    settle_s : float
        Samples before this time are not scored, s.
    q, r : dict, optional
        Filter tuning overrides; default ``TUNING[sensor_noise]``.
    wind_frame : str
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
    gust_sigma: tuple = (1.0, 2.0)
    vertical_sigma_ratio: float = MIL_VERTICAL_SIGMA_RATIO
    radius: tuple = (2.0, 5.0)
    speed: tuple = (1.0, 3.0)
    sensor_rate_hz: float = 100.0
    sensor_noise: str = "windnav"
    dt: float = 0.005
    settle_s: float = 2.0
    q: dict | None = None
    r: dict | None = None
    wind_frame: str = "world"

    def __post_init__(self):
        where = "MonteCarloConfig"
        positive_int(self.n_trials, "n_trials", where)
        if isinstance(self.seed, bool) or not isinstance(self.seed, (int, np.integer)) \
                or self.seed < 0:
            raise ValueError(f"The 'seed' parameter of {where} must be a non-negative int. "
                             f"Got {self.seed!r} instead.")
        for name in ("mass", "k_d", "k_z", "c_dx", "c_dy", "c_dz", "duration", "mean_wind",
                     "gust_sigma", "radius", "speed"):
            lo, hi = getattr(self, name)
            if not (math.isfinite(lo) and math.isfinite(hi) and lo <= hi):
                raise ValueError(f"The {name!r} parameter of {where} must be a finite range "
                                 f"(low, high) with low <= high. Got {(lo, hi)!r} instead.")
        for name in ("mass", "duration", "radius"):
            positive_float(getattr(self, name)[0], name, where)
        for name in ("k_d", "k_z", "c_dx", "c_dy", "c_dz", "gust_sigma", "speed"):
            positive_float(getattr(self, name)[0], name, where, allow_zero=True)
        positive_float(self.vertical_sigma_ratio, "vertical_sigma_ratio", where, allow_zero=True)
        positive_float(self.sensor_rate_hz, "sensor_rate_hz", where)
        if self.sensor_noise not in TUNING:
            raise ValueError(f"The 'sensor_noise' parameter of {where} must be one of "
                             f"{sorted(TUNING)}. Got {self.sensor_noise!r} instead.")
        q, r = TUNING[self.sensor_noise]
        object.__setattr__(self, "q", dict(q) if self.q is None else dict(self.q))
        object.__setattr__(self, "r", dict(r) if self.r is None else dict(self.r))
        positive_float(self.dt, "dt", where)
        positive_float(self.settle_s, "settle_s", where, allow_zero=True)
        if self.settle_s >= self.duration[0]:
            raise ValueError(f"The 'settle_s' parameter of {where} must be below the shortest "
                             f"flight {self.duration[0]!r} s. Got {self.settle_s!r} instead.")


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
    """IMU, odometry and rotor-speed sensors all at ``rate_hz``.

    ``noise="windnav"``: the default noise models of :mod:`windnav.sensors`. ``"rotorpy"``:
    RotorPy's defaults (``rotorpy.sensors``), whose white noise per sample is
    ``density * sqrt(rate / 2)``: accelerometer 0.038 m/s^2/sqrt(Hz), gyro 0.01 rad/s/sqrt(Hz),
    motion capture 0.0005 m, 0.005 m/s and 0.0005 rad per sqrt(Hz); no bias walk.
    """
    rate = positive_float(rate_hz, "rate_hz", "sensor_suite")
    if noise == "windnav":
        return SensorSuite(IMU(rate_hz=rate), Odometry(rate_hz=rate),
                           RotorSpeedSensor(rate_hz=rate))
    if noise == "rotorpy":
        c = math.sqrt(rate / 2.0)
        return SensorSuite(
            IMU(rate_hz=rate, accel_noise_density=0.038 / math.sqrt(2.0),
                gyro_noise_density=0.01 / math.sqrt(2.0), accel_bias_walk=0.0,
                gyro_bias_walk=0.0),
            Odometry(rate_hz=rate, position_std=0.0005 * c, velocity_std=0.005 * c,
                     attitude_std=0.0005 * c),
            RotorSpeedSensor(rate_hz=rate))
    raise ValueError(f"The 'noise' parameter of sensor_suite must be one of {sorted(TUNING)}. "
                     f"Got {noise!r} instead.")


def mass_to_drag(p: MultirotorParams) -> float:
    """``tau_drag = m / (k_d N eta_hover)``, s (inf when ``k_d = 0``)."""
    denom = p.k_d * p.n_rotors * p.hover_rotor_speed
    return float(p.mass / denom) if denom > 0 else math.inf


def draw_trials(config: MonteCarloConfig) -> list[TrialSpec]:
    """The trials of a study: the same config (seed) gives the same trials."""
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


def run_trial(spec: TrialSpec) -> dict:
    """Calibrate, fly and estimate one trial; returns its JSON-ready record (see
    :func:`run_montecarlo`)."""
    t0 = time.perf_counter()
    cfg = spec.config
    truth = spec.params()
    sensors = sensor_suite(cfg.sensor_rate_hz, cfg.sensor_noise)
    fit, believed = calibrate(truth, seed=spec.seed, sensors=sensors)
    wind = DrydenWind(mean=spec.mean_wind, sigma=spec.sigma, seed=spec.seed)
    traj = Circle(center=(0.0, 0.0, 10.0), radius=spec.radius, speed=spec.speed)
    # start on the circle (its t = 0 point) so the flight starts in hover
    log = fly(truth, traj, wind, spec.duration, dt=cfg.dt, sensors=sensors,
              seed=np.random.default_rng([spec.seed, 1]))
    track = run_wind_ukf(log, believed, q=cfg.q, r=cfg.r, wind_frame=cfg.wind_frame)
    return {
        "index": spec.index, "seed": spec.seed,
        "params": {k: getattr(truth, k) for k in ("mass", "k_d", "k_z", "c_dx", "c_dy", "c_dz")},
        "fitted": fit.coefficients,
        "calibration_residual_rms": list(fit.residual_rms),
        "tau_drag": mass_to_drag(truth),
        "duration": spec.duration, "mean_wind": list(spec.mean_wind),
        "sigma": list(spec.sigma), "radius": spec.radius, "speed": spec.speed,
        "rmse": track.rmse_after(cfg.settle_s),
        "rmse_axes": [track.rmse_after(cfg.settle_s, axis=j) for j in range(3)],
        "nees": track.nees(cfg.settle_s),
        "max_tracking_error": float(log.tracking_error.max()),
        "saturated_fraction": log.saturation_fraction,
        "filter_repairs": track.repairs,
        "seconds": time.perf_counter() - t0,
    }


def summarize(records: list[dict]) -> dict:
    """Median, quartiles, mean and extremes of the 3D RMSE over the finite trials (m/s), and
    the number of trials whose rotor commands saturated more than 1% of the time."""
    rmse = np.array([r["rmse"] for r in records], dtype=np.float64)
    ok = np.isfinite(rmse)
    if not np.any(ok):
        return {"n": 0}
    v = rmse[ok]
    axes = np.array([r["rmse_axes"] for r in records], dtype=np.float64)[ok]
    q1, med, q3 = np.percentile(v, [25, 50, 75])
    return {
        "n": int(v.size), "median": float(med), "q1": float(q1), "q3": float(q3),
        "mean": float(v.mean()), "min": float(v.min()), "max": float(v.max()),
        "median_axes": np.median(axes, axis=0).tolist(),
        "fraction_below_0.5": float(np.mean(v <= 0.5)),
        # heavy, high-drag draws can exceed the SE(3) controller's authority in strong wind:
        # they are kept (the filter sees the flight as flown) but counted
        "n_saturated_over_1pct": int(sum(r.get("saturated_fraction", 0.0) > 0.01
                                         for r, good in zip(records, ok, strict=True) if good)),
    }


def run_montecarlo(config: MonteCarloConfig, *, backend: str = "process",
                   workers: int | None = None, progress: bool = True) -> dict:
    """Run the study through :func:`windnav.experiments.run_tasks`.

    Returns
    -------
    dict
        ``config`` (dict), ``trials`` (per-trial records sorted by index, see
        :func:`run_trial`; failed trials carry ``error`` instead of results), ``failed``
        (count), ``summary`` (:func:`summarize` over the successful trials), ``seconds``.
    """
    specs = draw_trials(config)
    t0 = time.perf_counter()
    results = sorted(run_tasks(run_trial, specs, backend=backend, workers=workers,
                               progress=progress, desc="ukf monte carlo"),
                     key=lambda r: r.index)
    trials, failed = [], 0
    for res in results:
        if res.ok:
            trials.append(res.value)
        else:
            failed += 1
            spec = res.task
            trials.append({"index": spec.index, "seed": spec.seed, "params": spec.drag,
                           "error": res.error, "rmse": math.nan,
                           "rmse_axes": [math.nan] * 3, "seconds": res.seconds})
    return {"config": asdict(config), "trials": trials, "failed": failed,
            "summary": summarize([t for t in trials if "error" not in t]),
            "seconds": time.perf_counter() - t0}
