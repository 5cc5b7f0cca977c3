"""The ``windnav`` command.

Each subcommand lives in its own module under ``windnav.commands`` exposing
``register(subparsers)``. Every module listed here is imported when the parser is built, so a
command never disappears from ``--help``; a command's optional dependencies (Ray) are imported
only when it runs, and a missing one is reported then, with an install hint.

Errors: a named error (a ``ValueError``, an ``OSError`` on a path, an ``OverflowError`` from a
value too large to compute with, an exception class defined by windnav, a missing optional
dependency) is printed as one line and the exit status is
nonzero; Ctrl-C exits with 130 and one line. Any other exception is a bug and keeps its
traceback.
"""

from __future__ import annotations

import argparse
import importlib
import os
import sys
import warnings

# name of the module in windnav.commands, in the order shown by --help
COMMAND_MODULES = (
    "fly",
    "power_curve",
    "wind",
    "wind_sweep",
    "flow_validate",
    "ukf_montecarlo",
    "calibrate",
    "sysid",
    "similitude",
    "city",
    "navigate",
    "demo",
    "benchmark_nav",
    "nav_study",
    "tune_mppi",
    "train_decoder",
    "evaluate_decoder",
    "decoder_study",
    "predict",
)

EXIT_ERROR = 2
"""Exit status of a named error (bad input, an output path that cannot be written)."""
EXIT_FAILED = 1
"""Exit status of an environment failure (OSError) or a named failure of the computation."""
EXIT_INTERRUPTED = 130
"""Exit status after Ctrl-C (128 + SIGINT), as shells report it."""


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="windnav",
        description="Real-time local wind inference and wind-aware navigation for multirotors.",
    )
    from windnav import __version__

    parser.add_argument("--version", action="version", version=f"windnav {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for name in COMMAND_MODULES:
        importlib.import_module(f"windnav.commands.{name}").register(sub)
    parser.commands = sub.choices  # each command's own parser, for its usage line in errors
    return parser


def _missing_dependency(exc: ImportError) -> bool:
    """True for a third-party module that is not installed (not a broken windnav import)."""
    name = getattr(exc, "name", None) or ""
    return name.split(".")[0] != "windnav"


def _named(exc: Exception) -> bool:
    """An exception class windnav defines (FlowDivergedError, ...): a named error."""
    return type(exc).__module__.split(".")[0] == "windnav"


class _ClosedPipeSafe:
    """Standard output that a reader leaving the pipe (``windnav ... | head -1``) cannot stop:
    from the first ``BrokenPipeError`` on, what is printed goes to the null device and the
    command goes on to write its files. It was an ``error: [Errno 32] Broken pipe`` after
    every file had been written, or, if the break came first, a command stopped before its
    files (side-effects audit and review, thirty-seventh session)."""

    def __init__(self, stream):
        self._stream = stream

    def _closed(self) -> None:
        try:  # the buffered rest, and Python's flush at exit, go nowhere
            os.dup2(os.open(os.devnull, os.O_WRONLY), self._stream.fileno())
        except (AttributeError, OSError, ValueError):
            pass

    def write(self, text):
        try:
            return self._stream.write(text)
        except BrokenPipeError:
            self._closed()
            return len(text)

    def flush(self) -> None:
        try:
            self._stream.flush()
        except BrokenPipeError:
            self._closed()

    def __getattr__(self, name):
        return getattr(self._stream, name)


def _command_parser(parser: argparse.ArgumentParser, args) -> argparse.ArgumentParser:
    """The parser of the command ``args`` ran, down to a subcommand's (``windnav sysid
    similitude``)."""
    command = parser.commands[args.command]
    while True:
        subs = [a for a in command._actions if isinstance(a, argparse._SubParsersAction)]
        name = getattr(args, subs[0].dest, None) if subs else None
        if name not in (subs[0].choices if subs else {}):
            return command
        command = subs[0].choices[name]


def main(argv: list[str] | None = None) -> int:
    """Run the command line ``argv`` (default ``sys.argv[1:]``); returns the exit status."""
    parser = build_parser()
    args, extra = parser.parse_known_args(argv)
    if extra:  # parse_args's error, with the (sub)command's usage rather than windnav's
        _command_parser(parser, args).error(f"unrecognized arguments: {' '.join(extra)}")
    args.argv = list(sys.argv[1:] if argv is None else argv)  # for a command that restarts
    where = f"windnav {args.command}"
    if argv is None:  # the command line itself: warnings as one line, not a source location
        # and figures to files, never a window, whatever the user's backend (the plotting
        # modules no longer switch it at import, which a notebook's import of them did): set
        # before matplotlib is imported, and inherited by the worker processes
        # (and the variable restored after; matplotlib reads it once, at its first import, so a
        # program whose matplotlib the command imported first keeps Agg: import matplotlib, or
        # choose its backend, before calling main())
        backend = os.environ.get("MPLBACKEND")
        os.environ["MPLBACKEND"] = "Agg"
        stdout, sys.stdout = sys.stdout, _ClosedPipeSafe(sys.stdout)
        try:
            with warnings.catch_warnings():
                from windnav._console import one_line_warning

                warnings.showwarning = one_line_warning(where)
                return _run(args, where)
        finally:
            sys.stdout.flush()
            sys.stdout = stdout
            if backend is None:
                os.environ.pop("MPLBACKEND", None)
            else:
                os.environ["MPLBACKEND"] = backend
    return _run(args, where)


def _run(args, where: str) -> int:
    """Run the parsed command; named errors become one line and an exit status."""
    try:
        return int(args.func(args) or 0)
    except KeyboardInterrupt:
        print(f"{where}: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    except ValueError as exc:
        print(f"{where}: error: {exc}", file=sys.stderr)
        return EXIT_ERROR
    except ImportError as exc:
        if not _missing_dependency(exc):
            raise
        from windnav._extras import install_hint

        hint = "" if "install" in str(exc) else (
            f"; this command needs the optional dependency {exc.name!r}: "
            f"{install_hint(exc.name)}")
        print(f"{where}: error: {exc}{hint}", file=sys.stderr)
        return EXIT_ERROR
    except OSError as exc:
        print(f"{where}: error: {exc}", file=sys.stderr)
        return EXIT_FAILED
    except OverflowError as exc:  # `--duration 1e308`: a traceback from round(x / dt) (audit)
        print(f"{where}: error: a value given is too large to compute with ({exc}); check the "
              "options' magnitudes", file=sys.stderr)
        return EXIT_ERROR
    except Exception as exc:
        if not _named(exc):
            raise
        print(f"{where}: error: {type(exc).__name__}: {exc}", file=sys.stderr)
        return EXIT_FAILED


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
