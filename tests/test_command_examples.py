"""The command lines quoted in the docstrings of ``windnav.commands`` parse.

A docstring example that the parser refuses (``evaluate-decoder`` without its required
``--out``, found by an audit of the examples on 2026-12-05) misleads whoever copies it.
"""

from __future__ import annotations

import importlib
import pkgutil
import shlex

import pytest

import windnav.commands
from windnav.cli import build_parser


def _examples():
    """``(module, command line)`` for every ``windnav ...`` line of a command module's
    docstring, with backslash continuations joined and ``#`` comments dropped."""
    out = []
    for info in pkgutil.iter_modules(windnav.commands.__path__):
        if info.name.startswith("_"):
            continue
        module = importlib.import_module(f"windnav.commands.{info.name}")
        lines = (module.__doc__ or "").splitlines()
        k = 0
        while k < len(lines):
            line = lines[k].strip()
            while line.endswith("\\") and k + 1 < len(lines):
                k += 1
                line = line[:-1] + " " + lines[k].strip()
            if line.startswith("windnav ") and not line.startswith("windnav.") and (
                    "--" in line or len(line.split()) > 1):
                out.append((info.name, line.split(" #")[0].strip()))
            k += 1
    return out


EXAMPLES = _examples()


def test_the_command_docstrings_hold_examples():
    assert len(EXAMPLES) >= 40
    assert {m for m, _ in EXAMPLES} >= {"fly", "navigate", "evaluate_decoder", "sysid", "wind"}


@pytest.mark.parametrize(("module", "line"), EXAMPLES,
                         ids=[f"{m}:{i}" for i, (m, _) in enumerate(EXAMPLES)])
def test_each_docstring_command_line_parses(module, line, capsys):
    words = shlex.split(line)[1:]
    if any(w in ("...", "…") or w.endswith("...") for w in words):
        pytest.skip("an elided command line")
    try:
        build_parser().parse_args(words)
    except SystemExit as exc:  # argparse's refusal
        pytest.fail(f"{module}: {line!r} does not parse: {capsys.readouterr().err.strip()}"
                    f" (exit {exc.code})")
