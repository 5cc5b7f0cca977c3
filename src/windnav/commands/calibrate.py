"""``windnav calibrate``: fit the Wind UKF's drag coefficients from simulated steady flights.

::

    windnav calibrate --vehicle hummingbird --out calib/
    windnav calibrate --vehicle hummingbird --out calib_linear/ --linear   # k_d, k_z only

Flies the vehicle at a range of airspeeds along body x, y and z (hover in a tunnel wind, see
:mod:`windnav.experiments.calibration`), fits ``k_d, k_z`` (and ``c_dx, c_dy, c_dz`` unless
``--linear``) by least squares, prints the fit against the vehicle's true coefficients and
writes ``calibration.json`` (and the flight log ``calibration_log.npz``) into ``--out``.

A coefficient whose true value is 0 (the Crazyflie's parasitic drag ``c_dx, c_dy, c_dz``) has
no relative error: the table prints ``n/a`` with the absolute error, and the JSON's
``relative_error`` holds null for it and ``absolute_error`` the fitted minus the true value
(only for those coefficients).

With ``--linear`` on a vehicle that has frame drag (the Hummingbird), ``k_d`` and ``k_z``
absorb it; the JSON's ``notes`` (and stderr) say by how much and where their drag is wrong
(:func:`windnav.experiments.calibration.calibration_notes`).

A coefficient the flights do not determine (:attr:`windnav.estimate.DragFit.undetermined`: no
airflow along its axis, not separated from another, or at NNLS's bound 0) prints ``nan`` as its
standard error; the fit's notes (and a coefficient of determination below
:data:`windnav.estimate.calibrate.R2_MIN`) come on stderr as ``warning:`` lines, from
:func:`windnav.estimate.fit_drag`, and in the JSON's ``notes``.
"""

from __future__ import annotations

import json
import sys

from windnav._validate import positive_float
from windnav.commands._common import (
    add_output_arguments,
    document,
    options_named,
    outputs,
    path_argument,
    print_written,
    seed,
    where,
)

PRODUCTS = ("calibration.json", "calibration_log.npz")
"""What a run writes into ``--out``."""


def register(subparsers) -> None:
    """Add the ``calibrate`` subcommand."""
    from windnav.commands._choices import VEHICLES

    p = subparsers.add_parser(
        "calibrate",
        help="fit the Wind UKF drag coefficients from simulated steady flights",
        description="Fly a vehicle at several airspeeds along each axis and fit its rotor "
                    "(and parasitic) drag coefficients by least squares.",
    )
    p.add_argument("--vehicle", default="hummingbird", choices=VEHICLES,
                   help="built-in vehicle name (default %(default)s)")
    p.add_argument("--out", type=path_argument, required=True, help="output directory")
    p.add_argument("--seed", type=int, default=0, help="sensor-noise seed (default 0)")
    p.add_argument("--duration", type=float, default=6.0,
                   help="flight time per row, s (default %(default)s)")
    p.add_argument("--settle", type=float, default=3.0,
                   help="samples before this are dropped, s (default %(default)s; below "
                        "--duration)")
    p.add_argument("--linear", action="store_true",
                   help="fit only k_d and k_z (parasitic drag fixed at 0)")
    p.add_argument("--sensor-noise", choices=("windnav", "rotorpy"), default="windnav",
                   help="sensor noise models (default windnav's)")
    add_output_arguments(p)
    p.set_defaults(func=run)


def run(args) -> int:
    """Run the calibration; returns 0."""
    import windnav as wn
    from windnav.estimate.calibrate import fit_drag
    from windnav.experiments.calibration import calibration_flights, calibration_notes
    from windnav.experiments.results import write_json
    from windnav.experiments.ukf_montecarlo import sensor_suite

    name = where(args)
    seed(args)
    truth = wn.vehicle.params(args.vehicle)
    duration = positive_float(args.duration, "--duration", name)
    settle = positive_float(args.settle, "--settle", name, allow_zero=True)
    if settle >= duration:
        raise ValueError(f"The '--settle' parameter of {name} must be below --duration "
                         f"{duration:g}. Got {settle:g} instead.")
    out = outputs(args, out=("--out", args.out, PRODUCTS))
    # (the flights' memory check names the library's knobs; --duration is this command's)
    with options_named({"fly: the log": "the log",
                        "Fly fewer vehicles at once or a shorter flight, log less often "
                        "(log_every) or with fewer sensors": "Give a shorter --duration"}):
        log = calibration_flights(truth, duration=duration, rng=args.seed,
                                  sensors=sensor_suite(100.0, args.sensor_noise))
    with options_named({"'settle_s' parameter of fit_drag": f"'--settle' parameter of {name}"}):
        fit = fit_drag(log, truth, settle_s=settle, parasitic=not args.linear)
    print(f"drag calibration of {truth.name}: {fit.rows_used} rows ({fit.rows_dropped} "
          f"dropped), {fit.n_samples} samples")
    print(f"{'coefficient':<12}{'fitted':>14}{'std err':>12}{'true':>14}{'rel. error':>12}")
    # relative_errors gives fit - true where the truth is 0, which printed as "+0.00%"
    # (CLI audit C: c_dx 2.69e-6 against a true 0): no relative error there, say so
    rel = fit.relative_errors(truth)
    absolute = {k: v - getattr(truth, k) for k, v in fit.coefficients.items()
                if getattr(truth, k) == 0}
    rel = {k: None if k in absolute else e for k, e in rel.items()}
    for k, v in fit.coefficients.items():
        se = fit.stderr.get(k, float("nan"))
        error = (f"  n/a (abs {absolute[k]:+.1e})" if k in absolute
                 else f"{rel[k]:>+12.2%}")
        print(f"{k:<12}{v:>14.4e}{se:>12.2e}{getattr(truth, k):>14.4e}{error}")
    print("residual RMS of the specific force (m/s^2): "
          + ", ".join(f"{a} {r:.4f}" for a, r in zip("xyz", fit.residual_rms, strict=True))
          + f"; R^2 in-plane {fit.r2[0]:.5f}, axial {fit.r2[1]:.5f}")
    notes = calibration_notes(fit, truth)
    record = document("calibrate", {
        "vehicle": truth.name, "seed": args.seed, "fit": json.loads(fit.to_json()),
        "true": {k: getattr(truth, k) for k in fit.coefficients}, "relative_error": rel,
        "absolute_error": absolute, "notes": [*fit.notes, *notes]}, args)
    with out.writing() as stage:
        write_json(record, stage.dir / "calibration.json")
        log.save(stage.dir / "calibration_log.npz")
        if stage.file("--json") is not None:
            write_json(record, stage.file("--json"))
    print_written(out)
    # the linear model's k_d, k_z stand in for the frame drag it lacks (the fit's own notes
    # were fit_drag's warnings, above the table)
    for note in notes:
        print(f"{name}: note: {note}", file=sys.stderr)
    return 0
