"""Benchmark: the full Wind UKF Monte Carlo (50 trials, seed 0) against the thesis' level.

Runs :func:`windnav.experiments.ukf_montecarlo.run_montecarlo` with windnav's sensor models and
with RotorPy's (noisier) default sensors, on the process backend, and reports the median and
quartiles of the 3D wind RMSE after 2 s next to the thesis' Monte Carlo median (0.5 m/s; ratio
ours / thesis), plus wall time and the parallel speed-up (sum of per-trial times / wall time).
Appends the table to docs/benchmarks.md.

    .venv/bin/python benchmarks/bench_ukf_montecarlo.py [--trials 50] [--seed 0] [--workers 2]
        [--out DIR]   # also write each study's JSON and RMSE plot there
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from windnav.experiments.results import write_json
from windnav.experiments.ukf_montecarlo import MonteCarloConfig, quartiles_text, run_montecarlo
from windnav.viz.ukf import plot_montecarlo

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _record import append_record  # noqa: E402

THESIS_MEDIAN = 0.5
"""Median 3D wind RMSE of the thesis' Monte Carlo, m/s."""


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--trials", type=int, default=50)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--out", type=Path, default=None)
    ap.add_argument("--no-record", action="store_true",
                    help="print the table only; do not append docs/benchmarks.md")
    args = ap.parse_args()
    rows = ["| sensors | trials ok | median RMSE (m/s) | quartiles (m/s) | max (m/s) | "
            "median / thesis 0.5 | wall (s) | speed-up |",
            "|---|---|---|---|---|---|---|---|"]
    for noise in ("windnav", "rotorpy"):
        cfg = MonteCarloConfig(n_trials=args.trials, seed=args.seed, sensor_noise=noise)
        res = run_montecarlo(cfg, backend="process", workers=args.workers)
        s = res["summary"]
        busy = sum(t["seconds"] for t in res["trials"])
        rows.append(f"| {noise} | {s['n']}/{args.trials} | {s['median']:.3f} | "
                    f"{quartiles_text(s)} | {s['max']:.3f} | "
                    f"{s['median'] / THESIS_MEDIAN:.2f} | {res['seconds']:.1f} | "
                    f"{busy / res['seconds']:.2f} |")
        print(rows[-1], flush=True)
        if args.out is not None:
            write_json(res, args.out / f"ukf_montecarlo_{noise}.json")
            plot_montecarlo(res, args.out / f"ukf_montecarlo_{noise}.png")
    rows.append("")
    rows.append(f"{args.workers} worker processes; RMSE of the 3D wind error after 2 s; "
                "definitions in `windnav.experiments.ukf_montecarlo`.")
    print("\n".join(rows))
    if not args.no_record:
        append_record(f"Wind UKF Monte Carlo ({args.trials} trials, seed {args.seed})", rows)
    return 0


if __name__ == "__main__":
    sys.exit(main())
