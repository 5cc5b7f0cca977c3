"""2D LiDAR: agreement with a brute-force ray/edge reference, clipping, noise and bad input.

The reference below is written independently of ``windnav.city.lidar``: every ray is tested
against every one of the four edges of every footprint in plain numpy (no slab method, no
broad phase), and the nearest hit within range is kept.
"""

from __future__ import annotations

import numpy as np
import pytest

from windnav.city import City, dense_map, planning_map, training_map


def reference_scan(city, origins, n_rays, max_range):
    """Nearest ray/edge intersection per ray, float64, every ray against every edge."""
    a = 2.0 * np.pi * np.arange(n_rays) / n_rays
    c, s = np.cos(a), np.sin(a)
    # rays along the axes are exact: the tiny residues of cos(pi/2) etc. are zeros
    c[np.abs(c) < 1e-12] = 0.0
    s[np.abs(s) < 1e-12] = 0.0
    fp = city.footprints
    out = np.full((len(origins), n_rays), float(max_range))
    for b, (ox, oy) in enumerate(origins):
        best = np.full(n_rays, np.inf)
        # vertical edges x = const spanning [y0, y1]; horizontal y = const spanning [x0, x1]
        for xe in (fp[:, 0], fp[:, 1]):
            with np.errstate(divide="ignore", invalid="ignore"):
                t = (xe[None, :] - ox) / c[:, None]
            yy = oy + t * s[:, None]
            ok = (c[:, None] != 0) & (t >= 0) & (yy >= fp[:, 2]) & (yy <= fp[:, 3])
            best = np.minimum(best, np.where(ok, t, np.inf).min(axis=1, initial=np.inf))
        for ye in (fp[:, 2], fp[:, 3]):
            with np.errstate(divide="ignore", invalid="ignore"):
                t = (ye[None, :] - oy) / s[:, None]
            xx = ox + t * c[:, None]
            ok = (s[:, None] != 0) & (t >= 0) & (xx >= fp[:, 0]) & (xx <= fp[:, 1])
            best = np.minimum(best, np.where(ok, t, np.inf).min(axis=1, initial=np.inf))
        out[b] = np.minimum(best, max_range)
    return out


def street_origins(city, rng, n):
    x0, x1, y0, y1 = city.bounds
    pts = np.column_stack([rng.uniform(x0, x1, 4 * n), rng.uniform(y0, y1, 4 * n)])
    pts = pts[~city.contains(pts)][:n]
    assert len(pts) == n
    return pts


MAPS = {
    "training300": lambda: training_map(rng=1, size=300.0, n_buildings=10),
    "training500": lambda: training_map(rng=2, size=500.0),
    "planning": lambda: planning_map(rng=3),
    "dense": lambda: dense_map(rng=4),
}


@pytest.mark.parametrize("name", list(MAPS))
@pytest.mark.parametrize("n_rays", [360, 7, 4, 1])
def test_matches_brute_force_on_streets(name, n_rays):
    city = MAPS[name]()
    rng = np.random.default_rng([list(MAPS).index(name), n_rays])
    origins = street_origins(city, rng, 40)
    for max_range in (100.0, 400.0):
        got = city.lidar(origins, n_rays=n_rays, max_range=max_range)
        ref = reference_scan(city, origins, n_rays, max_range)
        assert got.shape == (40, n_rays)
        np.testing.assert_allclose(got, ref, rtol=0, atol=1e-9)
        assert np.any(ref < max_range)  # the scans do see buildings


def test_axis_rays_along_edges_and_through_corners():
    """Origins on the lines of building edges: axis rays run along edges or hit corners."""
    city = planning_map(rng=5)
    fp = city.footprints
    rng = np.random.default_rng(0)
    origins = []
    for x0, x1, y0, y1 in fp[:20]:
        origins += [[x0, y0 - rng.uniform(1, 30)], [x1, y1 + rng.uniform(1, 30)],
                    [x0 - rng.uniform(1, 30), y1], [x1 + rng.uniform(1, 30), y0]]
    origins = np.array(origins)
    origins = origins[~city.contains(origins)]
    assert len(origins) > 40
    for n_rays in (4, 8, 360):
        got = city.lidar(origins, n_rays=n_rays, max_range=200.0)
        ref = reference_scan(city, origins, n_rays, 200.0)
        np.testing.assert_allclose(got, ref, rtol=0, atol=1e-9)


def test_single_box_analytic():
    city = City((0, 100, 0, 100), [[60, 70, 30, 70]], [10])
    scan = city.lidar([50.0, 50.0], n_rays=8, max_range=50.0)
    assert scan.shape == (1, 8)
    expect = np.full(8, 50.0)
    expect[0] = 10.0                      # straight at the face x = 60
    expect[1] = 10.0 * np.sqrt(2.0)       # +-45 deg meet the same face at y = 60 and y = 40
    expect[7] = 10.0 * np.sqrt(2.0)
    np.testing.assert_allclose(scan[0], expect, rtol=0, atol=1e-12)
    # map bounds are not walls: an empty map reads max_range everywhere
    empty = City((0, 100, 0, 100), np.zeros((0, 4)), [])
    np.testing.assert_array_equal(empty.lidar([[1.0, 1.0]], n_rays=16, max_range=30.0), 30.0)


def test_min_range_clip_and_inside_origins():
    city = City((0, 100, 0, 100), [[60, 70, 40, 60]], [10])
    origins = [[58.0, 50.0], [65.0, 50.0], [60.0, 45.0], [70.0, 60.0], [20.0, 50.0]]
    scan = city.lidar(origins, n_rays=4, max_range=50.0, min_range=5.0)
    np.testing.assert_array_equal(scan[0], [5.0, 50.0, 50.0, 50.0])   # 2 m clipped up to 5 m
    # inside, on an edge and on a corner: blocked, every ray reads min_range
    np.testing.assert_array_equal(scan[1:4], 5.0)
    np.testing.assert_array_equal(scan[4], [40.0, 50.0, 50.0, 50.0])
    np.testing.assert_array_equal(city.lidar([65.0, 50.0], n_rays=3), 0.0)


def test_batch_equals_one_by_one():
    city = dense_map(rng=1)
    origins = street_origins(city, np.random.default_rng(2), 25)
    batch = city.lidar(origins, n_rays=90)
    for b, o in enumerate(origins):
        np.testing.assert_array_equal(city.lidar(o, n_rays=90)[0], batch[b])


def test_a_batch_clipped_in_one_pass_equals_scans_clipped_one_by_one():
    """Above 4,096 ranges the clip is np.clip's one pass (a batch's throughput), below it two
    ufuncs (one scan's latency): the same values, bit for bit, clipped at both ends."""
    from windnav.city.lidar import _ONE_PASS

    city = dense_map(rng=1)
    origins = street_origins(city, np.random.default_rng(3), 25)
    batch = city.lidar(origins, n_rays=360, max_range=60.0, min_range=3.0)
    assert batch.size > _ONE_PASS and (batch == 3.0).any() and (batch == 60.0).any()
    for b, o in enumerate(origins):
        np.testing.assert_array_equal(city.lidar(o, n_rays=360, max_range=60.0,
                                                 min_range=3.0)[0], batch[b])


def test_noise_statistics_clip_and_determinism():
    city = dense_map(rng=2)
    origins = street_origins(city, np.random.default_rng(3), 300)
    clean = city.lidar(origins, max_range=100.0)
    noisy = city.lidar(origins, max_range=100.0, noise_std=0.35, rng=np.random.default_rng(9))
    again = city.lidar(origins, max_range=100.0, noise_std=0.35, rng=9)
    np.testing.assert_array_equal(noisy, again)
    # the caller's own draw of the same normals gives the same scan (a deferred scan)
    normals = np.random.default_rng(9).standard_normal(size=clean.shape)
    drawn = city.lidar(origins, max_range=100.0, noise_std=0.35, normals=normals)
    np.testing.assert_array_equal(drawn, noisy)
    assert not np.array_equal(
        city.lidar(origins, max_range=100.0, noise_std=0.35, normals=normals[::-1]), noisy)
    assert noisy.min() >= 0.0 and noisy.max() <= 100.0
    # no return, no noise: rays that hit nothing read max_range exactly
    np.testing.assert_array_equal(noisy[clean == 100.0], 100.0)
    interior = (clean > 2.0) & (clean < 98.0)
    err = (noisy - clean)[interior]
    assert err.size > 10_000
    assert abs(err.mean()) < 4 * 0.35 / np.sqrt(err.size)
    assert abs(err.std() / 0.35 - 1.0) < 0.03


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [
        ({"origins_xy": [[np.nan, 1.0]]}, "origins_xy"),
        ({"origins_xy": [[1.0, 2.0, 3.0]]}, "origins_xy"),
        ({"origins_xy": np.zeros((2, 2, 2))}, "origins_xy"),
        ({"n_rays": 0}, "n_rays"),
        ({"n_rays": 2.5}, "n_rays"),
        ({"n_rays": np.inf}, "n_rays"),  # OverflowError, NaN and None messages without the
        ({"n_rays": np.nan}, "n_rays"),  # name until the 2026-12-05 audit
        ({"n_rays": None}, "n_rays"),
        ({"n_rays": "8"}, "n_rays"),
        ({"max_range": 5.0, "min_range": 5.0}, "max_range"),
        ({"max_range": 1.0, "min_range": 5.0}, "max_range"),
        ({"max_range": np.inf}, "max_range"),
        ({"min_range": -1.0}, "min_range"),
        ({"noise_std": -0.1}, "noise_std"),
        ({"noise_std": 0.1}, "rng"),
        ({"noise_std": 0.1, "rng": "x"}, "rng"),  # SeedSequence's TypeError before
        ({"noise_std": 0.1, "rng": -1}, "rng"),  # "expected non-negative integer" before
        ({"noise_std": 0.1, "normals": np.zeros((1, 359))}, "normals"),
        ({"noise_std": 0.1, "normals": np.full((1, 360), np.nan)}, "normals"),
    ],
)
def test_bad_input_names_the_argument(kwargs, name):
    city = City((0, 100, 0, 100), [[60, 70, 40, 60]], [10])
    args = {"origins_xy": [[10.0, 10.0]], **kwargs}
    with pytest.raises(ValueError, match=f"'{name}'"):
        city.lidar(**args)


def test_origins_hugging_a_face_see_a_half_plane():
    """Just outside a face the box subtends almost pi: the angular cull must keep every ray."""
    city = City((0, 100, 0, 100), [[40, 60, 40, 60]], [10])
    eps = 1e-7
    origins = np.array([[40 - eps, 50.0], [60 + eps, 41.0], [45.0, 40 - eps], [59.0, 60 + eps],
                        [40 - eps, 40 - eps]])
    got = city.lidar(origins, n_rays=360, max_range=100.0)
    ref = reference_scan(city, origins, 360, 100.0)
    np.testing.assert_allclose(got, ref, rtol=0, atol=1e-9)
    # the four face-huggers see the building over (almost) half the scan
    assert np.all(np.sum(got[:4] < 100.0, axis=1) >= 178)


def test_a_positional_rng_still_works_with_a_deprecation_warning():
    """``City.lidar`` is DESIGN's contract: its ``rng`` became keyword-only with a deprecation,
    not a TypeError (thirty-fifth session)."""
    city = City((0.0, 100.0, 0.0, 100.0), np.array([[40.0, 60.0, 40.0, 60.0]]), [10.0])
    origins = np.array([[10.0, 50.0], [90.0, 20.0]])
    want = city.lidar(origins, 90, 50.0, 0.0, 0.3, rng=3)
    with pytest.warns(DeprecationWarning, match=r"City.lidar: pass rng= by keyword"):
        got = city.lidar(origins, 90, 50.0, 0.0, 0.3, 3)
    np.testing.assert_array_equal(got, want)
    with pytest.raises(TypeError, match="multiple values for argument 'rng'"):
        city.lidar(origins, 90, 50.0, 0.0, 0.3, 3, rng=3)
    with pytest.warns(DeprecationWarning, match="lidar_scan: pass rng="):
        from windnav.city.lidar import lidar_scan
        np.testing.assert_array_equal(lidar_scan(city, origins, 90, 50.0, 0.0, 0.3, 3), want)
