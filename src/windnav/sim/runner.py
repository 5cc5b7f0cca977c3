"""``fly``: a closed-loop, multi-rate flight recorded into a :class:`FlightLog`.

trajectory -> SE(3) control -> dynamics in wind -> sensors. The physics runs at ``1 / dt``;
the controller and every sensor run at their own rates, each a whole number of physics steps
per sample. Rotor power is ``sum_i k_m eta_i^3 / efficiency`` (thesis power model (a)); energy
is its running trapezoidal integral.

``fly`` is three parts: setup and the pure closed-loop step (:mod:`windnav.sim.loop`), a
recorder of the logged series, and the sensors, sampled afterwards through one protocol
(:class:`windnav.sensors.Sensor`). Every log reports, per vehicle, a
:class:`~windnav.sim.log.FlightStatus` and the fractions of time saturated and outside the
model's envelope (:func:`windnav.vehicle.envelope.outside_envelope`).
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Sequence

import numpy as np

from windnav._console import progress_bar
from windnav._jit import njit
from windnav._validate import positive_float, positive_int
from windnav.control.se3 import SE3Gains
from windnav.sensors.base import Sensor, SensorTruth
from windnav.sensors.models import IMU, Odometry, RotorSpeedSensor, SensorSuite
from windnav.sim.log import FlightLog, FlightStatus
from windnav.sim.loop import (
    ClosedLoop,
    Instant,
    LoopState,
    advance,
    fitted_rate,
    initial_loop_state,
    make_closed_loop,
    observe,
    steps_per_sample,
)
from windnav.vehicle import layout
from windnav.vehicle.envelope import outside_envelope
from windnav.vehicle.params import LIFT_ENVELOPE_FRACTION, MultirotorParams
from windnav.vehicle.power import energy, rotor_power
from windnav.vehicle.state import VehicleState

_WHERE = "fly"


def _default_sensors(dt: float) -> SensorSuite:
    """The default suite, each rate lowered (if needed) to divide the physics rate."""
    d = SensorSuite()
    return SensorSuite(IMU(rate_hz=fitted_rate(d.imu.rate_hz, dt)),
                       Odometry(rate_hz=fitted_rate(d.odometry.rate_hz, dt)),
                       RotorSpeedSensor(rate_hz=fitted_rate(d.rotor_speeds.rate_hz, dt)))


def _generator(rng, seed) -> tuple[np.random.Generator, int | None]:
    if seed is not None and rng is not None:
        raise ValueError(f"The 'seed' parameter of {_WHERE} is a deprecated alias of 'rng'; "
                         f"pass only one of them. Got seed={seed!r} and rng={rng!r}.")
    if seed is not None:
        warnings.warn(f"{_WHERE}: 'seed' is deprecated; pass the random source as 'rng='.",
                      DeprecationWarning, stacklevel=3)
    src = seed if rng is None else rng
    src = 0 if src is None else src
    if isinstance(src, np.random.Generator):
        return src, None
    if isinstance(src, bool) or not isinstance(src, (int, np.integer)) or src < 0:
        raise ValueError(f"The 'rng' parameter of {_WHERE} must be a numpy.random.Generator or "
                         f"a non-negative int. Got {src!r} instead.")
    return np.random.default_rng(int(src)), int(src)


# The flight --------------------------------------------------------------------------------
def _outside_envelope(loop: ClosedLoop, x, wind, alive, lift_fraction, max_airspeed):
    """(T, B) bool: logged instants outside the model's envelope (frozen vehicles: False).

    ``x`` (T, B, 13 + N) logged states, ``wind`` (T, B, 3) or per hub (T, B, N, 3), ``alive``
    (T, B). Evaluated once after the flight, over every logged instant at once.
    """
    T, B = x.shape[:2]
    wind = np.where(alive.reshape(T, B, *([1] * (wind.ndim - 2))), wind, 0.0)
    options = {"lift_fraction": lift_fraction, "max_airspeed": max_airspeed}
    params = loop.model.params
    if isinstance(params, MultirotorParams):
        flat = outside_envelope(params, x.reshape(T * B, -1), wind.reshape(T * B, *wind.shape[2:]),
                                **options)
        outside = np.asarray(flat, dtype=bool).reshape(T, B)
    else:  # one vehicle per row: one call per vehicle, over its logged instants
        outside = np.stack([np.asarray(outside_envelope(params[b], x[:, b], wind[:, b],
                                                        **options), dtype=bool)
                            for b in range(B)], axis=1)
    return outside & alive


def fly(
    params: MultirotorParams | Sequence[MultirotorParams],
    trajectory,
    wind,
    duration: float,
    *,
    dt: float = 0.005,
    control_rate_hz: float | None = None,
    sensors: SensorSuite | Sequence[Sensor] | None = None,
    gains: SE3Gains | None = None,
    initial_state: VehicleState | None = None,
    batch: int | None = None,
    hub_wind: bool = False,
    log_every: int = 1,
    rng: np.random.Generator | int | None = None,
    seed: int | np.random.Generator | None = None,
    progress: bool = False,
    substeps: int | None = None,
    controller=None,
    lift_fraction: float | None = None,
    max_airspeed: float | None = None,
) -> FlightLog:
    """Fly ``trajectory`` in ``wind`` for ``duration`` seconds with the SE(3) controller.

    Parameters
    ----------
    params : MultirotorParams or sequence of them
        Vehicle(s); a sequence flies one vehicle per batch row.
    trajectory : callable
        ``trajectory(t) -> FlatOutput`` (see :mod:`windnav.sim.trajectories`).
    wind : WindField
        ``wind.velocity(t, xyz (B, 3)) -> (B, 3)`` m/s, world frame.
    duration : float
        Flight time, s.
    dt : float
        Physics step, s.
    control_rate_hz : float, optional
        Controller rate, Hz; a whole number of physics steps per update. Default 100 Hz, or
        the fastest rate below it that fits when ``1 / dt`` is not a multiple of 100 Hz.
    sensors : SensorSuite or sequence of Sensor, optional
        Defaults to ``SensorSuite()`` (IMU 200 Hz, odometry 100 Hz, rotor speeds 100 Hz, each
        lowered like the controller's to fit ``dt``); pass ``SensorSuite(None, None, None)``
        for none.
    gains : SE3Gains, optional
        Controller gains (default per vehicle).
    initial_state : VehicleState, optional
        Defaults to hover at the trajectory's start: its position and heading (yaw).
    batch : int, optional
        Number of vehicles when ``params`` is a single vehicle (default 1); with a sequence,
        its length or not given.
    hub_wind : bool
        Sample the wind at every rotor hub instead of once at the centre of mass.
    log_every : int
        Log every k-th physics step (sensors are always logged at their own rate). The
        energy is then integrated over the logged power (an hour's circle in gusts: 0.04 %
        below every step's at ``log_every=100``; a short flight aliases the control ripple
        more: an 8 s gusty circle at ``dt = 5`` ms, +0.24 % at 50 and -0.17 % at 100, within
        0.02 % up to 20; convergence audit, 2026-12-05). Memory: the true state is kept at every
        sensor tick until the sensors are sampled at the end, and copied once then: about
        1 kB per vehicle and physics step with the default sensors at ``log_every=1``, and
        1.6-1.8 kB for one vehicle (0.93-0.98 kB per vehicle at 1,000-10,000; an hour at 5 ms:
        1.5 GB at its peak; scale audit, 2026-12-05); ``sensors=SensorSuite(None, None,
        None)`` keeps only the log (0.27 GB with ``log_every=100``; long-run audit). A flight
        whose estimate exceeds the memory limit (:func:`windnav.flow.memory.default_memory_limit`:
        ``WINDNAV_MEMORY_LIMIT``, or 75 % of the machine's) is refused before it starts
        (:class:`~windnav.flow.MemoryEstimateError`).
    rng : numpy.random.Generator or int, optional
        Randomness of the sensor noise (default seed 0). Each sensor draws its noise over the
        whole flight at once, time-major, so a longer flight or another batch size draws
        other noise from t = 0 on, with the same seed (the physics is the same to the bit;
        scale audit, 2026-12-05).
    seed : int or numpy.random.Generator, optional
        Deprecated alias of ``rng`` (a DeprecationWarning).
    progress : bool
        Show a progress bar.
    substeps : int, optional
        RK4 sub-steps per physics step (default: sub-steps <= 5 ms).
    controller : object, optional
        Replaces the SE(3) controller; must provide ``track(x, pos, vel, acc, yaw, yaw_rate)``
        returning ``(rotor_speed_cmd (B, N), wrench (B, 4))``.
    lift_fraction, max_airspeed : float, optional
        The envelope (:func:`windnav.vehicle.envelope.outside_envelope`): translational lift
        above ``lift_fraction`` of a rotor's thrust (default that function's, 0.5), or an
        airspeed above ``max_airspeed`` (m/s; default the vehicle's stated limit), is outside
        it.

    Returns
    -------
    FlightLog
        With a per-vehicle ``status`` (:class:`~windnav.sim.log.FlightStatus`): a vehicle that
        meets a non-finite wind, command or state is frozen at its last finite state and
        flagged, its sensor readings NaN from then on; the others fly on unaffected.
        ``meta`` reports the fractions of time saturated and outside the envelope, overall
        and per vehicle, and ``non_finite_at_s``.

    Raises
    ------
    ValueError
        Naming the parameter, for bad configuration (rates that do not fit ``dt``, a wind
        without ``velocity`` or one returning the wrong shape, a non-finite initial state).
    """
    duration = positive_float(duration, "duration", _WHERE)
    log_every = positive_int(log_every, "log_every", _WHERE)
    gen, seed_used = _generator(rng, seed)
    loop = make_closed_loop(params, trajectory, wind, dt=dt, control_rate_hz=control_rate_hz,
                            gains=gains, batch=batch, hub_wind=hub_wind, substeps=substeps,
                            controller=controller)
    suite = _default_sensors(loop.dt) if sensors is None else sensors
    sensor_list = suite.sensors() if isinstance(suite, SensorSuite) else list(suite)
    periods = [_sensor_period(s, loop.dt) for s in sensor_list]
    names = [s.name for s in sensor_list]
    if len(set(names)) != len(names):
        raise ValueError(f"The 'sensors' parameter of {_WHERE} must not repeat a sensor name. "
                         f"Got {names} instead.")
    x0 = _initial_state(loop, initial_state)
    lift_fraction = LIFT_ENVELOPE_FRACTION if lift_fraction is None else positive_float(
        lift_fraction, "lift_fraction", _WHERE)
    if max_airspeed is not None:
        max_airspeed = positive_float(max_airspeed, "max_airspeed", _WHERE)
    if round(duration / loop.dt) < 1:  # no step at all: a log of the initial state alone
        raise ValueError(f"The 'duration' parameter of {_WHERE} must be at least half the "
                         f"physics step dt ({loop.dt} s) to fly one step. Got {duration} "
                         "instead.")
    held = _frames_end(wind, duration)
    rec = _Recorder(loop, duration, log_every, periods, lift_fraction, max_airspeed,
                    len(sensor_list))
    state = initial_loop_state(loop, x0)
    n_steps = rec.n_steps
    bar = progress_bar(total=n_steps, disable=not progress, desc="flying", unit="step",
                       leave=False, mininterval=0.5)
    record = rec.record
    for step in range(n_steps + 1):
        state, seen = observe(loop, state, step)
        record(state, seen)
        if step == n_steps:
            break
        state = advance(loop, state, seen)
        if progress and step % 100 == 0:
            bar.update(min(100, n_steps - bar.n))
    bar.close()
    sensors_out = _sample_sensors(loop, sensor_list, periods, rec, state.failed_step, gen)
    plist = [params] if isinstance(params, MultirotorParams) else list(params)
    log = rec.flight_log(state, plist, sensors_out, seed_used, suite_rates={
        s.name: s.rate_hz for s in sensor_list}, names=(type(wind).__name__,
                                                        type(trajectory).__name__))
    log.meta["wind_held_after_s"] = held
    return log


def _frames_end(wind, duration: float) -> float | None:
    """The time of an unsteady gridded wind's last frame when the flight outlasts it (the wind
    is held at that frame from then on, :class:`windnav.wind.GriddedWind`), with a warning;
    else None. (A 600 s flight in a flow of 100 s flew its last 500 s in a steady wind,
    silently; long-run audit.)"""
    frames = getattr(wind, "t", None)
    if not isinstance(frames, np.ndarray) or frames.ndim != 1 or frames.size < 2:
        return None
    end = float(frames[-1])
    if duration <= end + 1e-9:
        return None
    warnings.warn(
        f"{_WHERE}: the wind's frames end at {end:g} s and the flight lasts {duration:g} s: for "
        f"its last {duration - end:g} s the wind is held at its last frame, a steady wind "
        "(shorten the flight, or simulate the flow longer)", stacklevel=3)
    return end


def _sensor_period(sensor, dt: float) -> int:
    if not isinstance(sensor, Sensor):
        raise ValueError(f"The 'sensors' parameter of {_WHERE} must hold sensors with name, "
                         f"rate_hz and sample(truth, rng). Got {type(sensor).__name__} instead.")
    return steps_per_sample(sensor.rate_hz, dt, f"'sensors' parameter's {sensor.name} rate_hz")


def _initial_state(loop: ClosedLoop, initial_state) -> np.ndarray:
    B, N = loop.batch, loop.n_rotors
    if initial_state is None:
        ref0 = loop.trajectory(0.0)
        initial_state = loop.model.hover_state(np.broadcast_to(ref0.position, (B, 3)))
        yaw = float(ref0.yaw)
        if yaw != 0.0:  # a yaw-0 start made a yaw step at t = 0 (rotors to 3 and 1,272 rad/s)
            initial_state.attitude[:] = (0.0, 0.0, np.sin(yaw / 2), np.cos(yaw / 2))
    x = np.ascontiguousarray(initial_state.to_array(), dtype=np.float64)
    if x.shape != (B, layout.N_RIGID + N) or not np.all(np.isfinite(x)):
        raise ValueError(f"The 'initial_state' parameter of {_WHERE} must hold {B} finite "
                         f"vehicles with {N} rotors. Got packed shape {x.shape} instead.")
    return x


@njit(cache=True)
def _unpack_kernel(x, position, velocity, attitude, body_rates, rotor_speeds):  # pragma: no cover
    """Copy packed states ``x`` (M, 13 + N) into their blocks, each (M, k), in the order of
    :mod:`windnav.vehicle.layout`."""
    for m in range(x.shape[0]):
        for c in range(3):
            position[m, c] = x[m, layout.POS + c]
            velocity[m, c] = x[m, layout.VEL + c]
            body_rates[m, c] = x[m, layout.RATES + c]
        for c in range(4):
            attitude[m, c] = x[m, layout.QUAT + c]
        for c in range(rotor_speeds.shape[1]):
            rotor_speeds[m, c] = x[m, layout.ROTORS + c]


class _Recorder:
    """The logged time series and the true states kept at sensor ticks.

    ``record`` runs once per physics step, so it does little: the whole packed state goes into
    one (T, B, 13 + N) array (split into position, velocity, ... once, in :meth:`flight_log`),
    the log times are computed afterwards, and the sensor ticks keep references to the step's
    arrays (a pure step never mutates them).
    """

    def __init__(self, loop: ClosedLoop, duration, log_every, periods, lift_fraction,
                 max_airspeed, n_sensors: int):
        self.loop = loop
        self.n_steps = int(round(duration / loop.dt))
        self.duration = duration
        self.log_every = log_every
        self.control_every = loop.control_every
        self.envelope_args = (lift_fraction, max_airspeed)
        # sensors never feed back into the controller: keep the true state at sensor ticks
        # and sample them afterwards, vectorised over time
        self.snap_every = math.gcd(*periods) if periods else 0
        self.snaps: list = []  # (step, x, wind_com, wind_hub, cmd_clipped) at sensor ticks
        # every log_every-th step, and the last one: a duration that is not a whole number of
        # log intervals ended the log (and its energy) up to log_every - 1 steps early (10.3 s
        # of hover at log_every=100 logged 10.0 s and 2.9 % less energy; audit, 2026-12-05)
        n_log = self.n_steps // log_every + 1 + (self.n_steps % log_every != 0)
        # refused before anything is allocated (the log's own step indices took 7.9 GB before
        # the check at dt = 1e-9 s; audit, thirty-seventh session)
        _check_memory(self, n_log, n_sensors)
        self.log_steps = np.arange(0, self.n_steps + 1, log_every)
        if self.log_steps[-1] != self.n_steps:
            self.log_steps = np.append(self.log_steps, self.n_steps)
        B, N, T = loop.batch, loop.n_rotors, self.log_steps.size
        self.x = np.empty((T, B, layout.N_RIGID + N))
        self.cmd = np.empty((T, B, N))
        self.saturated = np.zeros((T, B, N), bool)
        self.targets = np.empty((T, 2, 3))  # position, velocity
        self.wind = np.empty((T, B, 3))
        self.hub = np.empty((T, B, N, 3)) if loop.hub_wind else None
        # ever saturated, per rotor: read off the log when it holds every control tick (the
        # flags only change there), else gathered at every tick
        self.saturated_rows = (np.zeros((B, N), bool) if loop.control_every % log_every
                               else None)

    def record(self, state: LoopState, seen: Instant) -> None:
        step = seen.step
        if self.saturated_rows is not None and step % self.control_every == 0:
            np.logical_or(self.saturated_rows, state.saturated, out=self.saturated_rows)
        if self.snap_every and step % self.snap_every == 0:
            self.snaps.append((step, state.x, seen.wind_com, seen.wind_hub, state.cmd_clipped))
        if step % self.log_every and step != self.n_steps:
            return
        i = -(-step // self.log_every)  # the last step of an uneven log is a row of its own
        self.x[i] = state.x
        self.cmd[i] = state.cmd
        self.saturated[i] = state.saturated
        targets = self.targets[i]
        targets[0] = state.reference.position
        targets[1] = state.reference.velocity
        self.wind[i] = seen.wind_com
        if self.hub is not None:
            self.hub[i] = seen.wind_hub

    def _logs(self) -> dict:
        """The logged series, each a contiguous array."""
        x = self.x
        T, B, n_x = x.shape
        parts = {name: np.empty((T, B, k)) for name, k in (
            ("position", 3), ("velocity", 3), ("attitude", 4), ("body_rates", 3),
            ("rotor_speeds", n_x - layout.N_RIGID))}
        _unpack_kernel(x.reshape(T * B, n_x), *(a.reshape(T * B, -1) for a in parts.values()))
        return {
            "t": self.log_steps * self.loop.dt,
            **parts, "rotor_speed_cmd": self.cmd, "saturated": self.saturated,
            "target_position": np.ascontiguousarray(self.targets[:, 0]),
            "target_velocity": np.ascontiguousarray(self.targets[:, 1]), "wind": self.wind,
        }

    def flight_log(self, state: LoopState, plist, sensors_out, seed, suite_rates, names):
        loop, lg = self.loop, self._logs()
        B, N = loop.batch, loop.n_rotors
        n_log = lg["t"].size
        km_eff = loop.model.packed.k_m / np.array(
            [p.motor_efficiency for p in plist])
        km_eff = float(km_eff[0]) if km_eff.size == 1 else km_eff
        km_rows = np.tile(km_eff, n_log) if np.ndim(km_eff) else km_eff  # time-major rows
        failed = state.failed_step
        alive = (failed[None, :] < 0) | (self.log_steps[:, None] < failed[None, :])
        power = rotor_power(lg["rotor_speeds"].reshape(n_log * B, N), km_rows).reshape(n_log, B)
        # a vehicle that left the model draws nothing: its frozen rotor speeds kept adding
        # to its energy (audit); its power is NaN there, as its sensors are
        power[~alive] = 0.0
        lg["energy"] = energy(lg["t"], power)
        power[~alive] = np.nan
        lg["power"] = power
        outside = _outside_envelope(loop, self.x, lg["wind"] if self.hub is None else self.hub,
                                    alive, *self.envelope_args)
        ever_saturated = (self.saturated.any(axis=(0, 2)) if self.saturated_rows is None
                          else self.saturated_rows.any(axis=1))
        status = (ever_saturated * FlightStatus.SATURATED
                  | outside.any(axis=0) * FlightStatus.OUTSIDE_ENVELOPE
                  | (failed >= 0) * FlightStatus.NON_FINITE).astype(np.uint8)
        meta = {
            "vehicles": [p.name for p in plist], "batch": B, "dt": loop.dt,
            "duration": self.duration, "control_rate_hz": 1.0 / (loop.control_every * loop.dt),
            "hub_wind": loop.hub_wind, "log_every": self.log_every, "sensors": suite_rates,
            "wind": names[0], "trajectory": names[1],
            "saturated_fraction": float(np.mean(lg["saturated"])),
            "saturated_fraction_per_vehicle": np.mean(lg["saturated"], axis=(0, 2)).tolist(),
            "envelope_fraction": float(np.mean(outside)),
            "envelope_fraction_per_vehicle": np.mean(outside, axis=0).tolist(),
            "envelope": {"lift_fraction": self.envelope_args[0],
                         "max_airspeed": self.envelope_args[1] or [
                             p.airspeed_limit for p in plist]},
            "non_finite_at_s": [None if k < 0 else float(k * loop.dt) for k in failed],
            "status": _status_names(status),
            "seed": seed,
        }
        return FlightLog(**lg, outside_envelope=outside, status=status, sensors=sensors_out,
                         meta=meta)


BYTES_PER_LOG_VALUE = 8 * 1.5
"""Bytes per logged float of a vehicle (float64, with half again for the arrays' copies and
the readings' temporaries)."""


def estimate_fly_memory(batch: int, n_rotors: int, n_log: int, n_snaps: int,
                        n_sensors: int) -> float:
    """Peak bytes of :func:`fly`'s records: ``n_log`` logged rows (state, commands, flags,
    wind: ``20 + 3 N`` floats per vehicle) and ``n_snaps`` sensor ticks (state, winds and
    commands, kept, stacked once and sampled into readings: ``3 (16 + 2 N)`` floats per
    vehicle when sensors are flown), each float :data:`BYTES_PER_LOG_VALUE`. Calibrated
    against the peak resident set (scale audit, 2026-12-05): 0.93-0.98 kB per vehicle and step
    with the default sensors at 1,000-10,000 vehicles; 2,000 vehicles for 2 s added 860 MB,
    estimated 1.0 GB (errs on the side of refusing)."""
    per_log = 20 + 3 * n_rotors
    per_snap = 3 * (16 + 2 * n_rotors) if n_sensors else 0
    return float(batch) * BYTES_PER_LOG_VALUE * (n_log * per_log + n_snaps * per_snap)


def _check_memory(rec: _Recorder, n_log: int, n_sensors: int) -> None:
    """Refuse a flight whose records (``n_log`` logged rows and the sensor ticks) would not
    fit the memory limit (a MemoryError after the whole flight, or the out-of-memory killer,
    before; scale audit, 2026-12-05)."""
    from windnav.flow.memory import refuse_above_limit

    n_snaps = rec.n_steps // rec.snap_every + 1 if rec.snap_every else 0
    need = estimate_fly_memory(rec.loop.batch, rec.loop.n_rotors, n_log, n_snaps, n_sensors)
    refuse_above_limit(need, _WHERE,
                       f"the log and the sensors' states of {rec.loop.batch} vehicle(s) for "
                       f"{rec.duration:g} s at dt = {rec.loop.dt:g} s ({rec.n_steps} steps)",
                       "Fly fewer vehicles at once or a shorter flight, log less often "
                       "(log_every) or with fewer sensors")


def _status_names(status: np.ndarray) -> list[str]:
    """``FlightStatus`` names of every vehicle (``"OK"`` for none), one lookup per value."""
    codes = status.tolist()
    names = {s: str(FlightStatus(s).name) if s else "OK" for s in set(codes)}
    return [names[s] for s in codes]


def _sample_sensors(loop: ClosedLoop, sensor_list, periods, rec: _Recorder, failed_step,
                    rng) -> dict:
    """Every sensor's readings, in order, from the true states kept at sensor ticks; NaN for a
    vehicle from the tick at which it was frozen."""
    if not sensor_list:
        return {}
    step, x, com, hub, cmd = zip(*rec.snaps, strict=True)
    steps = np.asarray(step)
    truth = SensorTruth(
        t=steps * loop.dt, state=np.stack(x), wind_com=np.stack(com),
        wind_hub=np.stack(hub) if loop.hub_wind else None,
        rotor_speed_cmd=np.stack(cmd), model=loop.model)
    out = {}
    for sensor, k in zip(sensor_list, periods, strict=True):
        sel = np.flatnonzero(steps % k == 0)
        entry = {"t": truth.t[sel], **sensor.sample(truth.at(sel), rng)}
        dead = (failed_step[None, :] >= 0) & (steps[sel][:, None] >= failed_step[None, :])
        if dead.any():
            for key, arr in entry.items():
                if key != "t" and np.issubdtype(np.asarray(arr).dtype, np.floating):
                    arr = np.array(arr, dtype=np.float64)
                    arr[dead] = np.nan
                    entry[key] = arr
        out[sensor.name] = entry
    return out


__all__ = ["fly"]
