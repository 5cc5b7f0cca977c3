"""``windnav wind-sweep``: a dataset of urban flows, maps x speeds x directions, in one Zarr store.

::

    windnav wind-sweep --maps maps/ --out sweep.zarr                 # the thesis grid
    windnav wind-sweep --maps a.json b.json --out s.zarr --speeds 5 10 --directions 4 \\
        --backend process --workers 8

Default inlet grid (the thesis's training data): speeds 0.1, 2.575, 5.05, 7.525, 10.0 m/s x
8 directions 0, 45, ..., 315 deg. The harness is :mod:`windnav.experiments.wind_sweep`;
rerunning the same command after an interruption computes only the simulations not marked done.
``--json`` writes one record per task run now (a map and one direction, or several with the
same inlet sides; its pending cases, with each case's speed and direction) and the counts; the
store itself is never replaced (``--overwrite`` applies to ``--json`` only).

After the sweep every finished case's stored diagnostics are judged by the averaging rule
(:func:`windnav.flow.validity.averaging_verdict`): one ``warning`` names the cases whose mean
is not converged (the sweep runs one time step, set by the fastest inlet, and fixed step
counts, so a slow inlet gets few flow-throughs), one ``note`` those whose mean is young; a
map whose ``--dx`` is above its validated resolution gets a ``note``. The
counts and the cases are in ``--json`` (``summary.not_converged``, ``summary.young``,
``averaging``, ``resolution``).
"""

from __future__ import annotations

import math
import os
import sys
import warnings
from pathlib import Path

from windnav._validate import positive_int
from windnav.commands._common import (
    add_output_arguments,
    check_output_path,
    checked_workers,
    document,
    inlet_direction,
    inlet_speed,
    outputs,
    print_written,
    seed,
    where,
)
from windnav.commands.wind import (
    RESOLUTION_WARNING,
    add_solver_arguments,
    load_city,
    print_resolution_note,
    solver_settings,
)
from windnav.experiments.maps import MAP_KINDS, generated_maps
from windnav.experiments.wind_sweep import (
    THESIS_SPEEDS,
    averaging_summary,
    directions_from,
    sweep,
)

MAX_DIRECTIONS = 360
"""The largest count one ``--directions N`` accepts: 1 deg apart (more is no count of inlet
directions anyone simulates; ``--directions 400`` meant an angle)."""
NAMED_CASES = 10
"""The most cases one averaging warning or note names (``--json`` lists them all)."""


def _map_files(items) -> list[Path]:
    files = []
    for item in items:
        p = Path(item)
        if p.is_dir():
            found = sorted(p.glob("*.json"))
            if not found:
                raise ValueError(f"The '--maps' parameter of windnav wind-sweep names the "
                                 f"folder {item!r}, which holds no .json map.")
            files += found
        else:
            files.append(p)
    return files


def register(subparsers) -> None:
    """Add the ``wind-sweep`` subcommand."""
    p = subparsers.add_parser(
        "wind-sweep",
        help="simulate many maps x inlets into one resumable Zarr dataset",
        description="Run maps x speeds x directions flow simulations into one Zarr store "
                    "(one group per map, one chunk per simulation). Rerun the same command to "
                    "resume after an interruption.",
    )
    p.add_argument("--maps", nargs="+", default=[], metavar="FILE_OR_DIR",
                   help="RotorPy world JSON files, or folders of them (default: none; then give "
                        "--generate)")
    p.add_argument("--generate", type=int, default=0, metavar="K",
                   help="also make K procedural maps (with --map-kind) (default %(default)s)")
    p.add_argument("--map-kind", choices=MAP_KINDS, default=None,
                   help="generator of the --generate maps (default training)")
    p.add_argument("--out", required=True, help="the dataset store (a .zarr directory)")
    p.add_argument("--speeds", nargs="+", type=float, default=list(THESIS_SPEEDS),
                   help="inlet speeds, m/s, each above 0 and at most 100 (default: 0.1 2.575 "
                        "5.05 7.525 10.0)")
    p.add_argument("--directions", nargs="+", type=float, default=None, metavar="N_OR_DEG",
                   help="one value: a COUNT N of directions (an integer, 1 to "
                        f"{MAX_DIRECTIONS}), evenly spaced from 0 deg, 360/N deg apart, never "
                        "an angle (for one direction, give --directions-deg); two or more "
                        "values: the directions themselves, deg (default: 8, i.e. 0 45 ... "
                        "315). Directions are those the wind blows toward, CCW from +x")
    p.add_argument("--directions-deg", nargs="+", type=float, default=None,
                   help="the directions themselves, deg, one or more (use for a single "
                        "direction); not with --directions (default: see --directions)")
    p.add_argument("--backend", choices=("serial", "process", "ray"), default="process",
                   help="where the simulations run (%(default)s)")
    p.add_argument("--workers", type=int, default=None,
                   help="worker count (default: all cores)")
    p.add_argument("--verify", action="store_true",
                   help="also recompute finished simulations whose data no longer reads back")
    p.add_argument("--no-progress", action="store_true", help="hide the progress bar")
    add_solver_arguments(p, "the seed of the --generate maps, recorded with each simulation; "
                            "the solver is deterministic (its symmetry-breaking kick is "
                            "fixed)")
    add_output_arguments(p)
    p.set_defaults(func=run)


def _directions_arg(args):
    name = "windnav wind-sweep"
    if args.directions_deg is not None:
        if args.directions is not None:  # one of them was silently ignored
            raise ValueError("The '--directions' parameter of windnav wind-sweep cannot be given "
                             "with --directions-deg: give one of them. Got both instead.")
        # "'directions' parameter of directions_from" before
        return [inlet_direction(d, "--directions-deg", name) for d in args.directions_deg]
    if args.directions is None:
        return None
    if len(args.directions) == 1:
        n = args.directions[0]
        if not math.isfinite(n) or n != int(n) or not 1 <= n <= MAX_DIRECTIONS:
            # int(nan) raised without the name; --directions 400 was 400 simulations 0.9 deg
            # apart where an angle was meant
            raise ValueError(
                "The '--directions' parameter of windnav wind-sweep must be, as one value, a "
                f"count of directions from 1 to {MAX_DIRECTIONS} (evenly spaced from 0 deg), "
                f"or two or more directions in deg. Got {n:g} instead"
                + (f"; for a single direction of {n:g} deg, give --directions-deg {n:g}."
                   if math.isfinite(n) and abs(n) <= 360 else ".")
            )
        if n > 36:  # "--directions 90" meant 90 deg, and flew 90 directions (CLI audit)
            print(f"windnav wind-sweep: note: --directions {int(n)} is a count: {int(n)} "
                  f"directions, {360 / n:.3g} deg apart; for one direction of {int(n)} deg, "
                  f"give --directions-deg {int(n)}", file=sys.stderr)
        return directions_from(int(n)).tolist()
    return [inlet_direction(d, "--directions", name) for d in args.directions]


def run(args, simulate=None) -> int:
    """Run ``windnav wind-sweep``; returns 0 when every simulation is done, 1 otherwise."""
    from windnav.experiments.results import write_json
    from windnav.flow.sweep_store import SweepMismatchError, SweepStore

    name = where(args)
    seed(args)
    speeds = [inlet_speed(v, "--speeds", name) for v in args.speeds]
    settings = solver_settings(args, max(speeds))
    directions = _directions_arg(args)  # checked, and noted, before the maps are read
    # the same inlet twice simulated it twice into a training store (failure audit)
    for flag, values, same in (("--speeds", speeds, speeds),
                               ("--directions-deg" if args.directions_deg is not None
                                else "--directions", directions or [],
                                [d % 360.0 for d in directions or ()])):
        if len(set(same)) < len(same):
            raise ValueError(f"The '{flag}' parameter of {name} must not repeat a value (a "
                             f"direction modulo 360 deg): each would be simulated again. Got "
                             f"{' '.join(f'{v:g}' for v in values)} instead.")
    maps = [(f.stem, os.path.abspath(f), load_city(f, "--maps", name))
            for f in _map_files(args.maps)]
    if args.generate:
        k = positive_int(args.generate, "--generate", name)
        args.map_kind = args.map_kind or "training"  # as the summary's arguments record it
        maps += generated_maps(k, args.map_kind, seed=args.seed)
    elif args.map_kind is not None:  # ignored before (options audit, 2026-12-05)
        raise ValueError(f"The '--map-kind' parameter of {name} chooses the generator of the "
                         "--generate maps; give --generate K with it, or leave it out.")
    if not maps:  # "'maps' parameter of sweep" before
        raise ValueError(f"The '--maps' parameter of {name} must name at least one map (or "
                         "give --generate N). Got none instead.")
    checked_workers(args, name)  # "'workers' parameter of run_tasks" before
    check_output_path(args.out, "--out", name, kind="dir")
    found = Path(args.out)
    if (found.is_dir() and any(found.iterdir())
            and not any((found / m).is_file() for m in ("zarr.json", ".zgroup"))):
        # (Zarr's "No group found in store" before; CLI audit, 2026-12-07)
        raise ValueError(f"The '--out' parameter of {name} must be a new or empty folder, or "
                         f"the store of a sweep to resume. Got {str(args.out)!r} instead, a "
                         "folder of other files (no zarr.json).")
    out = outputs(args)
    try:
        with warnings.catch_warnings():  # said once per map, at the end, as a note
            warnings.filterwarnings("ignore", message=RESOLUTION_WARNING)
            store, results = sweep(maps, args.out, speeds=speeds,
                                   directions_deg=directions, settings=settings,
                                   backend=args.backend, workers=args.workers, seed=args.seed,
                                   progress=not args.no_progress, verify=args.verify,
                                   simulate=simulate)
    except SweepMismatchError as exc:  # the library's message names no flag; add it here
        raise ValueError(
            f"The '--out' parameter of {name} names {args.out!r}, which already holds a "
            "different sweep (maps, speeds, directions, solver config or seed differ); choose "
            "another --out, or delete it to start over (--overwrite replaces the --json "
            "summary only: a sweep store is never deleted for you)."
        ) from exc
    except KeyboardInterrupt:
        try:
            store = SweepStore(args.out)
        except ValueError:  # interrupted before the store was created
            print(f"{name}: interrupted before any simulation was stored", file=sys.stderr)
            return 130
        total = store.n_maps * store.n_cases
        print(f"interrupted: {total - len(store.pending())}/{total} simulations done in "
              f"{store.path}; rerun the same command to resume.", file=sys.stderr)
        return 130
    failed = [r for r in results if not r.ok]
    total = store.n_maps * store.n_cases
    n_failed = sum(len(r.task.case_indices) for r in failed)
    n_now = sum(len(r.task.case_indices) for r in results) - n_failed
    n_done = total - len(store.pending())
    for r in failed:
        print(f"failed: {r.task.describe()}: {(r.error or '').splitlines()[0]}")
    print(f"{store.path}: {n_done}/{total} simulations done "
          f"({n_now} now, {total - n_now - n_failed} already, {n_failed} failed)")
    averaging = averaging_summary(store)
    print_averaging(averaging, settings, max(speeds), name)
    from windnav.flow.validity import resolution_check

    resolution = [{"map": m, **print_resolution_note(resolution_check(city, settings["dx"]),
                                                     name, f"map {m}: ")}
                  for m, _, city in maps]
    if args.json is not None:
        records = [{"map_index": r.task.map_index, "cases": list(r.task.case_indices),
                    "speeds": list(r.task.speeds),
                    "directions_deg": list(r.task.directions_deg),
                    "ok": r.ok, "seconds": r.seconds, "error": r.error}
                   for r in sorted(results, key=lambda r: r.index)]
        summary = {"store": str(store.path), "simulations": total, "done": n_done,
                   "now": n_now, "already": total - n_now - n_failed, "failed": n_failed,
                   "averaging_checked": averaging["checked"],
                   "not_converged": len(averaging["not_converged"]),
                   "young": len(averaging["young"])}
        with out.writing() as stage:
            write_json(document("wind-sweep", {"records": records, "summary": summary,
                                               "averaging": averaging,
                                               "resolution": resolution}, args),
                       stage.file("--json"))
        print_written(out)
    return 1 if failed else 0


def _named(cases: list) -> str:
    """``map speed m/s toward direction deg`` of the first cases, and how many more."""
    words = [f"map {c['map']} {c['speed']:g} m/s toward {c['direction_deg']:g} deg "
             f"(spin-up {c['flow_throughs_spinup']:.2g}, window "
             f"{c['flow_throughs_average']:.2g} flow-throughs, halves "
             f"{c['half_window_difference']:.2g} U apart)" for c in cases[:NAMED_CASES]]
    more = len(cases) - NAMED_CASES
    return "; ".join(words) + (f"; and {more} more (--json lists them)" if more > 0 else "")


def print_averaging(averaging: dict, settings: dict, max_speed: float, name: str) -> None:
    """One ``warning:`` line (stderr) naming the finished cases whose mean is not converged,
    one ``note:`` line naming those whose mean is young
    (:func:`~windnav.experiments.wind_sweep.averaging_summary`)."""
    from windnav.flow.validity import HALVES_LIMIT, SPINUP_FLOOR, WINDOW_FLOOR

    n = averaging["checked"]
    bad, young = averaging["not_converged"], averaging["young"]
    if bad:
        slower = any(c["speed"] < max_speed for c in bad)
        advice = (f"The sweep runs one time step ({settings['dt']:g} s, set by the fastest "
                  f"inlet, {max_speed:g} m/s) and fixed step counts, so slower inlets get fewer "
                  "flow-throughs: raise --spinup-steps / --steps, or sweep them separately"
                  if slower else "Raise --spinup-steps / --steps")
        print(f"{name}: warning: {len(bad)} of {n} simulations are not converged (spin-up under "
              f"{SPINUP_FLOOR:g} or window under {WINDOW_FLOOR:g} flow-throughs, or halves "
              f"over {HALVES_LIMIT:.0%} of the inlet speed apart): {_named(bad)}. {advice}",
              file=sys.stderr)
    if young:
        print(f"{name}: note: {len(young)} of {n} simulations are young means (spin-up under "
              f"one flow-through): {_named(young)}", file=sys.stderr)
