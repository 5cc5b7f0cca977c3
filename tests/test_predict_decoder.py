"""The wind flow decoder's inference (windnav.predict.decoder): NumPy against torch for every
architecture, exact D4 equivariance of ``d4-film``, the model file and its errors, the input
checks, and inference without torch.

The D4 action is checked against geometry nobody here fitted: a map turned by 90 deg (or
mirrored) must give, through ``City.lidar``, the scan the ray permutation predicts.
"""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

from windnav.city import City
from windnav.predict.decoder import (
    ARCHITECTURES,
    FORMAT_VERSION,
    METADATA_KEY,
    Decoder,
    boundary_side,
    canonical_elements,
    canonicalize_field,
    conv_block,
    d4_grid_permutation,
    d4_matrices,
    d4_ring_indices,
    ensemble_decoder,
    load_decoder,
    make_architecture,
    member_weights,
    on_sector_boundary,
    permute_cells,
    save_decoder,
    uncanonicalize,
)

torch = pytest.importorskip("torch")
from windnav.predict import torch_models as tm  # noqa: E402

SMALL = {"thesis-mlp": {"width": 48, "depth": 2},
         "d4-film": {"conv_channels": 4, "embed": 24, "film_hidden": 8, "width": 24,
                     "depth": 2, "modes": 12}}


def random_inputs(b, rng):
    scans = rng.uniform(0.25, 100.0, (b, 360))
    scans[:, rng.integers(0, 360, 40)] = 100.0  # rays that hit nothing
    return scans, rng.normal(0.0, 5.0, (b, 2)), rng.normal(0.0, 3.0, (b, 2))


def random_decoder(name, size=25, seed=0, **hp):
    torch.manual_seed(seed)
    model = tm.build_model(name, size, **{**SMALL[name], **hp})
    with torch.no_grad():  # push the weights off their initial values (the zero FiLM too)
        for p in model.parameters():
            p.add_(0.05 * torch.randn_like(p))
    return model, tm.to_decoder(model)


def transform_scenario(h, scans, w_up, w_robot):
    """The same scene turned by the D4 element h: what the robot sees and the winds."""
    a = d4_matrices()[h]
    return scans[:, d4_ring_indices(360)[h]], w_up @ a.T, w_robot @ a.T


def transform_field(h, field):
    """Field (B, 2, H, H) turned by h: u'(p) = A_h u(A_h^-1 p)."""
    b, _, n, _ = field.shape
    g = np.full(b, h)
    return canonicalize_field(field.reshape(b, 2, -1), g).reshape(b, 2, n, n)


# ------------------------------------------------------------------ NumPy against torch


@pytest.mark.parametrize("name", sorted(ARCHITECTURES))
@pytest.mark.parametrize("size", [25, 6])
def test_numpy_inference_matches_torch_forward(name, size):
    rng = np.random.default_rng(1)
    model, dec = random_decoder(name, size)
    scans, w_up, w_robot = random_inputs(64, rng)
    out = dec.predict(scans, w_up, w_robot)
    f = dec.arch.features(scans.astype(np.float32), w_up.astype(np.float32),
                          w_robot.astype(np.float32))
    with torch.no_grad():
        ref = model(tm.to_tensors(f, name)).numpy()
    ref = dec.arch.world_frame(ref, f)
    assert out.shape == (64, 2, size, size) and out.dtype == np.float32
    scale = np.abs(ref).max()
    np.testing.assert_allclose(out, ref, rtol=0, atol=1e-5 * scale)
    assert dec.n_parameters == sum(p.numel() for p in model.parameters())


@pytest.mark.parametrize("pool, kernel", [(1, 3), (9, 7), (15, 5), (45, 9)])
def test_the_banded_scan_convolution_matches_torch_for_other_pools_and_kernels(pool, kernel):
    """Blocks of 12, 10, 12 and 8 sectors (of 360, 40, 24 and 8; the last block's window,
    16 sectors, wraps around the whole ring of 8) against torch's circular convolution; and
    the dense circulant product that a single sample takes."""
    rng = np.random.default_rng(2)
    model, dec = random_decoder("d4-film", 6, pool=pool, kernel=kernel)
    n = 360 // pool
    assert dec.arch._block == conv_block(n) == {360: 12, 40: 10, 24: 12, 8: 8}[n]
    scans, w_up, w_robot = random_inputs(37, rng)
    out = dec.predict(scans, w_up, w_robot)
    f = dec.arch.features(scans.astype(np.float32), w_up.astype(np.float32),
                          w_robot.astype(np.float32))
    with torch.no_grad():
        ref = dec.arch.world_frame(model(tm.to_tensors(f, "d4-film")).numpy(), f)
    np.testing.assert_allclose(out, ref, rtol=0, atol=1e-5 * np.abs(ref).max())
    # one sample takes the dense circulant product (the recorded flights' arithmetic)
    one = dec.predict(scans[:1], w_up[:1], w_robot[:1])
    np.testing.assert_allclose(one, ref[:1], rtol=0, atol=1e-5 * np.abs(ref).max())


def test_thesis_mlp_has_the_thesis_size():
    arch = make_architecture("thesis-mlp", 25)
    n = sum(int(np.prod(s)) for s in arch.shapes().values())
    assert n == 11_701_474  # 364 -> 3 x 2048 -> 1250: the thesis's 11.7 M


def test_single_sample_is_a_batch_of_one_and_batches_agree():
    rng = np.random.default_rng(2)
    _, dec = random_decoder("d4-film")
    scans, w_up, w_robot = random_inputs(16, rng)
    batch = dec.predict(scans, w_up, w_robot)
    one = dec.predict(scans[3], w_up[3], w_robot[3])
    assert one.shape == (1, 2, 25, 25)
    np.testing.assert_allclose(one[0], batch[3], atol=1e-5 * np.abs(batch).max())
    assert dec.offsets.shape == (25,) and dec.offsets[12] == 0.0 and dec.offsets[-1] == 12.0


def test_a_large_batch_goes_through_in_chunks_with_the_whole_batchs_result():
    from windnav.predict.decoder import PREDICT_CHUNK

    rng = np.random.default_rng(12)
    _, dec = random_decoder("d4-film")
    b = 2 * PREDICT_CHUNK + 37
    scans, w_up, w_robot = (x.astype(np.float32) for x in random_inputs(b, rng))
    got = dec.predict(scans, w_up, w_robot)
    whole = dec.arch.predict(dec.prepared, scans, w_up, w_robot).reshape(got.shape)
    assert got.shape == (b, 2, 25, 25) and got.dtype == np.float32
    np.testing.assert_allclose(got, whole, rtol=0, atol=1e-5 * np.abs(whole).max())
    last = dec.predict(scans[2 * PREDICT_CHUNK:], w_up[2 * PREDICT_CHUNK:],
                       w_robot[2 * PREDICT_CHUNK:])
    # the fields of the whole batch are products grouped by D4 element across the chunks, so
    # the last chunk's rows alone agree with them to float32 rounding, not to the bit
    np.testing.assert_allclose(got[2 * PREDICT_CHUNK:], last, rtol=0,
                               atol=1e-5 * np.abs(last).max())
    # one sample (the onboard stack's call): the network's coefficients, then one product of
    # the row [U a, U, W_robot] with its element's folded basis, built here by hand
    arch, w = dec.arch, dec.prepared
    for k in (5, 6, 7):
        f = arch.features(scans[k:k + 1], w_up[k:k + 1], w_robot[k:k + 1])
        row = np.concatenate([arch.coefficients(w, f)[0] * f["scale"][0], f["scale"],
                              f["w_robot_world"][0]]).astype(np.float32)[None]
        np.testing.assert_array_equal(
            dec.predict(scans[k:k + 1], w_up[k:k + 1], w_robot[k:k + 1]).reshape(1, -1),
            row @ w["basis.folded"][f["g"][0]])


@pytest.mark.parametrize("boundary", ["blend", "average", "floor"])
def test_an_empty_batch_gives_an_empty_field(boundary):
    from windnav.predict import load_decoder

    dec = load_decoder(boundary=boundary)
    for w in (np.zeros((0, 2)), np.array([3.0, 1.0])):
        got = dec.predict(np.zeros((0, 360)), w, w)
        assert got.shape == (0, 2, 25, 25) and got.dtype == np.float32


# ------------------------------------------------------------------------------ D4


def test_permute_cells_is_take_along_axis_with_each_samples_permutation():
    rng = np.random.default_rng(2)
    perms = np.argsort(d4_grid_permutation(5), axis=1)
    g = rng.integers(0, 8, 50)
    g[:3] = 4  # the same element on neighbouring rows, and elements missing are fine
    labels = rng.normal(size=(50, 2, 25)).astype(np.float32)
    labels[0, 0, 3] = -0.0
    free = rng.random((50, 25)) > 0.4
    for a, idx in ((labels, perms[g][:, None, :]), (free, perms[g])):
        want = np.take_along_axis(a, idx, axis=-1)
        got = permute_cells(a, perms, g)
        assert got.dtype == a.dtype
        np.testing.assert_array_equal(got.view(np.uint8), want.view(np.uint8))  # to the bit
    one = permute_cells(labels[:1], perms, np.array([7]))
    np.testing.assert_array_equal(one, labels[:1][:, :, perms[7]])


def test_canonical_element_puts_the_wind_in_the_first_sector():
    rng = np.random.default_rng(3)
    w = rng.normal(size=(4000, 2))
    w[:8] = [[1, 0], [0, 1], [-1, 0], [0, -1], [1, 1], [-1, 1], [-1, -1], [1, -1]]
    g = canonical_elements(w)
    wc = np.einsum("bij,bj->bi", d4_matrices()[g], w)
    angle = np.degrees(np.arctan2(wc[:, 1], wc[:, 0]))
    assert angle.min() >= 0.0 and angle.max() <= 45.0 + 1e-12
    np.testing.assert_allclose(np.hypot(*wc.T), np.hypot(*w.T), rtol=1e-15)


def test_d4_tables_form_the_group_and_match_the_matrices():
    mats = d4_matrices().astype(int)
    rays, perm = d4_ring_indices(360), d4_grid_permutation(5)
    for g in range(8):
        for h in range(8):
            gh = [k for k in range(8) if np.array_equal(mats[k], mats[g] @ mats[h])]
            assert len(gh) == 1
            # composing the permutations composes the elements
            np.testing.assert_array_equal(rays[h][rays[g]], rays[gh[0]])
            np.testing.assert_array_equal(perm[g][perm[h]], perm[gh[0]])
    # the element turning by 90 deg takes the cell at offset (+2, 0) to (0, +2)
    r90 = [k for k in range(8) if np.array_equal(mats[k], [[0, -1], [1, 0]])][0]
    assert perm[r90][2 * 5 + 4] == 4 * 5 + 2


@pytest.mark.parametrize("h", range(8))
def test_the_scan_permutation_is_the_lidar_of_the_turned_map(h):
    """Turn a map about the robot by element h: City.lidar sees the permuted scan."""
    a = d4_matrices()[h].astype(float)
    fp = np.array([[5.0, 15.0, -3.0, 8.0], [-20.0, -12.0, -25.0, 30.0], [2.0, 9.0, 12.0, 40.0]])
    corners = np.stack([fp[:, [0, 2]], fp[:, [1, 3]]], axis=1)  # (M, 2, 2) lower-left, upper-right
    turned = corners @ a.T
    lo, hi = turned.min(axis=1), turned.max(axis=1)
    fp_t = np.column_stack([lo[:, 0], hi[:, 0], lo[:, 1], hi[:, 1]])
    heights = np.full(3, 20.0)
    city = City((-60.0, 60.0, -60.0, 60.0), fp, heights)
    city_t = City((-60.0, 60.0, -60.0, 60.0), fp_t, heights)
    scan = city.lidar(np.zeros((1, 2)), n_rays=360, max_range=100.0)
    scan_t = city_t.lidar(np.zeros((1, 2)), n_rays=360, max_range=100.0)
    np.testing.assert_allclose(scan_t, scan[:, d4_ring_indices(360)[h]], atol=1e-9)


@pytest.mark.parametrize("h", range(8))
def test_d4_film_is_equivariant_exactly(h):
    """Turning the scenario turns the prediction: bit for bit through the reference frame
    change, to float32 rounding through the folded basis of Decoder.predict."""
    rng = np.random.default_rng(10 + h)
    _, dec = random_decoder("d4-film", size=9)
    scans, w_up, w_robot = (x.astype(np.float32) for x in random_inputs(32, rng))
    arch, w = dec.arch, dec.prepared

    def reference(s, a, b):
        f = arch.features(s, a, b)
        return arch.world_frame(arch.network(w, f), f).reshape(-1, 2, 9, 9)

    expected = transform_field(h, reference(scans, w_up, w_robot))
    turned = transform_scenario(h, scans, w_up, w_robot)
    np.testing.assert_array_equal(reference(*turned), expected)
    got = dec.predict(*turned)
    np.testing.assert_allclose(got, expected, rtol=0, atol=2e-6 * np.abs(expected).max())


@pytest.mark.parametrize("factor", [0.37, 2.5])
def test_d4_film_is_homogeneous_in_the_wind_speed(factor):
    """The solver has no velocity scale, so neither has the decoder: scaling both winds
    scales the field."""
    rng = np.random.default_rng(7)
    _, dec = random_decoder("d4-film")
    scans, w_up, w_robot = random_inputs(32, rng)
    w_up[np.hypot(*w_up.T) < 0.5] = 1.0  # stay above speed_floor after scaling
    base = dec.predict(scans, w_up, w_robot)
    np.testing.assert_allclose(dec.predict(scans, factor * w_up, factor * w_robot),
                               factor * base, rtol=0, atol=1e-5 * factor * np.abs(base).max())


def test_frame_changes_are_inverse_and_exact():
    rng = np.random.default_rng(4)
    field = rng.normal(size=(40, 2, 49)).astype(np.float32)
    g = rng.integers(0, 8, 40)
    np.testing.assert_array_equal(uncanonicalize(canonicalize_field(field, g), g), field)
    arch = make_architecture("d4-film", 7)
    f = {"g": g}
    free = rng.random((40, 49)) > 0.3
    lab, fr = arch.model_labels(field, free, f)
    np.testing.assert_array_equal(arch.world_frame(lab, f), field.reshape(40, 2, 7, 7))
    np.testing.assert_array_equal(fr, np.take_along_axis(
        free, np.argsort(d4_grid_permutation(7), axis=1)[g], axis=1))


# ------------------------------------------------------------------------ ensembles


def test_an_ensemble_predicts_the_mean_of_its_members_in_one_pass(tmp_path):
    """The members' modes stacked in one folded basis give the mean of their fields, through
    the reference path (each member's network) and through Decoder.predict, and survive the
    file; the ensemble stays equivariant."""
    rng = np.random.default_rng(21)
    members = [random_decoder("d4-film", size=9, seed=s)[1] for s in (0, 1, 2)]
    ens = ensemble_decoder(members)
    assert ens.hyperparameters["members"] == 3 and ens.size == 9
    assert ens.n_parameters == sum(m.n_parameters for m in members)
    for i, m in enumerate(members):
        assert all(np.array_equal(v, m.weights[k])
                   for k, v in member_weights(ens.weights, i).items())
    scans, w_up, w_robot = (x.astype(np.float32) for x in random_inputs(48, rng))
    mean = np.mean([m.predict(scans, w_up, w_robot) for m in members], axis=0)
    scale = np.abs(mean).max()
    np.testing.assert_allclose(ens.predict(scans, w_up, w_robot), mean, rtol=0,
                               atol=2e-6 * scale)
    f = ens.arch.features(scans, w_up, w_robot)
    ref = ens.arch.world_frame(ens.arch.network(ens.prepared, f), f)
    np.testing.assert_allclose(ref, mean, rtol=0, atol=2e-6 * scale)
    back = load_decoder(save_decoder(ens.weights, ens.metadata, tmp_path / "e.npz"),
                        boundary=ens.boundary)
    np.testing.assert_array_equal(back.predict(scans, w_up, w_robot),
                                  ens.predict(scans, w_up, w_robot))
    turned = transform_scenario(3, scans, w_up, w_robot)
    np.testing.assert_allclose(ens.predict(*turned), transform_field(3, mean), rtol=0,
                               atol=4e-6 * scale)


def test_only_like_single_d4film_members_make_an_ensemble():
    a = random_decoder("d4-film", size=9)[1]
    for bad in ([a], [a, random_decoder("d4-film", size=9, width=16)[1]],
                [a, random_decoder("thesis-mlp", size=9)[1]],
                [a, ensemble_decoder([a, a])], [a, "model.npz"]):
        with pytest.raises(ValueError, match="'decoders' parameter of ensemble_decoder"):
            ensemble_decoder(bad)
    with pytest.raises(ValueError, match="'members' hyperparameter of build_model"):
        tm.build_model("d4-film", 9, members=2)
    with pytest.raises(ValueError, match="'members' hyperparameter of make_architecture"):
        make_architecture("d4-film", 9, members=0)
    # a file whose members are missing a parameter is refused as any other
    ens = ensemble_decoder([a, a])
    weights = {k: v for k, v in ens.weights.items() if k != "member1.coeff.bias"}
    with pytest.raises(ValueError, match="missing \\['member1.coeff.bias'\\]"):
        Decoder(weights, ens.metadata)


# ---------------------------------------------------------------------- model files


def test_save_and_load_round_trip(tmp_path):
    rng = np.random.default_rng(5)
    _, dec = random_decoder("d4-film", size=11)
    path = save_decoder(dec.weights, {**dec.metadata, "metrics": {"speed_error": 0.5}},
                        tmp_path / "m.npz")
    back = load_decoder(path, boundary=dec.boundary)  # the rule is the loader's, not the file's
    args = random_inputs(8, rng)
    np.testing.assert_array_equal(back.predict(*args), dec.predict(*args))
    assert load_decoder(path).boundary == "blend" and dec.boundary == "average"
    assert back.metadata["metrics"] == {"speed_error": 0.5}
    assert back.metadata["version"] == FORMAT_VERSION and back.size == 11
    assert back.n_parameters == dec.n_parameters and "d4-film" in repr(back)


def test_missing_model_file_is_a_value_error_naming_path(tmp_path):
    with pytest.raises(ValueError, match="'path' parameter of load_decoder.*does not exist"):
        load_decoder(tmp_path / "nope.npz")
    with pytest.raises(ValueError, match="'path' parameter of load_decoder.*instead, a folder"):
        load_decoder(tmp_path)


def test_missing_default_model_says_how_to_build_it(monkeypatch, tmp_path):
    import windnav.predict.decoder as decoder

    monkeypatch.setattr(decoder, "DEFAULT_MODEL", tmp_path / "decoder_default.npz")
    with pytest.raises(ValueError, match="'path'.*windnav train-decoder"):
        load_decoder()


@pytest.mark.parametrize("damage", ["garbage", "truncated", "plain_npz", "bad_json",
                                    "wrong_version", "wrong_shape", "nan_weight"])
def test_corrupt_model_file_is_a_value_error_naming_path(tmp_path, damage):
    _, dec = random_decoder("d4-film", size=5)
    path = save_decoder(dec.weights, dec.metadata, tmp_path / "m.npz")
    arrays = dict(np.load(path))
    meta = json.loads(str(arrays[METADATA_KEY]))
    if damage == "garbage":
        path.write_bytes(b"not a zip file at all" * 10)
    elif damage == "truncated":
        path.write_bytes(path.read_bytes()[:300])
    elif damage == "plain_npz":
        np.savez(path, x=np.zeros(3))
    elif damage == "bad_json":
        np.savez(path, **{**arrays, METADATA_KEY: np.array("{not json")})
    elif damage == "wrong_version":
        np.savez(path, **{**arrays, METADATA_KEY: np.array(json.dumps(
            {**meta, "version": FORMAT_VERSION + 1}))})
    elif damage == "wrong_shape":
        np.savez(path, **{**arrays, "coeff.weight": np.zeros((3, 3), np.float32)})
    elif damage == "nan_weight":
        bad = arrays["embed.weight"].copy()
        bad[0, 0] = np.nan
        np.savez(path, **{**arrays, "embed.weight": bad})
    with pytest.raises(ValueError, match="'path' parameter of load_decoder") as info:
        load_decoder(path)
    assert "pickle" not in str(info.value)  # NumPy's advice to load a corrupt file unsafely


# --------------------------------------------------------------------------- inputs


@pytest.mark.parametrize(("bad", "name"), [
    ({"scans": np.full((2, 359), 10.0)}, "scans"),
    ({"scans": np.where(np.arange(360) == 7, np.nan, 10.0)[None].repeat(2, 0)}, "scans"),
    ({"scans": np.where(np.arange(360) == 7, -1.0, 10.0)[None].repeat(2, 0)}, "scans"),
    ({"w_up": np.array([[np.nan, 1.0], [1.0, 1.0]])}, "w_up"),
    ({"w_robot": np.array([[1.0, np.inf], [1.0, 1.0]])}, "w_robot"),
    ({"w_robot": np.ones((3, 2))}, "w_robot"),
    # beyond float32's range: an all-NaN field with only an overflow warning (2026-12-05)
    ({"w_up": np.array([[1e39, 0.0], [1.0, 1.0]])}, "w_up"),
    ({"scans": np.full((2, 360), 10.0 + 1j)}, "scans"),  # the imaginary part was dropped
])
@pytest.mark.parametrize("arch", sorted(ARCHITECTURES))
def test_bad_inputs_raise_value_errors_naming_the_argument(bad, name, arch):
    _, dec = random_decoder(arch, size=5)
    args = {"scans": np.full((2, 360), 10.0), "w_up": np.ones((2, 2)),
            "w_robot": np.ones((2, 2)), **bad}
    with pytest.raises(ValueError, match=f"'{name}' parameter of Decoder.predict"):
        dec.predict(**args)


def test_bad_hyperparameters_are_refused():
    with pytest.raises(ValueError, match="'pool' hyperparameter"):
        make_architecture("d4-film", 25, pool=4)  # sectors not permuted by D4
    with pytest.raises(ValueError, match="'name' parameter"):
        make_architecture("resnet", 25)
    with pytest.raises(ValueError, match="unknown"):
        make_architecture("thesis-mlp", 25, modes=3)
    with pytest.raises(ValueError, match="'width' hyperparameter"):
        make_architecture("thesis-mlp", 25, width=0)
    with pytest.raises(ValueError, match="'metadata' parameter of Decoder"):
        Decoder({}, {"architecture": "nope"})


def test_inference_does_not_import_torch(tmp_path):
    _, dec = random_decoder("d4-film", size=5)
    path = dec.save(tmp_path / "m.npz")
    code = ("import sys, numpy as np\n"
            "import windnav.predict\n"
            "from windnav.predict.decoder import load_decoder\n"
            f"d = load_decoder({str(path)!r})\n"
            "out = d.predict(np.full((3, 360), 20.0), np.ones((3, 2)), np.ones((3, 2)))\n"
            "assert out.shape == (3, 2, 5, 5)\n"
            "assert 'torch' not in sys.modules, 'inference imported torch'\n")
    subprocess.run([sys.executable, "-c", code], check=True)

def test_d4film_features_equal_the_two_step_reference_for_every_element():
    """features() pools the canonical sectors in one gather and keeps the inlet wind's part
    between calls; both give the values of the documented two-step recipe, to the bit."""
    from windnav.predict.decoder import (
        _D4,
        canonical_elements,
        centred_min_pool,
        make_architecture,
        range_channels,
        wind_features,
    )

    arch = make_architecture("d4-film", 9)
    hp = arch.hp
    rng = np.random.default_rng(4)
    b = 64
    scans = rng.uniform(0.3, 120.0, size=(b, hp["n_rays"])).astype(np.float32)
    ang = rng.uniform(0, 2 * np.pi, b)
    ang[:8] = np.radians(np.arange(8) * 45.0)  # sector edges
    w_up = (rng.uniform(0, 10, b)[:, None] * np.c_[np.cos(ang), np.sin(ang)]).astype(np.float32)
    w_up[8] = 0.0
    for _ in range(2):  # the second call reuses the inlet wind's part
        w_robot = rng.normal(scale=4.0, size=(b, 2)).astype(np.float32)
        f = arch.features(scans, w_up, w_robot)
        g = canonical_elements(w_up)
        assert set(g.tolist()) == set(range(8))
        pooled = np.take_along_axis(centred_min_pool(scans, hp["pool"]), arch._bins[g], axis=1)
        w_up_c = np.einsum("bij,bj->bi", _D4[g], w_up)
        w_robot_c = np.einsum("bij,bj->bi", _D4[g], w_robot).astype(np.float32)
        winds, scale = wind_features(w_up_c, w_robot_c, hp["speed_floor"])
        want = {"g": g, "channels": range_channels(pooled, hp["range_scale"], hp["range_min"]),
                "winds": winds, "scale": scale, "w_robot": w_robot_c}
        for k, v in want.items():
            assert f[k].dtype == v.dtype and np.array_equal(f[k], v), k
    f["scale"][:] = -1.0  # callers own what they get
    assert np.all(arch.features(scans, w_up, w_robot)["scale"] > 0)


@pytest.mark.parametrize("h", range(8))
def test_d4_film_is_equivariant_on_the_sector_boundaries_too(h):
    """On a multiple of 45 deg two symmetries take the wind into [0, 45] deg and the network
    answers differently through each: the decoder jumped there (0 and 360 deg differed by
    1.3 m/s; a mirrored scene's field was not the mirrored field; conventions audit,
    2026-12-05). ``boundary="average"`` (the default) takes the mean of the two sides, so the
    symmetry holds there as well; ``"floor"`` keeps the old answer (the benchmark's)."""
    rng = np.random.default_rng(30 + h)
    _, dec = random_decoder("d4-film", size=9)
    scans, _, w_robot = random_inputs(16, rng)
    angles = np.radians(45.0 * rng.integers(0, 9, 16))  # 0, 45, ..., 360 deg
    speed = rng.uniform(1.0, 8.0, 16)
    w_up = speed[:, None] * np.column_stack([np.cos(angles), np.sin(angles)])
    assert dec.boundary == "average" and on_sector_boundary(w_up).all()
    turned = transform_scenario(h, scans, w_up, w_robot)
    got = dec.predict(*turned)
    expected = transform_field(h, dec.predict(scans, w_up, w_robot))
    np.testing.assert_allclose(got, expected, rtol=0, atol=2e-6 * np.abs(expected).max())
    # 0 and 360 deg, whose sines round to 0 and -2e-15, are one direction
    full = w_up.copy()
    full[angles == 0.0] = speed[angles == 0.0, None] * [np.cos(2 * np.pi), np.sin(2 * np.pi)]
    np.testing.assert_allclose(dec.predict(scans, full, w_robot), dec.predict(scans, w_up,
                                                                              w_robot),
                               rtol=0, atol=2e-6 * np.abs(expected).max())
    # the mean of the two sides, each a hair off the boundary
    sides = [dec.predict(scans, boundary_side(w_up, s), w_robot) for s in (1.0, -1.0)]
    np.testing.assert_allclose(dec.predict(scans, w_up, w_robot), 0.5 * (sides[0] + sides[1]),
                               rtol=0, atol=1e-6 * np.abs(expected).max())
    floor = Decoder(dec.weights, dec.metadata, boundary="floor")
    arch, w = floor.arch, floor.prepared
    f = arch.features(*(x.astype(np.float32) for x in (scans, w_up, w_robot)))
    old = floor.predict(scans, w_up, w_robot)  # the sector rounding picks, as before
    reference = arch.world_frame(arch.network(w, f), f).reshape(-1, 2, 9, 9)
    np.testing.assert_allclose(old, reference, rtol=0, atol=2e-6 * np.abs(reference).max())
    assert np.abs(old - dec.predict(scans, w_up, w_robot)).max() > 1e-3


def test_off_the_boundaries_the_two_ways_are_one():
    rng = np.random.default_rng(5)
    _, dec = random_decoder("d4-film", size=9)
    scans, w_up, w_robot = random_inputs(64, rng)
    assert not on_sector_boundary(w_up).any()
    floor = Decoder(dec.weights, dec.metadata, boundary="floor")
    np.testing.assert_array_equal(dec.predict(scans, w_up, w_robot),
                                  floor.predict(scans, w_up, w_robot))
    with pytest.raises(ValueError, match="'boundary' parameter of Decoder"):
        Decoder(dec.weights, dec.metadata, boundary="round")
    with pytest.raises(ValueError, match="'boundary' parameter of load_decoder"):
        load_decoder(boundary="nearest")


def test_the_benchmark_decoder_keeps_the_boundaries_its_flights_met():
    from windnav.experiments.nav_benchmark import benchmark_decoder

    assert benchmark_decoder().boundary == "floor"
    assert load_decoder().boundary == "blend"


def test_expand_is_each_rows_product_with_its_elements_basis_written_or_added():
    """``D4FilmArchitecture.expand``: row i's field is ``aug[i] @ basis.folded[g[i]]`` however
    the rows are grouped (more rows of one element than a chunk); with ``out`` it is added into
    ``out[rows]``, the other rows untouched."""
    from windnav.predict.decoder import PREDICT_CHUNK, D4FilmArchitecture

    rng = np.random.default_rng(4)
    w = {"basis.folded": rng.normal(size=(8, 5, 7)).astype(np.float32)}
    n = PREDICT_CHUNK + 40
    aug = rng.normal(size=(n, 5)).astype(np.float32)
    g = rng.integers(0, 8, n)
    g[:PREDICT_CHUNK + 5] = 3                                # one element over two groups
    want = np.einsum("ik,ikn->in", aug, w["basis.folded"][g])
    got = D4FilmArchitecture.expand(w, aug, g)
    np.testing.assert_allclose(got, want, rtol=1e-5, atol=1e-5)
    np.testing.assert_allclose(D4FilmArchitecture.expand(w, aug, np.full(n, 6)),
                               aug @ w["basis.folded"][6], rtol=1e-5, atol=1e-5)
    out = np.ones((n + 3, 7), dtype=np.float32)
    rows = rng.permutation(n + 3)[:n]
    D4FilmArchitecture.expand(w, aug, g, out=out, rows=rows)
    np.testing.assert_allclose(out[rows], 1.0 + want, rtol=1e-5, atol=1e-5)
    assert (np.delete(out, rows, axis=0) == 1.0).all()
