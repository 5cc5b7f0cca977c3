"""Tuning MPPI's base hyperparameters on the intersection without wind (``windnav tune-mppi``).

Real flights through the 200 m intersection in still air (a flight takes well under a second);
the studies are 2-3 trials on one to three flight seeds.
"""

from __future__ import annotations

import argparse
import json
import sys

import numpy as np
import optuna
import pytest

import windnav.commands.tune_mppi as tune_cmd
from windnav.experiments import tune_mppi as tm
from windnav.experiments.navigate import OUTCOMES, navigate
from windnav.experiments.results import OutputExistsError


def command(argv):
    parser = argparse.ArgumentParser(prog="windnav")
    sub = parser.add_subparsers(dest="command", required=True)
    tune_cmd.register(sub)
    args = parser.parse_args(["tune-mppi", *map(str, argv)])
    return args.func(args)


def _street_bands(city):
    """The free bands between the blocks: ``(x_lo, x_hi)`` of the north-south street and
    ``(y_lo, y_hi)`` of the east-west one."""
    fp = city.footprints
    xs, ys = np.unique(fp[:, :2]), np.unique(fp[:, 2:])
    x0, x1, y0, y1 = city.bounds
    gap_x = [(a, b) for a, b in zip(xs[:-1], xs[1:], strict=True)
             if not city.contains(np.array([[0.5 * (a + b), y0 + 1.0]]))[0]]
    gap_y = [(a, b) for a, b in zip(ys[:-1], ys[1:], strict=True)
             if not city.contains(np.array([[x0 + 1.0, 0.5 * (a + b)]]))[0]]
    return gap_x, gap_y


# -------------------------------------------------------------------------------- the case


def test_intersection_has_two_perpendicular_streets_and_the_flight_turns_the_corner():
    city, start, goal = tm.intersection_case()
    fp = city.footprints
    assert fp.shape == (4, 4)
    assert np.allclose(fp[:, 1] - fp[:, 0], fp[:, 3] - fp[:, 2])  # square blocks
    (sx,), (sy,) = _street_bands(city)
    assert sx[1] - sx[0] == sy[1] - sy[0] == tm.STREET_WIDTH
    # the blocks cover everything outside the two streets: sample the map on a grid
    g = np.linspace(0.5, 199.5, 200)
    pts = np.stack(np.meshgrid(g, g), axis=-1).reshape(-1, 2)
    in_street = (((pts[:, 0] > sx[0]) & (pts[:, 0] < sx[1]))
                 | ((pts[:, 1] > sy[0]) & (pts[:, 1] < sy[1])))
    assert np.array_equal(city.contains(pts), ~in_street)
    # start and goal are free, the start in the north-south street away from the crossing,
    # the goal in the east-west street away from it
    assert not city.contains(np.array([start, goal])).any()
    assert sx[0] < start[0] < sx[1] and not sy[0] <= start[1] <= sy[1]
    assert sy[0] < goal[1] < sy[1] and not sx[0] <= goal[0] <= sx[1]
    # the straight line between them crosses a block: the vehicle must turn the corner
    line = start + np.linspace(0.0, 1.0, 101)[:, None] * (goal - start)
    assert city.contains(line).any()


def test_still_air_is_zero_wind_the_vehicle_feels():
    city, start, goal = tm.intersection_case()
    flow = tm.still_air(city, 3.0)
    assert not np.any(flow.frames_u) and not np.any(flow.frames_v)
    assert flow.t[-1] == 3.0 and flow.solid.any()
    res = navigate(city, start, goal, speed=flow.speed, direction_deg=flow.direction_deg,
                   variant="mppi", rng=0, flow=flow, duration=2.0)
    assert res.outcome == "timeout" and np.all(res.wind == 0.0)
    assert np.all(res.airspeed == np.hypot(*res.velocity[:, :2].T))


# --------------------------------------------------------------------------- the objective


def test_any_failure_costs_more_than_any_success():
    duration = 45.0
    slowest_success = tm.flight_cost({"outcome": "success", "time_s": duration,
                                      "final_distance_to_goal_m": 0.0}, duration)
    failures = [tm.flight_cost({"outcome": o, "time_s": t, "final_distance_to_goal_m": d},
                               duration)
                for o in OUTCOMES if o != "success" for t in (0.5, duration) for d in (0.0, 3.0)]
    assert slowest_success == duration < min(failures)
    near, far = (tm.flight_cost({"outcome": "hover", "time_s": 9.0,
                                 "final_distance_to_goal_m": d}, duration) for d in (10.0, 50.0))
    assert near < far


def test_objective_on_real_flights():
    res = tm.evaluate(seeds=(0, 1, 2))
    flights = res["flights"]
    assert [f["seed"] for f in flights] == [0, 1, 2]
    ok = [f["cost"] for f in flights if f["outcome"] == "success"]
    bad = [f["cost"] for f in flights if f["outcome"] != "success"]
    assert ok, "the thesis defaults should reach the goal on some seed"
    assert all(f["cost"] == f["time_s"] for f in flights if f["outcome"] == "success")
    assert max(ok) <= tm.DURATION_S < tm.DURATION_S + tm.FAILURE_PENALTY_S <= min(bad,
                                                                                    default=1e9)
    assert res["cost"] == pytest.approx(np.mean(ok + bad))
    # too short to arrive: every flight fails and costs more than its time limit
    assert tm.objective(seeds=(0,), duration=3.0) > 3.0 + tm.FAILURE_PENALTY_S


# ------------------------------------------------------------------------------ the search


def test_tune_is_deterministic_and_starts_from_the_thesis_defaults():
    a = tm.tune(3, seed=0, seeds=(0,))
    b = tm.tune(3, seed=0, seeds=(0,))
    assert [(t["params"], t["cost"]) for t in a["trials"]] == \
        [(t["params"], t["cost"]) for t in b["trials"]]
    assert a["trials"][0]["params"] == a["defaults"] == tm.thesis_defaults() == {
        "temperature": 0.79, "sigma_u": 5.15, "sigma_gf": 5.97, "obstacle_weight": 1.25}
    assert a["defaults_cost"] == a["trials"][0]["cost"] == tm.objective(seeds=(0,))
    costs = [t["cost"] for t in a["trials"]]
    assert a["best_cost"] == min(costs) == costs[a["best_trial"]]
    assert a["best_params"] == a["trials"][a["best_trial"]]["params"]
    for t in a["trials"]:
        for name, v in t["params"].items():
            lo, hi = tm.SEARCH_SPACE[name]
            assert lo <= v <= hi and hi / lo == pytest.approx(16.0)
    # another sampler seed draws other parameters after the same trial 0
    c = tm.tune(2, seed=1, seeds=(0,))
    assert c["trials"][0] == a["trials"][0] and c["trials"][1]["params"] != a["trials"][1]["params"]
    assert a["optuna_version"] == optuna.__version__


def test_tune_validates_its_inputs():
    with pytest.raises(ValueError, match="'n_trials'"):
        tm.tune(0)
    # one trial is the defaults alone, which it called the best (statistics audit)
    with pytest.raises(ValueError, match="'n_trials' parameter of tune must be at least 2"):
        tm.tune(1)
    with pytest.raises(ValueError, match="'seeds'"):
        tm.tune(2, seeds=())
    with pytest.raises(ValueError, match="'search_space'.*'sigma_u'"):
        tm.tune(2, search_space={"sigma_u": (6.0, 10.0)})  # leaves out the thesis value
    with pytest.raises(ValueError, match="'search_space'.*'variant'"):
        tm.tune(2, search_space={"variant": (1.0, 2.0)})


# ----------------------------------------------------------------------------- the command


def test_command_writes_json_and_figure_and_refuses_to_overwrite(tmp_path, capsys):
    out = tmp_path / "tune"
    assert command(["--trials", 2, "--seed", 0, "--out", out, "--json", tmp_path / "t.json",
                    "--no-progress"]) == 0
    text = capsys.readouterr().out
    assert "best_params" in text and "defaults_cost_s" in text
    doc = json.loads((out / "tune_mppi.json").read_text())
    assert doc["command"] == "windnav tune-mppi"
    assert len(doc["trials"]) == 2 and doc["trials"][0]["params"] == tm.thesis_defaults()
    assert doc["defaults_cost"] == doc["trials"][0]["cost"] and doc["seeds"] == [0, 1, 2]
    assert json.loads((tmp_path / "t.json").read_text()) == doc
    assert (out / "tune_mppi.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    before = (out / "tune_mppi.json").read_bytes()
    with pytest.raises(OutputExistsError, match="'--out'.*overwrite"):
        command(["--trials", 2, "--out", out, "--no-progress"])
    assert (out / "tune_mppi.json").read_bytes() == before
    with pytest.raises(ValueError, match="'--trials' parameter of windnav tune-mppi"):
        command(["--trials", 0, "--out", tmp_path / "other"])
    with pytest.raises(ValueError, match="'--trials' parameter of windnav tune-mppi must be at "
                                         "least 2"):
        command(["--trials", 1, "--out", tmp_path / "other"])
    with pytest.raises(ValueError, match="'--holdout' parameter of windnav tune-mppi must be an "
                                         "integer >= 0"):  # it said ">= 1", but 0 is allowed
        command(["--trials", 2, "--holdout", -1, "--out", tmp_path / "other"])
    assert command(["--trials", 2, "--out", out, "--overwrite", "--no-progress",
                    "--flight-seeds", 1, "--holdout", 1]) == 0
    doc = json.loads((out / "tune_mppi.json").read_text())
    assert len(doc["trials"]) == 2 and doc["seeds"] == [0]
    # the held-out check flies seed 1, the first the study never saw
    assert doc["holdout"]["seeds"] == [1]
    assert doc["holdout"]["defaults"]["cost"] == pytest.approx(
        tm.evaluate(tm.thesis_defaults(), seeds=[1])["cost"])
    with pytest.raises(ValueError, match="'--flight-seeds' parameter"):
        command(["--trials", 2, "--flight-seeds", 0, "--out", tmp_path / "x"])


def test_command_without_optuna_says_how_to_install_it(tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "optuna", None)  # `import optuna` raises ImportError
    with pytest.raises(ImportError) as info:
        command(["--trials", 2, "--out", tmp_path / "tune"])
    message = str(info.value)
    assert "pip install 'windnav[tune]'" in message and "\n" not in message
    assert not (tmp_path / "tune").exists()
