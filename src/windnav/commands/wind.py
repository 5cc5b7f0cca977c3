"""``windnav wind``: one urban flow simulation, saved as Zarr and drawn as a PNG.

::

    windnav wind --map city.json --speed 5 --direction-deg 30 --out runs/wind
    # -> runs/wind/flow.zarr (see windnav.flow.solution_io) and runs/wind/mean_speed.png

The flow is solved by :func:`windnav.flow.simulate` (through
:func:`windnav.experiments.wind_sweep.simulate_case`, the body every ``wind-sweep`` task runs
too); the picture (:func:`windnav.experiments.flow_figures.plot_mean_speed`) shows the
time-averaged wind speed ``|(mean_u, mean_v)|`` with streamlines of the mean wind over the
building footprints.

The run ends with the averaging diagnostics and their verdict
(:func:`windnav.flow.validity.averaging_verdict`: a ``warning`` when the mean is not
converged, a ``note`` when it is young), and a ``note`` on stderr when ``--dx`` is above the
validated resolution (:func:`windnav.flow.validity.resolution_check`); both are in ``--json``
(``averaging``, ``resolution``) and in the Zarr attributes of ``flow.zarr``.
"""

from __future__ import annotations

import os
import sys
import warnings
from pathlib import Path

from windnav._validate import nonnegative_int, positive_float, positive_int
from windnav.commands._common import (
    add_output_arguments,
    document,
    inlet_direction,
    inlet_speed,
    options_named,
    outputs,
    print_written,
    seed,
    where,
)
from windnav.experiments.wind_sweep import (
    AUTO_CFL,
    DEFAULT_SETTINGS,
    auto_dt,
    simulate_case,
    solver_grid,
)

PRODUCTS = ("flow.zarr", "mean_speed.png")
"""What a run writes into ``--out``."""


def add_solver_arguments(parser, seed_help: str = "recorded with the flow; the solver is "
                         "deterministic (its symmetry-breaking kick is fixed), so it changes no "
                         "field") -> None:
    """Add ``--dx --dt --spinup-steps --steps --record-every --seed`` to ``parser`` (what
    ``--seed`` does in this command: ``seed_help``)."""
    d = DEFAULT_SETTINGS
    parser.add_argument("--dx", type=float, default=d["dx"], help="cell size, m (%(default)s)")
    parser.add_argument("--dt", type=float, default=None,
                        help=f"time step, s (default: {d['dt']}, or less to keep the CFL "
                             f"number speed*dt/dx <= {AUTO_CFL:g} at the fastest inlet)")
    parser.add_argument("--spinup-steps", type=int, default=d["spinup_steps"],
                        help="steps run before averaging starts (%(default)s)")
    parser.add_argument("--steps", type=int, default=d["steps"],
                        help="steps averaged into the mean wind (%(default)s)")
    parser.add_argument("--record-every", type=int, default=d["record_every"],
                        help="store a frame every this many averaged steps; 0: none "
                             "(%(default)s)")
    parser.add_argument("--seed", type=int, default=0, help=f"{seed_help} (%(default)s)")


def solver_settings(args, max_speed: float) -> dict:
    """Validated solver settings from parsed arguments, as a dict of JSON values.

    ``max_speed`` (m/s), the fastest inlet, sets the default time step (:func:`auto_dt`).
    """
    from windnav.flow.solver import MAX_CFL

    name = where(args)
    dx = positive_float(args.dx, "--dx", name)
    dt = auto_dt(dx, max_speed) if args.dt is None else positive_float(args.dt, "--dt", name)
    if max_speed * dt / dx > MAX_CFL:
        raise ValueError(
            f"The '--dt' parameter of {name} must keep the CFL number speed*dt/dx at or below "
            f"{MAX_CFL:g} at the fastest inlet {max_speed:g} m/s; use --dt <= "
            f"{MAX_CFL * dx / max_speed:.4g} (or leave it out). Got {dt:g} instead.")
    steps = positive_int(args.steps, "--steps", name)
    every = nonnegative_int(args.record_every, "--record-every", name)
    if every > steps:  # no frame would be recorded
        raise ValueError(f"The '--record-every' parameter of {name} must be at most --steps "
                         f"({steps}), or 0 for no frames. Got {every} instead.")
    return {
        "dx": dx,
        "dt": dt,
        "spinup_steps": nonnegative_int(args.spinup_steps, "--spinup-steps", name),
        "steps": steps,
        "record_every": every,
    }


def load_city(path, name: str = "--map", where: str = "windnav wind"):
    """Read a RotorPy world JSON map; a missing file is a ValueError naming the argument."""
    from windnav.city import City

    if not os.path.isfile(path):
        raise ValueError(f"The {name!r} parameter of {where} must be an existing RotorPy world "
                         f"JSON file. Got {str(path)!r} instead.")
    return City.from_rotorpy_json(path)


def register(subparsers) -> None:
    """Add the ``wind`` subcommand."""
    p = subparsers.add_parser(
        "wind",
        help="simulate the wind over one map and save it (Zarr + PNG)",
        description="Simulate the 2D urban wind over one map for one inlet; write "
                    "OUT/flow.zarr and OUT/mean_speed.png.",
    )
    p.add_argument("--map", required=True, help="RotorPy world JSON file")
    p.add_argument("--speed", type=float, required=True,
                   help="inlet speed, m/s (above 0, at most 100: the incompressible "
                        "solver's Mach 0.3)")
    p.add_argument("--direction-deg", type=float, default=0.0,
                   help="inlet direction the wind blows toward, deg CCW from +x (%(default)s)")
    p.add_argument("--out", required=True, help="output directory")
    add_solver_arguments(p)
    add_output_arguments(p)
    p.set_defaults(func=run)


def run(args, simulate=None) -> int:
    """Run ``windnav wind``; returns the exit code."""
    from windnav.experiments.flow_figures import plot_mean_speed
    from windnav.experiments.results import write_json
    from windnav.flow.solution_io import save_flow

    name = where(args)
    seed(args)
    speed = inlet_speed(args.speed, "--speed", name)
    direction_deg = inlet_direction(args.direction_deg, "--direction-deg", name)
    settings = solver_settings(args, speed)
    city = load_city(args.map)
    with options_named({"simulate: City block": f"The '--dx' parameter of {name} is too coarse "
                                                "for the map: its block",
                        "Use dx <=": "Use --dx <="}):
        with warnings.catch_warnings():  # its warnings come once, from the solve itself
            warnings.simplefilter("ignore")
            city.check_resolution(settings["dx"], "simulate")  # before any output or work
    out = outputs(args, out=("--out", args.out, PRODUCTS), inputs={"--map": args.map})
    x, y = solver_grid(city, settings["dx"])
    print(f"{name}: solving {x.size} x {y.size} cells, {settings['spinup_steps']} spin-up + "
          f"{settings['steps']} averaged steps of {settings['dt']:g} s", flush=True)
    from windnav.flow.validity import averaging_verdict, resolution_check

    resolution = resolution_check(city, settings["dx"])
    with warnings.catch_warnings():  # said once, at the end, as a note
        warnings.filterwarnings("ignore", message=RESOLUTION_WARNING)
        solution, seconds = simulate_case(city, speed, direction_deg, settings, args.seed,
                                          simulate)
    config = {
        "speed": speed,
        "direction_deg": direction_deg,
        **settings,
        "seed": int(args.seed),
        "map_source": os.path.abspath(args.map),
        "solve_seconds": seconds,
    }
    verdict = averaging_verdict(solution)
    with out.writing() as stage:
        save_flow(solution, stage.dir / "flow.zarr", config=config)
        add_flow_attrs(stage.dir / "flow.zarr", {"averaging": verdict, "resolution": resolution})
        plot_mean_speed(
            solution, city, stage.dir / "mean_speed.png",
            title=f"{Path(args.map).name}: inlet {speed:g} m/s toward {direction_deg:g} deg",
        )
        if stage.file("--json") is not None:
            diagnostics = dict(getattr(solution, "diagnostics", {}) or {})
            diagnostics["validated_dx"] = resolution["validated_dx"]
            write_json(document("wind", {"config": config, "diagnostics": diagnostics,
                                         "averaging": verdict, "resolution": resolution}, args),
                       stage.file("--json"))
    print(f"solved in {seconds:.1f} s")
    print_written(out)
    print(averaging_report(solution))
    print_resolution_note(resolution, name)
    return 0


RESOLUTION_WARNING = ".*cell size above the validated resolution"
"""The message of the solver's resolution warning (:meth:`windnav.city.City.check_resolution`),
which the commands print as a note instead."""


def print_resolution_note(check: dict, name: str, label: str = "") -> dict:
    """Print the ``note:`` line (stderr) of a :func:`windnav.flow.validity.resolution_check`
    when its cell size is above the map's validated resolution; returns ``check``."""
    if check["note"] is not None:
        print(f"{name}: note: {label}{check['note']}", file=sys.stderr, flush=True)
    return check


def add_flow_attrs(path, attrs: dict) -> None:
    """Add attributes to a saved flow (``flow.zarr``; its arrays are left as they are)."""
    from windnav.experiments.results import json_ready
    from windnav.flow._zarr import FLOW_FORMAT, open_group

    open_group(path, FLOW_FORMAT, "windnav wind", mode="r+").attrs.update(json_ready(attrs))


def averaging_report(solution) -> str:
    """One paragraph on how well the mean wind is converged (printed by ``windnav wind``):
    the diagnostics, then the verdict's ``warning:`` or ``note:`` line
    (:func:`windnav.flow.validity.averaging_verdict`) when it is not converged."""
    from windnav.flow.validity import averaging_message, averaging_verdict

    d = getattr(solution, "diagnostics", {})
    if not d:
        return "averaging: no diagnostics (solver override)"
    text = (
        f"averaging: spin-up {d['flow_throughs_spinup']:.2f} and window "
        f"{d['flow_throughs_average']:.2f} flow-throughs of the domain; mean differs between "
        f"the window's halves by {d['half_window_difference']:.3f} of the inlet speed (RMS); "
        f"closure: Smagorinsky C_s = {d['smagorinsky']:g}, filter {d['filter_width']:.2f} m"
    )
    message = averaging_message(averaging_verdict(d))
    if message is not None:
        text += "\n" + message
    return text
