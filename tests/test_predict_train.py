"""Training the wind flow decoder end to end on the tiny recipe: a real (tiny) flow sweep, a
tiny d4-film that must beat the Local baseline on its training maps and on the held-out map,
the saved model reproducing the metrics measured in memory, resumption from a checkpoint
giving the uninterrupted run's model, and the ``train-decoder`` command."""

from __future__ import annotations

import argparse
import copy
import functools
import importlib.util
import json
import warnings
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("torch")

from windnav.experiments.wind_sweep import sweep  # noqa: E402
from windnav.predict.dataset import DecoderDataset, fields_from_store  # noqa: E402
from windnav.predict.decoder import load_decoder, make_architecture, save_decoder  # noqa: E402
from windnav.predict.metrics import field_errors  # noqa: E402
from windnav.predict.train import (  # noqa: E402
    RECIPES,
    _augment,
    _Batches,
    _ema_update,
    _fingerprint,
    _model_frame_in_place,
    _split_fields,
    _tensor_batch,
    _train_block,
    ema_decay_at,
    load_recipe,
    recipe_maps,
    recipe_toml,
    shipped_recipes,
    train_decoder,
)
from windnav.predict.train import (
    _loss as train_loss,
)

DOCS_DATA = Path(__file__).resolve().parents[1] / "docs" / "data"


class Stop(Exception):
    """Raised by a callback to interrupt a training run."""


def _stopping_after(n: int):
    """A training callback that stops the run (``Stop``) after epoch ``n``."""
    def stop(epoch, record):
        if epoch == n:
            raise Stop
    return stop


def tiny_recipe(**train):
    recipe = load_recipe(RECIPES / "tiny.toml")
    recipe["train"].update({"tensorboard": False, **train})
    return recipe


@pytest.fixture(scope="module")
def tiny(tmp_path_factory):
    """The tiny recipe's sweep (serial) and one uninterrupted training run."""
    recipe = tiny_recipe()
    out = tmp_path_factory.mktemp("tiny")
    sw = recipe["sweep"]
    store, results = sweep(recipe_maps(recipe), out / "sweep.zarr", speeds=sw["speeds"],
                           directions_deg=sw["directions_deg"], settings=sw["settings"],
                           backend="serial", seed=sw["seed"], progress=False)
    assert all(r.ok for r in results)
    history = train_decoder(recipe, store=out / "sweep.zarr", out_dir=out, progress=False,
                            log=None)
    return recipe, out, history


def test_tiny_model_learns_and_beats_the_local_baseline(tiny):
    recipe, out, h = tiny
    losses = [e["train_loss"] for e in h["epochs"]]
    assert len(losses) == recipe["train"]["epochs"] and losses[-1] < 0.8 * losses[0]
    mine, local = h["train_metrics"]["decoder"], h["train_metrics"]["local"]
    assert mine["speed_error"] < 0.9 * local["speed_error"]
    assert mine["direction_error_deg"] < local["direction_error_deg"]
    # and on the held-out map
    assert h["best_val"]["speed_error"] < h["baselines"]["local"]["speed_error"]
    assert h["baselines"]["upstream"]["speed_error"] > h["baselines"]["local"]["speed_error"]
    saved = json.loads((out / "history.json").read_text())
    assert saved["best_epoch"] == h["best_epoch"] and len(saved["epochs"]) == len(losses)


def test_saved_model_reproduces_the_metrics_measured_in_memory(tiny):
    recipe, out, h = tiny
    dec = load_decoder(out / "model.npz")
    assert dec.architecture == "d4-film" and dec.size == recipe["data"]["size"]
    assert dec.metadata["metrics"]["validation"] == h["best_val"]
    assert dec.metadata["recipe"]["train"]["epochs"] == recipe["train"]["epochs"]
    data = recipe["data"]
    fields = fields_from_store(out / "sweep.zarr", maps=[2])  # the held-out map
    val = DecoderDataset(fields, data["validation_samples_per_field"], seed=data["seed"] + 1,
                         size=data["size"]).materialize()
    e = field_errors(dec.predict(val.scans, val.w_up, val.w_robot), val.labels, val.free,
                     val.inlet_speed)
    for k, v in h["best_val"].items():
        assert float(e[k]) == pytest.approx(v, rel=1e-6)


def test_resumed_training_ends_with_the_uninterrupted_model(tiny, tmp_path):
    recipe, out, full = tiny
    tensorboard = importlib.util.find_spec("tensorboard") is not None
    resumed = copy.deepcopy(recipe)
    resumed["train"]["tensorboard"] = True  # not part of the recipe's identity

    def stop_after_two(epoch, record):
        if epoch == 2:
            raise Stop

    with pytest.warns(UserWarning, match="tensorboard") if not tensorboard else _nothing():
        with pytest.raises(Stop):
            train_decoder(resumed, store=out / "sweep.zarr", out_dir=tmp_path, progress=False,
                          log=None, callback=stop_after_two)
    assert len(json.loads((tmp_path / "history.json").read_text())["epochs"]) == 2
    lines = []
    with pytest.warns(UserWarning, match="tensorboard") if not tensorboard else _nothing():
        h = train_decoder(resumed, store=out / "sweep.zarr", out_dir=tmp_path, progress=False,
                          log=lines.append)
    assert "resuming" in lines[0] and "after epoch 2" in lines[0]
    assert (tmp_path / "tensorboard").is_dir() == tensorboard
    assert [e["train_loss"] for e in h["epochs"]] == [e["train_loss"] for e in full["epochs"]]
    a, b = load_decoder(out / "model.npz"), load_decoder(tmp_path / "model.npz")
    for k in a.weights:
        np.testing.assert_array_equal(a.weights[k], b.weights[k])
    # a finished run is not trained again
    again = train_decoder(resumed, store=out / "sweep.zarr", out_dir=tmp_path, progress=False,
                          log=None)
    assert again["epochs"] == h["epochs"]


class _nothing:
    def __enter__(self):
        return self

    def __exit__(self, *exc):
        return False


def test_members_train_from_successive_seeds_and_ship_their_mean(tiny, tmp_path, capsys):
    recipe, out, full = tiny
    ens = copy.deepcopy(recipe)
    ens["train"]["members"] = 2
    lines = []
    h = train_decoder(ens, store=out / "sweep.zarr", out_dir=tmp_path, progress=False,
                      log=lines.append)
    single = load_decoder(out / "model.npz")
    m0, m1 = (load_decoder(tmp_path / f"member{i}" / "model.npz") for i in range(2))
    for k in single.weights:   # member 0 is the recipe's own single model, bit for bit
        np.testing.assert_array_equal(m0.weights[k], single.weights[k])
    assert m1.metadata["recipe"]["train"]["seed"] == recipe["train"]["seed"] + 1
    assert not all(np.array_equal(m0.weights[k], m1.weights[k]) for k in m0.weights)
    dec = load_decoder(tmp_path / "model.npz")
    assert dec.hyperparameters["members"] == 2 and dec.n_parameters == 2 * single.n_parameters
    assert dec.metadata["recipe"]["train"]["members"] == 2
    # the figures recorded are the ensemble's, measured on the same validation samples as the
    # members': its vector error is at most the members' mean (|mean(p) - u| <= mean|p - u|)
    assert dec.metadata["metrics"]["validation"] == h["best_val"]
    members_val = [m["best_val"] for m in h["members"]]
    assert members_val[0] == full["best_val"]
    assert h["best_val"]["vector_error"] <= np.mean([v["vector_error"] for v in members_val])
    assert h["best_val"] not in members_val
    assert "member 2/2" in " ".join(lines) and "ensemble of 2 members" in lines[-1]
    # a finished ensemble is not trained again; another recipe in its folder is refused
    assert train_decoder(ens, store=out / "sweep.zarr", out_dir=tmp_path, progress=False,
                         log=None) == h
    three = copy.deepcopy(ens)
    three["train"]["members"] = 3
    with pytest.raises(ValueError, match="'config' parameter of train_decoder differs"):
        train_decoder(three, store=out / "sweep.zarr", out_dir=tmp_path, progress=False,
                      log=None)
    with pytest.raises(ValueError, match="'config' parameter of train_decoder differs"):
        train_decoder(ens, store=out / "sweep.zarr", out_dir=out, progress=False, log=None)
    # the command on the finished ensemble reports the members' best epochs
    from windnav.commands import train_decoder as command

    (tmp_path / "sweep.zarr").symlink_to(out / "sweep.zarr")
    cfg = tmp_path / "ens.toml"
    cfg.write_text(f'base = "{(RECIPES / "tiny.toml").as_posix()}"\n[train]\nmembers = 2\n')
    parser = argparse.ArgumentParser()
    command.register(parser.add_subparsers(dest="command"))
    args = parser.parse_args(["train-decoder", "--config", str(cfg), "--out", str(tmp_path),
                              "--no-progress", "--backend", "serial"])
    assert args.func(args) == 0
    epochs = ", ".join(f"{m['best_epoch']}/{recipe['train']['epochs']}" for m in h["members"])
    assert f"members' best epochs {epochs}" in capsys.readouterr().out


def test_a_finished_run_is_freed_without_waiting_for_the_cycle_collector(tiny, tmp_path,
                                                                          monkeypatch):
    """The members of an ensemble train one after the other in one process: each run's
    training samples (gigabytes in the default recipe) must be gone when the next starts."""
    import gc
    import weakref

    from windnav.predict import train as tr

    recipe, out, _ = tiny
    runs = []
    init = tr._Run.__init__

    def tracked(self, *args, **kwargs):
        init(self, *args, **kwargs)
        runs.append(weakref.ref(self))

    monkeypatch.setattr(tr._Run, "__init__", tracked)
    gc.disable()
    try:
        train_decoder(recipe, store=out / "sweep.zarr", out_dir=tmp_path, progress=False,
                      log=None)
        assert len(runs) == 1 and runs[0]() is None
    finally:
        gc.enable()


def test_a_resume_on_another_thread_count_says_it_will_not_match(tiny, tmp_path):
    """A run begun on one torch thread and resumed on two was accepted silently, and its
    model matched neither uninterrupted run (thread audit); the recipe keeps train.threads
    out of its identity, so it may still be resumed, with a warning."""
    recipe, out, _ = tiny
    one, two = tiny_recipe(threads=1), tiny_recipe(threads=2)
    with pytest.raises(Stop):
        train_decoder(one, store=out / "sweep.zarr", out_dir=tmp_path, progress=False,
                      log=None, callback=_stopping_after(1))
    with pytest.warns(UserWarning, match=r"resuming on 2 torch thread\(s\) a run begun on 1"):
        train_decoder(two, store=out / "sweep.zarr", out_dir=tmp_path, progress=False,
                      log=None)


def test_another_recipe_does_not_resume_a_checkpoint(tiny):
    recipe, out, _ = tiny
    changed = copy.deepcopy(recipe)
    changed["train"]["learning_rate"] = 1e-2
    with pytest.raises(ValueError, match="'config' parameter of train_decoder differs"):
        train_decoder(changed, store=out / "sweep.zarr", out_dir=out, progress=False, log=None)


def test_excluded_maps_are_left_out_of_training_only(tiny):
    recipe, out, h = tiny
    store = out / "sweep.zarr"
    full, val, n_train, n_val = _split_fields(store, ["holdout-0"], "here")
    part, val2, n_part, _ = _split_fields(store, ["holdout-0"], "here", ["train-1"])
    assert (n_train, n_val, n_part) == (2, 1, 1)
    assert len(part) == len(full) // 2 == h["n_train_fields"] // 2 and len(val2) == len(val)
    # the fields kept are those of train-0, in the same order, bit for bit
    for a, b in zip(part, full[:len(part)], strict=True):
        np.testing.assert_array_equal(a.u, b.u)
    with pytest.raises(ValueError, match="excluded maps of the store"):
        _split_fields(store, ["holdout-0"], "here", ["train-7"])
    # an empty exclusion keeps the fingerprint of recipes written before the option existed
    older = copy.deepcopy(recipe)
    del older["data"]["exclude_maps"]
    assert _fingerprint(older) == _fingerprint(recipe)
    changed = copy.deepcopy(recipe)
    changed["data"]["exclude_maps"] = ["train-1"]
    assert _fingerprint(changed) != _fingerprint(recipe)


def test_map_weights_repeat_a_groups_training_fields(tiny):
    recipe, out, h = tiny
    store = out / "sweep.zarr"
    full, val, n_train, _ = _split_fields(store, ["holdout-0"], "here")
    heavy, val2, n_heavy, _ = _split_fields(store, ["holdout-0"], "here", (), {"train": 3})
    assert n_heavy == n_train == 2 and len(heavy) == 3 * len(full) and len(val2) == len(val)
    # each map's fields, in order, three times over; the held-out map is never repeated
    per_map = len(full) // n_train
    for k in range(n_train):
        block = heavy[3 * per_map * k:3 * per_map * (k + 1)]
        for rep in range(3):
            for a, b in zip(block[rep * per_map:(rep + 1) * per_map],
                            full[per_map * k:per_map * (k + 1)], strict=True):
                np.testing.assert_array_equal(a.u, b.u)
    # each repeat draws its own robot positions
    ds = DecoderDataset(heavy[:per_map + 1], 4, seed=0)
    first, again = ds.samples(np.arange(4)), ds.samples(np.arange(4 * per_map, 4 * per_map + 4))
    assert not np.allclose(first.w_robot, again.w_robot)
    # no weights keep the fingerprints of recipes written before the option existed
    older = copy.deepcopy(recipe)
    del older["data"]["map_weights"]
    assert _fingerprint(older) == _fingerprint(recipe)
    changed = copy.deepcopy(recipe)
    changed["data"]["map_weights"] = {"train": 2}
    assert _fingerprint(changed) != _fingerprint(recipe)


def test_thesis_mlp_trains_without_augmentation_from_the_cached_model_frame(tiny, tmp_path):
    """The model-frame cache (the default) kept a D4 frame ``g`` the thesis MLP's features do
    not have: a KeyError at setup whenever it trained without augmentation (audit,
    2026-12-05)."""
    recipe, out, _ = tiny
    mlp = copy.deepcopy(recipe)
    mlp["model"] = {"architecture": "thesis-mlp", "hyperparameters": {"width": 64, "depth": 2}}
    mlp["train"].update(epochs=1, augment_d4=False, cache=True)
    h = train_decoder(mlp, store=out / "sweep.zarr", out_dir=tmp_path, progress=False,
                      log=None)
    assert len(h["epochs"]) == 1 and np.isfinite(h["epochs"][0]["train_loss"])


def test_thesis_mlp_trains_with_d4_augmentation(tiny, tmp_path):
    recipe, out, _ = tiny
    mlp = copy.deepcopy(recipe)
    mlp["model"] = {"architecture": "thesis-mlp", "hyperparameters": {"width": 64, "depth": 2}}
    mlp["train"].update(epochs=2, optimizer="adam", weight_decay=0.002, loss_speed_power=2.0,
                        augment_d4=True, cache=False)
    h = train_decoder(mlp, store=out / "sweep.zarr", out_dir=tmp_path, progress=False,
                      log=None)
    assert h["epochs"][-1]["train_loss"] < h["epochs"][0]["train_loss"]
    assert h["flush_denormal"] is None
    assert load_decoder(tmp_path / "model.npz").architecture == "thesis-mlp"


# 1e-20 * 1e-20 = 1e-40 is subnormal in float32 unless the thread flushes it to zero; with two
# threads, each computes part of these products.
_FLUSH_PROBE = """
import sys, torch
from windnav.predict.train import flush_denormals
if sys.argv[1] == "late":
    torch.set_num_threads(2)
    torch.ones(1 << 20) * 2.0  # starts the worker threads
ok = flush_denormals()
torch.set_num_threads(2)
a = torch.full((1 << 20,), 1e-20)
m = torch.full((256, 256), 1e-20)
print(ok, int((a * a != 0).sum()), int((m @ m != 0).sum()))
"""


def _flush_probe(when: str) -> list:
    import subprocess
    import sys

    done = subprocess.run([sys.executable, "-c", _FLUSH_PROBE, when], capture_output=True,
                          text=True, timeout=120, check=True)
    ok, elementwise, matmul = done.stdout.split()
    return [ok == "True", int(elementwise), int(matmul)]


def test_flush_denormals_reaches_every_thread_when_set_first():
    assert _flush_probe("first") == [True, 0, 0]


def test_flush_denormals_set_late_reaches_the_calling_thread_only_and_says_so():
    ok, elementwise, _ = _flush_probe("late")
    assert not ok
    # the calling thread flushed its part of the product, the started worker did not
    assert 0 < elementwise < 1 << 20


_TRAIN_FLUSHED = """
import json, sys
import numpy as np
from windnav.predict.decoder import load_decoder
from windnav.predict.train import train_decoder
recipe, store, out = json.loads(sys.argv[1]), sys.argv[2], sys.argv[3]
h = train_decoder(recipe, store=store, out_dir=out, progress=False, log=None)
w = load_decoder(out + "/model.npz")
print(json.dumps([h["flush_denormal"], w.metadata["training"]["flush_denormal"]]))
"""


def test_thesis_mlp_trains_with_subnormals_flushed_in_a_fresh_process(tiny, tmp_path):
    import subprocess
    import sys

    recipe, out, _ = tiny
    mlp = copy.deepcopy(recipe)
    mlp["model"] = {"architecture": "thesis-mlp", "hyperparameters": {"width": 64, "depth": 2}}
    mlp["train"].update(epochs=1, optimizer="adam", weight_decay=0.002, cache=False,
                        flush_denormal=True, tensorboard=False)
    done = subprocess.run([sys.executable, "-c", _TRAIN_FLUSHED, json.dumps(mlp),
                           str(out / "sweep.zarr"), str(tmp_path)],
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    # set before torch's threads start: every thread flushed, and the model file says so
    assert json.loads(done.stdout.splitlines()[-1]) == [True, True]


def test_d4_augmentation_turns_whole_samples(tiny):
    """The canonical frame forgets the turn: augmented samples have the same canonical
    inputs and labels, so augmentation turns scans, winds, labels and masks consistently."""
    recipe, out, _ = tiny
    fields = fields_from_store(out / "sweep.zarr", maps=[0])
    s = DecoderDataset(fields, 16, size=9).materialize()
    batch = (s.scans, s.w_up, s.w_robot, s.labels, s.free, s.inlet_speed)
    turned = _augment(batch, np.random.default_rng(0))
    arch = make_architecture("d4-film", 9)
    fa, fb = arch.features(*batch[:3]), arch.features(*turned[:3])
    for k in ("channels", "winds", "scale", "w_robot"):
        np.testing.assert_allclose(fa[k], fb[k], rtol=1e-6, atol=1e-6)
    la = arch.model_labels(s.labels.reshape(-1, 2, 81), s.free.reshape(-1, 81), fa)
    lb = arch.model_labels(turned[3].reshape(-1, 2, 81), turned[4].reshape(-1, 81), fb)
    np.testing.assert_array_equal(la[1], lb[1])
    np.testing.assert_allclose(la[0], lb[0], atol=1e-6)


def test_labels_cached_in_the_model_frame_are_those_each_batch_turned_itself(tiny):
    """Turning a block's cached labels into the model frame once gives every batch, in every
    block, the tensors that turning the batch's world-frame labels gave (bit for bit)."""
    import torch

    recipe, out, _ = tiny
    fields = fields_from_store(out / "sweep.zarr", maps=[0, 1])
    arch = make_architecture("d4-film", recipe["data"]["size"],
                             **recipe["model"]["hyperparameters"])
    make = functools.partial(_train_block, fields, recipe["data"])
    world = _Batches(make, True, 100, 2)
    model = _Batches(make, True, 100, 2, model_frame=arch)
    assert model.in_model_frame and not world.in_model_frame
    assert not _Batches(make, False, 100, 2, model_frame=arch).in_model_frame
    n = 0
    for e in (0, 1, 2):  # blocks 0 and 1
        for (a, none), (b, cached) in zip(world.epoch(e), model.epoch(e), strict=True):
            assert none is None and set(cached) == {"channels", "winds", "scale", "w_robot", "g"}
            ta = _tensor_batch(arch, a, "cpu")
            # the labels turned once per block; and the features cached with them as well
            for tb in (_tensor_batch(arch, b, "cpu", in_model_frame=True),
                       _tensor_batch(arch, b, "cpu", in_model_frame=True, features=cached)):
                assert all(torch.equal(x[k], y[k]) for x, y in [(ta[0], tb[0])] for k in x)
                assert all(torch.equal(x, y) for x, y in zip(ta[1:], tb[1:], strict=True))
            g = arch.features(a[0], a[1], a[2])["g"]
            np.testing.assert_array_equal(cached["g"], g)
            n += 1
    assert n >= 3 * 10
    # chunk by chunk (a chunk of 7 samples) as in one piece
    s = make(0).materialize()
    f = arch.features(s.scans, s.w_up, s.w_robot)
    lab, fr = arch.model_labels(s.labels.reshape(len(s.scans), 2, -1),
                                s.free.reshape(len(s.scans), -1), f)
    got = _model_frame_in_place(arch, s.scans, s.w_up, s.w_robot, s.labels.copy(),
                                s.free.copy(), chunk=7, keep=("channels", "g"))
    np.testing.assert_array_equal(got[0], lab.astype(np.float32))
    np.testing.assert_array_equal(got[1], fr)
    np.testing.assert_array_equal(got[2]["channels"], f["channels"].astype(np.float32))
    np.testing.assert_array_equal(got[2]["g"], f["g"])


def test_a_second_run_into_the_same_out_refuses_at_once(tmp_path, capsys, held_elsewhere):
    """Two train-decoder runs into one --out: the second resumed the first's live checkpoint
    and crashed on its temporary file (2 of 2 tries), or replaced its files silently
    (concurrency audit). The first holds a lock on --out; the second names it and stops."""
    import time

    from windnav import cli
    from windnav.commands.train_decoder import LOCK

    out = tmp_path / "same"
    out.mkdir()
    with held_elsewhere("exclusive", out / LOCK) as holder:
        t0 = time.perf_counter()
        assert cli.main(["train-decoder", "--config", "tiny", "--out", str(out)]) == 1
        assert time.perf_counter() - t0 < 30  # at once, not after a sweep
        err = capsys.readouterr().err
        assert "OutputBusyError: Another run is writing the decoder run" in err
        assert f"process {holder.pid} on" in err
        assert sorted(p.name for p in out.iterdir()) == [LOCK]  # nothing else written


def test_train_decoder_command_resumes_sweep_and_training(tiny, capsys):
    from windnav.commands import train_decoder as decoder

    recipe, out, h = tiny
    parser = argparse.ArgumentParser()
    decoder.register(parser.add_subparsers(dest="command"))
    args = parser.parse_args(["train-decoder", "--config", str(RECIPES / "tiny.toml"),
                              "--out", str(out), "--no-progress", "--backend", "serial",
                              "--json", str(out / "run.json")])
    assert args.func(args) == 0
    text = capsys.readouterr().out
    assert "12/12 simulations done (0 now" in text and str(out / "model.npz") in text
    doc = json.loads((out / "run.json").read_text())
    assert doc["command"] == "windnav train-decoder"
    assert doc["history"]["best_epoch"] == h["best_epoch"]
    # the recipe copy is written by fresh runs only, never over an existing checkpoint's
    assert not (out / "recipe.toml").exists()


def _on_the_tiny_sweep(tiny, out_dir, *options):
    """``(parser, args)``: ``windnav train-decoder --config tiny.toml --out out_dir`` with
    ``options``, its sweep store linked to the ``tiny`` fixture's (no simulation)."""
    from windnav.commands import train_decoder as command

    (out_dir / "sweep.zarr").symlink_to(tiny[1] / "sweep.zarr")
    parser = argparse.ArgumentParser()
    command.register(parser.add_subparsers(dest="command"))
    return parser, parser.parse_args(["train-decoder", "--config", str(RECIPES / "tiny.toml"),
                                      "--out", str(out_dir), "--no-progress", *options])


def test_train_decoder_writes_the_resolved_recipe_and_takes_a_seed(tiny, tmp_path, capsys):
    """OUT/recipe.toml was a byte copy of --config: a recipe with a ``base`` (four of the six
    shipped) named it relative to its own folder, so the copy did not load, and an edited base
    changed what it meant. It is now the resolved recipe, ``--seed`` included."""
    parser, args = _on_the_tiny_sweep(tiny, tmp_path, "--seed", "3")
    assert args.func(args) == 0
    capsys.readouterr()
    copy = load_recipe(tmp_path / "recipe.toml")
    assert copy["train"]["seed"] == 3 and copy["train"]["tensorboard"] is True
    want = load_recipe(RECIPES / "tiny.toml")
    want["train"]["seed"] = 3
    assert {k: v for k, v in copy.items() if k != "source"} == \
        {k: v for k, v in want.items() if k != "source"}
    seeded, first = load_decoder(tmp_path / "model.npz"), load_decoder(tiny[1] / "model.npz")
    assert any(not np.array_equal(seeded.weights[k], first.weights[k]) for k in first.weights)
    # the same out folder with another seed is another recipe: refused, not resumed
    again = parser.parse_args(["train-decoder", "--config", str(tmp_path / "recipe.toml"),
                               "--out", str(tmp_path), "--no-progress", "--seed", "4"])
    with pytest.raises(ValueError, match="differs from the recipe of the checkpoint"):
        again.func(again)
    bad = parser.parse_args(["train-decoder", "--config", "tiny", "--seed", "-1"])
    with pytest.raises(ValueError, match="'--seed' parameter of windnav train-decoder must be "):
        bad.func(bad)
    # every shipped recipe (and a base chain) reads back from its resolved form
    for name in shipped_recipes():
        r = load_recipe(RECIPES / f"{name}.toml")
        (tmp_path / "r.toml").write_text(recipe_toml(r))
        assert load_recipe(tmp_path / "r.toml") == {**r, "source": str(tmp_path / "r.toml")}


def test_train_decoder_command_ctrl_c_says_what_is_kept_and_how_to_resume(tiny, tmp_path,
                                                                          monkeypatch, capsys):
    """Audit: Ctrl-C printed only ``windnav train-decoder: interrupted``. It now says which step
    stopped, what is kept (the sweep's simulations; the checkpoint after the last finished
    epoch) and that rerunning the same command resumes; and rerunning does."""
    import windnav.experiments.wind_sweep as wind_sweep
    import windnav.predict.train as train
    recipe, out, full = tiny
    parser, args = _on_the_tiny_sweep(tiny, tmp_path, "--backend", "serial")
    real_train, real_sweep = train.train_decoder, wind_sweep.sweep

    def interrupted(*a, **k):
        raise KeyboardInterrupt

    def after_two_epochs(*a, **k):
        def stop(epoch, record):
            if epoch == 2:
                raise KeyboardInterrupt
        return real_train(*a, **k, callback=stop)

    monkeypatch.setattr(wind_sweep, "sweep", interrupted)
    assert args.func(args) == 130
    err = capsys.readouterr().err.strip()
    assert err == ("windnav train-decoder: interrupted during the sweep (12/12 simulations "
                   f"done, kept in {tmp_path / 'sweep.zarr'}); rerun the same command to "
                   "continue it, then train.")
    monkeypatch.setattr(wind_sweep, "sweep", real_sweep)
    monkeypatch.setattr(train, "train_decoder", interrupted)
    assert args.func(args) == 130
    err = capsys.readouterr().err.strip()
    assert "before its first epoch finished (no checkpoint yet" in err
    monkeypatch.setattr(train, "train_decoder", after_two_epochs)
    assert args.func(args) == 130
    err = capsys.readouterr().err.strip()
    assert err == ("windnav train-decoder: interrupted during the training; the checkpoint "
                   f"after the last finished epoch is kept in {tmp_path / 'checkpoint.pt'}; "
                   "rerun the same command to resume from it.")
    monkeypatch.setattr(train, "train_decoder", real_train)
    assert args.func(args) == 0   # resumes after epoch 2, ends with the uninterrupted model
    assert "resuming" in capsys.readouterr().out
    a, b = load_decoder(out / "model.npz"), load_decoder(tmp_path / "model.npz")
    for k in a.weights:
        np.testing.assert_array_equal(a.weights[k], b.weights[k])
    over = parser.parse_args(["train-decoder", "--config", str(RECIPES / "tiny.toml"),
                              "--out", str(tmp_path), "--no-progress", "--overwrite"])
    monkeypatch.setattr(train, "train_decoder", after_two_epochs)
    assert over.func(over) == 130
    assert "rerun the same command without --overwrite (which starts over) to resume" in \
        capsys.readouterr().err


@pytest.mark.parametrize("fused", [True, False])
def test_loss_is_the_free_cell_mean_of_relative_squared_error_and_misdirection(fused):
    import torch

    _loss = functools.partial(train_loss, fused=fused)

    label = torch.tensor([[[3.0, 0.0, 5.0], [4.0, 1.0, 0.0]]])  # (1, 2, 3): three cells
    free = torch.tensor([[1.0, 1.0, 0.0]])
    speed = torch.tensor([5.0])
    assert float(_loss(label, label, free, speed, 1.0, 0.5)) == pytest.approx(0.0, abs=1e-5)
    pred = label.clone()
    pred[0, :, 0] = torch.tensor([-3.0, -4.0])  # reversed in cell 0: error 10 m/s, cos -1
    pred[0, :, 2] = 100.0  # a building cell does not count
    mse = 100.0 / 25.0 * (5.0 / 10.0) / 2  # |err|^2 / U^2 * (U / 10)^p, mean over 2 cells
    assert float(_loss(pred, label, free, speed, 1.0, 0.0)) == pytest.approx(mse, rel=1e-6)
    assert float(_loss(pred, label, free, speed, 1.0, 0.5)) == pytest.approx(
        mse + 0.5 * 2.0 / 2, rel=1e-5)
    # the direction term does not pull on the predicted speed
    scaled = (2.0 * label).requires_grad_(True)
    _loss(scaled, label, free, speed, 1.0, 0.0).backward()
    mse_grad = scaled.grad.clone()
    scaled.grad = None
    _loss(scaled, label, free, speed, 1.0, 0.5).backward()
    torch.testing.assert_close(scaled.grad, mse_grad, atol=1e-5, rtol=0)


@pytest.mark.parametrize("fused", [True, False])
def test_norm_and_speed_loss_terms_are_the_metrics_own_forms(fused):
    import torch

    from windnav.predict.metrics import field_errors

    _loss = functools.partial(train_loss, fused=fused)
    rng = np.random.default_rng(3)
    label = torch.tensor(rng.normal(0, 4, (2, 2, 9)), dtype=torch.float32)
    pred = torch.tensor(rng.normal(0, 4, (2, 2, 9)), dtype=torch.float32)
    free = torch.tensor(rng.random((2, 9)) > 0.3, dtype=torch.float32)
    speed = torch.tensor([5.0, 5.0])
    scale = (5.0 / 10.0) / 5.0  # (U / 10)^p / U at p = 1
    # the vector and speed errors of windnav.predict.metrics, on the same cells
    lab = label.numpy().reshape(2, 2, 3, 3)
    prd = pred.numpy().reshape(2, 2, 3, 3)
    m = field_errors(prd, lab, free.numpy().reshape(2, 3, 3).astype(bool), [5.0, 5.0])
    norm = float(_loss(pred, label, free, speed, 1.0, 0.0, "norm"))
    assert norm == pytest.approx(scale * m["vector_error"], rel=1e-4)
    both = float(_loss(pred, label, free, speed, 1.0, 0.0, "norm", 2.0))
    assert both - norm == pytest.approx(2.0 * scale * m["speed_error"], rel=1e-4)
    # the squared form is the default and the speed term is off by default
    assert float(_loss(pred, label, free, speed, 1.0, 0.5)) == float(
        _loss(pred, label, free, speed, 1.0, 0.5, "squared", 0.0))
    # the speed term pulls only on the predicted speed, never on the direction
    p = pred.clone().requires_grad_(True)
    _loss(p, label, free, speed, 1.0, 0.0, "norm", 1.0).backward()
    g_both = p.grad.clone()
    p.grad = None
    _loss(p, label, free, speed, 1.0, 0.0, "norm", 0.0).backward()
    g_speed = (g_both - p.grad).numpy()
    q = pred.numpy()
    tangential = (g_speed[:, 0] * q[:, 1] - g_speed[:, 1] * q[:, 0]) / np.linalg.norm(q, axis=1)
    np.testing.assert_allclose(tangential, 0.0, atol=1e-6)
    # finite gradients where the prediction and the label are both zero
    zero = torch.zeros_like(label).requires_grad_(True)
    _loss(zero, torch.zeros_like(label), free, speed, 1.0, 0.0, "norm", 1.0).backward()
    assert torch.isfinite(zero.grad).all()


@pytest.mark.parametrize(("power", "vector", "speed_weight", "direction_weight", "fade"),
                         [(1.0, "norm", 1.0, 1.0, 0.1), (2.0, "squared", 0.0, 0.5, 0.1),
                          (0.0, "squared", 1.5, 0.0, 0.1), (1.0, "norm", 0.0, 2.0, 0.1),
                          (1.0, "norm", 1.0, 1.0, 0.0), (1.0, "norm", 0.0, 2.0, 0.3)])
def test_fused_loss_gives_the_torch_formulas_value_and_gradient(power, vector, speed_weight,
                                                                  direction_weight, fade):
    """The compiled loss (the default on the CPU) against the torch formula it replaces, on a
    batch with building cells, zero labels, slow cells and inlets below the 0.1 m/s floor."""
    import torch

    rng = np.random.default_rng(11)
    label = torch.tensor(rng.normal(0, 3, (64, 2, 49)), dtype=torch.float32)
    label[:, :, :5] = 0.0  # calm cells, where the direction term fades out
    label[:, :, 5:9] *= 0.01
    pred = label + torch.tensor(rng.normal(0, 1, (64, 2, 49)), dtype=torch.float32)
    pred[0, :, 0] = 0.0  # a zero prediction on a zero label
    free = torch.tensor(rng.random((64, 49)) > 0.25, dtype=torch.float32)
    speed = torch.tensor(rng.uniform(0.02, 12.0, 64), dtype=torch.float32)
    terms = (power, direction_weight, vector, speed_weight, "cosine", fade)
    grads, values = [], []
    for fused in (True, False):
        p = pred.clone().requires_grad_(True)
        loss = train_loss(p, label, free, speed, *terms, fused=fused)
        loss.backward()
        values.append(float(loss))
        grads.append(p.grad.numpy())
    assert values[0] == pytest.approx(values[1], rel=2e-6)
    # the torch formula's gradient is NaN at a zero prediction with the direction term on
    # (the square root's derivative at 0); the compiled one stays finite there, 0 on the cell
    assert np.isfinite(grads[0]).all()
    ok = np.isfinite(grads[1])
    assert ok[1:].all() and ok[0, :, 1:].all()
    scale = np.abs(grads[1][ok]).max()
    np.testing.assert_allclose(grads[0][ok], grads[1][ok], rtol=0, atol=2e-6 * scale)
    assert np.all(grads[0][free.numpy()[:, None, :].repeat(2, 1) == 0] == 0)  # buildings


def test_fused_loss_rows_are_independent_and_its_backward_scales_by_the_outer_gradient():
    """The compiled loss's samples are independent (two runs of rows give the gradient of one,
    to the bit, and the loss to float64 rounding), and its backward multiplies the gradient
    by the outer one unless that is 1 (a weighted loss, as in distillation)."""
    import torch

    from windnav.predict._loss import free_count, loss_and_grad, loss_rows

    rng = np.random.default_rng(12)
    pred = rng.normal(0, 3, (9, 2, 49)).astype(np.float32)
    label = rng.normal(0, 3, (9, 2, 49)).astype(np.float32)
    free = (rng.random((9, 49)) > 0.25).astype(np.float32)
    speed = rng.uniform(0.5, 10.0, 9).astype(np.float32)
    whole, parts = np.empty_like(pred), np.empty_like(pred)
    value = loss_and_grad(pred, label, free, speed, 1.0, True, 1.0, 1.0, whole)
    inv_n = np.float32(1.0 / free_count(free))
    split = sum(loss_rows(pred, label, free, speed, 1.0, True, 1.0, 1.0, inv_n, parts, a, b)
                for a, b in ((0, 4), (4, 9)))
    assert np.array_equal(whole.view(np.int32), parts.view(np.int32))
    assert split == pytest.approx(value, rel=1e-12)
    grads = []
    for weight in (1.0, 0.25):
        p = torch.tensor(pred, requires_grad=True)
        (weight * train_loss(p, torch.tensor(label), torch.tensor(free), torch.tensor(speed),
                             1.0, 1.0, "norm", 1.0)).backward()
        grads.append(p.grad.numpy())
    assert np.array_equal(grads[0], whole)
    np.testing.assert_array_equal(grads[1], np.float32(0.25) * whole)


def test_angle_direction_loss_is_the_direction_errors_own_form():
    import torch

    from windnav.predict.metrics import field_errors

    rng = np.random.default_rng(4)
    label = torch.tensor(rng.normal(0, 4, (2, 2, 9)) + 3.0, dtype=torch.float32)
    pred = torch.tensor(rng.normal(0, 4, (2, 2, 9)) + 3.0, dtype=torch.float32)
    free = torch.tensor(rng.random((2, 9)) > 0.3, dtype=torch.float32)
    speed = torch.tensor([0.2, 0.2])  # c = 1 wherever |label| >= 0.02 m/s: every cell here
    m = field_errors(pred.numpy().reshape(2, 2, 3, 3), label.numpy().reshape(2, 2, 3, 3),
                     free.numpy().reshape(2, 3, 3).astype(bool), [0.2, 0.2])
    vec = float(train_loss(pred, label, free, speed, 1.0, 0.0, "norm"))
    ang = float(train_loss(pred, label, free, speed, 1.0, 0.7, "norm", 0.0, "angle")) - vec
    assert ang == pytest.approx(0.7 * np.radians(m["direction_error_deg"]), rel=1e-4)
    # it never pulls on the predicted speed: its gradient is tangential
    p = pred.clone().requires_grad_(True)
    train_loss(p, label, free, speed, 1.0, 1.0, "norm", 0.0, "angle").backward()
    g_dir = p.grad.clone()
    p.grad = None
    train_loss(p, label, free, speed, 1.0, 0.0, "norm").backward()
    g = (g_dir - p.grad).numpy()
    np.testing.assert_allclose((g * pred.numpy()).sum(axis=1), 0.0, atol=1e-5)
    # and stays finite where prediction and label agree
    q = label.clone().requires_grad_(True)
    train_loss(q, label, free, speed, 1.0, 1.0, "norm", 0.0, "angle").backward()
    assert torch.isfinite(q.grad).all()


def test_direction_fade_zero_counts_every_free_cell_as_the_metric_does():
    """``train.direction_fade = 0``: the direction term weighs slow cells fully, as the
    direction-error metric counts them; at the default 0.1 cells slower than 0.1 U weigh
    less. Checked on the ``1 - cos`` term (fused and torch) against NumPy."""
    import torch

    rng = np.random.default_rng(5)
    label = rng.normal(0, 2, (2, 2, 9)) + 1.0
    pred = rng.normal(0, 2, (2, 2, 9)) + 1.0
    free = rng.random((2, 9)) > 0.3
    speed = torch.tensor([60.0, 60.0])  # 0.1 U = 6 m/s: every cell here is "slow"
    # the cosine as the loss softens it: |p| |l| + 1e-6 U^2
    norms = np.linalg.norm(pred, axis=1) * np.linalg.norm(label, axis=1) + 1e-6 * 60.0 ** 2
    want = 0.7 * (1.0 - (pred * label).sum(1) / norms)[free].mean()
    t = [torch.tensor(a, dtype=torch.float32) for a in (pred, label, free)]
    vec = float(train_loss(*t, speed, 1.0, 0.0, "norm"))
    for fused in (True, False):
        full = float(train_loss(*t, speed, 1.0, 0.7, "norm", 0.0, "cosine", 0.0, fused=fused))
        faded = float(train_loss(*t, speed, 1.0, 0.7, "norm", 0.0, "cosine", fused=fused))
        assert full - vec == pytest.approx(want, rel=1e-4)
        assert faded - vec < 0.6 * (full - vec)


def test_a_teacher_pulls_the_student_towards_its_field(tiny, tmp_path):
    """Distillation: from another seed, a student with the whole loss on the tiny model's
    field (weight 1) ends closer to that field than the same seed trained on the labels; the
    teacher's file, not its path, is in the fingerprint; a teacher on another grid is
    refused."""
    recipe, out, full = tiny
    teacher_path = tmp_path / "teacher.npz"
    teacher_path.write_bytes((out / "model.npz").read_bytes())
    teacher = load_decoder(teacher_path)
    data = recipe["data"]
    val = DecoderDataset(fields_from_store(out / "sweep.zarr", maps=[2]),
                         data["validation_samples_per_field"], seed=data["seed"] + 1,
                         size=data["size"]).materialize()
    args = (val.scans, val.w_up, val.w_robot)
    t, free = teacher.predict(*args), val.free.astype(bool)
    gap = {}
    for name, train in (("plain", {}), ("taught", {"teacher": str(teacher_path),
                                                   "teacher_weight": 1.0})):
        r = copy.deepcopy(recipe)
        r["train"].update(seed=1, **train)
        h = train_decoder(r, store=out / "sweep.zarr", out_dir=tmp_path / name,
                          progress=False, log=None)
        gap[name] = float(np.abs(load_decoder(h["model"]).predict(*args) - t).sum(axis=1)[
            free].mean())
    assert gap["taught"] < 0.85 * gap["plain"]  # 0.43 against 0.56 m/s (2026-12-02)
    taught = copy.deepcopy(recipe)
    taught["train"].update(seed=1, teacher=str(teacher_path), teacher_weight=1.0)
    moved = copy.deepcopy(taught)
    (tmp_path / "moved.npz").write_bytes(teacher_path.read_bytes())
    moved["train"]["teacher"] = str(tmp_path / "moved.npz")
    assert _fingerprint(moved) == _fingerprint(taught) != _fingerprint(recipe)
    save_decoder(teacher.weights, {**teacher.metadata, "spacing": 2.0}, teacher_path)
    with pytest.raises(ValueError, match="train.teacher predict on the recipe's grid"):
        train_decoder(taught, store=out / "sweep.zarr", out_dir=tmp_path / "other",
                      progress=False, log=None)


def test_moving_average_decay_and_update_follow_their_formulas():
    """``ema_decay_at`` is ``min(d, (1 + t) / (10 + t))``; ``_ema_update`` moves each average
    by ``1 - d_t`` of its distance to the parameter, step after step."""
    torch = pytest.importorskip("torch")
    assert ema_decay_at(0.999, 1) == pytest.approx(2 / 11)
    assert ema_decay_at(0.999, 8990) == pytest.approx(8991 / 9000)
    assert ema_decay_at(0.999, 9000) == 0.999
    rng = np.random.default_rng(0)
    steps = rng.normal(size=(50, 3, 4))
    avg = [torch.zeros(3, 4, dtype=torch.float64)]
    ref = np.zeros((3, 4))
    for t, p in enumerate(steps, start=1):
        _ema_update(avg, [torch.from_numpy(p)], 0.9, t)
        d = min(0.9, (1 + t) / (10 + t))
        ref = d * ref + (1 - d) * p
    np.testing.assert_allclose(avg[0].numpy(), ref, rtol=1e-12, atol=1e-14)


def test_moving_average_is_the_model_kept_and_resumes(tiny, tmp_path):
    """With ``train.ema_decay`` the raw weights train exactly as without it (their validation,
    recorded as ``val_raw``, is the plain run's to the bit), the averaged weights are the
    ones validated, kept and saved, and an interrupted run resumes to the same average."""
    recipe, out, plain = tiny
    ema = copy.deepcopy(recipe)
    ema["train"]["ema_decay"] = 0.99
    h = train_decoder(ema, store=out / "sweep.zarr", out_dir=tmp_path / "full", progress=False,
                      log=None)
    assert [e["val_raw"] for e in h["epochs"]] == [e["val"] for e in plain["epochs"]]
    assert [e["train_loss"] for e in h["epochs"]] == [e["train_loss"] for e in plain["epochs"]]
    assert all(e["val"] != e["val_raw"] for e in h["epochs"])
    kept = load_decoder(h["model"])
    assert kept.metadata["metrics"]["validation"] == h["best_val"]
    raw = load_decoder(out / "model.npz")
    assert any(not np.array_equal(kept.weights[k], raw.weights[k]) for k in kept.weights)

    def stop_after_two(epoch, record):
        if epoch == 2:
            raise Stop

    with pytest.raises(Stop):
        train_decoder(ema, store=out / "sweep.zarr", out_dir=tmp_path / "resumed",
                      progress=False, log=None, callback=stop_after_two)
    again = train_decoder(ema, store=out / "sweep.zarr", out_dir=tmp_path / "resumed",
                          progress=False, log=None)
    assert [e["val"] for e in again["epochs"]] == [e["val"] for e in h["epochs"]]
    b = load_decoder(again["model"])
    for k in kept.weights:
        np.testing.assert_array_equal(kept.weights[k], b.weights[k])


def test_keep_last_ships_the_last_epoch_and_trains_the_same(tiny, tmp_path, monkeypatch):
    """``train.keep = "last"`` trains exactly as the default (every epoch's validation to the
    bit) and keeps the last epoch's weights, whatever epoch validated best."""
    import windnav.predict.train as train_mod

    recipe, out, plain = tiny
    last = copy.deepcopy(recipe)
    last["train"]["keep"] = "last"
    scores = iter([1.0, 0.5, 0.9, 0.8, 0.7, 0.6])  # the second epoch validates best
    monkeypatch.setattr(train_mod, "_score", lambda metrics, local: next(scores))
    h = train_decoder(last, store=out / "sweep.zarr", out_dir=tmp_path, progress=False,
                      log=None)
    assert [e["val"] for e in h["epochs"]] == [e["val"] for e in plain["epochs"]]
    assert h["best_epoch"] == 2 < len(h["epochs"])
    kept = load_decoder(h["model"])
    n = len(h["epochs"])
    assert kept.metadata["metrics"]["epoch"] == n
    assert kept.metadata["metrics"]["validation"] == h["epochs"][-1]["val"]
    assert kept.metadata["training"]["kept"] == "last"
    assert load_decoder(plain["model"]).metadata["training"]["kept"] == "best"
    # the last epoch's weights: those of the checkpoint the run ends with
    import torch

    state = torch.load(tmp_path / "checkpoint.pt", weights_only=False)["model"]
    for k, v in kept.weights.items():
        np.testing.assert_array_equal(v, state[k].numpy())


def test_loss_options_at_their_defaults_keep_earlier_fingerprints():
    recipe = load_recipe({"data": {"validation_maps": ["holdout-0"]}})
    older = copy.deepcopy(recipe)
    for key in ("vector_loss", "speed_loss_weight", "direction_loss", "members", "teacher",
                "teacher_weight", "ema_decay", "keep", "direction_fade"):
        del older["train"][key]
    assert _fingerprint(older) == _fingerprint(recipe)
    for key, value in (("vector_loss", "norm"), ("speed_loss_weight", 1.0),
                       ("direction_loss", "angle"), ("members", 2), ("ema_decay", 0.999),
                       ("keep", "last"), ("direction_fade", 0.0)):
        changed = copy.deepcopy(recipe)
        changed["train"][key] = value
        assert _fingerprint(changed) != _fingerprint(recipe)


@pytest.mark.parametrize(("change", "match"), [
    ({"trian": {}}, "unknown key 'trian'"),
    ({"train": {"epochs": 0}}, "train.epochs"),
    ({"train": {"optimizer": "sgd"}}, "train.optimizer"),
    ({"train": {"vector_loss": "huber"}}, "train.vector_loss"),
    ({"train": {"direction_loss": "sine"}}, "train.direction_loss"),
    ({"train": {"speed_loss_weight": -1.0}}, "train.speed_loss_weight"),
    ({"train": {"flush_denormal": 1}}, "train.flush_denormal"),
    # strings are truthy: augment_d4 = "false" augmented (audit, 2026-12-05)
    ({"train": {"augment_d4": "false"}}, "train.augment_d4"),
    ({"train": {"cache": "no"}}, "train.cache"),
    ({"train": {"tensorboard": 0}}, "train.tensorboard"),
    ({"train": {"loss_speed_power": -1.0}}, "train.loss_speed_power"),
    ({"data": {"validation_maps": []}}, "data.validation_maps"),
    ({"data": {"turn_deg": 46}}, "data.turn_deg"),
    ({"data": {"turn_deg": -1}}, "data.turn_deg"),
    ({"data": {"turn_deg": 4.0}}, "data.turn_deg"),
    ({"data": {"turn_deg": True}}, "data.turn_deg"),
    ({"data": {"exclude_maps": "train-1"}}, "data.exclude_maps"),
    ({"data": {"exclude_maps": ["holdout-0"]}}, "data.exclude_maps"),
    ({"data": {"map_weights": {"nowhere": 2}}}, "data.map_weights"),
    ({"sweep": {"maps": [{"name": "train", "kind": "training"}]},
      "data": {"map_weights": {"train": 0}}}, "data.map_weights"),
    ({"sweep": {"maps": [{"name": "train", "kind": "training"}]},
      "data": {"map_weights": {"train": 1.5}}}, "data.map_weights"),
    ({"model": {"architecture": "resnet"}}, "'name' parameter of make_architecture"),
    ({"model": {"hyperparameters": {"pool": 4}}}, "'pool' hyperparameter"),
    ({"train": {"members": 0}}, "train.members"),
    ({"model": {"hyperparameters": {"members": 2}}}, "model.hyperparameters.members"),
    ({"model": {"architecture": "thesis-mlp"}, "train": {"members": 2}}, "train.members"),
    ({"sweep": {"maps": [{"name": "a", "kind": "forest"}]}}, "sweep.maps"),
    ({"sweep": {"maps": [{"name": "mine", "kind": "file"}]}}, r"sweep.maps\[0\]"),
    ({"sweep": {"maps": [{"name": "mine", "kind": "file", "path": "c.json", "count": 2}]}},
     r"sweep.maps\[0\].*kind \"file\""),
    ({"train": {"teacher_weight": 1.5, "teacher": "t.npz"}}, "train.teacher_weight"),
    ({"train": {"teacher_weight": 0.5}}, "train.teacher"),
    ({"train": {"teacher": "t.npz"}}, "train.teacher"),
    ({"train": {"ema_decay": 1.0}}, "train.ema_decay"),
    ({"train": {"ema_decay": -0.1}}, "train.ema_decay"),
    ({"train": {"ema_decay": True}}, "train.ema_decay"),
    ({"train": {"keep": "first"}}, "train.keep"),
    # map names the sweep will not make: refused after the sweep before (2026-12-05)
    ({"sweep": {"maps": [{"name": "holdout", "kind": "training"}]},
      "data": {"validation_maps": ["holdout-1"]}}, r"data.validation_maps.*\['holdout-1'\]"),
    ({"sweep": {"maps": [{"name": "holdout", "kind": "training"}]},
      "data": {"exclude_maps": ["nowhere-0"]}}, "data.exclude_maps"),
    ({"sweep": {"maps": [{"name": "holdout", "kind": "training", "count": 0}]}},
     r"sweep.maps\[0\].count"),
    # an even window has no centre cell (decoder-study --sizes refused it; CLI audit)
    ({"data": {"size": 24}}, r"data.size an odd integer >= 3"),
    ({"data": {"size": 1}}, r"data.size an odd integer >= 3"),
    # as every --direction-deg: within one turn (720 was accepted; CLI audit)
    ({"sweep": {"directions_deg": [10, 720]}}, r"sweep.directions_deg .* from -360 to 360"),
    ({"sweep": {"directions_deg": [float("nan")]}}, r"sweep.directions_deg"),
    ({"sweep": {"directions_deg": []}}, r"sweep.directions_deg"),
    ({"sweep": {"directions_deg": "90"}}, r"sweep.directions_deg"),
    # as every inlet --speed: refused by the sweep, naming its 'speeds', after the run's
    # folder was made (CLI audit)
    ({"sweep": {"speeds": [-3.0, 6.0]}}, r"sweep.speeds a non-empty list of inlet speeds > 0 "
                                         r"and <= 100 m/s\. Got \[-3\.0, 6\.0\]"),
    ({"sweep": {"speeds": []}}, r"sweep.speeds"),
    ({"sweep": {"speeds": [float("nan")]}}, r"sweep.speeds"),
    ({"sweep": {"speeds": [500.0]}}, r"sweep.speeds"),
    ({"sweep": {"speeds": 6.0}}, r"sweep.speeds"),
])
def test_bad_recipes_are_refused(change, match):
    base = {"data": {"validation_maps": ["holdout-0"]}}
    for key, value in change.items():
        base[key] = {**base.get(key, {}), **value}
    with pytest.raises(ValueError, match=match):
        load_recipe(base)


@pytest.mark.parametrize("name", ["../../escape", "a/b", "a\\b", "..", ".", "", 5, None])
def test_a_recipe_name_must_be_a_folder_name(name, tmp_path, capsys):
    """The run's folder is runs/<name>: "../../escape" wrote outside runs/, and 5 was accepted
    (CLI audit); refused by load_recipe, and by train-decoder before any sweep."""
    import windnav.cli as cli

    base = {"data": {"validation_maps": ["holdout-0"]}, "name": name}
    with pytest.raises(ValueError, match=r"must have name a non-empty name without path "
                                         r"separators, not '\.' or '\.\.'"):
        load_recipe(base)
    recipe = tmp_path / "recipe.toml"
    text = name if isinstance(name, int) else json.dumps(name) if name is not None else '""'
    recipe.write_text(f'base = "{(RECIPES / "tiny.toml").as_posix()}"\nname = {text}\n')
    assert cli.main(["train-decoder", "--config", str(recipe), "--out",
                     str(tmp_path / "out")]) == 2
    assert "'--config' parameter of windnav train-decoder must have name" in \
        capsys.readouterr().err
    assert not (tmp_path / "out").exists()
    for fine in ("default", "thesis-mlp", "wrobot_noise", "a.b"):
        assert load_recipe({**base, "name": fine})["name"] == fine


def test_recipe_files_are_checked(tmp_path):
    with pytest.raises(ValueError, match="'config' parameter of load_recipe.*instead, a folder"):
        load_recipe(tmp_path)  # "(names), which does not exist" before
    with pytest.raises(ValueError, match="'config' parameter of load_recipe.*does not exist"):
        load_recipe(tmp_path / "none.toml")
    bad = tmp_path / "bad.toml"
    bad.write_text("[train\nepochs = 3\n")
    with pytest.raises(ValueError, match="not valid TOML"):
        load_recipe(bad)


@pytest.mark.parametrize("name", ["default", "default_2026-12-06", "tiny", "thesis_mlp",
                                  "thesis_mlp_2026-12-06", "wrobot_noise", "wrobot_flight",
                                  "ensemble"])
def test_shipped_recipes_are_complete(name):
    recipe = load_recipe(RECIPES / f"{name}.toml")
    names = [group["name"] for group in recipe["sweep"]["maps"]]
    assert len(set(names)) == len(names)
    counts = {g["name"]: g.get("count", 1) for g in recipe["sweep"]["maps"]}
    maps = [f"{n}-{i}" for n in names for i in range(counts[n])]
    assert set(recipe["data"]["validation_maps"]) < set(maps)
    assert recipe["data"]["size"] == 25


@pytest.mark.parametrize(("name", "noise"), [("wrobot_noise", 0.85), ("wrobot_flight", 2.7)])
def test_wrobot_recipes_are_the_default_but_for_the_noise(name, noise):
    noisy = load_recipe(RECIPES / f"{name}.toml")
    # the default recipe of 2026-12-06 (69 maps), which their committed results were made on
    default = load_recipe(RECIPES / "default_2026-12-06.toml")
    assert noisy["name"] == name
    assert noisy["data"].pop("w_robot_noise") == noise and default["data"].pop("w_robot_noise") == 0
    # and the squared loss their models were trained with (the default's since 2026-11-30 has
    # the metrics' own forms)
    assert (noisy["train"].pop("vector_loss"), noisy["train"].pop("speed_loss_weight")) == (
        "squared", 0.0)
    assert (default["train"].pop("vector_loss"), default["train"].pop("speed_loss_weight")) == (
        "norm", 1.0)
    # and no turned scenes (the default's since 2026-12-06)
    assert (noisy["data"].pop("turn_deg"), default["data"].pop("turn_deg")) == (0, 4)
    for key in ("sweep", "data", "model", "train"):
        assert noisy[key] == default[key], key


def test_ensemble_recipe_is_the_default_in_two_members_of_half_the_epochs():
    from windnav.predict.train import member_recipe

    ens = load_recipe(RECIPES / "ensemble.toml")
    default = load_recipe(RECIPES / "default_2026-12-06.toml")
    assert (ens["train"].pop("members"), ens["train"].pop("epochs")) == (2, 20)
    assert (default["train"].pop("members"), default["train"].pop("epochs")) == (1, 40)
    assert (ens["data"].pop("turn_deg"), default["data"].pop("turn_deg")) == (0, 4)
    for key in ("sweep", "data", "model", "train"):
        assert ens[key] == default[key], key
    # its members are the default recipe at 20 epochs from seeds 0 and 1: the same runs
    ens = load_recipe(RECIPES / "ensemble.toml")
    for i in range(2):
        single = load_recipe(RECIPES / "default_2026-12-06.toml")
        single["train"].update(epochs=20, seed=i)
        single["data"]["turn_deg"] = 0
        assert _fingerprint(member_recipe(ens, i)) == _fingerprint(single)


@pytest.mark.parametrize("name", ["thesis_mlp", "thesis_mlp_2026-12-06"])
def test_thesis_mlp_recipe_keeps_the_thesis_loss(name):
    t = load_recipe(RECIPES / f"{name}.toml")["train"]
    assert (t["vector_loss"], t["speed_loss_weight"], t["direction_loss_weight"],
            t["loss_speed_power"], t["weight_decay"]) == ("squared", 0.0, 0.0, 2.0, 0.002)


def test_default_recipe_has_windinet_like_clusters():
    maps = recipe_maps(load_recipe(RECIPES / "default.toml"))
    extra = [(name, city) for name, _, city in maps if name.startswith("cluster")]
    assert [name for name, _ in extra] == [*(f"cluster-{i}" for i in range(6)),
                                           "cluster-stacked-0", "cluster-stacked-1"]
    for name, city in extra:   # 1.1 km, the buildings in the middle 500 m (300 m margins)
        f = city.footprints
        assert city.bounds == (0.0, 1100.0, 0.0, 1100.0)
        assert f[:, [0, 2]].min() >= 300.0 and f[:, [1, 3]].max() <= 800.0, name
    for _, city in extra[:6]:   # single blocks, as many as windinet's
        assert len(city.footprints) == 52
    assert len(maps) == 125


def _samples_per_group(recipe):
    """Training samples per block of each sweep group: maps x directions x weight x samples."""
    d = recipe["data"]
    return {g["name"]: g.get("count", 1) * len(recipe["sweep"]["directions_deg"])
            * len(recipe["sweep"]["speeds"]) * d["map_weights"].get(g["name"], 1)
            * d["samples_per_field"]
            for g in recipe["sweep"]["maps"] if f"{g['name']}-0" not in d["validation_maps"]}


def test_default_recipe_doubles_the_300_m_maps_and_keeps_each_groups_share():
    """The default since the forty-sixth session (2026-12-06): twice the 300 m maps of the
    recipe before (default_2026-12-06.toml), whose maps are the first half of each group, and
    every group's samples per block as before (the 300 m groups' spread over twice the maps)."""
    new = load_recipe(RECIPES / "default.toml")
    old = load_recipe(RECIPES / "default_2026-12-06.toml")
    counts = {g["name"]: g.get("count", 1) for g in new["sweep"]["maps"]}
    before = {g["name"]: g.get("count", 1) for g in old["sweep"]["maps"]}
    assert {k: counts[k] // before[k] for k in counts} == {
        "dense": 2, "dense12": 2, "sparse": 2, "district": 1, "holdout": 1, "scattered": 2,
        "cluster": 1, "cluster-stacked": 1}
    assert _samples_per_group(new) == _samples_per_group(old)
    assert sum(_samples_per_group(new).values()) == 552_960
    for key in ("speeds", "directions_deg", "settings", "seed"):
        assert new["sweep"][key] == old["sweep"][key], key
    assert new["model"] == old["model"] and new["train"] == old["train"]
    # the first maps of each group are the recipe's before, building for building
    old_maps = {name: city for name, _, city in recipe_maps(old)}
    for name, _, city in recipe_maps(new):
        if name in old_maps:
            np.testing.assert_array_equal(city.footprints, old_maps[name].footprints)
    assert len(old_maps) == 69


def test_a_file_map_is_read_from_its_rotorpy_json(tmp_path):
    from windnav.city import dense_map, read_rotorpy_json

    city = dense_map(rng=3, size=150.0, lots_per_side=2)
    path = city.to_rotorpy_json(tmp_path / "mine.json")
    recipe = load_recipe({"sweep": {"maps": [
        {"name": "mine", "kind": "file", "path": str(path)},
        {"name": "holdout", "kind": "dense", "count": 1, "seed": 5, "size": 150.0,
         "lots_per_side": 2}]}, "data": {"validation_maps": ["holdout-0"]}})
    maps = recipe_maps(recipe)
    assert [n for n, _, _ in maps] == ["mine-0", "holdout-0"]
    name, source, got = maps[0]
    np.testing.assert_array_equal(got.footprints, read_rotorpy_json(path).footprints)
    np.testing.assert_array_equal(got.footprints, city.footprints)
    assert str(path) in source
    recipe["sweep"]["maps"][0]["path"] = str(tmp_path / "none.json")
    with pytest.raises(FileNotFoundError):
        recipe_maps(recipe)


def test_a_recipe_starts_from_its_base(tmp_path):
    (tmp_path / "sub").mkdir()
    (tmp_path / "a.toml").write_text(   # a chain: b -> a -> tiny (an absolute path)
        f'base = "{(RECIPES / "tiny.toml").as_posix()}"\n'
        'name = "a"\n[data]\nsize = 15\nscan_noise = 0.2\n'
        '[model]\narchitecture = "d4-film"\nhyperparameters = { pool = 3, modes = 8 }\n')
    (tmp_path / "sub" / "b.toml").write_text(
        'base = "../a.toml"\nname = "b"\n[data]\nscan_noise = 0.5\n'
        '[model]\nhyperparameters = { width = 64 }\n')
    b = load_recipe(tmp_path / "sub" / "b.toml")
    a = load_recipe(tmp_path / "a.toml")
    assert b["name"] == "b" and b["source"] == str(tmp_path / "sub" / "b.toml")
    assert b["data"]["size"] == 15 and b["data"]["scan_noise"] == 0.5   # merged key by key
    assert b["model"]["hyperparameters"] == {"width": 64}                # replaced whole
    tiny = load_recipe(RECIPES / "tiny.toml")
    for key in ("sweep", "train"):
        assert b[key] == a[key] == tiny[key]
    assert a["model"]["hyperparameters"] == {"pool": 3, "modes": 8}
    # the shipped recipes that start from another resolve to it but for what they set: the
    # thesis MLP on the default's data, and that of 2026-12-06 on that recipe's
    for name, base, store in (("thesis_mlp", "default", "../default/sweep.zarr"),
                              ("thesis_mlp_2026-12-06", "default_2026-12-06",
                               "../default_2026-12-06/sweep.zarr")):
        thesis = load_recipe(RECIPES / f"{name}.toml")
        default = load_recipe(RECIPES / f"{base}.toml")
        assert thesis["model"]["hyperparameters"] == {"width": 2048, "depth": 3}
        assert thesis["sweep"] == {**default["sweep"], "store": store}
        assert thesis["data"] == {**default["data"], "turn_deg": 0}


def test_a_recipe_file_without_a_section_is_warned(tmp_path):
    """A copy of the default recipe cut before its [train] table parsed and trained with the
    built-in training defaults, not the recipe's, without a word (leftover of 2026-12-05)."""
    text = (RECIPES / "default.toml").read_text()
    cut = tmp_path / "cut.toml"
    cut.write_text(text[:text.index("\n[train]")])
    with pytest.warns(UserWarning, match=r"sets nothing in \[train\]: the built-in defaults"):
        recipe = load_recipe(cut)
    default = load_recipe(RECIPES / "default.toml")
    assert recipe["train"] != default["train"]   # what the warning is about
    assert recipe["data"] == default["data"]
    text = (RECIPES / "tiny.toml").read_text()
    cut.write_text(text[:text.index("\n[model]")])   # (before [data]: no validation map, refused)
    with pytest.warns(UserWarning, match=r"sets nothing in \[model\], \[train\]"):
        load_recipe(cut)
    with warnings.catch_warnings():   # a base, or a dict from code, sets them all
        warnings.simplefilter("error")
        for name in shipped_recipes():
            load_recipe(RECIPES / f"{name}.toml")
        load_recipe({"data": {"validation_maps": ["m"]}})


def test_a_recipe_base_is_checked(tmp_path):
    (tmp_path / "x.toml").write_text('base = "y.toml"\n')
    (tmp_path / "y.toml").write_text('base = "x.toml"\n')
    with pytest.raises(ValueError, match="'config' parameter of load_recipe.*cycle"):
        load_recipe(tmp_path / "x.toml")
    (tmp_path / "z.toml").write_text('base = "missing.toml"\n')
    with pytest.raises(ValueError, match=r"the base of .*z.toml'\). Got .*missing.toml' "
                                         "instead, which does not exist"):
        load_recipe(tmp_path / "z.toml")
    (tmp_path / "w.toml").write_text('base = 3\n')
    with pytest.raises(ValueError, match="must have base.*a recipe file name. Got 3"):
        load_recipe(tmp_path / "w.toml")


def test_train_decoder_trains_on_the_rest_when_a_sweep_task_fails(tmp_path, capsys):
    """A flow that fails (here every direction past 100 deg) is listed and left out, and the
    model trains on the rest; the listing named a task's ``direction_deg``, which a task has
    not, and crashed after the sweep (CLI audit, 2026-12-05)."""
    from windnav.commands import train_decoder as command
    from windnav.flow import simulate as real

    def failing(city, speed, direction_deg, **kw):
        if direction_deg > 100:
            raise RuntimeError("a flow that diverged")
        return real(city, speed=speed, direction_deg=direction_deg, **kw)

    parser = argparse.ArgumentParser()
    command.register(parser.add_subparsers(dest="command"))
    args = parser.parse_args(["train-decoder", "--config", "tiny", "--out",
                              str(tmp_path / "run"), "--no-progress"])
    assert command.run(args, simulate=failing) == 0
    err = capsys.readouterr().err
    assert "failed: map 0 cases [1] (speeds 3 m/s, directions 125 deg): RuntimeError: a flow" in err
    assert "sweep task(s) failed and are left out of the training" in err
    assert (tmp_path / "run" / "model.npz").exists()


def test_a_learning_rate_that_makes_the_training_diverge_is_named(tiny, tmp_path):
    """``learning_rate = 1e6`` ended in "The 'weights' parameter of Decoder must be finite",
    naming neither the recipe nor its learning rate, after the rest of the epoch ran on NaN
    (failure audit, thirty-eighth session)."""
    _, out, _ = tiny
    with pytest.raises(ValueError, match=r"'train.learning_rate' parameter of the recipe made "
                                         r"the training diverge: the loss became nan in epoch 1"):
        train_decoder(tiny_recipe(learning_rate=1e6), store=out / "sweep.zarr",
                      out_dir=tmp_path, progress=False, log=None)


def test_a_resume_under_other_training_code_is_said_and_recorded(tiny, tmp_path, monkeypatch):
    """A checkpoint resumed after a change of the training code (the loss, the model, the
    sampling) made one model of two codes, and nothing said so (cache audit's leftover). The
    checkpoint and the history now record the code's hash; a resume under another warns, and
    the history says from which epoch."""
    import windnav.predict.train as tr

    recipe, out, _ = tiny
    stop_after_one, stop_after_two = _stopping_after(1), _stopping_after(2)
    with pytest.raises(Stop):
        train_decoder(recipe, store=out / "sweep.zarr", out_dir=tmp_path, progress=False,
                      log=None, callback=stop_after_one)
    first = json.loads((tmp_path / "history.json").read_text())["code"]
    assert first == tr.module_key(tr.TRAINING_MODULE)
    monkeypatch.setattr(tr, "module_key", lambda name: "0123456789abcdef")
    with pytest.warns(UserWarning, match=f"other training code \\(source hash {first}"):
        h = train_decoder(recipe, store=out / "sweep.zarr", out_dir=tmp_path, progress=False,
                          log=None)
    assert h["code"] == first
    assert h["resumed_by_code"] == [{"code": "0123456789abcdef", "from_epoch": 1}]
    # resumed again under the same (new) code: no new change to record (review)
    out2 = tmp_path / "again"
    monkeypatch.setattr(tr, "module_key", lambda name: "aaaaaaaaaaaaaaaa")
    with pytest.raises(Stop):
        train_decoder(recipe, store=out / "sweep.zarr", out_dir=out2, progress=False,
                      log=None, callback=stop_after_one)
    monkeypatch.setattr(tr, "module_key", lambda name: "bbbbbbbbbbbbbbbb")
    with pytest.raises(Stop), pytest.warns(UserWarning, match="other training code"):
        train_decoder(recipe, store=out / "sweep.zarr", out_dir=out2, progress=False,
                      log=None, callback=stop_after_two)
    h = train_decoder(recipe, store=out / "sweep.zarr", out_dir=out2, progress=False, log=None)
    assert h["code"] == "aaaaaaaaaaaaaaaa"
    assert h["resumed_by_code"] == [{"code": "bbbbbbbbbbbbbbbb", "from_epoch": 1}]


def test_turned_scenes_train_and_the_validation_is_scored_as_simulated(tiny):
    """``data.turn_deg`` turns the training blocks' scenes, never the validation samples (a
    validation of turned scenes would score another set than the runs before)."""
    from windnav.predict.train import _Run

    recipe, out, _ = tiny
    turned = copy.deepcopy(recipe)
    turned["data"]["turn_deg"] = 3
    run = _Run(turned, out, out / "sweep.zarr")
    run.load_data("test")
    plain = _Run(recipe, out, out / "sweep.zarr")
    plain.load_data("test")
    for a, b in zip(run.val, plain.val, strict=True):
        np.testing.assert_array_equal(a, b)
    block, unturned = run.train_set(0), plain.train_set(0)
    assert block.turn_deg == 3 and unturned.turn_deg == 0
    idx = np.arange(0, len(block), 7)
    got = block.samples(idx)
    data = turned["data"]
    want = DecoderDataset(run.fields_train, data["samples_per_field"], seed=data["seed"],
                          size=data["size"], spacing=data["spacing"],
                          scan_noise=data["scan_noise"], turn_deg=3).samples(idx)
    for a, b in zip(got, want, strict=True):
        np.testing.assert_array_equal(a, b)
    assert not np.array_equal(got.scans, unturned.samples(idx).scans)


def test_no_turn_keeps_earlier_fingerprints_and_a_turn_changes_it():
    recipe = load_recipe("default_2026-12-06")
    assert recipe["data"]["turn_deg"] == 4   # since 2026-12-06
    unturned = copy.deepcopy(recipe)
    unturned["data"]["turn_deg"] = 0
    older = copy.deepcopy(recipe)
    del older["data"]["turn_deg"]
    # the recipe before 2026-12-06, whose model is decoder_2026-12-01.npz (benchmarks.md)
    assert _fingerprint(older) == _fingerprint(unturned) == "0fe7330b88b78d73"
    assert _fingerprint(recipe) == "8eab07857d7435de"   # decoder_2026-12-06.npz's (benchmarks.md)
    # the trial of the turned scenes was the default from then
    assert _fingerprint(load_recipe(RECIPES / "turned.toml")) == _fingerprint(recipe)
    # and the default since the forty-sixth session is the trial with twice the 300 m maps,
    # whose run is the shipped model (benchmarks.md)
    assert _fingerprint(load_recipe("default")) == _fingerprint(
        load_recipe(DOCS_DATA / "decoder_trial_maps2w.toml")) == "d932fca1ed95f341"


@pytest.mark.parametrize(("path", "fingerprint", "turn_deg"), [
    (RECIPES / "ensemble.toml", "8bde9713598e5c73", 0),
    (RECIPES / "thesis_mlp_2026-12-06.toml", "4031057be4d60171", 0),
    (RECIPES / "wrobot_noise.toml", "86f818972f337ae1", 0),
    (RECIPES / "wrobot_flight.toml", "e434da5beafeb1b8", 0),
    (DOCS_DATA / "decoder_trial_wd02.toml", "b2809d3f49d0097d", 0),
    (DOCS_DATA / "decoder_trial_e80.toml", "bd4fcb5daf035816", 0),
    (DOCS_DATA / "decoder_trial_fade0.toml", "c9b940d2eb49ed56", 0),
    (DOCS_DATA / "decoder_trial_maps2.toml", "b57fa4cc6b5d5a21", 4)])
def test_recipes_on_the_default_keep_the_fingerprints_of_their_runs(path, fingerprint, turn_deg):
    """They were trained without turned scenes, on the 69 maps of default_2026-12-06.toml (the
    trial of twice the 300 m maps on 125, with turns); neither the default's turn (2026-12-06)
    nor its doubled maps (since the forty-sixth session) must reach them, or their runs could
    not resume and their records would not be theirs."""
    recipe = load_recipe(path)
    assert recipe["data"]["turn_deg"] == turn_deg
    assert _fingerprint(recipe) == fingerprint
