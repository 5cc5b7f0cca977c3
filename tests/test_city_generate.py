"""Procedural maps: the stated counts, sizes, spacing and containment hold over many seeds,
and a seed fixes the map."""

from __future__ import annotations

import numpy as np
import pytest

from windnav.city import dense_map, planning_map, training_map

SEEDS = range(200)


def _gaps(boxes: np.ndarray) -> np.ndarray:
    """Euclidean distances between every pair of closed rectangles (upper triangle)."""
    gx = np.maximum(0.0, np.maximum(boxes[None, :, 0] - boxes[:, None, 1],
                                    boxes[:, None, 0] - boxes[None, :, 1]))
    gy = np.maximum(0.0, np.maximum(boxes[None, :, 2] - boxes[:, None, 3],
                                    boxes[:, None, 2] - boxes[None, :, 3]))
    d = np.hypot(gx, gy)
    return d[np.triu_indices(len(boxes), 1)]


def _inside(city, margin=0.0) -> bool:
    x0, x1, y0, y1 = city.bounds
    fp = city.footprints
    return bool(np.all(fp[:, 0] >= x0 + margin) and np.all(fp[:, 1] <= x1 - margin)
                and np.all(fp[:, 2] >= y0 + margin) and np.all(fp[:, 3] <= y1 - margin))


def _building_boxes(city) -> np.ndarray:
    labels = city.building_labels()
    fp = city.footprints
    return np.array([[fp[labels == g, 0].min(), fp[labels == g, 1].max(),
                      fp[labels == g, 2].min(), fp[labels == g, 3].max()]
                     for g in range(labels.max() + 1)])


@pytest.mark.parametrize("size", [300.0, 500.0])
def test_training_maps(size):
    counts = []
    for seed in SEEDS:
        city = training_map(rng=np.random.default_rng(seed), size=size)
        counts.append(city.n_buildings)
        assert city.bounds == (0.0, size, 0.0, size)
        assert 1 <= city.n_buildings <= 10
        assert _inside(city, margin=10.0)
        w = city.footprints[:, 1] - city.footprints[:, 0]
        d = city.footprints[:, 3] - city.footprints[:, 2]
        assert np.all((w >= 10.0) & (w <= 80.0) & (d >= 10.0) & (d <= 80.0))
        assert np.all(_gaps(city.footprints) >= 10.0)
        assert np.all((city.heights >= 10.0) & (city.heights <= 60.0))
        # buildings are distinct (no touching blocks)
        assert len(np.unique(city.building_labels())) == city.n_buildings
    assert set(counts) == set(range(1, 11))


def test_training_map_full_count_always_placed():
    for seed in SEEDS:
        city = training_map(rng=seed, size=300.0, n_buildings=10)
        assert city.n_buildings == 10
        assert np.all(_gaps(city.footprints) >= 10.0)


def test_planning_maps():
    counts, blocks_per_building = [], []
    for seed in SEEDS:
        city = planning_map(rng=np.random.default_rng(seed))
        assert city.bounds == (0.0, 600.0, 0.0, 600.0)
        assert _inside(city)
        labels = city.building_labels()
        n = labels.max() + 1
        counts.append(n)
        assert 9 <= n <= 16
        boxes = _building_boxes(city)
        sides = np.concatenate([boxes[:, 1] - boxes[:, 0], boxes[:, 3] - boxes[:, 2]])
        assert np.all((sides >= 10.0) & (sides <= 50.0))
        # alleys between distinct buildings (any block of one to any block of another)
        fp = city.footprints
        diff = labels[:, None] != labels[None, :]
        gx = np.maximum(0.0, np.maximum(fp[None, :, 0] - fp[:, None, 1],
                                        fp[:, None, 0] - fp[None, :, 1]))
        gy = np.maximum(0.0, np.maximum(fp[None, :, 2] - fp[:, None, 3],
                                        fp[:, None, 2] - fp[None, :, 3]))
        assert np.all(np.hypot(gx, gy)[diff] >= 15.0)
        blocks_per_building.extend(np.bincount(labels))
        assert np.all((city.heights >= 10.0) & (city.heights <= 50.0))
    assert set(counts) == set(range(9, 17))
    # buildings are stacked from 1, 2 and 3 cuboids
    assert set(blocks_per_building) == {1, 2, 3}


def test_dense_maps():
    for seed in range(12):
        city = dense_map(rng=seed)
        assert city.bounds == (0.0, 1200.0, 0.0, 1200.0)
        assert city.n_buildings >= 200
        assert _inside(city, margin=5.0)
        assert np.all(_gaps(city.footprints) >= 10.0)
        sides = np.concatenate([city.footprints[:, 1] - city.footprints[:, 0],
                                city.footprints[:, 3] - city.footprints[:, 2]])
        assert np.all((sides >= 15.0) & (sides <= 65.0))


@pytest.mark.parametrize("make", [training_map, planning_map, dense_map])
def test_seed_fixes_the_map(make):
    a, b = make(rng=7), make(rng=np.random.default_rng(7))
    np.testing.assert_array_equal(a.footprints, b.footprints)
    np.testing.assert_array_equal(a.heights, b.heights)
    c = make(rng=8)
    assert c.footprints.shape != a.footprints.shape or not np.array_equal(
        c.footprints, a.footprints)


@pytest.mark.parametrize("make", [training_map, planning_map, dense_map])
def test_generators_take_rng_by_keyword(make):
    """The randomness convention: keyword-only ``rng`` (Generator, int or None); the old
    positional form still gives the same map, with a DeprecationWarning."""
    with pytest.warns(DeprecationWarning, match="rng="):
        old = make(7)
    new = make(rng=7)
    np.testing.assert_array_equal(old.footprints, new.footprints)
    np.testing.assert_array_equal(make(rng=np.random.default_rng(7)).footprints, new.footprints)
    assert make(rng=None).n_buildings >= 1  # fresh entropy
    for bad in ("seed", True, 1.5):
        with pytest.raises(ValueError, match="'rng'"):
            make(rng=bad)


def test_generator_bad_arguments_are_named():
    with pytest.raises(ValueError, match="'n_buildings'"):
        training_map(rng=0, size=60.0, n_buildings=10, side_range=(30.0, 40.0))
    with pytest.raises(ValueError, match="'side_range'"):
        training_map(rng=0, side_range=(50.0, 20.0))
    with pytest.raises(ValueError, match="'max_blocks'"):
        planning_map(rng=0, max_blocks=4)
    with pytest.raises(ValueError, match="'n_buildings'"):
        dense_map(rng=0, n_buildings=300)
    with pytest.raises(ValueError, match="'size'"):
        dense_map(rng=0, size=-1.0)
