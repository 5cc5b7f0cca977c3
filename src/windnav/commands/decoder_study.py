"""``windnav decoder-study``: one study of the wind flow decoder, its figure and its JSON.

::

    windnav decoder-study eigenflows --out runs/studies --flow-cache runs/flows   # (e)
    windnav decoder-study gradients  --out runs/studies --flow-cache runs/flows   # (c)
    windnav decoder-study mosaic     --out runs/studies --flow-cache runs/flows   # (d)
    windnav decoder-study winds      --out runs/studies --runs runs/decoder_studies  # (a)
    windnav decoder-study size       --out runs/studies --runs runs/decoder_studies  # (b)
    windnav decoder-study averaging  --out runs/studies                           # label noise
    windnav decoder-study averaging  --out runs/studies_windinet --windinet       # ... windinet
    windnav decoder-study start      --out runs/studies                           # label spread
    windnav decoder-study scaling    --out runs/studies --runs runs/scaling           # maps, size
    windnav decoder-study noise      --out runs/studies --flow-cache runs/flows \
        --compare wrobot-noise=runs/wrobot_noise/model.npz                         # noisy W_robot
    windnav decoder-study direction  --out runs/studies_windinet --windinet --inlets 8  # where
    windnav decoder-study basis      --out runs/studies --flow-cache runs/flows --maps 2 \
        --inlets 3                                                                 # output modes
    windnav decoder-study eigenflows --out /tmp/s --quick                         # seconds

``eigenflows``, ``gradients`` and ``mosaic`` use the shipped decoder (or ``--model``) on the
mean flow of dense 1.2 km evaluation maps at random inlets (the protocol of ``windnav
evaluate-decoder``); ``--flow-cache`` keeps the flows, so the three share them. ``winds`` and
``size`` train models on a reduced copy of the default recipe (resumable, in ``--runs``; their
schedule is printed and recorded). ``averaging`` scores the shipped decoder and its baselines
against the mean of the thesis's short average and of a long one, on the default recipe's
held-out 600 m district (never trained on), or with ``--windinet`` on the third-party 1.1 km
layout, at 6 m/s (``--speed``, ``--direction-deg``): is the error the label noise of the short
average? ``start`` starts the same flow (same map and inlet) with four symmetry-breaking kicks
and averages each with the thesis protocol: how far apart are labels that differ only by an
arbitrary choice of the solver's start, and so how low can any model's error go? ``scaling``
trains the default recipe on a quarter, a half and all of its training maps (as many samples
per epoch) and a wider model on all of them (in ``--runs``, resumable; a ``maps-1-e40-n768``
folder there that holds a finished default-recipe run is reused): does the error fall with
more maps or with a bigger model? ``noise`` gives the decoder (and each ``--compare`` model)
a ``W_robot`` with noise of 0-0.2 U per component, as the Wind UKF gives it in flight, on the
flows of ``eigenflows``. ``direction`` bins the direction error of the decoder and its
baselines by the true speed over the inlet's and by the distance from the robot, on those
flows or with ``--windinet`` on the windinet layout at ``--inlets`` inlets, drawn for it as
the first map's (:func:`~windnav.experiments.decoder_eval.inlet_slots`): those of ``windnav
evaluate-decoder --maps 0`` with the same ``--seed`` and ``--inlets``, not those of its
windinet slots after dense maps (its default ``--maps 3`` draws them as the fourth map's).
``basis`` scores the best fields the d4-film's output modes
can express (each label fitted by least squares) beside the decoder, and the decoder's R^2 on
each of the labels' eigenflows within those modes, on the same flows (or ``--windinet``): is
the output basis what limits the decoder? ``--quick``:
a 150 m map and short flows, or the tiny recipe's sweep and models. ``--maps``, ``--inlets``
and ``--flow-cache`` are for the studies on evaluation flows (eigenflows, gradients, mosaic,
noise, direction, basis), ``--maps`` and ``--inlets`` not with ``--quick`` (one map, one
inlet), and ``--maps`` not with ``--windinet`` for direction and basis (the windinet layout is
their one map): where a study would ignore them they are refused, before any work. ``--map
[NAME=]FILE`` (since the fiftieth session) runs the studies on evaluation flows on a city of
your own, a RotorPy world JSON, instead (its inlets those of ``windnav evaluate-decoder --map
FILE`` alone with the same ``--seed`` and ``--inlets``, its flows shared through
``--flow-cache`` under the same NAME), e.g. the mosaic of your city::

    windnav decoder-study mosaic --map my_city.json --inlets 8 --out runs/mosaic_mine \
        --flow-cache runs/flows   # the first flow of evaluate-decoder --map my_city.json's

The harness is :mod:`windnav.experiments.decoder_studies`, the figures
:mod:`windnav.viz.decoder`.

Writes into ``--out``: ``decoder_<study>.json`` and ``decoder_<study>.png``.
"""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

from windnav._extras import require
from windnav._validate import positive_int
from windnav.commands._common import (
    add_boundary_argument,
    add_output_arguments,
    cache_folder,
    document,
    inlet_direction,
    model_files,
    options_named,
    outputs,
    path_argument,
    print_written,
    refuse_other_studies,
    seed,
    where,
)

TRAINING_STUDIES = ("winds", "size", "scaling")
"""The studies that train models (they need the ``train`` extra's torch)."""

STUDY_OPTIONS = {"epochs": ("winds", "size"), "samples_per_field": ("winds", "size"),
                 "sizes": ("size",), "compare": ("noise",), "runs": ("winds", "size", "scaling"),
                 "speed": ("averaging", "start"), "direction_deg": ("averaging", "start")}
"""The studies that read each of these options; given to another, it is refused."""

STUDIES = ("eigenflows", "gradients", "mosaic", "winds", "size", "averaging", "start",
           "scaling", "noise", "direction", "basis")
"""The studies, as named on the command line."""
FLOW_STUDIES = ("eigenflows", "gradients", "mosaic", "noise", "direction", "basis")
"""The studies on the flows of dense evaluation maps: the ones that read ``--maps``,
``--inlets`` and ``--flow-cache``."""
WINDINET_FLOW_STUDIES = ("direction", "basis")
"""The studies on evaluation flows that ``--windinet`` runs on the windinet layout instead of
``--maps`` dense maps."""
WINDINET_STUDIES = ("averaging", "start", *WINDINET_FLOW_STUDIES)
"""The studies that read ``--windinet`` (refused with the others, and with ``--quick``)."""
MAPS, INLETS = 1, 2
"""The defaults of ``--maps`` and ``--inlets``."""
SPEED, DIRECTION_DEG = 6.0, 3.75
"""The defaults of ``--speed`` (m/s) and ``--direction-deg`` (deg): averaging and start."""
QUICK_FLOW = {"spinup_steps": 20, "steps": 20}
"""The ``--quick`` flow protocol (steps), on 2 m cells."""


def register(subparsers) -> None:
    """Add the ``decoder-study`` subcommand."""
    p = subparsers.add_parser(
        "decoder-study",
        help="a study of the wind flow decoder (eigenflows, gradients, mosaic, winds, size, "
             "averaging, start, scaling, noise, direction, basis)",
        description=__doc__.splitlines()[0],
    )
    p.add_argument("study", choices=STUDIES, help="which study")
    p.add_argument("--out", type=path_argument, required=True, metavar="DIR",
                   help="output folder (JSON, figure)")
    p.add_argument("--seed", type=int, default=0,
                   help="seed of the inlets and the samples (default %(default)s)")
    p.add_argument("--quick", action="store_true",
                   help="a tiny run (tests): small map and short flows, or the tiny recipe")
    p.add_argument("--model", type=Path, default=None, metavar="FILE",
                   help="decoder file for gradients, mosaic, direction, averaging, start and "
                        "noise (default: the shipped model; eigenflows uses only its grid)")
    p.add_argument("--compare", action="append", default=[], metavar="NAME=FILE",
                   help="noise: another decoder, on --model's grid, scored beside --model "
                        "on the same samples (repeatable; read before any flow)")
    add_boundary_argument(p, "--model, and --compare's")
    p.add_argument("--maps", type=int, default=None, metavar="N",
                   help="dense 1.2 km evaluation maps (default 1; the mosaic uses the first; "
                        "not with --quick, whose one map is fixed, nor with direction or "
                        "basis --windinet, whose one map is the windinet layout)")
    p.add_argument("--inlets", type=int, default=None, metavar="N",
                   help="random inlets per map (default 2; the mosaic uses the first; not "
                        "with --quick, whose one inlet is fixed)")
    p.add_argument("--samples", type=int, default=None, metavar="N",
                   help="samples per (map, inlet) for eigenflows, gradients, noise, direction, "
                        "basis, averaging and start (default 2048; not with --quick, whose "
                        "studies take 64)")
    p.add_argument("--flow-cache", type=Path, default=None, metavar="DIR",
                   help="eigenflows, gradients, mosaic, noise, direction, basis: keep the flow "
                        "solutions here and reuse them (default: no cache)")
    p.add_argument("--runs", type=Path, default=None, metavar="DIR",
                   help="winds/size/scaling: the sweep store and trained models (default "
                        "runs/decoder_studies, runs/scaling, or with --quick ..._quick)")
    p.add_argument("--epochs", type=int, default=None,
                   help="winds/size: training epochs per model (default 20 for winds, 12 for "
                        "size; quick 2)")
    p.add_argument("--samples-per-field", type=int, default=None, metavar="N",
                   help="winds/size: training samples per mean field (default 384)")
    p.add_argument("--sizes", type=int, nargs="+", default=None, metavar="H",
                   help="size: the grid sizes H, cells per side of the H x H window, odd "
                        "(default 5 15 25 35 45; quick 5 15 25)")
    p.add_argument("--speed", type=float, default=None,
                   help=f"averaging, start: inlet speed, m/s ({SPEED:g})")
    p.add_argument("--direction-deg", type=float, default=None,
                   help="averaging, start: direction the inlet wind blows toward, deg CCW "
                        f"from +x ({DIRECTION_DEG:g})")
    p.add_argument("--windinet", action="store_true",
                   help="averaging, start: the third-party windinet 1.1 km layout instead of the "
                        "default recipe's held-out district; direction, basis: instead of the "
                        "dense evaluation maps (at --inlets inlets; not with --maps)")
    p.add_argument("--map", default=None, metavar="[NAME=]FILE",
                   help="eigenflows, gradients, mosaic, noise, direction, basis: a city of your "
                        "own (RotorPy world JSON) instead of the dense evaluation maps, at "
                        "--inlets inlets drawn as evaluate-decoder --map draws them alone (not "
                        "with --maps, --windinet or --quick)")
    p.add_argument("--no-progress", action="store_true", help="hide the progress bars")
    add_output_arguments(p)
    p.set_defaults(func=run)


def _quick_map():
    """The ``--quick`` studies' map: a 150 m dense district of 4 buildings."""
    from windnav.city import dense_map

    return dense_map(rng=7, size=150.0, lots_per_side=2, n_buildings=4)


def _windinet_map():
    """The third-party windinet layout (``--windinet``) as a City."""
    from windnav.city import read_rotorpy_json
    from windnav.experiments.decoder_eval import windinet_layout

    return read_rotorpy_json(windinet_layout())


def _inlet(args) -> tuple[float, float]:
    """``(--speed, --direction-deg)`` of the averaging and start studies, defaults filled in
    (the options default to None, so that another study can refuse them)."""
    return (SPEED if args.speed is None else args.speed,
            DIRECTION_DEG if args.direction_deg is None
            else inlet_direction(args.direction_deg, "--direction-deg", where(args)))


def _fields(args, name, simulate, progress):
    from windnav.experiments.decoder_studies import evaluation_fields

    first = 1 if args.study == "mosaic" else None  # the mosaic maps the first flow only

    if args.quick:
        maps = [("quick-0", _quick_map())]
        return evaluation_fields(maps, 1, seed=args.seed, dx=2.0, flow_settings=QUICK_FLOW,
                                 cache_dir=args.flow_cache, simulate=simulate,
                                 max_fields=first, progress=progress)
    # the defaults resolved here, not written into ``args``: its recorded ``arguments`` are
    # the parsed line, which windnav.provenance rebuilds from the words typed (``argv``)
    maps = positive_int(MAPS if args.maps is None else args.maps, "--maps", name)
    inlets = positive_int(INLETS if args.inlets is None else args.inlets, "--inlets", name)
    if args.windinet and args.study in WINDINET_FLOW_STUDIES:
        # one map, its inlets drawn as map 0's: evaluate-decoder's windinet inlets only with
        # its --maps 0 (and the same --seed and --inlets), where the layout is map 0 there too
        maps = [("windinet", _windinet_map())]
    own = None
    if args.map is not None:  # likewise map 0: evaluate-decoder --map FILE's, alone
        from windnav.city import read_rotorpy_json
        from windnav.commands.evaluate_decoder import map_files
        from windnav.experiments.decoder_eval import map_sha256

        ((label, path),) = map_files([args.map], name)
        maps = [(label, read_rotorpy_json(path))]
        own = {"map": label, "path": str(path), "sha256": map_sha256(path)}
    flows = evaluation_fields(maps, inlets, seed=args.seed, cache_dir=args.flow_cache,
                              simulate=simulate, max_fields=first, progress=progress)
    if own is not None:  # the file read, by hash (the JSON's flows.map_file)
        flows["map_file"] = own
    return flows


def _note_truths(flows: dict, name: str) -> None:
    """One note on stderr when some of the study's flows fail the averaging rule, as
    ``evaluate-decoder`` and ``predict`` say of their truths (a leftover of the thirty-eighth
    session: the studies said nothing); per flow in the JSON's ``flows.slots[].averaging``."""
    from windnav.commands.evaluate_decoder import averaging_failures

    failing = averaging_failures(flows["slots"])
    if failing:
        print(f"{name}: note: {failing[0]} of {len(flows['slots'])} flows fail the averaging "
              f"rule {failing[1]}; the study scores against them as they are (per flow: "
              "flows.slots[].averaging in the JSON)", file=sys.stderr)


def _averaging_map(args):
    """The averaging study's map, its name and protocol overrides (``--quick``: small)."""
    if args.quick:
        return (_quick_map(), "quick-0",
                {"dx": 2.0, "protocols": {"thesis": (10, 20), "long": (20, 80)}})
    if args.windinet:
        return _windinet_map(), "windinet", {}
    from windnav.predict.train import RECIPES, load_recipe, recipe_maps

    maps = recipe_maps(load_recipe(RECIPES / "default.toml"))
    name, _, city = next(m for m in maps if m[0] == "holdout-0")
    return city, name, {}


def _summary(study: str, res: dict) -> dict:
    """What the command prints."""
    if study == "averaging":
        return {"label_noise": res["label_noise"], "mean_speed": res["mean_speed"],
                "protocols": {k: {"steps": (p["spinup_steps"], p["steps"]),
                                  "half_window_difference":
                                      p["diagnostics"]["half_window_difference"],
                                  **{m: {e: p["errors"][m][e] for e in
                                         ("speed_error", "direction_error_deg")}
                                     for m in ("decoder", "local", "upstream")}}
                              for k, p in res["protocols"].items()}}
    if study == "start":
        return {"floor": res["floor"], "spread_rms_mps": res["spread_rms_mps"],
                "pairs": [{k: p[k] for k in ("a", "b", "speed_error", "direction_error_deg")}
                          for p in res["pairs"]],
                "kicks": {f"{r['kick']:g}": {m: {e: r["errors"][m][e] for e in
                                                 ("speed_error", "direction_error_deg")}
                                             for m in ("decoder", "local", "upstream")}
                          for r in res["kicks"]}}
    if study == "eigenflows":
        return {f: {"n_modes": res[f]["n_modes"],
                    "explained_16": float(res[f]["cumulative"][15])
                    if res[f]["cumulative"].size >= 16 else None}
                for f in ("world", "canonical")} | {"n_fields": res["n_fields"]}
    if study == "direction":
        return {m: {"direction_error_deg": r["direction_error_deg"],
                    **{axis: {k: r[axis][k] for k in ("share", "mean_deg", "contribution_deg")}
                       for axis in ("by_speed", "by_radius")}}
                for m, r in res["models"].items()} | {"speed_edges": res["models"]["decoder"][
                    "speed_edges"], "radius_edges": res["models"]["decoder"]["radius_edges"]}
    if study == "basis":
        return {"errors": {m: {k: e[k] for k in ("speed_error", "direction_error_deg")}
                           for m, e in res["errors"].items()},
                "r2_total": res["r2_total"],
                "fixed_modes": {k: {m: e[m] for m in ("speed_error", "direction_error_deg")}
                                for k, e in res["fixed_modes"].items()},
                "first_8_modes": {k: [round(float(v), 3) for v in res["modes"][k][:8]]
                                  for k in ("variance_share", "error_share", "r2")}}
    if study == "gradients":
        return {k: {"r2": res[k]["r2"], "pearson_r": res[k].get("pearson_r"),
                    "n_samples": res[k]["n_samples"],
                    **({"note": res[k]["note"]} if res[k].get("note") else {})}
                for k in ("decoder", "decoder_per_U")}
    if study == "mosaic":
        return {"metrics": {m: {k: res["metrics"][m][k] for k in
                                ("speed_error", "direction_error_deg", "vector_error")}
                            for m in ("decoder", "local", "upstream")},
                "improvement_pct": res["metrics"]["improvement_pct"],
                "coverage": res["coverage"], "n_robots": res["n_robots"],
                "n_moved": res["n_moved"]}
    if study == "noise":
        return {"levels": res["levels"], "w_robot_error_mps": res["w_robot_error_mps"],
                "errors": {m: [{k: e[k] for k in ("speed_error", "direction_error_deg")}
                               for e in errs] for m, errs in res["errors"].items()}}
    if study == "scaling":
        return {"per_doubling": res["per_doubling"], "variants": {
            n: {"maps": v["n_train_maps"], "parameters": v["n_parameters"],
                **{f"{who}_{k}": (v["errors"]["model"] if who == "test" else
                                  v["train_errors"]["decoder"])[k]
                   for who in ("test", "train") for k in ("speed_error",
                                                          "direction_error_deg")},
                "train_seconds": v["train_seconds"]} for n, v in res["variants"].items()}}
    return {"schedule": res["schedule"], "variants": {
        n: {"model": {k: v["errors"]["model"][k] for k in ("speed_error",
                                                             "direction_error_deg")},
            "local": {k: v["errors"]["local"][k] for k in ("speed_error",
                                                             "direction_error_deg")},
            "train_seconds": v["train_seconds"]}
        for n, v in res["variants"].items()}}


def run(args, simulate=None) -> int:
    """Run ``windnav decoder-study``; returns 0."""
    from windnav.commands._decoder_file import load_files
    from windnav.commands.evaluate_decoder import _named_compare_files
    from windnav.experiments import decoder_studies as ds
    from windnav.experiments.results import json_ready, write_json
    from windnav.viz import decoder as figures

    name = where(args)
    seed(args)
    study = args.study
    _check_flow_options(args, name)
    cache_folder(args.flow_cache, "--flow-cache", name)
    progress = not args.no_progress
    refuse_other_studies(args, name, STUDY_OPTIONS)  # scaling ignored the training options
    for flag, value in (("--samples", args.samples), ("--epochs", args.epochs),
                        ("--samples-per-field", args.samples_per_field)):
        if value is not None:
            positive_int(value, flag, name)
    if args.model is not None and not Path(args.model).is_file():
        raise ValueError(f"The '--model' parameter of {name} must be a decoder file. Got "
                         f"{str(args.model)!r} instead, which does not exist.")
    dec, compare, decoders = None, {}, {}
    if study not in TRAINING_STUDIES:  # (they train their own)
        # the decoders read now, not after minutes of flows: a file that is no decoder (a text
        # file, another .npz) was refused only then, naming load_decoder's 'path' (CLI audit)
        compare = _named_compare_files(args.compare, name)
        (dec,) = load_files([args.model], "--model", name, boundary=args.boundary)
        decoders = load_files(compare, "--compare", name, boundary=args.boundary)
        _check_compared(decoders, dec, name)
    # the weights a study that predicts reads, by hash (the training studies train their own)
    files = None if study in TRAINING_STUDIES else model_files(args)
    products = (f"decoder_{study}.json", f"decoder_{study}.png")
    out = outputs(args, out=("--out", args.out, products))
    if study in TRAINING_STUDIES:  # before their sweep, which ran whole before this failed
        require("torch", f"windnav {name} {study}")
    t0 = time.perf_counter()
    if args.quick and args.samples is not None:  # it was replaced by 64, unsaid (CLI audit)
        raise ValueError(f"The '--samples' parameter of {name} must not be given with --quick, "
                         f"whose studies take 64 samples. Got {args.samples!r} instead.")
    samples = 64 if args.quick else (2048 if args.samples is None else args.samples)
    flows = None
    if study == "noise":
        flows = _fields(args, name, simulate, progress)
        _note_truths(flows, name)
        res = ds.noise_study({"decoder": dec, **decoders}, flows["fields"], samples,
                             seed=args.seed)
        res["flows"] = {k: v for k, v in flows.items() if k != "fields"}
        res["models"] = {"decoder": str(args.model) if args.model else "default",
                         **{n: str(f) for n, f in compare.items()}}
        plot = figures.plot_noise
    elif study in ("eigenflows", "gradients", "mosaic", "direction", "basis"):
        flows = _fields(args, name, simulate, progress)
        _note_truths(flows, name)
        fields = flows["fields"]
        if study == "eigenflows":
            res = ds.eigenflow_study(fields, samples, seed=args.seed, size=dec.size,
                                     spacing=dec.spacing)
            plot = figures.plot_eigenflows
        elif study == "gradients":
            res = ds.gradient_study(dec, fields, samples, seed=args.seed)
            plot = figures.plot_gradients
        elif study == "direction":
            res = ds.direction_study(dec, fields, samples, seed=args.seed)
            plot = figures.plot_direction
        elif study == "basis":
            with options_named({"'samples_per_field' parameter of basis_study":
                                f"'--samples' parameter of {name}"}):
                res = ds.basis_study(dec, fields, samples, seed=args.seed)
            plot = figures.plot_basis
        else:
            res = ds.mosaic(dec, fields[0], rng=args.seed, progress=progress)
            plot = figures.plot_mosaic
        res["flows"] = {k: v for k, v in flows.items() if k != "fields"}
        res["model"] = {"path": str(args.model) if args.model else "default",
                          "architecture": dec.architecture, "size": dec.size,
                          "boundary": dec.boundary}
    elif study == "averaging":
        city, map_name, kw = _averaging_map(args)
        with options_named({"'speed' parameter of averaging_study": f"'--speed' parameter of "
                                                                     f"{name}"}):
            speed, direction = _inlet(args)
            res = ds.averaging_study(dec, city, speed=speed, direction_deg=direction,
                                     samples=samples, seed=args.seed, simulate=simulate,
                                     name=map_name, **kw)
        plot = figures.plot_averaging
    elif study == "start":
        city, map_name, kw = _averaging_map(args)
        protocols = kw.pop("protocols", None)
        if protocols is not None:  # --quick: the short protocol
            kw["spinup_steps"], kw["steps"] = protocols["thesis"]
        speed, direction = _inlet(args)
        res = ds.start_study(dec, city, speed=speed, direction_deg=direction,
                             samples=samples, seed=args.seed, simulate=simulate,
                             name=map_name, **kw)
        plot = figures.plot_start
    elif study == "scaling":
        runs = args.runs or Path("runs/scaling" + ("_quick" if args.quick else ""))
        res = ds.scaling_study(runs, quick=args.quick, progress=progress, seed=args.seed)
        res["runs"] = str(runs)
        plot = figures.plot_scaling
    else:
        runs = args.runs or Path("runs/decoder_studies" + ("_quick" if args.quick else ""))
        kw = dict(quick=args.quick, epochs=args.epochs, samples_per_field=args.samples_per_field,
                  progress=progress, seed=args.seed)
        if study == "winds":
            res = ds.winds_ablation(runs, **kw)
            plot = figures.plot_winds_ablation
        else:
            sizes = args.sizes or ((5, 15, 25) if args.quick else ds.SIZES)
            with options_named({"'sizes' parameter of size_study":
                                f"'--sizes' parameter of {name}"}):
                res = ds.size_study(runs, sizes=sizes, **kw)
            plot = figures.plot_size_study
        res["runs"] = str(runs)
    res["elapsed_s"] = time.perf_counter() - t0
    res["quick"] = bool(args.quick)
    if files is not None:
        res["model_files"] = files
    with out.writing() as stage:
        plot(res, stage.dir / products[1])
        doc = document("decoder-study", {"study": study, **_drop_bulk(study, res)}, args)
        write_json(doc, stage.dir / products[0])
        if stage.file("--json") is not None:
            write_json(doc, stage.file("--json"))
    print(json.dumps(json_ready({"study": study, **_summary(study, res),
                                 "elapsed_s": round(res["elapsed_s"], 1)}), indent=1))
    print_written(out)
    return 0


def _check_compared(decoders: dict, dec, name: str) -> None:
    """Refuse, before any flow, ``--compare`` models the noise study cannot score beside
    ``--model``'s ``dec``: one named as a model it scores itself (``decoder`` replaced the
    decoder, unsaid; ``local``, ``upstream``), or on another grid (refused after the flows)."""
    for label, model in decoders.items():
        if label in ("decoder", "local", "upstream"):
            raise ValueError(f"The '--compare' parameter of {name} must name each model other "
                             "than decoder, local and upstream (the study's own). Got "
                             f"{label!r} instead.")
        if (model.size, model.spacing) != (dec.size, dec.spacing):
            raise ValueError(f"The '--compare' parameter of {name} must hold models on "
                             f"--model's grid ({dec.size} cells of {dec.spacing:g} m). Got "
                             f"{label!r} with {model.size} cells of {model.spacing:g} m "
                             "instead.")


def _check_flow_options(args, name: str) -> None:
    """Refuse ``--windinet``, ``--flow-cache``, ``--maps`` and ``--inlets`` where the study
    would ignore them (a study without a windinet variant; a study that simulates no
    evaluation flows; ``--quick``, whose one map and inlet are fixed; ``--maps`` for direction
    and basis with ``--windinet``, whose one map is the windinet layout), before any work.
    ``args`` is left as parsed (unset ``--maps`` and ``--inlets`` stay None: :func:`_fields`
    resolves them), so the result records the line as typed."""
    study = args.study
    if args.map is not None:
        if study not in FLOW_STUDIES:
            raise ValueError(f"The '--map' parameter of {name} is for the studies on "
                             f"evaluation flows ({', '.join(FLOW_STUDIES)}). Got {args.map!r} "
                             f"for {study!r} instead.")
        for flag, given in (("--maps", args.maps is not None), ("--windinet", args.windinet),
                            ("--quick", args.quick)):
            if given:
                raise ValueError(f"The '--map' parameter of {name} names the one map of the "
                                 f"{study} study: not with {flag}. Got --map {args.map!r} with "
                                 f"{flag} instead.")
    if args.windinet and study not in WINDINET_STUDIES:
        raise ValueError(f"The '--windinet' parameter of {name} is for the studies "
                         f"{', '.join(WINDINET_STUDIES)}; the {study} study would ignore it. "
                         f"Got --windinet for {study!r} instead.")
    if args.windinet and args.quick:
        raise ValueError(f"The '--windinet' parameter of {name} does not apply with --quick "
                         "(one 150 m map, which --quick fixes). Got --windinet with --quick "
                         "instead.")
    if args.flow_cache is not None and study not in FLOW_STUDIES:
        raise ValueError(f"The '--flow-cache' parameter of {name} is for the studies on "
                         f"evaluation flows ({', '.join(FLOW_STUDIES)}); the {study} study "
                         f"keeps no flows. Got {str(args.flow_cache)!r} for {study!r} instead.")
    for flag, value in (("--maps", args.maps), ("--inlets", args.inlets)):
        if value is None:
            continue
        if study not in FLOW_STUDIES:
            raise ValueError(f"The {flag!r} parameter of {name} is for the studies on "
                             f"evaluation flows ({', '.join(FLOW_STUDIES)}). Got {value!r} for "
                             f"{study!r} instead.")
        if args.quick:
            raise ValueError(f"The {flag!r} parameter of {name} does not apply with --quick "
                             f"(one 150 m map, one inlet). Got {value!r} with --quick instead.")
        if flag == "--maps" and args.windinet and study in WINDINET_FLOW_STUDIES:
            raise ValueError(f"The '--maps' parameter of {name} does not apply with --windinet "
                             f"for the {study} study (its one map is the windinet layout; "
                             f"--inlets sets its inlets). Got {value!r} with --windinet "
                             "instead.")


def _drop_bulk(study: str, res: dict) -> dict:
    """The result without its per-cell and per-sample arrays (kept small in the JSON)."""
    out = dict(res)
    if study == "eigenflows":
        out = {**out, **{f: {k: v for k, v in res[f].items() if k not in ("modes", "mean")}
                         for f in ("world", "canonical")}}
        for f in ("world", "canonical"):
            out[f]["explained_variance_ratio"] = res[f]["explained_variance_ratio"][:200]
            out[f]["cumulative"] = res[f]["cumulative"][:200]
    elif study == "gradients":
        out = {**out, **{k: {kk: vv for kk, vv in res[k].items() if kk not in ("pred", "true")}
                         for k in ("decoder", "decoder_per_U")}}
    elif study == "averaging":
        out = {k: v for k, v in res.items() if k != "difference"}
    elif study == "start":
        out = {k: v for k, v in res.items() if k != "spread"}
    elif study == "basis":
        out = {k: v for k, v in res.items() if k != "eigenflow_fields"}
    elif study == "mosaic":
        out = {k: v for k, v in res.items()
               if k not in ("truth", "prediction", "local", "free", "covered", "x", "y",
                            "robots")}
    return out
