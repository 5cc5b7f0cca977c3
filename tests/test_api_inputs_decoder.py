"""Bad inputs to the decoder's training, evaluation, studies and provenance functions are
refused up front with a ValueError naming the argument (or the recipe key).

Python API audit, fifty-eighth session: each case below was accepted (a NaN, a zero-width
interval, a negative seed carried into a run) or met a bare error (KeyError, AttributeError,
TypeError, NumPy's or torch's) before; the comment of each test says which.
"""

from __future__ import annotations

import copy
import gzip
import json
import math
import types
from pathlib import Path

import numpy as np
import pytest

import windnav.experiments.decoder_eval as DE
import windnav.experiments.decoder_studies as DS
import windnav.predict.train as T
import windnav.provenance as PV
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
    for bad, match in ((np.zeros((0, 162)), r"shape \(n, 162\) with n >= 1"),
                       (rng.random((50, 7)), r"shape"),
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
    assert tm.init_basis_pca(m, rng.random((1, 162))).shape == (4,)   # one sample: a zero basis


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


# ----------------------------------------------------------------------- decoder_eval


@pytest.fixture(scope="module")
def ev():
    from pathlib import Path

    path = Path(__file__).resolve().parents[1] / "docs" / "data" / "decoder_eval.json"
    return json.loads(path.read_text())


@pytest.mark.parametrize("kwargs, match", [
    ({"group": "foo"}, "'group' parameter"),
    ({"confidence": 0}, "'confidence' parameter"), ({"confidence": 1.5}, "'confidence'"),
    ({"confidence": math.nan}, "'confidence'"), ({"confidence": "x"}, "'confidence'"),
    ({"n_boot": -5}, "'n_boot' parameter"), ({"n_boot": 10**9}, "'n_boot' parameter"),
    ({"n_boot": 2.5}, "'n_boot'"), ({"seed": -1}, "'seed' parameter"),
])
def test_improvement_interval_refuses_bad_settings(ev, kwargs, match):
    # Python API audit, fifty-eighth session: group 'foo' gave {'value': None, 'slots': 0},
    # confidence 0 a zero-width interval, 1.5 and NaN NumPy's quantile error, n_boot -5
    # "negative dimensions", 10**9 a 44.7 GiB MemoryError, seed -1 NumPy's message
    with pytest.raises(ValueError, match=rf"{match}.*improvement_interval"):
        DE.improvement_interval(ev["records"], **kwargs)


def test_improvement_interval_refuses_the_whole_json_and_keeps_its_value(ev):
    # Python API audit, fifty-eighth session: the whole JSON met an AttributeError
    with pytest.raises(ValueError, match=r"'records' parameter of improvement_interval .* "
                                         r"pass its 'records'"):
        DE.improvement_interval(ev)
    with pytest.raises(ValueError, match="one dict per slot"):
        DE.improvement_interval([1, 2])
    got = DE.improvement_interval(ev["records"], group="dense")
    assert got == DE.improvement_interval(iter(ev["records"]), group="dense")
    assert got["slots"] == len(ev["records"])


@pytest.mark.parametrize("call, name", [
    (lambda: DE.inlet_slots(-1, 2, 0), "n_maps"), (lambda: DE.inlet_slots(2.5, 2, 0), "n_maps"),
    (lambda: DE.inlet_slots(2, 0, 0), "n_inlets"), (lambda: DE.inlet_slots(2, 2, -1), "seed"),
    (lambda: DE.slot_rng(-1, 0, 0), "seed"), (lambda: DE.slot_rng(0, -1, 0), "map_index"),
    (lambda: DE.slot_rng(0, 0, "1"), "inlet_index"),
])
def test_inlet_slots_and_slot_rng_name_their_counts_and_seeds(call, name):
    # Python API audit, fifty-eighth session: "negative dimensions", a TypeError and NumPy's
    # seed messages
    with pytest.raises(ValueError, match=rf"'{name}' parameter of (inlet_slots|slot_rng)"):
        call()
    assert DE.inlet_slots(0, 2, 0).shape == (0, 2, 2)


def test_check_point_and_predict_at_name_what_is_no_city_point_or_field(city):
    # Python API audit, fifty-eighth session: None met AttributeError 'bounds', 'ab' NumPy's
    # bare conversion error, a FlowSolution AttributeError 'city'
    with pytest.raises(ValueError, match="'city' parameter of predict_at must be a City"):
        DE.check_point(None, [1, 1])
    with pytest.raises(ValueError, match="'at' parameter of predict_at must be two finite "
                                         "numbers X Y, m. Got 'ab' instead"):
        DE.check_point(city, "ab")
    with pytest.raises(ValueError, match="'field' parameter of predict_at must be a MeanField"):
        DE.predict_at(None, types.SimpleNamespace(city=None), [20, 40])
    np.testing.assert_array_equal(DE.check_point(city, [20, 40]), [20.0, 40.0])


# -------------------------------------------------------------------- decoder_studies


def test_masked_least_squares_refuses_what_it_cannot_solve():
    # Python API audit, fifty-eighth session: a NaN target passed through, a shape mismatch
    # met an einsum error, chunk 0 a range() error, an all-zero mask a LinAlgError
    rng = np.random.default_rng(0)
    b, t, m = rng.normal(size=(10, 3)), rng.normal(size=(4, 10)), np.ones((4, 10))
    ref = DS.masked_least_squares(b, t, m)
    for args, kw, match in (((b, np.full((4, 10), np.nan), m), {}, "'target'.*finite"),
                            ((b, t[:, :7], m), {}, r"'target'.*shape \(B, 10\)"),
                            ((b, t, m[:, :7]), {}, "'mask'.*shape"),
                            ((b, t, m), {"chunk": 0}, "'chunk'"),
                            ((b, t, np.zeros((4, 10))), {}, "'mask'.*full rank"),
                            ((b[0], t, m), {}, "'basis'")):
        with pytest.raises(ValueError, match=match) as raised:
            DS.masked_least_squares(*args, **kw)
        assert "parameter of masked_least_squares" in str(raised.value)
    np.testing.assert_array_equal(DS.masked_least_squares(b, t, m, chunk=1), ref)


def test_gradient_r2_names_its_own_arguments():
    # Python API audit, fifty-eighth session: a NaN prediction gave NaN R^2, a spacing of 0
    # or an even H was named as central_gradients'
    rng = np.random.default_rng(0)
    true = rng.normal(size=(6, 2, 5, 5))
    free = np.ones((6, 5, 5), bool)
    with pytest.raises(ValueError, match="'pred' parameter of gradient_r2 must be finite"):
        DS.gradient_r2(np.full_like(true, np.nan), true, free, 1.0)
    with pytest.raises(ValueError, match="'spacing' parameter of gradient_r2"):
        DS.gradient_r2(true, true, free, 0.0)
    with pytest.raises(ValueError, match="'true' parameter of gradient_r2 must be an array "
                                         "of shape"):
        DS.gradient_r2(true[..., :4, :4], true[..., :4, :4], free[:, :4, :4], 1.0)
    assert DS.gradient_r2(true, true, free, 1.0)["r2"]["du/dx"] == 1.0


def test_area_fraction_and_eigenflow_study_refuse_sizes_and_lengths():
    # Python API audit, fifty-eighth session: a size of -5 gave a fraction > 0, d_max 0 inf;
    # eigenflow_study took no fields to a TypeError from SampleBatch, an even size, and named
    # a spacing of 0 as grid_offsets'
    for kw, name in (({"size": -5}, "size"), ({"size": 25, "d_max": 0}, "d_max"),
                     ({"size": 25, "spacing": -1}, "spacing"), ({"size": []}, "size"),
                     ({"size": "x"}, "size")):
        with pytest.raises(ValueError, match=rf"'{name}' parameter of area_fraction"):
            DS.area_fraction(**kw)
    assert DS.area_fraction(25) == pytest.approx(625 / (math.pi * 100.0**2))
    fields = [object()]  # refused before any sample is drawn
    with pytest.raises(ValueError, match="'fields' parameter of eigenflow_study must be a "
                                         "sequence of at least one MeanField"):
        DS.eigenflow_study([], samples_per_field=10)
    with pytest.raises(ValueError, match="'size' parameter of eigenflow_study must be an odd"):
        DS.eigenflow_study(fields, samples_per_field=10, size=4)
    with pytest.raises(ValueError, match="'spacing' parameter of eigenflow_study"):
        DS.eigenflow_study(fields, samples_per_field=10, spacing=0)


# ------------------------------------------------------------------------- provenance


@pytest.mark.parametrize("doc, match", [
    ({"command": "windnav fly", "arguments": {}, "argv": ["--nope"]},
     r"argv starting with its command's name 'fly'"),
    ({"command": "windnav fly", "arguments": {}, "argv": ["fly", "--nope"]},
     r"no longer parses"),
    ({"command": "windnav fly", "arguments": {"duration": "abc"}}, r"no longer parses"),
])
def test_command_line_parses_the_line_it_gives(doc, match, capsys):
    # Python API audit, fifty-eighth session: 'windnav --nope' and 'windnav fly --duration
    # abc' were given as lines
    with pytest.raises(ValueError, match=match):
        PV.command_line(doc)
    assert PV.command_line({"command": "windnav fly", "arguments": {"duration": 2.0},
                            "argv": ["fly", "--duration", "2"]}) == "windnav fly --duration 2"


def test_command_line_names_a_doc_it_cannot_read(tmp_path):
    # Python API audit, fifty-eighth session: None met pathlib's TypeError, a file of no JSON
    # a JSONDecodeError, a bad .json.gz a BadGzipFile, a JSON list an AttributeError
    (tmp_path / "a.json").write_text("not json")
    (tmp_path / "b.json").write_text("[1, 2]")
    (tmp_path / "c.json.gz").write_bytes(b"not gzip")
    with gzip.open(tmp_path / "d.json.gz", "wt") as f:
        f.write("[]")
    for doc, match in ((None, "must be a result document"), (5, "must be a result document"),
                       (tmp_path / "a.json", "readable JSON result file"),
                       (tmp_path / "b.json", "which holds a list"),
                       (tmp_path / "c.json.gz", "readable JSON result file"),
                       (tmp_path / "d.json.gz", "which holds a list"),
                       (tmp_path / "none.json", "readable JSON result file")):
        with pytest.raises(ValueError, match=rf"'doc' parameter of command_line {match}|"
                                             rf"'doc' parameter of command_line .*{match}"):
            PV.command_line(doc)


def test_resolve_paths_refuses_an_empty_out_dir():
    # Python API audit, fifty-eighth session: '' gave Path('') == '.', the current folder (the
    # command line's --out '' was refused since the session before)
    recipe = T.load_recipe("tiny")
    with pytest.raises(ValueError, match="'out_dir' parameter of resolve_paths must be a path"):
        T.resolve_paths(recipe, out_dir="")
    assert T.resolve_paths(recipe)[0] == Path("runs") / recipe["name"]
