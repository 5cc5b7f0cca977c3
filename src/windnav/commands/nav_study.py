"""``windnav nav-study``: the navigation benchmark's studies, each one command writing a figure and
JSON into ``--out``.

::

    windnav nav-study qe    --store runs/thesis --maps 0-1 --out docs/navigation   # Q_E sweep
    windnav nav-study h     --store runs/thesis --maps 0-1 --out docs/navigation   # H sweep
    windnav nav-study cases --store runs/thesis --out docs/navigation    # best and worst cases
    windnav nav-study winds --map 0 --out docs/navigation                # 4 winds of one map
    windnav nav-study gs    --out docs/navigation                        # cases against GS
    windnav nav-study pace  --store runs/thesis --out docs/navigation    # time and power
    windnav nav-study feasibility --store runs/thesis --out docs/navigation  # reachable?
    windnav nav-study gusts --out docs/navigation                        # gust-aware routes
    windnav nav-study bound --store runs/thesis --out docs/navigation    # energy bound
    windnav nav-study tilt  --store runs/thesis --maps 0-1 --out docs/navigation   # tilt cap
    windnav nav-study inflight --maps 0-3 --out docs/img/navigation   # the decoder in flight

``qe`` and ``h`` fly MPPI and EA-MPPI+W at each value of ``Q_E`` (default 0, 0.5, 1, 2, 3, 4,
5, 6) or ``H`` (0, 25, 50, 100, 200, inf m) through the suite's scenarios of ``--maps`` into the
benchmark store ``--store`` (:func:`windnav.experiments.nav_benchmark.run_benchmark`: resumable,
one wind per map and inlet, shared with whatever the store already holds; values that are
thesis variants fly under their names), then plot the paired energy reduction against MPPI per
value, overall and per inlet speed, with the failure rate
(:mod:`windnav.experiments.nav_sweeps`). A rerun flies nothing already recorded.

``cases`` ranks the store's scenarios where neither MPPI nor EA-MPPI+W (``--variant``) failed
by the paired energy reduction, re-flies the best and the worst with both (their winds simulated
again, so the flights are the recorded ones) and draws each: the paths over the mean wind, and
airspeed, power and energy against time (:mod:`windnav.experiments.nav_cases`). ``winds`` draws
4 of a map's 16 winds (one per inlet speed and incidence: w01, w06, w11, w12) with the start and
goal of each pair. ``gs`` flies MPPI, EA-MPPI+W (``Q_E = 3``, ``H = 90`` m), GS and GS+W on
the three case studies of :mod:`windnav.experiments.gs_cases` (an intersection, a single
building, a scenario of the thesis suite; ``--case`` picks one) and draws each. ``pace``
splits the energy ratio of ``--variant`` to MPPI over the store's pairs into a time ratio and a
mean-power ratio, with the vehicle's power curve and the ``@power=crazyflie`` counterfactual
where the store has it (:mod:`windnav.experiments.nav_pace`); it flies nothing.
``feasibility`` simulates the winds of ``--maps`` (cached in ``--cache``, resumable) and bounds
from below the time any planner needs to reach each scenario's goal within the vehicle's
airspeed envelope (:mod:`windnav.experiments.nav_feasibility`), then sets the failures of the
flights in ``--store`` (optional) against which scenarios are reachable at all; ``--fly
VARIANTS`` also flies those variants' pending flights into ``--store`` in the same winds.
``gusts`` re-flies one scenario (``--scenario``) with the sixth variant's setting ``--base``
and with ``--base@gust=K`` (``--gust-k``) and draws the mean wind and the gust map (the
standard deviation of the wind along the inlet) with the least-time routes each flew
(:mod:`windnav.experiments.nav_gusts`). ``bound`` reads the store's GS+W flights (each records the
energy-optimal route it planned in the mean wind) and sets every variant flown on the same
scenarios (but the ``@power=`` counterfactuals, whose energies use another curve) against the
largest table ratio and paired reduction any planner could reach
(:mod:`windnav.experiments.nav_bound`); it flies nothing. ``tilt`` flies the thesis's four
variants at each tilt cap of ``--values`` (degrees, default 55 70 78; 55 is the variants
themselves, the others ``@tilt=`` labels) through the scenarios of ``--maps`` into ``--store``,
then sets each cap's variants against its own MPPI: failure, commanded acceleration, paired
energy (:mod:`windnav.experiments.nav_tilt`). ``inflight`` re-flies the scenarios of ``--maps``
(pairs ``--pairs``, default one tailwind and one headwind, 0 and 2) with the onboard stack
(``--variant``, default ``ea-mppi-w-hat@outside=robot``) and scores the decoder and the
baselines along the paths against the mean field, given the UKF's, the mean and the true
instantaneous ``W_robot`` (and, with ``--tau``, the UKF's estimate averaged over time)
(:mod:`windnav.experiments.nav_inflight`); it needs no store. It keeps each finished wind's
flights in ``--out``'s ``nav_inflight.partial.jsonl`` until its outputs are written: after
Ctrl-C (exit 130) or a kill, rerunning the same command flies only the winds not yet done, with
the uninterrupted run's result.

A store flown by ``windnav benchmark-nav --decoder FILE`` (the onboard stack flying a decoder
file of your own) holds that decoder in its suite's settings: the studies on a store (``qe``,
``h``, ``cases``, ``pace``, ``bound``, ``tilt``, ``feasibility``) take the same ``--decoder
FILE``, and the flights they fly into it fly it (``cases --variant ea-mppi-w-hat``); without
it, or with another file, such a store is refused naming the option. ``feasibility`` keeps its
reach cache the suite's (without a decoder) and reads such a store; its ``--fly`` does not fly
into one (refused, naming it): fly with ``benchmark-nav --decoder``. ``inflight --decoder
FILE`` (it needs no store) flies that file in the onboard stack and scores it along the paths
(the variant without ``@decoder=``; ``--compare NAME=FILE`` scores others on the same samples
without flying them).

``--map [NAME=]FILE`` (since the fifty-first session) studies a city of your own, as
``windnav benchmark-nav --map`` flies it: a store of that command (``--store``) holds its
suite, and every study on it takes the same map again (refused without it, naming it); with no
store, ``--suite``'s rule (default thesis) on that city (``winds``, ``inflight``, ``gusts``,
``feasibility``). ``--map N`` remains the winds study's map index::

    windnav nav-study winds --suite thesis --map my_city.json --out runs/winds_mine

``--pair-distance``, ``--edge`` and ``--clearance`` (since the fifty-second session) change that
rule on the city, as ``benchmark-nav`` takes them; on a store they may only repeat its own.
"""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

from windnav._validate import positive_int
from windnav.commands._common import (
    add_output_arguments,
    check_output_path,
    document,
    fill_defaults,
    model_files,
    options_named,
    outputs,
    path_argument,
    print_written,
    refuse_other_studies,
    where,
)
from windnav.commands._decoder_file import (
    decoder_file,
    load_files,
    refuse_other_views,
    store_decoder,
    with_decoder,
)

STUDIES = ("qe", "h", "cases", "winds", "gs", "pace", "feasibility", "gusts", "bound", "tilt",
           "inflight")
"""The studies, as named on the command line."""


def register(subparsers) -> None:
    """Add the ``nav-study`` subcommand."""
    from windnav.commands._city_suite import add_city_rule_arguments
    from windnav.experiments.executor import BACKENDS
    from windnav.experiments.nav_suite import SUITES

    p = subparsers.add_parser(
        "nav-study",
        help="the navigation benchmark's studies (Q_E and H sweeps, best and worst cases, "
             "wind scenarios, cases against GS)",
        description="The navigation benchmark's studies: the Q_E and H sweeps of EA-MPPI+W "
                    "against MPPI flown into a benchmark store, the best and worst cases of a "
                    "store, the wind scenarios of a map; each writes figures and JSON.",
    )
    p.add_argument("study", choices=STUDIES)
    p.add_argument("--out", type=path_argument, required=True, help="output folder (figure, JSON)")
    p.add_argument("--store", type=Path, default=None,
                   help="qe, h, tilt: the benchmark store the flights go to (created or "
                        "resumed); "
                        "cases, pace, bound: the store whose records are read (no default: "
                        "these studies need it)")
    p.add_argument("--suite", choices=tuple(SUITES), default=None,
                   help="the suite (default: the --store's own, with its seed; else thesis)")
    p.add_argument("--maps", default=None, metavar="LIST",
                   help="the suite's maps to fly, e.g. 0-1 (default: all)")
    p.add_argument("--values", type=float, nargs="+", default=None,
                   help="the values swept: qe, Q_E; h, the window side H, m; tilt, the "
                        "tilt cap, deg (default: qe 0 0.5 1 2 3 4 5 6; h 0 25 50 100 200 "
                        "inf; tilt 55 70 78)")
    p.add_argument("--variant", default=None,
                   help="cases, pace: the variant compared with MPPI (default ea-mppi-w); "
                        "inflight: the onboard-stack variant re-flown (default "
                        "ea-mppi-w-hat@outside=robot)")
    p.add_argument("--pairs", default=None, metavar="LIST",
                   help="inflight: the pairs of each wind flown (default 0,2: one tailwind, "
                        "one headwind)")
    p.add_argument("--every", type=float, default=None,
                   help="inflight: seconds between samples along a flight (default 0.5)")
    p.add_argument("--compare", action="append", default=[], metavar="NAME=FILE",
                   help="inflight: another decoder scored on the same samples (repeatable; it "
                        "does not fly)")
    p.add_argument("--tau", type=float, nargs="+", default=[], metavar="S",
                   help="inflight: also score the decoder and Local given the UKF's estimate "
                        "averaged over time with each time constant, s (> 0; the onboard "
                        "stack's '@tau=S'); nothing flies differently (default: none)")
    p.add_argument("--map", type=map_option, default=None, metavar="N|[NAME=]FILE",
                   help="winds: the suite's map N (default 0); every study but gs: "
                        "[NAME=]FILE, a city of your own (a RotorPy world JSON) as the suite's "
                        "one map, as 'benchmark-nav --map' flies it (a store of that command "
                        "needs the same map again)")
    add_city_rule_arguments(p)
    p.add_argument("--case", default=None,
                   help="gs: one case (intersection, single-building, evaluation-map; default "
                        "all)")
    p.add_argument("--seed", type=int, default=None, help="gs: the flights' seed (default 0)")
    p.add_argument("--cache", type=Path, default=None,
                   help="feasibility: folder of the per-scenario reach records (created or "
                        "resumed; one suite and seed per folder, refused for another; default "
                        "runs/reach)")
    p.add_argument("--airspeeds", type=float, nargs="+", default=None,
                   help="feasibility: the airspeed limits searched, m/s (default: 10, the "
                        "Hummingbird's envelope limit 13.45, 16); the figure and table use the "
                        "envelope limit")
    p.add_argument("--fly", default=None, metavar="VARIANTS",
                   help="feasibility: also fly these variants' pending flights (comma-separated "
                        "labels) into --store, in the same winds (default: none)")
    p.add_argument("--scenario", default=None,
                   help="gusts: the scenario re-flown (default thesis/m12/w14/p2)")
    p.add_argument("--base", default=None,
                   help="gusts: the sixth variant's setting, without @gust (default "
                        "ea-mppi-w-esc@escair=13.45@edge=15@pace=20@regain=20@launch=40)")
    p.add_argument("--gust-k", type=float, default=None,
                   help="gusts: the gust margin, standard deviations (default 0.5)")
    p.add_argument("--executor", choices=BACKENDS, default=None,
                   help="qe, h, tilt, inflight, feasibility: where the flights run (process)")
    p.add_argument("--workers", type=int, default=None,
                   help="worker processes (default: all cores); each holds one 600 m wind, "
                        "2.3 GB")
    p.add_argument("--native-arithmetic", action="store_true", default=None,
                   help="cases: re-fly under this machine's own BLAS kernel and NumPy SIMD "
                        "loops; by default the command restarts under the records' when they "
                        "differ and this CPU can run them (a flight re-flies as recorded only "
                        "under the arithmetic that flew it)")
    p.add_argument("--decoder", type=Path, default=None, metavar="FILE",
                   help="qe, h, cases, pace, bound, tilt, feasibility: the decoder file the "
                        "store's onboard stack flew: a store of 'benchmark-nav --decoder FILE' "
                        "needs the same file again, and the flights a study flies into it "
                        "(cases: ea-mppi-w-hat) fly it; inflight: the decoder file the "
                        "onboard stack flies and is scored (the variant without '@decoder=')")
    p.add_argument("--no-progress", action="store_true", help="hide the progress bar")
    add_output_arguments(p)
    p.set_defaults(func=run)


_SUITE_STUDIES = tuple(s for s in STUDIES if s != "gs")  # (gs reads no suite)

STUDY_OPTIONS = {
    "store": ("qe", "h", "cases", "pace", "bound", "tilt", "feasibility"),
    "maps": ("qe", "h", "pace", "bound", "tilt", "inflight", "feasibility"),
    "values": ("qe", "h", "tilt"),
    "variant": ("cases", "pace", "inflight"),
    "workers": ("qe", "h", "tilt", "inflight", "feasibility"),
    "executor": ("qe", "h", "tilt", "inflight", "feasibility"),
    "suite": _SUITE_STUDIES,
    "pairs": ("inflight",), "every": ("inflight",), "compare": ("inflight",),
    "tau": ("inflight",),
    "map": _SUITE_STUDIES,
    **dict.fromkeys(("pair_distance", "edge", "clearance"), _SUITE_STUDIES),
    "case": ("gs",), "seed": ("gs",),
    "cache": ("feasibility",), "airspeeds": ("feasibility",), "fly": ("feasibility",),
    "scenario": ("gusts",), "base": ("gusts",), "gust_k": ("gusts",),
    "native_arithmetic": ("cases",),
    "decoder": ("qe", "h", "cases", "pace", "bound", "tilt", "feasibility", "inflight"),
}
"""The studies that read each option; given to another, it is refused."""

LATE_DEFAULTS = {"pairs": "0,2", "every": 0.5, "map": 0, "seed": 0,
                 "cache": Path("runs/reach"), "gust_k": 0.5, "executor": "process",
                 "native_arithmetic": False}
"""Defaults set once the options are checked (None until then, so that a given one shows)."""


def _check_study_options(args, name: str) -> None:
    """Refuse an option the study does not read, then fill in :data:`LATE_DEFAULTS`: such
    options were accepted and ignored, only the JSON's ``arguments`` differing (``bound
    --variant mppi --values 3 --seed 7`` wrote the plain ``bound``'s results; CLI audit,
    2026-12-05). The keys filled are kept in ``args.filled_defaults``, which
    :func:`windnav.experiments.results.document` records as None, so that the JSON's
    ``arguments`` stay the line as typed, which ``windnav.provenance`` parses back to them (a
    result recorded the filled values, and its typed line did not parse back to it)."""
    refuse_other_studies(args, name, STUDY_OPTIONS)
    if isinstance(args.map, int) and args.study != "winds":
        raise ValueError(f"The '--map' parameter of {name} is a map index for the winds study "
                         "only; the other studies take a city of your own, [NAME=]FILE. Got "
                         f"{args.map!r} for {args.study!r} instead.")
    fill_defaults(args, LATE_DEFAULTS)


def _with_decoder(args, name: str, spec):
    """``spec`` whose onboard stack flies ``--decoder``
    (:func:`windnav.commands._decoder_file.with_decoder`): a store flown by ``benchmark-nav
    --decoder FILE`` holds that decoder in its suite's settings, and was refused as another
    suite's without a way to give it (the forty-ninth session's note). ``feasibility --fly``
    into such a store, or with ``--decoder``, is refused naming ``--fly`` (its flights are
    flown with the reach cache's suite, which has no decoder), and ``feasibility --decoder``
    without ``--store`` (the other studies need a store: theirs is the error). The sweeps
    (``qe``, ``h``, ``tilt``) fly no decoder into such a store: a note says so, as
    ``benchmark-nav`` does."""
    from windnav.commands.benchmark_nav import _manifest

    man = (None if args.store is None else _manifest(Path(args.store))) or {}
    if args.study == "feasibility" and args.fly and (
            args.decoder is not None or store_decoder(man, spec)[1] is not None):
        raise ValueError(f"The '--fly' parameter of {name} flies into a store of the suite "
                         "without a decoder: a store of 'benchmark-nav --decoder FILE' is "
                         "flown with that command. Got --fly "
                         f"{args.fly!r} with {'--decoder' if args.decoder else 'such a store'} "
                         "instead.")
    if args.decoder is not None and args.store is None and args.study == "feasibility":
        raise ValueError(f"The '--decoder' parameter of {name} names the decoder of --store's "
                         f"flights. Got {str(args.decoder)!r} without --store instead.")
    if args.decoder is not None and args.study in ("qe", "h", "tilt"):
        print(f"{name}: note: the {args.study} study's variants fly no decoder; --decoder "
              "names the store's", file=sys.stderr)
    return with_decoder(args, name, spec, man)


def _check_store(store: Path, name: str) -> None:
    """``--store`` names an existing benchmark store (the studies that only read one)."""
    if not (store / "manifest.json").is_file():
        raise ValueError(f"The '--store' parameter of {name} must name a benchmark store (with "
                         f"manifest.json). Got {str(store)!r} instead.")


def _write(out, args, payload: dict, json_name: str, draw) -> None:
    """Write a study's outputs together: its figures (``draw(folder)``) and its JSON
    (``payload`` as a ``nav-study`` document) into the output folder, the JSON also to
    ``--json``."""
    from windnav.experiments.results import write_json

    with out.writing() as stage:
        draw(stage.dir)
        doc = document("nav-study", {**payload, **decoder_file(args)}, args)
        write_json(doc, stage.dir / json_name)
        if stage.file("--json") is not None:
            write_json(doc, stage.file("--json"))


def map_option(text: str) -> int | str:
    """``--map``'s value: a map index (ASCII digits, signed) as an int, anything else as the
    text of a city file, ``[NAME=]FILE`` (``./3`` for a file named ``3``)."""
    body = text[1:] if text.startswith("-") else text
    return int(text) if body.isascii() and body.isdigit() else text


def study_suite(args):
    """The suite of a study: ``--suite``, else the ``--store``'s own (its manifest's), else the
    thesis suite; with the store's seed when it is the store's suite, else 0. The suite was
    always the thesis suite with seed 0, so a store flown with ``benchmark-nav --seed 5`` (or
    another suite) could not be studied: nav-study's ``--seed`` is the gs study's (CLI audit,
    thirty-seventh session). With ``--map [NAME=]FILE``, the suite on that city
    (:func:`windnav.commands._city_suite.city_suite`): the store's, else ``--suite``'s
    (default thesis) rule on it; a store of a city without ``--map`` is refused naming it."""
    from windnav.commands._city_suite import city_rule, city_suite, store_city
    from windnav.commands.benchmark_nav import _manifest
    from windnav.experiments.nav_suite import SUITES, get_suite

    store = getattr(args, "store", None)
    man = (_manifest(Path(store)) if store is not None else None) or {}
    recorded = store_city(man)
    given = getattr(args, "map", None)
    rule = city_rule(args)  # (refused without a city)
    if isinstance(given, str):  # a city of one's own: the store's suite, else --suite's
        suite = args.suite or (None if recorded is not None else "thesis")
        return city_suite(given, where(args), man, suite=suite, seed_value=None, store=store,
                          rule=rule)
    if recorded is not None:  # (it was refused as another suite's, naming no option)
        given = None if "map" in getattr(args, "filled_defaults", ()) else given
        raise ValueError(f"The '--map' parameter of {where(args)} must name the map file that "
                         f"the store {str(store)!r} was flown on (suite {man.get('suite')!r}, "
                         f"{recorded}). Got {given!r} instead.")
    own = man.get("suite") if man.get("suite") in SUITES else None
    suite = args.suite or own or "thesis"
    value = man.get("seed", 0) if suite == own else 0
    return get_suite(suite, seed=int(value) if isinstance(value, int) else 0)


def run(args) -> int:
    """Run ``windnav nav-study``; 0 when every flight flew, 1 when some harness failed."""
    from windnav.commands.benchmark_nav import suite_maps
    from windnav.experiments import nav_sweeps
    from windnav.experiments.nav_benchmark import NavStore, run_benchmark
    from windnav.experiments.results import json_ready
    from windnav.viz.nav_sweeps import plot_sweep

    name = where(args)
    study = args.study
    _check_study_options(args, name)  # (first: gs reads no suite, and --map 3 is winds')
    spec = study_suite(args)
    plain = spec  # the suite without --decoder: feasibility's reach cache is the suite's
    if study in STUDY_OPTIONS["decoder"]:
        spec = _with_decoder(args, name, spec)
    if study == "winds":
        return _winds(args, name, spec)
    if study == "gs":
        return _gs(args, name)
    if study == "feasibility":
        return _feasibility(args, name, plain, spec)
    if study == "gusts":
        return _gusts(args, name, spec)
    if study == "inflight":
        return _inflight(args, name, spec)
    if args.store is None:
        raise ValueError(f"The '--store' parameter of {name} must name a benchmark store for "
                         f"the {study} study. Got None instead.")
    check_output_path(args.store, "--store", name, kind="dir")
    if study == "cases":
        return _cases(args, name, spec)
    if study == "pace":
        return _pace(args, name, spec)
    if study == "bound":
        return _bound(args, name, spec)
    if study == "tilt":
        return _tilt(args, name, spec)
    maps = suite_maps(args.maps, spec, name)
    workers = None if args.workers is None else positive_int(args.workers, "--workers", name)
    with options_named({"'values' parameter of sweep_labels": f"'--values' parameter of {name}"}):
        labels = nav_sweeps.sweep_labels(study, args.values)
    products = (f"nav_sweep_{study}.json", f"nav_sweep_{study}.png")
    out = outputs(args, out=("--out", args.out, products))
    t0 = time.perf_counter()
    variants = [nav_sweeps.REFERENCE, *dict.fromkeys(labels.values())]
    summary = run_benchmark(spec, variants, args.store, executor=args.executor,
                            workers=workers, progress=not args.no_progress, maps=maps)
    records = [r for r in NavStore(args.store, spec, create=False).load()
               if r["map_index"] in maps]
    res = nav_sweeps.sweep_table(records, labels)
    sweep = nav_sweeps.SWEEPS[study]
    res.update(study=study, suite=spec.name, maps=list(maps), store=str(args.store),
               flights_now=summary["now"], errors_now=summary["errors_now"],
               elapsed_s=time.perf_counter() - t0)
    _write(out, args, res, products[0], lambda folder: plot_sweep(
        res, folder / products[1], name=sweep["name"], unit=sweep["unit"]))
    brief = {f"{v:g}": {"label": r["label"], "failure_pct": r["failure_pct"],
                        "paired_reduction": r["paired_reduction"]["mean"],
                        "pairs": r["paired_reduction"]["n"]}
             for v, r in res["rows"].items()}
    print(json.dumps(json_ready({"study": study, "reference_failure_pct":
                                 res["reference_failure_pct"], "values": brief,
                                 "flights_now": summary["now"],
                                 "elapsed_s": round(res["elapsed_s"], 1)}), indent=1))
    print_written(out)
    return 1 if summary["errors_now"] or summary["pending"] else 0


def _cases(args, name: str, spec) -> int:
    import argparse

    from windnav.commands.benchmark_nav import _manifest, _pinned, _reproduced
    from windnav.experiments.nav_benchmark import NavStore, compare_records
    from windnav.experiments.nav_cases import best_worst, fly_cases
    from windnav.experiments.nav_records import latest_records, record_arithmetic
    from windnav.experiments.results import json_ready
    from windnav.viz.nav_studies import plot_cases

    _check_store(args.store, name)
    (variant,) = _one_variant(args, name)
    refuse_other_views(args, name, [variant], "--variant")
    tags = ("best", "worst")
    products = ("nav_cases.json", *(f"{t}_{k}.png" for t in tags for k in ("paths", "energy")))
    out = outputs(args, out=("--out", args.out, products))
    t0 = time.perf_counter()
    stored = NavStore(args.store, spec, create=False).load()  # read once: ranked and compared
    ranked = best_worst(stored, variant=variant)
    ids = {t: ranked[t]["scenario_id"] for t in tags}
    variants = ["mppi", variant]
    # the re-flown flights are the recorded ones only under the records' arithmetic: flown
    # under this machine's, the best case's MPPI hovered out (6.69 kJ) where its record
    # succeeded with 7.08 kJ, and nothing said so (failure audit, 2026-12-06)
    latest = latest_records(stored)
    records = {(sid, v): latest.get((sid, v)) for sid in ids.values() for v in variants}
    first = next((r for r in records.values() if r is not None), None)
    if first is not None and getattr(args, "argv", None) is not None:  # (the command line)
        status = _pinned(argparse.Namespace(native_arithmetic=args.native_arithmetic,
                                            argv=args.argv),
                         record_arithmetic(first, _manifest(args.store)),
                         "re-flying the cases", "their records'")
        if status is not None:
            return status
    cases = fly_cases(spec, list(dict.fromkeys(ids.values())), variants,
                      progress=not args.no_progress)
    flown = {t: {v: cases[sid]["results"][v].summary()["energy_J"] for v in variants}
             for t, sid in ids.items()}
    for (sid, v), rec in records.items():
        again = cases[sid]["results"][v].summary()
        check = None if rec is None else compare_records(again, rec)  # as --check compares
        if check is not None and not _reproduced(check):
            print(f"{name}: warning: {v} in {sid} re-flew as {again['outcome']} with "
                  f"{again['energy_J']:.1f} J, not its record's {rec.get('outcome')} with "
                  f"{rec.get('energy_J')} J (fields up to "
                  f"{check['max_relative_difference']:.2g} apart): the figures show the "
                  "re-flown flights (another arithmetic or another version of windnav; "
                  "benchmark-nav --replay says which)", file=sys.stderr)
    res = {"variant": variant, "reference": "mppi", "store": str(args.store), "n": ranked["n"],
           "best": ranked["best"], "worst": ranked["worst"], "reflown_energy_J": flown,
           "ranked": ranked["ranked"], "elapsed_s": time.perf_counter() - t0}
    _write(out, args, {"study": "cases", **res}, products[0],
           lambda folder: plot_cases(cases, folder, tags=ids))
    print(json.dumps(json_ready({"study": "cases", "pairs": ranked["n"],
                                 **{t: ranked[t] for t in tags}, "reflown_energy_J": flown,
                                 "elapsed_s": round(res["elapsed_s"], 1)}), indent=1))
    print_written(out)
    return 0


def _pace(args, name: str, spec) -> int:
    from windnav.commands.benchmark_nav import suite_maps
    from windnav.experiments.nav_benchmark import NavStore
    from windnav.experiments.nav_pace import pace_study
    from windnav.experiments.results import json_ready
    from windnav.viz.nav_sweeps import plot_pace

    _check_store(args.store, name)
    (variant,) = _one_variant(args, name)
    maps = suite_maps(args.maps, spec, name)
    products = ("nav_pace.json", "nav_pace.png")
    out = outputs(args, out=("--out", args.out, products))
    records = [r for r in NavStore(args.store, spec, create=False).load()
               if r.get("map_index") in maps]
    with options_named({"'records' parameter of pace_study": f"'--store' parameter of {name}",
                        "'variant' parameter of pace_study": f"'--variant' parameter of {name}"}):
        res = pace_study(records, variant)
    res.update(store=str(args.store), maps=list(maps))
    _write(out, args, {"study": "pace", **res}, products[0],
           lambda folder: plot_pace(res, folder / products[1]))
    brief = {k: {"pairs": c["time_ratio"]["n"], "time_ratio": c["time_ratio"]["mean"],
                 "power_ratio": c["power_ratio"]["mean"],
                 "energy_ratio": c["energy_ratio"]["mean"], "power_floor": c["power_floor"]}
             for k, c in res["curves"].items()}
    print(json.dumps(json_ready({"study": "pace", "variant": variant, "curves": brief,
                                 "thesis": res["thesis"]}), indent=1))
    print_written(out)
    return 0


def _one_variant(args, name: str) -> tuple[str]:
    """``--variant`` (default :data:`STORE_VARIANT`), checked; its errors name ``--variant``
    (they named check_variants's 'variants': CLI audit)."""
    from windnav.experiments.nav_benchmark import check_variants

    with options_named({f"'variants' parameter of {name}": f"'--variant' parameter of {name}"}):
        return check_variants([args.variant or STORE_VARIANT], name)


STORE_VARIANT = "ea-mppi-w"
"""The variant the ``cases`` and ``pace`` studies read without ``--variant``. (It was written
into the arguments, so a result's recorded ``variant`` was not what was typed, and the ``bound``
study, which reads no variant, recorded one; its rebuilt line failed the provenance test.)"""


def _bound(args, name: str, spec) -> int:
    from windnav.commands.benchmark_nav import suite_maps
    from windnav.experiments.nav_benchmark import NavStore
    from windnav.experiments.nav_bound import bound_study
    from windnav.experiments.results import json_ready
    from windnav.viz.nav_sweeps import plot_bound

    _check_store(args.store, name)
    maps = suite_maps(args.maps, spec, name)
    products = ("nav_bound.json", "nav_bound.png")
    out = outputs(args, out=("--out", args.out, products))
    records = [r for r in NavStore(args.store, spec, create=False).load()
               if r.get("map_index") in maps]
    with options_named({"'records' parameter of bound_study": f"'--store' parameter of {name}"}):
        res = bound_study(records)
    res.update(store=str(args.store), maps=list(maps))
    _write(out, args, {"study": "bound", **res}, products[0],
           lambda folder: plot_bound(res, folder / products[1]))
    brief = {"scenarios": res["n"], "no_route": res["no_route"],
             "ideal_mean_J": res["ideal_mean_J"], "reference_mean_J": res["reference_mean_J"],
             "targets": res["targets"],
             "ideal_paired": {k: res["ideal_paired"][k] for k in ("mean", "n", "ci95")},
             "variants": {v: {"failure_pct": r["failure_pct"], "table_ratio": r["table_ratio"],
                              "paired": r["paired"]["mean"], "below_bound": r["below_bound"],
                              "successes": r["successes"]}
                          for v, r in res["variants"].items()}}
    print(json.dumps(json_ready({"study": "bound", **brief}), indent=1))
    print_written(out)
    return 0


def _tilt(args, name: str, spec) -> int:
    from windnav.commands.benchmark_nav import suite_maps
    from windnav.experiments.nav_benchmark import NavStore, run_benchmark
    from windnav.experiments.nav_tilt import TILTS, VARIANTS, check_tilts, tilt_label, tilt_study
    from windnav.experiments.results import json_ready
    from windnav.viz.nav_sweeps import plot_tilt

    maps = suite_maps(args.maps, spec, name)
    workers = None if args.workers is None else positive_int(args.workers, "--workers", name)
    tilts = check_tilts(TILTS if args.values is None else args.values, "--values", name)
    products = ("nav_tilt.json", "nav_tilt.png")
    out = outputs(args, out=("--out", args.out, products))
    t0 = time.perf_counter()
    variants = [tilt_label(v, t) for t in tilts for v in VARIANTS]
    summary = run_benchmark(spec, variants, args.store, executor=args.executor,
                            workers=workers, progress=not args.no_progress, maps=maps)
    records = [r for r in NavStore(args.store, spec, create=False).load()
               if r["map_index"] in maps]
    res = tilt_study(records, tilts)
    res.update(study="tilt", suite=spec.name, maps=list(maps), store=str(args.store),
               flights_now=summary["now"], errors_now=summary["errors_now"],
               elapsed_s=time.perf_counter() - t0)
    _write(out, args, res, products[0], lambda folder: plot_tilt(res, folder / products[1]))
    brief = {f"{t:g}": {v: {"failure_pct": r["failure_pct"]["value"],
                            "cmd_accel": r["cmd_accel"],
                            **({"paired": r["paired"]["mean"], "pairs": r["paired"]["n"]}
                               if "paired" in r else {})}
                        for v, r in row.items()}
             for t, row in res["rows"].items()}
    print(json.dumps(json_ready({"study": "tilt", "scenarios": res["scenarios"], "tilts": brief,
                                 "flights_now": summary["now"],
                                 "elapsed_s": round(res["elapsed_s"], 1)}), indent=1))
    print_written(out)
    return 1 if summary["errors_now"] or summary["pending"] else 0


def _inflight(args, name: str, spec) -> int:
    from windnav.commands.benchmark_nav import suite_maps
    from windnav.commands.evaluate_decoder import _named_compare_files
    from windnav.experiments import nav_inflight
    from windnav.experiments.results import RecordMismatchError, json_ready
    from windnav.viz.nav_studies import plot_inflight, plot_inflight_tau

    maps = suite_maps(args.maps, spec, name)
    workers = None if args.workers is None else positive_int(args.workers, "--workers", name)
    refuse_other_views(args, name, [args.variant or nav_inflight.INFLIGHT_VARIANT], "--variant")
    try:
        pairs = sorted({int(p) for p in str(args.pairs).split(",") if p.strip()})
    except ValueError:
        pairs = []
    if not pairs or any(p not in spec.pairs for p in pairs):
        raise ValueError(f"The '--pairs' parameter of {name} must be comma-separated pair "
                         f"indices of the {spec.name} suite, among {list(spec.pairs)}. Got "
                         f"{args.pairs!r} instead.")
    ids = [f"{spec.name}/m{m:02d}/w{w:02d}/p{p}" for m in maps for w in spec.winds
           for p in pairs]  # the suite's id scheme (nav_suite.Scenario), in its order
    products = ("nav_inflight.json", "nav_inflight.png",
                *(("nav_inflight_tau.png",) if args.tau else ()))
    out = outputs(args, out=("--out", args.out, products))
    compare = _named_compare_files(args.compare, name)
    files = model_files(args)  # the compared files' SHA-256, before they are read
    # read now, their errors naming --compare (they named load_decoder's 'path': CLI audit)
    # the suite's 0 and 45 deg inlets sit on the decoder's sector boundaries: scored as the
    # flown decoder meets them (benchmark_decoder), as the study's records were
    compared = load_files(compare, "--compare", name, boundary="floor")
    log = Path(args.out) / nav_inflight.RECORDS  # each finished wind, until the outputs are in

    def study():
        return nav_inflight.inflight_study(
            spec, ids, variant=args.variant or nav_inflight.INFLIGHT_VARIANT,
            every_s=args.every, compare=compared,
            taus=args.tau, executor=args.executor, workers=workers,
            progress=not args.no_progress, records=log)

    t0 = time.perf_counter()
    options = {f"'{library}' parameter of inflight_study": f"'{option}' parameter of {name}"
               for library, option in (("variant", "--variant"), ("variants", "--variant"),
                                       ("every_s", "--every"),
                                       ("compare", "--compare"), ("taus", "--tau"))}
    try:
        with options_named(options):
            try:
                res = study()
            except RecordMismatchError:  # raised before any flight
                if not args.overwrite:
                    raise ValueError(
                        f"The '--out' parameter of {name} names {str(args.out)!r}, whose "
                        f"record log {str(log)!r} holds the flights of another inflight study "
                        "(suite, --variant, --every, --tau or the decoder the variant flies "
                        "differ); rerun that study to finish it, pass --overwrite to discard "
                        "them, or choose another --out.") from None
                log.unlink()
                res = study()
    except KeyboardInterrupt:
        kept = f"the finished winds are kept in {log}" if log.exists() else "no wind finished"
        print(f"{name}: interrupted: {kept}; rerun the same command to resume",
              file=sys.stderr)
        return 130
    res.update(study="inflight", suite=spec.name, seed=spec.seed, maps=list(maps),
               pairs=pairs, models={n: str(f) for n, f in compare.items()},
               elapsed_s=time.perf_counter() - t0)
    if compare:  # (by hash: a line naming the shipped file is redirected once it is replaced)
        res["model_files"] = files

    def draw(folder):
        plot_inflight(res, folder / products[1])
        if res["taus"]:
            plot_inflight_tau(res, folder / products[2])

    _write(out, args, res, products[0], draw)
    log.unlink(missing_ok=True)
    print("\n".join(nav_inflight.summarize_inflight(res)))
    print(json.dumps(json_ready({"study": "inflight", "flights": len(res["flights"]),
                                 "errors": len(res["errors"]),
                                 "elapsed_s": round(res["elapsed_s"], 1)}), indent=1))
    print_written(out)
    return 1 if res["errors"] else 0


def _winds(args, name: str, spec) -> int:
    from windnav.experiments.nav_cases import wind_scenarios
    from windnav.experiments.results import json_ready
    from windnav.viz.nav_studies import plot_wind_scenarios

    m = args.map if isinstance(args.map, int) else 0  # (a city: the suite's one map)
    if m not in spec.maps:
        raise ValueError(f"The '--map' parameter of {name} must be a map of the {spec.name} "
                         f"suite, among {list(spec.maps)}. Got {args.map!r} instead.")
    products = ("nav_winds.json", "nav_winds.png")
    out = outputs(args, out=("--out", args.out, products))
    t0 = time.perf_counter()
    res = wind_scenarios(spec, m, progress=not args.no_progress)
    summary = {"suite": spec.name, "map_index": m,
               "winds": [{"wind_index": w["wind_index"], "speed": w["speed"],
                          "direction_deg": w["direction_deg"],
                          "pairs": [{"scenario_id": sc.scenario_id, "kind": sc.kind,
                                     "start": sc.start, "goal": sc.goal}
                                    for sc in w["scenarios"]]} for w in res["winds"]],
               "elapsed_s": time.perf_counter() - t0}
    _write(out, args, {"study": "winds", **summary}, products[0],
           lambda folder: plot_wind_scenarios(res, folder / products[1]))
    print(json.dumps(json_ready({"study": "winds", "map_index": m,
                                 "winds": [w["wind_index"] for w in summary["winds"]],
                                 "elapsed_s": round(summary["elapsed_s"], 1)}), indent=1))
    print_written(out)
    return 0


def _gs(args, name: str) -> int:
    from windnav.experiments.gs_cases import CASES, case_summary, run_case
    from windnav.experiments.results import json_ready
    from windnav.viz.gs_cases import plot_gs_case, plot_gs_case_energy

    if args.case is not None and args.case not in CASES:
        raise ValueError(f"The '--case' parameter of {name} must be one of {list(CASES)}. Got "
                         f"{args.case!r} instead.")
    names = [args.case] if args.case else list(CASES)
    products = ("nav_gs.json", *(f"gs_{c}{k}.png" for c in names for k in ("", "_energy")))
    out = outputs(args, out=("--out", args.out, products))
    t0 = time.perf_counter()
    cases = {c: run_case(c, seed=args.seed, progress=not args.no_progress) for c in names}
    summary = {c: case_summary(case) for c, case in cases.items()}
    def draw(folder):
        for c, case in cases.items():
            plot_gs_case(case, folder / f"gs_{c}.png")
            plot_gs_case_energy(case, folder / f"gs_{c}_energy.png")

    _write(out, args, {"study": "gs", "seed": args.seed, "cases": summary,
                       "elapsed_s": time.perf_counter() - t0}, products[0], draw)
    brief = {c: {v: {k: s[k] for k in ("outcome", "energy_J", "time_s")}
                 for v, s in case_summary(cases[c])["variants"].items()} for c in names}
    print(json.dumps(json_ready({"study": "gs", "cases": brief,
                                 "elapsed_s": round(time.perf_counter() - t0, 1)}), indent=1))
    print_written(out)
    return 0


def _gusts(args, name: str, spec) -> int:
    import numpy as np

    from windnav.experiments import nav_gusts
    from windnav.experiments.nav_benchmark import check_scenario_ids
    from windnav.experiments.results import json_ready
    from windnav.viz.nav_studies import plot_gust_routes

    if args.scenario is None and spec.city is not None:  # (its default is the thesis suite's)
        raise ValueError(f"The '--scenario' parameter of {name} must name a scenario of the "
                         f"suite {spec.name!r} with --map (e.g. {spec.name}/m00/w14/p2; the "
                         f"default, {nav_gusts.DEFAULT_SCENARIO}, is the thesis suite's). Got "
                         "None instead.")
    scenario = args.scenario or nav_gusts.DEFAULT_SCENARIO
    with options_named({"'scenario_ids'": "'--scenario'"}):
        check_scenario_ids(spec, [scenario], name)
    base = args.base or nav_gusts.DEFAULT_BASE
    products = ("nav_gusts.json", "nav_gusts.png")
    out = outputs(args, out=("--out", args.out, products))
    t0 = time.perf_counter()
    with options_named({"'base' parameter of gust_routes": f"'--base' parameter of {name}",
                        "'gust_k' parameter of gust_routes": f"'--gust-k' parameter of {name}"}):
        res = nav_gusts.gust_routes(spec, scenario, base=base, gust_k=args.gust_k,
                                    progress=not args.no_progress)
    sigma = res["sigma_along"][~res["flow"].solid]
    summary = {"scenario_id": scenario, "gust_k": res["gust_k"],
               "sigma_along_mps": {"median": float(np.median(sigma)),
                                   "p90": float(np.percentile(sigma, 90)),
                                   "max": float(sigma.max())},
               "flights": {v: {k: r.summary()[k] for k in ("outcome", "energy_J", "time_s",
                                                          "arrival_time_s")}
                           for v, r in res["flights"].items()},
               "routes": {v: None if r is None else {"begun_s": r["begun_s"],
                                                      "time_s": r["time_s"],
                                                      "samples": r["samples"].tolist()}
                          for v, r in res["routes"].items()},
               "elapsed_s": time.perf_counter() - t0}
    _write(out, args, {"study": "gusts", **summary}, products[0],
           lambda folder: plot_gust_routes(res, folder / products[1]))
    print(json.dumps(json_ready({"study": "gusts", "scenario_id": scenario,
                                 "sigma_along_mps": summary["sigma_along_mps"],
                                 "flights": summary["flights"],
                                 "elapsed_s": round(summary["elapsed_s"], 1)}), indent=1))
    print_written(out)
    return 0


def _feasibility(args, name: str, spec, stored=None) -> int:
    """The feasibility study: the reach cache and its searches of the suite ``spec``, the
    flights of ``--store`` read (and flown, ``--fly``) with ``stored`` (``spec`` whose onboard
    stack flies ``--decoder``: the store's suite; default ``spec``)."""
    stored = spec if stored is None else stored
    from windnav.commands.benchmark_nav import suite_maps
    from windnav.experiments.nav_benchmark import NavStore
    from windnav.experiments.nav_feasibility import check_cache, reach_scenarios, reach_table
    from windnav.experiments.results import json_ready
    from windnav.vehicle import params
    from windnav.viz.nav_studies import plot_reach

    limit = params("hummingbird").airspeed_limit
    airspeeds = [10.0, limit, 16.0] if args.airspeeds is None else list(args.airspeeds)
    for a in airspeeds:
        if not a > 0:
            raise ValueError(f"The '--airspeeds' parameter of {name} must be positive speeds. "
                             f"Got {a!r} instead.")
    if limit not in airspeeds:
        airspeeds.append(limit)
    maps = suite_maps(args.maps, spec, name)
    workers = None if args.workers is None else positive_int(args.workers, "--workers", name)
    fly = [v for v in (args.fly or "").split(",") if v]
    if fly and args.store is None:
        raise ValueError(f"The '--store' parameter of {name} must name the benchmark store the "
                         f"--fly flights go to. Got None instead.")
    if args.store is not None and not fly:  # the store checked before the searches: a
        _check_store(args.store, name)      # malformed or another suite's was refused after
        NavStore(args.store, stored, create=False)  # them (review, fiftieth session)
    check_output_path(args.cache, "--cache", name, kind="dir")
    if Path(args.cache).is_dir():  # another suite's records, before anything is written
        check_cache(spec, args.cache, name, option="--cache")
    products = ("nav_feasibility.json", "nav_feasibility.png")
    out = outputs(args, out=("--out", args.out, products))
    t0 = time.perf_counter()
    with options_named({"'variants' parameter of reach_scenarios": f"'--fly' parameter of {name}"}):
        reach = reach_scenarios(spec, args.cache, maps=maps, airspeeds=airspeeds,
                                executor=args.executor, workers=workers,
                                progress=not args.no_progress, fly=fly, store=args.store)
    flights = ([] if args.store is None else
               [r for r in NavStore(args.store, stored, create=False).load()
                if r.get("map_index") in maps])
    tables = {f"{a:g}": reach_table(reach, flights, airspeed=a) for a in airspeeds}
    res = {"study": "feasibility", "suite": spec.name, "seed": spec.seed, "maps": list(maps),
           "airspeed_limit": limit, "store": None if args.store is None else str(args.store),
           "cache": str(args.cache), "tables": tables, "elapsed_s": time.perf_counter() - t0}
    _write(out, args, res, products[0],
           lambda folder: plot_reach(reach, tables[f"{limit:g}"], folder / products[1]))
    brief = {k: {"reachable": t["reachable"], "n": t["n"],
                 "failures_reachable_pct": {
                     # no reachable flight: no rate (it printed 0.0 %: failure audit)
                     v: (round(100 * c["failures_reachable"] / c["reachable"], 1)
                         if c["reachable"] else None)
                     for v, c in t["variants"].items() if "@" not in v}}
             for k, t in tables.items()}
    print(json.dumps(json_ready({"study": "feasibility", "airspeeds": brief,
                                 "elapsed_s": round(res["elapsed_s"], 1)}), indent=1))
    print_written(out)
    return 0
