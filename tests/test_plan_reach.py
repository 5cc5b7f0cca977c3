"""The least-time search within an airspeed limit (windnav.plan.reach), against closed forms."""

import json
import math
import re

import numpy as np
import pytest

from windnav.city import City
from windnav.experiments.nav_feasibility import _hold_ok, reach_table
from windnav.plan.reach import (
    ReachLattice,
    fastest_route,
    least_time,
    max_ground_speed,
    nearest_free_cell,
    reach_lattice,
)
from windnav.wind.gridded import GriddedWind

EMPTY = City((0, 200, 0, 200), np.zeros((0, 4)), np.zeros(0))


def tiny_suite(name: str):
    """A suite of 4 scenarios on one 200 m map (2 winds at 3 m/s, 100 m pairs, 30 s records)."""
    from windnav.experiments.nav_suite import SuiteSpec

    return SuiteSpec(
        name, maps=(0,), winds=(0, 1), pairs=(0, 1), speeds=(3.0,),
        incidences_deg=(0.0, 90.0), n_tailwind=1, n_headwind=1, pair_distance=100.0,
        clearance=25.0, edge=15.0, map_size=200.0,
        map_options={"n_buildings": 2, "side_range": (10.0, 20.0)}, spinup_s=5.0, record_s=30.0)


def test_max_ground_speed_closed_form():
    e = [[1, 0], [1, 0], [1, 0], [1, 0], [3, 4]]
    w = [[-5, 0], [0, 5], [-14, 0], [0, 14], [3, 4]]
    v = max_ground_speed(e, w, 13.0)
    # headwind: A - 5; crosswind: sqrt(A^2 - 25); headwind or crosswind past A: none;
    # tailwind along a non-axis direction: A + |w|
    np.testing.assert_allclose(v, [8.0, 12.0, 0.0, 0.0, 18.0], rtol=1e-12)


def test_max_ground_speed_keeps_airspeed_at_the_limit():
    rng = np.random.default_rng(0)
    e = rng.normal(size=(200, 2))
    e /= np.hypot(*e.T)[:, None]
    w = rng.uniform(-10, 10, size=(200, 2))
    v = max_ground_speed(e, w, 12.0)
    air = np.hypot(*(v[:, None] * e - w).T)
    moving = v > 0
    np.testing.assert_allclose(air[moving], 12.0, rtol=1e-9)
    # a slightly faster ground speed would exceed the limit
    faster = np.hypot(*((v[:, None] + 1e-3) * e - w).T)
    assert np.all(faster[moving] > 12.0)


def test_max_ground_speed_rejects_bad_input():
    with pytest.raises(ValueError, match="'direction'"):
        max_ground_speed([[0, 0]], [[1, 0]], 10.0)
    with pytest.raises(ValueError, match="'airspeed_max'"):
        max_ground_speed([[1, 0]], [[1, 0]], -1.0)


def test_least_time_rejects_an_end_point_off_the_map():
    lat = reach_lattice(EMPTY, (0.0, 0.0), dx=2.0, clearance=0.0)
    with pytest.raises(ValueError, match="'goal_xy' parameter of least_time must lie inside"):
        least_time(lat, (20, 100), (260, 100), airspeed_max=10.0)
    # audit 2026-12-05: an airspeed of 1e308 gave a time of 0, a speed cap under the 0.5 m/s
    # floor was flown at 0.5, and NaN found a cell
    with pytest.raises(ValueError, match="'airspeed_max' parameter of least_time must be at "
                                         "most"):
        least_time(lat, (20, 100), (180, 100), airspeed_max=1e308)
    with pytest.raises(ValueError, match="'speed_max' parameter of fastest_route must be at "
                                         "least 0.5"):
        fastest_route(lat, (20, 100), (180, 100), airspeed_max=10.0, speed_max=1e-300)
    with pytest.raises(ValueError, match="'point_xy' parameter of nearest_free_cell"):
        nearest_free_cell(lat, (np.nan, 0.0))
    with pytest.raises(ValueError, match="'max_distance' parameter of nearest_free_cell"):
        nearest_free_cell(lat, (10.0, 10.0), -1.0)


@pytest.mark.parametrize("wind", [(0.0, 0.0), (-6.0, 0.0), (4.0, 3.0), (0.0, 8.0)])
def test_uniform_wind_straight_line(wind):
    """Open map, uniform wind: the straight line at v_max (the lattice's 16 moves follow a
    line within 3 degrees, so the time is within 0.5 % for this axis-aligned leg)."""
    lat = reach_lattice(EMPTY, wind, dx=2.0, clearance=0.0)
    r = least_time(lat, (20, 100), (180, 100), airspeed_max=10.0)
    v = max_ground_speed([[1, 0]], [wind], 10.0)[0]
    assert r.reached and not r.unsteady
    assert r.time_s == pytest.approx(160.0 / v, rel=5e-3)
    assert r.length_m == pytest.approx(160.0, rel=5e-3)


def test_diagonal_leg_within_lattice_error():
    lat = reach_lattice(EMPTY, (0.0, 0.0), dx=2.0, clearance=0.0)
    r = least_time(lat, (20, 20), (180, 120), airspeed_max=10.0)
    straight = math.dist((20, 20), (180, 120))
    # the 16-move lattice's worst stretch is 1 / cos(atan(1/2) / 2)... < 1.027
    assert straight / 10.0 <= r.time_s <= 1.03 * straight / 10.0


def test_headwind_beyond_the_limit_is_unreachable_but_not_around_it():
    """A 12 m/s wind toward -x below y = 140, calm above, A = 10: from inside the band the
    vehicle can only make headway downwind-ish (north-west), so it reaches a goal up and to
    the east by leaving the band first."""
    x = y = np.arange(0.5, 200.0, 1.0)
    u = np.where(y[:, None] < 140, -12.0, 0.0) * np.ones((1, x.size))
    wind = GriddedWind(x, y, u, np.zeros_like(u))
    lat = reach_lattice(EMPTY, wind, dx=2.0, clearance=0.0)
    r = least_time(lat, (100, 100), (180, 170), airspeed_max=10.0)
    assert r.reached
    assert r.path[:, 0].min() < 100 and r.path[:, 1].max() >= 139
    assert not least_time(lat, (100, 100), (180, 170), airspeed_max=10.0,
                          t_end=r.time_s - 1.0).reached
    # a goal east in the band itself cannot be reached at all
    blocked = least_time(lat, (100, 100), (180, 100), airspeed_max=10.0)
    assert not blocked.reached and math.isinf(blocked.time_s) and blocked.path.shape == (0, 2)
    assert math.isinf(blocked.length_m)


def test_unsteady_wind_waits_for_the_lull():
    """A 20 m/s headwind until t = 10 s, then calm: with A = 10 the vehicle waits, then flies
    160 m at 10 m/s, arriving at 26 s (to the frame spacing)."""
    x = y = np.arange(0.5, 200.0, 1.0)
    t = np.arange(0.0, 60.0, 0.25)
    u = np.where(t < 10.0, -20.0, 0.0)[:, None, None] * np.ones((1, y.size, x.size))
    wind = GriddedWind(x, y, u, np.zeros_like(u), t=t)
    lat = reach_lattice(EMPTY, wind, dx=2.0, clearance=0.0)
    assert lat.unsteady
    r = least_time(lat, (20, 100), (180, 100), airspeed_max=10.0)
    assert r.unsteady
    assert r.time_s == pytest.approx(26.0, abs=0.3)
    late = least_time(lat, (20, 100), (180, 100), airspeed_max=10.0, t_start=30.0)
    assert late.time_s == pytest.approx(46.0, rel=5e-3)


def test_building_detour_and_goal_radius():
    city = City((0, 200, 0, 200), [[95, 105, 0, 170]], [20])  # a wall with a gap at the top
    lat = reach_lattice(city, (0.0, 0.0), dx=2.0, clearance=1.0)
    r = least_time(lat, (50, 100), (150, 100), airspeed_max=10.0)
    # up to the wall's near corner, along its 10 m end, down: with 1 m of clearance
    around = 2 * math.hypot(44, 71) + 12
    assert r.length_m == pytest.approx(around, rel=0.03)
    assert r.time_s == pytest.approx(r.length_m / 10.0, rel=0.02)  # ends snapped to cells
    near = least_time(lat, (50, 100), (150, 100), airspeed_max=10.0, goal_radius=5.0)
    assert r.time_s - 0.6 <= near.time_s < r.time_s
    assert math.dist(near.path[-1], (150, 100)) <= 5.0
    with pytest.raises(ValueError, match="'goal_xy'"):
        least_time(lat, (50, 100), (100, 100), airspeed_max=10.0)
    with pytest.raises(ValueError, match="'lattice'"):
        least_time(city, (50, 100), (150, 100), airspeed_max=10.0)
    with pytest.raises(ValueError, match="'t_end'"):
        least_time(lat, (50, 100), (150, 100), airspeed_max=10.0, t_end=0.0)


def test_hold_window():
    t = np.arange(0.25, 100.01, 0.25)
    calm = np.full(t.size, 5.0)
    assert _hold_ok(calm, t, 90.0, 100.0, 5.0, 10.0)
    assert not _hold_ok(calm, t, 96.0, 100.0, 5.0, 10.0)  # too late to hold 5 s
    gusty = np.where((t > 50) & (t < 98), 20.0, 5.0)
    assert not _hold_ok(gusty, t, 60.0, 100.0, 5.0, 10.0)
    assert _hold_ok(gusty, t, 40.0, 100.0, 5.0, 10.0)


def test_the_hold_may_be_anywhere_a_success_may_hold_within_the_goal_radius():
    """A goal whose own cell is in a jet but whose disc of 5 m holds a calm free cell can be
    held there, as a success may: the check at the goal cell alone called such goals
    unreachable (audit, 2026-12-05). Cells beyond the radius or inside a building do not
    count."""
    from windnav.experiments.nav_feasibility import goal_disc_wind
    from windnav.plan.reach import ReachLattice

    x = y = np.arange(0.0, 20.0, 2.0) + 1.0  # cell centres 1, 3, ..., 19
    t = np.arange(0.25, 100.01, 0.25)
    frames = np.zeros((t.size, y.size, x.size, 2))
    frames[..., 0] = 20.0                    # a jet everywhere
    frames[:, 5, 7, 0] = 3.0                 # calm at (15, 11): 4.1 m from the goal (11, 12)
    frames[:, 5, 9, 0] = 3.0                 # calm at (19, 11): 8.1 m, outside the disc
    free = np.ones((y.size, x.size), bool)
    lat = ReachLattice(x=x, y=y, free=free, frames=frames, t0=0.25, dt_frames=0.25, dx=2.0,
                       clearance=1.0)
    winds = goal_disc_wind(lat, (11.0, 12.0), 5.0)
    near = np.hypot(*np.meshgrid(x - 11.0, y - 12.0)) <= 5.0
    assert winds.shape == (t.size, int(near.sum()))
    assert any(_hold_ok(winds[:, c], t, 30.0, 100.0, 5.0, 15.45) for c in range(winds.shape[1]))
    assert not _hold_ok(np.hypot(*frames[:, 6, 5].T), t, 30.0, 100.0, 5.0, 15.45)  # goal cell
    free[5, 7] = False                       # the calm cell inside a building's clearance
    winds = goal_disc_wind(lat, (11.0, 12.0), 5.0)
    assert not any(_hold_ok(winds[:, c], t, 30.0, 100.0, 5.0, 15.45)
                   for c in range(winds.shape[1]))


def test_reach_table_counts():
    def rec(sid, speed, kind, reachable, time, mean_time):
        return {"scenario_id": sid, "speed": speed, "kind": kind,
                "limits": {"13": {"reachable": reachable, "recorded_time_s": time,
                                  "mean_time_s": mean_time}}}

    reach = [rec("a", 10.0, "headwind", True, 40.0, 55.0),
             rec("b", 10.0, "headwind", False, None, None),
             rec("c", 2.0, "tailwind", True, 20.0, 30.0)]
    flights = [{"scenario_id": "a", "variant": "v", "outcome": "error"},  # re-flown below
               {"scenario_id": "a", "variant": "v", "outcome": "timeout"},
               {"scenario_id": "b", "variant": "v", "outcome": "success"},
               {"scenario_id": "c", "variant": "v", "outcome": "success"},
               {"scenario_id": "zz", "variant": "v", "outcome": "success"}]
    table = reach_table(reach, flights, airspeed=13.0)
    assert table["n"] == 3 and table["reachable"] == 2
    assert table["groups"]["10/headwind"] == {"n": 2, "reachable": 1, "median_time_s": 40.0}
    assert list(table["groups"]) == ["2/tailwind", "10/headwind"]
    v = table["variants"]["v"]
    bins = v.pop("by_mean_time")
    assert v == {"flights": 3, "failures": 1, "reachable": 2, "failures_reachable": 1,
                 "success_unreachable": 1, "errors": 0}
    # 30 s falls in the first bin (upper edges inclusive), 55 s in 50-60, no route in "none"
    assert bins == {"0-30": [1, 0], "30-40": [0, 0], "40-50": [0, 0], "50-60": [1, 1],
                    "60-95": [0, 0], "none": [1, 0]}


def test_reach_scenarios_on_a_tiny_suite_resumes_and_bounds_the_flights(tmp_path):
    from windnav.experiments.nav_feasibility import RECORDS, reach_scenarios

    spec = tiny_suite("tiny")
    reach = reach_scenarios(spec, tmp_path, airspeeds=(2.0, 13.0), executor="serial",
                            progress=False)
    assert [r["scenario_id"] for r in reach] == [f"tiny/m00/w0{w}/p{p}" for w in (0, 1)
                                                 for p in (0, 1)]
    for r in reach:
        fast, slow = r["limits"]["13"], r["limits"]["2"]
        # 100 m in a 3 m/s wind: at 13 m/s of airspeed at least 100 / 16 s, and reachable
        assert fast["reachable"] and fast["recorded_time_s"] >= 95.0 / 16.0
        assert fast["mean_time_s"] >= 95.0 / 16.0
        # a 2 m/s limit cannot make headway into the 3 m/s inlet
        if r["kind"] == "headwind":
            assert not slow["reachable"]
        assert slow["recorded_time_s"] is None or slow["recorded_time_s"] > fast[
            "recorded_time_s"]
    lines = (tmp_path / RECORDS).read_text().splitlines()
    assert len(lines) == 4
    again = reach_scenarios(spec, tmp_path, airspeeds=(2.0, 13.0), executor="serial",
                            progress=False)
    assert again == reach and len((tmp_path / RECORDS).read_text().splitlines()) == 4
    # a kill mid-append tears the last line (no newline): the rerun ignores it, cuts it off
    # and appends the missing record whole (it used to exit 2 on every rerun, naming no file)
    whole = (tmp_path / RECORDS).read_bytes()
    cut = len(whole) - len(whole.splitlines()[-1]) // 2 - 1
    (tmp_path / RECORDS).write_bytes(whole[:cut])
    mended = reach_scenarios(spec, tmp_path, airspeeds=(2.0, 13.0), executor="serial",
                             progress=False)

    def untimed(records):
        return [{k: v for k, v in r.items() if k != "flow_s"} for r in records]

    assert untimed(mended) == untimed(reach)
    lines = (tmp_path / RECORDS).read_bytes().split(b"\n")
    assert lines[:3] == whole.split(b"\n")[:3] and lines[4] == b""  # torn line gone, 4 whole
    assert untimed([json.loads(x) for x in lines[:4]]) == untimed(reach)
    # a corrupt line elsewhere is an error naming the file and the line
    lines[1] = b'{"scenario_id": "tiny/m00/w00/p1", "lim'
    (tmp_path / RECORDS).write_bytes(b"\n".join(lines))
    with pytest.raises(ValueError, match=rf"{RECORDS}'.* at line 2: "):
        reach_scenarios(spec, tmp_path, airspeeds=(2.0, 13.0), executor="serial",
                        progress=False)


def test_feasibility_command_writes_tables_and_figure(tmp_path, monkeypatch, capsys):
    import json

    from windnav import cli
    from windnav.experiments.nav_benchmark import NavStore
    from windnav.experiments.nav_suite import SUITES

    spec = tiny_suite("quick")
    monkeypatch.setitem(SUITES, "quick", spec)
    store = NavStore(tmp_path / "store", spec, create=True)
    for w, outcome in ((0, "success"), (1, "timeout")):
        store.append({"scenario_id": f"quick/m00/w0{w}/p0", "variant": "mppi", "map_index": 0,
                      "outcome": outcome, "energy_J": 1000.0})
    args = ["nav-study", "feasibility", "--suite", "quick", "--store", str(store.path),
            "--cache", str(tmp_path / "reach"), "--airspeeds", "2", "--executor", "serial",
            "--out", str(tmp_path / "out"), "--no-progress"]
    assert cli.main(args) == 0
    doc = json.loads((tmp_path / "out" / "nav_feasibility.json").read_text())
    assert set(doc["tables"]) == {"2", f"{doc['airspeed_limit']:g}"}  # the limit is added
    limit = doc["tables"][f"{doc['airspeed_limit']:g}"]
    assert limit["n"] == 4 and limit["reachable"] == 4
    mppi = limit["variants"]["mppi"]
    assert sum(n for n, _ in mppi.pop("by_mean_time").values()) == 2
    assert mppi == {"flights": 2, "failures": 1, "reachable": 2, "failures_reachable": 1,
                    "success_unreachable": 0, "errors": 0}
    assert (tmp_path / "out" / "nav_feasibility.png").stat().st_size > 10_000
    capsys.readouterr()
    args[args.index("--airspeeds") + 1] = "-1"
    assert cli.main([*args, "--overwrite"]) == 2
    assert "'--airspeeds' parameter" in capsys.readouterr().err
    assert cli.main(["nav-study", "feasibility", "--suite", "quick", "--fly", "mppi",
                     "--out", str(tmp_path / "o2")]) == 2
    assert "'--store' parameter" in capsys.readouterr().err
    # no reachable flight: no failure rate (it printed, and drew, 0/0 as 0.0 %: failure audit)
    import windnav.experiments.nav_feasibility as feasibility

    table = feasibility.reach_table

    def unreachable(*a, **kw):
        t = table(*a, **kw)
        t["reachable"] = 0
        for c in t["variants"].values():
            c["reachable"] = c["failures_reachable"] = 0
        return t

    monkeypatch.setattr(feasibility, "reach_table", unreachable)
    args[args.index("--airspeeds") + 1] = "2"
    assert cli.main([*args, "--overwrite"]) == 0
    brief = json.loads(capsys.readouterr().out)["airspeeds"]
    assert all(t["failures_reachable_pct"] == {"mppi": None} for t in brief.values())
    assert (tmp_path / "out" / "nav_feasibility.png").stat().st_size > 10_000


def test_feasibility_reads_a_decoder_store_with_the_suites_own_reach_cache(tmp_path,
                                                                           monkeypatch, capsys):
    """A store of ``benchmark-nav --decoder FILE``: ``feasibility --decoder FILE`` reads it with
    the reach cache of the suite without a decoder (the cache's identity does not change with
    the decoder: review, fiftieth session), its ``--fly`` into such a store is refused naming
    ``--fly``, and ``--decoder`` without ``--store`` naming ``--decoder``."""
    import dataclasses
    import json

    from windnav import cli
    from windnav.experiments.nav_benchmark import NavStore
    from windnav.experiments.nav_feasibility import RECORDS
    from windnav.experiments.nav_suite import SUITES, SuiteSpec
    from windnav.predict import load_decoder
    from windnav.predict.decoder import DEFAULT_MODEL

    spec = SuiteSpec(
        "quick", maps=(0,), winds=(0,), pairs=(0, 1), speeds=(3.0,), incidences_deg=(0.0,),
        n_tailwind=1, n_headwind=1, pair_distance=100.0, clearance=25.0, edge=15.0,
        map_size=200.0, map_options={"n_buildings": 2, "side_range": (10.0, 20.0)},
        spinup_s=5.0, record_s=30.0)
    monkeypatch.setitem(SUITES, "quick", spec)
    mine = DEFAULT_MODEL.with_name("decoder_2026-12-01.npz")
    flown = dataclasses.replace(spec, navigate_options={
        "decoder": load_decoder(mine, boundary="blend")})
    store = NavStore(tmp_path / "store", flown, create=True)
    store.append({"scenario_id": "quick/m00/w00/p0", "variant": "ea-mppi-w-hat",
                  "map_index": 0, "outcome": "success", "energy_J": 1000.0})
    cache = tmp_path / "reach"
    base = ["nav-study", "feasibility", "--suite", "quick", "--cache", str(cache),
            "--airspeeds", "13", "--executor", "serial", "--no-progress"]
    assert cli.main([*base, "--out", str(tmp_path / "plain")]) == 0  # the suite's cache
    searched = (cache / RECORDS).read_text()
    assert cli.main([*base, "--store", str(store.path), "--decoder", str(mine), "--out",
                     str(tmp_path / "mine")]) == 0
    assert (cache / RECORDS).read_text() == searched  # read, not searched again
    doc = json.loads((tmp_path / "mine" / "nav_feasibility.json").read_text())
    assert doc["tables"]["13"]["variants"]["ea-mppi-w-hat"]["flights"] == 1
    assert doc["decoder_file"]["path"] == str(mine)
    capsys.readouterr()
    for extra, match in (
            (["--store", str(store.path), "--fly", "mppi"], "'--fly' parameter .* such a store"),
            (["--store", str(store.path), "--fly", "mppi", "--decoder", str(mine)],
             "'--fly' parameter .* with --decoder"),
            (["--decoder", str(mine)], "'--decoder' parameter .* without --store")):
        assert cli.main([*base, *extra, "--out", str(tmp_path / "x")]) == 2, extra
        assert re.search(match, capsys.readouterr().err), extra
    assert not (tmp_path / "x").exists()
    # a malformed store is refused before the searches (it was after them: review)
    import windnav.experiments.nav_feasibility as feasibility

    def no_search(*a, **kw):
        raise AssertionError("searched before the store was checked")

    monkeypatch.setattr(feasibility, "reach_scenarios", no_search)
    bad = tmp_path / "bad"
    bad.mkdir()
    (bad / "manifest.json").write_text("[1]")
    assert cli.main([*base, "--store", str(bad), "--out", str(tmp_path / "x")]) == 2
    assert "not a benchmark manifest" in capsys.readouterr().err


def test_feasibility_flies_pending_flights_in_the_same_winds(tmp_path):
    from windnav.experiments.nav_benchmark import NavStore
    from windnav.experiments.nav_feasibility import reach_scenarios
    from windnav.experiments.nav_suite import SuiteSpec

    spec = SuiteSpec(
        "tiny", maps=(0,), winds=(0,), pairs=(0, 1), speeds=(3.0,),
        incidences_deg=(0.0, 90.0), n_tailwind=1, n_headwind=1, pair_distance=100.0,
        clearance=25.0, edge=15.0, map_size=200.0,
        map_options={"n_buildings": 2, "side_range": (10.0, 20.0)}, spinup_s=5.0, record_s=30.0)
    store = tmp_path / "store"
    reach_scenarios(spec, tmp_path / "reach", airspeeds=(13.0,), executor="serial",
                    progress=False, fly=["mppi"], store=store)
    recs = NavStore(store, spec, create=False).load()
    assert sorted(r["scenario_id"] for r in recs) == ["tiny/m00/w00/p0", "tiny/m00/w00/p1"]
    assert all(r["variant"] == "mppi" and r["error"] is None and r["flow_s"] > 0
               and r["outside_envelope_s"] is not None for r in recs)
    # nothing pending, nothing missing: a rerun simulates no wind and flies nothing
    reach_scenarios(spec, tmp_path / "reach", airspeeds=(13.0,), executor="serial",
                    progress=False, fly=["mppi"], store=store)
    assert len(NavStore(store, spec, create=False).load()) == 2
    assert len((tmp_path / "reach" / "reach.jsonl").read_text().splitlines()) == 2
    with pytest.raises(ValueError, match="'store' parameter"):
        reach_scenarios(spec, tmp_path / "reach", airspeeds=(13.0,), fly=["mppi"])
    with pytest.raises(ValueError, match="'variants' parameter"):
        reach_scenarios(spec, tmp_path / "reach", airspeeds=(13.0,), fly=["bogus"],
                        store=store)


# ------------------------------------------------------------------ the least-time route to fly


def test_fastest_route_speeds_keep_the_airspeed_at_the_limit():
    from windnav.plan.reach import fastest_route

    wind = (-4.0, 3.0)
    lat = reach_lattice(EMPTY, wind, dx=2.0, clearance=0.0)
    r = fastest_route(lat, (20, 100), (180, 100), airspeed_max=10.0)
    pieces = np.diff(r.samples, axis=0)
    e = pieces / np.hypot(*pieces.T)[:, None]
    air = np.hypot(*(r.speeds[:, None] * e - np.asarray(wind)).T)
    np.testing.assert_allclose(air, 10.0, rtol=1e-9)
    assert r.time_s == pytest.approx(least_time(lat, (20, 100), (180, 100),
                                                airspeed_max=10.0).time_s, rel=5e-3)
    assert r.length_m == pytest.approx(160.0, rel=5e-3)
    assert tuple(r.samples[0]) == (20, 100) and tuple(r.samples[-1]) == (180, 100)
    # a tailwind leg flown at most at speed_max
    fast = fastest_route(lat, (180, 100), (20, 100), airspeed_max=10.0, speed_max=7.0)
    assert np.all(fast.speeds == 7.0) and fast.time_s == pytest.approx(160.0 / 7.0, rel=5e-3)


def test_fastest_route_leaves_a_building_clearance_and_says_when_there_is_none():
    from windnav.plan.reach import fastest_route, nearest_free_cell

    city = City((0, 200, 0, 200), [[95, 105, 0, 170]], [20])
    lat = reach_lattice(city, (0.0, 0.0), dx=2.0, clearance=6.0)
    beside = (92.0, 100.0)  # 3 m from the wall, inside its 6 m clearance
    entry = nearest_free_cell(lat, beside)
    assert 95.0 - entry[0] >= 6.0 and math.dist(entry, beside) <= 6.0
    r = fastest_route(lat, beside, (150, 100), airspeed_max=10.0)
    assert tuple(r.samples[0]) == beside and tuple(r.samples[1]) == tuple(entry)
    assert r.speeds[0] == 2.0 and not city.contains(r.samples).any()
    assert fastest_route(lat, beside, (150, 100), airspeed_max=10.0, snap_m=1.0) is None
    # a 12 m/s wall of wind along the wall's gap: no route within 10 m/s of airspeed
    x = y = np.arange(0.5, 200.0, 1.0)
    u = np.where(y[:, None] > 150, -12.0, 0.0) * np.ones((1, x.size))
    from windnav.wind.gridded import GriddedWind

    blocked = reach_lattice(city, GriddedWind(x, y, u, np.zeros_like(u)), dx=2.0, clearance=6.0)
    assert fastest_route(blocked, (50, 100), (150, 100), airspeed_max=10.0) is None
    assert fastest_route(blocked, (50, 100), (150, 100), airspeed_max=13.0) is not None
    unsteady = reach_lattice(EMPTY, GriddedWind(x, y, u[None].repeat(2, 0),
                                                np.zeros((2,) + u.shape), t=[0.0, 1.0]))
    with pytest.raises(ValueError, match="steady ReachLattice"):
        fastest_route(unsteady, (50, 100), (150, 100), airspeed_max=10.0)


# ------------------------------------------------------------------------- the gust margin


def _gusty(sigma_u, sigma_v=0.0, cov_uv=0.0, mean=(0.0, 0.0), shape=(200, 200)):
    """A uniform mean wind on 1 m cells and a uniform covariance of the wind there."""
    x = y = np.arange(0.5, 200.0, 1.0)
    u = np.full(shape, mean[0])
    v = np.full(shape, mean[1])
    gust = np.empty(shape + (3,))
    gust[...] = (sigma_u**2, cov_uv, sigma_v**2)
    return GriddedWind(x, y, u, v), gust


def test_wind_covariance_equals_numpy_over_the_strided_frames():
    from types import SimpleNamespace

    from windnav.plan.reach import wind_covariance

    rng = np.random.default_rng(3)
    fu = rng.normal(2.0, 1.5, size=(41, 6, 7))
    fv = 0.5 * fu + rng.normal(-1.0, 0.7, size=fu.shape)
    cov = wind_covariance(SimpleNamespace(frames_u=fu, frames_v=fv), every=4)
    a, b = fu[::4], fv[::4]
    np.testing.assert_allclose(cov[..., 0], a.var(0), rtol=1e-12)
    np.testing.assert_allclose(cov[..., 1], ((a - a.mean(0)) * (b - b.mean(0))).mean(0),
                               rtol=1e-10)
    np.testing.assert_allclose(cov[..., 2], b.var(0), rtol=1e-12)
    with pytest.raises(ValueError, match="'every'"):
        wind_covariance(SimpleNamespace(frames_u=fu, frames_v=fv), every=0)
    with pytest.raises(ValueError, match="'solution'.*recorded frames"):
        wind_covariance(SimpleNamespace(frames_u=None, frames_v=None))


@pytest.mark.parametrize("k", [0.5, 1.0, 2.0])
def test_gust_margin_lowers_the_ground_speed_by_k_deviations_along_the_track(k):
    """Open map, a 3 m/s tailwind along +x with a 2 m/s deviation in every direction: the leg
    along +x is flown at A + 3 - 2k, the crosswind leg along +y at sqrt(A^2 - 3^2) - 2k."""
    wind, gust = _gusty(2.0, 2.0, mean=(3.0, 0.0))
    lat = reach_lattice(EMPTY, wind, dx=2.0, clearance=0.0, gust=gust)
    np.testing.assert_allclose(lat.gust[..., 0], 4.0)
    along_x = least_time(lat, (20, 100), (180, 100), airspeed_max=10.0, gust_k=k)
    assert along_x.time_s == pytest.approx(160.0 / (13.0 - 2.0 * k), rel=5e-3)
    along_y = least_time(lat, (100, 20), (100, 180), airspeed_max=10.0, gust_k=k)
    v_y = math.sqrt(100.0 - 9.0) - 2.0 * k
    assert along_y.time_s == pytest.approx(160.0 / v_y, rel=5e-3)


def test_gust_margin_zero_is_the_mean_wind_search_to_the_bit():
    from windnav.plan.reach import fastest_route

    city = City((0, 200, 0, 200), [[60, 80, 40, 120], [120, 150, 90, 170]], [20, 20])
    x = y = np.arange(0.5, 200.0, 1.0)
    u = -3.0 + 0.02 * y[:, None] * np.ones((1, x.size))
    v = 1.5 * np.sin(x[None, :] / 30.0) * np.ones((y.size, 1))
    wind = GriddedWind(x, y, u, v)
    gust = np.random.default_rng(0).uniform(0.0, 9.0, size=(y.size, x.size, 3))
    plain = reach_lattice(city, wind, dx=2.0, clearance=2.0)
    gusty = reach_lattice(city, wind, dx=2.0, clearance=2.0, gust=gust)
    a = least_time(plain, (20, 100), (180, 120), airspeed_max=9.0)
    b = least_time(gusty, (20, 100), (180, 120), airspeed_max=9.0, gust_k=0.0)
    assert a.time_s == b.time_s and np.array_equal(a.path, b.path)
    ra = fastest_route(plain, (20, 100), (180, 120), airspeed_max=9.0)
    rb = fastest_route(gusty, (20, 100), (180, 120), airspeed_max=9.0, gust_k=0.0)
    assert np.array_equal(ra.speeds, rb.speeds) and ra.time_s == rb.time_s


def test_gust_margin_takes_the_calm_street_around_a_gusty_one():
    """A wall with two gaps, the same calm mean wind in both: with no margin the route takes
    the near gap; a 9.5 m/s deviation in every direction inside the near gap (0.5 m/s of
    ground speed left through it at k = 1) sends the gust-aware route over the far one. Its
    pieces are flown at the mean wind's speeds, the full airspeed in this calm."""
    from windnav.plan.reach import fastest_route

    city = City((0, 200, 0, 200), [[95, 105, 0, 90], [95, 105, 110, 170]], [20, 20])
    x = y = np.arange(0.5, 200.0, 1.0)
    wind = GriddedWind(x, y, np.zeros((200, 200)), np.zeros((200, 200)))
    gust = np.zeros((200, 200, 3))
    in_gap = ((y >= 88) & (y <= 112))[:, None] & ((x >= 90) & (x <= 110))[None, :]
    gust[in_gap, 0] = gust[in_gap, 2] = 9.5**2
    lat = reach_lattice(city, wind, dx=2.0, clearance=2.0, gust=gust)
    plain = least_time(lat, (50, 100), (150, 100), airspeed_max=10.0)
    assert plain.path[:, 1].max() < 115  # through the near gap
    careful = fastest_route(lat, (50, 100), (150, 100), airspeed_max=10.0, gust_k=1.0)
    assert careful.samples[:, 1].max() > 170  # over the far gap
    np.testing.assert_allclose(careful.speeds, 10.0)
    assert careful.time_s == pytest.approx(careful.length_m / 10.0)
    assert careful.length_m > plain.length_m + 50.0


def test_gust_margin_rejects_what_it_cannot_use():
    from windnav.plan.reach import fastest_route

    wind, gust = _gusty(1.0)
    plain = reach_lattice(EMPTY, wind, dx=2.0, clearance=0.0)
    with pytest.raises(ValueError, match="'gust_k'.*no gust"):
        least_time(plain, (20, 100), (180, 100), airspeed_max=10.0, gust_k=1.0)
    with pytest.raises(ValueError, match="'gust_k'"):
        fastest_route(plain, (20, 100), (180, 100), airspeed_max=10.0, gust_k=-1.0)
    with pytest.raises(ValueError, match="'gust'.*shape"):
        reach_lattice(EMPTY, wind, dx=2.0, clearance=0.0, gust=gust[:-1])
    with pytest.raises(ValueError, match="'gust'.*gridded wind"):
        reach_lattice(EMPTY, (1.0, 0.0), dx=2.0, clearance=0.0, gust=gust)


def test_a_move_the_held_wind_never_opens_is_not_waited_for():
    """Past the last frame the wind is held, so a move it blocks stays blocked: with the
    default ``t_end = inf`` the search waited for it for ever (metamorphic audit, 2026-12-05).
    Two equal frames give the steady lattice's answer."""
    from windnav.city import City
    from windnav.plan.reach import least_time, reach_lattice
    from windnav.wind import GriddedWind

    city = City((0, 100, 0, 100), np.array([[40.0, 60.0, 40.0, 60.0]]), [10.0])
    x = np.arange(1.0, 100.0, 2.0)
    u = np.full((x.size, x.size), 3.0)
    u[:, x > 80] = 12.0  # a strip the 10 m/s airspeed cannot fly against
    v = np.zeros_like(u)
    steady = least_time(reach_lattice(city, GriddedWind(x, x, u, v), dx=2.0), (10.0, 10.0),
                        (30.0, 90.0), airspeed_max=10.0)
    frames = GriddedWind(x, x, np.stack([u, u]), np.stack([v, v]), t=np.array([0.0, 10.0]))
    held = least_time(reach_lattice(city, frames, dx=2.0), (10.0, 10.0), (30.0, 90.0),
                      airspeed_max=10.0)
    assert np.isfinite(steady.time_s) and held.time_s == pytest.approx(steady.time_s, rel=1e-12)


def test_a_route_search_too_large_for_memory_is_refused_before_its_graph(monkeypatch):
    """``energy_route`` and ``grid_route`` built their graphs without a memory check: an 8 km
    map at dx = 1 m needs about 47 GB, a bare MemoryError or the out-of-memory killer (scale
    audit, 2026-12-05)."""
    import windnav as wn
    from windnav.flow import MemoryEstimateError
    from windnav.plan import energy_route, grid_route, planner_config

    city = wn.city.planning_map(rng=0, size=300.0)
    cfg = planner_config(wn.vehicle.params("hummingbird"), "gs")
    start, goal = (20.0, 20.0), (280.0, 280.0)
    monkeypatch.setenv("WINDNAV_MEMORY_LIMIT", "1MB")
    with pytest.raises(MemoryEstimateError, match=r"energy_route: a lattice of \d+ x \d+ "
                                                  r"cells .* WINDNAV_MEMORY_LIMIT"):
        energy_route(city, start, goal, cfg)
    with pytest.raises(MemoryEstimateError, match="grid_route: a lattice"):
        grid_route(city, start, goal)
    monkeypatch.delenv("WINDNAV_MEMORY_LIMIT")
    assert np.isfinite(energy_route(city, start, goal, cfg).energy)


def test_waiting_before_a_move_it_could_fly_arrives_sooner_with_wait_best():
    """A 2.9 m/s headwind that drops to calm after 1 s, a goal one 2 m cell downwind of it at
    an airspeed of 3 m/s: flying at once crawls (the search detours by a side street, 3.55 s),
    hovering for the calm and then flying arrives at 1 + 2/3 s. The search only waited before
    a move it could not fly (a reference audit, 2026-12-05, found arrivals up to 23 % late in
    gusty winds); ``wait="best"`` also tries departing at each later frame time. A steady wind
    gives the same answer either way."""
    nx, ny = 6, 3
    frames = np.zeros((3, ny, nx, 2))
    frames[0, ..., 0] = -2.9
    axes = {"x": 2.0 * np.arange(nx), "y": 2.0 * np.arange(ny),
            "free": np.ones((ny, nx), bool), "t0": 0.0, "dt_frames": 1.0, "dx": 2.0,
            "clearance": 0.0}
    lat = ReachLattice(frames=frames, **axes)
    blocked = least_time(lat, (0.0, 2.0), (2.0, 2.0), airspeed_max=3.0).time_s
    best = least_time(lat, (0.0, 2.0), (2.0, 2.0), airspeed_max=3.0, wait="best").time_s
    assert best == pytest.approx(1.0 + 2.0 / 3.0, rel=1e-12)
    assert blocked > best + 1.5
    steady = ReachLattice(frames=frames[:1], **axes)
    assert (least_time(steady, (0.0, 2.0), (8.0, 2.0), airspeed_max=3.0, wait="best").time_s
            == least_time(steady, (0.0, 2.0), (8.0, 2.0), airspeed_max=3.0).time_s)
    with pytest.raises(ValueError, match="'wait' parameter of least_time"):
        least_time(lat, (0.0, 2.0), (2.0, 2.0), airspeed_max=3.0, wait="always")


def test_a_reach_cache_belongs_to_one_suite_seed_and_search(tmp_path, capsys):
    """Reach records were keyed by scenario id alone: ``nav-study feasibility --store
    runs/heldout`` (seed 1) read the default cache's seed-0 records and printed their tables as
    its own, in 0.7 s (cache audit, thirty-ninth session). A cache folder now has a manifest;
    one of another suite, seed or search is refused, as is a cache from before the manifest
    whose records are not this suite's seed 0."""
    import dataclasses
    import json

    from windnav import cli
    from windnav.experiments.nav_feasibility import MANIFEST, RECORDS, check_cache
    from windnav.experiments.nav_suite import SUITES

    thesis = SUITES["thesis"]
    check_cache(thesis, tmp_path / "a")  # a new folder: its manifest is written
    man = json.loads((tmp_path / "a" / MANIFEST).read_text())
    assert (man["suite"], man["seed"]) == ("thesis", 0)
    check_cache(thesis, tmp_path / "a")  # the same suite again: fine
    (tmp_path / "a" / MANIFEST).write_text(json.dumps({**man, "dx": 2, "hold_s": 5}))
    check_cache(thesis, tmp_path / "a")  # whole numbers written as such: the same
    held_out = dataclasses.replace(thesis, seed=1)
    with pytest.raises(ValueError, match="'out' parameter of reach_scenarios names a reach cache "
                                         "of another suite or search \\(seed 0 there, 1 here\\)"):
        check_cache(held_out, tmp_path / "a")
    for bad in ("[]", "null", "{"):  # not a manifest: named, not an AttributeError
        (tmp_path / "b").mkdir(exist_ok=True)
        (tmp_path / "b" / MANIFEST).write_text(bad)
        with pytest.raises(ValueError, match="cannot be read"):
            check_cache(thesis, tmp_path / "b")
    # a cache from before the manifest (the committed thesis_reach.jsonl.gz restored): its
    # records are taken for seed 0 when the suite's name, settings and search match, else
    # refused
    old = tmp_path / "old"
    old.mkdir()
    rec = {"scenario_id": "thesis/m00/w00/p0", "record_s": thesis.record_s, "dx": 2.0,
           "clearance": 1.0, "hold_s": 5.0, "limits": {}}
    (old / RECORDS).write_text(json.dumps(rec) + "\n")
    for other in (held_out, dataclasses.replace(thesis, map_size=500.0),
                  dataclasses.replace(thesis, maps=(0, 1))):
        with pytest.raises(ValueError, match="taken for seed 0\\) are not this suite's"):
            check_cache(other, old)
    assert not (old / MANIFEST).exists()
    check_cache(thesis, old)
    assert json.loads((old / MANIFEST).read_text()) == man
    # the command names its option, before writing anything
    (tmp_path / "store").mkdir()
    (tmp_path / "store" / "manifest.json").write_text(json.dumps(
        {"suite": "thesis", "seed": 1, "settings_hash": held_out.settings_hash()}))
    assert cli.main(["nav-study", "feasibility", "--store", str(tmp_path / "store"), "--cache",
                     str(tmp_path / "a"), "--out", str(tmp_path / "out")]) == 2
    assert "'--cache' parameter of windnav nav-study" in capsys.readouterr().err
    assert not (tmp_path / "out").exists()


def test_reach_table_leaves_harness_errors_out_of_its_rates_as_the_benchmark_table_does():
    """A flight whose latest record is a harness error (no flight flown) counted as a failure
    here but in no rate of the benchmark's table: four flights (success, success, hover,
    error), all reachable, gave 50 % failures where the table says 33 % (definitions audit)."""
    from windnav.experiments.nav_records import benchmark_table

    reach = [{"scenario_id": s, "speed": 6.0, "kind": "tailwind",
              "limits": {"13": {"reachable": True, "recorded_time_s": 30.0,
                                "mean_time_s": 30.0}}} for s in "abcd"]
    flights = [{"scenario_id": s, "variant": "v", "outcome": o}
               for s, o in zip("abcd", ("success", "success", "hover", "error"), strict=True)]
    v = reach_table(reach, flights, airspeed=13.0)["variants"]["v"]
    assert (v["flights"], v["failures"], v["failures_reachable"], v["errors"]) == (3, 1, 1, 1)
    assert sum(n for n, _ in v["by_mean_time"].values()) == 3
    full = [{**f, "energy_J": 1.0, "rotor_energy_J": 1.0, "time_s": 1.0, "distance_m": 1.0,
             "mean_cmd_accel": 1.0, "speed": 6.0, "kind": "tailwind", "map_index": 0,
             "wind_index": i, "pair_index": 0} for i, f in enumerate(flights)]
    table = benchmark_table(full, reference="v")
    assert 100.0 * v["failures"] / v["flights"] == pytest.approx(
        table["rows"]["v"]["failure_pct"]["value"])


def test_feasibility_and_gusts_study_a_city_file_without_a_store(tmp_path, monkeypatch, capsys):
    """``nav-study feasibility`` and ``gusts`` with ``--map FILE`` and no store: ``--suite``'s
    winds with a rule of the city's own (the tiny suite's 100 m pairs do not fit a 90 m map),
    the scenario ids the file's name, and, with no flights to set against, the feasibility
    figure's reach panel alone (its failure panels were drawn empty)."""
    import json

    import matplotlib.pyplot as plt

    from windnav import cli
    from windnav.city import City
    from windnav.experiments.nav_suite import SUITES

    spec = tiny_suite("quick")
    monkeypatch.setitem(SUITES, "quick", spec)
    file = tmp_path / "yard.json"
    City(bounds=(0.0, 90.0, 0.0, 90.0), footprints=[[40.0, 50.0, 40.0, 50.0]],
         heights=[20.0]).to_rotorpy_json(file)
    rule = ["--suite", "quick", "--map", str(file), "--pair-distance", "50", "--edge", "10",
            "--clearance", "10"]
    out = tmp_path / "feas"
    assert cli.main(["nav-study", "feasibility", *rule, "--cache", str(tmp_path / "reach"),
                     "--executor", "serial", "--out", str(out), "--no-progress"]) == 0
    doc = json.loads((out / "nav_feasibility.json").read_text())
    limit = doc["tables"][f"{doc['airspeed_limit']:g}"]
    assert limit["n"] == 4 and limit["variants"] == {}
    height, width = plt.imread(out / "nav_feasibility.png").shape[:2]
    assert width > 2.5 * height                  # one row of panels
    capsys.readouterr()
    assert cli.main(["nav-study", "gusts", *rule, "--scenario", "yard/m00/w01/p0",
                     "--out", str(tmp_path / "gusts"), "--no-progress"]) == 0
    gusts = json.loads((tmp_path / "gusts" / "nav_gusts.json").read_text())
    assert gusts["scenario_id"] == "yard/m00/w01/p0"
    # both flights flew (the goal lies 10 m in, inside the sixth variant's 15 m edge band:
    # the route search refused it and the study stopped, before the band left it clear)
    assert len(gusts["flights"]) == 2
    assert all(f["outcome"] != "error" for f in gusts["flights"].values())
