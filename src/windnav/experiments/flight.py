"""One reference flight in wind, and its summary (the harness of ``windnav fly``).

The vehicle flies a named trajectory (:func:`windnav.sim.make_trajectory`) with the SE(3)
controller in no wind, a constant wind or Dryden gusts; the summary scores the tracking error
after the take-off transient (``t >= min(2 s, duration / 2)``), the rotor power and energy,
and the fraction of rotor commands that saturated.

With ``conditions`` (a Wind UKF preset, :data:`windnav.estimate.CONDITIONS`) the vehicle
carries that preset's sensors and the Wind UKF runs on the log under it
(:func:`windnav.experiments.ukf_conditions.estimate_wind`; no calibration flights: the filter
starts from the true parameters, less what the preset's filter does not model or gets wrong);
the summary adds the wind RMSE after the same transient.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Mapping

import numpy as np

from windnav._validate import positive_float
from windnav.sensors.models import IMU, Odometry, RotorSpeedSensor, SensorSuite

__all__ = ["WIND_KINDS", "WIND_USES", "flight_summary", "make_wind", "misfit_rates", "run_flight",
           "sensors_at", "wind_estimate"]

WIND_KINDS = ("none", "constant", "dryden")
WIND_USES = {"mean": ("constant", "dryden"), "sigma": ("dryden",)}
"""The kinds of :func:`make_wind` that use each of its arguments; the others refuse it."""


def make_wind(kind: str, mean=(0.0, 0.0, 0.0), sigma=(0.0, 0.0, 0.0), *, seed: int = 0):
    """The wind of a flight: ``"none"``, ``"constant"`` (``mean``, m/s, world frame) or
    ``"dryden"`` gusts of standard deviation ``sigma`` (m/s) around ``mean``, seeded by ``seed``.
    """
    from windnav.wind import ConstantWind, DrydenWind

    for name, value in (("mean", mean), ("sigma", sigma)):
        kinds = WIND_USES[name]
        if kind in WIND_KINDS and kind not in kinds and value is not None and np.any(
                np.asarray(value, dtype=object) != 0):
            # make_wind("none", (5, 0, 0)) flew in still air (API audit, fifty-eighth session)
            raise ValueError(f"The '{name}' parameter of make_wind applies only to the kinds "
                             f"{list(kinds)}: {kind!r} ignores it. Got {value!r} with "
                             f"kind={kind!r} instead.")
    if kind == "none":
        return ConstantWind((0.0, 0.0, 0.0))
    if kind == "constant":
        return ConstantWind(tuple(mean))
    if kind == "dryden":
        return DrydenWind(mean=tuple(mean), sigma=tuple(sigma), seed=seed)
    raise ValueError(f"The 'kind' parameter of make_wind must be one of {WIND_KINDS}. "
                     f"Got {kind!r} instead.")


def sensors_at(rate_hz: float | None = None, conditions=None, *, dt: float = 0.005
               ) -> SensorSuite | None:
    """windnav's default sensors all at ``rate_hz`` (Hz); None (the runner's defaults, each
    lowered when needed to fit the physics step) without one. With ``conditions`` (a Wind UKF
    preset): its sensors, all at ``rate_hz`` or 100 Hz lowered to fit ``dt`` (s)."""
    # rate 0 was refused naming IMU's 'rate_hz', dt=0 accepted (API audit)
    dt = positive_float(dt, "dt", "sensors_at")
    if rate_hz is not None:
        rate_hz = positive_float(rate_hz, "rate_hz", "sensors_at")
    if conditions is not None:
        from windnav.estimate.conditions import ukf_conditions
        from windnav.sim.loop import fitted_rate

        rate = fitted_rate(100.0, dt) if rate_hz is None else rate_hz
        return ukf_conditions(conditions).sensor_suite(rate)
    if rate_hz is None:
        return None
    return SensorSuite(IMU(rate_hz=rate_hz), Odometry(rate_hz=rate_hz),
                       RotorSpeedSensor(rate_hz=rate_hz))


def misfit_rates(dt: float, rates: dict[str, float]) -> dict[str, float]:
    """The ``name -> rate_hz`` of ``rates`` that are not a whole number (>= 1) of physics steps
    ``dt`` (s) per sample."""
    where = "misfit_rates"
    dt = positive_float(dt, "dt", where)  # dt=0 raised ZeroDivisionError (API audit)
    if not isinstance(rates, Mapping):
        raise ValueError(f"The 'rates' parameter of {where} must be a dict name -> rate_hz. "
                         f"Got {rates!r} instead.")
    for name, rate in rates.items():  # NaN said "cannot convert float NaN to integer"
        try:
            ok = math.isfinite(float(rate)) and float(rate) > 0
        except (TypeError, ValueError):
            ok = False
        if not ok:
            raise ValueError(f"The 'rates' parameter of {where} must give each name a finite "
                             f"rate > 0, Hz. Got {name!r}: {rate!r} instead.")
    bad = {}
    for name, rate in rates.items():
        steps = 1.0 / (rate * dt)
        if round(steps) < 1 or abs(steps - round(steps)) > 1e-6 * steps:
            bad[name] = rate
    return bad


def run_flight(vehicle: str, trajectory: str, wind, *, size: float, speed: float,
               duration: float, dt: float, control_rate_hz: float | None = None,
               sensor_rate_hz: float | None = None, hub_wind: bool = False, rng=0,
               conditions=None, progress: bool = False, return_track: bool = False):
    """Fly ``trajectory`` (from (0, 0, 2) m) in ``wind``; returns ``(log, summary)``, and with
    ``return_track`` ``(log, summary, track)``: the Wind UKF's
    :class:`~windnav.estimate.flight.WindTrack` (None without ``conditions`` or when the filter
    diverged).

    Parameters as in :func:`windnav.sim.fly` and :func:`windnav.sim.make_trajectory`;
    ``sensor_rate_hz`` (optional) runs every sensor at one rate. Without rates the controller
    (100 Hz) and the sensors run at their defaults, lowered where ``dt`` needs it. ``rng``
    (a seed) draws the sensor noise and the preset's parameter errors. ``conditions`` (a Wind
    UKF preset name, optional): fly its sensors and run the Wind UKF under it (module
    docstring); the summary gains ``conditions``, ``wind_rmse_m_s`` and
    ``wind_rmse_axes_m_s``.
    """
    import windnav as wn
    from windnav.control.se3 import default_gains
    from windnav.sim.loop import DEFAULT_CONTROL_RATE_HZ, fitted_rate

    where = "run_flight"
    duration = positive_float(duration, "duration", where)
    dt = positive_float(dt, "dt", where)
    params = wn.vehicle.params(vehicle)
    rate = (fitted_rate(DEFAULT_CONTROL_RATE_HZ, dt) if control_rate_hz is None
            else positive_float(control_rate_hz, "control_rate_hz", where))
    kd_att = default_gains(params).kd_att
    if kd_att / rate > 2.0:
        # at dt = 0.5 s the controller ran at 2 Hz and a circle fell 0.6 m in 1 s, silently (API
        # audit): between updates the body-rate loop holds its command, and the held rate term
        # alone, w <- (1 - kd_att T) w, grows once T > 2 / kd_att (43 ms for the built-in gains)
        warnings.warn(f"run_flight: the controller updates every {1.0 / rate:g} s (dt {dt:g} s), "
                      f"beyond 2 / kd_att = {2.0 / kd_att:.3g} s, where its body-rate loop "
                      "stops being stable between updates: the flight may saturate or "
                      "diverge; the vehicle's models are validated at dt 0.005-0.01 s with "
                      "100 Hz control", RuntimeWarning, stacklevel=2)
    traj = wn.sim.make_trajectory(trajectory, start=(0.0, 0.0, 2.0), size=size, speed=speed)
    log = wn.sim.fly(params, traj, wind, duration, dt=dt, control_rate_hz=control_rate_hz,
                     sensors=sensors_at(sensor_rate_hz, conditions, dt=dt), hub_wind=hub_wind,
                     rng=rng, progress=progress)
    log.meta.update(command="fly", trajectory_kind=trajectory)
    summary = flight_summary(log, duration)
    track = None
    if conditions is not None and summary["non_finite_from_s"] is not None:
        # the filter on a log of NaN failed on SciPy's "zero norm quaternions" (review)
        summary.update(conditions=conditions, wind_estimate_error=(
            f"the flight diverged at {summary['non_finite_from_s']:g} s; no wind estimate"))
    elif conditions is not None:
        estimate, track = _wind_estimate(log, params, conditions, duration, rng=rng)
        summary.update(estimate)
    return (log, summary, track) if return_track else (log, summary)


def wind_estimate(log, params, conditions, duration: float, *, rng=0) -> dict:
    """The Wind UKF's accuracy on ``log`` under ``conditions`` (see the module docstring):
    ``conditions``, ``wind_rmse_m_s`` (3D) and ``wind_rmse_axes_m_s`` after
    ``min(2 s, duration / 2)``, ``filter_covariance_repairs``; when the filter diverges
    (:class:`~windnav.estimate.FilterDivergedError`) these are None and
    ``wind_estimate_error`` says why."""
    duration = positive_float(duration, "duration", "wind_estimate")  # -1 was scored (audit)
    return _wind_estimate(log, params, conditions, duration, rng=rng)[0]


def _wind_estimate(log, params, conditions, duration: float, *, rng=0):
    """:func:`wind_estimate`'s summary and the track it scored (None when it diverged)."""
    from windnav.estimate import FilterDivergedError
    from windnav.experiments.ukf_conditions import estimate_wind

    try:
        track, applied = estimate_wind(log, params, conditions,
                                       rng=np.random.default_rng([rng, 2]))
    except FilterDivergedError as exc:  # the flight is kept; the summary says why no estimate
        name = conditions if isinstance(conditions, str) else conditions.name
        return {"conditions": name, "wind_rmse_m_s": None, "wind_rmse_axes_m_s": None,
                "filter_covariance_repairs": None, "wind_estimate_error": str(exc)}, None
    settle = min(2.0, duration / 2)
    return {"conditions": applied["conditions"], "wind_rmse_m_s": track.rmse_after(settle),
            "wind_rmse_axes_m_s": [track.rmse_after(settle, axis=k) for k in range(3)],
            "wind_mean_error_m_s": [float(e) for e in track.mean_error_after(settle)],
            **drag_model_note(log, params, conditions, settle),
            "filter_covariance_repairs": int(track.repairs)}, track


def drag_model_note(log, params, conditions, settle_s: float, *, believed=None) -> dict:
    """``drag_model_bias_m_s``: the bias the filter's drag model under ``conditions`` (what it
    leaves out of the vehicle's, e.g. the frame drag of the thesis's presets; not the
    preset's random parameter errors) gives its wind estimate at the flight's median
    horizontal airspeed after ``settle_s`` (:func:`windnav.estimate.drag_model_bias`), m/s
    along the airflow; and that airspeed, ``median_horizontal_airspeed_m_s``. ``params`` is
    the vehicle flown; ``believed`` what the filter starts from (default ``params``; the
    calibrated parameters where the conditions calibrate)."""
    from windnav.estimate import drag_model_bias
    from windnav.experiments.ukf_conditions import believed_model

    model = believed_model(params if believed is None else believed, conditions)
    air = np.linalg.norm((log.velocity - log.wind)[..., :2], axis=-1)[log.t >= settle_s]
    median = float(np.median(air)) if air.size else 0.0
    return {"median_horizontal_airspeed_m_s": median,
            "drag_model_bias_m_s": float(drag_model_bias(params, model, median))}


def settled(log, duration: float) -> np.ndarray:
    """(T,) bool: the logged instants after the take-off transient, ``t >= min(2 s,
    duration / 2)``: the window every summary's tracking error is taken over."""
    return _settled(log, duration, "settled")


def _settled(log, duration, where: str) -> np.ndarray:
    """:func:`settled`, ``duration`` checked and named in ``where``'s errors (NaN kept no
    instant, a duration past the log's end none either; API audit)."""
    duration = positive_float(duration, "duration", where)
    keep = np.asarray(log.t) >= min(2.0, duration / 2)
    if not keep.any():
        end = float(np.max(log.t)) if np.size(log.t) else 0.0
        raise ValueError(f"The 'duration' parameter of {where} must be the flight's duration, "
                         f"leaving a logged instant at or after min(2 s, duration / 2) = "
                         f"{min(2.0, duration / 2):g} s (the log ends at {end:g} s). Got "
                         f"{duration!r} instead.")
    return keep


def tracking_rms(log, duration: float) -> float:
    """RMS of the position error (m) over every vehicle and :func:`settled`'s instants:
    ``rms_tracking_error_m`` of ``windnav fly`` and of ``windnav demo --story ukf`` (whose
    tracking error took in the take-off too: over one 12 s waypoint flight in a 6 m/s wind,
    ``run_flight("hummingbird", "waypoints", ConstantWind((6, 0, 0)), size=20, speed=4,
    duration=12)``, 0.60 m where ``fly``'s gave 0.66 m; about 1 % apart on the UKF story's own
    flights; definitions audit)."""
    err = log.tracking_error[_settled(log, duration, "tracking_rms")]
    return float(np.sqrt(np.mean(err ** 2)))


def flight_summary(log, duration: float) -> dict:
    """Tracking error (m) after the take-off transient, power (W), energy (J), saturation,
    mean wind speed (m/s) and the flight status (``OK``, or the flags of
    :class:`windnav.sim.log.FlightStatus`: saturated, outside the envelope, non-finite) of
    ``log``, with the fraction of logged instants outside the envelope (all, and after the
    transient) and the largest and median airspeed (m/s). A flight whose state stopped being
    finite has no energy (null: the log holds it from that step on, which read as a small,
    plausible number: 0.42 J for a 2 s flight in a 1e5 m/s wind) and says when it stopped
    (``non_finite_from_s``, else null).

    The energy is the rotors' (:attr:`windnav.sim.log.FlightLog.energy`, the first vehicle),
    ``rotor_energy_J``, as ``navigate`` and the benchmark name it; ``energy_J`` is the same
    number under its older name, kept for the scripts that read it, though in ``navigate``,
    the benchmark and ``windnav demo --story navigate`` ``energy_J`` is the airspeed power
    curve's energy."""
    settled_ = settled(log, duration)
    stopped = ~np.isfinite(np.asarray(log.power)).all(axis=1)
    err = log.tracking_error[settled_]
    rotor_energy = None if stopped.any() else float(log.energy[-1, 0])
    airspeed = np.linalg.norm(log.velocity - log.wind, axis=-1)
    outside = np.asarray(log.outside_envelope, bool)
    return {
        "status": log.meta.get("status"),
        # the status flags a flight outside the envelope at any instant: these say how much
        # of it, after the take-off transient too, and how far (the model's trusted airspeed is
        # meta["envelope"]["max_airspeed"])
        "outside_envelope_fraction": float(outside.mean()) if outside.size else 0.0,
        "outside_envelope_fraction_settled": (float(outside[settled_].mean())
                                              if outside[settled_].size else 0.0),
        "max_airspeed_m_s": float(airspeed.max()) if airspeed.size else 0.0,
        "median_airspeed_m_s": float(np.median(airspeed)) if airspeed.size else 0.0,
        "rms_tracking_error_m": tracking_rms(log, duration),
        "max_tracking_error_m": float(np.max(err)),
        "mean_power_W": float(log.power.mean()),
        "rotor_energy_J": rotor_energy,
        # the same number under its old name, which elsewhere (navigate, the benchmark, the
        # navigation demo) is the airspeed power curve's energy (definitions audit)
        "energy_J": rotor_energy,
        "non_finite_from_s": float(log.t[np.argmax(stopped)]) if stopped.any() else None,
        "rotor_saturation_fraction": log.saturation_fraction,
        "mean_wind_speed_m_s": float(np.linalg.norm(log.wind, axis=-1).mean()),
    }
