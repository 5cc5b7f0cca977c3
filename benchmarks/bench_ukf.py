"""Benchmark: one predict + update (accelerometer + gyro + odometry) of the 16-state Wind UKF.

Ours (``WindUKF``: numba sigma-point arithmetic, batched numba models) against FilterPy's
``UnscentedKalmanFilter`` + ``MerweScaledSigmaPoints`` running the *same* model kernels one
sigma point at a time, as FilterPy requires. Both filters consume the same synthetic flight
(generated from the model itself). Reports medians over many timed cycles and the ratio, and
appends them to docs/benchmarks.md.

    .venv/bin/python benchmarks/bench_ukf.py [--cycles 4000] [--seed 0]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
from filterpy.kalman import MerweScaledSigmaPoints, UnscentedKalmanFilter

import windnav as wn
from windnav.estimate import WindUKF
from windnav.estimate import wind_model as wm

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _record import append_record  # noqa: E402

DT = 0.01


def flight(params, steps: int, rng: np.random.Generator):
    """Commands and noisy measurements of a gently manoeuvring flight in a 3 m/s wind."""
    prm = wm.model_constants(params, wind_frame="body")
    x = np.zeros(16)
    x[12:] = params.hover_rotor_speed
    x[9:12] = [3.0, -1.0, 0.2]
    us, zs = [], []
    for k in range(steps):
        t = k * DT
        x[3:6] = [0.5 * np.sin(3.1 * t), 0.5 * np.cos(2.5 * t), 0.2 * np.sin(1.3 * t)]
        u = params.hover_rotor_speed * (1 + 0.05 * np.sin(4.4 * t)) * np.ones(4)
        x = wm.process(x[None], DT, u, prm)[0]
        X = x[None]
        zs.append({"accel": wm.specific_force(X, prm)[0] + rng.normal(0, 0.3, 3),
                   "gyro": x[3:6] + rng.normal(0, 0.07, 3),
                   "odom": wm.odometry(X)[0] + rng.normal(0, 0.01, 6)})
        us.append(u)
    return us, zs


def time_cycles(cycle, n: int) -> np.ndarray:
    out = np.empty(n)
    for i in range(n):
        t0 = time.perf_counter_ns()
        cycle(i)
        out[i] = time.perf_counter_ns() - t0
    return out * 1e-3   # us


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cycles", type=int, default=4000, help="timed cycles of our filter")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--no-record", action="store_true", help="do not append to docs/benchmarks.md")
    args = ap.parse_args(argv)
    params = wn.vehicle.params("hummingbird")
    rng = np.random.default_rng(args.seed)
    n_ref = max(args.cycles // 8, 200)
    us, zs = flight(params, 1000, rng)
    prm = wm.model_constants(params, wind_frame="body")

    ours = WindUKF(params, DT, wind_frame="body")  # the recorded setup
    ours.step(us[0], zs[0])                       # compile / warm up

    def ours_cycle(i):
        k = i % len(us)
        ours.ukf.predict(DT, us[k])
        ours.ukf.update(zs[k])

    def ours_step(i):
        k = i % len(us)
        ours.step(us[k], zs[k])

    R = np.zeros((12, 12))
    R[:3, :3], R[3:6, 3:6], R[6:, 6:] = ours.R["accel"], ours.R["gyro"], ours.R["odom"]

    def hx(x):
        X = x[None]
        return np.concatenate([wm.specific_force(X, prm)[0], x[3:6], wm.odometry(X)[0]])

    def fx(x, dt, u):
        return wm.process(x[None], dt, u, prm)[0]

    ref = UnscentedKalmanFilter(16, 12, DT, hx=hx, fx=fx,
                                points=MerweScaledSigmaPoints(16, 1.0, 2.0, 0.0))
    ref.x, ref.P, ref.Q, ref.R = ours.x.copy(), ours.P.copy(), ours.Q, R

    def ref_cycle(i):
        k = i % len(us)
        z = zs[k]
        ref.predict(u=us[k])
        ref.update(np.concatenate([z["accel"], z["gyro"], z["odom"]]))

    # interleave repeats so that load from other processes hits both alike
    t_ours, t_step, t_ref = [], [], []
    for _ in range(4):
        t_ours.append(time_cycles(ours_cycle, args.cycles // 4))
        t_step.append(time_cycles(ours_step, args.cycles // 4))
        t_ref.append(time_cycles(ref_cycle, n_ref // 4))
    m_ours = float(np.median(np.concatenate(t_ours)))
    m_step = float(np.median(np.concatenate(t_step)))
    m_ref = float(np.median(np.concatenate(t_ref)))
    # the two filters ran the same data from the same start: they must agree
    check = WindUKF(params, DT, wind_frame="body")
    ref.x, ref.P = check.x.copy(), check.P.copy()
    for k in range(100):
        check.ukf.predict(DT, us[k])
        check.ukf.update(zs[k])
        ref_cycle(k)
    agree = float(np.max(np.abs(check.x - ref.x)))

    rows = [
        "| filter (16 states, accel + gyro + odom) | median per predict + update, us |",
        "|---|---|",
        f"| windnav `WindUKF` (predict + update) | {m_ours:.1f} |",
        f"| windnav `WindUKF.step` (+ world-frame wind and covariance) | {m_step:.1f} |",
        f"| FilterPy `UnscentedKalmanFilter`, same model per sigma point | {m_ref:.1f} |",
        "",
        f"- speed-up over FilterPy: **{m_ref / m_ours:.1f}x** (step incl. output: "
        f"{m_ref / m_step:.1f}x)",
        f"- samples: {args.cycles} ours, {n_ref} FilterPy; state agreement after 100 steps: "
        f"{agree:.1e}",
    ]
    print("\n".join(rows))
    if not args.no_record:
        append_record("Wind UKF: one predict + update (benchmarks/bench_ukf.py)", rows,
                      command="python benchmarks/bench_ukf.py " + " ".join(argv or sys.argv[1:]))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
