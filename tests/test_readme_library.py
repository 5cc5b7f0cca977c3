"""README.md's "## The library" tour runs as written.

The ```python blocks of that section are executed in order, in one namespace, in a temporary
working directory (the tour writes ``flight.npz`` and ``world.json`` there), so a renamed
function, a changed signature or a wrong shape in a comment's promise fails here instead of in
a user's first session. Tracebacks point at README.md's own line numbers.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

import windnav as wn
from windnav.experiments.navigate import OUTCOMES

README = Path(__file__).resolve().parents[1] / "README.md"
SECTION = "## The library"


def section_blocks(text: str, heading: str = SECTION) -> list[tuple[int, str]]:
    """``(first line number, code)`` of each ```python block under ``heading``, up to the next
    ``## `` heading; line numbers are 1-based, of the block's first code line."""
    lines = text.splitlines()
    starts = [i for i, line in enumerate(lines) if line.strip() == heading]
    if len(starts) != 1:
        raise AssertionError(f"README.md must have one {heading!r} heading; found {len(starts)}")
    blocks, code, first = [], None, 0
    for i in range(starts[0] + 1, len(lines)):
        line = lines[i]
        if code is None and line.startswith("## "):
            break
        if code is None and re.fullmatch(r"```python\s*", line):
            code, first = [], i + 2
        elif code is not None and line.strip() == "```":
            blocks.append((first, "\n".join(code) + "\n"))
            code = None
        elif code is not None:
            code.append(line)
    if code is not None:
        raise AssertionError(f"README.md's {heading!r} section has an unclosed ```python block")
    return blocks


def test_section_blocks_parses_only_that_section():
    text = ("## Before\n```python\nx = 0\n```\n## The library\ntext\n```python\na = 1\n"
            "```\n```bash\nls\n```\n```python\nb = a + 1\n```\n## After\n```python\nc = 2\n```\n")
    assert section_blocks(text) == [(8, "a = 1\n"), (14, "b = a + 1\n")]


def run_tour(blocks) -> dict:
    """Execute ``blocks`` in order in one namespace (in the current working directory)."""
    namespace = {"__name__": "readme_library"}
    for first, code in blocks:
        # pad so that the compiled line numbers are README.md's
        exec(compile("\n" * (first - 1) + code, str(README), "exec"), namespace)
    return namespace


@pytest.mark.slow
def test_readme_library_tour_runs(tmp_path, monkeypatch):
    blocks = section_blocks(README.read_text(encoding="utf-8"))
    assert len(blocks) >= 2, "the tour lost its code blocks"
    monkeypatch.chdir(tmp_path)
    ns = run_tour(blocks)

    # what the tour writes lands in the working directory, and reads back
    assert (tmp_path / "flight.npz").is_file()
    again = wn.city.City.from_rotorpy_json(tmp_path / "world.json")
    np.testing.assert_array_equal(again.footprints, ns["city"].footprints)

    # the shapes and units its comments promise
    b = ns["xy"].shape[0]
    assert ns["scans"].shape == (b, 360)
    # the robot stands in the street: its position was inside a building (every range 0, a
    # field predicted from nothing and a planner update that braked; thread audit)
    assert not ns["city"].contains(ns["xy"]).any() and ns["scans"].min() > 1.0
    assert ns["planner"].stats.fallbacks == 0
    assert ns["uv"].shape == (b, 2, ns["dec"].offsets.size, ns["dec"].offsets.size) == (
        b, 2, 25, 25)
    assert np.all(np.isfinite(ns["uv"]))
    assert ns["r"].outcome in OUTCOMES
    assert ns["route"].energy > 0
    straight = np.hypot(*np.subtract(ns["goal"], ns["start"]))
    assert ns["route"].length >= straight  # no route is shorter than the straight line
    assert ns["planner"].goal.tolist() == list(ns["goal"])
