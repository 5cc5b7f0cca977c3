"""Decoder metrics against hand-computed values, gradients on linear fields, and the baselines
(outputs, and the shared input validation every predictor uses)."""

from __future__ import annotations

import numpy as np
import pytest

from windnav.predict.baselines import LocalBaseline, UpstreamBaseline, check_inputs
from windnav.predict.dataset import N_RAYS, grid_offsets
from windnav.predict.metrics import (
    central_gradients,
    field_errors,
    improvement,
    pooled_errors,
)


def hand_case():
    """Two samples of 2 x 2 cells; the last cell of each is not free (and would be huge)."""
    true = np.zeros((2, 2, 2, 2))
    pred = np.zeros((2, 2, 2, 2))
    cells = [
        # sample 0, inlet 5 m/s: masked direction keeps |u| >= 0.5
        [((3.0, 4.0), (0.0, 5.0)), ((1.0, 0.0), (0.0, 0.0)), ((0.0, 0.0), (1.0, 1.0)),
         ((0.0, 0.0), (100.0, 100.0))],
        # sample 1, inlet 10 m/s: masked direction keeps |u| >= 1
        [((0.5, 0.0), (-0.5, 0.0)), ((2.0, 0.0), (2.0, 2.0)), ((0.0, -3.0), (0.0, -3.0)),
         ((1.0, 1.0), (-50.0, 0.0))],
    ]
    for b, sample in enumerate(cells):
        for k, (t, p) in enumerate(sample):
            iy, ix = divmod(k, 2)
            true[b, :, iy, ix] = t
            pred[b, :, iy, ix] = p
    free = np.array([[[True, True], [True, False]]] * 2)
    return pred, true, free, np.array([5.0, 10.0])


def test_field_errors_match_hand_computed_values():
    pred, true, free, inlet = hand_case()
    out = field_errors(pred, true, free, inlet, per_sample=True)
    a = np.degrees(np.arccos(0.8))  # (0, 5) against (3, 4)
    speed = [0.0, 1.0, np.sqrt(2.0), 0.0, 2.0 * np.sqrt(2.0) - 2.0, 0.0]
    vector = [np.sqrt(10.0), 1.0, np.sqrt(2.0), 1.0, 2.0, 0.0]
    assert out["speed_error"] == pytest.approx(np.mean(speed))
    assert out["vector_error"] == pytest.approx(np.mean(vector))
    # zero vectors have no direction: out of the mean (cells 2 and 3 of sample 0)
    assert out["direction_error_deg"] == pytest.approx((a + 180.0 + 45.0 + 0.0) / 4)
    # and |u| = 0.5 < 0.1 * 10 m/s leaves the masked mean
    assert out["direction_error_masked_deg"] == pytest.approx((a + 45.0 + 0.0) / 3)
    assert (out["n_free"], out["n_direction"], out["n_direction_masked"]) == (6, 4, 3)
    ps = out["per_sample"]
    np.testing.assert_allclose(ps["speed_error"], [np.mean(speed[:3]), np.mean(speed[3:])])
    np.testing.assert_allclose(ps["direction_error_deg"], [a, 225.0 / 3])
    np.testing.assert_array_equal(ps["n_direction_masked"], [1, 2])
    pooled = pooled_errors(ps)
    for name in ("speed_error", "direction_error_deg", "direction_error_masked_deg",
                 "vector_error", "n_free"):
        assert pooled[name] == pytest.approx(out[name])
    one = pooled_errors(ps, select=[1])
    assert one["direction_error_masked_deg"] == pytest.approx(22.5)
    # a looser mask keeps the slow cell
    loose = field_errors(pred, true, free, inlet, min_speed_fraction=0.0)
    assert loose["direction_error_masked_deg"] == pytest.approx(out["direction_error_deg"])


def test_masked_direction_error_masks_by_the_true_speed_not_the_predicted_one():
    """Inlet 10 m/s, so the mask keeps |u| >= 1 m/s of the truth u. Cell A: slow truth (0.5, 0),
    fast prediction (0, 2), 90 deg: left out. Cell B: fast truth (3, 0), slow prediction
    (-0.3, 0.4), arccos(-0.6) deg: kept. Cells C (0 deg) and D (45 deg): fast both, kept."""
    true = np.zeros((1, 2, 2, 2))
    pred = np.zeros((1, 2, 2, 2))
    cells = [((0.5, 0.0), (0.0, 2.0)), ((3.0, 0.0), (-0.3, 0.4)),
             ((0.0, 2.0), (0.0, 4.0)), ((2.0, 0.0), (2.0, 2.0))]
    for k, (t, p) in enumerate(cells):
        true[0, :, k // 2, k % 2] = t
        pred[0, :, k // 2, k % 2] = p
    out = field_errors(pred, true, np.ones((1, 2, 2), bool), np.array([10.0]))
    b = np.degrees(np.arccos(-0.6))
    assert out["direction_error_deg"] == pytest.approx((90.0 + b + 0.0 + 45.0) / 4)
    assert out["n_direction_masked"] == 3
    assert out["direction_error_masked_deg"] == pytest.approx((b + 0.0 + 45.0) / 3), \
        "the mask must keep cell B (true 3 m/s) and drop cell A (true 0.5 m/s)"


def test_field_errors_of_the_truth_are_zero_and_empty_masks_give_nan():
    rng = np.random.default_rng(0)
    true = rng.normal(size=(3, 2, 5, 5)).astype(np.float32)
    free = rng.random((3, 5, 5)) > 0.3
    out = field_errors(true, true, free, np.full(3, 2.0))
    assert out["speed_error"] == out["vector_error"] == 0.0
    assert out["direction_error_deg"] == pytest.approx(0.0, abs=1e-3)
    none = field_errors(true, true, np.zeros((3, 5, 5), bool), np.full(3, 2.0), per_sample=True)
    assert np.isnan(none["speed_error"]) and none["n_free"] == 0
    assert np.isnan(none["per_sample"]["vector_error"]).all()


def test_field_errors_refuse_bad_input_by_name():
    pred, true, free, inlet = hand_case()
    cases = [
        ("pred", (pred[:, :, :1], true, free, inlet)),
        ("true", (pred[0], true[0], free, inlet)),
        ("free", (pred, true, free.astype(int), inlet)),
        ("free", (pred, true, free[:1], inlet)),
        ("inlet_speed", (pred, true, free, inlet[:1])),
        ("inlet_speed", (pred, true, free, np.array([np.nan, 1.0]))),
        ("pred", (np.where(true == 0, np.nan, pred), true, free, inlet)),
    ]
    for name, args in cases:
        with pytest.raises(ValueError, match=f"'{name}'"):
            field_errors(*args)
    with pytest.raises(ValueError, match="'min_speed_fraction'"):
        field_errors(pred, true, free, inlet, min_speed_fraction=-0.1)


def test_improvement():
    assert improvement(0.77, 1.0) == pytest.approx(0.23)
    assert improvement(2.0, 1.0) == pytest.approx(-1.0)
    np.testing.assert_allclose(improvement([0.5, 0.25], 1.0), [0.5, 0.75])
    with pytest.raises(ValueError, match="'baseline_err'"):
        improvement(0.5, 0.0)
    with pytest.raises(ValueError, match="'model_err'"):
        improvement(np.nan, 1.0)


def test_central_gradients_are_exact_on_a_linear_field():
    o = grid_offsets(7, 0.5)
    gx, gy = np.meshgrid(o, o)  # [iy, ix]
    grads = np.array([[0.3, -0.2, 0.05, 0.7], [-1.0, 0.4, 2.0, 0.0]])
    uv = np.stack([np.stack([1.0 + g[0] * gx + g[1] * gy, -2.0 + g[2] * gx + g[3] * gy])
                   for g in grads])
    np.testing.assert_allclose(central_gradients(uv, 0.5), grads, atol=1e-12)
    with pytest.raises(ValueError, match="'uv'"):
        central_gradients(np.zeros((1, 2, 4, 4)), 1.0)
    with pytest.raises(ValueError, match="'spacing'"):
        central_gradients(uv, 0.0)


# ----------------------------------------------------------------- baselines


def inputs(b=3, seed=0):
    rng = np.random.default_rng(seed)
    return (rng.uniform(0.25, 100.0, (b, N_RAYS)), rng.normal(size=(b, 2)),
            rng.normal(size=(b, 2)))


@pytest.mark.parametrize("cls", [UpstreamBaseline, LocalBaseline])
def test_baselines_predict_uniform_fields(cls):
    scans, w_up, w_robot = inputs()
    model = cls(size=5, spacing=2.0)
    np.testing.assert_array_equal(model.offsets, grid_offsets(5, 2.0))
    out = model.predict(scans, w_up, w_robot)
    assert out.shape == (3, 2, 5, 5) and out.dtype == np.float32
    want = w_up if cls is UpstreamBaseline else w_robot
    np.testing.assert_array_equal(out, np.broadcast_to(
        want.astype(np.float32)[:, :, None, None], out.shape))
    one = model.predict(scans[0], w_up[0], w_robot[0])
    assert one.shape == (1, 2, 5, 5)
    np.testing.assert_array_equal(one[0], out[0])
    assert cls().predict(scans, w_up, w_robot).shape == (3, 2, 25, 25)


def test_local_baseline_errors_vanish_on_a_uniform_field():
    scans, w_up, w_robot = inputs(4)
    truth = LocalBaseline(size=5).predict(scans, w_up, w_robot)
    free = np.ones((4, 5, 5), bool)
    out = field_errors(LocalBaseline(size=5).predict(scans, w_up, w_robot), truth, free,
                       np.hypot(*w_up.T))
    assert out["vector_error"] == 0.0
    assert field_errors(UpstreamBaseline(size=5).predict(scans, w_up, w_robot), truth, free,
                        np.hypot(*w_up.T))["vector_error"] > 0.1


def bad_inputs():
    scans, w_up, w_robot = inputs()
    nan_scan, neg_scan, inf_scan = scans.copy(), scans.copy(), scans.copy()
    nan_scan[1, 7] = np.nan
    neg_scan[2, 3] = -0.1
    inf_scan[0, 0] = np.inf
    return [
        ("scans", (scans[:, :359], w_up, w_robot)),
        ("scans", (scans[:, :, None], w_up, w_robot)),
        ("scans", (nan_scan, w_up, w_robot)),
        ("scans", (neg_scan, w_up, w_robot)),
        ("scans", (inf_scan, w_up, w_robot)),
        ("scans", ("far", w_up, w_robot)),
        ("w_up", (scans, np.where(w_up > 0, np.nan, w_up), w_robot)),
        ("w_up", (scans, w_up[:, :1], w_robot)),
        ("w_up", (scans, w_up[:2], w_robot)),
        ("w_up", (scans, w_up[:1], w_robot)),  # a (2,) wind is used for every scan, (1, 2) not
        ("w_robot", (scans, w_up, np.full((3, 2), np.inf))),
        ("w_robot", (scans, w_up, w_robot[:1])),
        ("w_robot", (scans, w_up, np.zeros((3, 3)))),
    ]


@pytest.mark.parametrize("cls", [UpstreamBaseline, LocalBaseline])
def test_baselines_refuse_bad_input_by_name(cls):
    for name, args in bad_inputs():
        with pytest.raises(ValueError, match=f"'{name}' parameter of {cls.__name__}.predict"):
            cls().predict(*args)
    with pytest.raises(ValueError, match="'size'"):
        cls(size=0)
    with pytest.raises(ValueError, match="'spacing'"):
        cls(spacing=-1.0)


def test_check_inputs_batches_single_samples():
    scans, w_up, w_robot = inputs(1)
    s, u, r = check_inputs(scans[0], w_up[0], w_robot[0], "here")
    assert s.shape == (1, N_RAYS) and u.shape == r.shape == (1, 2)
    assert s.dtype == u.dtype == r.dtype == np.float64
    with pytest.raises(ValueError, match="'scans' parameter of here"):
        check_inputs(scans[0, :10], w_up[0], w_robot[0], "here")


# ------------------------------------------------------------- direction error breakdown


def test_direction_breakdown_sums_to_field_errors_direction_error():
    from windnav.predict import direction_error_breakdown

    rng = np.random.default_rng(3)
    b, h = 40, 9
    true = rng.standard_normal((b, 2, h, h)) * 3.0
    pred = true + rng.standard_normal((b, 2, h, h))
    free = rng.random((b, h, h)) > 0.2
    true[0, :, 0, 0] = 0.0  # a zero vector: no direction, left out by both
    inlet = rng.uniform(2.0, 10.0, b)
    offsets = (np.arange(h) - h // 2) * 1.0
    ref = field_errors(pred, true, free, inlet)
    br = direction_error_breakdown(pred, true, free, inlet, offsets)
    assert br["n_direction"] == ref["n_direction"] == int(br["n"].sum())
    assert br["direction_error_deg"] == pytest.approx(ref["direction_error_deg"], rel=1e-12)
    for axis in ("by_speed", "by_radius"):
        assert np.sum(br[axis]["contribution_deg"]) == pytest.approx(
            ref["direction_error_deg"], rel=1e-12)
        assert np.sum(br[axis]["share"]) == pytest.approx(1.0)


def test_direction_breakdown_puts_each_cell_in_its_speed_and_radius_bin():
    from windnav.predict import direction_error_breakdown

    h = 5
    offsets = np.arange(h) - 2.0
    true = np.zeros((1, 2, h, h))
    true[0, 0] = 10.0            # 1.0 U everywhere at U = 10 m/s
    true[0, 0, 2, 2] = 0.5       # the robot's cell: 0.05 U
    pred = np.zeros_like(true)
    pred[0, 1] = 10.0            # 90 deg off everywhere...
    pred[0, :, 2, 2] = [0.5, 0.0]  # ...but the robot's cell, exact
    free = np.ones((1, h, h), dtype=bool)
    br = direction_error_breakdown(pred, true, free, [10.0], offsets,
                                   speed_edges=(0, 0.1, np.inf), radius_edges=(0, 0.5, np.inf))
    np.testing.assert_array_equal(br["n"], [[1, 0], [0, 24]])
    np.testing.assert_allclose(br["by_speed"]["mean_deg"], [0.0, 90.0], atol=1e-6)
    np.testing.assert_allclose(br["by_radius"]["share"], [1 / 25, 24 / 25])
    assert br["direction_error_deg"] == pytest.approx(90.0 * 24 / 25)


@pytest.mark.parametrize(("kw", "name"), [
    ({"speed_edges": (0.1, 1.0)}, "speed_edges"),
    ({"radius_edges": (0.0, 3.0, 2.0)}, "radius_edges"),
    ({"offsets": np.zeros(4)}, "offsets"),
    ({"inlet_speed": [0.0]}, "inlet_speed"),
])
def test_direction_breakdown_bad_input_names_the_argument(kw, name):
    from windnav.predict import direction_error_breakdown

    h = 5
    args = {"pred": np.ones((1, 2, h, h)), "true": np.ones((1, 2, h, h)),
            "free": np.ones((1, h, h), dtype=bool), "inlet_speed": [5.0],
            "offsets": np.arange(h) - 2.0}
    args.update(kw)
    with pytest.raises(ValueError, match=name):
        direction_error_breakdown(**args)


def test_one_inlet_speed_stands_for_every_sample():
    """A float inlet speed is every sample's (it was refused as shape (), where
    ``Decoder.predict`` takes one ``(2,)`` wind for a batch)."""
    rng = np.random.default_rng(3)
    true = rng.normal(size=(4, 2, 5, 5))
    pred = true + 0.3 * rng.normal(size=true.shape)
    free = np.ones((4, 5, 5), bool)
    a = field_errors(pred, true, free, 2.5)
    b = field_errors(pred, true, free, np.full(4, 2.5))
    assert a == b
    with pytest.raises(ValueError, match="inlet_speed"):
        field_errors(pred, true, free, -1.0)


def test_the_per_cell_direction_error_is_the_metrics_and_blank_where_it_counts_none():
    """The figures computed their own angle with a 1e-18 floor, so a calm cell (|u| = 0) drew
    a 90-deg error that field_errors leaves out: a 3 x 3 field titled 0.0 deg showed a 90-deg
    cell (definitions audit). direction_error_cells is the metric's angle, NaN where none."""
    import pathlib

    from windnav.predict import direction_error_cells, field_errors

    rng = np.random.default_rng(5)
    true = rng.normal(size=(3, 2, 7, 7))
    pred = true + 0.3 * rng.normal(size=true.shape)
    true[0, :, 3, 3] = 0.0                                   # calm air in the truth
    pred[1, :, 2, 4] = 0.0                                   # and in a prediction
    free = rng.random((3, 7, 7)) > 0.2
    cells = direction_error_cells(pred, true, axis=1)
    assert cells.shape == (3, 7, 7)
    assert np.isnan(cells[0, 3, 3]) and np.isnan(cells[1, 2, 4])
    counted = np.where(free, cells, np.nan)
    want = field_errors(pred, true, free, 5.0)
    assert np.nanmean(counted) == pytest.approx(want["direction_error_deg"], rel=1e-12)
    assert np.isfinite(counted).sum() == want["n_direction"]
    one = direction_error_cells(pred[0], true[0])            # components first, as the figures
    assert np.array_equal(np.isnan(one), np.isnan(cells[0]))
    assert np.allclose(one[~np.isnan(one)], cells[0][~np.isnan(one)], rtol=0, atol=0)
    with pytest.raises(ValueError, match="pred"):
        direction_error_cells(pred[0], true[0, :, :3])
    viz = pathlib.Path(__file__).parents[1] / "src" / "windnav" / "viz" / "decoder.py"
    assert "arccos" not in viz.read_text()                   # the figures draw this one
