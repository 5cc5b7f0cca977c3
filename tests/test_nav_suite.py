"""The benchmark suite's scenario rules, against closed forms and brute force.

The harness itself (store, table, flights) is tested in ``test_nav_benchmark.py``; here the
suite's geometry: the clearance from a point to the buildings, and the spread of the start/goal
directions inside the wind cone.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from scipy import stats

from windnav.city import City
from windnav.experiments.nav_suite import SuiteSpec, clearance_to_buildings, get_suite, make_suite

# two buildings [x_min, x_max, y_min, y_max], m
FOOTPRINTS = [[100.0, 140.0, 200.0, 220.0], [300.0, 310.0, 50.0, 120.0]]


def two_buildings():
    return City(bounds=(0.0, 400.0, 0.0, 400.0), footprints=FOOTPRINTS, heights=[20.0, 30.0])


def test_clearance_is_the_euclidean_distance_to_the_nearest_footprint():
    city = two_buildings()
    cases = [
        ((143.0, 224.0), 5.0),    # beyond the north-east corner by (3, 4): a 3-4-5 triangle
        ((94.0, 192.0), 10.0),    # beyond the south-west corner by (6, 8)
        ((96.0, 210.0), 4.0),     # beside the west edge
        ((120.0, 195.0), 5.0),    # below the south edge
        ((120.0, 210.0), 0.0),    # inside
        ((140.0, 220.0), 0.0),    # on a corner
        ((315.0, 132.0), 13.0),   # second building: (5, 12) from its north-east corner
        ((220.0, 160.0), math.hypot(80.0, 40.0)),  # (80, 40) from a corner of each building
    ]
    pts = np.array([p for p, _ in cases])
    want = np.array([d for _, d in cases])
    np.testing.assert_allclose(clearance_to_buildings(city, pts), want, rtol=0, atol=1e-12)


def test_clearance_agrees_with_densely_sampled_walls():
    city = two_buildings()
    spacing = 0.01  # m between samples along the walls: the brute force is within spacing / 2
    walls = []
    for x0, x1, y0, y1 in FOOTPRINTS:
        xs = np.arange(x0, x1 + spacing / 2, spacing)
        ys = np.arange(y0, y1 + spacing / 2, spacing)
        walls += [np.c_[xs, np.full_like(xs, y0)], np.c_[xs, np.full_like(xs, y1)],
                  np.c_[np.full_like(ys, x0), ys], np.c_[np.full_like(ys, x1), ys]]
    walls = np.concatenate(walls)
    rng = np.random.default_rng(3)
    pts = rng.uniform(0.0, 400.0, (200, 2))
    inside = np.zeros(len(pts), bool)
    for x0, x1, y0, y1 in FOOTPRINTS:
        inside |= ((pts[:, 0] >= x0) & (pts[:, 0] <= x1) & (pts[:, 1] >= y0)
                   & (pts[:, 1] <= y1))
    pts = pts[~inside]
    brute = np.array([np.hypot(*(walls - p).T).min() for p in pts])
    got = clearance_to_buildings(city, pts)
    assert np.all(got <= brute + 1e-9)
    assert np.all(brute - got <= spacing / 2 + 1e-9)


def test_thesis_pair_directions_spread_over_the_whole_cone():
    # the start-to-goal heading, relative to the wind (tailwind) or its opposite (headwind), is
    # drawn uniform in (-45, 45) deg: both sides of the wind, about evenly
    spec = get_suite("thesis")
    suite = make_suite(spec)  # 1,024 pairs, under a second
    offsets = []
    for sc in suite:
        v = np.subtract(sc.goal, sc.start)
        heading = math.degrees(math.atan2(v[1], v[0]))
        target = sc.direction_deg + (0.0 if sc.kind == "tailwind" else 180.0)
        offsets.append((heading - target + 180.0) % 360.0 - 180.0)
    offsets = np.array(offsets)
    assert len(offsets) == 1024
    assert np.all(np.abs(offsets) <= spec.cone_deg + 1e-9)
    for kind in ("tailwind", "headwind"):
        half = offsets[[sc.kind == kind for sc in suite]]
        assert 0.4 <= np.mean(half > 0) <= 0.6, kind
    assert stats.kstest(offsets, stats.uniform(-45.0, 90.0).cdf).pvalue > 1e-3
    assert np.mean(offsets) == pytest.approx(0.0, abs=3.0)  # standard error ~0.8 deg


def test_wind_of_names_the_map_and_wind_a_scenario_shares_with_its_pairs():
    from windnav.experiments.nav_suite import wind_of

    assert wind_of("thesis/m03/w07/p2") == wind_of("thesis/m03/w07/p0") == "thesis/m03/w07"
    assert wind_of("thesis/m03/w08/p2") != wind_of("thesis/m03/w07/p2")
    assert wind_of("quick/m00/w00/p1") == "quick/m00/w00"
    assert wind_of("my-own-flight") == "my-own-flight"   # another form: its own group
    assert wind_of("thesis/m03/w07/p2\n") == "thesis/m03/w07/p2\n"


def test_the_settings_hash_tells_two_decoders_apart():
    """A decoder among the navigate options is hashed by its weights: its str is the same for
    every decoder of one architecture, and one store took two decoders' flights as one
    suite's (audit, 2026-12-05). The committed suites, without one, keep their hashes."""
    from dataclasses import replace

    from windnav.predict import load_decoder

    thesis = get_suite("thesis")
    assert thesis.settings_hash() == "7c0d341fac564cde"  # docs/navigation/thesis_manifest.json
    import windnav.predict

    data = Path(windnav.predict.__file__).parent / "data"
    shipped, older = load_decoder(), load_decoder(data / "decoder_2026-11-23.npz")
    hashes = [replace(thesis, navigate_options={"decoder": d}).settings_hash()
              for d in (shipped, older, load_decoder())]
    assert hashes[0] != hashes[1] and hashes[0] == hashes[2]
    assert str(shipped) == str(older)


def test_a_suite_on_a_city_of_ones_own_flies_it_as_its_one_map():
    """``SuiteSpec(city=...)``: the city is map 0 (no other), its pairs obey the rule inside the
    city's bounds, and it enters the settings by its fingerprint: its blocks' geometry, not
    their colours, and not the object."""
    from dataclasses import replace

    from windnav.experiments.nav_suite import SuiteSpec, parse_scenario_id, suite_map

    city = two_buildings()
    spec = replace(get_suite("quick"), name="two", maps=(0,), city=city)
    assert suite_map(spec, 0) is city
    with pytest.raises(ValueError, match="'m' parameter of suite_map must be 0"):
        suite_map(spec, 1)
    scenarios = make_suite(spec)
    assert [s.scenario_id for s in scenarios] == ["two/m00/w04/p0", "two/m00/w04/p2",
                                                  "two/m00/w10/p0", "two/m00/w10/p2"]
    for s in scenarios:
        points = np.array([s.start, s.goal])
        assert math.dist(s.start, s.goal) == pytest.approx(282.0)
        assert np.all((points >= 25.0) & (points <= 375.0))
        assert clearance_to_buildings(city, points).min() >= 15.0
    assert parse_scenario_id(spec, "two/m00/w10/p2") == scenarios[3]
    same = City(bounds=city.bounds, footprints=FOOTPRINTS, heights=[20.0, 30.0],
                block_attrs=[{"color": "red"}, {}])
    taller = City(bounds=city.bounds, footprints=FOOTPRINTS, heights=[20.0, 31.0])
    assert same.fingerprint() == city.fingerprint() != taller.fingerprint()
    hashes = {replace(spec, city=c).settings_hash() for c in (city, same)}
    assert hashes == {spec.settings_hash()} and replace(spec, city=taller).settings_hash() \
        not in hashes
    assert spec.settings()["city"] == f"City sha256:{city.fingerprint()}"
    assert "city" not in get_suite("quick").settings()
    import pickle  # (as the process executor sends it to its workers)

    sent = pickle.loads(pickle.dumps(spec))
    assert sent.settings_hash() == spec.settings_hash() and make_suite(sent) == scenarios
    for bad, match in (({"maps": (0, 1)}, "'maps' parameter of SuiteSpec must be \\(0,\\)"),
                       ({"city": "city.json"}, "'city' parameter of SuiteSpec must be a City"),
                       ({"pair_distance": 500.0}, "'pair_distance' parameter .* \\(494.975 m\\)"),
                       ({"name": "my town"}, "'name' parameter .* white space")):
        with pytest.raises(ValueError, match=match):
            SuiteSpec(**{**spec.__dict__, **bad})


def test_the_committed_windinet_store_is_the_thesis_suite_on_that_layout():
    """docs/navigation/windinet_manifest.json (``benchmark-nav --suite thesis --map
    windinet=FILE``) names the suite this code builds from the layout: its settings hash, and
    the city's fingerprint, stay what the committed records were flown under."""
    import json

    from windnav.commands.benchmark_nav import city_suite
    from windnav.experiments.decoder_eval import windinet_layout

    manifest = json.loads((Path(__file__).parents[1] / "docs" / "navigation"
                           / "windinet_manifest.json").read_text())
    spec = city_suite(f"windinet={windinet_layout()}", "test", {}, suite="thesis",
                      seed_value=None, store=None)
    assert spec.settings() == manifest["settings"]
    assert spec.settings_hash() == manifest["settings_hash"] == "0a34e6b85db41218"
    again = city_suite(f"windinet={windinet_layout()}", "test", manifest, suite=None,
                       seed_value=None, store="docs/navigation")  # the store's own: the same
    assert again.settings() == spec.settings() and again.name == "windinet"


def test_the_committed_town300_store_is_the_thesis_suite_with_a_rule_of_its_own():
    """docs/navigation/town300_manifest.json (``benchmark-nav --suite thesis --map
    town300=docs/img/navigation/town300/city.json --pair-distance 180 --edge 60``): the suite
    this code builds from the committed map and that rule, and from the store alone."""
    import json

    from windnav.commands.benchmark_nav import city_suite

    docs = Path(__file__).parents[1] / "docs"
    manifest = json.loads((docs / "navigation" / "town300_manifest.json").read_text())
    text = f"town300={docs / 'img' / 'navigation' / 'town300' / 'city.json'}"
    spec = city_suite(text, "test", {}, suite="thesis", seed_value=None, store=None,
                      rule={"pair_distance": 180.0, "edge": 60.0})
    assert spec.settings() == manifest["settings"]
    assert spec.settings_hash() == manifest["settings_hash"]
    assert (spec.pair_distance, spec.edge, spec.clearance) == (180.0, 60.0, 15.0)
    again = city_suite(text, "test", manifest, suite=None, seed_value=None,
                       store="docs/navigation")
    assert again.settings() == spec.settings() and again.name == "town300"


def test_a_suite_built_by_hand_on_a_city_is_the_command_s():
    """``SuiteSpec(name, maps=(0,), city=...)`` with the thesis defaults is the suite that
    ``benchmark-nav --suite thesis --map windinet=FILE`` flew (the committed store's hash):
    ``map_size`` is the city's larger side (it kept the preset's 600 m, and hashed apart), and
    a rule given as ints is the same suite as with floats (it wrote 282, not 282.0)."""
    import json

    from windnav.city import read_rotorpy_json
    from windnav.experiments.decoder_eval import windinet_layout

    manifest = json.loads((Path(__file__).parents[1] / "docs" / "navigation"
                           / "windinet_manifest.json").read_text())
    city = read_rotorpy_json(windinet_layout())
    by_hand = SuiteSpec("windinet", maps=(0,), city=city)
    assert by_hand.map_size == max(city.size) and by_hand.settings() == manifest["settings"]
    ints = SuiteSpec("windinet", maps=(0,), city=city, pair_distance=282, edge=25,
                     clearance=15, record_s=100, map_size=600)
    assert ints.settings_hash() == by_hand.settings_hash() == manifest["settings_hash"]
    assert isinstance(ints.pair_distance, float) and isinstance(ints.edge, float)


def test_a_map_size_other_than_the_city_s_is_refused_not_replaced():
    """With a city, ``map_size`` draws nothing and became the city's larger side whatever it
    was given: 400 m on a 300 m city flew the city, unsaid (left by the fifty-second session)."""
    from windnav.city import planning_map

    city = planning_map(rng=3, size=300.0)
    rule = {"pair_distance": 150.0, "edge": 30.0}
    with pytest.raises(ValueError, match=r"'map_size' parameter of SuiteSpec draws nothing "
                                         r"with a city: it is the city's larger side, 300 m\. "
                                         r"Got 400\.0 instead"):
        SuiteSpec("c", maps=(0,), city=city, map_size=400.0, **rule)
    for size in (300.0, 600.0):  # its own side, or the default: the same suite
        assert SuiteSpec("c", maps=(0,), city=city, map_size=size, **rule).map_size == 300.0
