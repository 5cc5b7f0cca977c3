"""``windnav city``: make a map, or look at one, before simulating, flying or training on it.

::

    windnav city --kind planning --seed 5 --size 300 --out runs/town   # -> city.json, city.png
    windnav city --map my_city.json --suite thesis --out runs/look      # its plan and the pairs
    windnav city --map my_city.json --suite quick --pair-distance 150 --edge 20 --out runs/look
    windnav city --map my_city.json --suite thesis --suite-seed 2 --out runs/look2  # seed 2's

``--kind`` writes a generated map (:func:`windnav.city.planning_map`, ``training_map`` or
``dense_map``, with ``--seed``, ``--size`` and ``--buildings`` when given) as a RotorPy world
JSON, ``city.json``, which every ``--map`` option reads; ``--map [NAME=]FILE`` reads one. Both
draw the map's blocks by height (``city.png``) and print its summary (extent, buildings and
blocks, heights, the built-up share, the median block's smaller side, whether the flow
solver's 1 m grid resolves it, and how much of a cross-section across the wind its blocks
close: :func:`windnav.flow.validity.blockage`, with the mean wind's factor through that
section along a map axis). ``--kind dense --seed N`` is the evaluation maps' generator, not
those maps (``evaluate-decoder`` draws them from its own seed).

``--suite`` (with the rule options of ``windnav benchmark-nav --map``: ``--pair-distance``,
``--edge``, ``--clearance``) draws the start/goal pairs that ``benchmark-nav --suite S --map
FILE`` would fly on the map, every wind's, without simulating any wind, and estimates one
wind's memory there. A map that cannot hold them is said, with the reason and the options
that change the rule, and the exit status is 1 (the figure and JSON are still written): a
check to run before a long benchmark. The JSON's ``suite.pairs`` give each pair's scenario id,
inlet, start, goal and flight seed, and the command prints the ``windnav navigate`` line that
flies the first as the benchmark would (:func:`fly_one`; its flights equal the records of
``benchmark-nav``'s for the same labels, to the bit on the same arithmetic). ``--suite-seed N``
draws the pairs of ``benchmark-nav --seed N`` (default 0, its default): a held-out suite's.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

from windnav.commands._common import (
    add_output_arguments,
    document,
    map_argument,
    options_named,
    outputs,
    print_written,
    where,
)

KINDS = ("planning", "training", "dense")
"""The generators of ``--kind``: :func:`windnav.city.planning_map` (the navigation suites'),
:func:`~windnav.city.training_map` (the decoder's training maps) and
:func:`~windnav.city.dense_map` (its 1.2 km evaluation maps)."""

PRODUCTS = ("city.json", "city.png", "city_summary.json")
"""What a run writes into ``--out`` (``city.json`` only for ``--kind``)."""


def register(subparsers) -> None:
    """Add the ``city`` subcommand."""
    from windnav.commands._city_suite import add_city_rule_arguments
    from windnav.experiments.nav_suite import SUITES

    p = subparsers.add_parser(
        "city",
        help="make a city map (RotorPy world JSON) or look at one, with a suite's "
             "start/goal pairs on it",
        description="Generate a map (--kind) or read one (--map); draw its blocks by height "
                    "and summarise it; with --suite, draw the start/goal pairs that "
                    "'benchmark-nav --map' would fly on it, or say why it cannot hold them.",
    )
    source = p.add_mutually_exclusive_group(required=True)
    source.add_argument("--kind", choices=KINDS, default=None,
                        help="generate a map: planning (the navigation suites', 600 m), "
                             "training (the decoder's, 300 m) or dense (the generator of its "
                             "1.2 km evaluation maps), written as OUT/city.json")
    source.add_argument("--map", default=None, metavar="[NAME=]FILE",
                        help="a RotorPy world JSON of your own (NAME: default the file's name)")
    p.add_argument("--seed", type=int, default=None,
                   help="--kind: the generator's seed (default 0)")
    p.add_argument("--size", type=float, default=None, metavar="M",
                   help="--kind: the side of the square map, m (default: the generator's)")
    p.add_argument("--buildings", type=int, default=None, metavar="N",
                   help="--kind: the number of buildings (default: the generator's draw)")
    p.add_argument("--suite", choices=tuple(SUITES), default=None,
                   help="draw the start/goal pairs this suite's rule draws on the map (as "
                        "'benchmark-nav --suite S --map FILE' with --suite-seed); exit "
                        "status 1 when it holds none")
    p.add_argument("--suite-seed", type=int, default=None, metavar="N",
                   help="with --suite: the suite seed, as 'benchmark-nav --seed N' (default: "
                        "0, its default)")
    add_city_rule_arguments(p)
    p.add_argument("--out", required=True, help="output folder")
    add_output_arguments(p)
    p.set_defaults(func=run)


def _generate(args, name: str):
    """The map of ``--kind`` with ``--seed``, ``--size`` and ``--buildings`` (errors naming
    them)."""
    from windnav._validate import nonnegative_int
    from windnav.city import dense_map, planning_map, training_map

    make = {"planning": planning_map, "training": training_map, "dense": dense_map}[args.kind]
    kwargs = {"rng": 0 if args.seed is None else nonnegative_int(args.seed, "--seed", name)}
    if args.size is not None:
        kwargs["size"] = args.size
    if args.buildings is not None:
        kwargs["n_buildings"] = args.buildings
    where_ = make.__name__
    with options_named({f"'rng' parameter of {where_}": f"'--seed' parameter of {name}",
                        f"'size' parameter of {where_}": f"'--size' parameter of {name}",
                        f"'n_buildings' parameter of {where_}":
                            f"'--buildings' parameter of {name}",
                        f"{where_} drew": f"{name} (--kind {args.kind}) drew",
                        "Pass a smaller n_buildings= or a larger size.":
                            "Pass a smaller --buildings or a larger --size."}):
        try:
            return make(**kwargs)
        except ValueError as exc:  # the layout's own parameters, which no flag sets (CLI audit)
            text = str(exc)
            if not any(f"'{p}' parameter of {where_}" in text
                       for p in ("side_range", "lots_per_side")):
                raise
            size = "its default" if args.size is None else f"{args.size:g} m"
            raise ValueError(f"The '--size' parameter of {name} must leave room for a --kind "
                             f"{args.kind} map's buildings, streets and margins: give a larger "
                             f"--size. Got {size} instead ({where_}: {text})") from None


def summarize_city(city) -> dict:
    """The summary of ``city``: its bounds and extent (m), buildings (connected blocks) and
    blocks, the heights (m), the built-up share of its area (on a 1 m raster), the median
    block's smaller side (m), the flow solver's resolution note at 1 m (None when the 1 m
    grid resolves it), and the blockage of a cross-section across the wind for winds every
    15 deg (:func:`windnav.flow.validity.blockage`; a wind and its opposite block alike), the
    largest, and the largest along a map axis with ``mean_wind_factor``, ``1 / (1 - b)``: the
    solver's mean wind through that section over the inlet's, exact by continuity along an
    axis only (None when a section is closed: no wind passes)."""
    import numpy as np

    from windnav.flow.validity import blockage

    x, y = city.grid(1.0)
    solid = city.rasterize(x, y)
    heights = np.asarray(city.heights, dtype=float)
    angles = np.arange(0.0, 180.0, 15.0)
    shares = blockage(city, angles)
    worst = int(np.argmax(shares))
    axis = 0 if shares[0] >= shares[6] else 6  # 0 or 90 deg
    return {
        "bounds": [float(b) for b in city.bounds],
        "size_m": [float(s) for s in city.size],
        "buildings": int(np.unique(city.building_labels()).size) if city.n_buildings else 0,
        "blocks": city.n_buildings,
        "height_m": [float(heights.min()), float(heights.max())] if heights.size else None,
        "built_fraction": float(solid.mean()),
        "median_block_side_m": city.median_building_side,
        "resolution_note": city.resolution_note(1.0),
        "blockage": {"by_direction_deg": {f"{a:g}": float(b)
                                          for a, b in zip(angles, shares, strict=True)},
                     "max": float(shares[worst]), "at_deg": float(angles[worst]),
                     "along_axis": float(shares[axis]), "axis_deg": float(angles[axis]),
                     "mean_wind_factor": (float(1.0 / (1.0 - shares[axis]))
                                          if shares[axis] < 1.0 else None)},
        "fingerprint": city.fingerprint(),
    }


def suite_pairs(city, label: str, suite: str, rule: dict, name: str, *, path: str,
                flag: str, seed: int = 0) -> dict:
    """The start/goal pairs of ``suite``'s rule (with ``rule``'s values, as ``benchmark-nav
    --map`` takes them, with the suite seed ``seed``: its default 0) on ``city``, named ``label``:
    ``holds`` (bool), the rule, each pair (``scenario_id``, ``kind``, ``speed``,
    ``direction_deg``, ``start``, ``goal``) and the memory one wind of the suite takes to
    simulate there, as ``benchmark-nav`` counts it to batch its winds
    (:func:`windnav.experiments.nav_benchmark.wind_memory`); or ``why`` the map cannot hold
    them (naming ``flag``, the map's option, and ``path``)."""
    from windnav.commands._city_suite import new_city_suite, suite_rule
    from windnav.experiments.nav_benchmark import wind_memory
    from windnav.experiments.nav_suite import get_suite, make_suite
    from windnav.flow.memory import format_bytes

    base = get_suite(suite, seed=seed)
    out = {"name": label, "suite": suite, "seed": base.seed,
           "rule": {**suite_rule(base), **rule},
           "holds": False, "pairs": [], "why": None, "wind_memory_bytes": None,
           "wind_memory": None}
    try:
        spec = new_city_suite(base, label, city, path, name, rule, flag=flag)
    except ValueError as exc:
        out["why"] = str(exc)
        return out
    out["holds"] = True
    out["wind_memory_bytes"] = wind_memory(spec)
    out["wind_memory"] = format_bytes(out["wind_memory_bytes"])
    out["pairs"] = [{"scenario_id": s.scenario_id, "kind": s.kind, "speed": s.speed,
                     "direction_deg": s.direction_deg, "start": [float(v) for v in s.start],
                     "goal": [float(v) for v in s.goal], "seed": int(s.seed)}
                    for s in make_suite(spec)]
    return out


def fly_one(path, pair: dict) -> str:
    """The ``windnav navigate`` line that flies ``pair`` (one of :func:`suite_pairs`'s) on the
    map file ``path`` as the benchmark would: its start, goal, inlet and flight seed, with the
    thesis's baseline and the sixth variant's last setting (``benchmark-nav``'s labels; a
    label's flight equals the benchmark's record of it, docs/navigation.md)."""
    import shlex

    words = ["windnav", "navigate", "--map", str(path),
             "--start", *(repr(v) for v in pair["start"]),
             "--goal", *(repr(v) for v in pair["goal"]),
             "--speed", repr(pair["speed"]), "--direction-deg", repr(pair["direction_deg"]),
             "--seed", str(pair["seed"]), "--variant", f"mppi,{SIXTH}",
             "--out", f"runs/{pair['scenario_id'].replace('/', '_')}"]
    return shlex.join(words)


SIXTH = "ea-mppi-w-esc@escair=13.45@edge=15@pace=20@regain=20@launch=40@gust=0.5"
"""The sixth variant's last setting (docs/navigation.md), the label :func:`fly_one` names."""


def run(args) -> int:
    """Run ``windnav city``; 1 when ``--suite``'s pairs do not fit the map, else 0."""
    from windnav.commands._city_suite import CITY_RULE, city_label, city_rule
    from windnav.experiments.results import json_ready, write_json
    from windnav.viz.city import plot_city

    name = where(args)
    if args.map is not None:
        for flag, value in (("--seed", args.seed), ("--size", args.size),
                            ("--buildings", args.buildings)):
            if value is not None:
                raise ValueError(f"The '{flag}' parameter of {name} applies to --kind (a map "
                                 f"made here); --map reads one. Got {flag} {value!r} with "
                                 "--map instead.")
    rule = city_rule(args, name, city=True)  # (a made map is one's own too)
    suite_seed = 0
    if args.suite_seed is not None:
        if args.suite is None:
            raise ValueError(f"The '--suite-seed' parameter of {name} is the seed of --suite's "
                             f"pairs. Got {args.suite_seed!r} without --suite instead.")
        from windnav._validate import nonnegative_int

        suite_seed = nonnegative_int(args.suite_seed, "--suite-seed", name)
    if rule and args.suite is None:
        flag = CITY_RULE[next(iter(rule))]
        raise ValueError(f"The '{flag}' parameter of {name} changes --suite's start/goal rule. "
                         f"Got it without --suite instead.")
    made = args.kind is not None
    products = PRODUCTS if made else PRODUCTS[1:]
    out = outputs(args, out=("--out", args.out, products))
    if made:
        city = _generate(args, name)
        label, path = "city", None  # (the file's name, as benchmark-nav --map names it)
    else:
        label, path, city = map_argument(args.map, "--map", name)
        if args.suite is not None:
            city_label(label, "--map", name)
        if args.json is not None and Path(args.json).resolve() == path.resolve():
            raise ValueError(f"The '--json' parameter of {name} must not be the map file it "
                             f"reads. Got {str(args.json)!r} instead.")
    try:
        summary = {"map": None if path is None else str(path), "name": label,
                   "kind": args.kind, **summarize_city(city)}
    except ValueError as exc:  # the summary's 1 m raster; city has no --dx (CLI audit)
        if "'dx' parameter of grid_shape" not in str(exc):
            raise
        x0, x1, y0, y1 = city.bounds
        raise ValueError(f"The '{'--size' if made else '--map'}' parameter of {name} must give "
                         f"a map the summary can raster at 1 m (at most 1e9 cells). Got "
                         f"{x1 - x0:g} x {y1 - y0:g} m instead.") from None
    if args.suite is not None:
        summary["suite"] = suite_pairs(
            city, label, args.suite, rule, name, flag="--kind" if made else "--map",
            path=f"the {args.kind} map" if made else str(path), seed=suite_seed)
    with out.writing() as stage:
        if made:
            city.to_rotorpy_json(stage.dir / PRODUCTS[0])
        plot_city(city, summary, stage.dir / PRODUCTS[1])
        doc = document("city", json_ready(summary), args)
        write_json(doc, stage.dir / PRODUCTS[2])
        if stage.file("--json") is not None:
            write_json(doc, stage.file("--json"))
    brief = {k: v for k, v in summary.items() if k not in ("suite", "fingerprint", "blockage")}
    brief["blockage"] = {k: summary["blockage"][k] for k in (
        "max", "at_deg", "along_axis", "axis_deg", "mean_wind_factor")}
    if args.suite is not None:
        s = summary["suite"]
        brief["suite"] = {"suite": s["suite"], "rule": s["rule"], "holds": s["holds"],
                          "pairs": len(s["pairs"]), "wind_memory": s["wind_memory"]}
    print(json.dumps(json_ready(brief), indent=1))
    if summary["resolution_note"]:
        print(f"{name}: note: {summary['resolution_note']}", file=sys.stderr)
    print_written(out)
    if args.suite is not None and summary["suite"]["holds"]:
        where_map = path if path is not None else Path(args.out) / PRODUCTS[0]
        print(f"{name}: the pairs, their inlets and flight seeds are in "
              f"{Path(args.out) / PRODUCTS[2]} (suite.pairs); to fly the first as the "
              f"benchmark would:\n  {fly_one(where_map, summary['suite']['pairs'][0])}",
              file=sys.stderr)
    if args.suite is not None and not summary["suite"]["holds"]:
        print(f"{name}: the map cannot hold the suite's pairs: {summary['suite']['why']}",
              file=sys.stderr)
        return 1
    return 0
