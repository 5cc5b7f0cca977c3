"""``windnav demo``: the end-to-end demo (city wind, flight, Wind UKF) with figures.

::

    windnav demo --seed 1 --out out/demo
    windnav demo --wind-speed 12 --flow-dt 0.1 --out out/demo12 --json demo12.json
    windnav demo --conditions thesis --out out/demo_thesis   # the thesis's sensing and filter

The harness is :mod:`windnav.experiments.demo`. The flow time step defaults to 0.2 s, or less
to keep the CFL number ``wind_speed * flow_dt / dx`` (dx = 2 m) at or below 1.
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

from windnav._validate import positive_float
from windnav.commands._common import (
    add_output_arguments,
    document,
    outputs,
    print_written,
    seed,
    where,
)

PRODUCTS = ("map_wind_path.png", "wind_estimate.png", "flight.npz", "summary.json")
"""What a run writes into ``--out``."""


def register(sub) -> None:
    from windnav.estimate.conditions import CONDITIONS
    from windnav.vehicle.params import VEHICLES

    p = sub.add_parser("demo", help="end-to-end demo: urban wind, flight, wind estimation",
                       description="Simulate the wind of a random city, fly a route through it "
                                   "and estimate the wind with the Wind UKF; write figures.")
    p.add_argument("--seed", type=int, default=0, help="seed of the city, wind and sensors")
    p.add_argument("--vehicle", default="hummingbird", choices=VEHICLES)
    p.add_argument("--wind-speed", type=float, default=5.0, help="inlet wind speed, m/s")
    p.add_argument("--flow-dt", type=float, default=None,
                   help="time step of the flow solver, s (default: 0.2, or less to keep "
                        "wind_speed * flow_dt / dx <= 1 with dx = 2 m)")
    p.add_argument("--conditions", choices=tuple(CONDITIONS), default=None,
                   help="Wind UKF preset (sensors and filter; see docs/ukf.md); default: "
                        "windnav's sensors and the filter's defaults")
    p.add_argument("--out", type=Path, default=Path("out/demo"), help="output folder")
    add_output_arguments(p)
    p.set_defaults(func=run)


def _config(args):
    from windnav.experiments.demo import DemoConfig, auto_flow_dt
    from windnav.flow.solver import MAX_CFL

    name = where(args)
    seed(args)
    speed = positive_float(args.wind_speed, "--wind-speed", name)
    dx = DemoConfig.dx
    if args.flow_dt is None:
        flow_dt = auto_flow_dt(speed, dx)
    else:
        flow_dt = positive_float(args.flow_dt, "--flow-dt", name)
        if speed * flow_dt / dx > MAX_CFL:
            raise ValueError(
                f"The '--flow-dt' parameter of {name} must keep the CFL number "
                f"wind_speed*flow_dt/dx at or below {MAX_CFL:g} (dx = {dx:g} m); use "
                f"--flow-dt <= {MAX_CFL * dx / speed:.4g} at --wind-speed {speed:g}. "
                f"Got {flow_dt:g} instead.")
    return DemoConfig(seed=args.seed, vehicle=args.vehicle, wind_speed=speed, flow_dt=flow_dt,
                      conditions=args.conditions)


def run(args) -> int:
    from windnav.experiments.demo import run_demo
    from windnav.experiments.results import write_json
    from windnav.viz.demo import plot_map, plot_wind_estimate

    cfg = _config(args)
    out = outputs(args, out=("--out", args.out, PRODUCTS))
    result = run_demo(cfg, progress=True)
    summary = document("demo", {"config": dataclasses.asdict(cfg), **result["metrics"]}, args)
    with out.writing() as stage:
        plot_map(result, stage.dir / "map_wind_path.png")
        plot_wind_estimate(result, stage.dir / "wind_estimate.png")
        result["log"].save(stage.dir / "flight.npz")
        write_json(summary, stage.dir / "summary.json")
        if stage.file("--json") is not None:
            write_json(summary, stage.file("--json"))
    print(json.dumps({"config": dataclasses.asdict(cfg), **result["metrics"]}, indent=2))
    print_written(out)
    return 0
