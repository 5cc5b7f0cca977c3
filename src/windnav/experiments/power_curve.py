"""Steady-flight power versus airspeed of a vehicle, beside the thesis's Crazyflie curve.

The harness of ``windnav power-curve``: :func:`windnav.sim.sweeps.simulated_power_curve` sweeps
steady level flights (hover in a uniform wind, Galilean invariance), fits a polynomial
``P(V) = sum_k c_k V^k`` to the unsaturated points, and reports the maximum-endurance speed
``argmin P(V)`` and the maximum-range ground speed ``argmin P(|V - W|) / V`` for along-track
winds ``W`` of -3, 0 and +3 m/s. The sweep draws nothing at random (no sensors, steady wind).

Where power rises from hover (the Hummingbird's and the Crazyflie's simulated curves), the fit's
minimum is a dip of the polynomial, not of the samples: the Hummingbird's degree-4 fit puts it
at 0.99 m/s, 0.09 W below the hover sample, while its residuals reach 0.16 W and the samples
rise from 0 m/s (56.193, 56.203, 56.244 W, ...). The fitted speed is still reported; the result
flags it (``endurance_within_fit_noise``, see :func:`endurance_check`) and says so in ``notes``.
"""

from __future__ import annotations

import numpy as np

__all__ = ["RANGE_WINDS", "endurance_check", "plot_power_curve", "power_curve_study"]

RANGE_WINDS = (-3.0, 0.0, 3.0)
"""Along-track winds of the maximum-range speeds, m/s."""


def power_curve_study(vehicle: str, max_speed: float = 12.0, points: int = 21,
                      degree: int = 4) -> dict:
    """Sweep ``points`` airspeeds in ``[0, max_speed]`` m/s and fit a degree-``degree`` curve.

    Returns
    -------
    dict
        JSON-ready: ``speeds_m_s``, ``power_W``, ``tilt_deg``, ``saturated_fraction`` (per
        point), ``fit_coefficients`` (ascending powers), ``fitted_speed_max_m_s`` (the
        fastest point fitted: below ``max_speed`` when the vehicle's envelope ends first),
        ``max_endurance_speed_m_s``,
        ``max_range`` (per wind; None in a headwind of at least ``max_speed``), the thesis
        Crazyflie curve's values, the fields of :func:`endurance_check`
        (``lowest_power_sample_speed_m_s``, ``endurance_within_fit_noise``, ...) and ``notes``
        (caveats, one sentence each; empty when there are none).
    """
    import windnav as wn
    from windnav._validate import positive_int
    from windnav.sim.sweeps import simulated_power_curve
    from windnav.vehicle.power import PowerCurve, max_endurance_speed, max_range_speed

    where = "power_curve_study"
    # checked before the sweep (Python API audit, fifty-eighth session): too few points for the
    # degree were blamed on simulated_power_curve's 'max_speed', "it leaves it at None m/s"
    degree = positive_int(degree, "degree", where)
    points = positive_int(points, "points", where)
    if points <= degree:
        raise ValueError(f"The 'points' parameter of {where} must be at least degree + 1 = "
                         f"{degree + 1} (a degree-{degree} fit has {degree + 1} coefficients). "
                         f"Got {points} instead.")
    params = wn.vehicle.params(vehicle)
    curve, sweep = simulated_power_curve(params, max_speed, points, degree)
    thesis = PowerCurve.crazyflie()
    fitted = sweep["fitted"]
    endurance = endurance_check(curve, sweep["speeds"][fitted], sweep["power"][fitted])
    note = endurance.pop("note")
    notes = [note] if note is not None else []
    return {
        "vehicle": vehicle,
        "max_speed_m_s": float(max_speed),
        "fitted_speed_max_m_s": float(curve.speed_max),
        "degree": int(degree),
        "speeds_m_s": sweep["speeds"].tolist(),
        "power_W": sweep["power"].tolist(),
        "tilt_deg": sweep["pitch_deg"].tolist(),
        "saturated_fraction": sweep["saturated"].tolist(),
        "fit_coefficients": curve.coefficients.tolist(),
        "max_endurance_speed_m_s": max_endurance_speed(curve),
        **{k: v for k, v in endurance.items() if k != "note"},
        "max_range": {f"{w:+.0f} m/s along track": _max_range(curve, w, max_speed)
                      for w in RANGE_WINDS},
        "thesis_crazyflie": {
            "coefficients": thesis.coefficients.tolist(),
            "max_endurance_speed_m_s": max_endurance_speed(thesis),
            "max_range_speed_m_s": max_range_speed(thesis, 0.0).ground_speed,
        },
        "notes": notes,
    }


def endurance_check(curve, speeds, powers) -> dict:
    """Whether the fit's maximum-endurance speed is a dip of the fit, not of the samples.

    The rule: flagged (``endurance_within_fit_noise`` True) when the lowest sampled power is at
    the slowest sample, the fit's minimum lies at a faster speed, and the fitted minimum power
    is below that lowest sample by less than the fit's largest absolute residual at the sampled
    points. The samples then show no dip, and the one the fit shows is smaller than the fit's
    own misfit: the maximum-endurance speed is the slowest sample (hover, for a sweep from
    0 m/s) to within the fit. A fit through no more samples than its coefficients
    (``degree + 1``) has no residual: the check is None there, with a note (it read False,
    as if checked; statistics audit).

    Parameters
    ----------
    curve : PowerCurve
        The fit of ``powers`` at ``speeds``.
    speeds, powers : array_like of shape (M,)
        The fitted samples, m/s and W.

    Returns
    -------
    dict
        ``lowest_power_sample_speed_m_s`` and ``lowest_power_sample_W`` (the sample of least
        power), ``max_endurance_fit_power_W`` (the fit at its minimum), ``fit_residual_rms_W``
        and ``fit_residual_max_W`` (of the fit at the samples), ``endurance_within_fit_noise``
        (bool; None when the fit has no residual), and ``note`` (a sentence saying so when
        flagged or unjudged, else None).
    """
    from windnav.vehicle.power import PowerCurve, max_endurance_speed

    where = "endurance_check"
    if not isinstance(curve, PowerCurve):  # a raw AttributeError or TypeError before (Python
        # API audit, fifty-eighth session)
        raise ValueError(f"The 'curve' parameter of {where} must be a PowerCurve. Got "
                         f"{type(curve).__name__} instead.")
    v = _samples(speeds, "speeds", where)
    p = _samples(powers, "powers", where, v.size)
    residual = p - curve(v)
    rms = float(np.sqrt(np.mean(residual ** 2)))
    worst = float(np.max(np.abs(residual)))
    k = int(np.argmin(p))
    v_fit = max_endurance_speed(curve)
    p_fit = float(curve(v_fit))
    slowest = float(v.min())
    flagged = bool(v[k] == slowest and v_fit > slowest and p[k] - p_fit < worst)
    note = None
    n_coef = np.asarray(curve.coefficients).size
    if v.size <= n_coef:
        flagged = None
        note = (f"the fit passes through its {v.size} samples exactly (as many as its "
                f"{n_coef} coefficients): with no residual, "
                f"its maximum-endurance speed ({v_fit:.2f} m/s) cannot be told from a dip "
                "of the fit; sample more speeds or fit a lower degree")
    elif flagged:
        where = "hover, 0 m/s" if slowest == 0 else f"{slowest:.3g} m/s"
        note = (f"the sampled power is lowest at the slowest sample ({where}: {p[k]:.3f} W; "
                f"every faster sample draws more); the fit's minimum at {v_fit:.2f} m/s "
                f"({p_fit:.3f} W) is {p[k] - p_fit:.3f} W below it, within the fit's "
                f"residuals (up to {worst:.3f} W, RMS {rms:.3f} W), so the maximum-endurance "
                f"speed is {'hover' if slowest == 0 else f'{slowest:.3g} m/s'} to within the "
                "fit")
    return {
        "lowest_power_sample_speed_m_s": float(v[k]),
        "lowest_power_sample_W": float(p[k]),
        "max_endurance_fit_power_W": p_fit,
        "fit_residual_rms_W": rms,
        "fit_residual_max_W": worst,
        "endurance_within_fit_noise": flagged,
        "note": note,
    }


def _samples(value, name: str, where: str, size: int | None = None) -> np.ndarray:
    """A non-empty finite 1-D float64 array (of ``size`` when given), else a named
    ValueError."""
    try:
        a = None if isinstance(value, (str, bytes)) else np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        a = None
    if a is None or a.ndim != 1 or not a.size or (size is not None and a.size != size):
        what = ("a non-empty sequence of numbers" if size is None
                else f"a sequence of {size} numbers (one per speed)")
        got = repr(value) if a is None else f"shape {a.shape}"
        raise ValueError(f"The {name!r} parameter of {where} must be {what}. Got {got} "
                         "instead.")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"The {name!r} parameter of {where} must be finite (no NaN or inf). "
                         "Got non-finite entries instead.")
    return a


def _max_range(curve, wind_along: float, max_speed: float) -> dict | None:
    """:func:`max_range_speed` as a dict; None in a headwind at least as fast as the sweep's
    top speed, where the curve cannot make headway (power-curve --max-speed 2 stopped with an
    error about a 3 m/s headwind the user never asked for)."""
    from windnav.vehicle.power import max_range_speed

    if -wind_along >= max_speed:
        return None
    opt = max_range_speed(curve, wind_along)._asdict()
    # the sweep's top airspeed is an edge of the search, not a minimum (CLI audit 2026-12-05);
    # the JSON's name for max_range_speed's at_speed_limit
    opt["at_speed_max"] = opt.pop("at_speed_limit")
    return opt


def plot_power_curve(result: dict, path) -> None:
    """Two panels: the simulated points and fit of ``result``, and the thesis Crazyflie curve
    with its no-wind maximum-range tangent. Writes a PNG to ``path``."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    from windnav.vehicle.power import PowerCurve, max_range_speed

    curve = PowerCurve(np.asarray(result["fit_coefficients"]))
    thesis = PowerCurve.crazyflie()
    fig = Figure(figsize=(11, 4.2))
    FigureCanvasAgg(fig)
    axes = fig.subplots(1, 2)
    v = np.linspace(0, result["max_speed_m_s"], 200)
    axes[0].plot(result["speeds_m_s"], result["power_W"], "o", label="simulated steady flight")
    axes[0].plot(v, curve(v), "-", label=f"degree-{result['degree']} fit")
    axes[0].set_title(f"{result['vehicle']}: rotor power vs airspeed")
    vt = np.linspace(0, 10, 200)
    axes[1].plot(vt, thesis(vt), "-", color="tab:green", label="thesis Crazyflie curve")
    vr = max_range_speed(thesis, 0.0)
    axes[1].plot([0, vr.ground_speed], [0, vr.power], "k--", lw=0.8,
                 label=f"max range {vr.ground_speed:.2f} m/s")
    axes[1].set_ylim(0, thesis(vt).max() * 1.1)
    axes[1].set_title("thesis Crazyflie curve")
    for ax in axes:
        ax.set_xlabel("airspeed (m/s)")
        ax.set_ylabel("power (W)")
        ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
