"""``windnav predict``: the wind flow decoder's prediction at one point of a map, beside the truth.

::

    windnav predict --map city.json --at 420 310 --speed 6 --direction-deg 30 --out runs/pred

Simulates the map's mean flow (the thesis protocol: 100 spin-up steps, mean over 200) at the
given inlet, takes the LiDAR scan at ``--at`` (noise-free unless ``--scan-noise``; its noise
from ``--seed``), W_up from the inlet and W_robot the mean wind at the point, and predicts the
local field. Writes into ``--out`` one figure, ``predict.png`` (truth, prediction, speed error,
direction error on the H x H grid, buildings masked, the metrics in the title), and
``predict.json`` (the metrics of the decoder and both baselines).
"""

from __future__ import annotations

import json
from pathlib import Path

from windnav._validate import positive_float
from windnav.commands._common import (
    add_output_arguments,
    document,
    inlet_speed,
    options_named,
    outputs,
    print_written,
    seed,
    where,
)

PRODUCTS = ("predict.json", "predict.png")
"""What a run writes into ``--out``."""


def register(subparsers) -> None:
    """Add the ``predict`` subcommand."""
    p = subparsers.add_parser(
        "predict",
        help="predict the local wind at one point of a map with the decoder, beside the truth",
        description=__doc__.splitlines()[0],
    )
    p.add_argument("--map", type=Path, required=True, metavar="FILE",
                   help="RotorPy world JSON map")
    p.add_argument("--at", type=float, nargs=2, required=True, metavar=("X", "Y"),
                   help="robot position, m (inside the map, outside every building)")
    p.add_argument("--speed", type=float, required=True, help="inlet wind speed, m/s (0 to 100)")
    p.add_argument("--direction-deg", type=float, required=True,
                   help="direction the inlet wind blows toward, deg CCW from +x")
    p.add_argument("--model", type=Path, default=None, metavar="FILE",
                   help="decoder file (default: the shipped model)")
    p.add_argument("--dx", type=float, default=1.0, help="solver cell size, m (default 1)")
    p.add_argument("--scan-noise", type=float, default=0.0, metavar="M",
                   help="LiDAR range noise standard deviation, m (default 0: noise-free)")
    p.add_argument("--seed", type=int, default=0,
                   help="seed of the scan noise (default %(default)s)")
    p.add_argument("--out", type=Path, required=True, metavar="DIR",
                   help="output folder (figure, JSON)")
    p.add_argument("--no-progress", action="store_true", help="hide the solver's progress")
    add_output_arguments(p)
    p.set_defaults(func=run)


def run(args, flow_settings=None) -> int:
    """Run ``windnav predict``; returns 0."""
    from windnav.commands.wind import load_city
    from windnav.experiments.decoder_eval import PROTOCOL, check_point, predict_at
    from windnav.experiments.results import json_ready, write_json
    from windnav.experiments.wind_sweep import auto_dt
    from windnav.flow import simulate
    from windnav.predict import field_from_solution, load_decoder
    from windnav.viz.decoder import plot_prediction

    name = where(args)
    seed(args)
    speed = inlet_speed(args.speed, "--speed", name)
    dx = positive_float(args.dx, "--dx", name)
    noise = positive_float(args.scan_noise, "--scan-noise", name, allow_zero=True)
    city = load_city(args.map, "--map", name)
    at = check_point(city, args.at, "--at", name)
    try:
        dec = load_decoder(args.model)
    except ValueError as exc:
        raise ValueError(str(exc).replace("'path' parameter of load_decoder",
                                          f"'--model' parameter of {name}")) from None
    out = outputs(args, out=("--out", args.out, PRODUCTS))
    settings = {**PROTOCOL, "dt": auto_dt(dx, speed), **(flow_settings or {})}
    with options_named({"'direction_deg' parameter of simulate":
                        f"'--direction-deg' parameter of {name}",
                        "'speed' parameter of simulate": f"'--speed' parameter of {name}",
                        "'dx' parameter of simulate": f"'--dx' parameter of {name}",
                        "simulate: City block": f"The '--dx' parameter of {name} is too coarse "
                                                "for the map: its block",
                        "Use dx <=": "Use --dx <="}):
        sol = simulate(city, speed=speed, direction_deg=args.direction_deg, dx=dx,
                       progress=not args.no_progress, **settings)
    field = field_from_solution(city, sol, name=str(args.map))
    pred = predict_at(dec, field, at, scan_noise=noise, rng=args.seed)
    c = len(pred["offsets"]) // 2  # the robot's cell (H is odd: offsets centred on 0)
    at_robot = [float(v) for v in pred["prediction"][:, c, c]]
    payload = {"position": at, "speed": speed, "direction_deg": args.direction_deg,
               "flow": {"dx": dx, **settings}, "w_up": pred["w_up"],
               "w_robot": pred["w_robot"], "prediction_at_position": at_robot,
               "n_free_cells": int(pred["free"].sum()),
               "n_window_cells": int(pred["free"].size),
               "decoder": {"architecture": dec.architecture, "size": dec.size,
                           "path": str(args.model) if args.model else "default"},
               "metrics": pred["metrics"]}
    with out.writing() as stage:
        plot_prediction(pred, stage.dir / "predict.png",
                        title=f"({at[0]:g}, {at[1]:g}) m, {speed:g} m/s toward "
                              f"{args.direction_deg:g} deg - ")
        doc = document("predict", payload, args)
        write_json(doc, stage.dir / "predict.json")
        if stage.file("--json") is not None:
            write_json(doc, stage.file("--json"))
    print(json.dumps(json_ready(pred["metrics"]), indent=1))
    # the prediction itself, not only its errors (CLI audit, 2026-12-05)
    w = pred["w_robot"]
    print(f"predicted wind at ({at[0]:g}, {at[1]:g}) m: ({at_robot[0]:.2f}, {at_robot[1]:.2f}) "
          f"m/s (W_robot, the mean there: ({w[0]:.2f}, {w[1]:.2f})); {payload['n_free_cells']} "
          f"of the window's {payload['n_window_cells']} cells are free air on the map (the "
          "errors count those)")
    print_written(out)
    return 0
