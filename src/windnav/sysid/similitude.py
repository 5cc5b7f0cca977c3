"""Similitude between a full-scale aircraft and a small model flying in scaled wind.

The length scale is the ratio of rotor diameters, ``lambda = D_FS / D_M`` (thesis: a 1.8 m
air-taxi rotor against the Crazyflie's 55 mm, 32.7, used as 32). With model quantities ``_M``
and full-scale ones ``_FS``:

- **Reynolds similarity** (same ``Re = U D / nu``, same fluid) needs ``U_M = lambda U_FS``:
  a model 32 times faster than the aircraft, impossible in practice;
- **Froude similarity** (same ``Fr = U^2 / (g D)``), the one used: ::

      speed      U_M = U_FS / sqrt(lambda)         time   t_M = t_FS / sqrt(lambda)
      frequency  f_M = f_FS sqrt(lambda)           mass   m_M = m_FS / lambda^3
      force      F_M = F_FS / lambda^3             power  P_M = P_FS / lambda^3.5

  so a 2000 kg aircraft corresponds to a 2000 / 32^3 = 61 g model. The Reynolds number is
  not kept: ``Re_M = Re_FS / lambda^1.5``.
- Every frequency scales alike, so the ratio of the control rate to the vortex-shedding
  frequency ``f_shed = St U / W`` of an obstacle of width ``W`` is the same at both scales
  (the thesis: about 50).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from windnav._validate import positive_float

__all__ = ["KINEMATIC_VISCOSITY_AIR", "Similitude"]

KINEMATIC_VISCOSITY_AIR = 1.5e-5
"""Kinematic viscosity of air at 20 degC, m^2/s."""


MACH_03_M_S = 103.0
"""Mach 0.3 in air at 20 degC, m/s: above it compressibility matters."""

SCALE_RANGE = (1e-6, 1e6)
"""The length scales (full scale / model) :class:`Similitude` accepts."""

RE_SHEDDING_ONSET = 47.0
"""Reynolds number ``U W / nu`` below which the wake of a circular cylinder is steady: no
vortex shedding (onset near Re 47)."""

RE_STROUHAL_CONSTANT = (300.0, 2e5)
"""Reynolds numbers between which a circular cylinder's Strouhal number stays near 0.2. Below,
in laminar shedding, it falls toward 0.12 (Roshko: about 0.21 (1 - 21/Re)); above, the drag
crisis changes it. Sharp-edged obstacles (buildings) separate at their corners, so their
Strouhal number depends far less on Re: only the lower end is noted."""


def _number(value, name: str, where: str, *, allow_zero: bool = False) -> float:
    """:func:`~windnav._validate.positive_float`, refusing a bool too (True read as 1 m)."""
    if isinstance(value, (bool, np.bool_)):
        raise ValueError(f"The {name!r} parameter of {where} must be a number. Got {value!r} "
                         "instead.")
    return positive_float(value, name, where, allow_zero=allow_zero)


def _amounts(value, name: str, where: str, *, allow_zero: bool = True):
    """A speed, mass or frequency to scale: a number (:func:`_number`) or an array of them,
    each finite and >= 0 (> 0 without ``allow_zero``); an array stays an array."""
    if np.ndim(value) == 0:
        return _number(value, name, where, allow_zero=allow_zero)
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        arr = None
    if arr is None or arr.dtype == object or not np.all(np.isfinite(arr)) or np.any(
            arr < 0 if allow_zero else arr <= 0):
        raise ValueError(f"The {name!r} parameter of {where} must hold finite numbers "
                         f"{'>=' if allow_zero else '>'} 0. Got {value!r} instead.")
    return arr


@dataclass(frozen=True)
class Similitude:
    """Froude scaling between a full-scale vehicle and its model.

    Attributes
    ----------
    full_scale_diameter : float
        Rotor diameter at full scale, m.
    model_diameter : float
        Rotor diameter of the model, m.
    scale : float or None
        The length scale used; None: the exact ratio of the diameters (the thesis rounds
        32.7 to 32).
    """

    full_scale_diameter: float
    model_diameter: float
    scale: float | None = None

    def __post_init__(self):
        where = "Similitude"
        # the validated floats are kept: a str that positive_float read ("1.8") stayed a str
        # and failed in the arithmetic, a TypeError (Python API audit, fifty-eighth session)
        for name in ("full_scale_diameter", "model_diameter", "scale"):
            if name != "scale" or self.scale is not None:
                object.__setattr__(self, name, _number(getattr(self, name), name, where))
        lam = self.length_scale
        if not SCALE_RANGE[0] <= lam <= SCALE_RANGE[1]:  # lambda^3.5 overflowed at 1e-200
            name = "scale" if self.scale is not None else "full_scale_diameter"
            raise ValueError(f"The {name!r} parameter of {where} must give a length scale in "
                             f"[{SCALE_RANGE[0]:g}, {SCALE_RANGE[1]:g}]. Got a scale of "
                             f"{lam:g} instead.")

    @classmethod
    def thesis(cls) -> Similitude:
        """1.8 m against 0.055 m rotors, used as lambda = 32."""
        return cls(1.8, 0.055, 32.0)

    @property
    def exact_scale(self) -> float:
        """``D_FS / D_M``."""
        return self.full_scale_diameter / self.model_diameter

    @property
    def length_scale(self) -> float:
        """lambda: ``scale`` when given, else :attr:`exact_scale`."""
        return self.exact_scale if self.scale is None else float(self.scale)

    # Froude ------------------------------------------------------------------------------
    # Each takes a finite number >= 0 (a mass > 0), as reynolds and report do, or an array of
    # them (scaled element by element, as before the checks; review): a negative mass
    # gave -9.2e-5 kg, a NaN speed NaN, a negative speed -160 m/s (Python API audit,
    # fifty-eighth session).
    def model_speed(self, full_scale_speed: float) -> float:
        """``U_M = U_FS / sqrt(lambda)``, m/s (``full_scale_speed`` m/s >= 0)."""
        u = _amounts(full_scale_speed, "full_scale_speed", "Similitude.model_speed")
        return u / math.sqrt(self.length_scale)

    def full_scale_speed(self, model_speed: float) -> float:
        """``U_FS = U_M sqrt(lambda)``, m/s (``model_speed`` m/s >= 0)."""
        u = _amounts(model_speed, "model_speed", "Similitude.full_scale_speed")
        return u * math.sqrt(self.length_scale)

    def model_mass(self, full_scale_mass: float) -> float:
        """``m_M = m_FS / lambda^3``, kg (``full_scale_mass`` kg > 0)."""
        m = _amounts(full_scale_mass, "full_scale_mass", "Similitude.model_mass", allow_zero=False)
        return m / self.length_scale**3

    def model_frequency(self, full_scale_frequency: float) -> float:
        """``f_M = f_FS sqrt(lambda)``, Hz (``full_scale_frequency`` Hz >= 0)."""
        f = _amounts(full_scale_frequency, "full_scale_frequency", "Similitude.model_frequency")
        return f * math.sqrt(self.length_scale)

    def full_scale_frequency(self, model_frequency: float) -> float:
        """``f_FS = f_M / sqrt(lambda)``, Hz (``model_frequency`` Hz >= 0)."""
        f = _amounts(model_frequency, "model_frequency", "Similitude.full_scale_frequency")
        return f / math.sqrt(self.length_scale)

    # Reynolds ----------------------------------------------------------------------------
    def reynolds_model_speed(self, full_scale_speed: float) -> float:
        """The model speed Reynolds similarity would need, ``lambda U_FS``, m/s
        (``full_scale_speed`` m/s >= 0)."""
        u = _amounts(full_scale_speed, "full_scale_speed", "Similitude.reynolds_model_speed")
        return self.length_scale * u

    def reynolds(self, speed: float, diameter: float,
                 kinematic_viscosity: float = KINEMATIC_VISCOSITY_AIR) -> float:
        """``U D / nu`` (speed m/s >= 0, diameter m > 0, kinematic viscosity m^2/s > 0)."""
        where = "Similitude.reynolds"  # a zero viscosity was a ZeroDivisionError
        return (positive_float(speed, "speed", where, allow_zero=True)
                * positive_float(diameter, "diameter", where)
                / positive_float(kinematic_viscosity, "kinematic_viscosity", where))

    def report(self, *, full_scale_speed: float | None = None,
               full_scale_mass: float | None = None, model_speed: float | None = None,
               control_rate_hz: float | None = None, obstacle_width: float | None = None,
               strouhal: float = 0.2,
               kinematic_viscosity: float = KINEMATIC_VISCOSITY_AIR) -> dict:
        """The scalings and, for the quantities given, their values at both scales.

        Parameters
        ----------
        full_scale_speed : float, optional
            Wind or flight speed at full scale, m/s (or give ``model_speed``).
        full_scale_mass : float, optional
            kg.
        model_speed : float, optional
            m/s.
        control_rate_hz : float, optional
            The model's control rate, Hz.
        obstacle_width : float, optional
            Width of the model's obstacle (a building), m: with a speed and a control rate,
            gives the shedding frequency ``St U / W`` and the ratio ``f_control / f_shed``;
            refused without them.
        strouhal : float
            Strouhal number of the shedding (0.2: a circular cylinder; about 0.13 for a
            square one).
        kinematic_viscosity : float
            m^2/s.

        Returns
        -------
        dict
            JSON-ready.
        """
        where = "Similitude.report"
        lam = self.length_scale
        nu = positive_float(kinematic_viscosity, "kinematic_viscosity", where)
        out = {
            "length_scale_exact": self.exact_scale, "length_scale": lam,
            "full_scale_diameter_m": self.full_scale_diameter,
            "model_diameter_m": self.model_diameter,
            "froude": {"speed": 1 / math.sqrt(lam), "time": 1 / math.sqrt(lam),
                       "frequency": math.sqrt(lam), "mass": lam**-3, "force": lam**-3,
                       "power": lam**-3.5, "reynolds": lam**-1.5,
                       "note": "model / full-scale ratios under Froude similarity"},
        }
        if not math.isclose(lam, self.exact_scale, rel_tol=1e-9):  # the thesis rounds 32.7
            gap = 100.0 * abs(lam / self.exact_scale - 1.0)
            out["scale_note"] = (
                f"the length scale {lam:g} is not the rotors' ratio {self.exact_scale:.4g}: the "
                "Froude ratios and speed.model_reynolds_m_s use the length scale, the Reynolds "
                "numbers of 'speed' the diameters themselves, so their ratio differs from "
                f"froude.reynolds by {gap:.1f} % (similitude audit)")
        if full_scale_speed is not None and model_speed is not None:
            raise ValueError(f"The 'model_speed' parameter of {where} must not be given with "
                             "full_scale_speed (one follows from the other).")
        if model_speed is not None:
            full_scale_speed = self.full_scale_speed(positive_float(model_speed, "model_speed",
                                                                    where))
            if not math.isfinite(full_scale_speed):  # was named full_scale_speed's (audit)
                raise ValueError(f"The 'model_speed' parameter of {where} is too large: its "
                                 "full-scale speed is not a finite number. Got "
                                 f"{model_speed!r} instead.")
        if full_scale_speed is not None:
            u = positive_float(full_scale_speed, "full_scale_speed", where)
            um = self.model_speed(u)
            out["speed"] = {
                "full_scale_m_s": u, "model_froude_m_s": um,
                "model_reynolds_m_s": self.reynolds_model_speed(u),
                "reynolds_full_scale": self.reynolds(u, self.full_scale_diameter, nu),
                "reynolds_model": self.reynolds(um, self.model_diameter, nu),
            }
        if obstacle_width is not None and (control_rate_hz is None or full_scale_speed is None):
            # (ignored, the report silent about it: CLI audit, 2026-12-07)
            raise ValueError(f"The 'obstacle_width' parameter of {where} gives the shedding "
                             "against the control rate: it needs control_rate_hz and a speed "
                             "(full_scale_speed or model_speed). Got "
                             f"{obstacle_width!r} without them instead.")
        if full_scale_mass is not None:
            m = positive_float(full_scale_mass, "full_scale_mass", where)
            out["mass"] = {"full_scale_kg": m, "model_kg": self.model_mass(m)}
        if control_rate_hz is not None:
            fc = positive_float(control_rate_hz, "control_rate_hz", where)
            out["control"] = {"model_hz": fc, "full_scale_hz": self.full_scale_frequency(fc)}
            if obstacle_width is not None and full_scale_speed is not None:
                w = positive_float(obstacle_width, "obstacle_width", where)
                st = positive_float(strouhal, "strouhal", where)
                f_m = st * self.model_speed(full_scale_speed) / w
                f_fs = st * full_scale_speed / (w * lam)
                out["shedding"] = {
                    "strouhal": st, "model_obstacle_width_m": w,
                    "full_scale_obstacle_width_m": w * lam,
                    "model_hz": f_m, "full_scale_hz": f_fs,
                    "control_to_shedding_model": fc / f_m,
                    "control_to_shedding_full_scale": self.full_scale_frequency(fc) / f_fs,
                    "reynolds_model": self.model_speed(full_scale_speed) * w / nu,
                    "reynolds_full_scale": full_scale_speed * w * lam / nu,
                    "kinematic_viscosity_m2_s": nu,
                }
        out["notes"] = self._notes(out)
        return out

    @staticmethod
    def _notes(out: dict) -> list[str]:
        """What in ``out`` leaves the similitude's valid range (CLI audit, 2026-12-05: a
        Reynolds-matched model speed near Mach 1 and a model larger than the aircraft were
        reported without a word)."""
        notes = []
        if out["length_scale"] < 1.0:
            notes.append(f"the length scale {out['length_scale']:.4g} is below 1: the model is "
                         "larger than the full-scale aircraft (diameters swapped, or in mm?)")
        speed = out.get("speed", {})
        for key, what in (("model_froude_m_s", "Froude"), ("model_reynolds_m_s", "Reynolds")):
            if speed.get(key, 0.0) > MACH_03_M_S:
                notes.append(f"the {what}-scaled model speed {speed[key]:.4g} m/s is above Mach "
                             f"0.3 ({MACH_03_M_S:g} m/s): the air is compressible there and the "
                             "incompressible scaling does not hold")
        shedding = out.get("shedding", {})
        for scale in ("model", "full_scale"):
            if f"reynolds_{scale}" not in shedding:
                continue
            re, what = shedding[f"reynolds_{scale}"], scale.replace("_", "-")
            lo, hi = RE_STROUHAL_CONSTANT
            if re < RE_SHEDDING_ONSET:
                notes.append(f"the {what} obstacle's Reynolds number U W / nu is {re:.3g}, below "
                             f"~{RE_SHEDDING_ONSET:g} where a cylinder's wake starts to shed "
                             f"vortices: there is no shedding, and shedding.{scale}_hz is not a "
                             "frequency of the flow")
            elif re < lo:  # above the range, the drag crisis moves a cylinder's St, but the
                # obstacles here are buildings, whose corners fix separation: no note
                notes.append(f"the {what} obstacle's Reynolds number U W / nu is {re:.3g}, "
                             f"below ~{lo:g}, where a cylinder sheds in the laminar regime and "
                             "its Strouhal number falls toward 0.12 near onset: "
                             f"shedding.{scale}_hz assumes St = {shedding['strouhal']:g} holds "
                             "there")
        return notes
