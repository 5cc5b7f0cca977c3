"""City maps: RotorPy world JSON round trip, validation, rasterisation and grids.

Real maps used (copied into tests/data/, see its README.md):
- ``rotorpy/2d_vortex_shedding.json``: spencerfolk/rotorpy @ 9b760b89,
  ``rotorpy/worlds/2d_vortex_shedding.json`` (MIT) -- a bluff body of 5 touching blocks.
- ``windinet/example_layout.json``: Weihao-Li-2001/windinet @ 2de913ee,
  ``examples/inverse_optimization/example_layout.json`` (Apache-2.0) -- 1100 m, 52 buildings.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from windnav.city import City, dense_map, planning_map, training_map

DATA = Path(__file__).parent / "data"
VORTEX = DATA / "2d_vortex_shedding.json"
LAYOUT = DATA / "example_layout.json"
REAL_MAPS = [VORTEX, LAYOUT]


# ------------------------------------------------------------------ RotorPy JSON
@pytest.mark.parametrize("path", REAL_MAPS, ids=lambda p: p.name)
def test_real_map_round_trip_is_lossless(path, tmp_path):
    city = City.from_rotorpy_json(path)
    out = city.to_rotorpy_json(tmp_path / "out.json")
    original = json.loads(path.read_text())
    assert json.loads(out.read_text()) == original
    # and a second generation is byte-identical to the first
    again = City.from_rotorpy_json(out).to_rotorpy_json(tmp_path / "again.json")
    assert again.read_text() == out.read_text()


def test_layout_file_contents():
    city = City.from_rotorpy_json(LAYOUT)
    doc = json.loads(LAYOUT.read_text())
    assert city.bounds == (0.0, 1100.0, 0.0, 1100.0)
    assert city.z_bounds == (0.0, 15.0)
    assert city.n_buildings == 52
    ext = np.array([b["extents"] for b in doc["blocks"]])
    np.testing.assert_array_equal(city.footprints, ext[:, :4])
    np.testing.assert_array_equal(city.base_z + city.heights, ext[:, 5])
    assert city.block_attrs[0] == {"color": [0.28, 0.01, 0.61], "trainable": False}


def test_vortex_bluff_body_is_one_building():
    city = City.from_rotorpy_json(VORTEX)
    assert city.n_buildings == 5
    # the five blocks touch edge to edge: one connected bluff body
    assert np.all(city.building_labels() == 0)
    np.testing.assert_array_equal(city.base_z, -0.5)
    np.testing.assert_array_equal(city.heights, 10.5)


def test_generated_map_round_trips_and_loads_in_rotorpy(tmp_path):
    from rotorpy.world import World  # the reference reader

    city = planning_map(rng=3)
    path = city.to_rotorpy_json(tmp_path / "plan.json")
    back = City.from_rotorpy_json(path)
    np.testing.assert_array_equal(back.footprints, city.footprints)
    np.testing.assert_array_equal(back.heights, city.heights)
    world = World.from_file(str(path)).world
    ext = np.array([b["extents"] for b in world["blocks"]])
    np.testing.assert_array_equal(ext[:, :4], city.footprints)
    np.testing.assert_array_equal(ext[:, 5] - ext[:, 4], city.heights)
    np.testing.assert_array_equal(world["bounds"]["extents"][:4], city.bounds)


def _write(tmp_path, text) -> Path:
    p = tmp_path / "bad.json"
    p.write_text(text if isinstance(text, str) else json.dumps(text))
    return p


GOOD_BOUNDS = {"extents": [0, 100, 0, 100, 0, 20]}


@pytest.mark.parametrize(
    ("doc", "words"),
    [
        ('{"bounds": {"extents": [0, 1', "not valid JSON"),
        ([1, 2], "top level"),
        ({"blocks": []}, "'bounds'"),
        ({"bounds": {"extents": [0, 1, 0, 1]}, "blocks": []}, "'bounds.extents'"),
        ({"bounds": {"extents": [0, 1, 0, 1, 0, "a"]}, "blocks": []}, "'bounds.extents'"),
        ({"bounds": {"extents": [5, 1, 0, 1, 0, 1]}, "blocks": []}, "min < max"),
        ({"bounds": GOOD_BOUNDS}, "'blocks'"),
        ({"bounds": GOOD_BOUNDS, "blocks": [{"color": [0, 0, 0]}]}, "block 0"),
        ({"bounds": GOOD_BOUNDS,
          "blocks": [{"extents": [1, 2, 1, 2, 0, 5]}, {"extents": [1, 2, 1, 2, 0, None]}]},
         "block 1 'extents'"),
        ({"bounds": GOOD_BOUNDS,
          "blocks": [{"extents": [1, 2, 1, 2, 0, 5]}, {"extents": [3, 3, 1, 2, 0, 5]}]},
         "block 1 'extents' [3, 3, 1, 2, 0, 5] must have min < max"),
        ({"bounds": GOOD_BOUNDS,
          "blocks": [{"extents": [1, 2, 1, 2, 0, 5]}, {"extents": [90, 120, 1, 2, 0, 5]}]},
         "block 1 with extents [90.0, 120.0, 1.0, 2.0, 0.0, 5.0] must lie inside"),
        ({"bounds": GOOD_BOUNDS, "blocks": [{"extents": [1, 2, 1, 2, 0, 25]}]},
         "block 0 with extents [1.0, 2.0, 1.0, 2.0, 0.0, 25.0] must lie inside"),
    ],
)
def test_malformed_json_names_file_and_problem(tmp_path, doc, words):
    path = _write(tmp_path, doc)
    with pytest.raises(ValueError) as info:
        City.from_rotorpy_json(path)
    msg = str(info.value)
    assert str(path) in msg
    assert words in msg


def test_missing_file_raises_file_not_found(tmp_path):
    with pytest.raises(FileNotFoundError, match="nope.json' does not exist"):
        City.from_rotorpy_json(tmp_path / "nope.json")


def test_a_folder_or_a_binary_file_is_a_value_error_naming_it(tmp_path):
    with pytest.raises(ValueError, match="is a folder, not a JSON file"):
        City.from_rotorpy_json(tmp_path)  # IsADirectoryError before
    binary = tmp_path / "map.json"
    binary.write_bytes(b"\xff\xfe\x00garbage")
    with pytest.raises(ValueError, match="map.json' is not UTF-8 text"):
        City.from_rotorpy_json(binary)  # a UnicodeDecodeError without the file before


def test_overlapping_blocks_form_a_union(tmp_path):
    doc = {"bounds": GOOD_BOUNDS, "blocks": [
        {"extents": [10, 30, 10, 20, 0, 5]}, {"extents": [20, 25, 15, 40, 0, 9]},
        {"extents": [60, 70, 60, 70, 0, 5]}]}
    city = City.from_rotorpy_json(_write(tmp_path, doc))
    np.testing.assert_array_equal(city.building_labels(), [0, 0, 1])
    x, y = city.grid(1.0)
    mask = city.rasterize(x, y)
    # area of the union: 20*10 + 5*25 - 5*5 overlap, plus 10*10 (cells of 1 m, centres inside)
    assert mask.sum() == 20 * 10 + 5 * 25 - 5 * 5 + 10 * 10


# ------------------------------------------------------------------ City validation
@pytest.mark.parametrize(
    ("footprints", "heights", "words"),
    [
        ([[0, 10, 0, 10], [5, 5, 0, 10]], [1, 1], "block 1 with extents [5.0, 5.0, 0.0, 10.0"),
        ([[0, 10, 0, 10]], [0.0], "positive size"),
        ([[-1, 10, 0, 10]], [1], "block 0 with extents [-1.0, 10.0"),
        ([[0, 10, 0, 101]], [1], "inside the map bounds"),
        ([[0, np.nan, 0, 10]], [1], "must be finite"),
    ],
)
def test_city_rejects_bad_blocks_by_index_and_extents(footprints, heights, words):
    with pytest.raises(ValueError) as info:
        City((0, 100, 0, 100), footprints, heights)
    assert words in str(info.value)


def test_city_rejects_bad_bounds_and_shapes():
    with pytest.raises(ValueError, match="'bounds'"):
        City((0, 0, 0, 1), np.zeros((0, 4)), [])
    with pytest.raises(ValueError, match="'heights'"):
        City((0, 10, 0, 10), [[1, 2, 1, 2]], [1, 2])
    with pytest.raises(ValueError, match="'footprints'"):
        City((0, 10, 0, 10), [[1, 2, 1]], [1])


def test_empty_city_is_valid():
    city = City((0, 10, 0, 10), np.zeros((0, 4)), [])
    assert city.n_buildings == 0
    assert not city.rasterize(*city.grid(1.0)).any()


# ------------------------------------------------------------------ grids and rasterisation
def test_bad_block_attrs_and_a_grid_too_fine_are_named():
    with pytest.raises(ValueError, match="'block_attrs' parameter of City must be a sequence "
                                         "of dicts"):
        City((0, 10, 0, 10), [[1, 2, 1, 2]], [5], block_attrs=[1])  # a TypeError before
    city = City((0, 600, 0, 600), np.zeros((0, 4)), np.zeros(0))
    with pytest.raises(ValueError, match="'dx' parameter of grid_shape must give at most"):
        city.grid(1e-9)  # a MemoryError after trying to allocate 298 GiB before
    assert city.grid(0.1)[0].size == 6000
    from windnav.city import grid_shape
    for bad in (0.0, -1.0, np.nan):  # a recipe's dx = 0 was a ZeroDivisionError
        with pytest.raises(ValueError, match="'dx' parameter of grid_shape"):
            grid_shape((0, 10, 0, 10), bad)


def test_grid_cell_centres():
    city = City((-5.0, 25.0, 10.0, 30.0), [[0, 1, 11, 12]], [3])
    x, y = city.grid(0.1)
    assert x.shape == (300,) and y.shape == (200,)
    np.testing.assert_allclose(np.diff(x), 0.1, rtol=0, atol=1e-12)
    assert x[0] == pytest.approx(-4.95) and x[-1] == pytest.approx(24.95)
    # a non-multiple extent gets one extra cell reaching past the bound
    x, y = city.grid(7.0)
    assert x.size == 5 and y.size == 3
    with pytest.raises(ValueError, match="'dx'"):
        city.grid(0.0)


def _raster_reference(city, x, y):
    """Cell centres tested against each closed footprint, one cell at a time."""
    mask = np.zeros((y.size, x.size), dtype=bool)
    for j, yc in enumerate(y):
        for i, xc in enumerate(x):
            mask[j, i] = any(x0 <= xc <= x1 and y0 <= yc <= y1
                             for x0, x1, y0, y1 in city.footprints)
    return mask


@pytest.mark.parametrize("seed", range(4))
def test_rasterize_matches_per_cell_reference(seed):
    rng = np.random.default_rng(seed)
    # edges on multiples of 3 m land exactly on half of the 6 m cell centres (3 + 6 k)
    lo = rng.integers(0, 90, size=(12, 2)) * 3.0
    ext = rng.integers(1, 10, size=(12, 2)) * 3.0
    fp = np.column_stack([lo[:, 0], lo[:, 0] + ext[:, 0], lo[:, 1], lo[:, 1] + ext[:, 1]])
    city = City((0.0, 300.0, 0.0, 300.0), fp, np.ones(12))
    x, y = city.grid(6.0)
    ref = _raster_reference(city, x, y)
    np.testing.assert_array_equal(city.rasterize(x, y), ref)
    # decreasing coordinates take the comparison path and agree too
    np.testing.assert_array_equal(city.rasterize(x[::-1], y)[:, ::-1], ref)


def test_rasterize_dense_map_matches_comparisons_and_area():
    city = dense_map(rng=0)
    x, y = city.grid(1.0)
    mask = city.rasterize(x, y)
    assert mask.shape == (1200, 1200)
    full = np.zeros_like(mask)
    for x0, x1, y0, y1 in city.footprints:
        full |= ((y >= y0) & (y <= y1))[:, None] & ((x >= x0) & (x <= x1))[None, :]
    np.testing.assert_array_equal(mask, full)
    # buildings do not overlap, so the solid area approaches the footprint area
    area = np.sum((city.footprints[:, 1] - city.footprints[:, 0])
                  * (city.footprints[:, 3] - city.footprints[:, 2]))
    assert abs(mask.sum() - area) / area < 0.05


def test_contains_closed_footprints():
    city = City((0, 10, 0, 10), [[2, 4, 2, 4]], [1])
    pts = [[3, 3], [2, 3], [4, 4], [4.0000001, 3], [1, 1]]
    np.testing.assert_array_equal(city.contains(pts), [True, True, True, False, False])


# ------------------------------------------------------------------ coarse grids (issue 13)
def _overlap_reference(city, x, y, dx):
    """A cell [x - dx/2, x + dx/2] x [...] is solid when it overlaps a footprint with area."""
    mask = np.zeros((y.size, x.size), dtype=bool)
    for j, yc in enumerate(y):
        for i, xc in enumerate(x):
            mask[j, i] = any(min(xc + dx / 2, x1) > max(xc - dx / 2, x0)
                             and min(yc + dx / 2, y1) > max(yc - dx / 2, y0)
                             for x0, x1, y0, y1 in city.footprints)
    return mask


@pytest.mark.parametrize("dx", [0.7, 3.0, 6.0, 25.0])
def test_overlap_rasterisation_is_conservative(dx):
    rng = np.random.default_rng(1)
    lo = rng.uniform(0, 180, size=(10, 2))
    ext = rng.uniform(0.1, 20, size=(10, 2))
    fp = np.column_stack([lo[:, 0], lo[:, 0] + ext[:, 0], lo[:, 1], lo[:, 1] + ext[:, 1]])
    city = City((0.0, 200.0, 0.0, 200.0), fp, np.ones(10))
    x, y = city.grid(dx)
    over = city.rasterize(x, y, rule="overlap")
    np.testing.assert_array_equal(over, _overlap_reference(city, x, y, dx))
    assert np.all(over >= city.rasterize(x, y))  # contains the centre rule
    # every block leaves at least one solid cell, however thin
    for k in range(10):
        one = City(city.bounds, fp[k:k + 1], [1.0])
        assert one.rasterize(x, y, rule="overlap").any()
    with pytest.raises(ValueError, match="'rule'"):
        city.rasterize(x, y, rule="nearest")


def test_overlap_rule_on_footprint_edges_that_are_cell_edges():
    """Whole-metre buildings on a 1 m grid (the usual case): a cell that only touches the
    footprint along an edge (zero overlap area) stays free, on every side. [10, 20] x [10, 20]
    covers exactly the 10 x 10 cells centred at 10.5 ... 19.5."""
    city = City((0.0, 30.0, 0.0, 30.0), [[10.0, 20.0, 10.0, 20.0]], [5.0])
    x, y = city.grid(1.0)
    over = city.rasterize(x, y, rule="overlap")
    inside_x, inside_y = (x > 10.0) & (x < 20.0), (y > 10.0) & (y < 20.0)
    assert over.sum() == 100, f"{over.sum()} cells marked, expected 100"
    np.testing.assert_array_equal(over, inside_y[:, None] & inside_x[None, :])
    np.testing.assert_array_equal(over, _overlap_reference(city, x, y, 1.0))


def test_a_thin_wall_cannot_vanish_from_the_flow():
    """Issue 13.5: a 0.2 m wall across the map vanished at dx = 1 m and --dx 100 on a 40 m
    map removed every building, both silently. The solver now refuses, naming the block and
    the dx that keeps it; the planner's occupancy keeps it."""
    from windnav.flow import simulate
    from windnav.plan.graph_search import free_space

    wall = City((0.0, 40.0, 0.0, 20.0), [[20.1, 20.3, 0.0, 20.0]], [10.0])
    x, y = wall.grid(1.0)
    assert not wall.rasterize(x, y).any()  # the centre rule misses it ...
    with pytest.raises(ValueError, match=r"block 0 .*covers no cell.*dx <= 0\.1"):
        simulate(wall, 2.0, dx=1.0, dt=0.1, spinup_steps=0, steps=1)
    free = free_space(wall, 1.0, 0.0)[2]
    assert not free[:, 20].any()  # ... the planner's occupancy does not: no way through

    city = City((0.0, 40.0, 0.0, 40.0), [[5.0, 15.0, 5.0, 15.0], [25.0, 35.0, 20.0, 30.0]],
                [10.0, 10.0])
    with pytest.raises(ValueError, match="covers no cell.*1 more block"):
        simulate(city, 2.0, dx=100.0, dt=1.0, spinup_steps=0, steps=1)
    with pytest.warns(UserWarning, match="thinner than 2 cells"):
        city.check_resolution(6.0)


def test_lidar_hits_lie_in_solid_cells():
    """The LiDAR and the grids agree on what is solid: every return lands in a solid cell of
    the conservative raster, and the solver's raster keeps every block (a random training
    map at the thesis's dx = 1 m)."""
    city = training_map(rng=3, size=300.0, n_buildings=10)
    city.check_resolution(1.0)
    x, y = city.grid(1.0)
    over = city.rasterize(x, y, rule="overlap")
    origins = np.array([[p, q] for p in np.linspace(5, 295, 12) for q in np.linspace(5, 295, 12)])
    origins = origins[~city.contains(origins)]
    ranges = city.lidar(origins, n_rays=360, max_range=400.0)
    ang = 2 * np.pi * np.arange(360) / 360
    hit = ranges < 400.0
    pts = origins[:, None, :] + (ranges + 1e-6)[..., None] * np.stack(
        [np.cos(ang), np.sin(ang)], -1)[None]
    pts = pts[hit]
    inside = (pts[:, 0] < 300.0) & (pts[:, 1] < 300.0) & (pts[:, 0] > 0) & (pts[:, 1] > 0)
    pts = pts[inside]
    assert pts.shape[0] > 1000
    i = np.clip(np.floor(pts[:, 0]).astype(int), 0, x.size - 1)
    j = np.clip(np.floor(pts[:, 1]).astype(int), 0, y.size - 1)
    assert over[j, i].all()
