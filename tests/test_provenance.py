"""A result file names the command that reproduces it: ``windnav.provenance.command_line``.

The provenance audit (2026-12-06) found committed results whose documented commands were
fragments (``evaluate-decoder ... --compare NAME=...``, three without ``--out`` that did not
parse) although each JSON records its command and arguments. The line is now rebuilt from the
file, and every committed JSON that records its arguments rebuilds to a line the current
interface parses to the same arguments: a renamed or removed option fails here first.
"""

from __future__ import annotations

import gzip
import json
from pathlib import Path

import pytest

import windnav.cli as cli
from windnav.experiments.results import NOT_ARGUMENTS
from windnav.provenance import command_arguments, command_line

DOCS = Path(__file__).resolve().parents[1] / "docs"


def _documents():
    for path in sorted([*DOCS.rglob("*.json"), *DOCS.rglob("*.json.gz")]):
        opener = gzip.open if path.suffix == ".gz" else open
        with opener(path, "rt") as f:
            doc = json.load(f)
        if (isinstance(doc, dict) and isinstance(doc.get("arguments"), dict)
                and str(doc.get("command", "")).startswith("windnav ")):
            yield path, doc


COMMITTED = list(_documents())


def _parsed(words):
    ns = vars(cli.build_parser().parse_args(words[1:]))
    return json.loads(json.dumps(ns, default=str))


def test_there_are_committed_results_to_rebuild():
    assert len(COMMITTED) >= 90


@pytest.mark.parametrize("path, doc", COMMITTED, ids=[str(p.relative_to(DOCS)) for p, _ in
                                                        COMMITTED])
def test_every_committed_result_rebuilds_to_its_own_arguments(path, doc):
    words = command_arguments(doc)
    assert words[:2] == doc["command"].split()[:2]
    parsed = _parsed(words)
    recorded = {k: v for k, v in doc["arguments"].items() if k not in NOT_ARGUMENTS}
    assert {k: parsed.get(k) for k in recorded} == recorded


def _rerun(words, tmp_path, name):
    words = list(words)
    words[words.index("--out") + 1] = str(tmp_path / name)
    words[words.index("--json") + 1] = str(tmp_path / f"{name}.json")
    assert cli.main(words[1:]) == 0
    return json.loads((tmp_path / f"{name}.json").read_text())


def test_the_line_of_a_result_runs_and_reproduces_it(tmp_path):
    typed = ["fly", "--trajectory", "hover", "--wind", "dryden", "--duration", "1",
             "--no-plots", "--no-progress", "--out", str(tmp_path / "a"), "--json",
             str(tmp_path / "a.json")]
    assert cli.main(typed) == 0
    first = json.loads((tmp_path / "a.json").read_text())
    assert first["argv"] == typed                           # the words as typed
    assert command_arguments(first) == ["windnav", *typed]
    again = _rerun(command_arguments(first), tmp_path, "b")
    old = {k: v for k, v in first.items() if k != "argv"}  # a result from before argv
    line = command_line(old)
    assert line.startswith("windnav fly ") and "--duration 1.0" in line
    assert "--wind " not in line and "--dt" not in line     # the defaults': left out
    rebuilt = _rerun(command_arguments(old), tmp_path, "c")
    numbers = ("energy_J", "rms_tracking_error_m", "max_airspeed_m_s", "mean_power_W")
    for other in (again, rebuilt):
        assert [other[k] for k in numbers] == [first[k] for k in numbers]
        assert {**other["arguments"], "out": None, "json": None} == {
            **first["arguments"], "out": None, "json": None}


def test_a_result_the_interface_can_no_longer_rebuild_is_an_error_naming_why():
    doc = {"command": "windnav fly", "arguments": {"duration": 1.0, "old_option": 3}}
    with pytest.raises(ValueError, match="no longer has: old_option"):
        command_line(doc)
    with pytest.raises(ValueError, match="'command'"):
        command_line({"arguments": {}})
    with pytest.raises(ValueError, match="'arguments'"):
        command_line({"command": "windnav fly"})
    with pytest.raises(ValueError, match="no longer a windnav command"):
        command_line({"command": "windnav teleport", "arguments": {}})
