"""``windnav evaluate-decoder``: the wind flow decoder against its baselines (JSON + figure).

::

    windnav evaluate-decoder --out runs/eval --json eval.json --seed 0          # 20 min budget
    windnav evaluate-decoder --model runs/default/model.npz --maps 3 --inlets 8 --budget-min 5 \
        --out runs/eval_own
    windnav evaluate-decoder --compare thesis-mlp=runs/thesis_mlp/model.npz --out runs/eval
    windnav evaluate-decoder --maps 0 --out runs/eval_wi --flow-cache runs/flows  # flows shared
    windnav evaluate-decoder --map my_city.json --out runs/eval_mine  # your own city alone

Simulates the mean flow of dense 1.2 km evaluation maps (never trained on) and of the windinet
1.1 km layout at random inlets (speed U[2, 10] m/s, direction U[0, 360) deg), draws samples
from each field and reports the speed, direction and vector errors of the decoder, the Local
baseline (uniform W_robot) and the Upstream baseline (uniform W_up), per (map, inlet) and
pooled, with the improvements over each baseline and issue 9's acceptance checks; models given
with ``--compare`` are scored on the same fields and samples beside it. ``--map [NAME=]FILE``
(repeatable) adds a city of your own, a RotorPy world JSON, pooled apart as the group
``file``; with it the dense maps and windinet are left out unless ``--maps`` or
``--windinet`` is given. Inlets are
added, map by map, while they fit in the budget. Each solved flow is kept in the flow cache,
``--out``'s ``flows`` folder unless ``--flow-cache DIR`` names another (``--no-flow-cache``:
none), so the same command run again after Ctrl-C or a kill resumes: an inlet whose flow comes
from the cache is charged the simulation time recorded with it, so a resumed run runs the same
inlets as one never interrupted, up to the timing noise of the work done again (an entry that
cannot be read is solved again, with a warning). The harness is
:mod:`windnav.experiments.decoder_eval`, the figure :mod:`windnav.viz.decoder`.

Writes into ``--out``: ``decoder_eval.json`` and ``decoder_eval.png``, and the flow cache
``flows/`` (tens of MB a flow) by default. The cache holds no results: it does not make a rerun
an overwrite (a run interrupted before its results were written reruns without
``--overwrite``), and ``--overwrite`` keeps it (an entry is the flow of one map, inlet and
protocol, whichever run solved it). The JSON records the folder used (``flow_cache``, null with
``--no-flow-cache``).

Each record carries its truth flow's diagnostics (``flow_diagnostics``), their averaging
verdict (``averaging``: :func:`windnav.flow.validity.averaging_verdict`), its air travel beside
the decoder's training flows' (``travel``, read from the decoder's recipe:
:func:`windnav.predict.envelope.training_envelope`) and its ``notes``; ``truth_checks`` counts
them, and one ``note`` on stderr says how many slots' truths fail the averaging rule or travel
more than 25 % farther or shorter than the training's (as ``windnav predict`` does for one).
``model_files`` gives the SHA-256 of ``--model``'s file (the shipped one's when not given) and
of each ``--compare``'s (:func:`windnav.commands._common.model_files`).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from windnav._validate import positive_float, positive_int
from windnav.commands._common import (
    add_output_arguments,
    add_rotations_argument,
    cache_folder,
    compare_boundary,
    document,
    load_model,
    map_argument,
    model_files,
    options_named,
    outputs,
    path_argument,
    print_written,
    seed,
    where,
)

MAPS = 3
"""``--maps``'s default without ``--map``."""
PRODUCTS = ("decoder_eval.json", "decoder_eval.png")
"""The results a run writes into ``--out`` (what ``--overwrite`` replaces)."""
FLOW_CACHE = "flows"
"""The default flow cache: this folder of ``--out`` (not one of :data:`PRODUCTS`)."""


def register(subparsers) -> None:
    """Add the ``evaluate-decoder`` subcommand."""
    p = subparsers.add_parser(
        "evaluate-decoder",
        help="score the wind flow decoder and its baselines on simulated evaluation maps",
        description=__doc__.splitlines()[0],
    )
    p.add_argument("--model", type=Path, default=None, metavar="FILE",
                   help="decoder file (default: the shipped model)")
    add_rotations_argument(p, compare=True)
    p.add_argument("--compare", action="append", default=[], metavar="[NAME=]FILE",
                   help="another decoder file scored beside the decoder on the same samples "
                        "(e.g. the thesis MLP trained on the same data); repeatable; NAME "
                        "defaults to its architecture")
    p.add_argument("--maps", type=int, default=None, metavar="N",
                   help=f"dense 1.2 km evaluation maps (default {MAPS}, 0 with --map; 0: only "
                        "windinet and --map's)")
    p.add_argument("--map", action="append", default=[], metavar="[NAME=]FILE",
                   help="a map of your own, a RotorPy world JSON file, evaluated as the "
                        "others are (group 'file', pooled apart); repeatable; NAME defaults "
                        "to the file's name without .json; with it --maps defaults to 0 and "
                        "--windinet to no")
    p.add_argument("--inlets", type=int, default=8, metavar="N",
                   help="random inlets per map at most (default 8; the budget may stop earlier)")
    p.add_argument("--samples", type=int, default=2048, metavar="N",
                   help="samples per (map, inlet) (default 2048)")
    p.add_argument("--budget-min", type=float, default=20.0, metavar="MIN",
                   help="wall-clock budget in minutes (default 20): no inlet starts that would "
                        "end past it; an inlet read from the flow cache is charged the "
                        "simulation time recorded with it, as if solved again")
    p.add_argument("--windinet", action=argparse.BooleanOptionalAction, default=None,
                   help="also evaluate the third-party windinet 1.1 km layout (default: yes; "
                        "no with --map)")
    p.add_argument("--dx", type=float, default=1.0, help="solver cell size, m (default 1)")
    p.add_argument("--out", type=path_argument, required=True, metavar="DIR",
                   help="output folder (JSON, figure)")
    p.add_argument("--seed", type=int, default=0,
                   help="seed of the inlets and the samples (default %(default)s)")
    p.add_argument("--flow-cache", type=Path, default=None, metavar="DIR",
                   help="keep each inlet's flow here and reuse it when the same map, inlet and "
                        "protocol come again, so a rerun after an interrupt resumes (shared "
                        f"with decoder-study --flow-cache; default: OUT/{FLOW_CACHE}, in "
                        "--out)")
    p.add_argument("--no-flow-cache", action="store_true",
                   help="keep no flows: a rerun solves every flow again (default: kept in "
                        "the flow cache)")
    p.add_argument("--no-progress", action="store_true", help="hide the per-inlet lines")
    add_output_arguments(p)
    p.set_defaults(func=run)


def run(args, simulate=None, flow_settings=None) -> int:
    """Run ``windnav evaluate-decoder``; returns 0."""
    from windnav.experiments.decoder_eval import evaluate_decoder
    from windnav.experiments.results import json_ready, write_json
    from windnav.viz.decoder import plot_evaluation

    name = where(args)
    seed(args)
    positive_int(args.inlets, "--inlets", name)
    positive_int(args.samples, "--samples", name)
    budget = positive_float(args.budget_min, "--budget-min", name)
    positive_float(args.dx, "--dx", name)
    own = map_files(args.map, name)
    # the defaults resolved, not written back: the JSON's arguments keep what was typed (None:
    # the default), its config what ran (windnav.provenance rebuilds older lines)
    maps = (0 if own else MAPS) if args.maps is None else args.maps
    windinet = not own if args.windinet is None else args.windinet
    if isinstance(maps, bool) or maps < 0 or (maps == 0 and not windinet and not own):
        raise ValueError(f"The '--maps' parameter of {name} must be an integer >= 0 (>= 1 with "
                         f"--no-windinet and no --map). Got {args.maps!r} instead.")
    if args.model is not None and not Path(args.model).is_file():
        what = "a folder" if Path(args.model).is_dir() else "which does not exist"
        raise ValueError(f"The '--model' parameter of {name} must be a decoder file. Got "
                         f"{str(args.model)!r} instead, {what}.")
    compare = _compare_files(args.compare, name)
    if args.compare_boundary is not None and not args.compare:  # it was ignored (CLI audit)
        raise ValueError(f"The '--compare-boundary' parameter of {name} applies only with "
                         f"--compare (the compared models' rule). Got "
                         f"{args.compare_boundary!r} without --compare instead.")
    out = outputs(args, out=("--out", args.out, PRODUCTS),
                  inputs={"--map": [file for _, file in own]})  # (--json M.json: CLI audit)
    flow_cache = flow_cache_folder(args, name)
    from windnav.commands.predict import dx_notes, print_notes, training_conditions
    from windnav.predict.envelope import training_envelope

    dec = load_model(args, name)
    files = model_files(args)  # the weights read, by hash
    training = training_conditions(training_envelope(dec))
    notes = dx_notes(training, args.dx)
    try:
        # --compare's files are read first, before any flow: their errors name the option,
        # not load_decoder's 'path' (CLI audit)
        with options_named({"'files' parameter of evaluate_decoder":
                            f"'--map' parameter of {name}",
                            "'compare' parameter of evaluate_decoder":
                            f"'--compare' parameter of {name}",
                            "'path' parameter of load_decoder":
                            f"'--compare' parameter of {name}"}):
            res = evaluate_decoder(args.model, decoder=dec, maps=maps, windinet=windinet,
                                   files=own, compare=compare,
                                   compare_boundary=compare_boundary(args),
                                   n_inlets=args.inlets, samples_per_inlet=args.samples,
                                   seed=args.seed, budget_s=60.0 * budget, dx=args.dx,
                                   flow_settings=flow_settings, progress=not args.no_progress,
                                   simulate=simulate, flow_cache=flow_cache)
    except KeyboardInterrupt:  # said only "interrupted": the solved flows were lost unsaid
        kept = (f"the flows solved so far are kept in {str(flow_cache)!r}; rerun the same "
                "command to reuse them (the same result)" if flow_cache is not None else
                "nothing is kept with --no-flow-cache; without it each solved flow is kept "
                "and a rerun reuses it (the same result)")
        print(f"{name}: interrupted; {kept}", file=sys.stderr)
        return 130
    res["flow_cache"] = str(flow_cache) if flow_cache is not None else None
    res["model_files"] = files
    res["truth_checks"] = check_truths(res, training)
    print_notes(notes + truth_summary(res), name)  # once the run is not refused
    with out.writing() as stage:
        plot_evaluation(res, stage.dir / "decoder_eval.png")
        doc = document("evaluate-decoder", res, args)
        write_json(doc, stage.dir / "decoder_eval.json")
        if stage.file("--json") is not None:
            write_json(doc, stage.file("--json"))
    summary = {g: {m: {k: p[m][k] for k in ("speed_error", "direction_error_deg")}
                   for m in res["models"]}
               | {"improvement_pct": p["improvement_pct"],
                  # the intervals over the slots (bootstrap; None below 6 slots)
                  "improvement_ci95": {b: {k: c["ci95"] for k, c in by.items()}
                                       for b, by in p["improvement_ci95"]["decoder"].items()},
                  "acceptance": p["acceptance"], "n_slots": p["n_slots"]}
               for g, p in res["pooled"].items()}
    print(json.dumps(json_ready({"pooled": summary, "n_slots_run": res["n_slots_run"],
                      "stopped_by_budget": res["stopped_by_budget"],
                      "elapsed_s": round(res["elapsed_s"], 1)}), indent=1))
    print_written(out)
    if flow_cache is not None and Path(flow_cache).is_dir():  # its disk use said, not silent
        files = [f for f in Path(flow_cache).rglob("*") if f.is_file()]
        size = sum(f.stat().st_size for f in files)
        print(f"flow cache: {str(flow_cache)!r}, {size / 1e6:.1f} MB: reused by a rerun (and "
              "decoder-study --flow-cache); delete it to free the space, or pass "
              "--no-flow-cache", file=sys.stderr)
    return 0


def flow_cache_folder(args, name: str) -> Path | None:
    """The folder the run keeps its flows in: ``--flow-cache``, else ``--out``'s
    :data:`FLOW_CACHE` folder; None with ``--no-flow-cache``. Checked before any work, as
    :func:`~windnav.commands._common.cache_folder` checks ``--flow-cache``: a file where the
    folder should be is refused, naming the option that put it there."""
    if args.no_flow_cache:
        if args.flow_cache is not None:
            raise ValueError(f"The '--no-flow-cache' parameter of {name} keeps no flows, and "
                             f"'--flow-cache' names where to keep them: give one of the two. "
                             f"Got both (--flow-cache {str(args.flow_cache)!r}) instead.")
        return None
    if args.flow_cache is not None:
        return cache_folder(args.flow_cache, "--flow-cache", name)
    path = Path(args.out) / FLOW_CACHE
    if path.exists() and not path.is_dir():
        raise ValueError(f"The '--out' parameter of {name} must name a folder whose "
                         f"{FLOW_CACHE!r} (the default flow cache) is a folder or missing. Got "
                         f"{str(args.out)!r} instead, where {str(path)!r} is a file; pass "
                         "--flow-cache DIR or --no-flow-cache.")
    return path


def map_files(items, name: str) -> list[tuple[str, Path]]:
    """``--map`` values ``[NAME=]FILE``: ``[(NAME, FILE)]`` (:func:`map_argument`), each file
    read before any flow is solved, and refused when it has no buildings."""
    out = []
    for item in items:
        label, path, city = map_argument(item, "--map", name)
        if not len(city.footprints):  # (its samples lie near buildings: after the flow, said)
            raise ValueError(f"The '--map' parameter of {name} must be a map with buildings: "
                             "the decoder is scored at robots near them. Got "
                             f"{str(path)!r} instead, which has none.")
        out.append((label, path))
    return out


def _compare_files(items, name) -> dict | list:
    """``--compare`` values: ``{NAME: FILE}`` when every one is named, else the files."""
    pairs = [item.split("=", 1) if "=" in item else (None, item) for item in items]
    for _, file in pairs:
        if not Path(file).is_file():
            raise ValueError(f"The '--compare' parameter of {name} must be a decoder file "
                             f"([NAME=]FILE). Got {file!r} instead, which does not exist.")
    if all(n is not None for n, _ in pairs):
        return {n: Path(f) for n, f in pairs}
    if any(n is not None for n, _ in pairs):
        raise ValueError(f"The '--compare' parameter of {name} must name every model or none "
                         f"(NAME=FILE). Got {items!r} instead.")
    return [Path(f) for _, f in pairs]


def _named_compare_files(items, name) -> dict:
    """``--compare`` values that must all be named: ``{NAME: FILE}`` (empty for none)."""
    compare = _compare_files(items, name) if items else {}
    if isinstance(compare, list):
        raise ValueError(f"The '--compare' parameter of {name} must name every model "
                         f"(NAME=FILE). Got {items!r} instead.")
    return compare


def check_truths(res: dict, training: dict) -> dict:
    """Add ``averaging``, ``travel`` and ``notes`` to each record of ``res`` (its truth flow's,
    from the record's ``flow_diagnostics``, solved or read from the cache; see
    :func:`windnav.commands.predict.truth_notes`); returns the counts: ``slots``,
    ``not_converged``, ``young``, ``unknown``, ``travel_outside``."""
    from windnav.commands.predict import travel_check, truth_notes
    from windnav.flow.validity import averaging_verdict

    config = res["config"]
    counts = {"slots": len(res["records"]), "not_converged": 0, "young": 0, "unknown": 0,
              "travel_outside": 0, "training_travel_m": training["flow"]["travel_m"]}
    for rec in res["records"]:
        verdict = averaging_verdict(rec["flow_diagnostics"])
        travel = travel_check(training, rec["speed"], {"spinup_steps": config["spinup_steps"],
                                                       "steps": config["steps"],
                                                       "dt": rec["dt"]})
        rec.update(averaging=verdict, travel=travel, notes=truth_notes(verdict, travel))
        bucket = {"warning": "not_converged", "note": "young", "unknown": "unknown"}.get(
            verdict["level"])
        if bucket is not None:
            counts[bucket] += 1
        counts["travel_outside"] += int(travel["outside"])
    return counts


def averaging_failures(items) -> tuple[int, str] | None:
    """How many of ``items`` (dicts with ``averaging``, ``map`` and ``inlet``: evaluation
    records or study slots) fail the averaging rule, and the words after the count
    (``"(2 not converged, 1 young; e.g. dense-0 inlet 3: ...)"``); None when none does."""
    bad = [r for r in items if r["averaging"]["level"] in ("warning", "note")]
    if not bad:
        return None
    young = sum(r["averaging"]["level"] == "note" for r in bad)
    first = bad[0]
    return len(bad), (f"({len(bad) - young} not converged, {young} young; e.g. {first['map']} "
                      f"inlet {first['inlet']}: {first['averaging']['reason']})")


def truth_summary(res: dict) -> list[str]:
    """The note on the truths of an evaluation (empty when every one passes)."""
    from windnav.commands.predict import TRAVEL_TOLERANCE

    n, parts = res["truth_checks"]["slots"], []
    recs = res["records"]
    failing = averaging_failures(recs)
    if failing:
        parts.append(f"the truth flows of {failing[0]} of {n} slots fail the averaging rule "
                     f"{failing[1]}")
    far = [r for r in recs if r["travel"]["outside"]]
    if far:
        lo, hi = far[0]["travel"]["training_travel_m"]
        trained = f"{lo:.0f} m" if lo == hi else f"{lo:.0f}-{hi:.0f} m"
        slots = ", ".join(f"{r['map']} inlet {r['inlet']} ({r['speed']:.2f} m/s: "
                          f"{r['travel']['travel_m']:.0f} m)" for r in far[:10])
        parts.append(f"the air of {len(far)} of {n} slots travelled more than "
                     f"{TRAVEL_TOLERANCE:.0%} farther or "
                     f"shorter during spin-up and averaging than in the decoder's training "
                     f"flows ({trained}): {slots}{' ...' if len(far) > 10 else ''}")
    return ["; ".join(parts) + " (per slot: records[].averaging, .travel in the JSON)"] \
        if parts else []
