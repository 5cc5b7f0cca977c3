"""Optional dependencies: a command that needs one says so before its work, naming the extra
that installs it, and the shipped decoder recipes are found by name (packaging audit)."""

from __future__ import annotations

import sys

import pytest

from windnav._extras import TORCH_CPU, install_hint, require
from windnav.cli import main
from windnav.predict.train import RECIPES, load_recipe, recipe_path


def test_hints_name_the_extra_and_torch_s_cpu_build():
    assert "pip install 'windnav[tune]'" in install_hint("optuna")
    assert "pip install 'windnav[ray]'" in install_hint("ray.util")
    torch = install_hint("torch")
    assert "'windnav[train]'" in torch and TORCH_CPU in torch
    assert install_hint("somethingelse") == "install it with pip (pip install somethingelse)"


def without(monkeypatch, module):
    """``module`` not installed, as far as windnav's checks go (a None in sys.modules for torch
    breaks SciPy's array API helpers, which look torch up there)."""
    import windnav._extras as extras

    real = extras.installed
    monkeypatch.setattr(extras, "installed", lambda m: m != module and real(m))


def test_require_finds_without_importing(monkeypatch):
    require("numpy", "this test")
    without(monkeypatch, "torch")
    with pytest.raises(ModuleNotFoundError, match=r"^windnav x needs the optional dependency "
                       r"'torch': install it with pip install 'windnav\[train\]'") as info:
        require("torch", "windnav x")
    assert info.value.name == "torch"


def test_train_decoder_without_torch_stops_before_its_sweep(tmp_path, monkeypatch, capsys):
    """It ran the recipe's whole flow sweep (414 simulations for the default recipe, up to an
    hour) and only then failed on the import."""
    without(monkeypatch, "torch")
    out = tmp_path / "run"
    assert main(["train-decoder", "--config", "tiny", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "needs the optional dependency 'torch'" in err and "'windnav[train]'" in err
    assert not out.exists()


@pytest.mark.parametrize("study", ["winds", "size", "scaling"])
def test_training_studies_without_torch_stop_before_their_sweep(study, tmp_path, monkeypatch,
                                                                 capsys):
    without(monkeypatch, "torch")
    runs = tmp_path / "runs"
    assert main(["decoder-study", study, "--quick", "--out", str(tmp_path / "out"),
                 "--runs", str(runs)]) == 2
    assert "'windnav[train]'" in capsys.readouterr().err
    assert not runs.exists()


def test_a_rotorpy_monte_carlo_without_rotorpy_fails_once(monkeypatch):
    """Each trial failed on the import and said so, 50 lines for the default 50 trials."""
    from windnav.experiments.ukf_montecarlo import MonteCarloConfig, run_montecarlo

    monkeypatch.setitem(sys.modules, "rotorpy", None)
    with pytest.raises(ModuleNotFoundError, match="'thesis' conditions' gusts .*rotorpy"):
        run_montecarlo(MonteCarloConfig(n_trials=3, conditions="thesis"), backend="serial",
                       progress=False)


def test_shipped_recipes_are_found_by_name_from_anywhere(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert recipe_path("default") == recipe_path("default.toml") == RECIPES / "default.toml"
    assert load_recipe("tiny")["source"] == str(RECIPES / "tiny.toml")
    (tmp_path / "tiny").mkdir()  # a path that exists is the path (a folder: refused)
    with pytest.raises(ValueError, match="Got 'tiny' instead, a folder"):
        load_recipe("tiny")
    with pytest.raises(ValueError, match=r"or a shipped recipe \(default, .*tiny"):
        load_recipe("nope")
