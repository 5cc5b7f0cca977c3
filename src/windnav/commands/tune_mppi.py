"""``windnav tune-mppi``: tune MPPI's base hyperparameters with Optuna on the intersection case
without wind, as the thesis did before fixing them for every variant.

::

    windnav tune-mppi --trials 20 --seed 0 --out docs/navigation/tuning

Flies MPPI through the intersection of
:func:`windnav.experiments.tune_mppi.intersection_case` in still air for each trial's
``lambda``, ``sigma_u``, ``sigma_gf`` and ``Q_O`` (flight seeds 0, 1, 2), with Optuna's TPE
sampler seeded by ``--seed``; trial 0 is the thesis defaults. Writes ``tune_mppi.json`` (every
trial's parameters, cost and flights, the best, the defaults' cost) and ``tune_mppi.png`` into
``--out``, and prints the best parameters and the defaults' cost. Needs the ``tune`` extra
(``pip install 'windnav[tune]'``).
"""

from __future__ import annotations

import json
from pathlib import Path

from windnav._validate import nonnegative_int, positive_int
from windnav.commands._common import (
    add_output_arguments,
    document,
    outputs,
    print_written,
    seed,
    where,
)

PRODUCTS = ("tune_mppi.json", "tune_mppi.png")
"""What a run writes into ``--out``."""


def register(subparsers) -> None:
    """Add the ``tune-mppi`` subcommand."""
    p = subparsers.add_parser(
        "tune-mppi",
        help="tune MPPI's base hyperparameters with Optuna (intersection, no wind)",
        description="Tune MPPI's base hyperparameters (lambda, sigma_u, sigma_gf, Q_O) with "
                    "Optuna's TPE sampler on the intersection case without wind; trial 0 is "
                    "the thesis defaults. Writes tune_mppi.json and tune_mppi.png into --out. "
                    "Needs the 'tune' extra: pip install 'windnav[tune]'.",
    )
    p.add_argument("--trials", type=int, default=20,
                   help="Optuna trials, >= 2; the first flies the defaults (%(default)s)")
    p.add_argument("--seed", type=int, default=0, help="seed of the TPE sampler (%(default)s)")
    p.add_argument("--flight-seeds", type=int, default=3,
                   help="flights per trial, seeds 0..N-1 (%(default)s)")
    p.add_argument("--holdout", type=int, default=0,
                   help="then fly the best and the default parameters on N further seeds "
                        "(N..): the tuned parameters checked on flights the study never saw "
                        "(%(default)s)")
    p.add_argument("--out", type=Path, required=True, help="output folder (JSON, figure)")
    p.add_argument("--no-progress", action="store_true", help="hide the per-trial lines")
    add_output_arguments(p)
    p.set_defaults(func=run)


def run(args) -> int:
    """Run ``windnav tune-mppi``; 0 when the study finished."""
    from windnav.experiments import tune_mppi
    from windnav.experiments.results import json_ready, write_json

    name = where(args)
    tune_mppi.require_optuna()  # a missing extra is reported before anything is written
    trials = positive_int(args.trials, "--trials", name)
    if trials < 2:  # the defaults alone were reported as the best of one (statistics audit)
        raise ValueError(f"The '--trials' parameter of {name} must be at least 2 (the first "
                         f"trial flies the defaults). Got {trials} instead.")
    n_seeds = positive_int(args.flight_seeds, "--flight-seeds", name)
    holdout = nonnegative_int(args.holdout, "--holdout", name)  # 0: no held-out seeds
    sampler_seed = seed(args)
    out = outputs(args, out=("--out", args.out, PRODUCTS))
    res = tune_mppi.tune(trials, seed=sampler_seed, seeds=range(n_seeds),
                         progress=not args.no_progress)
    if holdout:
        fresh = range(n_seeds, n_seeds + holdout)
        res["holdout"] = {"seeds": list(fresh), **{
            k: {"cost": e["cost"], "successes": sum(f["outcome"] == "success"
                                                    for f in e["flights"])}
            for k, e in (("best", tune_mppi.evaluate(res["best_params"], seeds=fresh)),
                         ("defaults", tune_mppi.evaluate(res["defaults"], seeds=fresh)))}}
    from windnav.viz.tune import plot_tuning

    with out.writing() as stage:
        plot_tuning(res, stage.dir / PRODUCTS[1])
        doc = document("tune-mppi", res, args)
        write_json(doc, stage.dir / PRODUCTS[0])
        if stage.file("--json") is not None:
            write_json(doc, stage.file("--json"))
    print(json.dumps(json_ready({
        "best_params": res["best_params"], "best_cost_s": res["best_cost"],
        "best_trial": res["best_trial"], "defaults": res["defaults"],
        "defaults_cost_s": res["defaults_cost"], "trials": res["n_trials"],
        "holdout": res.get("holdout"),
        "elapsed_s": round(res["elapsed_s"], 1)}), indent=1))
    print_written(out)
    return 0
