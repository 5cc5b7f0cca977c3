"""``windnav navigate``: fly a planner variant through a city's urban wind (closed loop).

::

    windnav navigate --map city.json --start 40 300 --goal 560 300 --speed 5 \\
                     --direction-deg 0 --variant ea-mppi-w --seed 0 --out out/nav --json nav.json

The harness is :func:`windnav.experiments.navigate.navigate` (its docstring describes the loop,
the termination rules and the two energies). The wind is simulated first (25 s of spin-up and
100 s of recorded frames on a 1 m grid; ``--spinup-s``, ``--record-s``), which takes about a
minute for a 600 m map. Writes ``summary.json``, ``series.npz`` (the time series) and two
figures: the path over the mean wind, and airspeed, power and energy against time.

``--variant ea-mppi-w-hat`` (EA-MPPI+Ŵ) flies the onboard wind stack of
:mod:`windnav.experiments.onboard` (Wind UKF on the thesis-level simulated sensors at 100 Hz,
decoder at 50 Hz, planner at 10 Hz); its JSON adds the per-stage median times
(``stage_ms_median``), the real-time load (``real_time_fraction``) and the UKF's RMS wind error
(``ukf_wind_rms_mps``), and ``series.npz`` the UKF's estimate (``wind_estimate``). Two of its
settings are ours (:class:`~windnav.experiments.onboard.OnboardOptions`): ``--outside robot``
gives the planner the decoder's ``W_robot`` outside the decoder's window instead of zero, and
``--wrobot-tau S`` averages the UKF's estimate over ``S`` seconds before it becomes ``W_robot``
(the benchmark's ``ea-mppi-w-hat@outside=robot@tau=8``), and ``--rotations-deg 0 -3 3`` flies
the decoder's turned views (the benchmark's ``@views=3``). It flies the shipped decoder, or
``--model FILE`` (a file of ``windnav train-decoder``, or a dated shipped one such as
``src/windnav/predict/data/decoder_2026-11-23.npz``); the JSON's ``model_files`` records the
SHA-256 of the file read (since 2026-12-07), so that
:func:`windnav.provenance.command_line` names the dated file once the shipped model is
replaced. The benchmark's onboard flights were flown with the decoder of 2026-11-23
(``@decoder=`` picks another), so to re-fly one of its records use ``windnav benchmark-nav
--replay SCENARIO_ID --variant V``, which loads the record's decoder (``navigate`` with the
same scenario gives another flight: 1,749.6 against 1,745.2 J in one; pipeline audit,
2026-12-05).

``--variant ea-mppi-w-esc`` (EA-MPPI+W+esc) is EA-MPPI+W with the progress monitor and GS+W
route escape of :mod:`windnav.plan.escape`; its JSON's ``settings.escapes`` lists the escapes.

**Labels and several variants (2026-12-07).** ``--variant`` takes the labels of ``windnav
benchmark-nav`` (:func:`windnav.experiments.nav_benchmark.parse_variant`): the sixth variant
as the benchmark flew it last,
``ea-mppi-w-esc@escair=13.45@edge=15@pace=20@regain=20@launch=40@gust=0.5`` (the bare
``ea-mppi-w-esc`` is its first, 60 m escapes), ``ea-mppi-w@energy=mission``,
``ea-mppi-w-hat@outside=robot@tau=8``, ... Up to :data:`MAX_VARIANTS` of them, separated by
commas, fly the same start, goal and seed in one simulated wind (simulated once); the summary
then holds ``variants`` (label -> the flight's summary), ``reference`` (the first) and
``energy_vs_reference_percent`` (``100 (E_ref - E) / E_ref`` where both reached the goal on
the same power curve, else None and ``energy_not_compared`` says why: one flight each, not a
rate), ``series_K.npz`` the K-th flight's series, and the figures
are ``navigate_paths.png`` and ``navigate_energy.png``. One variant keeps the outputs above.
``--gif-frames N`` also writes ``navigate_flight.gif``, the flights over the unsteady wind (the
demo's animation).
With a label or several variants, ``--horizon``, ``--energy``, ``--outside`` and
``--wrobot-tau`` are refused: each label carries its own (``@h=``, ``@energy=mission``,
``@outside=robot``, ``@tau=``; :func:`flights`). ``--model`` sets the decoder of each onboard
label without ``@decoder=DATE`` (which flies the benchmark's dated file under its boundary rule,
as ``benchmark-nav`` does), and ``--rotations-deg`` turns it for each of those without
``@views=``: a label without ``@decoder=`` flies ``--model`` or the shipped decoder, where
``benchmark-nav`` flies its pinned ``2026-11-23``.
"""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

from windnav._validate import finite_float, positive_float
from windnav.commands._common import (
    add_output_arguments,
    add_rotations_argument,
    document,
    gif_frames,
    inlet_direction,
    inlet_speed,
    load_model,
    model_files,
    outputs,
    path_argument,
    print_written,
    seed,
    where,
)

MAX_VARIANTS = 4
"""The most variants one run flies (``--variant a,b,...``): the colours of the comparison
figures (:data:`windnav.viz.nav_compare.COLORS`)."""

PRODUCTS = ("summary.json", "series.npz", "series_*.npz", "navigate_*.png",
            "navigate_flight.gif")
"""What a run writes into ``--out``."""


def register(sub) -> None:
    from windnav.commands._choices import ENERGY_MODES, NAV_VARIANTS, UNAWARE_VARIANTS

    p = sub.add_parser("navigate", help="fly a planner through a city's urban wind",
                       description="Simulate the map's unsteady wind, then fly the 6-DoF "
                                   "Hummingbird from --start to --goal with a planner variant "
                                   "(closed loop: 10 Hz planner, 100 Hz SE(3) control); report "
                                   "the outcome, the energy and the flight time.")
    p.add_argument("--map", type=Path, required=True, metavar="FILE",
                   help="city map, RotorPy world JSON")
    p.add_argument("--start", type=float, nargs=2, required=True, metavar=("X", "Y"),
                   help="start position, m (more than the 10 m capture radius from --goal)")
    p.add_argument("--goal", type=float, nargs=2, required=True, metavar=("X", "Y"),
                   help="goal position, m")
    p.add_argument("--speed", type=float, required=True,
                   help="inlet wind speed, m/s (above 0, at most 100; above 10 the flow step is "
                        "shortened)")
    p.add_argument("--direction-deg", type=float, default=0.0,
                   help="direction the wind blows toward, deg CCW from +x (%(default)s)")
    p.add_argument("--variant", default="ea-mppi-w", metavar="LABEL[,LABEL...]",
                   help="planner (%(default)s; docs/planner.md): one of "
                        + ", ".join(NAV_VARIANTS)
                        + ", or a label with benchmark-nav's study parameters (e.g. "
                          "ea-mppi-w@energy=mission, ea-mppi-w-esc@escair=13.45); several, "
                          f"separated by commas (at most {MAX_VARIANTS}), fly the same start, "
                          "goal and seed in one simulated wind and are compared with the "
                          "first")
    p.add_argument("--horizon", type=float, default=FLAG_DEFAULTS["horizon"],
                   help="side H of the window in which the -w MPPI variants know the wind, m "
                        "(default: inf, the whole map; ea-mppi-w-hat: the decoder's 25 m grid, "
                        "and at most that)")
    p.add_argument("--energy", choices=ENERGY_MODES, default=FLAG_DEFAULTS["energy"],
                   help="what the energy-aware variants' J_E measures: the planning horizon's "
                        "energy (the thesis) or the mission's, which is least at the "
                        "max-range speed (ours) (%(default)s); 'mission' is an error with "
                        "the variants without an energy term ("
                        + ", ".join(UNAWARE_VARIANTS)
                        + ")")
    p.add_argument("--outside", choices=("zero", "robot"), default=FLAG_DEFAULTS["outside"],
                   help="ea-mppi-w-hat only: the planner's wind outside the decoder's window, "
                        "zero (the thesis) or the decoder's W_robot (ours) (%(default)s)")
    p.add_argument("--wrobot-tau", type=float, default=FLAG_DEFAULTS["wrobot_tau"], metavar="S",
                   help="ea-mppi-w-hat only: time constant of the average of the Wind UKF's "
                        "estimate given as W_robot, s; 0 is the estimate itself, the thesis's "
                        "(%(default)s)")
    p.add_argument("--model", type=Path, default=None, metavar="FILE",
                   help="ea-mppi-w-hat only: the decoder file the onboard stack flies, e.g. "
                        "a model of 'windnav train-decoder' (default: the shipped decoder)")
    add_rotations_argument(p, which="ea-mppi-w-hat only: the onboard stack's --model",
                           boundary=False)
    p.add_argument("--altitude", type=float, default=10.0,
                   help="flight altitude, m (%(default)s; the 2D wind is a slice below the "
                        "roofs)")
    p.add_argument("--tilt-max-deg", type=float, default=55.0,
                   help="tilt cap of the acceleration commands, deg (%(default)s)")
    p.add_argument("--spinup-s", type=float, default=25.0, help="wind spin-up, s (%(default)s)")
    p.add_argument("--record-s", type=float, default=100.0,
                   help="recorded wind, s; the longest flight (%(default)s)")
    p.add_argument("--seed", type=int, default=0,
                   help="seed of the planner and LiDAR noise; the MPPI variants only, the "
                        "graph search (gs, gs-w) draws nothing (%(default)s)")
    p.add_argument("--out", type=path_argument, default=Path("out/navigate"),
                   help="output folder (%(default)s)")
    p.add_argument("--no-plots", action="store_true", help="write no PNG figures")
    p.add_argument("--gif-frames", type=int, default=None, metavar="N",
                   help="also write navigate_flight.gif: the flights over the unsteady wind in "
                        "N frames from take-off to the last landing, 10 per second (default: "
                        "no GIF)")
    p.add_argument("--no-progress", action="store_true",
                   help="hide the wind simulation's progress bar and the line each flight "
                        "starts with")
    add_output_arguments(p)
    p.set_defaults(func=run)


def _city(path: Path, name: str):
    from windnav.city import City

    if not Path(path).is_file():
        raise ValueError(f"The '--map' parameter of {name} must be an existing RotorPy world "
                         f"JSON file. Got {str(path)!r} instead.")
    return City.from_rotorpy_json(path)


def _onboard(args, name: str) -> dict | None:
    """The onboard stack's settings from ``--outside`` and ``--wrobot-tau`` (None: defaults)."""
    from windnav.plan import VARIANTS

    tau = positive_float(args.wrobot_tau, "--wrobot-tau", name, allow_zero=True)
    settings = {k: v for k, v in (("outside", args.outside), ("wrobot_tau_s", tau))
                if v not in ("zero", 0.0)}
    if settings and VARIANTS[args.variant].wind_source != "onboard":
        flags = ", ".join({"outside": "--outside", "wrobot_tau_s": "--wrobot-tau"}[k]
                          for k in settings)
        raise ValueError(f"The {flags} parameter of {name} applies only to the onboard stack "
                         f"(--variant ea-mppi-w-hat). Got --variant {args.variant!r} instead.")
    return settings or None


def _decoder(args, name: str):
    """``--model`` (default the shipped decoder) with ``--rotations-deg`` and the SHA-256 of
    the file read (:func:`~windnav.commands._common.model_files`), for the onboard stack; (None,
    None) for another variant, which reads no decoder (then either option is an error naming
    it). The decoder is None, the stack's default (the shipped decoder as given), where neither
    option is given."""
    from windnav.plan import VARIANTS

    given = [flag for flag, value in (("--model", args.model),
                                      ("--rotations-deg", args.rotations_deg))
             if value is not None]
    if VARIANTS[args.variant].wind_source != "onboard":
        if given:
            raise ValueError(f"The '{given[0]}' parameter of {name} applies only to the "
                             f"onboard stack's decoder (--variant ea-mppi-w-hat). Got "
                             f"--variant {args.variant!r} instead.")
        return None, None
    decoder = load_model(args, name) if given else None
    return decoder, model_files(args)


def energy_aware_variants() -> tuple[str, ...]:
    """The variants whose MPPI cost has an energy term (``Q_E > 0``): the only ones
    ``--energy`` changes (:class:`~windnav.plan.PlannerConfig` ``energy_mode``)."""
    from windnav.plan import VARIANTS

    return tuple(k for k, v in VARIANTS.items() if v.planner == "mppi" and v.energy_weight > 0)


def _energy_mode(args, name: str) -> dict | None:
    """The planner override of ``--energy`` (None: the default, ``horizon``); a ValueError
    when it is given to a variant without an energy term, which would ignore it."""
    if args.energy == "horizon":
        return None
    aware = energy_aware_variants()
    if args.variant not in aware:
        raise ValueError(f"The '--energy' parameter of {name} applies only to the energy-aware "
                         f"variants (--variant {', '.join(aware)}), whose J_E it sets; "
                         f"--variant {args.variant!r} has no energy term and would ignore it. "
                         f"Got --energy {args.energy!r} with --variant {args.variant!r} "
                         "instead.")
    return {"energy_mode": args.energy}


FLAG_LABELS = {"horizon": ("--horizon", "@h=H"), "energy": ("--energy", "@energy=mission"),
               "outside": ("--outside", "@outside=robot"),
               "wrobot_tau": ("--wrobot-tau", "@tau=S")}
"""The options that set one variant's study parameter, with the label parameter that sets it
for each of several (:data:`windnav.experiments.nav_benchmark.PARAMETERS`)."""
FLAG_DEFAULTS = {"horizon": math.inf, "energy": "horizon", "outside": "zero", "wrobot_tau": 0.0}


def labels(args, name: str) -> tuple[str, ...]:
    """``--variant``'s labels, checked (:func:`~windnav.experiments.nav_benchmark.check_variants`:
    distinct, each a variant or a label with study parameters), at most :data:`MAX_VARIANTS`."""
    from windnav.experiments.nav_benchmark import check_variants

    where_ = f"{name} (--variant)"
    try:
        found = check_variants(str(args.variant), where_)
    except ValueError as exc:
        raise ValueError(str(exc).replace(f"'variants' parameter of {where_}",
                                          f"'--variant' parameter of {name}")) from None
    if len(found) > MAX_VARIANTS:
        raise ValueError(f"The '--variant' parameter of {name} must name at most "
                         f"{MAX_VARIANTS} variants (the comparison figures' colours). Got "
                         f"{len(found)} instead: {args.variant!r}.")
    return found


def flights(args, name: str) -> list[dict]:
    """One dict per ``--variant`` label: ``label``, ``base`` (the key of
    :data:`windnav.plan.VARIANTS`), ``kwargs`` (navigate's keyword arguments beyond the
    scenario: ``horizon``, ``tilt_max_deg``, ``onboard``, ``planner_overrides``, ``decoder``,
    and a label's ``power_shape``, ``outside``, ``escape``) and ``reads_model`` (the flight's
    decoder is ``--model`` or the shipped file, whose hash the result records).

    One variant without ``@`` parameters takes ``--horizon``, ``--energy``, ``--outside`` and
    ``--wrobot-tau`` as before. A label with parameters, or several variants, take them from
    each label (:func:`~windnav.experiments.nav_benchmark.parse_variant`, the benchmark's
    grammar), and those options are refused: one run, several variants, would apply them to
    some and not others. ``--model`` gives the decoder of each onboard label without
    ``@decoder=`` (which flies the benchmark's dated file, as ``benchmark-nav`` does), and
    ``--rotations-deg`` turns it for each of those without ``@views=V`` (which turns it by 0 and
    ``+-V`` deg, as ``--rotations-deg 0 -V V``); ``--tilt-max-deg`` is the tilt of each label
    without ``@tilt=``. Each of the three is refused when no label takes it. A label's
    ``@regain`` no larger than the capture radius is refused here, before the wind is
    simulated (:func:`~windnav.experiments.nav_benchmark.check_against_suite`'s rule)."""
    from windnav.experiments.nav_benchmark import flight_decoder, parse_variant
    from windnav.experiments.navigate import CAPTURE_RADIUS, TILT_MAX_DEG
    from windnav.plan import VARIANTS

    found = labels(args, name)
    if len(found) == 1 and "@" not in found[0]:  # (the label as parsed: "mppi," is "mppi")
        base = found[0]
        one = _with(args, variant=base)
        if base.startswith("gs") and float(args.horizon) != float("inf"):  # the whole map
            raise ValueError(f"The '--horizon' parameter of {name} is for the MPPI variants "
                             f"(the graph search plans over the whole map). Got "
                             f"{args.horizon!r} for {base!r} instead.")
        decoder, files = _decoder(one, name)
        return [{"label": base, "base": base, "reads_model": files is not None,
                 "kwargs": {"horizon": float(args.horizon), "tilt_max_deg": args.tilt_max_deg,
                            "onboard": _onboard(one, name),
                            "planner_overrides": _energy_mode(one, name),
                            "decoder": decoder}}]
    for key, (flag, param) in FLAG_LABELS.items():
        value = getattr(args, key)
        if value != FLAG_DEFAULTS[key]:
            what = "several variants" if len(found) > 1 else "a label"
            raise ValueError(f"The '{flag}' parameter of {name} applies to one variant named "
                             f"without parameters; with {what} give it in each label that "
                             f"takes it ('{param}'). Got {flag} "
                             f"{value!r} with --variant {args.variant!r} instead.")
    out, used = [], set()
    for label in found:
        base, options = parse_variant(label, f"{name} (--variant)")
        escape = options.get("escape")
        if escape is not None and escape.regain_inside(CAPTURE_RADIUS):
            raise ValueError(f"The '--variant' parameter of {name} must give regain larger "
                             f"than the capture radius, {CAPTURE_RADIUS:g} m (the hold begins "
                             f"within it). Got {label!r} instead.")
        kwargs = {k: v for k, v in options.items() if k not in ("decoder", "decoder_views")}
        if "tilt_max_deg" not in options:
            kwargs["tilt_max_deg"] = args.tilt_max_deg
            used.add("--tilt-max-deg")
        reads_model = False
        if VARIANTS[base].wind_source == "onboard":
            if "decoder" in options:  # the benchmark's dated file, with its views
                kwargs["decoder"] = flight_decoder(options)
            else:
                views = options.get("decoder_views")
                turned = args.rotations_deg if views is None else [0.0, -views, views]
                used |= {"--model"} | ({"--rotations-deg"} if views is None else set())
                if args.model is not None or turned is not None:
                    kwargs["decoder"] = load_model(_with(args, rotations_deg=turned), name)
                reads_model = True
        out.append({"label": label, "base": base, "kwargs": kwargs,
                    "reads_model": reads_model})
    for flag, value, default, takers in (
            ("--model", args.model, None, "an onboard label without @decoder="),
            ("--rotations-deg", args.rotations_deg, None,
             "an onboard label without @decoder= or @views="),
            ("--tilt-max-deg", args.tilt_max_deg, TILT_MAX_DEG, "a label without @tilt=")):
        if value != default and flag not in used:
            raise ValueError(f"The '{flag}' parameter of {name} applies only to {takers} "
                             f"(ea-mppi-w-hat for the decoder's). Got {flag} {value!r} with "
                             f"--variant {args.variant!r}, where no label takes it, instead.")
    return out


def _with(args, **changes):
    """A copy of ``args`` with ``changes`` (its own attributes kept)."""
    import argparse

    return argparse.Namespace(**{**vars(args), **changes})


def _check_apart(start, goal, name: str) -> None:
    """Refuse a goal within the capture radius of the start: the loop holds the goal from
    take-off there, and ``--start 5 5 --goal 5 5`` reported a "success" after 0.22 m (CLI
    audit)."""
    from windnav.experiments.navigate import CAPTURE_RADIUS

    apart = math.hypot(goal[0] - start[0], goal[1] - start[1])
    if not apart > CAPTURE_RADIUS:
        raise ValueError(f"The '--start' and '--goal' parameters of {name} must be more than "
                         f"the capture radius, {CAPTURE_RADIUS:g} m, apart (within it the "
                         "flight holds the goal from take-off). Got start "
                         f"{[float(v) for v in start]} and goal {[float(v) for v in goal]} "
                         f"instead, {apart:.3g} m apart.")


def _check_horizons(planned, args, name: str) -> None:
    """Refuse an onboard-stack flight's finite horizon wider than its decoder's window (the
    grid it predicts; ``inf`` is the window) before the wind is simulated: navigate refused it
    only after that, naming its own 'horizon' (CLI audit)."""
    from windnav.plan import VARIANTS

    for flight in planned:
        horizon = flight["kwargs"].get("horizon", math.inf)
        if VARIANTS[flight["base"]].wind_source != "onboard" or not (
                isinstance(horizon, (int, float)) and 0 < horizon < math.inf):
            continue
        decoder = flight["kwargs"].get("decoder")
        if decoder is None:  # the stack's default: the shipped decoder
            from windnav.experiments.onboard import default_decoder

            decoder = default_decoder()
        offsets = [float(v) for v in decoder.offsets]
        window = offsets[-1] - offsets[0] + (offsets[1] - offsets[0])  # OnboardStack.window
        if horizon > window + 1e-9:
            single = flight["label"] == flight["base"]
            flag, got = ("--horizon", args.horizon) if single else ("--variant",
                                                                    flight["label"])
            raise ValueError(f"The '{flag}' parameter of {name} must give {flight['base']} a "
                             f"horizon of at most the decoder's window, {window:g} m (or inf: "
                             f"the window). Got {got!r} instead.")


def _check_route(city, start, goal, variant: str, name: str) -> None:
    """For a variant that flies or keeps a GS route, that one exists in still air, before the
    flow simulation: the search refused a start or goal near a wall, or a goal walled in, only
    after the flow (a minute on a 600 m map), naming its own parameters (vehicle audit)."""
    from windnav.experiments.navigate import ROUTE_CLEARANCE, ROUTE_DX
    from windnav.plan import VARIANTS, energy_route, planner_config
    from windnav.vehicle import params

    if VARIANTS[variant].planner != "gs" and not VARIANTS[variant].escape:
        return
    try:  # connectivity does not depend on the wind: the still-air search decides it
        energy_route(city, start, goal, planner_config(params("hummingbird"), "gs"),
                     dx=ROUTE_DX, clearance=ROUTE_CLEARANCE)
    except ValueError as exc:
        raise ValueError(f"The '--start' and '--goal' parameters of {name} must allow the "
                         f"{variant} variant's GS route, which keeps {ROUTE_CLEARANCE:g} m from "
                         f"every building. Got start {list(start)} and goal {list(goal)} "
                         f"instead: {exc}") from None


def run(args) -> int:
    import numpy as np

    from windnav.experiments.nav_demo import compare_energies, describe_comparison, legend_name
    from windnav.experiments.navigate import navigate, simulate_flow
    from windnav.experiments.results import json_ready, write_json

    name = where(args)
    seed(args)
    speed = inlet_speed(args.speed, "--speed", name)
    direction = inlet_direction(args.direction_deg, "--direction-deg", name)
    positive_float(args.altitude, "--altitude", name)
    horizon = float(args.horizon)
    if not horizon > 0:
        raise ValueError(f"The '--horizon' parameter of {name} must be > 0 (inf allowed). "
                         f"Got {args.horizon!r} instead.")
    spinup = positive_float(args.spinup_s, "--spinup-s", name, allow_zero=True)
    from windnav.experiments.navigate import TILT_LIMIT_DEG, check_point

    tilt = finite_float(args.tilt_max_deg, "--tilt-max-deg", name)
    if not 0.0 < tilt < TILT_LIMIT_DEG:
        raise ValueError(f"The '--tilt-max-deg' parameter of {name} must be in "
                         f"(0, {TILT_LIMIT_DEG:g}). Got {args.tilt_max_deg!r} instead.")
    planned = flights(args, name)
    frames = gif_frames(getattr(args, "gif_frames", None), name)
    progress = not getattr(args, "no_progress", False)
    record = positive_float(args.record_s, "--record-s", name)
    start = [finite_float(v, "--start", name) for v in args.start]
    goal = [finite_float(v, "--goal", name) for v in args.goal]
    _check_apart(start, goal, name)
    _check_horizons(planned, args, name)
    city = _city(args.map, name)
    out = outputs(args, out=("--out", args.out, PRODUCTS), inputs={"--map": args.map})

    # check the start and the goal before the (long) flow simulation
    check_point(city, start, "--start", name)
    check_point(city, goal, "--goal", name)
    for flight in planned:
        _check_route(city, start, goal, flight["base"], name)
    from windnav.flow.solver import MAX_CFL

    dt = 0.25  # the thesis's frames; shorter above 10 m/s, where the CFL number would pass 2.5
    if speed * dt > MAX_CFL:
        dt = MAX_CFL / speed
        print(f"{name}: note: the wind is simulated at dt = {dt:.4g} s, not 0.25 s, to keep the "
              f"CFL number at {MAX_CFL:g} at {speed:g} m/s", file=sys.stderr)
    from windnav.flow import MemoryEstimateError

    try:
        flow = simulate_flow(city, speed, direction, spinup_s=spinup, record_s=record, dt=dt,
                             progress=progress)
    except MemoryEstimateError as exc:  # its advice named simulate's dx and memory_limit
        raise MemoryEstimateError(
            f"{exc} Here: {name} simulates the wind on a 1 m grid over the whole map and keeps "
            f"--record-s ({record:g} s) of frames; a shorter --record-s or a smaller map "
            "needs less.") from None
    results, summaries = {}, {}
    for flight in planned:
        if progress:
            print(f"{name}: flying {flight['label']}", file=sys.stderr, flush=True)
        result = navigate(city, start, goal, speed=speed, direction_deg=direction,
                          variant=flight["base"], rng=args.seed, flow=flow,
                          altitude=args.altitude, **flight["kwargs"])
        results[flight["label"]] = result
        summary = result.summary()
        if flight["label"] != flight["base"]:
            summary["label"] = flight["label"]
        summaries[flight["label"]] = summary
    files = model_files(args) if any(f["reads_model"] for f in planned) else None
    if len(planned) == 1:
        summary = {"map": str(args.map), "seed": args.seed, **summaries[planned[0]["label"]]}
    else:
        summary = {"map": str(args.map), "seed": args.seed, "variants": summaries,
                   **compare_energies(summaries, {f["label"]: f["kwargs"].get("power_shape")
                                                  for f in planned})}
    if files is not None:  # the decoder's weights, by hash (windnav.provenance)
        summary["model_files"] = files
    doc = document("navigate", summary, args)
    with out.writing() as stage:
        write_json(doc, stage.dir / "summary.json")
        for k, result in enumerate(results.values(), start=1):
            series = "series.npz" if len(results) == 1 else f"series_{k}.npz"
            _write_series(result, stage.dir / series)
        inlet = f"{speed:g} m/s toward {direction:g} deg"
        if not args.no_plots:
            _plot(results, city, flow, stage.dir, inlet=inlet)
        if frames is not None:
            from windnav.viz.animate import animate_flights

            named = {legend_name(label, width=math.inf): r for label, r in results.items()}
            animate_flights(named, city, flow, stage.dir / "navigate_flight.gif",
                            n_frames=frames, fps=10.0,
                            title=(f"{' vs '.join(named)}, wind {inlet}" if len(named) < 3
                                   else f"Wind {inlet}"))
        if stage.file("--json") is not None:
            write_json(doc, stage.file("--json"))
    keys = ("outcome", "variant", "label", "energy_J", "rotor_energy_J", "time_s",
            "distance_m", "mean_cmd_accel", "planner_ms_median", "fallbacks",
            "stage_ms_median", "real_time_fraction", "ukf_wind_rms_mps", "airspeed_max_mps",
            "outside_envelope_s")
    if len(planned) == 1:
        print(json.dumps(json_ready({k: summary[k] for k in keys if k in summary}), indent=2))
    else:
        print(json.dumps(json_ready({
            "variants": {label: {k: s[k] for k in keys if k in s and k not in ("variant", "label")}
                         for label, s in summaries.items()},
            **{k: summary[k] for k in ("reference", "energy_vs_reference_percent",
                                       "energy_not_compared")}}),
            indent=2))
        print(describe_comparison(summary), file=sys.stderr)
    for label, s in summaries.items():
        warn_envelope(s, prefix=f"{name}: " if len(planned) == 1 else f"{name} ({label}): ")
    tallest = float(np.max(city.heights)) if len(city.heights) else 0.0
    if len(city.heights) and args.altitude > tallest:  # the flight ignored the 3D gap
        print(f"{name}: note: --altitude {args.altitude:g} m is above the tallest building "
              f"({tallest:g} m): the 2D wind is a slice between the buildings, and the planner "
              "still avoids their footprints", file=sys.stderr)
    timed_out = [label for label, s in summaries.items() if s["outcome"] == "timeout"]
    if timed_out:  # the flight lasts as long as the recorded wind
        which = "the flight" if len(planned) == 1 else ", ".join(timed_out)
        print(f"{name}: note: {which} timed out when the recorded wind ended "
              f"({float(flow.t[-1]):g} s, --record-s); a longer record gives it more time",
              file=sys.stderr)
    print_written(out)
    status = 0
    for label, s in summaries.items():
        if s.get("diverged_s") is not None:  # recorded as left_map, status 0 (audit)
            which = "" if len(planned) == 1 else f" ({label})"
            print(f"{name}: error: the simulation{which} diverged: the vehicle's state stopped "
                  f"being finite at {s['diverged_s']:.2f} s, and the flight, recorded as "
                  f"{s['outcome']!r} where it was, ends there", file=sys.stderr)
            status = 1
    return status


def _write_series(result, path) -> None:
    """The flight's time series (``series.npz``; the onboard stack's adds its estimate)."""
    import numpy as np

    extra = {} if result.wind_estimate is None else {"wind_estimate": result.wind_estimate}
    np.savez_compressed(path, t=result.t, position=result.position, velocity=result.velocity,
                        wind=result.wind, airspeed=result.airspeed, accel_cmd=result.accel_cmd,
                        power=result.power, rotor_power=result.rotor_power,
                        energy=result.energy, rotor_energy=result.rotor_energy, **extra)


def _plot(results: dict, city, flow, out_dir, *, inlet: str) -> None:
    """One flight: ``navigate_path.png`` and ``navigate_series.png``; several:
    ``navigate_paths.png`` (every path over the mean wind) and ``navigate_energy.png``
    (airspeed, power and energy, one colour each)."""
    if len(results) == 1:
        from windnav.viz.navigate import plot_navigation

        plot_navigation(next(iter(results.values())), city, flow, out_dir)
        return
    from windnav.experiments.nav_demo import legend_name
    from windnav.viz.nav_compare import plot_energy, plot_paths

    results = {legend_name(label): r for label, r in results.items()}
    plot_paths(results, city, flow, out_dir / "navigate_paths.png",
               title=f"{len(results)} variants, wind {inlet}")
    plot_energy(results, out_dir / "navigate_energy.png",
                title=f"Wind {inlet}: airspeed, power and energy")


def warn_envelope(summary: dict, prefix: str = "") -> None:
    """Say on stderr when the flight left the models' envelope, when the onboard Wind UKF's drag
    model biases its estimate (``ukf_drag_model_bias_mps``), and when it held the goal at its
    tilt cap (the summary's :meth:`~windnav.experiments.navigate.NavigationResult.envelope`);
    each line starts with ``prefix`` (the demo names its command and variant there)."""
    import math
    import sys

    from windnav.experiments.navigate import HOLD_SETTLE_S

    out_s = summary.get("outside_envelope_s") or 0.0
    extra_s = summary.get("power_extrapolated_s") or 0.0
    if out_s > 0 or extra_s > 0:
        settings = summary.get("settings", {})
        print(f"{prefix}warning: the flight spent {out_s:.2f} s above the vehicle's trusted "
              f"airspeed ({settings.get('airspeed_limit', float('nan')):.2f} m/s; largest "
              f"{summary['airspeed_max_mps']:.2f} m/s), where its aerodynamic model is not "
              f"validated, and {extra_s:.2f} s above the power curve's valid range "
              f"({settings.get('power_speed_max', float('nan')):g} m/s), where energy_J "
              "extrapolates it", file=sys.stderr)
    if "ukf_drag_model_bias_mps" in summary:  # the onboard stack's Wind UKF
        from windnav.commands._common import print_drag_model_note

        print_drag_model_note(summary["ukf_drag_model_bias_mps"],
                              summary["ukf_median_airspeed_mps"],
                              summary.get("onboard", {}).get("conditions", "onboard"), prefix)
    settings = summary.get("settings", {})
    route_air = settings.get("route_airspeed_max_mps", 0.0)
    if route_air > min(settings.get("airspeed_limit", math.inf),
                       settings.get("power_speed_max", math.inf)):  # the search has no cap
        print(f"{prefix}warning: the route is planned at up to {route_air:.3g} m/s of airspeed, "
              f"above the vehicle's trusted {settings.get('airspeed_limit', math.inf):.3g} m/s "
              f"or its power curve's valid {settings.get('power_speed_max', math.inf):.3g} m/s: "
              "its energy and time "
              "(route_energy_J, route_time_s) rest on the curve's continuation",
              file=sys.stderr)
    capped_s = summary.get("goal_hold_at_cap_settled_s") or 0.0  # not the capture's braking
    if capped_s > 0:
        print(f"{prefix}warning: for {capped_s:.2f} s near the goal (within "
              f"{settings.get('capture_radius', float('nan')):g} m, after the first "
              f"{HOLD_SETTLE_S:g} s of the hold) the hold's command was at the "
              f"{settings.get('tilt_max_deg', float('nan')):g} deg tilt cap: the wind there "
              "was more than the vehicle can hold against", file=sys.stderr)
