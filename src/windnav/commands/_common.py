"""Arguments and output handling shared by every command.

Every command that writes results takes ``--json PATH`` (a JSON summary, see
:func:`windnav.experiments.results.document`) and ``--overwrite`` (replace the results of an
earlier run, removing its stale files); its output paths are checked by
:class:`windnav.experiments.results.Outputs` before anything is computed.
"""

from __future__ import annotations

import os
from pathlib import Path

from windnav._validate import options_named  # noqa: F401  (the commands import it from here)
from windnav.experiments.results import Outputs, check_output_path, document

__all__ = ["add_boundary_argument", "add_compare_boundary_argument", "add_output_arguments",
           "add_rotations_argument", "compare_boundary", "cache_folder", "check_figure_format",
           "check_output_path",
           "document", "fill_defaults", "load_model", "map_argument", "model_files",
           "options_named", "outputs", "path_argument", "print_written", "seed", "where"]


def path_argument(text: str) -> Path | str:
    """The argparse ``type`` of an output folder option: ``Path(text)``, but the empty string
    kept as typed, so that :func:`check_output_path` refuses it ("must be a path"):
    ``Path("")`` is ``.``, so ``fly --out ""`` wrote its results into the current folder
    (CLI audit)."""
    return Path(text) if text else text


def add_output_arguments(parser, *, overwrite: bool = True) -> None:
    """Add ``--json PATH`` (and ``--overwrite``) to ``parser``."""
    parser.add_argument("--json", type=Path, default=None, metavar="PATH",
                        help="also write a JSON summary of the run here")
    if overwrite:
        parser.add_argument("--overwrite", action="store_true",
                            help="replace the results of an earlier run (its files that this run "
                                 "does not write again are removed); without it, existing "
                                 "results are never replaced")


def add_rotations_argument(parser, *, compare: bool = False, which: str | None = None,
                           boundary: bool = True) -> None:
    """Add ``--rotations-deg A [A ...]``: the decoder's turned views
    (:class:`windnav.predict.Decoder`'s ``rotations_deg``), and with ``boundary``
    ``--boundary``, its rule at the sector boundaries (``boundary``); ``compare``: the command
    also takes ``--compare`` models, which the help says run without the views and under
    ``--boundary`` unless ``--compare-boundary`` (:func:`add_compare_boundary_argument`)
    says otherwise; ``which``: the decoder the help names (default ``--model``)."""
    if which is None:
        which = "--model; not --compare's models" if compare else "--model"
    parser.add_argument("--rotations-deg", type=float, nargs="+", default=None, metavar="DEG",
                        help=f"predict the mean of the decoder ({which}) over the scene turned "
                             "by each of these angles, deg CCW, whole degrees within 45 of 0 "
                             "(e.g. 0 -3 3: three views; default: the scene as given)")
    if not boundary:
        return
    add_boundary_argument(parser, "--model, and --compare's models unless --compare-boundary"
                          if compare else which)
    if compare:
        add_compare_boundary_argument(parser)


BOUNDARY_RULES = ("blend", "average", "floor")
"""``--boundary``'s and ``--compare-boundary``'s choices, the default first:
:data:`windnav.predict.decoder.BOUNDARIES` (not imported here: every command's start-up reads
this module)."""
BOUNDARY_HELP = ("how {which} answers inlets near a multiple of 45 deg, where its two symmetries "
                 "meet: 'blend' (default since 2026-12-06): the two blended within 8 deg of one, "
                 "so that the field is continuous in the inlet direction (two passes there); "
                 "'average': one pass, their mean only on a boundary (the rule of the results "
                 "made before); 'floor': the side rounding picks")


def add_boundary_argument(parser, which: str = "--model") -> None:
    """Add ``--boundary`` (:data:`windnav.predict.decoder.BOUNDARIES`, default ``blend``, as
    :func:`windnav.predict.load_decoder`): the rule of the decoder ``which`` names."""
    parser.add_argument("--boundary", choices=BOUNDARY_RULES, default=BOUNDARY_RULES[0],
                        help=BOUNDARY_HELP.format(which=f"the decoder ({which})"))


def add_compare_boundary_argument(parser) -> None:
    """Add ``--compare-boundary``: the ``--compare`` models' rule (default: ``--boundary``'s)."""
    parser.add_argument("--compare-boundary", choices=BOUNDARY_RULES,
                        default=None,
                        help="the --compare models' rule at the sector boundaries, as "
                             "--boundary (default: --boundary's; only with --compare)")


def compare_boundary(args) -> str:
    """The ``--compare`` models' boundary rule: ``--compare-boundary``, else ``--boundary``."""
    rule = getattr(args, "compare_boundary", None)
    return args.boundary if rule is None else rule


def model_files(args) -> dict:
    """The decoder files a command read, as its result records them (since 2026-12-06, the
    forty-seventh session): ``{"model": {"path", "sha256"}, "compare": {ITEM: {"path",
    "sha256"}}}`` for ``--model`` (``"default"``: the shipped model's file, hashed) and each
    ``--compare`` item as given; without ``"model"`` for a command that has no ``--model``
    (``nav-study inflight``'s ``--compare``). :func:`windnav.provenance.command_line` names the
    dated file of a default model that has since been replaced."""
    from windnav.predict.decoder import DEFAULT_MODEL, model_sha256

    def one(path):  # a missing file (refused by the command, naming it): no hash
        exists = Path(DEFAULT_MODEL if path is None else path).is_file()
        return {"path": "default" if path is None else str(path),
                "sha256": model_sha256(path) if exists else None}

    compare = {}
    for item in getattr(args, "compare", None) or []:
        text = str(item)  # [NAME=]FILE, read as evaluate-decoder's _compare_files reads it
        compare[text] = one(text.split("=", 1)[1] if "=" in text else text)
    if not hasattr(args, "model"):
        return {"compare": compare}
    return {"model": one(args.model), "compare": compare}


def load_model(args, name: str):
    """``--model`` (default the shipped decoder) loaded with ``--rotations-deg`` and
    ``--boundary`` (load_decoder's default for a command without it), their errors naming the
    options."""
    from windnav.predict import load_decoder

    rule = getattr(args, "boundary", None)
    with options_named({"'path' parameter of load_decoder": f"'--model' parameter of {name}",
                        "'rotations_deg' parameter of load_decoder":
                            f"'--rotations-deg' parameter of {name}"}):
        return load_decoder(args.model, rotations_deg=args.rotations_deg,
                            **({} if rule is None else {"boundary": rule}))


def where(args) -> str:
    """``"windnav <command>"``, the subject of every message."""
    return f"windnav {args.command}"


def refuse_other_studies(args, name: str, readers) -> None:
    """Refuse each option of ``readers`` (its ``args`` attribute name, to the studies that read
    it) given to another ``args.study``: such options were accepted and ignored, only the
    JSON's ``arguments`` differing (CLI audit, 2026-12-05). None and [] count as not given."""
    for key, studies in readers.items():
        value = getattr(args, key)
        if args.study not in studies and value not in (None, []):
            which = (" and " if len(studies) == 2 else ", ").join(studies)
            shown = repr(str(value) if isinstance(value, os.PathLike) else value)  # not
            # "PosixPath('...')" (CLI audit)
            raise ValueError(f"The '--{key.replace('_', '-')}' parameter of {name} is for the "
                             f"{which} {'study' if len(studies) == 1 else 'studies'}. Got "
                             f"{shown} for {args.study!r} instead.")


def seed(args) -> int:
    """``--seed``, checked: an integer >= 0 (what ``numpy.random.default_rng`` accepts)."""
    value = args.seed
    if isinstance(value, bool) or int(value) != value or value < 0:
        raise ValueError(f"The '--seed' parameter of {where(args)} must be an integer >= 0. "
                         f"Got {value!r} instead.")
    return int(value)


def checked_workers(args, name: str) -> int | None:
    """``--workers``, checked (None when not given): an integer >= 1, and refused with ``--backend
    serial``, which runs no workers (it was accepted and ignored; CLI audit, thirty-seventh
    session)."""
    from windnav._validate import positive_int

    if args.workers is None:
        return None
    count = positive_int(args.workers, "--workers", name)
    if getattr(args, "backend", None) == "serial":
        raise ValueError(f"The '--workers' parameter of {name} is for the process and ray "
                         f"backends. Got {args.workers!r} with --backend serial instead.")
    return count


def cache_folder(path, option: str, name: str):
    """``path`` (a folder to keep a cache in, made when missing), or a ValueError naming
    ``option`` when it is a file ("[Errno 17] File exists" named nothing)."""
    if path is not None and os.path.exists(path) and not os.path.isdir(path):
        raise ValueError(f"The {option!r} parameter of {name} must name a folder (made when "
                         f"missing). Got {str(path)!r} instead, which is a file.")
    return path


def gif_frames(value, name: str, default: int | None = None) -> int | None:
    """``--gif-frames``, checked: an integer >= 2 (``value`` None: ``default``), the frames of
    :func:`windnav.viz.animate.animate_flights` (``windnav demo`` and ``windnav navigate``)."""
    frames = default if value is None else value
    if frames is not None and (isinstance(frames, bool) or int(frames) != frames or frames < 2):
        raise ValueError(f"The '--gif-frames' parameter of {name} must be an integer >= 2. "
                         f"Got {frames!r} instead.")
    return None if frames is None else int(frames)


def inlet_direction(value, option: str, name: str) -> float:
    """An inlet direction option, deg CCW from +x: finite and within one turn either way,
    [-360, 360] (``wind --direction-deg 1e308`` flew some direction and recorded 1e308 deg:
    options audit, 2026-12-05), checked before any work, named."""
    from windnav._validate import finite_float

    direction = finite_float(value, option, name)
    if abs(direction) > 360.0:
        raise ValueError(f"The {option!r} parameter of {name} must be a direction within one "
                         f"turn, from -360 to 360 deg. Got {value!r} instead.")
    return direction


def inlet_speed(value, option: str, name: str) -> float:
    """An inlet speed option, m/s: > 0 and no faster than the flow solver's model holds
    (:data:`windnav.flow.solver.MAX_SPEED`), checked before any work, named."""
    from windnav._validate import positive_float
    from windnav.flow.solver import MAX_SPEED

    speed = positive_float(value, option, name)
    if speed > MAX_SPEED:
        raise ValueError(f"The {option!r} parameter of {name} must be <= {MAX_SPEED:g} m/s: the "
                         "wind solver is incompressible, valid below Mach 0.3. Got "
                         f"{value!r} instead.")
    return speed


def fill_defaults(args, defaults) -> None:
    """Set each option of ``defaults`` (attribute name to value) that ``args`` leaves None, and
    name those set in ``args.filled_defaults``, which
    :func:`windnav.experiments.results.document` records as None: a result's ``arguments``
    stay the line as typed, which :mod:`windnav.provenance` parses back to them."""
    filled = [key for key in defaults if getattr(args, key) is None]
    for key in filled:
        setattr(args, key, defaults[key])
    args.filled_defaults = (*getattr(args, "filled_defaults", ()), *filled)


def map_argument(item: str, flag: str, name: str):
    """A map option's value ``[NAME=]FILE``: ``(NAME, FILE, City)``, NAME defaulting to the
    file's name without ``.json`` (a path with ``=`` in it that names a file is the file); the
    file read now, so a missing or unreadable one is refused naming ``flag``."""
    from windnav.city import read_rotorpy_json

    given, sep, file = str(item).partition("=")
    if not sep or Path(item).is_file():
        given, file = None, str(item)
    path = Path(file)
    if not path.is_file():
        what = "a folder" if path.is_dir() else "which does not exist"
        raise ValueError(f"The {flag!r} parameter of {name} must be a RotorPy world JSON file "
                         f"([NAME=]FILE). Got {file!r} instead, {what}.")
    try:
        city = read_rotorpy_json(path)
    except ValueError as exc:
        raise ValueError(f"The {flag!r} parameter of {name} must be a RotorPy world JSON file "
                         f"([NAME=]FILE). Got {file!r} instead: {exc}") from None
    label = given if given is not None else (path.stem if path.suffix == ".json" else path.name)
    if not label:
        raise ValueError(f"The {flag!r} parameter of {name} must give a name before '=' "
                         f"(NAME=FILE). Got {item!r} instead.")
    return label, path, city


def outputs(args, *, out=None, files=None, inputs=None) -> Outputs:
    """Check the run's output paths now (before any computation); see
    :class:`~windnav.experiments.results.Outputs`. ``files`` defaults to ``{"--json":
    args.json}``. Also refused: a file inside a folder that ``out`` writes (``Outputs``
    refuses one of its products by name, not ``wind --json OUT/flow.zarr/zarr.json``, inside
    the store), and one that is an input the run reads (``inputs``: flag -> path, or a list of
    paths for a repeatable option; ``wind --map M.json --json M.json --overwrite`` replaced
    the map with the summary): CLI audit."""
    files = {"--json": getattr(args, "json", None)} if files is None else files
    name = where(args)
    given = {flag: path for flag, path in files.items() if path is not None and str(path)}
    if out is not None and out[1] is not None and str(out[1]):
        _refuse_inside_products(given, out, name)
    sources = [(source_flag, source) for source_flag, value in (inputs or {}).items()
               for source in (value if isinstance(value, (list, tuple)) else [value])]
    for flag, path in given.items():
        for source_flag, source in sources:
            if source is not None and str(source) and _same_file(path, source):
                raise ValueError(f"The {flag!r} parameter of {name} must not name "
                                 f"{source_flag}'s file, an input of the run. Got "
                                 f"{str(path)!r} instead.")
    return Outputs(name, out=out, files=files,
                   overwrite=bool(getattr(args, "overwrite", False)))


def _same_file(a, b) -> bool:
    """Whether the paths ``a`` and ``b`` name one file (the same path, or links to one)."""
    if os.path.abspath(a) == os.path.abspath(b):
        return True
    try:
        return os.path.samefile(a, b)
    except OSError:  # one of them missing: not the same file
        return False


def _refuse_inside_products(files: dict, out, name: str) -> None:
    """Refuse a file of ``files`` (flag -> path) under one of the products of ``out`` (flag,
    folder, names or glob patterns): a folder the run writes whole, and replaces."""
    from fnmatch import fnmatch

    flag, folder, products = out
    base = Path(os.path.realpath(folder))
    for option, path in files.items():
        try:
            parts = Path(os.path.realpath(path)).relative_to(base).parts
        except ValueError:  # not under --out
            continue
        if len(parts) > 1 and any(fnmatch(parts[0], pattern) for pattern in products):
            raise ValueError(f"The {option!r} parameter of {name} must not name a file inside "
                             f"{parts[0]!r}, which {flag} writes (and replaces). Got "
                             f"{str(path)!r} instead.")


def print_written(out: Outputs) -> None:
    """One ``wrote`` line per file written, one ``removed`` line per stale file removed, on
    stderr: a command's standard output is its JSON summary alone, for a pipe (the lines
    followed the summary there, and ``json.load`` of it failed; side-effects audit,
    thirty-seventh session)."""
    import sys

    for path in out.written:
        print(f"wrote {path}", file=sys.stderr)
    for path in out.removed:
        print(f"removed {path} (from an earlier run)", file=sys.stderr)


def print_drag_model_note(bias, airspeed, conditions: str, prefix: str = "", *,
                          measured=None) -> None:
    """Say on stderr when the Wind UKF's drag model under ``conditions`` is not the vehicle's
    enough to bias its estimate: ``bias`` (m/s, :func:`windnav.estimate.drag_model_bias`) at
    the flight's median horizontal ``airspeed`` (m/s) at least
    :data:`~windnav.estimate.uncertainty.DRAG_BIAS_NOTE_MPS`; ``measured``: the mean
    estimation error, m/s per axis, when known."""
    import math
    import sys

    from windnav.estimate.uncertainty import DRAG_BIAS_NOTE_MPS

    if bias is None or not math.isfinite(bias) or abs(bias) < DRAG_BIAS_NOTE_MPS:
        return
    got = ("" if measured is None else
           f"; measured here: mean error ({', '.join(f'{e:+.2f}' for e in measured)}) m/s")
    print(f"{prefix}note: the '{conditions}' Wind UKF's drag model is not the vehicle's "
          "(e.g. no frame drag): at this flight's median horizontal airspeed "
          f"{airspeed:.3g} m/s it reads the airflow {bias:+.2f} m/s too strong "
          f"(drag_model_bias, at hover rotor speed){got}; the bias grows with the square of "
          "the airspeed", file=sys.stderr)


def check_figure_format(path, flag: str, name: str) -> None:
    """Refuse a figure file ``path`` (``flag``) whose suffix Matplotlib cannot write, before
    any computation (a table or a Monte Carlo printed first, then refused; CLI audit)."""
    if path is None:
        return
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    kinds = FigureCanvasAgg.get_supported_filetypes()
    if Path(path).suffix.lstrip(".").lower() not in kinds:
        raise ValueError(f"The '{flag}' parameter of {name} must end in a figure format "
                         f"({', '.join(sorted(kinds))}). Got {str(path)!r} instead.")
