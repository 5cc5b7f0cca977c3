"""Decoder samples: fields and their interpolation, robot positions, sample batches, datasets.

The fields are analytic (a linear shear whose x and y coefficients differ, so any swap of x and
y, or of [iy, ix], fails), laid on small maps; one test reads a real sweep store written by the
sweep harness with a stand-in solver whose answer is known in closed form.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from windnav.city import City, training_map
from windnav.flow import FlowSolution, SweepStore
from windnav.predict.dataset import (
    N_RAYS,
    SCAN_MAX,
    SCAN_MIN,
    DecoderDataset,
    MeanField,
    _normals,
    _splitmix64,
    draw_samples,
    field_from_solution,
    fields_from_store,
    grid_offsets,
    robot_positions,
)
from windnav.wind import GriddedWind

# u = 2 + 0.03 x - 0.05 y, v = -1 + 0.07 x + 0.02 y (m/s), zero in buildings
COEF_U = (2.0, 0.03, -0.05)
COEF_V = (-1.0, 0.07, 0.02)


def linear(coef, x, y):
    return coef[0] + coef[1] * x + coef[2] * y


def small_city():
    return City((0.0, 90.0, 0.0, 70.0),
                [[30.0, 41.5, 22.0, 37.0], [55.2, 63.0, 12.0, 19.4]], [10.0, 20.0])


def shear_field(city=None, dx=1.0, w_up=(3.0, 1.0), name="shear"):
    city = small_city() if city is None else city
    x, y = city.grid(dx)
    solid = city.rasterize(x, y)
    xx, yy = np.meshgrid(x, y)
    u = np.where(solid, 0.0, linear(COEF_U, xx, yy))
    v = np.where(solid, 0.0, linear(COEF_V, xx, yy))
    return MeanField(city, x, y, u, v, solid, w_up, name)


def distance_to_buildings(city, p):
    fp = city.footprints
    ex = np.maximum(np.maximum(fp[:, 0] - p[:, :1], p[:, :1] - fp[:, 1]), 0.0)
    ey = np.maximum(np.maximum(fp[:, 2] - p[:, 1:], p[:, 1:] - fp[:, 3]), 0.0)
    return np.hypot(ex, ey).min(axis=1)


# ----------------------------------------------------------------- grid and field


def test_grid_offsets_are_centred_cell_centres():
    np.testing.assert_array_equal(grid_offsets(5, 2.0), [-4.0, -2.0, 0.0, 2.0, 4.0])
    np.testing.assert_array_equal(grid_offsets(4, 1.0), [-1.5, -0.5, 0.5, 1.5])
    assert grid_offsets().shape == (25,) and grid_offsets()[12] == 0.0
    with pytest.raises(ValueError, match="'size'"):
        grid_offsets(0)
    with pytest.raises(ValueError, match="'spacing'"):
        grid_offsets(5, -1.0)


def test_interpolate_reproduces_a_linear_field_and_is_zero_in_buildings_and_outside():
    field = shear_field()
    city = field.city
    p = np.random.default_rng(0).uniform([1.0, 1.0], [89.0, 69.0], size=(4000, 2))
    # a bilinear stencil 1.5 m off every wall holds fluid cells only: exact there
    clear = p[distance_to_buildings(city, p) >= 1.5]
    got = field.interpolate(clear)
    np.testing.assert_allclose(got[:, 0], linear(COEF_U, clear[:, 0], clear[:, 1]), atol=1e-12)
    np.testing.assert_allclose(got[:, 1], linear(COEF_V, clear[:, 0], clear[:, 1]), atol=1e-12)
    inside = p[city.contains(p)]
    assert inside.shape[0] > 50
    np.testing.assert_array_equal(field.interpolate(inside), 0.0)
    outside = np.array([[-0.2, 30.0], [90.1, 30.0], [40.0, -3.0], [45.0, 70.2]])
    np.testing.assert_array_equal(field.interpolate(outside), 0.0)
    assert field.interpolate([10.0, 10.0]).shape == (1, 2)
    # within half a cell of the bounds, in open air: the nearest cell centres' wind, as the
    # flight's GriddedWind reads it; it read 0 m/s there (API audit, thirty-ninth session)
    edge = np.array([[0.2, 30.0], [89.9, 30.0], [40.0, 0.3], [45.0, 69.8], [0.0, 0.0]])
    hull = np.clip(edge, [field.x[0], field.y[0]], [field.x[-1], field.y[-1]])
    np.testing.assert_allclose(field.interpolate(edge), field.interpolate(hull), atol=1e-12)
    assert np.all(np.abs(field.interpolate(edge)) > 0.1)
    flight = GriddedWind(field.x, field.y, field.u, field.v).velocity(
        0.0, np.column_stack([edge, np.zeros(len(edge))]))
    np.testing.assert_allclose(field.interpolate(edge), flight[:, :2], atol=1e-12)


def test_interpolation_is_the_degree_one_spline_and_the_flight_wind():
    """The batched evaluator equals RectBivariateSpline(kx=ky=1).ev (the thesis's interpolant)
    and GriddedWind (the wind the simulated vehicle flies in), off buildings."""
    city = small_city()
    x, y = city.grid(1.0)
    rng = np.random.default_rng(1)
    solid = city.rasterize(x, y)
    u = np.where(solid, 0.0, rng.normal(size=solid.shape))
    v = np.where(solid, 0.0, rng.normal(size=solid.shape))
    field = MeanField(city, x, y, u, v, solid, (1.0, 0.0))
    p = rng.uniform([x[0], y[0]], [x[-1], y[-1]], size=(3000, 2))
    p = p[~city.contains(p)]
    got = field.interpolate(p)
    su, sv = field.splines
    np.testing.assert_allclose(got[:, 0], su.ev(p[:, 0], p[:, 1]), atol=1e-12)
    np.testing.assert_allclose(got[:, 1], sv.ev(p[:, 0], p[:, 1]), atol=1e-12)
    flight = GriddedWind(x, y, u, v).velocity(0.0, np.column_stack([p, np.zeros(len(p))]))
    np.testing.assert_allclose(got, flight[:, :2], atol=1e-12)


def test_mean_field_refuses_bad_input_by_name():
    f = shear_field()
    good = dict(city=f.city, x=f.x, y=f.y, u=f.u, v=f.v, solid=f.solid, w_up=(1.0, 0.0))
    bad = [("city", "not a city"), ("x", f.x[::-1]), ("u", f.u[:, :-1]),
           ("v", np.where(f.solid, np.nan, f.v)), ("solid", f.solid[:-1]), ("w_up", (1.0,)),
           ("w_up", (np.nan, 0.0))]
    for name, value in bad:
        with pytest.raises(ValueError, match=f"'{name}'"):
            MeanField(**{**good, name: value})
    assert not f.u.flags.writeable and f.inlet_speed == pytest.approx(np.hypot(3.0, 1.0))


def test_pockets_the_solver_filled_are_not_free():
    f = shear_field()
    solid = f.solid.copy()
    solid[5:8, 5:8] = True  # a filled pocket around (6, 6) m, outside every footprint
    g = MeanField(f.city, f.x, f.y, np.where(solid, 0.0, f.u), np.where(solid, 0.0, f.v),
                  solid, f.w_up)
    uv, free = g.grid_values([[6.5, 6.5]], grid_offsets(5))
    assert not free[0, 2, 2] and free[0, 0, 0]
    np.testing.assert_array_equal(uv[0][:, ~free[0]], 0.0)
    pos = robot_positions(g, 3000, rng=0, building_reach=60.0)
    assert not np.any((np.abs(pos[:, 0] - 6.0) < 1.0) & (np.abs(pos[:, 1] - 6.0) < 1.0))


# ----------------------------------------------------------------- positions


def test_robot_positions_keep_clearance_reach_and_margin_and_follow_the_seed():
    field = shear_field()
    pos = robot_positions(field, 3000, rng=7, wall_clearance=1.0, building_reach=12.0,
                          edge_margin=5.0)
    assert pos.shape == (3000, 2)
    d = distance_to_buildings(field.city, pos)
    assert d.min() >= 1.0 and d.max() <= 12.0
    assert pos[:, 0].min() >= field.x[0] + 5.0 and pos[:, 0].max() <= field.x[-1] - 5.0
    assert pos[:, 1].min() >= field.y[0] + 5.0 and pos[:, 1].max() <= field.y[-1] - 5.0
    # uniform over the admissible set: both buildings get robots, close and far
    assert (d < 3.0).mean() > 0.05 and (d > 9.0).mean() > 0.05
    np.testing.assert_array_equal(pos, robot_positions(
        field, 3000, rng=np.random.default_rng(7), building_reach=12.0, edge_margin=5.0))
    assert not np.array_equal(pos, robot_positions(field, 3000, rng=8, building_reach=12.0,
                                                   edge_margin=5.0))
    on_city = robot_positions(field.city, 500, rng=1)
    assert distance_to_buildings(field.city, on_city).min() >= 1.0


def test_robot_positions_refuse_maps_without_admissible_area():
    empty = City((0.0, 50.0, 0.0, 50.0), np.zeros((0, 4)), [])
    with pytest.raises(ValueError, match="no buildings"):
        robot_positions(empty, 10, rng=0)
    with pytest.raises(ValueError, match="no admissible area"):
        robot_positions(small_city(), 10, rng=0, building_reach=2.0, edge_margin=35.0)
    walled = City((0.0, 20.0, 0.0, 20.0), [[0.0, 20.0, 0.0, 20.0]], [5.0])
    with pytest.raises(ValueError, match="no admissible area"):
        robot_positions(walled, 10, rng=0)
    with pytest.raises(ValueError, match="'building_reach'"):
        robot_positions(small_city(), 10, rng=0, wall_clearance=5.0, building_reach=4.0)
    with pytest.raises(ValueError, match="'rng'"):
        robot_positions(small_city(), 10, rng="seed")


# ----------------------------------------------------------------- samples


def test_draw_samples_labels_are_the_field_around_the_robot():
    field = shear_field()
    size, spacing = 7, 1.5
    batch = draw_samples(field, 300, rng=3, size=size, spacing=spacing, scan_noise=0.0)
    o = grid_offsets(size, spacing)
    assert batch.labels.shape == (300, 2, size, size) and batch.labels.dtype == np.float32
    assert batch.free.shape == (300, size, size) and batch.free.dtype == bool
    assert batch.scans.dtype == batch.w_up.dtype == batch.w_robot.dtype == np.float32
    assert batch.positions.dtype == np.float64
    # [b, :, iy, ix] is the field at (x + o[ix], y + o[iy]): an asymmetric field catches swaps
    gx = batch.positions[:, None, None, 0] + o[None, None, :]
    gy = batch.positions[:, None, None, 1] + o[None, :, None]
    points = np.stack(np.broadcast_arrays(gx, gy), axis=-1).reshape(-1, 2)
    want = field.interpolate(points).reshape(300, size, size, 2)
    np.testing.assert_allclose(batch.labels[:, 0], want[..., 0], rtol=1e-6, atol=1e-6)
    np.testing.assert_allclose(batch.labels[:, 1], want[..., 1], rtol=1e-6, atol=1e-6)
    np.testing.assert_array_equal(batch.free, ~field.city.contains(points).reshape(300, size,
                                                                                   size))
    assert (~batch.free).any()  # some grids reach into a building, where labels are 0
    np.testing.assert_array_equal(batch.labels.transpose(1, 0, 2, 3)[:, ~batch.free], 0.0)
    # the centre cell is the robot: W_robot without noise
    np.testing.assert_array_equal(batch.labels[:, :, 3, 3], batch.w_robot)
    np.testing.assert_array_equal(batch.w_up, np.tile(np.float32([3.0, 1.0]), (300, 1)))
    np.testing.assert_allclose(batch.inlet_speed, np.hypot(3.0, 1.0), rtol=1e-6)


def test_draw_samples_scans_are_noisy_lidar_at_the_positions():
    field = shear_field()
    batch = draw_samples(field, 400, rng=11)
    clean = field.city.lidar(batch.positions, n_rays=N_RAYS, max_range=SCAN_MAX,
                             min_range=SCAN_MIN)
    assert batch.scans.shape == (400, N_RAYS)
    assert batch.scans.min() >= SCAN_MIN and batch.scans.max() <= SCAN_MAX
    miss = clean == SCAN_MAX
    np.testing.assert_array_equal(batch.scans[miss], SCAN_MAX)  # no return, no noise
    hit = ~miss & (clean > 2.0) & (clean < SCAN_MAX - 2.0)
    err = batch.scans[hit] - clean[hit]
    assert hit.sum() > 10_000
    assert abs(err.mean()) < 0.02 and err.std() == pytest.approx(0.35, rel=0.05)
    # the 360 rays: a building to the east of a robot is seen by ray 0, not by ray 90
    robot = np.array([[25.0, 30.0]])  # 5 m west of the first building, open to the north
    scan = field.city.lidar(robot)
    assert scan[0, 0] == pytest.approx(5.0) and scan[0, 90] == SCAN_MAX


def test_draw_samples_is_deterministic_and_w_robot_noise_has_its_level():
    field = shear_field()
    a = draw_samples(field, 500, rng=5, size=5, w_robot_noise=0.5)
    b = draw_samples(field, 500, rng=np.random.default_rng(5), size=5, w_robot_noise=0.5)
    for x, y in zip(a, b, strict=True):
        np.testing.assert_array_equal(x, y)
    c = draw_samples(field, 500, rng=6, size=5, w_robot_noise=0.5)
    assert not np.array_equal(a.positions, c.positions)
    noise = a.w_robot - a.labels[:, :, 2, 2]
    assert noise.std() == pytest.approx(0.5, rel=0.1) and abs(noise.mean()) < 0.05
    with pytest.raises(ValueError, match="'w_robot_noise'"):
        draw_samples(field, 5, rng=0, w_robot_noise=-1.0)
    with pytest.raises(ValueError, match="'field'"):
        draw_samples(field.city, 5, rng=0)


def test_noise_stream_is_splitmix64():
    # published first outputs of SplitMix64 from state 0 (Vigna's splitmix64.c)
    got = np.empty(4, dtype=np.uint64)
    _splitmix64(np.uint64(0), np.arange(4, dtype=np.uint64), got)
    assert [int(g) for g in got] == [0xE220A8397B1DCDAF, 0x6E789E6AA1B965F4,
                                     0x06C45D188009454F, 0xF88BB8A8724C81EC]
    # sample j's block of m normals: Box-Muller on outputs m j ... m j + m - 1 of the stream
    key, m, j = 12345, 6, np.array([3, 0])
    bits = np.empty(2 * m, dtype=np.uint64)
    _splitmix64(np.uint64(key), (m * j[:, None] + np.arange(m)).astype(np.uint64).ravel(), bits)
    u = ((bits >> np.uint64(11)).astype(float) + 0.5) * 2.0**-53
    u1, u2 = u[0::2], u[1::2]
    r = np.sqrt(-2.0 * np.log(u1))
    want = np.column_stack([r * np.cos(2 * np.pi * u2), r * np.sin(2 * np.pi * u2)])
    np.testing.assert_allclose(_normals(key, j, m), want.reshape(2, m), rtol=1e-13)


# ----------------------------------------------------------------- dataset


def two_fields():
    a = shear_field(name="a")
    city = training_map(rng=4, size=120.0, n_buildings=2, side_range=(10.0, 30.0))
    return [a, shear_field(city, w_up=(0.0, 2.0), name="b")]


def test_dataset_samples_are_fixed_whatever_the_batching():
    fields = two_fields()
    ds = DecoderDataset(fields, 37, seed=3, size=5, w_robot_noise=0.2)
    assert len(ds) == 74
    full = ds.materialize()
    # field f's samples are draw_samples(fields[f], S, rng=default_rng([seed, 0, f]))
    for f in range(2):
        ref = draw_samples(fields[f], 37, rng=np.random.default_rng([3, 0, f]), size=5,
                           w_robot_noise=0.2)
        for x, y in zip(ref, full, strict=True):
            np.testing.assert_array_equal(x, y[37 * f:37 * (f + 1)])
    for epoch, batch_size in ((0, 8), (0, 74), (1, 5), (2, 100)):
        order = ds.indices(epoch)
        assert sorted(order) == list(range(74))  # every sample once
        batches = list(ds.epoch(epoch, batch_size))
        assert [len(b.scans) for b in batches[:-1]] == [batch_size] * (len(batches) - 1)
        got = [np.concatenate(parts) for parts in zip(*batches, strict=True)]
        for x, y in zip(got, full, strict=True):
            np.testing.assert_array_equal(x, y[order])  # bit for bit, any batch size
    assert not np.array_equal(ds.indices(0), ds.indices(1))
    np.testing.assert_array_equal(ds.indices(0), DecoderDataset(fields, 37, seed=3).indices(0))
    plain = np.concatenate([b.positions for b in ds.epoch(0, 10, shuffle=False)])
    np.testing.assert_array_equal(plain, full.positions)
    again = DecoderDataset(fields, 37, seed=3, size=5, w_robot_noise=0.2).samples([70, 2, 40])
    np.testing.assert_array_equal(again.scans, full.scans[[70, 2, 40]])


def test_dataset_on_threads_gives_the_same_samples_bit_for_bit():
    """Fields derived on threads at once (one field object listed three times, as the recipe's
    map weights list it) give the samples of one thread, to the bit, in any order asked."""
    a, b = two_fields()
    fields = [a, b, a, a, b]
    one = DecoderDataset(fields, 29, seed=5, size=7, w_robot_noise=0.1)
    for threads in (2, 3, 8):
        many = DecoderDataset(fields, 29, seed=5, size=7, w_robot_noise=0.1, threads=threads)
        for x, y in zip(one.materialize(), many.materialize(), strict=True):
            np.testing.assert_array_equal(x, y)
        rows = np.random.default_rng(threads).permutation(len(one))[:60]
        for x, y in zip(one.samples(rows), many.samples(rows), strict=True):
            np.testing.assert_array_equal(x, y)
    # the repeats draw their own positions: the same field, other samples
    full = one.materialize()
    assert not np.array_equal(full.positions[:29], full.positions[58:87])


def test_dataset_refuses_bad_arguments():
    fields = two_fields()
    with pytest.raises(ValueError, match="'fields'"):
        DecoderDataset([], 4)
    with pytest.raises(ValueError, match="'samples_per_field'"):
        DecoderDataset(fields, 0)
    for threads in (0, 1.5, True):
        with pytest.raises(ValueError, match="'threads'"):
            DecoderDataset(fields, 4, threads=threads)
    walled = shear_field(City((0.0, 40.0, 0.0, 40.0), [[0.0, 40.0, 0.0, 40.0]], [5.0]),
                         name="walled")
    with pytest.raises(ValueError, match="field 1 \\('walled'\\).*no admissible area"):
        DecoderDataset([fields[0], walled], 4)
    ds = DecoderDataset(fields, 4)
    with pytest.raises(ValueError, match="'indices'"):
        ds.samples([8])
    with pytest.raises(ValueError, match="'batch_size'"):
        next(ds.epoch(0, 0))
    with pytest.raises(ValueError, match="'epoch'"):
        ds.indices(-1)


# ----------------------------------------------------------------- sources


def fake_simulate(city, speed, direction_deg, dx, dt, spinup_steps, steps, record_every):
    """Stand-in solver: the shear field scaled by the inlet speed, rotated to its direction."""
    x, y = city.grid(dx)
    solid = city.rasterize(x, y)
    xx, yy = np.meshgrid(x, y)
    s = speed / 3.0
    u = np.where(solid, 0.0, s * linear(COEF_U, xx, yy) + np.cos(np.deg2rad(direction_deg)))
    v = np.where(solid, 0.0, s * linear(COEF_V, xx, yy))
    return FlowSolution(x, y, solid, u, v, None, None, None, speed, direction_deg, dx, dt)


def test_fields_from_store_reads_every_finished_case_in_order(tmp_path):
    from windnav.experiments.wind_sweep import sweep

    cities = [small_city(), training_map(rng=2, size=60.0, n_buildings=1,
                                         side_range=(10.0, 20.0))]
    settings = {"dx": 1.0, "dt": 0.1, "spinup_steps": 1, "steps": 2, "record_every": 0}
    store, _ = sweep([("m0", "m0.json", cities[0]), ("m1", "m1.json", cities[1])],
                     tmp_path / "s.zarr", speeds=[2.0, 4.0], directions_deg=[0.0, 90.0],
                     settings=settings, backend="serial", progress=False,
                     simulate=fake_simulate)
    store.invalidate([(0, 1)])
    fields = fields_from_store(tmp_path / "s.zarr")
    names = [f.name for f in fields]
    assert names == ["m0/0", "m0/2", "m0/3", "m1/0", "m1/1", "m1/2", "m1/3"]
    assert fields_from_store(SweepStore(tmp_path / "s.zarr"), maps=[1], cases=[3])[0].name \
        == "m1/3"
    for f in fields:
        map_name, case = f.name.split("/")
        k, c = int(map_name[1:]), int(case)
        np.testing.assert_array_equal(f.city.footprints, cities[k].footprints)
        sol = fake_simulate(cities[k], store.speeds[c], store.directions_deg[c], 1.0, 0.1, 1,
                            2, 0)
        np.testing.assert_array_equal(f.u, sol.mean_u)
        np.testing.assert_array_equal(f.v, sol.mean_v)
        a = np.deg2rad(store.directions_deg[c])
        np.testing.assert_allclose(f.w_up, store.speeds[c] * np.array([np.cos(a), np.sin(a)]))
    with pytest.raises(ValueError, match="'maps'"):
        fields_from_store(tmp_path / "s.zarr", maps=[2])


def test_field_from_solution_takes_the_inlet_of_the_solution():
    city = small_city()
    sol = fake_simulate(city, 3.0, 90.0, 1.0, 0.1, 1, 2, 0)
    f = field_from_solution(city, sol, name="x")
    np.testing.assert_allclose(f.w_up, [0.0, 3.0], atol=1e-12)
    np.testing.assert_array_equal(f.u, sol.mean_u)
    assert field_from_solution(city, sol, (1.0, 2.0)).w_up.tolist() == [1.0, 2.0]


def test_robot_positions_fill_the_band_around_a_building_by_area():
    # one 40 m x 20 m building in the middle of a 400 m map; the admissible set (distance to the
    # footprint in [c, r]) is four straight strips along the walls and four quarter annuli at
    # the corners: each part's share of the positions is its share of the area
    x0, x1, y0, y1 = 180.0, 220.0, 190.0, 210.0
    city = City(bounds=(0.0, 400.0, 0.0, 400.0), footprints=[[x0, x1, y0, y1]],
                heights=[20.0])
    c, r, n = 5.0, 30.0, 20000
    pos = robot_positions(city, n, rng=11, wall_clearance=c, building_reach=r)
    x, y = pos[:, 0], pos[:, 1]
    west, east, south, north = x < x0, x > x1, y < y0, y > y1
    mid_x, mid_y = ~west & ~east, ~south & ~north
    strip_x, strip_y = (x1 - x0) * (r - c), (y1 - y0) * (r - c)
    corner = math.pi * (r * r - c * c) / 4
    total = 2 * strip_x + 2 * strip_y + 4 * corner
    parts = {"west": (west & mid_y, strip_y), "east": (east & mid_y, strip_y),
             "south": (south & mid_x, strip_x), "north": (north & mid_x, strip_x),
             "south-west": (west & south, corner), "south-east": (east & south, corner),
             "north-west": (west & north, corner), "north-east": (east & north, corner)}
    for name, (inside, area) in parts.items():
        share = area / total  # binomial standard error <= 0.0035 at n = 20,000
        assert np.mean(inside) == pytest.approx(share, abs=0.015), name


def test_robot_positions_at_zero_clearance_stay_outside_the_buildings():
    """``wall_clearance=0`` admits positions on the street up to the wall but none inside a
    footprint, whose distance is 0 too (audit, 2026-12-05: 923 of 2,000 lay inside)."""
    city = City((0.0, 100.0, 0.0, 100.0), np.array([(30.0, 70.0, 30.0, 70.0)]),
                np.array([20.0]))
    pos = robot_positions(city, 2000, rng=3, wall_clearance=0.0, building_reach=10.0)
    d = distance_to_buildings(city, pos)
    inside = (pos[:, 0] > 30) & (pos[:, 0] < 70) & (pos[:, 1] > 30) & (pos[:, 1] < 70)
    assert not inside.any() and d.min() > 0.0 and d.min() < 0.1
