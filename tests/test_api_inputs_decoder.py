"""Bad inputs to the decoder's training, evaluation, studies and provenance functions are
refused up front with a ValueError naming the argument (or the recipe key).

Python API audit, fifty-eighth session: each case below was accepted (a NaN, a zero-width
interval, a negative seed carried into a run) or met a bare error (KeyError, AttributeError,
TypeError, NumPy's or torch's) before; the comment of each test says which.
"""

from __future__ import annotations

import copy
import math

import numpy as np
import pytest

import windnav.predict.train as T
from windnav.predict.envelope import training_envelope


@pytest.fixture(scope="module")
def base():
    r = T.load_recipe("default")
    r.pop("source")
    return r


def _with(base: dict, section: str, **changes) -> dict:
    r = copy.deepcopy(base)
    r[section].update(changes)
    return r


# ------------------------------------------------------------------------ recipes (train)


@pytest.mark.parametrize("section, key, value, named", [
    ("data", "scan_noise", -1, "data.scan_noise"),
    ("data", "scan_noise", math.inf, "data.scan_noise"),
    ("data", "wall_clearance", -1, "data.wall_clearance"),
    ("data", "building_reach", 0, "data.building_reach"),
    ("data", "spacing", 0, "data.spacing"),
    ("data", "w_robot_noise", -0.1, "data.w_robot_noise"),
    ("data", "seed", -1, "data.seed"), ("train", "seed", -1, "train.seed"),
    ("sweep", "seed", -1, "sweep.seed"), ("sweep", "speeds", [5, 5], "sweep.speeds"),
    ("sweep", "settings", {"dx": -1}, "sweep.settings.dx"),
    ("sweep", "settings", {"foo": 1}, "sweep.settings"),
    ("sweep", "settings", [1], "sweep.settings"),
    ("sweep", "settings", {"dt": 0}, "sweep.settings.dt"),
    ("sweep", "settings", {"steps": 0}, "sweep.settings.steps"),
    ("sweep", "settings", {"spinup_steps": -1}, "sweep.settings.spinup_steps"),
    ("sweep", "settings", {"steps": 10, "record_every": 20}, "sweep.settings.record_every"),
    ("data", "size", 403, "data.size"), ("train", "pca_samples", 1, "train.pca_samples"),
])
def test_a_recipe_refuses_bad_sampling_and_sweep_keys_naming_them(base, section, key, value,
                                                                    named):
    # Python API audit, fifty-eighth session: each was accepted as a checked recipe and
    # refused (or simulated twice) only after the sweep, by the dataset, NumPy or the solver
    with pytest.raises(ValueError, match=rf"'config' parameter of load_recipe must have "
                                         rf"{named.replace('.', '[.]')} "):
        T.load_recipe(_with(base, section, **{key: value}))


def test_a_recipe_refusals_name_the_recipe_key_and_the_shape(base):
    # Python API audit, fifty-eighth session: an empty sweep.maps was said to be a bad
    # data.map_weights, maps = 5 met "'int' object is not iterable", architecture 'foo' was
    # named as make_architecture's 'name', and None or 5 met pathlib's TypeError
    with pytest.raises(ValueError, match=r"data.map_weights \{\} when sweep.maps is empty"):
        T.load_recipe(_with(base, "sweep", maps=[]))
    with pytest.raises(ValueError, match=r"must have sweep.maps a list of map groups"):
        T.load_recipe({"sweep": {"maps": 5}, "data": {"validation_maps": ["a-0"]}})
    with pytest.raises(ValueError, match=r"must have model.architecture one of"):
        T.load_recipe(_with(base, "model", architecture="foo"))
    with pytest.raises(ValueError, match=r"must have model.hyperparameters a table"):
        T.load_recipe(_with(base, "model", hyperparameters=5))
    for bad in (None, 5):
        with pytest.raises(ValueError, match=r"'config' parameter of load_recipe must be a "
                                             r"recipe \(a dict\)"):
            T.load_recipe(bad)


def test_every_shipped_recipe_still_loads_with_its_fingerprint():
    # the recipe check grew: the shipped recipes load as before, without warnings
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        prints = {name: T._fingerprint(T.load_recipe(name)) for name in T.shipped_recipes()}
    assert prints["default"] == "d932fca1ed95f341"
    assert prints["tiny"] == "37a71724a7db94a1"
    assert prints["ensemble"] == "8bde9713598e5c73"


@pytest.mark.parametrize("decay, step, name", [
    (1.5, 1, "decay"), (-1, 1, "decay"), (math.nan, 1, "decay"), (True, 1, "decay"),
    ("0.9", 1, "decay"), (0.9, -10, "step"), (0.9, 0, "step"), (0.9, 1.5, "step"),
])
def test_ema_decay_at_refuses_a_decay_outside_0_1_and_a_step_below_1(decay, step, name):
    # Python API audit, fifty-eighth session: 1.5, -1 and NaN were returned as decays, step
    # -10 divided by zero
    with pytest.raises(ValueError, match=rf"'{name}' parameter of ema_decay_at"):
        T.ema_decay_at(decay, step)
    assert T.ema_decay_at(0.999, 1) == pytest.approx(2 / 11)
    assert T.ema_decay_at(0.0, 3) == 0.0


def test_member_recipe_resolve_paths_and_recipe_toml_refuse_what_is_no_recipe(base):
    # Python API audit, fifty-eighth session: -1 and 99 of 3 members were accepted, {} met
    # KeyError 'train' (member_recipe) or 'name' (resolve_paths), '1' a TypeError, [1] an
    # AttributeError (recipe_toml)
    r = _with(base, "train", members=3)
    for i in (-1, 3, 99, "1", 1.0, True):
        with pytest.raises(ValueError, match=r"'i' parameter of member_recipe must be a "
                                             r"member of the recipe: an integer in \[0, 3\)"):
            T.member_recipe(r, i)
    assert T.member_recipe(r, np.int64(2))["train"]["seed"] == base["train"]["seed"] + 2
    with pytest.raises(ValueError, match="'recipe' parameter of member_recipe"):
        T.member_recipe({}, 0)
    with pytest.raises(ValueError, match="'recipe' parameter of resolve_paths"):
        T.resolve_paths({})
    with pytest.raises(ValueError, match="'recipe' parameter of recipe_toml"):
        T.recipe_toml([1])


def test_train_decoder_names_a_missing_store_before_making_the_out_folder(tmp_path):
    # Python API audit, fifty-eighth session: "SweepStore: there is no Zarr store ..." named
    # no argument, after the out folder was made
    out = tmp_path / "out"
    with pytest.raises(ValueError, match=r"'store' parameter of train_decoder must be a "
                                         r"sweep store .* which does not exist"):
        T.train_decoder("tiny", store=tmp_path / "nonexistent.zarr", out_dir=out,
                        progress=False, log=None)
    with pytest.raises(ValueError, match=r"train_decoder: there is no sweep store at .*pass "
                                         r"'store'"):
        T.train_decoder("tiny", out_dir=out, progress=False, log=None)
    assert not out.exists()


# ------------------------------------------------------------------------- torch models


def test_build_model_takes_a_window_within_the_recipe_limit():
    # Python API audit, fifty-eighth session: 100001 asked torch for 163 TB (an even size is
    # left: the NumPy architecture takes it, and tests/test_predict_decoder.py compares the
    # two on a grid of 6)
    tm = pytest.importorskip("windnav.predict.torch_models")
    for size in (0, 402, 100001, 9.5, "9"):
        with pytest.raises(ValueError, match="'size' parameter of build_model"):
            tm.build_model("d4-film", size)
    with pytest.raises(ValueError, match="'architecture' parameter of build_model"):
        tm.build_model("foo", 9)


def test_init_basis_pca_refuses_residuals_it_cannot_decompose():
    # Python API audit, fifty-eighth session: no rows set the bias to NaN with only warnings,
    # 7 columns met a torch RuntimeError, NaN a LinAlgError, a thesis-mlp KeyError 'modes'
    torch = pytest.importorskip("torch")
    from windnav.predict import torch_models as tm

    m = tm.build_model("d4-film", 9, conv_channels=2, embed=8, film_hidden=4, width=8,
                       depth=1, modes=4)
    before = {k: v.clone() for k, v in m.state_dict().items()}
    rng = np.random.default_rng(0)
    nan = rng.normal(size=(20, 162))
    nan[3, 5] = np.nan
    for bad, match in ((np.zeros((0, 162)), r"shape \(n, 162\) with n >= 2"),
                       (np.zeros((1, 162)), r"n >= 2"), (rng.random((50, 7)), r"shape"),
                       (nan, "finite"), ("abc", "an array of numbers")):
        with pytest.raises(ValueError, match=rf"'residuals' parameter of init_basis_pca.*"
                                             rf"{match}"):
            tm.init_basis_pca(m, bad)
    assert all(torch.equal(v, m.state_dict()[k]) for k, v in before.items())
    mlp = tm.build_model("thesis-mlp", 9, width=8, depth=1)
    with pytest.raises(ValueError, match="'model' parameter of init_basis_pca must be a "
                                         "d4-film"):
        tm.init_basis_pca(mlp, rng.random((5, 162)))
    assert tm.init_basis_pca(m, rng.random((30, 162))).shape == (4,)


def test_to_tensors_to_decoder_and_export_weights_name_their_arguments():
    # Python API audit, fifty-eighth session: {} met KeyError 'channels', an unknown
    # architecture a KeyError, 'abc' NumPy's message, a Linear or a dict an AttributeError,
    # a spacing of -1 was named as grid_offsets'
    torch = pytest.importorskip("torch")
    from windnav.predict import torch_models as tm

    with pytest.raises(ValueError, match=r"'features' parameter of to_tensors must be a dict "
                                         r"holding \['channels'"):
        tm.to_tensors({}, "d4-film")
    with pytest.raises(ValueError, match="'architecture' parameter of to_tensors"):
        tm.to_tensors({"x": np.zeros((1, 3))}, "foo")
    with pytest.raises(ValueError, match="'features' parameter of to_tensors must hold arrays "
                                         "of numbers. Got 'abc' at 'x'"):
        tm.to_tensors({"x": "abc"}, "thesis-mlp")
    assert tm.to_tensors({"x": np.zeros((1, 3))}, "thesis-mlp")["x"].dtype == torch.float32
    with pytest.raises(ValueError, match="'model' parameter of to_decoder must be a torch "
                                         "module made by build_model"):
        tm.to_decoder(torch.nn.Linear(2, 2))
    with pytest.raises(ValueError, match="'model' parameter of export_weights"):
        tm.export_weights({})
    m = tm.build_model("thesis-mlp", 5, width=4, depth=1)
    with pytest.raises(ValueError, match=r"'metadata' parameter of to_decoder must have "
                                         r"spacing a finite number > 0, m. Got -1 instead"):
        tm.to_decoder(m, {"spacing": -1})
    with pytest.raises(ValueError, match="'metadata' parameter of to_decoder"):
        tm.to_decoder(m, [1])
    assert tm.to_decoder(m, {"spacing": 2.0}).spacing == 2.0


def test_training_envelope_refuses_a_path_and_a_recipe_of_no_tables():
    # Python API audit, fifty-eighth session: a file name met AttributeError 'get', a data
    # list a TypeError from dict()
    with pytest.raises(ValueError, match=r"'decoder_or_metadata' parameter of "
                                         r"training_envelope must be a Decoder or its metadata.*"
                                         r"load_decoder"):
        training_envelope("decoder.npz")
    for key in ("data", "sweep"):
        with pytest.raises(ValueError, match=rf"recipe whose '{key}' is a table"):
            training_envelope({"recipe": {key: [1, 2]}})
    assert training_envelope(None)["source"] == "defaults"
    assert training_envelope({})["source"] == "defaults"
