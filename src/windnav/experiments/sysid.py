"""The thesis's chapter-6 experiments: simulated thrust stand and tunnel, studies, figures.

Synthetic experiments, through the simulator, with known coefficients and sensor noise; they
write the formats the fits read, so the round trip data -> coefficients is tested:

- :func:`simulate_stand`: the PWM ramp (10k to 50k counts in steps of 5k, 1 s per step) at
  supply voltages 2.7 ... 4.1 V. The rotor follows the first-order motor model
  ``d omega/dt = (omega_cmd - omega) / tau_m`` driven by the PWM model
  ``omega_cmd = Kv (V + V0)(PWM - DZ)^(2/3)``, clipped to the vehicle's rotor-speed limits as
  the simulator's motors are (each run counts its clipped samples); the stand reads the whole
  vehicle's thrust
  ``N k_eta omega^2``, one motor's speed (rev/min), the supply voltage and the current, each
  with white noise. One CSV per voltage, with the thrust-stand header.
- :func:`simulate_tunnel`: hover (SE(3) control, :func:`windnav.sim.fly`) in uniform airflows
  of 0 ... 6 m/s in 0.5 m/s steps along several body axes, one vehicle of the batch per
  condition. The IMU has the default noise densities of :class:`windnav.sensors.IMU` and a
  constant bias; the tunnel's anemometer and the motors' speed telemetry add white noise in
  the CSV. Writes a FlightLog (``.npz``) and an aero CSV.

Studies (:func:`thrust_stand_study`, :func:`aero_study`, :func:`power_study`,
:func:`unsteadiness_study`) read files, fit, and return JSON-ready payloads; the ``plot_*``
functions draw the fitted curves over the data and the residuals (matplotlib, Agg).
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import ClassVar

import numpy as np

from windnav._validate import generator, positive_float

__all__ = [
    "AXES", "STAND_PWM_STEPS", "STAND_VOLTAGES", "THESIS_VEHICLE", "TunnelNoise",
    "StandNoise", "aero_assumptions", "aero_study", "plot_aero", "plot_power",
    "plot_thrust_stand", "plot_unsteadiness", "power_study", "simulate_stand", "simulate_tunnel",
    "stand_clipping_note",
    "thrust_stand_study", "ukf_wind_on_log", "unsteadiness_study", "vehicle_names",
    "vehicle_params", "write_stand_csvs",
]

THESIS_VEHICLE = "crazyflie_thesis"
STAND_PWM_STEPS = tuple(range(10_000, 50_001, 5_000))
"""The thesis's PWM ramp, counts."""
STAND_VOLTAGES = tuple(round(2.7 + 0.2 * k, 2) for k in range(8))
"""Supply voltages of the ramps, V (2.7 ... 4.1)."""
AXES = {"x": (1.0, 0.0, 0.0), "y": (0.0, 1.0, 0.0), "xy": (2**-0.5, 2**-0.5, 0.0),
        "neg_x": (-1.0, 0.0, 0.0), "neg_y": (0.0, -1.0, 0.0), "z": (0.0, 0.0, 1.0),
        "neg_z": (0.0, 0.0, -1.0)}
"""Airspeed directions of the tunnel conditions, body axes at zero yaw: ``"x"`` is an
airspeed along +x (the air blows toward -x, as in forward flight); ``"z"`` along +z (the air
comes from above, as in a climb), ``"neg_z"`` as in a descent."""


# ------------------------------------------------------------------------------ vehicles


def vehicle_names() -> tuple[str, ...]:
    """The built-in vehicles and ``crazyflie_thesis``."""
    from windnav.vehicle.params import VEHICLES

    return tuple(VEHICLES) + (() if THESIS_VEHICLE in VEHICLES else (THESIS_VEHICLE,))


def vehicle_params(name: str):
    """Parameters of ``name`` (``crazyflie_thesis`` from its preset builder)."""
    from windnav.vehicle.params import VEHICLES, params

    if name == THESIS_VEHICLE and name not in VEHICLES:
        from windnav.vehicle.thesis_presets import crazyflie_thesis

        return crazyflie_thesis()
    return params(name)


# ------------------------------------------------------------------------------ stand


@dataclass(frozen=True)
class StandNoise:
    """White-noise standard deviations of the simulated thrust stand.

    Attributes
    ----------
    rpm_fraction : float
        Optical speed sensor, fraction of the speed (0.005: 0.5 %).
    thrust_N : float
        Load cell, N.
    torque_Nm : float
        N m.
    voltage_V : float
        V.
    current_A : float
        A.
    """

    rpm_fraction: float = 0.005
    thrust_N: float = 0.005
    torque_Nm: float = 2e-5
    voltage_V: float = 0.005
    current_A: float = 0.02

    def __post_init__(self):
        # -1 and NaN were accepted, to fail in the draw or fill the CSVs with NaN (Python API
        # audit, fifty-eighth session)
        for name in ("rpm_fraction", "thrust_N", "torque_Nm", "voltage_V", "current_A"):
            object.__setattr__(self, name, _noise(getattr(self, name), name, "StandNoise"))


def _noise(value, name: str, where: str) -> float:
    """A noise level: a finite number >= 0 (not a bool), else a named ValueError."""
    if isinstance(value, (bool, np.bool_)):
        raise ValueError(f"The {name!r} parameter of {where} must be a number. Got {value!r} "
                         "instead.")
    return positive_float(value, name, where, allow_zero=True)


def simulate_stand(params, *, voltages: Sequence[float] = STAND_VOLTAGES,
                   pwm_steps: Sequence[float] = STAND_PWM_STEPS, step_s: float = 1.0,
                   rate_hz: float = 100.0, noise: StandNoise = StandNoise(), motor=None,
                   rng: np.random.Generator | int | None = None) -> list[dict]:
    """The thrust-stand procedure on a simulated vehicle, one ramp per supply voltage.

    Parameters
    ----------
    params : MultirotorParams
        The vehicle (``k_eta``, ``k_m``, ``tau_m``, ``n_rotors``, ``motor_efficiency``; the PWM
        model from ``extra["pwm_motor"]`` unless ``motor`` is given).
    voltages : sequence of float
        Supply voltages, V (distinct, > 0; at least one).
    pwm_steps : sequence of float
        PWM commands of the ramp, counts (finite, >= 0), each held ``step_s`` seconds.
    step_s : float
        Hold time of each PWM step, s (default 1).
    rate_hz : float
        Logging rate, Hz: ``step_s * rate_hz`` rounds to 1 ... 1,000,000 samples per step.
    noise : StandNoise
    motor : PWMMotorModel, optional
    rng : numpy.random.Generator or int, optional
        Randomness of the sensor noise (default seed 0).

    Returns
    -------
    list of dict
        Per voltage: ``{"voltage": V, "columns": {name: (n,)}, "clipped": k,
        "clipped_pwm": [...]}`` with the columns ``timestamp, pwm, thrust_N, torque_Nm, rpm,
        voltage_V, current_A``; ``clipped`` counts the samples whose PWM command asked for a
        rotor speed outside ``[rotor_speed_min, rotor_speed_max]``, held at the limit (as
        :meth:`windnav.vehicle.Multirotor.clip_rotor_speeds` holds the simulator's), and
        ``clipped_pwm`` lists their PWM steps. The Hummingbird with the thesis's Kv asked for
        up to 2151 rad/s of its 1500 rad/s, unclipped, before.
    """
    from windnav.sysid.thrust_stand import RPM_TO_RAD_S, PWMMotorModel

    where = "simulate_stand"
    # checked before the ramps (Python API audit, fifty-eighth session): 0 V drew rpm with a
    # divide-by-zero, -3.7 V ran, [] gave no ramp, a repeated voltage two ramps; a PWM of
    # -1000 or NaN ran; a step of 0 s gave empty columns, 1e7 s a 67 GiB MemoryError; a rate
    # of 0, -100 or NaN Hz failed in NumPy, a negative seed with NumPy's message
    volts = _distinct_positive(voltages, "voltages", where, "V")
    steps = _values(pwm_steps, "pwm_steps", where, "PWM commands >= 0, counts")
    if np.any(steps < 0):
        raise ValueError(f"The 'pwm_steps' parameter of {where} must hold PWM commands >= 0, "
                         f"counts. Got {steps.tolist()!r} instead.")
    step_s = positive_float(step_s, "step_s", where)
    rate_hz = positive_float(rate_hz, "rate_hz", where)
    samples = step_s * rate_hz
    samples = round(samples) if math.isfinite(samples) else samples
    if not 1 <= samples <= MAX_STAND_SAMPLES_PER_STEP:
        raise ValueError(f"The 'rate_hz' parameter of {where} must give 1 to "
                         f"{MAX_STAND_SAMPLES_PER_STEP:,} samples per PWM step of step_s = "
                         f"{step_s:g} s. Got {rate_hz!r} Hz instead ({samples:g} samples; "
                         "change step_s or rate_hz).")
    if not isinstance(noise, StandNoise):
        raise ValueError(f"The 'noise' parameter of {where} must be a StandNoise. Got "
                         f"{type(noise).__name__} instead.")
    gen = generator(0 if rng is None else rng, "rng", where)
    motor = PWMMotorModel.from_params(params) if motor is None else motor
    n = params.n_rotors
    dt = 1.0 / rate_hz
    per_step = int(round(step_s * rate_hz))
    decay = np.exp(-dt / params.tau_m)
    runs = []
    for volt in volts:
        pwm = np.repeat(steps, per_step)
        wanted = motor.rotor_speed(pwm, volt)
        cmd = np.clip(wanted, params.rotor_speed_min, params.rotor_speed_max)
        clipped = cmd != wanted
        omega = np.empty_like(cmd)
        w = 0.0
        for k, c in enumerate(cmd):  # exact solution of the first-order lag over each dt
            w = c + (w - c) * decay
            omega[k] = w
        thrust = n * params.k_eta * omega**2
        torque = np.sum(params.rotor_directions) * params.k_m * omega**2
        power = n * params.k_m * omega**3 / params.motor_efficiency
        size = omega.size
        runs.append({"voltage": float(volt), "columns": {
            "timestamp": dt * np.arange(1, size + 1),
            "pwm": pwm,
            "thrust_N": thrust + gen.normal(0, noise.thrust_N, size),
            "torque_Nm": torque + gen.normal(0, noise.torque_Nm, size),
            "rpm": omega * (1 + gen.normal(0, noise.rpm_fraction, size)) / RPM_TO_RAD_S,
            "voltage_V": volt + gen.normal(0, noise.voltage_V, size),
            "current_A": power / volt + gen.normal(0, noise.current_A, size),
        }, "clipped": int(clipped.sum()),
            "clipped_pwm": sorted({float(v) for v in pwm[clipped]})})
    return runs


MAX_STAND_SAMPLES_PER_STEP = 1_000_000
"""The most samples :func:`simulate_stand` logs per PWM step (``step_s * rate_hz``), as
``sysid simulate-stand`` allows."""


def _values(value, name: str, where: str, rule: str) -> np.ndarray:
    """A non-empty 1-D float64 array of finite numbers, else a ValueError naming ``name``
    (``rule`` says what they are)."""
    try:
        a = None if isinstance(value, (str, bytes)) else np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        a = None
    if a is None or a.ndim != 1 or not a.size or not np.all(np.isfinite(a)):
        raise ValueError(f"The {name!r} parameter of {where} must be a non-empty sequence of "
                         f"finite {rule}. Got {value!r} instead.")
    return a


def _distinct_positive(value, name: str, where: str, unit: str) -> list[float]:
    """Distinct finite numbers > 0 (voltages), as a list of floats, else a named ValueError."""
    try:  # any iterable, as the loop over it took before
        items = value if isinstance(value, (str, bytes, np.ndarray)) else list(value)
    except TypeError:
        items = value
    a = _values(items, name, where, f"numbers > 0, {unit}")
    if np.any(a <= 0) or np.unique(a).size != a.size:
        raise ValueError(f"The {name!r} parameter of {where} must hold distinct numbers > 0, "
                         f"{unit}. Got {a.tolist()!r} instead.")
    return [float(v) for v in items]


def stand_clipping_note(runs, params) -> str | None:
    """A note when :func:`simulate_stand` held rotor speeds at the vehicle's limits, else
    None: those steps leave the PWM model, which ``sysid thrust-stand`` fits to every steady
    point."""
    n = sum(r["clipped"] for r in runs)
    if not n:
        return None
    total = sum(r["columns"]["pwm"].size for r in runs)
    volts = [r["voltage"] for r in runs if r["clipped"]]
    pwms = sorted({v for r in runs for v in r["clipped_pwm"]})
    return (f"{n} of the {total} samples ({len(volts)} of the {len(runs)} ramps, "
            f"{min(volts):g} to {max(volts):g} V, PWM {pwms[0]:g} to {pwms[-1]:g}) command a "
            f"rotor speed outside {params.name}'s limits [{params.rotor_speed_min:g}, "
            f"{params.rotor_speed_max:g}] rad/s and are held at the limit, as the simulator's "
            "motors are: there the rotor speed stops following the PWM model, and sysid "
            "thrust-stand fitted on them gives a biased Kv, V0 and DZ; lower --kv or "
            "--voltages to stay inside the limits")


# ------------------------------------------------------------------------------ tunnel


@dataclass(frozen=True)
class TunnelNoise:
    """Sensor imperfections of the simulated tunnel campaign.

    Attributes
    ----------
    accel_bias : tuple of 3 float
        Constant accelerometer bias, body axes, m/s^2 (the IMU's white noise and bias walk
        are those of :class:`windnav.sensors.IMU`).
    airspeed_m_s : float
        Anemometer white noise on each airspeed component, m/s (CSV only).
    rotor_speed_rad_s : float
        Motor speed telemetry white noise, rad/s (CSV only).
    """

    accel_bias: tuple = (0.05, -0.04, 0.03)
    airspeed_m_s: float = 0.03
    rotor_speed_rad_s: float = 5.0

    def __post_init__(self):
        # a bias of two components and negative or NaN noise were accepted (Python API audit,
        # fifty-eighth session); the bias is kept as given (truth.json lists it)
        where = "TunnelNoise"
        bias = self.accel_bias
        try:
            ok = (not isinstance(bias, (str, bytes)) and len(bias) == 3
                  and all(isinstance(b, numbers.Real) and not isinstance(b, (bool, np.bool_))
                          and math.isfinite(b) for b in bias))
        except TypeError:
            ok = False
        if not ok:
            raise ValueError(f"The 'accel_bias' parameter of {where} must be 3 finite numbers, "
                             f"m/s^2. Got {bias!r} instead.")
        for name in ("airspeed_m_s", "rotor_speed_rad_s"):
            object.__setattr__(self, name, _noise(getattr(self, name), name, where))


@dataclass(frozen=True)
class _BiasedIMU:
    """The standard IMU with a constant accelerometer bias (a sensor of the runner)."""

    name: ClassVar[str] = "imu"
    imu: object
    bias: tuple

    @property
    def rate_hz(self) -> float:
        return self.imu.rate_hz

    def sample(self, truth, rng) -> dict:
        B = truth.state.shape[1]
        bias0 = np.tile(np.r_[np.asarray(self.bias, dtype=np.float64), np.zeros(3)], (B, 1))
        accel, gyro, bias = self.imu.measure(truth.specific_force_body, truth.body_rates, rng,
                                             bias0=bias0)
        return {"accel": accel, "gyro": gyro, "bias": bias}


def _duration(value, name: str, where: str, *, allow_zero: bool = False) -> None:
    """Refuse anything but a finite real number > 0 (>= 0), by name."""
    if not isinstance(value, numbers.Real) or isinstance(value, (bool, np.bool_)):
        raise ValueError(f"The {name!r} parameter of {where} must be a number, s. Got "
                         f"{value!r} instead.")
    positive_float(value, name, where, allow_zero=allow_zero)


class _PerVehicleWind:
    """A steady wind per batch row: row b of ``velocity`` is vehicle b's (the runner queries
    the vehicles in batch order)."""

    def __init__(self, winds: np.ndarray):
        self.winds = np.ascontiguousarray(winds, dtype=np.float64)

    def velocity(self, t, xyz) -> np.ndarray:
        if np.shape(xyz)[0] != self.winds.shape[0]:
            raise ValueError(f"The tunnel wind holds {self.winds.shape[0]} vehicles' flows. "
                             f"Got {np.shape(xyz)[0]} positions instead.")
        return self.winds.copy()


def simulate_tunnel(params, *, speeds: Sequence[float] = tuple(np.arange(0.0, 6.01, 0.5)),
                    axes: Sequence[str] = ("x", "y", "xy", "z", "neg_z"), settle_s: float = 2.5,
                    record_s: float = 1.5, dt: float = 0.005,
                    noise: TunnelNoise = TunnelNoise(),
                    rng: np.random.Generator | int | None = None):
    """Hover in steady airflows of the given speeds along the given body axes.

    Parameters
    ----------
    params : MultirotorParams
    speeds : sequence of float
        Airspeeds, m/s (thesis: 0 ... 6 in 0.5 steps).
    axes : sequence of str
        Keys of :data:`AXES`: the direction of the airspeed in body axes. The vertical flows
        (``"z"``, ``"neg_z"``) separate ``k_z`` from ``k_h``: in horizontal flows the inflow
        ``v_a,z`` comes only from the tilt, which grows like ``V``, so ``v_a,z sum(eta)`` and
        ``v_h^2`` both grow like ``V^2`` and are nearly collinear.
    settle_s, record_s : float
        Transient after the flow starts (dropped by the fits), then the recorded hover, s.
    dt : float
        Physics step, s: a whole number of them per sample of the IMU (200 Hz).
    noise : TunnelNoise
    rng : numpy.random.Generator or int, optional
        Randomness of the IMU and the CSV noise (default seed 0).

    Returns
    -------
    log : FlightLog
        One vehicle per condition; ``meta["sysid"]`` holds ``settle_s``, ``mass``, the true
        coefficients, the bias and the conditions.
    csv_columns : dict
        The recorded part as aero CSV columns (:func:`windnav.sysid.aero_columns`), with the
        anemometer and telemetry noise added.
    """
    import windnav as wn
    from windnav.sensors import IMU
    from windnav.sysid.aero import AeroData, aero_from_flight_log

    bad = [a for a in axes if a not in AXES]
    if bad or not axes or len(set(axes)) != len(axes):  # (a repeat flew each flow twice)
        raise ValueError(f"The 'axes' parameter of simulate_tunnel must name some of "
                         f"{list(AXES)}, each once. Got {list(axes)!r} instead.")
    where = "simulate_tunnel"
    # checked before the flights (Python API audit, fifty-eighth session): dt = 1 s was named
    # "The 'sensors' parameter's imu rate_hz of fly", dt = 0 fly's, and settle_s = -1
    # aero_from_flight_log's after the flights
    _duration(settle_s, "settle_s", where, allow_zero=True)  # kept as given: meta lists them
    _duration(record_s, "record_s", where)
    dt = positive_float(dt, "dt", where)
    imu_hz = IMU().rate_hz
    ratio = 1.0 / (imu_hz * dt)
    if round(ratio) < 1 or abs(ratio - round(ratio)) > 1e-6 * ratio:  # as fly's sensors need
        raise ValueError(f"The 'dt' parameter of {where} must divide the IMU's sample period "
                         f"1/{imu_hz:g} s (a whole number of physics steps per IMU sample). Got "
                         f"{dt!r} instead.")
    if not isinstance(noise, TunnelNoise):
        raise ValueError(f"The 'noise' parameter of {where} must be a TunnelNoise. Got "
                         f"{type(noise).__name__} instead.")
    gen = generator(0 if rng is None else rng, "rng", where)
    speeds = np.asarray(speeds, dtype=np.float64)
    if (speeds.ndim != 1 or not speeds.size or not np.all(np.isfinite(speeds))
            or np.any(speeds < 0) or not np.any(speeds > 0)
            or np.unique(speeds).size != speeds.size):  # (all zero: no airflow, no k_d)
        raise ValueError("The 'speeds' parameter of simulate_tunnel must be distinct finite "
                         "airspeeds >= 0 m/s, one of them > 0. Got "
                         f"{speeds.tolist()!r} instead.")
    conditions = [(a, float(v)) for a in axes for v in speeds]
    winds = np.array([[-v * c for c in AXES[a]] for a, v in conditions])
    sensor = _BiasedIMU(IMU(), tuple(float(b) for b in noise.accel_bias))
    log = wn.sim.fly(params, wn.sim.Hover((0.0, 0.0, 1.0)), _PerVehicleWind(winds),
                     settle_s + record_s, dt=dt, batch=len(conditions), sensors=[sensor],
                     rng=gen, log_every=2)
    log.meta["sysid"] = {
        "experiment": "tunnel", "settle_s": settle_s, "record_s": record_s,
        "mass": params.mass, "vehicle": params.name,
        "true": {"k_eta": params.k_eta, "k_d": params.k_d, "k_z": params.k_z,
                 "k_h": params.k_h, "c_Dx": params.c_dx, "c_Dy": params.c_dy,
                 "c_Dz": params.c_dz, "accel_bias": list(noise.accel_bias)},
        "conditions": [{"axis": a, "airspeed_m_s": v} for a, v in conditions],
    }
    data = aero_from_flight_log(log)
    noisy = AeroData(data.t,
                     data.airspeed_body + gen.normal(0, noise.airspeed_m_s,
                                                     data.airspeed_body.shape),
                     data.specific_force_body,
                     data.rotor_speeds + gen.normal(0, noise.rotor_speed_rad_s,
                                                    data.rotor_speeds.shape))
    return log, noisy.to_columns()


# ------------------------------------------------------------------------------ studies


def thrust_stand_study(paths: Sequence, n_rotors: int, *, max_accel: float = 1000.0,
                       min_speed: float = 250.0, window_s: float = 0.1,
                       settle_s: float | None = None, tables=None,
                       where: str = "thrust_stand_study"):
    """Read thrust-stand CSV files (or ``tables``) and fit; returns ``(fit, payload)``."""
    from windnav.sysid.io import read_table
    from windnav.sysid.thrust_stand import SETTLE_S, fit_thrust_stand

    settle_s = SETTLE_S if settle_s is None else settle_s
    tabs = list(tables or []) + [read_table(p, where=where) for p in paths]
    fit = fit_thrust_stand(tabs, n_rotors, max_accel=max_accel, min_speed=min_speed,
                           window_s=window_s, settle_s=settle_s, where=where)
    return fit, {**fit.to_dict(), "n_rotors": int(n_rotors),
                 "steadiness": {"max_accel_rad_s2": max_accel, "min_speed_rad_s": min_speed,
                                "window_s": window_s, "settle_s": settle_s}}


def aero_assumptions(fit) -> list[str]:
    """What the aero fit assumes and its data cannot test, one sentence each (the payload's
    ``assumptions``, beside the data-triggered ``notes``).

    The vertical equation has no intercept, so an accelerometer bias ``b_z`` along body z
    scales the whole fit: ``k_eta``, ``k_z`` and ``k_h`` move by about ``b_z / g`` relative
    (+0.3 % for the simulated campaign's 0.03 m/s^2), outside their intervals, and nothing in
    the samples shows it (hover holds ``sum(eta^2)`` nearly constant, so an intercept would be
    collinear with ``k_eta``). The fitted lateral biases ``b_x``, ``b_y`` are quoted for scale.
    """
    bx, by = (b.value for b in fit.accel_bias)
    return [f"the vertical fit has no intercept: an accelerometer z bias b_z moves k_eta, k_z "
            f"and k_h by about b_z / 9.81 relative (+0.3 % per +0.03 m/s^2), which their "
            f"intervals do not include and the samples cannot show (for scale, this fit's x "
            f"and y biases are {bx:.3g} and {by:.3g} m/s^2); calibrate the accelerometer's z "
            "bias first if that matters"]


def aero_study(data, mass: float, *, parasitic: bool = False, where: str = "aero_study"):
    """Fit pooled :class:`~windnav.sysid.AeroData` (``parasitic``: with the frame drag,
    :func:`~windnav.sysid.fit_aero`); returns ``(fit, payload)``, the payload with the fit's
    ``notes``, its untestable ``assumptions`` (:func:`aero_assumptions`) and ``n_dropped``,
    the samples the data left out for a non-finite value (a note when any: NaN on every other
    CSV row halved the samples fitted, silently; files audit)."""
    from windnav.sysid.aero import fit_aero

    fit = fit_aero(data, mass, parasitic=parasitic, where=where)
    payload = {**fit.to_dict(), "assumptions": aero_assumptions(fit)}
    payload["n_dropped"] = dropped = sum(d.dropped for d in (
        data if isinstance(data, (list, tuple)) else [data]))
    if dropped:
        payload["notes"] = [*payload["notes"], f"{dropped} sample(s) with a non-finite value "
                            "were left out of the fit"]
    return fit, payload


def power_study(table, speed_col: str, power_col: str, *, degree: int = 3,
                speed_max: float | None = None, time_col: str | None = None,
                vertical_speed_col: str | None = None, altitude_col: str | None = None,
                min_altitude: float | None = None, max_vertical_speed: float = 0.3,
                max_accel: float = 0.5, min_segment_s: float = 1.0, winds=None,
                speed_range=None, where: str = "power_study"):
    """Fit power against speed from a table; returns ``(fit, payload)``.

    Steady level flight is selected (:func:`windnav.sysid.steady_level_mask`) when
    ``time_col`` is given; otherwise every row is used. ``speed_range = (lo, hi)`` (m/s)
    keeps only the samples with speeds in it.

    The payload's ``notes`` say where the curve does not match the samples: the fit's own
    (:attr:`~windnav.sysid.PowerFit.notes`, the lack-of-fit test), the samples slower than
    0.5 m/s off the curve at their speeds (:func:`windnav.sysid.power.hover_check`), and
    ``windnav power-curve``'s :func:`~windnav.experiments.power_curve.endurance_check`
    (``endurance_check``).
    """
    from windnav.sysid.power import (
        DEFAULT_WINDS,
        HOVER_SPEED_M_S,
        fit_power,
        hover_check,
        steady_level_mask,
    )

    # the selection's columns and limits without time_col, and one altitude argument without
    # the other, were read and ignored: every row fitted (Python API audit, fifty-eighth
    # session, and its review); sysid power refuses the same flags
    given = {"vertical_speed_col": vertical_speed_col, "altitude_col": altitude_col,
             "min_altitude": min_altitude}
    if time_col is None and any(v is not None for v in given.values()):
        first = next(k for k, v in given.items() if v is not None)
        raise ValueError(f"The 'time_col' parameter of {where} must be given with {first}: the "
                         "selection of steady level flight needs the samples' times. Got none "
                         "instead.")
    if (altitude_col is None) != (min_altitude is None):
        missing, present = (("altitude_col", "min_altitude") if altitude_col is None
                            else ("min_altitude", "altitude_col"))
        raise ValueError(f"The '{missing}' parameter of {where} must be given with {present}. "
                         f"Got none with {present}={given[present]!r} instead.")
    speed = table.column(speed_col, where)
    power = table.column(power_col, where)
    keep = np.isfinite(speed) & np.isfinite(power)
    selection = {"rows": len(table), "finite": int(keep.sum())}
    if speed_range is not None:
        lo, hi = (float(v) for v in speed_range)
        keep &= (speed >= lo) & (speed <= hi)
        selection.update(speed_range_m_s=[lo, hi], in_speed_range=int(keep.sum()))
    if time_col is not None:
        t = table.column(time_col, where)
        vz = None if vertical_speed_col is None else table.column(vertical_speed_col, where)
        alt = None if altitude_col is None else table.column(altitude_col, where)
        steady = steady_level_mask(t, speed, vertical_speed=vz, altitude=alt,
                                   max_vertical_speed=max_vertical_speed, max_accel=max_accel,
                                   min_altitude=min_altitude, min_segment_s=min_segment_s)
        keep &= steady
        selection.update(steady_level=int(keep.sum()), max_vertical_speed_m_s=(
            max_vertical_speed if vz is not None else None), max_accel_m_s2=max_accel,
            min_altitude_m=min_altitude if alt is not None else None,
            min_segment_s=min_segment_s)
        if not keep.any():
            raise ValueError(
                f"The file {table.source!r} given to {where} has no steady level point: none "
                f"of its rows has |d {speed_col}/dt| < {max_accel:g} m/s^2"
                + (f", |{vertical_speed_col}| < {max_vertical_speed:g} m/s" if vz is not None
                   else "")
                + (f", {altitude_col} > {min_altitude:g} m" if alt is not None and
                   min_altitude is not None else "")
                + f" for {min_segment_s:g} s.")
    src = f"{table.source!r} (columns {speed_col!r}, {power_col!r})"
    fit = fit_power(speed[keep], power[keep], degree=degree, speed_max=speed_max,
                    winds=DEFAULT_WINDS if winds is None else winds, source=src)
    from windnav.experiments.power_curve import endurance_check

    hover = hover_check(fit, HOVER_SPEED_M_S)
    hover_note = hover.pop("note")
    # windnav power-curve's check: a fitted V_E that is a dip of the fit, not of the samples
    endurance = endurance_check(fit.curve, fit.speed, fit.power)
    endurance_note = endurance.pop("note")
    notes = [*fit.notes, *(n for n in (hover_note, endurance_note) if n)]
    return fit, {**fit.to_dict(), "selection": selection, **hover,
                 "endurance_check": endurance, "notes": notes,
                 "columns": {"speed": speed_col, "power": power_col}}


def unsteadiness_study(samples, *, cell: float = 1.0, min_count: int = 1):
    """Bin flight samples; returns ``(maps, payload)``."""
    from windnav.sysid.unsteadiness import unsteadiness_maps

    maps = unsteadiness_maps(samples, cell=cell, min_count=min_count)
    return maps, {**maps.to_dict(), "cell_m": cell, "min_count": min_count,
                  "n_samples": int(samples.xy.shape[0])}


def ukf_wind_on_log(log, params) -> np.ndarray:
    """The Wind UKF's horizontal wind estimate of every vehicle of ``log`` on the log's times.

    Runs :func:`windnav.estimate.flight.run_wind_ukf` per vehicle with ``params`` (the
    filter's belief) and interpolates its estimate linearly to ``log.t``; (T, B, 2) m/s,
    world frame, NaN for vehicles flagged non-finite.
    """
    from windnav.estimate.flight import run_wind_ukf

    T, B = log.position.shape[:2]
    out = np.full((T, B, 2), np.nan)
    for b in np.flatnonzero(np.asarray(log.finite, dtype=bool)):
        track = run_wind_ukf(log, params, vehicle=int(b))
        for j in range(2):
            out[:, b, j] = np.interp(log.t, track.t, track.wind_est[:, j])
    return out


# ------------------------------------------------------------------------------ figures


def _figure(rows: int, cols: int, size):
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=size)
    FigureCanvasAgg(fig)
    return fig, np.atleast_1d(fig.subplots(rows, cols)).ravel()


def _ci_text(name: str, e, unit: str) -> str:
    return f"{name} = {e.value:.4g} [{e.ci95[0]:.4g}, {e.ci95[1]:.4g}] {unit}"


def plot_thrust_stand(fit, path) -> None:
    """Thrust against rotor speed and rotor speed against PWM per voltage, with the fitted
    curves, and both residuals. Writes a PNG."""
    fig, ax = _figure(2, 2, (11, 8))
    w = np.linspace(0, fit.omega.max() * 1.05, 200)
    ax[0].plot(fit.omega, fit.thrust_per_rotor, ".", ms=2, alpha=0.4, label="steady points")
    ax[0].plot(w, fit.k_eta.value * w**2, "k-", label="k_eta w^2")
    ax[0].set(xlabel="rotor speed w (rad/s)", ylabel="thrust per rotor (N)",
              title=_ci_text("k_eta", fit.k_eta, "N/(rad/s)^2") + f", R2 {fit.thrust.r2:.4f}")
    volts = np.round(fit.voltage, 1)
    from matplotlib import colormaps

    cmap = colormaps["viridis"]
    levels = np.unique(volts)
    p = np.linspace(max(fit.DZ.value, 0), fit.pwm.max() * 1.02, 200)
    for i, v in enumerate(levels):
        c = cmap(i / max(len(levels) - 1, 1))
        sel = volts == v
        ax[1].plot(fit.pwm[sel], fit.omega[sel], ".", ms=2, color=c, alpha=0.4)
        ax[1].plot(p, fit.motor.rotor_speed(p, v), "-", color=c, lw=1, label=f"{v:.1f} V")
    ax[1].set(xlabel="PWM (counts)", ylabel="rotor speed (rad/s)",
              title=f"Kv {fit.Kv.value:.4g}, V0 {fit.V0.value:.4g} V, DZ {fit.DZ.value:.0f}, "
                    f"R2 {fit.speed.r2:.4f}")
    ax[1].legend(fontsize=7, ncol=2)
    ax[2].plot(fit.omega, fit.thrust.residuals, ".", ms=2, alpha=0.4)
    ax[2].axhline(0, color="k", lw=0.8)
    ax[2].set(xlabel="rotor speed (rad/s)", ylabel="thrust residual (N)",
              title="thrust residuals")
    sc = ax[3].scatter(fit.pwm, fit.speed.residuals, c=fit.voltage, s=2, cmap="viridis")
    fig.colorbar(sc, ax=ax[3], label="supply voltage (V)")
    ax[3].axhline(0, color="k", lw=0.8)
    ax[3].set(xlabel="PWM (counts)", ylabel="rotor speed residual (rad/s)",
              title="rotor-speed residuals (colour: voltage)")
    for a in ax:
        a.grid(alpha=0.3)
    ax[0].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def plot_aero(fit, path) -> None:
    """Lateral specific force against ``-v_a sum(eta) / m`` (less the fitted frame drag, when
    fitted), vertical specific force measured against fitted, and their residuals. Writes a
    PNG."""
    d, m = fit.data, fit.mass
    s1 = d.rotor_speeds.sum(axis=1)
    drag = fit.frame_drag_accel()
    less = "" if fit.frame_drag is None else " - frame drag"
    fig, ax = _figure(2, 2, (11, 8))
    for j, (lab, b) in enumerate((("x", fit.accel_bias[0]), ("y", fit.accel_bias[1]))):
        xr = -d.airspeed_body[:, j] * s1 / m
        ax[0].plot(xr, d.specific_force_body[:, j] - drag[:, j], ".", ms=1.5, alpha=0.3,
                   label=f"f_{lab}{less}")
        xs = np.linspace(xr.min(), xr.max(), 2)
        ax[0].plot(xs, fit.k_d.value * xs + b.value, "-", lw=1, label=f"fit f_{lab}")
    ax[0].set(xlabel="-v_a sum(eta) / m  (rad/s m/s / kg)", ylabel="specific force (m/s^2)",
              title=_ci_text("k_d", fit.k_d, "kg/rad") + f", R2 {fit.lateral.r2:.4f}")
    legend = ax[0].legend(fontsize=8)
    for handle in legend.legend_handles:  # the samples' 1.5-point dots, keyed visibly
        if handle.get_marker() == ".":
            handle.set_markersize(8)
            handle.set_alpha(0.8)
    ax[1].plot(fit.vertical.fitted, d.specific_force_body[:, 2], ".", ms=1.5, alpha=0.3)
    lo, hi = fit.vertical.fitted.min(), fit.vertical.fitted.max()
    ax[1].plot([lo, hi], [lo, hi], "k-", lw=0.8)
    ax[1].set(xlabel="fitted f_z (m/s^2)", ylabel="measured f_z (m/s^2)",
              title=f"k_eta {fit.k_eta.value:.4g}, k_z {fit.k_z.value:.4g}, "
                    f"k_h {fit.k_h.value:.4g}; R2 {fit.vertical.r2:.4f}")
    K = d.t.size
    speed = np.linalg.norm(d.airspeed_body, axis=1)
    ax[2].plot(np.r_[speed, speed], fit.lateral.residuals, ".", ms=1.5, alpha=0.3)
    ax[2].set(xlabel="airspeed (m/s)", ylabel="lateral residual (m/s^2)",
              title="lateral residuals (x and y)")
    ax[3].plot(speed, fit.vertical.residuals[:K], ".", ms=1.5, alpha=0.3)
    ax[3].set(xlabel="airspeed (m/s)", ylabel="vertical residual (m/s^2)",
              title="vertical residuals")
    for a in ax:
        a.grid(alpha=0.3)
    for a in ax[2:]:
        a.axhline(0, color="k", lw=0.8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def plot_power(fit, path, *, title: str = "power", xlabel: str = "airspeed (m/s)") -> None:
    """The samples with the fitted curve, the minimum and the range tangent; the residuals;
    the maximum-range speed against the along-track wind. Writes a PNG."""
    fig, ax = _figure(1, 3, (15, 4.5))
    v = np.linspace(0, fit.curve.speed_max, 300)
    # a few samples drawn large enough to see under the fit; thousands small and faint
    many = fit.speed.size > 2000
    ax[0].plot(fit.speed, fit.power, ".", ms=2 if many else 5, alpha=0.35 if many else 0.8,
               label=f"samples ({fit.speed.size})")
    ax[0].plot(v, fit.curve(v), "k-", label=f"degree-{len(fit.coefficients) - 1} fit "
                                            f"(R2 {fit.fit.r2:.3f})")
    ve, pm = fit.max_endurance_speed.value, fit.min_power.value
    ax[0].plot([ve], [pm], "o", color="tab:red",
               label=f"min {pm:.4g} W at {ve:.3g} m/s")
    vr = fit.max_range_speed.value
    edge = vr >= fit.curve.speed_max * (1 - 1e-6)
    ax[0].plot([0, vr], [0, float(fit.curve(vr))], "--", color="tab:green", lw=1,
               label=f"max range {vr:.3g} m/s (tangent from 0"
                     + (", at the search limit)" if edge else ")"))
    slowest = float(np.min(fit.speed))
    ax[0].plot([0], [fit.hover.value], "s", color="tab:purple",
               label=f"hover {fit.hover.value:.4g} W (fit at 0 m/s"
                     + (f", extrapolated below {slowest:.2g})" if slowest > 0.5 else ")"))
    top = max(float(np.max(fit.power)), float(fit.curve(v).max()))
    # from 0 W: the range tangent starts at the origin (figures audit, 2026-12-05)
    ax[0].set(xlabel=xlabel, ylabel="power (W)", title=title, ylim=(0.0, 1.05 * top))
    ax[0].legend(fontsize=8)
    ax[1].plot(fit.speed, fit.fit.residuals, ".", ms=2 if many else 5,
               alpha=0.35 if many else 0.8)
    ax[1].axhline(0, color="k", lw=0.8)
    ax[1].set(xlabel=xlabel, ylabel="residual (W)", title=f"residuals (RMS {fit.fit.rmse:.3g} W)")
    rows = [r for r in fit.in_wind if r["ground_speed_m_s"] is not None]
    w = np.array([r["wind_m_s"] for r in rows])
    gs = np.array([r["ground_speed_m_s"] for r in rows])
    air = np.array([r["airspeed_m_s"] for r in rows])
    lim = np.array([r["at_speed_limit"] for r in rows], dtype=bool)
    ax[2].plot(w, gs, "-", color="tab:blue", label="ground speed V_R(W)")
    ax[2].plot(w, air, "--", color="tab:orange", label="its airspeed")
    for y, c, mk in ((gs, "tab:blue", "o"), (air, "tab:orange", "s")):
        ax[2].plot(w[~lim], y[~lim], mk, color=c)
        ax[2].plot(w[lim], y[lim], mk, color=c, mfc="none")
    if lim.any():
        ax[2].plot([], [], "o", color="grey", mfc="none",
                   label=f"airspeed at the search limit {fit.curve.speed_max:.3g} m/s")
    ax[2].set(xlabel="along-track wind W (m/s; < 0 headwind)", ylabel="speed (m/s)",
              title="max-range speed in wind")
    ax[2].legend(fontsize=8)
    for a in ax:
        a.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def plot_unsteadiness(maps, path) -> None:
    """Heat maps: mean wind (speed and arrows), std of the lateral force command, mean
    body-rate magnitude. Writes a PNG."""
    fig, ax = _figure(1, 3, (16, 4.8))
    xe, ye = maps.x_edges, maps.y_edges
    xc, yc = maps.centres
    speed = np.linalg.norm(maps.wind_mean, axis=-1)
    panels = ((speed, "mean wind speed (m/s)"), (maps.force_cmd_std,
                                                 "std of lateral force command (N)"),
              (maps.body_rate_mean, "mean body-rate magnitude (rad/s)"))
    for a, (z, label) in zip(ax, panels, strict=True):
        im = a.pcolormesh(xe, ye, np.ma.masked_invalid(z), shading="flat", cmap="viridis")
        fig.colorbar(im, ax=a, label=label)
        a.set(xlabel="x (m)", ylabel="y (m)", aspect="equal", title=label)
    X, Y = np.meshgrid(xc, yc)
    ax[0].quiver(X, Y, maps.wind_mean[..., 0], maps.wind_mean[..., 1], color="w", scale=None)
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def stand_csv_name(voltage: float) -> str:
    """The file name of the stand ramp at ``voltage`` (V > 0, to two decimals)."""
    # NaN gave 'stand_nanV.csv', '3.7' Python's format error (Python API audit, 58th session)
    if isinstance(voltage, (bool, np.bool_, str, bytes)):
        raise ValueError(f"The 'voltage' parameter of stand_csv_name must be a number, V. Got "
                         f"{voltage!r} instead.")
    positive_float(voltage, "voltage", "stand_csv_name")
    return f"stand_{voltage:.2f}V.csv"


def write_stand_csvs(runs, folder: Path) -> list[Path]:
    """Write :func:`simulate_stand` runs as :func:`stand_csv_name` files into ``folder``."""
    from windnav.sysid.io import write_csv

    return [write_csv(Path(folder) / stand_csv_name(r["voltage"]), r["columns"]) for r in runs]
