"""The pace study: a variant's energy against MPPI split into time and mean power per pair."""

from __future__ import annotations

import json

import numpy as np
import pytest
from test_nav_benchmark import TINY

from windnav import cli
from windnav.experiments.nav_pace import THESIS, pace_study
from windnav.experiments.nav_records import NavStore, paired_pace
from windnav.experiments.nav_suite import SUITES
from windnav.plan import planner_config
from windnav.vehicle import params
from windnav.viz.nav_sweeps import plot_pace


def rec(sid, variant, outcome, energy, time_s, speed=5.0, m=0):
    return {"scenario_id": sid, "variant": variant, "outcome": outcome, "energy_J": energy,
            "time_s": time_s, "speed": speed, "map_index": m, "seed": 0}


# (E_mppi, T_mppi, E_ea, T_ea, outcome of EA-MPPI+W)
FLIGHTS = [(3000.0, 50.0, 3300.0, 60.0, "success"), (2000.0, 40.0, 1800.0, 36.0, "success"),
           (2500.0, 45.0, 2000.0, 45.0, "hover")]


def records(suffix=""):
    out = []
    for i, (e_ref, t_ref, e, t, outcome) in enumerate(FLIGHTS):
        sid = f"quick/m00/w{i // 2:02d}/p{i % 2}"  # flights of the tiny suite
        out += [rec(sid, "mppi" + suffix, "success", e_ref, t_ref),
                rec(sid, "ea-mppi-w" + suffix, outcome, e, t)]
    return out


def test_pairs_split_the_energy_ratio_into_time_and_mean_power():
    recs = records()
    by = {v: {r["scenario_id"]: r for r in recs if r["variant"] == v}
          for v in ("mppi", "ea-mppi-w")}
    pairs = paired_pace(by["ea-mppi-w"], by["mppi"])
    assert pairs["scenario_id"] == ["quick/m00/w00/p0", "quick/m00/w00/p1"]  # p2 failed
    np.testing.assert_allclose(pairs["time_ratio"], [60 / 50, 36 / 40])
    np.testing.assert_allclose(pairs["power_ratio"], [(3300 / 60) / (3000 / 50),
                                                      (1800 / 36) / (2000 / 40)])
    np.testing.assert_allclose(pairs["reference_power_W"], [60.0, 50.0])
    res = pace_study(recs + records("@power=crazyflie"))
    assert set(res["curves"]) == {"vehicle", "crazyflie"} and res["thesis"] == THESIS
    c = res["curves"]["vehicle"]
    assert c["energy_ratio"]["mean"] == pytest.approx(np.mean([3300 / 3000, 1800 / 2000]))
    assert c["time_ratio"]["n"] == 2 and c["power_ratio"]["mean"] == pytest.approx(
        np.mean(pairs["power_ratio"]))
    # the least power of each curve: the Hummingbird's just under its hover power; the
    # Crazyflie shape's its 10.12 W bucket times P_hover / 10.56 W (the thesis's numbers)
    hover = planner_config(params("hummingbird"), "mppi").hover_power
    assert 0.95 * hover < c["min_power_W"] <= hover
    assert res["curves"]["crazyflie"]["min_power_W"] == pytest.approx(10.12 / 10.56 * hover,
                                                                      rel=2e-3)
    assert c["power_floor"] == pytest.approx(np.mean([c["min_power_W"] / 60.0,
                                                      c["min_power_W"] / 50.0]))
    # the mission's energy: that variant against the reference as it is (no suffix)
    mission = [dict(r, variant="ea-mppi-w@energy=mission", energy_J=0.5 * r["energy_J"])
               for r in recs if r["variant"] == "ea-mppi-w"]
    res = pace_study(recs + mission)
    assert set(res["curves"]) == {"vehicle", "mission"}
    m = res["curves"]["mission"]
    assert (m["variant"], m["reference"], m["shape"]) == ("ea-mppi-w@energy=mission", "mppi",
                                                         "vehicle")
    assert m["energy_ratio"]["mean"] == pytest.approx(0.5 * c["energy_ratio"]["mean"])
    assert m["min_power_W"] == c["min_power_W"]
    # the thesis's own means: 1.34 x the time at 0.59 x the power, a 20.6 % saving
    assert THESIS["time_ratio"] * THESIS["power_ratio"] == pytest.approx(1 - 0.206, abs=1e-3)


def test_a_store_without_the_variants_is_refused(tmp_path):
    with pytest.raises(ValueError, match="'records' parameter of pace_study.*'ea-mppi-w'"):
        pace_study([r for r in records() if r["variant"] == "mppi"])
    path = plot_pace(pace_study(records()), tmp_path / "pace.png")
    assert path.stat().st_size > 10_000


def test_a_store_where_the_two_never_both_succeeded_still_draws(tmp_path):
    """No scenario where neither failed: no pair, no means; the figure says 0 pairs (its
    label formatted the missing mean energy ratio, a TypeError, on a small city's store)."""
    failed = [dict(r, outcome="left_map") if r["variant"] == "mppi" else r for r in records()]
    res = pace_study(failed)
    c = res["curves"]["vehicle"]
    assert c["time_ratio"]["n"] == 0 and c["energy_ratio"]["mean"] is None
    assert plot_pace(res, tmp_path / "pace.png").stat().st_size > 10_000


def test_command_reads_the_store_and_writes_the_figure(tmp_path, monkeypatch, capsys):
    monkeypatch.setitem(SUITES, "quick", TINY.__class__(**{**TINY.__dict__, "name": "quick"}))
    store = NavStore(tmp_path / "store", SUITES["quick"])
    for r in records():
        store.append(r)
    args = ["nav-study", "pace", "--suite", "quick", "--store", str(store.path), "--out",
            str(tmp_path / "pace")]
    assert cli.main(args) == 0
    doc = json.loads((tmp_path / "pace" / "nav_pace.json").read_text())
    assert doc["curves"]["vehicle"]["time_ratio"]["n"] == 2 and "crazyflie" not in doc["curves"]
    assert (tmp_path / "pace" / "nav_pace.png").stat().st_size > 10_000
    assert '"energy_ratio"' in capsys.readouterr().out
    assert cli.main([*args, "--variant", "mppi-w", "--overwrite"]) == 2  # not in the store
    assert "'--store' parameter of windnav nav-study" in capsys.readouterr().err
