"""``windnav ukf-montecarlo``: the Wind UKF Monte Carlo over vehicles and Dryden winds.

::

    windnav ukf-montecarlo --trials 50 --seed 0 --json out.json --plot rmse.png
    windnav ukf-montecarlo --conditions thesis --workers 2 --json thesis.json
    windnav ukf-montecarlo --conditions hardware --workers 2

``--conditions`` picks the sensing and the filter (:data:`windnav.estimate.CONDITIONS`,
``docs/ukf.md``): ``windnav`` (default, the kindest), ``thesis`` (the thesis's Monte Carlo:
RotorPy's sensor arithmetic with accelerometer density 0.38^2, RotorPy's Dryden gusts, no
parasitic drag in the filter), ``thesis-0.038`` (the same with RotorPy's numpy default density
0.038^2) and ``hardware`` (differenced motion-capture acceleration, PWM rotor speeds,
+-5% parameter errors).

Every trial draws a vehicle (mass and drag around the Hummingbird), calibrates its drag, flies a
circle in Dryden gusts and scores the filter's 3D wind RMSE after 2 s (definitions:
:mod:`windnav.experiments.ukf_montecarlo`). Trials run through
:func:`windnav.experiments.run_tasks`; a failing trial is recorded with its error and does not
stop the others. The JSON holds the config, one record per trial, a summary (median,
quartiles) and ``workers``, the worker count the trials ran on (:func:`workers_used`: not more
than the trials left to run); non-finite numbers are written as null.

With ``--json OUT.json``, every finished trial is also appended to ``OUT.partial.jsonl`` as it
finishes: after Ctrl-C (exit 130) or a kill, rerunning the same command runs only the trials
not yet done; the partial file is removed once ``OUT.json`` is written.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

from windnav._validate import positive_float, positive_int
from windnav.commands._choices import CONDITION_NAMES
from windnav.commands._common import (
    add_output_arguments,
    check_figure_format,
    checked_workers,
    document,
    outputs,
    print_written,
    seed,
    where,
)
from windnav.experiments.results import OutputExistsError, write_json

MODULE_DOC = __doc__



MAX_DURATION_S = 3600.0
"""The longest flight ``--duration`` accepts, s (an hour at 200 Hz)."""

MAX_TRIALS = 10_000
"""The most trials ``--trials`` runs: each a calibration and a 20-60 s flight, seconds of CPU
(the docs run 1-50; 10^9 ran on with no output and no end in sight:
CLI audit)."""

MIN_NEES_TRIALS = 5
"""Fewest trials with a NEES from which the command judges the filter's covariance: from one
trial (``--trials 1``) it called it "5.4 x too large" in "these conditions" (statistics
audit)."""

NEES_BAND = (1.5, 6.0)
"""A median NEES outside this band (half and twice the 3 of a consistent 3D estimate) is
noted: the covariance the filter reports is off by more than a factor of two."""


def partial_path(json_path) -> Path:
    """The record log kept next to ``--json`` while the study runs (``OUT.partial.jsonl``)."""
    return Path(json_path).with_suffix(".partial.jsonl")


def workers_used(backend: str, workers: int | None, n_run: int) -> int:
    """The workers ``n_run`` trials ran on, as :func:`windnav.experiments.run_tasks` starts
    them: ``workers`` (default: the CPU count; under Ray, the CPUs of the Ray instance the trials
    ran in) but at most one per trial; 1 serially; 0 when no trial ran (every one resumed).
    ``--workers`` was printed instead, and the CPU count by default: "on 16 workers" for 2
    trials (leftovers, 2026-12-05)."""
    from windnav.experiments.executor import task_workers

    if n_run <= 0:
        return 0
    if backend == "serial":
        return 1
    if backend == "ray":
        import ray

        if ray.is_initialized():  # started for these trials, or joined: its CPUs ran them
            workers = int(ray.cluster_resources().get("CPU", 0)) or None
        workers = workers or os.cpu_count() or 1  # ray.init's own default: every CPU
    return task_workers(backend, workers, n_run)


def register(subparsers) -> None:
    """Add the ``ukf-montecarlo`` subcommand."""
    p = subparsers.add_parser(
        "ukf-montecarlo",
        help="Monte Carlo of the Wind UKF over vehicles (calibrated drag) and Dryden winds",
        description="Draw vehicles around the Hummingbird, calibrate their drag, fly them in "
                    "Dryden gusts and report the 3D wind RMSE of the Wind UKF after 2 s.",
    )
    p.add_argument("--trials", type=int, default=50,
                   help=f"number of trials, at most {MAX_TRIALS} (default 50)")
    p.add_argument("--seed", type=int, default=0, help="study seed (default 0)")
    p.add_argument("--plot", type=Path, default=None,
                   help="write the RMSE vs mass-to-drag ratio plot here (PNG; default: no plot)")
    p.add_argument("--conditions", choices=CONDITION_NAMES, default="windnav",
                   help="sensing and filter preset (default windnav; see docs/ukf.md)")
    p.add_argument("--sensor-noise", choices=("windnav", "rotorpy"), default=None,
                   help="under --conditions windnav only: the sensor suite (default windnav's; "
                        "rotorpy: the earlier study's RotorPy densities)")
    p.add_argument("--vertical-sigma-ratio", type=float, default=None,
                   help="vertical / horizontal gust std (default MIL-F-8785C at 10 m, 0.53, "
                        "for windnav's gusts; 1 for RotorPy's)")
    p.add_argument("--duration", type=float, nargs=2, default=None, metavar=("MIN", "MAX"),
                   help="range of the flight time, s (default 20 60)")
    p.add_argument("--backend", choices=("serial", "process", "ray"), default="process",
                   help="where the trials run (default %(default)s)")
    p.add_argument("--workers", type=int, default=None,
                   help="worker processes (default: CPU count)")
    p.add_argument("--no-progress", action="store_true", help="hide the progress bar")
    add_output_arguments(p)
    p.set_defaults(func=run)


def _config(args):
    from windnav.experiments.ukf_montecarlo import MonteCarloConfig

    name = where(args)
    seed(args)
    if args.sensor_noise is not None and args.conditions != "windnav":
        raise ValueError(f"The '--sensor-noise' parameter of {name} applies to --conditions "
                         f"windnav only (the {args.conditions!r} conditions fix their sensors). "
                         f"Got {args.sensor_noise!r} instead.")
    trials = positive_int(args.trials, "--trials", name)
    if trials > MAX_TRIALS:
        raise ValueError(f"The '--trials' parameter of {name} must be at most {MAX_TRIALS} "
                         "(each trial a calibration and a flight of seconds of CPU). Got "
                         f"{args.trials!r} instead.")
    kw = {"n_trials": trials, "seed": args.seed,
          "sensor_noise": args.sensor_noise, "conditions": args.conditions}
    if args.vertical_sigma_ratio is not None:
        kw["vertical_sigma_ratio"] = positive_float(args.vertical_sigma_ratio,
                                                    "--vertical-sigma-ratio", name,
                                                    allow_zero=True)
    if args.duration is not None:
        settle = MonteCarloConfig.settle_s
        lo, hi = (positive_float(v, "--duration", name) for v in args.duration)
        if not settle < lo <= hi <= MAX_DURATION_S:  # 1e9 s: a 20 TiB MemoryError per trial
            raise ValueError(f"The '--duration' parameter of {name} must be a range MIN MAX "
                             f"with {settle:g} s (the unscored settling time) < MIN <= MAX <= "
                             f"{MAX_DURATION_S:g} s. Got {lo:g} {hi:g} instead.")
        kw["duration"] = (lo, hi)
    checked_workers(args, name)
    return MonteCarloConfig(**kw)


def _record_log(args, config):
    """The record log of ``--json`` (None without it), checked before any trial runs."""
    from windnav.experiments.results import RecordLog, RecordMismatchError
    from windnav.experiments.ukf_montecarlo import draw_trials, recorded_trials, records_header

    if args.json is None:
        return None
    log = RecordLog(partial_path(args.json), records_header(config))
    try:
        n = len(recorded_trials(log.load(), draw_trials(config)))
    except RecordMismatchError:
        if not args.overwrite:
            raise ValueError(
                f"The '--json' parameter of {where(args)} names {str(args.json)!r}, whose "
                f"partial records {str(log.path)!r} belong to another study (trials, seed or "
                "ranges differ); rerun that study to finish it, pass --overwrite to discard "
                "them, or choose another --json.") from None
        log.remove()
        n = 0
    if n:
        print(f"resuming: {n}/{config.n_trials} trials already done in {log.path}",
              file=sys.stderr)
    return log


TRIAL_NOTES = {
    "n_outside_envelope":
        "trials flew outside the vehicle's envelope (trusted airspeed or lift) for part of the "
        "flight: their RMSE is the filter's against extrapolated aerodynamics (each trial's "
        "'outside_envelope_fraction' in --json)",
    "n_saturated_over_1pct":
        "trials saturated their rotors for more than 1 % of the flight (the controller out of "
        "authority: tracking errors of tens of metres are possible): their RMSE is the "
        "filter's on a flight that did not follow its trajectory (each trial's "
        "'saturated_fraction' in --json)",
    "n_calibration_undetermined":
        "trials' calibrations left a drag coefficient undetermined (no airflow along its axis, "
        "not separated, or pinned at 0), which the filter believed as fitted (each trial's "
        "'calibration_undetermined' in --json)",
}
"""The summary's trial counts the command notes, each with what the counted trials mean."""


def run(args) -> int:
    """Run the study; returns 0 when every trial succeeded, 1 otherwise, 130 on Ctrl-C."""
    from windnav.experiments.ukf_montecarlo import THESIS_MEDIAN, quartiles_text, run_montecarlo

    name = where(args)
    config = _config(args)
    check_figure_format(args.plot, "--plot", name)  # before the trials, not after them
    out = outputs(args, files={"--json": args.json, "--plot": args.plot})
    log = _record_log(args, config)
    try:
        result = run_montecarlo(config, backend=args.backend, workers=args.workers,
                                progress=not args.no_progress,
                                records=None if log is None else log.path)
    except KeyboardInterrupt:
        if log is None:
            print(f"{name}: interrupted; finished trials were not kept (pass --json to keep "
                  "them and resume)", file=sys.stderr)
        else:
            n = sum(r.get("error") is None for r in log.load()) if log.path.exists() else 0
            print(f"{name}: interrupted: {n}/{config.n_trials} trials done, kept in "
                  f"{log.path}; rerun the same command to resume", file=sys.stderr)
        return 130
    s = result["summary"]
    n_run = len(result["trials"]) - result["resumed"]
    used = workers_used(args.backend, args.workers, n_run)
    if n_run == 0:
        how = "with no trial left to run"
    elif args.backend == "serial":
        how = "serially"
    else:
        how = f"on {used} worker{'s' if used != 1 else ''}"
        if args.workers is not None and used < args.workers:
            why = ("one per trial left to run" if used == n_run else
                   "the CPUs of the Ray instance")
            how += f" ({args.workers} asked for; {why})"
    print(f"Wind UKF Monte Carlo ({config.conditions} conditions): {len(result['trials'])} "
          f"trials ({result['resumed']} resumed), {result['failed']} failed, "
          f"{result['seconds']:.1f} s {how}")
    if s.get("n"):
        print(f"3D wind RMSE after {config.settle_s:g} s (m/s): median {s['median']:.3f}, "
              f"quartiles {quartiles_text(s)}, mean {s['mean']:.3f}, "
              f"min {s['min']:.3f}, max {s['max']:.3f} (thesis: median {THESIS_MEDIAN:g})")
        print("median per world axis (m/s): "
              + ", ".join(f"{a} {v:.3f}" for a, v in zip("xyz", s["median_axes"], strict=True)))
        nees, n_nees = s.get("nees_median"), s.get("nees_n", 0)
        if nees is not None:
            few = n_nees < MIN_NEES_TRIALS
            print(f"median NEES {nees:.2f} (3 when the filter's reported wind covariance "
                  "matches its errors)" + (f"; from {n_nees} trial{'s' if n_nees > 1 else ''}, "
                                           f"too few to judge it ({MIN_NEES_TRIALS} needed)"
                                           if few else ""))
            if not few and not NEES_BAND[0] <= nees <= NEES_BAND[1]:
                small = nees > 3
                why = ("an error the filter does not model, such as a parameter or drag-model "
                       "bias, or a wind walk q['wind'] too small for the gusts" if small else
                       "a wind walk q['wind'] larger than the gusts need")
                print(f"{name}: note: the filter's reported wind covariance is about "
                      f"{nees / 3 if small else 3 / nees:.2g} x "
                      f"{'too small' if small else 'too large'} for its errors (median NEES "
                      f"{nees:.2f} against 3): intervals from 'wind_cov' are "
                      f"{'too narrow' if small else 'too wide'} in these conditions ({why}; "
                      "each trial's 'nees' in --json)", file=sys.stderr)
        for key, said in TRIAL_NOTES.items():  # (saturated and undetermined: JSON only before)
            if s.get(key):
                print(f"{name}: note: {s[key]} of {s['n']} {said}", file=sys.stderr)
    for t in result["trials"]:
        if t.get("error") is not None:
            first = t["error"].splitlines()[0] if t["error"] else "unknown error"
            print(f"trial {t['index']} failed: {first}", file=sys.stderr)
    try:
        with out.writing() as stage:
            if stage.file("--json") is not None:
                write_json(document("ukf-montecarlo", {**result, "workers": used}, args),
                           stage.file("--json"))
            if stage.file("--plot") is not None:
                from windnav.viz.ukf import plot_montecarlo

                plot_montecarlo(result, stage.file("--plot"))
    except OutputExistsError:  # another run wrote --json meanwhile; this one's are kept
        if log is not None:   # beside it, trials and all: nothing is left to resume
            log.remove()
        raise
    if log is not None:
        log.remove()
    print_written(out)
    return 0 if result["failed"] == 0 else 1
