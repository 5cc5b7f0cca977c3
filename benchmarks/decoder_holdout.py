"""Compare decoders on the held-out district at random inlets: the set that chooses, never
the evaluation maps.

A trained candidate (a recipe trial) is scored beside the reference decoder (default: the
shipped model) on the default recipe's validation map (``holdout-0``, the 600 m district no
model trains on), at random inlets (speed uniform in [2, 10] m/s, direction uniform on the
circle), on the same flows and samples. A training run's own validation (``history.json``)
sees only the sweep's six directions, which fold onto the d4-film's six training angles; a
random direction also falls between them and near the sector boundaries, where a candidate
such as the turned training scenes (``data.turn_deg``) is meant to differ.

The default inlets are those of the fold trial (``docs/data/decoder_fold_blend.py``): 4 of
seed 1 and 12 of seed 2, 16 in all, whose flows ``--flow-cache runs/flows`` may hold.

    .venv/bin/python benchmarks/decoder_holdout.py --out runs/holdout_cmp
        --compare turned=runs/turned/model.npz [--compare NAME=FILE ...] [--model FILE]
        [--boundary average|floor|blend] [--runs 4:1 12:2] [--flow-cache runs/flows]

Each model is scored under ``--boundary`` (default ``average``: the one pass, the package's
default rule until 2026-12-06 and the committed comparisons'; ``load_decoder``'s is ``blend``
since) and, with ``--rotations-deg``, averaged over those turned views
(``load_decoder(rotations_deg=)``).
Reports per model the speed and direction errors pooled over every inlet's cells (each cell
weighing equally, as ``evaluate-decoder`` pools), and against the reference the improvement of
those pooled errors with a paired bootstrap interval over the inlets
(``windnav.experiments.decoder_eval.improvement_interval``, the same pooling), and the count of
inlets where it is better. Inlets that failed or that the budget stopped are listed. Writes
``decoder_holdout.json`` into ``--out``; ``--record`` appends the table to docs/benchmarks.md.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import decoder_views as views  # noqa: E402

METRICS = ("speed_error", "direction_error_deg")
RUNS = ((4, 1), (12, 2))
"""(inlets, seed) of each evaluation run: the fold trial's 16 inlets."""


def parse_run(text: str) -> tuple[int, int]:
    """``"N:SEED"`` -> (N, SEED), N >= 1, SEED >= 0."""
    try:
        n, seed = (int(v) for v in text.split(":"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected N:SEED (e.g. 4:1), got {text!r}") from None
    if n < 1 or seed < 0:
        raise argparse.ArgumentTypeError(f"N must be >= 1 and SEED >= 0, got {text!r}")
    return n, seed


def parse_compare(text: str) -> tuple[str, Path]:
    """``"NAME=FILE"`` -> (NAME, FILE)."""
    name, sep, path = text.partition("=")
    if not sep or not name or not path or name in ("decoder", "local", "upstream"):
        raise argparse.ArgumentTypeError(
            f"expected NAME=FILE with a NAME other than decoder, local and upstream, got "
            f"{text!r}")
    return name, Path(path)


def pooled_error(records, name: str, metric: str) -> float:
    """``metric`` of model ``name`` pooled over the records' cells, each cell weighing equally
    (the cell counts :data:`windnav.predict.metrics` keeps beside each metric)."""
    from windnav.predict.metrics import _COUNTS

    n = np.array([float(r[name][_COUNTS[metric]]) for r in records])
    e = np.array([float(r[name][metric]) for r in records])
    return float((e * n).sum() / n.sum()) if n.sum() > 0 else float("nan")


def holdout_records(reference, others: dict, *, model_path=None, runs=RUNS, flow_cache=None,
                    progress: bool = False) -> tuple[list, list, bool]:
    """``evaluate_decoder``'s records of the decoder ``reference`` and the ``others`` (name ->
    decoder) on the held-out district, run by run (``runs``: (inlets, seed) pairs), each with
    ``run_seed``; the failed inlets, likewise; and whether the budget stopped a run. The
    trial scripts of ``docs/data`` score their own decoder objects through it."""
    from windnav.experiments.decoder_eval import evaluate_decoder

    maps = [(views.VALIDATION_MAP, views.holdout_city())]  # the map drawn once for every run
    records, failed, stopped = [], [], False
    for n_inlets, seed in runs:
        res = evaluate_decoder(model_path, decoder=reference, maps=maps, windinet=False,
                               n_inlets=n_inlets, seed=seed, budget_s=3600.0, compare=others,
                               flow_cache=flow_cache, progress=progress)
        for r in res["records"]:  # the seed of its run beside each inlet's record
            r["run_seed"] = seed
        records += res["records"]
        failed += [{**f, "run_seed": seed} for f in res.get("failed", [])]
        stopped = stopped or bool(res.get("stopped_by_budget"))
    return records, failed, stopped


def run(model=None, compare=(), *, boundary: str = "average", rotations_deg=None, runs=RUNS,
        flow_cache=None, progress: bool = True) -> dict:
    """Score ``model`` (default: shipped) and the ``compare`` files on the held-out district."""
    from windnav.experiments.decoder_eval import improvement_interval
    from windnav.predict import load_decoder
    from windnav.predict.decoder import model_sha256

    reference = load_decoder(model, boundary=boundary, rotations_deg=rotations_deg)
    others = {name: load_decoder(path, boundary=boundary, rotations_deg=rotations_deg)
              for name, path in compare}
    sha256 = {"decoder": model_sha256(model), **{n: model_sha256(p) for n, p in compare}}
    t0 = time.perf_counter()
    records, failed, stopped = holdout_records(reference, others, model_path=model, runs=runs,
                                               flow_cache=flow_cache, progress=progress)
    names = ["decoder", *others, "local"]
    pooled = {n: {m: pooled_error(records, n, m) for m in METRICS} for n in names}
    versus = {}
    for n in others:
        versus[n] = {}
        for m in METRICS:
            iv = improvement_interval(records, n, "decoder", m, group="all")
            better = sum(r[n][m] < r["decoder"][m] for r in records)
            versus[n][m] = {**iv, "better_inlets": int(better)}
    per_inlet = [{"seed": r["run_seed"], "speed": r["speed"], "direction_deg": r["direction_deg"],
                  **{n: {m: r[n][m] for m in METRICS} for n in names}} for r in records]
    return {"reference": str(model) if model is not None else "shipped", "boundary": boundary,
            "rotations_deg": None if rotations_deg is None else [float(a) for a in rotations_deg],
            "compare": {n: str(p) for n, p in compare}, "sha256": sha256,
            "map": views.VALIDATION_MAP,
            "runs": [list(r) for r in runs], "inlets": len(records),
            "samples": int(sum(r["n_samples"] for r in records)), "pooled": pooled,
            "versus_reference": versus, "per_inlet": per_inlet, "failed": failed,
            "stopped_by_budget": stopped,
            "elapsed_s": time.perf_counter() - t0}


def table(res: dict) -> list[str]:
    """The Markdown table of a :func:`run` result."""
    lines = [f"Held-out district `{res['map']}` (never trained on), {res['inlets']} random "
             f"inlets (runs {', '.join(f'{n} of seed {s}' for n, s in res['runs'])}), "
             f"{res['samples']:,} samples; boundary rule `{res['boundary']}`"
             + ("" if not res.get("rotations_deg") else
                f", every model averaged over its views turned by "
                f"{', '.join(f'{a:g}' for a in res['rotations_deg'])} deg")
             + ". Errors pooled "
             "over the cells; improvement on the reference: the pooled errors', paired "
             "bootstrap over the inlets (95 %).", "",
             "| model | speed error (m/s) | direction error (deg) | speed vs reference | "
             "direction vs reference |", "|---|---|---|---|---|"]
    for n, e in res["pooled"].items():
        label = {"decoder": f"reference ({res['reference']})", "local": "Local baseline"}.get(
            n, f"{n} ({res['compare'].get(n, '')})")
        cells = []
        for m in METRICS:
            v = res["versus_reference"].get(n, {}).get(m)
            if v is None:
                cells.append("")
                continue
            ci = "" if v["ci95"] is None else f" [{v['ci95'][0]:+.2f}, {v['ci95'][1]:+.2f}]"
            cells.append(f"{v['value']:+.2f} %{ci}, better at {v['better_inlets']} of "
                         f"{res['inlets']}")
        lines.append(f"| {label} | {e['speed_error']:.4f} | {e['direction_error_deg']:.3f} | "
                     f"{cells[0]} | {cells[1]} |")
    if res.get("failed") or res.get("stopped_by_budget"):
        lines += ["", f"Not scored: {len(res.get('failed', []))} inlets failed"
                  f"{'; the budget stopped a run' if res.get('stopped_by_budget') else ''}."]
    return lines


def main(argv=None) -> int:
    from windnav.predict.decoder import BOUNDARIES

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, required=True, metavar="DIR", help="output folder")
    ap.add_argument("--model", type=Path, default=None,
                    help="the reference decoder file (default: the shipped model)")
    ap.add_argument("--compare", type=parse_compare, action="append", default=[],
                    metavar="NAME=FILE", help="a decoder scored beside it (repeatable)")
    ap.add_argument("--boundary", choices=sorted(BOUNDARIES), default="average",
                    help="every model's rule at the sector boundaries (default average: one "
                         "pass, the committed comparisons' rule; load_decoder's is blend)")
    ap.add_argument("--rotations-deg", type=float, nargs="+", default=None, metavar="DEG",
                    help="every model averaged over the scene turned by these angles, whole "
                         "deg (e.g. 0 -3 3; default: one pass)")
    ap.add_argument("--runs", type=parse_run, nargs="+", default=list(RUNS), metavar="N:SEED",
                    help="random inlets and their seed per run (default 4:1 12:2)")
    ap.add_argument("--flow-cache", type=Path, default=None, metavar="DIR",
                    help="keep and reuse the flows here (shared with evaluate-decoder)")
    ap.add_argument("--no-progress", action="store_true", help="hide the per-inlet lines")
    ap.add_argument("--record", action="store_true", help="append to docs/benchmarks.md")
    args = ap.parse_args(argv)
    if not args.compare:
        ap.error("give at least one --compare NAME=FILE")
    if len({n for n, _ in args.compare}) != len(args.compare):
        ap.error("--compare names must differ")
    res = run(args.model, args.compare, boundary=args.boundary,
              rotations_deg=args.rotations_deg, runs=args.runs,
              flow_cache=args.flow_cache, progress=not args.no_progress)
    res["command"] = "python benchmarks/decoder_holdout.py " + " ".join(
        sys.argv[1:] if argv is None else argv)
    lines = table(res)
    print("\n".join(lines))
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "decoder_holdout.json").write_text(json.dumps(res, indent=1) + "\n")
    print(f"wrote {args.out / 'decoder_holdout.json'}", file=sys.stderr)
    if args.record:
        from _record import append_record

        append_record("Decoders compared on the held-out district (accuracy)", lines,
                      command=res["command"])
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
