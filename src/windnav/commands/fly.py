"""``windnav fly``: fly a trajectory in wind; write the FlightLog and PNG plots.

::

    windnav fly --trajectory circle --wind dryden --duration 20 --out out/fly
    windnav fly --dt 0.01 --sensor-rate-hz 100 --json fly.json --overwrite
    windnav fly --conditions thesis --out out/fly_thesis     # + the Wind UKF's RMSE and plot

The harness is :mod:`windnav.experiments.flight`. The controller runs at 100 Hz and the
sensors at their own rates (IMU 200 Hz, odometry and rotor speeds 100 Hz), each lowered to
the fastest rate a physics step ``--dt`` allows; a rate given with ``--control-rate-hz`` or
``--sensor-rate-hz`` must be a whole number of steps. ``--conditions NAME`` (a Wind UKF preset,
``docs/ukf.md``) flies that preset's sensors (all at 100 Hz unless ``--sensor-rate-hz``) and runs
the Wind UKF on the log under it; the summary adds the wind RMSE, and
``flight_wind_estimate.png`` the estimate against the true wind. The exit status is 1 when the
flight diverged, or when the Wind UKF asked for diverged on it (the summary's
``wind_estimate_error`` says why); the files are written either way.
"""

from __future__ import annotations

import json
import math
import sys
import warnings
from pathlib import Path

from windnav._validate import finite_float, positive_float
from windnav.commands._common import (
    add_output_arguments,
    document,
    outputs,
    path_argument,
    print_drag_model_note,
    print_written,
    seed,
    where,
)

PRODUCTS = ("log.npz", "summary.json", "flight_*.png")
"""What a run writes into ``--out``."""


def register(sub) -> None:
    from windnav.commands._choices import CONDITION_NAMES, TRAJECTORIES, VEHICLES, WIND_KINDS

    p = sub.add_parser("fly", help="fly a trajectory in wind and plot it",
                       description="Fly a reference trajectory with the SE(3) controller in a "
                                   "constant or Dryden wind; write log.npz, summary.json, PNGs.")
    p.add_argument("--vehicle", default="hummingbird", choices=VEHICLES,
                   help="vehicle preset (%(default)s)")
    p.add_argument("--wind", default="dryden", choices=WIND_KINDS,
                   help="wind model (%(default)s; none: still air, an error with --wind-mean "
                        "or --wind-sigma)")
    # default None: whether the option was typed (it is an error with a wind that ignores it)
    p.add_argument("--wind-mean", type=float, nargs=3, default=None,
                   metavar=("WX", "WY", "WZ"),
                   help="mean wind, world frame, m/s (3 1 0); constant and dryden only")
    p.add_argument("--wind-sigma", type=float, nargs=3, default=None,
                   metavar=("SX", "SY", "SZ"),
                   help="Dryden gust standard deviations, m/s (1.5 1.5 0.7); dryden only")
    p.add_argument("--trajectory", default="circle", choices=TRAJECTORIES,
                   help="reference trajectory (%(default)s)")
    p.add_argument("--size", type=float, default=3.0,
                   help="circle radius / line length / waypoint square side, m (%(default)s)")
    p.add_argument("--speed", type=float, default=2.0,
                   help="reference speed, m/s (%(default)s; > 0 for a line or waypoints)")
    p.add_argument("--duration", type=float, default=20.0, help="flight time, s (%(default)s)")
    p.add_argument("--dt", type=float, default=0.005,
                   help="physics step, s (%(default)s; the models are validated at 0.005-0.01)")
    p.add_argument("--control-rate-hz", type=float, default=None,
                   help="SE(3) controller rate, Hz; a whole number of --dt steps (default: "
                        "100, or the fastest rate below it that fits --dt)")
    p.add_argument("--sensor-rate-hz", type=float, default=None,
                   help="run every sensor at this rate, Hz; a whole number of --dt steps "
                        "(default: IMU 200 Hz, odometry and rotor speeds 100 Hz, each lowered "
                        "to fit --dt)")
    p.add_argument("--conditions", choices=CONDITION_NAMES, default=None,
                   help="Wind UKF preset: fly its sensors and run the filter under it "
                        "(windnav, thesis, thesis-0.038, hardware; see docs/ukf.md)")
    p.add_argument("--hub-wind", action="store_true",
                   help="sample the wind at each rotor hub instead of the centre of mass")
    p.add_argument("--seed", type=int, default=0,
                   help="seed of the gusts and sensor noise (%(default)s)")
    p.add_argument("--out", type=path_argument, default=Path("out/fly"),
                   help="output folder (%(default)s)")
    p.add_argument("--no-plots", action="store_true", help="write no PNG figures")
    p.add_argument("--no-progress", action="store_true", help="hide the progress bars")
    add_output_arguments(p)
    p.set_defaults(func=run)


def _check_rates(dt: float, control_rate_hz, sensor_rate_hz, name: str) -> None:
    """A rate given on the command line must be a whole number of physics steps ``--dt``."""
    from windnav.experiments.flight import misfit_rates

    rates = {flag: rate for flag, rate in (("--control-rate-hz", control_rate_hz),
                                           ("--sensor-rate-hz", sensor_rate_hz))
             if rate is not None}
    bad = misfit_rates(dt, rates)
    if bad:
        listed = " and ".join(f"{flag} {rate:g} (period {1.0 / rate:g} s)"
                              for flag, rate in bad.items())
        raise ValueError(
            f"The '--dt' parameter of {name} must divide the period of {listed}. Got {dt:g} "
            "instead; use a --dt that does, or lower the rate (left out, each rate fits "
            "itself to --dt).")


WIND_DEFAULTS = {"wind_mean": (3.0, 1.0, 0.0), "wind_sigma": (1.5, 1.5, 0.7)}
"""``--wind-mean`` and ``--wind-sigma`` when not given, m/s."""


def _wind_uses() -> dict:
    """``wind_mean``/``wind_sigma`` -> the ``--wind`` kinds that use each option
    (:data:`windnav.experiments.flight.WIND_USES`): with another, the option is refused."""
    from windnav.experiments.flight import WIND_USES

    return {f"wind_{key}": kinds for key, kinds in WIND_USES.items()}


def _wind_options(args, name: str) -> None:
    """Refuse ``--wind-mean``/``--wind-sigma`` typed with a ``--wind`` that ignores them (``fly
    --wind none --wind-mean 5 0 0`` flew in still air), then fill in their defaults."""
    for key, kinds in _wind_uses().items():
        value = getattr(args, key)
        if value is not None and args.wind not in kinds:
            flag = "--" + key.replace("_", "-")
            what = "still air" if args.wind == "none" else "a steady wind"
            raise ValueError(
                f"The '{flag}' parameter of {name} applies only to --wind "
                f"{' or '.join(kinds)}: --wind {args.wind} flies in {what} and would ignore "
                f"it. Got {flag} {' '.join(f'{v:g}' for v in value)} with --wind {args.wind} "
                "instead.")
        if value is None:
            setattr(args, key, WIND_DEFAULTS[key])


def run(args) -> int:
    from windnav.experiments.flight import make_wind, run_flight
    from windnav.experiments.results import json_ready, write_json

    name = where(args)
    seed(args)
    _wind_options(args, name)
    size = positive_float(args.size, "--size", name)
    duration = positive_float(args.duration, "--duration", name)
    dt = positive_float(args.dt, "--dt", name)
    if round(duration / dt) < 1:
        raise ValueError(f"The '--duration' parameter of {name} must be at least half of --dt "
                         f"({dt:g} s) to fly one step. Got {args.duration!r} instead.")
    # a line or waypoints must get somewhere; a circle at 0 m/s holds its first point
    speed = positive_float(args.speed, "--speed", name,
                           allow_zero=args.trajectory in ("hover", "circle"))
    control = (None if args.control_rate_hz is None
               else positive_float(args.control_rate_hz, "--control-rate-hz", name))
    sensor = (None if args.sensor_rate_hz is None
              else positive_float(args.sensor_rate_hz, "--sensor-rate-hz", name))
    _check_rates(dt, control, sensor, name)
    mean = [finite_float(v, "--wind-mean", name) for v in args.wind_mean]
    sigma = [positive_float(v, "--wind-sigma", name, allow_zero=True) for v in args.wind_sigma]
    from windnav.flow.solver import MAX_SPEED

    for flag, value, size in (("--wind-mean", mean, math.hypot(*mean)),
                              ("--wind-sigma", sigma, max(sigma))):
        if size > MAX_SPEED:  # 1e5 m/s flew, diverged, and exited 0 (options audit)
            raise ValueError(f"The '{flag}' parameter of {name} must be a wind of at most "
                             f"{MAX_SPEED:g} m/s: the vehicle's aerodynamics are "
                             "incompressible-flow models, valid below Mach 0.3. Got "
                             f"{' '.join(f'{v:g}' for v in value)} instead.")
    out = outputs(args, out=("--out", args.out, PRODUCTS))

    uses = {key: args.wind in kinds for key, kinds in _wind_uses().items()}
    wind = make_wind(args.wind, mean if uses["wind_mean"] else (0.0, 0.0, 0.0),
                     sigma if uses["wind_sigma"] else (0.0, 0.0, 0.0), seed=args.seed)
    with warnings.catch_warnings():
        if args.control_rate_hz is None:  # the rate fitted to --dt: its note below says it
            warnings.filterwarnings("ignore", message="run_flight: the controller updates",
                                    category=RuntimeWarning)
        log, metrics, track = run_flight(
            args.vehicle, args.trajectory, wind, size=size, speed=speed, duration=duration,
            dt=dt, control_rate_hz=control, sensor_rate_hz=sensor, hub_wind=args.hub_wind,
            rng=args.seed, conditions=args.conditions, progress=not args.no_progress,
            return_track=True)
    log.meta.update(wind_kind=args.wind)
    status = " ".join(str(s) for s in (metrics.get("status") or []))
    rate = log.meta.get("control_rate_hz")
    if dt > 0.01 and ("SATURATED" in status or "OUTSIDE" in status):  # named the cause nowhere
        print(f"{name}: note: the flight left the envelope ({status}) with a physics step of "
              f"{dt:g} s" + (f" and the controller at {rate:g} Hz" if rate else "")
              + ": the vehicle's models are validated at --dt 0.005-0.01 s with 100 Hz control",
              file=sys.stderr)
    elif args.control_rate_hz is None and rate and rate < 100.0:
        # the rate lowered to fit --dt was said only for a flight that saturated (a mild
        # circle at --dt 0.05 flew at 20 Hz, 0.22 % off in energy, unsaid; discretisation audit)
        print(f"{name}: note: the controller ran at {rate:g} Hz, the fastest rate up to 100 Hz "
              f"whose period is a whole number of --dt {dt:g} s steps; the vehicle's models are "
              "validated with 100 Hz control (--dt 0.005-0.01 s)", file=sys.stderr)
    settled = metrics.get("outside_envelope_fraction_settled", 0.0)
    if settled > 0:  # the status alone read the same for a take-off blip and a whole flight
        limit = (log.meta.get("envelope") or {}).get("max_airspeed")
        limit = limit[0] if isinstance(limit, list) else limit
        print(f"{name}: note: {100 * settled:.3g} % of the flight after its first "
              f"{min(2.0, duration / 2):g} s is outside the vehicle's envelope (largest "
              f"airspeed {metrics['max_airspeed_m_s']:.3g} m/s"
              + (f", trusted to {limit:g} m/s" if limit else "")
              + "): its aerodynamics and power are extrapolated there", file=sys.stderr)
    if args.conditions is not None and metrics.get("wind_rmse_m_s") is not None:
        print_drag_model_note(metrics["drag_model_bias_m_s"],
                              metrics["median_horizontal_airspeed_m_s"], args.conditions,
                              f"{name}: ", measured=metrics.get("wind_mean_error_m_s"))
    failed = metrics.get("non_finite_from_s")
    if failed is not None:  # exit status 0 and a NON_FINITE flag were the only sign (audit)
        print(f"{name}: error: the flight diverged: its state stopped being finite at "
              f"{failed:g} s (mean wind {metrics['mean_wind_speed_m_s']:.3g} m/s); its energy "
              "and power are not reported, and the log holds NaN from there", file=sys.stderr)
    no_estimate = metrics.get("wind_estimate_error")
    if no_estimate and failed is None:  # asked for with --conditions: exit status 0 and a
        # note before (leftover); a diverged flight's error line above already says why
        print(f"{name}: error: no wind estimate: {no_estimate}", file=sys.stderr)
    summary = {"vehicle": args.vehicle, "wind": args.wind, "trajectory": args.trajectory,
               "duration_s": duration, "seed": args.seed, **metrics}
    doc = document("fly", summary, args)
    with out.writing() as stage:
        log.save(stage.dir / "log.npz")
        write_json(doc, stage.dir / "summary.json")
        if not args.no_plots:
            from windnav.viz.flight import plot_flight

            plot_flight(log, stage.dir)
            if track is not None:  # the estimate against the truth, with its 2-sigma band
                from windnav.viz.ukf import plot_wind_track

                plot_wind_track(track, stage.dir / "flight_wind_estimate.png",
                                settle_s=min(2.0, duration / 2))
        if stage.file("--json") is not None:
            write_json(doc, stage.file("--json"))
    print(json.dumps(json_ready(summary), indent=2))
    print_written(out)
    return 0 if failed is None and not no_estimate else 1
