"""Append a benchmark's figures to docs/benchmarks.md with the command and the date."""

from __future__ import annotations

import datetime as _dt
import sys
from pathlib import Path

from windnav.experiments import results

DOC = Path(__file__).resolve().parents[1] / "docs" / "benchmarks.md"


def machine() -> str:
    """One-line description of the machine the figures were taken on.

    The same kind of machine has differed by up to 1.5x in speed from one day to another, so
    compare figures across records by their in-run reference ratios, not their seconds.
    """
    m = results.machine()
    return f"{m['platform']}, {m['cpu']}, {m['cores']} cores, Python {m['python']}"


def append_record(title: str, rows: list[str], *, command: str | None = None) -> None:
    """Append a section to ``docs/benchmarks.md``.

    Parameters
    ----------
    title : str
        Section title (what was measured).
    rows : list of str
        Markdown lines (a table or bullet list) with the figures and the reference ratio.
    command : str, optional
        The command that produced the figures; defaults to this process's argv.
    """
    command = command or "python " + " ".join(sys.argv)
    today = _dt.date.today().isoformat()
    DOC.parent.mkdir(parents=True, exist_ok=True)
    new = not DOC.exists()
    with DOC.open("a") as fh:
        if new:
            fh.write("# Benchmarks\n\nFigures appended by the scripts in `benchmarks/`.\n")
        fh.write(f"\n## {title}\n\n- date: {today}\n- command: `{command}`\n")
        fh.write(f"- machine: {machine()}\n\n")
        fh.write("\n".join(rows) + "\n")
