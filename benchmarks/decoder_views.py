"""Choose the decoder's turned views on the held-out district, never on the evaluation maps.

The decoder can predict the mean over the scene turned by a few small angles
(``load_decoder(rotations_deg=(0, -a, a))``: three passes, docs/decoder.md, "Turned views").
Which ``a`` is chosen here on the default recipe's validation map (``holdout-0``, the 600 m
district no model trains on) at ``--inlets`` random inlets, so that the evaluation maps
(``windnav evaluate-decoder``: the dense 1.2 km maps and the third-party windinet layout) play
no part in the choice. Reference in the same run: the decoder with one pass (no turn), on the
same flows and samples. The chosen ``a`` is the one with the lowest mean of the two error
ratios to the reference (speed and direction); ties go to the smaller angle.

    .venv/bin/python benchmarks/decoder_views.py --out runs/views [--model FILE]
        [--angles 1 2 3 4 5 6 8 10] [--inlets 4] [--seed 1] [--flow-cache runs/flows]

Writes ``decoder_views.json`` and ``decoder_views.png`` (speed and direction error against
``a``) into ``--out``; prints the table and the ``evaluate-decoder`` commands that score the
choice on the evaluation maps. ``--record`` appends the table to docs/benchmarks.md.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

ANGLES_DEG = (1, 2, 3, 4, 5, 6, 8, 10)
"""The half-spreads ``a`` tried by default, deg: views at 0, -a and +a."""
VALIDATION_MAP = "holdout-0"
"""The default recipe's validation map (``data.validation_maps``)."""
METRICS = ("speed_error", "direction_error_deg")
DEFAULT_FILE = "src/windnav/predict/data/decoder_default.npz"
"""The shipped model's file, as a command line in the checkout names it."""


def holdout_city():
    """The default recipe's held-out district as a City."""
    from windnav.predict.train import RECIPES, load_recipe, recipe_maps

    maps = recipe_maps(load_recipe(RECIPES / "default.toml"))
    return next(city for name, _, city in maps if name == VALIDATION_MAP)


def views(a: float) -> tuple[float, float, float]:
    """The three views of half-spread ``a``, deg."""
    return (0.0, -float(a), float(a))


def choose(pooled: dict, angles) -> dict:
    """Per ``a``, its errors and their ratios to the one-pass decoder; the chosen ``a``."""
    ref = pooled["decoder"]
    rows = {}
    for a in angles:
        e = pooled[f"a{a:g}"]
        ratios = {m: e[m] / ref[m] for m in METRICS}
        rows[f"{a:g}"] = {"rotations_deg": views(a), **{m: e[m] for m in METRICS},
                          "ratio": ratios, "mean_ratio": float(np.mean(list(ratios.values())))}
    # ratios equal to 1e-9 are a tie (float rounding must not pick the larger angle)
    best = min(angles, key=lambda a: (round(rows[f"{a:g}"]["mean_ratio"], 9), abs(a)))
    return {"reference": {m: ref[m] for m in METRICS}, "by_angle": rows,
            "chosen_deg": float(best), "chosen_rotations_deg": views(best)}


def per_inlet(records, angles) -> list[dict]:
    """Per inlet: its speed, direction and distance from a sector boundary, the one pass's
    errors and each ``a``'s, and each ``a``'s gain over the one pass (%)."""
    from windnav.predict.decoder import sector_boundary_distance_deg

    out = []
    for r in records:
        row = {"speed": r["speed"], "direction_deg": r["direction_deg"],
               "boundary_distance_deg": float(
                   sector_boundary_distance_deg(r["direction_deg"])),
               "one_pass": {m: r["decoder"][m] for m in METRICS}, "by_angle": {}}
        for a in angles:
            e = r[f"a{a:g}"]
            row["by_angle"][f"{a:g}"] = {
                **{m: e[m] for m in METRICS},
                "gain_pct": {m: 100.0 * (1.0 - e[m] / r["decoder"][m]) for m in METRICS}}
        out.append(row)
    return out


def run(model=None, *, angles=ANGLES_DEG, n_inlets: int = 4, seed: int = 1,
        flow_cache=None, progress: bool = True) -> dict:
    """Score the one-pass decoder and its three-view variants on the held-out district."""
    from windnav.experiments.decoder_eval import evaluate_decoder
    from windnav.predict import load_decoder
    from windnav.predict.decoder import Decoder

    angles = sorted({float(a) for a in angles})
    # the one pass (the views' reference); the file read once, each view set shares its weights
    plain = load_decoder(model, boundary="average")
    compare = {f"a{a:g}": Decoder(plain.weights, plain.metadata, rotations_deg=views(a))
               for a in angles}
    t0 = time.perf_counter()
    res = evaluate_decoder(model, decoder=plain, maps=[(VALIDATION_MAP, holdout_city())],
                           windinet=False, n_inlets=n_inlets, seed=seed, budget_s=3600.0,
                           compare=compare, flow_cache=flow_cache, progress=progress)
    pooled = res["pooled"]["dense"]
    return {"model": str(model) if model is not None else "default",
            "map": VALIDATION_MAP, "n_inlets": n_inlets, "seed": seed,
            "samples": sum(r["n_samples"] for r in res["records"]),
            "inlets": [{"speed": r["speed"], "direction_deg": r["direction_deg"]}
                       for r in res["records"]],
            "per_inlet": per_inlet(res["records"], angles),
            "local": {m: pooled["local"][m] for m in METRICS},
            **choose(pooled, angles), "elapsed_s": time.perf_counter() - t0}


def table(res: dict) -> list[str]:
    """The Markdown table of a :func:`run` result."""
    ref = res["reference"]
    lines = [f"Held-out district `{res['map']}` (never trained on), {res['n_inlets']} random "
             f"inlets (seed {res['seed']}), {res['samples']:,} samples; model "
             f"{res['model']}. Views at 0, -a and +a deg (three passes) against one pass.",
             "",
             "| a (deg) | speed error (m/s) | direction error (deg) | mean ratio to one pass |",
             "|---|---|---|---|",
             f"| one pass | {ref['speed_error']:.4f} | {ref['direction_error_deg']:.3f} | 1 |"]
    for a, r in res["by_angle"].items():
        mark = " (chosen)" if float(a) == res["chosen_deg"] else ""
        lines.append(f"| {a}{mark} | {r['speed_error']:.4f} | {r['direction_error_deg']:.3f} "
                     f"| {r['mean_ratio']:.4f} |")
    loc = res["local"]
    lines += [f"| Local baseline | {loc['speed_error']:.4f} | "
              f"{loc['direction_error_deg']:.3f} | |", "",
              f"Chosen: a = {res['chosen_deg']:g} deg, `--rotations-deg "
              f"{' '.join(f'{v:g}' for v in res['chosen_rotations_deg'])}`."]
    return lines


def plot(res: dict, path: Path) -> Path:
    """Speed and direction error against the half-spread ``a``, the one pass as a line."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(9, 3.6))
    axes = fig.subplots(1, 2)
    a = [float(k) for k in res["by_angle"]]
    for ax, metric, label in zip(axes, METRICS, ("speed error (m/s)", "direction error (deg)"),
                                 strict=True):
        ax.plot(a, [r[metric] for r in res["by_angle"].values()], "o-", label="views 0, -a, +a")
        ax.axhline(res["reference"][metric], color="k", ls="--", label="one pass")
        ax.axvline(res["chosen_deg"], color="C3", ls=":", label="chosen")
        ax.set_xlabel("a (deg)")
        ax.set_ylabel(label)
    axes[0].legend(fontsize=8)
    fig.suptitle(f"Turned views on the held-out district ({res['n_inlets']} inlets, "
                 f"{res['samples']:,} samples)", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    return path


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, required=True, metavar="DIR",
                    help="output folder (JSON, figure)")
    ap.add_argument("--model", type=Path, default=None, help="decoder file (default: shipped)")
    ap.add_argument("--angles", type=float, nargs="+", default=list(ANGLES_DEG),
                    metavar="A", help="half-spreads a to try, whole deg (default "
                                      f"{' '.join(map(str, ANGLES_DEG))})")
    ap.add_argument("--inlets", type=int, default=4, help="random inlets (default 4)")
    ap.add_argument("--seed", type=int, default=1,
                    help="seed of the inlets and samples (default 1)")
    ap.add_argument("--flow-cache", type=Path, default=None, metavar="DIR",
                    help="keep and reuse the flows here (shared with evaluate-decoder)")
    ap.add_argument("--no-progress", action="store_true", help="hide the per-inlet lines")
    ap.add_argument("--record", action="store_true", help="append to docs/benchmarks.md")
    args = ap.parse_args(argv)
    if args.inlets < 1:
        ap.error("--inlets must be >= 1")
    from windnav.predict.decoder import ROTATIONS_LIMIT_DEG

    bad = [a for a in args.angles if not (0 < a <= ROTATIONS_LIMIT_DEG and a == round(a))]
    if bad or len(set(args.angles)) != len(args.angles):
        ap.error(f"--angles must be distinct whole degrees in (0, {ROTATIONS_LIMIT_DEG:g}] (the "
                 f"views are 0, -a and +a). Got {args.angles} instead.")
    res = run(args.model, angles=args.angles, n_inlets=args.inlets, seed=args.seed,
              flow_cache=args.flow_cache, progress=not args.no_progress)
    lines = table(res)
    print("\n".join(lines))
    rot = " ".join(f"{v:g}" for v in res["chosen_rotations_deg"])
    model = f" --model {args.model}" if args.model is not None else ""
    print(f"\nScore the choice on the evaluation maps:\n  windnav evaluate-decoder --maps 0 "
          f"--inlets 8 --budget-min 40 --out runs/eval_wi_views --seed 0{model} "
          f"--rotations-deg {rot} --compare one-pass={args.model or DEFAULT_FILE}\n"
          "  (the same with --maps 2 --inlets 3 --no-windinet for the dense maps)")
    res["command"] = "python benchmarks/decoder_views.py " + " ".join(
        sys.argv[1:] if argv is None else argv)
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "decoder_views.json").write_text(json.dumps(res, indent=1) + "\n")
    plot(res, args.out / "decoder_views.png")
    print(f"wrote {args.out / 'decoder_views.json'}\nwrote {args.out / 'decoder_views.png'}",
          file=sys.stderr)
    if args.record:
        sys.path.insert(0, str(Path(__file__).resolve().parent))
        from _record import append_record

        append_record("Decoder views chosen on the held-out district (accuracy)", lines,
                      command="python benchmarks/decoder_views.py " + " ".join(argv or []))
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
