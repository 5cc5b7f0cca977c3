"""Append a benchmark's figures to docs/benchmarks.md with the command and the date."""

from __future__ import annotations

import datetime as _dt
import os
import platform
import sys
from pathlib import Path

DOC = Path(__file__).resolve().parents[1] / "docs" / "benchmarks.md"


def cpu_model() -> str:
    """The CPU's model name from /proc/cpuinfo (the platform's processor string elsewhere)."""
    try:
        with open("/proc/cpuinfo") as fh:
            for line in fh:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown CPU"


def machine() -> str:
    """One-line description of the machine the figures were taken on.

    The same kind of machine has differed by up to 1.5x in speed from one day to another, so
    compare figures across records by their in-run reference ratios, not their seconds.
    """
    return (f"{platform.machine()}, {cpu_model()}, {os.cpu_count()} cores, "
            f"Python {platform.python_version()}")


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
