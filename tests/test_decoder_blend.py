"""``boundary="blend"``: the d4-film's two symmetries blended near a sector boundary, so that the
field is continuous in the inlet direction (windnav.predict.decoder; docs/decoder.md)."""

from __future__ import annotations

import numpy as np
import pytest
from _scripts import load_script

from windnav.predict import load_decoder
from windnav.predict.decoder import (
    _D4,
    BLEND_WIDTH_DEG,
    BOUNDARIES,
    Decoder,
    canonical_elements,
    canonicalize_field,
    centred_min_pool,
    d4_matrices,
    d4_ring_indices,
    range_channels,
    wind_features,
)


@pytest.fixture(scope="module")
def decoders():
    plain = load_decoder(boundary="average")
    return plain, Decoder(plain.weights, plain.metadata, boundary="blend")


def scenes(b, seed=0):
    rng = np.random.default_rng(seed)
    scans = rng.uniform(0.5, 100.0, (b, 360))
    scans[:, rng.integers(0, 360, 60)] = 100.0  # rays that hit nothing
    return scans, rng.normal(0.0, 2.0, (b, 2))


def inlets(directions_deg, speed=6.0):
    a = np.radians(np.asarray(directions_deg, dtype=np.float64))
    return speed * np.column_stack([np.cos(a), np.sin(a)])


def other_side(dec, scans, w_up, w_robot, g):
    """The network's answer through the D4 elements ``g`` (not the inlet's own), built from
    the documented steps (pool, gather the canonical sectors, turn the winds), not through
    ``features``' own ``g``."""
    arch, w = dec.arch, dec.prepared
    hp = arch.hp
    scans, w_up, w_robot = (np.asarray(x, dtype=np.float32) for x in (scans, w_up, w_robot))
    pooled = np.take_along_axis(centred_min_pool(scans, hp["pool"]), arch._bins[g], axis=1)
    w_up_c = np.einsum("bij,bj->bi", _D4[g], w_up)
    w_robot_c = np.einsum("bij,bj->bi", _D4[g], w_robot).astype(np.float32)
    winds, scale = wind_features(w_up_c, w_robot_c, hp["speed_floor"])
    f = {"g": g, "channels": range_channels(pooled, hp["range_scale"], hp["range_min"]),
         "winds": winds, "scale": scale, "w_robot": w_robot_c, "w_robot_world": w_robot}
    return arch.world_frame(arch.network(w, f), f).reshape(-1, 2, dec.size, dec.size)


def test_the_blend_is_continuous_across_each_sector_boundary(decoders):
    """An inlet turned 0.01 deg either way across a multiple of 45 deg changed the field by
    about 2 m/s on average with the other rules; blended, by what the turn itself moves."""
    plain, blend = decoders
    scans, w_robot = scenes(24)
    for edge in range(0, 360, 45):
        fields = {}
        for rule, dec in (("average", plain), ("blend", blend)):
            lo, hi = (dec.predict(scans, inlets(np.full(24, edge + e)), w_robot)
                      for e in (-0.01, 0.01))
            fields[rule] = np.hypot(*(hi - lo).transpose(1, 0, 2, 3)).mean()
        assert fields["average"] > 0.2, edge  # the jump the blend removes
        assert fields["blend"] < 0.02 * fields["average"], (edge, fields)


def test_the_blend_is_the_documented_mix_of_the_two_sides(decoders):
    """Within BLEND_WIDTH_DEG: (1 - w) own + w other, w = (1 - |s| / width) / 2, the other side's
    answer built independently; on a boundary and beyond the width: the default rule's."""
    plain, blend = decoders
    scans, w_robot = scenes(8, seed=1)
    for edge, s in ((45.0, 0.3), (90.0, -2.0), (315.0, 5.5), (0.0, 7.9), (180.0, -7.5)):
        w_up = inlets(np.full(8, edge + s))
        mirrored = inlets(np.full(8, edge - s))
        g = canonical_elements(mirrored)
        assert not np.array_equal(g, canonical_elements(w_up))
        weight = np.float32(0.5 * (1.0 - abs(s) / BLEND_WIDTH_DEG))
        want = ((np.float32(1) - weight) * plain.predict(scans, w_up, w_robot)
                + weight * other_side(plain, scans, w_up, w_robot, g))
        got = blend.predict(scans, w_up, w_robot)
        np.testing.assert_allclose(got, want, rtol=0, atol=2e-5 * np.abs(want).max())
    for direction in (45.0, 0.0, 270.0, 45.0 + BLEND_WIDTH_DEG, 90.0 - BLEND_WIDTH_DEG - 1,
                      22.5, 112.0):  # on a boundary, or at least the width from one
        w_up = inlets(np.full(8, direction))
        np.testing.assert_array_equal(blend.predict(scans, w_up, w_robot),
                                      plain.predict(scans, w_up, w_robot))


def test_a_large_batch_is_blended_row_by_row_as_alone(decoders):
    """Batches of several chunks (PREDICT_CHUNK rows each): near, far and on-boundary rows
    mixed, and a batch whose rows are all near a boundary (one inlet's), each row as when
    predicted alone (a chunk offset in the second passes moved fields by up to 9.5 m/s in a
    review's patch, unseen by batches of one chunk)."""
    from windnav.predict.decoder import PREDICT_CHUNK

    plain, blend = decoders
    n = 2 * PREDICT_CHUNK + 61
    scans, w_robot = scenes(n, seed=6)
    rng = np.random.default_rng(6)
    mixed = 45.0 * rng.integers(0, 8, n) + rng.uniform(-12.0, 12.0, n)
    mixed[::17] = 45.0 * rng.integers(0, 8, mixed[::17].size)  # on a boundary
    for directions in (mixed, np.full(n, 44.0)):
        w_up = inlets(directions, speed=rng.uniform(1.0, 9.0, n)[:, None])
        whole = blend.predict(scans, w_up, w_robot)
        for k in rng.choice(n, 12, replace=False):
            alone = blend.predict(scans[k:k + 1], w_up[k:k + 1], w_robot[k:k + 1])[0]
            np.testing.assert_allclose(whole[k], alone, rtol=0, atol=2e-5 * np.abs(alone).max())
        near = np.abs((directions + 22.5) % 45.0 - 22.5) < BLEND_WIDTH_DEG
        assert near.sum() > PREDICT_CHUNK  # second passes over several chunks


def test_the_turned_views_are_continuous_with_the_blend(decoders):
    """A +-3 deg view of an inlet at 42 or 48 deg crosses the 45 deg boundary: with the blend
    applied in each view (with that view's own weights), the views' field is continuous there
    too."""
    plain, _ = decoders
    views = Decoder(plain.weights, plain.metadata, boundary="blend", rotations_deg=(0, -3, 3))
    average = Decoder(plain.weights, plain.metadata, rotations_deg=(0, -3, 3))
    scans, w_robot = scenes(24, seed=7)
    for direction in (42.0, 48.0, 45.0, 87.0):
        jumps = {}
        for name, dec in (("blend", views), ("average", average)):
            lo, hi = (dec.predict(scans, inlets(np.full(24, direction + e)), w_robot)
                      for e in (-0.01, 0.01))
            jumps[name] = np.hypot(*(hi - lo).transpose(1, 0, 2, 3)).mean()
        assert jumps["average"] > 0.2, (direction, jumps)
        assert jumps["blend"] < 0.02 * jumps["average"], (direction, jumps)


@pytest.mark.parametrize("h", range(8))
def test_the_blend_keeps_the_square_symmetry(decoders, h):
    """The blend's weights depend on the distance from a boundary, which the square's eight
    symmetries keep: the blended field of a turned or mirrored scene is the turned field."""
    _, blend = decoders
    scans, w_robot = scenes(16, seed=2 + h)
    rng = np.random.default_rng(40 + h)
    w_up = inlets(45.0 * rng.integers(0, 8, 16) + rng.uniform(-9.0, 9.0, 16),
                  speed=rng.uniform(1.0, 9.0, 16)[:, None])
    a = d4_matrices()[h]
    got = blend.predict(scans[:, d4_ring_indices(360)[h]], w_up @ a.T, w_robot @ a.T)
    field = blend.predict(scans, w_up, w_robot)
    want = canonicalize_field(field.reshape(16, 2, -1), np.full(16, h)).reshape(field.shape)
    np.testing.assert_allclose(got, want, rtol=0, atol=2e-5 * np.abs(want).max())


def test_the_option_is_the_trial_it_was_chosen_by(decoders):
    """docs/data/decoder_fold_blend.py (the held-out trial that chose the width) at the
    chosen width predicts what ``boundary="blend"`` predicts, to float32 rounding (the option
    computes both answers in one batch and blends as ``a + w (b - a)``)."""
    plain, blend = decoders
    trial = load_script("docs/data/decoder_fold_blend.py")
    fold = trial.FoldBlend(plain.weights, plain.metadata)
    fold.delta = BLEND_WIDTH_DEG
    scans, w_robot = scenes(40, seed=3)
    w_up = inlets(np.random.default_rng(3).uniform(0.0, 360.0, 40))
    w_up[:8] = inlets([44.9, 45.0, 0.1, 359.0, 91.0, 130.0, 222.0, 3.0])
    want = fold.predict(scans, w_up, w_robot)
    np.testing.assert_allclose(blend.predict(scans, w_up, w_robot), want, rtol=0,
                               atol=1e-5 * np.abs(want).max())


def test_the_blend_in_views_the_thesis_mlp_and_its_name(decoders):
    plain, blend = decoders
    assert "blend" in BOUNDARIES and blend.fingerprint() != plain.fingerprint()
    scans, w_robot = scenes(6, seed=4)
    w_up = inlets([44.0, 46.5, 1.0, 100.0, 200.0, 316.0])
    views = Decoder(plain.weights, plain.metadata, boundary="blend", rotations_deg=(0, -3, 3))
    one = [Decoder(plain.weights, plain.metadata, boundary="blend", rotations_deg=(a,))
           for a in (0, -3, 3)]
    np.testing.assert_allclose(views.predict(scans, w_up, w_robot),
                               sum(d.predict(scans, w_up, w_robot) for d in one) / 3,
                               rtol=0, atol=1e-5)
    # the thesis MLP has no symmetry to blend: the same answer under every rule
    from windnav.predict.decoder import make_architecture

    arch = make_architecture("thesis-mlp", 5, width=16, depth=2)
    rng = np.random.default_rng(5)
    weights = {k: (0.1 * rng.standard_normal(v)).astype(np.float32)
               for k, v in arch.shapes().items()}
    meta = {"architecture": "thesis-mlp", "hyperparameters": dict(arch.hp)}
    mlp, mlp_blend = (Decoder(weights, meta, boundary=b) for b in ("average", "blend"))
    np.testing.assert_array_equal(mlp.predict(scans, w_up, w_robot),
                                  mlp_blend.predict(scans, w_up, w_robot))


def test_the_commands_take_the_rule(tmp_path):
    """``--boundary`` of predict and evaluate-decoder loads the decoder with it, its choices
    are the library's rules, and another is refused by argparse."""
    import windnav.cli as cli
    from windnav.commands._common import load_model

    parser = cli.build_parser()
    for command in ("predict", "evaluate-decoder"):
        base = ([command, "--map", "m.json", "--at", "1", "2", "--speed", "5",
                 "--direction-deg", "0", "--out", str(tmp_path)] if command == "predict"
                else [command, "--out", str(tmp_path)])
        args = parser.parse_args(base + ["--boundary", "blend"])
        args.model = None
        assert load_model(args, command).boundary == "blend"
        assert parser.parse_args(base).boundary == "blend"
        with pytest.raises(SystemExit):
            parser.parse_args(base + ["--boundary", "round"])
    action = next(a for a in cli.build_parser()._subparsers._group_actions[0].choices[
        "predict"]._actions if a.dest == "boundary")
    assert set(action.choices) == set(BOUNDARIES)
