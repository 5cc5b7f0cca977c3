"""Frictions an API audit found using the library from Python, each fixed without changing a
number: the subpackages, navigate without repeating the flow's wind, energy_route's ignored
wind, the predictors' wind shapes, FlowSolution.inlet_xy, planning_map's drawn count, the
block count and the exported baselines."""

from __future__ import annotations

import hashlib
import warnings

import numpy as np
import pytest

import windnav as wn
from windnav.city import City, planning_map, training_map
from windnav.experiments.navigate import navigate, simulate_flow
from windnav.plan import energy_route, planner_config
from windnav.predict import LocalBaseline, UpstreamBaseline, check_inputs, load_decoder
from windnav.predict.dataset import N_RAYS, _inlet, field_from_solution
from windnav.vehicle import params

# ----------------------------------------------------------------------------- 1. sysid


def test_sysid_is_a_subpackage_of_windnav():
    assert "sysid" in wn.__all__ and "sysid" in dir(wn)
    assert wn.sysid.fit_aero is wn.sysid.aero.fit_aero


# ------------------------------------------------------------- 2-3. navigate, energy_route

START, GOAL = (10.0, 60.0), (110.0, 60.0)


@pytest.fixture(scope="module")
def flow(city):
    return simulate_flow(city, 2.0, 10.0, spinup_s=5.0, record_s=10.0)


def _flight(res) -> tuple:
    return (res.outcome, res.energy_J, res.rotor_energy_J, res.time_s, res.distance_m,
            res.position.tobytes(), res.settings["speed"], res.settings["direction_deg"])


@pytest.mark.parametrize("variant", ["gs", "gs-w"])
def test_navigate_takes_the_wind_from_the_flow(city, flow, variant):
    with warnings.catch_warnings():
        # the GS flight no longer hands energy_route a wind it ignores
        warnings.simplefilter("error", UserWarning)
        implied = navigate(city, START, GOAL, variant=variant, flow=flow, rng=0, duration=4.0)
    given = navigate(city, START, GOAL, speed=2.0, direction_deg=10.0, variant=variant,
                     flow=flow, rng=0, duration=4.0)
    assert _flight(implied) == _flight(given)
    assert implied.settings["speed"] == flow.speed
    assert implied.settings["direction_deg"] == flow.direction_deg
    # one of the two given, the other from the flow
    half = navigate(city, START, GOAL, speed=2.0, variant=variant, flow=flow, rng=0,
                    duration=4.0)
    assert _flight(half) == _flight(given)


def test_navigate_still_needs_the_wind_without_a_flow_and_refuses_another(city, flow):
    with pytest.raises(ValueError, match="'speed' parameter of navigate must be given when "
                                         "'flow' is not"):
        navigate(city, START, GOAL, direction_deg=0.0, variant="mppi")
    with pytest.raises(ValueError, match="'direction_deg' parameter of navigate must be given"):
        navigate(city, START, GOAL, speed=2.0, variant="mppi")
    with pytest.raises(ValueError, match="'flow' parameter of navigate must be simulated at "
                                         r"speed=2.0 and direction_deg=0.0"):
        navigate(city, START, GOAL, direction_deg=0.0, variant="mppi", flow=flow)
    with pytest.raises(ValueError, match="'flow' parameter of navigate must be simulated at "
                                         r"speed=3.0"):
        navigate(city, START, GOAL, speed=3.0, variant="mppi", flow=flow)
    with pytest.raises(ValueError, match="'flow' parameter of navigate must be a FlowSolution"):
        navigate(city, START, GOAL, variant="mppi", flow="flow.zarr")


def test_energy_route_warns_that_a_still_air_config_ignores_the_wind():
    city = City((0, 200, 0, 200), np.zeros((0, 4)), np.zeros(0))
    gs = planner_config(params("hummingbird"), "gs")
    gs_w = planner_config(params("hummingbird"), "gs-w")
    still = energy_route(city, (10, 100), (190, 100), gs)
    for wind in [(-5.0, 0.0), wn.wind.ConstantWind((-5.0, 0.0, 0.0))]:
        with pytest.warns(UserWarning, match=r"'wind' parameter of energy_route is ignored: "
                                             r"the config \(variant 'gs', use_wind False\)"):
            r = energy_route(city, (10, 100), (190, 100), gs, wind=wind)
        np.testing.assert_array_equal(r.samples, still.samples)  # planned in still air, as before
        np.testing.assert_array_equal(r.speeds, still.speeds)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        # nothing to ignore: no wind, a zero wind; and a wind-aware config uses it
        energy_route(city, (10, 100), (190, 100), gs, wind=None)
        energy_route(city, (10, 100), (190, 100), gs, wind=(0.0, 0.0))
        windy = energy_route(city, (10, 100), (190, 100), gs_w, wind=(-5.0, 0.0))
    assert windy.energy != still.energy


# ------------------------------------------------------------------ 4. predictors' winds


def _inputs(b=4, seed=0):
    rng = np.random.default_rng(seed)
    return (rng.uniform(0.5, 60.0, (b, N_RAYS)), rng.normal(size=(b, 2)) * 4.0,
            rng.normal(size=(b, 2)) * 3.0)


@pytest.fixture(scope="module")
def decoder():
    return load_decoder()


@pytest.mark.parametrize("which", ["baselines", "decoder"])
def test_one_wind_for_a_batch_of_scans_is_the_same_wind_in_every_row(which, decoder):
    scans, w_up, w_robot = _inputs()
    models = ([UpstreamBaseline(), LocalBaseline()] if which == "baselines" else [decoder])
    for model in models:
        tiled = model.predict(scans, np.tile(w_up[1], (4, 1)), np.tile(w_robot[2], (4, 1)))
        np.testing.assert_array_equal(model.predict(scans, w_up[1], w_robot[2]), tiled)
        np.testing.assert_array_equal(model.predict(scans, w_up, w_robot[2]),
                                      model.predict(scans, w_up, np.tile(w_robot[2], (4, 1))))
    s, u, r = check_inputs(scans, w_up[1], list(w_robot[2]), "here")
    assert u.shape == r.shape == (4, 2) and u.flags.writeable and r.flags.writeable
    # (B, 2) winds pass through unchanged, bit for bit
    s, u, r = check_inputs(scans, w_up, w_robot, "here")
    assert u.tobytes() == w_up.tobytes() and r.tobytes() == w_robot.tobytes()
    assert s.tobytes() == scans.tobytes()


@pytest.mark.parametrize(("bad", "got"), [
    ({"w_up": np.ones((2, 2))}, r"'w_up' parameter of Decoder.predict must be an array of "
                                r"shape \(4, 2\), a row per scan, or \(2,\), the same for every "
                                r"scan. Got shape \(2, 2\) instead."),
    ({"w_robot": np.ones((1, 2))}, r"'w_robot' parameter .* Got shape \(1, 2\) instead."),
    ({"w_robot": np.ones(3)}, r"'w_robot' parameter .* Got shape \(3,\) instead."),
    ({"scans": np.ones((4, 359))}, r"'scans' parameter of Decoder.predict must be an array of "
                                   r"shape \(B, 360\), a scan per row, or \(360,\), one scan. "
                                   r"Got shape \(4, 359\) instead."),
])
def test_a_wrongly_shaped_input_is_told_the_shapes_expected_and_received(decoder, bad, got):
    scans, w_up, w_robot = _inputs()
    args = {"scans": scans, "w_up": w_up, "w_robot": w_robot, **bad}
    with pytest.raises(ValueError, match=got) as info:
        decoder.predict(**args)
    assert "'a batch" not in str(info.value) and "'shape" not in str(info.value)


# ----------------------------------------------------------------------- 5. inlet_xy


@pytest.mark.parametrize(("speed", "direction_deg"), [(5.0, 0.0), (7.5, 90.0), (3.0, 135.0),
                                                      (10.0, -30.0), (4.0, 270.0)])
def test_inlet_xy_is_the_decoders_w_up(speed, direction_deg):
    a = np.zeros(3)
    sol = wn.flow.FlowSolution(a, a, np.zeros((3, 3), bool), np.zeros((3, 3)), np.zeros((3, 3)),
                               None, None, None, speed, direction_deg, 1.0, 0.25)
    w = sol.inlet_xy
    assert w.shape == (2,) and w.dtype == np.float64
    assert w.tobytes() == _inlet(speed, direction_deg).tobytes()
    assert np.hypot(*w) == pytest.approx(speed, rel=1e-15)
    th = np.deg2rad(direction_deg)  # toward direction_deg, counter-clockwise from +x
    np.testing.assert_allclose(w, speed * np.array([np.cos(th), np.sin(th)]), atol=1e-12)


def test_inlet_xy_is_the_free_stream_of_a_simulated_flow():
    empty = City((0.0, 40.0, 0.0, 30.0), np.zeros((0, 4)), np.zeros(0))
    sol = wn.flow.simulate(empty, speed=3.0, direction_deg=30.0, dx=2.0, dt=0.25,
                           spinup_steps=4, steps=4)
    np.testing.assert_allclose(sol.mean_u, sol.inlet_xy[0], atol=1e-9)
    np.testing.assert_allclose(sol.mean_v, sol.inlet_xy[1], atol=1e-9)
    assert field_from_solution(empty, sol).w_up.tobytes() == sol.inlet_xy.tobytes()


# ------------------------------------------------------------------- 6. planning_map


def test_a_drawn_count_that_does_not_fit_is_said_to_be_drawn():
    with pytest.raises(ValueError, match=r"planning_map drew 15 buildings \(9-16 when "
                                         r"n_buildings is not given\), which do not fit a 200 m "
                                         r"map with these alleys .* Pass a smaller n_buildings= "
                                         r"or a larger size.") as info:
        planning_map(rng=0, size=200.0)
    assert "'n_buildings' parameter" not in str(info.value)
    with pytest.raises(ValueError, match=r"training_map drew \d+ buildings \(1-10 when"):
        training_map(rng=0, size=40.0)
    # a count the user passed is still named as the user's
    with pytest.raises(ValueError, match="'n_buildings' parameter of planning_map is too large"):
        planning_map(rng=0, size=200.0, n_buildings=16)


def _map_hash(city) -> str:
    m = hashlib.sha256()
    for a in (np.asarray(city.bounds, float), city.footprints, city.heights, city.base_z):
        m.update(np.ascontiguousarray(a, dtype=np.float64).tobytes())
    return m.hexdigest()[:16]


# computed with the code before the message changed (git HEAD 7b12a3d): the benchmark's maps
PLANNING_600 = {0: "971e9a8818ba6a2e", 1: "fd5401415da750df", 2: "7a5b50a2d4d142a6",
                3: "e3e0b6e5ce75d43a", 4: "0e4c3c0a70f72da4"}
TRAINING_300 = {0: "cc34e821c63eb131", 1: "ee8c7755b407b868", 2: "46bf02ec69c74228"}


def test_maps_that_fit_are_the_same_bit_for_bit():
    for seed, digest in PLANNING_600.items():
        assert _map_hash(planning_map(rng=seed, size=600.0)) == digest
    for seed, digest in TRAINING_300.items():
        assert _map_hash(training_map(rng=seed, size=300.0)) == digest


# ------------------------------------------------------------------- 7. n_buildings


def test_n_buildings_counts_blocks_and_building_labels_the_buildings():
    city = planning_map(rng=0, size=400.0)
    assert city.n_buildings == city.footprints.shape[0] == 33
    assert np.unique(city.building_labels()).size == 15
    doc = type(city).n_buildings.__doc__
    assert "blocks" in doc and "building_labels" in doc


# ------------------------------------------------------------------ 8. with_baselines


def test_with_baselines_is_exported():
    assert "with_baselines" in wn.predict.__all__
    models = wn.predict.with_baselines({"mine": LocalBaseline(size=3)}, 5, 2.0)
    assert list(models) == ["mine", "local", "upstream"]
    assert models["upstream"] == UpstreamBaseline(size=5, spacing=2.0)
