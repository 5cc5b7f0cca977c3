"""The ``windnav`` command.

Each subcommand lives in its own module under ``windnav.commands`` exposing
``register(subparsers)``; modules are imported only when listed here, so a
missing optional dependency of one command never breaks the others.
"""

from __future__ import annotations

import argparse
import importlib
import sys

# name of the module in windnav.commands, in the order shown by --help
COMMAND_MODULES = (
    "fly",
    "power_curve",
    "wind",
    "wind_sweep",
    "flow_validate",
    "ukf_montecarlo",
    "calibrate",
    "demo",
)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="windnav",
        description="Real-time local wind inference and wind-aware navigation for multirotors.",
    )
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for name in COMMAND_MODULES:
        try:
            module = importlib.import_module(f"windnav.commands.{name}")
        except ModuleNotFoundError as exc:
            if exc.name == f"windnav.commands.{name}":
                continue  # command not written yet
            raise
        module.register(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except ValueError as exc:
        print(f"windnav {args.command}: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
