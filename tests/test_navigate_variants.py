"""``windnav navigate --variant a,b,...``: several planners, each a benchmark label, flown from
one start to one goal in one simulated wind, and compared with the first.

The small map and weak wind of ``tests/test_navigate.py`` (140 m x 120 m, one building, 2 m/s);
the command's flow simulation is replaced by that one flow, so each flight can be compared to
the bit with ``navigate`` called directly in the same wind.
"""

import json

import numpy as np
import pytest

import windnav.experiments.nav_demo as nav_demo
import windnav.experiments.navigate as nav_mod
from windnav import cli
from windnav.plan import EscapeConfig

START = (10.0, 60.0)
GOAL = (110.0, 60.0)
SPEED = 2.0
ESC = "ea-mppi-w-esc@escair=13.45@edge=15@pace=20"


@pytest.fixture
def command(city, flow, tmp_path, monkeypatch):
    """``windnav navigate`` on the yard's map, in its flow (conftest's, simulated once)."""
    path = city.to_rotorpy_json(tmp_path / "city.json")
    monkeypatch.setattr(nav_mod, "simulate_flow", lambda *a, **kw: flow)

    def run(variant, *extra, out="out"):
        argv = ["navigate", "--map", str(path), "--start", *map(str, START), "--goal",
                *map(str, GOAL), "--speed", str(SPEED), "--variant", variant, "--out",
                str(tmp_path / out), *extra]
        status = cli.main(argv)
        return status, json.loads((tmp_path / out / "summary.json").read_text())

    return run


def direct(city, flow, variant, **kw):
    return nav_mod.navigate(city, START, GOAL, speed=SPEED, direction_deg=0.0, variant=variant,
                            rng=0, flow=flow, **kw).summary()


def test_several_variants_fly_what_each_label_flies_and_compare_with_the_first(
        city, flow, command, tmp_path, capsys):
    labels = ["mppi", "ea-mppi-w@energy=mission", ESC]
    status, doc = command(",".join(labels))
    assert status == 0
    assert list(doc["variants"]) == labels and doc["reference"] == "mppi"
    # each flight is the label's flight: navigate with the parameters the label stands for
    wanted = {"mppi": direct(city, flow, "mppi"),
              labels[1]: direct(city, flow, "ea-mppi-w",
                                planner_overrides={"energy_mode": "mission"}),
              ESC: direct(city, flow, "ea-mppi-w-esc",
                          escape=EscapeConfig(airspeed_mps=13.45, edge_m=15.0,
                                              pace_margin_s=20.0))}
    for label in labels:
        got = doc["variants"][label]
        for key in ("outcome", "energy_J", "rotor_energy_J", "time_s", "distance_m"):
            assert got[key] == wanted[label][key], (label, key)
        assert got.get("label") == (None if label == "mppi" else label)
    assert doc["variants"][ESC]["settings"]["escapes"] == wanted[ESC]["settings"]["escapes"]
    # the comparison: the reference's energy against each, where both reached the goal
    ref = doc["variants"]["mppi"]
    for label in labels[1:]:
        s = doc["variants"][label]
        pct = doc["energy_vs_reference_percent"][label]
        if ref["outcome"] == s["outcome"] == "success":
            assert pct == pytest.approx(100 * (ref["energy_J"] - s["energy_J"]) / ref["energy_J"])
        else:
            assert pct is None
    err = capsys.readouterr().err
    assert f"{ESC}: {doc['variants'][ESC]['outcome']}" in err
    assert "(one flight each, not a rate)" in err or "not compared" in err
    out = tmp_path / "out"
    assert {p.name for p in out.iterdir()} == {
        "summary.json", "series_1.npz", "series_2.npz", "series_3.npz",
        "navigate_paths.png", "navigate_energy.png"}
    series = np.load(out / "series_2.npz")
    assert series["energy"][-1] == pytest.approx(doc["variants"][labels[1]]["energy_J"])


def test_one_label_flies_as_the_options_do_and_keeps_the_one_flight_outputs(command, tmp_path,
                                                                             capsys):
    status, labelled = command("ea-mppi-w@energy=mission", "--no-plots", out="a")
    assert status == 0
    assert "windnav navigate: flying ea-mppi-w@energy=mission" in capsys.readouterr().err
    status, flagged = command("ea-mppi-w", "--energy", "mission", "--no-plots", "--no-progress",
                              out="b")
    assert status == 0
    assert "flying" not in capsys.readouterr().err
    for key in ("outcome", "energy_J", "time_s", "distance_m", "variant"):
        assert labelled[key] == flagged[key]
    assert labelled["label"] == "ea-mppi-w@energy=mission" and "label" not in flagged
    assert {p.name for p in (tmp_path / "a").iterdir()} == {"summary.json", "series.npz"}
    status, _ = command("mppi", "--no-plots", "--no-progress", "--gif-frames", "3", out="c")
    from PIL import Image

    with Image.open(tmp_path / "c" / "navigate_flight.gif") as gif:
        assert status == 0 and gif.n_frames == 3


@pytest.mark.parametrize("variant, extra, match", [
    ("mppi,ea-mppi-w", ["--horizon", "50"], r"'--horizon' parameter of windnav navigate "
     r"applies to one variant named without parameters; with several variants give it in each "
     r"label that takes it \('@h=H'\)"),
    ("ea-mppi-w@h=50", ["--outside", "robot"], r"with a label give it in each label .*"
     r"'@outside=robot'"),
    ("ea-mppi-w@qe=2", ["--energy", "mission"], r"'@energy=mission'"),
    ("mppi,ea-mppi-w-hat", ["--wrobot-tau", "8"], r"'@tau=S'"),
    ("mppi,ea-mppi-w", ["--model", "x.npz"], r"'--model' parameter of windnav navigate "
     r"applies only to an onboard label"),
    ("ea-mppi-w-hat@decoder=2026-11-23", ["--rotations-deg", "0", "-3", "3"],
     r"'--rotations-deg' parameter of windnav navigate applies only to an onboard label "
     r"without @decoder= or @views="),
    ("ea-mppi-w-hat@views=3", ["--rotations-deg", "0", "-3", "3"], r"no label takes it"),
    ("ea-mppi-w-hat@decoder=2026-11-23", ["--model", "x.npz"], r"'--model' parameter of "
     r"windnav navigate applies only to an onboard label without @decoder="),
    ("ea-mppi-w@tilt=70", ["--tilt-max-deg", "60"], r"'--tilt-max-deg' parameter of windnav "
     r"navigate applies only to a label without @tilt="),
    ("ea-mppi-w@tilt=70", ["--tilt-max-deg", "nan"], r"'--tilt-max-deg' parameter of windnav "
     r"navigate must be"),
    ("mppi,ea-mppi-w-esc@escair=13.45@regain=5", [], r"'--variant' parameter of windnav "
     r"navigate must give regain larger than the capture radius, 10 m"),
    ("gs,", ["--horizon", "5"], r"'--horizon' parameter of windnav navigate is for the MPPI "
     r"variants"),
    ("mppi,mppi", [], r"'--variant' parameter of windnav navigate must be distinct"),
    ("mppi,ea-mppi,ea-mppi-w,mppi-w,gs", [], r"must name at most 4 variants"),
    ("mppi@h=5@qe=1,mppi@qe=1@h=5", [], r"names one flight twice"),
    ("mppi@foo=1", [], r"'--variant' parameter of windnav navigate must be distinct names"),
    ("mppi", ["--gif-frames", "1"], r"'--gif-frames' parameter of windnav navigate must be an "
     r"integer >= 2"),
])
def test_refused_before_the_wind_is_simulated(variant, extra, match, city, tmp_path,
                                              monkeypatch, capsys):
    def no_flow(*a, **kw):
        raise AssertionError("simulated the wind")

    monkeypatch.setattr(nav_mod, "simulate_flow", no_flow)
    path = city.to_rotorpy_json(tmp_path / "city.json")  # a real map: only the refusal stops it
    argv = ["navigate", "--map", str(path), "--start", *map(str, START), "--goal",
            *map(str, GOAL), "--speed", "3", "--variant", variant, *extra, "--out",
            str(tmp_path / "o")]
    assert cli.main(argv) == 2
    import re

    assert re.search(match, capsys.readouterr().err)
    assert not (tmp_path / "o").exists()


def test_a_stray_comma_or_space_is_read_as_the_one_label(command):
    """``--variant "mppi,"`` ended in a KeyError: the one-variant path looked the raw string up
    (review, fifty-third session)."""
    status, doc = command(" mppi, ", "--no-plots", "--no-progress")
    assert status == 0 and doc["variant"] == "mppi" and "label" not in doc


def test_onboard_labels_fly_model_or_a_dated_decoder_and_the_line_rebuilds(
        city, flow, command, tmp_path):
    """``--model`` flies the onboard labels without ``@decoder=``; ``@decoder=DATE`` flies the
    benchmark's dated file; the result records ``--model``'s hash, and its command line, rebuilt
    by windnav.provenance, parses to the arguments it ran with."""
    from windnav.experiments.nav_benchmark import benchmark_decoder
    from windnav.predict import load_decoder
    from windnav.predict.decoder import DEFAULT_MODEL, model_sha256
    from windnav.provenance import command_arguments

    model = DEFAULT_MODEL.parent / "decoder_2026-12-01.npz"
    labels = ["ea-mppi-w-hat@outside=robot", "ea-mppi-w-hat@decoder=2026-11-23"]
    status, doc = command(",".join(labels), "--model", str(model), "--no-plots", "--no-progress")
    assert status == 0
    assert doc["model_files"]["model"] == {"path": str(model), "sha256": model_sha256(model)}
    mine = direct(city, flow, "ea-mppi-w-hat", onboard={"outside": "robot"},
                  decoder=load_decoder(model))
    dated = direct(city, flow, "ea-mppi-w-hat", decoder=benchmark_decoder("2026-11-23"))
    for label, want in zip(labels, (mine, dated), strict=True):
        for key in ("outcome", "energy_J", "time_s"):
            assert doc["variants"][label][key] == want[key], (label, key)
    words = command_arguments(doc)
    parsed = vars(cli.build_parser().parse_args(words[1:]))
    assert {k: parsed[k] for k in ("variant", "model", "start", "goal")} == {
        "variant": ",".join(labels), "model": model, "start": list(START), "goal": list(GOAL)}


def test_legend_names_break_long_labels_before_an_at_sign():
    assert nav_demo.legend_name("ea-mppi-w") == "EA-MPPI+W"
    long = "ea-mppi-w-esc@escair=13.45@edge=15@pace=20@regain=20@launch=40@gust=0.5"
    lines = nav_demo.legend_name(long).split("\n")
    assert lines[0].startswith("EA-MPPI+W+esc@escair=13.45") and len(lines) == 3
    assert all(len(line) <= 36 for line in lines)
    assert "".join(lines) == "EA-MPPI+W+esc" + long[len("ea-mppi-w-esc"):]


def test_energies_compare_only_where_both_reached_the_goal():
    flown = {"time_s": 30.0, "distance_m": 120.0}
    runs = {"a": {"outcome": "success", "energy_J": 200.0, **flown},
            "b": {"outcome": "success", "energy_J": 150.0, **flown},
            "c": {"outcome": "timeout", "energy_J": 100.0, **flown}}
    got = nav_demo.compare_energies(runs)
    assert got == {"reference": "a", "energy_vs_reference_percent": {"b": 25.0, "c": None},
                   "energy_not_compared": {"c": "c did not reach the goal"}}
    text = nav_demo.describe_comparison({"variants": runs, **got})
    assert "b used 25.0 % less energy than a" in text
    assert "c against a: not compared (c did not reach the goal)" in text
    # a counterfactual power curve (@power=crazyflie) prices its flight on another curve
    other = nav_demo.compare_energies(runs, {"b": "crazyflie"})
    assert other["energy_vs_reference_percent"]["b"] is None
    assert "another power curve (crazyflie's against the vehicle's" in \
        other["energy_not_compared"]["b"]


def test_the_labels_fly_the_benchmark_s_flights_of_a_scenario_to_the_bit(tmp_path):
    """``navigate`` given a scenario's start, goal, inlet and seed flies, for each label, the
    record ``benchmark-nav`` writes for it (its own flow simulation against the suite's: the
    same wind). Measured on the windinet store too: MPPI, ``ea-mppi-w@energy=mission`` and the
    sixth variant's last setting on ``windinet/m00/w01/p3`` gave their records' energies to
    the bit (docs/navigation.md)."""
    from windnav.experiments.nav_benchmark import fly_scenario, suite_flow
    from windnav.experiments.nav_suite import SuiteSpec, make_suite, suite_map

    spec = SuiteSpec("tiny", maps=(0,), winds=(1,), pairs=(0,), speeds=(3.0,),
                     incidences_deg=(0.0, 90.0), n_tailwind=1, n_headwind=1,
                     pair_distance=100.0, clearance=25.0, edge=15.0, map_size=200.0,
                     map_options={"n_buildings": 2, "side_range": (10.0, 20.0)}, spinup_s=5.0,
                     record_s=30.0)
    sc = make_suite(spec)[0]
    city = suite_map(spec, sc.map_index)
    flow = suite_flow(spec, city, sc.speed, sc.direction_deg)
    labels = ["mppi", "ea-mppi-w-esc@escair=13.45@edge=15"]
    records = {v: fly_scenario(spec, sc, v, city=city, flow=flow) for v in labels}
    path = city.to_rotorpy_json(tmp_path / "city.json")
    argv = ["navigate", "--map", str(path), "--start", *map(repr, sc.start), "--goal",
            *map(repr, sc.goal), "--speed", repr(sc.speed), "--direction-deg",
            repr(sc.direction_deg), "--seed", str(sc.seed), "--spinup-s", repr(spec.spinup_s),
            "--record-s", repr(spec.record_s), "--variant", ",".join(labels), "--no-plots",
            "--out", str(tmp_path / "o")]
    assert cli.main(argv) == 0
    doc = json.loads((tmp_path / "o" / "summary.json").read_text())
    for label in labels:
        got, rec = doc["variants"][label], records[label]
        for key in ("outcome", "energy_J", "rotor_energy_J", "time_s", "distance_m"):
            assert got[key] == rec[key], (label, key)


def test_one_diverged_flight_of_several_exits_1_naming_it(command, monkeypatch, capsys):
    """The run exits 1 when any of its flights diverged, and says which; the others are
    written as flown."""
    import dataclasses

    real = nav_mod.navigate

    def second_diverges(*a, **kw):
        res = real(*a, **kw)
        return dataclasses.replace(res, diverged_s=1.5) if kw["variant"] == "ea-mppi" else res

    monkeypatch.setattr(nav_mod, "navigate", second_diverges)
    status, doc = command("mppi,ea-mppi", "--no-plots", "--no-progress")
    assert status == 1
    assert doc["variants"]["ea-mppi"]["diverged_s"] == 1.5
    assert doc["variants"]["mppi"]["diverged_s"] is None
    err = capsys.readouterr().err
    assert "windnav navigate: error: the simulation (ea-mppi) diverged" in err
    assert "(mppi) diverged" not in err


def test_the_parser_defaults_are_the_flag_defaults_the_labels_check_against():
    """A label with parameters refuses --horizon/--energy/--outside/--wrobot-tau that differ
    from FLAG_DEFAULTS; the parser's defaults were literals written beside it, so a change to
    one would have refused every multi-variant run given no option at all."""
    from windnav.commands.navigate import FLAG_DEFAULTS, FLAG_LABELS

    args = cli.build_parser().parse_args(["navigate", "--map", "m.json", "--start", "0", "0",
                                          "--goal", "50", "0", "--speed", "5"])
    assert set(FLAG_DEFAULTS) == set(FLAG_LABELS)
    assert {key: getattr(args, key) for key in FLAG_DEFAULTS} == FLAG_DEFAULTS
