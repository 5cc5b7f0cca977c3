"""``windnav benchmark-nav --reference`` when flying (leftovers, 2026-12-05).

A run never checked ``--reference``: ``--reference bogus`` (or a variant neither flown nor in
the store) flew every flight, then printed the table without its paired columns and exited 0;
with ``--check`` or ``--replay`` it was ignored. The stand-ins are those of
``test_nav_benchmark`` (no wind, no physics).
"""

from __future__ import annotations

import json

import pytest
from test_nav_benchmark import TINY, command, fake_flows, fake_fly

import windnav.experiments.nav_benchmark as nb
from windnav import cli
from windnav.experiments.nav_suite import SUITES


@pytest.fixture
def flights(monkeypatch):
    """The ``quick`` suite made tiny and stand-in flights; the list of the flights flown."""
    flown = []

    def counted(*a, **kw):
        flown.append(a[2])
        return fake_fly(*a, **kw)

    monkeypatch.setattr(nb, "suite_flows", fake_flows)
    monkeypatch.setitem(SUITES, "quick", TINY.__class__(**{**TINY.__dict__, "name": "quick"}))
    monkeypatch.setattr(nb, "fly_scenario", counted)
    return flown


FLY = ["--suite", "quick", "--executor", "serial", "--no-progress"]


def test_a_run_refuses_a_reference_it_does_not_fly_before_any_flight(tmp_path, flights,
                                                                     capsys):
    store = tmp_path / "store"
    for ref in ("bogus", "ea-mppi"):  # a typo; a variant not flown, in no store
        with pytest.raises(ValueError, match=r"'--reference' parameter of windnav benchmark-nav "
                                             r"must be a variant of the table: one of "
                                             r"--variants \['mppi', 'ea-mppi-w'\] or a variant "
                                             rf"the store already holds \[\]. Got '{ref}'"):
            command([*FLY, "--variants", "mppi,ea-mppi-w", "--reference", ref, "--out", store])
    assert flights == [] and not (store / "records.jsonl").exists()
    # on the command line: one line, exit 2, as the other refusals
    assert cli.main(["benchmark-nav", *FLY, "--reference", "bogus", "--out", str(store)]) == 2
    err = capsys.readouterr().err
    assert "'--reference' parameter" in err and "Traceback" not in err and flights == []


def test_the_default_reference_and_one_the_store_holds_still_fly(tmp_path, flights, capsys):
    store = tmp_path / "store"
    # the defaults: the four variants, paired with mppi; the table names mppi, the JSON's
    # arguments the line as typed (None), which rebuilds to them (windnav.provenance)
    from windnav.provenance import command_arguments

    assert command([*FLY, "--out", store, "--json", tmp_path / "run.json"]) == 0
    doc = json.loads((tmp_path / "run.json").read_text())
    assert doc["arguments"]["reference"] is None and doc["table"]["reference"] == "mppi"
    assert (doc["arguments"]["executor"], doc["arguments"]["wind_batch"]) == ("serial", None)
    assert "--reference" not in command_arguments(doc)
    assert "vs_reference" in doc["table"]["rows"]["ea-mppi-w"] and len(flights) == 16
    # a reference this run does not fly but the store holds: paired with the store's flights
    assert command([*FLY, "--variants", "gs", "--reference", "ea-mppi", "--out", store,
                    "--json", tmp_path / "gs.json"]) == 0
    table = json.loads((tmp_path / "gs.json").read_text())["table"]
    assert table["variants"] == ["ea-mppi", "gs"] and "vs_reference" in table["rows"]["gs"]
    # only the store's flights of --scenarios count
    fresh = tmp_path / "fresh"
    assert command([*FLY, "--variants", "mppi", "--out", fresh,
                    "--scenarios", "quick/m00/w00/p0"]) == 0
    with pytest.raises(ValueError, match=r"already holds \[\]. Got 'mppi'"):
        command([*FLY, "--variants", "gs", "--reference", "mppi", "--out", fresh,
                 "--scenarios", "quick/m00/w01/p0"])
    # the default reference is not refused: other variants into a new store tabulate alone
    # (docs/navigation.md: --variants gs-w into runs/gsw)
    assert command([*FLY, "--variants", "gs", "--out", tmp_path / "gs_only"]) == 0
    assert "| gs |" in capsys.readouterr().out


def test_check_and_replay_refuse_a_reference_they_would_ignore(tmp_path, flights):
    store = tmp_path / "store"
    assert command([*FLY, "--variants", "mppi", "--out", store]) == 0
    for argv, mode in ((["--check", "1"], "--check"),
                       (["--replay", "quick/m00/w00/p0", "--variant", "mppi"], "--replay")):
        with pytest.raises(ValueError, match=r"'--reference' parameter of windnav benchmark-nav "
                                             rf"applies only with --table or when flying a "
                                             rf"suite. Got it with {mode} instead"):
            command(["--out", store, *argv, "--reference", "mppi"])
    # the table keeps its own check
    with pytest.raises(ValueError, match="must be a variant the store holds: \\['mppi'\\]"):
        command(["--out", store, "--table", "--reference", "gs"])
    assert command(["--out", store, "--table", "--reference", "mppi"]) == 0
