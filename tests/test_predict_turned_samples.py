"""Training scenes turned about the robot (``turn_deg``): the sample of the turned world.

The references are built apart from the code under test: the world turned by a quarter turn
as arrays (a city, a solver field) in their own right, sampled by the unturned path; and the
field read point by point through :meth:`MeanField.interpolate` and ``City.contains``.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

import windnav.predict.dataset as ds
from windnav.city import City
from windnav.predict.dataset import (
    N_RAYS,
    DecoderDataset,
    MeanField,
    draw_samples,
    grid_offsets,
    turn_angles,
)

sys.path.insert(0, str(Path(__file__).resolve().parent))
from test_predict_dataset import shear_field  # noqa: E402


def quarter_turned(field: MeanField) -> MeanField:
    """``field``'s world turned 90 deg counter-clockwise about the origin: ``(x, y) -> (-y,
    x)``, every vector turned with it, built as arrays."""
    city = field.city
    x0, x1, y0, y1 = (float(b) for b in city.bounds)
    fp = city.footprints
    turned_city = City((-y1, -y0, x0, x1),
                       np.column_stack([-fp[:, 3], -fp[:, 2], fp[:, 0], fp[:, 1]]),
                       city.heights)
    # the new array's [j, i] is the world's point (x_j, y_(ny-1-i)): a[::-1].T
    u2, v2 = -field.v[::-1].T, field.u[::-1].T  # R u, R = [[0, -1], [1, 0]]
    return MeanField(turned_city, -field.y[::-1], field.x, u2, v2, field.solid[::-1].T,
                     (-field.w_up[1], field.w_up[0]), field.name + "-turned")


def test_a_zero_turn_is_the_unturned_grid_to_the_bit():
    field = shear_field()
    o = grid_offsets(9, 1.5)
    c = draw_samples(field, 200, rng=2, size=9, spacing=1.5).positions
    for dtype in (np.float32, np.float64):
        want, want_free = field.grid_values(c, o, dtype=dtype)
        got, free = field.turned_grid_values(c, o, np.zeros(200), dtype=dtype)
        assert got.dtype == dtype
        np.testing.assert_array_equal(got, want)
        np.testing.assert_array_equal(free, want_free)
    assert (~want_free).any()  # some cells in a building


def test_a_quarter_turn_is_the_sample_of_the_turned_world(monkeypatch):
    """Every scene turned by 90 deg (the angle forced): scan, winds, labels and free cells
    are those the unturned path draws in the world turned as arrays, at the turned robot."""
    field = shear_field()
    turned = quarter_turned(field)
    size, spacing, n = 7, 1.5, 300
    monkeypatch.setattr(ds, "turn_angles", lambda key, index, turn_deg: np.full(
        np.size(index), 90, dtype=np.int64))
    got = draw_samples(field, n, rng=5, size=size, spacing=spacing, scan_noise=0.0,
                       turn_deg=1)
    at = np.column_stack([-got.positions[:, 1], got.positions[:, 0]])
    want = ds._samples(turned, at, 0, np.arange(n), grid_offsets(size, spacing), 0.0, 0.0)
    np.testing.assert_allclose(got.scans, want.scans, atol=1e-4)
    np.testing.assert_allclose(got.w_up, want.w_up, atol=1e-6)
    np.testing.assert_allclose(got.w_robot, want.w_robot, atol=1e-5)
    np.testing.assert_array_equal(got.free, want.free)
    assert (~got.free).any()
    np.testing.assert_allclose(got.labels, want.labels, atol=1e-5)
    np.testing.assert_array_equal(got.positions, draw_samples(
        field, n, rng=5, size=size, spacing=spacing, scan_noise=0.0, turn_deg=1).positions)


@pytest.mark.parametrize("turn_deg", [1, 4, 30])
def test_turned_samples_are_the_field_read_where_the_turn_carries_each_cell(turn_deg):
    field = shear_field()
    size, spacing, n = 7, 1.5, 250
    o = grid_offsets(size, spacing)
    plain = draw_samples(field, n, rng=7, size=size, spacing=spacing, scan_noise=0.0,
                         turn_deg=turn_deg)
    # the angles: the ray shift of the scan against the clean scan at the robot
    clean = field.city.lidar(plain.positions, n_rays=N_RAYS, max_range=ds.SCAN_MAX,
                             min_range=0.0).clip(ds.SCAN_MIN, ds.SCAN_MAX).astype(np.float32)
    angles = np.empty(n, dtype=np.int64)
    for b in range(n):
        shifts = [s for s in range(-turn_deg, turn_deg + 1)
                  if np.array_equal(np.roll(clean[b], s), plain.scans[b])]
        assert shifts, b
        angles[b] = shifts[0]
    if turn_deg > 1:
        assert len(np.unique(angles)) > 2  # a scan that is not round tells its angle
    a = np.radians(angles)
    cos, sin = np.cos(a), np.sin(a)
    # each cell o of the turned world is the world's point c + R^T o, its vector turned by R
    ox, oy = np.meshgrid(o, o)
    px = plain.positions[:, 0, None, None] + cos[:, None, None] * ox + sin[:, None, None] * oy
    py = plain.positions[:, 1, None, None] - sin[:, None, None] * ox + cos[:, None, None] * oy
    pts = np.column_stack([px.ravel(), py.ravel()])
    uv = field.interpolate(pts).reshape(n, size, size, 2)
    want_u = cos[:, None, None] * uv[..., 0] - sin[:, None, None] * uv[..., 1]
    want_v = sin[:, None, None] * uv[..., 0] + cos[:, None, None] * uv[..., 1]
    free = ~field.city.contains(pts).reshape(n, size, size)
    np.testing.assert_array_equal(plain.free, free)
    np.testing.assert_allclose(plain.labels[:, 0], np.where(free, want_u, 0), atol=1e-5)
    np.testing.assert_allclose(plain.labels[:, 1], np.where(free, want_v, 0), atol=1e-5)
    turn = np.stack([np.stack([cos, -sin], -1), np.stack([sin, cos], -1)], 1)
    w_robot = np.einsum("bij,bj->bi", turn, field.interpolate(plain.positions))
    np.testing.assert_allclose(plain.w_robot, w_robot, atol=1e-5)
    np.testing.assert_allclose(plain.w_up, np.einsum("bij,j->bi", turn, field.w_up), atol=1e-5)
    # the centre cell is the robot, turned as W_robot is
    np.testing.assert_allclose(plain.labels[:, :, 3, 3], plain.w_robot, atol=1e-5)


def test_turn_angles_are_uniform_whole_degrees_and_a_function_of_key_and_index():
    idx = np.arange(40_000)
    a = turn_angles(123, idx, 4)
    assert a.dtype == np.int64 and a.min() == -4 and a.max() == 4
    counts = np.bincount(a + 4)
    expected = idx.size / 9
    assert np.all(np.abs(counts - expected) < 5 * np.sqrt(expected))
    np.testing.assert_array_equal(turn_angles(123, idx[::-7], 4), a[::-7])
    assert not np.array_equal(turn_angles(124, idx, 4), a)
    # a pair of neighbouring samples is not correlated
    assert abs(np.corrcoef(a[:-1], a[1:])[0, 1]) < 0.02


def test_a_dataset_of_turned_samples_is_draw_samples_and_keeps_the_noise_stream():
    fields = [shear_field(), shear_field(w_up=(-2.0, 2.5), name="other")]
    data = DecoderDataset(fields, 64, seed=3, size=7, spacing=1.5, turn_deg=5, threads=2)
    got = data.samples(np.arange(64, 128)[::-1])
    want = draw_samples(fields[1], 64, rng=np.random.default_rng([3, 0, 1]), size=7,
                        spacing=1.5, turn_deg=5)
    for g, w in zip(got, want, strict=True):
        np.testing.assert_array_equal(g, w[::-1])
    # the turn changes the positions' margin, not the noise: the unturned set differs
    plain = DecoderDataset(fields, 64, seed=3, size=7, spacing=1.5)
    assert not np.array_equal(plain.samples(np.arange(64)).positions,
                              data.samples(np.arange(64)).positions)


@pytest.mark.parametrize("bad", [True, 4.0, -1, 46, "4", None])
def test_a_bad_turn_is_refused_by_name(bad):
    field = shear_field()
    with pytest.raises(ValueError, match="'turn_deg' parameter of draw_samples"):
        draw_samples(field, 4, rng=0, turn_deg=bad)
    with pytest.raises(ValueError, match="'turn_deg' parameter of DecoderDataset"):
        DecoderDataset([field], 4, turn_deg=bad)


def test_turned_grid_values_refuses_a_wrong_count_of_angles():
    field = shear_field()
    with pytest.raises(ValueError, match="'angles_deg' parameter of MeanField.turned_grid"):
        field.turned_grid_values([[20.0, 20.0], [30.0, 50.0]], grid_offsets(5), [1.0])
    with pytest.raises(ValueError, match="'angles_deg'"):
        field.turned_grid_values([[20.0, 20.0]], grid_offsets(5), [np.nan])


def test_a_turned_grid_keeps_pockets_the_hull_and_wall_cells_out():
    """Cells in a pocket the solver filled, beyond the solver grid, or exactly on a wall are
    not free in a turned grid either (the quarter turn of a field with a pocket, checked
    against the unturned grid of the world turned as arrays)."""
    f = shear_field()
    solid = f.solid.copy()
    solid[5:8, 5:8] = True  # a filled pocket around (6, 6) m, outside every footprint
    g = MeanField(f.city, f.x, f.y, np.where(solid, 0.0, f.u), np.where(solid, 0.0, f.v),
                  solid, f.w_up)
    o = grid_offsets(9)
    # robots near the pocket and near the grid's corner (cells beyond the hull); off the
    # half-cells, where the pocket's nearest cell is a tie that the quarter turn's
    # cos(90 deg) = 6e-17 can break either way
    c = np.array([[6.3, 9.2], [3.3, 3.2], [86.3, 66.2]])
    got, free = g.turned_grid_values(c, o, np.full(3, 90.0))
    turned = quarter_turned(g)
    want, want_free = turned.grid_values(np.column_stack([-c[:, 1], c[:, 0]]), o)
    np.testing.assert_array_equal(free, want_free)
    assert not free[0].all() and not free[1].all() and not free[2].all()
    np.testing.assert_allclose(got, want, atol=1e-12)
    # a cell exactly on a wall (the footprint's edge x = 30 m) is in the building
    at, free = g.turned_grid_values([[26.0, 30.0]], grid_offsets(9), [0.0])
    assert not free[0, 4, 8]  # offset (+4, 0): the point (30, 30)


def test_the_largest_turn_is_taken_and_bad_offsets_are_refused():
    field = shear_field()
    batch = draw_samples(field, 50, rng=4, size=5, scan_noise=0.0, turn_deg=45)
    assert batch.labels.shape == (50, 2, 5, 5) and batch.w_up.flags.c_contiguous
    assert draw_samples(field, 3, rng=4, size=5).w_up.flags.c_contiguous
    for bad in ([[-1.0, 0.0, 1.0]] * 2, [1.0, 0.0, -1.0], [np.nan, 0.0, 1.0], []):
        with pytest.raises(ValueError, match="'offsets' parameter of MeanField.turned_grid"):
            field.turned_grid_values([[20.0, 20.0]], bad, [1.0])
