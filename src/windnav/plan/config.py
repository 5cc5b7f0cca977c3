"""Planner configuration: the MPPI hyperparameters and the vehicle constants derived for them.

The planner's model (Folk 2026, ch. 5) is a point mass in the plane, ``v' = a + d`` with the
control ``a`` clipped to ``[a_min, a_max]`` per axis and the drag ``d = -C |v_a| v_a``,
``v_a = v - w``; its energy cost uses a steady-flight power curve ``P(|v_a|)``. The thesis gives
no numbers for ``a_min, a_max, C``; :func:`planner_config` derives them, and the power curve,
from the simulated vehicle, so that the planner and the flight agree:

- **Power curve** ``P(V)``: a degree-4 polynomial fitted (least squares) to the simulator's own
  steady-flight sweep :func:`windnav.sim.sweeps.power_sweep` at airspeeds 0, 0.5, ..., 20 m/s,
  keeping the points the sweep marks valid (trimmed, unsaturated, inside the aerodynamic
  envelope; 0-13 m/s for the Hummingbird). ``P_hover = P(0)``. Beyond the last valid speed
  ``V_max`` the curve is continued by its second-order Taylor expansion at ``V_max``
  (increasing and convex, like the parasitic power it models), see :func:`power_bar`.
- **Drag** ``C`` (1/m): in steady level flight at airspeed ``V`` the tilted thrust balances the
  drag, so the drag per unit mass is ``g tan(theta(V))`` with ``theta`` the sweep's mean tilt.
  ``C`` is the least-squares fit of ``C V^2`` to it over the valid speeds,
  ``C = sum g tan(theta_i) V_i^2 / sum V_i^4``. (The same drag follows from the parameters,
  linearised at hover rotor speed ``eta_h``: ``(N k_d eta_h V + (c_dx + c_dy)/2 V^2) / m``;
  the tests check the two agree. It is mostly linear in ``V``, so the quadratic model of the
  thesis is a compromise: too low below ~8 m/s, too high above ~12 m/s.)
- **Acceleration limit**: the horizontal acceleration available at maximum rotor speed while
  holding altitude, ``a_h = sqrt((N k_eta eta_max^2 / m)^2 - g^2)``. The planner clips each axis
  to ``[-a_max, a_max]`` with ``a_max = a_h / sqrt(2)``, the box inscribed in that disk, so every
  clipped command is achievable.

Hyperparameters (thesis, simulation settings): ``N_tau = 100`` samples, ``dt = 0.25`` s,
``N_k = 187`` steps, ``f_plan = 10`` Hz, ``lambda = 0.79``, ``sigma_u = 5.15`` m/s^2,
``sigma_gf = 5.97`` (steps), ``Q_O = 1.25``, ``D_max = 100`` m; ``Q_E`` and the use of wind per
variant (:data:`VARIANTS`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields, replace
from functools import lru_cache
from typing import NamedTuple

import numpy as np

from windnav._validate import _fail, batch_array, finite_float, positive_float, positive_int
from windnav._validate import speed_range as check_speed_range
from windnav.plan._kernels import power_bar_array
from windnav.sim.sweeps import power_sweep
from windnav.vehicle.params import GRAVITY, MultirotorParams
from windnav.vehicle.power import PowerCurve

__all__ = [
    "ENERGY_MODES",
    "SAMPLING",
    "VARIANTS",
    "WIND_SOURCES",
    "PlannerConfig",
    "Variant",
    "acceleration_limit",
    "planner_config",
    "steady_flight",
    "with_variant",
]

SAMPLING = ("gaussian", "uniform")
"""Sampling modes: perturb-clip-smooth around the previous plan, or uniform in the bounds."""

ENERGY_MODES = ("horizon", "mission")
"""What ``J_E`` measures: the energy over the planning horizon (the thesis), or the energy of
the mission, the horizon's energy until the goal is reached plus the energy to fly the rest
at the max-range speed (ours; :class:`PlannerConfig` ``energy_mode``)."""

SWEEP_SPEEDS = np.linspace(0.0, 20.0, 41)
"""Airspeeds of the steady-flight sweep behind the power curve and the drag fit, m/s."""

POWER_DEGREE = 4
"""Degree of the polynomial power curve."""

MAX_COEFFICIENTS = 8
"""Most power-curve coefficients a PlannerConfig takes (degree 7)."""


WIND_SOURCES = ("truth", "onboard")
"""Where a variant's wind comes from: the ground-truth mean wind, or the onboard estimate."""


class Variant(NamedTuple):
    """A planner variant: which planner, its energy weight ``Q_E``, whether it uses wind,
    where that wind comes from (:data:`WIND_SOURCES`), and whether the closed loop adds the
    progress monitor and GS+W route escape of :mod:`windnav.plan.escape` (``escape``).

    ``wind_source="truth"``: the ground-truth mean wind inside ``L_t`` (the thesis's ``-w``
    variants); ``"onboard"``: the onboard estimate, the wind flow decoder fed by the LiDAR scan,
    the inlet wind and the Wind UKF (wired by :mod:`windnav.experiments.onboard`; the planner
    itself only sees a :class:`~windnav.plan.LocalWind` either way).
    """

    planner: str
    energy_weight: float
    use_wind: bool
    wind_source: str = "truth"
    escape: bool = False


VARIANTS = {
    "mppi": Variant("mppi", 0.0, False),
    "mppi-w": Variant("mppi", 0.0, True),
    "ea-mppi": Variant("mppi", 3.0, False),
    "ea-mppi-w": Variant("mppi", 5.0, True),
    "gs": Variant("gs", 0.0, False),
    "gs-w": Variant("gs", 0.0, True),
    "ea-mppi-w-hat": Variant("mppi", 5.0, True, "onboard"),
    "ea-mppi-w-esc": Variant("mppi", 5.0, True, "truth", escape=True),
}
"""The six navigation variants of the thesis (``gs``: global graph search, energy-optimal),
``ea-mppi-w-hat`` (EA-MPPI+Ŵ): EA-MPPI+W's planner whose wind inside ``L_t`` is the onboard
estimate instead of the truth (issue 11), and ``ea-mppi-w-esc`` (EA-MPPI+W+esc): EA-MPPI+W plus
a progress monitor that hands a stalled vehicle to the GS+W route for a stretch
(:mod:`windnav.plan.escape`, issue 11)."""


MAX_STEPS = 5_000
"""The longest horizon in model steps a :class:`PlannerConfig` takes (its dense smoothing matrix
is ``n_steps^2`` floats: 200 MB)."""

MAX_SAMPLE_STEPS = 50_000_000
"""The most ``n_samples * n_steps`` a :class:`PlannerConfig` takes (400 MB a buffer of
samples)."""

@dataclass(frozen=True, eq=False)
class PlannerConfig:
    """Hyperparameters of the MPPI planner and the vehicle constants they need.

    Build it with :func:`planner_config` (which derives the vehicle constants); change it with
    :func:`dataclasses.replace`. Every field is validated at construction.

    Attributes
    ----------
    a_max : float
        Per-axis acceleration bound, m/s^2 (controls are clipped to ``[a_min, a_max]``).
    drag : float
        Drag coefficient ``C`` of ``d = -C |v_a| v_a``, 1/m.
    power_coefficients : tuple of float
        Steady-flight power curve ``P(V) = sum_k c_k V^k``, ascending, ``c_k`` in W/(m/s)^k.
    power_speed_max : float
        Largest airspeed at which the curve was fitted, m/s; beyond it :func:`power_bar`.
    a_min : float or None
        Lower bound, m/s^2 (< a_max); None means ``-a_max``.
    variant : str
        Key of :data:`VARIANTS`.
    energy_weight : float
        ``Q_E`` (>= 0); None takes the variant's.
    use_wind : bool or None
        Whether the wind enters the model and the cost; None takes the variant's.
    horizon : float
        ``H``: side of the square window ``L_t`` (``|p~|_inf <= H/2``) around the start of the
        planning period inside which the wind is known, m (> 0, ``inf`` for everywhere).
    n_samples, n_steps : int
        ``N_tau`` sampled control sequences and ``N_k`` steps each.
    dt : float
        Model step, s.
    rate_hz : float
        Re-planning rate ``f_plan``, Hz (the warm start is shifted by ``1 / rate_hz``).
    temperature : float
        Softmin temperature ``lambda`` (> 0).
    sigma_u : float
        Standard deviation of the control perturbation, m/s^2 (> 0).
    sigma_gf : float
        Standard deviation of the Gaussian smoothing kernel, in steps (>= 0; 0: none).
    sampling : {"gaussian", "uniform"}
        Perturb the previous plan (clip, smooth), or draw uniformly in ``[a_min, a_max]``.
    obstacle_weight : float
        ``Q_O`` (>= 0).
    lidar_range : float
        ``D_max``, the range that non-dimensionalises positions and caps the goal, m.
    obstacle_resolution : float
        Node spacing of the obstacle field built from each scan, m.
    energy_mode : {"horizon", "mission"}
        ``"horizon"`` (the thesis): ``J_E`` is the energy of the whole rollout,
        ``sum_k P(|v_a|) / P_hover dt``. Over a fixed horizon that is least for the least
        power, so it rewards flying slowly even where that costs more energy per metre.
        ``"mission"`` (ours): the rollout's energy until it first comes within
        ``goal_radius`` of the (uncapped) goal, plus the energy to fly the rest of the way,
        ``e_R max(|p_K - g| - goal_radius, 0)``, where ``e_R = min_V P(|V g^ - w_0|) /
        (P_hover V)`` (s/m) is the least energy per metre of ground towards the goal in the
        wind at the vehicle (zero for the variants without wind): the energy of the mission
        the rollout starts, whose minimum over a straight flight is at the max-range speed.
    goal_radius : float
        ``"mission"`` only: the distance to the goal at which the mission's energy stops, m
        (> 0; the closed loop's success radius).
    vehicle : str
        Name of the vehicle the constants were derived from.
    derivation : dict
        How the constants were obtained (sweep speeds, fit residuals, thrust margin), for
        the record; not used by the planner.
    """

    a_max: float
    drag: float
    power_coefficients: tuple
    power_speed_max: float
    a_min: float | None = None
    variant: str = "ea-mppi-w"
    energy_weight: float | None = None
    use_wind: bool | None = None
    horizon: float = math.inf
    n_samples: int = 100
    n_steps: int = 187
    dt: float = 0.25
    rate_hz: float = 10.0
    temperature: float = 0.79
    sigma_u: float = 5.15
    sigma_gf: float = 5.97
    sampling: str = "gaussian"
    obstacle_weight: float = 1.25
    lidar_range: float = 100.0
    obstacle_resolution: float = 1.0
    energy_mode: str = "horizon"
    goal_radius: float = 5.0
    vehicle: str = ""
    derivation: dict = field(default_factory=dict)

    def __post_init__(self):
        where = "PlannerConfig"
        if self.variant not in VARIANTS:
            raise _fail("variant", where, f"one of {list(VARIANTS)}", self.variant)
        var = VARIANTS[self.variant]
        set_ = object.__setattr__
        set_(self, "a_max", positive_float(self.a_max, "a_max", where))
        a_min = -self.a_max if self.a_min is None else self.a_min
        try:
            a_min = float(a_min)
        except (TypeError, ValueError):
            raise _fail("a_min", where, "a number below a_max", self.a_min) from None
        if not (math.isfinite(a_min) and a_min < self.a_max):
            raise _fail("a_min", where, f"a finite number below a_max={self.a_max!r}", self.a_min)
        set_(self, "a_min", a_min)
        set_(self, "drag", positive_float(self.drag, "drag", where, allow_zero=True))
        c = np.asarray(self.power_coefficients, dtype=np.float64).reshape(-1)
        if not (1 <= c.size <= MAX_COEFFICIENTS) or not np.all(np.isfinite(c)) or c[0] <= 0:
            raise _fail("power_coefficients", where, f"1 to {MAX_COEFFICIENTS} finite numbers "
                        "with a positive hover power c_0", self.power_coefficients)
        set_(self, "power_coefficients", tuple(float(v) for v in c))
        set_(self, "power_speed_max",
             positive_float(self.power_speed_max, "power_speed_max", where))
        lowest = float(np.min(np.polynomial.polynomial.polyval(
            np.linspace(0.0, self.power_speed_max, 201), c)))
        if not lowest > 0:  # a power that falls to 0 or below made J_E reward speed
            raise _fail("power_coefficients", where, "a power curve above 0 W from hover to "
                        f"power_speed_max={self.power_speed_max:g} m/s (its lowest: "
                        f"{lowest:.3g} W)", self.power_coefficients)
        _, p_top, slope, half_curv = _power_table(self.power_coefficients,
                                                  self.power_speed_max)[:4]
        if slope < 0 and (half_curv == 0 or p_top - slope**2 / (4 * half_curv) <= 0):
            # the continuation beyond power_speed_max fell below 0 W: a flight's energy came
            # out negative, and J_E rewarded speed (review of the closure-module audit)
            raise _fail("power_coefficients", where, "a power curve whose continuation beyond "
                        f"power_speed_max={self.power_speed_max:g} m/s stays above 0 W (it "
                        f"falls there at {slope * self.hover_power:.3g} W/(m/s))",
                        self.power_coefficients)
        q_e = var.energy_weight if self.energy_weight is None else self.energy_weight
        set_(self, "energy_weight", positive_float(q_e, "energy_weight", where, allow_zero=True))
        use_wind = var.use_wind if self.use_wind is None else self.use_wind
        if not isinstance(use_wind, (bool, np.bool_)):
            raise _fail("use_wind", where, "a bool or None", self.use_wind)
        set_(self, "use_wind", bool(use_wind))
        try:
            h = float(self.horizon)
        except (TypeError, ValueError):
            raise _fail("horizon", where, "a number > 0 (inf allowed)", self.horizon) from None
        if not h > 0:
            raise _fail("horizon", where, "a number > 0 (inf allowed)", self.horizon)
        set_(self, "horizon", h)
        for name in ("n_samples", "n_steps"):
            set_(self, name, positive_int(getattr(self, name), name, where))
        # the smoothing matrix is n_steps^2 floats (3.2 GB at 20,000 steps), each buffer of
        # samples n_steps x n_samples x 2 float32s
        if self.n_steps > MAX_STEPS:
            raise _fail("n_steps", where, f"at most {MAX_STEPS}", self.n_steps)
        if self.n_steps * self.n_samples > MAX_SAMPLE_STEPS:
            raise _fail("n_samples", where, f"at most {MAX_SAMPLE_STEPS:.0e} / n_steps "
                        f"({MAX_SAMPLE_STEPS // self.n_steps})", self.n_samples)
        for name in ("dt", "rate_hz", "temperature", "sigma_u", "lidar_range",
                     "obstacle_resolution", "goal_radius"):
            set_(self, name, positive_float(getattr(self, name), name, where))
        for name in ("sigma_gf", "obstacle_weight"):
            set_(self, name, positive_float(getattr(self, name), name, where, allow_zero=True))
        if self.sampling not in SAMPLING:
            raise _fail("sampling", where, f"one of {list(SAMPLING)}", self.sampling)
        if self.energy_mode not in ENERGY_MODES:
            raise _fail("energy_mode", where, f"one of {list(ENERGY_MODES)}", self.energy_mode)
        # forward Euler of v' = a - C |v| v: along the velocity the drag's derivative is
        # 2 C |v|, so a steady speed is stable while dt C |v| < 1 (across it, C |v|: < 2); the
        # fastest steady speed is the terminal speed at full acceleration, sqrt(|a|_max / C).
        # (The bound was 2 until an audit of 2026-12-05: between the two, rollouts alternated
        # between two speeds or overflowed, and every update fell back to braking.)
        a_top = math.hypot(max(abs(self.a_min), self.a_max), max(abs(self.a_min), self.a_max))
        if self.dt * math.sqrt(a_top * self.drag) >= 1.0:
            raise _fail("dt", where, "below 1 / sqrt(C |a|_max) (forward Euler of the drag at the "
                        f"terminal speed: {1.0 / math.sqrt(a_top * self.drag):.3g} s)", self.dt)

    @classmethod
    def from_vehicle(cls, params: MultirotorParams, variant: str = "ea-mppi-w", *,
                     horizon: float = math.inf, **overrides) -> PlannerConfig:
        """Same as :func:`planner_config`."""
        return planner_config(params, variant, horizon=horizon, **overrides)

    # Derived ----------------------------------------------------------------------------------
    @property
    def planner(self) -> str:
        """``"mppi"`` or ``"gs"``: which planner the variant uses."""
        return VARIANTS[self.variant].planner

    @property
    def hover_power(self) -> float:
        """``P_hover = P(0)``, W."""
        return self.power_coefficients[0]

    @property
    def power_curve(self) -> PowerCurve:
        """The fitted curve as a :class:`windnav.vehicle.PowerCurve` (valid to power_speed_max)."""
        return PowerCurve(np.array(self.power_coefficients), speed_max=self.power_speed_max,
                          name=f"{self.vehicle} (simulated)")

    def power_table(self) -> np.ndarray:
        """Packed non-dimensional power curve for the kernels (see :func:`power_bar`)."""
        return _power_table(self.power_coefficients, self.power_speed_max)

    def power(self, airspeed) -> np.ndarray:
        """Steady-flight power at ``airspeed`` (m/s, any shape, >= 0), W, with the continuation
        beyond ``power_speed_max`` the planner uses."""
        try:
            v = np.asarray(airspeed, dtype=np.float64)
        except (TypeError, ValueError):  # NumPy's "could not convert string to float"
            raise _fail("airspeed", "PlannerConfig.power", "numbers >= 0, m/s",
                        airspeed) from None
        if not np.all(v >= 0):  # -1 m/s gave a power; NaN a NaN
            raise ValueError("The 'airspeed' parameter of PlannerConfig.power must be >= 0 m/s "
                             "(no NaN).")
        return power_bar_array(v, self.power_table()) * self.hover_power

    def energy_per_metre(self, direction, wind=(0.0, 0.0), *, speed_range=(0.5, 25.0)
                         ) -> float:
        """``e_R = min_V P(|V d - w|) / (P_hover V)``: the least energy per metre of ground
        flown along the unit vector ``d`` (2,) in the uniform wind ``w`` (2,), m/s, over ground
        speeds ``V`` in ``speed_range``, m/s; in s/m (energy divided by ``P_hover``). In still
        air it is ``P(V_R) / (P_hover V_R)``, with ``V_R`` the max-range speed.

        Raises
        ------
        ValueError
            On a ``direction`` or ``wind`` that is not 2 finite numbers, a zero ``direction``,
            or a ``speed_range`` that is not ``0 < low < high``.
        """
        where = "PlannerConfig.energy_per_metre"
        d = batch_array(direction, "direction", where, (2,), batch=1)[0]
        norm = float(np.hypot(*d))
        if norm == 0.0:  # no direction: hovering's power at the top speed, 0.04 s/m, came back
            raise _fail("direction", where, "a non-zero vector", direction)
        d = d / max(norm, 1e-12)
        w = batch_array(wind, "wind", where, (2,), batch=1)[0]
        v = np.linspace(*check_speed_range(speed_range, "speed_range", where), 981)
        air = np.hypot(v * d[0] - float(w[0]), v * d[1] - float(w[1]))
        return float(np.min(power_bar_array(air, self.power_table()) / v))

    def max_range_speed(self, wind_along: float = 0.0, *, speed_range=(0.5, 20.0)) -> float:
        """``V_R(W) = argmin_V P(|V - W|) / V`` over ground speeds in ``speed_range``, m/s: an
        end of the range when the unconstrained optimum lies beyond it (a strong tail- or
        headwind), the best speed the planner may fly, not a minimum of the curve (compare
        the result with ``speed_range`` to tell)."""
        where = "PlannerConfig.max_range_speed"
        lo, hi = check_speed_range(speed_range, "speed_range", where)
        wind_along = finite_float(wind_along, "wind_along", where)  # NaN gave 0.5
        v = np.linspace(lo, hi, 20001)
        k = int(np.argmin(self.power(np.abs(v - wind_along)) / v))
        return float(v[k])


@lru_cache(maxsize=32)
def _power_table(coefficients: tuple, speed_max: float) -> np.ndarray:
    c = np.asarray(coefficients) / coefficients[0]
    poly = np.polynomial.Polynomial(c)
    d1, d2 = poly.deriv(1), poly.deriv(2)
    # [V_max, P(V_max), P'(V_max), P''(V_max) / 2, c_0 .. c_7], all divided by P_hover, the
    # polynomial padded to degree 7 for the kernels' unrolled Horner scheme
    tab = np.concatenate([[speed_max, poly(speed_max), d1(speed_max),
                           0.5 * max(d2(speed_max), 0.0)], c, np.zeros(MAX_COEFFICIENTS - c.size)])
    tab.setflags(write=False)
    return tab


def acceleration_limit(params: MultirotorParams) -> float:
    """Horizontal acceleration at maximum rotor speed while holding altitude, m/s^2.

    ``a_h = sqrt((N k_eta eta_max^2 / m)^2 - g^2)``.

    Raises
    ------
    ValueError
        If the vehicle cannot lift its weight at maximum rotor speed.
    """
    t_max = params.max_thrust / params.mass
    if t_max <= GRAVITY:
        raise ValueError("The 'params' parameter of acceleration_limit must describe a vehicle "
                         "whose maximum thrust exceeds its weight. Got a thrust-to-weight ratio "
                         f"of {t_max / GRAVITY:.3g} instead.")
    return float(np.sqrt(t_max**2 - GRAVITY**2))


def _params_key(params: MultirotorParams) -> tuple:
    out = []
    for f in fields(params):
        v = getattr(params, f.name)
        out.append(v.tobytes() if isinstance(v, np.ndarray) else repr(v))
    return tuple(out)


_SWEEPS: dict = {}
_SWEEPS_KEPT = 64
"""Vehicles whose sweep is kept (the oldest dropped first; a sweep of a vehicle's mass in one
process grew the cache by 3.5 kB a vehicle without end; leak audit, thirty-seventh session)."""


def steady_flight(params: MultirotorParams) -> dict:
    """The simulator's steady-flight sweep behind the planner's power curve and drag.

    Runs :func:`windnav.sim.sweeps.power_sweep` at :data:`SWEEP_SPEEDS` once per distinct set
    of parameters (cached) and keeps the valid points.

    Returns
    -------
    dict
        ``speeds`` (M,) m/s, ``power`` (M,) W and ``drag_accel`` (M,) m/s^2 (``g tan(tilt)``)
        of the valid points, and ``envelope_speed`` (the first invalid speed, or None).
    """
    if not isinstance(params, MultirotorParams):
        raise ValueError("The 'params' parameter of steady_flight must be a MultirotorParams. "
                         f"Got {type(params).__name__} instead.")
    key = _params_key(params)
    if key not in _SWEEPS:
        sweep = power_sweep(params, SWEEP_SPEEDS)
        valid = np.asarray(sweep.get("valid", np.ones(SWEEP_SPEEDS.size, bool)), bool)
        valid &= np.isfinite(sweep["power"]) & (np.asarray(sweep["saturated"]) == 0)
        tilt = np.radians(np.asarray(sweep["pitch_deg"]))
        while len(_SWEEPS) >= _SWEEPS_KEPT:
            del _SWEEPS[next(iter(_SWEEPS))]
        _SWEEPS[key] = {
            "speeds": SWEEP_SPEEDS[valid],
            "power": np.asarray(sweep["power"])[valid],
            "drag_accel": GRAVITY * np.tan(tilt[valid]),
            "envelope_speed": sweep.get("envelope_speed"),
        }
    return {k: (v.copy() if isinstance(v, np.ndarray) else v) for k, v in _SWEEPS[key].items()}


def planner_config(
    params: MultirotorParams,
    variant: str = "ea-mppi-w",
    *,
    horizon: float = math.inf,
    **overrides,
) -> PlannerConfig:
    """The planner configuration of a variant, with the constants derived from a vehicle.

    Parameters
    ----------
    params : MultirotorParams
        The simulated vehicle (e.g. ``windnav.vehicle.params("hummingbird")``; pass
        ``DragFit.apply(params)`` to plan with calibrated drag coefficients).
    variant : str
        Key of :data:`VARIANTS` (sets ``Q_E`` and the use of wind).
    horizon : float
        ``H``, side of the window ``L_t`` inside which the wind is known, m (``inf``: all).
    **overrides
        Any other :class:`PlannerConfig` field (``n_samples=1000, n_steps=25``, ``sampling``,
        and even the derived ``a_max``, ``drag`` ...).

    Returns
    -------
    PlannerConfig
        With ``derivation`` recording the sweep and fits. Its ``a_max`` is the vehicle's own
        (full thrust, holding altitude: 70.6 m/s^2 per axis for the Hummingbird); the closed
        loop of :func:`windnav.experiments.navigate.navigate` overrides it with what its
        controller's tilt cap allows, ``g tan(tilt_max) / sqrt(2)`` (9.9 m/s^2 at 55 deg).
        Pass ``a_max=`` likewise for plans a tilt-capped controller can follow.

    Raises
    ------
    ValueError
        On an unknown variant, a field that does not exist, or an invalid value.
    """
    where = "planner_config"
    if variant not in VARIANTS:
        raise _fail("variant", where, f"one of {list(VARIANTS)}", variant)
    names = {f.name for f in fields(PlannerConfig)}
    unknown = sorted(set(overrides) - names)
    if unknown:
        raise _fail("overrides", where, f"fields of PlannerConfig {sorted(names)}", unknown)
    sweep = steady_flight(params)
    v, p, d = sweep["speeds"], sweep["power"], sweep["drag_accel"]
    if v.size <= POWER_DEGREE + 1:
        raise ValueError(f"The 'params' parameter of {where} must describe a vehicle with more "
                         f"than {POWER_DEGREE + 1} valid steady-flight points in 0-20 m/s. Got "
                         f"{v.size} instead.")
    curve = PowerCurve.from_samples(v, p, POWER_DEGREE)
    drag = float(np.sum(d * v**2) / np.sum(v**4))
    a_h = acceleration_limit(params)
    eta_h = params.hover_rotor_speed
    derivation = {
        "sweep_speeds_mps": v.tolist(),
        "sweep_power_W": p.tolist(),
        "power_fit_max_error_W": float(np.max(np.abs(curve(v) - p))),
        "drag_accel_mps2": d.tolist(),
        "drag_fit_rms_mps2": float(np.sqrt(np.mean((drag * v**2 - d) ** 2))),
        "drag_from_params_per_m": {
            "linear": params.n_rotors * params.k_d * eta_h / params.mass,
            "quadratic": 0.5 * (params.c_dx + params.c_dy) / params.mass,
        },
        "thrust_to_weight": params.max_thrust / params.weight,
        "horizontal_accel_max_mps2": a_h,
        "envelope_speed_mps": sweep["envelope_speed"],
    }
    base = dict(a_max=a_h / np.sqrt(2.0), drag=drag, power_coefficients=tuple(curve.coefficients),
                power_speed_max=float(v.max()), variant=variant, horizon=horizon,
                vehicle=params.name, derivation=derivation)
    return PlannerConfig(**{**base, **overrides})


def with_variant(config: PlannerConfig, variant: str) -> PlannerConfig:
    """``config`` switched to another variant (its ``Q_E`` and use of wind)."""
    if variant not in VARIANTS:
        raise _fail("variant", "with_variant", f"one of {list(VARIANTS)}", variant)
    return replace(config, variant=variant, energy_weight=None, use_wind=None)
