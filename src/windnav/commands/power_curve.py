"""``windnav power-curve``: steady-flight power versus airspeed, swept in the simulator.

::

    windnav power-curve --vehicle crazyflie_brushless --max-speed 6.5 --out out/power_curve

The harness is :mod:`windnav.experiments.power_curve`. The sweep is deterministic (no sensors,
steady wind), so the command takes no ``--seed``.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

from windnav._validate import positive_float, positive_int
from windnav.commands._common import (
    add_output_arguments,
    document,
    options_named,
    outputs,
    print_written,
    where,
)

PRODUCTS = ("power_curve.json", "power_curve.png")
"""What a run writes into ``--out``."""


def register(sub) -> None:
    from windnav.commands._choices import VEHICLES

    p = sub.add_parser("power-curve", help="sweep steady-flight power versus airspeed",
                       description="Sweep steady level flights (hover in a uniform wind) in the "
                                   "simulator, fit P(airspeed), and report the best speeds.")
    p.add_argument("--vehicle", default="hummingbird", choices=VEHICLES,
                   help="vehicle preset (%(default)s)")
    p.add_argument("--max-speed", type=float, default=12.0,
                   help="largest airspeed, m/s (%(default)s; points beyond the vehicle's "
                        "envelope are left out)")
    p.add_argument("--points", type=int, default=21,
                   help="airspeeds in the sweep (%(default)s)")
    p.add_argument("--degree", type=int, default=4,
                   help="degree of the fitted polynomial (%(default)s)")
    p.add_argument("--out", type=Path, default=Path("out/power_curve"),
                   help="output folder (%(default)s)")
    add_output_arguments(p)
    p.set_defaults(func=run)


def run(args) -> int:
    from windnav.experiments.power_curve import plot_power_curve, power_curve_study
    from windnav.experiments.results import write_json

    name = where(args)
    max_speed = positive_float(args.max_speed, "--max-speed", name)
    degree = positive_int(args.degree, "--degree", name)
    points = positive_int(args.points, "--points", name)
    if points < degree + 2:  # degree + 1 interpolated: no residual, so no check could fire
        raise ValueError(f"The '--points' parameter of {name} must be at least --degree + 2 = "
                         f"{degree + 2} (a fit of degree {degree} has {degree + 1} coefficients "
                         f"and needs residuals to judge it by). Got {points} instead.")
    out = outputs(args, out=("--out", args.out, PRODUCTS))

    with options_named({"'max_speed' parameter of simulated_power_curve":
                        f"'--max-speed' parameter of {name}"}):
        result = power_curve_study(args.vehicle, max_speed, points, degree)
    doc = document("power-curve", result, args)
    with out.writing() as stage:
        write_json(doc, stage.dir / "power_curve.json")
        plot_power_curve(result, stage.dir / "power_curve.png")
        if stage.file("--json") is not None:
            write_json(doc, stage.file("--json"))
    print(json.dumps({k: result[k] for k in ("vehicle", "max_endurance_speed_m_s",
                                             "endurance_within_fit_noise",
                                             "lowest_power_sample_speed_m_s", "max_range")},
                     indent=2))
    for note in result["notes"]:  # the fitted endurance speed is a dip of the fit only
        print(f"{name}: note: {note}", file=sys.stderr)
    edge = [w for w, opt in result["max_range"].items() if opt and opt.get("at_speed_max")]
    if edge:
        top = result["fitted_speed_max_m_s"]
        why = (f"the sweep ends at {top:.3g} m/s, where the vehicle's trusted envelope does "
               f"(not at --max-speed {max_speed:g}), so the max-range speed lies beyond what "
               "the model is trusted for" if top < max_speed * (1.0 - 1e-6) else
               "raise --max-speed (within the vehicle's envelope) to find it")
        print(f"{name}: note: the max-range airspeed is the sweep's top speed, an edge and not a "
              f"minimum, at {', '.join(edge)}: {why}", file=sys.stderr)
    print_written(out)
    return 0
