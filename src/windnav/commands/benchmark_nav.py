"""``windnav benchmark-nav``: the thesis's navigation benchmark, its store and its table.

::

    windnav benchmark-nav --suite thesis --variants mppi,mppi-w,ea-mppi,ea-mppi-w \\
                          --executor process --workers 2 --out runs/thesis
    windnav benchmark-nav --out runs/thesis --table --json table.json
    windnav benchmark-nav --out runs/thesis --replay thesis/m03/w07/p2 --variant ea-mppi-w \\
                          --json replay.json
    windnav benchmark-nav --out runs/thesis --check 32

A run flies every pending (scenario, variant) of the suite, one task per (map, wind) whose wind
is simulated once, and appends one JSON line per flight to ``STORE/records.jsonl``; rerun the
same command after an interruption to resume. At the end it prints the ablation table in
Markdown, its energies paired with ``--reference``'s flights (a reference typed that the run
does not fly and the store does not hold is refused before any flight). ``--table`` prints
the table of a store without flying; ``--replay`` re-flies one scenario from its id and seed
and writes the record's fields (compared with the recorded flight when ``--out`` holds it).
The harness is :mod:`windnav.experiments.nav_benchmark`. ``--check N`` flies the records of
N random scenarios again and compares them (an audit of the store's reproducibility on this
machine). A replay and a check restart themselves under the
records' arithmetic (BLAS kernel, NumPy's SIMD loops) when it differs from this machine's and
the CPU can run it; ``--portable`` flies a run under the arithmetic every AVX2 CPU can run.
``--json`` writes the run's counts and the table as data; the store itself is never replaced
(``--overwrite`` applies to ``--json`` only).

``--decoder FILE`` (since 2026-12-07) flies the onboard stack (``ea-mppi-w-hat``, without
``@decoder=``) with that decoder file, e.g. a model of ``windnav train-decoder``, instead of the
benchmark's pinned one (:data:`windnav.experiments.nav_benchmark.BENCHMARK_DECODER`), with its
two folds blended near a sector boundary (:data:`DECODER_RULE`, pinned)::

    windnav benchmark-nav --suite thesis --variants mppi,ea-mppi-w-hat \
                          --decoder runs/mine/model.npz --out runs/thesis_mine

The decoder is part of the suite's settings (by its fingerprint: weights, architecture, rule),
so its flights need a store of their own, with the variants they are compared with (the
reference) flown into it too; ``--table``, ``--check`` and ``--replay`` of that store take the
same ``--decoder`` again (another file, or none, is refused naming the option), and a JSON
records the file's SHA-256, taken when it is loaded (``decoder_file``). The studies of
``windnav nav-study --store`` on such a store take the same ``--decoder`` (since the fiftieth
session). The option's pieces shared by both commands are :mod:`windnav.commands._decoder_file`.

``--map [NAME=]FILE`` (since the fifty-first session) flies the suite's winds, start/goal rule
and flight options on a city of one's own (a RotorPy world JSON) as its one map, ``m00``,
instead of its planning maps; the scenario ids are ``NAME/m00/wWW/pP``::

    windnav benchmark-nav --suite thesis --map my_city.json --variants mppi,ea-mppi-w \
                          --out runs/nav_mine

The city is part of the suite's settings (by :meth:`windnav.city.City.fingerprint`, its
geometry), so its flights need a store of their own; ``--table``, ``--check``, ``--replay`` and
further runs on that store take the same map again (any path to the same blocks) and read the
suite's rule from its manifest, ``--suite`` not needed; so do the studies of ``windnav
nav-study --store`` on it (``nav-study --map``). ``--table --figure PNG`` draws where each
variant fails on the map. ``--pair-distance``, ``--edge`` and ``--clearance`` (since the
fifty-second session) change the suite's start/goal rule for a new store of such a city (a
small city cannot hold the presets' 282 m pairs); the store records them, and on a store they
may only repeat its values::

    windnav benchmark-nav --suite quick --map small.json --pair-distance 150 --edge 15 \\
                          --out runs/nav_small
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

from windnav._validate import positive_int
from windnav.commands._city_suite import (
    add_city_rule_arguments,
    city_rule,
    city_suite,
)
from windnav.commands._city_suite import store_city as _store_city
from windnav.commands._common import (
    add_output_arguments,
    check_figure_format,
    check_output_path,
    document,
    fill_defaults,
    options_named,
    outputs,
    path_argument,
    print_written,
    seed,
    where,
)
from windnav.commands._decoder_file import (
    DECODER_RULE,  # noqa: F401  (named by the docstring above)
    decoder_file,
    decoder_labels,
    refuse_other_views,
    with_decoder,
)

DEFAULT_VARIANTS = "mppi,mppi-w,ea-mppi,ea-mppi-w"
DEFAULT_REFERENCE = "mppi"


def register(subparsers) -> None:
    """Add the ``benchmark-nav`` subcommand."""
    from windnav.experiments.executor import BACKENDS
    from windnav.experiments.nav_suite import SUITES

    p = subparsers.add_parser(
        "benchmark-nav",
        help="fly the navigation benchmark (thesis: 1,024 scenarios per variant)",
        description="Fly every planner variant through every scenario of a suite (maps x "
                    "winds x start/goal pairs), one wind simulation per map and wind, into a "
                    "resumable store of per-flight records; print the ablation table.",
    )
    p.add_argument("--suite", choices=tuple(SUITES), default=None,
                   help="the suite (required for a new store; default: the store's own)")
    p.add_argument("--variants", default=None,
                   help=f"comma-separated planner variants (to fly: default {DEFAULT_VARIANTS}; "
                        "with --table or --check: default every variant the store holds)")
    p.add_argument("--executor", choices=BACKENDS, default=None,
                   help="where the tasks run (default process)")
    p.add_argument("--workers", type=int, default=None,
                   help="worker processes (default: all cores); each holds the winds of its "
                        "task, 2.3 GB each for a 600 m map")
    p.add_argument("--wind-batch", type=int, default=None, metavar="N",
                   help="most winds of a map simulated together, 1 to 3 (default 3): one "
                        "pressure solve per step for all, each wind the same to the bit; 1 "
                        "needs less memory (a worker peaked at 3.2 GB against 7.8 GB)")
    p.add_argument("--out", type=path_argument, default=None, metavar="STORE",
                   help="the store folder (manifest.json, records.jsonl)")
    p.add_argument("--seed", type=int, default=None,
                   help="suite seed (default: the store's own, else 0)")
    p.add_argument("--maps", default=None, metavar="LIST",
                   help="fly only these maps of the suite, e.g. 0,1 or 0-3 (default: all); "
                        "the rest can be flown later into the same store; with --table, "
                        "tabulate only these maps' flights")
    p.add_argument("--scenarios", default=None, metavar="IDS",
                   help="fly only these scenarios: a file with one id per line, or ids "
                        "separated by commas (e.g. thesis/m03/w07/p2,thesis/m03/w07/p3); a "
                        "pilot whose records are the suite's own; with --table, tabulate "
                        "only their flights")
    p.add_argument("--retry-errors", action="store_true",
                   help="also re-fly the flights whose harness failed in an earlier run")
    p.add_argument("--table", action="store_true",
                   help="print the table of the store's records; fly nothing")
    p.add_argument("--figure", type=Path, default=None, metavar="PNG",
                   help="with --table: also draw where each variant succeeds and fails on the "
                        "map, a panel per variant (the records of one map: a store of --map, "
                        "or --maps N)")
    p.add_argument("--against", type=Path, default=None, metavar="STORE",
                   help="with --table: also compare each flight with the same flight (scenario "
                        "and variant) of another store of the same suite, e.g. one flown on "
                        "another machine: same outcome, every field within 1e-6")
    p.add_argument("--reference", default=None,
                   help=f"the variant the energies are compared with (default "
                        f"{DEFAULT_REFERENCE}); one the table holds: flown by this run "
                        "(--variants) or already in the store")
    p.add_argument("--replay", default=None, metavar="SCENARIO_ID",
                   help="re-fly one scenario (e.g. thesis/m03/w07/p2) with --variant")
    p.add_argument("--variant", default=None, help="the variant of --replay")
    p.add_argument("--check", default=None, metavar="N",
                   help="audit the store's reproducibility: fly again the recorded flights of "
                        "N scenarios drawn at random (seed 0; 'all': every one), of --variants "
                        "(default: every variant recorded), --maps and --scenarios, and compare "
                        "each with its record (exit status 1 when one differs by more than "
                        "1e-6 or in outcome); the store is not changed")
    p.add_argument("--native-arithmetic", action="store_true",
                   help="replay under this machine's own BLAS kernel and NumPy SIMD loops; by "
                        "default a replay restarts under the record's when they differ and "
                        "this CPU can run them (a flight replays to 1e-6 only under the "
                        "arithmetic that flew it; for records that name none, the one the "
                        "store's manifest declares as unnamed_records_arithmetic)")
    p.add_argument("--portable", action="store_true",
                   help="fly under OpenBLAS's Haswell kernels and NumPy's X86_V3 (AVX2) loops, "
                        "which every x86-64 CPU with AVX2 can run, so that the records replay "
                        "on any of them (the command restarts itself under them)")
    p.add_argument("--decoder", type=Path, default=None, metavar="FILE",
                   help="the decoder file the onboard stack (ea-mppi-w-hat without "
                        "'@decoder=') flies, e.g. a model of 'windnav train-decoder' (default: "
                        "the benchmark's pinned decoder); part of the suite's settings, so a "
                        "store of its own, and every mode on that store needs it again")
    p.add_argument("--map", default=None, metavar="[NAME=]FILE",
                   help="fly the suite's winds and start/goal rule on a city of your own (a "
                        "RotorPy world JSON) as its one map, instead of its planning maps: "
                        "the scenario ids are NAME/m00/wWW/pP (NAME: default the file's name); "
                        "part of the suite's settings (by the city's fingerprint), so a store "
                        "of its own, and every mode on that store needs it again")
    add_city_rule_arguments(p)
    p.add_argument("--no-progress", action="store_true", help="hide the progress bar")
    add_output_arguments(p)
    p.set_defaults(func=run)


def _read_manifest(store: Path | None):
    """``(manifest, problem)`` of the store folder ``store``: its ``manifest.json`` as a dict
    and None, or None and what is wrong with it: ``"missing"``, the error that reading or
    parsing it gave, or ``"not an object"`` (``[1]``: an AttributeError; files audit)."""
    import json

    if store is None or not (Path(store) / "manifest.json").is_file():
        return None, "missing"
    try:
        found = json.loads((Path(store) / "manifest.json").read_text())
    except (OSError, ValueError) as exc:
        return None, str(exc)
    return (found, None) if isinstance(found, dict) else (None, "not an object")


def _manifest(store: Path | None) -> dict | None:
    """The store's manifest, or None (NavStore names the problem)."""
    return _read_manifest(store)[0]


def _existing_store(store: Path | None, flag: str, name: str) -> None:
    """Refuse ``store`` (``flag``) unless it is a benchmark store to read: a folder whose
    ``manifest.json`` is a JSON object naming its suite. The message says which of these
    fails (a manifest that was not JSON read as a missing one; CLI audit, 2026-12-07)."""
    found, problem = _read_manifest(store)
    if problem == "missing":
        raise ValueError(f"The '{flag}' parameter of {name} must name a benchmark store (with "
                         f"manifest.json). Got {str(store)!r} instead.")
    if problem is not None and problem != "not an object":
        raise ValueError(f"The '{flag}' parameter of {name} must name a benchmark store whose "
                         f"manifest.json is readable JSON. Got {str(store)!r} instead, whose "
                         f"manifest.json gives: {problem}")
    if found is None or "suite" not in found:
        raise ValueError(f"The '{flag}' parameter of {name} must name a benchmark store whose "
                         f"manifest.json names its suite (a JSON object with 'suite'). Got "
                         f"{str(store)!r} instead.")


def _spec(args, name: str, prefer: str | None = None):
    """The suite: ``--suite``, else ``prefer`` (a replayed id's suite), else the store's
    manifest; the seed: ``--seed``, else the store's (for its own suite), else 0. With
    ``--map``, that suite's rule on the city of the file (:func:`city_suite`)."""
    from windnav.experiments.nav_suite import SUITES, get_suite

    man = _manifest(args.out) or {}
    if args.map is not None:
        value = None if args.seed is None else seed(args)
        spec = city_suite(args.map, name, man, suite=args.suite, seed_value=value,
                          store=args.out, rule=city_rule(args, name))
        return with_decoder(args, name, spec, man)
    city_rule(args, name)  # (refused without --map)
    recorded = _store_city(man)
    if recorded is not None:
        raise ValueError(f"The '--map' parameter of {name} must name the map file that the "
                         f"store {str(args.out)!r} was flown on (suite {man.get('suite')!r}, "
                         f"{recorded}). Got None instead.")
    suite = args.suite or prefer or (man.get("suite") if man.get("suite") in SUITES else None)
    if suite is None:
        raise ValueError(f"The '--suite' parameter of {name} must be given for a new store "
                         f"(one of {list(SUITES)}). Got None instead.")
    if args.seed is None:
        value = man.get("seed", 0) if man.get("suite") == suite else 0
    else:
        value = seed(args)
    return with_decoder(args, name, get_suite(suite, seed=value), man)


def _document(payload: dict, args, spec=None) -> dict:
    """The JSON document of this run, with ``decoder_file`` (the path and SHA-256 of
    ``--decoder`` when it was loaded) when given, and with ``--map`` ``map_file``: its path,
    the flown city's fingerprint and the suite's start/goal ``rule`` (m; since the
    fifty-second session, when a store may have a rule of its own)."""
    from windnav.commands._city_suite import suite_rule

    extra = decoder_file(args)
    if spec is not None and spec.city is not None:
        extra["map_file"] = {"suite": spec.name, "path": str(args.map),
                             "city": spec.settings()["city"],
                             "rule": suite_rule(spec)}
    return document("benchmark-nav", {**payload, **extra}, args)


def run(args) -> int:
    """Run ``windnav benchmark-nav``; 0 when every flight flew, 1 when some harness failed."""
    name = where(args)
    if args.seed is not None:
        seed(args)
    _check_modes(args, name)
    if args.out is not None and str(args.out) == "":  # (path_argument keeps it as typed; a
        # replay reads --out without the output check below)
        check_output_path(args.out, "--out", name, kind="dir")
    reference_given = args.reference is not None
    fill_defaults(args, {"reference": DEFAULT_REFERENCE})  # (recorded as None: as typed)
    if args.portable and (args.replay is not None or args.check is not None):
        raise ValueError(f"The '--portable' parameter of {name} applies to flying a suite; a "
                         "replay or a check runs under the arithmetic of its records. Got "
                         f"--portable with {'--replay' if args.replay else '--check'} instead.")
    if args.replay is not None:
        return _replay(args, name)
    if args.portable:
        from windnav.experiments.arithmetic import PIN_VARIABLE, portable_environment

        env, line = portable_environment()
        if env is None:
            raise ValueError(f"The '--portable' parameter of {name} cannot be met: {line}.")
        if env and PIN_VARIABLE not in os.environ:
            return _restart(args, env, f"flying under the portable arithmetic ({line})")
    if args.out is None:
        raise ValueError(f"The '--out' parameter of {name} must name the store folder. Got "
                         "None instead.")
    check_output_path(args.out, "--out", name, kind="dir")
    if args.table:
        return _table(args, name)
    if args.check is not None:
        return _check(args, name)
    return _run(args, name, reference_given)


def _check_modes(args, name: str) -> None:
    """``--table``, ``--check`` and ``--replay`` one at a time, and each mode's options only
    with it: ``--table --check 2`` printed the table and exited 0, checking nothing, and
    ``--against``, ``--variant`` and ``--retry-errors`` were ignored outside their modes
    (CLI audit, 2026-12-05), as was ``--reference`` with ``--check`` or ``--replay``."""
    modes = [flag for flag, on in (("--table", args.table), ("--check", args.check is not None),
                                   ("--replay", args.replay is not None)) if on]
    if len(modes) > 1:
        raise ValueError(f"The '{modes[1]}' parameter of {name} must not be given with "
                         f"{modes[0]}: one of --table, --check and --replay at a time. Got "
                         f"{' and '.join(modes)} instead.")
    mode = modes[0] if modes else None
    for flag, given, belongs in (("--against", args.against is not None, "--table"),
                                 ("--figure", args.figure is not None, "--table"),
                                 ("--variant", args.variant is not None, "--replay"),
                                 ("--retry-errors", args.retry_errors, None)):
        if given and mode != belongs:
            what = f"only with {belongs}" if belongs else "only when flying a suite"
            raise ValueError(f"The '{flag}' parameter of {name} applies {what}. Got it "
                             f"{'with ' + mode if mode else 'without ' + str(belongs)} "
                             "instead.")
    if args.reference is not None and mode in ("--check", "--replay"):  # (None: not typed)
        raise ValueError(f"The '--reference' parameter of {name} applies only with --table or "
                         f"when flying a suite. Got it with {mode} instead.")
    if mode == "--table":  # flies nothing: these were accepted and ignored (options audit)
        for flag, given in (("--executor", args.executor is not None),
                            ("--workers", args.workers is not None),
                            ("--wind-batch", args.wind_batch is not None),
                            ("--native-arithmetic", args.native_arithmetic),
                            ("--portable", args.portable)):
            if given:
                raise ValueError(f"The '{flag}' parameter of {name} applies to flying; "
                                 "--table flies nothing. Got it with --table instead.")
    # the defaults, filled in now and recorded as None, as typed (a result's typed line did
    # not parse back to its recorded arguments: the fifty-first session's provenance test)
    fill_defaults(args, {"executor": "process", "wind_batch": 3})


def _variants(args, name: str) -> tuple[str, ...]:
    from windnav.experiments.nav_benchmark import check_variants

    with options_named({"'variants'": "'--variants'"}):
        return check_variants(DEFAULT_VARIANTS if args.variants is None else args.variants,
                              name)


def suite_maps(text, spec, name: str) -> tuple[int, ...]:
    """``--maps`` of ``spec``: comma-separated map indices and ranges ``a-b`` (inclusive),
    checked against the suite (:func:`~windnav.experiments.nav_benchmark.check_maps`); None:
    every map of the suite."""
    from windnav.experiments.nav_benchmark import check_maps

    out = None
    if text is not None:
        out = []
        try:
            for part in str(text).split(","):
                lo, sep, hi = part.strip().partition("-")
                if sep and int(hi) < int(lo):  # ("Got [] instead": CLI audit, 2026-12-07)
                    raise ValueError(f"The '--maps' parameter of {name} must give each range "
                                     f"low-high, e.g. 1-3. Got {part.strip()!r} in {text!r} "
                                     "instead.")
                out += list(range(int(lo), int(hi) + 1)) if sep else [int(lo)]
        except ValueError as exc:
            if "low-high" in str(exc):
                raise
            raise ValueError(f"The '--maps' parameter of {name} must be map indices and "
                             f"ranges, e.g. 0,1 or 0-3. Got {text!r} instead.") from None
    with options_named({"'maps'": "'--maps'"}):
        return check_maps(spec, out, name)


def scenario_ids(text, spec, name: str) -> frozenset | None:
    """``--scenarios``: the ids in the file ``text`` (one per line; blank lines and ``#``
    comments skipped) or, when no such file exists, separated by commas; checked against
    ``spec``. None: every scenario."""
    from windnav.experiments.nav_benchmark import check_scenario_ids

    if text is None:
        return None
    path = Path(text)
    if path.is_file():
        try:
            text_ = path.read_text(encoding="utf-8-sig")
        except UnicodeDecodeError:
            raise ValueError(f"The '--scenarios' parameter of {name} must name a text file of "
                             f"scenario ids. Got {str(path)!r} instead, which is not UTF-8 "
                             "text.") from None
        lines = (line.split("#", 1)[0].strip() for line in text_.splitlines())
        ids = [line for line in lines if line]
    else:
        ids = [part.strip() for part in str(text).split(",") if part.strip()]
    with options_named({"'scenario_ids'": "'--scenarios'"}):
        return check_scenario_ids(spec, ids, name)


def _print_table(records, variants, reference, spec) -> dict:
    from windnav.experiments.nav_benchmark import with_goal_clearance
    from windnav.experiments.nav_records import benchmark_table, render_table

    records = with_goal_clearance(spec, records)
    present = {r["variant"] for r in records}
    rows = [v for v in variants if v in present and v != reference]
    if reference in present:
        rows = [reference, *rows]
    table = benchmark_table(records, variants=rows, reference=reference)
    print(render_table(table), end="")
    return table


def _check_reference(args, name: str, variants, spec, chosen) -> None:
    """Refuse a ``--reference`` typed for a run that is neither among ``variants`` nor among the
    variants the store already holds (of the ``chosen`` scenarios, as the table is): the run
    flew every flight, then printed a table without its paired columns (an unknown name, a
    typo, was not even named). The default reference is not refused: a run of other variants
    into a new store (e.g. ``--variants gs-w``) tabulates them alone, as before."""
    from windnav.experiments.nav_benchmark import NavStore

    if args.reference in variants:
        return
    held = []
    if _manifest(args.out) is not None:
        held = sorted({r["variant"] for r in NavStore(args.out, spec, create=False).load()
                       if chosen is None or r.get("scenario_id") in chosen})
    if args.reference not in held:
        raise ValueError(f"The '--reference' parameter of {name} must be a variant of the "
                         f"table: one of --variants {list(variants)} or a variant the store "
                         f"already holds {held}. Got {args.reference!r} instead.")


def _run(args, name: str, reference_given: bool) -> int:
    from windnav.experiments.nav_benchmark import NavStore, check_wind_batch, run_benchmark
    from windnav.experiments.results import write_json

    variants = _variants(args, name)
    refuse_other_views(args, name, variants, "--variants")
    spec = _spec(args, name)
    if args.decoder is not None and not decoder_labels(variants, name)[1]:
        print(f"{name}: note: no variant of this run flies --decoder's file (ea-mppi-w-hat "
              "without '@decoder='); its store is that decoder's all the same", file=sys.stderr)
    out = outputs(args)
    workers = None if args.workers is None else positive_int(args.workers, "--workers", name)
    maps = suite_maps(args.maps, spec, name)
    chosen = scenario_ids(args.scenarios, spec, name)
    if reference_given:  # before any flight, not in the table after them
        _check_reference(args, name, variants, spec, chosen)
    with options_named({"'wind_batch'": "'--wind-batch'"}):
        wind_batch = check_wind_batch(args.wind_batch, name)
    try:
        summary = run_benchmark(spec, variants, args.out, executor=args.executor,
                                workers=workers, progress=not args.no_progress,
                                retry_errors=args.retry_errors, maps=maps,
                                scenario_ids=None if chosen is None else sorted(chosen),
                                wind_batch=wind_batch)
    except KeyboardInterrupt:
        try:
            n = len(NavStore(args.out, spec, create=False).latest())
        except ValueError:
            n = 0
        print(f"{name}: interrupted; {n} flights recorded in {args.out}; rerun the same "
              "command to resume.", file=sys.stderr)
        return 130
    records = NavStore(args.out, spec, create=False).load()
    if chosen is not None:
        records = [r for r in records if r.get("scenario_id") in chosen]
    part = ("" if len(summary["maps"]) == len(spec.maps)
            else f", maps {','.join(map(str, summary['maps']))} of {len(spec.maps)}")
    if chosen is not None:
        part += f", {summary['scenarios']} chosen scenarios"
    print(f"{summary['store']}: suite {spec.name} (seed {spec.seed}{part}), "
          f"{summary['total'] - summary['pending']}/{summary['total']} flights recorded "
          f"({summary['now']} now, {summary['already']} already, {summary['errors_now']} "
          f"harness errors now) in {summary['wall_s']:.0f} s")
    if summary["wind_batch"] < wind_batch:
        print(f"winds simulated {summary['wind_batch']} at a time, not {wind_batch}: the "
              "memory limit (WINDNAV_MEMORY_LIMIT, or 3/4 of the machine's) holds no more for "
              "the workers at once")
    for t in summary["failed_tasks"]:
        winds = ",".join(map(str, t["wind_indices"]))
        print(f"failed: map {t['map_index']} winds {winds}: {t['error']}")
    if summary["errors_now"]:
        print(f"{summary['errors_now']} flights failed in the harness: their tracebacks are in "
              f"{summary['store']}/records.jsonl ('error'); --retry-errors re-flies them")
    print()
    table = _print_table(records, variants, args.reference, spec)
    if args.json is not None:
        with out.writing() as stage:
            write_json(_document({"summary": summary, "table": table}, args, spec),
                       stage.file("--json"))
        print_written(out)
    return 1 if summary["errors_now"] or summary["pending"] else 0


def _stored(args, name: str):
    """The suite, the store's records of ``--maps`` and ``--scenarios``, and the variants
    asked for (``--variants``; by default every variant among those records)."""
    from windnav.experiments.nav_benchmark import NavStore, check_variants

    _existing_store(args.out, "--out", name)
    spec = _spec(args, name)
    records = NavStore(args.out, spec, create=False).load()
    if args.maps is not None:
        maps = set(suite_maps(args.maps, spec, name))
        records = [r for r in records if r.get("map_index") in maps]
    chosen = scenario_ids(args.scenarios, spec, name)
    if chosen is not None:
        records = [r for r in records if r.get("scenario_id") in chosen]
    present = sorted({r["variant"] for r in records})
    # (None, not the flying default: typing that default string tabulated every variant)
    asked = args.variants if args.variants is not None else ",".join(present)
    variants = check_variants(asked, name) if asked else ()
    absent = [v for v in variants if v not in present]
    if args.variants is not None and absent and present:
        # a mistyped label was left out without a word: `--check 8 --variants a,b` checked a
        # alone and reported every flight reproduced (fifty-ninth session)
        near = {v: _nearest_label(v, present) for v in absent}
        hints = "; ".join(f"{v!r} (nearest held: {m[0]!r})" if m else repr(v)
                          for v, m in near.items())
        among = (" among the chosen --maps and --scenarios"
                 if args.maps is not None or chosen is not None else "")
        raise ValueError(f"The '--variants' parameter of {name} must name variants the store "
                         f"{str(args.out)!r} holds{among} ({len(present)} of them; --table "
                         f"lists them). Got {hints}, which it does not hold.")
    return spec, records, variants


def _nearest_label(label: str, held: list[str]) -> list[str]:
    """The held variant nearest ``label``: the shortest holding all its ``@`` parts (the
    base and every parameter), else the closest spelling (none: [])."""
    import difflib

    parts = set(label.split("@"))
    wider = sorted((h for h in held if parts <= set(h.split("@"))), key=len)
    return wider[:1] or difflib.get_close_matches(label, held, n=1, cutoff=0.6)


def _table(args, name: str) -> int:
    from windnav.experiments.nav_benchmark import NavStore, checked_flight
    from windnav.experiments.nav_records import ERROR, latest_records
    from windnav.experiments.results import write_json

    spec, records, variants = _stored(args, name)
    flown = sorted({r["variant"] for r in records})
    if args.reference not in flown:  # the table came out without its paired columns
        raise ValueError(f"The '--reference' parameter of {name} must be a variant the store "
                         f"holds: {flown}. Got {args.reference!r} instead.")
    other = None
    if args.against is not None:  # checked before the table is printed
        _existing_store(args.against, "--against", name)
        if Path(args.against).resolve() == Path(args.out).resolve():  # all "the same" (audit)
            raise ValueError(f"The '--against' parameter of {name} must name another store "
                             f"than --out. Got {str(args.against)!r}, the --out store, "
                             "instead.")
        other = NavStore(args.against, spec, create=False).latest()
    checks = []
    if other is not None:
        for (sid, v), rec in latest_records(records).items():
            theirs = other.get((sid, v))
            if v in variants and theirs is not None and ERROR not in (rec["outcome"],
                                                                       theirs["outcome"]):
                checks.append(checked_flight(theirs, rec))
        if not checks:  # "0 flights in both: 0 the same", status 0 (failure audit)
            raise ValueError(f"The '--against' parameter of {name} must name a store holding "
                             f"some of this table's flights (scenario and variant, flown "
                             f"without a harness error). Got {str(args.against)!r} instead, "
                             "which holds none of them.")
    if args.figure is not None and len({r.get("map_index") for r in records}) > 1:
        raise ValueError(f"The '--figure' parameter of {name} draws one map: give --maps N "
                         "(the records of this table lie on the maps "
                         f"{sorted({r.get('map_index') for r in records})}). Got "
                         f"{str(args.figure)!r} for all of them instead.")
    check_figure_format(args.figure, "--figure", name)  # before the table is printed
    out = outputs(args, files={"--json": args.json, "--figure": args.figure})
    if spec.city is not None:  # (its rule may be its own: said above the table)
        from windnav.commands._city_suite import suite_rule
        from windnav.experiments.nav_suite import rule_words

        print(f"suite {spec.name} on the map {args.map}: start/goal pairs "
              f"{rule_words(**suite_rule(spec))}\n")
    table = _print_table(records, variants, args.reference, spec)
    payload = {"table": table}
    if other is not None:
        print()
        bad = _report(checks, f"{args.out} against {args.against}: {len(checks)} flights in "
                              "both", "the same", f"in {args.against}")
        payload["against"] = {"store": args.against, "flights": len(checks),
                              "same": len(checks) - len(bad), "checks": checks}
    if args.json is not None or args.figure is not None:
        with out.writing() as stage:
            if args.figure is not None:
                _draw_outcomes(spec, records, list(table["rows"]), stage.file("--figure"))
            if args.json is not None:
                write_json(_document(payload, args, spec), stage.file("--json"))
        print_written(out)
    return 0


def _draw_outcomes(spec, records, variants, path) -> None:
    """``--figure``: each variant's latest flight of each scenario on their one map, but the
    harness errors, which the table leaves out too (so the panels' failure rates are its)."""
    from windnav.experiments.nav_records import ERROR, latest_records
    from windnav.experiments.nav_suite import suite_map
    from windnav.viz.nav_studies import plot_outcome_map

    latest = [r for r in latest_records(records).values() if r["outcome"] != ERROR]
    if not latest:
        raise ValueError(f"The '--figure' parameter of windnav benchmark-nav draws flown "
                         f"records. Got {str(path)!r} for a table of none (harness errors "
                         "only, or no flight) instead.")
    (m,) = {r["map_index"] for r in latest}
    speeds = sorted({float(r["speed"]) for r in latest})
    toward = sorted({float(r["direction_deg"]) for r in latest})
    plot_outcome_map(suite_map(spec, m), latest, variants, path,
                     title=f"{spec.name} suite, map m{m:02d}: each variant's outcome at each "
                           f"of {len({r['scenario_id'] for r in latest})} scenarios (winds of "
                           f"{speeds[0]:g}-{speeds[-1]:g} m/s toward {toward[0]:g}-"
                           f"{toward[-1]:g}°)")


def _report(checks: list, head: str, same: str, other: str) -> list:
    """Mark each of ``checks`` ``reproduced``, print the summary line, the table per variant and
    the first flights that differ; returns those."""
    for c in checks:
        c["reproduced"] = _reproduced(c["check"])
    bad = [c for c in checks if not c["reproduced"]]
    print(f"{head}: {len(checks) - len(bad)} {same} (same outcome, every field within "
          f"{REPLAY_TOLERANCE:g})\n")
    print("| variant | flights | same outcome | within 1e-6 | largest relative difference |")
    print("|---|---|---|---|---|")
    rows = {}
    for c in checks:
        row = rows.setdefault(c["variant"], [0, 0, 0, 0.0])
        row[0] += 1
        if c["check"] is None:
            row[3] = float("inf")
            continue
        row[1] += c["check"]["same_outcome"]
        row[2] += c["reproduced"]
        row[3] = max(row[3], c["check"]["max_relative_difference"])
    for v, (k, same_outcome, good, worst) in rows.items():
        print(f"| {v} | {k} | {same_outcome} | {good} | {worst:.3g} |")
    for c in bad[:10]:
        if c["check"] is None:
            print(f"not flown: {c['scenario_id']} {c['variant']}")
            continue
        a, b = c["replayed"], c["recorded"]
        print(f"differs: {c['scenario_id']} {c['variant']}: {a['outcome']}, {_joules(a)} "
              f"against {b['outcome']}, {_joules(b)} {other} "
              f"({c['check']['max_relative_difference']:.3g})")
    if len(bad) > 10:
        print(f"... and {len(bad) - 10} more (--json lists every flight)")
    return bad


def _check(args, name: str) -> int:
    import numpy as np

    from windnav.experiments.arithmetic import arithmetic
    from windnav.experiments.nav_benchmark import (
        KERNEL_FIELDS,
        KERNEL_SENSITIVE_NOTE,
        check_records,
        check_wind_batch,
    )
    from windnav.experiments.nav_records import ERROR, latest_records, record_arithmetic
    from windnav.experiments.results import write_json

    text = str(args.check).strip().lower()
    n = None if text == "all" else positive_int(_int(args.check, "--check", name), "--check",
                                                 name)
    spec, records, variants = _stored(args, name)
    out = outputs(args)
    workers = None if args.workers is None else positive_int(args.workers, "--workers", name)
    with options_named({"'wind_batch'": "'--wind-batch'"}):
        wind_batch = check_wind_batch(args.wind_batch, name)
    flights = [r for r in latest_records(records).values()
               if r["variant"] in variants and r.get("outcome") != ERROR]
    ids = sorted({r["scenario_id"] for r in flights})
    if n is not None and n < len(ids):  # the same draw in a process restarted under a pin
        ids = sorted(ids[i] for i in np.random.default_rng(0).choice(len(ids), n, False))
    chosen = set(ids)
    flights = [r for r in flights if r["scenario_id"] in chosen]
    if not flights:
        raise ValueError(f"The store {str(args.out)!r} holds no flight of {name}'s --variants, "
                         "--maps and --scenarios to check.")
    man = _manifest(args.out)
    kinds, groups = {}, {}  # each arithmetic among the records (named, or declared) and its
    for r in flights:       # flights
        known = record_arithmetic(r, man)
        key = tuple(known.get(k) for k in KERNEL_FIELDS)
        kinds.setdefault(key, known)
        groups.setdefault(key, []).append(r)
    under = f"under {_arithmetic(arithmetic())}"
    pins = []  # with several arithmetics: each group's pin, for the JSON
    if len(kinds) == 1:
        status = _pinned(args, next(iter(kinds.values())), "checking", "the records'")
        if status is not None:
            return status
    elif args.executor != "process" or args.native_arithmetic:
        why = ("--native-arithmetic" if args.native_arithmetic else
               f"the {args.executor!r} executor flies them in processes not started here")
        print(f"note: the records were flown under {len(kinds)} arithmetics; checking under "
              f"this machine's own ({why})", file=sys.stderr)
    else:
        checks, pins = _check_groups(args, spec, kinds, groups, workers, wind_batch)
        under = f"under their records' {len(kinds)} arithmetics (each group's workers pinned)"
    if not pins:  # one group, flown here or under this process's pin
        checks = check_records(spec, flights, executor=args.executor, workers=workers,
                               progress=not args.no_progress, wind_batch=wind_batch)
    bad = _report(checks, f"{args.out}: {len(checks)} flights of {len(ids)} scenarios flown "
                          f"again {under}", "reproduced", "recorded")
    if bad:
        print(f"note: {KERNEL_SENSITIVE_NOTE}. Arithmetic of the records: "
              + "; ".join(sorted({_arithmetic(r) for r in kinds.values()})), file=sys.stderr)
    if args.json is not None:
        summary = {"flights": len(checks), "scenarios": len(ids),
                   "variants": list(dict.fromkeys(r["variant"] for r in flights)),
                   "reproduced": len(checks) - len(bad), "arithmetic": arithmetic(),
                   "records_arithmetic": list(kinds.values()), "tolerance": REPLAY_TOLERANCE}
        if pins:
            summary["groups"] = pins
        with out.writing() as stage:
            write_json(_document({"summary": summary, "flights": checks}, args, spec),
                       stage.file("--json"))
        print_written(out)
    return 0 if not bad else 1


def _check_groups(args, spec, kinds: dict, groups: dict, workers, wind_batch):
    """Check the flights of each arithmetic among the records in worker processes started under
    it, or the nearest this machine runs (``None`` pins: this machine's own, said so).

    Returns the checks (the groups' in turn) and, per group, ``records_arithmetic``,
    ``environment`` (None when it could not be pinned), ``line`` and ``flights``. A scenario
    with flights in two groups has its wind simulated once in each.
    """
    from windnav.experiments.arithmetic import pinned_environment, process_environment
    from windnav.experiments.nav_benchmark import check_records

    checks, pins = [], []
    for key, known in kinds.items():
        group = groups[key]
        env, line = pinned_environment(known, nearest=True)
        where_ = (f"this machine's own ({line})" if env is None else
                  f"the records' arithmetic ({line})")
        print(f"note: checking {len(group)} flights of {_arithmetic(known)} under {where_}",
              file=sys.stderr, flush=True)
        with process_environment(env or {}):
            checks += check_records(spec, group, executor="process", workers=workers,
                                    progress=not args.no_progress, wind_batch=wind_batch)
        pins.append({"records_arithmetic": known, "environment": env, "line": line,
                     "flights": len(group)})
    return checks, pins


def _joules(record: dict) -> str:
    e = record.get("energy_J")
    return "no energy" if e is None else f"{e:.1f} J"


def _int(text, flag: str, name: str) -> int:
    try:
        return int(str(text))
    except ValueError:
        raise ValueError(f"The '{flag}' parameter of {name} must be a number of scenarios or "
                         f"'all'. Got {text!r} instead.") from None


def _reproduced(check: dict | None) -> bool:
    """Whether a flight compared with its record (:func:`compare_records`; None: not flown)
    reproduced it: the same outcome, every field within :data:`REPLAY_TOLERANCE`."""
    return (check is not None and check["same_outcome"]
            and check["max_relative_difference"] <= REPLAY_TOLERANCE)


def _pinned(args, record: dict, doing: str, whose: str) -> int | None:
    """Restart this command under ``record``'s arithmetic when it differs from this machine's
    and the CPU can run it, or the nearest one it can (NumPy SIMD targets it lacks left out;
    :func:`~windnav.experiments.arithmetic.pinned_environment`), not with
    ``--native-arithmetic`` nor in a process so started: the new process's exit status; None to
    go on here (with a note when the CPU cannot, or runs only the nearest)."""
    from windnav.experiments.arithmetic import (
        FIELDS,
        PIN_VARIABLE,
        arithmetic,
        pinned_environment,
    )

    if args.native_arithmetic or PIN_VARIABLE in os.environ:
        return None
    env, line = pinned_environment(record, nearest=True)
    if env:
        return _restart(args, env, f"{doing} under {whose} arithmetic ({line})")
    if env is None:
        print(f"note: {line}; {doing} under this machine's own", file=sys.stderr)
    else:
        ours = arithmetic()  # once: it asks the BLAS library and NumPy
        if any(record.get(k) not in (None, ours[k]) for k in FIELDS):  # the nearest is ours
            print(f"note: {doing} under {whose} arithmetic ({line}): this machine's own "
                  "already", file=sys.stderr)
    return None


def _restart(args, env: dict, why: str) -> int:
    """Run this command line again in a new Python process whose environment adds ``env`` (a
    pinned arithmetic, :mod:`windnav.experiments.arithmetic`); its exit status."""
    import subprocess

    from windnav.experiments.arithmetic import PIN_VARIABLE

    print(f"note: {why}: restarting with " + " ".join(f"{k}={v!r}" for k, v in env.items()),
          file=sys.stderr, flush=True)
    sys.stdout.flush()
    proc = subprocess.Popen([sys.executable, "-m", "windnav", *map(str, args.argv)],
                            env={**os.environ, **env, PIN_VARIABLE: "1"})
    while True:
        try:
            return proc.wait()
        except KeyboardInterrupt:  # the new process got it too, and stops on its own
            continue


def _arithmetic(record: dict) -> str:
    """A record's arithmetic (or :func:`~windnav.experiments.nav_records.record_arithmetic`'s
    answer for it) in words."""
    if "blas_kernel" not in record:
        return "not recorded (flown before 2026-12-02)"
    simd = record.get("numpy_simd", "not recorded")
    text = f"BLAS {record['blas_kernel'] or 'unknown (not OpenBLAS)'}, NumPy SIMD {simd}"
    if record.get("declared"):
        text += " (not recorded: declared by the store's manifest, found by audit)"
    return text


REPLAY_TOLERANCE = 1e-6
"""Largest relative difference of a replayed record's fields that counts as reproduced (issue
11's criterion)."""


def _replay(args, name: str) -> int:
    import json

    from windnav.experiments.nav_benchmark import (
        KERNEL_SENSITIVE_NOTE,
        NavStore,
        compare_records,
        replay,
    )
    from windnav.experiments.nav_records import record_arithmetic
    from windnav.experiments.results import json_ready, write_json

    if args.variant is None:
        raise ValueError(f"The '--variant' parameter of {name} must name the variant to "
                         "replay with --replay. Got None instead.")
    refuse_other_views(args, name, [args.variant], "--variant")
    suite = str(args.replay).split("/", 1)[0]
    from windnav.experiments.nav_suite import SUITES

    if args.suite is None and suite not in SUITES and args.map is None:
        raise ValueError(f"The '--replay' parameter of {name} must be a scenario id of a suite "
                         f"in {list(SUITES)} (e.g. thesis/m03/w07/p2). Got {args.replay!r} "
                         "instead.")
    spec = _spec(args, name, prefer=suite)
    out = outputs(args)
    recorded, known, man = None, {}, _manifest(args.out)
    if man is not None:
        from windnav.experiments.nav_suite import parse_scenario_id

        with options_named({"'scenario_id' parameter of parse_scenario_id":
                            f"'--replay' parameter of {name}"}):
            canonical = parse_scenario_id(spec, args.replay).scenario_id  # m3 is m03
        recorded = NavStore(args.out, spec, create=False).latest().get(
            (canonical, args.variant))
    if recorded is not None:
        known = record_arithmetic(recorded, man)
        status = _pinned(args, known, "replaying", "the record's")
        if status is not None:
            return status
    with options_named({"'scenario_id' parameter of parse_scenario_id":
                        f"'--replay' parameter of {name}",
                        "'variants' parameter of replay": f"'--variant' parameter of {name}"}):
        record = replay(spec, args.replay, args.variant)
    payload = dict(record)
    if recorded is not None:
        payload["check"] = compare_records(record, recorded)
    keys = ("scenario_id", "variant", "seed", "outcome", "energy_J", "rotor_energy_J",
            "time_s", "distance_m", "mean_cmd_accel")
    print(json.dumps(json_ready({k: record[k] for k in keys}), indent=2))
    if recorded is not None:
        c = payload["check"]
        print(f"against the record in {args.out}: same outcome {c['same_outcome']}, largest "
              f"relative difference {c['max_relative_difference']:.3g}")
        if not _reproduced(c):
            print(f"note: {KERNEL_SENSITIVE_NOTE}. Arithmetic of the record: "
                  f"{_arithmetic(known)}; of this replay: {_arithmetic(record)}",
                  file=sys.stderr)
    if record["error"]:
        print(record["error"], file=sys.stderr)
    if args.json is not None:
        with out.writing() as stage:
            write_json(_document(payload, args, spec), stage.file("--json"))
        print_written(out)
    return 1 if record["error"] else 0
