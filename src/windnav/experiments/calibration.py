"""Calibration flights of the Wind UKF's drag model: a simulated wind tunnel, then the fit.

Steady flight at airspeed ``V`` through still air is, by Galilean invariance, hover in a
uniform wind of ``-V`` (a wind tunnel): :func:`calibration_flights` hovers one batch row per
(axis, airspeed) in such a wind (:class:`windnav.sim.sweeps.RowWind`), with the SE(3) controller
and the sensors of the study; :func:`calibrate` then fits the drag coefficients by least squares
(:func:`windnav.estimate.calibrate.fit_drag`, the pure fitting math, which knows nothing of the
simulator).

:func:`calibration_notes` says when the fitted model leaves out a drag term the vehicle has
(``--linear`` on the Hummingbird, whose frame drag is 0.005/0.005/0.01 N/(m/s)^2: k_d came
out +9.0 % and k_z +6.2 %, thousands of standard errors from the truth, and only the table's
truth column, there because the data are simulated, showed it).
"""

from __future__ import annotations

import math
import warnings

import numpy as np

from windnav._validate import finite_float, positive_float
from windnav.estimate.calibrate import AXES, DEFAULT_SPEEDS, DragFit, fit_drag
from windnav.sensors.models import IMU, Odometry, RotorSpeedSensor, SensorSuite
from windnav.sim.log import FlightLog
from windnav.sim.runner import fly
from windnav.sim.sweeps import RowWind
from windnav.sim.trajectories import Hover
from windnav.vehicle.params import MultirotorParams

__all__ = ["DEFAULT_SPEEDS", "calibrate", "calibration_flights", "calibration_notes"]


def _rng(rng, seed, where: str):
    """``rng``, or the deprecated ``seed`` alias (with a DeprecationWarning)."""
    if seed is None:
        return rng
    if rng is not None:
        raise ValueError(f"The 'seed' parameter of {where} is a deprecated alias of 'rng'; pass "
                         f"only one of them. Got seed={seed!r} and rng={rng!r}.")
    warnings.warn(f"The 'seed' parameter of {where} is deprecated; use 'rng'.",
                  DeprecationWarning, stacklevel=3)
    return seed


def calibration_flights(
    params: MultirotorParams,
    speeds: dict | None = None,
    *,
    duration: float = 6.0,
    dt: float = 0.005,
    sensor_rate_hz: float = 100.0,
    sensors: SensorSuite | None = None,
    rng: np.random.Generator | int | None = None,
    seed: np.random.Generator | int | None = None,
) -> FlightLog:
    """Simulate the calibration: hover, one batch row per (axis, airspeed), in a tunnel wind.

    Parameters
    ----------
    params : MultirotorParams
        The true vehicle.
    speeds : dict of str to sequence of float, optional
        Signed airspeeds (m/s) per body axis ``"x"``, ``"y"``, ``"z"``; default
        :data:`DEFAULT_SPEEDS`. A zero-speed row (hover) is always added.
    duration : float
        Flight time of every row, s.
    dt : float
        Physics step, s.
    sensor_rate_hz : float
        Rate of the IMU, odometry and rotor-speed sensors, Hz (when ``sensors`` is None).
    sensors : SensorSuite, optional
        Overrides the default suite.
    rng : numpy.random.Generator or int, optional
        Sensor noise (default seed 0, as :func:`windnav.sim.fly`).
    seed : numpy.random.Generator or int, optional
        Deprecated alias of ``rng``.

    Returns
    -------
    FlightLog
        ``meta["airspeed_world"]`` lists the (B, 3) airspeed of each row, m/s.
    """
    where = "calibration_flights"
    rng = _rng(rng, seed, where)
    speeds = DEFAULT_SPEEDS if speeds is None else speeds
    unknown = set(speeds) - set(AXES)
    if unknown:
        raise ValueError(f"The 'speeds' parameter of {where} has unknown axes {sorted(unknown)};"
                         f" known: {sorted(AXES)}.")
    rows = [np.zeros(3)]
    for axis, values in speeds.items():
        for v in np.asarray(values, dtype=np.float64).reshape(-1):
            finite_float(v, f"speeds[{axis!r}]", where)
            row = np.zeros(3)
            row[AXES[axis]] = v
            rows.append(row)
    airspeed = np.array(rows)
    rate = positive_float(sensor_rate_hz, "sensor_rate_hz", where)
    if sensors is None:
        sensors = SensorSuite(IMU(rate_hz=rate), Odometry(rate_hz=rate),
                              RotorSpeedSensor(rate_hz=rate))
    # flying at +V through still air == hovering in a wind of -V (yaw 0: body = world axes)
    log = fly(params, Hover((0.0, 0.0, 10.0)), RowWind(-airspeed), duration, dt=dt,
              batch=airspeed.shape[0], sensors=sensors, rng=rng)
    log.meta["airspeed_world"] = airspeed.tolist()
    return log


def calibrate(
    params_true: MultirotorParams,
    *,
    speeds: dict | None = None,
    duration: float = 6.0,
    settle_s: float = 3.0,
    parasitic: bool = True,
    sensors: SensorSuite | None = None,
    rng: np.random.Generator | int | None = None,
    seed: np.random.Generator | int | None = None,
) -> tuple[DragFit, MultirotorParams]:
    """Fly the calibration flights of ``params_true`` and fit its drag coefficients.

    Arguments are those of :func:`calibration_flights` and
    :func:`windnav.estimate.calibrate.fit_drag`.

    Returns
    -------
    fit : DragFit
        Its ``undetermined`` coefficients (flights along too few axes, ``speeds={"x": ...}``)
        have NaN standard errors, and ``fit_drag`` warns (``RuntimeWarning``) naming them.
    params_filter : MultirotorParams
        ``params_true`` with the drag coefficients replaced by the fitted ones, undetermined or
        not (:meth:`DragFit.apply`, whose warning would repeat ``fit_drag``'s): what the Wind
        UKF believes (mass, thrust and lift coefficients known).
    """
    rng = _rng(rng, seed, "calibrate")
    log = calibration_flights(params_true, speeds, duration=duration, sensors=sensors, rng=rng)
    fit = fit_drag(log, params_true, settle_s=settle_s, parasitic=parasitic)
    return fit, params_true.replace(**fit.coefficients)


def calibration_notes(fit: DragFit, truth: MultirotorParams, speeds: dict | None = None
                      ) -> list[str]:
    """Caveats of a calibration whose truth is known (simulated), one sentence each.

    A note when the fitted model leaves out a drag term ``truth`` has (the frame drag
    ``c_dx, c_dy, c_dz`` of a fit without ``parasitic``): ``k_d`` and ``k_z`` then absorb it.
    It gives how far they lie from the truth (percent and standard errors) and where their
    linear drag equals the true one: along an in-plane axis, with hover's rotor-speed sum ``S``,
    ``k_d' S V = k_d S V + c_d V^2`` at ``V* = (k_d' - k_d) S / c_d``; below ``V*`` the fitted
    drag is too large, above it too small, so a Wind UKF built on it is biased at airspeeds
    unlike the calibration's.

    Parameters
    ----------
    fit : DragFit
    truth : MultirotorParams
        The simulated vehicle.
    speeds : dict, optional
        The calibration's airspeeds per axis, m/s (default :data:`DEFAULT_SPEEDS`).

    Returns
    -------
    list of str
        Empty when the model has every drag term the vehicle has.
    """
    omitted = [] if fit.parasitic else [k for k in ("c_dx", "c_dy", "c_dz")
                                        if getattr(truth, k) > 0]
    if not omitted:
        return []
    speeds = DEFAULT_SPEEDS if speeds is None else speeds
    top = {a: max((abs(float(v)) for v in speeds.get(a, ())), default=0.0) for a in AXES}
    s_hover = truth.n_rotors * truth.hover_rotor_speed
    errors = []
    for k in ("k_d", "k_z"):
        true, got = getattr(truth, k), getattr(fit, k)
        se = fit.stderr.get(k)
        z = ("" if not se or not math.isfinite(se)  # NaN: undetermined (fit.undetermined)
             else f" ({abs(got - true) / se:.3g} standard errors)")
        errors.append(f"{k} {100 * (got / true - 1):+.1f} %{z}")
    where = []
    for name, k, c, top_v in (
            ("in-plane", "k_d", 0.5 * (truth.c_dx + truth.c_dy), max(top["x"], top["y"])),
            ("vertical", "k_z", truth.c_dz, top["z"])):
        true, got = getattr(truth, k), getattr(fit, k)
        if c <= 0 or got <= true:
            continue
        v_eq = (got - true) * s_hover / c
        slow, fast = 0.5 * v_eq, 2.0 * v_eq
        err = [100 * (got * s_hover / (true * s_hover + c * v) - 1) for v in (slow, fast)]
        where.append(f"{name} near {v_eq:.2g} m/s (the calibration flew up to {top_v:g} m/s), "
                     f"{err[0]:+.0f} % at {slow:.2g} m/s and {err[1]:+.0f} % at {fast:.2g} m/s")
    drag = ", ".join(f"{k} = {getattr(truth, k):g}" for k in omitted)
    return [f"the fitted model leaves out {truth.name}'s frame drag ({drag} N/(m/s)^2), so k_d "
            f"and k_z absorb it: {' and '.join(errors)} from the truth"
            + ("; their linear drag matches the true drag (at hover's rotor speeds) only "
               + "; ".join(where) if where else "")
            + ", so a Wind UKF built on them is biased at airspeeds unlike the calibration's; "
            "fit the frame drag too (windnav calibrate without --linear, "
            "fit_drag(parasitic=True))"]
