"""Thrust-stand identification: the thrust coefficient and the PWM -> rotor-speed motor model.

The procedure of the thesis (S. Folk 2026, ch. 6): a PWM ramp from 10,000 to 50,000 counts in
steps of 5,000, one second per step, repeated at supply voltages from 2.7 to 4.1 V, with all
rotors commanded alike. The stand logs the whole vehicle's thrust and one motor's optical
speed. Only steady points are kept::

    |d omega / dt| < 1000 rad/s^2   and   omega > 250 rad/s

where ``d omega / dt`` is the steeper of the straight-line slopes over the ``window_s / 2``
(0.05 s) before and after each sample (:func:`rotor_acceleration`). The fits:

    thrust per rotor    T = k_eta omega^2,          k_eta = sum(T omega^2) / sum(omega^4)
    rotor speed         omega = Kv (V + V0) (PWM - DZ)^(2/3)     (nonlinear least squares)

Thesis values: k_eta = 4.052e-8 N/(rad/s)^2, Kv = 0.3637, V0 = 0.5535 V, DZ = 4673 counts,
R^2 = 0.979.

The 95 % intervals are cluster-robust, one cluster per PWM step (a run of one PWM value in one
file): the sandwich covariance CR1 of :mod:`windnav.sysid._fit` (``cov_type="cluster"``) with
Student's t on ``G - 1`` degrees of freedom for ``G`` steps. They allow for a scatter that
changes with the speed (an optical tachometer's relative noise) and for an error shared by the
points of one step. On the simulated stand (a 5 ms motor, 400 seeds) they covered the truth
94.8 % (Kv), 95.8 % (V0), 96.0 % (DZ) and 87.5 % (k_eta) of the time, and 92-95 % with an
error shared within each step, where the classical ``s^2 (J^T J)^-1`` covered 90, 91, 99.8
(too wide) and 73 %, and 28-57 %. No interval covers a bias: k_eta's regressor is the noisy
speed squared (errors in variables, ``-5 sigma^2`` relative, -1.25e-4 at 0.5 % noise: 0.65
standard deviations, which caps its coverage near 90 %); and the thesis's steadiness rule
admits the first sample of a PWM step whose jump is small, up to ~1 % below steady with a
5 ms motor, which moved DZ by +1e-3 (1.6 standard deviations; its CR1 interval covered 75 %):
samples less than :data:`SETTLE_S` after a PWM change are therefore not steady. The estimates
do not depend on the covariance.

Two checks of the motor model against the data (:attr:`ThrustStandFit.notes`):

- **settling** (:attr:`ThrustStandFit.settling_check`): a slow motor (the Crazyflie's
  ``tau_m`` = 0.05 s) is still up to ``tau_m * max_accel`` (50 rad/s) below steady when the
  rule first admits it, which biased V0 by -1 % and DZ by +0.6 %, outside their intervals in
  most seeds, silently. The first and second halves of each PWM step are compared (a paired
  test of their mean rotor-speed residuals), and the motor model is fitted again on the second
  halves only; a note when the halves differ (p < :data:`SETTLING_P`) and a coefficient of
  either fit lies outside the other's 95 % interval. (Halves by time, not a stricter
  ``max_accel``: the acceleration estimate is noisy, and selecting on it selects on the
  speed noise too.)
- **saturation** (:attr:`ThrustStandFit.saturation`): per file, the rotor speed from the
  second-highest to the highest PWM step must rise by at least ``(P1 / P2)^(2/3) - 1``
  (the model's least rise, with DZ = 0); a rise smaller than half that by three standard
  errors is a ceiling (a speed limit, a saturated ESC) the model does not have.
"""

from __future__ import annotations

import dataclasses
import warnings
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
import scipy.stats

from windnav._validate import finite_float, positive_float, positive_int
from windnav.sysid._fit import (
    Estimate,
    LeastSquares,
    linear_fit,
    median_std_error,
    nonlinear_fit,
)
from windnav.sysid._signal import steepest_slope
from windnav.sysid.io import Table

__all__ = ["SETTLING_P", "STAND_COLUMNS", "PWMMotorModel", "ThrustStandFit",
           "fit_thrust_stand", "rotor_acceleration", "steady_mask"]

STAND_COLUMNS = ("timestamp", "pwm", "thrust_N", "rpm", "voltage_V")
"""Columns the fit needs (the author's header also has ``torque_Nm`` and ``current_A``):
time (s), PWM command (counts), whole-vehicle thrust (N), one motor's speed (rev/min),
supply voltage (V)."""

RPM_TO_RAD_S = 2.0 * np.pi / 60.0

SCATTER_P = 1e-3
"""Below this p-value of the rank correlation between the absolute rotor-speed residual and the
rotor speed, the scatter is uneven (:attr:`ThrustStandFit.scatter_check`, a diagnostic: the
cluster-robust intervals allow for it)."""

SETTLE_S = 0.05
"""Samples less than this after a PWM change are left out of the steady points, s. The thesis's
rule (``|d omega/dt| < max_accel`` over a 0.1 s window) admitted the first sample of a step
whose jump is small, up to 1 % below steady with a 5 ms motor, which biased DZ by +1e-3
(1.6 standard deviations: its cluster-robust interval covered the truth 75 % of the time on the
simulated stand, 95 % without those samples; 1,000 seeds, 2026-12-05)."""

MIN_R2_THRUST = 0.9
"""Below this R^2 of thrust per rotor against ``omega^2`` the thrust samples do not follow the
rotor speed, and ``k_eta`` is noted as untrustworthy: a load cell that read noise gave k_eta
195 x too small, its interval clear of 0, with R^2 = -0.008 and no note (an audit); the
simulated stand's 0.999, which noise-free thrust physics cannot fall far below."""

SETTLING_P = 1e-3
"""Below this p-value of the paired test of the first against the second halves of the PWM
steps, the rotor speed has not settled (with a fast motor, ``tau_m`` = 5 ms, 0 of 20 seeds
went below it together with a coefficient outside the other fit's interval; with 50 ms,
20 of 20; the same with the cluster-robust intervals)."""

_MOTOR_NAMES = ("Kv", "V0", "DZ")


@dataclass(frozen=True)
class PWMMotorModel:
    """Steady rotor speed of a brushless motor against its PWM command and supply voltage.

    ``omega = Kv (V + V0) max(PWM - DZ, 0)^(2/3)``

    Attributes
    ----------
    Kv : float
        Gain, rad/s per volt per count^(2/3).
    V0 : float
        Voltage offset, V.
    DZ : float
        Dead zone: the PWM below which the rotor does not turn, counts.
    pwm_max : float
        Largest PWM command, counts (65535 on the Crazyflie's 16-bit timer).
    """

    Kv: float
    V0: float
    DZ: float
    pwm_max: float = 65535.0

    def __post_init__(self):
        positive_float(self.Kv, "Kv", "PWMMotorModel")
        finite_float(self.V0, "V0", "PWMMotorModel")  # NaN gave a stand log of NaN
        positive_float(self.pwm_max, "pwm_max", "PWMMotorModel")
        dz = positive_float(self.DZ, "DZ", "PWMMotorModel", allow_zero=True)
        if dz >= self.pwm_max:  # the motor would never spin
            raise ValueError(f"The 'DZ' parameter of PWMMotorModel must be below pwm_max "
                             f"({self.pwm_max:g}). Got {self.DZ!r} instead.")

    @classmethod
    def thesis(cls) -> PWMMotorModel:
        """The Crazyflie 2.1 Brushless fit of the thesis: Kv 0.3637, V0 0.5535 V, DZ 4673."""
        return cls(Kv=0.3637, V0=0.5535, DZ=4673.0)

    @classmethod
    def from_params(cls, params) -> PWMMotorModel:
        """The model a vehicle preset carries in ``params.extra["pwm_motor"]`` (e.g.
        ``crazyflie_thesis``)."""
        spec = getattr(params, "extra", {}).get("pwm_motor")
        if not isinstance(spec, dict):
            raise ValueError("The 'params' parameter of PWMMotorModel.from_params must carry "
                             "extra['pwm_motor'] = {'Kv', 'V0', 'DZ'}. Got vehicle "
                             f"{getattr(params, 'name', params)!r} without it.")
        return cls(Kv=spec["Kv"], V0=spec["V0"], DZ=spec["DZ"],
                   pwm_max=spec.get("pwm_max", 65535.0))

    def rotor_speed(self, pwm, voltage) -> np.ndarray:
        """Steady rotor speed (rad/s) at PWM ``pwm`` (counts) and supply ``voltage`` (V);
        arrays broadcast."""
        u = np.clip(np.asarray(pwm, dtype=np.float64) - self.DZ, 0.0, None) ** (2.0 / 3.0)
        return self.Kv * (np.asarray(voltage, dtype=np.float64) + self.V0) * u

    def pwm(self, rotor_speed, voltage) -> np.ndarray:
        """The PWM (counts) that gives ``rotor_speed`` (rad/s) at ``voltage`` (V), clipped to
        ``[DZ, pwm_max]`` (the inverse of :meth:`rotor_speed`)."""
        w = np.clip(np.asarray(rotor_speed, dtype=np.float64), 0.0, None)
        u = w / (self.Kv * (np.asarray(voltage, dtype=np.float64) + self.V0))
        return np.clip(self.DZ + u**1.5, self.DZ, self.pwm_max)

    def to_dict(self) -> dict:
        """``{"Kv", "V0", "DZ", "pwm_max"}`` for JSON (the attributes' units)."""
        return {"Kv": self.Kv, "V0": self.V0, "DZ": self.DZ, "pwm_max": self.pwm_max}


def rotor_acceleration(t, omega, window_s: float = 0.1) -> np.ndarray:
    """``d omega / dt`` (rad/s^2): the steeper of the least-squares slopes over the
    ``window_s / 2`` before and after each sample (:func:`windnav.sysid._signal.steepest_slope`).

    The lines keep speed-sensor noise from passing for acceleration; the one-sided windows
    keep the first samples after a PWM step, still far from steady, from passing for steady
    (a centred window would average them with the flat samples before the step). ``t`` in s,
    ``omega`` in rad/s.
    """
    return steepest_slope(t, omega, window_s)


def steady_mask(t, omega, *, max_accel: float = 1000.0, min_speed: float = 250.0,
                window_s: float = 0.1) -> np.ndarray:
    """The thesis's steady points: ``|d omega/dt| < max_accel`` (rad/s^2, > 0) and
    ``omega > min_speed`` (rad/s, >= 0); see :func:`rotor_acceleration`. ``t`` (n,) are finite,
    increasing times, s, and ``omega`` (n,) the rotor speeds, rad/s (a NaN speed is not
    steady)."""
    where = "steady_mask"
    # NaN thresholds kept no point, and NaN, repeated or decreasing times every point
    max_accel = positive_float(max_accel, "max_accel", where)
    min_speed = positive_float(min_speed, "min_speed", where, allow_zero=True)
    t = np.asarray(t, dtype=np.float64)
    if t.ndim == 1 and not (np.all(np.isfinite(t)) and np.all(np.diff(t) > 0)):
        got = "repeated or decreasing" if np.all(np.isfinite(t)) else "non-finite"
        raise ValueError(f"The 't' parameter of {where} must be finite and increasing, s. Got "
                         f"{got} times instead.")
    w = np.asarray(omega, dtype=np.float64)
    return (np.abs(rotor_acceleration(t, w, window_s)) < max_accel) & (w > min_speed)


@dataclass(frozen=True, eq=False)
class ThrustStandFit:
    """Thrust coefficient and motor model of a thrust-stand campaign.

    Attributes
    ----------
    k_eta : Estimate
        Thrust coefficient per rotor, N/(rad/s)^2, with its cluster-robust standard error and
        95 % interval (same unit; clusters: the PWM steps, module docstring).
    Kv, V0, DZ : Estimate
        The :class:`PWMMotorModel` coefficients (rad/s/V/count^(2/3), V, counts), each with
        its cluster-robust standard error and 95 % interval.
    motor : PWMMotorModel
        The fitted model.
    thrust : LeastSquares
        The fit of thrust per rotor against ``omega^2`` (``thrust.r2``; ``thrust.cov`` the
        cluster-robust covariance, ``thrust.t_dof`` = steps - 1).
    speed : LeastSquares
        The fit of the rotor speed (``speed.r2``: the thesis's R^2; covariance as ``thrust``).
    pwm, voltage, omega, thrust_per_rotor : ndarray of shape (n,)
        The steady points (counts, V, rad/s, N).
    counts : dict
        Per file: ``rows``, ``steady`` and ``dropped_nan`` counts.
    saturation : dict
        Per file with steady points at two PWM steps or more: the two highest steps'
        ``pwm`` (counts), median ``rotor_speed_rad_s``, the ``rise`` between them and the
        model's least ``model_min_rise`` (fractions), and ``saturated``: the rise falls short
        of half the least by more than three standard errors (a ceiling).
    settling_check : dict or None
        The first against the second half of each PWM step: ``steps`` compared,
        ``early_minus_late`` (mean relative rotor-speed residual, fraction), its ``p_value``
        (paired t test), ``late_fit`` (Kv, V0, DZ fitted on the second halves, each
        ``{"value", "std_error", "ci95"}``, cluster-robust as the full fit's, and its
        ``n_points``), and ``significant`` (p below
        :data:`SETTLING_P` and a coefficient of either fit outside the other's 95 %
        interval: the motor's lag biases the model). None where fewer than three steps have
        steady points in both halves, or the second halves cannot be fitted.
    max_accel : float
        The steadiness threshold used, rad/s^2.
    min_speed : float
        The least steady rotor speed used, rad/s.
    step : ndarray of shape (n,) or None
        The PWM step of each steady point (0, 1, ... over all files in order): the clusters
        of the intervals.
    """

    k_eta: Estimate
    Kv: Estimate
    V0: Estimate
    DZ: Estimate
    motor: PWMMotorModel
    thrust: LeastSquares
    speed: LeastSquares
    pwm: np.ndarray
    voltage: np.ndarray
    omega: np.ndarray
    thrust_per_rotor: np.ndarray
    counts: dict
    saturation: dict = field(default_factory=dict)
    settling_check: dict | None = None
    max_accel: float = 1000.0
    step: np.ndarray | None = None
    min_speed: float = 250.0

    @property
    def r2(self) -> float:
        """R^2 of the rotor-speed model (the thesis reports 0.979)."""
        return self.speed.r2

    @property
    def at_bound(self) -> dict:
        """The motor coefficients fitted on a bound of the fit, each with that bound (empty
        for most fits; :attr:`windnav.sysid.LeastSquares.at_bound`): DZ below the lowest
        steady PWM (less 1e-6 counts), Kv above 1e-12. Their standard error and 95 % interval
        are NaN (a note): the covariance's linearisation does not hold at a bound."""
        return dict(self.speed.at_bound)

    @property
    def scatter_check(self) -> dict | None:
        """Whether the rotor-speed scatter is even: ``spearman_rho`` between the absolute
        residual and the rotor speed, its ``p_value``, and ``uneven`` (p below
        :data:`SCATTER_P`). None for fewer than 20 points. A diagnostic, not a note: the
        cluster-robust intervals allow for an uneven scatter (the classical ``s^2 (J^T J)^-1``
        did not: on the simulated stand's 0.5 % relative speed noise, rho ~ +0.4, it covered
        the truth 92-93 % (Kv, V0) and 99.7 % (DZ, too wide) of the time with a lag-free fast
        motor, 1,000 seeds). An uneven scatter still costs precision: weighting the points by
        the inverse variance would narrow the intervals."""
        if self.omega.size < 20:
            return None
        rho, pval = scipy.stats.spearmanr(self.omega, np.abs(self.speed.residuals))
        if not np.isfinite(rho):  # residuals all equal (noise-free): even
            return {"spearman_rho": 0.0, "p_value": 1.0, "uneven": False}
        return {"spearman_rho": float(rho), "p_value": float(pval),
                "uneven": bool(pval < SCATTER_P)}

    @property
    def notes(self) -> list[str]:
        """Caveats of the fit, one sentence each (empty when none)."""
        notes = []
        if not self.thrust.r2 >= MIN_R2_THRUST:
            notes.append(
                f"the thrust samples do not follow omega^2: R^2 = {self.thrust.r2:.3g} (below "
                f"{MIN_R2_THRUST:g}), so k_eta = {self.k_eta.value:.4g} N/(rad/s)^2 describes "
                "noise, not the rotor; check the load cell's column ('thrust_N': its units, "
                "its zero, whether it recorded) before using it")
        flat = {src: c for src, c in self.saturation.items() if c["saturated"]}
        if flat:
            src, c = min(flat.items(), key=lambda item: item[1]["rise"])  # the flattest
            notes.append(
                f"in {len(flat)} of the {len(self.saturation)} files the rotor speed stops "
                f"rising with PWM at the top (e.g. {src!r}: {c['rotor_speed_rad_s'][0]:.4g} "
                f"and {c['rotor_speed_rad_s'][1]:.4g} rad/s at PWM {c['pwm'][0]:g} and "
                f"{c['pwm'][1]:g}, {100 * c['rise']:+.2f} % where the model rises at least "
                f"{100 * c['model_min_rise']:.1f} %): a speed limit or a saturated drive the "
                "PWM model does not have, whose points bias Kv, V0 and DZ; drop the saturated "
                "steps")
        for name, bound in self.at_bound.items():
            value = getattr(self, name).value
            if name == "DZ":
                notes.append(
                    f"DZ ({value:.8g} counts) sits on its bound, or nearer it than its 95 % "
                    f"interval's half-width: the lowest steady PWM ({float(self.pwm.min()):g}, "
                    "less 1e-6 counts); the fit pushes the dead zone up against a PWM step it "
                    "was given as turning, so DZ has no standard error or 95 % interval (ci95 "
                    "null; the covariance's interval means nothing at a bound); steady points "
                    "at a PWM inside the dead zone (a stopped rotor's reading above min_speed, "
                    f"{self.min_speed:g} rad/s) do this: raise min_speed (--min-speed) or drop "
                    "those steps")
            else:
                notes.append(
                    f"{name} ({value:.6g}) sits on its bound {bound:.6g} in the motor-model fit, "
                    "or nearer it than its 95 % interval's half-width: it has no standard error "
                    "or 95 % interval (ci95 null), and the model does not describe these data")
        check = self.settling_check
        if check is not None and check["significant"]:
            d = check["early_minus_late"]
            late = {n: Estimate(e["value"], e["std_error"], tuple(e["ci95"]))
                    for n, e in check["late_fit"].items() if n in _MOTOR_NAMES}
            moved = [f"{n} {late[n].value:.5g} (this fit {getattr(self, n).value:.5g} "
                     f"[{getattr(self, n).ci95[0]:.5g}, {getattr(self, n).ci95[1]:.5g}])"
                     for n in _MOTOR_NAMES if _apart(getattr(self, n), late[n])]
            notes.append(
                f"the rotor speed had not settled at the first steady points of the PWM "
                f"steps: over each step's first half they sit {100 * abs(d):.2g} % "
                f"{'below' if d < 0 else 'above'} its second half (paired over "
                f"{check['steps']} steps, p = {check['p_value']:.1g}), the motor's lag (|d "
                f"omega/dt| < {self.max_accel:g} rad/s^2 admits points up to tau_m x "
                f"{self.max_accel:g} rad/s from steady), and it biases the motor model: "
                f"fitted on the second halves, {', '.join(moved)}, each outside the other's "
                "95 % interval (settling_check); the second halves' values are the less "
                "biased, or hold each step longer")
        return notes

    def to_dict(self) -> dict:
        """The JSON payload: each coefficient with ``value``, ``std_error``, ``ci95``."""
        return {
            "k_eta": self.k_eta.to_dict(), "Kv": self.Kv.to_dict(), "V0": self.V0.to_dict(),
            "DZ": self.DZ.to_dict(), "r2": self.speed.r2, "r2_thrust": self.thrust.r2,
            "at_bound": self.at_bound,
            "rmse_rotor_speed_rad_s": self.speed.rmse, "rmse_thrust_N": self.thrust.rmse,
            "n_steady_points": int(self.omega.size), "files": self.counts,
            "saturation": self.saturation, "settling_check": self.settling_check,
            "scatter_check": self.scatter_check,
            "intervals": {"covariance": "cluster-robust (CR1), one cluster per PWM step",
                          "n_clusters": None if self.step is None
                          else int(np.unique(self.step).size)},
            "notes": self.notes,
            "units": {"k_eta": "N/(rad/s)^2", "Kv": "rad/s/V/count^(2/3)", "V0": "V",
                      "DZ": "PWM counts"},
        }


def _apart(a: Estimate, b: Estimate) -> bool:
    """Each estimate outside the other's 95 % interval (an estimate without one, on a bound,
    is judged by the other's interval alone; two without: not apart)."""
    def outside(e: Estimate, value: float) -> bool | None:
        if not np.all(np.isfinite(e.ci95)):
            return None
        return not e.ci95[0] <= value <= e.ci95[1]

    verdicts = [v for v in (outside(a, b.value), outside(b, a.value)) if v is not None]
    return bool(verdicts) and all(verdicts)


def _step_halves(t: np.ndarray, pwm: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per sample: the index of its PWM step (a run of one PWM value), whether it lies in the
    step's second half (by time), and the time since the step began, s."""
    new = np.r_[True, pwm[1:] != pwm[:-1]]
    step = np.cumsum(new) - 1
    start = t[new]
    dt = float(np.median(np.diff(t))) if t.size > 1 else 0.0
    end = np.r_[start[1:], t[-1] + dt]
    since = t - start[step]
    frac = since / np.maximum(end - start, 1e-300)[step]
    return step, frac >= 0.5, since


def _top_steps(pwm: np.ndarray, omega: np.ndarray) -> dict | None:
    """The saturation check of one file's steady points (see ThrustStandFit.saturation)."""
    levels = np.unique(pwm)
    if levels.size < 2 or levels[-2] <= 0:
        return None
    stats = []
    for level in levels[-2:]:
        w = omega[pwm == level]
        stats.append((float(np.median(w)), median_std_error(w)))
    (w2, se2), (w1, se1) = stats
    if not w2 > 0:
        return None
    rise = w1 / w2 - 1
    least = float((levels[-1] / levels[-2]) ** (2.0 / 3.0) - 1)
    se = float(np.hypot(se1 / w2, se2 * w1 / w2**2))
    return {"pwm": [float(levels[-2]), float(levels[-1])], "rotor_speed_rad_s": [w2, w1],
            "rise": float(rise), "model_min_rise": least,
            "saturated": bool(0.5 * least - rise > 3 * se)}


def _settling_check(late: np.ndarray, step: np.ndarray, pwm, volt, omega,
                    motor_fit: LeastSquares, src: str) -> dict | None:
    """The first against the second halves of the PWM steps (see
    ThrustStandFit.settling_check); ``motor_fit`` is the fit on all the steady points."""
    rel = motor_fit.residuals / omega
    diffs = []
    for j in np.unique(step):
        e, ll = (step == j) & ~late, (step == j) & late
        if e.any() and ll.any():
            diffs.append(rel[e].mean() - rel[ll].mean())
    if len(diffs) < 3 or late.sum() <= len(_MOTOR_NAMES) + 1:
        return None
    diffs = np.asarray(diffs)
    pval = float(scipy.stats.ttest_1samp(diffs, 0.0).pvalue) if np.ptp(diffs) > 0 else 1.0
    try:
        with warnings.catch_warnings():  # a bound of the second halves shows as a null ci95
            warnings.simplefilter("ignore", RuntimeWarning)
            second = _fit_motor(pwm[late], volt[late], omega[late], motor_fit.coef,
                                f"{src}, second halves of the PWM steps", step[late])
    except ValueError:  # too few points or steps, or they do not separate Kv, V0 and DZ
        return None
    full = {n: motor_fit.estimate(n) for n in _MOTOR_NAMES}
    est = {n: second.estimate(n) for n in _MOTOR_NAMES}
    moved = any(_apart(full[n], est[n]) for n in _MOTOR_NAMES)
    return {"steps": len(diffs), "early_minus_late": float(diffs.mean()), "p_value": pval,
            "late_fit": {**{n: e.to_dict() for n, e in est.items()},
                         "n_points": int(late.sum())},
            "significant": bool(pval < SETTLING_P and moved)}


def _initial_motor(pwm, volt, omega) -> np.ndarray:
    """(Kv, V0, DZ) from a scan of DZ with the linear fit of omega / u = Kv V + Kv V0."""
    best = None
    for dz in np.linspace(0.0, pwm.min() - 1.0, 200):
        u = (pwm - dz) ** (2.0 / 3.0)
        A = np.column_stack([volt * u, u])
        coef, *_ = np.linalg.lstsq(A, omega, rcond=None)
        rss = float(np.sum((A @ coef - omega) ** 2))
        if best is None or rss < best[0]:
            best = (rss, coef, dz)
    _, (a, b), dz = best
    a = a if a > 0 else 1e-3
    return np.array([a, b / a, dz])


def fit_thrust_stand(tables: Sequence[Table], n_rotors: int, *, max_accel: float = 1000.0,
                     min_speed: float = 250.0, window_s: float = 0.1,
                     settle_s: float = SETTLE_S,
                     where: str = "fit_thrust_stand") -> ThrustStandFit:
    """Fit ``k_eta`` and the PWM motor model to thrust-stand logs.

    Parameters
    ----------
    tables : sequence of Table
        One per file, with the columns :data:`STAND_COLUMNS` (``thrust_N`` the whole
        vehicle's thrust with all rotors commanded alike, ``rpm`` one motor's speed).
    n_rotors : int
        Rotors carrying the measured thrust (thrust per rotor = ``thrust_N / n_rotors``).
    max_accel, min_speed, window_s : float
        The steadiness rule (rad/s^2, rad/s, s), see :func:`steady_mask`.
    settle_s : float
        Samples less than this after a PWM change are not steady, s (:data:`SETTLE_S`; 0:
        the thesis's rule alone).
    where : str
        The caller, for messages.

    Returns
    -------
    ThrustStandFit
        The estimates with cluster-robust standard errors and 95 % intervals, one cluster
        per PWM step (module docstring).

    Raises
    ------
    ValueError
        Naming the file and the column: missing columns, a file without steady points,
        fewer steady points than parameters, a PWM that never changes, steady points at
        fewer than four PWM steps.
    """
    n_rotors = positive_int(n_rotors, "n_rotors", where)
    settle_s = positive_float(settle_s, "settle_s", where, allow_zero=True)
    max_accel = positive_float(max_accel, "max_accel", where)  # else named by steady_mask
    min_speed = positive_float(min_speed, "min_speed", where, allow_zero=True)
    if not tables:
        raise ValueError(f"The 'tables' parameter of {where} must hold at least one file.")
    if not all(isinstance(tab, Table) for tab in tables):  # an AttributeError before
        raise ValueError(f"The 'tables' parameter of {where} must hold tables read with "
                         "read_table. Got "
                         f"{sorted({type(tab).__name__ for tab in tables})} instead.")
    parts, counts, saturation = [], {}, {}
    n_steps = 0
    for tab in tables:
        tab.require(STAND_COLUMNS, where)
        cols = {c: tab.columns[c] for c in STAND_COLUMNS}
        finite = np.logical_and.reduce([np.isfinite(v) for v in cols.values()])
        t = cols["timestamp"][finite]
        if t.size > 1 and np.any(np.diff(t) <= 0):
            raise ValueError(f"The column 'timestamp' of {tab.source!r} must increase from row "
                             "to row.")
        omega = cols["rpm"][finite] * RPM_TO_RAD_S
        step, late, since = _step_halves(t, cols["pwm"][finite])
        mask = steady_mask(t, omega, max_accel=max_accel, min_speed=min_speed,
                           window_s=window_s) & (since >= settle_s)
        counts[tab.source] = {"rows": len(tab), "steady": int(mask.sum()),
                              "dropped_nan": int((~finite).sum())}
        if not mask.any():
            fast = omega > min_speed
            acc = np.abs(rotor_acceleration(t, omega, window_s))
            raise ValueError(
                f"The file {tab.source!r} given to {where} has no steady point in column "
                f"'rpm': none has |d omega/dt| < {max_accel:g} rad/s^2 and omega > "
                f"{min_speed:g} rad/s at least {settle_s:g} s after a PWM change "
                f"({int(fast.sum())} of {omega.size} rows are fast "
                f"enough; the smallest |d omega/dt| among them is "
                f"{acc[fast].min() if fast.any() else float('nan'):.4g} rad/s^2).")
        parts.append({"pwm": cols["pwm"][finite][mask], "volt": cols["voltage_V"][finite][mask],
                      "omega": omega[mask],
                      "thrust": cols["thrust_N"][finite][mask] / n_rotors,
                      "step": step[mask] + n_steps, "late": late[mask]})
        n_steps += int(step.max()) + 1
        top = _top_steps(parts[-1]["pwm"], parts[-1]["omega"])
        if top is not None:
            saturation[tab.source] = top
    pwm, volt, omega, thrust, step, late = (np.concatenate([p[k] for p in parts])
                                            for k in ("pwm", "volt", "omega", "thrust", "step",
                                                      "late"))
    files = ", ".join(repr(t.source) for t in tables)
    if np.unique(pwm).size < 2:
        raise ValueError(f"The column 'pwm' of {files} must take at least two values at the "
                         "steady points to fit the motor model (a PWM ramp).")
    th = linear_fit(omega[:, None] ** 2, thrust, ["k_eta"],
                    source=f"the steady points of {files} (columns 'thrust_N', 'rpm')",
                    cov_type="cluster", clusters=step)
    if not th.estimate("k_eta").value > 0:  # all-zero or negative thrust: k_eta <= 0, R^2 0.999
        raise ValueError(f"The column 'thrust_N' of {files} must give a thrust coefficient "
                         f"k_eta > 0 at the steady points. Got k_eta = "
                         f"{th.estimate('k_eta').value:.3g} instead (no thrust, or its sign "
                         "reversed).")
    src = f"the steady points of {files} (columns 'pwm', 'voltage_V', 'rpm')"
    if np.ptp(volt) == 0:
        raise ValueError(f"The column 'voltage_V' of {files} must vary to separate Kv and V0 "
                         "(repeat the ramp at several supply voltages).")
    n_used = np.unique(step).size
    if n_used <= len(_MOTOR_NAMES) < pwm.size:  # (too few points: nonlinear_fit says so)
        raise ValueError(f"The column 'pwm' of {files} must hold steady points at "
                         f"{len(_MOTOR_NAMES) + 1} PWM steps or more (runs of one value) for "
                         "intervals of Kv, V0 and DZ robust to errors shared within a step. "
                         f"Got {n_used} instead.")
    with warnings.catch_warnings(record=True) as caught:  # given after the check below
        warnings.simplefilter("always")
        sp = _fit_motor(pwm, volt, omega, _initial_motor(pwm, volt, omega), src, step)
    kv, v0, dz = (sp.estimate(n) for n in _MOTOR_NAMES)
    for name in ("Kv", "V0"):  # the covariance's interval, even where it reaches a bound
        e = dataclasses.replace(sp, at_bound={}).estimate(name)
        if not e.ci95[0] * e.ci95[1] > 0:  # the interval holds 0: the data do not tell
            raise ValueError(  # (one voltage, sagging: Kv 0.0007 [-0.56, 0.56], V0 2185 V)
                f"The column 'voltage_V' of {files} must span supply voltages far enough "
                f"apart to determine Kv and V0 (repeat the ramp at several voltages): the "
                f"steady points span {float(np.ptp(volt)):.3g} V and give {name} = "
                f"{e.value:.4g} with a 95 % interval of [{e.ci95[0]:.3g}, {e.ci95[1]:.3g}].")
    for w in caught:  # a coefficient on its bound, or no convergence (nonlinear_fit)
        warnings.warn(w.message, w.category, stacklevel=2)
    motor = PWMMotorModel(Kv=kv.value, V0=v0.value, DZ=max(dz.value, 0.0))
    settling = _settling_check(late, step, pwm, volt, omega, sp, src)
    return ThrustStandFit(th.estimate("k_eta"), kv, v0, dz, motor, th, sp, pwm, volt, omega,
                          thrust, counts, saturation, settling, max_accel, step, min_speed)


def _fit_motor(pwm, volt, omega, x0, src: str, step) -> LeastSquares:
    """``omega = Kv (V + V0)(PWM - DZ)^(2/3)`` by nonlinear least squares from ``x0``, with
    the covariance cluster-robust by ``step`` (each point's PWM step)."""
    third = 2.0 / 3.0

    def model(b):
        return b[0] * (volt + b[1]) * np.clip(pwm - b[2], 1e-9, None) ** third

    def jac(b):
        d = np.clip(pwm - b[2], 1e-9, None)
        u = d**third
        return np.column_stack([(volt + b[1]) * u, b[0] * u,
                                -b[0] * (volt + b[1]) * third * d ** (-1.0 / 3.0)])

    hi_dz = float(pwm.min()) - 1e-6
    return nonlinear_fit(model, jac, x0, omega, list(_MOTOR_NAMES), source=src,
                         bounds=([1e-12, -np.inf, -np.inf], [np.inf, np.inf, hi_dz]),
                         cov_type="cluster", clusters=step)
