"""``windnav demo``: the end-to-end demo, in one of two stories.

``--story navigate`` (the default): a city and its wind; MPPI and EA-MPPI+W (or up to four
``--variant`` labels of ``benchmark-nav``) fly the same start and goal through it; the energy
each used, and an animated GIF of the flight. The harness is
:mod:`windnav.experiments.nav_demo`; writes ``summary.json``, ``paths.png``, ``energy.png`` and
``flight.gif``.

``--story ukf``: a city's wind, a flight along a graph-search route with sensors, and the Wind
UKF's estimate of the wind (:mod:`windnav.experiments.demo`); writes ``map_wind_path.png``,
``wind_estimate.png``, ``flight.npz`` and ``summary.json``.

::

    windnav demo --out out/demo --seed 0                       # the navigation story
    windnav demo --wind-speed 8 --direction-deg 180 --out out/demo8   # into the wind: with
                                                   # seed 0 both flights fail, and it says so
    windnav demo --variant mppi,ea-mppi-w,ea-mppi-w@energy=mission --out out/demo3
                                                   # three of benchmark-nav's labels
    windnav demo --story ukf --seed 1 --out out/demo_ukf
    windnav demo --story ukf --conditions thesis --out out/demo_thesis

The flow time step defaults to the story's (0.25 s navigate, 0.2 s ukf), or less to keep the
CFL number ``wind_speed * flow_dt / dx`` at or below 1.
"""

from __future__ import annotations

import dataclasses
import json
import sys
import time
from pathlib import Path

from windnav._validate import positive_float
from windnav.commands._common import (
    add_output_arguments,
    document,
    gif_frames,
    inlet_direction,
    inlet_speed,
    options_named,
    outputs,
    path_argument,
    print_written,
    seed,
    where,
)

NAV_PRODUCTS = ("summary.json", "paths.png", "energy.png", "flight.gif")
"""What ``--story navigate`` writes into ``--out``."""
UKF_PRODUCTS = ("map_wind_path.png", "wind_estimate.png", "flight.npz", "summary.json")
"""What ``--story ukf`` writes into ``--out``."""
PRODUCTS = tuple(dict.fromkeys(NAV_PRODUCTS + UKF_PRODUCTS))
"""What a run of either story may have written into ``--out`` (``--overwrite`` replaces them
all, so a folder never mixes the two stories)."""
STORIES = ("navigate", "ukf")
GIF_FRAMES = 80
"""Frames of ``flight.gif`` (8 s at 10 frames per second)."""
NAV_FLOW_DT = 0.25
"""Flow time step (and frame interval) of the navigation story at moderate inlet speeds, s."""


def register(sub) -> None:
    from windnav.commands._choices import CONDITION_NAMES, VEHICLES
    from windnav.experiments.nav_demo import NavDemoConfig as Nav

    p = sub.add_parser("demo", help="end-to-end demo: urban wind, MPPI vs EA-MPPI+W (or the "
                                    "Wind UKF)",
                       description="Simulate the wind of a random city and fly through it. "
                                   "--story navigate (default): MPPI and EA-MPPI+W (or up to "
                                   "four --variant labels) fly the same start and goal; their "
                                   "energies, figures and a GIF. --story ukf: a route flown "
                                   "with sensors, the wind estimated by the Wind UKF.")
    p.add_argument("--story", choices=STORIES, default="navigate",
                   help="which demo (default: %(default)s)")
    p.add_argument("--seed", type=int, default=0,
                   help="seed of the city, the planners and the sensors (default %(default)s)")
    p.add_argument("--wind-speed", type=float, default=5.0,
                   help="inlet wind speed, m/s (default %(default)s)")
    p.add_argument("--flow-dt", type=float, default=None,
                   help="time step of the flow solver, s (default: 0.25 navigate, 0.2 ukf, or "
                        "less to keep wind_speed * flow_dt / dx <= 1)")
    nav = p.add_argument_group("navigate story")
    nav.add_argument("--direction-deg", type=float, default=None,
                     help="direction the inlet wind blows toward, deg CCW from +x "
                          f"(default {Nav.direction_deg:g})")
    nav.add_argument("--map-size", type=float, default=None,
                     help=f"side of the square city, m (default {Nav.map_size:g})")
    nav.add_argument("--record-s", type=float, default=None,
                     help=f"recorded wind after the {Nav.spinup_s:g} s spin-up, s: the longest "
                          f"flight (default {Nav.record_s:g})")
    nav.add_argument("--gif-frames", type=int, default=None,
                     help=f"frames of flight.gif, shown at 10 per second (default {GIF_FRAMES})")
    nav.add_argument("--variant", default=None, metavar="LABEL[,LABEL...]",
                     help="the flights, separated by commas (at most 4): variants or "
                          "benchmark-nav's labels (e.g. ea-mppi-w@energy=mission, "
                          "ea-mppi-w-esc@escair=13.45), each compared with the first "
                          "(default: mppi,ea-mppi-w)")
    nav.add_argument("--model", type=Path, default=None, metavar="FILE",
                     help="the decoder file of each ea-mppi-w-hat label without @decoder= "
                          "(default: the shipped decoder; @decoder=DATE flies a dated one)")
    ukf = p.add_argument_group("ukf story")
    ukf.add_argument("--vehicle", default=None, choices=VEHICLES,
                     help="vehicle (default hummingbird)")
    ukf.add_argument("--conditions", choices=CONDITION_NAMES, default=None,
                     help="Wind UKF preset (sensors and filter; see docs/ukf.md); default: "
                          "windnav's sensors and the filter's defaults")
    p.add_argument("--out", type=path_argument, default=Path("out/demo"),
                   help="output folder (default %(default)s)")
    p.add_argument("--no-progress", action="store_true", help="hide the progress bars")
    add_output_arguments(p)
    p.set_defaults(func=run)


def _only(args, story: str, flags: dict) -> None:
    """Refuse options of the other story (their default is None)."""
    name = where(args)
    for flag, value in flags.items():
        if value is not None:
            raise ValueError(f"The {flag!r} parameter of {name} applies to --story {story} "
                             f"only. Got {value!r} with --story {args.story} instead.")


def _flow_dt(args, default, dx: float) -> float:
    """``--flow-dt``, checked against the CFL limit; ``default(speed, dx)`` when not given."""
    from windnav.flow.solver import MAX_CFL

    name = where(args)
    speed = inlet_speed(args.wind_speed, "--wind-speed", name)
    if args.flow_dt is None:
        return default(speed, dx)
    flow_dt = positive_float(args.flow_dt, "--flow-dt", name)
    if speed * flow_dt / dx > MAX_CFL:
        raise ValueError(
            f"The '--flow-dt' parameter of {name} must keep the CFL number "
            f"wind_speed*flow_dt/dx at or below {MAX_CFL:g} (dx = {dx:g} m); use "
            f"--flow-dt <= {MAX_CFL * dx / speed:.4g} at --wind-speed {speed:g}. "
            f"Got {flow_dt:g} instead.")
    return flow_dt


def _config(args):
    """The UKF story's :class:`~windnav.experiments.demo.DemoConfig`."""
    from windnav.experiments.demo import DemoConfig, auto_flow_dt

    seed(args)
    _only(args, "navigate", {"--direction-deg": args.direction_deg,
                             "--map-size": args.map_size, "--record-s": args.record_s,
                             "--gif-frames": args.gif_frames, "--variant": args.variant,
                             "--model": args.model})
    flow_dt = _flow_dt(args, auto_flow_dt, DemoConfig.dx)
    return DemoConfig(seed=args.seed, vehicle=args.vehicle or "hummingbird",
                      wind_speed=float(args.wind_speed), flow_dt=flow_dt,
                      conditions=args.conditions)


def _nav_config(args):
    """The navigation story's :class:`~windnav.experiments.nav_demo.NavDemoConfig` and the
    GIF's frame count."""
    from windnav.experiments.nav_demo import NavDemoConfig

    name = where(args)
    seed(args)
    _only(args, "ukf", {"--vehicle": args.vehicle, "--conditions": args.conditions})
    frames = gif_frames(args.gif_frames, name, default=GIF_FRAMES)
    fields = {"seed": args.seed, "wind_speed": inlet_speed(args.wind_speed, "--wind-speed",
                                                           name)}
    if args.direction_deg is not None:
        fields["direction_deg"] = inlet_direction(args.direction_deg, "--direction-deg",
                                                  name)
    if args.map_size is not None:
        fields["map_size"] = positive_float(args.map_size, "--map-size", name)
        import math

        from windnav.city.core import MAX_GRID_CELLS

        # NavDemoConfig's and grid_shape's rules, said in this flag's terms (CLI audit)
        dx = NavDemoConfig.dx
        least, most = 20 * dx, dx * math.isqrt(MAX_GRID_CELLS)
        if not least <= fields["map_size"] <= most:
            raise ValueError(f"The '--map-size' parameter of {name} must be {least:g}-{most:g} "
                             f"m (20 to {math.isqrt(MAX_GRID_CELLS)} cells a side of the flow's "
                             f"{dx:g} m grid). Got {args.map_size:g} instead.")
    if args.record_s is not None:
        fields["record_s"] = positive_float(args.record_s, "--record-s", name)
    fields["flow_dt"] = _flow_dt(args, lambda speed, dx: min(NAV_FLOW_DT, dx / speed),
                                 NavDemoConfig.dx)
    return NavDemoConfig(**fields), int(frames)


def _nav_flights(args):
    """``--variant``'s flights (:func:`windnav.commands.navigate.flights`, with navigate's
    defaults for the options the demo does not have) and the namespace they were read with;
    (None, None) without ``--variant``: :func:`~windnav.experiments.nav_demo.default_flights`."""
    import argparse

    from windnav.commands.navigate import FLAG_DEFAULTS, flights
    from windnav.experiments.navigate import TILT_MAX_DEG

    if args.variant is None:
        if args.model is not None:
            raise ValueError(f"The '--model' parameter of {where(args)} applies only to an "
                             "ea-mppi-w-hat label of --variant (the default flights read no "
                             f"decoder). Got {str(args.model)!r} without --variant instead.")
        return None, None
    ns = argparse.Namespace(command=args.command, variant=args.variant, model=args.model,
                            rotations_deg=None, tilt_max_deg=TILT_MAX_DEG, **FLAG_DEFAULTS)
    return flights(ns, where(args)), ns


def run(args) -> int:
    if args.story == "ukf":
        return _run_ukf(args)
    return _run_navigate(args)


def _run_navigate(args) -> int:
    import math

    from windnav.commands._common import model_files
    from windnav.experiments.nav_demo import describe, legend_name, run_nav_demo
    from windnav.experiments.results import write_json
    from windnav.viz.animate import animate_flights
    from windnav.viz.nav_compare import plot_energy, plot_paths

    t_start = time.perf_counter()
    cfg, n_frames = _nav_config(args)
    planned, read_with = _nav_flights(args)
    out = outputs(args, out=("--out", args.out, PRODUCTS))
    # the library's names for what --map-size sets (no flag sets n_buildings; CLI audit)
    with options_named({"'map_size' parameter of run_nav_demo":
                        f"'--map-size' parameter of {where(args)}",
                        " Pass a smaller n_buildings= or a larger size.": ""}):
        result = run_nav_demo(cfg, flights=planned, progress=not args.no_progress)
    summary = result["summary"]
    city, flow = result["city"], result["flow"]
    named = {legend_name(v): r for v, r in result["results"].items()}
    flown = [legend_name(v, math.inf) for v in result["results"]]
    who = " vs ".join(flown) + ", wind" if len(flown) < 3 else "Wind"
    inlet = f"{cfg.wind_speed:g} m/s toward {cfg.direction_deg:g} deg"
    timings = summary["timings_s"]
    with out.writing() as stage:
        print("drawing the figures and the GIF", file=sys.stderr, flush=True)
        t0 = time.perf_counter()
        plot_paths(named, city, flow, stage.dir / "paths.png",
                   title=f"Seed {cfg.seed}: {who} {inlet}")
        plot_energy(named, stage.dir / "energy.png",
                    title=f"Seed {cfg.seed}, wind {inlet}: airspeed, power and energy")
        timings["figures"] = time.perf_counter() - t0
        t0 = time.perf_counter()
        gif = animate_flights({legend_name(v, math.inf): r for v, r in result["results"].items()},
                              city, flow, stage.dir / "flight.gif", n_frames=n_frames, fps=10.0,
                              title=f"{who} {inlet}")
        timings["gif"] = time.perf_counter() - t0
        timings["total"] = time.perf_counter() - t_start
        payload = {"story": "navigate", "config": dataclasses.asdict(cfg), **summary,
                   "gif": {"frames": n_frames, "fps": 10.0,
                           "bytes": gif.stat().st_size}}
        if planned is not None and any(f["reads_model"] for f in planned):
            payload["model_files"] = model_files(read_with)  # the decoder, by hash
        doc = document("demo", payload, args)
        write_json(doc, stage.dir / "summary.json")
        if stage.file("--json") is not None:
            write_json(doc, stage.file("--json"))
    print(describe(summary))
    _warn_variants(args, summary)
    print(f"({timings['total']:.0f} s: wind {timings['flow']:.0f} s, flights "
          f"{sum(timings[v] for v in result['results']):.0f} s, figures and GIF "
          f"{timings['figures'] + timings['gif']:.0f} s)")
    print_written(out)
    return _diverged(args, summary)


def _run_ukf(args) -> int:
    from windnav.experiments.demo import run_demo
    from windnav.experiments.results import write_json
    from windnav.viz.demo import plot_map, plot_wind_estimate

    cfg = _config(args)
    out = outputs(args, out=("--out", args.out, PRODUCTS))
    result = run_demo(cfg, progress=not args.no_progress)
    metrics = {"story": "ukf", "config": dataclasses.asdict(cfg), **result["metrics"]}
    summary = document("demo", metrics, args)
    with out.writing() as stage:
        plot_map(result, stage.dir / "map_wind_path.png")
        plot_wind_estimate(result, stage.dir / "wind_estimate.png")
        result["log"].save(stage.dir / "flight.npz")
        write_json(summary, stage.dir / "summary.json")
        if stage.file("--json") is not None:
            write_json(summary, stage.file("--json"))
    print(json.dumps(metrics, indent=2))
    _warn_ukf_envelope(args, metrics)
    print_written(out)
    return 0


def _warn_variants(args, summary: dict) -> None:
    """:func:`windnav.commands.navigate.warn_envelope` for each variant flown, its lines named
    by the command and the variant (the JSON holds the numbers; the console said only
    ``EA-MPPI+W: success, 4.54 kJ`` of a flight with 1.41 s of extrapolated power)."""
    import math

    from windnav.commands.navigate import warn_envelope
    from windnav.experiments.nav_demo import legend_name

    name = where(args)
    for v, record in summary["variants"].items():
        warn_envelope(record, prefix=f"{name}: {legend_name(v, math.inf)}: ")


def _diverged(args, summary: dict) -> int:
    """1, with an error line naming each, when a flight's simulation diverged (recorded as
    ``left_map`` where it was, as ``windnav navigate`` records and reports it); else 0."""
    import math

    from windnav.experiments.nav_demo import legend_name

    status = 0
    for v, record in summary["variants"].items():
        if record.get("diverged_s") is not None:
            print(f"{where(args)}: error: the simulation ({legend_name(v, math.inf)}) "
                  f"diverged: the vehicle's state stopped being finite at "
                  f"{record['diverged_s']:.2f} s, and the flight, recorded as "
                  f"{record['outcome']!r} where it was, ends there", file=sys.stderr)
            status = 1
    return status


def _warn_ukf_envelope(args, metrics: dict) -> None:
    """One line on stderr when the UKF story's filter reads a drag model that biases it
    (``drag_model_bias_m_s``), and one when its flight left the model's envelope (its status,
    time outside and largest airspeed are in the summary too)."""
    if "drag_model_bias_m_s" in metrics:
        from windnav.commands._common import print_drag_model_note

        print_drag_model_note(metrics["drag_model_bias_m_s"],
                              metrics["median_horizontal_airspeed_m_s"], args.conditions,
                              f"{where(args)}: ", measured=metrics["wind_mean_error_m_s"])
    if "OUTSIDE_ENVELOPE" not in str(metrics.get("status")):
        return
    frac = metrics["outside_envelope_fraction"]
    print(f"{where(args)}: warning: the flight spent {100 * frac:.1f} % of its "
          f"{metrics['flight_duration_s']:.0f} s outside the vehicle model's envelope (status "
          f"{metrics['status']}; largest airspeed {metrics['airspeed_max_m_s']:.2f} m/s, "
          f"trusted up to {metrics['airspeed_limit_m_s']:.2f} m/s), where its aerodynamic model, "
          "the simulated flight's and the Wind UKF's, is not validated", file=sys.stderr)
