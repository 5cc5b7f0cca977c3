"""``windnav sysid``: the thesis's chapter-6 tools, from data files to coefficients and figures.

::

    windnav sysid thrust-stand --csv stand_*.csv --n-rotors 4 --json stand.json --out out/stand
    windnav sysid aero --log tunnel_log.npz --json aero.json --out out/aero
    windnav sysid aero --csv tunnel.csv --mass 0.044 --out out/aero_csv
    windnav sysid power --csv flight.csv --speed-col speed --power-col power --out out/power
    windnav sysid similitude --full-scale-mass 2000 --full-scale-speed 10 --scale 32
    windnav sysid unsteadiness --log flight.npz --cell 1 --out out/unsteady
    windnav sysid simulate-stand --out out/sim_stand --seed 0
    windnav sysid simulate-tunnel --out out/sim_tunnel --seed 0

Inputs are CSV files (a header line), headerless whitespace tables (``--layout``), FlightLog
``.npz`` files (``--log``) and ROS 1/2 bags (``--bag`` with ``--topic COLUMN=/topic:field``,
through the optional ``rosbags`` package). Every fit writes its JSON (coefficients with 95%
confidence intervals and R^2) and a figure (fitted curves over the data, residuals) into
``--out``, and the JSON also to ``--json`` when given. Output paths are checked before any
computation; earlier results are replaced only with ``--overwrite``. The fits are in
:mod:`windnav.sysid`, the experiments and figures in :mod:`windnav.experiments.sysid`; the
column layouts are in ``docs/sysid.md``.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

from windnav._validate import finite_float, nonnegative_int, positive_float, positive_int
from windnav.commands._common import (
    add_output_arguments,
    document,
    options_named,
    path_argument,
    print_written,
)

PRODUCTS = {
    "thrust-stand": ("thrust_stand.json", "thrust_stand.png"),
    "aero": ("aero.json", "aero.png"),
    "power": ("power.json", "power.png"),
    "unsteadiness": ("unsteadiness.json", "unsteadiness.png"),
    "simulate-stand": ("stand_*.csv", "truth.json"),
    "simulate-tunnel": ("tunnel_log.npz", "tunnel.csv", "truth.json"),
}
"""What each subcommand writes into ``--out``."""


def _steps(lo: float, hi: float, step: float, option: str, name: str, *, most: int):
    """``lo, lo + step, ..., hi`` (rounded to 1e-10), at most ``most`` values: a ValueError
    naming ``option`` before NumPy tries to allocate a step of 1e-9 over 100 units. A step
    that does not divide ``hi - lo`` stops at the last value below ``hi``, with a note on
    stderr (it went one step past ``hi`` when the remainder was over half a step: 0 to 2 by
    0.75 flew 2.25 m/s, beyond --max-speed, unsaid; CLI audit)."""
    import math

    import numpy as np

    if (hi - lo) / step + 1 > most:
        raise ValueError(f"The '{option}' parameter of {name} must give at most {most} values "
                         f"from {lo:g} to {hi:g}. Got a step of {step:g} instead "
                         f"({(hi - lo) / step + 1:.3g} values).")
    n = math.floor((hi - lo) / step + 1e-9) + 1  # (float noise neither adds nor drops hi)
    values = np.round(lo + step * np.arange(n), 10)
    if values[-1] < hi - 1e-9 * step:
        print(f"{name}: note: {option} {step:g} does not divide {lo:g} to {hi:g}: the last "
              f"value is {values[-1]:g}", file=sys.stderr)
    return values


def _where(args) -> str:
    sub = getattr(args, "sysid_command", None)
    return f"windnav {args.command}" + (f" {sub}" if sub else "")


def _outputs(args, name: str):
    from windnav.experiments.results import Outputs

    out = None if getattr(args, "out", None) is None else ("--out", args.out, PRODUCTS[name])
    return Outputs(_where(args), out=out, files={"--json": args.json},
                   overwrite=bool(getattr(args, "overwrite", False)))


def _add_bag_arguments(p) -> None:
    p.add_argument("--bag", type=Path, action="append", default=[], metavar="BAG",
                   help="a ROS 1 (.bag) or ROS 2 (folder) bag; repeat for several (needs the "
                        "rosbags package)")
    p.add_argument("--topic", action="append", default=[], metavar="COLUMN=/topic:field",
                   help="map a message field to a column (repeat); the first topic is the "
                        "time base")


def _bag_tables(args, time_column: str) -> list:
    from windnav.sysid.io import parse_topic_map, read_bag

    if not args.bag:
        if args.topic:
            raise ValueError(f"The '--topic' parameter of {_where(args)} is only for --bag.")
        return []
    topics = parse_topic_map(args.topic, _where(args))
    return [read_bag(b, topics, time_column=time_column, where=_where(args)) for b in args.bag]


def _print(summary: dict, out) -> None:
    from windnav.experiments.results import json_ready

    print(json.dumps(json_ready(summary), indent=2))
    print_written(out)


def _write(args, doc: dict, out, name: str, plot=None) -> None:
    from windnav.experiments.results import write_json

    with out.writing() as stage:
        if stage.dir is not None:
            write_json(doc, stage.dir / f"{name}.json")
            if plot is not None:
                plot(stage.dir / f"{name}.png")
        if stage.file("--json") is not None:
            write_json(doc, stage.file("--json"))


def _coefficients(payload: dict, names) -> dict:
    return {n: {"value": payload[n]["value"], "ci95": payload[n]["ci95"]} for n in names}


# ------------------------------------------------------------------------------ register


def register(sub) -> None:
    p = sub.add_parser("sysid", help="system identification, energetics and similitude",
                       description="The thesis's chapter-6 tools: thrust stand, tunnel hover "
                                   "aerodynamics, power curves, similitude, unsteadiness maps, "
                                   "and simulated experiments that produce their data.")
    ss = p.add_subparsers(dest="sysid_command", required=True, metavar="EXPERIMENT")
    _register_thrust_stand(ss)
    _register_aero(ss)
    _register_power(ss)
    q = ss.add_parser("similitude", help="Froude and Reynolds scaling between a full-scale "
                                         "aircraft and a model")
    add_similitude_arguments(q)
    q.set_defaults(func=run_similitude)
    _register_unsteadiness(ss)
    _register_simulate_stand(ss)
    _register_simulate_tunnel(ss)


# ------------------------------------------------------------------------------ thrust stand


def _register_thrust_stand(ss) -> None:
    p = ss.add_parser("thrust-stand", help="fit k_eta and the PWM motor model to stand logs",
                      description="Keep the steady points (|dw/dt| < --max-accel, w > "
                                  "--min-speed), fit thrust per rotor = k_eta w^2 and "
                                  "w = Kv (V + V0)(PWM - DZ)^(2/3). CSV header: timestamp,pwm,"
                                  "thrust_N,torque_Nm,rpm,voltage_V,current_A (thrust_N: the "
                                  "whole vehicle; rpm: one motor).")
    p.add_argument("--csv", type=Path, nargs="+", default=[], metavar="FILE",
                   help="stand logs, CSV with the header above (default: none; give --csv or "
                        "--bag)")
    _add_bag_arguments(p)
    p.add_argument("--n-rotors", type=int, default=4,
                   help="rotors carrying the measured thrust (%(default)s)")
    p.add_argument("--max-accel", type=float, default=1000.0,
                   help="steady: |dw/dt| below this, rad/s^2 (%(default)s)")
    p.add_argument("--min-speed", type=float, default=250.0,
                   help="steady: w above this, rad/s (%(default)s)")
    p.add_argument("--window-s", type=float, default=0.1,
                   help="window of the dw/dt line fit, s (%(default)s)")
    p.add_argument("--settle-s", type=float, default=0.05,
                   help="steady: at least this long after a PWM change, s (%(default)s; 0: the "
                        "thesis's rule alone, which admits the first sample of a small step "
                        "before the rotor has settled)")
    p.add_argument("--out", type=path_argument, default=Path("out/sysid_thrust_stand"),
                   help="output folder (%(default)s)")
    add_output_arguments(p)
    p.set_defaults(func=run_thrust_stand)


def _stand_tables(args, name: str) -> list:
    """The stand logs, bags first then ``--csv`` files, each with a row whose
    :data:`~windnav.sysid.thrust_stand.STAND_COLUMNS` are all finite: a file of a header alone
    (or of inf thrust throughout) was an IndexError traceback from inside the fit (CLI audit),
    where one such row gets the fit's "no steady point" message."""
    import numpy as np

    from windnav.sysid.io import read_table
    from windnav.sysid.thrust_stand import STAND_COLUMNS

    tables = [("--bag", t) for t in _bag_tables(args, "timestamp")]
    tables += [("--csv", read_table(p, where=name)) for p in args.csv]
    for option, tab in tables:
        tab.require(STAND_COLUMNS, name)
        if not np.logical_and.reduce([np.isfinite(tab.columns[c]) for c in STAND_COLUMNS]).any():
            raise ValueError(f"The file {tab.source!r} given to {name} ({option}) has no row "
                             f"with finite {'/'.join(STAND_COLUMNS)} values: none of its "
                             f"{len(tab)} row(s) can be fitted.")
    return [tab for _, tab in tables]


def run_thrust_stand(args) -> int:
    from windnav.experiments.sysid import plot_thrust_stand, thrust_stand_study

    name = _where(args)
    n_rotors = positive_int(args.n_rotors, "--n-rotors", name)
    max_accel = positive_float(args.max_accel, "--max-accel", name)
    min_speed = positive_float(args.min_speed, "--min-speed", name, allow_zero=True)
    window = positive_float(args.window_s, "--window-s", name)
    settle = positive_float(args.settle_s, "--settle-s", name, allow_zero=True)
    if not args.csv and not args.bag:
        raise ValueError(f"The '--csv' parameter of {name} must name at least one file (or "
                         "give --bag).")
    out = _outputs(args, "thrust-stand")
    fit, payload = thrust_stand_study([], n_rotors, max_accel=max_accel,
                                      min_speed=min_speed, window_s=window, settle_s=settle,
                                      tables=_stand_tables(args, name), where=name)
    doc = document("sysid thrust-stand", payload, args)
    _write(args, doc, out, "thrust_stand", lambda path: plot_thrust_stand(fit, path))
    _print({**_coefficients(payload, ("k_eta", "Kv", "V0", "DZ")), "r2": payload["r2"]}, out)
    for note in payload["notes"]:
        print(f"{name}: note: {note}", file=sys.stderr)
    return 0


# ------------------------------------------------------------------------------ aero


def _register_aero(ss) -> None:
    p = ss.add_parser("aero", help="fit k_d, k_eta, k_z, k_h to hover in a known airflow",
                      description="Lateral: m f_xy = -k_d v_xy sum(eta) + m b; vertical: "
                                  "m f_z = k_eta sum(eta^2) - k_z v_z sum(eta) + N k_h v_h^2. "
                                  "CSV header: time_s,airspeed_x,airspeed_y,airspeed_z,"
                                  "specific_force_x,specific_force_y,specific_force_z,"
                                  "rotor_speed_1,...,rotor_speed_N (SI, body x fwd, y left, "
                                  "z up).")
    p.add_argument("--log", type=Path, nargs="+", default=[], metavar="FILE",
                   help="FlightLog .npz files (IMU specific force, logged airspeed and rotor "
                        "speeds) (default: none; give --log, --csv or --bag)")
    p.add_argument("--csv", type=Path, nargs="+", default=[], metavar="FILE",
                   help="CSV files with the header above (default: none)")
    _add_bag_arguments(p)
    p.add_argument("--mass", type=float, default=None,
                   help="vehicle mass, kg (default: from --vehicle or the log)")
    p.add_argument("--vehicle", default=None,
                   help="take the mass from this vehicle preset (default: none)")
    p.add_argument("--settle-s", type=float, default=None,
                   help="drop log samples before this time, s (default: the log's "
                        "meta['sysid']['settle_s'], else 0)")
    p.add_argument("--average-s", type=float, default=None,
                   help="average consecutive samples over blocks of this many seconds "
                        "before fitting (against noise on rotor speeds and airspeed) "
                        "(default: none, no averaging)")
    p.add_argument("--parasitic", action="store_true",
                   help="fit the frame (parasitic) drag c_Dx, c_Dy, c_Dz with the rest, which "
                        "the thesis's model leaves out (default: the thesis's model, with a "
                        "note when the samples carry frame drag that biases it)")
    p.add_argument("--out", type=path_argument, default=Path("out/sysid_aero"),
                   help="output folder (%(default)s)")
    add_output_arguments(p)
    p.set_defaults(func=run_aero)


POWER_SELECTION = {"max_vertical_speed": 0.3, "max_accel": 0.5, "min_segment_s": 1.0}
"""Defaults of ``sysid power``'s steady-level selection (with ``--time-col``)."""


def _check_power_selection(args, name: str) -> None:
    """The selection of steady level flight runs only with ``--time-col``, and the altitude
    limit only with ``--altitude-col``: given without them, they were accepted, recorded in
    the JSON and ignored, every row fitted (CLI audit, 2026-12-05)."""
    if args.time_col is None:
        given = [f"--{k.replace('_', '-')}" for k in (
            "vertical_speed_col", "altitude_col", "min_altitude", *POWER_SELECTION)
            if getattr(args, k) is not None]
        if given:
            raise ValueError(f"The '--time-col' parameter of {name} must be given with "
                             f"{', '.join(given)}: the selection of steady level flight needs "
                             "the samples' times (without it every row is fitted). Got none "
                             "instead.")
    if args.min_altitude is not None and args.altitude_col is None:
        raise ValueError(f"The '--altitude-col' parameter of {name} must be given with "
                         "--min-altitude. Got none instead.")
    if args.altitude_col is not None and args.min_altitude is None:
        # the column was read and ignored: no limit, every height fitted (API audit follow-up)
        raise ValueError(f"The '--min-altitude' parameter of {name} must be given with "
                         f"--altitude-col (the height the samples must be above, m). Got none "
                         f"with --altitude-col {args.altitude_col!r} instead.")


def _aero_mass(args, logs, name: str) -> float:
    """The mass the fit divides by, kg: ``--mass``, ``--vehicle``'s, or what the logs say; a
    note on stderr when the given one differs from the logs' by more than 10 % (27 for 0.027
    kg gave drag coefficients 600 x too large, unflagged)."""
    from windnav.experiments.sysid import vehicle_names, vehicle_params

    if args.mass is not None and args.vehicle is not None:  # --mass won, unsaid (CLI audit)
        raise ValueError(f"The '--mass' parameter of {name} must not be given with --vehicle, "
                         "which sets the mass too. Got both instead.")
    if args.mass is not None or args.vehicle is not None:
        if args.mass is not None:
            mass, what = positive_float(args.mass, "--mass", name), "--mass"
        else:
            if args.vehicle not in vehicle_names():
                raise ValueError(f"The '--vehicle' parameter of {name} must be one of "
                                 f"{list(vehicle_names())}. Got {args.vehicle!r} instead.")
            mass, what = vehicle_params(args.vehicle).mass, f"--vehicle {args.vehicle}'s mass"
        logged = _logged_mass(logs)
        if logged is not None and abs(mass - logged) > 0.1 * logged:
            print(f"{name}: note: {what} {mass:g} kg differs from the {logged:g} kg the logs "
                  "record; the fitted coefficients scale with it", file=sys.stderr)
        return mass
    logged = _logged_mass(logs)
    if logged is not None:
        return logged
    raise ValueError(f"The '--mass' parameter of {name} must be given (kg): the inputs do "
                     "not say the vehicle's mass (or pass --vehicle).")


def _logged_mass(logs) -> float | None:
    """The vehicle mass the first log that records one gives, kg, or None."""
    from windnav.experiments.sysid import vehicle_names, vehicle_params

    for path, log in logs:
        meta = log.meta
        if "mass" in meta.get("sysid", {}):
            return positive_float(meta["sysid"]["mass"], "meta['sysid']['mass']",
                                  str(path))
        vehicles = meta.get("vehicles") or []
        if vehicles and vehicles[0] in vehicle_names():
            return vehicle_params(vehicles[0]).mass
    return None


AVERAGE_NOTE = (
    "the measured samples (CSV or bag, faster than 20 Hz, not averaged) carry the sensors' noise "
    "in the regressors (airspeed, rotor speeds), which least squares turns into a bias toward "
    "zero that the intervals ignore: on the simulated tunnel's CSVs the 95 % intervals of k_d, "
    "k_z and k_eta covered the truth 51, 57 and 75 % of the time unaveraged, 91-97 % with "
    "--average-s 0.1 (coverage audit, 2026-12-05); average the samples (--average-s 0.1)")
"""The note of ``sysid aero`` on fast measured samples fitted without ``--average-s``."""


def run_aero(args) -> int:
    import numpy as np

    from windnav.experiments.sysid import aero_study, plot_aero
    from windnav.sim import FlightLog
    from windnav.sysid.aero import AeroData, aero_and_status_from_flight_log, block_average
    from windnav.sysid.io import read_table

    name = _where(args)
    if not (args.log or args.csv or args.bag):
        raise ValueError(f"The '--log' parameter of {name} must name at least one file (or "
                         "give --csv or --bag).")
    settle = (None if args.settle_s is None
              else positive_float(args.settle_s, "--settle-s", name, allow_zero=True))
    if settle is not None and not args.log:  # accepted and ignored (CLI audit, 37th session)
        raise ValueError(f"The '--settle-s' parameter of {name} is for flight logs (--log): a "
                         f"--csv or --bag table holds steady samples already. Got "
                         f"{args.settle_s!r} without --log instead.")
    out = _outputs(args, "aero")
    with options_named({"'path' parameter of FlightLog.load": f"'--log' parameter of {name}"}):
        logs = [(p, FlightLog.load(p)) for p in args.log]
    with options_named({"'settle_s' parameter of aero_from_flight_log":
                        f"'--settle-s' parameter of {name}"}):
        parts, status = [], []
        for p, log in logs:
            data, counts = aero_and_status_from_flight_log(log, settle_s=settle, source=str(p))
            parts.append(data)
            status.append(counts)
    tables = [read_table(p, where=name) for p in args.csv] + _bag_tables(args, "time_s")
    measured = [AeroData.from_table(t, name) for t in tables]
    parts += measured
    mass = _aero_mass(args, logs, name)
    noisy = args.average_s is None and any(
        d.t.size > 2 and float(np.median(np.diff(d.t))) < 0.05 for d in measured)
    if args.average_s is not None:
        window = positive_float(args.average_s, "--average-s", name)
        parts = [block_average(p, window) for p in parts]
    fit, payload = aero_study(parts if len(parts) > 1 else parts[0], mass,
                              parasitic=args.parasitic, where=name)
    if logs:
        payload["log_status"], note = _log_status(status)
        if note:
            payload["notes"] = [*payload["notes"], note]
    if noisy:
        payload["notes"] = [*payload["notes"], AVERAGE_NOTE]
    doc = document("sysid aero", payload, args)
    _write(args, doc, out, "aero", lambda path: plot_aero(fit, path))
    summary = _coefficients(payload, ("k_eta", "k_d", "k_z", "k_h"))
    if payload["frame_drag"] is not None:
        summary |= _coefficients(payload["frame_drag"], tuple(payload["frame_drag"]))
    summary["accel_bias"] = {a: payload["accel_bias"][a]["value"] for a in "xy"}
    _print(summary, out)
    for note in payload["notes"]:
        print(f"{name}: note: {note}", file=sys.stderr)
    for assumption in payload["assumptions"]:  # not testable from the data: said once, here
        print(f"{name}: assumption: {assumption}", file=sys.stderr)
    return 0


def _log_status(counts) -> tuple[dict, str | None]:
    """The logs' samples by the FlightStatus of their vehicle, and a note when some vehicle
    was not OK (a 12 m/s campaign fitted 30 of 65 vehicles outside the envelope unflagged)."""
    samples: dict[str, int] = {}
    vehicles: dict[str, int] = {}
    for c in counts:
        for key, total in (("samples", samples), ("vehicles", vehicles)):
            for status, n in c[key].items():
                total[status] = total.get(status, 0) + n
    n_all, n_bad = sum(samples.values()), sum(n for s, n in samples.items() if s != "OK")
    v_all, v_bad = sum(vehicles.values()), sum(n for s, n in vehicles.items() if s != "OK")
    out = {"samples": samples, "vehicles": vehicles, "samples_not_ok": n_bad,
           "vehicles_not_ok": v_bad, "not_ok_kept": True}
    if not n_bad:
        return out, None
    kinds = ", ".join(f"{vehicles[s]} {s}" for s in sorted(vehicles) if s != "OK")
    return out, (f"{n_bad} of the {n_all} log samples come from {v_bad} of {v_all} vehicles "
                 f"whose status is not OK ({kinds}): saturated rotors or flight outside the "
                 "model's envelope (the flag covers the whole flight, the settling included); "
                 "they are kept in the fit")


# ------------------------------------------------------------------------------ power


def _register_power(ss) -> None:
    from windnav.commands._choices import TABLE_LAYOUTS

    p = ss.add_parser("power", help="fit power against speed; hover, endurance, range speeds",
                      description="Fit a polynomial (default a cubic) of power against speed; "
                                  "report hover power, the max-endurance and max-range speeds "
                                  "and the max-range speed in along-track winds. With "
                                  "--time-col, only steady level flight is used.")
    p.add_argument("--csv", type=Path, default=None, metavar="FILE",
                   help="a CSV with a header, or a headerless whitespace table (columns "
                        "named 0, 1, ... or by --layout) (default: none; give --csv or --bag)")
    _add_bag_arguments(p)
    p.add_argument("--layout", default=None, choices=TABLE_LAYOUTS,
                   help="column names of a headerless table (default: none, columns 0, 1, "
                        "...)")
    p.add_argument("--speed-col", required=True, help="speed column, m/s")
    p.add_argument("--power-col", required=True, help="electrical power column, W")
    p.add_argument("--time-col", default=None,
                   help="time column, s: select steady level flight; its values must "
                        "increase from row to row (default: none, every sample is used)")
    p.add_argument("--vertical-speed-col", default=None,
                   help="climb-rate column, m/s (default: none)")
    p.add_argument("--altitude-col", default=None, help="height column, m (default: none)")
    p.add_argument("--min-altitude", type=float, default=None,
                   help="keep samples above, m (default: none, no altitude limit)")
    p.add_argument("--max-vertical-speed", type=float, default=None,
                   help=f"level: |climb rate| below, m/s ({POWER_SELECTION['max_vertical_speed']})")
    p.add_argument("--max-accel", type=float, default=None,
                   help=f"steady: |dV/dt| below, m/s^2 ({POWER_SELECTION['max_accel']})")
    p.add_argument("--min-segment-s", type=float, default=None,
                   help=f"drop steady runs shorter than this, s "
                        f"({POWER_SELECTION['min_segment_s']})")
    p.add_argument("--speed-range", type=float, nargs=2, default=None, metavar=("LO", "HI"),
                   help="fit only the samples with speeds in [LO, HI], m/s (default: all)")
    p.add_argument("--degree", type=int, default=3, help="polynomial degree (%(default)s)")
    p.add_argument("--speed-max", type=float, default=None,
                   help="upper end of the speed searches, m/s (default: the fastest sample)")
    p.add_argument("--wind", type=float, nargs=3, default=(-5.0, 5.0, 1.0),
                   metavar=("MIN", "MAX", "STEP"),
                   help="along-track winds of the range table, m/s (default -5 5 1; > 0 "
                        "tailwind)")
    p.add_argument("--out", type=path_argument, default=Path("out/sysid_power"),
                   help="output folder (%(default)s)")
    add_output_arguments(p)
    p.set_defaults(func=run_power)


def _speed_range(value, name: str):
    if value is None:
        return None
    lo = positive_float(value[0], "--speed-range", name, allow_zero=True)
    hi = positive_float(value[1], "--speed-range", name)
    if hi <= lo:
        raise ValueError(f"The '--speed-range' parameter of {name} must be LO < HI. Got "
                         f"{list(value)} instead.")
    return lo, hi


def run_power(args) -> int:
    from windnav.experiments.sysid import plot_power, power_study
    from windnav.sysid.io import read_table

    name = _where(args)
    degree = positive_int(args.degree, "--degree", name)
    lo, hi, step = (finite_float(v, "--wind", name) for v in args.wind)
    if step <= 0 or hi < lo:
        raise ValueError(f"The '--wind' parameter of {name} must be MIN <= MAX and STEP > 0. "
                         f"Got {list(args.wind)} instead.")
    winds = _steps(lo, hi, step, "--wind", name, most=10_001)
    if (args.csv is None) == (not args.bag):
        raise ValueError(f"The '--csv' parameter of {name} must name one file, or give one "
                         "--bag instead (not both).")
    if len(args.bag) > 1:
        raise ValueError(f"The '--bag' parameter of {name} takes one bag.")
    speed_max = (None if args.speed_max is None
                 else positive_float(args.speed_max, "--speed-max", name))
    _check_power_selection(args, name)
    selection = {k: POWER_SELECTION[k] if getattr(args, k) is None else getattr(args, k)
                 for k in POWER_SELECTION}
    out = _outputs(args, "power")
    table = (read_table(args.csv, layout=args.layout, where=name) if args.csv is not None
             else _bag_tables(args, args.time_col or "time_s")[0])
    # steady_level_mask refuses a clock that does not increase (a reversed or constant time was
    # "no steady level point", others fitted: CLI audit); said here as thrust-stand says it
    with options_named({"The 't' parameter of steady_level_mask must increase from sample to "
                        "sample (its finite values).":
                        f"The column {args.time_col!r} of {table.source!r} (--time-col) must "
                        "increase from row to row."}):
        fit, payload = power_study(
            table, args.speed_col, args.power_col, degree=degree, speed_max=speed_max,
            time_col=args.time_col, vertical_speed_col=args.vertical_speed_col,
            altitude_col=args.altitude_col, min_altitude=args.min_altitude,
            max_vertical_speed=positive_float(selection["max_vertical_speed"],
                                              "--max-vertical-speed", name),
            max_accel=positive_float(selection["max_accel"], "--max-accel", name),
            min_segment_s=positive_float(selection["min_segment_s"], "--min-segment-s", name,
                                         allow_zero=True),
            winds=winds, speed_range=_speed_range(args.speed_range, name), where=name)
    doc = document("sysid power", payload, args)
    title = f"{Path(table.source).name}:\n{args.power_col} vs {args.speed_col}"
    _write(args, doc, out, "power",
           lambda path: plot_power(fit, path, title=title, xlabel=f"{args.speed_col} (m/s)"))
    _print({k: payload[k] for k in ("coefficient_values", "hover_W", "min_power_W",
                                    "max_endurance_speed", "max_range_speed", "hover_ratio",
                                    "r2")}, out)
    for note in payload["notes"]:
        print(f"{name}: note: {note}", file=sys.stderr)
    return 0


# ------------------------------------------------------------------------------ similitude


SIMILITUDE_DEFAULTS = {"strouhal": 0.2, "kinematic_viscosity": 1.5e-5}
"""Defaults of ``similitude``'s ``--strouhal`` and ``--kinematic-viscosity``: another value
without the quantities that use it is refused (:func:`run_similitude`)."""


def add_similitude_arguments(p) -> None:
    """The arguments of ``windnav sysid similitude`` and ``windnav similitude``."""
    p.add_argument("--full-scale-diameter", type=float, default=1.8,
                   help="full-scale rotor diameter, m (%(default)s: the thesis's air taxi)")
    p.add_argument("--model-diameter", type=float, default=0.055,
                   help="model rotor diameter, m (%(default)s: Crazyflie)")
    p.add_argument("--scale", type=float, default=None,
                   help="length scale to use (the thesis rounds 32.7 to 32); default the "
                        "ratio of the diameters")
    p.add_argument("--full-scale-mass", type=float, default=None,
                   help="full-scale mass, kg (default: none, no mass scaling)")
    speed = p.add_mutually_exclusive_group()
    speed.add_argument("--full-scale-speed", type=float, default=None,
                       help="full-scale wind or flight speed, m/s (default: none; or give "
                            "--model-speed)")
    speed.add_argument("--model-speed", type=float, default=None,
                       help="the model's speed, m/s (default: none; or give "
                            "--full-scale-speed)")
    p.add_argument("--control-rate-hz", type=float, default=None,
                   help="the model's control rate, Hz (default: none)")
    p.add_argument("--obstacle-width", type=float, default=None,
                   help="width of the model's obstacle, m (for the shedding frequency; needs a "
                        "speed and --control-rate-hz; default: none)")
    p.add_argument("--strouhal", type=float, default=SIMILITUDE_DEFAULTS["strouhal"],
                   help="Strouhal number of the shedding, dimensionless; another value needs "
                        "--obstacle-width (%(default)s)")
    p.add_argument("--kinematic-viscosity", type=float,
                   default=SIMILITUDE_DEFAULTS["kinematic_viscosity"],
                   help="kinematic viscosity of the air, m^2/s; another value needs a speed "
                        "(%(default)s: air at 20 degC)")
    add_output_arguments(p)


def _check_similitude_inputs(args, name: str) -> None:
    """Refuse the options the report would leave unused: ``--obstacle-width`` without
    ``--control-rate-hz`` or a speed, ``--strouhal`` without ``--obstacle-width``,
    ``--kinematic-viscosity`` without a speed (each was accepted and ignored, the output
    silent about it; CLI audit). A ``--strouhal`` or ``--kinematic-viscosity`` equal to its
    default cannot be told from one not typed, and changes nothing."""
    speed = args.full_scale_speed is not None or args.model_speed is not None
    if args.obstacle_width is not None:
        missing = [what for what, given in (
            ("--control-rate-hz", args.control_rate_hz is not None),
            ("a speed", speed)) if not given]
        if missing:
            raise ValueError(f"The '--obstacle-width' parameter of {name} is for the shedding "
                             "frequency, reported against the control rate: it needs "
                             "--control-rate-hz and a speed (--full-scale-speed or "
                             f"--model-speed). Got {args.obstacle_width!r} without "
                             f"{' and '.join(missing)} instead.")
    if args.strouhal != SIMILITUDE_DEFAULTS["strouhal"] and args.obstacle_width is None:
        raise ValueError(f"The '--strouhal' parameter of {name} is for the shedding of an "
                         "obstacle (--obstacle-width, with --control-rate-hz and a speed). Got "
                         f"{args.strouhal!r} without --obstacle-width instead.")
    if (args.kinematic_viscosity != SIMILITUDE_DEFAULTS["kinematic_viscosity"]
            and not speed):
        raise ValueError(f"The '--kinematic-viscosity' parameter of {name} is for the "
                         "Reynolds numbers of a speed (--full-scale-speed or --model-speed). "
                         f"Got {args.kinematic_viscosity!r} without a speed instead.")


def run_similitude(args) -> int:
    from windnav.experiments.results import Outputs
    from windnav.sysid.similitude import Similitude

    name = _where(args)
    # the library's checks named its parameters ('strouhal' parameter of Similitude.report)
    options = {f"'{param}' parameter of {library} ": f"'--{param.replace('_', '-')}' "
                                                     f"parameter of {name} "
               for library, params in (
                   ("Similitude", ("full_scale_diameter", "model_diameter", "scale")),
                   ("Similitude.report", ("full_scale_speed", "full_scale_mass",
                                          "model_speed", "control_rate_hz", "obstacle_width",
                                          "strouhal", "kinematic_viscosity")))
               for param in params}
    with options_named(options):
        sim = Similitude(positive_float(args.full_scale_diameter, "--full-scale-diameter",
                                        name),
                         positive_float(args.model_diameter, "--model-diameter", name),
                         None if args.scale is None else positive_float(args.scale, "--scale",
                                                                        name))
    # checked here too: the report uses them only with a speed, a control rate and a width
    # (`--obstacle-width -1` and `nan` ran to status 0; CLI audit, thirty-seventh session)
    strouhal = positive_float(args.strouhal, "--strouhal", name)
    positive_float(args.kinematic_viscosity, "--kinematic-viscosity", name)
    for option in ("obstacle_width", "control_rate_hz"):
        if getattr(args, option) is not None:
            positive_float(getattr(args, option), f"--{option.replace('_', '-')}", name)
    _check_similitude_inputs(args, name)
    out = Outputs(name, files={"--json": args.json}, overwrite=bool(args.overwrite))
    with options_named(options):
        report = sim.report(full_scale_speed=args.full_scale_speed,
                            full_scale_mass=args.full_scale_mass, model_speed=args.model_speed,
                            control_rate_hz=args.control_rate_hz,
                            obstacle_width=args.obstacle_width, strouhal=strouhal,
                            kinematic_viscosity=args.kinematic_viscosity)
    doc = document(name.removeprefix("windnav "), report, args)
    _write(args, doc, out, "similitude")
    _print(report, out)
    for note in report["notes"]:
        print(f"{name}: note: {note}", file=sys.stderr)
    return 0


# ------------------------------------------------------------------------------ unsteadiness


def _register_unsteadiness(ss) -> None:
    p = ss.add_parser("unsteadiness", help="bin wind and control activity on an x-y grid",
                      description="Mean wind per bin; std of the lateral force command and "
                                  "mean body-rate magnitude per bin. CSV header: x,y,wind_x,"
                                  "wind_y,force_cmd_x,force_cmd_y,body_rate_x,body_rate_y,"
                                  "body_rate_z (SI, world x-y).")
    p.add_argument("--log", type=Path, nargs="+", default=[], metavar="FILE",
                   help="FlightLog .npz files (default: none; give --log or --csv)")
    p.add_argument("--csv", type=Path, nargs="+", default=[], metavar="FILE",
                   help="CSV files with the header above (default: none)")
    p.add_argument("--wind", choices=("truth", "ukf"), default="truth",
                   help="for logs: the simulator's wind, or the Wind UKF's estimate run on "
                        "the log's sensors (%(default)s)")
    p.add_argument("--vehicle", default=None,
                   help="vehicle preset for k_eta and the UKF (default: the log's)")
    p.add_argument("--cell", type=float, default=1.0, help="bin size, m (%(default)s)")
    p.add_argument("--min-count", type=int, default=5,
                   help="bins with fewer samples are blank (%(default)s)")
    p.add_argument("--out", type=path_argument, default=Path("out/sysid_unsteadiness"),
                   help="output folder (%(default)s)")
    add_output_arguments(p)
    p.set_defaults(func=run_unsteadiness)


def run_unsteadiness(args) -> int:
    from windnav.experiments.sysid import (
        plot_unsteadiness,
        ukf_wind_on_log,
        unsteadiness_study,
        vehicle_names,
        vehicle_params,
    )
    from windnav.sim import FlightLog
    from windnav.sysid.io import read_table
    from windnav.sysid.unsteadiness import (
        UNSTEADINESS_COLUMNS,
        FlightSamples,
        flight_samples_from_log,
    )

    name = _where(args)
    cell = positive_float(args.cell, "--cell", name)
    min_count = positive_int(args.min_count, "--min-count", name)
    if not (args.log or args.csv):
        raise ValueError(f"The '--log' parameter of {name} must name at least one file (or "
                         "give --csv).")
    for option, given in (("--wind", args.wind != "truth"), ("--vehicle", args.vehicle)):
        if given and not args.log:  # a CSV holds its wind and forces (CLI audit, 37th session)
            raise ValueError(f"The '{option}' parameter of {name} is for flight logs (--log): "
                             "a --csv table holds its own wind and forces. Got "
                             f"{getattr(args, option[2:])!r} with --csv only instead.")
    if args.vehicle is not None and args.vehicle not in vehicle_names():
        raise ValueError(f"The '--vehicle' parameter of {name} must be one of "
                         f"{list(vehicle_names())}. Got {args.vehicle!r} instead.")
    out = _outputs(args, "unsteadiness")
    parts = []
    for path in args.log:
        with options_named({"'path' parameter of FlightLog.load":
                            f"'--log' parameter of {name}"}):
            log = FlightLog.load(path)
        flown = (log.meta.get("vehicles") or [None])[0]
        vname = args.vehicle or flown
        if args.vehicle is not None and flown is not None and flown != args.vehicle:
            # the force spread came out 135 x smaller, unflagged (CLI audit 2026-12-05)
            print(f"{name}: note: {str(path)!r} flew {flown!r}, not --vehicle "
                  f"{args.vehicle!r}: its thrust coefficient scales the force spread",
                  file=sys.stderr)
        if vname not in vehicle_names():
            raise ValueError(f"The '--vehicle' parameter of {name} must be given: the log "
                             f"{str(path)!r} flew {vname!r}, not a known preset.")
        params = vehicle_params(vname)
        wind = ukf_wind_on_log(log, params) if args.wind == "ukf" else None
        parts.append(flight_samples_from_log(log, params.k_eta, wind_xy=wind))
    tables = [FlightSamples.from_table(read_table(p, where=name), name) for p in args.csv]
    parts += tables
    samples = FlightSamples.concatenate(parts)
    for path, table in zip(args.csv, tables, strict=True):
        if table.xy.shape[0] == 0 and samples.xy.shape[0] > 0:
            # the other files were binned and this one passed unsaid (CLI audit, 57th session)
            print(f"{name}: note: {str(path)!r} (--csv) has no row with finite "
                  f"{'/'.join(UNSTEADINESS_COLUMNS)} values: it adds no sample",
                  file=sys.stderr)
    if samples.xy.shape[0] == 0:  # "The 'samples' parameter of unsteadiness_maps holds no
        # finite sample." named neither the option nor the file (CLI audit)
        given = [(o, paths) for o, paths in (("--log", args.log), ("--csv", args.csv)) if paths]
        raise ValueError(
            f"The file(s) {', '.join(repr(str(p)) for _, paths in given for p in paths)} given "
            f"to {name} ({' and '.join(o for o, _ in given)}) hold no sample to bin"
            + ("" if args.log else
               f": no row with finite {'/'.join(UNSTEADINESS_COLUMNS)} values") + ".")
    with options_named({"'cell' parameter of unsteadiness_maps": f"'--cell' parameter of {name}",
                        "'min_count' parameter of unsteadiness_maps":
                        f"'--min-count' parameter of {name}"}):
        maps, payload = unsteadiness_study(samples, cell=cell, min_count=min_count)
    payload["wind_source"] = args.wind if args.log else "csv"
    doc = document("sysid unsteadiness", payload, args)
    _write(args, doc, out, "unsteadiness", lambda path: plot_unsteadiness(maps, path))
    _print({k: payload[k] for k in ("n_samples", "occupied_bins", "force_cmd_std_N_max",
                                    "body_rate_mean_rad_s_max")}, out)
    return 0


# ------------------------------------------------------------------------------ simulations


def _vehicle_argument(p) -> None:
    from windnav.commands._choices import VEHICLES
    from windnav.experiments.sysid import THESIS_VEHICLE

    p.add_argument("--vehicle", default=THESIS_VEHICLE, choices=VEHICLES,
                   help="vehicle preset simulated (%(default)s)")


def _register_simulate_stand(ss) -> None:
    from windnav.experiments.sysid import STAND_VOLTAGES

    p = ss.add_parser("simulate-stand", help="simulate the thrust-stand procedure (CSV files)",
                      description="PWM ramp 10k..50k in 5k steps, 1 s each, at each supply "
                                  "voltage; first-order motor driven by the PWM model; noisy "
                                  "thrust, rpm, voltage, current. Writes stand_<V>V.csv and "
                                  "truth.json into --out (V to two decimals: the voltages "
                                  "must differ there).")
    _vehicle_argument(p)
    p.add_argument("--voltages", type=float, nargs="+", default=list(STAND_VOLTAGES),
                   metavar="V", help="supply voltages, V, distinct to two decimals (default "
                                     + " ".join(f"{v:g}" for v in STAND_VOLTAGES) + ")")
    p.add_argument("--rate-hz", type=float, default=100.0, help="log rate, Hz (%(default)s)")
    p.add_argument("--step-s", type=float, default=1.0,
                   help="time per PWM step, s (%(default)s)")
    p.add_argument("--kv", type=float, default=None,
                   help="override the motor model's Kv, rad/s/V/count^(2/3) (default: the "
                        "vehicle's)")
    p.add_argument("--v0", type=float, default=None,
                   help="override V0, V (default: the vehicle's)")
    p.add_argument("--dz", type=float, default=None,
                   help="override DZ, counts (default: the vehicle's)")
    p.add_argument("--seed", type=int, default=0,
                   help="seed of the sensor noise (%(default)s)")
    p.add_argument("--out", type=path_argument, default=Path("out/sysid_simulate_stand"),
                   help="output folder (%(default)s)")
    add_output_arguments(p)
    p.set_defaults(func=run_simulate_stand)


def run_simulate_stand(args) -> int:
    from windnav.experiments.results import write_json
    from windnav.experiments.sysid import (
        MAX_STAND_SAMPLES_PER_STEP,
        simulate_stand,
        stand_clipping_note,
        stand_csv_name,
        vehicle_params,
        write_stand_csvs,
    )
    from windnav.sysid.thrust_stand import PWMMotorModel

    name = _where(args)
    volts = [positive_float(v, "--voltages", name) for v in args.voltages]
    files = [stand_csv_name(v) for v in volts]  # the names write_stand_csvs gives them
    same = sorted({f for f in files if files.count(f) > 1})
    if same:  # 3.7 3.7: truth.json listed both, one CSV was written (CLI audit)
        raise ValueError(f"The '--voltages' parameter of {name} must give distinct voltages "
                         "to two decimals (each ramp is written to stand_<V>V.csv, V to two "
                         f"decimals). Got {[float(v) for v in volts]} instead, whose "
                         f"{', '.join(same)} would be written more than once.")
    rate = positive_float(args.rate_hz, "--rate-hz", name)
    step = positive_float(args.step_s, "--step-s", name)
    per_step = round(step * rate)  # samples per PWM step of the ramp
    most = MAX_STAND_SAMPLES_PER_STEP  # none: CSVs of a header alone; 1e9 Hz: 67 GiB
    if not 1 <= per_step <= most:
        raise ValueError(f"The '--rate-hz' parameter of {name} must give 1 to {most:,} samples "
                         f"per --step-s ({step:g} s). Got {args.rate_hz!r} instead ({per_step} "
                         "samples).")
    params = vehicle_params(args.vehicle)
    overrides = {"Kv": args.kv, "V0": args.v0, "DZ": args.dz}
    if "pwm_motor" in params.extra:
        base = PWMMotorModel.from_params(params).to_dict()
    elif None in overrides.values():  # "'--kv' ... must be given with --v0 and --dz" misled
        given = [f"--{k.lower()}" for k, v in overrides.items() if v is not None]
        raise ValueError(f"The vehicle {args.vehicle!r} has no PWM motor model, so the '--kv', "
                         f"'--v0' and '--dz' parameters of {name} must all be given. Got "
                         f"{'only ' + ' and '.join(given) if given else 'none of them'} "
                         "instead.")
    else:
        base = {}
    spec = {**base, **{k: v for k, v in overrides.items() if v is not None}}
    with options_named({f"'{k}' parameter of PWMMotorModel": f"'--{k.lower()}' parameter of "
                        f"{name}" for k, v in overrides.items() if v is not None}):
        motor = PWMMotorModel(Kv=spec["Kv"], V0=spec["V0"], DZ=spec["DZ"],
                              pwm_max=spec.get("pwm_max", 65535.0))
    out = _outputs(args, "simulate-stand")
    runs = simulate_stand(params, voltages=volts, rate_hz=rate, step_s=step, motor=motor,
                          rng=nonnegative_int(args.seed, "--seed", name))
    note = stand_clipping_note(runs, params)
    truth = {"vehicle": params.name, "n_rotors": params.n_rotors, "k_eta": params.k_eta,
             "tau_m": params.tau_m, "motor": motor.to_dict(), "voltages": volts,
             "rotor_speed_limits_rad_s": [params.rotor_speed_min, params.rotor_speed_max],
             "clipped_samples": sum(r["clipped"] for r in runs), "seed": args.seed,
             "notes": [] if note is None else [note]}
    doc = document("sysid simulate-stand", truth, args)
    with out.writing() as stage:
        write_stand_csvs(runs, stage.dir)
        write_json(doc, stage.dir / "truth.json")
        if stage.file("--json") is not None:
            write_json(doc, stage.file("--json"))
    _print(truth, out)
    for note in truth["notes"]:
        print(f"{name}: note: {note}", file=sys.stderr)
    return 0


def _register_simulate_tunnel(ss) -> None:
    from windnav.experiments.sysid import AXES

    p = ss.add_parser("simulate-tunnel", help="simulate hover in a wind tunnel (log + CSV)",
                      description="Hover (SE(3) control) in steady airflows of 0 ... "
                                  "--max-speed along body axes, IMU with noise and bias. "
                                  "Writes tunnel_log.npz, tunnel.csv (aero CSV with "
                                  "anemometer and telemetry noise) and truth.json.")
    _vehicle_argument(p)
    p.add_argument("--axes", nargs="+", default=["x", "y", "xy", "z", "neg_z"],
                   choices=list(AXES),
                   help="airspeed directions, body axes, each once (%(default)s)")
    p.add_argument("--max-speed", type=float, default=6.0,
                   help="largest airspeed, m/s (%(default)s)")
    p.add_argument("--speed-step", type=float, default=0.5,
                   help="airspeed step from 0 to --max-speed (> 0), at most --max-speed, m/s "
                        "(%(default)s)")
    p.add_argument("--settle-s", type=float, default=2.5,
                   help="transient dropped by the fits, s (%(default)s)")
    p.add_argument("--record-s", type=float, default=1.5,
                   help="recorded hover, s (%(default)s)")
    p.add_argument("--seed", type=int, default=0,
                   help="seed of the sensor noise (%(default)s)")
    p.add_argument("--out", type=path_argument, default=Path("out/sysid_simulate_tunnel"),
                   help="output folder (%(default)s)")
    add_output_arguments(p)
    p.set_defaults(func=run_simulate_tunnel)


def run_simulate_tunnel(args) -> int:

    from windnav.experiments.results import write_json
    from windnav.experiments.sysid import simulate_tunnel, vehicle_params
    from windnav.sysid.io import write_csv

    name = _where(args)
    vmax = positive_float(args.max_speed, "--max-speed", name)  # 0: no airflow, no k_d
    step = positive_float(args.speed_step, "--speed-step", name)
    if step > vmax:  # --speed-step 10 --max-speed 2 flew 0 m/s alone, unsaid (CLI audit)
        raise ValueError(f"The '--speed-step' parameter of {name} must be at most --max-speed "
                         f"({vmax:g} m/s), or only 0 m/s is flown. Got {args.speed_step!r} "
                         "instead.")
    repeated = sorted({a for a in args.axes if args.axes.count(a) > 1})
    if repeated:  # --axes x x flew every condition twice
        raise ValueError(f"The '--axes' parameter of {name} must name each axis once. Got "
                         f"{args.axes} instead ({', '.join(repeated)} repeated).")
    settle = positive_float(args.settle_s, "--settle-s", name, allow_zero=True)
    record = positive_float(args.record_s, "--record-s", name)
    out = _outputs(args, "simulate-tunnel")
    params = vehicle_params(args.vehicle)
    speeds = _steps(0.0, vmax, step, "--speed-step", name, most=1_001)
    log, columns = simulate_tunnel(params, speeds=speeds, axes=args.axes, settle_s=settle,
                                   record_s=record, rng=nonnegative_int(args.seed, "--seed", name))
    truth = {**log.meta["sysid"], "status": log.meta.get("status"), "seed": args.seed}
    note = _tunnel_status_note(log, params)
    truth["notes"] = [] if note is None else [note]
    doc = document("sysid simulate-tunnel", truth, args)
    with out.writing() as stage:
        log.save(stage.dir / "tunnel_log.npz")
        write_csv(stage.dir / "tunnel.csv", columns)
        write_json(doc, stage.dir / "truth.json")
        if stage.file("--json") is not None:
            write_json(doc, stage.file("--json"))
    _print({k: truth[k] for k in ("vehicle", "mass", "true", "settle_s")}, out)
    for note in truth["notes"]:
        print(f"{name}: note: {note}", file=sys.stderr)
    return 0


def _tunnel_status_note(log, params) -> str | None:
    """A note counting the tunnel conditions whose vehicle did not fly OK (--max-speed 12 on
    the Crazyflie: 30 of 65 outside the envelope, said only in truth.json's status list)."""
    from collections import Counter

    from windnav.sim.log import FlightStatus

    codes = [int(c) for c in log.status]
    bad = [i for i, c in enumerate(codes) if c]
    if not bad:
        return None
    kinds = Counter(str(FlightStatus(codes[i]).name) for i in bad)
    conditions = log.meta["sysid"]["conditions"]
    slowest = min(conditions[i]["airspeed_m_s"] for i in bad)
    return (f"{len(bad)} of the {len(codes)} tunnel conditions did not fly OK ("
            + ", ".join(f"{n} {k}" for k, n in sorted(kinds.items()))
            + f"), from {slowest:g} m/s airspeed ({params.name}'s trusted airspeed limit is "
            f"{params.airspeed_limit:.3g} m/s): their samples are in tunnel_log.npz and "
            "tunnel.csv, and sysid aero fits them; see truth.json's status, or lower "
            "--max-speed")
