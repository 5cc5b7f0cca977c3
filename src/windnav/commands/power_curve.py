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
    path_argument,
    print_written,
    where,
)

PRODUCTS = ("power_curve.json", "power_curve.png")
"""What a run writes into ``--out``."""
MAX_POINTS = 1001
"""The most airspeeds ``--points`` sweeps: one batch of flights, 4 s and 0.9 GB at 1001 (the
docs sweep 21-25; 10^9 allocated for ever, silently: CLI audit)."""
MIN_MAX_SPEED = 1.0
"""The slowest ``--max-speed``, m/s: below it a sweep from hover fits the controller's noise,
not a power curve (1e-6 ran, its speeds 2e-7 m/s apart: CLI audit)."""


def register(sub) -> None:
    from windnav.commands._choices import VEHICLES

    p = sub.add_parser("power-curve", help="sweep steady-flight power versus airspeed",
                       description="Sweep steady level flights (hover in a uniform wind) in the "
                                   "simulator, fit P(airspeed), and report the best speeds.")
    p.add_argument("--vehicle", default="hummingbird", choices=VEHICLES,
                   help="vehicle preset (%(default)s)")
    p.add_argument("--max-speed", type=float, default=12.0,
                   help=f"largest airspeed, m/s, at least {MIN_MAX_SPEED:g} (%(default)s; "
                        "points beyond the vehicle's envelope, its airspeed limit, are left "
                        "out)")
    p.add_argument("--points", type=int, default=21,
                   help=f"airspeeds in the sweep, at most {MAX_POINTS} (%(default)s)")
    p.add_argument("--degree", type=int, default=4,
                   help="degree of the fitted polynomial (%(default)s)")
    p.add_argument("--out", type=path_argument, default=Path("out/power_curve"),
                   help="output folder (%(default)s)")
    add_output_arguments(p)
    p.set_defaults(func=run)


def run(args) -> int:
    from windnav.experiments.power_curve import plot_power_curve, power_curve_study
    from windnav.experiments.results import write_json

    name = where(args)
    max_speed = positive_float(args.max_speed, "--max-speed", name)
    if max_speed < MIN_MAX_SPEED:
        raise ValueError(f"The '--max-speed' parameter of {name} must be at least "
                         f"{MIN_MAX_SPEED:g} m/s (a sweep from hover to a slower speed fits "
                         f"the controller's noise, not a power curve). Got {args.max_speed!r} "
                         "instead.")
    degree = positive_int(args.degree, "--degree", name)
    points = positive_int(args.points, "--points", name)
    if points > MAX_POINTS:
        raise ValueError(f"The '--points' parameter of {name} must be at most {MAX_POINTS} "
                         "(one batch of flights: about 1 GB at that). Got "
                         f"{args.points!r} instead.")
    if points < degree + 2:  # degree + 1 interpolated: no residual, so no check could fire
        raise ValueError(f"The '--points' parameter of {name} must be at least --degree + 2 = "
                         f"{degree + 2} (a fit of degree {degree} has {degree + 1} coefficients "
                         f"and needs residuals to judge it by). Got {points} instead.")
    limit = _check_envelope(args.vehicle, max_speed, points, degree, name)
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
        why = (f"the sweep ends at {top:.3g} m/s, its last point inside the vehicle's "
               f"trusted envelope (which ends at the airspeed limit, {limit:.2f} m/s; not at "
               f"--max-speed {max_speed:g}), so the max-range speed lies beyond what the "
               "model is trusted for" if top < max_speed * (1.0 - 1e-6) else
               "raise --max-speed (within the vehicle's envelope) to find it")
        print(f"{name}: note: the max-range airspeed is the sweep's top speed, an edge and not a "
              f"minimum, at {', '.join(edge)}: {why}", file=sys.stderr)
    print_written(out)
    return 0


def _check_envelope(vehicle: str, max_speed: float, points: int, degree: int,
                    name: str) -> float:
    """The vehicle's airspeed limit, m/s, where its envelope ends
    (:attr:`MultirotorParams.airspeed_limit`; a point there is already outside). Refuses,
    before the sweep, a ``--max-speed`` whose sweep leaves too few points below it for a
    degree-``degree`` fit: the sweep said so itself, but named the first swept speed outside
    the envelope as where it ends (``--max-speed 100``: "it leaves it at 15.0 m/s", the
    Hummingbird's limit being 13.45; CLI audit)."""
    import numpy as np

    import windnav as wn

    limit = wn.vehicle.params(vehicle).airspeed_limit
    inside = int(np.count_nonzero(np.linspace(0.0, max_speed, points) < limit))
    if inside <= degree:
        raise ValueError(f"The '--max-speed' parameter of {name} leaves {inside} of the "
                         f"{points} points below the airspeed limit of {vehicle}'s envelope, "
                         f"{limit:.2f} m/s, too few for a degree-{degree} fit. Got "
                         f"{max_speed:g}; lower it toward {limit:.2f} m/s or sweep more "
                         "--points.")
    return limit
