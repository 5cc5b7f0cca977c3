"""``windnav demo``: the end-to-end demo (city wind, flight, Wind UKF) with figures."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path


def register(sub) -> None:
    p = sub.add_parser("demo", help="end-to-end demo: urban wind, flight, wind estimation",
                       description="Simulate the wind of a random city, fly a route through it "
                                   "and estimate the wind with the Wind UKF; write figures.")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--vehicle", default="hummingbird")
    p.add_argument("--wind-speed", type=float, default=5.0, help="inlet wind speed, m/s")
    p.add_argument("--out", type=Path, default=Path("out/demo"))
    p.set_defaults(func=run)


def run(args) -> int:
    from windnav.experiments.demo import DemoConfig, run_demo
    from windnav.viz.demo import plot_map, plot_wind_estimate

    cfg = DemoConfig(seed=args.seed, vehicle=args.vehicle, wind_speed=args.wind_speed)
    result = run_demo(cfg, progress=True)
    args.out.mkdir(parents=True, exist_ok=True)
    files = [plot_map(result, args.out / "map_wind_path.png"),
             plot_wind_estimate(result, args.out / "wind_estimate.png"),
             result["log"].save(args.out / "flight.npz")]
    summary = {"config": dataclasses.asdict(cfg), **result["metrics"]}
    (args.out / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
    files.append(args.out / "summary.json")
    print(json.dumps(summary, indent=2))
    for f in files:
        print(f"wrote {f}")
    return 0
