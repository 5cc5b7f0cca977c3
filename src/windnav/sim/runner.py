"""Closed-loop, multi-rate flight: trajectory -> SE(3) control -> dynamics in wind -> sensors.

The physics runs at ``1 / dt``; the controller and every sensor run at their own rates, which
must divide the physics rate. Rotor power is ``sum_i k_m eta_i^3 / efficiency`` (thesis power
model (a)); energy is its running trapezoidal integral.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from tqdm.auto import tqdm

from windnav._validate import positive_float, positive_int
from windnav.control.se3 import SE3Controller, SE3Gains
from windnav.sensors.models import SensorSuite
from windnav.sim.log import FlightLog
from windnav.vehicle.multirotor import Multirotor
from windnav.vehicle.params import MultirotorParams
from windnav.vehicle.power import energy, rotor_power
from windnav.vehicle.rotation import quat_to_matrix
from windnav.vehicle.state import VehicleState


def _ticks(rate_hz: float, dt: float, name: str) -> int:
    """Physics steps per sample of a component running at ``rate_hz``."""
    ratio = 1.0 / (rate_hz * dt)
    k = round(ratio)
    if k < 1 or abs(ratio - k) > 1e-6 * ratio:
        raise ValueError(f"The 'rate_hz' of {name} must divide the physics rate {1 / dt:g} Hz. "
                         f"Got {rate_hz:g} Hz instead.")
    return k


def _hub_positions(model: Multirotor, x: np.ndarray) -> np.ndarray:
    """World positions of every rotor hub, (B * N, 3)."""
    R = quat_to_matrix(x[:, 6:10])  # (B, 3, 3)
    r = model.packed.rotor_positions  # (P, N, 3)
    hubs = x[:, None, 0:3] + np.einsum("bij,bnj->bni", R, np.broadcast_to(r, (x.shape[0],) +
                                                                         r.shape[1:]))
    return hubs.reshape(-1, 3)


def fly(
    params: MultirotorParams | Sequence[MultirotorParams],
    trajectory,
    wind,
    duration: float,
    *,
    dt: float = 0.005,
    control_rate_hz: float = 100.0,
    sensors: SensorSuite | None = None,
    gains: SE3Gains | None = None,
    initial_state: VehicleState | None = None,
    batch: int = 1,
    hub_wind: bool = False,
    log_every: int = 1,
    seed: int | np.random.Generator = 0,
    progress: bool = False,
    substeps: int | None = None,
    controller=None,
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
    control_rate_hz : float
        Controller rate, Hz (must divide ``1 / dt``).
    sensors : SensorSuite, optional
        Defaults to ``SensorSuite()`` (IMU 200 Hz, odometry 100 Hz, rotor speeds 100 Hz); pass
        ``SensorSuite(None, None, None)`` for none.
    gains : SE3Gains, optional
        Controller gains (default per vehicle).
    initial_state : VehicleState, optional
        Defaults to hover at the trajectory's start.
    batch : int
        Number of vehicles when ``params`` is a single vehicle.
    hub_wind : bool
        Sample the wind at every rotor hub instead of once at the centre of mass.
    log_every : int
        Log every k-th physics step (sensors are always logged at their own rate).
    seed : int or numpy.random.Generator
        Randomness of the sensor noise.
    progress : bool
        Show a progress bar.
    substeps : int, optional
        RK4 sub-steps per physics step (default: sub-steps <= 5 ms).
    controller : object, optional
        Replaces the SE(3) controller; must provide ``track(x, pos, vel, acc, yaw, yaw_rate)``
        returning ``(rotor_speed_cmd (B, N), wrench (B, 4))``.

    Returns
    -------
    FlightLog
    """
    where = "fly"
    duration = positive_float(duration, "duration", where)
    dt = positive_float(dt, "dt", where)
    log_every = positive_int(log_every, "log_every", where)
    if not hasattr(wind, "velocity"):
        raise ValueError(f"The 'wind' parameter of {where} must be a WindField with a "
                         f"velocity(t, xyz) method. Got {type(wind).__name__} instead.")
    plist = [params] if isinstance(params, MultirotorParams) else list(params)
    B = len(plist) if len(plist) > 1 else positive_int(batch, "batch", where)
    rng = seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)
    sensors = SensorSuite() if sensors is None else sensors
    model = Multirotor(plist if len(plist) > 1 else plist[0], substeps=substeps)
    ctrl = controller or SE3Controller(plist if len(plist) > 1 else plist[0], gains)
    N = model.n_rotors

    ref0 = trajectory(0.0)
    if initial_state is None:
        initial_state = model.hover_state(np.broadcast_to(ref0.position, (B, 3)))
    x = np.ascontiguousarray(initial_state.to_array())
    if x.shape != (B, 13 + N):
        raise ValueError(f"The 'initial_state' parameter of {where} must hold {B} vehicles with "
                         f"{N} rotors. Got packed shape {x.shape} instead.")

    n_steps = int(round(duration / dt))
    k_ctrl = _ticks(control_rate_hz, dt, "the controller")
    k_sens = {name: _ticks(s.rate_hz, dt, name) for name, s in sensors.items()}
    n_log = n_steps // log_every + 1

    logs = {
        "t": np.empty(n_log), "position": np.empty((n_log, B, 3)),
        "velocity": np.empty((n_log, B, 3)), "attitude": np.empty((n_log, B, 4)),
        "body_rates": np.empty((n_log, B, 3)), "rotor_speeds": np.empty((n_log, B, N)),
        "rotor_speed_cmd": np.empty((n_log, B, N)), "saturated": np.zeros((n_log, B, N), bool),
        "target_position": np.empty((n_log, 3)), "target_velocity": np.empty((n_log, 3)),
        "wind": np.empty((n_log, B, 3)),
    }
    # Sensors never feed back into the controller, so the loop only keeps the true state at
    # sensor ticks; the noisy measurements are generated afterwards, vectorised over time.
    k_snap = math.gcd(*k_sens.values()) if k_sens else 0
    snaps: dict = {"step": [], "x": [], "com": [], "hub": [], "cmd": []}
    # rotor power per vehicle: k_m / efficiency folded into one coefficient
    km_eff = model.packed.scalars[:, 2] / np.array([p.motor_efficiency for p in plist])
    km_eff = float(km_eff[0]) if km_eff.size == 1 else km_eff

    pos_d = np.empty((B, 3))
    vel_d = np.empty((B, 3))
    acc_d = np.empty((B, 3))
    yaw_d = np.empty(B)
    yaw_rate_d = np.empty(B)
    cmd = np.zeros((B, N))
    cmd_clipped = np.zeros((B, N))
    sat = np.zeros((B, N), bool)
    out = np.empty_like(x)
    ref = ref0

    hub_buf = np.empty((B, N, 3))

    def wind_at(t, xk):
        if hub_wind:
            hub = np.asarray(wind.velocity(t, _hub_positions(model, xk)), dtype=np.float64)
            hub = hub.reshape(B, N, 3)
            com = hub.mean(axis=1)
        else:
            com = np.asarray(wind.velocity(t, xk[:, 0:3]), dtype=np.float64)
            hub = None
        if com.shape != (B, 3) or not np.all(np.isfinite(com)):
            raise ValueError(f"The 'wind' parameter of {where} returned an invalid wind at "
                             f"t = {t:.3f} s (shape {com.shape}, finite: "
                             f"{bool(np.all(np.isfinite(com)))}).")
        if hub is None:  # one wind per vehicle: every hub sees the centre-of-mass wind
            hub_buf[:] = com[:, None, :]
            hub = hub_buf
        return np.ascontiguousarray(com), np.ascontiguousarray(hub)

    def log(i, t, xk, com):
        logs["t"][i] = t
        logs["position"][i] = xk[:, 0:3]
        logs["velocity"][i] = xk[:, 3:6]
        logs["attitude"][i] = xk[:, 6:10]
        logs["body_rates"][i] = xk[:, 10:13]
        logs["rotor_speeds"][i] = xk[:, 13:]
        logs["rotor_speed_cmd"][i] = cmd
        logs["saturated"][i] = sat
        logs["target_position"][i] = ref.position
        logs["target_velocity"][i] = ref.velocity
        logs["wind"][i] = com

    bar = tqdm(total=n_steps, disable=not progress, desc="flying", unit="step", leave=False,
               mininterval=0.5)
    lo = model.packed.scalars[:, 11:12]
    hi = model.packed.scalars[:, 12:13]
    for step in range(n_steps + 1):
        t = step * dt
        com, hub = wind_at(t, x)
        if step % k_ctrl == 0:
            ref = trajectory(t)
            pos_d[:] = ref.position
            vel_d[:] = ref.velocity
            acc_d[:] = ref.acceleration
            yaw_d[:] = ref.yaw
            yaw_rate_d[:] = ref.yaw_rate
            cmd, _ = ctrl.track(x, pos_d, vel_d, acc_d, yaw_d, yaw_rate_d)
            np.clip(cmd, lo, hi, out=cmd_clipped)
            np.not_equal(cmd_clipped, cmd, out=sat)
        if k_snap and step % k_snap == 0:
            snaps["step"].append(step)
            snaps["x"].append(x.copy())
            snaps["com"].append(com)
            snaps["hub"].append(hub if hub_wind else None)
            snaps["cmd"].append(cmd_clipped.copy())
        if step % log_every == 0:
            log(step // log_every, t, x, com)
        if step == n_steps:
            break
        model.step_packed(x, cmd_clipped, com, hub, dt, out)
        x, out = out, x
        if progress and step % 100 == 0:
            bar.update(min(100, n_steps - bar.n))
    bar.close()

    sensors_out = _measure(model, sensors, k_sens, snaps, dt, hub_wind, rng)
    eta = logs["rotor_speeds"]
    km_rows = np.tile(km_eff, n_log) if np.ndim(km_eff) else km_eff  # time-major rows
    logs["power"] = rotor_power(eta.reshape(n_log * B, N), km_rows).reshape(n_log, B)
    logs["energy"] = energy(logs["t"], logs["power"])
    meta = {
        "vehicles": [p.name for p in plist], "batch": B, "dt": dt, "duration": duration,
        "control_rate_hz": control_rate_hz, "hub_wind": hub_wind, "log_every": log_every,
        "sensors": {name: s.rate_hz for name, s in sensors.items()},
        "wind": type(wind).__name__, "trajectory": type(trajectory).__name__,
        "saturated_fraction": float(np.mean(logs["saturated"])),
        "seed": seed if isinstance(seed, int) else None,
    }
    return FlightLog(**logs, sensors=sensors_out, meta=meta)


def _measure(model, sensors, k_sens, snaps, dt, hub_wind, rng) -> dict:
    """Noisy sensor readings from the true states kept at sensor ticks."""
    if not k_sens:
        return {}
    steps = np.asarray(snaps["step"])
    xs = np.stack(snaps["x"])  # (K, B, 13 + N)
    out = {}
    for name, k in k_sens.items():
        sel = np.flatnonzero(steps % k == 0)
        x = xs[sel]
        entry = {"t": steps[sel] * dt}
        if name == "imu":
            K, B = x.shape[:2]
            N = model.n_rotors
            com = np.stack([snaps["com"][i] for i in sel]).reshape(K * B, 3)
            if hub_wind:
                hub = np.stack([snaps["hub"][i] for i in sel]).reshape(K * B, N, 3)
            else:
                hub = np.ascontiguousarray(np.broadcast_to(com[:, None, :], (K * B, N, 3)))
            flat = x.reshape(K * B, -1)
            if model.packed.size > 1:  # per-vehicle parameters: evaluate one tick at a time
                f = np.concatenate([model.derivatives_packed(x[i], com[i * B:(i + 1) * B],
                                                            hub[i * B:(i + 1) * B])
                                    ["specific_force_body"] for i in range(K)])
            else:
                f = model.derivatives_packed(np.ascontiguousarray(flat), com, hub)[
                    "specific_force_body"]
            accel, gyro, bias = sensors.imu.measure(f.reshape(K, B, 3), x[..., 10:13], rng)
            entry.update(accel=accel, gyro=gyro, bias=bias)
        elif name == "odometry":
            p, v, q = sensors.odometry.measure(x[..., 0:3], x[..., 3:6], x[..., 6:10], rng)
            entry.update(position=p, velocity=v, attitude=q)
        elif name == "rotor_speeds":
            cmd = np.stack([snaps["cmd"][i] for i in sel])
            entry.update(cmd=sensors.rotor_speeds.measure(cmd, rng))
        out[name] = entry
    return out


__all__ = ["fly"]
