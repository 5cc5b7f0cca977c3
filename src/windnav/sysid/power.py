"""Electrical power against speed: the fitted curve, the best speeds, and their uncertainty.

A polynomial (the thesis: a cubic) is fitted to steady level-flight samples by least squares::

    P(V) = c0 + c1 V + c2 V^2 + c3 V^3                        (W, V in m/s)

and gives (:mod:`windnav.vehicle.power`):

- the hover power ``P(0) = c0``;
- the maximum-endurance speed ``V_E = argmin_V P(V)`` and the least power ``P(V_E)``;
- the maximum-range speed ``V_R = argmin_V P(V) / V`` (the tangent from the origin), and in a
  wind ``W`` along the track (``W > 0`` tailwind, ``W < 0`` headwind) the ground speed
  ``V_R(W) = argmin_V P(|V - W|) / V``.

Confidence intervals of the derived speeds and powers come from the coefficients' covariance
by the delta method (central differences of each quantity in each coefficient). They assume
the polynomial's shape is right. Where the samples repeat speeds (the same speed, or within
:data:`REPLICATE_BIN_M_S`), :attr:`PowerFit.lack_of_fit` tests that assumption (the classical
lack-of-fit F test: the residual variance against the scatter at repeated speeds) and
:attr:`PowerFit.notes` says when the shape is rejected: on the simulated Hummingbird's curve,
which has no bucket, a cubic gave hover 55.24 [54.84, 55.64] W against the true 56.19 W and
V_R 9.18 [9.14, 9.21] m/s against 9.35, with an RMS residual of 0.57 W on 0.05 W of noise
(F = 666, p = 1e-76), and said nothing.

Thesis (Crazyflie 2.1 Brushless): P = 10.56 + 0.15160 V - 0.14970 V^2 + 0.021114 V^3 W, hover
10.56 W, minimum 10.12 W at 4.15 m/s, maximum-range speed 7.73 m/s.

For logs, :func:`steady_level_mask` keeps level, steady flight: small vertical speed, small
along-track acceleration, above a minimum height, in runs of a minimum duration.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np
import scipy.special
import scipy.stats

from windnav._validate import finite_float, positive_float, positive_int
from windnav.sysid._fit import Estimate, LeastSquares, linear_fit, median_std_error
from windnav.sysid._signal import min_run, steepest_slope
from windnav.vehicle.power import PowerCurve, max_endurance_speed, max_range_speed

__all__ = ["DEFAULT_WINDS", "HOVER_CHECK_P", "HOVER_SPEED_M_S", "LACK_OF_FIT_P",
           "NO_SCATTER_RESOLUTION", "PowerFit", "REPLICATE_BIN_M_S", "fit_power", "hover_check",
           "lack_of_fit_test", "steady_level_mask"]

DEFAULT_WINDS = tuple(float(w) for w in range(-5, 6))
"""Along-track winds of the ``max_range_speed_in_wind`` table, m/s (-5 ... +5)."""

HOVER_SPEED_M_S = 0.5
"""Samples slower than this count as hover, m/s: without one, ``P(0)`` is extrapolated below
the slowest sample (``hover_extrapolated``; a fit on 3.5 ... 6 m/s gave 12.15 W against the
true 10.56 W, with an interval that assumed the polynomial held down to 0)."""

HOVER_CHECK_P = 0.05
"""Nominal false-alarm rate of :func:`hover_check` (two-sided): a right curve's samples are
flagged this often (measured: 4.5 % of 2,000 noisy samplings of the thesis's cubic)."""

REPLICATE_BIN_M_S = 0.05
"""Samples whose speeds fall in the same bin of this width (``floor(V / 0.05)``) count as
repeats of one speed for the lack-of-fit test, m/s. Within a bin the test uses the residuals
less their bin mean, so the curve's own slope across the bin does not count as scatter."""

LACK_OF_FIT_P = 0.01
"""Below this p-value of the lack-of-fit F test, the fitted shape is rejected (a note)."""

EXACT_FIT_RESOLUTION = 1e-9
"""A residual RMS under this fraction of the largest power is an exact fit (floating-point
rounding): :attr:`PowerFit.notes` says that its intervals reflect no noise."""
NO_SCATTER_RESOLUTION = 1e-3
"""Where the samples at repeated speeds agree exactly (noise-free, duplicated or rounded data),
the F test has no scatter to weigh the misfit against: a residual RMS under this fraction of
the largest power is then taken for the data's rounding (a logged resolution, float32 values)
and not tested; a larger one rejects the shape. (A float32 copy of exact cubic samples was
rejected as the wrong shape, F infinite, where the float64 one passed.)"""


def steady_level_mask(t, speed, *, vertical_speed=None, altitude=None,
                      max_vertical_speed: float = 0.3, max_accel: float = 0.5,
                      min_altitude: float | None = None, window_s: float = 1.0,
                      min_segment_s: float = 1.0) -> np.ndarray:
    """Samples of level, steady flight.

    Parameters
    ----------
    t : ndarray of shape (n,)
        Times, s (gaps longer than five median steps split the log).
    speed : ndarray of shape (n,)
        Horizontal speed, m/s.
    vertical_speed : ndarray of shape (n,), optional
        Climb rate, m/s: kept where ``|vz| < max_vertical_speed``.
    altitude : ndarray of shape (n,), optional
        Height, m: kept where ``altitude > min_altitude`` (clear of ground effect, take-off
        and landing).
    max_vertical_speed : float
        m/s.
    max_accel : float
        Largest ``|dV/dt|``, m/s^2: the steeper of the line slopes over the ``window_s / 2``
        before and after each sample.
    min_altitude : float, optional
        m.
    window_s : float
        Window of the acceleration estimate, s.
    min_segment_s : float
        Runs of kept samples shorter than this are dropped, s.

    Returns
    -------
    ndarray of bool, shape (n,)
    """
    where = "steady_level_mask"
    if (altitude is None) != (min_altitude is None):  # the one given was ignored (Python API
        # audit, fifty-eighth session)
        given, missing = (("altitude", "min_altitude") if min_altitude is None
                          else ("min_altitude", "altitude"))
        raise ValueError(f"The {missing!r} parameter of {where} must be given with {given} "
                         "(samples are kept where altitude > min_altitude). Got "
                         f"{given} alone instead.")
    t = _series(t, "t", where)
    v = _series(speed, "speed", where, t.size)
    keep = np.isfinite(v) & np.isfinite(t)
    if np.any(np.diff(t[np.isfinite(t)]) <= 0):  # the slopes and runs read it as a clock: a
        # reversed one kept nothing, a shuffled one fitted (CLI audit, 2026-12-07)
        raise ValueError(f"The 't' parameter of {where} must increase from sample to sample "
                         "(its finite values).")
    accel = steepest_slope(t, v, positive_float(window_s, "window_s", where))
    keep &= np.abs(accel) < positive_float(max_accel, "max_accel", where)
    if vertical_speed is not None:
        vz = _series(vertical_speed, "vertical_speed", where, t.size)
        keep &= np.abs(vz) < positive_float(max_vertical_speed, "max_vertical_speed", where)
    if altitude is not None:
        keep &= _series(altitude, "altitude", where, t.size) > finite_float(
            min_altitude, "min_altitude", where)
    return min_run(t, keep, positive_float(min_segment_s, "min_segment_s", where,
                                           allow_zero=True))


def _array(value, name: str, where: str) -> np.ndarray:
    """``value`` as a float64 array, else a ValueError naming ``name`` (NumPy's "could not
    convert string to float" before; Python API audit, fifty-eighth session)."""
    try:
        return np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"The {name!r} parameter of {where} must be an array of numbers. Got "
                         f"{value!r} instead.") from None


def _series(value, name: str, where: str, size: int | None = None,
            per: str = "sample of t") -> np.ndarray:
    """``value`` as a float64 array of shape (n,), of ``size`` samples (one per ``per``) when
    given, else a ValueError naming ``name`` (a broadcast error before)."""
    a = _array(value, name, where)
    if a.ndim != 1 or (size is not None and a.size != size):
        want = "of shape (n,)" if size is None else f"of shape ({size},), one per {per}"
        raise ValueError(f"The {name!r} parameter of {where} must be an array {want}. Got "
                         f"shape {a.shape} instead.")
    return a


def lack_of_fit_test(speed, residuals, n_params: int, *, scale: float = 1.0,
                     bin_m_s: float = REPLICATE_BIN_M_S) -> dict | None:
    """The lack-of-fit F test of a curve fitted to samples that repeat speeds.

    The residual sum of squares splits into pure error (the scatter of the residuals about
    their mean within each bin of repeated speeds, ``n - g`` degrees of freedom for ``n``
    samples in ``g`` bins) and lack of fit (the rest, ``g - p`` degrees of freedom for ``p``
    fitted parameters)::

        F = (SS_lack / (g - p)) / (SS_pure / (n - g))    ~ F(g - p, n - g) if the shape is right

    Parameters
    ----------
    speed : array_like of shape (n,)
        Sample speeds, m/s.
    residuals : array_like of shape (n,)
        Their residuals, W.
    n_params : int
        Parameters of the fitted curve (degree + 1).
    scale : float
        Size of the fitted values, W (the largest power): a residual RMS below ``1e-10``
        times it is rounding, and the fit exact.
    bin_m_s : float
        Width of the bins of repeated speeds, m/s (exact repeats always share a bin).

    Returns
    -------
    dict or None
        ``bin_m_s``, ``groups``, ``pure_error_dof``, ``lack_of_fit_dof``,
        ``pure_error_rms_W`` (the scatter within bins), ``no_scatter`` (the samples at
        repeated speeds agree to rounding), ``F``, ``p_value`` and ``rejected``
        (``p_value < LACK_OF_FIT_P``); None where the samples repeat no speed or hold no more
        bins than parameters (nothing to test). A fit exact to rounding has ``F`` and
        ``p_value`` None and is not rejected. Without scatter, a residual RMS under
        :data:`NO_SCATTER_RESOLUTION` of ``scale`` is rounding (``F`` None, not rejected),
        and a curve that misses the repeats by more has ``F`` infinite and is rejected.
    """
    where = "lack_of_fit_test"
    # NaN residuals gave F NaN and "not rejected", unequal lengths NumPy's "weights and list
    # don't have the same length", n_params = -3 a test (Python API audit, fifty-eighth session)
    v = _array(speed, "speed", where).reshape(-1)
    r = _series(_array(residuals, "residuals", where).reshape(-1), "residuals", where, v.size,
                "speed")
    for name, a in (("speed", v), ("residuals", r)):
        if not np.all(np.isfinite(a)):
            raise ValueError(f"The {name!r} parameter of {where} must be finite (no NaN or "
                             "inf). Got non-finite entries instead.")
    p = positive_int(n_params, "n_params", where)
    finite_float(scale, "scale", where)
    h = positive_float(bin_m_s, "bin_m_s", where)
    _, group = np.unique(np.floor(v / h), return_inverse=True)
    n, g = v.size, int(group.max()) + 1 if v.size else 0
    if n - g < 1 or g - p < 1:
        return None
    mean = np.bincount(group, r) / np.bincount(group)
    ss_pure = float(np.sum((r - mean[group]) ** 2))
    ss_all = float(np.sum(r**2))
    ss_lack = max(ss_all - ss_pure, 0.0)
    rounding = n * (1e-10 * abs(float(scale))) ** 2
    out = {"bin_m_s": h, "groups": g, "pure_error_dof": n - g, "lack_of_fit_dof": g - p,
           "pure_error_rms_W": float(np.sqrt(ss_pure / (n - g))),
           "no_scatter": bool(ss_pure <= rounding)}
    if ss_all <= rounding:  # exact to rounding: nothing to test
        return {**out, "F": None, "p_value": None, "rejected": False}
    if out["no_scatter"]:  # the misfit against nothing: rounding, or a wrong shape
        if ss_all <= n * (NO_SCATTER_RESOLUTION * abs(float(scale))) ** 2:
            return {**out, "F": None, "p_value": None, "rejected": False}
        return {**out, "F": float("inf"), "p_value": 0.0, "rejected": True}
    F = (ss_lack / (g - p)) / (ss_pure / (n - g))
    pval = float(scipy.stats.f.sf(F, g - p, n - g))
    return {**out, "F": float(F), "p_value": pval, "rejected": bool(pval < LACK_OF_FIT_P)}


@dataclass(frozen=True, eq=False)
class PowerFit:
    """A fitted power curve and what it gives.

    Attributes
    ----------
    coefficients : tuple of Estimate
        ``c_k`` in ascending powers, W/(m/s)^k.
    fit : LeastSquares
        The regression (residuals in W).
    curve : PowerCurve
        The curve, searched on ``[0, speed_max]`` m/s.
    hover, min_power, max_endurance_speed, max_range_speed : Estimate
        ``P(0)`` (W), ``P(V_E)`` (W), ``V_E`` (m/s), ``V_R`` (m/s, no wind). A best speed on
        the bound of the speeds searched has a NaN standard error and interval (a note).
    in_wind : list of dict
        Per along-track wind ``W`` (m/s): the ground speed ``V_R(W)``, its airspeed, power and
        energy per metre, and ``at_speed_limit`` when the airspeed sits on ``speed_max``
        (the optimum lies beyond the data).
    speed, power : ndarray of shape (n,)
        The samples, m/s and W (those with a finite speed and power).
    n_dropped : int
        Samples given with a non-finite speed or power, left out (a note says how many).
    """

    coefficients: tuple
    fit: LeastSquares
    curve: PowerCurve
    hover: Estimate
    min_power: Estimate
    max_endurance_speed: Estimate
    max_range_speed: Estimate
    in_wind: list
    speed: np.ndarray
    power: np.ndarray
    n_dropped: int = 0

    @property
    def hover_extrapolated(self) -> bool:
        """True when no sample is slower than :data:`HOVER_SPEED_M_S`: ``hover`` (and
        ``hover_ratio``) is then the polynomial extrapolated below the slowest sample."""
        return bool(self.speed.min() >= HOVER_SPEED_M_S)

    @property
    def hover_ratio(self) -> float:
        """``P(V_E) / P(0)``: how deep the bucket is (1 = no bucket)."""
        return self.min_power.value / self.hover.value

    @property
    def degree(self) -> int:
        """The polynomial's degree."""
        return len(self.coefficients) - 1

    @property
    def lack_of_fit(self) -> dict | None:
        """:func:`lack_of_fit_test` of this fit (bins of :data:`REPLICATE_BIN_M_S`): whether
        the polynomial's shape fits the samples to within their scatter at repeated speeds;
        None where no speed repeats."""
        return lack_of_fit_test(self.speed, self.fit.residuals, len(self.coefficients),
                                scale=float(np.max(np.abs(self.power))))

    @property
    def max_range_at_speed_limit(self) -> bool:
        """Whether the max-range speed is the curve's top speed ``speed_max`` (an edge of the
        speeds searched, not a minimum inside them)."""
        return bool(self.max_range_speed.value >= self.curve.speed_max * (1 - 1e-6))

    @property
    def notes(self) -> list[str]:
        """Caveats of the fit, one sentence each (empty when none): the lack-of-fit test, a
        best speed on the bound of the speeds searched or beyond the fastest sample, a hover
        power extrapolated below the slowest sample, dropped samples. (The last three were
        said only by ``windnav sysid power`` until 2026-12-05: the library's fit gave them
        with no note; API audit.)"""
        notes = []
        test = self.lack_of_fit
        if test is not None and test["rejected"]:
            f = "infinite" if test["F"] == float("inf") else f"{test['F']:.3g}"
            notes.append(
                f"the degree-{self.degree} curve does not follow the samples to within their "
                f"scatter at repeated speeds (lack-of-fit F = {f} on {test['lack_of_fit_dof']} "
                f"and {test['pure_error_dof']} degrees of freedom, p = "
                f"{test['p_value']:.2g} < {LACK_OF_FIT_P:g}; residual RMS "
                f"{self.fit.rmse:.3g} W against {test['pure_error_rms_W']:.3g} W of scatter "
                "within a speed): its shape is wrong for these data (or the samples at one "
                "speed share something the curve does not model, such as one leg's wind), "
                "so hover_W, min_power_W, max_endurance_speed and max_range_speed may be "
                "biased, and their 95 % intervals, which assume the shape is right, ignore "
                "that misfit; try another --degree, or read the powers off the samples"
                + (" (the samples at each repeated speed agree exactly, as noise-free or "
                   "duplicated data do, and the residual RMS is "
                   f"{self.fit.rmse / np.max(np.abs(self.power)):.2%} of the largest power, "
                   f"over the {NO_SCATTER_RESOLUTION:.1%} taken for rounding)"
                   if test["no_scatter"] else ""))
        top = self.max_range_at_speed_limit
        fastest = float(self.speed.max())
        for name, e in (("max_endurance_speed", self.max_endurance_speed),
                        ("max_range_speed", self.max_range_speed)):
            if name == "max_range_speed" and top:  # an edge, not a minimum (CLI audit)
                notes.append(f"the max-range speed is the curve's top speed "
                             f"{self.curve.speed_max:g} m/s, not a minimum inside it: fly "
                             "faster, or raise speed_max (--speed-max)"
                             + (": no 95 % interval is given for it"
                                if np.isnan(e.std_error) else ""))
            elif np.isnan(e.std_error):
                notes.append(
                    f"{name} ({e.value:.3g} m/s) lies on the bound of the speeds searched (0 or "
                    f"speed_max {self.curve.speed_max:.3g} m/s): the optimum is not inside the "
                    "data, and no 95 % interval is given for it")
        grid = np.linspace(float(self.speed.min()), fastest, 201)
        span = float(np.ptp(self.curve(grid)))
        if span < NO_SCATTER_RESOLUTION * float(np.max(np.abs(self.power))):
            # a stuck power column fitted an "optimum" of rounding noise (failure audit)
            notes.append(f"the fitted curve is flat: it varies by {span:.3g} W over the "
                         "samples, under the rounding of its powers, so no speed draws less "
                         "power than another and max_endurance_speed and max_range_speed "
                         "are not determined (a power column that did not record?)")
        for name, e in (("max_endurance_speed", self.max_endurance_speed),
                        ("max_range_speed", self.max_range_speed)):
            lo, hi = e.ci95
            if np.isfinite(lo) and (lo < 0.0 or hi > self.curve.speed_max):
                notes.append(f"the samples do not determine {name}: its 95 % interval "
                             f"[{lo:.3g}, {hi:.3g}] m/s reaches past the speeds searched (0 "
                             f"to {self.curve.speed_max:.3g} m/s)")
        if self.max_range_speed.value > fastest * (1 + 1e-9):
            notes.append(f"the max-range speed {self.max_range_speed.value:.3g} m/s lies beyond "
                         f"the fastest sample ({fastest:.3g} m/s): the curve is extrapolated "
                         "there")
        if self.hover_extrapolated:  # 12.15 W for 10.56 W from 3.5 ... 6 m/s (audit)
            notes.append(f"hover_W is extrapolated below {float(self.speed.min()):.3g} m/s (the "
                         "slowest fitted sample): P(0), hover_ratio and their intervals assume "
                         "the polynomial holds down to hover; fit samples near hover, or widen "
                         "the speed range (--speed-range)")
        if self.n_dropped:
            notes.append(f"{self.n_dropped} sample(s) with a non-finite speed or power were "
                         "left out of the fit")
        if (not (test is not None and test["rejected"])
                and self.fit.rmse <= EXACT_FIT_RESOLUTION * np.max(np.abs(self.power))):
            # a noise-free curve gave intervals of width 0, with no word (statistics audit)
            notes.append(f"the curve passes through the samples exactly (residual RMS "
                         f"{self.fit.rmse:.2g} W): the 95 % intervals have no measurement "
                         "noise to reflect (noise-free, digitised or synthetic data) and are "
                         "not the uncertainty of a measured curve")
        return notes

    def to_dict(self) -> dict:
        """The JSON payload."""
        return {
            "coefficients": [c.to_dict() for c in self.coefficients],
            "coefficient_values": [c.value for c in self.coefficients],
            "degree": len(self.coefficients) - 1,
            "r2": self.fit.r2, "rmse_W": self.fit.rmse, "n_points": int(self.speed.size),
            "n_dropped": int(self.n_dropped),
            "speed_max": self.curve.speed_max,
            "hover_W": self.hover.value, "hover_W_ci95": list(self.hover.ci95),
            "slowest_speed": float(self.speed.min()),
            "hover_extrapolated": self.hover_extrapolated,
            "min_power_W": self.min_power.value, "min_power_W_ci95": list(self.min_power.ci95),
            "max_endurance_speed": self.max_endurance_speed.value,
            "max_endurance_speed_ci95": list(self.max_endurance_speed.ci95),
            "max_range_speed": self.max_range_speed.value,
            "max_range_speed_ci95": list(self.max_range_speed.ci95),
            "max_range_at_speed_limit": self.max_range_at_speed_limit,
            "max_endurance_at_speed_limit": _on_bound(self.max_endurance_speed.value,
                                                      self.curve.speed_max),
            "hover_ratio": self.hover_ratio,
            "max_range_speed_in_wind": self.in_wind,
            "lack_of_fit": self.lack_of_fit,
            "notes": self.notes,
            "units": {"speed": "m/s", "power": "W", "coefficients": "W/(m/s)^k",
                      "wind_m_s": "along track, > 0 tailwind, < 0 headwind"},
        }


def hover_check(fit: PowerFit, hover_speed: float = HOVER_SPEED_M_S) -> dict:
    """The fitted samples slower than ``hover_speed`` against the curve at their speeds.

    With ``S`` the ``m`` slow samples (at least three) and ``r_i`` the fit's residuals, the
    offset ``d = median_{i in S} r_i`` (W) says how far the slow samples sit off the curve. They
    are part of the fit, so ``d`` and the curve share them: to first order
    ``d = median_S(e) - xbar_S^T (c - beta)``, with ``e`` the noise, ``xbar_S`` the mean of the
    polynomial's regressors over ``S`` and ``c - beta`` the coefficients' error, and by the
    delta method with the cross term::

        var d = var median_S(e) + xbar^T cov(c) xbar - 2 cov(median_S(e), xbar^T c)
              = sigma^2 (k_m + h - 2 h) = sigma^2 (k_m - h),     h = xbar^T (X^T X)^-1 xbar

    since ``cov(median_S(e), e_i) = sigma^2 / m`` for each ``i`` in ``S`` (normal noise: the
    median less the mean is independent of the mean), ``k_m`` is the variance of the median of
    ``m`` standard normal samples (:func:`_median_variance`; ``pi / (2 m)`` for large ``m``)
    and ``h <= 1 / m < k_m``. The curve's variance at the slow speeds is taken off, not added.
    ``sigma^2`` is the fit's residual variance ``s^2`` (one variance at hover and in cruise, as
    the fit's own intervals assume), and ``hover_outside_fit`` when ``|d| / (s sqrt(k_m -
    h))`` exceeds Student's ``1 - HOVER_CHECK_P / 2`` quantile on the fit's ``n - p`` degrees
    of freedom, unless the offset and the residual RMS are both under
    :data:`NO_SCATTER_RESOLUTION` of the largest power: the data's rounding (noise-free samples
    gave an offset of 9e-15 W, 3.3 standard errors of rounding, and were flagged).

    Until 2026-12-05 the slow samples' median was set against ``hover_W = P(0)`` with the
    standard error ``hypot(se(hover_W), se(median))``, as if the two were independent, the
    median's from the slow samples alone with Student's quantile on ``m - 1`` degrees of
    freedom, and the median had to lie outside ``hover_W``'s 95 % interval too. Over 2,000 noisy
    samplings of the thesis's cubic (4 samples every 0.5 m/s, 4 of them at hover) that rule
    flagged none of the right curves for a nominal 5 %, its standard error 1.7 x the offset's
    spread; this one flags 4.5 % (2.6-5.0 % on four other designs, 2,000 each; 4.3 % of the
    1,000 of ``tests/test_sysid_hover.py``). Slow samples 0.1 W (2 sigma) off the curve were
    flagged in 3 % of 1,000 samplings, now in 68 %.

    Parameters
    ----------
    fit : PowerFit
        The fit; its samples ``fit.speed``, ``fit.power`` are those tested.
    hover_speed : float
        Samples slower than this count as hover, m/s (:data:`HOVER_SPEED_M_S`).

    Returns
    -------
    dict
        ``hover_measured_W`` (the median power of the slow samples) and
        ``hover_measured_std_error_W`` (its standard error from their own scatter,
        :func:`~windnav.sysid._fit.median_std_error`), ``hover_offset_W`` (``d``) and
        ``hover_offset_std_error_W``, ``hover_outside_fit`` (bool) and ``note`` (a sentence,
        or None); all None (``note`` too) with fewer than three slow samples.
    """
    if not isinstance(fit, PowerFit):  # an AttributeError before (Python API audit,
        # fifty-eighth session)
        raise ValueError("The 'fit' parameter of hover_check must be a PowerFit (fit_power's "
                         f"result). Got {type(fit).__name__} instead.")
    hover_speed = positive_float(hover_speed, "hover_speed", "hover_check")
    slow = fit.speed < hover_speed
    m = int(slow.sum())
    if m < 3:
        return {"hover_measured_W": None, "hover_measured_std_error_W": None,
                "hover_offset_W": None, "hover_offset_std_error_W": None,
                "hover_outside_fit": None, "note": None}
    measured = float(np.median(fit.power[slow]))
    offset = float(np.median(fit.fit.residuals[slow]))
    # the fit's classical covariance is s^2 (X^T X)^-1, so the curve's variance at the slow
    # samples' mean regressor, s^2 h, is xbar^T cov xbar
    xbar = np.vander(fit.speed[slow], fit.degree + 1, increasing=True).mean(axis=0)
    s2 = float(np.sum(fit.fit.residuals**2)) / fit.fit.dof
    se = float(np.sqrt(max(s2 * _median_variance(m) - float(xbar @ fit.fit.cov @ xbar), 0.0)))
    z = abs(offset) / max(se, 1e-300)
    resolution = NO_SCATTER_RESOLUTION * float(np.max(np.abs(fit.power)))
    rounding = fit.fit.rmse <= resolution and abs(offset) <= resolution  # noise-free, rounded
    outside = bool(z > float(scipy.stats.t.ppf(1.0 - HOVER_CHECK_P / 2.0, fit.fit.dof))
                   and not rounding)
    note = None
    if outside:
        lo, hi = fit.hover.ci95
        note = (f"the {m} samples slower than {hover_speed:g} m/s draw {measured:.5g} W (median), "
                f"{offset:+.3g} W off the degree-{fit.degree} curve at their speeds, {z:.1f} "
                f"times that offset's standard error (hover_W {fit.hover.value:.5g} "
                f"[{lo:.5g}, {hi:.5g}] W): the curve misses the power at hover, so hover_W, "
                "hover_ratio and the low-speed end of the curve (max_endurance_speed with it) "
                "are biased")
    return {"hover_measured_W": measured,
            "hover_measured_std_error_W": median_std_error(fit.power[slow]),
            "hover_offset_W": offset, "hover_offset_std_error_W": se,
            "hover_outside_fit": outside, "note": note}


@functools.lru_cache(maxsize=256)
def _median_variance(m: int) -> float:
    """The variance of the median of ``m`` independent standard normal samples, by quadrature
    over the order statistics' densities (0.4487 for m = 3, 0.2982 for m = 4, ``pi / (2 m)``
    as m grows, used beyond 400)."""
    if m > 400:
        return float(np.pi / (2 * m))
    x = np.linspace(-9.0, 9.0, 36_001)
    dx = x[1] - x[0]
    log_cdf, log_sf = scipy.stats.norm.logcdf(x), scipy.stats.norm.logsf(x)
    log_pdf = scipy.stats.norm.logpdf(x)
    k = m // 2
    lg = scipy.special.gammaln
    if m % 2:  # X_(k+1) of 2k + 1
        f = np.exp(lg(m + 1) - 2 * lg(k + 1) + k * (log_cdf + log_sf) + log_pdf)
        return float(np.sum(x**2 * f) * dx)
    # m = 2k: (X_(k) + X_(k+1)) / 2, var = (E X_(k)^2 + E X_(k) X_(k+1)) / 2 by symmetry
    marginal = np.exp(lg(m + 1) - lg(k) - lg(k + 1) + (k - 1) * log_cdf + k * log_sf + log_pdf)
    lower = x * np.exp((k - 1) * log_cdf + log_pdf)  # x_(k) = x, below y
    upper = x * np.exp((k - 1) * log_sf + log_pdf)   # x_(k+1) = y
    joint = np.exp(lg(m + 1) - 2 * lg(k)) * np.sum(upper * (np.cumsum(lower) - lower / 2) * dx) * dx
    return float((np.sum(x**2 * marginal) * dx + joint) / 2)


def _inside(e: Estimate, speed_max: float) -> Estimate:
    """``e``, a best speed, without an interval when it lies on the searched range's bound
    (0 or ``speed_max``): there the optimum does not move with the coefficients, the delta
    method's gradient is 0 and its interval a point that never covered the truth (8.5 % of
    13-sample fits of the thesis's cubic; coverage audit)."""
    if _on_bound(e.value, speed_max):
        return Estimate(e.value, float("nan"), (float("nan"), float("nan")))
    return e


def _on_bound(speed: float, speed_max: float) -> bool:
    """Whether a best speed lies on the bound of the speeds searched, 0 or ``speed_max``
    (to 1e-6 of ``speed_max``)."""
    return speed <= 1e-6 * speed_max or speed >= speed_max * (1 - 1e-6)


def _delta(func, coef: np.ndarray, cov: np.ndarray, dof: int) -> Estimate:
    """Estimate of ``func(coef)`` with the delta-method CI.

    The gradient is a central difference over a thousandth of each coefficient's standard
    error (a millionth of its value when that is 0). A best speed is found to about
    ``sqrt(eps) |V|`` only, and the millionth of the value that this step was until 2026-12-05
    moved it by little more than that: standard errors of V_E 0.69-1.27 x the analytic
    (implicit-function) ones over 40 noisy fits (audit)."""
    value = func(coef)
    grad = np.empty(coef.size)
    for k in range(coef.size):
        sd = np.sqrt(max(cov[k, k], 0.0))
        h = 1e-3 * sd if sd > 0 else 1e-6 * max(abs(coef[k]), 1e-12)
        up, dn = coef.copy(), coef.copy()
        up[k] += h
        dn[k] -= h
        grad[k] = (func(up) - func(dn)) / (2 * h)
    se = float(np.sqrt(max(grad @ cov @ grad, 0.0)))
    half = float(scipy.stats.t.ppf(0.975, dof)) * se
    return Estimate(float(value), se, (value - half, value + half))


def fit_power(speed, power, *, degree: int = 3, speed_max: float | None = None,
              winds=DEFAULT_WINDS, source: str = "the power samples") -> PowerFit:
    """Fit ``P(V)`` by least squares and derive hover power and the best speeds.

    Parameters
    ----------
    speed : array_like of shape (n,)
        Speeds, m/s (>= 0).
    power : array_like of shape (n,)
        Electrical power, W.
    degree : int
        Polynomial degree (3: the thesis's cubic).
    speed_max : float, optional
        Upper end of the speed searches, m/s (default: the largest sample speed).
    winds : sequence of float
        Along-track winds of the ``in_wind`` table, m/s (> 0 tailwind).
    source : str
        What the samples are (file and columns), for messages.

    Raises
    ------
    ValueError
        Naming ``source``: negative speeds, powers <= 0 W, fewer distinct speeds than
        coefficients. A sample with a non-finite speed or power is left out and counted
        (``n_dropped``, a note); a curve without an interior minimum is not an error
        (reported as found).
    """
    where = "fit_power"
    deg = positive_int(degree, "degree", where)
    v = _array(speed, "speed", where).reshape(-1)
    p = _array(power, "power", where).reshape(-1)
    try:  # 'float' object is not iterable, after the fit (Python API audit, 58th session)
        wind_list = None if isinstance(winds, (str, bytes)) else list(winds)
    except TypeError:
        wind_list = None
    if wind_list is None:
        raise ValueError(f"The 'winds' parameter of {where} must be a sequence of along-track "
                         f"winds, m/s. Got {winds!r} instead.")
    if v.shape != p.shape:
        raise ValueError(f"The speeds and powers of {source} must have the same length. Got "
                         f"{v.size} and {p.size} instead.")
    ok = np.isfinite(v) & np.isfinite(p)
    v, p = v[ok], p[ok]
    if np.any(v < 0):
        raise ValueError(f"The speeds of {source} must be >= 0. Got {float(v.min())!r} instead.")
    if p.size and not np.all(p > 0):  # zeros gave a ZeroDivisionError, negatives a curve
        raise ValueError(f"The powers of {source} must be > 0 W. Got {float(p.min())!r} instead.")
    if np.unique(v).size <= deg:
        raise ValueError(f"The data of {source} hold {np.unique(v).size} distinct speeds, "
                         f"fewer than the {deg + 1} needed to fit a degree-{deg} curve with an "
                         "uncertainty.")
    names = [f"c{k}" for k in range(deg + 1)]
    fit = linear_fit(np.vander(v, deg + 1, increasing=True), p, names, source=source)
    vmax = float(v.max()) if speed_max is None else positive_float(speed_max, "speed_max",
                                                                   where)
    curve = PowerCurve(fit.coef, speed_max=vmax, name="fitted")

    def ve(c):
        return max_endurance_speed(PowerCurve(c, speed_max=vmax))

    def pmin(c):
        pc = PowerCurve(c, speed_max=vmax)
        return float(pc(max_endurance_speed(pc)))

    def vr(c):
        return max_range_speed(PowerCurve(c, speed_max=vmax), 0.0).ground_speed

    table = []
    for w in wind_list:
        w = finite_float(w, "winds", where)
        if w + vmax <= 0:
            table.append({"wind_m_s": w, "ground_speed_m_s": None, "airspeed_m_s": None,
                          "power_W": None, "energy_per_metre_J_m": None,
                          "at_speed_limit": True})
            continue
        opt = max_range_speed(curve, w)
        table.append({"wind_m_s": w, "ground_speed_m_s": opt.ground_speed,
                      "airspeed_m_s": opt.airspeed, "power_W": opt.power,
                      "energy_per_metre_J_m": opt.energy_per_metre,
                      "at_speed_limit": opt.at_speed_limit})
    return PowerFit(tuple(fit.estimate(n) for n in names), fit, curve, fit.estimate("c0"),
                    _delta(pmin, fit.coef, fit.cov, fit.dof),
                    _inside(_delta(ve, fit.coef, fit.cov, fit.dof), vmax),
                    _inside(_delta(vr, fit.coef, fit.cov, fit.dof), vmax), table, v, p,
                    int(ok.size - ok.sum()))
