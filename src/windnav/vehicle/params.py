"""Multirotor parameters: frozen dataclasses in SI units.

The built-in vehicles carry the values RotorPy ships (``rotorpy/vehicles/*_params.py``),
so that windnav reproduces RotorPy's physics exactly. Change a value with
``dataclasses.replace(p, mass=0.6)``; build other airframes with :func:`symmetric_rotor_positions`.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field, replace

import numpy as np

from windnav._validate import ReadOnlyOnCopy, positive_float

GRAVITY = 9.81
"""Gravitational acceleration, m/s^2 (RotorPy's value)."""

TRANSLATIONAL_LIFT_MODELS = ("rotorpy", "bounded")
"""Accepted values of ``MultirotorParams.translational_lift``."""

INERTIA_TOLERANCE = 0.01
"""Relative margin by which the largest principal moment of inertia may exceed the sum of the
other two (a flat body's equality, measured or rounded), before it is refused as no rigid
body's."""

LIFT_ENVELOPE_FRACTION = 0.5
"""Translational lift, as a fraction of the rotor's thrust, beyond which the model is used
outside its envelope (the default of :func:`windnav.vehicle.outside_envelope`)."""


def symmetric_rotor_positions(n_rotors: int, arm_m: float, *, x_config: bool = True) -> np.ndarray:
    """Rotor hub positions of a symmetric multirotor, body frame (x forward, y left, z up).

    Parameters
    ----------
    n_rotors : int
        Number of rotors (4 quad, 6 hexa, 8 octo, ...).
    arm_m : float
        Distance of each hub from the centre of mass, m.
    x_config : bool
        If True the first rotor sits half a spacing left of +x (quad-X order of RotorPy:
        front-left, front-right, rear-right, rear-left, i.e. going clockwise seen from above).

    Returns
    -------
    ndarray of shape (n_rotors, 3)
    """
    if n_rotors < 3:
        raise ValueError(f"The 'n_rotors' parameter must be >= 3. Got {n_rotors!r} instead.")
    offset = np.pi / n_rotors if x_config else 0.0
    angles = offset - 2 * np.pi * np.arange(n_rotors) / n_rotors
    return arm_m * np.stack([np.cos(angles), np.sin(angles), np.zeros(n_rotors)], axis=1)


def alternating_directions(n_rotors: int) -> np.ndarray:
    """Spin directions ``[1, -1, 1, -1, ...]`` (the sign of each rotor's yaw moment)."""
    return np.where(np.arange(n_rotors) % 2 == 0, 1.0, -1.0)


@dataclass(frozen=True, eq=False)
class MultirotorParams(ReadOnlyOnCopy):
    """Physical parameters of a multirotor with N rotors whose thrust acts along +body z.

    Attributes
    ----------
    name : str
        Human-readable identifier.
    mass : float
        Mass, kg.
    inertia : ndarray of shape (3, 3)
        Inertia tensor about the centre of mass in body axes, kg m^2.
    rotor_positions : ndarray of shape (N, 3)
        Hub positions relative to the centre of mass, body frame, m.
    rotor_directions : ndarray of shape (N,)
        +1 or -1: sign of the yaw moment ``dir_i * k_m * eta_i**2`` of each rotor.
    k_eta : float
        Thrust coefficient, N/(rad/s)^2: ``T_i = k_eta * eta_i**2``.
    k_m : float
        Yaw-moment coefficient, N m/(rad/s)^2.
    k_d : float
        In-plane rotor drag coefficient, N/(rad/s)/(m/s) = kg/rad.
    k_z : float
        Induced-inflow (axial rotor drag) coefficient, kg/rad.
    k_h : float
        Translational-lift coefficient, N/(m/s)^2 = kg/m.
    k_flap : float
        Blade-flapping moment coefficient, N m/(rad/s)/(m/s) = kg m/rad.
    c_dx, c_dy, c_dz : float
        Parasitic (frame) drag coefficients along body axes, N/(m/s)^2.
    tau_m : float
        First-order motor time constant, s.
    rotor_speed_min, rotor_speed_max : float
        Rotor speed limits, rad/s. Commands are clipped to this range.
    motor_efficiency : float
        Electrical-to-mechanical efficiency used by the rotor power model (0, 1]. Every preset
        keeps 1.0 (no source gives one), so its "rotor power" is the rotors' shaft power
        ``sum k_m eta^3``, not what a battery supplies.
    extra : dict
        Free-form metadata (not used by the physics).
    translational_lift : {"rotorpy", "bounded"}
        Translational-lift model of :mod:`windnav.vehicle.dynamics`. "rotorpy" (default, RotorPy
        parity): ``k_h V_h^2`` per rotor whatever its speed. "bounded": that lift times
        ``min(1, T_i / T_ref)`` with ``T_i = k_eta eta_i^2`` and ``T_ref = m g / N`` (hover thrust
        per rotor), so it vanishes when the rotor stops and equals RotorPy's at or above hover
        thrust.
    max_airspeed : float or None
        Airspeed beyond which the aerodynamic model is not trusted, m/s (see
        :func:`windnav.vehicle.outside_envelope`). None (default): derived, see
        :attr:`airspeed_limit`.
    """

    name: str
    mass: float
    inertia: np.ndarray
    rotor_positions: np.ndarray
    rotor_directions: np.ndarray
    k_eta: float
    k_m: float
    k_d: float = 0.0
    k_z: float = 0.0
    k_h: float = 0.0
    k_flap: float = 0.0
    c_dx: float = 0.0
    c_dy: float = 0.0
    c_dz: float = 0.0
    tau_m: float = 0.005
    rotor_speed_min: float = 0.0
    rotor_speed_max: float = 1500.0
    motor_efficiency: float = 1.0
    extra: dict = field(default_factory=dict)
    translational_lift: str = "rotorpy"
    max_airspeed: float | None = None

    def __post_init__(self):
        where = "MultirotorParams"
        inertia = np.array(self.inertia, dtype=np.float64)
        if inertia.shape == (3,):
            inertia = np.diag(inertia)
        if inertia.shape != (3, 3) or not np.allclose(inertia, inertia.T):
            raise ValueError(
                f"The 'inertia' parameter of {where} must be a symmetric (3, 3) matrix "
                f"or a (3,) diagonal. Got shape {inertia.shape} instead."
            )
        moments = np.linalg.eigvalsh(inertia)  # principal moments, ascending
        if np.any(moments <= 0):
            raise ValueError(f"The 'inertia' parameter of {where} must be positive definite.")
        if moments[2] > (1.0 + INERTIA_TOLERANCE) * (moments[0] + moments[1]):
            # each principal moment is the integral of m r^2 about its axis, at most the sum
            # of the other two (equal for a flat body): Izz = 5e-3 over Ixx + Iyy = 2e-3 was
            # accepted (closure-module audit)
            raise ValueError(
                f"The 'inertia' parameter of {where} must be a rigid body's: no principal "
                f"moment above the sum of the other two (Izz <= Ixx + Iyy, within "
                f"{INERTIA_TOLERANCE:.0%} for measured values). Got principal moments "
                f"{[float(f'{m:.6g}') for m in moments]} instead.")
        pos = np.array(self.rotor_positions, dtype=np.float64)
        if pos.ndim != 2 or pos.shape[1] != 3 or pos.shape[0] < 1:
            raise ValueError(
                f"The 'rotor_positions' parameter of {where} must have shape (N, 3). "
                f"Got shape {pos.shape} instead."
            )
        dirs = np.array(self.rotor_directions, dtype=np.float64).reshape(-1)
        if dirs.shape != (pos.shape[0],) or not np.all(np.abs(dirs) == 1):
            raise ValueError(
                f"The 'rotor_directions' parameter of {where} must hold N={pos.shape[0]} "
                f"values of +1 or -1. Got {dirs.tolist()!r} instead."
            )
        positive_float(self.mass, "mass", where)
        positive_float(self.k_eta, "k_eta", where)
        positive_float(self.tau_m, "tau_m", where)
        positive_float(self.rotor_speed_max, "rotor_speed_max", where)
        if positive_float(self.motor_efficiency, "motor_efficiency", where) > 1.0:
            # fly divides k_m by it before rotor_power, whose own check then never saw it: 1.5
            # logged 37.5 W of electrical power for 56.2 W of shaft power (audit, 2026-12-05)
            raise ValueError(f"The 'motor_efficiency' parameter of {where} must be in (0, 1]. "
                             f"Got {self.motor_efficiency!r} instead.")
        for name in ("k_m", "k_d", "k_z", "k_h", "k_flap", "c_dx", "c_dy", "c_dz",
                     "rotor_speed_min"):
            positive_float(getattr(self, name), name, where, allow_zero=True)
        if self.translational_lift not in TRANSLATIONAL_LIFT_MODELS:
            raise ValueError(
                f"The 'translational_lift' parameter of {where} must be one of "
                f"{list(TRANSLATIONAL_LIFT_MODELS)}. Got {self.translational_lift!r} instead."
            )
        if self.max_airspeed is not None:
            object.__setattr__(self, "max_airspeed",
                               positive_float(self.max_airspeed, "max_airspeed", where))
        if self.rotor_speed_min >= self.rotor_speed_max:
            raise ValueError(
                f"The 'rotor_speed_min' parameter of {where} must be below rotor_speed_max. "
                f"Got {self.rotor_speed_min!r} >= {self.rotor_speed_max!r} instead."
            )
        for name, arr in (("inertia", inertia), ("rotor_positions", pos),
                          ("rotor_directions", dirs)):
            arr.setflags(write=False)
            object.__setattr__(self, name, arr)
        for name in ("mass", "k_eta", "k_m", "k_d", "k_z", "k_h", "k_flap", "c_dx", "c_dy",
                     "c_dz", "tau_m", "rotor_speed_min", "rotor_speed_max", "motor_efficiency"):
            object.__setattr__(self, name, float(getattr(self, name)))

    # Derived quantities -------------------------------------------------------------------
    @property
    def n_rotors(self) -> int:
        """Number of rotors N."""
        return int(self.rotor_positions.shape[0])

    @property
    def weight(self) -> float:
        """Weight m g, N."""
        return self.mass * GRAVITY

    @property
    def max_thrust(self) -> float:
        """``N k_eta eta_max^2``: the thrust of all rotors at their top speed, N."""
        return self.n_rotors * self.k_eta * self.rotor_speed_max**2

    @property
    def hover_thrust_per_rotor(self) -> float:
        """``T_ref = m g / N``: the thrust of each of N equal rotors in hover, N."""
        return self.weight / self.n_rotors

    @property
    def airspeed_limit(self) -> float:
        """Largest airspeed at which the aerodynamic model is trusted, m/s.

        :attr:`max_airspeed` when given. Otherwise derived from the translational lift: the
        airspeed at which RotorPy's ``k_h V^2`` on a rotor at hover thrust reaches
        :data:`LIFT_ENVELOPE_FRACTION` of that thrust, ``sqrt(0.5 m g / (N k_h))`` (13.4 m/s for
        the Hummingbird, 7.0 m/s for the Crazyflie Brushless; infinite when ``k_h = 0``).
        """
        if self.max_airspeed is not None:
            return self.max_airspeed
        if self.k_h == 0.0:
            return float("inf")
        return float(np.sqrt(LIFT_ENVELOPE_FRACTION * self.hover_thrust_per_rotor / self.k_h))

    @property
    def rotor_drag_matrix(self) -> np.ndarray:
        """``diag(k_d, k_d, k_z)``, kg/rad."""
        return np.diag([self.k_d, self.k_d, self.k_z])

    @property
    def drag_matrix(self) -> np.ndarray:
        """``diag(c_dx, c_dy, c_dz)``, N/(m/s)^2."""
        return np.diag([self.c_dx, self.c_dy, self.c_dz])

    @property
    def hover_rotor_speed(self) -> float:
        """Rotor speed at which N equal rotors carry the weight in still air, rad/s."""
        return float(np.sqrt(self.weight / (self.n_rotors * self.k_eta)))

    @property
    def allocation_matrix(self) -> np.ndarray:
        """Map from rotor thrusts (N,) to ``[collective thrust, Mx, My, Mz]`` (4, N).

        Rows: ``sum T_i``; ``(r_i x e3 T_i)_x``, ``(r_i x e3 T_i)_y`` i.e. ``y_i T_i`` and
        ``-x_i T_i``; ``dir_i (k_m / k_eta) T_i``.
        """
        r = self.rotor_positions
        return np.vstack([
            np.ones(self.n_rotors),
            r[:, 1],
            -r[:, 0],
            self.rotor_directions * (self.k_m / self.k_eta),
        ])

    def replace(self, **changes) -> MultirotorParams:
        """Return a copy with ``changes`` applied (``dataclasses.replace``)."""
        return replace(self, **changes)


def _quad_x(arm_m: float) -> np.ndarray:
    s = 0.70710678118  # RotorPy's literal, kept for bit-level agreement
    return arm_m * np.array([[s, s, 0.0], [s, -s, 0.0], [-s, -s, 0.0], [-s, s, 0.0]])


_BUILTIN = {
    # AscTec Hummingbird, RotorPy rotorpy/vehicles/hummingbird_params.py
    "hummingbird": dict(
        mass=0.5,
        inertia=np.diag([3.65e-3, 3.68e-3, 7.03e-3]),
        rotor_positions=_quad_x(0.17),
        rotor_directions=np.array([1.0, -1.0, 1.0, -1.0]),
        k_eta=5.57e-6, k_m=1.36e-7, k_d=1.19e-4, k_z=2.32e-4, k_h=3.39e-3, k_flap=0.0,
        c_dx=0.5e-2, c_dy=0.5e-2, c_dz=1e-2,
        tau_m=0.005, rotor_speed_min=0.0, rotor_speed_max=1500.0,
    ),
    # Crazyflie Brushless with guards, RotorPy rotorpy/vehicles/crazyfliebrushless_params.py
    "crazyflie_brushless": dict(
        mass=0.044,
        inertia=np.diag([3.3e-5, 3.6e-5, 5.9e-5]),
        rotor_positions=_quad_x(0.043),
        rotor_directions=np.array([1.0, -1.0, 1.0, -1.0]),
        k_eta=4.052e-8, k_m=7.8e-10, k_d=5.09e-6, k_z=1.19e-5, k_h=1.11e-3, k_flap=0.0,
        c_dx=0.0, c_dy=0.0, c_dz=0.0,
        tau_m=0.05, rotor_speed_min=0.0, rotor_speed_max=3100.0,
    ),
}

VEHICLES = (*_BUILTIN, "crazyflie_thesis")
"""Names accepted by :func:`params` (``crazyflie_thesis``: the Crazyflie 2.1 Brushless with the
thesis's identified coefficients, :mod:`windnav.vehicle.thesis_presets`)."""


def params(name: str, **overrides) -> MultirotorParams:
    """Parameters of a built-in vehicle.

    Parameters
    ----------
    name : {"hummingbird", "crazyflie_brushless", "crazyflie_thesis"}
        Vehicle name (:data:`VEHICLES`).
    **overrides
        Fields to change, e.g. ``params("hummingbird", mass=0.6)``.

    Raises
    ------
    ValueError
        If ``name`` is not a known vehicle; naming the overrides that leave a vehicle unable to
        hover (full thrust ``N k_eta eta_max^2`` at most its weight).
    """
    where = "windnav.vehicle.params"
    if name == "crazyflie_thesis":
        # the preset starts from crazyflie_brushless through params() itself
        from windnav.vehicle.thesis_presets import _thesis_params

        return _hovering(_thesis_params(overrides), overrides, where)
    if name not in _BUILTIN:
        raise ValueError(
            f"The 'name' parameter of {where} must be one of {list(VEHICLES)}. "
            f"Got {name!r} instead."
        )
    return _hovering(MultirotorParams(name=name, **{**_BUILTIN[name], **overrides}), overrides,
                    where)


_THRUST_FIELDS = ("mass", "k_eta", "rotor_speed_max", "rotor_positions")
"""The fields that set full thrust and weight."""


def _hovering(p: MultirotorParams, overrides: dict, where: str) -> MultirotorParams:
    """``p``, a preset changed by ``overrides``, when its rotors can lift it; else a ValueError
    naming the overrides. ``MultirotorParams`` itself (and ``replace``) keeps accepting such a
    vehicle: a check of the thrust margin builds one on purpose."""
    if p.max_thrust > p.weight:
        return p
    named = [k for k in overrides if k in _THRUST_FIELDS] or list(overrides)
    got = ", ".join(f"{k}={overrides[k]!r}" if np.ndim(overrides[k]) == 0
                    else f"{k} of shape {np.shape(overrides[k])}" for k in named)
    which = " and ".join(repr(k) for k in named)
    raise ValueError(
        f"The {which} parameter{'s' if len(named) > 1 else ''} of {where} must leave a vehicle "
        f"that can hover: full thrust N k_eta eta_max^2 = {p.max_thrust:.4g} N against a "
        f"weight m g = {p.weight:.4g} N is a thrust-to-weight of {p.max_thrust / p.weight:.2f} "
        f"(hover needs {p.hover_rotor_speed:.0f} of {p.rotor_speed_max:.0f} rad/s). Got {got} "
        f"instead.")


def params_to_rotorpy_dict(p: MultirotorParams) -> dict:
    """RotorPy's ``quad_params`` dictionary of a vehicle (for cross-checks and adapters).

    Parameters
    ----------
    p : MultirotorParams

    Returns
    -------
    dict
        The keys RotorPy's ``Multirotor`` and ``SE3Control`` read, in SI units, with windnav's
        default attitude gains (``kp_att``, ``kd_att``). RotorPy knows only its own
        translational-lift model: ``translational_lift="bounded"`` and ``max_airspeed`` have no
        counterpart in the dictionary.
    """
    if not isinstance(p, MultirotorParams):
        raise ValueError("The 'p' parameter of params_to_rotorpy_dict must be a MultirotorParams."
                         f" Got {type(p).__name__} instead.")
    return {
        "mass": p.mass,
        "Ixx": p.inertia[0, 0], "Iyy": p.inertia[1, 1], "Izz": p.inertia[2, 2],
        "Ixy": p.inertia[0, 1], "Iyz": p.inertia[1, 2], "Ixz": p.inertia[0, 2],
        "num_rotors": p.n_rotors,
        "rotor_pos": {f"r{i + 1}": np.array(r) for i, r in enumerate(p.rotor_positions)},
        "rotor_directions": np.array(p.rotor_directions),
        "rI": np.zeros(3),
        "c_Dx": p.c_dx, "c_Dy": p.c_dy, "c_Dz": p.c_dz,
        "k_eta": p.k_eta, "k_m": p.k_m, "k_d": p.k_d, "k_z": p.k_z, "k_h": p.k_h,
        "k_flap": p.k_flap,
        "tau_m": p.tau_m, "rotor_speed_min": p.rotor_speed_min,
        "rotor_speed_max": p.rotor_speed_max, "motor_noise_std": 0.0,
        "k_w": 1, "k_v": 10, "kp_att": 544, "kd_att": 46.64,
    }


def to_rotorpy_dict(p: MultirotorParams) -> dict:
    """Deprecated alias of :func:`params_to_rotorpy_dict` (``windnav.city.to_rotorpy_dict``
    converts a City; this one converts vehicle parameters)."""
    warnings.warn("windnav.vehicle.to_rotorpy_dict is deprecated; use "
                  "windnav.vehicle.params_to_rotorpy_dict.", DeprecationWarning, stacklevel=2)
    return params_to_rotorpy_dict(p)
