"""Wind-sweep throughput: the thesis's training grid, extrapolated from a timed subset.

Run: ``.venv/bin/python benchmarks/bench_sweep.py`` (about 5-10 minutes on 2 cores).

The thesis's training data: 64 maps (32 of 500 m, 32 of 300 m) x 40 inlets (5 speeds x 8
directions), each 100 + 200 steps at dx = 1 m, dt = 0.25 s: 2,560 simulations. This runs a
representative subset with the ``process`` executor on 2 workers -- one 500 m and one 300 m
training map, an axis-aligned (0 deg) and a diagonal (45 deg) direction, all 5 speeds -- twice:

* batched (the sweep's default): one task per map and direction, its 5 speeds stepped
  together (one factorisation, one 5-right-hand-side pressure solve per step);
* per simulation (the reference, the sweep's previous scheme): one task per simulation.

The full grid's time is extrapolated from the mean task time per map size (the subset's two
directions stand for the 8) as 32 x 8 tasks per size on 2 workers. Appends to
docs/benchmarks.md.

``--all-directions`` instead runs the batched scheme alone over all 8 thesis directions of the
two maps: 80 of the grid's 2,560 simulations, exactly 1/32 of it (one 500 m and one 300 m map
of the 32 of each), so the full grid takes 32 x its wall time with nothing extrapolated but
the maps.

``--recipe`` times the decoder recipe's sweep scheme instead (``src/windnav/predict/recipes/
default.toml``: one speed, 6 m/s, six directions, dt = 1/6 s) on two of its maps, a 1.1 km
cluster and a 300 m dense map, on 2 workers, twice: directions with the same inlet sides
stepped together (the default: 3.75 + 56.25 and 198.75 + 228.75 deg, one factorisation and one
two-right-hand-side pressure solve per step a pair) against one task per direction (the
reference, the scheme before 2026-12-03); it checks that both give the same fields to the bit.
"""

from __future__ import annotations

import os

for _var in ("NUMBA_NUM_THREADS", "OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_var] = "1"

import argparse  # noqa: E402
import shutil  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _record import append_record  # noqa: E402

from windnav.city import training_map  # noqa: E402
from windnav.experiments.wind_sweep import THESIS_SPEEDS, sweep  # noqa: E402
from windnav.flow import simulate  # noqa: E402

PROTOCOL = {"dx": 1.0, "dt": 0.25, "spinup_steps": 100, "steps": 200, "record_every": 0}
MAPS_PER_SIZE = 32
DIRECTIONS = 8
WORKERS = 2
RECIPE_MAPS = ("cluster-0", "dense-0")  # --recipe: a 1.1 km cluster and a 300 m dense map


def _scaled(settings: dict, scale: float) -> dict:
    """``settings`` with the spin-up and averaging step counts scaled by ``--steps-scale``."""
    out = dict(settings)
    out["spinup_steps"] = int(round(settings["spinup_steps"] * scale))
    out["steps"] = max(1, int(round(settings["steps"] * scale)))
    return out


def _command(flags: str, scale: float) -> str:
    """The command line of a record: this script with ``flags`` and any ``--steps-scale``."""
    return f"python benchmarks/bench_sweep.py{flags}" + (
        f" --steps-scale {scale:g}" if scale != 1.0 else "")


def _maps(seed: int):
    rng = np.random.default_rng(seed)
    return [(f"training-{int(s)}m", f"training_map(size={s:g})", training_map(rng=rng, size=s))
            for s in (500.0, 300.0)]


def run(maps, out: Path, directions, batched: bool, settings: dict) -> dict:
    """Run the subset; returns wall time and the mean task time per map (s)."""
    t0 = time.perf_counter()
    store, results = sweep(maps, out, speeds=THESIS_SPEEDS, directions_deg=directions,
                           settings=settings, backend="process", workers=WORKERS,
                           progress=False, simulate=None if batched else simulate)
    wall = time.perf_counter() - t0
    failed = [r for r in results if not r.ok]
    if failed:
        raise RuntimeError(f"{len(failed)} tasks failed: {failed[0].error}")
    per_map = {k: [r.seconds for r in results if r.task.map_index == k]
               for k in range(len(maps))}
    n_sims = sum(len(r.task.case_indices) for r in results)
    return {"wall": wall, "n_sims": n_sims, "n_tasks": len(results),
            "task_seconds": {k: float(np.sum(v)) for k, v in per_map.items()}}


def extrapolate(res: dict, n_directions: int) -> float:
    """Hours for the full grid: per map size, (its subset time / subset directions) x 8
    directions x 32 maps, over 2 workers."""
    per_map_direction = [t / n_directions for t in res["task_seconds"].values()]
    return sum(MAPS_PER_SIZE * DIRECTIONS * t for t in per_map_direction) / WORKERS / 3600.0


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--steps-scale", type=float, default=1.0,
                        help="scale the protocol's step counts (for a quick check; 1 = thesis)")
    parser.add_argument("--no-record", action="store_true")
    parser.add_argument("--all-directions", action="store_true",
                        help="run the batched scheme over all 8 directions (1/32 of the grid)")
    parser.add_argument("--recipe", action="store_true",
                        help="the decoder recipe's scheme on a cluster and a dense map: "
                             "directions of the same inlet sides together, against one task "
                             "per direction")
    args = parser.parse_args(argv)
    if args.recipe:
        return _recipe(args)
    settings = _scaled(PROTOCOL, args.steps_scale)
    maps = _maps(args.seed)
    if args.all_directions:
        return _all_directions(maps, settings, args)
    directions = [0.0, 45.0]
    tmp = Path(tempfile.mkdtemp(prefix="bench_sweep_"))
    try:
        batched = run(maps, tmp / "batched.zarr", directions, True, settings)
        print("batched", batched, flush=True)
        single = run(maps, tmp / "single.zarr", directions, False, settings)
        print("per simulation", single, flush=True)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    scale = 1.0 / args.steps_scale
    hb = extrapolate(batched, len(directions)) * scale
    hs = extrapolate(single, len(directions)) * scale
    rows = [
        "| scheme | subset wall (s) | tasks | 500 m map: task s per direction | 300 m map | "
        "full thesis grid, 2 workers (h) |",
        "|---|---|---|---|---|---|",
    ]
    for name, r, h in (("batched speeds (default)", batched, hb),
                       ("one task per simulation (reference)", single, hs)):
        t = r["task_seconds"]
        rows.append(f"| {name} | {r['wall']:.1f} | {r['n_tasks']} | "
                    f"{t[0] / len(directions):.1f} | {t[1] / len(directions):.1f} | {h:.2f} |")
    rows.append("")
    rows.append(f"- subset: {len(maps)} training maps (500 m: {maps[0][2].n_buildings} "
                f"buildings, 300 m: {maps[1][2].n_buildings}), directions {directions} deg, "
                f"speeds {list(THESIS_SPEEDS)} m/s, {settings['spinup_steps']} + "
                f"{settings['steps']} steps, dx = 1 m, dt = 0.25 s, process executor, "
                f"{WORKERS} workers, default closure")
    rows.append(f"- batched / per simulation: {hs / hb:.2f}x faster; target: full grid <= 2 h")
    if args.steps_scale != 1.0:
        rows.append(f"- step counts scaled by {args.steps_scale:g} and the time rescaled")
    for line in rows:
        print(line)
    if not args.no_record:
        append_record("Wind sweep: the thesis training grid extrapolated (2 workers)", rows,
                      command=_command("", args.steps_scale))
    return 0


def _all_directions(maps, settings: dict, args) -> int:
    """The batched sweep over all 8 directions of the two maps: 1/32 of the thesis grid."""
    directions = [45.0 * k for k in range(DIRECTIONS)]
    tmp = Path(tempfile.mkdtemp(prefix="bench_sweep_"))
    try:
        res = run(maps, tmp / "all.zarr", directions, True, settings)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    scale = 1.0 / args.steps_scale
    hours = MAPS_PER_SIZE * res["wall"] * scale / 3600.0
    t = res["task_seconds"]
    rows = [
        "| map | simulations | task s per direction (mean over 8, 5 speeds each) |",
        "|---|---|---|",
        f"| 500 m, {maps[0][2].n_buildings} buildings | {len(THESIS_SPEEDS) * DIRECTIONS} | "
        f"{t[0] / DIRECTIONS:.1f} |",
        f"| 300 m, {maps[1][2].n_buildings} buildings | {len(THESIS_SPEEDS) * DIRECTIONS} | "
        f"{t[1] / DIRECTIONS:.1f} |",
        f"| both, wall ({WORKERS} workers) | {res['n_sims']} of "
        f"{2 * MAPS_PER_SIZE * DIRECTIONS * len(THESIS_SPEEDS)} | {res['wall']:.1f} s |",
        "",
        f"- full thesis grid: {MAPS_PER_SIZE} x the wall = **{hours:.2f} h** "
        f"(target <= 2 h); {settings['spinup_steps']} + {settings['steps']} steps, dx = 1 m, "
        "dt = 0.25 s, process executor, default closure",
    ]
    if args.steps_scale != 1.0:
        rows.append(f"- step counts scaled by {args.steps_scale:g} and the time rescaled")
    for line in rows:
        print(line)
    if not args.no_record:
        append_record("Wind sweep: 1/32 of the thesis training grid run for real (2 workers)",
                      rows, command=_command(" --all-directions", args.steps_scale))
    return 0


def _recipe(args) -> int:
    """The decoder recipe's six directions on two of its maps: sides grouped against not."""
    from windnav.predict.train import load_recipe, recipe_maps

    path = Path(__file__).resolve().parents[1] / "src/windnav/predict/recipes/default.toml"
    recipe = load_recipe(path)
    sw = recipe["sweep"]
    names = RECIPE_MAPS
    maps = [m for m in recipe_maps(recipe) if m[0] in names]
    settings = _scaled(sw["settings"], args.steps_scale)
    tmp = Path(tempfile.mkdtemp(prefix="bench_sweep_"))
    out = {}
    try:
        for name, grouped in (("grouped", True), ("per direction", False)):
            t0 = time.perf_counter()
            store, results = sweep(maps, tmp / f"{grouped}.zarr", speeds=sw["speeds"],
                                   directions_deg=sw["directions_deg"], settings=settings,
                                   backend="process", workers=WORKERS, progress=False,
                                   group_sides=grouped)
            wall = time.perf_counter() - t0
            if not all(r.ok for r in results):
                raise RuntimeError(next(r.error for r in results if not r.ok))
            out[name] = {"wall": wall, "tasks": len(results), "store": store,
                         "map_s": [sum(r.seconds for r in results if r.task.map_index == k)
                                   for k in range(len(maps))]}
            print(name, {k: v for k, v in out[name].items() if k != "store"}, flush=True)
        a, b = out["grouped"]["store"], out["per direction"]["store"]
        same = all(np.array_equal(a.read_case(k, c)[f], b.read_case(k, c)[f])
                   for k in range(len(maps)) for c in range(a.n_cases)
                   for f in ("mean_u", "mean_v"))
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    g, r = out["grouped"], out["per direction"]
    rows = [
        f"| scheme | wall, s | tasks | {maps[0][0]}, task s | {maps[1][0]}, task s |",
        "|---|---|---|---|---|",
    ]
    for name, x in (("same inlet sides together (default)", g),
                    ("one task per direction (reference)", r)):
        rows.append(f"| {name} | {x['wall']:.1f} | {x['tasks']} | {x['map_s'][0]:.1f} | "
                    f"{x['map_s'][1]:.1f} |")
    rows += [
        "",
        f"- grouped / per direction: wall **{g['wall'] / r['wall']:.3f}x**, task seconds "
        f"{g['map_s'][0] / r['map_s'][0]:.3f}x on {maps[0][0]} and "
        f"{g['map_s'][1] / r['map_s'][1]:.3f}x on {maps[1][0]}",
        f"- mean fields of all {2 * a.n_cases} simulations bit for bit equal between the "
        f"schemes: {'yes' if same else 'NO'}",
        f"- the recipe's maps {list(names)}, speeds {sw['speeds']} m/s, directions "
        f"{sw['directions_deg']} deg, {settings['spinup_steps']} + {settings['steps']} steps, "
        f"dx = {settings['dx']:g} m, process executor, {WORKERS} workers",
    ]
    if args.steps_scale != 1.0:
        rows.append(f"- step counts scaled by {args.steps_scale:g}")
    for line in rows:
        print(line)
    if not args.no_record:
        append_record("Wind sweep: the decoder recipe's directions grouped by inlet sides "
                      "(2 workers)", rows,
                      command=_command(" --recipe", args.steps_scale))
    return 0 if same else 1


if __name__ == "__main__":
    sys.exit(main())
