"""The Wind UKF under named conditions: what the filter is told, and the thesis's gusts.

:func:`estimate_wind` is the one place that turns a flown log into the Wind UKF's estimate under
a :class:`~windnav.estimate.conditions.UKFConditions` preset; the Monte Carlo, ``windnav fly``
and the demo all call it. It applies the parts of the conditions that the filter cannot see for
itself:

- **what the filter believes about the vehicle**: the given (e.g. calibrated) parameters, with
  the parasitic drag set to zero when the conditions' filter does not model it, and every
  believed parameter (mass, ``k_eta``, ``k_d``, ``k_z``, ``k_h``, ``tau_m``) scaled by
  ``1 + U(-e, e)`` when ``parameter_error = e > 0``;
- **what the filter sees of the motors** (``rotor_speeds="pwm"``, the hardware): every rotor
  speed command is sent as a PWM count through the true motor law of
  :class:`windnav.sysid.PWMMotorModel` (the thesis's Crazyflie fit, ``omega = Kv (V + V0)
  (PWM - DZ)^(2/3)``) at the battery voltage, rounded to a whole count, and read back through
  the same law with ``Kv`` scaled by ``1 + U(-kv_error, kv_error)`` (:func:`pwm_rotor_speed_map`);
  the battery voltage is measured (the hardware's INA sensor resolves millivolts), so only
  ``Kv``'s error remains.

:func:`rotorpy_dryden` is the thesis's turbulence: RotorPy's ``DrydenGust`` at its intensity
``sigma`` (30-60 in the thesis), stepped at RotorPy's default 100 Hz and altitude 2 m, through
the :class:`windnav.wind.FromRotorPy` adapter (RotorPy is imported when called).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from windnav._extras import install_hint
from windnav.estimate.conditions import UKFConditions, ukf_conditions
from windnav.estimate.flight import WindTrack, run_wind_ukf
from windnav.sysid.thrust_stand import PWMMotorModel
from windnav.vehicle.params import MultirotorParams

__all__ = [
    "BATTERY_VOLTAGE",
    "PERTURBED_PARAMETERS",
    "ROTORPY_GUST_ALTITUDE",
    "ROTORPY_GUST_DT",
    "believed_model",
    "believed_params",
    "estimate_wind",
    "pwm_rotor_speed_map",
    "rotorpy_dryden",
]

PERTURBED_PARAMETERS = ("mass", "k_eta", "k_d", "k_z", "k_h", "tau_m")
"""Believed parameters that ``parameter_error`` scales."""

BATTERY_VOLTAGE = 3.9
"""Battery voltage of the PWM chain, V (a charged 1S LiPo in flight)."""

ROTORPY_GUST_DT = 0.01
"""Step of RotorPy's Dryden gusts, s: RotorPy's default simulation rate (100 Hz). The gust
amplitude of RotorPy's discretisation depends on its step (its white input is not scaled by
the step): at 0.01 s an intensity of 30-60 gives gusts of about 0.9-1.9 m/s."""

ROTORPY_GUST_ALTITUDE = 2.0
"""Altitude argument of RotorPy's ``DrydenGust`` (its default), m: length scales of about
15 m horizontally and 2 m vertically at its fixed 1 m/s airspeed."""


def believed_params(params: MultirotorParams, conditions: str | UKFConditions, *,
                    rng: np.random.Generator | int | None = None
                    ) -> tuple[MultirotorParams, dict[str, float]]:
    """What the filter believes under ``conditions``, starting from ``params``.

    Returns
    -------
    params_filter : MultirotorParams
    errors : dict of str to float
        The relative error drawn for each of :data:`PERTURBED_PARAMETERS` (empty when
        ``parameter_error`` is 0).
    """
    cond = ukf_conditions(conditions)
    out = params
    if not cond.parasitic_drag:
        out = out.replace(c_dx=0.0, c_dy=0.0, c_dz=0.0)
    errors = {}
    if cond.parameter_error > 0:
        gen = np.random.default_rng(rng)
        e = cond.parameter_error
        errors = {k: float(gen.uniform(-e, e)) for k in PERTURBED_PARAMETERS}
        out = out.replace(**{k: getattr(out, k) * (1.0 + v) for k, v in errors.items()})
    return out, errors


def believed_model(params: MultirotorParams, conditions: str | UKFConditions
                   ) -> MultirotorParams:
    """What the filter's force model believes under ``conditions`` by design, starting from
    ``params`` (the true or calibrated parameters): :func:`believed_params` without the
    preset's random parameter errors (e.g. the thesis's presets without the frame drag)."""
    cond = ukf_conditions(conditions)
    return believed_params(params, replace(cond, parameter_error=0.0))[0]


def pwm_rotor_speed_map(kv_error: float = 0.0, *, motor: PWMMotorModel | None = None,
                        voltage: float = BATTERY_VOLTAGE):
    """``(t, cmd) -> omega``: rotor-speed commands (rad/s) sent as PWM counts through
    ``motor`` at ``voltage`` (V) and read back with ``Kv (1 + kv_error)``.

    Parameters
    ----------
    kv_error : float
        Relative error of the believed ``Kv``.
    motor : PWMMotorModel, optional
        The true motor law; default the thesis's Crazyflie fit.
    voltage : float
        Battery voltage, V (measured exactly).
    """
    true = PWMMotorModel.thesis() if motor is None else motor
    believed = PWMMotorModel(Kv=true.Kv * (1.0 + kv_error), V0=true.V0, DZ=true.DZ,
                             pwm_max=true.pwm_max)

    def rotor_speed_map(t, cmd):
        pwm = np.round(true.pwm(cmd, voltage))
        return believed.rotor_speed(pwm, voltage)

    return rotor_speed_map


def rotorpy_dryden(mean, intensity, *, seed: int, dt: float = ROTORPY_GUST_DT,
                   altitude: float = ROTORPY_GUST_ALTITUDE):
    """RotorPy's ``DrydenGust`` (mean ``mean`` m/s, intensity ``intensity`` per axis) as a
    windnav wind field, reproducible under ``seed`` (see the module docstring).

    Needs RotorPy (the ``rotorpy`` extra): the thesis's gusts are RotorPy's own process."""
    try:
        from rotorpy.wind.dryden_winds import DrydenGust
    except ImportError as exc:
        raise ModuleNotFoundError(
            "The 'thesis' and 'hardware' conditions fly RotorPy's DrydenGust; "
            f"{install_hint('rotorpy')}.", name=exc.name) from exc

    from windnav.wind.adapters import FromRotorPy

    gust = DrydenGust(dt=dt, avg_wind=np.asarray(mean, dtype=np.float64),
                      sig_wind=np.asarray(intensity, dtype=np.float64), altitude=altitude)
    return FromRotorPy(gust, dt=dt, seed=seed)


def estimate_wind(log, params: MultirotorParams, conditions: str | UKFConditions = "windnav",
                  *, rng: np.random.Generator | int | None = None, **options
                  ) -> tuple[WindTrack, dict]:
    """The Wind UKF's estimate of a flown ``log`` under ``conditions``.

    Parameters
    ----------
    log : FlightLog
        Flown with ``conditions.sensor_suite(...)`` (or any sensors with the same names).
    params : MultirotorParams
        What the filter would believe with perfect knowledge under these conditions: the
        calibrated parameters where the conditions calibrate, else the true ones.
    conditions : str or UKFConditions
    rng : numpy.random.Generator or int, optional
        Draws the parameter and ``Kv`` errors (None: fresh entropy; unused when the
        conditions draw no error).
    **options
        Passed to :func:`~windnav.estimate.run_wind_ukf` (``q``, ``r``, ``wind_frame``,
        ``vehicle``, ``progress``, ...), overriding the conditions'.

    Returns
    -------
    track : WindTrack
    applied : dict
        ``conditions`` (name), ``parameter_errors`` (relative, per parameter) and
        ``kv_error`` (relative, or None without the PWM chain).
    """
    cond = ukf_conditions(conditions)
    gen = np.random.default_rng(rng)
    believed, errors = believed_params(params, cond, rng=gen)
    rotor_map, kv = None, None
    if cond.rotor_speeds == "pwm":
        kv = float(gen.uniform(-cond.kv_error, cond.kv_error)) if cond.kv_error > 0 else 0.0
        rotor_map = pwm_rotor_speed_map(kv)
    track = run_wind_ukf(log, believed, conditions=cond, rotor_speed_map=rotor_map, **options)
    return track, {"conditions": cond.name, "parameter_errors": errors, "kv_error": kv}
