"""``windnav city``: a generated map written as RotorPy JSON, a map's summary and plan, and the
start/goal pairs a suite's rule draws on it, checked against the pairs the committed windinet
benchmark flew."""

from __future__ import annotations

import gzip
import json
from pathlib import Path

import numpy as np
import pytest

from windnav import cli
from windnav.city import City, planning_map, read_rotorpy_json, training_map

DOCS = Path(__file__).parents[1] / "docs"


def test_a_generated_map_is_the_generator_s_and_its_summary_measures_it(tmp_path, capsys):
    out = tmp_path / "town"
    assert cli.main(["city", "--kind", "planning", "--seed", "5", "--size", "300",
                     "--buildings", "10", "--out", str(out)]) == 0
    city = read_rotorpy_json(out / "city.json")
    want = planning_map(rng=5, size=300.0, n_buildings=10)
    assert city.fingerprint() == want.fingerprint()
    summary = json.loads(capsys.readouterr().out)
    assert summary["buildings"] == 10 and summary["blocks"] == want.n_buildings
    assert summary["size_m"] == [300.0, 300.0] and "suite" not in summary
    assert summary["height_m"] == [min(want.heights), max(want.heights)]
    doc = json.loads((out / "city_summary.json").read_text())
    assert doc["command"] == "windnav city" and doc["fingerprint"] == want.fingerprint()
    assert (out / "city.png").stat().st_size > 10_000
    # the built share on the 1 m raster: the footprints' area where blocks do not overlap
    # (a training map's buildings are single blocks, at least a street apart)
    out = tmp_path / "train"
    assert cli.main(["city", "--kind", "training", "--seed", "2", "--out", str(out)]) == 0
    summary = json.loads(capsys.readouterr().out)
    city = training_map(rng=2)
    fp = city.footprints
    area = float(np.sum((fp[:, 1] - fp[:, 0]) * (fp[:, 3] - fp[:, 2])))
    assert summary["built_fraction"] == pytest.approx(area / np.prod(city.size), abs=0.004)
    assert summary["median_block_side_m"] == pytest.approx(city.median_building_side)


def test_the_pairs_drawn_are_those_the_benchmark_flew_on_the_windinet_layout(tmp_path,
                                                                               capsys):
    """The committed windinet store (``benchmark-nav --suite thesis --map windinet=FILE``):
    each of its 64 scenarios started and aimed where ``city --suite thesis`` draws them."""
    from windnav.experiments.decoder_eval import windinet_layout

    out = tmp_path / "look"
    assert cli.main(["city", "--map", f"windinet={windinet_layout()}", "--suite", "thesis",
                     "--out", str(out)]) == 0
    printed = capsys.readouterr()
    brief = json.loads(printed.out)
    assert brief["suite"]["holds"] and brief["suite"]["pairs"] == 64
    assert brief["suite"]["rule"] == {"pair_distance": 282.0, "edge": 25.0, "clearance": 15.0}
    drawn = {p["scenario_id"]: p for p in json.loads(
        (out / "city_summary.json").read_text())["suite"]["pairs"]}
    with gzip.open(DOCS / "navigation" / "windinet_records.jsonl.gz", "rt") as f:
        flown, seeds = {}, {}
        for line in f:
            r = json.loads(line)
            flown[r["scenario_id"]] = (r["start"], r["goal"], r["kind"], r["speed"])
            seeds[r["scenario_id"]] = r["seed"]
    assert set(drawn) == set(flown) and len(flown) == 64
    for sid, (start, goal, kind, speed) in flown.items():
        p = drawn[sid]
        assert (p["kind"], p["speed"]) == (kind, speed)
        np.testing.assert_allclose([p["start"], p["goal"]], [start, goal], rtol=0, atol=1e-9)
        assert p["seed"] == seeds[sid]
    # and the line that flies the first one as the benchmark would (its record's seed)
    err = printed.err
    first = drawn["windinet/m00/w00/p0"]
    assert (f"--seed {seeds['windinet/m00/w00/p0']} --variant mppi,ea-mppi-w-esc@escair=13.45"
            in err)
    assert f"--start {first['start'][0]!r} {first['start'][1]!r}" in err
    # one wind of the thesis suite there: the estimate the benchmark's batching uses
    from windnav.commands._city_suite import city_suite
    from windnav.experiments.nav_benchmark import wind_memory

    spec = city_suite(f"windinet={windinet_layout()}", "test", {}, suite="thesis",
                      seed_value=None, store=None)
    summary = json.loads((out / "city_summary.json").read_text())
    assert summary["suite"]["wind_memory_bytes"] == wind_memory(spec) > 4e9


def test_a_suite_seed_draws_the_pairs_benchmark_nav_flies_with_that_seed(tmp_path, capsys):
    """``--suite-seed 2``: the pairs of ``benchmark-nav --suite thesis --seed 2 --map
    windinet=FILE`` (its suite, through the benchmark's own reading of ``--map``), not seed
    0's."""
    from windnav.commands._city_suite import city_suite
    from windnav.experiments.decoder_eval import windinet_layout
    from windnav.experiments.nav_suite import make_suite

    drawn = {}
    for value in (None, 2):
        out = tmp_path / f"s{value}"
        extra = [] if value is None else ["--suite-seed", str(value)]
        assert cli.main(["city", "--map", f"windinet={windinet_layout()}", "--suite", "thesis",
                         *extra, "--out", str(out)]) == 0
        capsys.readouterr()
        doc = json.loads((out / "city_summary.json").read_text())
        assert doc["suite"]["seed"] == (value or 0)
        drawn[value] = doc["suite"]["pairs"]
    spec = city_suite(f"windinet={windinet_layout()}", "test", {}, suite="thesis",
                      seed_value=2, store=None)
    flown = make_suite(spec)
    assert [p["scenario_id"] for p in drawn[2]] == [s.scenario_id for s in flown]
    for p, s in zip(drawn[2], flown, strict=True):
        assert (p["speed"], p["direction_deg"], p["seed"]) == (s.speed, s.direction_deg, s.seed)
        assert [p["start"], p["goal"]] == [list(map(float, s.start)), list(map(float, s.goal))]
    assert [p["start"] for p in drawn[2]] != [p["start"] for p in drawn[None]]
    assert [p["seed"] for p in drawn[2]] != [p["seed"] for p in drawn[None]]


def test_a_map_too_small_for_the_rule_is_said_and_a_rule_of_its_own_fits(tmp_path, capsys):
    small = tmp_path / "yard.json"
    City(bounds=(0.0, 200.0, 0.0, 200.0), footprints=[[90.0, 110.0, 90.0, 110.0]],
         heights=[20.0]).to_rotorpy_json(small)
    out = tmp_path / "a"
    assert cli.main(["city", "--map", str(small), "--suite", "quick", "--out", str(out)]) == 1
    captured = capsys.readouterr()
    assert "cannot hold the suite's pairs" in captured.err
    assert "--pair-distance, --edge, --clearance change them" in captured.err
    doc = json.loads((out / "city_summary.json").read_text())  # still written
    assert not doc["suite"]["holds"] and doc["suite"]["pairs"] == []
    # the one 20 m block closes a tenth of a cross-section along an axis, a little more
    # across it at 15-30 deg (20 (cos + sin) m of a section 200 / cos m long)
    block = doc["blockage"]
    assert block["by_direction_deg"]["0"] == pytest.approx(0.1)
    assert block["by_direction_deg"]["90"] == pytest.approx(0.1)
    assert 0.1 <= block["max"] < 0.12 and block["at_deg"] not in (0.0, 90.0)
    assert (block["along_axis"], block["axis_deg"]) == (pytest.approx(0.1), 0.0)
    assert block["mean_wind_factor"] == pytest.approx(1 / 0.9)  # along an axis only
    assert (out / "city.png").is_file()
    assert cli.main(["city", "--map", str(small), "--suite", "quick", "--pair-distance", "150",
                     "--edge", "20", "--out", str(tmp_path / "b")]) == 0
    brief = json.loads(capsys.readouterr().out)
    assert brief["suite"]["holds"] and brief["suite"]["pairs"] == 4
    # a generated map is named as benchmark-nav names its file (city.json), and one that
    # cannot hold the pairs is said naming --kind
    assert cli.main(["city", "--kind", "training", "--seed", "1", "--size", "150",
                     "--suite", "quick", "--out", str(tmp_path / "k")]) == 1
    assert "The '--kind' parameter of windnav city must be a map that holds" in (
        capsys.readouterr().err)
    assert cli.main(["city", "--kind", "training", "--seed", "1", "--suite", "quick",
                     "--pair-distance", "150", "--out", str(tmp_path / "k2")]) == 0
    capsys.readouterr()
    doc = json.loads((tmp_path / "k2" / "city_summary.json").read_text())
    assert doc["name"] == "city" and doc["suite"]["pairs"][0]["scenario_id"].startswith(
        "city/m00/")
    pairs = json.loads((tmp_path / "b" / "city_summary.json").read_text())["suite"]["pairs"]
    for p in pairs:
        pts = np.array([p["start"], p["goal"]])
        assert np.linalg.norm(pts[1] - pts[0]) == pytest.approx(150.0)
        assert pts.min() >= 20.0 and pts.max() <= 180.0


@pytest.mark.parametrize("argv, match", [
    (["--map", "M", "--seed", "3"], "'--seed' parameter .* applies to --kind"),
    (["--kind", "planning", "--edge", "10"], "'--edge' parameter .* without --suite"),
    (["--kind", "planning", "--suite", "quick", "--edge", "-1"], "'--edge' parameter .* >= 0"),
    (["--kind", "planning", "--size", "100", "--buildings", "40"],
     r"'--buildings' parameter of windnav city is too large"),
    (["--kind", "planning", "--size", "150"],
     r"windnav city \(--kind planning\) drew .* Pass a smaller --buildings or a larger --size"),
    (["--kind", "training", "--size", "-5"], "'--size' parameter"),
    # the layouts' own parameters, which no flag sets, were named (CLI audit, 2026-12-07)
    (["--kind", "training", "--size", "5"], r"'--size' parameter of windnav city must leave "
     r"room for a --kind training map's buildings, streets and margins: give a larger --size\. "
     r"Got 5 m instead \(training_map: "),
    (["--kind", "dense", "--size", "100"], r"'--size' parameter .* --kind dense map's .* Got "
     r"100 m instead \(dense_map: The 'lots_per_side'"),
    (["--kind", "training", "--size", "1e7"], r"'--size' parameter of windnav city must give a "
     r"map the summary can raster at 1 m \(at most 1e9 cells\)\. Got 1e\+07 x 1e\+07 m"),
    (["--map", "none.json"], "'--map' parameter .* which does not exist"),
    (["--kind", "planning", "--seed", "-1"], "'--seed' parameter .* >= 0"),
    (["--kind", "planning", "--suite-seed", "2"], "'--suite-seed' parameter .* without --suite"),
    (["--map", "M", "--suite", "quick", "--suite-seed", "-1"], "'--suite-seed' parameter .* >= 0"),
    (["--map", "my town=M", "--suite", "thesis"], "'--map' parameter .* without '/' or white"),
    (["--map", "thesis=M", "--suite", "thesis"], "'--map' parameter .* apart from"),
    (["--map", "M", "--json", "M", "--overwrite"], "'--json' parameter .* must not be the map"),
])
def test_bad_input_is_refused_naming_the_option(tmp_path, capsys, argv, match):
    import re

    small = tmp_path / "m.json"
    City(bounds=(0.0, 100.0, 0.0, 100.0), footprints=np.zeros((0, 4)),
         heights=np.zeros(0)).to_rotorpy_json(small)
    argv = [str(small) if a == "M" else str(tmp_path / a) if a == "none.json"
            else a.replace("=M", f"={small}") for a in argv]
    assert cli.main(["city", *argv, "--out", str(tmp_path / "x")]) == 2
    assert re.search(match, capsys.readouterr().err), argv
    assert not (tmp_path / "x").exists()
    assert read_rotorpy_json(small).n_buildings == 0   # the map read is never written over
