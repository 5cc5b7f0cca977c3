"""The command lines quoted in the docstrings of ``windnav.commands`` parse.

A docstring example that the parser refuses (``evaluate-decoder`` without its required
``--out``, found by an audit of the examples on 2026-12-05) misleads whoever copies it.
"""

from __future__ import annotations

import importlib
import pkgutil
import re
import shlex
from pathlib import Path

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


ROOT = Path(__file__).resolve().parents[1]


def _doc_examples():
    """``(file:line, command line)`` for every ``windnav ...`` command of the fenced code blocks
    of README.md and docs/*.md: continuations joined, comments dropped, split at ``&&``, ``;``
    and ``|``, leading variable assignments and ``time`` dropped; lines with a shell variable
    left out (their values are in other lines)."""
    out = []
    for path in [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]:
        lines = path.read_text(encoding="utf-8").splitlines()
        fenced = False
        k = 0
        while k < len(lines):
            first = k
            line = lines[k]
            if line.lstrip().startswith("```"):
                fenced = not fenced
                k += 1
                continue
            while fenced and line.rstrip().endswith("\\") and k + 1 < len(lines):
                k += 1
                line = line.rstrip()[:-1] + " " + lines[k].strip()
            k += 1
            if not fenced or "$" in line:
                continue
            for part in re.split(r"&&|;|\|", line.split(" #")[0]):
                words = part.split()
                while words and (re.fullmatch(r"[A-Za-z_]+=\S*", words[0])
                                 or words[0] in ("time", "/usr/bin/time", "-v")):
                    words = words[1:]
                if words and words[0] == "windnav" and len(words) > 1:
                    out.append((f"{path.relative_to(ROOT)}:{first + 1}", " ".join(words)))
    return out


DOC_EXAMPLES = _doc_examples()


def test_the_docs_hold_command_examples():
    assert len(DOC_EXAMPLES) >= 100


@pytest.mark.parametrize(("where", "line"), DOC_EXAMPLES, ids=[w for w, _ in DOC_EXAMPLES])
def test_each_documented_command_line_parses(where, line, capsys):
    """Six command lines of the docs' prose lacked a required ``--out`` (an audit, 2026-12-06);
    the fenced blocks, the ones to copy, are held to parse here."""
    words = shlex.split(line, comments=True)[1:]
    if any(w in ("...", "…") or w.endswith("...") for w in words):
        pytest.skip("an elided command line")
    try:
        build_parser().parse_args(words)
    except SystemExit as exc:
        pytest.fail(f"{where}: {line!r} does not parse: {capsys.readouterr().err.strip()}"
                    f" (exit {exc.code})")


def test_the_parsers_choices_are_their_sources():
    """The parser takes its choices from ``windnav.commands._choices`` so that ``windnav
    --help`` does not import the packages behind them (0.8 s of CPU before, 0.2 s after);
    each must stay what its source says."""
    from windnav.commands import _choices
    from windnav.commands.navigate import energy_aware_variants
    from windnav.estimate.conditions import CONDITIONS
    from windnav.experiments.flight import WIND_KINDS
    from windnav.plan import ENERGY_MODES, VARIANTS
    from windnav.sim.trajectories import TRAJECTORIES
    from windnav.sysid.io import LAYOUTS
    from windnav.vehicle.params import VEHICLES

    assert _choices.CONDITION_NAMES == tuple(CONDITIONS)
    assert _choices.TABLE_LAYOUTS == tuple(sorted(LAYOUTS))
    assert _choices.WIND_KINDS == tuple(WIND_KINDS)
    assert _choices.TRAJECTORIES == tuple(TRAJECTORIES)
    assert _choices.VEHICLES == tuple(VEHICLES)
    assert _choices.ENERGY_MODES == tuple(ENERGY_MODES)
    assert _choices.NAV_VARIANTS == tuple(VARIANTS)
    assert _choices.UNAWARE_VARIANTS == tuple(k for k in VARIANTS
                                              if k not in energy_aware_variants())


def test_building_the_parser_imports_no_solver_or_model(tmp_path):
    """``windnav --help`` imported the Wind UKF's conditions, the vehicle models, the flow
    solver (a demo default built at import) and SciPy's statistics to list choices."""
    import subprocess
    import sys

    code = ("import sys\nfrom windnav.cli import build_parser\nbuild_parser()\n"
            "heavy = [m for m in ('numba', 'scipy', 'windnav.flow', 'windnav.estimate', "
            "'windnav.vehicle', 'windnav.plan', 'windnav.sysid', 'torch') if m in sys.modules]\n"
            "print(heavy)\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         cwd=tmp_path, check=True).stdout.strip()
    assert out == "[]"
