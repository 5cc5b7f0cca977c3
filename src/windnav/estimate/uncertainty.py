"""A-priori wind uncertainty of a single measurement (Folk 2026, appendix A).

With the linear rotor-drag model along one body axis,

    a_x = -(k_d sum(eta) / m) (v_x - w_x)     =>     w_x = v_x + m a_x / (k_d sum(eta)),

first-order error propagation of independent velocity and accelerometer noise gives

    sigma_w^2 = sigma_v^2 + D^2 sigma_a^2,     D = m / (k sum(eta))   [s]

with ``k = k_d`` for the body x and y axes and ``k = k_z`` for z. Biases ``b_v`` (m/s) and
``b_a`` (m/s^2) propagate the same way into a systematic wind error ``b_w``. They are combined:

    combine="rss"    sigma_total = sqrt(sigma_v^2 + D^2 sigma_a^2 + b_v^2 + D^2 b_a^2)
    combine="worst"  sigma_total = sqrt(sigma_v^2 + D^2 sigma_a^2) + |b_v| + D |b_a|

"rss" treats the (unknown-sign) biases as further independent errors; "worst" adds them at
full magnitude with the same sign, an upper bound. A vehicle with a large drag-to-mass ratio
``k sum(eta) / m`` (s^-1) turns accelerometer noise into a small wind error; a heavy vehicle
with little rotor drag cannot sense wind well from one sample.

A filter whose drag model is not the vehicle's is biased instead (:func:`drag_model_bias`):
in a steady airflow ``V`` along a body axis, at hover rotor speeds, the vehicle's drag per unit
mass is ``(k_d N eta_h V + c_d V^2) / m``, and the filter reads the airspeed ``V_hat`` at which
its own model gives that drag, ``(k_d' N eta_h V_hat + c_d' V_hat^2) / m' = ...``. A filter
without the frame drag ``c_d`` of the Hummingbird (the thesis's conditions) reads ``V_hat - V
= c_d V^2 / (k_d N eta_h)``: +0.36 m/s at 4 m/s, +1.43 m/s at 8 m/s (measured in hover: +0.37
and +1.6 m/s, ``docs/ukf.md``).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from windnav.vehicle.params import MultirotorParams
from windnav.vehicle.params import params as vehicle_params

__all__ = ["DRAG_BIAS_NOTE_MPS", "compare_vehicles", "drag_model_bias", "wind_uncertainty",
           "wind_uncertainty_axes"]

DRAG_BIAS_NOTE_MPS = 0.1
"""m/s: the :func:`drag_model_bias` above which the commands note that the Wind UKF's drag
model is not the vehicle's (its estimates biased by about that much along the airflow)."""

_COMBINE = ("rss", "worst")


def _nonneg(value, name: str, where: str) -> np.ndarray:
    a = np.asarray(value, dtype=np.float64)
    if not np.all(np.isfinite(a)) or np.any(a < 0):
        raise ValueError(f"The {name!r} parameter of {where} must be finite and >= 0. "
                         f"Got {value!r} instead.")
    return a


def wind_uncertainty(mass, drag_coeff, rotor_speed_sum, sigma_accel, sigma_velocity,
                     bias_accel=0.0, bias_velocity=0.0, *, combine: str = "rss"):
    """One-sample wind uncertainty along one axis from the linear drag model.

    All arguments broadcast against each other (numpy rules).

    Parameters
    ----------
    mass : float or ndarray
        Vehicle mass, kg (> 0).
    drag_coeff : float or ndarray
        Rotor drag coefficient of the axis (``k_d`` in x/y, ``k_z`` in z), kg/rad (> 0).
    rotor_speed_sum : float or ndarray
        ``sum_i eta_i``, rad/s (> 0); at hover ``N * hover_rotor_speed``.
    sigma_accel : float or ndarray
        Accelerometer noise standard deviation, m/s^2.
    sigma_velocity : float or ndarray
        Velocity noise standard deviation, m/s.
    bias_accel : float or ndarray
        Accelerometer bias magnitude, m/s^2.
    bias_velocity : float or ndarray
        Velocity bias magnitude, m/s.
    combine : {"rss", "worst"}
        How biases join the noise (see the module docstring).

    Returns
    -------
    float or ndarray
        Wind standard deviation (or bound, for "worst"), m/s.
    """
    where = "wind_uncertainty"
    if combine not in _COMBINE:
        raise ValueError(f"The 'combine' parameter of {where} must be one of {list(_COMBINE)}. "
                         f"Got {combine!r} instead.")
    m = _nonneg(mass, "mass", where)
    k = _nonneg(drag_coeff, "drag_coeff", where)
    s = _nonneg(rotor_speed_sum, "rotor_speed_sum", where)
    if np.any(m == 0) or np.any(k == 0) or np.any(s == 0):
        raise ValueError(f"The 'mass', 'drag_coeff' and 'rotor_speed_sum' parameters of {where}"
                         " must be > 0 (wind is unobservable from drag when k sum(eta) = 0).")
    sa = _nonneg(sigma_accel, "sigma_accel", where)
    sv = _nonneg(sigma_velocity, "sigma_velocity", where)
    ba = np.abs(np.asarray(bias_accel, dtype=np.float64))
    bv = np.abs(np.asarray(bias_velocity, dtype=np.float64))
    if not (np.all(np.isfinite(ba)) and np.all(np.isfinite(bv))):
        raise ValueError(f"The 'bias_accel' and 'bias_velocity' parameters of {where} must be "
                         "finite.")
    D = m / (k * s)
    noise2 = sv**2 + (D * sa) ** 2
    if combine == "rss":
        out = np.sqrt(noise2 + bv**2 + (D * ba) ** 2)
    else:
        out = np.sqrt(noise2) + bv + D * ba
    return float(out) if np.ndim(out) == 0 else out


def wind_uncertainty_axes(params: MultirotorParams, sigma_accel, sigma_velocity,
                          bias_accel=0.0, bias_velocity=0.0, *, rotor_speed_sum=None,
                          combine: str = "rss") -> np.ndarray:
    """Per-axis one-sample wind uncertainty of a vehicle (x, y with ``k_d``; z with ``k_z``).

    Parameters
    ----------
    params : MultirotorParams
    sigma_accel, sigma_velocity, bias_accel, bias_velocity : float or array_like of shape (3,)
        Per-axis (or common) noise and bias, m/s^2 and m/s.
    rotor_speed_sum : float, optional
        ``sum eta_i``, rad/s; default the hover value ``N * params.hover_rotor_speed``.
    combine : {"rss", "worst"}

    Returns
    -------
    ndarray of shape (3,)
        Wind uncertainty along body x, y, z, m/s.
    """
    if not isinstance(params, MultirotorParams):
        raise ValueError("The 'params' parameter of wind_uncertainty_axes must be a "
                         f"MultirotorParams. Got {type(params).__name__} instead.")
    if rotor_speed_sum is None:
        rotor_speed_sum = params.n_rotors * params.hover_rotor_speed
    k = np.array([params.k_d, params.k_d, params.k_z])
    return np.asarray(wind_uncertainty(params.mass, k, rotor_speed_sum, sigma_accel,
                                       sigma_velocity, bias_accel, bias_velocity,
                                       combine=combine), dtype=np.float64).reshape(3)


def compare_vehicles(vehicles: Sequence[MultirotorParams | str], sigma_accel, sigma_velocity,
                     bias_accel=0.0, bias_velocity=0.0, *, combine: str = "rss") -> list[dict]:
    """Hover one-sample wind uncertainty of several vehicles, for side-by-side comparison.

    Parameters
    ----------
    vehicles : sequence of MultirotorParams or built-in vehicle names
    sigma_accel, sigma_velocity, bias_accel, bias_velocity, combine
        As in :func:`wind_uncertainty_axes` (the same sensors on every vehicle).

    Returns
    -------
    list of dict
        One per vehicle, in order: ``name``, ``mass`` (kg), ``rotor_speed_sum`` (rad/s),
        ``drag_to_mass_xy`` and ``drag_to_mass_z`` (``k sum(eta) / m``, 1/s) and
        ``sigma_wind`` (ndarray (3,), m/s, body x, y, z).
    """
    rows = []
    for v in vehicles:
        p = vehicle_params(v) if isinstance(v, str) else v
        s = p.n_rotors * p.hover_rotor_speed
        rows.append({
            "name": p.name,
            "mass": p.mass,
            "rotor_speed_sum": s,
            "drag_to_mass_xy": p.k_d * s / p.mass,
            "drag_to_mass_z": p.k_z * s / p.mass,
            "sigma_wind": wind_uncertainty_axes(p, sigma_accel, sigma_velocity, bias_accel,
                                                bias_velocity, combine=combine),
        })
    return rows


def drag_model_bias(true: MultirotorParams, believed: MultirotorParams, airspeed,
                    axis: str = "x") -> np.ndarray:
    """The steady airspeed a filter believing ``believed`` reads where ``true`` flies at
    ``airspeed``, less that airspeed, m/s (module docstring): the bias of its wind estimate
    along the airflow (positive: it reads a stronger airflow than there is).

    Parameters
    ----------
    true, believed : MultirotorParams
        The vehicle, and what the filter's force model believes about it (e.g.
        :func:`windnav.experiments.ukf_conditions.believed_params`, or calibrated drag).
    airspeed : float or array_like
        Airspeed along the body ``axis``, m/s (>= 0).
    axis : {"x", "y", "z"}
        The body axis of the airflow: in-plane rotor drag ``k_d`` and ``c_dx``/``c_dy``, or
        axial drag ``k_z`` and ``c_dz``.

    Returns
    -------
    ndarray
        The bias at each airspeed, m/s (the shape of ``airspeed``). At hover rotor speed
        ``eta_h`` of ``true``: in forward flight the rotors spin faster and the rotor drag
        weighs more, so this is an upper estimate of the frame-drag bias. NaN where
        ``believed`` has no drag along ``axis`` (its rotor and frame coefficients both 0): such
        a filter reads no airspeed from drag. The callers (``fly``'s summary, the onboard
        stack's report, the Monte-Carlo study) keep that NaN, and the commands say nothing of
        it; so it is a result here, not a ValueError (code-hash audit, 2026-12-07).
    """
    where = "drag_model_bias"
    for name, p in (("true", true), ("believed", believed)):
        if not isinstance(p, MultirotorParams):
            raise ValueError(f"The {name!r} parameter of {where} must be a MultirotorParams. "
                             f"Got {type(p).__name__} instead.")
    if axis not in ("x", "y", "z"):
        raise ValueError(f"The 'axis' parameter of {where} must be 'x', 'y' or 'z'. Got "
                         f"{axis!r} instead.")
    v = _nonneg(airspeed, "airspeed", where)
    rotor = "k_z" if axis == "z" else "k_d"
    frame = f"c_d{axis}"
    s = true.n_rotors * true.hover_rotor_speed
    drag = (getattr(true, rotor) * s * v + getattr(true, frame) * v**2) / true.mass
    a = getattr(believed, frame) / believed.mass      # the filter: a v^2 + b v = drag
    b = getattr(believed, rotor) * s / believed.mass
    if b <= 0 and a <= 0:
        return np.full(v.shape, np.nan)
    with np.errstate(divide="ignore", invalid="ignore"):
        v_hat = (drag / b if a == 0 else
                 (np.sqrt(b * b + 4.0 * a * drag) - b) / (2.0 * a))
    return v_hat - v
