"""Power and energy of a multirotor: rotor shaft power, steady-flight power curves, best speeds.

(a) Rotor mechanical power. Rotor ``i`` turning at ``eta_i`` (rad/s) feels the aerodynamic drag
torque ``Q_i = k_m eta_i^2`` (the yaw-moment model of RotorPy), so its shaft power is
``Q_i eta_i``; at an electrical-to-mechanical ``efficiency`` (1 in every preset: shaft power)
the power drawn is ::

    P = sum_i k_m |eta_i|^3 / efficiency                      (W)

and :func:`energy` integrates a power history with the trapezoid rule into cumulative joules.

(b) Steady-flight power curve ``P(V)`` versus airspeed ``V`` (m/s): a polynomial
``P(V) = sum_k c_k V^k`` (:class:`PowerCurve`). From it:

- the maximum-endurance speed ``V_E = argmin_V P(V)`` (least power, longest hover-like flight);
- the maximum-range speed for a wind component ``W`` along the track (``W > 0`` tailwind,
  ``W < 0`` headwind): the ground speed ``V_R = argmin_{V > 0} P(|V - W|) / V``, minimising the
  energy per metre of ground track, ``e = P / V`` (J/m). With no wind the line from the origin
  is tangent to the curve at ``V_R``: ``P'(V_R) V_R = P(V_R)``.

The thesis's Crazyflie curve (S. Folk 2026) is the cubic fixed by its four reported numbers:
``P(0) = 10.56 W`` (hover), minimum ``10.12 W`` at ``4.15 m/s``, and no-wind maximum-range speed
``7.73 m/s``; see :meth:`PowerCurve.crazyflie`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
import scipy.integrate
import scipy.optimize

from windnav._validate import ReadOnlyOnCopy, finite_float, positive_float, positive_int

_GRID = 2049  # coarse grid points that bracket the global minimum before the bounded search


def rotor_power(rotor_speeds, k_m, efficiency: float = 1.0) -> np.ndarray:
    """Electrical power drawn by the rotors, ``sum_i k_m |eta_i|^3 / efficiency``.

    Parameters
    ----------
    rotor_speeds : array_like of shape (B, N) or (N,)
        Rotor speeds, rad/s.
    k_m : float or array_like of shape (B,)
        Drag-torque coefficient ``Q_i = k_m eta_i^2``, N m/(rad/s)^2 (one per vehicle allowed).
    efficiency : float
        Electrical-to-mechanical efficiency in (0, 1].

    Returns
    -------
    ndarray of shape (B,)
        Power, W.
    """
    where = "rotor_power"
    eta = np.asarray(rotor_speeds, dtype=np.float64)
    if eta.ndim == 1:
        eta = eta[None]
    if eta.ndim != 2 or eta.shape[1] < 1 or not np.all(np.isfinite(eta)):
        raise ValueError(
            f"The 'rotor_speeds' parameter of {where} must be a finite array of shape (B, N) "
            f"or (N,). Got shape {np.shape(rotor_speeds)} instead."
        )
    km = np.asarray(k_m, dtype=np.float64)
    if km.ndim > 1 or (km.ndim == 1 and km.shape[0] != eta.shape[0]) or np.any(~(km >= 0)):
        raise ValueError(
            f"The 'k_m' parameter of {where} must be a number >= 0 or an array of shape "
            f"({eta.shape[0]},). Got {k_m!r} instead."
        )
    eff = positive_float(efficiency, "efficiency", where)
    if eff > 1.0:
        raise ValueError(
            f"The 'efficiency' parameter of {where} must be in (0, 1]. Got {efficiency!r} instead."
        )
    return km * np.sum(np.abs(eta) ** 3, axis=1) / eff


def energy(t, power) -> np.ndarray:
    """Cumulative energy ``E(t_k) = int_{t_0}^{t_k} P dt`` by the trapezoid rule, J.

    Parameters
    ----------
    t : array_like of shape (T,)
        Non-decreasing times, s.
    power : array_like of shape (T, ...)
        Power at each time, W (trailing axes, e.g. a batch, are integrated independently).

    Returns
    -------
    ndarray of shape (T, ...)
        Energy used since ``t[0]``, J (``E[0] = 0``).

    Raises
    ------
    ValueError
        Naming ``t`` (not finite, 1-D and non-decreasing) or ``power`` (not finite, of
        another length, or negative: the rotors only draw power).
    """
    where = "energy"
    t = np.asarray(t, dtype=np.float64)
    p = np.asarray(power, dtype=np.float64)
    if t.ndim != 1 or t.size < 1 or not np.all(np.isfinite(t)) or np.any(np.diff(t) < 0):
        raise ValueError(
            f"The 't' parameter of {where} must be a finite, non-decreasing 1-D array. "
            f"Got shape {t.shape} instead."
        )
    if p.ndim < 1 or p.shape[0] != t.size or not np.all(np.isfinite(p)):
        raise ValueError(
            f"The 'power' parameter of {where} must be finite of shape ({t.size}, ...). "
            f"Got shape {p.shape} instead."
        )
    if np.any(p < 0):  # gave a negative energy (-10 J for -10 W over 1 s)
        raise ValueError(f"The 'power' parameter of {where} must be >= 0 W (drawn, never "
                         f"returned). Got a minimum of {float(p.min())!r} W instead.")
    return scipy.integrate.cumulative_trapezoid(p, t, axis=0, initial=0.0)


@dataclass(frozen=True, eq=False)
class PowerCurve(ReadOnlyOnCopy):
    """Steady level-flight power versus airspeed, ``P(V) = sum_k coefficients[k] V^k``.

    Attributes
    ----------
    coefficients : ndarray of shape (K,)
        Polynomial coefficients in ascending powers; ``c_k`` has units W/(m/s)^k.
    speed_max : float
        Largest airspeed the curve is meant for, m/s; the speed optimisers search
        ``[0, speed_max]`` in airspeed.
    name : str
        Label.

    Calling the curve evaluates it: ``curve(V)`` for airspeeds ``V`` (m/s, any shape, >= 0)
    returns powers in W of the same shape.
    """

    coefficients: np.ndarray
    speed_max: float = 12.0
    name: str = "power curve"

    def __post_init__(self):
        c = np.array(self.coefficients, dtype=np.float64).reshape(-1)
        if c.size < 1 or not np.all(np.isfinite(c)):
            raise ValueError(
                "The 'coefficients' parameter of PowerCurve must be a finite non-empty array. "
                f"Got {self.coefficients!r} instead."
            )
        c.setflags(write=False)
        object.__setattr__(self, "coefficients", c)
        object.__setattr__(
            self, "speed_max", positive_float(self.speed_max, "speed_max", "PowerCurve")
        )

    def __call__(self, airspeed) -> np.ndarray:
        v = np.asarray(airspeed, dtype=np.float64)
        if np.any(~(v >= 0)):
            raise ValueError(
                "The 'airspeed' parameter of PowerCurve must be >= 0 and not NaN. "
                f"Got min {np.nanmin(v) if v.size else v!r} instead."
            )
        return np.polynomial.polynomial.polyval(v, self.coefficients)

    def derivative(self, airspeed) -> np.ndarray:
        """``dP/dV`` at ``airspeed`` (m/s), W/(m/s)."""
        d = np.polynomial.polynomial.polyder(self.coefficients)
        return np.polynomial.polynomial.polyval(np.asarray(airspeed, dtype=np.float64), d)

    # Constructors -----------------------------------------------------------------------------
    @classmethod
    def from_conditions(
        cls,
        hover_power: float,
        min_power: float,
        min_power_speed: float,
        max_range_speed: float,
        *,
        speed_max: float = 12.0,
        name: str = "cubic from four conditions",
    ) -> PowerCurve:
        """The cubic ``c0 + c1 V + c2 V^2 + c3 V^3`` fixed by four reported numbers.

        Conditions: ``P(0) = hover_power``; ``P(V_E) = min_power`` and ``P'(V_E) = 0`` at
        ``V_E = min_power_speed``; the no-wind range tangency ``P'(V_R) V_R = P(V_R)`` at
        ``V_R = max_range_speed``, i.e. ``c2 V_R^2 + 2 c3 V_R^3 = c0``. Solved as a 4x4 linear
        system; conditions whose cubic is not above 0 W on ``[0, speed_max]`` raise a
        ValueError.
        """
        where = "PowerCurve.from_conditions"
        speed_max = positive_float(speed_max, "speed_max", where)
        c0 = positive_float(hover_power, "hover_power", where)
        p_min = positive_float(min_power, "min_power", where)
        v_e = positive_float(min_power_speed, "min_power_speed", where)
        v_r = positive_float(max_range_speed, "max_range_speed", where)
        if v_r <= v_e:
            raise ValueError(
                f"The 'max_range_speed' parameter of {where} must exceed min_power_speed "
                f"{v_e!r}. Got {max_range_speed!r} instead."
            )
        if p_min >= c0:  # the "minimum" at V_E came out a local maximum
            raise ValueError(f"The 'min_power' parameter of {where} must be below hover_power "
                             f"{c0!r} (a bucket). Got {min_power!r} instead.")
        with np.errstate(all="ignore"):
            try:
                a = np.array([
                    [1.0, 0.0, 0.0, 0.0],
                    [1.0, v_e, v_e**2, v_e**3],
                    [0.0, 1.0, 2 * v_e, 3 * v_e**2],
                    [-1.0, 0.0, v_r**2, 2 * v_r**3],
                ])
                coeffs = np.linalg.solve(a, np.array([c0, p_min, 0.0, 0.0]))
            except (np.linalg.LinAlgError, OverflowError):
                coeffs = np.full(4, np.nan)
        if not np.all(np.isfinite(coeffs)):  # speeds of 1e-300 or 1e300: singular or overflow
            raise ValueError(f"The 'min_power_speed' and 'max_range_speed' parameters of {where} "
                             f"must give a solvable cubic. Got {min_power_speed!r} and "
                             f"{max_range_speed!r} instead.")
        curve = cls(coeffs, speed_max=speed_max, name=name)
        lowest, at = _lowest_power(curve)
        if not lowest > 0:  # (10, 1, 4, 7) fell to -8.9 W at 12 m/s: a negative energy per metre
            raise ValueError(
                f"The 'hover_power', 'min_power', 'min_power_speed', 'max_range_speed' and "
                f"'speed_max' parameters of {where} must give a cubic above 0 W from 0 to "
                f"speed_max (its lowest: {lowest:.3g} W at {at:.3g} m/s). Got {hover_power!r}, "
                f"{min_power!r}, {min_power_speed!r}, {max_range_speed!r} and {speed_max!r} "
                "instead.")
        return curve

    @classmethod
    def crazyflie(cls) -> PowerCurve:
        """The thesis's Crazyflie (brushless) steady-flight power curve, W vs m/s.

        The cubic through ``P(0) = 10.56 W``, ``P_min = 10.12 W`` at ``4.15 m/s`` and the no-wind
        maximum-range speed ``7.73 m/s``. Coefficients (W, W s/m, W s^2/m^2, W s^3/m^3)::

            c0 = 10.56, c1 = 0.151596, c2 = -0.149702, c3 = 0.0211145

        It falls from the hover power to the bucket at 4.15 m/s (convex for V > 2.36 m/s, the
        inflection ``-c2 / (3 c3)``). A cubic through these four numbers also has a shallow
        local maximum of 10.60 W at 0.58 m/s; the global minimum on [0, 12] m/s is unique.
        """
        return cls.from_conditions(10.56, 10.12, 4.15, 7.73, speed_max=12.0,
                                   name="crazyflie (thesis)")

    @classmethod
    def from_samples(cls, speeds, powers, degree: int = 4, *, name: str = "fitted") -> PowerCurve:
        """Least-squares polynomial fit of measured ``powers`` (W) at airspeeds ``speeds`` (m/s).

        Parameters
        ----------
        speeds, powers : array_like of shape (M,)
            Steady-flight samples; M must exceed ``degree``.
        degree : int
            Polynomial degree (default 4: the simulated curves' fits; the thesis's and
            :func:`windnav.sysid.fit_power`'s default is 3, so the two give different curves
            from the same samples unless ``degree`` is given).
        name : str
            Label of the fitted curve (default "fitted").

        Returns
        -------
        PowerCurve
            With ``speed_max = max(speeds)``. No intervals or checks:
            :func:`windnav.sysid.fit_power` fits the same polynomial with the coefficients'
            95 % intervals, the best speeds' intervals and the notes (lack of fit, hover
            extrapolated, optimum beyond the samples).
        """
        where = "PowerCurve.from_samples"
        deg = positive_int(degree, "degree", where)
        v = np.asarray(speeds, dtype=np.float64)
        p = np.asarray(powers, dtype=np.float64)
        if v.ndim != 1 or not np.all(np.isfinite(v)) or np.any(v < 0):
            raise ValueError(f"The 'speeds' parameter of {where} must be a finite 1-D array >= 0.")
        if p.shape != v.shape or not np.all(np.isfinite(p)):
            raise ValueError(
                f"The 'powers' parameter of {where} must be finite of shape {v.shape}. "
                f"Got shape {p.shape} instead."
            )
        if np.unique(v).size <= deg:
            raise ValueError(
                f"The 'speeds' parameter of {where} must hold more than degree={deg} distinct "
                f"values. Got {np.unique(v).size} instead."
            )
        fit = np.polynomial.Polynomial.fit(v, p, deg)
        return cls(fit.convert().coef, speed_max=float(v.max()), name=name)


class RangeOptimum(NamedTuple):
    """Best cruise for range: ``ground_speed`` (m/s), ``energy_per_metre`` (J/m), the
    ``airspeed`` flown (m/s), the ``power`` drawn (W), and ``at_speed_limit``: True when that
    airspeed is the curve's ``speed_max``, an edge of the search rather than a minimum inside
    it (the optimum lies beyond the curve's range; it was reported as the optimum, unflagged:
    API audit, thirty-ninth session)."""

    ground_speed: float
    energy_per_metre: float
    airspeed: float
    power: float
    at_speed_limit: bool = False


def _global_min(f, lo: float, hi: float) -> float:
    """Minimiser of ``f`` on ``[lo, hi]``: a grid brackets it, then Brent's bounded search."""
    grid = np.linspace(lo, hi, _GRID)
    k = int(np.argmin(f(grid)))
    a, b = grid[max(k - 1, 0)], grid[min(k + 1, _GRID - 1)]
    res = scipy.optimize.minimize_scalar(f, bounds=(a, b), method="bounded",
                                         options={"xatol": 1e-10 * max(1.0, hi)})
    return float(res.x) if f(np.array(res.x)) <= f(grid[k]) else float(grid[k])


def _check_curve(curve, where: str) -> None:
    if not isinstance(curve, PowerCurve):  # an AttributeError on speed_max before
        raise ValueError(f"The 'curve' parameter of {where} must be a PowerCurve. Got "
                         f"{type(curve).__name__} instead.")


def _lowest_power(curve: PowerCurve) -> tuple[float, float]:
    """``(P, V)``: the least power of ``curve`` on a grid of ``[0, speed_max]`` (W) and where
    (m/s); NaN where the polynomial overflows."""
    v = np.linspace(0.0, curve.speed_max, _GRID)
    with np.errstate(all="ignore"):
        p = curve(v)
    k = int(np.argmin(p))  # the first NaN, if any
    return float(p[k]), float(v[k])


def max_endurance_speed(curve: PowerCurve) -> float:
    """Airspeed of least power ``argmin_{0 <= V <= speed_max} P(V)``, m/s."""
    _check_curve(curve, "max_endurance_speed")
    return _global_min(curve, 0.0, curve.speed_max)


def max_range_speed(curve: PowerCurve, wind_along: float = 0.0) -> RangeOptimum:
    """Ground speed that minimises energy per metre with a wind ``W`` along the track.

    ``V_R = argmin_V P(|V - W|) / V`` over ground speeds ``V > 0`` whose airspeed
    ``|V - W|`` is at most ``curve.speed_max``.

    Parameters
    ----------
    curve : PowerCurve
        Power versus airspeed.
    wind_along : float
        Wind component along the direction of travel, m/s: ``W > 0`` tailwind, ``W < 0``
        headwind. (The crosswind is ignored: this is the along-track 1D problem.)

    Returns
    -------
    RangeOptimum
        ``(ground_speed, energy_per_metre, airspeed, power, at_speed_limit)``. Against a
        headwind the best airspeed rises, with a tailwind it falls; ``at_speed_limit`` says
        that the best airspeed is ``speed_max`` itself (the true optimum lies past it).

    Raises
    ------
    ValueError
        If the headwind is at least ``speed_max`` (no forward progress possible), or the
        curve's power is not above 0 W everywhere on ``[0, speed_max]``.
    """
    _check_curve(curve, "max_range_speed")
    lowest, at = _lowest_power(curve)
    if not lowest > 0:  # P <= 0 made P / V least at the ends of the search: a negative J/m
        raise ValueError(
            "The 'curve' parameter of max_range_speed must have a power above 0 W from 0 to its "
            f"speed_max {curve.speed_max:g} m/s (its lowest: {lowest:.3g} W at {at:.3g} m/s). "
            f"Got the curve {curve.name!r} instead.")
    w = finite_float(wind_along, "wind_along", "max_range_speed")
    hi = w + curve.speed_max
    if hi <= 0:
        raise ValueError(
            "The 'wind_along' parameter of max_range_speed must be a headwind weaker than the "
            f"curve's speed_max {curve.speed_max!r} m/s. Got {wind_along!r} instead."
        )
    lo = max(w - curve.speed_max, 1e-6 * hi)

    def per_metre(v):
        return curve(np.abs(v - w)) / v

    v_r = _global_min(per_metre, lo, hi)
    air = abs(v_r - w)
    power = float(curve(air))
    return RangeOptimum(v_r, power / v_r, air, power,
                        bool(air >= curve.speed_max * (1 - 1e-6)))
