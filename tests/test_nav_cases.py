"""Single benchmark cases: best/worst ranking, re-flying scenarios, their figures, the winds.

The ranking runs on hand-made records; the flights and figures use the tiny suite of
``test_nav_benchmark`` (one 200 m map, 3 m/s, 5 s of spin-up and 30 s recorded: a wind takes
a second or two, a flight half a second).
"""

from __future__ import annotations

from dataclasses import replace
from types import SimpleNamespace

import numpy as np
import pytest

import windnav.experiments.nav_benchmark as nb
from windnav.experiments.nav_cases import (
    best_worst,
    default_winds,
    fly_cases,
    wind_scenarios,
)
from windnav.experiments.nav_suite import SUITES, SuiteSpec, parse_scenario_id
from windnav.experiments.navigate import OUTCOMES
from windnav.viz.nav_studies import plot_cases, plot_wind_scenarios

TINY = SuiteSpec(
    "tiny", maps=(0,), winds=(0, 1), pairs=(0, 1), speeds=(3.0,), incidences_deg=(0.0, 90.0),
    n_tailwind=1, n_headwind=1, pair_distance=100.0, clearance=25.0, edge=15.0, map_size=200.0,
    map_options={"n_buildings": 2, "side_range": (10.0, 20.0)}, spinup_s=5.0, record_s=30.0)

P0, P1 = "tiny/m00/w00/p0", "tiny/m00/w00/p1"


# ----------------------------------------------------------------------------- ranking


def rec(sid, variant, outcome, energy):
    return {"scenario_id": f"thesis/{sid}", "variant": variant, "outcome": outcome,
            "energy_J": energy}


RECORDS = [
    rec("m00/w00/p0", "mppi", "success", 1000.0),
    rec("m00/w00/p0", "ea-mppi-w", "success", 900.0),        # r = 0.1
    rec("m00/w01/p0", "ea-mppi-w", "success", 500.0),        # superseded: r would be 0.5
    rec("m00/w01/p0", "mppi", "success", 1000.0),
    rec("m00/w01/p0", "ea-mppi-w", "success", 1200.0),       # r = -0.2, the worst
    rec("m00/w02/p0", "ea-mppi-w", "success", 100.0),        # reference failed
    rec("m00/w02/p0", "mppi", "hover", 3000.0),
    rec("m00/w03/p0", "ea-mppi-w", "collision", 100.0),      # variant failed
    rec("m00/w03/p0", "mppi", "success", 3000.0),
    rec("m00/w04/p0", "ea-mppi-w", "error", None),           # retried: the success counts
    rec("m00/w04/p0", "mppi", "success", 1000.0),
    rec("m00/w04/p0", "ea-mppi-w", "success", 800.0),        # r = 0.2, the best
    rec("m00/w05/p0", "mppi", "success", 1000.0),            # retried: the failure counts
    rec("m00/w05/p0", "ea-mppi-w", "success", 10.0),
    rec("m00/w05/p0", "ea-mppi-w", "timeout", 900.0),
    rec("m00/w00/p0", "gs", "success", 1.0),                 # another variant
]


def test_best_worst_ranks_paired_reductions_of_the_last_records():
    out = best_worst(RECORDS)
    assert out["n"] == 3
    assert [sid for sid, _ in out["ranked"]] == ["thesis/m00/w04/p0", "thesis/m00/w00/p0",
                                                 "thesis/m00/w01/p0"]
    assert [r for _, r in out["ranked"]] == pytest.approx([0.2, 0.1, -0.2])
    assert out["best"] == {"scenario_id": "thesis/m00/w04/p0",
                           "reduction": pytest.approx(0.2),
                           "energy_J": {"ea-mppi-w": 800.0, "mppi": 1000.0}}
    assert out["worst"]["scenario_id"] == "thesis/m00/w01/p0"
    assert out["worst"]["energy_J"] == {"ea-mppi-w": 1200.0, "mppi": 1000.0}
    # another pair of variants; equal reductions in the order of the ids
    tie = best_worst(RECORDS + [rec("m00/w09/p0", "gs", "success", 1.0),
                                rec("m00/w09/p0", "mppi", "success", 1000.0)], variant="gs")
    assert tie["ranked"] == [("thesis/m00/w00/p0", pytest.approx(0.999)),
                             ("thesis/m00/w09/p0", pytest.approx(0.999))]


def test_best_worst_names_what_is_missing():
    failed = [r for r in RECORDS if r["outcome"] != "success"]
    with pytest.raises(ValueError, match="'records' parameter of best_worst.*'ea-mppi-w' and "
                                         "'mppi' succeeded"):
        best_worst(failed)
    with pytest.raises(ValueError, match="'records' parameter of best_worst"):
        best_worst([])
    with pytest.raises(ValueError, match="'variant' parameter of best_worst must differ"):
        best_worst(RECORDS, variant="mppi")


# ----------------------------------------------------------------------------- flights


def test_fly_cases_shares_a_wind_per_map_and_wind_and_flies_as_the_benchmark(monkeypatch):
    spec = replace(TINY, navigate_options={"capture_radius": 7.0})
    winds, calls = [], []

    def flow(spec_, city, speed, direction_deg):
        winds.append(direction_deg)
        return SimpleNamespace(direction_deg=direction_deg)

    def fake_navigate(city, start, goal, *, speed, direction_deg, variant, rng, flow, **kw):
        calls.append((tuple(start), variant, rng, flow.direction_deg, kw))
        return SimpleNamespace(outcome="success", energy_J=1.0)

    monkeypatch.setattr(nb, "suite_flow", flow)
    ids = [P0, "tiny/m00/w01/p0", P1]
    cases = fly_cases(spec, ids, "mppi,ea-mppi-w", navigate_fn=fake_navigate)
    assert list(cases) == ids and winds == [0.0, 90.0]
    assert len(calls) == 6
    for sid in ids:
        sc = parse_scenario_id(spec, sid)
        assert cases[sid]["scenario"] == sc
        assert list(cases[sid]["results"]) == ["mppi", "ea-mppi-w"]
        assert [c[1:] for c in calls if c[0] == sc.start] == [
            (v, sc.seed, sc.direction_deg, {"capture_radius": 7.0}) for v in ("mppi", "ea-mppi-w")]
    assert cases[P0]["city"] is cases[P1]["city"] and cases[P0]["flow"] is cases[P1]["flow"]
    # a variant label with study parameters flies as the benchmark flies it
    calls.clear()
    cases = fly_cases(spec, [P0], ["ea-mppi-w@qe=2"], navigate_fn=fake_navigate)
    assert list(cases[P0]["results"]) == ["ea-mppi-w@qe=2"]
    assert [c[1] for c in calls] == ["ea-mppi-w"]
    assert calls[0][4] == {"capture_radius": 7.0, "planner_overrides": {"energy_weight": 2.0}}
    with pytest.raises(ValueError, match="'scenario_ids' parameter of fly_cases.*'quick/m00"):
        fly_cases(spec, [P0, "quick/m00/w04/p0"], ["mppi"], navigate_fn=fake_navigate)
    with pytest.raises(ValueError, match="'scenario_ids' parameter of fly_cases"):
        fly_cases(spec, [P0, P0], ["mppi"], navigate_fn=fake_navigate)
    with pytest.raises(ValueError, match="'variants' parameter of fly_cases.*'mppi-x'"):
        fly_cases(spec, [P0], ["mppi-x"], navigate_fn=fake_navigate)


@pytest.fixture(scope="module")
def tiny_cases():
    return fly_cases(TINY, [P0, P1], ["mppi", "ea-mppi-w"])


def test_real_cases_are_the_benchmark_flights(tiny_cases):
    for sid in (P0, P1):
        case = tiny_cases[sid]
        flow = case["flow"]
        assert flow.frames_u is None and flow.mean_u.shape == flow.solid.shape
        for v, r in case["results"].items():
            assert r.variant == v and r.outcome in OUTCOMES and r.energy_J > 0
            np.testing.assert_allclose(r.start, case["scenario"].start)
    # the benchmark's own flight (its own map and wind) gives the same record
    sc = tiny_cases[P1]["scenario"]
    again = nb.fly_scenario(TINY, sc, "ea-mppi-w")
    r = tiny_cases[P1]["results"]["ea-mppi-w"]
    assert again["outcome"] == r.outcome
    assert again["energy_J"] == pytest.approx(r.energy_J, rel=1e-9)


def test_plot_cases_writes_paths_and_energy_per_tag(tiny_cases, tmp_path):
    paths = plot_cases(tiny_cases, tmp_path / "figs", tags={"best": P0, "worst": P1})
    assert [p.name for p in paths] == ["best_paths.png", "best_energy.png",
                                       "worst_paths.png", "worst_energy.png"]
    assert all(p.stat().st_size > 10_000 for p in paths)
    default = plot_cases({P0: tiny_cases[P0]}, tmp_path, labels={"mppi": "A"})
    assert [p.name for p in default] == ["tiny_m00_w00_p0_paths.png",
                                         "tiny_m00_w00_p0_energy.png"]
    with pytest.raises(ValueError, match="'tags' parameter of plot_cases.*'best': 'tiny/m00/w01"):
        plot_cases(tiny_cases, tmp_path, tags={"best": "tiny/m00/w01/p0"})
    with pytest.raises(ValueError, match="'tags' parameter of plot_cases.*'a/b'"):
        plot_cases(tiny_cases, tmp_path, tags={"a/b": P0})


# ----------------------------------------------------------------------------- winds


def test_default_winds_are_one_per_speed_at_different_incidences():
    thesis = SUITES["thesis"]
    assert default_winds(thesis) == (1, 6, 11, 12)
    assert {thesis.wind(w) for w in default_winds(thesis)} == {
        (2.0, 15.0), (5.0, 30.0), (7.0, 45.0), (10.0, 0.0)}
    assert default_winds(TINY) == (1,)
    # a suite that flies none of the diagonal: its own winds (was an empty choice, refused)
    assert default_winds(SUITES["quick"]) == (4, 10)
    assert default_winds(replace(thesis, winds=tuple(range(16))[::-1])) == (1, 6, 11, 12)
    assert default_winds(replace(thesis, winds=(0, 2, 3, 5, 7, 8))) == (0, 2, 3, 5)


def test_wind_scenarios_figure(tmp_path):
    out = wind_scenarios(TINY, 0, (0, 1))
    assert (out["suite"], out["map_index"]) == ("tiny", 0)
    assert [(w["wind_index"], w["speed"], w["direction_deg"]) for w in out["winds"]] == [
        (0, 3.0, 0.0), (1, 3.0, 90.0)]
    for w in out["winds"]:
        flow = w["flow"]
        assert flow.frames_u is None and flow.direction_deg == w["direction_deg"]
        # the mean wind follows the inlet: mostly along +x for 0 deg, +y for 90 deg
        fluid = ~flow.solid
        along = flow.mean_u if w["direction_deg"] == 0.0 else flow.mean_v
        assert 0.5 * w["speed"] < along[fluid].mean() < 1.5 * w["speed"]
        assert [s.kind for s in w["scenarios"]] == ["tailwind", "headwind"]
        assert [s.wind_index for s in w["scenarios"]] == [w["wind_index"]] * 2
    path = plot_wind_scenarios(out, tmp_path / "winds.png")
    assert path.stat().st_size > 10_000
    with pytest.raises(ValueError, match="'map_index' parameter of wind_scenarios"):
        wind_scenarios(TINY, 3)
    for bad in ((0, 0), (2,), ()):
        with pytest.raises(ValueError, match="'winds' parameter of wind_scenarios"):
            wind_scenarios(TINY, 0, bad)


# ----------------------------------------------------------------------------- gusts


def test_gust_routes_flies_both_settings_as_the_benchmark_and_draws_them(tmp_path):
    from windnav.experiments.nav_gusts import gust_routes
    from windnav.viz.nav_studies import plot_gust_routes

    base = "ea-mppi-w-esc@escair=8@launch=1"  # every flight flies its least-time route
    out = gust_routes(TINY, P1, base=base, gust_k=0.5)
    assert out["variants"] == [base, base + "@gust=0.5"]
    flow, sigma = out["flow"], out["sigma_along"]
    assert flow.frames_u is None and sigma.shape == flow.solid.shape
    assert np.all(sigma >= 0) and sigma[~flow.solid].max() > 0  # the buildings' wakes gust
    for v in out["variants"]:
        route = out["routes"][v]
        assert route["begun_s"] == 0.0 and route["time_s"] > 1.0
        np.testing.assert_allclose(route["samples"][-1], out["scenario"].goal, atol=2.0)
    # the flights are the benchmark's
    again = nb.fly_scenario(TINY, out["scenario"], out["variants"][1])
    res = out["flights"][out["variants"][1]]
    assert again["outcome"] == res.outcome and again["energy_J"] == res.energy_J
    assert plot_gust_routes(out, tmp_path / "g.png").stat().st_size > 10_000
    for bad in ("ea-mppi-w", "ea-mppi-w-esc", base + "@gust=1"):
        with pytest.raises(ValueError, match="'base' parameter of gust_routes"):
            gust_routes(TINY, P1, base=bad)
    with pytest.raises(ValueError, match="'gust_k' parameter of gust_routes"):
        gust_routes(TINY, P1, base=base, gust_k=0.0)
