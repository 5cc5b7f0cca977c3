"""``windnav predict``: the wind flow decoder's prediction at one point of a map, beside the truth.

::

    windnav predict --map city.json --at 420 310 --speed 6 --direction-deg 30 --out runs/pred

Simulates the map's mean flow (the thesis protocol: 100 spin-up steps, mean over 200) at the
given inlet, takes the LiDAR scan at ``--at`` (noise-free unless ``--scan-noise``; its noise
from ``--seed``), W_up from the inlet and W_robot the mean wind at the point, and predicts the
local field. Writes into ``--out`` one figure, ``predict.png`` (truth, prediction, speed error,
direction error on the H x H grid, buildings masked, the metrics in the title), and
``predict.json`` (the metrics of the decoder and both baselines).

The inputs are compared with the decoder's training conditions, read from its file
(:func:`windnav.predict.envelope.training_envelope`): one ``note`` (stderr) per input outside
them (scan noise above the training's, ``--at`` nearer a wall or farther from every building
than the training's robots, ``--dx`` other than the training flows' cell size), and one when
the truth flow's mean fails the averaging rule
(:func:`windnav.flow.validity.averaging_verdict`) or its air travelled, during spin-up and
averaging, more than :data:`TRAVEL_TOLERANCE` farther or shorter than the training flows' (the
time step ``min(0.25 s, dx / U)`` makes the flow of an inlet under 4 m/s younger). The notes,
the truth's diagnostics and the training conditions are in ``predict.json`` (``notes``,
``flow_diagnostics``, ``averaging``, ``training``), with the SHA-256 of the decoder file read
(``model_files``: :func:`windnav.commands._common.model_files`).
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

from windnav._validate import positive_float
from windnav.commands._common import (
    add_output_arguments,
    add_rotations_argument,
    document,
    inlet_direction,
    inlet_speed,
    load_model,
    model_files,
    options_named,
    outputs,
    path_argument,
    print_written,
    seed,
    where,
)

PRODUCTS = ("predict.json", "predict.png")
"""What a run writes into ``--out``."""
TRAVEL_TOLERANCE = 0.25
"""Relative difference between the truth's and the training flows' air travel (and the
relative slack on the scan noise and ``--dx``) above which a note is printed."""


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
    p.add_argument("--speed", type=float, required=True,
                   help="inlet wind speed, m/s (above 0, at most 100)")
    p.add_argument("--direction-deg", type=float, required=True,
                   help="direction the inlet wind blows toward, deg CCW from +x")
    p.add_argument("--model", type=Path, default=None, metavar="FILE",
                   help="decoder file (default: the shipped model)")
    add_rotations_argument(p)
    p.add_argument("--dx", type=float, default=1.0, help="solver cell size, m (default 1)")
    p.add_argument("--scan-noise", type=float, default=0.0, metavar="M",
                   help="LiDAR range noise standard deviation, m (default 0: noise-free)")
    p.add_argument("--seed", type=int, default=None,
                   help="seed of the scan noise, with --scan-noise (default 0)")
    p.add_argument("--out", type=path_argument, required=True, metavar="DIR",
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
    from windnav.predict import field_from_solution
    from windnav.viz.decoder import plot_prediction

    name = where(args)
    if args.seed is not None:
        seed(args)
    speed = inlet_speed(args.speed, "--speed", name)
    direction = inlet_direction(args.direction_deg, "--direction-deg", name)
    dx = positive_float(args.dx, "--dx", name)
    noise = positive_float(args.scan_noise, "--scan-noise", name, allow_zero=True)
    if args.seed is not None and noise == 0.0:  # accepted and ignored (CLI audit, 37th session)
        raise ValueError(f"The '--seed' parameter of {name} is the scan noise's: give "
                         f"--scan-noise with it. Got {args.seed!r} without noise instead.")
    city = load_city(args.map, "--map", name)
    at = check_point(city, args.at, "--at", name)
    from windnav.flow.grid import grid_for

    grid = grid_for(city.bounds[:4], dx)
    x, y = grid.x, grid.y
    # the truth's label grid keeps out the cells past the outermost centres, so its robot
    # cell would be blank there (W_robot read 0 m/s before MeanField.interpolate clamped)
    if not (x[0] <= at[0] <= x[-1] and y[0] <= at[1] <= y[-1]):
        raise ValueError(f"The '--at' parameter of {name} must lie among the solver's cell "
                         f"centres, [{x[0]:g}, {x[-1]:g}] x [{y[0]:g}, {y[-1]:g}] m at --dx "
                         f"{dx:g}: half a cell or more from the map's edge. Got ({at[0]:g}, "
                         f"{at[1]:g}) instead.")
    dec = load_model(args, name)
    files = model_files(args)  # the weights read, by hash
    out = outputs(args, out=("--out", args.out, PRODUCTS), inputs={"--map": args.map})
    settings = {**PROTOCOL, "dt": auto_dt(dx, speed), **(flow_settings or {})}
    from windnav.predict.envelope import training_envelope

    training = training_conditions(training_envelope(dec))
    notes = input_notes(training, city, at, dx, noise)  # said once the run is not refused
    with options_named({"'direction_deg' parameter of simulate":
                        f"'--direction-deg' parameter of {name}",
                        "'speed' parameter of simulate": f"'--speed' parameter of {name}",
                        "'dx' parameter of simulate": f"'--dx' parameter of {name}",
                        "simulate: City block": f"The '--dx' parameter of {name} is too coarse "
                                                "for the map: its block",
                        "Use dx <=": "Use --dx <="}):
        sol = simulate(city, speed=speed, direction_deg=direction, dx=dx,
                       progress=not args.no_progress, **settings)
    from windnav.flow.validity import averaging_verdict

    diagnostics = dict(getattr(sol, "diagnostics", {}) or {})
    verdict = averaging_verdict(diagnostics)
    travel = travel_check(training, speed, settings)
    notes += truth_notes(verdict, travel)
    print_notes(notes, name)
    field = field_from_solution(city, sol, name=str(args.map))
    pred = predict_at(dec, field, at, scan_noise=noise, rng=0 if args.seed is None else args.seed)
    c = len(pred["offsets"]) // 2  # the robot's cell (H is odd: offsets centred on 0)
    at_robot = [float(v) for v in pred["prediction"][:, c, c]]
    payload = {"position": at, "speed": speed, "direction_deg": direction,
               "flow": {"dx": dx, **settings}, "w_up": pred["w_up"],
               "w_robot": pred["w_robot"], "prediction_at_position": at_robot,
               "n_free_cells": int(pred["free"].sum()),
               "n_window_cells": int(pred["free"].size),
               "decoder": {"architecture": dec.architecture, "size": dec.size,
                           "path": str(args.model) if args.model else "default",
                           "boundary": dec.boundary, "rotations_deg": dec.rotations_deg},
               "model_files": files, "metrics": pred["metrics"],
               "flow_diagnostics": diagnostics, "averaging": verdict, "travel": travel,
               "training": training, "notes": notes}
    with out.writing() as stage:
        plot_prediction(pred, stage.dir / "predict.png",
                        title=f"({at[0]:g}, {at[1]:g}) m, {speed:g} m/s toward "
                              f"{direction:g} deg - ")
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


def training_conditions(envelope: dict) -> dict:
    """A decoder's training conditions (:func:`windnav.predict.envelope.training_envelope`)
    with its flow protocol completed as its sweep ran it: the solver settings the recipe left
    out take :data:`~windnav.experiments.wind_sweep.DEFAULT_SETTINGS`, the time step
    :func:`~windnav.experiments.wind_sweep.auto_dt` of the fastest speed; ``flow`` holds
    ``dx`` m, ``dt`` s, ``spinup_steps``, ``steps``, ``speeds`` m/s and ``travel_m`` (the
    inlet's air travel during spin-up and averaging, ``U dt (spinup_steps + steps)``, per
    speed, m)."""
    from windnav.experiments.wind_sweep import DEFAULT_SETTINGS, auto_dt

    given = envelope["settings"]
    settings = {**DEFAULT_SETTINGS, **given}
    speeds = envelope["speeds"]
    dx = float(settings["dx"])
    dt = float(given["dt"]) if given.get("dt") is not None else auto_dt(dx, max(speeds))
    n_steps = int(settings["spinup_steps"]) + int(settings["steps"])
    flow = {"dx": dx, "dt": dt, "spinup_steps": int(settings["spinup_steps"]),
            "steps": int(settings["steps"]), "speeds": speeds,
            "travel_m": [u * dt * n_steps for u in speeds]}
    return {**{k: v for k, v in envelope.items() if k not in ("settings", "speeds")},
            "flow": flow}


def print_notes(notes, name: str) -> None:
    """One ``note:`` line per note, on stderr."""
    for note in notes:
        print(f"{name}: note: {note}", file=sys.stderr, flush=True)


def _outside(value: float, trained: float) -> bool:
    """``value`` more than :data:`TRAVEL_TOLERANCE` (relative) away from ``trained``."""
    return abs(value - trained) > TRAVEL_TOLERANCE * abs(trained)


def input_notes(training: dict, city, at, dx: float, scan_noise: float) -> list[str]:
    """One note per input of ``windnav predict`` outside the decoder's training conditions
    (``training``: :func:`windnav.predict.envelope.training_envelope`)."""
    import numpy as np

    notes = []
    trained = training["scan_noise"]
    if scan_noise > trained * (1.0 + TRAVEL_TOLERANCE):
        notes.append(f"--scan-noise {scan_noise:g} m is above the decoder's training scan "
                     f"noise ({trained:g} m): outside its training range")
    fp = np.asarray(city.footprints, dtype=np.float64).reshape(-1, 4)
    if fp.shape[0]:
        p = np.asarray(at, dtype=np.float64)
        ex = np.maximum(np.maximum(fp[:, 0] - p[0], p[0] - fp[:, 1]), 0.0)
        ey = np.maximum(np.maximum(fp[:, 2] - p[1], p[1] - fp[:, 3]), 0.0)
        gap = float(np.sqrt((ex * ex + ey * ey).min()))
        near, reach = training["wall_clearance"], training["building_reach"]
        if not near <= gap <= reach:
            notes.append(f"--at ({p[0]:g}, {p[1]:g}) is {gap:.3g} m from the nearest building; "
                         f"the decoder was trained at {near:g} to {reach:g} m from one: outside "
                         "its training range")
    else:  # no building at all: farther than any trained position (vehicle audit)
        notes.append(f"the map has no building; the decoder was trained at "
                     f"{training['wall_clearance']:g} to {training['building_reach']:g} m from "
                     "one: outside its training range")
    notes += dx_notes(training, dx)
    return notes


def dx_notes(training: dict, dx: float) -> list[str]:
    """The note on a cell size ``dx`` (m) more than :data:`TRAVEL_TOLERANCE` from the decoder's
    training flows' (empty when within), for ``predict`` and ``evaluate-decoder``."""
    flow_dx = training["flow"]["dx"]
    if not _outside(dx, flow_dx):
        return []
    return [f"--dx {dx:g} m differs from the cell size of the decoder's training flows "
            f"({flow_dx:g} m): outside its training range"]


def travel_check(training: dict, speed: float, settings: dict) -> dict:
    """How far the inlet's air travelled during the truth's spin-up and averaging, beside the
    decoder's training flows (``U dt (spinup_steps + steps)``, m)."""
    n_steps = int(settings["spinup_steps"]) + int(settings["steps"])
    travel = float(speed) * float(settings["dt"]) * n_steps
    lo, hi = min(training["flow"]["travel_m"]), max(training["flow"]["travel_m"])
    return {"travel_m": travel, "training_travel_m": [lo, hi],
            "outside": bool(travel < lo * (1.0 - TRAVEL_TOLERANCE)
                            or travel > hi * (1.0 + TRAVEL_TOLERANCE))}


def truth_notes(verdict: dict, travel: dict) -> list[str]:
    """Notes on the truth flow: its averaging verdict
    (:func:`windnav.flow.validity.averaging_verdict`) and its air travel
    (:func:`travel_check`) when outside the training's."""
    notes = []
    if verdict["level"] in ("warning", "note"):
        kind = "not converged" if verdict["level"] == "warning" else "young"
        notes.append(f"the truth flow's mean is {kind}: {verdict['reason']}")
    if travel["outside"]:
        lo, hi = travel["training_travel_m"]
        trained = f"{lo:.0f} m" if lo == hi else f"{lo:.0f}-{hi:.0f} m"
        age = "a younger" if travel["travel_m"] < lo else "an older"
        notes.append(f"the truth flow's air travelled {travel['travel_m']:.0f} m during spin-up "
                     f"and averaging, the decoder's training flows' {trained}: {age} flow "
                     f"than it learned (more than {TRAVEL_TOLERANCE:.0%} apart)")
    return notes
