"""``windnav flow-validate``: the flow solver's validation study (plots + JSON).

Checks, each against a reference that does not come from this code: the discrete
divergence after every projection (0), the normal velocity on building faces (0), uniform
flow without buildings (stays uniform), the Taylor-Green vortex in a free-slip box (an exact
steady Euler solution: its decay is the scheme's numerical viscosity). ``--studies`` adds the
Strouhal studies of the thesis's validation figure (St against incidence for 1:1, 2:1 and 3:1
rectangles, St against the depth ratio B/H, runs that have not settled
recorded for longer; 7 min 26 s on 2 shared cores, 2026-12-05), ``--full`` also the
resolution series (a square at 0 and 90 deg, 8/16/32 cells per height), the closure comparison
and the label-noise table of the thesis's averaging protocol (18 min 39 s on
2 shared cores, 2026-12-05).

The studies keep every finished run in ``--out``'s ``flow_validation.partial.jsonl`` until the
outputs are written: after Ctrl-C (exit 130) or a kill, rerunning the same command runs only the
runs not yet done, and writes what an uninterrupted run writes. A record log of another
validation (``--studies`` or ``--full``, or ``--seed``, differ) is refused, or discarded with
``--overwrite``.

The harness is :mod:`windnav.experiments.flow_validation`, the figures
:mod:`windnav.experiments.flow_figures`.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

from windnav._validate import positive_int
from windnav.commands._common import (
    add_output_arguments,
    document,
    outputs,
    path_argument,
    print_written,
    seed,
    where,
)


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "flow-validate",
        help="validate the 2D flow solver (divergence, walls, vortex decay, Strouhal)",
        description=__doc__.splitlines()[0],
    )
    p.add_argument("--out", type=path_argument, required=True,
                   help="output folder (plots, JSON; while the studies run, their finished runs "
                        "are kept there in flow_validation.partial.jsonl, to resume from)")
    p.add_argument("--studies", action="store_true",
                   help="also run the Strouhal studies against incidence and aspect ratio "
                        "(about 7.5 minutes on 2 cores; resumable after an interrupt)")
    p.add_argument("--full", action="store_true",
                   help="the studies, plus the resolution series (8/16/32 cells per height), "
                        "the closure comparison and the label-noise table (about 19 minutes on 2 "
                        "cores; resumable after an interrupt)")
    p.add_argument("--workers", type=int, default=None,
                   help="worker processes for the Strouhal runs (default: all cores)")
    p.add_argument("--seed", type=int, default=0,
                   help="seed of the random city layout (and of the label-noise map) "
                        "(%(default)s)")
    p.add_argument("--no-progress", action="store_true", help="hide the progress bars")
    add_output_arguments(p)
    p.set_defaults(func=run)


def _is_record_log(path: Path) -> bool:
    """Whether the file at ``path`` starts as a record log does: a JSON object with a
    ``header`` on its first line (:class:`windnav.experiments.results.RecordLog`)."""
    with open(path, "rb") as f:
        first = f.readline()
    try:
        head = json.loads(first.decode("utf-8", errors="replace"))
    except ValueError:
        return False
    return isinstance(head, dict) and "header" in head


def products() -> tuple[str, ...]:
    """What a run writes into ``--out``."""
    from windnav.experiments.flow_figures import CHECK_FIGURES, STROUHAL_FIGURES

    return ("flow_validation.json", "strouhal_runs.json", *CHECK_FIGURES, *STROUHAL_FIGURES)


def _record_log(args, name: str):
    """The studies' record log in ``--out`` (None without --studies or --full), checked before
    anything runs: one of another validation is refused, or discarded with --overwrite."""
    from windnav.experiments.flow_validation import RECORDS, open_records
    from windnav.experiments.results import RecordMismatchError

    if not (args.studies or args.full):
        return None
    path = Path(args.out) / RECORDS
    config = {"seed": args.seed, "studies": args.studies, "full": args.full}
    try:
        log = open_records(path, **config)
    except RecordMismatchError:
        if not args.overwrite:
            if _is_record_log(path):
                what = ("holds the runs of another validation (--studies or --full, or --seed, "
                        "differ); rerun that validation to finish it, pass --overwrite to "
                        "discard them")
            else:  # (said to be another validation's before; CLI audit, 2026-12-07)
                what = ("is not a record log (its first line is no JSON header: damaged, or "
                        "another file); pass --overwrite to discard it")
            raise ValueError(
                f"The '--out' parameter of {name} names {str(args.out)!r}, whose record log "
                f"{str(path)!r} {what}, or choose another --out.") from None
        path.unlink()
        log = open_records(path, **config)
    n = len(log.load())
    if n:
        print(f"resuming: {n} finished run{'s' * (n != 1)} already in {log.path}",
              file=sys.stderr)
    return log


def run(args) -> int:
    from windnav.experiments.flow_figures import plot_checks, plot_strouhal
    from windnav.experiments.flow_validation import run_validation
    from windnav.experiments.results import write_json

    name = where(args)
    seed(args)
    if args.workers is not None:
        positive_int(args.workers, "--workers", name)
        if not (args.studies or args.full):  # accepted and ignored (CLI audit, 37th session)
            raise ValueError(f"The '--workers' parameter of {name} is for the Strouhal runs of "
                             f"--studies and --full. Got {args.workers!r} without either "
                             "instead.")
    out = outputs(args, out=("--out", args.out, products()))
    log = _record_log(args, name)
    try:
        res = run_validation(seed=args.seed, studies=args.studies, full=args.full,
                             workers=args.workers, progress=not args.no_progress,
                             records=None if log is None else log.path)
    except KeyboardInterrupt:
        if log is None:
            raise  # the checks alone: seconds, nothing to keep
        n = len(log.load()) if log.path.exists() else 0
        kept = f"{n} finished run{'s' * (n != 1)} kept in {log.path}" if n else "no run finished"
        print(f"{name}: interrupted: {kept}; rerun the same command to resume", file=sys.stderr)
        return 130
    with out.writing() as stage:
        figures = plot_checks(stage.dir, res["projection"], res["taylor_green"])
        figures += plot_strouhal(stage.dir, res["strouhal"])
        summary = {**res["summary"], "figures": figures}
        doc = document("flow-validate", summary, args)
        write_json(doc, stage.dir / "flow_validation.json")
        if res["runs"]:
            write_json(res["runs"], stage.dir / "strouhal_runs.json", indent=None)
        if stage.file("--json") is not None:
            write_json(doc, stage.file("--json"))
    if log is not None:
        log.remove()
    print(json.dumps(summary, indent=2))
    print_written(out)
    return 0
