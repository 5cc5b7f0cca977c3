"""``windnav fly``: fly a trajectory in wind; write the FlightLog and PNG plots."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np


def register(sub) -> None:
    from windnav.sim.trajectories import TRAJECTORIES
    from windnav.vehicle.params import VEHICLES

    p = sub.add_parser("fly", help="fly a trajectory in wind and plot it",
                       description="Fly a reference trajectory with the SE(3) controller in a "
                                   "constant or Dryden wind; write log.npz, summary.json, PNGs.")
    p.add_argument("--vehicle", default="hummingbird", choices=VEHICLES)
    p.add_argument("--wind", default="dryden", choices=("none", "constant", "dryden"))
    p.add_argument("--wind-mean", type=float, nargs=3, default=(3.0, 1.0, 0.0),
                   metavar=("WX", "WY", "WZ"), help="mean wind, world frame, m/s")
    p.add_argument("--wind-sigma", type=float, nargs=3, default=(1.5, 1.5, 0.7),
                   metavar=("SX", "SY", "SZ"), help="Dryden gust standard deviations, m/s")
    p.add_argument("--trajectory", default="circle", choices=TRAJECTORIES)
    p.add_argument("--size", type=float, default=3.0,
                   help="circle radius / line length / waypoint square side, m")
    p.add_argument("--speed", type=float, default=2.0, help="reference speed, m/s")
    p.add_argument("--duration", type=float, default=20.0, help="flight time, s")
    p.add_argument("--dt", type=float, default=0.005, help="physics step, s")
    p.add_argument("--hub-wind", action="store_true",
                   help="sample the wind at each rotor hub instead of the centre of mass")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--out", type=Path, default=Path("out/fly"))
    p.add_argument("--no-plots", action="store_true")
    p.set_defaults(func=run)


def make_wind(kind: str, mean, sigma, seed: int):
    """The wind named on the command line."""
    from windnav.wind import ConstantWind, DrydenWind

    if kind == "none":
        return ConstantWind((0.0, 0.0, 0.0))
    if kind == "constant":
        return ConstantWind(tuple(mean))
    return DrydenWind(mean=tuple(mean), sigma=tuple(sigma), seed=seed)


def run(args) -> int:
    import windnav as wn
    from windnav.viz.flight import plot_flight

    params = wn.vehicle.params(args.vehicle)
    wind = make_wind(args.wind, args.wind_mean, args.wind_sigma, args.seed)
    traj = wn.sim.make_trajectory(args.trajectory, start=(0.0, 0.0, 2.0), size=args.size,
                                  speed=args.speed)
    log = wn.sim.fly(params, traj, wind, args.duration, dt=args.dt, hub_wind=args.hub_wind,
                     seed=args.seed, progress=True)
    log.meta.update(command="fly", trajectory_kind=args.trajectory, wind_kind=args.wind)
    args.out.mkdir(parents=True, exist_ok=True)
    path = log.save(args.out / "log.npz")
    settled = log.t >= min(2.0, args.duration / 2)
    summary = {
        "vehicle": args.vehicle, "wind": args.wind, "trajectory": args.trajectory,
        "duration_s": args.duration, "seed": args.seed,
        "rms_tracking_error_m": float(np.sqrt(np.mean(log.tracking_error[settled] ** 2))),
        "max_tracking_error_m": float(np.max(log.tracking_error[settled])),
        "mean_power_W": float(log.power.mean()), "energy_J": float(log.energy[-1, 0]),
        "rotor_saturation_fraction": log.saturation_fraction,
        "mean_wind_speed_m_s": float(np.linalg.norm(log.wind, axis=-1).mean()),
    }
    (args.out / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
    files = [path, args.out / "summary.json"]
    if not args.no_plots:
        files += plot_flight(log, args.out)
    print(json.dumps(summary, indent=2))
    for f in files:
        print(f"wrote {f}")
    return 0
