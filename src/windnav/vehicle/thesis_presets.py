"""Vehicle presets with the coefficients the thesis identified (S. Folk 2026, ch. 6).

``crazyflie_thesis``: the Crazyflie 2.1 Brushless as the thesis measured it, built from
RotorPy's ``crazyflie_brushless`` (:func:`windnav.vehicle.params`) with ``dataclasses.replace``.
Where each value comes from:

=====================  ===================  ================================================
value                  number               source
=====================  ===================  ================================================
mass, inertia, arms,   as crazyflie_        RotorPy ``crazyfliebrushless_params.py`` (not
k_m, tau_m, limits     brushless            re-identified by the thesis)
k_eta                  4.052e-8 N/(rad/s)^2 thrust stand, ``k_eta = sum(T w^2) / sum(w^4)``
                                            (steady points of the PWM ramps)
k_d                    5.09e-6 kg/rad       tunnel hover: slope of lateral specific force
                                            against ``v_a sum(eta)``
k_z                    1.19e-5 kg/rad       tunnel hover: joint vertical fit
k_h                    1.11e-3 kg/m         tunnel hover: joint vertical fit
extra["k_eta_hover"]   4.26e-8 N/(rad/s)^2  tunnel hover: the joint vertical fit's thrust
                                            coefficient (in flight, with the airframe's
                                            blockage), kept as metadata
extra["pwm_motor"]     Kv 0.3637,           thrust stand: ``w = Kv (V + V0)(PWM - DZ)^(2/3)``
                       V0 0.5535 V,         by nonlinear least squares (R^2 0.979); see
                       DZ 4673 counts       :class:`windnav.sysid.PWMMotorModel`
extra["power_curve"]   10.56, 0.15160,      electrical power against airspeed, W, ascending
                       -0.14970, 0.021114   powers of V (m/s); :meth:`PowerCurve.crazyflie`
=====================  ===================  ================================================

The dynamics use ``k_eta`` from the stand (per rotor, the coefficient the PWM model was fitted
with); RotorPy's preset already carries the thesis's stand and tunnel values for k_eta, k_d,
k_z and k_h, so the physics equals ``crazyflie_brushless``; this preset adds the motor model,
the in-flight thrust coefficient and the power curve, and names the provenance.

Two of RotorPy's values do not fit the thesis's measurements (kept: the thesis did not identify
them; ``docs/sysid.md``): ``k_m`` gives 13.56 W of rotor shaft power in hover, above the
10.56 W of electrical power the thesis measured (a consistent ``k_m`` is at most 6.07e-10), and
``rotor_speed_max`` = 3,100 rad/s exceeds the PWM law's 2,506 rad/s at full PWM and 3.9 V.
"""

from __future__ import annotations

from windnav.vehicle.params import MultirotorParams, _hovering, params
from windnav.vehicle.power import PowerCurve

__all__ = ["THESIS_CRAZYFLIE", "crazyflie_thesis"]

THESIS_CRAZYFLIE = {
    "k_eta": 4.052e-8,       # N/(rad/s)^2, thrust stand
    "k_eta_hover": 4.26e-8,  # N/(rad/s)^2, tunnel hover (joint fit with k_z, k_h)
    "k_d": 5.09e-6,          # kg/rad, tunnel hover
    "k_z": 1.19e-5,          # kg/rad, tunnel hover
    "k_h": 1.11e-3,          # kg/m, tunnel hover
    "Kv": 0.3637,            # rad/s per V per count^(2/3), thrust stand
    "V0": 0.5535,            # V, thrust stand
    "DZ": 4673.0,            # PWM counts, thrust stand
    "r2_motor": 0.979,       # R^2 of the PWM motor model
}
"""The thesis's identified values (ch. 6), SI units."""


def crazyflie_thesis(**overrides) -> MultirotorParams:
    """The Crazyflie 2.1 Brushless with the thesis's identified coefficients.

    Parameters
    ----------
    **overrides
        Fields to change afterwards (``crazyflie_thesis(mass=0.05)``).

    Returns
    -------
    MultirotorParams
        Named ``"crazyflie_thesis"``; ``extra`` holds ``pwm_motor`` (``Kv``, ``V0``, ``DZ``,
        ``pwm_max``), ``k_eta_hover``, ``power_curve`` (ascending W coefficients),
        ``power_curve_speed_max`` (m/s) and ``sources`` (where each value comes from).

    Raises
    ------
    ValueError
        Naming the overrides that leave a vehicle unable to hover, as
        :func:`windnav.vehicle.params` does.
    """
    return _hovering(_thesis_params(overrides), overrides, "crazyflie_thesis")


def _thesis_params(overrides: dict) -> MultirotorParams:
    """:func:`crazyflie_thesis` with ``overrides``, unchecked for hover."""
    th = THESIS_CRAZYFLIE
    base = params("crazyflie_brushless")
    curve = PowerCurve.crazyflie()
    extra = {
        **base.extra,
        "pwm_motor": {"Kv": th["Kv"], "V0": th["V0"], "DZ": th["DZ"], "pwm_max": 65535.0,
                      "r2": th["r2_motor"]},
        "k_eta_hover": th["k_eta_hover"],
        "power_curve": [float(c) for c in curve.coefficients],
        "power_curve_speed_max": curve.speed_max,
        "sources": {
            "k_eta": "thesis ch. 6 thrust stand: sum(T w^2)/sum(w^4) over steady points",
            "k_d": "thesis ch. 6 tunnel hover: lateral specific force vs v_a sum(eta)",
            "k_z": "thesis ch. 6 tunnel hover: joint vertical fit",
            "k_h": "thesis ch. 6 tunnel hover: joint vertical fit",
            "k_eta_hover": "thesis ch. 6 tunnel hover: joint vertical fit",
            "pwm_motor": "thesis ch. 6 thrust stand: w = Kv (V + V0)(PWM - DZ)^(2/3)",
            "power_curve": "thesis ch. 6: cubic through hover 10.56 W, min 10.12 W at "
                           "4.15 m/s, max-range speed 7.73 m/s",
            "other": "RotorPy crazyfliebrushless_params.py (mass, inertia, geometry, k_m, "
                     "tau_m, rotor-speed limits)",
        },
    }
    p = base.replace(name="crazyflie_thesis", k_eta=th["k_eta"], k_d=th["k_d"], k_z=th["k_z"],
                     k_h=th["k_h"], extra=extra)
    return p.replace(**overrides) if overrides else p
