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
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from windnav._validate import finite_float, positive_float, positive_int
from windnav.sysid._fit import Estimate, LeastSquares, linear_fit, nonlinear_fit
from windnav.sysid._signal import steepest_slope
from windnav.sysid.io import Table

__all__ = ["STAND_COLUMNS", "PWMMotorModel", "ThrustStandFit", "fit_thrust_stand",
           "rotor_acceleration", "steady_mask"]

STAND_COLUMNS = ("timestamp", "pwm", "thrust_N", "rpm", "voltage_V")
"""Columns the fit needs (the author's header also has ``torque_Nm`` and ``current_A``):
time (s), PWM command (counts), whole-vehicle thrust (N), one motor's speed (rev/min),
supply voltage (V)."""

RPM_TO_RAD_S = 2.0 * np.pi / 60.0


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
        Thrust coefficient per rotor, N/(rad/s)^2.
    Kv, V0, DZ : Estimate
        The :class:`PWMMotorModel` coefficients (rad/s/V/count^(2/3), V, counts).
    motor : PWMMotorModel
        The fitted model.
    thrust : LeastSquares
        The fit of thrust per rotor against ``omega^2`` (``thrust.r2``).
    speed : LeastSquares
        The fit of the rotor speed (``speed.r2``: the thesis's R^2).
    pwm, voltage, omega, thrust_per_rotor : ndarray of shape (n,)
        The steady points (counts, V, rad/s, N).
    counts : dict
        Per file: ``rows``, ``steady`` and ``dropped_nan`` counts.
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

    @property
    def r2(self) -> float:
        """R^2 of the rotor-speed model (the thesis reports 0.979)."""
        return self.speed.r2

    def to_dict(self) -> dict:
        """The JSON payload: each coefficient with ``value``, ``std_error``, ``ci95``."""
        return {
            "k_eta": self.k_eta.to_dict(), "Kv": self.Kv.to_dict(), "V0": self.V0.to_dict(),
            "DZ": self.DZ.to_dict(), "r2": self.speed.r2, "r2_thrust": self.thrust.r2,
            "rmse_rotor_speed_rad_s": self.speed.rmse, "rmse_thrust_N": self.thrust.rmse,
            "n_steady_points": int(self.omega.size), "files": self.counts,
            "units": {"k_eta": "N/(rad/s)^2", "Kv": "rad/s/V/count^(2/3)", "V0": "V",
                      "DZ": "PWM counts"},
        }


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
    where : str
        The caller, for messages.

    Returns
    -------
    ThrustStandFit

    Raises
    ------
    ValueError
        Naming the file and the column: missing columns, a file without steady points,
        fewer steady points than parameters, a PWM that never changes.
    """
    n_rotors = positive_int(n_rotors, "n_rotors", where)
    max_accel = positive_float(max_accel, "max_accel", where)  # else named by steady_mask
    min_speed = positive_float(min_speed, "min_speed", where, allow_zero=True)
    if not tables:
        raise ValueError(f"The 'tables' parameter of {where} must hold at least one file.")
    if not all(isinstance(tab, Table) for tab in tables):  # an AttributeError before
        raise ValueError(f"The 'tables' parameter of {where} must hold tables read with "
                         "read_table. Got "
                         f"{sorted({type(tab).__name__ for tab in tables})} instead.")
    parts, counts = [], {}
    for tab in tables:
        tab.require(STAND_COLUMNS, where)
        cols = {c: tab.columns[c] for c in STAND_COLUMNS}
        finite = np.logical_and.reduce([np.isfinite(v) for v in cols.values()])
        t = cols["timestamp"][finite]
        if t.size > 1 and np.any(np.diff(t) <= 0):
            raise ValueError(f"The column 'timestamp' of {tab.source!r} must increase from row "
                             "to row.")
        omega = cols["rpm"][finite] * RPM_TO_RAD_S
        mask = steady_mask(t, omega, max_accel=max_accel, min_speed=min_speed,
                           window_s=window_s)
        counts[tab.source] = {"rows": len(tab), "steady": int(mask.sum()),
                              "dropped_nan": int((~finite).sum())}
        if not mask.any():
            fast = omega > min_speed
            acc = np.abs(rotor_acceleration(t, omega, window_s))
            raise ValueError(
                f"The file {tab.source!r} given to {where} has no steady point in column "
                f"'rpm': none has |d omega/dt| < {max_accel:g} rad/s^2 and omega > "
                f"{min_speed:g} rad/s ({int(fast.sum())} of {omega.size} rows are fast "
                f"enough; the smallest |d omega/dt| among them is "
                f"{acc[fast].min() if fast.any() else float('nan'):.4g} rad/s^2).")
        parts.append({"pwm": cols["pwm"][finite][mask], "volt": cols["voltage_V"][finite][mask],
                      "omega": omega[mask],
                      "thrust": cols["thrust_N"][finite][mask] / n_rotors})
    pwm, volt, omega, thrust = (np.concatenate([p[k] for p in parts])
                                for k in ("pwm", "volt", "omega", "thrust"))
    files = ", ".join(repr(t.source) for t in tables)
    th = linear_fit(omega[:, None] ** 2, thrust, ["k_eta"],
                    source=f"the steady points of {files} (columns 'thrust_N', 'rpm')")
    if not th.estimate("k_eta").value > 0:  # all-zero or negative thrust: k_eta <= 0, R^2 0.999
        raise ValueError(f"The column 'thrust_N' of {files} must give a thrust coefficient "
                         f"k_eta > 0 at the steady points. Got k_eta = "
                         f"{th.estimate('k_eta').value:.3g} instead (no thrust, or its sign "
                         "reversed).")
    src = f"the steady points of {files} (columns 'pwm', 'voltage_V', 'rpm')"
    if np.unique(pwm).size < 2:
        raise ValueError(f"The column 'pwm' of {files} must take at least two values at the "
                         "steady points to fit the motor model (a PWM ramp).")
    if np.ptp(volt) == 0:
        raise ValueError(f"The column 'voltage_V' of {files} must vary to separate Kv and V0 "
                         "(repeat the ramp at several supply voltages).")
    x0 = _initial_motor(pwm, volt, omega)
    third = 2.0 / 3.0

    def model(b):
        return b[0] * (volt + b[1]) * np.clip(pwm - b[2], 1e-9, None) ** third

    def jac(b):
        d = np.clip(pwm - b[2], 1e-9, None)
        u = d**third
        return np.column_stack([(volt + b[1]) * u, b[0] * u,
                                -b[0] * (volt + b[1]) * third * d ** (-1.0 / 3.0)])

    hi_dz = float(pwm.min()) - 1e-6
    sp = nonlinear_fit(model, jac, x0, omega, ["Kv", "V0", "DZ"], source=src,
                       bounds=([1e-12, -np.inf, -np.inf], [np.inf, np.inf, hi_dz]))
    kv, v0, dz = (sp.estimate(n) for n in ("Kv", "V0", "DZ"))
    for name, e in (("Kv", kv), ("V0", v0)):
        if not e.ci95[0] * e.ci95[1] > 0:  # the interval holds 0: the data do not tell
            raise ValueError(  # (one voltage, sagging: Kv 0.0007 [-0.56, 0.56], V0 2185 V)
                f"The column 'voltage_V' of {files} must span supply voltages far enough "
                f"apart to determine Kv and V0 (repeat the ramp at several voltages): the "
                f"steady points span {float(np.ptp(volt)):.3g} V and give {name} = "
                f"{e.value:.4g} with a 95 % interval of [{e.ci95[0]:.3g}, {e.ci95[1]:.3g}].")
    motor = PWMMotorModel(Kv=kv.value, V0=v0.value, DZ=max(dz.value, 0.0))
    return ThrustStandFit(th.estimate("k_eta"), kv, v0, dz, motor, th, sp, pwm, volt, omega,
                          thrust, counts)
