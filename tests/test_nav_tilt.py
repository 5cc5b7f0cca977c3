"""The tilt-cap study: labels, the arithmetic on hand-made records, a real flight with another
cap, and the command (with the stand-in flights of ``tests/test_nav_benchmark.py``)."""

from __future__ import annotations

import json
import math

import pytest
from test_nav_sweeps import fly_small_map, quick_is_tiny  # noqa: F401 (a fixture)

import windnav.experiments.nav_benchmark as nb
from windnav import cli
from windnav.experiments.nav_records import NavStore
from windnav.experiments.nav_suite import SUITES
from windnav.experiments.nav_tilt import VARIANTS, tilt_label, tilt_study


def test_labels_are_the_variants_at_the_default_cap():
    assert tilt_label("ea-mppi-w", 55) == "ea-mppi-w"
    assert tilt_label("mppi", 70.0) == "mppi@tilt=70"
    assert nb.parse_variant(tilt_label("mppi-w", 77.5)) == ("mppi-w", {"tilt_max_deg": 77.5})


def _rec(sid, variant, outcome, energy, time_s=10.0, accel=2.0):
    return {"scenario_id": sid, "variant": variant, "outcome": outcome, "energy_J": energy,
            "rotor_energy_J": energy, "time_s": time_s, "distance_m": 100.0,
            "mean_cmd_accel": accel, "speed": 5.0}


def test_each_cap_is_compared_with_its_own_mppi():
    recs = []
    # at 55 deg every variant uses 1000 J against MPPI's 1000 J; at 70 deg MPPI uses 2000 J and
    # the others 1500 J in twice the time, so they save 25 % at 0.375 x the mean power
    for sid in ("a", "b"):
        for v in VARIANTS:
            recs.append(_rec(sid, v, "success", 1000.0))
            e, t = (2000.0, 10.0) if v == "mppi" else (1500.0, 20.0)
            recs.append(_rec(sid, tilt_label(v, 70), "success", e, t, accel=8.0))
    recs.append(_rec("c", "mppi", "success", 10.0))  # flown at one cap only: left out
    recs[0] = {**recs[0], "outcome": "hover"}  # MPPI fails scenario a at 55 deg
    res = tilt_study(recs, [70, 55])
    assert res["tilts"] == [55.0, 70.0] and res["scenarios"] == 2
    assert res["a_max"][55.0] == pytest.approx(9.81 * math.tan(math.radians(55)) / math.sqrt(2),
                                               rel=1e-3)
    r55, r70 = res["rows"][55.0], res["rows"][70.0]
    assert r55["mppi"]["failure_pct"]["value"] == 50.0 and r55["mppi"]["failures"]["hover"] == 50
    assert r55["ea-mppi-w"]["paired"]["mean"] == 0.0 and r55["ea-mppi-w"]["paired"]["n"] == 1
    assert r70["ea-mppi-w"]["label"] == "ea-mppi-w@tilt=70"
    assert r70["ea-mppi-w"]["paired"]["mean"] == pytest.approx(0.25)
    assert r70["ea-mppi-w"]["paired"]["n"] == 2 and r70["ea-mppi-w"]["paired"]["less"] == 2
    assert r70["ea-mppi-w"]["time_ratio"] == pytest.approx(2.0)
    assert r70["ea-mppi-w"]["power_ratio"] == pytest.approx(0.375)
    assert r70["mppi"]["cmd_accel"] == 8.0 and "paired" not in r70["mppi"]
    with pytest.raises(ValueError, match="Missing: \\['ea-mppi-w@tilt=78'"):
        tilt_study(recs, [55, 78])
    for bad in ([], [0], [80], [55, 55]):
        with pytest.raises(ValueError, match="'tilts' parameter of tilt_study"):
            tilt_study(recs, bad)


def test_a_higher_cap_lets_the_planner_command_more():
    """A real flight (15 s on a small map): the cap sets the planner's ``a_max`` and the
    commands follow it."""
    low, high = fly_small_map("mppi"), fly_small_map("mppi@tilt=75")
    assert low.settings["a_max"] == pytest.approx(9.81 * math.tan(math.radians(55)) / 2 ** 0.5,
                                                  rel=1e-3)
    assert high.settings["tilt_max_deg"] == 75.0
    assert high.settings["a_max"] == pytest.approx(9.81 * math.tan(math.radians(75)) / 2 ** 0.5,
                                                   rel=1e-3)
    assert high.summary()["mean_cmd_accel"] > low.summary()["mean_cmd_accel"]


@pytest.mark.usefixtures("quick_is_tiny")
def test_command_flies_every_variant_at_every_cap_and_plots_it(tmp_path, capsys):
    args = ["nav-study", "tilt", "--suite", "quick", "--store", str(tmp_path / "store"),
            "--values", "55", "70", "--executor", "serial", "--out", str(tmp_path / "t"),
            "--no-progress"]
    assert cli.main(args) == 0
    doc = json.loads((tmp_path / "t" / "nav_tilt.json").read_text())
    assert doc["tilts"] == [55.0, 70.0] and doc["flights_now"] == 32  # 4 scenarios x 8 labels
    assert doc["rows"]["70.0"]["ea-mppi"]["label"] == "ea-mppi@tilt=70"
    assert (tmp_path / "t" / "nav_tilt.png").stat().st_size > 10_000
    store = NavStore(tmp_path / "store", SUITES["quick"], create=False)
    assert {r["variant"] for r in store.load()} == {
        *VARIANTS, *(f"{v}@tilt=70" for v in VARIANTS)}
    capsys.readouterr()
    assert cli.main([*args, "--overwrite"]) == 0
    assert '"flights_now": 0' in capsys.readouterr().out  # a rerun flies nothing
    assert cli.main([*args[:7], "80", *args[9:], "--overwrite"]) == 2
    assert "'--values' parameter of windnav nav-study" in capsys.readouterr().err


def test_the_figure_draws_caps_without_an_interval_or_without_a_pair(tmp_path):
    """At 55 deg every variant flies MPPI's energy (the same value in both pairs: no interval,
    which the figure indexed); at 70 deg MPPI fails both scenarios (no pair, whose None mean
    the figure multiplied): the review of the thirty-ninth session."""
    from windnav.viz.nav_sweeps import plot_tilt

    recs = []
    for sid in ("a", "b"):
        for v in VARIANTS:
            recs.append(_rec(sid, v, "success", 1000.0))
            recs.append(_rec(sid, tilt_label(v, 70), "hover" if v == "mppi" else "success",
                             1500.0))
    res = tilt_study(recs, [55, 70])
    same, none = res["rows"][55.0]["ea-mppi-w"]["paired"], res["rows"][70.0]["ea-mppi-w"]["paired"]
    assert same["ci95"] is None and "all 2 values are equal" in same["ci95_note"]
    assert none["mean"] is None and none["n"] == 0
    assert plot_tilt(res, tmp_path / "tilt.png").stat().st_size > 10_000
