"""Options across the commands (CLI audit, thirty-seventh session)."""

from __future__ import annotations

import argparse
import json

import pytest

from windnav import cli
from windnav.commands.nav_study import study_suite


def _args(store=None, suite=None):
    return argparse.Namespace(store=store, suite=suite)


def test_nav_study_takes_the_suite_and_seed_of_its_store(tmp_path):
    """nav-study always studied the thesis suite with seed 0 (its --seed is the gs study's): a
    store flown with ``benchmark-nav --seed 5`` or another suite was refused as holding
    another suite, with no option to name it."""
    store = tmp_path / "store"
    store.mkdir()
    (store / "manifest.json").write_text(json.dumps({"suite": "quick", "seed": 5}))
    spec = study_suite(_args(store))
    assert (spec.name, spec.seed) == ("quick", 5)
    spec = study_suite(_args(store, suite="quick"))  # the store's suite: its seed
    assert (spec.name, spec.seed) == ("quick", 5)
    spec = study_suite(_args(store, suite="thesis"))  # another suite: seed 0
    assert (spec.name, spec.seed) == ("thesis", 0)
    spec = study_suite(_args(tmp_path / "new"))  # no store yet: the thesis suite
    assert (spec.name, spec.seed) == ("thesis", 0)


@pytest.mark.parametrize("argv, option", [
    (["nav-study", "pace", "--store", "S", "--executor", "ray"], "--executor"),
    (["nav-study", "gs", "--suite", "quick"], "--suite"),
])
def test_nav_study_refuses_options_its_study_ignores(argv, option, tmp_path, capsys):
    """``pace --executor ray`` and ``gs --suite quick`` ran, the option ignored."""
    argv = [a.replace("S", str(tmp_path / "store")) if a == "S" else a for a in argv]
    assert cli.main([*argv, "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert f"'{option}' parameter of windnav nav-study is for the" in err
    assert not (tmp_path / "out").exists()


def test_a_path_given_to_a_study_that_reads_none_is_written_as_typed(tmp_path, capsys):
    """"Got PosixPath('...') for 'inflight' instead" (CLI audit, 2026-12-07)."""
    assert cli.main(["nav-study", "inflight", "--store", str(tmp_path / "s"), "--out",
                     str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert f"Got {str(tmp_path / 's')!r} for 'inflight' instead." in err, err


@pytest.mark.parametrize("argv, option", [
    (["nav-study", "cases", "--store", "S", "--variant", "foo"], "--variant"),
    (["nav-study", "pace", "--store", "S", "--variant", "foo"], "--variant"),
    (["nav-study", "inflight", "--variant", "foo"], "--variant"),
    (["nav-study", "gusts", "--base", "foo"], "--base"),
])
def test_nav_study_names_the_option_of_an_unknown_variant(argv, option, tmp_path, capsys):
    """An unknown variant named the 'variants' parameter of check_variants, inflight_study or
    gust_routes, none of them an option (CLI audit, 2026-12-07)."""
    store = tmp_path / "store"
    store.mkdir()
    (store / "manifest.json").write_text(json.dumps({"suite": "quick", "seed": 0}))
    argv = [str(store) if a == "S" else a for a in argv]
    assert cli.main([*argv, "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert f"'{option}' parameter of windnav nav-study must be distinct names among" in err, err
    assert "'variants' parameter" not in err
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("argv, option", [
    # each ran to status 0: an invalid width, a horizon the graph search never reads, a Wind
    # UKF estimate for a table that holds its own wind
    (["similitude", "--full-scale-speed", "10", "--obstacle-width", "-1"], "--obstacle-width"),
    (["sysid", "similitude", "--full-scale-speed", "10", "--obstacle-width", "nan"],
     "--obstacle-width"),
    (["navigate", "--map", "M", "--start", "10", "10", "--goal", "50", "50", "--variant", "gs",
      "--horizon", "5", "--speed", "3", "--out", "O"], "--horizon"),
    (["sysid", "unsteadiness", "--csv", "C", "--wind", "ukf", "--out", "O"], "--wind"),
    (["sysid", "unsteadiness", "--csv", "C", "--vehicle", "hummingbird", "--out", "O"],
     "--vehicle"),
    # options a mode ignores: --workers without the studies or with the serial backend, a seed
    # without scan noise, a settling time without a flight log
    (["flow-validate", "--workers", "3", "--out", "O"], "--workers"),
    (["ukf-montecarlo", "--backend", "serial", "--workers", "4", "--trials", "1", "--json",
      "O"], "--workers"),
    (["predict", "--map", "M", "--at", "20", "20", "--speed", "3", "--direction-deg", "0",
      "--seed", "7", "--out", "O"], "--seed"),
    (["wind-sweep", "--maps", "M", "--speeds", "3", "--backend", "serial", "--workers", "2",
      "--out", "O"], "--workers"),
    (["sysid", "aero", "--csv", "C", "--settle-s", "5", "--out", "O"], "--settle-s"),
    # a generator for no generated maps, and flying options for a table that flies nothing
    # (left by the options audit; refused in the thirty-eighth session)
    (["wind-sweep", "--maps", "M", "--speeds", "3", "--map-kind", "dense", "--out", "O"],
     "--map-kind"),
    (["benchmark-nav", "--table", "--workers", "2", "--out", "O"], "--workers"),
    (["benchmark-nav", "--table", "--executor", "serial", "--out", "O"], "--executor"),
    (["benchmark-nav", "--table", "--wind-batch", "1", "--out", "O"], "--wind-batch"),
    (["benchmark-nav", "--table", "--native-arithmetic", "--out", "O"], "--native-arithmetic"),
    (["benchmark-nav", "--table", "--portable", "--out", "O"], "--portable"),
    # a direction of 1e308 deg flew some direction and recorded 1e308 (options audit)
    (["wind", "--map", "M", "--speed", "3", "--direction-deg", "1e308", "--out", "O"],
     "--direction-deg"),
    (["navigate", "--map", "M", "--start", "10", "10", "--goal", "50", "50", "--speed", "3",
      "--direction-deg", "-400", "--out", "O"], "--direction-deg"),
    (["predict", "--map", "M", "--at", "20", "20", "--speed", "3", "--direction-deg", "1e6",
      "--out", "O"], "--direction-deg"),
    (["wind-sweep", "--maps", "M", "--speeds", "3", "--directions-deg", "0", "720", "--out",
      "O"], "--directions-deg"),
    (["wind-sweep", "--maps", "M", "--speeds", "3", "--directions", "0", "1e308", "--out",
      "O"], "--directions"),
    (["demo", "--story", "navigate", "--direction-deg", "361", "--out", "O"],
     "--direction-deg"),
    (["decoder-study", "averaging", "--direction-deg", "1e308", "--out", "O"],
     "--direction-deg"),
    # winds past Mach 0.3: the flight diverged and the command exited 0 (options audit)
    (["fly", "--wind-mean", "1e5", "0", "0", "--out", "O"], "--wind-mean"),
    (["fly", "--wind-sigma", "150", "1", "1", "--out", "O"], "--wind-sigma"),
    # errors that named a library parameter or another option (options audit)
    (["similitude", "--model-speed", "1e308"], "--model-speed"),
    (["demo", "--wind-speed", "500", "--out", "O"], "--wind-speed"),
    (["sysid", "simulate-stand", "--kv", "-1", "--out", "O"], "--kv"),
    # within half a cell of the map's edge the mean field read 0 m/s in a 5 m/s flow (audit)
    (["predict", "--map", "M", "--at", "0.2", "20", "--speed", "3", "--direction-deg", "0",
      "--out", "O"], "--at"),
    # the same inlet twice was simulated twice into a training store (failure audit)
    (["wind-sweep", "--maps", "M", "--speeds", "5", "5", "--out", "O"], "--speeds"),
    (["wind-sweep", "--maps", "M", "--speeds", "5", "--directions-deg", "0", "360", "--out",
      "O"], "--directions-deg"),
])
def test_options_that_a_run_would_ignore_or_that_are_invalid_are_refused(argv, option,
                                                                          tmp_path, capsys):
    """Each ran, the option ignored or invalid (CLI audit, thirty-seventh session): now refused
    by name before any work."""
    city = tmp_path / "city.json"
    city.write_text(json.dumps({"bounds": {"extents": [0, 100, 0, 100, 0, 50]},
                                "blocks": [{"extents": [40, 60, 40, 60, 0, 20]}]}))
    table = tmp_path / "samples.csv"  # never read: each option is refused first
    table.write_text("time_s\n0\n")
    argv = [{"M": str(city), "C": str(table), "O": str(tmp_path / "out")}.get(a, a)
            for a in argv]
    assert cli.main(argv) == 2
    err = capsys.readouterr().err
    assert f"'{option}' parameter of windnav" in err, err
    assert not (tmp_path / "out").exists()
