"""Append a benchmark's figures to docs/benchmarks.md with the command and the date."""

from __future__ import annotations

import datetime as _dt
import functools
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


COMMITTED_STORE = DOC.parent / "navigation"
"""The committed navigation store: ``thesis_manifest.json`` and ``thesis_records.jsonl.gz``."""


def committed_record(scenario_id: str, variant: str) -> tuple[dict | None, dict]:
    """The committed store's latest record of ``scenario_id`` flown by ``variant`` (None when
    there is none) and the store's manifest."""
    return _committed(variant).get(scenario_id), _committed_manifest()


@functools.cache
def _committed(variant: str) -> dict:
    """``scenario_id -> latest record`` of ``variant`` in the committed store (read once)."""
    import gzip
    import json

    out = {}
    with gzip.open(COMMITTED_STORE / "thesis_records.jsonl.gz", "rt") as fh:
        for line in fh:
            if variant in line:
                rec = json.loads(line)
                if rec["variant"] == variant:
                    out[rec["scenario_id"]] = rec
    return out


@functools.cache
def _committed_manifest() -> dict:
    import json

    return json.loads((COMMITTED_STORE / "thesis_manifest.json").read_text())


def under_record_arithmetic(scenario_id: str, variant: str) -> dict | None:
    """Run this benchmark again, in a new process, under the arithmetic the committed record
    of ``scenario_id`` and ``variant`` was flown under, when this machine computes otherwise
    and can run it (or the nearest it can, as ``windnav benchmark-nav --replay`` does): a
    flight replays only under its own arithmetic (``docs/navigation.md``, "Replays across
    CPUs"), and under another one a benchmark's flight can be another flight (the onboard
    benchmarks' default timed out at 100 s on an AMD EPYC's own arithmetic instead of
    arriving at 37 s).

    Returns the record (None when the store has none) after a note on stderr of which
    arithmetic this process computes with; exits with the new process's status when it
    restarted.
    """
    import os
    import subprocess

    from windnav.experiments.arithmetic import PIN_VARIABLE, arithmetic, pinned_environment
    from windnav.experiments.nav_records import record_arithmetic

    record, manifest = committed_record(scenario_id, variant)
    if record is None:
        print(f"note: the committed store has no {variant} record of {scenario_id}: flying "
              "under this machine's arithmetic, with nothing to compare", file=sys.stderr)
        return None
    wanted = record_arithmetic(record, manifest)
    if PIN_VARIABLE not in os.environ:
        env, line = pinned_environment(wanted, nearest=True)
        if env:
            print(f"note: flying under the record's arithmetic ({line}): restarting with "
                  + " ".join(f"{k}={v!r}" for k, v in env.items()), file=sys.stderr, flush=True)
            proc = subprocess.run([sys.executable, *sys.argv],
                                  env={**os.environ, **env, PIN_VARIABLE: "1"}, check=False)
            raise SystemExit(proc.returncode)
        if env is None:
            print(f"note: {line}; flying under this machine's own arithmetic: the flight may "
                  "differ from its record", file=sys.stderr)
    print(f"arithmetic: {arithmetic()} (the record's: {wanted})", file=sys.stderr)
    return record


def matches_record(flown: dict, record: dict | None) -> str:
    """A line saying whether a flight ``flown`` is its committed ``record``'s (the outcome,
    and the time and energy to 1e-6 relative)."""
    if record is None:
        return "no committed record to compare with"
    same = (flown["outcome"] == record["outcome"]
            and all(abs(flown[k] - record[k]) <= 1e-6 * max(abs(record[k]), 1e-12)
                    for k in ("time_s", "energy_J")))
    return (f"the flight {'matches' if same else 'DIFFERS FROM'} its committed record "
            f"({flown['outcome']} at {flown['time_s']:.2f} s, {flown['energy_J']:.1f} J; "
            f"recorded {record['outcome']} at {record['time_s']:.2f} s, "
            f"{record['energy_J']:.1f} J)")
