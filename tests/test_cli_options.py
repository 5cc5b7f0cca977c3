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
