"""Dryden gust scaling and speed: windnav's DrydenWind against RotorPy's DrydenGust.

For sigma = 1 m/s on every axis, each model is stepped for ``--seconds`` of simulated time at
dt = 0.001, 0.01 and 0.05 s; the table gives each component's sample standard deviation (it
should equal sigma for any dt) and the cost per sample.

Run: ``python benchmarks/bench_dryden.py [--seconds 2000]``.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

import windnav as wn


def windnav_series(dt, n, seed=0):
    w = wn.wind.DrydenWind(mean=(0, 0, 0), sigma=(1.0, 1.0, 1.0), seed=seed, altitude=2.0)
    xyz = np.zeros((1, 3))
    t0 = time.perf_counter()
    out = np.array([w.velocity(k * dt, xyz)[0] for k in range(n)])
    return out, (time.perf_counter() - t0) / n


def rotorpy_series(dt, n, seed=0):
    from rotorpy.wind.dryden_winds import DrydenGust

    np.random.seed(seed)  # noqa: NPY002 - RotorPy draws its gusts from the global state
    w = DrydenGust(dt=dt, avg_wind=np.zeros(3), sig_wind=np.ones(3), altitude=2.0)
    pos = np.zeros(3)
    t0 = time.perf_counter()
    out = np.array([w.update(k * dt, pos) for k in range(n)])
    return out, (time.perf_counter() - t0) / n


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=2000.0, help="simulated time per series")
    ap.add_argument("--max-samples", type=int, default=400_000)
    ap.add_argument("--no-record", action="store_true")
    args = ap.parse_args()
    rows = ["| dt (s) | samples | windnav std (x, y, z) m/s | RotorPy std (x, y, z) m/s "
            "| windnav us/sample | RotorPy us/sample |", "|---|---|---|---|---|---|"]
    for dt in (0.001, 0.01, 0.05):
        n = min(int(args.seconds / dt), args.max_samples)
        ours, t_ours = windnav_series(dt, n)
        try:
            ref, t_ref = rotorpy_series(dt, n)
            ref_std = ", ".join(f"{s:.3f}" for s in ref.std(axis=0))
            t_ref_s = f"{t_ref * 1e6:.1f}"
        except ImportError as exc:
            ref_std, t_ref_s = f"not run ({exc.name} missing)", "n/a"
        rows.append(f"| {dt} | {n} | {', '.join(f'{s:.3f}' for s in ours.std(axis=0))} "
                    f"| {ref_std} | {t_ours * 1e6:.1f} | {t_ref_s} |")
        print(rows[-1])
    if not args.no_record:
        from _record import append_record

        append_record("Dryden gusts, sigma = 1 m/s: windnav vs RotorPy", rows)


if __name__ == "__main__":
    main()
