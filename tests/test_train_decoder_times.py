"""``windnav train-decoder``'s recorded times: the whole cost of a run over the invocations that
made it (interrupted and resumed ones included), each invocation's own seconds kept beside, on
the tiny recipe with a fake clock."""

from __future__ import annotations

import argparse
import json
from types import SimpleNamespace

import pytest

pytest.importorskip("torch")

import windnav.experiments.wind_sweep as wind_sweep  # noqa: E402
import windnav.predict.train as train  # noqa: E402
from windnav.commands import train_decoder as command  # noqa: E402
from windnav.predict.train import RECIPES, load_recipe, recipe_maps  # noqa: E402


@pytest.fixture(scope="module")
def store(tmp_path_factory):
    """The tiny recipe's sweep store (serial), finished."""
    sw = load_recipe(RECIPES / "tiny.toml")["sweep"]
    path = tmp_path_factory.mktemp("tiny") / "sweep.zarr"
    _, results = wind_sweep.sweep(recipe_maps(load_recipe(RECIPES / "tiny.toml")), path,
                                  speeds=sw["speeds"], directions_deg=sw["directions_deg"],
                                  settings=sw["settings"], backend="serial", seed=sw["seed"],
                                  progress=False)
    assert all(r.ok for r in results)
    return path


def test_times_add_up_over_interrupted_and_resumed_invocations(store, tmp_path, monkeypatch,
                                                               capsys):
    """Audit: after a resume, ``sweep_seconds`` and ``train_seconds`` counted only the last
    invocation, so an interrupted run reported a fraction of its cost. Each invocation here
    spends a known time on a fake clock: the totals are the sums over the invocations (a rerun
    of the finished run adding only its own), and ``--overwrite`` starts the training's count
    over while the kept sweep's stays."""
    out = tmp_path / "run"
    out.mkdir()
    (out / "sweep.zarr").symlink_to(store)
    now = [0.0]
    monkeypatch.setattr(command, "time", SimpleNamespace(perf_counter=lambda: now[0]))
    real_sweep, real_train = wind_sweep.sweep, train.train_decoder
    parser = argparse.ArgumentParser()
    command.register(parser.add_subparsers(dest="command"))

    def spending(real, seconds, stop_at=None):
        """``real``, taking ``seconds`` on the fake clock, interrupted before it starts
        (``stop_at`` 0) or after epoch ``stop_at``."""
        def call(*a, **k):
            now[0] += seconds
            if stop_at == 0:
                raise KeyboardInterrupt

            def stop(epoch, record):
                if epoch == stop_at:
                    raise KeyboardInterrupt
            return real(*a, **k, **({} if stop_at is None else {"callback": stop}))
        return call

    def invoke(i, sweep_s, train_s, *more, stop_sweep=False, stop_epoch=None):
        monkeypatch.setattr(wind_sweep, "sweep",
                            spending(real_sweep, sweep_s, 0 if stop_sweep else None))
        monkeypatch.setattr(train, "train_decoder", spending(real_train, train_s, stop_epoch))
        args = parser.parse_args(["train-decoder", "--config", str(RECIPES / "tiny.toml"),
                                  "--out", str(out), "--no-progress", "--backend", "serial",
                                  "--json", str(tmp_path / f"run{i}.json"), *more])
        return args.func(args)

    def ledger():
        return json.loads((out / command.TIMES).read_text())

    assert invoke(1, 50, 0, stop_sweep=True) == 130
    assert invoke(2, 100, 1000, stop_epoch=2) == 130
    assert (ledger()["sweep_seconds"], ledger()["train_seconds"]) == (150, 1000)
    capsys.readouterr()
    assert invoke(3, 10, 500) == 0
    assert "run time with the earlier invocations" in capsys.readouterr().out
    doc = json.loads((tmp_path / "run3.json").read_text())
    assert (doc["sweep_seconds"], doc["train_seconds"]) == (160, 1500)
    assert (doc["sweep_seconds_this_run"], doc["train_seconds_this_run"]) == (10, 500)
    assert [(i["sweep_seconds"], i["train_seconds"], i["ended"]) for i in doc["invocations"]] \
        == [(50, 0, "interrupted during the sweep"), (100, 1000, "interrupted during the training"),
            (10, 500, "finished")]
    assert doc["invocations"] == ledger()["invocations"]
    # the resumed history holds the epochs of both invocations that trained
    assert len(doc["history"]["epochs"]) == load_recipe(RECIPES / "tiny.toml")["train"]["epochs"]

    assert invoke(4, 1, 2) == 0  # the finished run again: it adds its own seconds only
    doc = json.loads((tmp_path / "run4.json").read_text())
    assert (doc["sweep_seconds"], doc["train_seconds"]) == (161, 1502)
    assert (doc["sweep_seconds_this_run"], doc["train_seconds_this_run"]) == (1, 2)

    assert invoke(5, 3, 700, "--overwrite", stop_epoch=1) == 130  # the training starts over
    assert (ledger()["sweep_seconds"], ledger()["train_seconds"]) == (164, 700)
    assert len(ledger()["invocations"]) == 5 and ledger()["invocations"][-1]["new_training"]
