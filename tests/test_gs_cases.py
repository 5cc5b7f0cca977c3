"""Case studies against GS: the stated geometries, one case flown end to end, its figure.

The flights use the intersection case in a shortened wind (5 s of spin-up, 20 s recorded,
instead of the thesis's 25 s + 100 s): the wind takes about a second, each flight under one.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from windnav.experiments.gs_cases import (
    CASES,
    EVALUATION_SCENARIO,
    INTERSECTION_STREETS,
    THESIS_FLOW,
    VARIANTS,
    case_summary,
    run_case,
)
from windnav.experiments.nav_suite import get_suite, parse_scenario_id, suite_map
from windnav.experiments.navigate import OUTCOMES, check_point
from windnav.plan import VARIANTS as PLAN_VARIANTS
from windnav.viz.gs_cases import plot_gs_case, plot_gs_case_energy

SHORT = {"spinup_s": 5.0, "record_s": 20.0}


def inside_building(city, xy) -> bool:
    return bool(city.contains(np.asarray([xy], dtype=float))[0])


# ------------------------------------------------------------------------------ geometry


@pytest.mark.parametrize("name", list(CASES))
def test_every_case_has_free_endpoints_inside_its_map_and_a_thesis_inlet(name):
    city, start, goal, speed, direction = CASES[name]()
    for label, p in (("start_xy", start), ("goal_xy", goal)):
        check_point(city, p, label)  # inside the map, outside every building
    assert 5.0 <= speed <= 7.0
    assert math.isfinite(direction)
    assert np.hypot(*np.subtract(goal, start)) >= 100.0


def test_intersection_start_and_goal_lie_in_perpendicular_streets_and_the_wind_follows_one():
    city, start, goal, speed, direction = CASES["intersection"]()
    y0, y1 = INTERSECTION_STREETS["east-west"]
    x0, x1 = INTERSECTION_STREETS["north-south"]
    assert len(city.footprints) == 4
    # the streets are free from wall to wall, 20-30 m wide, and cross
    for lo, hi in ((y0, y1), (x0, x1)):
        assert 20.0 <= hi - lo <= 30.0
    across = np.linspace(1e-3, 1 - 1e-3, 25)
    # the start is in the east-west street: buildings just north and south of it, none between
    assert y0 < start[1] < y1 and not x0 <= start[0] <= x1
    assert inside_building(city, (start[0], y0 - 1.0))
    assert inside_building(city, (start[0], y1 + 1.0))
    assert not any(inside_building(city, (start[0], y0 + f * (y1 - y0))) for f in across)
    # the goal is in the north-south street: buildings just east and west of it
    assert x0 < goal[0] < x1 and not y0 <= goal[1] <= y1
    assert inside_building(city, (x0 - 1.0, goal[1]))
    assert inside_building(city, (x1 + 1.0, goal[1]))
    assert not any(inside_building(city, (x0 + f * (x1 - x0), goal[1])) for f in across)
    # so the straight line start-goal cuts a block: the route must turn the corner
    line = np.linspace(start, goal, 200)
    assert city.contains(line).any()
    # the wind blows along the east-west street
    assert math.isclose(math.cos(math.radians(direction)) ** 2, 1.0, abs_tol=1e-12)


def test_single_building_stands_on_the_line_and_the_wind_crosses_it():
    city, start, goal, speed, direction = CASES["single-building"]()
    (bx0, bx1, by0, by1), = city.footprints
    assert 40.0 <= bx1 - bx0 <= 60.0 and 40.0 <= by1 - by0 <= 60.0
    assert city.contains(np.linspace(start, goal, 200)).any()
    line = np.subtract(goal, start) / np.hypot(*np.subtract(goal, start))
    wind = np.array([math.cos(math.radians(direction)), math.sin(math.radians(direction))])
    assert abs(line @ wind) < 1e-12
    assert np.ptp(city.bounds[:2]) == np.ptp(city.bounds[2:]) == 300.0


def test_evaluation_map_is_the_suite_scenario():
    city, start, goal, speed, direction = CASES["evaluation-map"]()
    spec = get_suite("thesis")
    sc = parse_scenario_id(spec, EVALUATION_SCENARIO)
    reference = suite_map(spec, sc.map_index)
    np.testing.assert_array_equal(city.footprints, reference.footprints)
    assert tuple(city.bounds) == tuple(reference.bounds)
    assert tuple(start) == sc.start and tuple(goal) == sc.goal
    assert (speed, direction) == (sc.speed, sc.direction_deg) == spec.wind(sc.wind_index)


def test_variants_are_the_four_of_the_issue():
    assert list(VARIANTS) == ["MPPI", "EA-MPPI+W", "GS", "GS+W"]
    assert all(v in PLAN_VARIANTS for v, _ in VARIANTS.values())
    variant, options = VARIANTS["EA-MPPI+W"]
    assert variant == "ea-mppi-w"
    assert options == {"planner_overrides": {"energy_weight": 3.0}, "horizon": 90.0}


def test_run_case_rejects_unknown_cases_and_settings():
    with pytest.raises(ValueError, match="'name' parameter of run_case"):
        run_case("roundabout")
    with pytest.raises(ValueError, match="'flow_settings' parameter of run_case"):
        run_case("intersection", flow_settings={"steps": 3})


# ---------------------------------------------------------------------------- one case


@pytest.fixture(scope="module")
def case():
    return run_case("intersection", seed=0, flow_settings=SHORT)


def test_run_case_flies_every_variant_in_one_wind(case):
    assert list(case["results"]) == list(VARIANTS) == list(case["summary"])
    assert case["flow_settings"] == {**THESIS_FLOW, **SHORT}
    assert case["flow"].frames_u is None  # only the mean is kept
    for label, r in case["results"].items():
        assert r.variant == VARIANTS[label][0]
        assert r.outcome in OUTCOMES
        np.testing.assert_array_equal(r.start, case["start"])
        np.testing.assert_array_equal(r.goal, case["goal"])
        assert r.time_s <= SHORT["record_s"] + 1e-9
        # energy is the integral of a positive power: it grows and ends at energy_J
        assert r.energy_J > 0.0 and np.all(np.diff(r.energy) >= 0.0)
        assert r.energy_J == pytest.approx(r.energy[-1])
    assert case["results"]["EA-MPPI+W"].settings["horizon"] == 90.0
    assert math.isinf(case["results"]["MPPI"].settings["horizon"])
    for label in ("GS", "GS+W"):
        route = case["results"][label].route
        np.testing.assert_allclose(route[0], case["start"])
        np.testing.assert_allclose(route[-1], case["goal"])
        assert not case["city"].contains(route).any()


def test_case_summary_is_strict_json_with_the_route_energy_of_gs(case):
    s = case_summary(case)
    text = json.dumps(s, allow_nan=False)
    back = json.loads(text)
    assert back["name"] == "intersection" and back["seed"] == 0
    assert set(back["variants"]) == set(VARIANTS)
    for label, numbers in back["variants"].items():
        r = case["results"][label]
        assert numbers["outcome"] == r.outcome
        for key in ("energy_J", "rotor_energy_J", "time_s", "distance_m"):
            assert numbers[key] == pytest.approx(getattr(r, key))
        assert ("route_energy_J" in numbers) == (label in ("GS", "GS+W"))
    assert back["variants"] == json.loads(json.dumps(case["summary"]))


def test_figures_are_written(case, tmp_path):
    png = plot_gs_case(case, tmp_path / "intersection.png")
    energy = plot_gs_case_energy(case, tmp_path / "intersection_energy.png")
    for path in (png, energy):
        assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
        assert 10_000 < path.stat().st_size < 1_000_000


def test_command_nav_study_gs_writes_the_case_figures_and_json(tmp_path, monkeypatch, capsys):
    import functools

    import windnav.experiments.gs_cases as gc
    from windnav import cli

    monkeypatch.setattr(gc, "run_case", functools.partial(run_case, flow_settings=SHORT))
    out = tmp_path / "gs"
    assert cli.main(["nav-study", "gs", "--case", "intersection", "--out", str(out),
                     "--no-progress"]) == 0
    doc = json.loads((out / "nav_gs.json").read_text())
    assert set(doc["cases"]) == {"intersection"}
    assert set(doc["cases"]["intersection"]["variants"]) == set(VARIANTS)
    for f in ("gs_intersection.png", "gs_intersection_energy.png"):
        assert (out / f).stat().st_size > 10_000
    capsys.readouterr()
    assert cli.main(["nav-study", "gs", "--case", "roundabout", "--out", str(tmp_path / "x")]) == 2
    assert "'--case' parameter" in capsys.readouterr().err


def test_energy_route_time_is_the_sum_of_each_piece_length_over_its_speed():
    """Through a wind that changes along the route (a headwind in half the corridor) GS+W flies
    the pieces at different ground speeds; the route's time is sum(length_i / speed_i)."""
    import windnav as wn
    from windnav.city import City
    from windnav.plan import energy_route, planner_config

    class HalfHeadwind:
        def velocity(self, t, xyz):
            w = np.zeros((len(xyz), 3))
            w[:, 0] = np.where(xyz[:, 0] > 100.0, -6.0, 0.0)
            return w

    city = City((0, 200, 0, 60), np.zeros((0, 4)), np.zeros(0))
    cfg = planner_config(wn.vehicle.params("hummingbird"), "gs-w")
    r = energy_route(city, (10.0, 30.0), (190.0, 30.0), cfg, wind=HalfHeadwind())
    lengths = np.hypot(*np.diff(r.samples, axis=0).T)
    assert len(lengths) == len(r.speeds)
    assert r.speeds.max() > 1.2 * r.speeds.min()  # the pieces are flown at different speeds
    assert r.time == pytest.approx(float(np.sum(lengths / r.speeds)), rel=1e-12)
    # and not the total length over the mean speed
    assert abs(r.time - lengths.sum() / r.speeds.mean()) > 1e-3 * r.time
