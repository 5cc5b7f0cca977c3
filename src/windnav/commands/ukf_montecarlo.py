"""``windnav ukf-montecarlo``: the Wind UKF Monte Carlo over vehicles and Dryden winds.

::

    windnav ukf-montecarlo --trials 50 --seed 0 --json out.json --plot rmse.png
    windnav ukf-montecarlo --trials 50 --sensor-noise rotorpy --workers 2

Every trial draws a vehicle (mass and drag around the Hummingbird), calibrates its drag, flies a
circle in Dryden gusts and scores the filter's 3D wind RMSE after 2 s (definitions:
:mod:`windnav.experiments.ukf_montecarlo`). Trials run through
:func:`windnav.experiments.run_tasks`; a failing trial is recorded with its error and does not
stop the others. The JSON holds the config, one record per trial and a summary (median,
quartiles); non-finite numbers are written as null.
"""

from __future__ import annotations

import json
import math
import os
import sys
from pathlib import Path

from windnav._validate import positive_float, positive_int

MODULE_DOC = __doc__


def _clean(obj):
    """JSON-safe copy: non-finite floats -> None, tuples -> lists."""
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else None
    if isinstance(obj, dict):
        return {str(k): _clean(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_clean(v) for v in obj]
    return obj


def write_json(result: dict, path) -> Path:
    """Write ``result`` atomically as JSON; returns the path."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(json.dumps(_clean(result), indent=1))
    tmp.replace(path)
    return path


def register(subparsers) -> None:
    """Add the ``ukf-montecarlo`` subcommand."""
    p = subparsers.add_parser(
        "ukf-montecarlo",
        help="Monte Carlo of the Wind UKF over vehicles (calibrated drag) and Dryden winds",
        description="Draw vehicles around the Hummingbird, calibrate their drag, fly them in "
                    "Dryden gusts and report the 3D wind RMSE of the Wind UKF after 2 s.",
    )
    p.add_argument("--trials", type=int, default=50, help="number of trials (default 50)")
    p.add_argument("--seed", type=int, default=0, help="study seed (default 0)")
    p.add_argument("--json", type=Path, default=None, help="write records + summary here")
    p.add_argument("--plot", type=Path, default=None,
                   help="write the RMSE vs mass-to-drag ratio plot here (PNG)")
    p.add_argument("--sensor-noise", choices=("windnav", "rotorpy"), default="windnav",
                   help="sensor noise models (default windnav's; rotorpy: RotorPy's defaults)")
    p.add_argument("--vertical-sigma-ratio", type=float, default=None,
                   help="vertical / horizontal gust std (default MIL-F-8785C at 10 m, 0.53)")
    p.add_argument("--backend", choices=("serial", "process", "ray"), default="process")
    p.add_argument("--workers", type=int, default=None,
                   help="worker processes (default: CPU count)")
    p.add_argument("--no-progress", action="store_true", help="hide the progress bar")
    p.set_defaults(func=run)


def run(args) -> int:
    """Run the study; returns 0 when every trial succeeded, 1 otherwise."""
    from windnav.experiments.ukf_montecarlo import MonteCarloConfig, run_montecarlo

    where = "windnav ukf-montecarlo"
    kw = {"n_trials": positive_int(args.trials, "--trials", where), "seed": args.seed,
          "sensor_noise": args.sensor_noise}
    if args.vertical_sigma_ratio is not None:
        kw["vertical_sigma_ratio"] = positive_float(args.vertical_sigma_ratio,
                                                    "--vertical-sigma-ratio", where,
                                                    allow_zero=True)
    if args.workers is not None:
        positive_int(args.workers, "--workers", where)
    config = MonteCarloConfig(**kw)
    result = run_montecarlo(config, backend=args.backend, workers=args.workers,
                            progress=not args.no_progress)
    s = result["summary"]
    print(f"Wind UKF Monte Carlo: {len(result['trials'])} trials, {result['failed']} failed, "
          f"{result['seconds']:.1f} s on {args.workers or os.cpu_count()} workers")
    if s.get("n"):
        print(f"3D wind RMSE after {config.settle_s:g} s (m/s): median {s['median']:.3f}, "
              f"quartiles {s['q1']:.3f} / {s['q3']:.3f}, mean {s['mean']:.3f}, "
              f"min {s['min']:.3f}, max {s['max']:.3f}")
        print("median per world axis (m/s): "
              + ", ".join(f"{a} {v:.3f}" for a, v in zip("xyz", s["median_axes"], strict=True)))
    for t in result["trials"]:
        if "error" in t:
            first = t["error"].splitlines()[0] if t["error"] else "unknown error"
            print(f"trial {t['index']} failed: {first}", file=sys.stderr)
    if args.json is not None:
        print(f"wrote {write_json(result, args.json)}")
    if args.plot is not None:
        from windnav.viz.ukf import plot_montecarlo

        print(f"wrote {plot_montecarlo(result, args.plot)}")
    return 0 if result["failed"] == 0 else 1
