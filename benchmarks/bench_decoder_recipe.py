"""The default decoder recipe from scratch: its time, and its metrics against the shipped model.

Run: ``.venv/bin/python benchmarks/bench_decoder_recipe.py`` (about 25-80 min on 2 cores; needs
``pip install '.[train]'``). It runs

    windnav train-decoder --config src/windnav/predict/recipes/default.toml --out OUT

into a fresh ``OUT`` (default ``runs/recipe-<date>``), times the whole command and its sweep,
then compares the validation metrics of the model it trained (``OUT/model.npz``) with those
the shipped model records (``windnav/predict/data/decoder_default.npz``): the acceptance is
that every one is reproduced to within 5 %. ``--log FILE --out DIR`` compares an earlier run
whose output was saved in ``FILE`` instead of running again. ``--recipe FILE --reference
MODEL`` does the same for another recipe and the model it made before (e.g.
``recipes/ensemble.toml``), also comparing the weights. Appends to docs/benchmarks.md.
"""

from __future__ import annotations

import argparse
import datetime as dt
import json
import re
import subprocess
import sys
import time
from importlib import resources
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _record import append_record  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
RECIPE = "src/windnav/predict/recipes/default.toml"
METRICS = ("speed_error", "direction_error_deg", "vector_error")
TOLERANCE = 0.05


def model_metrics(path) -> dict:
    """The validation metrics recorded in a decoder file's metadata."""
    with np.load(path, allow_pickle=False) as z:
        meta = json.loads(str(z["__metadata__"]))
    return meta["metrics"]["validation"]


def same_weights(a, b) -> tuple[int, int]:
    """How many of ``a``'s parameter arrays ``b`` holds bit for bit, and how many there are."""
    with np.load(a, allow_pickle=False) as x, np.load(b, allow_pickle=False) as y:
        names = [k for k in x.files if k != "__metadata__"]
        return sum(k in y.files and np.array_equal(x[k], y[k]) for k in names), len(names)


def sweep_seconds(log: str) -> float | None:
    """The sweep's wall time from train-decoder's output ('... (N now, S s)')."""
    found = re.findall(r"simulations done \(\d+ now, (\d+) s\)", log)
    return float(found[-1]) if found else None


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=None,
                        help="run directory (default runs/recipe-<date>; must not exist)")
    parser.add_argument("--log", type=Path, default=None,
                        help="compare the finished run in --out whose output is in this file")
    parser.add_argument("--wall", type=float, default=None,
                        help="with --log: the command's measured wall time, s")
    parser.add_argument("--recipe", default=RECIPE,
                        help=f"the recipe, relative to the repository (default {RECIPE})")
    parser.add_argument("--reference", type=Path, default=None,
                        help="the model the recipe made before (default: the shipped model)")
    parser.add_argument("--no-record", action="store_true")
    args = parser.parse_args(argv)
    out = args.out or ROOT / "runs" / f"recipe-{dt.date.today().isoformat()}"
    recipe = args.recipe
    command = f"windnav train-decoder --config {recipe} --out {out}"
    if args.log is None:
        if out.exists():
            parser.error(f"--out {out} exists: a reproduction starts from nothing")
        t0 = time.perf_counter()
        done = subprocess.run([str(Path(sys.executable).with_name("windnav")), "train-decoder",
                               "--config", str(ROOT / recipe), "--out", str(out),
                               "--no-progress"], cwd=ROOT, capture_output=True, text=True)
        wall = time.perf_counter() - t0
        log = done.stdout + done.stderr
        (out / "bench.log").write_text(log)
        if done.returncode != 0:
            print(log[-3000:])
            return done.returncode
    else:
        log, wall = args.log.read_text(), args.wall
    reference = args.reference or resources.files("windnav.predict") / "data" / \
        "decoder_default.npz"
    expected = model_metrics(reference)
    got = model_metrics(out / "model.npz")
    label = "shipped model" if args.reference is None else f"`{args.reference}`"
    rows = [f"| metric (held-out map) | {label} | this run | relative difference |",
            "|---|---|---|---|"]
    worst = 0.0
    for name in METRICS:
        rel = got[name] / expected[name] - 1.0
        worst = max(worst, abs(rel))
        rows.append(f"| {name} | {expected[name]:.3f} | {got[name]:.3f} | {100 * rel:+.2f} % |")
    sweep = sweep_seconds(log)
    rows.append("")
    rows.append(f"- command: `{command}`; wall "
                + (f"{wall / 60:.1f} min" if wall else "not measured")
                + (f" (sweep {sweep / 60:.1f} min, training and the rest "
                   f"{(wall - sweep) / 60:.1f} min)" if wall and sweep else ""))
    rows.append(f"- largest difference {100 * worst:.2f} % (tolerance {100 * TOLERANCE:.0f} %): "
                + ("reproduced" if worst <= TOLERANCE else "NOT reproduced"))
    same = same_weights(reference, out / "model.npz")
    rows.append(f"- weights: {same[0]} of {same[1]} arrays bitwise equal to the reference's")
    print("\n".join(rows))
    if not args.no_record:
        append_record("Decoder recipe reproduced from scratch (2 cores)", rows,
                      command="python benchmarks/bench_decoder_recipe.py"
                      + (f" --recipe {recipe}" if recipe != RECIPE else "")
                      + (f" --reference {args.reference}" if args.reference else ""))
    return 0 if worst <= TOLERANCE else 1


if __name__ == "__main__":
    sys.exit(main())
