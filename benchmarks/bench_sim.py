"""Simulator speed against RotorPy, measured in the same run.

1. One Hummingbird flying a 2 m circle with the SE(3) controller at 100 Hz for 20 s in a
   constant wind, with IMU and motion capture at 100 Hz: windnav's ``fly`` versus RotorPy's
   ``Environment.run`` (its ``simulate``: RK45 per step, IMU, mocap).
2. A batch of B vehicles hovering with the SE(3) controller at 100 Hz: windnav's ``fly``
   (Numba, one core, logging every 10th step, no sensors) versus RotorPy's ``BatchedMultirotor``
   + ``BatchedSE3Control`` on the CPU with its fixed-step ``rk4`` integrator (its fastest).
   Reported as vehicle-steps per second.

Run: ``python benchmarks/bench_sim.py [--repeats 5] [--batch 1000]``.
"""

from __future__ import annotations

import argparse
import os
import statistics
import time

os.environ.setdefault("NUMBA_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np  # noqa: E402

import windnav as wn  # noqa: E402
from windnav.sensors import IMU, Odometry, SensorSuite  # noqa: E402
from windnav.wind import ConstantWind  # noqa: E402

DURATION = 20.0
DT = 0.01


def windnav_single() -> float:
    p = wn.vehicle.params("hummingbird")
    traj = wn.sim.Circle(center=(0, 0, 0), radius=2.0, speed=2.0 * np.pi * 2.0 * 0.16)
    sensors = SensorSuite(IMU(rate_hz=100.0), Odometry(rate_hz=100.0), None)
    t0 = time.perf_counter()
    wn.sim.fly(p, traj, ConstantWind((2.0, 1.0, 0.0)), DURATION, dt=DT, control_rate_hz=100.0,
               sensors=sensors)
    return time.perf_counter() - t0


def rotorpy_single() -> float:
    from rotorpy.controllers.quadrotor_control import SE3Control
    from rotorpy.environments import Environment
    from rotorpy.sensors.external_mocap import MotionCapture
    from rotorpy.sensors.imu import Imu
    from rotorpy.trajectories.circular_traj import ThreeDCircularTraj
    from rotorpy.vehicles.hummingbird_params import quad_params
    from rotorpy.vehicles.multirotor import Multirotor
    from rotorpy.wind.default_winds import ConstantWind as RPConstantWind

    env = Environment(
        vehicle=Multirotor(quad_params), controller=SE3Control(quad_params),
        trajectory=ThreeDCircularTraj(radius=np.array([2.0, 2.0, 0.0]),
                                      freq=np.array([0.16, 0.16, 0.0])),
        wind_profile=RPConstantWind(2.0, 1.0, 0.0), imu=Imu(sampling_rate=100),
        mocap=MotionCapture(sampling_rate=100), sim_rate=int(1 / DT),
    )
    t0 = time.perf_counter()
    env.run(t_final=DURATION, use_mocap=False, terminate=False, plot=False,
            animate_bool=False, verbose=False)
    return time.perf_counter() - t0


def windnav_batch(B: int, steps: int, substeps: int | None = None) -> float:
    p = wn.vehicle.params("hummingbird")
    rng = np.random.default_rng(0)
    model = wn.vehicle.Multirotor(p)
    s0 = model.hover_state(rng.uniform(-1, 1, size=(B, 3)))
    t0 = time.perf_counter()
    wn.sim.fly(p, wn.sim.Hover((0.0, 0.0, 0.0)), ConstantWind((2.0, 1.0, 0.0)), steps * DT,
               dt=DT, batch=B, initial_state=s0, sensors=SensorSuite(None, None, None),
               log_every=10, substeps=substeps)
    return time.perf_counter() - t0


def rotorpy_batch(B: int, steps: int) -> float:
    import torch
    from rotorpy.controllers.quadrotor_control import BatchedSE3Control
    from rotorpy.vehicles.hummingbird_params import quad_params
    from rotorpy.vehicles.multirotor import BatchedMultirotor, BatchedMultirotorParams

    torch.set_num_threads(1)
    dev = torch.device("cpu")
    params = BatchedMultirotorParams([quad_params] * B, B, dev)
    rng = np.random.default_rng(0)
    d = torch.float64
    state = {
        "x": torch.tensor(rng.uniform(-1, 1, size=(B, 3)), dtype=d),
        "v": torch.zeros(B, 3, dtype=d), "q": torch.tensor([[0, 0, 0, 1.0]] * B, dtype=d),
        "w": torch.zeros(B, 3, dtype=d),
        "wind": torch.tensor([[2.0, 1.0, 0.0]] * B, dtype=d),
        "rotor_speeds": torch.full((B, 4), 469.2, dtype=d),
    }
    vehicle = BatchedMultirotor(params, B, state, dev, integrator="rk4")
    ctrl = BatchedSE3Control(params, B, dev)
    z = torch.zeros(B, 3, dtype=d)
    flat = {"x": z, "x_dot": z, "x_ddot": z, "x_dddot": z, "x_ddddot": z,
            "yaw": torch.zeros(B, dtype=d), "yaw_dot": torch.zeros(B, dtype=d)}
    t0 = time.perf_counter()
    for k in range(steps):
        control = ctrl.update(k * DT, state, flat)
        state = vehicle.step(state, control, DT)
        state["wind"] = torch.tensor([[2.0, 1.0, 0.0]] * B, dtype=d)
    return time.perf_counter() - t0


def median(fn, repeats):
    return statistics.median(fn() for _ in range(repeats))


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--batch", type=int, default=1000)
    ap.add_argument("--batch-steps", type=int, default=500)
    ap.add_argument("--rotorpy-batch-steps", type=int, default=50)
    ap.add_argument("--no-record", action="store_true")
    args = ap.parse_args()

    windnav_single()  # compile the kernels (cached afterwards)
    windnav_batch(8, 5)
    steps = int(DURATION / DT)
    ours = median(windnav_single, args.repeats)
    ref = median(rotorpy_single, max(1, args.repeats // 2))
    rows = [
        "| case | windnav | RotorPy | speed-up |",
        "|---|---|---|---|",
        f"| 1 Hummingbird, SE(3) circle at 100 Hz, IMU + mocap, 20 s "
        f"| {ours:.3f} s ({ours / steps * 1e6:.0f} us/step) "
        f"| {ref:.3f} s ({ref / steps * 1e6:.0f} us/step) | {ref / ours:.1f}x |",
    ]
    print(rows[-1])

    B = args.batch
    rates = {}
    for sub in (None, 1):
        tb = median(lambda sub=sub: windnav_batch(B, args.batch_steps, sub), args.repeats)
        rates[sub] = (B * args.batch_steps / tb, tb / args.batch_steps)
    try:
        tr = median(lambda: rotorpy_batch(B, args.rotorpy_batch_steps), max(1, args.repeats // 2))
        ref_rate = B * args.rotorpy_batch_steps / tr
        ref_cell = f"{ref_rate:,.0f} vehicle-steps/s ({tr / args.rotorpy_batch_steps * 1e3:.1f} " \
                   "ms/step, torch CPU, 1 thread, rk4)"
    except ImportError as exc:  # torch, torchdiffeq or roma missing: `make bench-venv`
        ref_cell, ref_rate = f"not run ({exc.name} missing)", None
    labels = {None: "default 2 RK4 sub-steps", 1: "1 RK4 step per 10 ms, as RotorPy's rk4"}
    for sub, (rate, per_step) in rates.items():
        ratio = f"{rate / ref_rate:.1f}x" if ref_rate else "n/a"
        rows.append(f"| B = {B} hovering vehicles + SE(3) controller, 100 Hz, one core, "
                    f"{labels[sub]} | {rate:,.0f} vehicle-steps/s ({per_step * 1e3:.2f} ms/step) "
                    f"| {ref_cell} | {ratio} |")
        print(rows[-1])
    if not args.no_record:
        from _record import append_record

        append_record("Simulator: windnav vs RotorPy", rows)


if __name__ == "__main__":
    main()
